// The fused kernel with 2 lanes (src/fused.hpp, src/fused_kernel.inc).
#include <cstddef>
#include <cstring>

#include "fused.hpp"

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#define KANEDYN_FUSED_LANES 2
namespace kanedyn::fused::lanes2 {
#include "fused_kernel.inc"
}  // namespace kanedyn::fused::lanes2
