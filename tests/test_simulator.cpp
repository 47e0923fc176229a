// The step API (simulator.hpp) against simulate(): steps with held inputs are the run of an
// input table or a sampled-data controller of the same values; failures, and no allocation.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/simulate.hpp"
#include "kanedyn/simulator.hpp"

namespace kanedyn {
namespace {

// A cart on a rail carrying a pendulum: joint, force and torque inputs on a jointed model.
const char* kCartPole = R"(format: kanedyn-model/1
name: cart_pole
gravity: [0, 0, -9.81]
bodies:
  - {name: cart, parent: ground, mass: 2, inertia: [0.02, 0.05, 0.06],
     joint: {type: prismatic, axis: [1, 0, 0]}}
  - name: pole
    parent: cart
    mass: 0.5
    inertia: [0.0168, 0.0168, 0.0002]
    com: [0, 0, -0.3]
    joint: {type: revolute, axis: [0, 1, 0]}
    initial: {joint: [0.5], joint_rate: [0.2]}
inputs:
  - {name: push, type: joint, body: cart}
  - {name: thrust, type: force, body: pole, direction: [1, 0, 0]}
  - {name: twist, type: torque, body: pole, axis: [0, 1, 0], reaction: true}
)";

// Two free bodies on a bushing, driven by a force and a torque: the notes' layout.
const char* kFreePair = R"(format: kanedyn-model/1
name: free_pair
gravity: [0, 0, -9.81]
bodies:
  - {name: base, parent: ground, mass: 3, inertia: [0.1, 0.2, 0.3]}
  - name: arm
    parent: base
    mass: 1
    inertia: [0.05, 0.04, 0.03]
    joint: [0.2, 0, 0]
    initial: {angular_velocity: [0.3, -0.2, 0.5]}
forces:
  - {type: bushing, body: arm, stiffness: 400, damping: 2, rotational_stiffness: 30,
     rotational_damping: 0.1}
inputs:
  - {name: lift, type: force, body: base, direction: [0, 0, 1]}
  - {name: spin, type: torque, body: arm, axis: [0, 0, 1], reaction: true}
)";

// dt a power of two: t_start + i dt (simulate's control instants and output times) and the
// sum of i steps of dt are then the same doubles, so equal runs mean equal bits.
constexpr double kDt = 1.0 / 64.0;
constexpr int kSteps = 40;

// The inputs of step i: smooth in i, with jumps between steps.
VectorX inputs_at(int m, int i) {
  VectorX u(m);
  for (int j = 0; j < m; ++j) u[j] = 3.0 * std::sin(0.7 * i + 1.3 * j) + 0.5 * j;
  return u;
}

struct Row {
  double t;
  VectorX q, z, u;
};

std::vector<Row> run_simulate(const io::ModelFile& f, SimulationSettings s) {
  std::vector<Row> rows;
  const SimulationStats stats =
      simulate(f.model, f.q, f.z, s,
               [&](double t, const State&, const VectorX& q, const VectorX& z, Data& data) {
                 rows.push_back({t, q, z, data.inputs});
               });
  EXPECT_TRUE(stats.ok()) << stats.message;
  return rows;
}

SimulationSettings settings_for(Integrator integrator) {
  SimulationSettings s;
  s.integrator = integrator;
  s.t_end = kSteps * kDt;
  s.dt_out = kDt;
  s.step = kDt;
  s.rtol = 1e-9;
  s.atol = 1e-11;
  return s;
}

// The steps against simulate()'s rows: the same bits at every step's end.
void expect_steps_equal(const io::ModelFile& f, const SimulationSettings& settings,
                        const std::vector<Row>& rows) {
  ASSERT_EQ(rows.size(), static_cast<size_t>(kSteps + 1));
  SimulationSettings plain = settings;
  plain.inputs = nullptr;
  plain.controller = nullptr;
  plain.control_interval = 0.0;
  Simulator sim(f.model, f.q, f.z, plain);
  EXPECT_EQ(sim.q(), rows[0].q);
  EXPECT_EQ(sim.z(), rows[0].z);
  for (int i = 0; i < kSteps; ++i) {
    sim.step(inputs_at(f.model.num_inputs(), i), kDt);
    const Row& r = rows[static_cast<size_t>(i + 1)];
    ASSERT_EQ(sim.time(), r.t) << "step " << i;
    ASSERT_EQ(sim.q(), r.q) << "step " << i;
    ASSERT_EQ(sim.z(), r.z) << "step " << i;
    // The row at the end of step i holds the next step's values (the table's next row).
    if (i + 1 < kSteps) {
      EXPECT_EQ(r.u, inputs_at(f.model.num_inputs(), i + 1));
    }
  }
}

