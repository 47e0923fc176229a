#include "kanedyn/simulate.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "kanedyn/constraints.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"

namespace kanedyn {

std::string to_string(SimulationStatus status) {
  switch (status) {
    case SimulationStatus::completed:
      return "completed";
    case SimulationStatus::interrupted:
      return "interrupted";
    case SimulationStatus::non_finite:
      return "non-finite state";
    case SimulationStatus::step_underflow:
      return "step size underflow";
    case SimulationStatus::controller_error:
      return "controller error";
  }
  return "unknown";
}

double SimulationStats::relative_energy_change() const {
  return energy_scale > 0.0 ? energy_change() / energy_scale
                            : std::numeric_limits<double>::quiet_NaN();
}

std::string describe_state_component(const Model& model, int component, int* body) {
  const int n = model.num_bodies();
  // Parts of z = ({x}; {y}) in order: eps (4 per body), s', w', s' dot (3 per body).
  static const char* const kColumns[4][4] = {
      {"e1", "e2", "e3", "e4"}, {"s1", "s2", "s3"}, {"w1", "w2", "w3"}, {"sd1", "sd2", "sd3"}};
  const int offsets[5] = {0, 4 * n, 7 * n, 10 * n, 13 * n};
  int k = -1;
  const char* column = "";
  for (int part = 0; part < 4; ++part)
    if (component >= offsets[part] && component < offsets[part + 1]) {
      const int width = part == 0 ? 4 : 3;
      k = (component - offsets[part]) / width;
      column = kColumns[part][(component - offsets[part]) % width];
    }
  if (body) *body = k;
  if (k < 0) return "no body";
  std::string text = "body '";
  text.append(model.body(k).name).append("' (").append(column).append(")");
  return text;
}

std::string joint_state_column(const Model& model, int component, int* body) {
  // (q; z) body by body: a free body's q is (eps_K, s'_K) and z (w'_K, s'_K dot), the notes'
  // columns; the other joints' are j1.. and jd1...
  static const char* const kFreeQ[7] = {"e1", "e2", "e3", "e4", "s1", "s2", "s3"};
  static const char* const kFreeZ[6] = {"w1", "w2", "w3", "sd1", "sd2", "sd3"};
  const int n = model.num_bodies(), nq = model.num_coordinates();
  int k = -1;
  std::string column;
  const bool speed = component >= nq;
  const int i = speed ? component - nq : component;
  for (int b = 0; b < n && component >= 0; ++b) {
    const int begin = speed ? model.speed_offset(b) : model.coordinate_offset(b);
    const int end = speed ? model.speed_offset(b + 1) : model.coordinate_offset(b + 1);
    if (i < begin || i >= end) continue;
    k = b;
    const int r = i - begin;
    if (model.joint(b).type == JointType::free)
      column = speed ? kFreeZ[r] : kFreeQ[r];
    else
      column = (speed ? "jd" : "j") + std::to_string(r + 1);
  }
  if (body) *body = k;
  return column;
}

std::string describe_joint_state_component(const Model& model, int component, int* body) {
  int k = -1;
  const std::string column = joint_state_column(model, component, &k);
  if (body) *body = k;
  if (k < 0) return "no body";
  return "body '" + model.body(k).name + "' (" + column + ")";
}

namespace {

std::string format_time(double t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", t);
  return buf;
}

std::string format_g(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

constexpr double kTimeEpsilon = std::numeric_limits<double>::epsilon();
constexpr double kMaxOutputTimes = 1e12;
constexpr double kMaxSteps = 1e15;
constexpr double kRk4StabilityBound = 2.8284271247461903;  // 2 sqrt(2)
/// Output rows written between two calls of on_step when one step spans many output times.
constexpr long kRowsBetweenPolls = 64;
/// A rolling disc's normal force counts as negative below -kLiftTolerance times the size of
/// the forces at play: the multipliers carry round-off of about 1e-15 of them.
constexpr double kLiftTolerance = 1e-9;

/// Index of the first component of z that is not finite or exceeds kStateBound, else -1.
/// One comparison per component: !(|z_i| <= bound) also catches NaN.
int first_diverged(const VectorX& z) {
  if ((z.array().abs() <= kStateBound).all()) return -1;
  for (Eigen::Index i = 0; i < z.size(); ++i)
    if (!(std::abs(z[i]) <= kStateBound)) return static_cast<int>(i);
  return -1;
}

}  // namespace

void validate_settings(const SimulationSettings& s) {
  if (!std::isfinite(s.t_start) || !std::isfinite(s.t_end) || s.t_end < s.t_start)
    throw std::invalid_argument("simulate: need finite t_start <= t_end");
  if (!std::isfinite(s.dt_out) || s.dt_out <= 0.0)
    throw std::invalid_argument("simulate: dt_out must be > 0");
  const double span = s.t_end - s.t_start;
  // Times are doubles: a step or output interval below a few ulp of the largest time would
  // repeat times (t + h == t) instead of advancing.
  const double resolution = 4.0 * kTimeEpsilon * std::max(std::abs(s.t_start), std::abs(s.t_end));
  if (span / s.dt_out > kMaxOutputTimes)
    throw std::invalid_argument("simulate: dt_out = " + format_g(s.dt_out) + " gives " +
                                format_g(span / s.dt_out) +
                                " output times from t = " + format_time(s.t_start) + " to " +
                                format_time(s.t_end) + "; at most " + format_g(kMaxOutputTimes) +
                                " are allowed (that many rows would fill any disk)");
  if (span > 0.0 && s.dt_out < resolution)
    throw std::invalid_argument("simulate: dt_out = " + format_g(s.dt_out) +
                                " is below the resolution of the times (" + format_g(resolution) +
                                " at t = " + format_time(s.t_end) + ")");
  if (s.integrator == Integrator::rk4) {
    if (!(std::isfinite(s.step) && s.step > 0.0))
      throw std::invalid_argument("simulate: the rk4 step must be > 0");
    if (std::min(span, s.dt_out) / s.step > kMaxSteps || (span > 0.0 && s.step < resolution))
      throw std::invalid_argument(
          "simulate: the rk4 step " + format_g(s.step) + " cannot be honoured: " +
          (s.step < resolution
               ? "it is below the resolution of the times (" + format_g(resolution) + ")"
               : "the run would take over " + format_g(kMaxSteps) + " steps"));
  }
  if (s.integrator == Integrator::dopri5 &&
      (!(s.rtol >= 0.0) || !(s.atol >= 0.0) || s.rtol + s.atol <= 0.0 || !std::isfinite(s.rtol) ||
       !std::isfinite(s.atol)))
    throw std::invalid_argument("simulate: rtol and atol must be >= 0 and not both 0");
  if (!(s.max_step > 0.0)) throw std::invalid_argument("simulate: max_step must be > 0");
  if (s.inputs && s.controller)
    throw std::invalid_argument("simulate: give an input table or a controller, not both");
  if (!(std::isfinite(s.control_interval) && s.control_interval >= 0.0))
    throw std::invalid_argument("simulate: control_interval must be finite and >= 0");
  if (s.control_interval > 0.0 && (s.t_end - s.t_start) / s.control_interval > kMaxOutputTimes)
    throw std::invalid_argument("simulate: control_interval = " + format_g(s.control_interval) +
                                " gives more than " + format_g(kMaxOutputTimes) +
                                " control instants");
}

void validate_settings(const Model& model, const SimulationSettings& s) {
  validate_settings(s);
  if (s.inputs && s.inputs->num_inputs() != model.num_inputs())
    throw std::invalid_argument("simulate: the input table has " +
                                std::to_string(s.inputs->num_inputs()) + " columns of values for " +
                                std::to_string(model.num_inputs()) +
                                (model.num_inputs() == 1 ? " input" : " inputs"));
  if (s.route == Route::assembled && !model.has_flat_chains())
    throw std::invalid_argument(
        "simulate: the model's " + std::to_string(model.num_bodies()) + " bodies have " +
        std::to_string(model.chain_entries()) +
        " chain entries (the sum of u_K + 1), more than the " +
        std::to_string(Model::kMaxFlatChainEntries) +
        " for which the assembled route's blocks of [A] are built; use the recursive route, "
        "O(N), which has no such limit");
}

double rk4_step_limit(const Model& model, int* force_index) {
  // Along the imaginary axis RK4 is stable for h omega <= 2 sqrt(2) ~ 2.83. Each element gives
  // its own estimate of omega (ForceElement::frequency_squared_estimate: a bushing or spring
  // taken as a lone oscillator of its bodies); a tree's highest mode can be somewhat faster,
  // so this is an estimate.
  double limit = std::numeric_limits<double>::infinity();
  if (force_index) *force_index = -1;
  const auto& forces = model.forces();
  for (size_t i = 0; i < forces.size(); ++i) {
    const double omega2 = forces[i]->frequency_squared_estimate(model);
    if (!(omega2 > 0.0)) continue;
    const double h = kRk4StabilityBound / std::sqrt(omega2);
    if (h < limit) {
      limit = h;
      if (force_index) *force_index = static_cast<int>(i);
    }
  }
  return limit;
}

long rk4_substeps(double span, double step) {
  // validate_settings keeps span / step far below the range of long.
  return std::max(1L, static_cast<long>(std::ceil(span / step - 1e-9)));
}

namespace {

/// Everything one run needs, allocated once.
class Run {
 public:
  Run(const Model& model, const VectorX& q0, const VectorX& z0, const SimulationSettings& settings,
      const Observer& observer)
      : model_(model),
        s_(settings),
        observer_(observer),
        dynamics_(model, settings.route),
        size_(dynamics_.size()),
        q_(q0),
        z_state_(z0),
        data_(model, DataOptions::recursive_only()),
        work_(model),
        out_state_(model),
        z_(VectorX::Zero(size_)),
        z_out_(VectorX::Zero(size_)),
        z_prev_(VectorX::Zero(size_)),
        u_(VectorX::Zero(model.num_inputs())),
        u_out_(u_),
        cq_(VectorX::Zero(model.num_coordinates())),
        cz_(VectorX::Zero(model.num_speeds())) {
    stats_.t_reached = settings.t_start;
    if (settings.inputs) {
      drive_ = Drive::table;
      segment_ = settings.inputs->segment(settings.t_start);
      settings.inputs->value(settings.t_start, segment_, u_);
      dynamics_.set_inputs(u_);
    } else if (settings.controller) {
      drive_ = settings.control_interval > 0.0 ? Drive::interval : Drive::every_evaluation;
    }
    normalize_joint_coordinates(model, q_);
    const bool finite = q_.allFinite() && z0.allFinite();
    VectorX z_start = z0;
    // With constraints the run starts on them (load_model_file has projected a file's state
    // already, and reported the change).
    if (finite && model.num_constraints() > 0) project_onto_constraints(model, q_, z_start);
    dynamics_.pack(q_, z_start, z_);
    z_state_ = z_start;
    if (finite) joint_state(model, q_, z_state_, work_);
    stats_.energy_initial =
        finite ? energy_of(work_, q_) : std::numeric_limits<double>::quiet_NaN();
    if (model.num_constraints() > 0) {
      reactions_ = std::make_unique<ConstrainedDynamics>(model);
      zdot_out_ = VectorX::Zero(model.num_speeds());
      stats_.normal_force_negative_at.assign(static_cast<size_t>(model.num_constraints()),
                                             std::numeric_limits<double>::quiet_NaN());
    }
  }

