// Simulation (simulate.hpp, io/csv.hpp, `kanedyn simulate`): conservation of energy and
// momentum, the Euler-parameter projection, output times, failures naming the time and the
// body, the trajectory CSV and its .partial protocol, and the command's exit codes.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/generate.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/simulate.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;

namespace {

using namespace kanedyn;

/// The notes' eight-body system of test_support with its bushings replaced: zero damping
/// (energy is conserved) or none on the root (a free system: momentum is conserved).
Model eight_body(Vector3 gravity, bool ground_bushing, double damping) {
  const Model base = test::eight_body_model(gravity, false);
  std::vector<std::shared_ptr<const ForceElement>> forces;
  for (int k = ground_bushing ? 0 : 1; k < 8; ++k)
    forces.push_back(std::make_shared<Bushing>(k, Vector3(200.0 + 10 * k, 150.0, 300.0 - 5 * k),
                                               damping * Vector3(2.0, 1.5, 3.0), 20.0 + k,
                                               damping * 0.5));
  return Model(base.bodies(), gravity, std::move(forces), "eight-body");
}

State moving_state(const Model& model, unsigned seed) {
  std::mt19937 rng(seed);
  return test::random_state(model, rng, 0.05, 1.5, 0.3);
}

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
  const auto stats = simulate(model, initial, s, [&](double t, const State& st, Data& data) {
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
  const auto stats = simulate(model, initial, s, [&](double t, const State& st, Data& data) {
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
    const auto stats = simulate(model, initial, s, [&](double, const State& st, Data&) {
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
    const auto stats = simulate(model, moving_state(model, 1), s,
                                [&](double t, const State&, Data&) { times.push_back(t); });
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
  for (const Method method : {Method::recursive, Method::kane}) {
    SimulationSettings s;
    s.integrator = Integrator::rk4;  // fixed steps: the same sequence of evaluations
    s.t_end = 1.0;
    s.dt_out = 0.25;
    s.method = method;
    simulate(model, initial, s,
             [&](double, const State& st, Data&) { states[route].push_back(st); });
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
  void apply(const Model&, const State&, Data& data) const override {
    if (data.p_G[static_cast<size_t>(k_)].z() < floor_)
      data.force[static_cast<size_t>(k_)].x() = std::nan("");
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
    const auto stats = simulate(model, State(model), s, [&](double, const State& st, Data&) {
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
      simulate(model, moving_state(model, 2), s, [&](double t, const State&, Data&) { last = t; });
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
  EXPECT_TRUE(simulate(model, initial, with([](auto& s) { s.t_end = 0; }),
                       [&](double, const State&, Data&) { ++outputs; })
                  .ok());
  EXPECT_EQ(outputs, 1);
}

// ---------------------------------------------------------------------------------------------
// CSV

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream in(text);
  while (std::getline(in, part, sep)) parts.push_back(part);
  if (!text.empty() && text.back() == sep) parts.emplace_back();
  return parts;
}

double parse(const std::string& s) {
  double v = 0.0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  EXPECT_EQ(r.ec, std::errc()) << s;
  EXPECT_EQ(r.ptr, s.data() + s.size()) << s;
  return v;
}

/// Rows of a CSV file; checks that every line is complete (ends with '\n') and has as many
/// fields as the header.
std::vector<std::vector<std::string>> read_csv(const fs::path& p) {
  const std::string text = slurp(p);
  EXPECT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n') << p;
  std::vector<std::vector<std::string>> rows;
  for (const std::string& line : split(text.substr(0, text.size() - 1), '\n')) {
    rows.push_back(split(line, ','));
    EXPECT_EQ(rows.back().size(), rows.front().size()) << "row " << rows.size() - 1;
  }
  return rows;
}

/// A fresh folder for one test, under the build folder (reused by the next run, so nothing
/// piles up in /tmp).
fs::path temp_dir(const std::string& name) {
  const fs::path dir = fs::path(KANEDYN_BINARY_DIR) / "tests" / "simulate_tmp" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(TrajectoryCsv, HeaderIsTheSpecifiedColumns) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const auto columns = io::trajectory_columns(model);
  ASSERT_EQ(columns.size(), 2u + 16u * 8u);
  EXPECT_EQ(columns.front(), "t");
  EXPECT_EQ(columns.back(), "energy");
  const char* expected[] = {"x",  "y",  "z",  "e1", "e2", "e3",  "e4",  "s1",
                            "s2", "s3", "w1", "w2", "w3", "sd1", "sd2", "sd3"};
  for (int k = 0; k < 8; ++k)
    for (int i = 0; i < 16; ++i)
      EXPECT_EQ(columns[static_cast<size_t>(1 + 16 * k + i)],
                "body" + std::to_string(k + 1) + "." + expected[i]);
}

TEST(TrajectoryCsv, RowsRoundTripAndFinishRenames) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const State state = moving_state(model, 4);
  Data data(model);
  compute_kinematics(model, state, data);
  const fs::path dir = temp_dir("roundtrip");
  const std::string path = (dir / "traj.csv").string();
  {
    io::TrajectoryWriter writer(model, path);
    EXPECT_TRUE(fs::exists(path + ".partial"));
    EXPECT_FALSE(fs::exists(path));
    writer.write_row(0.1, state, data, -1.0 / 3.0);
    writer.write_row(0.2, state, data, 1e-300);
    EXPECT_EQ(writer.rows(), 2);
    writer.finish();
  }
  EXPECT_FALSE(fs::exists(path + ".partial"));
  const auto rows = read_csv(path);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0], io::trajectory_columns(model));
  EXPECT_EQ(parse(rows[1][0]), 0.1);
  EXPECT_EQ(parse(rows[2].back()), 1e-300);
  EXPECT_EQ(parse(rows[1].back()), -1.0 / 3.0);  // bit for bit
  for (int k = 0; k < 8; ++k) {
    const auto& r = rows[1];
    const size_t o = 1 + 16 * static_cast<size_t>(k);
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(parse(r[o + i]), data.p_G[static_cast<size_t>(k)][i]);
      EXPECT_EQ(parse(r[o + 7 + i]), state.translation(k)[i]);
      EXPECT_EQ(parse(r[o + 10 + i]), state.angular_velocity(k)[i]);
      EXPECT_EQ(parse(r[o + 13 + i]), state.translation_rate(k)[i]);
    }
    for (int i = 0; i < 4; ++i) EXPECT_EQ(parse(r[o + 3 + i]), state.euler_parameters(k)[i]);
  }
}

TEST(TrajectoryCsv, EnergyOfTheKinematicsIsTotalEnergy) {
  // The command writes total_energy_of_kinematics (the kinematics simulate() computed for
  // the observer) where it wrote total_energy before: the same value, bit for bit.
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  Data a(model), b(model, DataOptions{false, false});
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const State state = moving_state(model, seed);
    const double reference = total_energy(model, state, a);
    compute_kinematics(model, state, b);
    EXPECT_EQ(total_energy_of_kinematics(model, state, b), reference);
  }
}

TEST(TrajectoryCsv, UnfinishedWriterLeavesOnlyThePartialFile) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const State state(model);
  Data data(model);
  compute_kinematics(model, state, data);
  const fs::path dir = temp_dir("unfinished");
  const std::string path = (dir / "traj.csv").string();
  {
    io::TrajectoryWriter writer(model, path);
    for (int i = 0; i < 3000; ++i) writer.write_row(i * 0.01, state, data, 0.0);  // > 64 KiB
  }  // destroyed without finish(), as when an exception unwinds
  EXPECT_FALSE(fs::exists(path));
  const auto rows = read_csv(path + ".partial");
  EXPECT_EQ(rows.size(), 3001u);
  EXPECT_THROW(io::TrajectoryWriter(model, (dir / "no-such-dir" / "x.csv").string()),
               std::runtime_error);
}

/// rows states of a moving system, as a trajectory would give them.
std::vector<State> some_states(const Model& model, int rows) {
  std::vector<State> states;
  for (int i = 0; i < rows; ++i) states.push_back(moving_state(model, 100 + i % 37));
  return states;
}

/// The file TrajectoryWriter writes for these rows, with the kinematics and energy the command
/// used to compute on its own thread.
std::string inline_writer_bytes(const Model& model, const std::vector<State>& states,
                                const std::string& path) {
  Data data(model, DataOptions{false, false});
  io::TrajectoryWriter writer(model, path);
  for (size_t i = 0; i < states.size(); ++i) {
    compute_kinematics(model, states[i], data);
    writer.write_row(0.01 * static_cast<double>(i), states[i], data,
                     total_energy_of_kinematics(model, states[i], data));
  }
  writer.finish();
  return slurp(path);
}

TEST(TrajectoryCsv, BackgroundWriterWritesTheSameBytes) {
  // The eight-body model queues up to 256 states, the 2048-body chain 19 (about 4 MB): 3000
  // and 120 rows go round each ring several times, with the producer waiting when it is full.
  const Model eight = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const Model chain = chain_model(2048).model;
  const fs::path dir = temp_dir("background");
  for (const auto& [model, rows] : {std::pair<const Model*, int>{&eight, 3000}, {&chain, 120}}) {
    const std::vector<State> states = some_states(*model, rows);
    const std::string expected = inline_writer_bytes(*model, states, (dir / "inline.csv").string());
    const std::string path = (dir / "background.csv").string();
    io::BackgroundTrajectoryWriter writer(*model, path);
    EXPECT_TRUE(fs::exists(path + ".partial"));  // with its header, at once
    for (size_t i = 0; i < states.size(); ++i) {
      writer.write_row(0.01 * static_cast<double>(i), states[i]);
      if (i % 500 == 7) writer.flush();
    }
    EXPECT_EQ(writer.rows(), rows);
    writer.finish();
    EXPECT_EQ(writer.rows(), rows);
    EXPECT_FALSE(fs::exists(path + ".partial"));
    EXPECT_EQ(slurp(path), expected) << model->num_bodies() << " bodies";
    EXPECT_THROW(writer.write_row(0.0, states[0]), std::logic_error);
  }
}

TEST(TrajectoryCsv, BackgroundWriterUnfinishedLeavesEveryQueuedRowInThePartialFile) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const std::vector<State> states = some_states(model, 1500);
  const fs::path dir = temp_dir("background_unfinished");
  const std::string path = (dir / "traj.csv").string();
  {
    io::BackgroundTrajectoryWriter writer(model, path);
    for (size_t i = 0; i < states.size(); ++i) writer.write_row(0.01 * i, states[i]);
  }  // destroyed without finish(), as when an exception unwinds
  EXPECT_FALSE(fs::exists(path));
  EXPECT_EQ(read_csv(path + ".partial").size(), 1501u);
  EXPECT_THROW(io::BackgroundTrajectoryWriter(model, (dir / "no-such-dir" / "x.csv").string()),
               std::runtime_error);
}

TEST(TrajectoryCsv, BackgroundWriterReportsAWriteErrorAndKeepsWholeRows) {
  // A file size limit makes write() fail (EFBIG) on the writer's thread, as a full disk would.
  // The error reaches the producer at its next call, names the file, and is thrown once more
  // by finish(); close() then does not repeat it, and the partial file ends with a whole row.
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const std::vector<State> states = some_states(model, 200);
  const fs::path dir = temp_dir("background_error");
  const std::string path = (dir / "traj.csv").string();
  constexpr rlim_t kLimit = 150000;  // about 55 rows of 2.7 KB
  struct rlimit old_limit {};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit limit = old_limit;
  limit.rlim_cur = kLimit;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &limit), 0);
  std::string message;
  long queued = 0;
  {
    io::BackgroundTrajectoryWriter writer(model, path);
    try {
      for (int round = 0; round < 100 && message.empty(); ++round)
        for (size_t i = 0; i < states.size(); ++i, ++queued) {
          writer.write_row(0.01 * queued, states[i]);
          if (i % 20 == 0) writer.flush();
        }
    } catch (const std::runtime_error& e) {
      message = e.what();
    }
    EXPECT_THROW(writer.finish(), std::runtime_error);
    EXPECT_NO_THROW(writer.close());
    EXPECT_LT(writer.rows(), queued);
  }
  setrlimit(RLIMIT_FSIZE, &old_limit);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_NE(message.find("cannot write '" + path + ".partial'"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(path));
  const std::string bytes = slurp(path + ".partial");
  ASSERT_FALSE(bytes.empty());
  EXPECT_LE(bytes.size(), kLimit);
  EXPECT_GT(read_csv(path + ".partial").size(), 1u);  // whole rows of the header's width
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
  const auto stats = run_example("tennis_racket.yaml", 0.0, [&](double t, const State& st, Data&) {
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
      run_example("double_pendulum.yaml", 2.0, [&](double, const State& st, Data& data) {
        for (int k = 0; k < 2; ++k) stretch = std::max(stretch, st.translation(k).norm());
        height_min = std::min(height_min, data.p_G[1].z());
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
  const auto stats = run_example("chain64.yaml", 0.1, [&](double t, const State&, Data& data) {
    (t == 0.0 ? end_z0 : end_z) = data.p_G[63].z();
  });
  ASSERT_TRUE(stats.ok()) << stats.message;
  EXPECT_LT(end_z, end_z0);  // released from rest: the free end falls
}

// ---------------------------------------------------------------------------------------------
// The command

struct Result {
  int exit_code;
  std::string out, err;
};

const std::string kTool = std::string(KANEDYN_BINARY_DIR) + "/kanedyn";
const std::string kExamples = std::string(KANEDYN_SOURCE_DIR) + "/examples";

/// Runs `cd DIR && SHELL_PREFIX kanedyn ARGS`.
Result run_in(const fs::path& dir, const std::string& args, const std::string& shell_prefix = "") {
  const std::string cmd = "cd '" + dir.string() + "' && " + shell_prefix + "'" + kTool + "' " +
                          args + " > stdout.txt 2> stderr.txt < /dev/null";
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(dir / "stdout.txt"),
          slurp(dir / "stderr.txt")};
}

TEST(SimulateCommand, WritesTheTrajectoryTheLibraryComputes) {
  const fs::path dir = temp_dir("cli_ok");
  const std::string model_path = kExamples + "/eight_body.yaml";
  const Result r = run_in(dir, "simulate '" + model_path + "' --t-end 0.5 --dt-out 0.1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Default output: the model file's name with .csv, in the current folder; no .partial left.
  ASSERT_TRUE(fs::exists(dir / "eight_body.csv"));
  EXPECT_FALSE(fs::exists(dir / "eight_body.csv.partial"));
  EXPECT_NE(r.out.find("trajectory: eight_body.csv (6 rows of 130 columns)"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("accepted"), std::string::npos);
  EXPECT_NE(r.out.find("derivative evaluations"), std::string::npos);
  EXPECT_NE(r.out.find("relative change"), std::string::npos);
  EXPECT_NE(r.out.find("Euler-parameter drift"), std::string::npos);
  EXPECT_EQ(r.err, "");  // stderr is not a terminal: no progress bar

  const auto file = io::load_model_file(model_path);
  const auto rows = read_csv(dir / "eight_body.csv");
  ASSERT_EQ(rows.size(), 7u);
  EXPECT_EQ(rows[0], io::trajectory_columns(file.model));
  // The same run through the library gives the same numbers, bit for bit.
  SimulationSettings s;
  s.t_end = 0.5;
  s.dt_out = 0.1;
  size_t row = 1;
  simulate(file.model, file.initial, s, [&](double t, const State& st, Data& data) {
    const double energy = total_energy(file.model, st, data);
    ASSERT_LT(row, rows.size());
    EXPECT_EQ(parse(rows[row][0]), t);
    EXPECT_EQ(parse(rows[row][1 + 16 * 7 + 11]), st.angular_velocity(7)[1]);  // left_forearm.w2
    EXPECT_EQ(parse(rows[row][3]), data.p_G[0].z());                          // torso.z
    EXPECT_EQ(parse(rows[row].back()), energy);
    ++row;
  });
  EXPECT_EQ(row, 7u);
}

TEST(SimulateCommand, FlagsWinOverTheModelFilesSimulationSection) {
  const fs::path dir = temp_dir("cli_settings");
  std::string text = slurp(kExamples + "/eight_body.yaml");
  const size_t at = text.find("simulation:");
  ASSERT_NE(at, std::string::npos);
  text = text.substr(0, at) +
         "simulation:\n  t_end: 0.2\n  dt_out: 0.1\n  integrator: rk4\n  step: 0.002\n";
  std::ofstream(dir / "m.yaml") << text;
  Result r = run_in(dir, "simulate m.yaml");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("integrator rk4"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("100 accepted"), std::string::npos) << r.out;  // 0.2 / 0.002
  EXPECT_EQ(read_csv(dir / "m.csv").size(), 4u);                      // header + 0, 0.1, 0.2
  r = run_in(dir, "simulate m.yaml --t-end 0.3 --integrator dopri5 --out other.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("integrator dopri5 (rtol 1e-08, atol 1e-10)"), std::string::npos) << r.out;
  EXPECT_EQ(read_csv(dir / "other.csv").size(), 5u);
}

TEST(SimulateCommand, FailureKeepsThePartialFileAndExitsNonzero) {
  // A stiff bushing (1000 rad/s) with rk4 steps of 0.01 s: far outside RK4's stability
  // region, the state grows ~400x per step and overflows after about 1.2 s.
  const fs::path dir = temp_dir("cli_blowup");
  std::ofstream(dir / "blowup.yaml") << R"(format: kanedyn-model/1
bodies:
  - name: rattler
    parent: ground
    mass: 1.0
    inertia: [0.1, 0.1, 0.1]
    initial: {translation: [0.01, 0, 0]}
forces:
  - {type: bushing, body: rattler, stiffness: 1.0e6, damping: 0,
     rotational_stiffness: 0, rotational_damping: 0}
)";
  const Result r =
      run_in(dir, "simulate blowup.yaml --integrator rk4 --step 0.01 --dt-out 0.01 --t-end 5");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_FALSE(fs::exists(dir / "blowup.csv"));
  ASSERT_TRUE(fs::exists(dir / "blowup.csv.partial"));
  EXPECT_NE(r.err.find("kanedyn: error: non-finite state in the step from t = "), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("body 'rattler'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("kept in blowup.csv.partial"), std::string::npos) << r.err;
  const auto rows = read_csv(dir / "blowup.csv.partial");  // whole rows only
  EXPECT_GT(rows.size(), 50u);
  // Every field is a number; the states are finite (the energy, quadratic in them, may
  // overflow near the end); times increase by dt_out.
  for (size_t i = 1; i < rows.size(); ++i) {
    for (size_t j = 0; j + 1 < rows[i].size(); ++j)
      EXPECT_TRUE(std::isfinite(parse(rows[i][j]))) << "row " << i << " column " << j;
    parse(rows[i].back());
    EXPECT_NEAR(parse(rows[i][0]), 0.01 * static_cast<double>(i - 1), 1e-12);
  }
}

TEST(SimulateCommand, WriteErrorStopsTheRunAndKeepsWholeRows) {
  // A file size limit (ulimit -f: 100 or 200 KB, in the shell's blocks) stands in for a full
  // disk: the writer's thread gets EFBIG (the command ignores SIGXFSZ), the run stops with
  // the file's name, and the partial file holds the whole rows the message counts.
  const fs::path dir = temp_dir("cli_write_error");
  const Result r = run_in(dir, "simulate '" + kExamples + "/eight_body.yaml'", "ulimit -f 200 && ");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("kanedyn: error: cannot write 'eight_body.csv.partial'"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir / "eight_body.csv"));
  const auto rows = read_csv(dir / "eight_body.csv.partial");  // whole rows only
  ASSERT_GT(rows.size(), 1u);
  EXPECT_LT(rows.size(), 1002u);
  EXPECT_NE(r.err.find("partial trajectory (" + std::to_string(rows.size() - 1) +
                       " rows) kept in eight_body.csv.partial"),
            std::string::npos)
      << r.err;
}

TEST(SimulateCommand, UsageAndSettingErrors) {
  const fs::path dir = temp_dir("cli_usage");
  const std::string model = "'" + kExamples + "/eight_body.yaml'";
  Result r = run_in(dir, "simulate " + model + " --integrator euler");
  EXPECT_GE(r.exit_code, 2);
  r = run_in(dir, "simulate " + model + " --t-end -1");
  EXPECT_GE(r.exit_code, 2);
  r = run_in(dir, "simulate " + model + " --rtol 0 --atol 0");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("rtol and atol"), std::string::npos) << r.err;
  r = run_in(dir, "simulate no-such-model.yaml");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no-such-model.yaml"), std::string::npos) << r.err;
  // None of these started a run, so none left a file behind.
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_NE(entry.path().extension(), ".partial") << entry.path();
  EXPECT_FALSE(fs::exists(dir / "eight_body.csv"));
}

TEST(SimulateCommand, SigtermKeepsThePartialFile) {
  const fs::path dir = temp_dir("cli_sigterm");
  const std::string model = kExamples + "/chain64.yaml";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    if (chdir(dir.c_str()) != 0) _exit(99);
    const int out = open("stdout.txt", O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = open("stderr.txt", O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (out < 0 || err < 0 || dup2(out, 1) < 0 || dup2(err, 2) < 0) _exit(97);
    execl(kTool.c_str(), "kanedyn", "simulate", model.c_str(), "--t-end", "1e6", "--dt-out",
          "0.001", static_cast<char*>(nullptr));
    _exit(98);
  }
  // Wait until the run has begun (the header is written at once), then a little more.
  const fs::path partial = dir / "chain64.csv.partial";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!fs::exists(partial) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_EQ(kill(pid, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGTERM);
  EXPECT_FALSE(fs::exists(dir / "chain64.csv"));
  ASSERT_TRUE(fs::exists(partial));
  const auto rows = read_csv(partial);
  EXPECT_GE(rows.size(), 2u);  // the header and at least the row at t = 0
  EXPECT_EQ(rows[0].size(), 2u + 16u * 64u);
  const std::string err = slurp(dir / "stderr.txt");
  EXPECT_NE(err.find("kanedyn: SIGTERM: interrupted at t = "), std::string::npos) << err;
  EXPECT_NE(err.find("kept in chain64.csv.partial"), std::string::npos) << err;
}

}  // namespace
