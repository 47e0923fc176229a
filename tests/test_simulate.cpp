// Simulation (simulate.hpp): conservation of energy and momentum, the Euler-parameter
// projection, output times, failures naming the time and the body, settings that cannot be
// honoured, and the example models.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "file_support.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/simulate.hpp"
#include "test_support.hpp"

namespace {

using namespace kanedyn;

using test::eight_body;
using test::moving_state;

TEST(Simulate, ZeroDampingEightBodyKeepsEnergyOverTenSeconds) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 0.0);
  const State initial = moving_state(model, 11);
  Data scratch(model);
  const double kinetic = kinetic_energy(model, initial, scratch);
  SimulationSettings s;
  s.t_end = 10.0;
  s.dt_out = 0.05;
  s.rtol = 1e-10;
  s.atol = 1e-12;
  double e0 = 0.0, worst = 0.0;
  const auto stats =
      simulate(model, initial, s,
               [&](double t, const State& st, const VectorX&, const VectorX&, Data& data) {
                 const double e = total_energy(model, st, data);
                 if (t == 0.0) e0 = e;
                 worst = std::max(worst, std::abs(e - e0));
               });
  ASSERT_TRUE(stats.ok()) << stats.message;
  // |E0| is not a near-cancellation of kinetic and potential terms (else "relative" says
  // little): it exceeds the kinetic energy here.
  ASSERT_GT(std::abs(e0), kinetic);
  EXPECT_EQ(stats.energy_initial, e0);
  EXPECT_LT(worst / std::abs(e0), 1e-8) << "worst " << worst << " of " << e0;
  EXPECT_LT(std::abs(stats.relative_energy_change()), 1e-8);
  // The run is long enough to mean something: many oscillations of the stiffest bushing.
  EXPECT_GT(stats.steps_accepted, 1000);
}

TEST(Simulate, DampingRemovesEnergy) {
  // The same check can fail: with damping the energy falls well beyond the tolerance.
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const auto stats = simulate(model, moving_state(model, 11), SimulationSettings{});
  ASSERT_TRUE(stats.ok());
  EXPECT_LT(stats.energy_final, stats.energy_initial);
  EXPECT_LT(stats.relative_energy_change(), -1e-3);
}

TEST(Simulate, FreeSystemKeepsLinearAndAngularMomentum) {
  // No gravity, no bushing to the ground: bushings between bodies (damped, still internal)
  // cannot change the total momentum or the angular momentum about the origin.
  const Model model = eight_body(Vector3::Zero(), false, 1.0);
  State initial = moving_state(model, 5);
  initial.translation_rate(0) = Vector3(0.4, -0.2, 0.3);  // the system drifts and turns
  SimulationSettings s;
  s.t_end = 5.0;
  s.dt_out = 0.05;
  s.rtol = 1e-11;
  s.atol = 1e-13;
  Vector3 p0, h0;
  double worst_p = 0.0, worst_h = 0.0;
  const auto stats = simulate(
      model, initial, s,
      [&](double t, const State& st, const VectorX&, const VectorX&, Data& data) {
        const Vector3 p = linear_momentum(model, st, data), h = angular_momentum(model, st, data);
        if (t == 0.0) p0 = p, h0 = h;
        worst_p = std::max(worst_p, (p - p0).norm());
        worst_h = std::max(worst_h, (h - h0).norm());
      });
  ASSERT_TRUE(stats.ok()) << stats.message;
  ASSERT_GT(p0.norm(), 1.0);
  ASSERT_GT(h0.norm(), 1.0);
  EXPECT_LT(worst_p / p0.norm(), 1e-9) << worst_p;
  EXPECT_LT(worst_h / h0.norm(), 1e-9) << worst_h;
  // Not conserved trivially: energy is lost to damping meanwhile.
  EXPECT_LT(stats.relative_energy_change(), -1e-3);
}