  SimulationStats run() {
    const auto clock_start = std::chrono::steady_clock::now();
    if (check_state(z_, s_.t_start, s_.t_start)) {
      if (!std::isfinite(stats_.energy_initial))
        fail_energy(s_.t_start, stats_.energy_initial);
      else
        integrate_naming_the_time();
    }
    final_energy();
    // A run that ends with a finite state but a non-finite energy (the potential of a huge
    // gravity, say) has not produced a usable result either.
    if (stats_.ok() && !std::isfinite(stats_.energy_final))
      fail_energy(stats_.t_reached, stats_.energy_final);
    stats_.energy_scale = energy_scale();
    stats_.wall_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
    return stats_;
  }

 private:
  /// integrate(), a constraint's failure in an evaluation (its rows undefined at a state the
  /// run reached) or a spring's (its direction undefined) naming the time after which it
  /// happened; a projection's names its own.
  void integrate_naming_the_time() {
    try {
      integrate();
    } catch (const ConstraintError& e) {
      if (std::string_view(e.what()).starts_with("at t = ")) throw;
      throw ConstraintError("after t = " + format_time(stats_.t_reached) + ": " + e.what());
    } catch (const SpringLengthError& e) {
      throw SpringLengthError("after t = " + format_time(stats_.t_reached) + ": " + e.what());
    }
  }

