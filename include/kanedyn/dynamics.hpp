// Forward dynamics: {y dot} and {x dot} at a state, by the route of the user's choice.
#pragma once

#include <string>

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

enum class Method {
  kane,      ///< assemble [A] and {f} (Eqs. 37-38) block-sparse, solve Eq. (36) by tree LDL^T
  recursive  ///< O(N): Newton-Euler per body, then s'' from the relative motion (docs/theory.md)
};

/// "kane" / "recursive".
std::string to_string(Method method);
/// Parses "kane" / "recursive"; throws std::invalid_argument otherwise.
Method parse_method(const std::string& text);

/// The O(N) route: per-body accelerations from the resultants (m a_G = F, Euler's equation),
/// then {w' dot} and {s'' } by one outward pass. Into data.ydot. Needs compute_kinematics()
/// and compute_resultants().
void recursive_accelerations(const Model& model, const State& state, Data& data);

/// {y dot} and {x dot} into data.ydot, data.xdot. No heap allocation.
/// Method::recursive works with any Data (DataOptions{false, false} is enough); when every
/// force element is a Bushing, ConstantForce or ConstantTorque it runs one fused pass over the
/// bodies (src/recursive/fused.cpp) that fills only ydot and xdot, otherwise it runs
/// compute_kinematics, compute_resultants and recursive_accelerations. Method::kane needs
/// DataOptions::mass_matrix (throws std::invalid_argument otherwise) and leaves the
/// kinematics, resultants, A_blocks, A_factor and f in data (not the dense data.A).
/// Both routes assume unit Euler parameters; they agree to round-off there.
void forward_dynamics(const Model& model, const State& state, Data& data,
                      Method method = Method::recursive);

}  // namespace kanedyn
