// Time integration of a first-order system dz/dt = f(t, z) on Eigen vectors: classical
// fixed-step RK4 and the adaptive embedded Dormand-Prince 5(4) pair with its continuous
// extension (dense output). Generic on purpose: simulate.hpp applies them to the 13N state
// z = ({x}; {y}) of Eq. (1). Both preallocate every stage vector at construction, so a step
// never touches the heap (as long as the derivative function does not).
#pragma once

#include <functional>
#include <limits>
#include <string>

#include "kanedyn/types.hpp"

namespace kanedyn {

/// dz/dt = f(t, z): writes every entry of dzdt (same size as z, preallocated by the caller).
using OdeFunction = std::function<void(double t, const VectorX& z, VectorX& dzdt)>;

enum class Integrator {
  dopri5,  ///< adaptive Dormand-Prince 5(4), dense output
  rk4      ///< classical Runge-Kutta, fixed step
};

/// "dopri5" / "rk4".
std::string to_string(Integrator integrator);
/// Parses "dopri5" / "rk4"; throws std::invalid_argument otherwise.
Integrator parse_integrator(const std::string& text);

/// Classical fourth-order Runge-Kutta with a step chosen by the caller.
class Rk4 {
 public:
  Rk4(int size, OdeFunction f);
  /// One step of size h from (t, z); z is overwritten with the value at t + h.
  void step(double t, double h, VectorX& z);
  long evaluations() const { return evaluations_; }

 private:
  OdeFunction f_;
  VectorX k1_, k2_, k3_, k4_, tmp_;
  long evaluations_ = 0;
};

/// Step-size control of Dopri5. The error of a step is the RMS norm of e_i / sc_i with
/// sc_i = atol + rtol * max(|z_i|, |z_new_i|); a step is accepted when that is <= 1, and the
/// next step is h * clamp(safety * err^(-1/5), min_factor, max_factor) (no growth right after
/// a rejection).
struct Dopri5Options {
  double rtol = 1e-8;
  double atol = 1e-10;
  double safety = 0.9;
  double min_factor = 0.2;
  double max_factor = 5.0;
  double initial_step = 0.0;  ///< 0: chosen by the starting-step heuristic of Hairer et al.
  double max_step = std::numeric_limits<double>::infinity();
};

/// Why Dopri5::step() or start() stopped.
enum class StepStatus {
  ok,
  non_finite,     ///< the state or its derivative is not finite and smaller steps do not help
  step_underflow  ///< the error test keeps failing with a step below min_step()
};

/// Adaptive Dormand-Prince 5(4) (Dormand & Prince 1980; Hairer, Norsett & Wanner, Solving
/// ODEs I, Sec. II.5), propagating the 5th-order solution (local extrapolation), FSAL (the
/// last stage of a step is the first of the next), with the 4th-order continuous extension
/// of Hairer et al. (Sec. II.6) for output between steps: output times never shorten a step.
class Dopri5 {
 public:
  Dopri5(int size, OdeFunction f, Dopri5Options options = {});

  /// Starts at (t0, z0) heading to t_end (which also sets the scale of min_step()).
  /// Evaluates f(t0, z0); returns non_finite if z0 or that is not finite.
  StepStatus start(double t0, const VectorX& z0, double t_end);

  /// Takes one accepted step (retrying rejected ones with smaller steps), never past t_end;
  /// the step that reaches t_end lands on it exactly. Returns ok, or why it failed (time()
  /// and state() then still hold the last accepted step).
  StepStatus step();

  /// Fixed step without error control (for order tests): one step of size h, FSAL kept.
  /// Returns non_finite if the new state is not finite (the step is then not taken).
  StepStatus fixed_step(double h);

  double time() const { return t_; }
  double previous_time() const { return t_old_; }  ///< start of the last accepted step
  const VectorX& state() const { return z_; }
  /// The state may be changed after a step (e.g. projected back onto a constraint by a small
  /// amount): the next step keeps using the derivative evaluated before the change (FSAL).
  VectorX& mutable_state() { return z_; }

  /// The continuous extension of the last accepted step at t in [previous_time(), time()],
  /// into out (size of the state). Fourth-order accurate; at time() it gives the step's
  /// result as computed, before any change through mutable_state(). Valid after a step that
  /// returned ok, until the next call of step().
  void dense_output(double t, VectorX& out) const;

  /// Smallest step allowed before step() reports step_underflow: 16 machine epsilons times
  /// max(|t|, |t_end - t0|).
  double min_step() const;
  double step_size() const { return h_; }  ///< the size the next step will try
  /// The scaled error norm of the last attempted step (<= 1 for an accepted one).
  double error_estimate() const { return err_; }
  long steps_accepted() const { return accepted_; }
  long steps_rejected() const { return rejected_; }
  long evaluations() const { return evaluations_; }
  /// The component of the state at fault after a failure: the first non-finite component,
  /// or the one with the largest share of the error norm in the last attempted step; -1
  /// before any step.
  int failed_component() const;

 private:
  void eval(double t, const VectorX& z, VectorX& dz);
  /// The stages of a step of size h from (t_, z_) with k1_ = f(t_, z_) known: z_new_, k7_,
  /// and the error norm (+inf if it overflows; NaN and trial_non_finite_ when a value is
  /// not finite).
  double attempt(double h);
  void accept(double h, double t_new);
  double error_norm(double h);
  double initial_step(double t_end);

  OdeFunction f_;
  Dopri5Options opt_;
  VectorX z_, z_old_, z_new_, tmp_;
  VectorX ratio_;  ///< (e_i / sc_i)^2 of the last attempted step
  VectorX k1_, k2_, k3_, k4_, k5_, k6_, k7_;
  double err_ = 0.0;
  double t_ = 0.0, t_old_ = 0.0, t_end_ = 0.0, h_ = 0.0, h_last_ = 0.0, span_ = 0.0;
  bool fsal_pending_ = false;      ///< k7_ holds f at the accepted state, not yet moved to k1_
  bool trial_non_finite_ = false;  ///< the last attempt produced a non-finite value
  long accepted_ = 0, rejected_ = 0, evaluations_ = 0;
  // Set by a failure, or found from ratio_ on demand (worst_pending_) by failed_component().
  mutable int failed_component_ = -1;
  mutable bool worst_pending_ = false;
};

}  // namespace kanedyn