  /// The total energy at the notes' state of q (with the joint springs' potentials of q).
  double energy_of(const State& state, const VectorX& q) {
    compute_kinematics(model_, state, data_);
    note_energies(state, q);
    return total_energy_of_kinematics(model_, state, q, data_);
  }

  /// The kinetic and potential energies of a state whose kinematics data_ holds, into the
  /// extremes energy_scale is made of.
  void note_energies(const State& state, const VectorX& q) {
    const double t = kinetic_energy_of_kinematics(model_, state, data_);
    const double v = potential_energy_of_kinematics(model_, state, q, data_);
    if (!std::isfinite(t) || !std::isfinite(v)) return;
    kinetic_max_ = std::max(kinetic_max_, t);
    potential_min_ = std::min(potential_min_, v);
    potential_max_ = std::max(potential_max_, v);
  }

  /// The largest kinetic energy or swing of the potential energy seen, when it stands above
  /// the round-off of the energies themselves, else 0 (docs/simulation.md).
  double energy_scale() const {
    if (potential_min_ > potential_max_) return 0.0;  // no finite energy seen
    const double swing = std::max(kinetic_max_, potential_max_ - potential_min_);
    const double size =
        std::max({kinetic_max_, std::abs(potential_min_), std::abs(potential_max_)});
    return swing > kEnergyScaleFloor * size ? swing : 0.0;
  }

