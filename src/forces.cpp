#include "kanedyn/forces.hpp"

#include <cmath>

#include "equations.hpp"

namespace kanedyn {

namespace {
size_t at(int i) { return static_cast<size_t>(i); }
}  // namespace

std::string ForceElement::validate(const Model& /*model*/) const { return ""; }
double ForceElement::potential_energy(const Model&, const State&, const Kinematics&) const {
  return 0.0;
}
double ForceElement::damping_power(const Model&, const State&, const Kinematics&) const {
  return 0.0;
}
void ForceElement::apply_joint(const Model&, const VectorX&, const VectorX&,
                               Eigen::Ref<VectorX>) const {}
double ForceElement::joint_potential_energy(const Model&, const VectorX&) const { return 0.0; }
double ForceElement::joint_damping_power(const Model&, const VectorX&) const { return 0.0; }

JointLoad::JointLoad(int body, VectorX k, VectorX c, VectorX r, VectorX v, std::string kind)
    : stiffness(std::move(k)),
      damping(std::move(c)),
      rest(std::move(r)),
      value(std::move(v)),
      body_(body),
      kind_(std::move(kind)) {}

std::string JointLoad::validate(const Model& model) const {
  const JointType t = model.joint(body_).type;
  const std::string who = "body " + model.body(body_).name + ": ";
  if (!speeds_are_coordinate_rates(t)) {
    // The types whose z_K = dq_K/dt (the rates apply_joint reads): "revolute, ... and planar".
    std::string names;
    int left = 0;
    for (const JointType type : kJointTypes) left += speeds_are_coordinate_rates(type) ? 1 : 0;
    for (const JointType type : kJointTypes) {
      if (!speeds_are_coordinate_rates(type)) continue;
      --left;
      names += std::string(names.empty() ? "" : left == 0 ? " and " : ", ") + to_string(type);
    }
    return who + kind_ + " acts on " + names + " joints, not on a " + to_string(t) + " joint";
  }
  const int m = coordinate_count(t);
  for (const VectorX* v : {&stiffness, &damping, &rest, &value})
    if (v->size() != m)
      return who + "a " + kind_ + " on a " + to_string(t) + " joint needs " + std::to_string(m) +
             " entries per parameter, not " + std::to_string(v->size());
  for (const VectorX* v : {&stiffness, &damping, &rest, &value})
    if (!v->allFinite()) return who + "a " + kind_ + " parameter is not finite";
  return "";
}

// On these joints z_K = dq_K/dt, so the rates are z's entries.
void JointLoad::apply_joint(const Model& model, const VectorX& q, const VectorX& z,
                            Eigen::Ref<VectorX> Q) const {
  const int m = static_cast<int>(value.size());
  const int o = model.coordinate_offset(body_), p = model.speed_offset(body_);
  Q.segment(p, m) += value - stiffness.cwiseProduct(q.segment(o, m) - rest) -
                     damping.cwiseProduct(z.segment(p, m));
}

double JointLoad::joint_potential_energy(const Model& model, const VectorX& q) const {
  double e = 0.0;
  const int o = model.coordinate_offset(body_);
  for (Eigen::Index i = 0; i < rest.size(); ++i) {
    const double d = q[o + i] - rest[i];
    e += 0.5 * stiffness[i] * (d * d);
  }
  return e;
}

double JointLoad::joint_damping_power(const Model& model, const VectorX& z) const {
  double p = 0.0;
  const int o = model.speed_offset(body_);
  for (Eigen::Index i = 0; i < damping.size(); ++i) p += damping[i] * (z[o + i] * z[o + i]);
  return p;
}

void add_joint_forces(const Model& model, const VectorX& q, const VectorX& z,
                      Eigen::Ref<VectorX> Q) {
  // JointLoad is final: through its own pointer the call is direct, and inlined here.
  if (model.joint_loads().size() == model.joint_force_elements().size()) {
    for (const JointLoad* l : model.joint_loads()) l->apply_joint(model, q, z, Q);
    return;
  }
  for (const ForceElement* f : model.joint_force_elements()) f->apply_joint(model, q, z, Q);
}

double joint_potential_energy(const Model& model, const VectorX& q) {
  double e = 0.0;
  for (const ForceElement* f : model.joint_force_elements())
    e += f->joint_potential_energy(model, q);
  return e;
}

double joint_damping_power(const Model& model, const VectorX& z) {
  double p = 0.0;
  for (const ForceElement* f : model.joint_force_elements()) p += f->joint_damping_power(model, z);
  return p;
}

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
  return eq::eigen(eq::bushing_force(eq::vec(stiffness), eq::vec(damping),
                                     eq::vec(state.translation(body_)),
                                     eq::vec(state.translation_rate(body_))));
}

Vector3 Bushing::rotation_vector(const Model& model, const State& state) const {
  return eq::eigen(
      eq::rotation_vector(eq::relative_euler(state.x.data(), model.lower_body(body_), body_)));
}

