// Eqs. (39)-(41): the 7N kinematical differential equations.
#pragma once

#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn {

/// {x dot} = ({eps dot} = 1/2 diag([Ebar'_K]^T){w'} (Eqs. 39, 41), {s' dot} = {y2} (Eq. 40)).
/// xdot must have size 7N (it is not resized).
void compute_xdot(const Model& model, const State& state, Eigen::Ref<VectorX> xdot);

}  // namespace kanedyn
