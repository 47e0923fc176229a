// Dynamics: forward dynamics of any model at its state (q, z), and the derivative simulate()
// integrates. The route dispatch of the library is here and only here: the notes' kernels
// (forward_dynamics) for an all-free model, detail::JointDynamics for any other.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>

#include "kanedyn/constraints.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/simulate.hpp"

#include "joint_dynamics.hpp"

namespace kanedyn {

namespace {

void copy(const double* from, int count, double* to) {
  std::memcpy(to, from, sizeof(double) * static_cast<size_t>(count));
}

DataOptions notes_options(Route route, int max_simd_lanes) {
  DataOptions o = DataOptions::recursive_only(max_simd_lanes);
  o.kane_terms = route == Route::assembled;  // the assembled route's scratch, no dense [A]
  return o;
}

}  // namespace

struct Dynamics::Impl {
  Impl(const Model& m, Route r, int lanes)
      : model(m),
        route(r),
        notes(m.all_free() && m.num_constraints() == 0),
        n(m.num_bodies()),
        data(m, notes ? notes_options(r, lanes) : DataOptions::recursive_only(lanes)),
        work(m) {
    if (!notes) joint.emplace(m);
    if (!notes) drift_q = VectorX::Zero(m.num_coordinates());
    if (m.num_constraints() > 0) {
      constrained.emplace(m, r == Route::assembled ? ConstrainedDynamics::Method::projected
                                                   : ConstrainedDynamics::Method::multipliers);
      cq.resize(m.num_coordinates());
      cz.resize(m.num_speeds());
    }
  }

  const Model& model;
  Route route;
  bool notes;  ///< the notes' free tree: every joint free
  int n;
  // The notes' kernels: their workspace and the state they run at; whether data holds that
  // state's kinematics and loads (forward_dynamics leaves them in its private scratch).
  Data data;
  State work;
  bool loads_current = false;
  // Any other model.
  std::optional<detail::JointDynamics> joint;
  VectorX drift_q;  // project()'s copy of q when the Euler parameters are not projected
  // A model with constraints (docs/theory.md, "Constraints"): its own route over the tree's.
  std::optional<ConstrainedDynamics> constrained;
  std::optional<ConstraintEquations> projector;  // project()'s workspace
  VectorX cq, cz;
  double constraint_error = 0.0;  // the largest holonomic error project() found