std::shared_ptr<const InputTable> table_of(int m) {
  std::vector<double> times;
  MatrixX values(kSteps, m);
  for (int i = 0; i < kSteps; ++i) {
    times.push_back(i * kDt);
    values.row(i) = inputs_at(m, i).transpose();
  }
  return std::make_shared<const InputTable>(times, values, InputHold::zero_order);
}

// A sampled-data controller with the table's values: step index round(t / dt).
Controller controller_of(int m) {
  return [m](double t, const VectorX&, const VectorX&, Eigen::Ref<VectorX> u) {
    u = inputs_at(m, static_cast<int>(std::lround(t / kDt)));
  };
}

TEST(Simulator, Rk4StepsAreSimulateWithAnInputTable) {
  for (const char* text : {kCartPole, kFreePair}) {
    const io::ModelFile f = io::parse_model_file(text, "model.yaml");
    SimulationSettings s = settings_for(Integrator::rk4);
    s.inputs = table_of(f.model.num_inputs());
    expect_steps_equal(f, s, run_simulate(f, s));
  }
}

TEST(Simulator, Rk4StepsAreSimulateWithASampledController) {
  for (const char* text : {kCartPole, kFreePair}) {
    const io::ModelFile f = io::parse_model_file(text, "model.yaml");
    SimulationSettings s = settings_for(Integrator::rk4);
    s.controller = controller_of(f.model.num_inputs());
    s.control_interval = kDt;
    expect_steps_equal(f, s, run_simulate(f, s));
  }
}

// dopri5 restarts at each control instant in simulate() as at each step here: the same steps,
// the same bits, and the same number of evaluations.
TEST(Simulator, Dopri5StepsAreSimulateWithASampledController) {
  for (const char* text : {kCartPole, kFreePair}) {
    const io::ModelFile f = io::parse_model_file(text, "model.yaml");
    SimulationSettings s = settings_for(Integrator::dopri5);
    s.controller = controller_of(f.model.num_inputs());
    s.control_interval = kDt;
    const std::vector<Row> rows = run_simulate(f, s);
    expect_steps_equal(f, s, rows);

    SimulationSettings plain = settings_for(Integrator::dopri5);
    Simulator sim(f.model, f.q, f.z, plain);
    for (int i = 0; i < kSteps; ++i) sim.step(inputs_at(f.model.num_inputs(), i), kDt);
    const SimulationStats stats = simulate(f.model, f.q, f.z, s);
    EXPECT_EQ(sim.evaluations(), stats.evaluations);
    EXPECT_EQ(sim.steps(), stats.steps_accepted);
    EXPECT_GT(sim.steps(), kSteps);  // several steps per interval: the error control worked
  }
}

TEST(Simulator, NotesStateAndInputsFollowTheSteps) {
  const io::ModelFile f = io::parse_model_file(kFreePair, "model.yaml");
  Simulator sim(f.model, f.q, f.z, settings_for(Integrator::rk4));
  EXPECT_EQ(sim.inputs(), VectorX::Zero(2));
  const VectorX u = inputs_at(2, 3);
  sim.step(u, kDt);
  EXPECT_EQ(sim.inputs(), u);
  EXPECT_EQ(sim.evaluations(), 4);  // one rk4 step
  // An all-free model's q is the notes' x body by body: eps_1 leads both.
  EXPECT_EQ(sim.state().x.head<4>(), sim.q().head<4>());
  EXPECT_EQ(sim.state().y.head<3>(), sim.z().head<3>());
  // Back to the start: the same step gives the same bits again.
  const VectorX q1 = sim.q(), z1 = sim.z();
  sim.set_state(f.q, f.z, 0.0);
  EXPECT_EQ(sim.time(), 0.0);
  sim.step(u, kDt);
  EXPECT_EQ(sim.q(), q1);
  EXPECT_EQ(sim.z(), z1);
}

long allocations_of(const std::function<void()>& work) {
  alloc_counter::count = 0;
  alloc_counter::counting = true;
  work();
  alloc_counter::counting = false;
  return alloc_counter::count.load();
}

TEST(Simulator, NoAllocationAfterTheFirstStep) {
  // The counter sees a vector's allocation (where malloc is interposed; see alloc_counter.hpp).
  if (alloc_counter::available()) {
    EXPECT_GT(allocations_of([] { VectorX v = VectorX::Zero(100); }), 0);
  }
  for (const char* text : {kCartPole, kFreePair})
    for (const Integrator integrator : {Integrator::rk4, Integrator::dopri5}) {
      const io::ModelFile f = io::parse_model_file(text, "model.yaml");
      Simulator sim(f.model, f.q, f.z, settings_for(integrator));
      const int m = f.model.num_inputs();
      const VectorX u0 = inputs_at(m, 0), u1 = inputs_at(m, 1);
      sim.step(u0, kDt);
      (void)sim.q();
      const long count = allocations_of([&] {
        for (int i = 0; i < 10; ++i) {
          sim.step(i % 2 ? u1 : u0, kDt);
          (void)sim.q();
          (void)sim.state();
        }
      });
      EXPECT_EQ(count, 0) << f.model.name() << " " << to_string(integrator);
    }
}

