// Eqs. (32)-(41): [A] and {f} (with Eq. 31 written densely; the generalized forces
// themselves: test_forces.cpp), their solution, the two routes of forward
// dynamics, and the equivalence of Kane's equations with Newton-Euler per body.
// g++ 12 reports a false -Wmaybe-uninitialized inside Eigen's dynamic-size
// SelfAdjointEigenSolver (its matrix-vector kernels); silence it for Eigen's headers only,
// which must therefore come first.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/partials.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/testing/oracles.hpp"
#include "test_support.hpp"

#include "../src/workspace.hpp"

namespace kanedyn {
namespace {

using test::angular_velocity_selection;

// Random forests with every kind of load: gravity, bushings (with damping), constant forces
// and torques; plus the eight-body system.
std::vector<Model> loaded_models(unsigned seed, int count) {
  test::RandomTreeOptions opt;
  opt.bushings = opt.forces = opt.torques = true;
  return test::eight_body_and_random_trees(seed, count, opt);
}

double inf_norm(const MatrixX& m) { return test::max_abs(m); }

TEST(Kane, MassMatrixSymmetricPositiveDefinite) {
  std::mt19937 rng(31);
  for (const Model& model : loaded_models(32, 50)) {
    Data data(model);
    const State state = test::random_state(model, rng);
    kane_equations(model, state, data);
    const double scale = inf_norm(data.kane.A);
    // data.kane.A is mirrored from its lower blocks, so its symmetry proves nothing. Eq. (37) term
    // by term (oracles::mass_matrix_term_by_term) forms block (I, J) and block (J, I) as separate
    // products: symmetric only if the partial velocities make it so. Round-off of sums of
    // ~6N products of O(|A|) terms: 1e-14 relative.
    // needs the partials kane_equations computed
    const MatrixX term_by_term = oracles::mass_matrix_term_by_term(model, data);
    EXPECT_LT(inf_norm(term_by_term - term_by_term.transpose()), 1e-14 * scale);
    EXPECT_LT(inf_norm(data.kane.A - term_by_term), 1e-12 * scale);
    EXPECT_EQ(workspace(data).assembled.factor.info(), Eigen::Success);
    EXPECT_EQ(Eigen::LLT<MatrixX>(data.kane.A).info(), Eigen::Success);
    const Eigen::SelfAdjointEigenSolver<MatrixX> eig(data.kane.A, Eigen::EigenvaluesOnly);
    // Smallest eigenvalue: positive, and well above the round-off of the eigensolver
    // (6N eps |A| ~ 1e-13 |A|), so "positive" is not an accident of rounding.
    EXPECT_GT(eig.eigenvalues().minCoeff(), 1e-10 * scale) << "N " << model.num_bodies();
  }
}

TEST(Kane, SingleFreeBodyWithoutComOffset) {
  // One free body, r' = 0: [A] = diag([I'_G], m [I]) whatever the orientation, since
  // [v_G,y] = [0, I] and [w',y] = [I, 0].
  std::mt19937 rng(33);
  for (int i = 0; i < 10; ++i) {
    BodySpec b;
    b.name = "free";
    b.mass = test::uniform(rng, 0.5, 5.0);
    b.inertia = test::random_inertia(rng, b.mass);
    b.joint = test::random_vector(rng, -1.0, 1.0);
    const Model model({b}, Vector3(0, 0, -9.81));
    const State state = test::random_state(model, rng);
    Data data(model);
    kane_equations(model, state, data);
    MatrixX expected = MatrixX::Zero(6, 6);
    expected.topLeftCorner<3, 3>() = b.inertia;
    expected.bottomRightCorner<3, 3>() = b.mass * Matrix3::Identity();
    EXPECT_LT(inf_norm(data.kane.A - expected), 1e-14);
  }
}

TEST(Kane, MassMatrixAndForceVectorEqualDenseEquations) {
  // Eq. (37) and Eq. (38) written densely from the 3 x 6N views:
  //   A = sum m V_G^T V_G + W^T I W,
  //   f = sum V_G^T (F - m Vdot_G y) + W^T (M' - w~ I w).
  // Same products summed in another order: round-off relative to the largest term
  // (1e-12 leaves a margin of ~100 over 6N ulp for N <= 30).
  std::mt19937 rng(34);
  for (const Model& model : loaded_models(35, 50)) {
    Data data(model);
    const State state = test::random_state(model, rng);
    kane_equations(model, state, data);
    const int n = model.num_bodies();
    MatrixX a = MatrixX::Zero(6 * n, 6 * n);
    VectorX f = VectorX::Zero(6 * n);
    VectorX fy = VectorX::Zero(6 * n);
    double f_scale = 0.0;
    for (int k = 0; k < n; ++k) {
      const auto i = static_cast<size_t>(k);
      const BodySpec& b = model.body(k);
      const MatrixX v = partial_velocity(model, data, k, Point::G);
      const MatrixX vdot = partial_velocity_rate(model, data, k, Point::G);
      const MatrixX w = angular_velocity_selection(n, k);
      const Vector3 om = state.angular_velocity(k);
      a += b.mass * v.transpose() * v + w.transpose() * b.inertia * w;
      const Vector3 inertial = data.loads.force[i] - b.mass * vdot * state.y;
      const Vector3 gyro = data.loads.moment_b[i] - om.cross(b.inertia * om);
      f += v.transpose() * inertial + w.transpose() * gyro;
      fy +=
          v.transpose() * data.loads.force[i] + w.transpose() * data.loads.moment_b[i];  // Eq. (31)
      f_scale = std::max({f_scale, test::max_abs(v) * inertial.norm(), gyro.norm()});
    }
    EXPECT_LT(inf_norm(data.kane.A - a), 1e-12 * inf_norm(a)) << "N " << n;
    EXPECT_LT(test::max_abs(data.kane.f - f), 1e-12 * f_scale) << "N " << n;
    EXPECT_LT(test::max_abs(data.kane.F_y - fy), 1e-12 * f_scale) << "N " << n;
  }
}

TEST(Kane, SolutionSatisfiesEquation36) {
  // A block LDL^T (Cholesky) solve is backward stable: |A ydot - f| <= c 6N eps |A| |ydot|
  // with c of order 1. Tolerance 4 * 6N * eps * (|A| |ydot| + |f|); measured residuals are
  // ~50x below it.
  std::mt19937 rng(38);
  for (const Model& model : loaded_models(39, 50)) {
    Data data(model);
    const State state = test::random_state(model, rng);
    kane_equations(model, state, data);
    const VectorX r = data.kane.A * data.ydot - data.kane.f;
    const double tol =
        4.0 * model.num_y() * std::numeric_limits<double>::epsilon() *
        (inf_norm(data.kane.A) * test::max_abs(data.ydot) + test::max_abs(data.kane.f));
    EXPECT_LT(test::max_abs(r), tol) << "N " << model.num_bodies();
  }
}

TEST(Kane, KaneAndRecursiveRoutesAgree) {
  // Two different algorithms (dense Cholesky of Eq. 36 vs the O(N) Newton-Euler pass) for the
  // same ydot. Relative 1e-10 in the 2-norm: [A] of these random forests has condition
  // numbers up to ~1e4 (measured), so each route carries <= ~1e-12 relative error (measured
  // worst difference 1e-13).
  std::mt19937 rng(40);
  for (const Model& model : loaded_models(41, 100)) {
    Data dk(model), dr(model);
    const State state = test::random_state(model, rng);
    forward_dynamics(model, state, dk, Route::assembled);
    forward_dynamics(model, state, dr, Route::recursive);
    EXPECT_LE((dk.ydot - dr.ydot).norm(), 1e-10 * dr.ydot.norm()) << "N " << model.num_bodies();
    EXPECT_EQ(dk.xdot, dr.xdot);
  }
}

TEST(Kane, KinematicEquations) {
  // Eqs. (39)-(41) against the matrix as the notes print it, written here (comparing with
  // euler_parameter_rates would compare compute_xdot with the function it calls): eps_dot =
  // 1/2 [Ebar']^T w' per body to round-off of 3-term sums, s' dot = y2 exactly.
  std::mt19937 rng(42);
  for (const Model& model : loaded_models(43, 10)) {
    Data data(model);
    const State state = test::random_state(model, rng);
    forward_dynamics(model, state, data, Route::assembled);
    const int n = model.num_bodies();
    ASSERT_EQ(data.xdot.size(), 7 * n);
    for (int k = 0; k < n; ++k) {
      const Vector4 e = state.euler_parameters(k);
      const Vector3 w = state.angular_velocity(k);
      Eigen::Matrix<double, 4, 3> ebar_t;
      ebar_t << e[3], -e[2], e[1], e[2], e[3], -e[0], -e[1], e[0], e[3], -e[0], -e[1], -e[2];
      EXPECT_LT((data.xdot.segment<4>(4 * k) - 0.5 * ebar_t * w).norm(), 1e-15);
    }
    EXPECT_EQ(VectorX(data.xdot.tail(3 * n)), VectorX(state.y.tail(3 * n)));
  }
}

TEST(Kane, KaneEquationsEqualNewtonEulerPerBody) {
  // With the Kane ydot, the mass-centre accelerations a_G = [v_G,y] ydot + [v_G,y dot] y
  // satisfy m a_G = F_K and the Euler equation I alpha + w x I w = M' holds for every body
  // (every body is free, so the 6N generalized equations are equivalent to the 6N
  // Newton-Euler ones). The Kane solution has <= ~1e-12 relative error (condition of [A]
  // <= ~1e4; measured worst 3e-13); tolerance 1e-11 relative to the size of the terms.
  std::mt19937 rng(44);
  for (const Model& model : loaded_models(45, 50)) {
    Data data(model);
    const State state = test::random_state(model, rng);
    kane_equations(model, state, data);
    for (int k = 0; k < model.num_bodies(); ++k) {
      const auto i = static_cast<size_t>(k);
      const BodySpec& b = model.body(k);
      const Vector3 a_g = partial_velocity(model, data, k, Point::G) * data.ydot +
                          partial_velocity_rate(model, data, k, Point::G) * state.y;
      const Vector3 alpha = angular_velocity_partial(model, k) * data.ydot;  // Eq. (10)
      EXPECT_EQ(alpha, angular_acceleration_b(data.ydot, k));
      const Vector3 w = state.angular_velocity(k);
      const double f_scale = data.loads.force[i].norm() + b.mass * a_g.norm() + 1.0;
      EXPECT_LT((b.mass * a_g - data.loads.force[i]).norm(), 1e-11 * f_scale) << "body " << k;
      const Vector3 euler = b.inertia * alpha + w.cross(b.inertia * w);
      const double m_scale = data.loads.moment_b[i].norm() + (b.inertia * alpha).norm() + 1.0;
      EXPECT_LT((euler - data.loads.moment_b[i]).norm(), 1e-11 * m_scale) << "body " << k;
    }
  }
}

}  // namespace
}  // namespace kanedyn
