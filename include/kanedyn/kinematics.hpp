// Eqs. (2)-(17): orientations, positions and velocities of every body, and the constant
// partial angular velocity matrices of Eqs. (6)-(8), (10).
#pragma once

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

/// [R_K] for every body (Eqs. 2-4), into data.kinematics.R.
void compute_rotations(const Model& model, const State& state, Data& data);

/// {p_O_K} (Eq. 12, recursive from the root) and {p_G_K} (Eq. 13), inertial components,
/// into data.kinematics.p_O, data.kinematics.p_G; also data.kinematics.qs_b = {q'_K} + {s'_K}.
/// Needs data.kinematics.R.
void compute_positions(const Model& model, const State& state, Data& data);

/// {v_O_K} (Eq. 15) and {v_G_K} (Eq. 17), inertial components, into data.kinematics.v_O,
/// data.kinematics.v_G. Needs compute_positions().
void compute_velocities(const Model& model, const State& state, Data& data);

/// All three above: fills data.kinematics.
void compute_kinematics(const Model& model, const State& state, Data& data);

/// The same on a Kinematics of the model's size (for force elements and programs that keep
/// their own).
void compute_rotations(const Model& model, const State& state, Kinematics& kin);
void compute_positions(const Model& model, const State& state, Kinematics& kin);
void compute_velocities(const Model& model, const State& state, Kinematics& kin);
void compute_kinematics(const Model& model, const State& state, Kinematics& kin);

/// [w'_K,y] of Eq. (8): the constant 3 x 6N matrix selecting {w'_K} from {y} (I in block K of
/// the y1 part). Dense, for output and tests; the algorithms use the selection directly.
MatrixX angular_velocity_partial(const Model& model, int k);

/// {alpha'_K} = [w'_K,y]{y dot} (Eq. 10): body-K angular acceleration from {y dot}.
Vector3 angular_acceleration_b(const VectorX& ydot, int k);

}  // namespace kanedyn
