// The reduced linearization (include/kanedyn/reduce.hpp, docs/analysis.md "Steady motions: the
// reduced system") against results worked out by hand: the upright rolling disc's stability
// boundary (Whittaker's sqrt(g r / 3)), the frequency of a coin's wobble about its steady circle
// against a simulation of the nonlinear motion, the names of what is dropped, the JSON of
// `linearize --reduce`, and a model with nothing to drop.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "file_support.hpp"
#include "kanedyn/analysis.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/reduce.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/simulate.hpp"

namespace kanedyn {
namespace {

constexpr double kG = 9.81, kRadius = 0.3, kMass = 2.0;

// A thin uniform disc (I = m r^2 / 2 about its axle, body y; m r^2 / 4 about a diameter)
// rolling without slip on z = 0.
Model thin_disc() {
  BodySpec b;
  b.name = "disc";
  b.mass = kMass;
  const double r2 = kRadius * kRadius;
  b.inertia = Vector3(kMass * r2 / 4, kMass * r2 / 2, kMass * r2 / 4).asDiagonal();
  Constraint c;
  c.name = "contact";
  c.type = ConstraintType::rolling_disc;
  c.axis = Vector3::UnitY();
  c.radius = kRadius;
  return Model({b}, Vector3(0, 0, -kG), {}, "disc", {}, {}, {}, {c});
}

// Upright, its centre moving at v along x: it spins about its axle y at v / r (the contact
// point -r z has velocity v x + (v / r) y x (-r z) = 0).
Linearization upright(const Model& disc, double v) {
  VectorX q(7), z(6);
  q << 0, 0, 0, 1, 0, 0, kRadius;
  z << 0, v / kRadius, 0, v, 0, 0;
  return linearize(disc, q, z, VectorX());
}

// The coin's steady circle (tests/test_constraint_physics.cpp derives it from Newton's and
// Euler's equations about the centre C): leaning by theta toward the centre O' of its path, C
// on a circle of radius rho, the whole turning about the vertical at Omega with
//   g tan(theta) = Omega^2 (3 rho / 2 + r sin(theta) / 4),
// and spinning about the axle a at s = -Omega (rho + r sin(theta)) / r relative to the turning
// frame (rolling). At t = 0, O' at the origin and C on +x; body axes x = -Y, y = a = (cos(theta),
// 0, sin(theta)), z = (-sin(theta), 0, cos(theta)); w = Omega Z + s a, v_C = Omega rho Y.
struct Coin {
  double theta = 0.3, rho = 1.0;
  double precession() const {
    return std::sqrt(kG * std::tan(theta) / (1.5 * rho + kRadius * std::sin(theta) / 4));
  }
  double spin() const { return -precession() * (rho + kRadius * std::sin(theta)) / kRadius; }
  void state(VectorX& q, VectorX& z) const {
    const double st = std::sin(theta), ct = std::cos(theta), W = precession(), s = spin();
    Matrix3 R;  // inertial -> body: its rows are the body's axes
    R.row(0) = -Vector3::UnitY();
    R.row(1) = Vector3(ct, 0, st);
    R.row(2) = Vector3(-st, 0, ct);
    q.resize(7);
    z.resize(6);
    q << euler_parameters_from_matrix(R), rho, 0, kRadius * ct;
    z << 0, W * st + s, W * ct, 0, W * rho, 0;
  }
};

// The largest imaginary part: the frequency of a pair on the imaginary axis (whose place in the
// sorted list depends on the round-off of the real parts around it).
double largest_imaginary_part(const Eigen::VectorXcd& values) {
  return values.size() ? values.imag().maxCoeff() : 0.0;
}

double largest_real_part(const Eigen::VectorXcd& values) {
  return values.size() ? values.real().maxCoeff() : 0.0;
}

// The tool's zero: a double eigenvalue (the reduced disc keeps two zeros: its spin rate and
// the heading rate's combination with the lean are conserved to first order) is found to
// sqrt(eps |A|); ten times that.
double zero_tolerance(const MatrixX& a) {
  return 10.0 * std::sqrt(std::numeric_limits<double>::epsilon() *
                          std::max(1.0, a.cwiseAbs().rowwise().sum().maxCoeff()));
}

// ---- 1. Whittaker's limit ----------------------------------------------------------------------
//
// A thin uniform disc rolling upright is stable above v = sqrt(g r / 3) (Whittaker, "Analytical
// Dynamics", sec. 244: w^2 > m g r I_d / (I_a (I_a + m r^2)) = g / (3 r) for the thin disc).
// Below it the lean diverges at sqrt(k (v_c - v)) / s with k about 50 / (m/s) here; the zero
// tolerance (about 1e-6) thus moves the boundary by 1e-6^2 / 50, some 1e-14 v_c, and bisection
// to 1e-12 v_c leaves the answer within 1e-9 v_c with three orders to spare.
TEST(ReducedLinearization, UprightDiscIsStableAboveWhittakersSpeed) {
  const Model disc = thin_disc();
  const double critical = std::sqrt(kG * kRadius / 3.0);
  const auto unstable = [&](double v) {
    const ReducedLinearization red = reduce(disc, upright(disc, v));
    EXPECT_TRUE(red.steady) << "at " << v;
    return largest_real_part(red.eigenvalues) > zero_tolerance(red.A);
  };
  EXPECT_TRUE(unstable(critical * (1 - 1e-6)));
  EXPECT_FALSE(unstable(critical * (1 + 1e-6)));
  EXPECT_FALSE(unstable(2 * critical));
  double lo = 0.5 * critical, hi = 2 * critical;  // unstable at lo, stable at hi
  ASSERT_TRUE(unstable(lo));
  while (hi - lo > 1e-12 * critical) {
    const double mid = 0.5 * (lo + hi);
    (unstable(mid) ? lo : hi) = mid;
  }
  EXPECT_NEAR(0.5 * (lo + hi), critical, 1e-9 * critical);
  // Negative control: the full linearization at one instant of the spinning disc has a real
  // eigenvalue far above zero even at twice the speed, where the disc is stable.
  EXPECT_GT(largest_real_part(upright(disc, 2 * critical).eigenvalues), 1.0);
}

// ---- 2. The coin's wobble about its circle, simulated ---------------------------------------
//
// The reduced eigenvalues of the steady circle are +-i w and zeros (rolling without slip is
// conservative). Started on the oscillating mode with amplitude 1e-6 rad, the simulated lean
// is theta + a cos(w t) + b sin(w t) up to terms of order 1e-12 rad (second order: a shift of
// the mean and a drift along the zero modes, both fitted, and a change of the frequency of
// relative order 1e-12), with the integrator's error (rtol 1e-12) about 1e-12 rad: noise of 1e-6
// of the amplitude, which over 6 periods of 60 samples moves the fitted w by about 1e-9
// relative. So 1e-6 relative tests the reduced frequency with three orders to spare.
struct Fit {
  double omega = 0, amplitude = 0;
};

// Least squares for d(t) = c0 + c1 t + a cos(w t) + b sin(w t), w by Gauss-Newton from w0.
Fit fit_sine(const std::vector<double>& t, const std::vector<double>& d, double w0) {
  const Eigen::Index m = static_cast<Eigen::Index>(t.size());
  Fit f{w0, 0};
  for (int iteration = 0; iteration < 20; ++iteration) {
    MatrixX J(m, 5);
    for (Eigen::Index i = 0; i < m; ++i) {
      const double ti = t[static_cast<size_t>(i)];
      J.row(i) << 1, ti, std::cos(f.omega * ti), std::sin(f.omega * ti), 0;
    }
    const VectorX y = Eigen::Map<const VectorX>(d.data(), m);
    const VectorX c = J.leftCols(4).colPivHouseholderQr().solve(y);
    for (Eigen::Index i = 0; i < m; ++i) {
      const double ti = t[static_cast<size_t>(i)];
      J(i, 4) = ti * (-c[2] * std::sin(f.omega * ti) + c[3] * std::cos(f.omega * ti));
    }
    const VectorX step = J.colPivHouseholderQr().solve(y - J.leftCols(4) * c);
    f.omega += step[4];
    f.amplitude = std::hypot(c[2], c[3]);
    if (std::abs(step[4]) < 1e-15 * f.omega) break;
  }
  return f;
}

TEST(ReducedLinearization, CoinWobblesAtTheReducedFrequency) {
  const Model disc = thin_disc();
  const Coin coin;
  VectorX q0, z0;
  coin.state(q0, z0);
  const Linearization lin = linearize(disc, q0, z0, VectorX());
  const ReducedLinearization red = reduce(disc, lin, true);
  ASSERT_TRUE(red.steady) << red.reduced_rate;
  ASSERT_EQ(red.eigenvalues.size(), 4);
  Eigen::Index top = 0;
  const double omega = red.eigenvalues.imag().maxCoeff(&top);
  ASSERT_GT(omega, 1.0);
  EXPECT_LE(std::abs(red.eigenvalues[top].real()), zero_tolerance(red.A));

  // The start: the real part of the mode (largest entry 1) times 1e-6, lifted to the full
  // tangent (the dropped directions' components zero, the dependent coordinates and speeds
  // following), then onto the constraints.
  const double size = 1e-6;
  const VectorX y = size * red.modes.col(top).real();
  const VectorX full = lin.full_state * (red.lift * y);
  const int n = disc.num_speeds();
  VectorX q = retract(disc, lin.q, full.head(n));
  VectorX z = lin.z + full.tail(n);
  project_onto_constraints(disc, q, z);

  const double period = 2 * std::numbers::pi / omega;
  SimulationSettings s;
  s.t_end = 6 * period;
  s.dt_out = period / 60;
  s.rtol = 1e-12;
  s.atol = 1e-14;
  std::vector<double> times, lean;
  const SimulationStats stats = simulate(
      disc, q, z, s, [&](double t, const State&, const VectorX& qq, const VectorX&, Data&) {
        const Vector3 axle = rotation_matrix(qq.head<4>()).row(1).transpose();
        times.push_back(t);
        lean.push_back(std::asin(std::clamp(axle.z(), -1.0, 1.0)) - coin.theta);
      });
  ASSERT_TRUE(stats.ok()) << stats.message;
  const Fit f = fit_sine(times, lean, omega);
  EXPECT_GT(f.amplitude, 0.1 * size);  // the lean does swing (the mode moves it)
  EXPECT_NEAR(f.omega, omega, 1e-6 * omega);
  // Negative control: the full linearization's oscillation at this instant (the disc spins, so
  // its eigenvalues are those of a periodic system's one instant) is off by more than 5 %.
  const double instant = largest_imaginary_part(lin.eigenvalues);
  EXPECT_GT(std::abs(instant - f.omega), 0.05 * f.omega);
}

// ---- 3. What is dropped ----------------------------------------------------------------------
//
// The coin's position (s1, s2: nothing depends on where it is), its heading about the vertical
// and its spin about the axle. At the state above the vertical has body components (0,
// sin(theta), cos(theta)), largest along z, so the heading replaces r3; the axle is y, so the
// spin replaces r2. The rates along them are the closed form's: Omega and s.
TEST(ReducedLinearization, NamesTheCoinsPositionHeadingAndSpin) {
  const Model disc = thin_disc();
  const Coin coin;
  VectorX q, z;
  coin.state(q, z);
  const Linearization lin = linearize(disc, q, z, VectorX());
  const ReducedLinearization red = reduce(disc, lin);
  std::vector<std::string> names, kinds;
  for (const DroppedCoordinate& d : red.dropped) {
    names.push_back(d.name);
    kinds.push_back(d.kind);
    EXPECT_EQ(lin.state[static_cast<size_t>(d.index)], d.name);
  }
  EXPECT_EQ(names, (std::vector<std::string>{"disc.s1", "disc.s2", "disc.r3", "disc.r2"}));
  EXPECT_EQ(kinds, (std::vector<std::string>{"coordinate", "coordinate", "heading", "spin"}));
  EXPECT_EQ(red.state, (std::vector<std::string>{"disc.r1", "disc.w1", "disc.w2", "disc.w3"}));
  ASSERT_EQ(red.rates.size(), 4u);
  EXPECT_NEAR(red.rates[2], coin.precession(), 1e-12 * coin.precession());
  EXPECT_NEAR(red.rates[3], coin.spin(), 1e-12 * std::abs(coin.spin()));
  // The same directions at another phase of the spin: the body's axes turned about the axle
  // by 0.7 rad (the spin's symmetry): the reduced eigenvalues do not change.
  const Matrix3 E = Eigen::AngleAxisd(0.7, Vector3::UnitY()).toRotationMatrix();
  VectorX q2 = q, z2 = z;
  q2.head<4>() = euler_parameters_from_matrix(E.transpose() * rotation_matrix(q.head<4>()));
  z2.head<3>() = E.transpose() * z.head<3>();
  const ReducedLinearization turned = reduce(disc, linearize(disc, q2, z2, VectorX()));
  EXPECT_EQ(turned.dropped.size(), 4u);
  const double w = largest_imaginary_part(red.eigenvalues);
  EXPECT_NEAR(largest_imaginary_part(turned.eigenvalues), w, 1e-10 * w);
}

// The Whipple bicycle riding straight at 5 m/s (examples/bicycle_upright.yaml): its wheels spin
// on joints, so nothing turns and the full system is already time-invariant. Reduced, it drops
// the rear frame's place, its heading and the wheels' angles, and keeps roll, steer, their rates
// and the forward speed: the paper's four eigenvalues (Meijaard et al. 2007, Table 2, v = 5;
// tests/data/meijaard2007.json) to 1e-12 of their size (as tests/test_bicycle.cpp asks of the
// full system) and one zero, the forward speed (conserved to first order).
TEST(ReducedLinearization, BicycleKeepsRollSteerAndTheForwardSpeed) {
  const io::ModelFile f = io::load_model_file(test::kExamples + "/bicycle_upright.yaml");
  const Linearization lin = linearize(f.model, f.q, f.z, VectorX());
  const ReducedLinearization red = reduce(f.model, lin);
  EXPECT_TRUE(red.steady);
  std::vector<std::string> names;
  for (const DroppedCoordinate& d : red.dropped) names.push_back(d.name + " " + d.kind);
  EXPECT_EQ(names,
            (std::vector<std::string>{"rear_frame.s1 coordinate", "rear_frame.s2 coordinate",
                                      "rear_wheel.j1 coordinate", "front_wheel.j1 coordinate",
                                      "rear_frame.r3 heading"}));
  EXPECT_EQ(red.state, (std::vector<std::string>{"rear_frame.r1", "front_frame.j1", "rear_frame.w1",
                                                 "rear_wheel.jd1", "front_frame.jd1"}));
  std::ifstream in(KANEDYN_SOURCE_DIR "/tests/data/meijaard2007.json");
  const nlohmann::json paper = nlohmann::json::parse(in);
  std::vector<std::complex<double>> ours(red.eigenvalues.data(),
                                         red.eigenvalues.data() + red.eigenvalues.size());
  int matched = 0;
  for (const auto& entry : paper["eigenvalues_published"]) {
    if (entry["v"].get<double>() != 5.0) continue;
    for (const auto& pair : entry["eigenvalues"]) {
      const std::complex<double> expected(pair[0].get<double>(), pair[1].get<double>());
      const auto nearest = std::min_element(ours.begin(), ours.end(), [&](auto a, auto b) {
        return std::abs(a - expected) < std::abs(b - expected);
      });
      EXPECT_LE(std::abs(*nearest - expected), 1e-12 * std::max(1.0, std::abs(expected)))
          << expected << " against " << *nearest;
      ours.erase(nearest);
      ++matched;
    }
  }
  EXPECT_EQ(matched, 4);
  ASSERT_EQ(ours.size(), 1u);
  EXPECT_LE(std::abs(ours[0]), 1e-12);
}

// ---- 4. The JSON of `linearize --reduce` ------------------------------------------------------

TEST(ReducedLinearization, JsonHasTheReducedObject) {
  const auto dir = test::temp_dir("linearize_reduce_json");
  const test::ToolRun r =
      test::run_in(dir, "linearize '" + test::kExamples + "/rolling_disc.yaml' --json --reduce");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::ordered_json::parse(r.out);
  std::vector<std::string> keys;
  for (const auto& item : j.items()) keys.push_back(item.key());
  EXPECT_EQ(keys, (std::vector<std::string>{"n", "m", "state", "inputs", "q", "z", "u", "A",
                                            "eigenvalues", "reduced"}));
  const auto& red = j["reduced"];
  keys.clear();
  for (const auto& item : red.items()) keys.push_back(item.key());
  EXPECT_EQ(keys, (std::vector<std::string>{"dropped", "state", "steady", "A", "eigenvalues"}));
  ASSERT_EQ(red["dropped"].size(), 4u);
  for (const auto& d : red["dropped"]) {
    EXPECT_EQ(d.size(), 3u);
    EXPECT_EQ(j["state"][d["index"].get<size_t>()], d["name"]);
  }
  EXPECT_EQ(red["dropped"][2]["kind"], "heading");
  EXPECT_EQ(red["state"].size(), 4u);
  EXPECT_EQ(red["A"].size(), 4u);
  EXPECT_TRUE(red["steady"].get<bool>());
  // The file's coin is Coin{} above: its wobble's frequency, to the digits JSON keeps.
  const io::ModelFile file = io::load_model_file(test::kExamples + "/rolling_disc.yaml");
  const ReducedLinearization lib =
      reduce(file.model, linearize(file.model, file.q, file.z, VectorX()));
  ASSERT_EQ(red["eigenvalues"].size(), 4u);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(red["eigenvalues"][i][0].get<double>(),
              lib.eigenvalues[static_cast<Eigen::Index>(i)].real());
    EXPECT_EQ(red["eigenvalues"][i][1].get<double>(),
              lib.eigenvalues[static_cast<Eigen::Index>(i)].imag());
  }
  // Without --reduce the object is the spec's, unchanged.
  const test::ToolRun plain =
      test::run_in(dir, "linearize '" + test::kExamples + "/rolling_disc.yaml' --json");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_FALSE(nlohmann::json::parse(plain.out).contains("reduced"));
  // The summary names the neutral coordinates and says the reduced system decides.
  const test::ToolRun text =
      test::run_in(dir, "linearize '" + test::kExamples + "/rolling_disc.yaml' --reduce");
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("neutral (the state's rate does not depend on them): disc.s1, "
                          "disc.s2, disc.r3 (heading), disc.r2 (spin)"),
            std::string::npos)
      << text.out;
  EXPECT_NE(text.out.find("the reduced system is time-invariant here"), std::string::npos);
}

