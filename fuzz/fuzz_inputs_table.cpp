// libFuzzer target: the inputs table reader (kanedyn::io::read_input_table) on arbitrary bytes,
// for a fixed model with three inputs, with the invariants of inputs_invariants.hpp
// (fuzz_entry.cpp is the entry point).
#include <string_view>

#include "inputs_invariants.hpp"

kanedyn::fuzz::LoaderVerdict kanedyn::fuzz::check_input(std::string_view text) {
  return check_inputs_table(text);
}