  OdeFunction ode() {
    if (drive_ == Drive::none || drive_ == Drive::interval ||
        (drive_ == Drive::table && s_.inputs->hold() == InputHold::zero_order))
      return [this](double, const VectorX& v, VectorX& dv) { dynamics_.derivative(v, dv); };
    return [this](double t, const VectorX& v, VectorX& dv) {
      if (drive_ == Drive::table) {
        s_.inputs->value(t, segment_, u_);
      } else {
        joint_coordinates_of(v);
        control(t, cq_, cz_, u_);
      }
      dynamics_.set_inputs(u_);
      dynamics_.derivative(v, dv);
    };
  }
  /// The model's (q, z) of the integrated v into cq_, cz_: (q; z) itself, or for an all-free
  /// model the notes' ({x}; {y}) of Eq. (1) body by body.
  void joint_coordinates_of(const VectorX& v) {
    if (!model_.all_free()) {
      cq_ = v.head(cq_.size());
      cz_ = v.tail(cz_.size());
      return;
    }
    const int n = model_.num_bodies();
    for (int k = 0; k < n; ++k) {
      cq_.segment<4>(7 * k) = v.segment<4>(4 * k);
      cq_.segment<3>(7 * k + 4) = v.segment<3>(4 * n + 3 * k);
      cz_.segment<3>(6 * k) = v.segment<3>(7 * n + 3 * k);
      cz_.segment<3>(6 * k + 3) = v.segment<3>(10 * n + 3 * k);
    }
  }
  /// The controller's values at (t, q, z) into u (holding its last values); its exception, or a
  /// value that is not finite, becomes a ControllerFailure.
  void control(double t, const VectorX& q, const VectorX& z, VectorX& u) {
    try {
      s_.controller(t, q, z, u);
    } catch (const std::exception& e) {
      throw ControllerFailure{t, e.what()};
    } catch (...) {
      throw ControllerFailure{t, "an exception that is not a std::exception"};
    }
    if (!u.allFinite()) throw ControllerFailure{t, "it set a value that is not finite"};
  }
  /// The end of the segment being integrated: the next row time of the table or control
  /// instant, or t_end. Integrators never step across it.
  double segment_end() const {
    double end = s_.t_end;
    if (drive_ == Drive::table) {
      const auto& times = s_.inputs->times();
      const auto next = static_cast<size_t>(segment_ + 1);
      if (next < times.size()) end = std::min(end, times[next]);
    } else if (drive_ == Drive::interval) {
      end = std::min(end, control_time(control_index_ + 1));
    }
    return end;
  }
  double control_time(long i) const {
    return s_.t_start + static_cast<double>(i) * s_.control_interval;
  }
  /// At a segment's end t before t_end, with v the state there: the next row's values, or the
  /// controller's at this instant.
  void cross(double t, const VectorX& v) {
    if (drive_ == Drive::table) {
      segment_ = s_.inputs->segment(t);
      s_.inputs->value(t, segment_, u_);
    } else if (drive_ == Drive::interval) {
      while (control_time(control_index_ + 1) <= t) ++control_index_;
      joint_coordinates_of(v);
      control(t, cq_, cz_, u_);
    }
    dynamics_.set_inputs(u_);
  }
  /// The inputs in force at an output time t (at the state q_, z_state_ of the output).
  void output_inputs(double t) {
    if (drive_ == Drive::table) {
      s_.inputs->value(t, u_out_);
    } else if (drive_ == Drive::every_evaluation) {
      u_out_ = u_;
      control(t, q_, z_state_, u_out_);
    } else {
      u_out_ = u_;
    }
    data_.inputs = u_out_;
  }
  /// Runs the integrator; a controller's failure ends the run with the state of the last
  /// accepted step.
  void integrate() {
    z_prev_ = z_;
    try {
      if (drive_ == Drive::interval) {
        joint_coordinates_of(z_);
        control(s_.t_start, cq_, cz_, u_);
        dynamics_.set_inputs(u_);
      }
      if (s_.integrator == Integrator::rk4)
        run_rk4();
      else
        run_dopri5();
    } catch (const ControllerFailure& f) {
      if (s_.integrator == Integrator::rk4) z_ = z_prev_;
      stats_.status = SimulationStatus::controller_error;
      stats_.message = "the controller failed at t = " + format_time(f.t) + ": " + f.what;
    }
  }

