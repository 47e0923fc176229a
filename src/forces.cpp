#include "kanedyn/forces.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>

#include "equations.hpp"
#include "tree_loads.hpp"

namespace kanedyn {

namespace {

using tree::at;
using tree::constant;

// What a force element's law reads and where it adds its loads in the double evaluation routes
// (the state and kinematics of one evaluation; Loads: forces at G_K, inertial, moments body
// K; generalized forces added to Q): the API of detail::TreeLoads, over double.
class StateLoads {
 public:
  using Scalar = double;
  StateLoads(const Model& model, const State* state, const Kinematics* kin, Loads* loads,
             const double* q = nullptr, const double* z = nullptr, double* Q = nullptr)
      : model_(model), state_(state), kin_(kin), loads_(loads), q_(q), z_(z), Q_(Q) {}

  const Model& model() const { return model_; }

  eq::Euler<double> relative_euler(int k) const {
    return eq::relative_euler(state_->x.data(), model_.lower_body(k), k);
  }
  eq::Mat3<double> rotation(int k) const { return eq::mat(kin_->R[at(k)]); }
  eq::Vec3<double> translation(int k) const { return eq::vec(state_->translation(k)); }
  eq::Vec3<double> translation_rate(int k) const { return eq::vec(state_->translation_rate(k)); }
  eq::Vec3<double> angular_velocity(int k) const { return eq::vec(state_->angular_velocity(k)); }
  tree::PointMotion<double> point(int k, const Vector3& offset) const {
    tree::PointMotion<double> pm{};
    if (k == kGround) {
      pm.p = eq::vec(offset);
      pm.r = pm.p;
      return pm;
    }
    const eq::Mat3<double> R = rotation(k);
    pm.r = eq::transpose_times(R, eq::vec(offset));
    pm.p = eq::vec(kin_->p_O[at(k)]) + pm.r;
    pm.v = eq::vec(kin_->v_O[at(k)]) + eq::cross(eq::transpose_times(R, angular_velocity(k)), pm.r);
    return pm;
  }
  double coordinate(int i) const { return q_[i]; }
  double speed(int i) const { return z_[i]; }

  void add_moment(int k, const eq::Vec3<double>& m) { eq::add_to(loads_->moment_b[at(k)], m); }
  void add_force_at_com(int k, const eq::Vec3<double>& f) { eq::add_to(loads_->force[at(k)], f); }
  void add_force_at_com_b(int k, const eq::Vec3<double>& f) {
    eq::add_to(loads_->force[at(k)], eq::transpose_times(rotation(k), f));
  }
  void add_force_at_com_lower(int k, const eq::Vec3<double>& f_j, const eq::Vec3<double>&) {
    const int j = model_.lower_body(k);
    eq::add_to(loads_->force[at(k)], j == kGround ? f_j : eq::transpose_times(rotation(j), f_j));
  }
  void add_force(int k, const Vector3& offset, const eq::Vec3<double>& f) {
    if (k == kGround) return;
    eq::add_to(loads_->force[at(k)], f);
    eq::add_to(loads_->moment_b[at(k)],
               eq::cross(eq::vec(Vector3(offset - model_.body(k).com)), rotation(k) * f));
  }
  void add_force_at_origin_lower(int k, const eq::Vec3<double>& f_j) {
    const int j = model_.lower_body(k);
    const eq::Vec3<double> f = j == kGround ? f_j : eq::transpose_times(rotation(j), f_j);
    eq::add_to(loads_->force[at(k)], f);
    eq::subtract_from(loads_->moment_b[at(k)],
                      eq::cross(eq::vec(model_.body(k).com), rotation(k) * f));
  }
  void add_reaction_moment(int k, const eq::Vec3<double>& m) {
    const int j = model_.lower_body(k);
    if (j == kGround) return;
    eq::subtract_from(loads_->moment_b[at(j)], rotation(j) * eq::transpose_times(rotation(k), m));
  }
  void add_generalized_force(int i, double value) { Q_[i] += value; }