TEST(Simulator, RefusesBadArguments) {
  const io::ModelFile f = io::parse_model_file(kCartPole, "model.yaml");
  Simulator sim(f.model, f.q, f.z, settings_for(Integrator::rk4));
  EXPECT_THROW(sim.step(VectorX::Zero(2), kDt), std::invalid_argument);
  EXPECT_THROW(sim.step(VectorX::Zero(3), 0.0), std::invalid_argument);
  EXPECT_THROW(sim.step(VectorX::Zero(3), -kDt), std::invalid_argument);
  EXPECT_THROW(sim.step(VectorX::Zero(3), std::nan("")), std::invalid_argument);
  EXPECT_THROW(sim.step(VectorX::Constant(3, INFINITY), kDt), std::invalid_argument);
  EXPECT_EQ(sim.time(), 0.0);
  EXPECT_THROW(Simulator(f.model, f.q, VectorX::Zero(5), {}), std::invalid_argument);
  VectorX z = f.z;
  z[0] = std::nan("");
  EXPECT_THROW(Simulator(f.model, f.q, z, {}), std::invalid_argument);
  SimulationSettings with_table = settings_for(Integrator::rk4);
  with_table.inputs = table_of(3);
  EXPECT_THROW(Simulator(f.model, f.q, f.z, with_table), std::invalid_argument);
  SimulationSettings bad_tolerance;
  bad_tolerance.rtol = -1.0;
  EXPECT_THROW(Simulator(f.model, f.q, f.z, bad_tolerance), std::invalid_argument);
}

// A torque of 1e300 on the pole (axial moment of inertia 2e-4, but it turns about y: 0.0168 +
// 0.5 * 0.3^2) drives its rate past 1e150 within one step: both integrators fail, naming the
// time and a body, and leave the state of the start of the step.
TEST(Simulator, FailureNamesTimeAndBodyAndKeepsTheState) {
  const io::ModelFile f = io::parse_model_file(kCartPole, "model.yaml");
  for (const Integrator integrator : {Integrator::rk4, Integrator::dopri5}) {
    Simulator sim(f.model, f.q, f.z, settings_for(integrator));
    sim.step(inputs_at(3, 0), kDt);
    const VectorX q = sim.q(), z = sim.z();
    const double t = sim.time();
    VectorX u = VectorX::Zero(3);
    u[2] = 1e300;
    try {
      sim.step(u, kDt);
      ADD_FAILURE() << "no failure with " << to_string(integrator);
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("t = 0.015625"), std::string::npos) << what;
      EXPECT_NE(what.find("body '"), std::string::npos) << what;
    }
    EXPECT_EQ(sim.time(), t);
    EXPECT_EQ(sim.q(), q);
    EXPECT_EQ(sim.z(), z);
    // It goes on from there.
    sim.step(inputs_at(3, 1), kDt);
    EXPECT_EQ(sim.time(), 2 * kDt);
  }
}

// on_step stops a long dopri5 interval between its steps (how Python sees Ctrl-C in step()):
// the step throws, keeps the state of its start, and the simulator goes on from there.
TEST(Simulator, OnStepStopsALongIntervalAndKeepsTheState) {
  const io::ModelFile f = io::parse_model_file(kCartPole, "model.yaml");
  SimulationSettings s = settings_for(Integrator::dopri5);
  int asked = 0;
  double last = 0.0;
  s.on_step = [&](double t) {
    last = t;
    return ++asked < 5;
  };
  Simulator sim(f.model, f.q, f.z, s);
  const VectorX q = sim.q(), z = sim.z();
  try {
    sim.step(inputs_at(3, 0), 100.0);
    ADD_FAILURE() << "not stopped";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("interrupted in the step from t = 0 to t = 100"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(asked, 5);
  EXPECT_GT(last, 0.0);
  EXPECT_LT(last, 100.0);
  EXPECT_EQ(sim.time(), 0.0);
  EXPECT_EQ(sim.q(), q);
  EXPECT_EQ(sim.z(), z);
  asked = -1000000;  // no more stops
  sim.step(inputs_at(3, 0), kDt);
  EXPECT_EQ(sim.time(), kDt);
}

}  // namespace
}  // namespace kanedyn
