// Eqs. (31)-(38): Kane's equations [A]{y dot} = {f} (Eq. 36), with every term kept for output
// and teaching. [A] is assembled block by block in O(number of nonzero blocks) from the
// partial velocity blocks and subtree (composite) sums and factored by a tree-ordered block
// LDL^T without fill-in (src/tree_ldlt.cpp); docs/theory.md, "O(N) forward dynamics".
#pragma once

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

/// Kane's equations at one state, every term: fills data.kinematics (compute_kinematics),
/// data.partials with their rates (with DataOptions::partials), data.loads
/// (compute_resultants), data.kane.F_y (Eq. 31), data.kane.A (Eq. 37, with
/// DataOptions::dense_mass_matrix), data.kane.f (Eq. 38), data.ydot (Eq. 36) and data.xdot
/// (Eqs. 39-40). Needs DataOptions::kane_terms (throws std::invalid_argument otherwise).
/// Assumes unit Euler parameters ([R_K] orthogonal).
void kane_equations(const Model& model, const State& state, Data& data);

/// The largest N for which the `eom` outputs (the tool's and Python's Model.eom) form the dense
/// 6N x 6N [A]: 36 N^2 doubles. A chain's [A] is full and its tree LDL^T O(N^3): at 300
/// bodies eom takes about 0.6 s (1.6 s and 13 MB with --json) on a 2-core machine, at 1000
/// about 16 s (29 s, 150 MB of JSON and 1.8 GB of memory), past what a table or a JSON
/// object of one state is for. Larger models: inspect (per body), bench, simulate.
constexpr int kMaxEomBodies = 300;

}  // namespace kanedyn