TEST(Simulate, ProjectsEulerParametersAndReportsTheDrift) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  State initial = moving_state(model, 3);
  initial.euler_parameters(2) *= 1.5;  // simulate() normalizes the initial state first
  double drift[2], worst_output[2];
  for (const bool project : {true, false}) {
    SimulationSettings s;
    s.t_end = 2.0;
    s.rtol = 1e-6;
    s.atol = 1e-8;
    s.project_euler_parameters = project;
    double worst = 0.0;
    const auto stats = simulate(
        model, initial, s, [&](double, const State& st, const VectorX&, const VectorX&, Data&) {
          for (int k = 0; k < 8; ++k)
            worst = std::max(worst, std::abs(st.euler_parameters(k).norm() - 1.0));
        });
    ASSERT_TRUE(stats.ok());
    drift[project] = stats.max_euler_drift;
    worst_output[project] = worst;
  }
  // Projected: every output has unit norm to round-off; the drift of one step is above
  // round-off and below the tolerance.
  EXPECT_LT(worst_output[true], 1e-15);
  EXPECT_GT(drift[true], 1e-15);
  EXPECT_LT(drift[true], 1e-6);
  // Not projected: the drift accumulates over the steps, and the reported largest drift is
  // the norm error the outputs show (they lie between steps: within 10 %).
  EXPECT_GT(drift[false], 3 * drift[true]);
  EXPECT_NEAR(worst_output[false], drift[false], 0.1 * drift[false]);
}

TEST(Simulate, OutputTimesAreEvenlySpacedAndIncludeTheEnd) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  for (const Integrator integrator : {Integrator::dopri5, Integrator::rk4}) {
    SimulationSettings s;
    s.integrator = integrator;
    s.t_start = 1.0;
    s.t_end = 1.25;
    s.dt_out = 0.1;
    std::vector<double> times;
    const auto stats = simulate(
        model, moving_state(model, 1), s,
        [&](double t, const State&, const VectorX&, const VectorX&, Data&) { times.push_back(t); });
    ASSERT_TRUE(stats.ok());
    ASSERT_EQ(times.size(), 4u);
    EXPECT_EQ(times[0], 1.0);
    EXPECT_NEAR(times[1], 1.1, 1e-15);
    EXPECT_NEAR(times[2], 1.2, 1e-15);
    EXPECT_EQ(times[3], 1.25);  // t_end, though off the grid
    EXPECT_EQ(stats.outputs, 4);
    EXPECT_EQ(stats.t_reached, 1.25);
  }
}

TEST(Simulate, Rk4SplitsOutputIntervalsIntoEqualSteps) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  SimulationSettings s;
  s.integrator = Integrator::rk4;
  s.t_end = 1.0;
  s.dt_out = 0.1;
  s.step = 0.03;  // 4 steps of 0.025 per output interval
  const auto stats = simulate(model, moving_state(model, 1), s);
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats.steps_accepted, 40);
  EXPECT_EQ(stats.evaluations, 160);
}

TEST(Simulate, KaneAndRecursiveRoutesGiveTheSameTrajectory) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const State initial = moving_state(model, 9);
  std::vector<State> states[2];
  int route = 0;
  for (const Route method : {Route::recursive, Route::assembled}) {
    SimulationSettings s;
    s.integrator = Integrator::rk4;  // fixed steps: the same sequence of evaluations
    s.t_end = 1.0;
    s.dt_out = 0.25;
    s.route = method;
    simulate(model, initial, s,
             [&](double, const State& st, const VectorX&, const VectorX&, Data&) {
               states[route].push_back(st);
             });
    ++route;
  }
  ASSERT_EQ(states[0].size(), states[1].size());
  for (size_t i = 0; i < states[0].size(); ++i) {
    // The two solutions of Eq. (36) differ by round-off (about 2e-13 of |y dot| ~ 300 per
    // evaluation), which 1000 steps carry along without growth: 1e-11 leaves a margin.
    EXPECT_LT((states[0][i].x - states[1][i].x).cwiseAbs().maxCoeff(), 1e-11) << "row " << i;
    EXPECT_LT((states[0][i].y - states[1][i].y).cwiseAbs().maxCoeff(), 1e-11) << "row " << i;
  }
}

// ---------------------------------------------------------------------------------------------
// Failures

