// Forward dynamics: {y dot} and {x dot} at a state, by the route of the user's choice.
#pragma once

#include <string>

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

enum class Method {
  kane,      ///< assemble [A] and {f} (Eqs. 37-38), solve Eq. (36) by Cholesky
  recursive  ///< O(N): Newton-Euler per body, then one outward pass (docs/theory.md)
};

/// "kane" / "recursive".
std::string to_string(Method method);
/// Parses "kane" / "recursive"; throws std::invalid_argument otherwise.
Method parse_method(const std::string& text);

/// The O(N) route: per-body accelerations from the resultants (m a_G = F, Euler's equation),
/// then {w' dot} and {s'' } by one outward pass. Into data.ydot. Needs compute_kinematics()
/// and compute_resultants().
void recursive_accelerations(const Model& model, const State& state, Data& data);

/// {y dot} and {x dot} into data.ydot, data.xdot. Method::kane needs a Data with partials
/// and mass matrix (the default DataOptions).
void forward_dynamics(const Model& model, const State& state, Data& data,
                      Method method = Method::recursive);

}  // namespace kanedyn
