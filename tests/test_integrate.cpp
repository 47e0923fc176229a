// Integrators (integrate.hpp): orders of convergence of RK4 and Dormand-Prince 5(4) on a
// case with a closed-form solution (a torque-free axisymmetric body in steady precession),
// the dense output, the step-size control, and that stepping does not allocate.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <random>
#include <vector>

#include "alloc_counter.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/integrate.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/simulate.hpp"
#include "test_support.hpp"

// Allocation counting: the binary's shared counter (alloc_counter.hpp).
#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
#define KANEDYN_COUNT_ALLOCATIONS 1
namespace {
std::atomic<bool>& g_count_allocations = alloc_counter::counting;
std::atomic<long>& g_allocations = alloc_counter::count;
}  // namespace
#endif

namespace {

using namespace kanedyn;

// ---------------------------------------------------------------------------------------------
// The closed-form case. A free body with [I'_G] = diag(A, A, C) and no load keeps its
// angular momentum H (inertial) and w'_3. In body axes (Euler's equations)
//   w'_1 + i w'_2 = (w'_1(0) + i w'_2(0)) exp(i lambda t),  lambda = (C - A)/A w'_3,
// and since H_b = A w' + (C - A) w'_3 e_3, w' = H_b/A - lambda e_3: the body turns at the
// rate |H|/A about the fixed direction of H and at -lambda about its own e_3. With
// [Q] = [R]^T (body to inertial): [Q(t)] = Rot(h, |H| t/A) [Q(0)] Rot(e_3, -lambda t).
// The mass centre moves on a straight line.

constexpr double kA = 1.0, kC = 1.6;  // kg m^2

Matrix3 rodrigues(const Vector3& unit_axis, double angle) {
  return std::cos(angle) * Matrix3::Identity() + std::sin(angle) * skew(unit_axis) +
         (1.0 - std::cos(angle)) * unit_axis * unit_axis.transpose();
}

struct Precession {
  Model model;
  State initial;
  Vector3 w0, h_hat, pG0, vG0;
  double lambda, rate;  // about e_3 (body) and about h (inertial), rad/s
  Matrix3 Q0;

