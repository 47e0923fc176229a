// The fused kernel with 2 lanes (src/recursive/fused.hpp, src/recursive/fused_kernel.inc; the
// equations of src/equations.inc compiled here for this target).
#include <cmath>
#include <cstddef>
#include <cstring>
#include <type_traits>

#include "fused.hpp"

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#define KANEDYN_FUSED_LANES 2
namespace kanedyn::fused::lanes2 {
#include "../equations.inc"
#include "fused_kernel.inc"
}  // namespace kanedyn::fused::lanes2