/// A test-only load: nothing while body k's mass centre is above z = floor, NaN below.
class NanBelow final : public ForceElement {
 public:
  NanBelow(int k, double floor) : k_(k), floor_(floor) {}
  std::string type() const override { return "nan-below"; }
  int body() const override { return k_; }
  void apply(const Model&, const State&, const Kinematics& kin, Loads& loads) const override {
    if (kin.p_G[static_cast<size_t>(k_)].z() < floor_)
      loads.force[static_cast<size_t>(k_)].x() = std::nan("");
  }

 private:
  int k_;
  double floor_;
};

/// Two free bodies; the first hangs from the ground by a bushing, the second carries the
/// given load (if any).
Model two_bodies(std::shared_ptr<const ForceElement> load_on_second) {
  BodySpec a, b;
  a.name = "anchor";
  a.mass = 1.0;
  a.inertia = Vector3(0.1, 0.1, 0.1).asDiagonal();
  b = a;
  b.name = "faller";
  std::vector<std::shared_ptr<const ForceElement>> forces{
      std::make_shared<Bushing>(0, Vector3(1e3, 1e3, 1e3), Vector3::Zero(), 0.0, 0.0)};
  if (load_on_second) forces.push_back(std::move(load_on_second));
  return Model({a, b}, Vector3(0, 0, -9.81), std::move(forces));
}

TEST(Simulate, NonFiniteStateStopsNamingTimeAndBody) {
  // The faller drops freely from z = 0 and reaches z = -1 at t = sqrt(2/9.81) = 0.4515 s.
  const Model model = two_bodies(std::make_shared<NanBelow>(1, -1.0));
  const double t_hit = std::sqrt(2.0 / 9.81);
  for (const Integrator integrator : {Integrator::dopri5, Integrator::rk4}) {
    SimulationSettings s;
    s.integrator = integrator;
    s.t_end = 2.0;
    s.dt_out = 0.1;
    long outputs = 0;
    const auto stats =
        simulate(model, State(model), s,
                 [&](double, const State& st, const VectorX&, const VectorX&, Data&) {
                   EXPECT_TRUE(st.x.allFinite() && st.y.allFinite());
                   ++outputs;
                 });
    EXPECT_EQ(stats.status, SimulationStatus::non_finite) << to_string(integrator);
    EXPECT_EQ(stats.failed_body, 1);
    EXPECT_NE(stats.message.find("body 'faller'"), std::string::npos) << stats.message;
    EXPECT_NE(stats.message.find("t = 0.45"), std::string::npos) << stats.message;
    EXPECT_LE(stats.t_reached, t_hit);
    EXPECT_GT(stats.t_reached, t_hit - 1.1e-3);  // rk4 steps are 1e-3
    EXPECT_EQ(outputs, 5);                       // t = 0 .. 0.4
    EXPECT_TRUE(std::isfinite(stats.energy_final));
  }
}

TEST(Simulate, StepSizeUnderflowStopsNamingTimeAndBody) {
  // atol = 1e-300 and rtol = 0 ask for more than double precision gives: any rounding error
  // in the spinning faller's error estimate fails the test, down to the smallest step. The
  // anchor rests without load (no gravity): its stages and error are exactly zero.
  const Model model(two_bodies(nullptr).bodies(), Vector3::Zero(), {});
  State initial(model);
  initial.angular_velocity(1) = Vector3(0.3, 1.0, -0.2);
  initial.translation_rate(1) = Vector3(0.0, 0.0, -1.0);
  SimulationSettings s;
  s.t_end = 1.0;
  s.rtol = 0.0;
  s.atol = 1e-300;
  const auto stats = simulate(model, initial, s);
  EXPECT_EQ(stats.status, SimulationStatus::step_underflow) << stats.message;
  EXPECT_EQ(stats.failed_body, 1);
  EXPECT_NE(stats.message.find("step size underflow at t = 0 "), std::string::npos)
      << stats.message;
  EXPECT_NE(stats.message.find("body 'faller'"), std::string::npos) << stats.message;
  EXPECT_EQ(stats.t_reached, 0.0);
  EXPECT_EQ(stats.steps_accepted, 0);
}

