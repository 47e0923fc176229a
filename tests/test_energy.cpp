// Energy and momentum (energy.hpp): kinetic, potential and total energy against values worked
// out by hand and against 1/2 y^T [A] y (Eq. 37), total_energy_of_kinematics against
// total_energy, the energy balance d(total_energy)/dt = -damping_power and the potential's
// rate against the power of the conservative loads along the motion, and the momenta: by
// hand, as the rate of the mass moment, and their balance for a floating system.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/rotation.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

constexpr Route kMethods[] = {Route::assembled, Route::recursive};

// One root body, m = 2, [I'] = diag(0.3, 0.4, 0.5), q' = (0, 0, 1), r' = (0, 0, 0.5), on a
// bushing to the ground with k = (100, 200, 300), c = (1, 2, 3), kr = 50, cr = 2, under
// g = (0, 0, -9.81); s' = (0.01, -0.02, 0.03), s' dot = (1, 2, 3), w' = (0.1, 0.2, 0.3),
// turned 0.6 rad about z.
struct HandBody {
  Model model;
  State state;
};
HandBody hand_body() {
  BodySpec b;
  b.name = "hand";
  b.mass = 2.0;
  b.inertia = Vector3(0.3, 0.4, 0.5).asDiagonal();
  b.joint = Vector3(0.0, 0.0, 1.0);
  b.com = Vector3(0.0, 0.0, 0.5);
  Model model({b}, Vector3(0.0, 0.0, -9.81),
              {std::make_shared<Bushing>(0, Vector3(100.0, 200.0, 300.0), Vector3(1.0, 2.0, 3.0),
                                         50.0, 2.0)});
  State state(model);
  state.euler_parameters(0) = euler_parameters_from_axis_angle(Vector3::UnitZ(), 0.6);
  state.translation(0) = Vector3(0.01, -0.02, 0.03);
  state.translation_rate(0) = Vector3(1.0, 2.0, 3.0);
  state.angular_velocity(0) = Vector3(0.1, 0.2, 0.3);
  return {std::move(model), std::move(state)};
}

TEST(Energy, SingleBodyByHand) {
  // The body above. r' lies on the axis of the turn, so [R]^T r' = r', G_K is at
  // q' + s' + r' = (0.01, -0.02, 1.53) and v_G = s' dot + w x r' with w = [R]^T w' =
  // (0.1 c - 0.2 s, 0.1 s + 0.2 c, 0.3), c = cos 0.6, s = sin 0.6; w x (0, 0, 0.5) =
  // 0.5 (w_y, -w_x, 0).
  //   T = 1/2 m |v_G|^2 + 1/2 w'.[I']w', the second term 1/2 (0.003 + 0.016 + 0.045) = 0.032;
  //   V = -m g.p_G + 1/2 s'^T diag(k) s' + 1/2 kr theta^2
  //     = 2 * 9.81 * 1.53 + 1/2 (0.01 + 0.08 + 0.27) + 1/2 * 50 * 0.36 = 30.0186 + 0.18 + 9;
  //   damping power = s' dot^T diag(c) s' dot + cr |w'|^2 = 1 + 8 + 27 + 2 * 0.14 = 36.28;
  //   P = m v_G, H = m p_G x v_G + [R]^T [I'] w'.
  // Round-off of a few operations on O(30) values: 1e-13.
  const HandBody hb = hand_body();
  const Model& model = hb.model;
  const State& state = hb.state;
  const double c = std::cos(0.6), s = std::sin(0.6);
  const Vector3 w_inertial(0.1 * c - 0.2 * s, 0.1 * s + 0.2 * c, 0.3);
  const Vector3 v_g = Vector3(1.0, 2.0, 3.0) + 0.5 * Vector3(w_inertial.y(), -w_inertial.x(), 0.0);
  const Vector3 p_g(0.01, -0.02, 1.53);
  const double kinetic = 0.5 * 2.0 * v_g.squaredNorm() + 0.032;
  const double potential = 30.0186 + 0.18 + 9.0;
  Data data(model);
  EXPECT_NEAR(kinetic_energy(model, state, data), kinetic, 1e-13);
  EXPECT_NEAR(potential_energy(model, state, data), potential, 1e-13);
  EXPECT_NEAR(total_energy(model, state, data), kinetic + potential, 1e-13);
  EXPECT_NEAR(damping_power(model, state, data), 36.28, 1e-13);
  EXPECT_LT((linear_momentum(model, state, data) - 2.0 * v_g).norm(), 1e-13);
  const Vector3 iw(0.03, 0.08, 0.15);
  const Vector3 iw_inertial(c * iw.x() - s * iw.y(), s * iw.x() + c * iw.y(), iw.z());
  EXPECT_LT((angular_momentum(model, state, data) - (2.0 * p_g.cross(v_g) + iw_inertial)).norm(),
            1e-13);
  // Constant loads are left out of the energy and do no damping.
  std::vector<std::shared_ptr<const ForceElement>> forces = model.forces();
  forces.push_back(std::make_shared<ConstantForce>(0, Vector3(1.0, 2.0, 3.0)));
  forces.push_back(std::make_shared<ConstantTorque>(0, Vector3(-1.0, 0.5, 2.0)));
  const Model loaded(model.bodies(), model.gravity(), forces);
  EXPECT_EQ(potential_energy(loaded, state, data), potential_energy(model, state, data));
  EXPECT_EQ(damping_power(loaded, state, data), damping_power(model, state, data));
}