  /// Projects the state of time t; a projection that fails names that time.
  double project(VectorX& v, double t) {
    try {
      return dynamics_.project(v, s_.project_euler_parameters);
    } catch (const ConstraintError& e) {
      throw ConstraintError("at t = " + format_time(t) + ": " + e.what());
    }
  }
  /// Output time i: t_start + i dt_out, snapped to t_end at the end.
  double output_time(long i) const {
    const double t = s_.t_start + static_cast<double>(i) * s_.dt_out;
    return t > s_.t_end - 1e-9 * s_.dt_out ? s_.t_end : t;
  }
  bool outputs_done() const { return done_outputs_; }

  void emit(double t, const VectorX& z) {
    // With constraints every output state is evaluated, observer or not: the lift of a
    // rolling disc is reported in the stats. The energies that make energy_scale are taken at
    // the output times too, but at most once per integration step: many output times in one
    // step would cost a kinematics pass each and add nothing the step's error has not.
    const bool constrained = model_.num_constraints() > 0;
    const bool sample = stats_.steps_accepted != energy_step_;
    if (observer_ || constrained || sample) {
      dynamics_.unpack(z, s_.project_euler_parameters, q_, z_state_, out_state_);
      if (constrained) {
        // Dense output between steps lies off the constraints by the interpolation's error:
        // the output is the state projected onto them, as the steps are.
        if (!projector_) projector_.emplace(model_);
        try {
          project_onto_constraints(*projector_, q_, z_state_);
        } catch (const ConstraintError& e) {
          throw ConstraintError("at t = " + format_time(t) + ": " + e.what());
        }
        joint_state(model_, q_, z_state_, out_state_);
      }
      if (sample || (observer_ && s_.observer_kinematics))
        compute_kinematics(model_, out_state_, data_);
      if (sample) {
        note_energies(out_state_, q_);
        energy_step_ = stats_.steps_accepted;
      }
      if (drive_ != Drive::none && (observer_ || constrained)) output_inputs(t);
      if (constrained) output_reactions(t);
      if (observer_) observer_(t, out_state_, q_, z_state_, data_);
    }
    ++stats_.outputs;
    if (t >= s_.t_end) done_outputs_ = true;
    ++next_output_;
  }

