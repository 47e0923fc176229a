#include "kanedyn/kinematics.hpp"

#include "kanedyn/rotation.hpp"

namespace kanedyn {

void compute_rotations(const Model& model, const State& state, Kinematics& kin) {
  for (int k = 0; k < model.num_bodies(); ++k)
    kin.R[static_cast<size_t>(k)] = rotation_matrix(state.euler_parameters(k));  // Eqs. (3)-(4)
}

void compute_positions(const Model& model, const State& state, Kinematics& kin) {
  for (int k = 0; k < model.num_bodies(); ++k) {
    const auto i = static_cast<size_t>(k);
    const int j = model.lower_body(k);
    kin.qs_b[i] = model.body(k).joint + state.translation(k);
    if (j == kGround) {
      kin.p_O[i] = kin.qs_b[i];  // p_O1 = s'_1 (+ the root's fixed attachment point)
    } else {
      const auto jj = static_cast<size_t>(j);
      kin.p_O[i] = kin.p_O[jj] + kin.R[jj].transpose() * kin.qs_b[i];  // Eq. (12)
    }
    kin.p_G[i] = kin.p_O[i] + kin.R[i].transpose() * model.body(k).com;  // Eq. (13)
  }
}

void compute_velocities(const Model& model, const State& state, Kinematics& kin) {
  for (int k = 0; k < model.num_bodies(); ++k) {
    const auto i = static_cast<size_t>(k);
    const int j = model.lower_body(k);
    if (j == kGround) {
      kin.v_O[i] = state.translation_rate(k);
    } else {
      const auto jj = static_cast<size_t>(j);
      // Eq. (15)
      kin.v_O[i] = kin.v_O[jj] +
                   kin.R[jj].transpose() *
                       (state.translation_rate(k) + state.angular_velocity(j).cross(kin.qs_b[i]));
    }
    // Eq. (17)
    kin.v_G[i] =
        kin.v_O[i] + kin.R[i].transpose() * state.angular_velocity(k).cross(model.body(k).com);
  }
}

void compute_kinematics(const Model& model, const State& state, Kinematics& kin) {
  compute_rotations(model, state, kin);
  compute_positions(model, state, kin);
  compute_velocities(model, state, kin);
}

void compute_rotations(const Model& model, const State& state, Data& data) {
  compute_rotations(model, state, data.kinematics);
}
void compute_positions(const Model& model, const State& state, Data& data) {
  compute_positions(model, state, data.kinematics);
}
void compute_velocities(const Model& model, const State& state, Data& data) {
  compute_velocities(model, state, data.kinematics);
}
void compute_kinematics(const Model& model, const State& state, Data& data) {
  compute_kinematics(model, state, data.kinematics);
}

MatrixX angular_velocity_partial(const Model& model, int k) {
  MatrixX m = MatrixX::Zero(3, model.num_y());  // Eq. (8)
  m.block<3, 3>(0, 3 * k).setIdentity();
  return m;
}

Vector3 angular_acceleration_b(const VectorX& ydot, int k) { return ydot.segment<3>(3 * k); }

}  // namespace kanedyn
