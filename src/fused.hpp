// The fused O(N) route of forward_dynamics(Method::recursive) (src/fused.cpp). Private to the
// library: the layout of its tables in Data depends on the SIMD width the library is built for.
#pragma once

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn::fused {

/// Fills data.fused_* from the model: per-body constants with the loads grouped per body.
/// Returns false (and leaves the route unused) when a force element is not a Bushing,
/// ConstantForce or ConstantTorque.
bool compile(const Model& model, Data& data);

/// {y dot} and {x dot} into data.ydot, data.xdot. Needs compile() to have returned true.
void forward_dynamics(const Model& model, const State& state, Data& data);

}  // namespace kanedyn::fused