  // The notes' state from q, z (an all-free model's slices are x, y body by body).
  void notes_state(const VectorX& q, const VectorX& z) {
    for (int k = 0; k < n; ++k) {
      work.euler_parameters(k) = q.segment<4>(7 * k);
      work.translation(k) = q.segment<3>(7 * k + 4);
      work.angular_velocity(k) = z.segment<3>(6 * k);
      work.translation_rate(k) = z.segment<3>(6 * k + 3);
    }
  }
};

Dynamics::Dynamics(const Model& model, Route route, int max_simd_lanes)
    : impl_(std::make_unique<Impl>(model, route, max_simd_lanes)) {}
Dynamics::~Dynamics() = default;

const Model& Dynamics::model() const { return impl_->model; }
Route Dynamics::route() const { return impl_->route; }

int Dynamics::simd_lanes() const {
  const Impl& s = *impl_;
  return s.notes && s.route == Route::recursive && s.data.single_pass() ? s.data.simd_lanes() : 0;
}

std::string Dynamics::kernel() const {
  const Impl& s = *impl_;
  if (s.notes) {
    if (s.route == Route::assembled) return "assembled [A] (Eqs. 37-38), tree LDL^T";
    if (const int lanes = simd_lanes(); lanes > 0)
      return "fused O(N) pass, " + std::to_string(lanes) + " bodies per SIMD pass";
    return "staged O(N) route";
  }
  if (s.constrained)
    return s.route == Route::assembled
               ? "projected Kane equations in the independent speeds (dense)"
               : "articulated-body recursion over the joints, multipliers in the constraint "
                 "space";
  return s.route == Route::assembled ? "projected Kane equations, tree LDL^T"
                                     : "articulated-body recursion over the joints";
}

void Dynamics::evaluate(const VectorX& q, const VectorX& z, Eigen::Ref<VectorX> zdot) {
  Impl& s = *impl_;
  if (s.constrained) {
    s.constrained->evaluate(q, z, s.joint->inputs(), zdot);
    return;
  }
  if (!s.notes) {
    s.joint->evaluate(q, z, s.route, zdot);
    return;
  }
  s.notes_state(q, z);
  forward_dynamics(s.model, s.work, s.data, s.route);
  s.loads_current = false;
  const int n = s.n;
  for (int k = 0; k < n; ++k) {  // Eq. (1)'s layout to z's, body by body
    zdot.segment<3>(6 * k) = s.data.ydot.segment<3>(3 * k);
    zdot.segment<3>(6 * k + 3) = s.data.ydot.segment<3>(3 * n + 3 * k);
  }
}

void Dynamics::evaluate(const VectorX& q, const VectorX& z, Eigen::Ref<VectorX> zdot,
                        Eigen::Ref<VectorX> qdot) {
  evaluate(q, z, zdot);
  Impl& s = *impl_;
  if (!s.notes) {
    joint_coordinate_rates(s.model, q, z, qdot);
    return;
  }
  const int n = s.n;
  for (int k = 0; k < n; ++k) {  // Eqs. (39)-(40) as forward_dynamics left them, in q's layout
    qdot.segment<4>(7 * k) = s.data.xdot.segment<4>(4 * k);
    qdot.segment<3>(7 * k + 4) = s.data.xdot.segment<3>(4 * n + 3 * k);
  }
}

void Dynamics::set_inputs(const VectorX& u) {
  Impl& s = *impl_;
  if (u.size() != s.model.num_inputs())
    throw std::invalid_argument("inputs: " + std::to_string(u.size()) + " values for " +
                                std::to_string(s.model.num_inputs()) +
                                (s.model.num_inputs() == 1 ? " input" : " inputs"));
  if (!s.notes) {
    s.joint->set_inputs(u);
    return;
  }
  s.data.inputs = u;
  s.loads_current = false;
}

const VectorX& Dynamics::inputs() const {
  const Impl& s = *impl_;
  return s.notes ? s.data.inputs : s.joint->inputs();
}

void Dynamics::forward(const VectorX& q, const VectorX& z, const VectorX& u,
                       Eigen::Ref<VectorX> zdot) {
  set_inputs(u);
  evaluate(q, z, zdot);
}

const State& Dynamics::state() {
  Impl& s = *impl_;
  return s.notes ? s.work : s.joint->state();
}

Data& Dynamics::data() {
  Impl& s = *impl_;
  if (!s.notes) return s.joint->data();
  if (!s.loads_current) {
    compute_kinematics(s.model, s.work, s.data);
    compute_resultants(s.model, s.work, s.data);
    s.loads_current = true;
  }
  return s.data;
}

std::string Dynamics::layout() const { return impl_->notes ? "({x}; {y}) of Eq. (1)" : "(q; z)"; }

int Dynamics::size() const {
  const Impl& s = *impl_;
  return s.notes ? 13 * s.n : s.model.num_coordinates() + s.model.num_speeds();
}

void Dynamics::pack(const VectorX& q, const VectorX& z, VectorX& v) const {
  const Impl& s = *impl_;
  if (!s.notes) {
    v << q, z;
    return;
  }
  State x(s.model);
  joint_state(s.model, q, z, x);
  v << x.x, x.y;
}

void Dynamics::unpack(const VectorX& v, bool normalize, VectorX& q, VectorX& z, State& state) {
  const Impl& s = *impl_;
  if (s.notes) {
    state.x = v.head(7 * s.n);
    state.y = v.tail(6 * s.n);
    if (normalize) state.normalize_euler_parameters();
    joint_coordinates(s.model, state, q, z);
    return;
  }
  const int nq = s.model.num_coordinates();
  q = v.head(nq);
  z = v.tail(v.size() - nq);
  if (normalize) normalize_joint_coordinates(s.model, q);
  joint_state(s.model, q, z, state);
}

// The stages of a step lie slightly off |e| = 1; the equations are evaluated at the normalized
// Euler parameters, so every [R_K] is a rotation and both routes see the same state.
// {eps dot} = 1/2 [Ebar'(eps/|eps|)]^T {w'} is orthogonal to eps, so this field keeps |eps_K|
// constant just as Eq. (39) does, and equals it on the constraint. For the notes' kernels this
// runs six times a step: the copies go through memcpy (glibc's, as wide as the CPU allows);
// with Eigen's portable SSE2 loops they took as many instructions as the normalization.
void Dynamics::derivative(const VectorX& v, VectorX& dv) {
  Impl& s = *impl_;
  if (s.constrained) {
    const int nq = s.model.num_coordinates();
    s.cq = v.head(nq);
    s.cz = v.tail(v.size() - nq);
    normalize_joint_coordinates(s.model, s.cq);
    joint_coordinate_rates(s.model, s.cq, s.cz, dv.head(nq));
    s.constrained->evaluate(s.cq, s.cz, s.joint->inputs(), dv.tail(v.size() - nq));
    return;
  }
  if (!s.notes) {
    s.joint->derivative(v, s.route, dv);
    return;
  }
  const int n = s.n;
  copy(v.data(), 7 * n, s.work.x.data());
  copy(v.data() + 7 * n, 6 * n, s.work.y.data());
  for (int k = 0; k < n; ++k) s.work.euler_parameters(k).normalize();
  forward_dynamics(s.model, s.work, s.data, s.route);
  s.loads_current = false;
  copy(s.data.xdot.data(), 7 * n, dv.data());
  copy(s.data.ydot.data(), 6 * n, dv.data() + 7 * n);
}

double Dynamics::project(VectorX& v, bool apply) {
  Impl& s = *impl_;
  if (s.constrained) {
    // The constraints are kept by projection whatever `apply` says about the Euler
    // parameters: their drift would otherwise grow without bound.
    const int nq = s.model.num_coordinates();
    s.cq = v.head(nq);
    s.cz = v.tail(v.size() - nq);
    // The drift before the projection, which normalizes again (a no-op on unit parameters).
    const double drift = normalize_joint_coordinates(s.model, s.cq);
    if (!s.projector) s.projector.emplace(s.model);
    const Projection p = project_onto_constraints(*s.projector, s.cq, s.cz);
    s.constraint_error = std::max(s.constraint_error, p.error_before);
    v.head(nq) = s.cq;
    v.tail(v.size() - nq) = s.cz;
    return drift;
  }
  if (!s.notes) {
    auto q = v.head(s.model.num_coordinates());
    if (apply) return normalize_joint_coordinates(s.model, q);
    s.drift_q = q;  // the drift alone: normalize a copy (sized once, no allocation)
    return normalize_joint_coordinates(s.model, s.drift_q);
  }
  double drift = 0.0;
  for (int k = 0; k < s.n; ++k) {
    auto e = v.segment<4>(4 * k);
    const double norm = e.norm();
    drift = std::max(drift, std::abs(norm - 1.0));
    if (apply) e /= norm;
  }
  return drift;
}

double Dynamics::constraint_error() const { return impl_->constraint_error; }

const VectorX& Dynamics::constraint_multipliers() const {
  static const VectorX none;
  return impl_->constrained ? impl_->constrained->lambda() : none;
}

const ConstraintEquations* Dynamics::constraint_equations() const {
  return impl_->constrained ? &impl_->constrained->equations() : nullptr;
}

std::string Dynamics::describe(int component, int* body) const {
  const Impl& s = *impl_;
  return s.notes ? describe_state_component(s.model, component, body)
                 : describe_joint_state_component(s.model, component, body);
}

}  // namespace kanedyn
