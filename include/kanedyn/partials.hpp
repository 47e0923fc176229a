// Eqs. (18)-(30): partial velocity matrices of the body origins O_K and mass centres G_K, by
// recursion and directly, and their time derivatives. Stored block-sparse in Data (see
// data.hpp): only the blocks of a body's own chain are nonzero.
#pragma once

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

/// [v_O_K,y] by Eqs. (18)-(20) from the lower body's matrix, and [v_G_K,y] by Eq. (21).
/// Needs data.kinematics (compute_positions() at least); fills the first four arrays of
/// data.partials. Every function here needs DataOptions::partials (throws
/// std::invalid_argument otherwise).
void compute_partials_recursive(const Model& model, const State& state, Data& data);

/// The same matrices directly from the chain, Eqs. (22)-(27): block at L^{r+1}(K) of the y1
/// part is -[R_{L^{r+1}(K)}]^T([q~'_{L^r(K)}] + [s~'_{L^r(K)}]), block at L^r(K) of the y2
/// part is [R_{L^{r+1}(K)}]^T ([I] at the root). Needs compute_positions().
void compute_partials_direct(const Model& model, const State& state, Data& data);

/// Time derivatives [v_O_K,y dot] (Eq. 30, with the s' dot slip of the text corrected) and
/// [v_G_K,y dot] (Eq. 29); Eq. (28) says the angular ones vanish. Needs compute_positions().
void compute_partial_rates(const Model& model, const State& state, Data& data);

/// Which point of body K a dense view is for.
enum class Point { O, G };

/// Dense 3 x 6N views of the stored blocks, for output and tests.
MatrixX partial_velocity(const Model& model, const Data& data, int k, Point point);
MatrixX partial_velocity_rate(const Model& model, const Data& data, int k, Point point);

}  // namespace kanedyn
