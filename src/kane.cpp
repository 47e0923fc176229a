#include "kanedyn/kane.hpp"

#include "kanedyn/forces.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/partials.hpp"

namespace kanedyn {

namespace {
size_t at(int i) { return static_cast<size_t>(i); }
}  // namespace

void compute_mass_matrix(const Model& model, Data& data) {
  const int n = model.num_bodies();
  MatrixX& A = data.A;
  A.setZero();
  for (int k = 0; k < n; ++k) {
    const double m = model.body(k).mass;
    const Model::Chain chain = model.chain(k);
    const size_t o = at(model.chain_offset(k));
    // m_K [v_G_K,y]^T [v_G_K,y]: only pairs of blocks on K's chain are nonzero.
    for (int a = 0; a < chain.size; ++a) {
      const int ca = chain[a];
      const Matrix3& wa = data.vG_w[o + at(a)];
      const Matrix3& sa = data.vG_s[o + at(a)];
      for (int b = 0; b < chain.size; ++b) {
        const int cb = chain[b];
        const Matrix3& wb = data.vG_w[o + at(b)];
        const Matrix3& sb = data.vG_s[o + at(b)];
        A.block<3, 3>(3 * ca, 3 * cb).noalias() += m * wa.transpose() * wb;
        A.block<3, 3>(3 * ca, 3 * n + 3 * cb).noalias() += m * wa.transpose() * sb;
        A.block<3, 3>(3 * n + 3 * ca, 3 * cb).noalias() += m * sa.transpose() * wb;
        A.block<3, 3>(3 * n + 3 * ca, 3 * n + 3 * cb).noalias() += m * sa.transpose() * sb;
      }
    }
    // [w'_K,y]^T [I'_G_K] [w'_K,y]: the inertia in the w'_K, w'_K block.
    A.block<3, 3>(3 * k, 3 * k) += model.body(k).inertia;
  }
}

void compute_force_vector(const Model& model, const State& state, Data& data) {
  const int n = model.num_bodies();
  data.f.setZero();
  for (int k = 0; k < n; ++k) {
    const Model::Chain chain = model.chain(k);
    const size_t o = at(model.chain_offset(k));
    // [v_G_K,y dot]{y}: the velocity-dependent part of the acceleration of G_K.
    Vector3 bias = Vector3::Zero();
    for (int r = 0; r < chain.size; ++r) {
      const int c = chain[r];
      bias.noalias() += data.vG_w_dot[o + at(r)] * state.angular_velocity(c);
      bias.noalias() += data.vG_s_dot[o + at(r)] * state.translation_rate(c);
    }
    const Vector3 g = data.force[at(k)] - model.body(k).mass * bias;
    for (int r = 0; r < chain.size; ++r) {
      const int c = chain[r];
      data.f.segment<3>(3 * c).noalias() += data.vG_w[o + at(r)].transpose() * g;
      data.f.segment<3>(3 * n + 3 * c).noalias() += data.vG_s[o + at(r)].transpose() * g;
    }
    // [w'_K,y]^T ({M'_K} - [w~'_K][I'_G_K]{w'_K})
    const Vector3 w = state.angular_velocity(k);
    data.f.segment<3>(3 * k) += data.moment_b[at(k)] - w.cross(model.body(k).inertia * w);
  }
}

void kane_equations(const Model& model, const State& state, Data& data) {
  compute_kinematics(model, state, data);
  compute_partials_recursive(model, state, data);
  compute_partial_rates(model, state, data);
  compute_resultants(model, state, data);
  compute_generalized_forces(model, data);
  compute_mass_matrix(model, data);
  compute_force_vector(model, state, data);
  data.A_factor.compute(data.A);  // [A] is symmetric positive definite: Cholesky
  data.ydot = data.f;
  data.A_factor.solveInPlace(data.ydot);  // Eq. (36)
}

}  // namespace kanedyn
