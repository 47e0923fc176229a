// libFuzzer target: the model loader (kanedyn::io::parse_model_file) on arbitrary bytes, with
// the invariants of loader_invariants.hpp (fuzz_entry.cpp is the entry point).
#include <string_view>

#include "loader_invariants.hpp"

kanedyn::fuzz::LoaderVerdict kanedyn::fuzz::check_input(std::string_view text) {
  return check_loader(text);
}
