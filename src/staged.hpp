// The staged routes of forward_dynamics: kinematics, resultants and then the accelerations,
// each stage a pass of its own, in the Data's private scratch. forward_dynamics takes them
// when a force element is not of a built-in type (Route::recursive) or always
// (Route::assembled); tests and benchmarks call them to compare with the fused pass. Private
// to the library.
#pragma once

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn::detail {

/// {y dot} and {x dot} into data.ydot, data.xdot by the staged form of the route.
void staged_forward_dynamics(const Model& model, const State& state, Data& data, Route route);

}  // namespace kanedyn::detail
