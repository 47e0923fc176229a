#include "kanedyn/kinematics.hpp"

#include "kanedyn/rotation.hpp"

namespace kanedyn {

void compute_rotations(const Model& model, const State& state, Data& data) {
  for (int k = 0; k < model.num_bodies(); ++k)
    data.R[static_cast<size_t>(k)] = rotation_matrix(state.euler_parameters(k));  // Eqs. (3)-(4)
}

void compute_positions(const Model& model, const State& state, Data& data) {
  for (int k = 0; k < model.num_bodies(); ++k) {
    const auto i = static_cast<size_t>(k);
    const int j = model.lower_body(k);
    data.qs_b[i] = model.body(k).joint + state.translation(k);
    if (j == kGround) {
      data.p_O[i] = data.qs_b[i];  // p_O1 = s'_1 (+ the root's fixed attachment point)
    } else {
      const auto jj = static_cast<size_t>(j);
      data.p_O[i] = data.p_O[jj] + data.R[jj].transpose() * data.qs_b[i];  // Eq. (12)
    }
    data.p_G[i] = data.p_O[i] + data.R[i].transpose() * model.body(k).com;  // Eq. (13)
  }
}

void compute_velocities(const Model& model, const State& state, Data& data) {
  for (int k = 0; k < model.num_bodies(); ++k) {
    const auto i = static_cast<size_t>(k);
    const int j = model.lower_body(k);
    if (j == kGround) {
      data.v_O[i] = state.translation_rate(k);
    } else {
      const auto jj = static_cast<size_t>(j);
      // Eq. (15)
      data.v_O[i] = data.v_O[jj] +
                    data.R[jj].transpose() *
                        (state.translation_rate(k) + state.angular_velocity(j).cross(data.qs_b[i]));
    }
    // Eq. (17)
    data.v_G[i] =
        data.v_O[i] + data.R[i].transpose() * state.angular_velocity(k).cross(model.body(k).com);
  }
}

void compute_kinematics(const Model& model, const State& state, Data& data) {
  compute_rotations(model, state, data);
  compute_positions(model, state, data);
  compute_velocities(model, state, data);
}

MatrixX angular_velocity_partial(const Model& model, int k) {
  MatrixX m = MatrixX::Zero(3, model.num_speeds());  // Eq. (8)
  m.block<3, 3>(0, 3 * k).setIdentity();
  return m;
}

Vector3 angular_acceleration_b(const VectorX& ydot, int k) { return ydot.segment<3>(3 * k); }

}  // namespace kanedyn
