// The fused kernel with 8 lanes (src/recursive/fused.hpp, src/recursive/fused_kernel.inc; the
// equations of src/equations.inc compiled here for this target).
#include <cmath>
#include <cstddef>
#include <cstring>
#include <type_traits>

#include "fused.hpp"

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#if defined(__x86_64__) || defined(__i386__)
// The kernel's functions are compiled for avx512f, the rest of the program is not (clang takes
// the target as an attribute of each function, GCC as a pragma).
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx512f")
#endif
#define KANEDYN_FUSED_LANES 8
namespace kanedyn::fused::lanes8 {
#include "../equations.inc"
#include "fused_kernel.inc"
}  // namespace kanedyn::fused::lanes8
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#else
namespace kanedyn::fused::lanes8 {
void evaluate(const Args&) {}  // never chosen: widest_supported_lanes() is 2 off x86
}  // namespace kanedyn::fused::lanes8
#endif
