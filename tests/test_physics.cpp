// Physical checks of the equations of motion: a torque-free body conserves energy and
// angular momentum, free fall, static equilibrium on bushings (solved by hand). The energy
// balance with damping and the momentum balance of a floating system: test_energy.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/partials.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

constexpr Route kMethods[] = {Route::assembled, Route::recursive};

using test::mass_centre_accelerations;

using test::evaluate;
using test::Evaluated;

BodySpec random_body(std::mt19937& rng, const std::string& name, int lower) {
  BodySpec b;
  b.name = name;
  b.lower_body = lower;
  b.mass = test::uniform(rng, 0.5, 5.0);
  b.inertia = test::random_inertia(rng, b.mass);
  b.com = test::random_vector(rng, -0.5, 0.5);
  b.joint = test::random_vector(rng, -0.5, 0.5);
  return b;
}

TEST(Physics, TorqueFreeBodyConservesEnergyAndAngularMomentum) {
  // Single free body, no gravity, asymmetric full inertia, r' != 0 (so O is not G and the
  // translation/rotation coupling of Eqs. 21, 29 is exercised).
  //   dE/dt = m v_G.a_G + w'.I w'dot = 0 and
  //   dH/dt = m p_G x a_G + R^T(w' x I w' + I w'dot) = 0 (H about the inertial origin).
  // Terms are O(m |v|^2 |w|) ~ 100 at most; round-off 1e-12 relative to their size.
  std::mt19937 rng(51);
  for (int i = 0; i < 20; ++i) {
    BodySpec b = random_body(rng, "free", kGround);
    ASSERT_GT(b.com.norm(), 0.0);
    const Model model({b});
    const State state = test::random_state(model, rng, 1.0, 3.0, 2.0);
    for (const Route method : kMethods) {
      Evaluated e = evaluate(model, state, method);
      const std::vector<Vector3> a = mass_centre_accelerations(model, state, e.data, e.ydot);
      const Vector3 w = state.angular_velocity(0);
      const Vector3 wdot = e.ydot.head<3>();
      const Vector3& v = e.data.kinematics.v_G[0];
      const double de = b.mass * v.dot(a[0]) + w.dot(b.inertia * wdot);
      const double e_scale = b.mass * v.norm() * a[0].norm() + w.norm() * (b.inertia * wdot).norm();
      EXPECT_LT(std::abs(de), 1e-12 * (e_scale + 1.0)) << to_string(method);
      const Vector3 dh =
          b.mass * e.data.kinematics.p_G[0].cross(a[0]) +
          e.data.kinematics.R[0].transpose() * (w.cross(b.inertia * w) + b.inertia * wdot);
      const double h_scale = b.mass * e.data.kinematics.p_G[0].norm() * a[0].norm() +
                             (b.inertia * w).norm() * w.norm();
      EXPECT_LT(dh.norm(), 1e-12 * (h_scale + 1.0)) << to_string(method);
      // G moves uniformly: a_G = 0 (no force at all).
      EXPECT_LT(a[0].norm(), 1e-12 * (w.squaredNorm() * b.com.norm() + 1.0));
    }
  }
}

TEST(Physics, TorqueFreeBodyFiniteDifferenceOfInvariants) {
  // The same invariants by finite differences of energy.hpp along (xdot, ydot): truncation
  // h^2/6 |E'''| with h = 1e-5 and |E'''| <= ~1e3 gives <= 2e-8, round-off
  // 1e-16 |E| / h ~ 1e-9. Tolerance 1e-7 relative to (1 + |E| |w|), while a missing
  // gyroscopic or coupling term changes the rate by O(1).
  std::mt19937 rng(52);
  const double h = 1e-5;
  for (int i = 0; i < 10; ++i) {
    const Model model({random_body(rng, "free", kGround)});
    const State state = test::random_state(model, rng, 1.0, 3.0, 2.0);
    for (const Route method : kMethods) {
      Data data(model);
      forward_dynamics(model, state, data, method);
      const State sp = test::advance(state, data.xdot, data.ydot, h);
      const State sm = test::advance(state, data.xdot, data.ydot, -h);
      const double e0 = total_energy(model, state, data);
      const double scale = 1.0 + std::abs(e0) * state.y.head<3>().norm();
      const double de = (total_energy(model, sp, data) - total_energy(model, sm, data)) / (2 * h);
      EXPECT_LT(std::abs(de), 1e-7 * scale) << to_string(method);
      const Vector3 dh =
          (angular_momentum(model, sp, data) - angular_momentum(model, sm, data)) / (2 * h);
      EXPECT_LT(dh.norm(), 1e-7 * scale) << to_string(method);
    }
  }
}

