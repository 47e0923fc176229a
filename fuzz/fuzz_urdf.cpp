// libFuzzer target: the URDF import (kanedyn::io::urdf_to_model_yaml) on arbitrary bytes, then
// the model loader on what it wrote. Any broken invariant (urdf_invariants.hpp) aborts, which
// libFuzzer records as a finding.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "urdf_invariants.hpp"

kanedyn::fuzz::LoaderVerdict kanedyn::fuzz::check_input(std::string_view text) {
  return check_urdf(text);
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const kanedyn::fuzz::LoaderVerdict verdict = kanedyn::fuzz::check_input(text);
  if (!verdict.violation.empty()) {
    std::fprintf(stderr, "kanedyn fuzz: invariant violated: %s\n", verdict.violation.c_str());
    std::fflush(stderr);
    std::abort();
  }
  return 0;
}
