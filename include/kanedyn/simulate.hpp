// Simulation: integrate the equations of motion of a Model from its state (q, z), calling an
// observer at evenly spaced output times. The library never prints; progress and interruption go
// through an optional callback. See docs/simulation.md.
#pragma once

#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/inputs.hpp"
#include "kanedyn/integrate.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

/// Sets the inputs u (model.num_inputs() entries, holding the values it set last; zero at
/// first) from the time and the model's state (q, z). An exception it throws stops the run as
/// a failure (SimulationStatus::controller_error), the output before it kept.
using Controller =
    std::function<void(double t, const VectorX& q, const VectorX& z, Eigen::Ref<VectorX> u)>;

/// How to simulate. Times in the model's time unit (s in the examples).
struct SimulationSettings {
  double t_start = 0.0;
  double t_end = 10.0;
  /// Output times are t_start + i dt_out up to t_end, and t_end itself.
  double dt_out = 0.01;
  Integrator integrator = Integrator::dopri5;
  double rtol = 1e-8;   ///< dopri5: relative tolerance
  double atol = 1e-10;  ///< dopri5: absolute tolerance
  /// rk4: the largest step. Each output interval is split into equal steps no longer than
  /// this, so every output time is reached by a step (no interpolation).
  double step = 1e-3;
  double max_step = std::numeric_limits<double>::infinity();  ///< dopri5: step cap
  Route route = Route::recursive;  ///< how forward_dynamics solves for {y dot}
  /// Rescale every eps_K to unit norm after each accepted step (and in every output state).
  /// The initial state is normalized in any case.
  bool project_euler_parameters = true;
  /// Compute the kinematics of each output state into the observer's data (see Observer).
  /// false when the observer does not read them, e.g. when it only queues the state (the data
  /// may hold them anyway: simulate() takes the energies of the first output state after each
  /// step, for SimulationStats::energy_scale).
  bool observer_kinematics = true;
  /// Called after every accepted step with the time reached, and every 64 output rows while
  /// one step spans many output times; return false to stop the run (status interrupted).
  /// Keep it cheap: it runs once per step.
  std::function<bool(double t)> on_step;

  /// The inputs' values over time (docs/model-format.md, "Inputs"): the table's value in force
  /// at each time, never stepped across a row's time (the integrator restarts there). Null:
  /// every input 0, unless a controller sets them. Its num_inputs() must be the model's.
  std::shared_ptr<const InputTable> inputs;
  /// Sets the inputs instead of a table (not both). With control_interval 0 it is called at
  /// every evaluation of the derivative with the state being evaluated, and at every output time
  /// for the values written there, so it must be a function of (t, q, z) alone. With
  /// control_interval > 0 it is called at t_start + i control_interval (and not otherwise),
  /// its value held until the next call; the integrator restarts at each of these instants.
  Controller controller;
  double control_interval = 0.0;
};

/// Called at each output time with the model's state there: its notes' state (x, y), its joint
/// coordinates q and speeds z (for an all-free model, the same numbers body by body), and data
/// holding the inputs in force then (data.inputs) and the kinematics of that state (R, p_O, p_G,
/// v_O, v_G: compute_kinematics; unless settings.observer_kinematics is false), and for a model
/// with constraints their reactions at that state and those inputs (data.reactions), which may be
/// used as scratch (e.g. to call total_energy). Exceptions thrown by the observer leave simulate().
using Observer = std::function<void(double t, const State& state, const VectorX& q,
                                    const VectorX& z, Data& data)>;

/// A state component beyond this magnitude counts as diverged: its square, which the energy
/// and the force laws form, nears the largest double (1.8e308).
constexpr double kStateBound = 1e150;

enum class SimulationStatus {
  completed,    ///< reached t_end
  interrupted,  ///< on_step returned false
  /// the state became non-finite or diverged (a component beyond kStateBound) at an accepted
  /// step, or the energy at the start or the end is not finite
  non_finite,
  step_underflow,    ///< dopri5 could not meet the tolerances with any representable step
  controller_error,  ///< the controller threw (the message has its what())
};

/// "completed", "interrupted", "non-finite state", "step size underflow", "controller error".
std::string to_string(SimulationStatus status);

/// energy_scale counts when above this fraction of the largest energy magnitude seen: the
/// energies' round-off is a few units in the last place of that magnitude (1e-16 relative), so
/// a scale above 1e-9 of it gives a relative change whose round-off is below about 1e-6.
constexpr double kEnergyScaleFloor = 1e-9;

