// libFuzzer target: the URDF import (kanedyn::io::urdf_to_model_yaml) on arbitrary bytes, then
// the model loader on what it wrote, with the invariants of urdf_invariants.hpp
// (fuzz_entry.cpp is the entry point).
#include <string_view>

#include "urdf_invariants.hpp"

kanedyn::fuzz::LoaderVerdict kanedyn::fuzz::check_input(std::string_view text) {
  return check_urdf(text);
}
