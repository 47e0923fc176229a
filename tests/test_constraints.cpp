// Constraints: the equations against finite differences, the two routes against each other,
// projection, and mechanisms with known motions (docs/theory.md, "Constraints").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "constraint_models.hpp"
#include "file_support.hpp"
#include "kanedyn/analysis.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/simulate.hpp"

namespace kanedyn {
namespace {

// A slender rod of length `length` along its body z, its centre at z = -length / 2.
BodySpec rod(const std::string& name, int lower, double mass, double length, Vector3 joint) {
  BodySpec b;
  b.name = name;
  b.lower_body = lower;
  b.mass = mass;
  const double side = mass * length * length / 12.0;
  b.inertia = Vector3(side, side, 0.01 * side).asDiagonal();
  b.com = Vector3(0, 0, -length / 2);
  b.joint = joint;
  return b;
}

Joint revolute_x() {
  Joint j;
  j.type = JointType::revolute;
  j.axis = Vector3::UnitX();
  return j;
}

const Vector3 kGravity(0, 0, -9.81);

// The rod on a revolute joint about x at the ground's origin.
Model revolute_pendulum() {
  return Model({rod("rod", kGround, 2.0, 1.5, Vector3::Zero())}, kGravity, {}, "pendulum",
               {revolute_x()});
}

// The same rod as a free body held by a hinge about x at its top end.
constexpr auto hinged_pendulum = test::hinged_rod;

// The free rod's (q, z) turned by angle about x at the origin, turning at rate.
constexpr auto free_rod_state = test::hinged_rod_state;

// Joint coordinates at the joints' zero: identity rotations, zero angles and translations.
VectorX zero_coordinates(const Model& m) {
  VectorX q = VectorX::Zero(m.num_coordinates());
  for (int k = 0; k < m.num_bodies(); ++k) {
    const JointType t = m.joint(k).type;
    if (t == JointType::free || t == JointType::spherical) q[m.coordinate_offset(k) + 3] = 1.0;
  }
  return q;
}

// Random states of a model: random q (unit Euler parameters), z projected onto [B] z = 0.
void random_consistent_state(const Model& m, std::mt19937& rng, VectorX& q, VectorX& z) {
  std::normal_distribution<double> g(0.0, 1.0);
  VectorX dx = VectorX::NullaryExpr(m.num_speeds(), [&] { return 0.3 * g(rng); });
  q = retract(m, zero_coordinates(m), dx);
  z = VectorX::NullaryExpr(m.num_speeds(), [&] { return g(rng); });
}

// [B] z is the time derivative of the holonomic errors, and {b} that of [B] z at z dot = 0:
// central differences along the motion (q moved by z dt in tangent coordinates). Truncation
// O(h^2) with h = 1e-5: about 1e-9 of the scale; round-off 1e-16 / 1e-5 = 1e-11.
void check_equations_by_differences(const Model& m, const VectorX& q, const VectorX& z) {
  ConstraintEquations eq(m);
  eq.evaluate(q, z);
  const MatrixX B = eq.B();
  const VectorX b = eq.b(), phi = eq.errors();
  const double h = 1e-5;
  ConstraintEquations plus(m), minus(m);
  const VectorX qp = retract(m, q, h * z), qm = retract(m, q, -h * z);
  plus.evaluate(qp, z);
  minus.evaluate(qm, z);
  const VectorX rate = (plus.errors() - minus.errors()) / (2 * h);
  const VectorX bz = B * z;
  for (int i = 0; i < eq.rows(); ++i) {
    if (!eq.holonomic(i)) continue;
    EXPECT_NEAR(rate[i], bz[i], 1e-7 * std::max(1.0, std::abs(bz[i]))) << eq.row_name(i);
  }
  // d/dt ([B] z) at constant z: ([B(q+)] - [B(q-)]) z / 2h = [B dot] z = b.
  const VectorX bdot = (plus.B() * z - minus.B() * z) / (2 * h);
  for (int i = 0; i < eq.rows(); ++i)
    EXPECT_NEAR(bdot[i], b[i], 1e-7 * std::max(1.0, std::abs(b[i]))) << eq.row_name(i);
}

TEST(ConstraintEquations, HingeRowsAreTheRatesOfTheirErrors) {
  const Model m = hinged_pendulum();
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5; ++trial) {
    VectorX q, z;
    random_consistent_state(m, rng, q, z);
    check_equations_by_differences(m, q, z);
  }
}

// The hinged free rod moves as the rod on a revolute joint: the same angle after 1 s, to the
// integrators' tolerance (rtol 1e-10: differences of 1e-8 over a half swing).
TEST(ConstrainedDynamics, HingedFreeBodyEqualsTheRevolutePendulum) {
  const Model hinged = hinged_pendulum(), revolute = revolute_pendulum();
  SimulationSettings s;
  s.t_end = 1.0;  // about half a period (3 g / 2 L = 9.81 / s^2: 2.0 s)
  s.dt_out = 1.0;
  s.rtol = 1e-10;
  s.atol = 1e-12;
  VectorX q, z;
  free_rod_state(0.7, 0.3, q, z);
  double hinged_angle = 0.0, revolute_angle = 0.0;
  simulate(hinged, q, z, s, [&](double t, const State&, const VectorX& qq, const VectorX&, Data&) {
    if (t == s.t_end) hinged_angle = 2.0 * std::atan2(qq[0], qq[3]);
  });
  VectorX qr(1), zr(1);
  qr << 0.7;
  zr << 0.3;
  simulate(revolute, qr, zr, s,
           [&](double t, const State&, const VectorX& qq, const VectorX&, Data&) {
             if (t == s.t_end) revolute_angle = qq[0];
           });
  EXPECT_NEAR(hinged_angle, revolute_angle, 1e-7);
  EXPECT_GT(std::abs(revolute_angle - 0.7), 0.1);  // it did swing
}

// Both routes give the same z dot and the same multipliers at random consistent states, and
// the multipliers balance: M z dot + b = [B]^T lambda.
TEST(ConstrainedDynamics, ProjectedAndMultiplierRoutesAgree) {
  const Model m = hinged_pendulum();
  std::mt19937 rng(5);
  for (int trial = 0; trial < 5; ++trial) {
    VectorX q, z;
    random_consistent_state(m, rng, q, z);
    project_onto_constraints(m, q, z);
    ConstrainedDynamics projected(m, ConstrainedDynamics::Method::projected);
    ConstrainedDynamics multipliers(m, ConstrainedDynamics::Method::multipliers);
    VectorX a(m.num_speeds()), b(m.num_speeds());
    projected.evaluate(q, z, VectorX(), a);
    multipliers.evaluate(q, z, VectorX(), b);
    EXPECT_LE((a - b).cwiseAbs().maxCoeff(), 1e-10 * std::max(1.0, a.cwiseAbs().maxCoeff()));
    // The hinge's 5 rows are independent: one set of multipliers.
    EXPECT_LE((projected.lambda() - multipliers.lambda()).cwiseAbs().maxCoeff(),
              1e-9 * std::max(1.0, multipliers.lambda().cwiseAbs().maxCoeff()));
    // The constrained acceleration satisfies [B] z dot + b = 0.
    const ConstraintEquations& eq = multipliers.equations();
    EXPECT_LE((eq.B() * b + eq.b()).cwiseAbs().maxCoeff(), 1e-10 * std::max(1.0, b.norm()));
  }
}

// At rest the hinge holds the rod's weight: the reaction force is m g up.
TEST(ConstrainedDynamics, HingeReactionAtRestIsTheWeight) {
  const Model m = hinged_pendulum();
  VectorX q, z;
  free_rod_state(0.0, 0.0, q, z);
  ConstrainedDynamics d(m);
  VectorX zdot(6);
  d.evaluate(q, z, VectorX(), zdot);
  EXPECT_LE(zdot.cwiseAbs().maxCoeff(), 1e-12);
  const Vector3 f = d.equations().force(0, d.lambda());
  EXPECT_NEAR(f.z(), 2.0 * 9.81, 1e-10);
  EXPECT_NEAR(f.x(), 0.0, 1e-10);
  EXPECT_NEAR(f.y(), 0.0, 1e-10);
}

// Projection moves a perturbed state back onto the constraints, changing the dependent
// coordinates only, to the tolerance.
TEST(Projection, BringsAPerturbedStateOntoTheConstraints) {
  const Model m = hinged_pendulum();
  VectorX q, z;
  free_rod_state(0.4, 0.2, q, z);
  q.tail<3>() << 0.01, -0.02, 0.015;  // O_K off the pin
  z.tail<3>() << 0.1, 0.0, -0.1;      // and moving
  const Projection p = project_onto_constraints(m, q, z);
  EXPECT_GT(p.error_before, 0.01);
  ConstraintEquations eq(m);
  eq.evaluate(q, z);
  EXPECT_LE(eq.errors().cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((eq.B() * z).cwiseAbs().maxCoeff(), 1e-13);
}

// A thin disc (radius r, mass m: I = m r^2 / 2 about the axle, body y, m r^2 / 4 about a
// diameter) rolling on z = 0, upright, its centre moving at `speed` along x, with a lean rate.
struct Disc {
  Model model;
  VectorX q, z;
};

Disc rolling_disc(double speed, double lean_rate) {
  const double r = 0.3, m = 2.0;
  BodySpec b;
  b.name = "disc";
  b.mass = m;
  b.inertia = Vector3(m * r * r / 4, m * r * r / 2, m * r * r / 4).asDiagonal();
  Constraint c;
  c.name = "contact";
  c.type = ConstraintType::rolling_disc;
  c.body = 0;
  c.axis = Vector3::UnitY();
  c.radius = r;
  Disc d{Model({b}, kGravity, {}, "disc", {}, {}, {}, {c}), VectorX::Zero(7), VectorX::Zero(6)};
  d.q << 0, 0, 0, 1, 0, 0, r;
  d.z << lean_rate, speed / r, 0, speed, 0, 0;
  project_onto_constraints(d.model, d.q, d.z);
  return d;
}

TEST(ConstraintEquations, RollingDiscRowsAreTheRatesOfTheirErrors) {
  const Disc d = rolling_disc(1.0, 0.0);
  std::mt19937 rng(11);
  for (int trial = 0; trial < 5; ++trial) {
    VectorX q, z;
    random_consistent_state(d.model, rng, q, z);
    q[6] += 0.3;  // the centre above the plane
    check_equations_by_differences(d.model, q, z);
  }
}

// Rolling without slip does no work: with no damping the energy is conserved, and the
// constraints hold along a 10 s run (holonomic to 1e-10 after each step's projection,
// nonholonomic to round-off in the speeds).
TEST(ConstrainedDynamics, RollingDiscConservesEnergyAndKeepsItsConstraints) {
  Disc d = rolling_disc(2.0, 0.5);
  SimulationSettings s;
  s.t_end = 10.0;
  s.dt_out = 0.5;
  s.rtol = 1e-10;
  s.atol = 1e-12;
  Data data(d.model);
  const double e0 = total_energy(d.model, d.q, d.z, data);
  double worst_energy = 0.0, worst_holonomic = 0.0, worst_speed = 0.0;
  ConstraintEquations eq(d.model);
  simulate(d.model, d.q, d.z, s,
           [&](double, const State&, const VectorX& q, const VectorX& z, Data& out) {
             worst_energy = std::max(worst_energy, std::abs(total_energy(d.model, q, z, out) - e0));
             eq.evaluate(q, z);
             worst_holonomic = std::max(worst_holonomic, std::abs(eq.errors()[0]));
             worst_speed = std::max(worst_speed, (eq.B() * z).cwiseAbs().maxCoeff());
           });
  EXPECT_LE(worst_energy, 1e-7 * std::abs(e0));
  EXPECT_LE(worst_holonomic, 1e-10);
  EXPECT_LE(worst_speed, 1e-12);
}

// The upright thin disc is stable above sqrt(g r / 3) (1.0 m/s for r = 0.3): at twice that speed
// a lean rate of 0.3 rad/s leaves it leaning less than 0.3 rad for 5 s; at half of it, it falls
// past 0.5 rad.
TEST(ConstrainedDynamics, UprightDiscIsStableAboveItsCriticalSpeed) {
  const double critical = std::sqrt(9.81 * 0.3 / 3.0);
  for (const double factor : {2.0, 0.5}) {
    Disc d = rolling_disc(factor * critical, 0.3);
    SimulationSettings s;
    s.t_end = 5.0;
    s.dt_out = 0.05;
    double lean = 0.0;
    simulate(d.model, d.q, d.z, s,
             [&](double, const State&, const VectorX& q, const VectorX&, Data&) {
               // The axle's tilt out of the ground plane.
               const Vector4 e = q.head<4>();
               const Matrix3 R = rotation_matrix(e);  // inertial -> body
               const Vector3 axle = R.transpose() * Vector3::UnitY();
               lean = std::max(lean, std::abs(std::asin(std::clamp(axle.z(), -1.0, 1.0))));
             });
    if (factor > 1.0)
      EXPECT_LT(lean, 0.3) << "at " << factor << " times the critical speed";
    else
      EXPECT_GT(lean, 0.5) << "at " << factor << " times the critical speed";
  }
}

// The four-bar of examples/four_bar.yaml (crank a, coupler b, rocker c, ground link d; its
// hinge closure has 3 redundant equations) swinging under gravity: at every output its rocker
// angle is Freudenstein's for the crank angle, and the coupler's and rocker's rates are the
// velocity analysis's, to 1e-9 (the holonomic projection's 1e-12 times the lever arms' ratios).
TEST(ConstrainedDynamics, FourBarFollowsFreudensteinsEquation) {
  const io::ModelFile f = io::load_model_file(KANEDYN_SOURCE_DIR "/examples/four_bar.yaml");
  const double a = 0.4, b = 1.2, c = 0.9, d = 1.0;
  EXPECT_EQ(f.partition.rank, 2);
  EXPECT_EQ(f.partition.redundant_rows.size(), 3u);
  SimulationSettings s;
  s.t_end = 3.0;
  s.dt_out = 0.1;
  int checked = 0;
  double crank_travel = 0.0;
  simulate(
      f.model, f.q, f.z, s, [&](double, const State&, const VectorX& q, const VectorX& z, Data&) {
        const double t2 = q[0], t3 = q[0] + q[1], t4 = q[0] + q[1] + q[2];
        crank_travel = std::max(crank_travel, std::abs(t2 - f.q[0]));
        // The rocker seen from D toward the coupler's tip.
        const double t4d = t4 + std::numbers::pi;
        const double k1 = d / a, k2 = d / c, k3 = (a * a - b * b + c * c + d * d) / (2 * a * c);
        const double A = k1 - std::cos(t2), B = -std::sin(t2), C = k2 * std::cos(t2) - k3;
        const double base = std::atan2(B, A), spread = std::acos(C / std::hypot(A, B));
        double best = 1e9;
        for (const double sign : {1.0, -1.0}) {
          const double candidate = base + sign * spread;
          best = std::min(best, std::abs(std::remainder(candidate - t4d, 2 * std::numbers::pi)));
        }
        EXPECT_LT(best, 1e-9);
        // Velocity analysis: a w2 u2' + b w3 u3' = -c w4 u4' (u' the unit vector turned by
        // 90 degrees), solved for w3 and w4 given w2.
        const double w2 = z[0];
        Eigen::Matrix2d m;
        m << -b * std::sin(t3), -c * std::sin(t4), b * std::cos(t3), c * std::cos(t4);
        const Eigen::Vector2d rhs(a * w2 * std::sin(t2), -a * w2 * std::cos(t2));
        const Eigen::Vector2d w = m.colPivHouseholderQr().solve(rhs);
        EXPECT_NEAR(z[0] + z[1], w[0], 1e-9 * std::max(1.0, std::abs(w[0])));
        EXPECT_NEAR(z[0] + z[1] + z[2], w[1], 1e-9 * std::max(1.0, std::abs(w[1])));
        ++checked;
      });
  EXPECT_EQ(checked, 31);
  EXPECT_GT(crank_travel, 0.2);  // it moved
}

// A long run's angles grow without bound: a crank turning at 12 rad/s has turned 14,856 rad
// after 1238 s, where a double's spacing is 1.8e-12, above the projection's 1e-12. The same
// assembled pose, every joint turned by whole turns, must project as the original does.
TEST(Projection, ConvergesWhenTheAnglesAreLargeAfterALongRun) {
  const io::ModelFile f = io::load_model_file(KANEDYN_SOURCE_DIR "/examples/four_bar.yaml");
  const double turn = 2.0 * std::numbers::pi;
  VectorX q = f.q, z = f.z;
  q[0] += 2364 * turn;  // 14,853 rad of crank
  q[1] -= 1304 * turn;  // a coupler angle near -8194 rad
  q[2] += 1000 * turn;
  ConstraintEquations eq(f.model);
  eq.evaluate(q, z);
  // The same pose: what is left is the round-off of the large angles alone.
  const double spacing = std::nextafter(q.cwiseAbs().maxCoeff(), 1e300) - q.cwiseAbs().maxCoeff();
  ASSERT_GT(eq.errors().cwiseAbs().maxCoeff(), 1e-12) << "not a test of the floor";
  EXPECT_LT(eq.errors().cwiseAbs().maxCoeff(), 100 * spacing);
  const VectorX before = q;
  const Projection p = project_onto_constraints(f.model, q, z);
  EXPECT_LE(p.iterations, 3);
  EXPECT_LE((q - before).cwiseAbs().maxCoeff(), 100 * spacing);  // nothing left to move
}

// A mechanism whose closing hinge is written 200 times (1000 rows, 600 of them redundant
// beyond the one hinge's 3) moves as with one hinge, and the copies share its reaction
// equally (the minimum-norm multipliers): the cost of the redundant rows follows the rank,
// where a c x c system of the rows once took seconds per evaluation here.
TEST(ConstrainedDynamics, ManyCopiesOfOneHingeMoveAsOne) {
  const std::string text = test::slurp(KANEDYN_SOURCE_DIR "/examples/four_bar.yaml");
  const size_t from = text.find("  - name: closure"), to = text.find("independent_speeds:");
  ASSERT_NE(from, std::string::npos);
  ASSERT_NE(to, std::string::npos);
  std::string copies = text.substr(0, from);
  const int count = 200;
  for (int i = 0; i < count; ++i) {
    std::string hinge = text.substr(from, to - from);
    hinge.replace(hinge.find("closure"), 7, "closure" + std::to_string(i));
    copies += hinge;
  }
  copies += text.substr(to);
  const io::ModelFile one = io::parse_model_file(text, "one.yaml");
  const io::ModelFile many = io::parse_model_file(copies, "many.yaml");
  ASSERT_EQ(many.model.num_constraints(), count);
  for (const auto method :
       {ConstrainedDynamics::Method::multipliers, ConstrainedDynamics::Method::projected}) {
    ConstrainedDynamics a(one.model, method), b(many.model, method);
    VectorX za(one.model.num_speeds()), zb(many.model.num_speeds());
    VectorX z = one.z;
    z[0] = 1.5;  // the crank turning, the others as the constraints say
    VectorX q = one.q;
    project_onto_constraints(one.model, q, z);
    a.evaluate(q, z, VectorX(), za);
    b.evaluate(q, z, VectorX(), zb);
    EXPECT_LE((za - zb).cwiseAbs().maxCoeff(), 1e-10 * za.cwiseAbs().maxCoeff());
    VectorX ra(reaction_count(one.model)), rb(reaction_count(many.model));
    constraint_reactions(a.equations(), a.lambda(), ra);
    constraint_reactions(b.equations(), b.lambda(), rb);
    Vector3 force = Vector3::Zero();
    for (int i = 0; i < count; ++i) {
      force += rb.segment<3>(6 * i);
      // Each copy carries the same share.
      EXPECT_LE((rb.segment<3>(6 * i) - ra.head<3>() / count).norm(),
                1e-9 * ra.head<3>().norm() / count);
    }
    EXPECT_LE((force - ra.head<3>()).norm(), 1e-9 * ra.head<3>().norm());
  }
}

// A projection that cannot remove the errors with the dependent coordinates the given
// independent speeds leave says that their count is wrong: naming every speed of the four-bar
// once crashed it (a least-squares solve in no unknowns), and naming two of three blamed the
// initial state. (The loader's partition refuses the count even where no step is needed.)
TEST(Projection, AWrongCountOfIndependentSpeedsIsTheReasonGiven) {
  const io::ModelFile f = io::load_model_file(KANEDYN_SOURCE_DIR "/examples/four_bar.yaml");
  for (const std::vector<int>& given :
       {std::vector<int>{0, 1, 2}, std::vector<int>{0, 2}, std::vector<int>{1, 2}}) {
    std::vector<Joint> joints;
    for (int k = 0; k < f.model.num_bodies(); ++k) joints.push_back(f.model.joint(k));
    const Model m(f.model.bodies(), f.model.gravity(), f.model.forces(), f.model.name(), joints,
                  f.model.frames(), f.model.inputs(), f.model.constraints(), given);
    VectorX q = f.q, z = f.z;
    q[2] += 0.01;  // the rocker off the assembly: one dependent coordinate cannot mend it
    try {
      project_onto_constraints(m, q, z);
      ADD_FAILURE() << given.size() << " independent speeds accepted";
    } catch (const ConstraintError& e) {
      EXPECT_EQ(std::string(e.what()),
                "independent_speeds: " + std::to_string(given.size()) +
                    " speeds given, but the 2 independent constraint equations leave 1 speeds "
                    "free");
    }
  }
}

}  // namespace
}  // namespace kanedyn