/// What happened in a run.
struct SimulationStats {
  SimulationStatus status = SimulationStatus::completed;
  bool ok() const { return status == SimulationStatus::completed; }
  double t_reached = 0.0;  ///< time of the last accepted state
  long steps_accepted = 0, steps_rejected = 0;
  long evaluations = 0;         ///< calls of forward_dynamics (the integrator's derivative)
  long outputs = 0;             ///< observer calls
  double energy_initial = 0.0;  ///< total_energy at t_start
  double energy_final = 0.0;    ///< total_energy at t_reached
  double energy_change() const { return energy_final - energy_initial; }  ///< [J]
  /// The size of the energy that moved in the run [J]: the largest kinetic energy, or the
  /// largest difference of potential energies, at the start, the output times (the first in
  /// each integration step) and the end;
  /// 0 when that is not above kEnergyScaleFloor times the energies' magnitude (nothing moved,
  /// and it is round-off). Unlike energy_initial, it does not depend on the potential's datum.
  double energy_scale = 0.0;
  /// energy_change() / energy_scale; NaN when energy_scale is 0 (a ratio to round-off would
  /// only mislead).
  double relative_energy_change() const;
  /// Largest | |eps_K| - 1 | found before a projection, over all steps and bodies.
  double max_euler_drift = 0.0;
  /// With constraints: the largest holonomic constraint error found before a projection.
  double max_constraint_error = 0.0;
  /// With constraints: per constraint (the model's order), the first output time at which a
  /// rolling disc's normal force n . f (its reaction along the plane normal) was negative: the
  /// wheel would lift there, and the run went on as if the constraint held. NaN for the other
  /// constraints and for a disc whose normal force stayed >= 0. Empty without constraints.
  std::vector<double> normal_force_negative_at;
  double wall_seconds = 0.0;
  int failed_body = -1;  ///< failures: the body at fault (index), -1 if none
  /// failures: the time and the body ("diverged in the step from t = 1.2 to t = 1.21:
  /// body 'link3' (w2) is not finite (the first such component in state order)"); empty
  /// when completed.
  std::string message;
};

/// Throws std::invalid_argument naming the first inconsistent setting (t_end < t_start,
/// dt_out <= 0, a non-positive rk4 step, negative or all-zero tolerances, ...) or one that
/// cannot be honoured: more than 1e12 output times, an rk4 run of more than 1e15 steps, a
/// dt_out or rk4 step below the resolution of the times (t + h == t).
void validate_settings(const SimulationSettings& settings);

/// The same, and that settings.route can run on this model (the Kane route builds partial
/// velocity blocks for every chain entry: Model::kMaxFlatChainEntries at most).
void validate_settings(const Model& model, const SimulationSettings& settings);

/// An estimate of the largest step rk4 takes stably: 2 sqrt(2) / omega for the stiffest
/// force element, omega^2 its ForceElement::frequency_squared_estimate (a bushing or a spring
/// taken as a lone oscillator of its bodies: reduced mass; the smallest principal moments for a
/// bushing's rotational stiffness). Infinity without such elements. Sets force_index to that
/// element's index in model.forces() (-1 if none).
double rk4_step_limit(const Model& model, int* force_index = nullptr);

/// The number of equal rk4 steps simulate() takes over an interval of length span with the
/// step cap `step` (at least 1; a ratio within 1e-9 of a whole number counts as that number,
/// so that dt_out / step = 10 gives 10 steps, not 11).
long rk4_substeps(double span, double step);

/// Integrates the model from its state (q0, z0) over [t_start, t_end] (docs/simulation.md);
/// every joint holds by construction. The Euler parameters in q0 (a free body's eps_K, a
/// spherical joint's q) are normalized first, and after each accepted step
/// (project_euler_parameters); max_euler_drift records their drift. The derivative is the
/// model's forward dynamics by settings.route (dynamics.hpp): for an all-free model the
/// notes' Eqs. (36), (39)-(40) in the layout of Eq. (1), otherwise the jointed kernel's
/// (Dynamics::derivative). The energy is total_energy at (q, z) (with the joint springs'
/// potentials). Calls observer (if set) at every output time, the first at t_start. Throws
/// std::invalid_argument for inconsistent settings or a state of the wrong size; integration
/// failures are reported in the returned stats (naming the body and its column), not thrown.
SimulationStats simulate(const Model& model, const VectorX& q0, const VectorX& z0,
                         const SimulationSettings& settings, const Observer& observer = {});

/// The same from the notes' state (x, y), where the joints allow it (joint_coordinates):
/// any state of an all-free model.
SimulationStats simulate(const Model& model, const State& initial,
                         const SimulationSettings& settings, const Observer& observer = {});

/// The column of a component of (q; z), as the trajectory CSV names it after the body name and
/// a dot: a free body's e1..e4, s1..s3, w1..w3, sd1..sd3, another joint's j1.. and jd1..; ""
/// outside (q; z). body (if not null) gets the 0-based body, or -1.
std::string joint_state_column(const Model& model, int component, int* body = nullptr);
/// "body 'NAME' (COLUMN)" for a component of (q; z) (joint_state_column), "no body" outside.
std::string describe_joint_state_component(const Model& model, int component, int* body = nullptr);

/// "body 'NAME' (COLUMN)" for a component of the 13N vector z = ({x}; {y}): COLUMN is the
/// trajectory column suffix (e1..e4, s1..s3, w1..w3, sd1..sd3). Sets body to its index.
std::string describe_state_component(const Model& model, int component, int* body = nullptr);

}  // namespace kanedyn
