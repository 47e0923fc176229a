// The fused kernel with 8 lanes, compiled for AVX-512F (src/recursive/fused_lanes.inc).
#define KANEDYN_FUSED_LANES 8
#define KANEDYN_FUSED_NAMESPACE lanes8
#define KANEDYN_FUSED_TARGET "avx512f"
#include "fused_lanes.inc"
