// libFuzzer target: the model loader (kanedyn::io::parse_model_file) on arbitrary bytes. Any
// broken invariant (loader_invariants.hpp) aborts, which libFuzzer records as a finding.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "loader_invariants.hpp"

kanedyn::fuzz::LoaderVerdict kanedyn::fuzz::check_input(std::string_view text) {
  return check_loader(text);
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
