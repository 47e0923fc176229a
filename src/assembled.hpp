// The stages of the assembled route (Eqs. 31, 37, 38 and 36), on the parts they read and
// write, so that kane_equations() fills the public parts of a Data and forward_dynamics()
// its private scratch with the same code. Private to the library.
#pragma once

#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

#include "workspace.hpp"

namespace kanedyn::assembled {

/// Eq. (37) into a.A_blocks (chain layout): block (K, I) for I on K's chain is
/// S_K^T [v_G_K,y]_I, with S_K = sum over K's subtree of m [v_G,y]_K (every body below K
/// shares K's partial blocks at I, Eqs. 26-27).
void mass_matrix(const Model& model, const Kinematics& kin, detail::AssembledScratch& a);

/// Eq. (38) into f by one outward pass (velocity-dependent accelerations of O_K, a.bias_O) and
/// one inward pass (subtree sums of the loads), O(N).
void force_vector(const Model& model, const State& state, const Kinematics& kin, const Loads& loads,
                  detail::AssembledScratch& a, std::vector<Vector3>& load_sum, VectorX& f);

/// Eq. (31) into F_y by the inward pass of Eq. (38), O(N).
void generalized_forces(const Model& model, const Kinematics& kin, const Loads& loads,
                        std::vector<Vector3>& load_sum, VectorX& F_y);

/// Eq. (36): factors a.A_blocks (a.factor) and solves [A] x = b in place (b = {f} on entry,
/// {y dot} on return).
void solve_in_place(const Model& model, detail::AssembledScratch& a, VectorX& b);

/// The dense 6N x 6N [A] in the speed order of Eq. (1) from the blocks.
void to_dense(const Model& model, const std::vector<Matrix6>& blocks, MatrixX& A);

}  // namespace kanedyn::assembled