  Precession() : model(make_model()), initial(model) {
    w0 = Vector3(0.8, 0.3, 2.0);
    const Vector4 eps0 = euler_parameters_from_axis_angle(Vector3(0.3, -0.5, 0.8), 0.7);
    initial.euler_parameters(0) = eps0;
    initial.translation(0) = Vector3(0.1, 0.2, -0.3);
    initial.angular_velocity(0) = w0;
    initial.translation_rate(0) = Vector3(0.05, -0.02, 0.01);
    Q0 = test::reference_rotation(eps0).transpose();
    const Vector3 H = Q0 * (Vector3(kA, kA, kC).asDiagonal() * w0);
    h_hat = H.normalized();
    rate = H.norm() / kA;
    lambda = (kC - kA) / kA * w0.z();
    Data data(model);
    compute_kinematics(model, initial, data);
    pG0 = data.kinematics.p_G[0];
    vG0 = data.kinematics.v_G[0];
  }
  static Model make_model() {
    BodySpec b;
    b.name = "spinner";
    b.mass = 2.0;
    b.inertia = Vector3(kA, kA, kC).asDiagonal();
    b.com = Vector3(0.1, -0.2, 0.05);  // O_K off the mass centre: s' is not trivial
    b.joint = Vector3(0.3, 0.0, 0.0);
    return Model({b});
  }
  Vector3 angular_velocity(double t) const {
    const double c = std::cos(lambda * t), s = std::sin(lambda * t);
    return {w0.x() * c - w0.y() * s, w0.y() * c + w0.x() * s, w0.z()};
  }
  Matrix3 rotation(double t) const {  // [R] (inertial to body)
    const Matrix3 Q = rodrigues(h_hat, rate * t) * Q0 * rodrigues(Vector3::UnitZ(), -lambda * t);
    return Q.transpose();
  }
  /// Largest error of w', [R] and p_G at time t.
  double error(double t, const State& state) const {
    Data data(model);
    compute_kinematics(model, state, data);
    const double ew = (state.angular_velocity(0) - angular_velocity(t)).cwiseAbs().maxCoeff();
    const double eR = (data.kinematics.R[0] - rotation(t)).cwiseAbs().maxCoeff();
    const double ep = (data.kinematics.p_G[0] - (pG0 + vG0 * t)).cwiseAbs().maxCoeff();
    return std::max({ew, eR, ep});
  }
};

/// The model's dz/dt on z = ({x}; {y}) for the generic integrators.
struct SystemOde {
  const Model& model;
  State state;
  Data data;
  explicit SystemOde(const Model& m) : model(m), state(m), data(m, DataOptions::recursive_only()) {}
  OdeFunction function() {
    return [this](double, const VectorX& z, VectorX& dz) {
      const int n = model.num_bodies();
      state.x = z.head(7 * n);
      state.y = z.tail(6 * n);
      forward_dynamics(model, state, data, Route::recursive);
      dz << data.xdot, data.ydot;
    };
  }
};

VectorX stack(const State& s) {
  VectorX z(s.x.size() + s.y.size());
  z << s.x, s.y;
  return z;
}
State unstack(const Model& model, const VectorX& z) {
  State s(model);
  s.x = z.head(7 * model.num_bodies());
  s.y = z.tail(6 * model.num_bodies());
  return s;
}

/// Least-squares slope of log(error) against log(step).
double observed_order(const std::vector<double>& steps, const std::vector<double>& errors) {
  const size_t n = steps.size();
  double mx = 0, my = 0;
  for (size_t i = 0; i < n; ++i) {
    mx += std::log(steps[i]) / n;
    my += std::log(errors[i]) / n;
  }
  double sxy = 0, sxx = 0;
  for (size_t i = 0; i < n; ++i) {
    sxy += (std::log(steps[i]) - mx) * (std::log(errors[i]) - my);
    sxx += (std::log(steps[i]) - mx) * (std::log(steps[i]) - mx);
  }
  return sxy / sxx;
}

constexpr double kT = 2.0;  // s: about one turn about H (rate 3.3 rad/s)

TEST(Precession, ClosedFormSatisfiesTheEquationsOfMotion) {
  // The reference itself: its derivative (central differences) matches forward_dynamics at a
  // few times, and w' = H_b/A - lambda e_3 holds. Guards the test against a wrong formula.
  const Precession p;
  Data data(p.model);
  for (double t : {0.0, 0.37, 1.4}) {
    State s(p.model);
    s.euler_parameters(0) = euler_parameters_from_matrix(p.rotation(t));
    s.angular_velocity(0) = p.angular_velocity(t);
    const Vector3 H_b = p.rotation(t) * (p.h_hat * p.rate * kA);
    EXPECT_LT((s.angular_velocity(0) - (H_b / kA - p.lambda * Vector3::UnitZ())).norm(), 1e-13);
    forward_dynamics(p.model, s, data);
    const double d = 1e-5;
    const Vector3 w_rate = (p.angular_velocity(t + d) - p.angular_velocity(t - d)) / (2 * d);
    EXPECT_LT((data.ydot.head<3>() - w_rate).norm(), 1e-8) << "t = " << t;
    // d[R]/dt = -[w'~][R] (README of the notes, Eqs. 3-4).
    const Matrix3 R_rate = (p.rotation(t + d) - p.rotation(t - d)) / (2 * d);
    EXPECT_LT((R_rate + skew(s.angular_velocity(0)) * p.rotation(t)).norm(), 1e-8);
  }
}

TEST(Rk4, FourthOrderOnTheTorqueFreeBody) {
  const Precession p;
  std::vector<double> steps, errors;
  for (int n : {25, 50, 100, 200}) {
    SimulationSettings s;
    s.integrator = Integrator::rk4;
    s.t_end = kT;
    s.dt_out = kT;
    s.step = kT / n;
    State last;
    const auto stats = simulate(
        p.model, p.initial, s,
        [&](double, const State& st, const VectorX&, const VectorX&, Data&) { last = st; });
    ASSERT_TRUE(stats.ok()) << stats.message;
    EXPECT_EQ(stats.steps_accepted, n);
    EXPECT_EQ(stats.evaluations, 4L * n);
    steps.push_back(kT / n);
    errors.push_back(p.error(kT, last));
  }
  // Errors from about 1e-5 down to 1e-10, far above round-off (1e-15): the slope is the
  // truncation order. Observed 4.0; the window allows higher-order terms at the large steps.
  const double order = observed_order(steps, errors);
  EXPECT_GT(order, 3.7) << "errors " << errors[0] << " .. " << errors.back();
  EXPECT_LT(order, 4.3) << "errors " << errors[0] << " .. " << errors.back();
  EXPECT_LT(errors.back(), 1e-8);
}

TEST(Dopri5, FifthOrderWithFixedSteps) {
  const Precession p;
  std::vector<double> steps, errors;
  // Steps of 0.05 down to 0.0125: errors from 4e-10 to 4e-13, above round-off (~1e-14 after
  // 160 steps). Longer steps show a steeper pre-asymptotic slope (about 6 between h = 0.2 and
  // 0.1 here), so they are left out.
  for (int n : {40, 80, 160}) {
    SystemOde ode(p.model);
    Dopri5 dp(13, ode.function());
    ASSERT_EQ(dp.start(0.0, stack(p.initial), kT), StepStatus::ok);
    for (int i = 0; i < n; ++i) {
      ASSERT_EQ(dp.fixed_step(kT / n), StepStatus::ok);
      VectorX& z = dp.mutable_state();
      z.head<4>().normalize();  // the projection simulate() makes
    }
    EXPECT_NEAR(dp.time(), kT, 1e-13);  // n additions of kT/n
    steps.push_back(kT / n);
    errors.push_back(p.error(kT, unstack(p.model, dp.state())));
  }
  const double order = observed_order(steps, errors);
  EXPECT_GT(order, 4.7) << "errors " << errors[0] << " .. " << errors.back();
  EXPECT_LT(order, 5.3) << "errors " << errors[0] << " .. " << errors.back();
}

TEST(Dopri5, DenseOutputIsFourthOrderWithinAStep) {
  // One step of size h from t = 0, read at theta = 0.3 and 0.7: the continuous extension of
  // order 4 has a local error O(h^5) at every theta. At theta = 1 it is the step's result.
  const Precession p;
  for (double theta : {0.3, 0.7}) {
    std::vector<double> steps, errors;
    for (double h : {0.4, 0.2, 0.1, 0.05}) {
      SystemOde ode(p.model);
      Dopri5 dp(13, ode.function());
      ASSERT_EQ(dp.start(0.0, stack(p.initial), 1.0), StepStatus::ok);
      ASSERT_EQ(dp.fixed_step(h), StepStatus::ok);
      VectorX z(13);
      dp.dense_output(h, z);
      EXPECT_LT((z - dp.state()).cwiseAbs().maxCoeff(), 1e-15);
      dp.dense_output(theta * h, z);
      State s = unstack(p.model, z);
      s.normalize_euler_parameters();
      steps.push_back(h);
      errors.push_back(p.error(theta * h, s));
    }
    const double order = observed_order(steps, errors);
    EXPECT_GT(order, 4.6) << "theta " << theta << ", errors " << errors[0] << " .. "
                          << errors.back();
    EXPECT_LT(order, 5.4) << "theta " << theta;
  }
}

TEST(Dopri5, DenseOutputIsExactForPolynomialsOfDegreeFour) {
  // Each component's solution is a polynomial of degree <= 4 whose stage values probe one of
  // the order conditions of a 4th-order method (u = t; v = t^2/2; v2 = t^3/3; v3 = t^3/6;
  // then w1 = t^4/4 (sum b c^3), w2 = t^4/8 (sum b c a c), w3 = t^4/12 (sum b a c^2),
  // w4 = t^4/24 (sum b a a c)). A continuous extension of order 4 reproduces them at every
  // theta up to round-off; a wrong coefficient leaves an error of the size of its error.
  OdeFunction f = [](double, const VectorX& z, VectorX& dz) {
    const double u = z[0], v = z[1], v2 = z[2], v3 = z[3];
    dz << 1.0, u, u * u, v, u * u * u, u * v, v2, v3;
  };
  auto exact = [](double t) {
    VectorX z(8);
    z << t, t * t / 2, t * t * t / 3, t * t * t / 6, std::pow(t, 4) / 4, std::pow(t, 4) / 8,
        std::pow(t, 4) / 12, std::pow(t, 4) / 24;
    return z;
  };
  Dopri5 dp(8, f);
  ASSERT_EQ(dp.start(0.0, VectorX::Zero(8), 2.0), StepStatus::ok);
  const double h = 0.9;
  ASSERT_EQ(dp.fixed_step(h), StepStatus::ok);
  VectorX z(8);
  for (double theta : {0.1, 0.35, 0.5, 0.8, 1.0}) {
    dp.dense_output(theta * h, z);
    EXPECT_LT((z - exact(theta * h)).cwiseAbs().maxCoeff(), 1e-15) << "theta " << theta;
  }
}

TEST(Dopri5, ErrorEstimateIsOfOrderFive) {
  // dz/dt = z, rtol = 0, atol = 1: the estimate is |y5 - y4| of one step, O(h^5) because
  // both solutions agree through h^4 (the weights' differences sum to zero, etc.).
  std::vector<double> steps, estimates;
  for (double h : {0.2, 0.1, 0.05, 0.025}) {
    OdeFunction f = [](double, const VectorX& z, VectorX& dz) { dz = z; };
    Dopri5Options opt;
    opt.rtol = 0.0;
    opt.atol = 1.0;
    Dopri5 dp(1, f, opt);
    ASSERT_EQ(dp.start(0.0, VectorX::Ones(1), 1.0), StepStatus::ok);
    ASSERT_EQ(dp.fixed_step(h), StepStatus::ok);
    steps.push_back(h);
    estimates.push_back(dp.error_estimate());
    // The 5th-order result itself is far more accurate than the estimate says.
    EXPECT_LT(std::abs(dp.state()[0] - std::exp(h)), 0.1 * dp.error_estimate());
  }
  const double order = observed_order(steps, estimates);
  EXPECT_GT(order, 4.8);
  EXPECT_LT(order, 5.2);
}

TEST(Dopri5, ErrorFollowsTheTolerance) {
  // Adaptive: the global error at T shrinks in proportion to the tolerance (the controlled
  // local error of the embedded 4th-order solution is ~ tol, so h ~ tol^(1/5) and the
  // propagated 5th-order error ~ h^5 ~ tol), and stays within a small multiple of it.
  const Precession p;
  std::vector<double> tols, errors;
  for (double tol : {1e-6, 1e-8, 1e-10}) {
    SimulationSettings s;
    s.t_end = kT;
    s.dt_out = kT;
    s.rtol = tol;
    s.atol = tol;
    State last;
    const auto stats = simulate(
        p.model, p.initial, s,
        [&](double, const State& st, const VectorX&, const VectorX&, Data&) { last = st; });
    ASSERT_TRUE(stats.ok()) << stats.message;
    tols.push_back(tol);
    errors.push_back(p.error(kT, last));
    EXPECT_LT(errors.back(), 10 * tol) << "tol " << tol;
  }
  const double slope = observed_order(tols, errors);
  EXPECT_GT(slope, 0.8) << errors[0] << " " << errors[1] << " " << errors[2];
  EXPECT_LT(slope, 1.2) << errors[0] << " " << errors[1] << " " << errors[2];
}

TEST(Dopri5, OutputTimesDoNotShortenSteps) {
  const Precession p;
  auto run = [&](double dt_out, double* worst) {
    SimulationSettings s;
    s.t_end = kT;
    s.dt_out = dt_out;
    s.rtol = 1e-9;
    s.atol = 1e-9;
    *worst = 0.0;
    long outputs = 0;
    const auto stats =
        simulate(p.model, p.initial, s,
                 [&](double t, const State& st, const VectorX&, const VectorX&, Data&) {
                   *worst = std::max(*worst, p.error(t, st));
                   EXPECT_NEAR(t, outputs * dt_out, 1e-12);
                   ++outputs;
                 });
    EXPECT_TRUE(stats.ok());
    EXPECT_EQ(outputs, std::lround(kT / dt_out) + 1);
    return stats;
  };
  double worst_coarse = 0.0, worst_dense = 0.0;
  const auto coarse = run(kT, &worst_coarse);
  const auto dense = run(0.001, &worst_dense);
  EXPECT_EQ(dense.steps_accepted, coarse.steps_accepted);
  EXPECT_EQ(dense.evaluations, coarse.evaluations);
  EXPECT_GT(coarse.steps_accepted, 20);  // so 2000 outputs fall mostly between steps
  // Interpolated states are as good as the steps' own (both ~ tol; 10x allows for the
  // interpolant's own O(h^5) error).
  EXPECT_LT(worst_dense, std::max(10 * worst_coarse, 1e-8));
}

TEST(Dopri5, RejectsStepsThatAreTooLargeAndRecovers) {
  // dz/dt = -50 (z - cos t): an initial step of 1 fails the error test; the controller must
  // reject, shrink and still reach t_end within tolerance of the exact solution
  // z = (2500 cos t + 50 sin t)/2501 + C exp(-50 t).
  OdeFunction f = [](double t, const VectorX& z, VectorX& dz) {
    dz[0] = -50.0 * (z[0] - std::cos(t));
  };
  Dopri5Options opt;
  opt.rtol = 1e-9;
  opt.atol = 1e-12;
  opt.initial_step = 1.0;
  Dopri5 dp(1, f, opt);
  VectorX z0(1);
  z0 << 0.0;
  ASSERT_EQ(dp.start(0.0, z0, 3.0), StepStatus::ok);
  while (dp.time() < 3.0) ASSERT_EQ(dp.step(), StepStatus::ok);
  EXPECT_EQ(dp.time(), 3.0);  // lands on t_end exactly
  EXPECT_GT(dp.steps_rejected(), 0);
  const double c = -2500.0 / 2501.0;
  const double exact = (2500 * std::cos(3.0) + 50 * std::sin(3.0)) / 2501 + c * std::exp(-150.0);
  EXPECT_NEAR(dp.state()[0], exact, 1e-8);
  // FSAL: 6 new evaluations per attempted step, plus start (1) and the initial-step guess (0,
  // because initial_step was given).
  EXPECT_EQ(dp.evaluations(), 1 + 6 * (dp.steps_accepted() + dp.steps_rejected()));
}

TEST(Dopri5, InitialStepHeuristicIsSensible) {
  // For dz/dt = z from z = 1 the heuristic's guess is (0.01/|z''|_sc)^(1/5)-like: well above
  // the minimum and well below the span, so the run needs neither many rejections nor a
  // first step that has to shrink 5 times.
  OdeFunction f = [](double, const VectorX& z, VectorX& dz) { dz = z; };
  Dopri5 dp(1, f, Dopri5Options{});
  VectorX z0 = VectorX::Ones(1);
  ASSERT_EQ(dp.start(0.0, z0, 1.0), StepStatus::ok);
  EXPECT_GT(dp.step_size(), 1e-4);
  EXPECT_LT(dp.step_size(), 0.5);
  while (dp.time() < 1.0) ASSERT_EQ(dp.step(), StepStatus::ok);
  EXPECT_LE(dp.steps_rejected(), 1);
  EXPECT_NEAR(dp.state()[0], std::exp(1.0), 1e-7);
}

TEST(Dopri5, NonFiniteTrialStepsAreRetriedSmaller) {
  // f is NaN for |z| > 1.5 only: large trial steps overshoot into it and must be rejected,
  // not accepted or fatal. dz/dt = 1 - z from 0 approaches 1 and never reaches 1.5.
  int nan_calls = 0;
  OdeFunction f = [&nan_calls](double, const VectorX& z, VectorX& dz) {
    if (std::abs(z[0]) > 1.5) ++nan_calls;
    dz[0] = std::abs(z[0]) > 1.5 ? std::nan("") : 1.0 - z[0];
  };
  Dopri5Options opt;
  opt.initial_step = 4.0;
  Dopri5 dp(1, f, opt);
  ASSERT_EQ(dp.start(0.0, VectorX::Zero(1), 5.0), StepStatus::ok);
  while (dp.time() < 5.0) ASSERT_EQ(dp.step(), StepStatus::ok);
  EXPECT_GT(nan_calls, 0);  // the case this test is about did occur
  EXPECT_GT(dp.steps_rejected(), 0);
  EXPECT_NEAR(dp.state()[0], 1.0 - std::exp(-5.0), 1e-7);
}

TEST(Dopri5, ReportsNonFiniteAndUnderflowWithTheComponent) {
  {  // z1' = 1/(1 - t)^2 blows up at t = 1 (z1 = 1/(1-t) - 1); z0 is harmless.
    OdeFunction f = [](double t, const VectorX&, VectorX& dz) {
      dz[0] = 1.0;
      dz[1] = 1.0 / ((1.0 - t) * (1.0 - t));
    };
    Dopri5 dp(2, f, Dopri5Options{});
    ASSERT_EQ(dp.start(0.0, VectorX::Zero(2), 2.0), StepStatus::ok);
    StepStatus status = StepStatus::ok;
    while (status == StepStatus::ok && dp.time() < 2.0) status = dp.step();
    EXPECT_NE(status, StepStatus::ok);
    EXPECT_EQ(dp.failed_component(), 1);
    EXPECT_LT(dp.time(), 1.0);
    EXPECT_GT(dp.time(), 0.99);
  }
  {  // A NaN initial derivative is reported at once.
    OdeFunction f = [](double, const VectorX&, VectorX& dz) {
      dz[0] = 0.0;
      dz[1] = std::nan("");
    };
    Dopri5 dp(2, f, Dopri5Options{});
    EXPECT_EQ(dp.start(0.0, VectorX::Zero(2), 1.0), StepStatus::non_finite);
    EXPECT_EQ(dp.failed_component(), 1);
  }
}

// The step's vector arithmetic is written as raw loops (compiled for SSE2 and AVX2, picked at
// load time). It must round exactly as the Eigen expressions of the tableau do, so that the
// trajectories stay bit for bit what they were: a reference step written with them.
TEST(Dopri5, StepsRoundAsTheTableauExpressions) {
  // Hairer, Norsett & Wanner, Table II.5.2.
  const double a21 = 1.0 / 5, a31 = 3.0 / 40, a32 = 9.0 / 40, a41 = 44.0 / 45, a42 = -56.0 / 15,
               a43 = 32.0 / 9, a51 = 19372.0 / 6561, a52 = -25360.0 / 2187, a53 = 64448.0 / 6561,
               a54 = -212.0 / 729, a61 = 9017.0 / 3168, a62 = -355.0 / 33, a63 = 46732.0 / 5247,
               a64 = 49.0 / 176, a65 = -5103.0 / 18656;
  const double b1 = 35.0 / 384, b3 = 500.0 / 1113, b4 = 125.0 / 192, b5 = -2187.0 / 6784,
               b6 = 11.0 / 84;
  const double e1 = 35.0 / 384 - 5179.0 / 57600, e3 = 500.0 / 1113 - 7571.0 / 16695,
               e4 = 125.0 / 192 - 393.0 / 640, e5 = -2187.0 / 6784 + 92097.0 / 339200,
               e6 = 11.0 / 84 - 187.0 / 2100, e7 = -1.0 / 40;
  const Model model = test::eight_body_model();
  std::mt19937 rng(5);
  const State initial = test::random_state(model, rng, 0.05, 1.0, 0.2);
  SystemOde ode(model), reference_ode(model);
  const OdeFunction f = reference_ode.function();
  Dopri5Options opt;
  Dopri5 dp(13 * model.num_bodies(), ode.function(), opt);
  VectorX z = stack(initial);
  ASSERT_EQ(dp.start(0.0, z, 1.0), StepStatus::ok);
  const Eigen::Index n = z.size();
  VectorX k1(n), k2(n), k3(n), k4(n), k5(n), k6(n), k7(n), tmp(n), z_new(n), e(n), out(n);
  double t = 0.0;
  for (int step = 0; step < 20; ++step) {
    const double h = 1e-3 * (1 + step % 3);
    f(t, z, k1);
    tmp = z + h * (a21 * k1);
    f(t, tmp, k2);
    tmp = z + h * (a31 * k1 + a32 * k2);
    f(t, tmp, k3);
    tmp = z + h * (a41 * k1 + a42 * k2 + a43 * k3);
    f(t, tmp, k4);
    tmp = z + h * (a51 * k1 + a52 * k2 + a53 * k3 + a54 * k4);
    f(t, tmp, k5);
    tmp = z + h * (a61 * k1 + a62 * k2 + a63 * k3 + a64 * k4 + a65 * k5);
    f(t, tmp, k6);
    z_new = z + h * (b1 * k1 + b3 * k3 + b4 * k4 + b5 * k5 + b6 * k6);
    f(t, z_new, k7);
    e = h * (e1 * k1 + e3 * k3 + e4 * k4 + e5 * k5 + e6 * k6 + e7 * k7);
    double sum = 0.0, worst = -1.0;
    int worst_at = -1;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double sc = opt.atol + opt.rtol * std::max(std::abs(z[i]), std::abs(z_new[i]));
      const double r = (e[i] / sc) * (e[i] / sc);
      sum += r;
      if (r > worst) {
        worst = r;
        worst_at = static_cast<int>(i);
      }
    }
    const double err = std::sqrt(sum / static_cast<double>(n));

    ASSERT_EQ(dp.fixed_step(h), StepStatus::ok);
    for (Eigen::Index i = 0; i < n; ++i) ASSERT_EQ(dp.state()[i], z_new[i]) << step << " " << i;
    ASSERT_EQ(dp.error_estimate(), err) << step;
    ASSERT_EQ(dp.failed_component(), worst_at) << step;  // the largest share of the error
    // The dense output within the step, as the weights of Hairer et al. Eq. (II.6.12) combine.
    const double t_out = t + 0.3 * h;
    const double th = std::clamp((t_out - t) / h, 0.0, 1.0);
    const double cubic = th * th * (3.0 - 2.0 * th), q = th * th * (th - 1.0) * (th - 1.0);
    const double w1 = cubic * b1 + th * (th - 1.0) * (th - 1.0) -
                      q * 5.0 * (2558722523.0 - 31403016.0 * th) / 11282082432.0;
    const double w3 = cubic * b3 + q * 100.0 * (882725551.0 - 15701508.0 * th) / 32700410799.0;
    const double w4 = cubic * b4 - q * 25.0 * (443332067.0 - 31403016.0 * th) / 1880347072.0;
    const double w5 = cubic * b5 + q * 32805.0 * (23143187.0 - 3489224.0 * th) / 199316789632.0;
    const double w6 = cubic * b6 - q * 55.0 * (29972135.0 - 7076736.0 * th) / 822651844.0;
    const double w7 = th * th * (th - 1.0) + q * 10.0 * (7414447.0 - 829305.0 * th) / 29380423.0;
    const VectorX dense = z + h * (w1 * k1 + w3 * k3 + w4 * k4 + w5 * k5 + w6 * k6 + w7 * k7);
    dp.dense_output(t_out, out);
    for (Eigen::Index i = 0; i < n; ++i) ASSERT_EQ(out[i], dense[i]) << step << " " << i;
    z = z_new;
    t += h;
  }
}