// ---- 5. Nothing to drop -------------------------------------------------------------------------
//
// Two links on hinges under gravity: every coordinate has a restoring moment, so --reduce keeps
// the whole system, A and all.
TEST(ReducedLinearization, AModelWithoutIgnorableCoordinatesIsUnchanged) {
  const io::ModelFile file = io::load_model_file(test::kExamples + "/double_pendulum_jointed.yaml");
  const Linearization lin = linearize(file.model, file.q, file.z, VectorX::Zero(0));
  const ReducedLinearization red = reduce(file.model, lin);
  EXPECT_TRUE(red.dropped.empty());
  EXPECT_EQ(red.state, lin.state);
  EXPECT_EQ(red.A, lin.A);
  EXPECT_EQ(red.eigenvalues, lin.eigenvalues);
  const auto dir = test::temp_dir("linearize_reduce_none");
  const test::ToolRun r = test::run_in(
      dir, "linearize '" + test::kExamples + "/double_pendulum_jointed.yaml' --json --reduce");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["reduced"]["dropped"].empty());
  EXPECT_EQ(j["reduced"]["A"], j["A"]);
  EXPECT_EQ(j["reduced"]["eigenvalues"], j["eigenvalues"]);
}

// At rest the summary names the neutral coordinates: a pendulum hanging from a cart on a rail,
// where nothing holds the cart. Its verdict is not "stable" bare.
TEST(ReducedLinearization, AtRestTheSummaryNamesTheNeutralCoordinates) {
  const auto dir = test::temp_dir("linearize_reduce_rest");
  std::ofstream(dir / "hanging.yaml") << R"(format: kanedyn-model/1
name: a pendulum on a cart
gravity: [0, 0, -9.81]
bodies:
  - name: cart
    parent: ground
    mass: 1.5
    inertia: [0.1, 0.1, 0.1]
    joint: {type: prismatic, axis: [1, 0, 0]}
  - name: pole
    parent: cart
    mass: 0.4
    inertia: [0.02, 0.02, 0.02]
    com: [0, 0, -0.6]
    joint: {type: revolute, axis: [0, 1, 0]}
)";
  const test::ToolRun r = test::run_in(dir, "linearize hanging.yaml --reduce");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("neutral (the state's rate does not depend on them): cart.j1\n"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("the operating point is not asymptotically stable (marginal eigenvalues: "
                       "the neutral coordinates above, or no damping)"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("the state pole.j1 cart.jd1 pole.jd1"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace kanedyn
