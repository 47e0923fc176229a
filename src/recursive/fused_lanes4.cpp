// The fused kernel with 4 lanes, compiled for AVX (src/recursive/fused_lanes.inc).
#define KANEDYN_FUSED_LANES 4
#define KANEDYN_FUSED_NAMESPACE lanes4
#define KANEDYN_FUSED_TARGET "avx"
#include "fused_lanes.inc"