TEST(Energy, KineticEnergyIsHalfYTransposeAY) {
  // [A] of Eq. (37) is the Hessian of T in the speeds and T is a quadratic form in y:
  // T = 1/2 {y}^T [A] {y}. Two ways of summing the same terms: round-off relative to T
  // (sums of 6N terms: 1e-12).
  std::mt19937 rng(71);
  test::RandomTreeOptions opt;
  opt.bushings = opt.forces = opt.torques = true;
  for (const Model& model : test::eight_body_and_random_trees(72, 40, opt)) {
    const State state = test::random_state(model, rng);
    Data data(model);
    kane_equations(model, state, data);
    const double quadratic = 0.5 * state.y.dot(data.kane.A * state.y);
    const double t = kinetic_energy(model, state, data);
    EXPECT_GE(t, 0.0);
    EXPECT_NEAR(t, quadratic, 1e-12 * t) << "N " << model.num_bodies();
  }
}

TEST(Energy, TotalEnergyOfKinematicsIsTotalEnergyBitForBit) {
  // From kinematics already in data (as a simulate() observer has them) the same sums give
  // the same bits, also in a Data that a forward_dynamics evaluation used before.
  std::mt19937 rng(73);
  test::RandomTreeOptions opt;
  opt.bushings = opt.forces = opt.torques = true;
  for (const Model& model : test::eight_body_and_random_trees(74, 30, opt)) {
    const State state = test::random_state(model, rng);
    Data data(model);
    const double total = total_energy(model, state, data);
    EXPECT_EQ(total, kinetic_energy(model, state, data) + potential_energy(model, state, data));
    Data fresh(model);
    compute_kinematics(model, state, fresh);
    EXPECT_EQ(total_energy_of_kinematics(model, state, fresh), total);
    forward_dynamics(model, test::random_state(model, rng), fresh, Route::recursive);
    compute_kinematics(model, state, fresh);
    EXPECT_EQ(total_energy_of_kinematics(model, state, fresh), total);
  }
}

