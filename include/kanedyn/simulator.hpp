// Stepping a model one interval at a time (as MuJoCo's mj_step): the caller sets the inputs u
// for each interval [t, t + dt] and advances, e.g. inside a control loop of its own. The
// Simulator holds the model's Dynamics, the integrated state, the time and the integrator's
// workspace. See docs/simulation.md, "Stepping".
#pragma once

#include <memory>
#include <string>

#include "kanedyn/model.hpp"
#include "kanedyn/simulate.hpp"
#include "kanedyn/state.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn {

/// A model's state (q, z) at a time t, advanced by step(u, dt). Of the SimulationSettings it
/// reads integrator, rtol, atol, max_step, route, project_euler_parameters and on_step
/// (t_start is the initial time); the output, rk4 step and input settings belong to
/// simulate(). The model must outlive it; not for concurrent calls on one object.
class Simulator {
 public:
  /// Starts at (q0, z0) at t = settings.t_start; the Euler parameters in q0 (a free body's
  /// eps_K, a spherical joint's q) are normalized, as simulate() does. Throws
  /// std::invalid_argument for settings simulate() refuses (validate_settings), an input table
  /// or controller in them (the inputs come with each step), or a state of the wrong size or
  /// not finite.
  Simulator(const Model& model, const VectorX& q0, const VectorX& z0,
            const SimulationSettings& settings = {});
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;
  ~Simulator();

  /// Holds the inputs at u (model.num_inputs() values) over [t, t + dt] and advances the state
  /// to t + dt: rk4, one step of dt; dopri5, error-controlled steps that land on t + dt exactly,
  /// restarted at t (u may have jumped there), as simulate() restarts at a control instant.
  /// After each step the Euler parameters are rescaled to unit norm
  /// (project_euler_parameters). So steps with the values a controller of interval dt sets give
  /// simulate()'s run bit for bit where the times t + i dt are the same doubles.
  /// Throws std::invalid_argument for a wrong size of u, a value not finite, or a dt that is not
  /// > 0 or that does not advance t; std::runtime_error when the state becomes non-finite (or
  /// beyond kStateBound) or dopri5's step underflows, naming the time and the body, and then
  /// the simulator holds the time and state it had before the call. dopri5 asks
  /// settings.on_step between its steps inside the interval (with the time reached): false
  /// stops the step, as a failure does (std::runtime_error "interrupted ...", the time and
  /// state before the call kept). No heap allocation after the first call (but for the
  /// exceptions' messages).
  void step(Eigen::Ref<const VectorX> u, double dt);

  double time() const { return t_; }
  /// The model's joint coordinates and speeds at time(): for an all-free model the notes'
  /// x and y body by body (as simulate()'s observer gets them).
  const VectorX& q() const;
  const VectorX& z() const;
  /// The notes' state (x, y) at time() (Eq. 1).
  const State& state() const;
  /// The inputs held over the last step (zero before the first).
  const VectorX& inputs() const { return u_; }
  /// Evaluations of the derivative so far, and accepted steps of the integrator.
  long evaluations() const { return evaluations_; }
  long steps() const { return steps_; }
  /// Largest | |e| - 1 | of the Euler parameters found before a projection, over all steps.
  double max_euler_drift() const { return max_euler_drift_; }
  /// Restarts from (q, z) at time t (Euler parameters normalized; checked as the constructor
  /// checks them). Keeps the inputs and the counters.
  void set_state(const VectorX& q, const VectorX& z, double t);

  const Model& model() const;
  const SimulationSettings& settings() const { return settings_; }

 private:
  struct Impl;
  void unpack() const;
  [[noreturn]] void fail(const char* what, int component, double t_from, double t_to,
                         const std::string& detail);

  std::unique_ptr<Impl> impl_;
  SimulationSettings settings_;
  double t_ = 0.0;
  VectorX u_;
  long evaluations_ = 0, steps_ = 0;
  double max_euler_drift_ = 0.0;
};

}  // namespace kanedyn
