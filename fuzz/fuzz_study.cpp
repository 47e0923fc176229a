// libFuzzer target: the study file reader (kanedyn::io::parse_study) on arbitrary bytes, with a
// fixed model text, and the invariants of study_invariants.hpp (fuzz_entry.cpp is the entry
// point).
#include <string_view>

#include "study_invariants.hpp"

kanedyn::fuzz::LoaderVerdict kanedyn::fuzz::check_input(std::string_view text) {
  return check_study(text);
}
