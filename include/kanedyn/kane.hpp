// Eqs. (31)-(38): Kane's equations [A]{y dot} = {f} (Eq. 36), assembled from the block-sparse
// partial velocity matrices and solved by Cholesky.
#pragma once

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

/// Eq. (37): [A] = sum_K m_K [v_G_K,y]^T[v_G_K,y] + [w'_K,y]^T[I'_G_K][w'_K,y], into data.A.
/// Only blocks whose bodies lie on one chain are touched. Needs the partials.
void compute_mass_matrix(const Model& model, Data& data);

/// Eq. (38): {f} = sum_K [v_G_K,y]^T({F_K} - m_K [v_G_K,y dot]{y})
///                + [w'_K,y]^T({M'_K} - [w~'_K][I'_G_K]{w'_K}), into data.f.
/// Needs the partials, their rates and the resultants.
void compute_force_vector(const Model& model, const State& state, Data& data);

/// Everything of the Kane route at one state: kinematics, partials (recursive), their rates,
/// resultants, Eq. (31), A, f, and {y dot} = A^-1 f by Cholesky, into data.ydot.
void kane_equations(const Model& model, const State& state, Data& data);

}  // namespace kanedyn
