#include "kanedyn/testing/oracles.hpp"

namespace kanedyn::oracles {

namespace {
size_t at(int i) { return static_cast<size_t>(i); }
}  // namespace

MatrixX mass_matrix_term_by_term(const Model& model, const Data& data) {
  const int n = model.num_bodies();
  MatrixX A = MatrixX::Zero(6 * n, 6 * n);
  for (int k = 0; k < n; ++k) {
    const double m = model.body(k).mass;
    const Model::Chain chain = model.chain(k);
    const size_t o = at(model.chain_offset(k));
    // m_K [v_G_K,y]^T [v_G_K,y]: only pairs of blocks on K's chain are nonzero.
    for (int a = 0; a < chain.size; ++a) {
      const int ca = chain[a];
      const Matrix3& wa = data.partials.vG_w[o + at(a)];
      const Matrix3& sa = data.partials.vG_s[o + at(a)];
      for (int b = 0; b < chain.size; ++b) {
        const int cb = chain[b];
        const Matrix3& wb = data.partials.vG_w[o + at(b)];
        const Matrix3& sb = data.partials.vG_s[o + at(b)];
        A.block<3, 3>(3 * ca, 3 * cb).noalias() += m * wa.transpose() * wb;
        A.block<3, 3>(3 * ca, 3 * n + 3 * cb).noalias() += m * wa.transpose() * sb;
        A.block<3, 3>(3 * n + 3 * ca, 3 * cb).noalias() += m * sa.transpose() * wb;
        A.block<3, 3>(3 * n + 3 * ca, 3 * n + 3 * cb).noalias() += m * sa.transpose() * sb;
      }
    }
    // [w'_K,y]^T [I'_G_K] [w'_K,y]: the inertia in the w'_K, w'_K block.
    A.block<3, 3>(3 * k, 3 * k) += model.body(k).inertia;
  }
  return A;
}

VectorX force_vector_term_by_term(const Model& model, const State& state, const Data& data) {
  const int n = model.num_bodies();
  VectorX f = VectorX::Zero(6 * n);
  for (int k = 0; k < n; ++k) {
    const Model::Chain chain = model.chain(k);
    const size_t o = at(model.chain_offset(k));
    // [v_G_K,y dot]{y}: the velocity-dependent part of the acceleration of G_K.
    Vector3 bias = Vector3::Zero();
    for (int r = 0; r < chain.size; ++r) {
      const int c = chain[r];
      bias.noalias() += data.partials.vG_w_dot[o + at(r)] * state.angular_velocity(c);
      bias.noalias() += data.partials.vG_s_dot[o + at(r)] * state.translation_rate(c);
    }
    const Vector3 g = data.loads.force[at(k)] - model.body(k).mass * bias;
    for (int r = 0; r < chain.size; ++r) {
      const int c = chain[r];
      f.segment<3>(3 * c).noalias() += data.partials.vG_w[o + at(r)].transpose() * g;
      f.segment<3>(3 * n + 3 * c).noalias() += data.partials.vG_s[o + at(r)].transpose() * g;
    }
    // [w'_K,y]^T ({M'_K} - [w~'_K][I'_G_K]{w'_K})
    const Vector3 w = state.angular_velocity(k);
    f.segment<3>(3 * k) += data.loads.moment_b[at(k)] - w.cross(model.body(k).inertia * w);
  }
  return f;
}

}  // namespace kanedyn::oracles
