// The point-to-point spring-damper (`type: spring`, forces.hpp): its law as
// docs/model-format.md ("Force laws, exactly") states it, worked by hand; the same loads as a
// bushing where the two coincide (a second formulation); energy and momentum conserved in a
// free tumbling pair (physics); a mass bouncing on it against the closed form; its derivatives
// exact with no code of its own (central differences); the model file's keys, refusals and
// writer; the zero-length failure of a run.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "kanedyn/analysis.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/model_writer.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/simulate.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

BodySpec block(const std::string& name, int lower, double mass, const Vector3& joint,
               const Vector3& com = Vector3::Zero()) {
  BodySpec b;
  b.name = name;
  b.lower_body = lower;
  b.mass = mass;
  b.inertia = Vector3(0.2, 0.3, 0.4).asDiagonal() * mass;
  b.com = com;
  b.joint = joint;
  return b;
}

Loads loads_at(const Model& model, const State& state) {
  Data data(model);
  compute_kinematics(model, state, data);
  compute_resultants(model, state, data);
  return data.loads;
}

// A root body at rest at O_K = (1, 2, 3), axes turned 90 deg about z, G_K = O_K + (0.1, 0, 0)
// in body axes; P = O_K + (0, 0.5, 0) in body axes = (1, 2, 3) + (-0.5, 0, 0) inertial
// = (0.5, 2, 3). P' fixed in the ground at (0.5, 2, 5): d = (0, 0, 2), L = 2, u = e_z.
// k = 10, L0 = 0.5: F = 10 * 1.5 e_z = (0, 0, 15) on K at P. Moving with s' dot = (0, 0, -1)
// (dL/dt = +1) and c = 3: F = (10 * 1.5 + 3 * 1) e_z = (0, 0, 18). The moment about G_K
// (inertial): (P - G_K) x F with G_K = (1, 2.1, 3): P - G = (-0.5, -0.1, 0), so
// (-0.5, -0.1, 0) x (0, 0, 18) = (-1.8, 9, 0) inertial; in body axes (turned 90 deg about z:
// x_b = y_in, y_b = -x_in) (9, 1.8, 0).
TEST(Spring, LawByHand) {
  const Model model({block("k", kGround, 2.0, Vector3(1, 2, 3), Vector3(0.1, 0, 0))},
                    Vector3::Zero(),
                    {std::make_shared<Spring>(0, Vector3(0, 0.5, 0), kGround, Vector3(0.5, 2, 5),
                                              10.0, 3.0, 0.5)});
  State state(1);
  state.euler_parameters(0) =
      Vector4(0, 0, std::sin(std::numbers::pi / 4), std::cos(std::numbers::pi / 4));
  state.translation_rate(0) = Vector3(0, 0, -1);
  const Loads loads = loads_at(model, state);
  EXPECT_LE((loads.force[0] - Vector3(0, 0, 18)).norm(), 1e-13);
  EXPECT_LE((loads.moment_b[0] - Vector3(9, 1.8, 0)).norm(), 1e-13);
  Data data(model);
  compute_kinematics(model, state, data);
  // Potential 1/2 k (L - L0)^2 = 11.25; damping power c (dL/dt)^2 = 3.
  EXPECT_NEAR(model.forces()[0]->potential_energy(model, state, data.kinematics), 11.25, 1e-13);
  EXPECT_NEAR(model.forces()[0]->damping_power(model, state, data.kinematics), 3.0, 1e-13);
}

// With `at` = O_K, P' where O_K sits at s' = 0 and L0 = c = 0, the spring's force k d = -k s'
// at O_K is a bushing's translational law with k1 = k2 = k3 = k (its J the ground or a body):
// the same loads at random states of a two-body chain.
TEST(Spring, EqualsAnIsotropicBushingWhereTheyCoincide) {
  std::mt19937 rng(3);
  const Vector3 joint0(0.2, -0.1, 0.4), joint1(0.3, 0.2, -0.5);
  const std::vector<BodySpec> bodies = {block("a", kGround, 1.5, joint0, Vector3(0.1, 0.05, 0)),
                                        block("b", 0, 0.7, joint1, Vector3(0, -0.1, 0.2))};
  // P' on body a at b's joint point q'_b (a's body axes, from O_a).
  const Model springs(bodies, Vector3(0, 0, -9.81),
                      {std::make_shared<Spring>(0, Vector3::Zero(), kGround, joint0, 40.0, 0, 0),
                       std::make_shared<Spring>(1, Vector3::Zero(), 0, joint1, 25.0, 0, 0)});
  const Model bushings(
      bodies, Vector3(0, 0, -9.81),
      {std::make_shared<Bushing>(0, Vector3::Constant(40.0), Vector3::Zero(), 0, 0),
       std::make_shared<Bushing>(1, Vector3::Constant(25.0), Vector3::Zero(), 0, 0)});
  for (int trial = 0; trial < 20; ++trial) {
    const State state = test::random_state(springs, rng);
    const Loads a = loads_at(springs, state), b = loads_at(bushings, state);
    for (int k = 0; k < 2; ++k) {
      EXPECT_LE((a.force[k] - b.force[k]).norm(), 1e-12 * (1 + b.force[k].norm()));
      EXPECT_LE((a.moment_b[k] - b.moment_b[k]).norm(), 1e-12 * (1 + b.moment_b[k].norm()));
    }
    // And through the whole dynamics (the spring takes the staged route, the bushing the fused
    // kernel): the same accelerations.
    VectorX ya(12), yb(12);
    Dynamics da(springs), db(bushings);
    VectorX qa, za;
    joint_coordinates(springs, state, qa, za);
    da.forward(qa, za, VectorX(), ya);
    db.forward(qa, za, VectorX(), yb);
    EXPECT_LE((ya - yb).cwiseAbs().maxCoeff(), 1e-11 * (1 + yb.cwiseAbs().maxCoeff()));
  }
}