 private:
  const Model& model_;
  const State* state_;
  const Kinematics* kin_;
  Loads* loads_;
  const double* q_;
  const double* z_;
  double* Q_;
};

// The reduced mass or moment of a body against its lower body (or another), the ground counting
// as infinitely heavy.
double reduced(double of_k, double of_j, bool ground) {
  return ground ? of_k : of_k * of_j / (of_k + of_j);
}

double smallest_moment(const Model& model, int b) {
  return Eigen::SelfAdjointEigenSolver<Matrix3>(model.body(b).inertia, Eigen::EigenvaluesOnly)
      .eigenvalues()
      .minCoeff();
}

ForceElement::FileKey numbers(std::string key, const VectorX& v) {
  return {std::move(key), v, false, -2};
}
ForceElement::FileKey number(std::string key, double v) {
  return {std::move(key), VectorX::Constant(1, v), true, -2};
}

}  // namespace

std::string ForceElement::validate(const Model& /*model*/) const { return ""; }
double ForceElement::frequency_squared_estimate(const Model&) const { return 0.0; }
#define KANEDYN_DEFINE_NO_GENERIC_LAW(S) \
  void ForceElement::apply_generic(detail::TreeLoads<S>&) const {}
KANEDYN_FOR_EACH_TREE_SCALAR(KANEDYN_DEFINE_NO_GENERIC_LAW)
#undef KANEDYN_DEFINE_NO_GENERIC_LAW

// The built-in elements' laws for every scalar of KANEDYN_FOR_EACH_TREE_SCALAR: each hook runs
// the one template law; over double flattened, over the dual numbers compiled as the passes that
// call them are (KANEDYN_DUAL_ATTRIBUTES: AVX2 and baseline clones, flattened).
// A virtual function cannot be multiversioned (target_clones): each dual hook calls a free
// function that is.
#define KANEDYN_DEFINE_GENERIC_LAWS(Class)                                                   \
  namespace {                                                                                \
  KANEDYN_DUAL_ATTRIBUTES void Class##_law(const Class& e, detail::TreeLoads<Dual<8>>& l) {  \
    e.law(l);                                                                                \
  }                                                                                          \
  KANEDYN_DUAL_ATTRIBUTES void Class##_law(const Class& e, detail::TreeLoads<Dual<12>>& l) { \
    e.law(l);                                                                                \
  }                                                                                          \
  KANEDYN_DUAL_ATTRIBUTES void Class##_law(const Class& e, detail::TreeLoads<Dual<16>>& l) { \
    e.law(l);                                                                                \
  }                                                                                          \
  }                                                                                          \
  __attribute__((flatten)) void Class::apply_generic(detail::TreeLoads<double>& l) const {   \
    law(l);                                                                                  \
  }                                                                                          \
  void Class::apply_generic(detail::TreeLoads<Dual<8>>& l) const { Class##_law(*this, l); }  \
  void Class::apply_generic(detail::TreeLoads<Dual<12>>& l) const { Class##_law(*this, l); } \
  void Class::apply_generic(detail::TreeLoads<Dual<16>>& l) const { Class##_law(*this, l); }

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
template <typename L>
void JointLoad::law(L& loads) const {
  const Model& model = loads.model();
  const int o = model.coordinate_offset(body_), p = model.speed_offset(body_);
  for (int c = 0; c < static_cast<int>(value.size()); ++c)
    loads.add_generalized_force(p + c, value[c] -
                                           stiffness[c] * (loads.coordinate(o + c) - rest[c]) -
                                           damping[c] * loads.speed(p + c));
}
KANEDYN_DEFINE_GENERIC_LAWS(JointLoad)

void JointLoad::apply_joint(const Model& model, const VectorX& q, const VectorX& z,
                            Eigen::Ref<VectorX> Q) const {
  StateLoads loads(model, nullptr, nullptr, nullptr, q.data(), z.data(), Q.data());
  law(loads);
}

std::vector<ForceElement::FileEntry> JointLoad::file_entries() const {
  // A joint_spring and a joint_force are one element here: a spring that also carries a value
  // (made in code) is written as the two entries the model format has.
  const bool spring = !stiffness.isZero(0.0) || !damping.isZero(0.0) || !rest.isZero(0.0) ||
                      kind_ == "joint_spring";
  std::vector<FileEntry> entries;
  if (spring)
    entries.push_back(
        {"joint_spring",
         {numbers("stiffness", stiffness), numbers("damping", damping), numbers("rest", rest)}});
  if (!spring || !value.isZero(0.0)) entries.push_back({"joint_force", {numbers("value", value)}});
  return entries;
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

template <typename L>
void Bushing::law(L& loads) const {
  using S = typename L::Scalar;
  const Model& model = loads.model();
  const int k = body_;
  const int j = model.lower_body(k);
  const eq::Euler<S> rel = loads.relative_euler(k);  // K relative to J
  const eq::Mat3<S> R = eq::rotation_matrix(rel);    // body J -> body K components
  const eq::Vec3<S> f = eq::bushing_force(constant<S>(stiffness), constant<S>(damping),
                                          loads.translation(k), loads.translation_rate(k));  // J
  eq::Vec3<S> w_rel = loads.angular_velocity(k);
  if (j != kGround) w_rel = w_rel - R * loads.angular_velocity(j);
  const eq::Vec3<S> m = eq::bushing_moment(S(rotational_stiffness), S(rotational_damping),
                                           eq::rotation_vector(rel), w_rel);  // body K
  const eq::ForceAndMoment<S> on_k = eq::bushing_load_on_k(R, f, constant<S>(model.body(k).com));
  loads.add_force_at_com_lower(k, f, on_k.force);
  loads.add_moment(k, on_k.moment);  // (M' + arm x F) + M, as the kernel adds them
  loads.add_moment(k, m);
  if (j == kGround) return;
  loads.add_force_at_com_b(j, -f);
  // Arm from G_J to O_K in body J: q'_K + s'_K - r'_J.
  const eq::Vec3<S> arm =
      constant<S>(model.body(k).joint) + loads.translation(k) - constant<S>(model.body(j).com);
  loads.add_moment(j, eq::bushing_moment_on_j(R, f, m, arm));
}
KANEDYN_DEFINE_GENERIC_LAWS(Bushing)

void Bushing::apply(const Model& model, const State& state, const Kinematics& kin,
                    Loads& loads) const {
  StateLoads l(model, &state, &kin, &loads);
  law(l);
}

bool Bushing::dissipative() const { return !damping.isZero(0.0) || rotational_damping != 0.0; }

double Bushing::frequency_squared_estimate(const Model& model) const {
  // Its body against its lower body: translational with the reduced mass, rotational with the
  // reduced smallest principal moments about G.
  const int k = body_;
  const int j = model.lower_body(k);
  const bool ground = j == kGround;
  double omega2 =
      stiffness.maxCoeff() / reduced(model.body(k).mass, ground ? 0.0 : model.body(j).mass, ground);
  if (rotational_stiffness > 0.0)
    omega2 = std::max(
        omega2, rotational_stiffness / reduced(smallest_moment(model, k),
                                               ground ? 0.0 : smallest_moment(model, j), ground));
  return omega2 > 0.0 ? omega2 : 0.0;
}

std::optional<LinearBodyLoad> Bushing::linear_body_load() const {
  LinearBodyLoad l;
  l.stiffness = stiffness;
  l.damping = damping;
  l.rotational_stiffness = rotational_stiffness;
  l.rotational_damping = rotational_damping;
  return l;
}

std::vector<ForceElement::FileEntry> Bushing::file_entries() const {
  return {{"bushing",
           {numbers("stiffness", stiffness), numbers("damping", damping),
            number("rotational_stiffness", rotational_stiffness),
            number("rotational_damping", rotational_damping)}}};
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

template <typename L>
void ConstantForce::law(L& loads) const {
  loads.add_force_at_com(body_, constant<typename L::Scalar>(value));  // inertial
}
KANEDYN_DEFINE_GENERIC_LAWS(ConstantForce)

std::string ConstantForce::validate(const Model&) const {
  return value.allFinite() ? "" : "the value of a force must be finite";
}

void ConstantForce::apply(const Model& model, const State& state, const Kinematics& kin,
                          Loads& loads) const {
  StateLoads l(model, &state, &kin, &loads);
  law(l);
}

std::optional<LinearBodyLoad> ConstantForce::linear_body_load() const {
  LinearBodyLoad l;
  l.force = value;
  return l;
}

std::vector<ForceElement::FileEntry> ConstantForce::file_entries() const {
  return {{"force", {numbers("value", value)}}};
}

template <typename L>
void ConstantTorque::law(L& loads) const {
  loads.add_moment(body_, constant<typename L::Scalar>(value));  // body K
}
KANEDYN_DEFINE_GENERIC_LAWS(ConstantTorque)

std::string ConstantTorque::validate(const Model&) const {
  return value.allFinite() ? "" : "the value of a torque must be finite";
}

void ConstantTorque::apply(const Model& model, const State& state, const Kinematics& kin,
                           Loads& loads) const {
  StateLoads l(model, &state, &kin, &loads);
  law(l);
}

std::optional<LinearBodyLoad> ConstantTorque::linear_body_load() const {
  LinearBodyLoad l;
  l.moment = value;
  return l;
}

std::vector<ForceElement::FileEntry> ConstantTorque::file_entries() const {
  return {{"torque", {numbers("value", value)}}};
}

Spring::Spring(int body, Vector3 at_, int other, Vector3 other_at_, double k, double c, double l0)
    : at(std::move(at_)),
      other_at(std::move(other_at_)),
      stiffness(k),
      damping(c),
      rest_length(l0),
      body_(body),
      other_(other) {}

std::string Spring::validate(const Model& model) const {
  if (other_ != kGround && (other_ < 0 || other_ >= model.num_bodies()))
    return "spring: other body index " + std::to_string(other_) + " out of range";
  if (other_ == body_) return "a spring joins two different bodies, not a body to itself";
  if (!at.allFinite() || !other_at.allFinite() || !std::isfinite(stiffness) ||
      !std::isfinite(damping) || !std::isfinite(rest_length))
    return "spring parameters must be finite";
  if (stiffness < 0) return "spring stiffness must be >= 0";
  if (damping < 0) return "spring damping must be >= 0";
  if (rest_length < 0) return "spring rest_length must be >= 0";
  return "";
}

namespace {
std::string spring_name(const Model& model, int body, int other) {
  return "the spring between " + model.body(body).name + " and " +
         (other == kGround ? std::string("ground") : model.body(other).name);
}
}  // namespace

template <typename L>
void Spring::law(L& loads) const {
  using S = typename L::Scalar;
  const tree::PointMotion<S> p = loads.point(body_, at);
  const tree::PointMotion<S> p_other = loads.point(other_, other_at);
  const eq::Vec3<S> d = p_other.p - p.p;
  eq::Vec3<S> f;
  if (rest_length == 0.0 && damping == 0.0) {
    f = stiffness * d;  // k (L - 0) u = k d: defined at L = 0 too
  } else {
    const S length = tree::norm_of(d);
    if (!(tree::value_of(length) > 0.0))
      throw SpringLengthError(spring_name(loads.model(), body_, other_) +
                              " has zero length, where its direction is undefined");
    const eq::Vec3<S> u = (1.0 / length) * d;
    const S rate = eq::dot(u, p_other.v - p.v);  // dL/dt
    f = (stiffness * (length - rest_length) + damping * rate) * u;
  }
  loads.add_force(body_, at, f);
  loads.add_force(other_, other_at, -f);
}
KANEDYN_DEFINE_GENERIC_LAWS(Spring)

void Spring::apply(const Model& model, const State& state, const Kinematics& kin,
                   Loads& loads) const {
  StateLoads l(model, &state, &kin, &loads);
  law(l);
}

double Spring::potential_energy(const Model& model, const State& state,
                                const Kinematics& kin) const {
  const StateLoads l(model, &state, &kin, nullptr);
  const eq::Vec3<double> d = l.point(other_, other_at).p - l.point(body_, at).p;
  const double stretch = tree::norm_of(d) - rest_length;
  return 0.5 * stiffness * stretch * stretch;
}

double Spring::damping_power(const Model& model, const State& state, const Kinematics& kin) const {
  if (damping == 0.0) return 0.0;
  const StateLoads l(model, &state, &kin, nullptr);
  const tree::PointMotion<double> p = l.point(body_, at), p_other = l.point(other_, other_at);
  const eq::Vec3<double> d = p_other.p - p.p;
  const double length = tree::norm_of(d);
  if (!(length > 0.0)) return 0.0;
  const double rate = eq::dot(d, p_other.v - p.v) / length;
  return damping * rate * rate;
}

double Spring::frequency_squared_estimate(const Model& model) const {
  // The two bodies as point masses on the spring (a lone oscillator, as for a bushing).
  const bool ground = other_ == kGround;
  return stiffness /
         reduced(model.body(body_).mass, ground ? 0.0 : model.body(other_).mass, ground);
}

std::vector<ForceElement::FileEntry> Spring::file_entries() const {
  FileKey other{"other", VectorX(), false, other_};
  return {{"spring",
           {numbers("at", at), std::move(other), numbers("other_at", other_at),
            number("stiffness", stiffness), number("damping", damping),
            number("rest_length", rest_length)}}};
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
  StateLoads l(model, &state, &kin, &loads);
  detail::input_body_loads(model, u.data(), l);
}

void add_input_joint_forces(const Model& model, const VectorX& u, Eigen::Ref<VectorX> Q) {
  StateLoads l(model, nullptr, nullptr, nullptr, nullptr, nullptr, Q.data());
  detail::input_joint_forces(model, u.data(), l);
}

}  // namespace kanedyn
