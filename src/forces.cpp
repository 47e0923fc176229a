#include "kanedyn/forces.hpp"

#include <cmath>

#include "kanedyn/detail/fast_rotation.hpp"
#include "kanedyn/rotation.hpp"

namespace kanedyn {

namespace {
size_t at(int i) { return static_cast<size_t>(i); }
}  // namespace

std::string ForceElement::validate(const Model& /*model*/) const { return ""; }
double ForceElement::potential_energy(const Model&, const State&, const Data&) const { return 0.0; }
double ForceElement::damping_power(const Model&, const State&, const Data&) const { return 0.0; }

Bushing::Bushing(int body, Vector3 k, Vector3 c, double kr, double cr)
    : stiffness(std::move(k)),
      damping(std::move(c)),
      rotational_stiffness(kr),
      rotational_damping(cr),
      body_(body) {}

std::string Bushing::validate(const Model& /*model*/) const {
  if (!stiffness.allFinite() || !damping.allFinite() || !std::isfinite(rotational_stiffness) ||
      !std::isfinite(rotational_damping))
    return "bushing parameters must be finite";
  if ((stiffness.array() < 0).any() || rotational_stiffness < 0)
    return "bushing stiffness must be >= 0";
  if ((damping.array() < 0).any() || rotational_damping < 0) return "bushing damping must be >= 0";
  return "";
}

Vector3 Bushing::translational_force_b(const State& state) const {
  return -stiffness.cwiseProduct(state.translation(body_)) -
         damping.cwiseProduct(state.translation_rate(body_));
}

Vector3 Bushing::rotation_vector(const State& state, const Model& model) const {
  const int j = model.lower_body(body_);
  const Vector4 eps_k = state.euler_parameters(body_);
  if (j == kGround) return kanedyn::rotation_vector(eps_k);
  return kanedyn::rotation_vector(relative_euler_parameters(state.euler_parameters(j), eps_k));
}

void Bushing::apply(const Model& model, const State& state, Data& data) const {
  const int k = body_;
  const int j = model.lower_body(k);
  const Vector3& com = model.body(k).com;
  // Translational part: {F'} in body-J components, on K at O_K, reversed on J at O_K.
  const Vector3 f_b = translational_force_b(state);
  // Rotational part: M = -kr theta - cr (w_K - w_J), body-K components, -M on J.
  Vector3 w_rel_b = state.angular_velocity(k);
  if (j == kGround) {
    data.force[at(k)] += f_b;
    data.moment_b[at(k)] += (data.R[at(k)] * f_b).cross(com);  // (O_K - G_K) x F
    const Vector3 m_b = -rotational_stiffness * detail::rotation_vector(state.euler_parameters(k)) -
                        rotational_damping * w_rel_b;
    data.moment_b[at(k)] += m_b;
    return;
  }
  const Matrix3& Rj = data.R[at(j)];
  const Matrix3 R_rel = data.R[at(k)] * Rj.transpose();  // body J -> body K components
  const Vector3 f = Rj.transpose() * f_b;                // inertial
  data.force[at(k)] += f;
  data.moment_b[at(k)] += (R_rel * f_b).cross(com);
  data.force[at(j)] -= f;
  // Arm from G_J to O_K in body J: q'_K + s'_K - r'_J.
  const Vector3 arm = model.body(k).joint + state.translation(k) - model.body(j).com;
  data.moment_b[at(j)] += f_b.cross(arm);
  w_rel_b -= R_rel * state.angular_velocity(j);
  const Vector4 rel =
      detail::relative_euler_parameters(state.x.data() + 4 * j, state.x.data() + 4 * k);
  const Vector3 m_b =
      -rotational_stiffness * detail::rotation_vector(rel) - rotational_damping * w_rel_b;
  data.moment_b[at(k)] += m_b;
  data.moment_b[at(j)] -= R_rel.transpose() * m_b;
}

double Bushing::potential_energy(const Model& model, const State& state, const Data&) const {
  const Vector3 s = state.translation(body_);
  const Vector3 theta = rotation_vector(state, model);
  return 0.5 * s.dot(stiffness.cwiseProduct(s)) + 0.5 * rotational_stiffness * theta.squaredNorm();
}

double Bushing::damping_power(const Model& model, const State& state, const Data& data) const {
  const int k = body_;
  const int j = model.lower_body(k);
  const Vector3 sd = state.translation_rate(k);
  Vector3 w_rel_b = state.angular_velocity(k);
  if (j != kGround)
    w_rel_b -= data.R[at(k)] * (data.R[at(j)].transpose() * state.angular_velocity(j));
  return sd.dot(damping.cwiseProduct(sd)) + rotational_damping * w_rel_b.squaredNorm();
}

void ConstantForce::apply(const Model&, const State&, Data& data) const {
  data.force[at(body())] += value;
}

void ConstantTorque::apply(const Model&, const State&, Data& data) const {
  data.moment_b[at(body())] += value;
}

void compute_resultants(const Model& model, const State& state, Data& data) {
  for (int k = 0; k < model.num_bodies(); ++k) {
    data.force[at(k)] = model.body(k).mass * model.gravity();
    data.moment_b[at(k)].setZero();
  }
  for (const auto& element : model.forces()) element->apply(model, state, data);
}

void compute_generalized_forces(const Model& model, Data& data) {
  const int n = model.num_bodies();
  data.F_y.setZero();
  for (int k = 0; k < n; ++k) {
    const Model::Chain chain = model.chain(k);
    const size_t o = at(model.chain_offset(k));
    const Vector3& F = data.force[at(k)];
    for (int r = 0; r < chain.size; ++r) {  // [v_G_K,y]^T {F_K}, block by block
      const int c = chain[r];
      data.F_y.segment<3>(3 * c) += data.vG_w[o + at(r)].transpose() * F;
      data.F_y.segment<3>(3 * n + 3 * c) += data.vG_s[o + at(r)].transpose() * F;
    }
    data.F_y.segment<3>(3 * k) += data.moment_b[at(k)];  // [w'_K,y]^T {M'_K}
  }
}

}  // namespace kanedyn
