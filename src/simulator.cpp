#include "kanedyn/simulator.hpp"

#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

#include "kanedyn/constraints.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/integrate.hpp"
#include "kanedyn/joints.hpp"

namespace kanedyn {

namespace {

std::string format_time(double t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", t);
  return buf;
}

/// The first component beyond kStateBound or not finite, else -1: simulate()'s test of an
/// accepted step.
int first_diverged(const VectorX& v) {
  if ((v.array().abs() <= kStateBound).all()) return -1;
  for (Eigen::Index i = 0; i < v.size(); ++i)
    if (!(std::abs(v[i]) <= kStateBound)) return static_cast<int>(i);
  return -1;
}

}  // namespace

struct Simulator::Impl {
  Impl(const Model& m, const SimulationSettings& s)
      : model(m),
        dynamics(m, s.route),
        v(VectorX::Zero(dynamics.size())),
        v_prev(v),
        q(VectorX::Zero(m.num_coordinates())),
        z(VectorX::Zero(m.num_speeds())),
        state(m) {
    // The integrated field with the inputs dynamics holds (set_inputs before each step).
    OdeFunction f = [this](double, const VectorX& x, VectorX& dx) { dynamics.derivative(x, dx); };
    if (s.integrator == Integrator::rk4) {
      rk4.emplace(dynamics.size(), f);
    } else {
      Dopri5Options opt;
      opt.rtol = s.rtol;
      opt.atol = s.atol;
      opt.max_step = s.max_step;
      dopri5.emplace(dynamics.size(), f, opt);
    }
  }