TEST(Physics, FreeFall) {
  // A single root body under gravity, nothing else. With w' = 0 the body does not start to
  // turn (w'dot = 0) and its origin falls with g: s'' = g (root s' is inertial). Exact up to
  // round-off of O(|g|) numbers.
  std::mt19937 rng(53);
  const Vector3 g(0.7, -1.3, -9.81);
  for (int i = 0; i < 10; ++i) {
    const Model model({random_body(rng, "falling", kGround)}, g);
    State state = test::random_state(model, rng);
    state.angular_velocity(0).setZero();
    for (const Route method : kMethods) {
      Evaluated e = evaluate(model, state, method);
      EXPECT_LT((e.ydot.tail<3>() - g).norm(), 1e-13) << to_string(method);
      EXPECT_LT(e.ydot.head<3>().norm(), 1e-13) << to_string(method);
    }
  }
  // Spinning: G still falls with g, and w' obeys the torque-free Euler equation
  // I w'dot = -w' x I w', while s'' of the origin O != G picks up the rotation terms.
  for (int i = 0; i < 10; ++i) {
    const BodySpec b = random_body(rng, "spinning", kGround);
    const Model model({b}, g);
    const State state = test::random_state(model, rng, 0.3, 3.0, 1.0);
    for (const Route method : kMethods) {
      Evaluated e = evaluate(model, state, method);
      const std::vector<Vector3> a = mass_centre_accelerations(model, state, e.data, e.ydot);
      EXPECT_LT((a[0] - g).norm(), 1e-12) << to_string(method);
      const Vector3 w = state.angular_velocity(0);
      const Vector3 wdot = -model.inverse_inertia(0) * w.cross(b.inertia * w);
      EXPECT_LT((e.ydot.head<3>() - wdot).norm(), 1e-12 * (1.0 + wdot.norm()));
    }
  }
}

TEST(Physics, BushingStaticEquilibriumSingleBody) {
  // A body on a bushing to the ground under gravity, identity orientation, zero speeds.
  // Force balance -diag(k) s' + m g = 0 gives s' = m g ./ k; with r' parallel to g gravity
  // has no moment about O, and theta = 0, so the body stays: ydot = 0.
  // Round-off of m g ~ 50 relative 1e-16, divided by m: 1e-12 absolute is ample; a
  // deflection off by 1% gives |ydot| ~ 0.1.
  const Vector3 g(1.5, -2.0, -9.0);
  const Vector3 k(400.0, 250.0, 900.0);
  BodySpec b;
  b.name = "hanging";
  b.mass = 3.0;
  b.inertia << 0.30, 0.02, -0.01, 0.02, 0.25, 0.03, -0.01, 0.03, 0.2;
  b.com = -0.04 * g;
  b.joint = Vector3(0.3, 0.1, 1.0);
  auto bushing = std::make_shared<Bushing>(0, k, Vector3(5.0, 6.0, 7.0), 30.0, 2.0);
  const Model model({b}, g, {bushing});
  State state(model);
  state.translation(0) = b.mass * g.cwiseQuotient(k);
  for (const Route method : kMethods) {
    Data data(model);
    forward_dynamics(model, state, data, method);
    EXPECT_LT(data.ydot.norm(), 1e-12) << to_string(method);
  }
  // Displaced by d from equilibrium the resultant force is -diag(k) d (gravity cancels the
  // equilibrium part), so by hand m a_G = -diag(k) d.
  const Vector3 d(0.01, -0.02, 0.005);
  state.translation(0) += d;
  Evaluated e = evaluate(model, state, Route::assembled);
  const std::vector<Vector3> a = mass_centre_accelerations(model, state, e.data, e.ydot);
  EXPECT_LT((a[0] + k.cwiseProduct(d) / b.mass).norm(), 1e-12);
}

TEST(Physics, BushingStaticEquilibriumTwoBodyChain) {
  // Body 1 on a bushing to the ground, body 2 on a bushing to body 1, identity orientations,
  // zero speeds. By hand: bushing 2 carries body 2, k2 s'_2 = m2 g; bushing 1 carries both,
  // diag(k1) s'_1 = (m1 + m2) g. Moments about each G vanish when the lever arms r'_1, q'_2,
  // r'_2 and s'_2 (isotropic k2) are parallel to g; theta = 0 for both bushings.
  const Vector3 g(1.5, -2.0, -9.0);
  const Vector3 k1(500.0, 800.0, 1200.0);
  const double k2 = 300.0;
  BodySpec b1, b2;
  b1.name = "upper";
  b1.mass = 4.0;
  b1.inertia << 0.4, 0.05, 0.0, 0.05, 0.35, -0.02, 0.0, -0.02, 0.3;
  b1.com = 0.02 * g;
  b1.joint = Vector3(-0.2, 0.4, 2.0);
  b2.name = "lower";
  b2.lower_body = 0;
  b2.mass = 1.5;
  b2.inertia << 0.1, -0.01, 0.02, -0.01, 0.12, 0.0, 0.02, 0.0, 0.09;
  b2.com = 0.03 * g;
  b2.joint = 0.05 * g;
  const std::vector<std::shared_ptr<const ForceElement>> forces = {
      std::make_shared<Bushing>(0, k1, Vector3(3.0, 3.0, 3.0), 40.0, 1.0),
      std::make_shared<Bushing>(1, Vector3::Constant(k2), Vector3(1.0, 2.0, 3.0), 25.0, 0.5)};
  const Model model({b1, b2}, g, forces);
  State state(model);
  state.translation(0) = (b1.mass + b2.mass) * g.cwiseQuotient(k1);
  state.translation(1) = b2.mass * g / k2;
  for (const Route method : kMethods) {
    Data data(model);
    forward_dynamics(model, state, data, method);
    EXPECT_LT(data.ydot.norm(), 1e-12) << to_string(method) << " " << data.ydot.transpose();
  }
  // The wrong split (each bushing carrying only its own body) is not an equilibrium.
  state.translation(0) = b1.mass * g.cwiseQuotient(k1);
  Data data(model);
  forward_dynamics(model, state, data, Route::assembled);
  EXPECT_GT(data.ydot.norm(), 1.0);
}

}  // namespace
}  // namespace kanedyn
