// Eqs. (2)-(17): orientations, positions and velocities of every body, and the constant
// partial angular velocity matrices of Eqs. (6)-(8), (10).
#pragma once

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

/// [R_K] for every body (Eqs. 2-4), into data.R.
void compute_rotations(const Model& model, const State& state, Data& data);

/// {p_O_K} (Eq. 12, recursive from the root) and {p_G_K} (Eq. 13), inertial components,
/// into data.p_O, data.p_G; also data.qs_b = {q'_K} + {s'_K}. Needs data.R.
void compute_positions(const Model& model, const State& state, Data& data);

/// {v_O_K} (Eq. 15) and {v_G_K} (Eq. 17), inertial components, into data.v_O, data.v_G.
/// Needs compute_positions().
void compute_velocities(const Model& model, const State& state, Data& data);

/// All three above.
void compute_kinematics(const Model& model, const State& state, Data& data);

/// [w'_K,y] of Eq. (8): the constant 3 x 6N matrix selecting {w'_K} from {y} (I in block K of
/// the y1 part). Dense, for output and tests; the algorithms use the selection directly.
MatrixX angular_velocity_partial(const Model& model, int k);

/// {alpha'_K} = [w'_K,y]{y dot} (Eq. 10): body-K angular acceleration from {y dot}.
Vector3 angular_acceleration_b(const VectorX& ydot, int k);

}  // namespace kanedyn