  const Model& model;
  Dynamics dynamics;
  VectorX v, v_prev;  ///< the integrated (q; z) or ({x}; {y}), and its value before a step
  std::optional<Rk4> rk4;
  std::optional<Dopri5> dopri5;
  // The model's state of v, unpacked on request.
  VectorX q, z;
  State state;
  bool unpacked = false;
};

Simulator::Simulator(const Model& model, const VectorX& q0, const VectorX& z0,
                     const SimulationSettings& settings)
    : settings_(settings), t_(settings.t_start), u_(VectorX::Zero(model.num_inputs())) {
  validate_settings(model, settings_);
  if (settings_.inputs || settings_.controller)
    throw std::invalid_argument(
        "Simulator: the inputs come with each step(u, dt); give no input table or controller");
  impl_ = std::make_unique<Impl>(model, settings_);
  set_state(q0, z0, settings_.t_start);
}

Simulator::~Simulator() = default;

const Model& Simulator::model() const { return impl_->model; }

void Simulator::set_state(const VectorX& q, const VectorX& z, double t) {
  const Model& model = impl_->model;
  if (q.size() != model.num_coordinates() || z.size() != model.num_speeds())
    throw std::invalid_argument("Simulator: the state (q, z) does not have the model's sizes (" +
                                std::to_string(model.num_coordinates()) + " + " +
                                std::to_string(model.num_speeds()) + ")");
  if (!std::isfinite(t)) throw std::invalid_argument("Simulator: the time must be finite");
  VectorX normalized = q;
  normalize_joint_coordinates(model, normalized);
  VectorX v(impl_->v.size());
  impl_->dynamics.pack(normalized, z, v);
  if (const int i = first_diverged(v); i >= 0)
    throw std::invalid_argument("Simulator: the state at t = " + format_time(t) + " has " +
                                impl_->dynamics.describe(i) + " = " + std::to_string(v[i]) +
                                ", not finite or beyond 1e150");
  impl_->v = v;
  impl_->unpacked = false;
  t_ = t;
}

void Simulator::fail(const char* what, int component, double t_from, double t_to,
                     const std::string& detail) {
  impl_->v = impl_->v_prev;
  impl_->unpacked = false;
  throw std::runtime_error(std::string(what) + " in the step from t = " + format_time(t_from) +
                           " to t = " + format_time(t_to) +
                           (component >= 0 ? ": " + impl_->dynamics.describe(component) : "") +
                           detail + "; the simulator is left at t = " + format_time(t_from));
}

void Simulator::step(Eigen::Ref<const VectorX> u, double dt) {
  Impl& s = *impl_;
  if (u.size() != u_.size())
    throw std::invalid_argument("Simulator::step: u has " + std::to_string(u.size()) +
                                " values for the model's " + std::to_string(u_.size()) +
                                (u_.size() == 1 ? " input" : " inputs"));
  if (!u.allFinite()) throw std::invalid_argument("Simulator::step: a value of u is not finite");
  const double t_end = t_ + dt;
  if (!(std::isfinite(dt) && dt > 0.0 && t_end > t_))
    throw std::invalid_argument("Simulator::step: dt = " + std::to_string(dt) +
                                " must be finite, > 0 and advance t = " + format_time(t_));
  u_ = u;
  s.dynamics.set_inputs(u_);
  s.v_prev = s.v;
  s.unpacked = false;
  const bool project = settings_.project_euler_parameters;
  // A projection that fails names the time it failed at.
  const auto project_at = [&](VectorX& v, double t) {
    try {
      return s.dynamics.project(v, project);
    } catch (const ConstraintError& e) {
      throw ConstraintError("at t = " + format_time(t) + ": " + e.what());
    }
  };
  if (s.rk4) {
    const long before = s.rk4->evaluations();
    s.rk4->step(t_, dt, s.v);
    evaluations_ += s.rk4->evaluations() - before;
    if (const int i = first_diverged(s.v); i >= 0)
      fail("diverged", i, t_, t_end,
           std::isfinite(s.v[i]) ? " exceeds 1e150 (the first such component in state order)"
                                 : " is not finite (the first such component in state order)");
    max_euler_drift_ = std::max(max_euler_drift_, project_at(s.v, t_end));
    ++steps_;
    t_ = t_end;
    return;
  }
  Dopri5& dp = *s.dopri5;
  // A restart at t: the first stage is evaluated with the new inputs (the field may jump at t).
  const StepStatus started = dp.start(t_, s.v, t_end);
  evaluations_ += dp.evaluations();
  if (started != StepStatus::ok)
    fail("non-finite derivative", dp.failed_component(), t_, t_end, " is not finite");
  long counted = dp.evaluations();
  while (dp.time() < t_end) {
    const double t_old = dp.time();
    const StepStatus status = dp.step();
    evaluations_ += dp.evaluations() - counted;
    counted = dp.evaluations();
    if (status == StepStatus::non_finite)
      fail("non-finite state", dp.failed_component(), t_old, t_end,
           " is not finite (steps down to the smallest allowed failed too)");
    if (status == StepStatus::step_underflow) {
      char buf[96];
      std::snprintf(buf, sizeof buf,
                    " has the largest error (no step above %.3g meets the "
                    "tolerances)",
                    dp.min_step());
      fail("step size underflow", dp.failed_component(), t_old, t_end, buf);
    }
    if (const int i = first_diverged(dp.state()); i >= 0)
      fail("diverged", i, t_old, dp.time(),
           std::isfinite(dp.state()[i]) ? " exceeds 1e150" : " is not finite");
    max_euler_drift_ = std::max(max_euler_drift_, project_at(dp.mutable_state(), dp.time()));
    ++steps_;
    // A long interval is many steps: the caller may stop it between them (on a signal), and
    // then nothing of it is kept.
    if (settings_.on_step && dp.time() < t_end && !settings_.on_step(dp.time()))
      fail("interrupted", -1, t_, t_end, " (on_step asked to stop)");
  }
  s.v = dp.state();
  t_ = t_end;
}

void Simulator::unpack() const {
  if (impl_->unpacked) return;
  // As simulate() gives a state to its observer.
  impl_->dynamics.unpack(impl_->v, settings_.project_euler_parameters, impl_->q, impl_->z,
                         impl_->state);
  impl_->unpacked = true;
}

const VectorX& Simulator::q() const {
  unpack();
  return impl_->q;
}

const VectorX& Simulator::z() const {
  unpack();
  return impl_->z;
}

const State& Simulator::state() const {
  unpack();
  return impl_->state;
}

}  // namespace kanedyn