  /// The reactions at the output state (q_, z_state_, with the inputs in force at t) into
  /// data_.reactions, and the first time a rolling disc's normal force is negative. They are
  /// computed here, once per output, and not by the writers: the output state is the projected
  /// one, which no evaluation of the integrator has seen, the run must know of a lift to report
  /// it, and every observer (the CSV writers, a sweep's reducer, Python) gets the same numbers.
  void output_reactions(double t) {
    const VectorX& u = drive_ != Drive::none ? u_out_ : u_;
    reactions_->evaluate(q_, z_state_, u, zdot_out_);
    constraint_reactions(reactions_->equations(), reactions_->lambda(), data_.reactions);
    Eigen::Index column = 0;
    for (int k = 0; k < model_.num_constraints(); ++k) {
      const Constraint& c = model_.constraints()[static_cast<size_t>(k)];
      const Vector3 f = data_.reactions.segment<3>(column);
      column += reaction_count(c.type);
      double& lifted = stats_.normal_force_negative_at[static_cast<size_t>(k)];
      if (c.type != ConstraintType::rolling_disc || !std::isnan(lifted)) continue;
      // Negative beyond round-off of the forces at play (the reaction and the disc's weight),
      // so that a disc pressed by nothing (no gravity along n) does not count as lifting.
      const double scale = f.norm() + model_.body(c.body).mass * model_.gravity().norm();
      if (c.plane_normal.dot(f) < -kLiftTolerance * scale) lifted = t;
    }
  }

  void step_done(double t, double drift) {
    ++stats_.steps_accepted;
    stats_.t_reached = t;
    stats_.max_euler_drift = std::max(stats_.max_euler_drift, drift);
    stats_.max_constraint_error = dynamics_.constraint_error();
  }
  bool keep_going(double t) { return !s_.on_step || s_.on_step(t); }

  void interrupted(double t) {
    stats_.status = SimulationStatus::interrupted;
    stats_.message = "interrupted at t = " + format_time(t);
  }

  void fail_energy(double t, double energy) {
    stats_.status = SimulationStatus::non_finite;
    stats_.message = "non-finite energy (" + format_g(energy) + ") at t = " + format_time(t) +
                     ", with a finite state: a force or potential overflows";
  }

  /// Emits every output time up to t (z_ is the state at t; earlier ones come from dense
  /// output when `dense` is set). Many output times can fall in one step (a tiny dt_out):
  /// on_step is asked between them too, so that a signal stops the run within a few rows.
  /// Returns false when on_step asked to stop.
  template <class Dense>
  bool emit_up_to(double t, const Dense& dense, bool before_t = false) {
    long since_asked = 0;
    while (!outputs_done() &&
           (before_t ? output_time(next_output_) < t : output_time(next_output_) <= t)) {
      const double t_out = output_time(next_output_);
      if (t_out == t) {
        emit(t_out, z_);
      } else {
        dense(t_out, z_out_);
        emit(t_out, z_out_);
      }
      if (++since_asked == kRowsBetweenPolls && !outputs_done() && output_time(next_output_) <= t) {
        since_asked = 0;
        if (!keep_going(t_out)) return false;
      }
    }
    return true;
  }

