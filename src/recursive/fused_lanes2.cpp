// The fused kernel with 2 lanes: SSE2 on any x86-64, the generic 16-byte vectors elsewhere
// (src/recursive/fused_lanes.inc).
#define KANEDYN_FUSED_LANES 2
#define KANEDYN_FUSED_NAMESPACE lanes2
#include "fused_lanes.inc"
