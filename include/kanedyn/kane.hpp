// Eqs. (31)-(38): Kane's equations [A]{y dot} = {f} (Eq. 36). [A] is assembled block by
// block in O(number of nonzero blocks) from the partial velocity blocks and subtree
// (composite) sums, and factored by a tree-ordered block LDL^T without fill-in
// (tree_ldlt.hpp); docs/theory.md, "O(N) forward dynamics". The dense forms of Eqs. (37)-(38)
// are kept as test oracles.
#pragma once

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

/// Eq. (37) into data.A_blocks (chain layout, see data.hpp): block (K, I) for I on K's chain
/// is S_K^T [v_G_K,y]_I, with S_K = sum over K's subtree of m [v_G,y]_K (every body below K
/// shares K's partial blocks at I, Eqs. 26-27). Needs compute_kinematics() and a Data with
/// DataOptions::mass_matrix. Assumes unit Euler parameters ([R_K] orthogonal).
void compute_mass_matrix(const Model& model, Data& data);

/// Eq. (38) into data.f by one outward pass (velocity-dependent accelerations of O_K) and one
/// inward pass (subtree sums of the loads), O(N). Needs compute_kinematics(),
/// compute_resultants() and DataOptions::mass_matrix.
void compute_force_vector(const Model& model, const State& state, Data& data);

/// The dense 6N x 6N [A] in the speed order of Eq. (1), into data.A, from data.A_blocks.
void dense_mass_matrix(const Model& model, Data& data);

/// Test oracle: Eq. (37) term by term, sum over K of m_K [v_G_K,y]^T[v_G_K,y] +
/// [w'_K,y]^T[I'_G_K][w'_K,y] over the pairs of blocks of K's chain (O(N d^2)), into data.A
/// (dense). Needs the chain-layout partials (compute_partials_*).
void compute_mass_matrix_dense(const Model& model, Data& data);

/// Test oracle: Eq. (38) term by term, {f} = sum_K [v_G_K,y]^T({F_K} - m_K [v_G_K,y dot]{y})
/// + [w'_K,y]^T({M'_K} - [w~'_K][I'_G_K]{w'_K}), into data.f. Needs the partials, their rates
/// (compute_partial_rates) and the resultants.
void compute_force_vector_dense(const Model& model, const State& state, Data& data);

/// {y dot} = [A]^-1 {f} by the Kane route, into data.ydot: compute_mass_matrix(),
/// compute_force_vector(), tree LDL^T (data.A_factor) and solve. Needs compute_kinematics() and
/// compute_resultants(). This is forward_dynamics(Method::kane) without the kinematical
/// equations.
void kane_accelerations(const Model& model, const State& state, Data& data);

/// Everything of the Kane route at one state, for output and teaching: kinematics, partials
/// and their rates (when DataOptions::partials), resultants, {F_y} (Eq. 31,
/// compute_generalized_forces), [A] (blocks, and the dense data.A when
/// DataOptions::dense_mass_matrix), {f}, the factor and {y dot}. Needs DataOptions::mass_matrix.
void kane_equations(const Model& model, const State& state, Data& data);

}  // namespace kanedyn