TEST(Simulate, OnStepCanInterrupt) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  SimulationSettings s;
  s.t_end = 10.0;
  s.dt_out = 0.1;
  s.on_step = [](double t) { return t < 0.5; };
  double last = -1;
  const auto stats =
      simulate(model, moving_state(model, 2), s,
               [&](double t, const State&, const VectorX&, const VectorX&, Data&) { last = t; });
  EXPECT_EQ(stats.status, SimulationStatus::interrupted);
  EXPECT_GE(stats.t_reached, 0.5);
  EXPECT_LT(stats.t_reached, 1.0);
  EXPECT_LE(last, stats.t_reached);
  EXPECT_GE(last, 0.4);
}

TEST(Simulate, RejectsInconsistentSettings) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const State initial(model);
  auto with = [](auto change) {
    SimulationSettings s;
    change(s);
    return s;
  };
  EXPECT_THROW(simulate(model, initial, with([](auto& s) { s.t_end = -1; })),
               std::invalid_argument);
  EXPECT_THROW(simulate(model, initial, with([](auto& s) { s.dt_out = 0; })),
               std::invalid_argument);
  EXPECT_THROW(simulate(model, initial, with([](auto& s) { s.rtol = s.atol = 0; })),
               std::invalid_argument);
  EXPECT_THROW(simulate(model, initial, with([](auto& s) {
                          s.integrator = Integrator::rk4;
                          s.step = 0;
                        })),
               std::invalid_argument);
  EXPECT_THROW(simulate(model, State(3), SimulationSettings{}), std::invalid_argument);
  // The zero-length run is fine: one output.
  long outputs = 0;
  EXPECT_TRUE(
      simulate(model, initial, with([](auto& s) { s.t_end = 0; }),
               [&](double, const State&, const VectorX&, const VectorX&, Data&) { ++outputs; })
          .ok());
  EXPECT_EQ(outputs, 1);
}

/// One body of mass m on a ground bushing of stiffness k (translational, isotropic), and
/// rotational stiffness kr; released from s' = (0.01, 0, 0).
Model oscillator(double m, double k, double kr = 0.0) {
  BodySpec b;
  b.name = "bob";
  b.mass = m;
  b.inertia = Vector3(0.1, 0.2, 0.3).asDiagonal();
  return Model({b}, Vector3::Zero(),
               {std::make_shared<Bushing>(0, Vector3(k, k, k), Vector3::Zero(), kr, 0.0)});
}

State displaced(const Model& model) {
  State s(model);
  s.translation(0) = Vector3(0.01, 0, 0);
  return s;
}