// Two free bodies joined by an undamped spring between off-centre points, no gravity, tumbling:
// no external load, so the total energy, the linear and the angular momentum are constant; at
// rtol 1e-10 they hold to 1e-8 relative (the integrator's error, not round-off).
TEST(Spring, APairTumblingConservesEnergyAndMomentum) {
  const Model model({block("a", kGround, 1.0, Vector3::Zero()),
                     block("b", kGround, 2.5, Vector3(1, 0, 0), Vector3(0.05, 0.1, 0))},
                    Vector3::Zero(),
                    {std::make_shared<Spring>(0, Vector3(0.2, 0.1, -0.1), 1, Vector3(-0.1, 0.3, 0),
                                              80.0, 0.0, 0.6)});
  State s(2);
  s.angular_velocity(0) = Vector3(1.0, -2.0, 0.5);
  s.angular_velocity(1) = Vector3(-0.3, 0.8, 1.5);
  s.translation_rate(0) = Vector3(0.2, 0.1, -0.3);
  s.translation_rate(1) = Vector3(-0.1, 0.4, 0.2);
  Data data(model);
  const double e0 = total_energy(model, s, data);
  const Vector3 p0 = linear_momentum(model, s, data), h0 = angular_momentum(model, s, data);
  SimulationSettings settings;
  settings.t_end = 3.0;
  settings.dt_out = 0.5;
  settings.rtol = 1e-10;
  settings.atol = 1e-12;
  double worst_e = 0, worst_p = 0, worst_h = 0;
  const SimulationStats stats = simulate(
      model, s, settings, [&](double, const State& st, const VectorX&, const VectorX&, Data& d) {
        worst_e = std::max(worst_e, std::abs(total_energy(model, st, d) - e0));
        worst_p = std::max(worst_p, (linear_momentum(model, st, d) - p0).norm());
        worst_h = std::max(worst_h, (angular_momentum(model, st, d) - h0).norm());
      });
  ASSERT_TRUE(stats.ok()) << stats.message;
  EXPECT_LE(worst_e, 1e-8 * std::abs(e0));
  EXPECT_LE(worst_p, 1e-8 * (1 + p0.norm()));
  EXPECT_LE(worst_h, 1e-8 * (1 + h0.norm()));
  EXPECT_GT(stats.energy_scale, 0.1 * std::abs(e0));  // the spring did work
}

// A body hanging from a ground point by a spring, moving along the vertical line: z'' =
// -(k/m)(z - z_eq), z_eq = P'_z - L0 - m g / k, so z(t) = z_eq + (z0 - z_eq) cos(sqrt(k/m) t),
// to the integrator's tolerance (L stays between 0.15 and 0.5: the body never reaches P').
TEST(Spring, ABodyBouncesAtItsNaturalFrequency) {
  const double m = 0.5, k = 200.0, g = 9.81, L0 = 0.3, top = 2.0, z0 = 1.5;
  const Model model(
      {block("bob", kGround, m, Vector3::Zero())}, Vector3(0, 0, -g),
      {std::make_shared<Spring>(0, Vector3::Zero(), kGround, Vector3(0, 0, top), k, 0.0, L0)});
  State s(1);
  s.translation(0) = Vector3(0, 0, z0);
  const double z_eq = top - L0 - m * g / k, omega = std::sqrt(k / m);
  SimulationSettings settings;
  settings.t_end = 1.0;
  settings.dt_out = 0.05;
  settings.rtol = 1e-11;
  settings.atol = 1e-13;
  double worst = 0;
  const SimulationStats stats = simulate(
      model, s, settings, [&](double t, const State& st, const VectorX&, const VectorX&, Data&) {
        const double expected = z_eq + (z0 - z_eq) * std::cos(omega * t);
        worst = std::max(worst, std::abs(st.translation(0).z() - expected));
      });
  ASSERT_TRUE(stats.ok()) << stats.message;
  EXPECT_LE(worst, 1e-8);
}

