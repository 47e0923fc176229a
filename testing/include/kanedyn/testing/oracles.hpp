// Test oracles: the notes' sums of Eqs. (37)-(38) taken term by term over the partial velocity
// matrices, O(N d^2), against which the block-sparse assembly and both routes are checked.
// Part of the testing library (kanedyn_testing), not of the installed API.
#pragma once

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn::oracles {

/// Eq. (37) term by term, sum over K of m_K [v_G_K,y]^T[v_G_K,y] + [w'_K,y]^T[I'_G_K][w'_K,y]
/// over the pairs of blocks of K's chain, dense 6N x 6N. Needs data.partials
/// (compute_partials_*).
MatrixX mass_matrix_term_by_term(const Model& model, const Data& data);

/// Eq. (38) term by term, {f} = sum_K [v_G_K,y]^T({F_K} - m_K [v_G_K,y dot]{y})
/// + [w'_K,y]^T({M'_K} - [w~'_K][I'_G_K]{w'_K}). Needs data.partials with their rates
/// (compute_partial_rates) and data.loads.
VectorX force_vector_term_by_term(const Model& model, const State& state, const Data& data);

}  // namespace kanedyn::oracles
