// libFuzzer's entry point, shared by every fuzz target and replay driver: the bytes to the
// target's check_input (fuzz_model_loader.cpp, fuzz_urdf.cpp, fuzz_inputs_table.cpp,
// fuzz_study.cpp); a broken invariant aborts, which libFuzzer records as a finding.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "loader_invariants.hpp"

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