TEST(Simulate, RefusesSettingsThatCannotBeHonoured) {
  const Model model = oscillator(1.0, 100.0);
  auto message = [&](auto change) {
    SimulationSettings s;
    change(s);
    try {
      simulate(model, State(model), s);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  // More output times than any disk holds (1e13 here), and times that cannot advance.
  EXPECT_NE(message([](auto& s) { s.dt_out = 1e-12; }).find("at most 1e+12 are allowed"),
            std::string::npos);
  EXPECT_NE(message([](auto& s) {
              s.t_start = 1e6;
              s.t_end = 1e6 + 1e-6;
              s.dt_out = 1e-16;
            }).find("below the resolution of the times"),
            std::string::npos);
  // An rk4 step that would overflow the step count, or not advance t.
  EXPECT_NE(message([](auto& s) {
              s.integrator = Integrator::rk4;
              s.step = s.dt_out / 1e19;
            }).find("the rk4 step 1e-21 cannot be honoured"),
            std::string::npos);
  EXPECT_NE(message([](auto& s) {
              s.integrator = Integrator::rk4;
              s.t_end = 1e-3;
              s.dt_out = 1e-3;
              s.step = 1e-19;  // 1e16 steps
            }).find("cannot be honoured"),
            std::string::npos);
  // Ordinary small values are fine.
  EXPECT_EQ(message([](auto& s) {
              s.t_end = 1e-6;
              s.dt_out = 1e-9;
            }),
            "(accepted)");
}

TEST(Simulate, TheKaneRouteIsRefusedUpFrontWhereItCannotBeBuilt) {
  // A chain of 5800 bodies: 16.8 million chain entries > 2^24.
  std::vector<BodySpec> bodies(5800);
  for (int k = 0; k < 5800; ++k) {
    bodies[static_cast<size_t>(k)].name = test::numbered_name("l", k + 1);
    bodies[static_cast<size_t>(k)].lower_body = k - 1;
    bodies[static_cast<size_t>(k)].mass = 1.0;
    bodies[static_cast<size_t>(k)].inertia = Matrix3::Identity();
  }
  const Model model(std::move(bodies), Vector3::Zero(), {});
  ASSERT_FALSE(model.has_flat_chains());
  SimulationSettings s;
  s.route = Route::assembled;
  try {
    validate_settings(model, s);
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("16822900 chain entries"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("use the recursive route"), std::string::npos) << e.what();
  }
  s.route = Route::recursive;
  EXPECT_NO_THROW(validate_settings(model, s));
  s.route = Route::assembled;
  EXPECT_THROW(simulate(model, State(model), s), std::invalid_argument);
}

TEST(Simulate, ADivergingRunStopsWhereTheStateLeavesTheBound) {
  // omega = 100 rad/s, rk4 steps of 0.05 s: h omega = 5, beyond RK4's stability (2.83). The
  // amplitude grows every step; the run must stop, not report a completed run of 1e218s.
  const Model model = oscillator(1.0, 1e4);
  SimulationSettings s;
  s.integrator = Integrator::rk4;
  s.step = s.dt_out = 0.05;
  double largest = 0.0;
  const auto stats = simulate(
      model, displaced(model), s,
      [&](double, const State& st, const VectorX&, const VectorX&, Data&) {
        largest = std::max({largest, st.x.cwiseAbs().maxCoeff(), st.y.cwiseAbs().maxCoeff()});
      });
  EXPECT_EQ(stats.status, SimulationStatus::non_finite);
  EXPECT_NE(stats.message.find("diverged in the step from t = "), std::string::npos)
      << stats.message;
  EXPECT_NE(stats.message.find("body 'bob' (sd1) exceeds 1e+150"), std::string::npos)
      << stats.message;
  EXPECT_LE(largest, kStateBound);
  EXPECT_GT(largest, 1e100);  // it did diverge: the bound, not the step count, stopped it
  EXPECT_LT(stats.t_reached, 10.0);
  EXPECT_TRUE(std::isfinite(stats.energy_final));
}

TEST(Simulate, ANonFiniteEnergyIsAFailure) {
  // A finite state whose potential overflows: m g z = 1 * 1e300 * 1e10.
  BodySpec b;
  b.name = "high";
  b.mass = 1.0;
  b.inertia = Matrix3::Identity();
  const Model model({b}, Vector3(0, 0, -1e300), {});
  State initial(model);
  initial.translation(0) = Vector3(0, 0, 1e10);
  const auto stats = simulate(model, initial, SimulationSettings{});
  EXPECT_EQ(stats.status, SimulationStatus::non_finite);
  EXPECT_NE(stats.message.find("non-finite energy (inf) at t = 0"), std::string::npos)
      << stats.message;
  EXPECT_EQ(stats.steps_accepted, 0);
}

TEST(Simulate, OnStepIsAskedBetweenTheRowsOfOneLongStep) {
  // dt_out = 1e-9 over a step of ~1e-3 s: about 1e6 rows per step. A stop asked at the first
  // call must end the run within kRowsBetweenPolls (64) rows, not after a million.
  const Model model = oscillator(1.0, 100.0);
  SimulationSettings s;
  s.t_end = 1.0;
  s.dt_out = 1e-9;
  long calls = 0, rows = 0;
  s.on_step = [&](double) { return ++calls < 3; };
  const auto stats =
      simulate(model, displaced(model), s,
               [&](double, const State&, const VectorX&, const VectorX&, Data&) { ++rows; });
  EXPECT_EQ(stats.status, SimulationStatus::interrupted);
  EXPECT_EQ(calls, 3);
  EXPECT_LE(rows, 1 + 3 * 64);
}

TEST(Simulate, Rk4StepLimitOfABushing) {
  // 2 sqrt(2) / omega with omega^2 = k / m for a body on ground; k_r / I_min for the
  // rotational part when that is faster; the reduced mass between two bodies.
  EXPECT_NEAR(rk4_step_limit(oscillator(2.0, 800.0)), 2.0 * std::sqrt(2.0) / 20.0, 1e-15);
  int index = -2;
  EXPECT_NEAR(rk4_step_limit(oscillator(2.0, 800.0, 1000.0), &index), 2.0 * std::sqrt(2.0) / 100.0,
              1e-15);  // I_min = 0.1: omega = 100
  EXPECT_EQ(index, 0);
  BodySpec a, b;
  a.name = "a";
  a.mass = 3.0;
  a.inertia = Matrix3::Identity();
  b = a;
  b.name = "b";
  b.mass = 6.0;
  b.lower_body = 0;
  const Model pair({a, b}, Vector3::Zero(),
                   {std::make_shared<Bushing>(1, Vector3(0, 0, 200.0), Vector3::Zero(), 0, 0)});
  EXPECT_NEAR(rk4_step_limit(pair, &index), 2.0 * std::sqrt(2.0) / 10.0, 1e-15);  // mu = 2
  EXPECT_EQ(index, 0);
  const Model free_body({a}, Vector3::Zero(), {});
  EXPECT_EQ(rk4_step_limit(free_body, &index), std::numeric_limits<double>::infinity());
  EXPECT_EQ(index, -1);
}

// ---------------------------------------------------------------------------------------------
// The example models

/// Simulates an example file with its own `simulation:` settings (t_end shortened if given).
SimulationStats run_example(const std::string& name, double t_end, const Observer& observer) {
  const auto file = io::load_model_file(std::string(KANEDYN_SOURCE_DIR) + "/examples/" + name);
  SimulationSettings s;
  s.t_end = t_end > 0 ? t_end : file.simulation.t_end.value_or(s.t_end);
  s.dt_out = file.simulation.dt_out.value_or(s.dt_out);
  return simulate(file.model, file.initial, s, observer);
}

TEST(Examples, TennisRacketFlipsWithinTheDefaultRun) {
  // w2 starts at +6 rad/s about the intermediate axis and turns over (to about -6) and back;
  // energy stays (free body, dopri5 at the default tolerances).
  double w2_min = 1e9, first_flip = -1.0;
  const auto stats =
      run_example("tennis_racket.yaml", 0.0,
                  [&](double t, const State& st, const VectorX&, const VectorX&, Data&) {
                    const double w2 = st.angular_velocity(0)[1];
                    w2_min = std::min(w2_min, w2);
                    if (w2 < 0 && first_flip < 0) first_flip = t;
                  });
  ASSERT_TRUE(stats.ok()) << stats.message;
  EXPECT_NEAR(stats.t_reached, 10.0, 1e-12);
  EXPECT_LT(w2_min, -5.9);
  EXPECT_GT(first_flip, 1.0);  // the wobble needs time to grow (rate 4.6 /s from 1e-3)
  EXPECT_LT(first_flip, 4.0);
  EXPECT_LT(std::abs(stats.relative_energy_change()), 1e-7);
}

TEST(Examples, DoublePendulumBushingsActAsJoints) {
  // The stiff bushings keep each pin within a millimetre while the links swing through
  // metres; the energy changes only by what the pins' damping takes from their vibration.
  double stretch = 0.0, height_min = 1e9;
  const auto stats =
      run_example("double_pendulum.yaml", 2.0,
                  [&](double, const State& st, const VectorX&, const VectorX&, Data& data) {
                    for (int k = 0; k < 2; ++k)
                      stretch = std::max(stretch, st.translation(k).norm());
                    height_min = std::min(height_min, data.kinematics.p_G[1].z());
                  });
  ASSERT_TRUE(stats.ok()) << stats.message;
  EXPECT_LT(stretch, 1e-3);
  EXPECT_LT(height_min, -1.0);  // the lower link swings down past the pivot by a metre
  EXPECT_LT(std::abs(stats.relative_energy_change()), 1e-2);
}

TEST(Examples, Chain64HangsUnderGravity) {
  const auto file = io::load_model_file(std::string(KANEDYN_SOURCE_DIR) + "/examples/chain64.yaml");
  ASSERT_EQ(file.model.num_bodies(), 64);
  EXPECT_EQ(file.model.depth(63), 63);
  double end_z0 = 0.0, end_z = 0.0;
  const auto stats = run_example(
      "chain64.yaml", 0.1, [&](double t, const State&, const VectorX&, const VectorX&, Data& data) {
        (t == 0.0 ? end_z0 : end_z) = data.kinematics.p_G[63].z();
      });
  ASSERT_TRUE(stats.ok()) << stats.message;
  EXPECT_LT(end_z, end_z0);  // released from rest: the free end falls
}

// A jointed double pendulum released horizontally: its initial energy is round-off (the mass
// centres' heights are cos(pi/2) L, about 3e-17), so a ratio to it would be a huge number.
// tests/data/horizontal_pendulum.yaml, the text of the model.
std::string horizontal_pendulum() {
  return test::slurp(KANEDYN_SOURCE_DIR "/tests/data/horizontal_pendulum.yaml");
}

TEST(Simulate, EnergyChangeIsMeasuredAgainstTheEnergyThatMoved) {
  const io::ModelFile file = io::parse_model_file(horizontal_pendulum(), "pendulum.yaml");
  const Model& model = file.model;
  SimulationSettings s;
  s.t_end = 2.0;
  // Rows farther apart than dopri5's steps here (about 0.01 at rtol 1e-8): each output is the
  // first of its step, where simulate() takes the energies too.
  s.dt_out = 0.05;
  // The scale by the definition (energy_scale), from the energies of the output states
  // computed here by the public functions of (q, z).
  double t_max = 0.0, v_min = std::numeric_limits<double>::infinity(), v_max = -v_min;
  Data scratch(model);
  const auto stats = simulate(model, file.q, file.z, s,
                              [&](double, const State&, const VectorX& q, const VectorX& z, Data&) {
                                t_max = std::max(t_max, kinetic_energy(model, q, z, scratch));
                                const double v = potential_energy(model, q, z, scratch);
                                v_min = std::min(v_min, v);
                                v_max = std::max(v_max, v);
                              });
  ASSERT_TRUE(stats.ok()) << stats.message;
  ASSERT_LT(std::abs(stats.energy_initial), 1e-12);    // the setting of the test: E0 ~ 0
  ASSERT_GT(stats.steps_accepted, 2 * stats.outputs);  // and its steps shorter than dt_out
  // The two links fall about 1.5 m in all: some 10 J move between the two kinds of energy.
  EXPECT_GT(t_max, 5.0);
  // The output times include the start and the end, where simulate() also takes the energies:
  // the same states, the same sums, to round-off of the order of 1e-16 x 15 J.
  EXPECT_NEAR(stats.energy_scale, std::max(t_max, v_max - v_min), 1e-13);
  EXPECT_EQ(stats.energy_change(), stats.energy_final - stats.energy_initial);
  EXPECT_EQ(stats.relative_energy_change(), stats.energy_change() / stats.energy_scale);
  // dopri5 at rtol 1e-8 keeps the energy to about 1e-7 of the energy that moves; a ratio to E0
  // would have been of the order of 1e+7.
  EXPECT_LT(std::abs(stats.relative_energy_change()), 1e-6) << stats.relative_energy_change();
}

TEST(Simulate, NoRelativeEnergyChangeWhenNothingMoves) {
  // The pendulum hanging at rest: the kinetic energy stays 0 and the potential energy at -9.81
  // x 2 J to round-off, so there is no scale and no ratio, only the absolute change.
  std::string text = horizontal_pendulum();
  text.replace(text.find("1.5707963267948966"), 18, "0.0");
  const io::ModelFile file = io::parse_model_file(text, "hanging.yaml");
  SimulationSettings s;
  s.t_end = 1.0;
  const auto stats = simulate(file.model, file.q, file.z, s);
  ASSERT_TRUE(stats.ok()) << stats.message;
  EXPECT_EQ(stats.energy_scale, 0.0);
  EXPECT_TRUE(std::isnan(stats.relative_energy_change()));
  EXPECT_LT(std::abs(stats.energy_change()), 1e-12);
}

}  // namespace