TEST(Integrators, ParseAndName) {
  EXPECT_EQ(parse_integrator("rk4"), Integrator::rk4);
  EXPECT_EQ(parse_integrator("dopri5"), Integrator::dopri5);
  EXPECT_EQ(to_string(Integrator::rk4), "rk4");
  EXPECT_EQ(to_string(Integrator::dopri5), "dopri5");
  EXPECT_THROW(parse_integrator("euler"), std::invalid_argument);
  EXPECT_THROW(Dopri5(1, OdeFunction{}, Dopri5Options{0.0, 0.0}), std::invalid_argument);
}

#ifdef KANEDYN_COUNT_ALLOCATIONS
TEST(Integrators, SteppingDoesNotAllocate) {
  const Model model = test::eight_body_model();
  std::mt19937 rng(7);
  const State initial = test::random_state(model, rng, 0.05, 1.0, 0.2);
  SystemOde ode(model);
  Dopri5 dp(13 * model.num_bodies(), ode.function());
  Rk4 rk4(13 * model.num_bodies(), ode.function());
  VectorX z = stack(initial), out(z.size());
  ASSERT_EQ(dp.start(0.0, z, 1.0), StepStatus::ok);
  g_allocations = 0;
  g_count_allocations = true;
  for (int i = 0; i < 20 && dp.time() < 1.0; ++i) {
    dp.step();
    dp.dense_output(0.5 * (dp.previous_time() + dp.time()), out);
    rk4.step(0.0, 1e-3, z);
  }
  g_count_allocations = false;
  EXPECT_EQ(g_allocations.load(), 0);
}

