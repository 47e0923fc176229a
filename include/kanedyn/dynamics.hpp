// Forward dynamics: {y dot} and {x dot} at a state, by the route of the user's choice. Both
// routes solve Kane's equations (Eq. 36) for the same unconstrained tree.
#pragma once

#include <string>

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

enum class Route {
  /// Assemble [A] and {f} (Eqs. 37-38) block-sparse and solve Eq. (36) by the tree-ordered
  /// block LDL^T (tree_ldlt.hpp); O(N d^2) for a tree of depth d.
  assembled,
  /// O(N): Newton-Euler per body, then s'' from the relative motion (docs/theory.md); one
  /// fused SIMD pass over the bodies when every force element is of a built-in type.
  recursive
};

/// "assembled" / "recursive".
std::string to_string(Route route);
/// Parses "assembled" / "recursive" (and "kane", the older spelling of "assembled"); throws
/// std::invalid_argument otherwise.
Route parse_route(const std::string& text);

/// {y dot} (Eq. 36) and {x dot} (Eqs. 39-40) at the state into data.ydot and data.xdot, and
/// nothing else of data's public parts: each route works in the Data's private scratch. No
/// heap allocation. Route::recursive runs with any Data; Route::assembled needs
/// DataOptions::kane_terms (throws std::invalid_argument otherwise). Both assume unit Euler
/// parameters; they agree to round-off there.
void forward_dynamics(const Model& model, const State& state, Data& data,
                      Route route = Route::recursive);

}  // namespace kanedyn
