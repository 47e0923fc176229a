// The spatial RSSR linkage of examples/rssr.yaml: a crank and a rocker on revolute joints about
// skew axes, a coupler on a spherical joint at the crank's tip, the loop closed by a ball at the
// rocker's tip. Along a simulated run its position and velocity analyses are checked against
// the closed-form input-output equation, its energy is conserved, its closure holds, the idle
// spin of the coupler stays zero, and the reported reaction turns the rocker as its moment of
// inertia says.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "kanedyn/constraints.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/simulate.hpp"

namespace kanedyn {
namespace {

// The geometry of examples/rssr.yaml (its header comment): the crank's tip B = a (cos theta,
// sin theta, 0); the rocker's tip C = D0 + c (cos phi e1 + sin phi e2), e1 the rocker's
// direction at phi = 0 and e2 = u x e1, u its axis; the coupler's length L.
struct Rssr {
  double a = 0.3, c = 0.7, L = 1.2;
  Vector3 D0{0.4, 0.9, 0.5}, u{0.8, 0.0, 0.6}, e1{0.0, -1.0, 0.0};
  Vector3 e2() const { return u.cross(e1); }
  Vector3 B(double theta) const { return a * Vector3(std::cos(theta), std::sin(theta), 0); }
  Vector3 B_rate(double theta, double theta_dot) const {
    return a * theta_dot * Vector3(-std::sin(theta), std::cos(theta), 0);
  }
  Vector3 C(double phi) const { return D0 + c * (std::cos(phi) * e1 + std::sin(phi) * e2()); }