  /// Records a failure; the message is before + the body at fault + after.
  void fail(SimulationStatus status, int component, const std::string& before,
            const std::string& after) {
    stats_.status = status;
    const std::string who = dynamics_.describe(component, &stats_.failed_body);
    stats_.message = before + (component >= 0 ? ": " + who + after : "");
  }

  void run_rk4() {
    Rk4 rk4(size_, ode());
    double t = s_.t_start;
    emit(t, z_);
    while (!outputs_done()) {
      const double t_next = output_time(next_output_);
      // Each output interval, split at the segments' ends (a table's rows, control
      // instants), in equal steps no longer than s_.step.
      while (t < t_next) {
        const double end = segment_end();
        const double stop = std::min(t_next, end);
        const double span = stop - t;
        const long substeps = rk4_substeps(span, s_.step);
        const double h = span / static_cast<double>(substeps);
        for (long i = 0; i < substeps; ++i) {
          const double t_new = i + 1 == substeps ? stop : t + h;
          z_prev_ = z_;
          rk4.step(t, h, z_);
          stats_.evaluations = rk4.evaluations();
          if (!check_state(z_, t, t_new)) {
            z_ = z_prev_;  // the last good state, for the final energy
            return;
          }
          step_done(t_new, project(z_, t_new));
          t = t_new;
          if (!keep_going(t) && !(outputs_done() || (t == s_.t_end))) {
            interrupted(t);
            return;
          }
        }
        if (t == end && t < s_.t_end) cross(t, z_);
      }
      emit(t, z_);
    }
  }

  /// True when every component of z is finite and within kStateBound; otherwise records
  /// the failure of the step from t_from to t_to (the initial state when they are equal),
  /// naming the first such component in state order (eps, s', w', s' dot; not necessarily
  /// the body whose load started the growth). Builds no message unless it fails.
  bool check_state(const VectorX& z, double t_from, double t_to) {
    const int i = first_diverged(z);
    if (i < 0) return true;
    fail(SimulationStatus::non_finite, i,
         t_from == t_to ? "initial state at t = " + format_time(t_from)
                        : "diverged in the step from t = " + format_time(t_from) +
                              " to t = " + format_time(t_to),
         std::isfinite(z[i])
             ? " exceeds " + format_g(kStateBound) + " (the first such component in state order)"
             : " is not finite (the first such component in state order)");
    return false;
  }

  void run_dopri5() {
    Dopri5Options opt;
    opt.rtol = s_.rtol;
    opt.atol = s_.atol;
    opt.max_step = s_.max_step;
    Dopri5 dp(size_, ode(), opt);
    double end = segment_end();
    const StepStatus started = dp.start(s_.t_start, z_, end);
    stats_.evaluations = dp.evaluations();
    long evaluations = 0, rejected = 0;  // of the segments before the current one
    if (started != StepStatus::ok) {
      fail(SimulationStatus::non_finite, dp.failed_component(),
           "non-finite initial state or derivative at t = " + format_time(s_.t_start),
           " is not finite");
      return;
    }
    emit(s_.t_start, z_);
    while (!outputs_done()) {
      const double t_old = dp.time();
      const StepStatus status = dp.step();
      stats_.evaluations = evaluations + dp.evaluations();
      stats_.steps_rejected = rejected + dp.steps_rejected();
      if (status == StepStatus::non_finite) {
        fail(SimulationStatus::non_finite, dp.failed_component(),
             "non-finite state after t = " + format_time(t_old),
             " is not finite (the first such component in state order; steps down to the "
             "smallest allowed failed too)");
        return;
      }
      if (status == StepStatus::step_underflow) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.3g", dp.min_step());
        fail(SimulationStatus::step_underflow, dp.failed_component(),
             "step size underflow at t = " + format_time(t_old) + " (no step above " + buf +
                 " meets the tolerances)",
             " has the largest error");
        return;
      }
      const double t = dp.time();
      // On failure z_ keeps the last good state, for the final energy.
      if (!check_state(dp.state(), t_old, t)) return;
      step_done(t, project(dp.mutable_state(), t));
      std::memcpy(z_.data(), dp.state().data(), sizeof(double) * static_cast<size_t>(size_));
      const auto dense = [&](double t_out, VectorX& z) { dp.dense_output(t_out, z); };
      if (t == end && t < s_.t_end) {
        // A segment's end: the outputs before it on this segment's inputs, then the new
        // inputs, and a restart (the derivative jumps here).
        if (!emit_up_to(t, dense, true)) {
          interrupted(t);
          return;
        }
        cross(t, z_);
        evaluations += dp.evaluations();
        rejected += dp.steps_rejected();
        end = segment_end();
        if (dp.start(t, z_, end) != StepStatus::ok) {
          fail(SimulationStatus::non_finite, dp.failed_component(),
               "non-finite derivative at t = " + format_time(t) + " after the inputs changed",
               " is not finite");
          return;
        }
        stats_.evaluations = evaluations + dp.evaluations();
      }
      const bool asked_on = emit_up_to(t, dense);
      if ((!asked_on || !keep_going(t)) && !outputs_done()) {
        interrupted(t);
        return;
      }
    }
  }