// The derivatives of a jointed model with springs between random points of random bodies are
// the dual numbers' (analytic), with no code for the spring beyond its law, and agree with
// central differences of the forward dynamics to 1e-6 of each block's scale.
TEST(Spring, DerivativesAreAnalyticAndMatchCentralDifferences) {
  std::mt19937 rng(21);
  for (int trial = 0; trial < 6; ++trial) {
    const Model base = test::random_jointed(rng, true);
    std::vector<std::shared_ptr<const ForceElement>> forces = base.forces();
    for (int i = 0; i < 3; ++i) {
      const int a = test::uniform_int(rng, 0, base.num_bodies() - 1);
      int b = test::uniform_int(rng, -1, base.num_bodies() - 1);
      if (b == a) b = kGround;
      const Vector3 at = test::random_vector(rng, -0.3, 0.3);
      const Vector3 other_at = test::random_vector(rng, -2, 2);
      const double stiffness = test::uniform(rng, 5, 50), damping = test::uniform(rng, 0, 2);
      forces.push_back(std::make_shared<Spring>(a, at, b, other_at, stiffness, damping, 0.1));
    }
    const Model model = test::rebuilt(base, forces, {});
    VectorX q, z;
    test::random_joint_state(model, rng, q, z);
    Derivatives derivatives(model);
    ASSERT_TRUE(derivatives.analytic()) << derivatives.method();
    const int n = model.num_speeds();
    MatrixX dq(n, n), dz(n, n), du(n, 0);
    derivatives.forward(q, z, VectorX(), dq, dz, du);
    // Central differences in the tangent coordinates (the exponential map for rotation
    // entries: Derivatives' own convention, checked against it in test_analysis.cpp).
    const double h = 1e-6;
    Dynamics dynamics(model);
    VectorX plus(n), minus(n);
    MatrixX fq(n, n), fz(n, n);
    for (int c = 0; c < n; ++c) {
      VectorX dv = VectorX::Zero(n);
      dv[c] = h;
      dynamics.forward(retract(model, q, dv), z, VectorX(), plus);
      dynamics.forward(retract(model, q, -dv), z, VectorX(), minus);
      fq.col(c) = (plus - minus) / (2 * h);
      VectorX zp = z, zm = z;
      zp[c] += h;
      zm[c] -= h;
      dynamics.forward(q, zp, VectorX(), plus);
      dynamics.forward(q, zm, VectorX(), minus);
      fz.col(c) = (plus - minus) / (2 * h);
    }
    const double sq = std::max(1.0, fq.cwiseAbs().maxCoeff());
    const double sz = std::max(1.0, fz.cwiseAbs().maxCoeff());
    EXPECT_LE((dq - fq).cwiseAbs().maxCoeff(), 1e-6 * sq) << "trial " << trial;
    EXPECT_LE((dz - fz).cwiseAbs().maxCoeff(), 1e-6 * sz) << "trial " << trial;
  }
}

// A spring whose points meet, with a rest length, has no direction: the run fails with the
// spring's bodies and the time named.
TEST(Spring, ZeroLengthWithARestLengthFailsTheRunNamingIt) {
  const Model model(
      {block("bob", kGround, 1.0, Vector3::Zero())}, Vector3::Zero(),
      {std::make_shared<Spring>(0, Vector3::Zero(), kGround, Vector3::Zero(), 10.0, 0.0, 0.5)});
  SimulationSettings settings;
  settings.t_end = 0.1;
  try {
    simulate(model, State(1), settings);
    FAIL() << "no error";
  } catch (const SpringLengthError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("after t = 0"), std::string::npos) << what;
    EXPECT_NE(what.find("the spring between bob and ground"), std::string::npos) << what;
  }
  // With L0 = c = 0 the force k d is defined there: the body stays at rest.
  const Model linear(
      {block("bob", kGround, 1.0, Vector3::Zero())}, Vector3::Zero(),
      {std::make_shared<Spring>(0, Vector3::Zero(), kGround, Vector3::Zero(), 10.0, 0.0, 0.0)});
  EXPECT_TRUE(simulate(linear, State(1), settings).ok());
}

