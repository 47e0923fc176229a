// Constraints against physics worked out by hand, not by the constraint code (docs/theory.md,
// "Constraints", "Checks"): a rolling disc in steady precession holds its circle; a loop closed
// by a stiff bushing converges to the loop closed by a ball as the stiffness grows; pendulums
// held by distance constraints swing as the revolute pendulum, with the rods' tensions of
// Newton's second law; and the reactions equal the loads that, applied to the tree with the
// constraint cut, give the motion the constraint allows.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "kanedyn/constraints.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/simulate.hpp"

namespace kanedyn {
namespace {

constexpr double kG = 9.81;

Joint revolute(const Vector3& axis) {
  Joint j;
  j.type = JointType::revolute;
  j.axis = axis;
  return j;
}

Joint planar() {
  Joint j;
  j.type = JointType::planar;  // x, y and the turn about z of the identity frame
  return j;
}

// Tight tolerances: the integrator's global error then sits near 1e-9 over the runs below.
SimulationSettings tight(double t_end, double dt_out) {
  SimulationSettings s;
  s.t_end = t_end;
  s.dt_out = dt_out;
  s.rtol = 1e-10;
  s.atol = 1e-12;
  return s;
}

// ---- 1. A thin disc in steady precession ------------------------------------------------------
//
// A thin disc (radius r, mass m; I_a = m r^2 / 2 about its axle, I_d = m r^2 / 4 about a
// diameter) rolls on z = 0 leaning by theta toward the centre O' of its path, its centre C on a
// horizontal circle of radius rho about O' at height r cos(theta), the whole turning about the
// vertical at the constant rate Omega: the textbook rolling coin (e.g. Greenwood, "Advanced
// Dynamics", 2003), derived here from Newton's and Euler's equations. With e_r the horizontal
// unit vector from O' toward C, e_t = Z x e_r, Z up:
//   axle a = cos(theta) e_r + sin(theta) Z,   P - C = r sin(theta) e_r - r cos(theta) Z,
//   w = Omega Z + s a (s the spin relative to the turning frame), v_C = Omega rho e_t.
// Rolling, v_C + w x (P - C) = 0: (Omega rho + Omega r sin(theta) + s r) e_t = 0, so
//   s = -Omega (rho + r sin(theta)) / r.
// Newton: the contact force F = m a_C + m g Z = m (-Omega^2 rho e_r + g Z) (gravity -g Z).
// Euler about C: H = I_d w + (I_a - I_d)(w . a) a turns with the frame, dH/dt = Omega Z x H =
// (I_a s + (I_a - I_d) Omega sin(theta)) Omega cos(theta) e_t, and the moment of F about C is
// (P - C) x F = m r (Omega^2 rho cos(theta) - g sin(theta)) e_t. Equal, with s from rolling:
//   g tan(theta) = Omega^2 (3 rho / 2 + r sin(theta) / 4).
// Checks: rho = 0 gives Omega^2 = 4 g / (r cos(theta)), Euler's disk spinning in place; rho >> r
// gives tan(theta) = 3 v^2 / (2 g rho), the disc's classic lean in a turn.

struct SteadyDisc {
  double r = 0.3, m = 2.0, theta = 0.3, rho = 1.0;
  double steady_rate() const {
    return std::sqrt(kG * std::tan(theta) / (1.5 * rho + r * std::sin(theta) / 4));
  }
};

Model disc_on_the_ground(const SteadyDisc& d) {
  BodySpec b;
  b.name = "disc";
  b.mass = d.m;
  const double r2 = d.r * d.r;
  b.inertia = Vector3(d.m * r2 / 4, d.m * r2 / 2, d.m * r2 / 4).asDiagonal();  // axle: body y
  Constraint c;
  c.name = "contact";
  c.type = ConstraintType::rolling_disc;
  c.axis = Vector3::UnitY();
  c.radius = d.r;
  return Model({b}, Vector3(0, 0, -kG), {}, "disc", {}, {}, {}, {c});
}

// The state of the derivation at t = 0 with O' at the origin and e_r = X, turning at Omega and
// rolling (s from the rolling condition). Body axes: x = -Y (the direction of travel reversed),
// y = a, z = from P toward C.
void precessing_state(const SteadyDisc& d, double Omega, VectorX& q, VectorX& z) {
  const double st = std::sin(d.theta), ct = std::cos(d.theta);
  Matrix3 R;  // inertial -> body: its rows are the body's axes
  R.row(0) = -Vector3::UnitY();
  R.row(1) = Vector3(ct, 0, st);
  R.row(2) = Vector3(-st, 0, ct);
  const double s = -Omega * (d.rho + d.r * st) / d.r;
  q = VectorX(7);
  z = VectorX(6);
  q << euler_parameters_from_matrix(R), d.rho, 0, d.r * ct;
  z << 0, Omega * st + s, Omega * ct,  // w = Omega Z + s a in body components
      0, Omega * d.rho, 0;             // v_C
}

struct CircleError {
  double radius = 0, height = 0, phase = 0, lean = 0, force = 0;
};

// Runs the disc from precessing_state(Omega) for one period of the steady rate and returns the
// largest departures from the steady motion: C's distance from the vertical through O', its
// height, its angle about O' against Omega t, the lean, and the contact force against Newton's.
CircleError run_precession(const SteadyDisc& d, double Omega) {
  const Model model = disc_on_the_ground(d);
  VectorX q, z;
  precessing_state(d, Omega, q, z);
  const Projection p = project_onto_constraints(model, q, z);
  EXPECT_LE(std::max(p.coordinate_change, p.speed_change), 1e-14);  // already rolling
  const double steady = d.steady_rate(), period = 2 * std::numbers::pi / steady;
  CircleError e;
  const SimulationStats stats = simulate(
      model, q, z, tight(period, period / 16),
      [&](double t, const State&, const VectorX& qq, const VectorX&, Data& data) {
        const Vector3 C = qq.tail<3>();
        const double radius = std::hypot(C.x(), C.y());
        e.radius = std::max(e.radius, std::abs(radius - d.rho));
        e.height = std::max(e.height, std::abs(C.z() - d.r * std::cos(d.theta)));
        const double angle = std::atan2(C.y(), C.x());
        e.phase =
            std::max(e.phase, std::abs(std::remainder(angle - steady * t, 2 * std::numbers::pi)));
        const Vector3 axle = rotation_matrix(qq.head<4>()).row(1).transpose();
        e.lean = std::max(e.lean, std::abs(std::asin(std::clamp(axle.z(), -1.0, 1.0)) - d.theta));
        const Vector3 e_r(C.x() / radius, C.y() / radius, 0);
        const Vector3 F = d.m * (-steady * steady * d.rho * e_r + kG * Vector3::UnitZ());
        e.force = std::max(e.force, (data.reactions.head<3>() - F).norm());
      });
  EXPECT_TRUE(stats.ok()) << stats.message;
  return e;
}

// Over one period (4.5 s, about 750 steps) the disc stays on its circle and keeps its lean and
// phase. At rtol 1e-10 the integrator's global error in these lengths and angles is about 1e-10
// (the steady motion is stable at these parameters: the speed Omega rho = 1.4 m/s is above the
// upright disc's sqrt(g r / 3) = 1.0 m/s, so errors do not grow); 1e-8 leaves two orders for
// other compilers and optimization levels, and is 3e-8 of the disc's radius. The contact force:
// the normal m g and the centripetal m Omega^2 rho, to 1e-8 of m g. A wrong steady rate (or a
// disc whose inertia or contact kinematics were wrong) would show errors of order 0.1 here.
TEST(SteadyPrecession, ARollingDiscHoldsItsCircle) {
  const SteadyDisc d;
  const CircleError e = run_precession(d, d.steady_rate());
  EXPECT_LE(e.radius, 1e-8);
  EXPECT_LE(e.height, 1e-8);
  EXPECT_LE(e.phase, 1e-8);
  EXPECT_LE(e.lean, 1e-8);
  EXPECT_LE(e.force, 1e-8 * d.m * kG);
}

// Negative control: turning 10 % too fast (still rolling), the disc is not in equilibrium and
// leaves the circle by far more than the tolerance above (by 0.7 m within the period).
TEST(SteadyPrecession, AtTheWrongRateTheCircleIsNotHeld) {
  const SteadyDisc d;
  const CircleError e = run_precession(d, 1.1 * d.steady_rate());
  EXPECT_GT(e.radius, 1e-2);
  EXPECT_GT(e.lean, 1e-3);
}

// ---- 2. A stiff bushing converges to the ball ------------------------------------------------
//
// A spatial double pendulum: an upper rod on a revolute joint about x at the origin, and a lower
// body, free, whose origin O_2 sits at the upper rod's tip (its joint offset). Closed by a ball
// (O_2 and the tip coincide) it is the constrained mechanism; with a translational bushing of
// stiffness k between O_2 and the tip instead (the bushing acts at O_K and its reaction at the
// point of the lower body coinciding with it: the same pair of points) it is a tree. Where the
// pin carries a force F the bushing stretches by about |F| / k, so the motions differ by O(1/k):
// the quasi-static stretch, and the fast vibration the start excites (amplitude |F| / k), which
// the damping c = 2 zeta sqrt(k m) with zeta = 0.5 removes in a few periods.

Model double_pendulum(double stiffness) {
  BodySpec upper;
  upper.name = "upper";
  upper.mass = 1.5;
  upper.inertia = Vector3(0.13, 0.13, 0.01).asDiagonal();
  upper.com = Vector3(0, 0, -0.5);
  BodySpec lower;
  lower.name = "lower";
  lower.lower_body = 0;
  lower.mass = 1.0;
  lower.inertia = Vector3(0.03, 0.02, 0.015).asDiagonal();
  lower.com = Vector3(0.1, 0.05, -0.4);
  lower.joint = Vector3(0, 0, -1.0);  // the upper rod's tip
  const std::vector<Joint> joints{revolute(Vector3::UnitX()), Joint{}};
  if (stiffness > 0) {
    const double damping = 2 * 0.5 * std::sqrt(stiffness * lower.mass);
    std::vector<std::shared_ptr<const ForceElement>> forces{std::make_shared<Bushing>(
        1, Vector3::Constant(stiffness), Vector3::Constant(damping), 0.0, 0.0)};
    return Model({upper, lower}, Vector3(0, 0, -kG), forces, "bushed", joints);
  }
  Constraint pin;
  pin.name = "pin";
  pin.type = ConstraintType::ball;
  pin.body = 1;
  pin.other = 0;
  pin.other_at = Vector3(0, 0, -1.0);
  return Model({upper, lower}, Vector3(0, 0, -kG), {}, "pinned", joints, {}, {}, {pin});
}

// The upper rod's angle and the lower body's mass centre at each output of a 1 s run.
std::vector<VectorX> double_pendulum_run(const Model& model, const VectorX& q, const VectorX& z) {
  std::vector<VectorX> out;
  const SimulationStats stats =
      simulate(model, q, z, tight(1.0, 0.05),
               [&](double, const State&, const VectorX& qq, const VectorX&, Data& data) {
                 VectorX row(4);
                 row << qq[0], data.kinematics.p_G[1];
                 out.push_back(row);
               });
  EXPECT_TRUE(stats.ok()) << stats.message;
  return out;
}

// The differences for k = 1e3, 1e4, 1e5 shrink, each tenfold increase of k dividing them by
// between 5 and 20 (1/k would give 10; the bounds allow for the higher-order terms and for
// where along the run the largest difference falls), and at k = 1e5 they are below 1e-3 (the
// pin's force is about 30 N: the stretch is 3e-4 m).
TEST(StiffBushing, ConvergesToTheBallAsTheStiffnessGrows) {
  const Model pinned = double_pendulum(0.0);
  VectorX q(8), z(7);
  q << 0.5, euler_parameters_from_axis_angle(Vector3(0.3, 1.0, 0.2), 0.4), 0, 0, 0;
  z << 0.8, 1.0, -0.5, 2.0, 0, 0, 0;
  project_onto_constraints(pinned, q, z);
  const std::vector<VectorX> reference = double_pendulum_run(pinned, q, z);
  std::vector<double> difference;
  for (const double k : {1e3, 1e4, 1e5}) {
    const std::vector<VectorX> run = double_pendulum_run(double_pendulum(k), q, z);
    ASSERT_EQ(run.size(), reference.size());
    double worst = 0.0;
    for (size_t i = 0; i < run.size(); ++i)
      worst = std::max(worst, (run[i] - reference[i]).cwiseAbs().maxCoeff());
    difference.push_back(worst);
  }
  for (size_t i = 1; i < difference.size(); ++i) {
    const double ratio = difference[i - 1] / difference[i];
    EXPECT_GT(ratio, 5.0) << "k = 1e" << i + 3;
    EXPECT_LT(ratio, 20.0) << "k = 1e" << i + 3;
  }
  EXPECT_LT(difference.back(), 1e-3);
}

// ---- 3. Pendulums held by distance constraints -----------------------------------------------
//
// In the x-y plane, gravity along -y. The revolute pendulum: a body on a revolute joint about z
// at the origin, its mass centre G at (0, -L) in its own axes. Its equation, about the pivot:
// (I_zz + m L^2) theta'' = -m g L sin(theta).

constexpr double kBobMass = 1.5, kArm = 1.2, kIzz = 0.05;

BodySpec bob() {
  BodySpec b;
  b.name = "bob";
  b.mass = kBobMass;
  b.inertia = Vector3(0.04, 0.03, kIzz).asDiagonal();
  b.com = Vector3(0, -kArm, 0);
  return b;
}

double revolute_angular_acceleration(double theta) {
  return -kBobMass * kG * kArm * std::sin(theta) / (kIzz + kBobMass * kArm * kArm);
}

Constraint rod_to_pivot(const std::string& name, const Vector3& at, double length) {
  Constraint c;
  c.name = name;
  c.type = ConstraintType::distance;
  c.at = at;
  c.length = length;  // to the ground's origin
  return c;
}

// The same body on a planar joint (x, y, angle), held by two rods of fixed length from the pivot
// to the body points (+-a, -L): the triangle pivot-P1-P2 is rigid, so the body can only turn
// about the pivot, as on the revolute joint.
constexpr double kHalfBase = 0.3;

Model triangle_pendulum() {
  const double length = std::hypot(kHalfBase, kArm);
  return Model({bob()}, Vector3(0, -kG, 0), {}, "triangle", {planar()}, {}, {},
               {rod_to_pivot("rod1", Vector3(kHalfBase, -kArm, 0), length),
                rod_to_pivot("rod2", Vector3(-kHalfBase, -kArm, 0), length)});
}

// The swing angles agree to the integrators' tolerance (rtol 1e-10: the two runs' global errors
// differ by about 1e-10 over 2 s, about one period; 1e-9 allowed), the pivot stays put to the
// projection's 1e-12 times the lever arm, and the rods' forces are Newton's: along each rod (from
// the pivot to its body point, e_i), f_1 + f_2 = m (a_G - g), a_G = L theta'' t - L theta'^2 n from
// the revolute equation at the state's theta and theta' (n from the pivot to G, t normal to it in
// the direction of theta), two equations in the two tensions. Their moments about the pivot vanish,
// as the revolute joint's do. Round-off in the 2 x 2 solve and in the multipliers: 1e-9 of m g.
TEST(DistanceConstraint, TwoRodsSwingAsTheRevolutePendulum) {
  const Model triangle = triangle_pendulum();
  const Model pendulum({bob()}, Vector3(0, -kG, 0), {}, "revolute", {revolute(Vector3::UnitZ())});
  const double theta0 = 0.9, rate0 = 0.6;
  VectorX q(3), z(3);
  q << 0, 0, theta0;
  z << 0, 0, rate0;
  const Projection p = project_onto_constraints(triangle, q, z);
  EXPECT_LE(p.coordinate_change, 1e-14);
  std::vector<double> triangle_angle, revolute_angle;
  const SimulationSettings s = tight(2.0, 0.1);
  double worst_force = 0.0, worst_pivot = 0.0;
  simulate(triangle, q, z, s,
           [&](double, const State&, const VectorX& qq, const VectorX& zz, Data& data) {
             triangle_angle.push_back(qq[2]);
             worst_pivot = std::max(worst_pivot, std::hypot(qq[0], qq[1]));
             const double theta = qq[2], rate = zz[2];
             const Vector3 n(std::sin(theta), -std::cos(theta), 0),
                 t(std::cos(theta), std::sin(theta), 0);
             const Vector3 a_G =
                 kArm * revolute_angular_acceleration(theta) * t - kArm * rate * rate * n;
             const Vector3 net = kBobMass * (a_G - Vector3(0, -kG, 0));
             const Matrix3 R =
                 rotation_matrix(euler_parameters_from_axis_angle(Vector3::UnitZ(), theta));
             const Vector3 e1 = (R.transpose() * Vector3(kHalfBase, -kArm, 0)).normalized();
             const Vector3 e2 = (R.transpose() * Vector3(-kHalfBase, -kArm, 0)).normalized();
             Eigen::Matrix2d E;
             E << e1.head<2>(), e2.head<2>();
             const Eigen::Vector2d tension = E.partialPivLu().solve(net.head<2>());
             worst_force =
                 std::max({worst_force, (data.reactions.head<3>() - tension[0] * e1).norm(),
                           (data.reactions.tail<3>() - tension[1] * e2).norm()});
           });
  simulate(pendulum, VectorX::Constant(1, theta0), VectorX::Constant(1, rate0), s,
           [&](double, const State&, const VectorX& qq, const VectorX&, Data&) {
             revolute_angle.push_back(qq[0]);
           });
  ASSERT_EQ(triangle_angle.size(), revolute_angle.size());
  double worst_angle = 0.0, travel = 0.0;
  for (size_t i = 0; i < revolute_angle.size(); ++i) {
    worst_angle = std::max(worst_angle, std::abs(triangle_angle[i] - revolute_angle[i]));
    travel = std::max(travel, std::abs(revolute_angle[i] - theta0));
  }
  EXPECT_LE(worst_angle, 1e-9);
  EXPECT_GT(travel, 1.0);  // it swung through the bottom
  EXPECT_LE(worst_pivot, 1e-11);
  EXPECT_LE(worst_force, 1e-9 * kBobMass * kG);
}

// A point mass on a rod: a body on a planar joint held at its mass centre G (its O_K) by one
// distance constraint of length L to the pivot. The rod's force passes through G, so the body's
// turn about z is free and uncoupled (a constant rate), and G swings as the simple pendulum,
// whose rod pulls with the tension T = m (g cos(theta) + L theta'^2) toward the pivot (the
// radial component of Newton's second law, theta from the downward vertical). theta and theta'
// are read from the state; the multipliers' round-off: 1e-9 of m g.
TEST(DistanceConstraint, APointMassOnARodPullsWithTheSimplePendulumsTension) {
  BodySpec point = bob();
  point.com = Vector3::Zero();
  const Model model({point}, Vector3(0, -kG, 0), {}, "simple", {planar()}, {}, {},
                    {rod_to_pivot("rod", Vector3::Zero(), kArm)});
  const double theta0 = 1.2, rate0 = -0.8, spin = 0.7;
  VectorX q(3), z(3);
  q << kArm * std::sin(theta0), -kArm * std::cos(theta0), 0.0;
  z << kArm * rate0 * std::cos(theta0), kArm * rate0 * std::sin(theta0), spin;
  const Projection p = project_onto_constraints(model, q, z);
  EXPECT_LE(std::max(p.coordinate_change, p.speed_change), 1e-14);
  double worst_force = 0.0, worst_spin = 0.0, largest_tension = 0.0;
  simulate(model, q, z, tight(2.0, 0.05),
           [&](double, const State&, const VectorX& qq, const VectorX& zz, Data& data) {
             const double theta = std::atan2(qq[0], -qq[1]);
             const double rate = (qq[0] * zz[1] - qq[1] * zz[0]) / (kArm * kArm);
             const double tension = kBobMass * (kG * std::cos(theta) + kArm * rate * rate);
             const Vector3 toward_pivot(-std::sin(theta), std::cos(theta), 0);
             worst_force = std::max(worst_force, (data.reactions - tension * toward_pivot).norm());
             worst_spin = std::max(worst_spin, std::abs(zz[2] - spin));
             largest_tension = std::max(largest_tension, tension);
           });
  EXPECT_LE(worst_force, 1e-9 * kBobMass * kG);
  EXPECT_LE(worst_spin, 1e-10);
  EXPECT_GT(largest_tension, 1.5 * kBobMass * kG);  // the rod did more than hold the weight
}

// ---- 4. Reactions as the loads on the cut tree ------------------------------------------------
//
// Kane's auxiliary speeds bring a constraint's reaction into the equations as an active force:
// cut the constraint, and the reaction is the load that, applied to the tree at the constraint's
// point, gives the tree the accelerations the constraint allows. So: the tree without the
// constraint, with inputs at the point (forces along the body's axes, and for a hinge moments
// about the two body axes normal to the hinge's), its forward dynamics at the constrained run's
// state (the tree's own, Dynamics::forward, never the constraint code), affine in the inputs:
// three evaluations give it exactly; the inputs that make the constraint's accelerations vanish
// solve a small linear system. The comparison is at one state, so only round-off separates the
// two: 1e-9 of the weights.

Input force_input(const std::string& name, int body, const Vector3& direction,
                  const Vector3& point) {
  Input in;
  in.name = name;
  in.type = InputType::force;
  in.body = body;
  in.direction = direction;
  in.point = point;
  return in;
}

Input torque_input(const std::string& name, int body, const Vector3& axis) {
  Input in;
  in.name = name;
  in.type = InputType::torque;
  in.body = body;
  in.axis = axis;
  return in;
}

// The inputs u that make residual(zdot(u)) = 0, residual affine in zdot and zdot affine in u.
template <typename Residual>
VectorX loads_that_satisfy(Dynamics& tree, const VectorX& q, const VectorX& z, int inputs,
                           const Residual& residual) {
  VectorX zdot(tree.model().num_speeds());
  VectorX u = VectorX::Zero(inputs);
  tree.forward(q, z, u, zdot);
  const VectorX r0 = residual(q, z, zdot);
  MatrixX J(r0.size(), inputs);
  for (int i = 0; i < inputs; ++i) {
    u.setZero();
    u[i] = 1.0;
    tree.forward(q, z, u, zdot);
    J.col(i) = residual(q, z, zdot) - r0;
  }
  return J.partialPivLu().solve(-r0);
}

// The four-bar of examples/four_bar.yaml (links along their own x, joints about z, gravity
// along -y), cut at its closure: the rocker's far end (0.9, 0, 0) must not accelerate. The
// planar tip acceleration is sum_i L_i (alpha_i e_i' - w_i^2 e_i) over the links at the
// absolute angles t_i, e_i = (cos t_i, sin t_i), e_i' = (-sin t_i, cos t_i). The in-plane force
// is determined; the hinge's other components are the redundant rows' minimum-norm share
// (tests/test_constraint_outputs.cpp checks them).
TEST(CutConstraint, TheFourBarsClosureForceIsTheLoadThatHoldsTheCutTree) {
  const io::ModelFile f = io::load_model_file(KANEDYN_SOURCE_DIR "/examples/four_bar.yaml");
  const Model& closed = f.model;
  std::vector<BodySpec> bodies = closed.bodies();
  std::vector<Joint> joints;
  for (int k = 0; k < closed.num_bodies(); ++k) joints.push_back(closed.joint(k));
  const Vector3 tip(0.9, 0, 0);
  const Model cut(
      bodies, closed.gravity(), closed.forces(), "cut", joints, {},
      {force_input("fx", 2, Vector3::UnitX(), tip), force_input("fy", 2, Vector3::UnitY(), tip)});
  Dynamics tree(cut);
  const double lengths[3] = {0.4, 1.2, 0.9};
  const auto tip_acceleration = [&](const VectorX& q, const VectorX& z, const VectorX& zdot) {
    Eigen::Vector2d a = Eigen::Vector2d::Zero();
    double t = 0, w = 0, alpha = 0;
    for (int i = 0; i < 3; ++i) {
      t += q[i];
      w += z[i];
      alpha += zdot[i];
      const Eigen::Vector2d e(std::cos(t), std::sin(t)), e_normal(-std::sin(t), std::cos(t));
      a += lengths[i] * (alpha * e_normal - w * w * e);
    }
    return VectorX(a);
  };
  double worst = 0.0, largest = 0.0;
  int rows = 0;
  simulate(closed, f.q, f.z, tight(2.0, 0.1),
           [&](double, const State&, const VectorX& q, const VectorX& z, Data& data) {
             const VectorX u = loads_that_satisfy(tree, q, z, 2, tip_acceleration);
             const double t3 = q[0] + q[1] + q[2];  // the rocker's axes turned by t3 about z
             const Eigen::Vector2d force = u[0] * Eigen::Vector2d(std::cos(t3), std::sin(t3)) +
                                           u[1] * Eigen::Vector2d(-std::sin(t3), std::cos(t3));
             worst = std::max(worst, (data.reactions.head<2>() - force).norm());
             largest = std::max(largest, force.norm());
             ++rows;
           });
  EXPECT_EQ(rows, 21);
  EXPECT_LE(worst, 1e-9 * 4.5 * kG);  // the linkage weighs 4.5 kg
  EXPECT_GT(largest, 1.0);            // the closure did carry a load
}

// A free body hinged about x at its origin O_K, its inertia with products about the hinge's
// axes and its mass centre off it: the hinge carries a force and, because the axis is not
// principal, a moment normal to the axis (the dynamic imbalance of a rotor). Cut: forces along
// the body's x, y, z at O_K and moments about its y and z; the hinge allows a_O = 0 (the root's
// s'' is O_K's inertial acceleration) and, the angular velocity being along the fixed axis,
// an angular acceleration along it only: the y and z components of w' dot are zero. Five
// equations, five inputs; the force and moment in inertial components are R^T of the body's.
TEST(CutConstraint, AHingesForceAndMomentAreTheLoadsThatHoldTheCutBody) {
  BodySpec b;
  b.name = "rotor";
  b.mass = 2.0;
  b.inertia << 0.30, 0.05, -0.04,  //
      0.05, 0.25, 0.06,            //
      -0.04, 0.06, 0.20;
  b.com = Vector3(0.1, 0.2, -0.5);
  Constraint hinge;
  hinge.name = "hinge";
  hinge.type = ConstraintType::hinge;
  hinge.axis = Vector3::UnitX();
  hinge.other_axis = Vector3::UnitX();
  const Model hinged({b}, Vector3(0, 0, -kG), {}, "hinged", {}, {}, {}, {hinge});
  const Model cut(
      {b}, Vector3(0, 0, -kG), {}, "cut", {}, {},
      {force_input("fx", 0, Vector3::UnitX(), Vector3::Zero()),
       force_input("fy", 0, Vector3::UnitY(), Vector3::Zero()),
       force_input("fz", 0, Vector3::UnitZ(), Vector3::Zero()),
       torque_input("my", 0, Vector3::UnitY()), torque_input("mz", 0, Vector3::UnitZ())});
  Dynamics tree(cut);
  const auto held = [](const VectorX&, const VectorX&, const VectorX& zdot) {
    VectorX r(5);
    r << zdot[1], zdot[2], zdot.tail<3>();  // w' dot across the axis, a_O
    return r;
  };
  VectorX q(7), z(6);
  q << euler_parameters_from_axis_angle(Vector3::UnitX(), 0.6), 0, 0, 0;
  z << 3.0, 0, 0, 0, 0, 0;
  project_onto_constraints(hinged, q, z);
  double worst_force = 0.0, worst_moment = 0.0, largest_moment = 0.0;
  simulate(hinged, q, z, tight(1.0, 0.1),
           [&](double, const State&, const VectorX& qq, const VectorX& zz, Data& data) {
             const VectorX u = loads_that_satisfy(tree, qq, zz, 5, held);
             const Matrix3 R = rotation_matrix(qq.head<4>());  // inertial -> body
             const Vector3 force = R.transpose() * u.head<3>();
             const Vector3 moment = R.transpose() * Vector3(0, u[3], u[4]);
             worst_force = std::max(worst_force, (data.reactions.head<3>() - force).norm());
             worst_moment = std::max(worst_moment, (data.reactions.tail<3>() - moment).norm());
             largest_moment = std::max(largest_moment, moment.norm());
           });
  EXPECT_LE(worst_force, 1e-9 * b.mass * kG);
  EXPECT_LE(worst_moment, 1e-9 * b.mass * kG * 0.5);  // the weight's moment arm: 0.5 m
  EXPECT_GT(largest_moment, 0.5);                     // the products of inertia did load it
}

}  // namespace
}  // namespace kanedyn