  // |C - B|^2 = L^2 with r = B - D0: r.r + c^2 - 2 c (cos phi r.e1 + sin phi r.e2) = L^2, that
  // is K1 cos phi + K2 sin phi = K3 with K1 = 2 c r.e1, K2 = 2 c r.e2, K3 = r.r + c^2 - L^2.
  struct Coefficients {
    double K1, K2, K3;
  };
  Coefficients coefficients(double theta) const {
    const Vector3 r = B(theta) - D0;
    return {2 * c * r.dot(e1), 2 * c * r.dot(e2()), r.squaredNorm() + c * c - L * L};
  }
  // The solutions phi = atan2(K2, K1) +- acos(K3 / hypot(K1, K2)); branch is the sign.
  double rocker_angle(double theta, double branch) const {
    const Coefficients k = coefficients(theta);
    return std::atan2(k.K2, k.K1) + branch * std::acos(k.K3 / std::hypot(k.K1, k.K2));
  }
  // The time derivative of the equation: (K2 cos phi - K1 sin phi) phi dot = K3 dot - K1 dot
  // cos phi - K2 dot sin phi, with K1 dot = 2 c B dot . e1, K2 dot = 2 c B dot . e2 and K3 dot
  // = 2 r . B dot.
  double rocker_rate(double theta, double theta_dot, double phi) const {
    const Coefficients k = coefficients(theta);
    const Vector3 r = B(theta) - D0, v = B_rate(theta, theta_dot);
    const double K1d = 2 * c * v.dot(e1), K2d = 2 * c * v.dot(e2()), K3d = 2 * r.dot(v);
    return (K3d - K1d * std::cos(phi) - K2d * std::sin(phi)) /
           (k.K2 * std::cos(phi) - k.K1 * std::sin(phi));
  }
};

double wrap(double angle) { return std::remainder(angle, 2 * std::numbers::pi); }

TEST(Rssr, TheLoaderClosesTheLoopWithTwoDegreesOfFreedom) {
  const io::ModelFile f = io::load_model_file(KANEDYN_SOURCE_DIR "/examples/rssr.yaml");
  const Model& m = f.model;
  ASSERT_EQ(m.num_bodies(), 3);
  EXPECT_EQ(m.num_speeds(), 5);
  EXPECT_EQ(f.partition.rank, 3);  // the ball's 3 rows are independent
  EXPECT_TRUE(f.partition.redundant_rows.empty());
  EXPECT_EQ(f.partition.independent, (std::vector<int>{0, 1}));  // crank.jd1, coupler.w1
  // The file's rounded initial coordinates were within 1e-4 of the loop: the projection moved
  // them by less than 1e-3 (and the crank's angle, an independent coordinate, not at all).
  EXPECT_EQ(f.q[0], 0.5);
  ConstraintEquations eq(m);
  eq.evaluate(f.q, f.z);
  EXPECT_LE(eq.errors().cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((eq.B() * f.z).cwiseAbs().maxCoeff(), 1e-12);
  const Rssr g;
  EXPECT_LT(std::abs(wrap(f.q[5] - g.rocker_angle(0.5, 1.0))), 1e-9);
}

// Along a 4 s run (rtol 1e-10) at every output:
// - the rocker's angle is the input-output equation's for the crank's angle, on the file's
//   branch (+), to 1e-9 rad: the holonomic error after each step's projection is below 1e-10 m
//   (checked below), and an error e of |C - B| moves phi by e L / |(C - B) . dC/dphi|, at most
//   some 5 e here (the lever is never below 0.8 |C - B| c sin: the rocker stays away from its
//   dead points, |K3| / hypot(K1, K2) <= 0.6);
// - the rocker's rate is the velocity analysis's for the crank's rate, to 1e-9 (the speeds are
//   projected to round-off, the same ratio of levers);
// - the energy is conserved to 1e-7 of the largest kinetic energy (rtol 1e-10 per step; the
//   drift measured is 3e-10 of it, the bound left loose for other compilers and libms);
// - the closure holds to 1e-10 m;
// - the coupler's spin about its own axis keeps its initial value (about 5e-5 rad/s, from the
//   file's rounding): no load on it has a moment about the line through its balls and its
//   inertia is symmetric about it (to the integrator's tolerance: 1e-8 rad/s).
TEST(Rssr, FollowsItsInputOutputEquationAndConservesEnergy) {
  const io::ModelFile f = io::load_model_file(KANEDYN_SOURCE_DIR "/examples/rssr.yaml");
  const Model& m = f.model;
  const int crank = m.coordinate_offset(0), rocker = m.coordinate_offset(2);
  const int crank_rate = m.speed_offset(0), rocker_rate = m.speed_offset(2);
  const Rssr g;
  SimulationSettings s;
  s.t_end = 4.0;
  s.dt_out = 0.02;
  s.rtol = 1e-10;
  s.atol = 1e-12;
  Data data(m);
  const double e0 = total_energy(m, f.q, f.z, data);
  ConstraintEquations eq(m);
  double worst_angle = 0, worst_rate = 0, worst_energy = 0, worst_closure = 0, worst_spin = 0;
  const double spin0 = f.initial.angular_velocity(1).x();  // w'_K in the coupler's axes
  double kinetic = 0, theta_min = f.q[0], theta_max = f.q[0], phi_min = 1e9, phi_max = -1e9;
  int checked = 0;
  simulate(m, f.q, f.z, s,
           [&](double, const State& state, const VectorX& q, const VectorX& z, Data& out) {
             const double theta = q[crank], phi = q[rocker];
             theta_min = std::min(theta_min, theta);
             theta_max = std::max(theta_max, theta);
             phi_min = std::min(phi_min, phi);
             phi_max = std::max(phi_max, phi);
             worst_angle = std::max(worst_angle, std::abs(wrap(phi - g.rocker_angle(theta, 1.0))));
             const double expected = g.rocker_rate(theta, z[crank_rate], phi);
             worst_rate = std::max(worst_rate, std::abs(z[rocker_rate] - expected) /
                                                   std::max(1.0, std::abs(expected)));
             eq.evaluate(q, z);
             worst_closure = std::max(worst_closure, eq.errors().cwiseAbs().maxCoeff());
             worst_spin = std::max(worst_spin, std::abs(state.angular_velocity(1).x() - spin0));
             const double e = total_energy(m, q, z, out);
             worst_energy = std::max(worst_energy, std::abs(e - e0));
             kinetic = std::max(kinetic, kinetic_energy(m, q, z, out));
             ++checked;
           });
  EXPECT_EQ(checked, 201);
  EXPECT_LT(worst_angle, 1e-9);
  EXPECT_LT(worst_rate, 1e-9);
  EXPECT_LT(worst_closure, 1e-10);
  EXPECT_LT(worst_spin, 1e-8);
  EXPECT_LT(worst_energy, 1e-7 * kinetic);
  // The run covers the linkage's motion: the crank turns all the way round, the rocker swings.
  EXPECT_GT(theta_max - theta_min, 2 * std::numbers::pi);
  EXPECT_GT(phi_max - phi_min, 0.5);
}

// The reaction the run reports is the closure's force f on the coupler at C (inertial): its
// opposite turns the rocker, a body on a fixed axis u through D0, with gravity:
// I_u phi ddot = u . ((C - D0) x (-f) + (G - D0) x m g). I_u about the axis is the rocker's
// inertia about u at G (0.06125, its inertia being 0.06125 across the rod) plus m |G - D0|^2
// (G - D0 is normal to u): 0.06125 + 1.5 * 0.35^2. Round-off of the moments: 1e-12 relative.
TEST(Rssr, TheReportedReactionTurnsTheRocker) {
  const io::ModelFile f = io::load_model_file(KANEDYN_SOURCE_DIR "/examples/rssr.yaml");
  const Model& m = f.model;
  const Rssr g;
  const double mass = 1.5, inertia = 0.06125 + mass * 0.35 * 0.35;
  SimulationSettings s;
  s.t_end = 1.0;
  s.dt_out = 0.1;
  ConstrainedDynamics dynamics(m);
  VectorX zdot(m.num_speeds());
  int checked = 0;
  simulate(m, f.q, f.z, s,
           [&](double, const State&, const VectorX& q, const VectorX& z, Data& out) {
             const double phi = q[m.coordinate_offset(2)];
             dynamics.evaluate(q, z, VectorX(), zdot);
             const Vector3 force = out.reactions.head<3>();
             const Vector3 arm = g.C(phi) - g.D0, centre = 0.5 * arm;
             const double moment = g.u.dot(arm.cross(-force) + centre.cross(mass * m.gravity()));
             const double scale = arm.norm() * force.norm() + centre.norm() * mass * 9.81;
             EXPECT_NEAR(inertia * zdot[m.speed_offset(2)], moment, 1e-12 * scale);
             EXPECT_GT(force.norm(), 1.0);  // a real load, not a vanishing one
             ++checked;
           });
  EXPECT_EQ(checked, 11);
}

}  // namespace
}  // namespace kanedyn