  void final_energy() {
    const bool finite = z_.allFinite();
    // At the normalized state: with projection on, z_ is so already (every accepted step and
    // the start), and normalizing again could change its last bits.
    if (finite) dynamics_.unpack(z_, !s_.project_euler_parameters, q_, z_state_, work_);
    stats_.energy_final = finite ? energy_of(work_, q_) : std::numeric_limits<double>::quiet_NaN();
  }

  /// The energies' extremes at the start, the output times and the end (note_energies).
  double kinetic_max_ = 0.0;
  double potential_min_ = std::numeric_limits<double>::infinity();
  double potential_max_ = -std::numeric_limits<double>::infinity();
  long energy_step_ = -1;  ///< steps_accepted when the energies were last taken at an output

  const Model& model_;
  const SimulationSettings& s_;
  const Observer& observer_;
  Dynamics dynamics_;  ///< what is integrated, and its derivative (the route dispatch)
  std::optional<ConstraintEquations> projector_;  ///< the outputs' projection's workspace
  int size_;
  VectorX q_, z_state_;  ///< the model's state at an output (and at the start and the end)
  Data data_;
  State work_, out_state_;
  VectorX z_, z_out_, z_prev_;
  // What sets the inputs: nothing (zero), a table, a controller at every evaluation, or a
  // controller at control instants.
  enum class Drive { none, table, every_evaluation, interval };
  struct ControllerFailure {
    double t;
    std::string what;
  };
  std::unique_ptr<ConstrainedDynamics> reactions_;  ///< with constraints: the outputs' reactions
  VectorX zdot_out_;                                ///< its z dot (not used)
  Drive drive_ = Drive::none;
  VectorX u_, u_out_;       ///< the inputs the derivative uses; those at an output time
  VectorX cq_, cz_;         ///< the state handed to the controller
  int segment_ = -1;        ///< the table's segment being integrated
  long control_index_ = 0;  ///< the last control instant: t_start + index * control_interval
  long next_output_ = 0;
  bool done_outputs_ = false;
  SimulationStats stats_;
};

}  // namespace

SimulationStats simulate(const Model& model, const VectorX& q0, const VectorX& z0,
                         const SimulationSettings& settings, const Observer& observer) {
  if (q0.size() != model.num_coordinates() || z0.size() != model.num_speeds())
    throw std::invalid_argument("simulate: the state (q, z) does not have the model's sizes (" +
                                std::to_string(model.num_coordinates()) + " + " +
                                std::to_string(model.num_speeds()) + ")");
  validate_settings(model, settings);
  Run run(model, q0, z0, settings, observer);
  return run.run();
}

SimulationStats simulate(const Model& model, const State& initial,
                         const SimulationSettings& settings, const Observer& observer) {
  if (initial.x.size() != model.num_x() || initial.y.size() != model.num_y())
    throw std::invalid_argument("simulate: the state does not have the model's size (7N + 6N)");
  VectorX q, z;
  joint_coordinates(model, initial, q, z);
  return simulate(model, q, z, settings, observer);
}

}  // namespace kanedyn