TEST(Simulate, AllocatesOnlyDuringSetup) {
  // Ten times the steps with the same number of outputs: the same number of allocations.
  const auto sys = test::eight_body_model();
  State initial(sys);
  initial.angular_velocity(0) = Vector3(0.5, -0.3, 1.0);
  auto count = [&](double t_end, Integrator integrator, Route method) {
    SimulationSettings s;
    s.t_end = t_end;
    s.dt_out = t_end / 4;
    s.integrator = integrator;
    s.route = method;
    g_allocations = 0;
    g_count_allocations = true;
    const auto stats = simulate(sys, initial, s);
    g_count_allocations = false;
    EXPECT_TRUE(stats.ok());
    return std::make_pair(g_allocations.load(), stats.steps_accepted);
  };
  for (const Integrator integrator : {Integrator::dopri5, Integrator::rk4})
    for (const Route method : {Route::recursive, Route::assembled}) {
      const auto [short_allocs, short_steps] = count(0.1, integrator, method);
      const auto [long_allocs, long_steps] = count(1.0, integrator, method);
      EXPECT_GT(long_steps, 5 * short_steps);
      EXPECT_EQ(long_allocs, short_allocs)
          << to_string(integrator) << " / " << to_string(method) << ": " << short_steps << " and "
          << long_steps << " steps";
    }
}
#endif

}  // namespace

TEST(Dopri5, StartsFromTheSmallestStepWhenTheGuessIsBelowIt) {
  // A stiff oscillator (omega = 1e9) from rest at z = 0.01: the starting-step guess of Hairer
  // et al. is ~1e-20, below min_step() (16 ulp of t_end). The integrator must take steps,
  // growing from the smallest one, rather than report an underflow before the first.
  const double omega2 = 1e18;
  Dopri5Options opt;
  opt.rtol = 1e-8;
  opt.atol = 1e-10;
  Dopri5 dp(
      2,
      [&](double, const VectorX& z, VectorX& dz) {
        dz[0] = z[1];
        dz[1] = -omega2 * z[0];
      },
      opt);
  VectorX z0(2);
  z0 << 0.01, 0.0;
  ASSERT_EQ(dp.start(0.0, z0, 1.0), StepStatus::ok);
  for (int i = 0; i < 50; ++i) ASSERT_EQ(dp.step(), StepStatus::ok) << "step " << i;
  EXPECT_GT(dp.time(), 0.0);
  // The step size has grown to where the error control holds it, ~1e-10 for omega = 1e9.
  const double reached_per_step = dp.time() / 50.0;
  EXPECT_GT(reached_per_step, 1e-13);
}