// examples/springs.yaml: two blocks on three undamped springs, swinging, bouncing and turning;
// its energy (with the springs' potentials) holds to 1e-8 of the energy that moves at rtol
// 1e-10 (the integrator's error; round-off is 1e-15 of it).
TEST(Spring, TheExampleConservesItsEnergy) {
  const io::ModelFile file = io::load_model_file(KANEDYN_SOURCE_DIR "/examples/springs.yaml");
  SimulationSettings settings = io::simulation_settings(file.simulation);
  settings.t_end = 2.0;
  settings.rtol = 1e-10;
  settings.atol = 1e-12;
  const SimulationStats stats = simulate(file.model, file.q, file.z, settings);
  ASSERT_TRUE(stats.ok()) << stats.message;
  EXPECT_GT(stats.energy_scale, 0.1);  // it moves
  EXPECT_LE(std::abs(stats.relative_energy_change()), 1e-8);
}

const char* kSpringFile = R"(format: kanedyn-model/1
bodies:
  - name: a
    parent: ground
    mass: 1.0
    inertia: [0.1, 0.1, 0.1]
  - name: b
    parent: a
    mass: 2.0
    inertia: [0.2, 0.2, 0.2]
    joint: [0, 0, -1]
forces:
  - type: spring
    body: b
    at: [0, 0, -0.1]
    other: a
    other_at: [0.1, 0, 0.2]
    stiffness: 200.0
    damping: 2.0
    rest_length: 0.3
  - type: spring
    body: a
    stiffness: 5.0
)";

TEST(Spring, ModelFileKeysDefaultsAndTheWriterRoundTrip) {
  const io::ModelFile file = io::parse_model_file(kSpringFile, "springs.yaml");
  ASSERT_EQ(file.model.forces().size(), 2u);
  const auto* s = dynamic_cast<const Spring*>(file.model.forces()[0].get());
  ASSERT_NE(s, nullptr);
  EXPECT_EQ(s->body(), 1);
  EXPECT_EQ(s->other(), 0);
  EXPECT_EQ(s->at, Vector3(0, 0, -0.1));
  EXPECT_EQ(s->other_at, Vector3(0.1, 0, 0.2));
  EXPECT_EQ(s->stiffness, 200.0);
  EXPECT_EQ(s->damping, 2.0);
  EXPECT_EQ(s->rest_length, 0.3);
  const auto* d = dynamic_cast<const Spring*>(file.model.forces()[1].get());
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->other(), kGround);
  EXPECT_EQ(d->at, Vector3::Zero());
  EXPECT_EQ(d->other_at, Vector3::Zero());
  EXPECT_EQ(d->damping, 0.0);
  EXPECT_EQ(d->rest_length, 0.0);
  // Written and read again: the same elements.
  const std::string text = io::model_file_text(file.model, file.q, file.z);
  const io::ModelFile again = io::parse_model_file(text, "written.yaml");
  ASSERT_EQ(again.model.forces().size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const auto* x = dynamic_cast<const Spring*>(file.model.forces()[i].get());
    const auto* y = dynamic_cast<const Spring*>(again.model.forces()[i].get());
    ASSERT_NE(y, nullptr) << text;
    EXPECT_EQ(x->body(), y->body());
    EXPECT_EQ(x->other(), y->other());
    EXPECT_EQ(x->at, y->at);
    EXPECT_EQ(x->other_at, y->other_at);
    EXPECT_EQ(x->stiffness, y->stiffness);
    EXPECT_EQ(x->damping, y->damping);
    EXPECT_EQ(x->rest_length, y->rest_length);
  }
}

// Each refusal names the file, the line and column and the problem.
TEST(Spring, ModelFileRefusals) {
  struct Case {
    const char* from;
    const char* to;
    const char* expected;
  };
  const Case cases[] = {
      {"    stiffness: 200.0\n", "", "stiffness"},  // required
      {"stiffness: 200.0", "stiffness: -1.0", "must be >= 0"},
      {"damping: 2.0", "damping: -2.0", "must be >= 0"},
      {"rest_length: 0.3", "rest_length: -0.3", "must be >= 0"},
      {"other: a", "other: b", "own body"},
      {"other: a", "other: c", "c"},
      {"rest_length: 0.3", "rest_lenght: 0.3", "rest_lenght"},
      {"rest_length: 0.3", "rotational_stiffness: 0.3", "rotational_stiffness"},
  };
  for (const Case& c : cases) {
    std::string text = kSpringFile;
    const size_t at = text.find(c.from);
    ASSERT_NE(at, std::string::npos) << c.from;
    text.replace(at, std::string(c.from).size(), c.to);
    try {
      (void)io::parse_model_file(text, "springs.yaml");
      ADD_FAILURE() << "accepted: " << c.to;
    } catch (const io::ModelFileError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("springs.yaml:"), std::string::npos) << what;
      EXPECT_NE(what.find("forces[0]"), std::string::npos) << what;
      EXPECT_NE(what.find(c.expected), std::string::npos) << what;
    }
  }
}

}  // namespace
}  // namespace kanedyn