void Bushing::apply(const Model& model, const State& state, const Kinematics& kin,
                    Loads& loads) const {
  const int k = body_;
  const int j = model.lower_body(k);
  const eq::Euler<double> rel = eq::relative_euler(state.x.data(), j, k);
  const eq::Mat3<double> R = eq::rotation_matrix(rel);               // body J -> body K components
  const eq::Vec3<double> f = eq::vec(translational_force_b(state));  // body J
  eq::Vec3<double> w_rel = eq::vec(state.angular_velocity(k));
  if (j != kGround) w_rel = w_rel - R * eq::vec(state.angular_velocity(j));
  const eq::Vec3<double> m = eq::bushing_moment(rotational_stiffness, rotational_damping,
                                                eq::rotation_vector(rel), w_rel);  // body K
  const eq::ForceAndMoment<double> on_k = eq::bushing_load_on_k(R, f, eq::vec(model.body(k).com));
  const eq::Vec3<double> f_inertial =
      j == kGround ? f : eq::transpose_times(eq::mat(kin.R[at(j)]), f);
  eq::add_to(loads.force[at(k)], f_inertial);
  eq::add_to(loads.moment_b[at(k)], on_k.moment);  // (M' + arm x F) + M, as the kernel adds them
  eq::add_to(loads.moment_b[at(k)], m);
  if (j == kGround) return;
  eq::subtract_from(loads.force[at(j)], f_inertial);
  // Arm from G_J to O_K in body J: q'_K + s'_K - r'_J.
  const Vector3 arm = model.body(k).joint + state.translation(k) - model.body(j).com;
  eq::add_to(loads.moment_b[at(j)], eq::bushing_moment_on_j(R, f, m, eq::vec(arm)));
}

double Bushing::potential_energy(const Model& model, const State& state, const Kinematics&) const {
  return eq::bushing_energy(eq::vec(stiffness), rotational_stiffness,
                            eq::vec(state.translation(body_)),
                            eq::vec(rotation_vector(model, state)));
}

double Bushing::damping_power(const Model& model, const State& state, const Kinematics&) const {
  const int k = body_;
  const int j = model.lower_body(k);
  eq::Vec3<double> w_rel = eq::vec(state.angular_velocity(k));
  if (j != kGround)
    w_rel = w_rel - eq::rotation_matrix(eq::relative_euler(state.x.data(), j, k)) *
                        eq::vec(state.angular_velocity(j));
  return eq::bushing_damping_power(eq::vec(damping), rotational_damping,
                                   eq::vec(state.translation_rate(k)), w_rel);
}

void ConstantForce::apply(const Model&, const State&, const Kinematics&, Loads& loads) const {
  loads.force[at(body())] += value;
}

void ConstantTorque::apply(const Model&, const State&, const Kinematics&, Loads& loads) const {
  loads.moment_b[at(body())] += value;
}

void compute_resultants(const Model& model, const State& state, const Kinematics& kin,
                        Loads& loads) {
  for (int k = 0; k < model.num_bodies(); ++k) {
    loads.force[at(k)] = model.body(k).mass * model.gravity();
    loads.moment_b[at(k)].setZero();
  }
  for (const auto& element : model.forces()) element->apply(model, state, kin, loads);
}

void compute_resultants(const Model& model, const State& state, const Kinematics& kin,
                        const VectorX& u, Loads& loads) {
  compute_resultants(model, state, kin, loads);
  if (model.has_body_inputs()) add_input_loads(model, u, state, kin, loads);
}

void compute_resultants(const Model& model, const State& state, Data& data) {
  compute_resultants(model, state, data.kinematics, data.inputs, data.loads);
}

void add_input_loads(const Model& model, const VectorX& u, const State& state,
                     const Kinematics& kin, Loads& loads) {
  const auto& inputs = model.inputs();
  for (size_t i = 0; i < inputs.size(); ++i) {
    const Input& in = inputs[i];
    const double value = u[static_cast<Eigen::Index>(i)];
    const int k = in.body;
    const int j = model.lower_body(k);
    switch (in.type) {
      case InputType::force: {
        const Vector3 f_b = value * in.direction;  // body K
        loads.force[at(k)].noalias() += kin.R[at(k)].transpose() * f_b;
        loads.moment_b[at(k)] += (in.point - model.body(k).com).cross(f_b);
        break;
      }
      case InputType::torque: {
        const Vector3 m_b = value * in.axis;  // body K
        loads.moment_b[at(k)] += m_b;
        if (in.reaction && j != kGround)
          loads.moment_b[at(j)].noalias() -= kin.R[at(j)] * (kin.R[at(k)].transpose() * m_b);
        break;
      }
      case InputType::joint: {
        if (model.joint(k).type != JointType::free) break;  // add_input_joint_forces
        if (in.speed < 3) {  // w'_K i: a moment about e_i, body-K components
          loads.moment_b[at(k)][in.speed] += value;
          break;
        }
        // s'_K dot i: the force e_i (body J) at O_K on K, reversed on J.
        Vector3 f_j = Vector3::Zero();
        f_j[in.speed - 3] = value;
        const Vector3 f = j == kGround ? f_j : Vector3(kin.R[at(j)].transpose() * f_j);
        loads.force[at(k)] += f;
        loads.moment_b[at(k)] -= model.body(k).com.cross(kin.R[at(k)] * f);
        if (j == kGround) break;
        loads.force[at(j)] -= f;
        // Arm from G_J to O_K in body J: q'_K + s'_K - r'_J.
        const Vector3 arm = model.body(k).joint + state.translation(k) - model.body(j).com;
        loads.moment_b[at(j)] -= arm.cross(f_j);
        break;
      }
    }
  }
}

void add_input_joint_forces(const Model& model, const VectorX& u, Eigen::Ref<VectorX> Q) {
  const auto& inputs = model.inputs();
  for (size_t i = 0; i < inputs.size(); ++i) {
    const Input& in = inputs[i];
    if (in.type != InputType::joint || model.joint(in.body).type == JointType::free) continue;
    Q[model.speed_offset(in.body) + in.speed] += u[static_cast<Eigen::Index>(i)];
  }
}

}  // namespace kanedyn