TEST(Energy, PotentialRateIsMinusThePowerOfTheConservativeLoads) {
  // With zero damping and no constant loads, gravity and the bushings are conservative:
  // dV/dt = -(power of the loads) = -F_y . y (Eq. 31; Forces.GeneralizedForcesPassThePowerCheck).
  // V depends on x only: central difference of V(x + h xdot), h = 1e-6. Round-off
  // eps |V| / h ~ 1e-10 |V| and truncation h^2/6 |V'''| lie far below the tolerance
  // 1e-8 (1 + |V| + |P|); a moment law that is not the gradient of 1/2 kr theta^2 (e.g. the
  // vector part of the Euler parameters in place of theta) errs by O(|P|) at these angles.
  std::mt19937 rng(75);
  test::RandomTreeOptions opt;
  opt.bushings = true;
  opt.damping = false;
  const double h = 1e-6;
  for (const Model& model : test::eight_body_and_random_trees(76, 40, opt)) {
    if (model.name() == "eight-body") continue;  // its bushings are damped
    const State state = test::random_state(model, rng);
    Data data(model);
    kane_equations(model, state, data);
    const double power = data.kane.F_y.dot(state.y);
    const VectorX xdot = data.xdot;
    const double v0 = potential_energy(model, state, data);
    const double dv = (potential_energy(model, test::advance(state, xdot, VectorX(), h), data) -
                       potential_energy(model, test::advance(state, xdot, VectorX(), -h), data)) /
                      (2 * h);
    EXPECT_EQ(damping_power(model, state, data), 0.0);
    EXPECT_NEAR(dv, -power, 1e-8 * (1.0 + std::abs(v0) + std::abs(power)))
        << "N " << model.num_bodies();
  }
}

TEST(Energy, LinearMomentumIsTheRateOfTheMassMoment) {
  // P = sum m v_G = d/dt sum m p_G: central difference of the positions along x + h xdot,
  // h = 1e-5. Truncation h^2/6 |sum m p_G'''| (|p_G'''| <= ~N |w|^3 |offsets|) stays below
  // ~1e-7 of 1 + sum m |v_G| for these forests of N <= 30, round-off eps |sum m p_G| / h
  // below 1e-9 of it; tolerance 1e-6 of it, while a missing w x r' term is O(0.1).
  std::mt19937 rng(77);
  const double h = 1e-5;
  for (const Model& model : test::eight_body_and_random_trees(78, 40)) {
    const State state = test::random_state(model, rng);
    Data data(model), dp(model), dm(model);
    forward_dynamics(model, state, data, Route::recursive);
    const VectorX xdot = data.xdot;
    compute_kinematics(model, test::advance(state, xdot, VectorX(), h), dp);
    compute_kinematics(model, test::advance(state, xdot, VectorX(), -h), dm);
    compute_kinematics(model, state, data);
    Vector3 fd = Vector3::Zero();
    double scale = 1.0;
    for (int k = 0; k < model.num_bodies(); ++k) {
      const auto i = static_cast<size_t>(k);
      fd += model.body(k).mass * (dp.kinematics.p_G[i] - dm.kinematics.p_G[i]) / (2 * h);
      scale += model.body(k).mass * data.kinematics.v_G[i].norm();
    }
    EXPECT_LT((linear_momentum(model, state, data) - fd).norm(), 1e-6 * scale)
        << "N " << model.num_bodies();
  }
}

TEST(Energy, RateEqualsMinusDampingPower) {
  // Gravity and bushings with damping only: d(total_energy)/dt = -damping_power. The rate is
  // the central difference of E(x + h xdot, y + h ydot), h = 1e-6. Relative to
  // S = 1 + |E| + P (|E| <= ~2e3 here): round-off eps |E| / h ~ 1e-10 S and truncation
  // h^2/6 |E'''| ~ 1e-10 S (measured: the error falls as h^2 down to h = 1e-6, worst
  // 2e-10 S). Tolerance 1e-8 S, i.e. ~1e-5 against powers of tens to hundreds; a wrong
  // bushing law or a missing reaction on J changes the rate by O(1) or more.
  std::mt19937 rng(54);
  test::RandomTreeOptions opt;
  opt.bushings = true;
  opt.damping = true;
  const double h = 1e-6;
  for (int i = 0; i < 40; ++i) {
    const Model model = i == 0 ? test::eight_body_model() : test::random_tree(rng, opt);
    const State state = test::random_state(model, rng);
    for (const Route method : kMethods) {
      Data data(model);
      forward_dynamics(model, state, data, method);
      const VectorX xdot = data.xdot, ydot = data.ydot;
      const double e0 = total_energy(model, state, data);
      const double power = damping_power(model, state, data);
      const double de = (total_energy(model, test::advance(state, xdot, ydot, h), data) -
                         total_energy(model, test::advance(state, xdot, ydot, -h), data)) /
                        (2 * h);
      EXPECT_GE(power, 0.0);
      EXPECT_NEAR(de, -power, 1e-8 * (1.0 + std::abs(e0) + power))
          << to_string(method) << " N " << model.num_bodies();
    }
  }
}

TEST(Energy, MomentumBalanceOfFloatingSystem) {
  // Floating forests (no bushing to the ground) with gravity and internal damped bushings:
  // internal loads cancel in pairs (the translational force acts on K at O_K and reversed on
  // J at the same point; the moments are equal and opposite), so
  //   dP/dt = (sum m) g  and  dH/dt = sum p_G x m g  (H about the inertial origin).
  // From ydot via a_G: round-off relative to the scale of the terms (measured ~1e-15; 1e-11
  // also covers the <= 1e-12 relative error of the Kane solve). By finite differences of
  // energy.hpp's momenta along (xdot, ydot), h = 1e-5: truncation ~h^2/6 |P'''| and
  // round-off 1e-16 |P| / h, measured <= 1.2e-9 relative to the scale; tolerance 1e-7.
  std::mt19937 rng(55);
  test::RandomTreeOptions opt;
  opt.bushings = true;
  opt.ground_bushings = false;
  opt.bushing_probability = 1.0;
  opt.gravity = Vector3(0.5, 1.0, -9.81);
  const double h = 1e-5;
  for (int i = 0; i < 40; ++i) {
    const Model model = test::random_tree(rng, opt);
    const State state = test::random_state(model, rng);
    const Vector3 g = model.gravity();
    for (const Route method : kMethods) {
      test::Evaluated e = test::evaluate(model, state, method);
      const std::vector<Vector3> a = test::mass_centre_accelerations(model, state, e.data, e.ydot);
      Vector3 dp = Vector3::Zero(), dh = Vector3::Zero(), torque = Vector3::Zero();
      double scale = 0.0;
      for (int k = 0; k < model.num_bodies(); ++k) {
        const auto kk = static_cast<size_t>(k);
        const BodySpec& b = model.body(k);
        const Vector3 w = state.angular_velocity(k);
        const Vector3 wdot = e.ydot.segment<3>(3 * k);
        dp += b.mass * a[kk];
        dh += b.mass * e.data.kinematics.p_G[kk].cross(a[kk]) +
              e.data.kinematics.R[kk].transpose() * (w.cross(b.inertia * w) + b.inertia * wdot);
        torque += e.data.kinematics.p_G[kk].cross(b.mass * g);
        scale += b.mass * a[kk].norm() * (1.0 + e.data.kinematics.p_G[kk].norm()) +
                 (b.inertia * wdot).norm() + (b.inertia * w).norm() * w.norm();
      }
      EXPECT_LT((dp - model.total_mass() * g).norm(), 1e-11 * scale) << to_string(method);
      EXPECT_LT((dh - torque).norm(), 1e-11 * scale) << to_string(method);

      Data d(model);
      const State sp = test::advance(state, e.xdot, e.ydot, h);
      const State sm = test::advance(state, e.xdot, e.ydot, -h);
      const Vector3 fd_p =
          (linear_momentum(model, sp, d) - linear_momentum(model, sm, d)) / (2 * h);
      const Vector3 fd_h =
          (angular_momentum(model, sp, d) - angular_momentum(model, sm, d)) / (2 * h);
      EXPECT_LT((fd_p - model.total_mass() * g).norm(), 1e-7 * scale) << to_string(method);
      EXPECT_LT((fd_h - torque).norm(), 1e-7 * scale) << to_string(method);
    }
  }
}

}  // namespace
}  // namespace kanedyn
