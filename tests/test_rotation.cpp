// Eqs. (2)-(5), (41) and the rotation helpers: checks against formulas written here from the
// README of the notes, finite differences along the kinematic equation, and round trips.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "kanedyn/rotation.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

using test::random_euler_parameters;
using test::random_vector;

// Round-off tolerance for O(1) expressions of a handful of products of unit-size numbers:
// each entry of [R] is a sum of 4 products, so its error is a few ulp (~1e-16); 1e-14 leaves
// a margin of ~50 and still fails on any wrong sign or index (errors of O(1)).
constexpr double kRoundOff = 1e-14;
constexpr double kPi = std::numbers::pi;

TEST(Rotation, OrthogonalWithDeterminantOne) {
  std::mt19937 rng(1);
  for (int i = 0; i < 200; ++i) {
    const Vector4 eps = random_euler_parameters(rng);
    const Matrix3 r = rotation_matrix(eps);
    EXPECT_LT((r * r.transpose() - Matrix3::Identity()).cwiseAbs().maxCoeff(), kRoundOff);
    EXPECT_NEAR(r.determinant(), 1.0, kRoundOff);
  }
}

TEST(Rotation, MatchesExplicitReadmeMatrix) {
  std::mt19937 rng(2);
  for (int i = 0; i < 200; ++i) {
    const Vector4 eps = random_euler_parameters(rng);
    const double e1 = eps[0], e2 = eps[1], e3 = eps[2], e4 = eps[3];
    // The README's element-by-element matrix of Eqs. (3)-(4).
    Matrix3 expected;
    expected << e1 * e1 - e2 * e2 - e3 * e3 + e4 * e4, 2 * (e1 * e2 + e3 * e4),
        2 * (e1 * e3 - e2 * e4),  //
        2 * (e1 * e2 - e3 * e4), -e1 * e1 + e2 * e2 - e3 * e3 + e4 * e4,
        2 * (e2 * e3 + e1 * e4),  //
        2 * (e1 * e3 + e2 * e4), 2 * (e2 * e3 - e1 * e4), -e1 * e1 - e2 * e2 + e3 * e3 + e4 * e4;
    const Matrix3 r = rotation_matrix(eps);
    EXPECT_LT((r - expected).cwiseAbs().maxCoeff(), kRoundOff);
    // ...and the compact form (e4^2 - e.e)[I] + 2 e e^T - 2 e4 [e~].
    EXPECT_LT((r - test::reference_rotation(eps)).cwiseAbs().maxCoeff(), kRoundOff);
  }
  // Rows of [R] are the body axes in inertial components (Eq. 2): a rotation by +90 deg about
  // N3 turns e1 into N2, so row 0 of [R] is (0, 1, 0).
  const Matrix3 r = rotation_matrix(euler_parameters_from_axis_angle(Vector3::UnitZ(), kPi / 2));
  EXPECT_LT((r.row(0).transpose() - Vector3::UnitY()).norm(), kRoundOff);
  EXPECT_LT((r.row(1).transpose() + Vector3::UnitX()).norm(), kRoundOff);
}

TEST(Rotation, TimeDerivativeIsMinusSkewOmegaTimesR) {
  // d[R_K]/dt = -[w'~][R_K] with eps moving along eps_dot = euler_parameter_rates(eps, w').
  // The path eps(t) = normalize(eps + t eps_dot) has tangent eps_dot at t = 0 (eps.eps_dot
  // = 0). Central difference with h = 1e-5: truncation h^2/6 |R'''| <= 1.7e-11 |w|^3 ~ 5e-10
  // for |w| <= 3.5, round-off ~ 1e-16 / h = 1e-11. Tolerance 1e-8 is 20x above both and far
  // below the O(|w|) error of a wrong sign or transposition.
  std::mt19937 rng(3);
  const double h = 1e-5;
  for (int i = 0; i < 100; ++i) {
    const Vector4 eps = random_euler_parameters(rng);
    const Vector3 w = random_vector(rng, -2.0, 2.0);
    const Vector4 eps_dot = euler_parameter_rates(eps, w);
    EXPECT_NEAR(eps.dot(eps_dot), 0.0, kRoundOff);
    const Matrix3 rp = rotation_matrix((eps + h * eps_dot).normalized());
    const Matrix3 rm = rotation_matrix((eps - h * eps_dot).normalized());
    const Matrix3 fd = (rp - rm) / (2 * h);
    const Matrix3 expected = -skew(w) * rotation_matrix(eps);
    EXPECT_LT((fd - expected).cwiseAbs().maxCoeff(), 1e-8) << "w = " << w.transpose();
  }
}

TEST(Rotation, EulerMatrixOrthogonalAndConsistentWithRates) {
  std::mt19937 rng(4);
  for (int i = 0; i < 100; ++i) {
    const Vector4 eps = random_euler_parameters(rng);
    const Matrix4 e = euler_matrix(eps);
    EXPECT_LT((e * e.transpose() - Matrix4::Identity()).cwiseAbs().maxCoeff(), kRoundOff);
    // Eq. (5) as the README prints it.
    Matrix4 expected;
    expected << eps[3], eps[2], -eps[1], -eps[0],  //
        -eps[2], eps[3], eps[0], -eps[1],          //
        eps[1], -eps[0], eps[3], -eps[2],          //
        eps[0], eps[1], eps[2], eps[3];
    EXPECT_EQ(e, expected);
    // [Ebar']^T of Eq. (41) is [E']^T without its fourth column.
    const Eigen::Matrix<double, 4, 3> bar = e.transpose().leftCols<3>();
    EXPECT_EQ(euler_matrix_bar_transpose(eps), bar);
    // eps_dot = 1/2 [E']^T {w'; 0}.
    const Vector3 w = random_vector(rng, -3.0, 3.0);
    Vector4 w4;
    w4 << w, 0.0;
    EXPECT_LT((euler_parameter_rates(eps, w) - 0.5 * e.transpose() * w4).norm(), kRoundOff);
  }
}

TEST(Rotation, AngularVelocityFromRatesRecoversOmega) {
  std::mt19937 rng(5);
  for (int i = 0; i < 100; ++i) {
    const Vector4 eps = random_euler_parameters(rng);
    const Vector3 w = random_vector(rng, -5.0, 5.0);
    const Vector3 back = angular_velocity_from_rates(eps, euler_parameter_rates(eps, w));
    EXPECT_LT((back - w).norm(), 5 * kRoundOff);  // |w| <= 9: scale round-off accordingly
  }
}

TEST(Rotation, RelativeEulerParameters) {
  std::mt19937 rng(6);
  for (int i = 0; i < 200; ++i) {
    const Vector4 ej = random_euler_parameters(rng);
    const Vector4 ek = random_euler_parameters(rng);
    const Vector4 rel = relative_euler_parameters(ej, ek);
    EXPECT_NEAR(rel.norm(), 1.0, kRoundOff);
    const Matrix3 lhs = rotation_matrix(rel) * rotation_matrix(ej);
    EXPECT_LT((lhs - rotation_matrix(ek)).cwiseAbs().maxCoeff(), kRoundOff);
  }
  // Identical frames: no relative rotation.
  const Vector4 e = random_euler_parameters(rng);
  EXPECT_LT((rotation_matrix(relative_euler_parameters(e, e)) - Matrix3::Identity())
                .cwiseAbs()
                .maxCoeff(),
            kRoundOff);
}

// The rotation vector of eps is theta with |theta| in [0, pi] and R(axis theta, |theta|) = R.
void expect_rotation_vector_consistent(const Vector4& eps) {
  const Vector3 theta = rotation_vector(eps);
  const double angle = theta.norm();
  EXPECT_GE(angle, 0.0);
  EXPECT_LE(angle, kPi * (1 + 1e-15));
  const Matrix3 r = rotation_matrix(euler_parameters_from_axis_angle(theta, angle));
  EXPECT_LT((r - rotation_matrix(eps)).cwiseAbs().maxCoeff(), 1e-13) << eps.transpose();
}

TEST(Rotation, RotationVectorRandom) {
  std::mt19937 rng(7);
  for (int i = 0; i < 200; ++i) {
    const Vector4 eps = random_euler_parameters(rng);
    expect_rotation_vector_consistent(eps);
    expect_rotation_vector_consistent(-eps);  // same rotation, same theta
    EXPECT_LT((rotation_vector(eps) - rotation_vector(-eps)).norm(), kRoundOff);
  }
}

TEST(Rotation, RotationVectorOfKnownAxisAngle) {
  // theta = angle * axis for angle in [0, pi]; an angle a in (pi, 2 pi) is the rotation by
  // 2 pi - a about -axis. Expected values are computed from the inputs, not from the code.
  std::mt19937 rng(8);
  const double angles[] = {1e-14, 1e-10, 1e-8, 2e-8,       1e-6,       0.3,
                           1.0,   2.0,   3.0,  kPi - 1e-6, kPi - 1e-9, kPi - 1e-12};
  for (int i = 0; i < 20; ++i) {
    const Vector3 axis = random_vector(rng, -1.0, 1.0).normalized();
    for (const double a : angles) {
      const Vector4 eps = euler_parameters_from_axis_angle(axis, a);
      const Vector3 expected = a * axis;
      // Relative to the angle: eps is accurate to a few ulp relative even for tiny angles.
      EXPECT_LT((rotation_vector(eps) - expected).norm(), 1e-14 * a) << "angle " << a;
      expect_rotation_vector_consistent(eps);
      // The same rotation written with the opposite sign of eps.
      EXPECT_LT((rotation_vector(-eps) - expected).norm(), 1e-14 * a);
      // A rotation by 2 pi - a about axis is the rotation by a about -axis (here e4 < 0).
      // Absolute tolerance: the input 2 pi - a is itself rounded to ~1e-15 absolute.
      const Vector4 eps2 = euler_parameters_from_axis_angle(axis, 2 * kPi - a);
      EXPECT_LT((rotation_vector(eps2) + expected).norm(), 1e-14) << "angle 2 pi - " << a;
    }
    // Exactly pi: both signs of the axis describe the rotation.
    const Vector3 t = rotation_vector(euler_parameters_from_axis_angle(axis, kPi));
    EXPECT_NEAR(t.norm(), kPi, 1e-14);
    EXPECT_NEAR(std::abs(t.normalized().dot(axis)), 1.0, 1e-14);
    expect_rotation_vector_consistent(euler_parameters_from_axis_angle(axis, kPi));
  }
  // Identity.
  EXPECT_EQ(rotation_vector(Vector4(0, 0, 0, 1)), Vector3::Zero());
  EXPECT_EQ(rotation_vector(Vector4(0, 0, 0, -1)), Vector3::Zero());
}

TEST(Rotation, AxisAngleIndependentOfTheAxisScale) {
  // The axis need not be unit: any positive multiple gives the same Euler parameters, also
  // where |axis| would overflow (1e200 squared) or underflow (1e-170 squared) in a plain norm,
  // and for subnormal components. Reference: the unit axis itself, where the norm is exact.
  std::mt19937 rng(12);
  for (int i = 0; i < 20; ++i) {
    const Vector3 unit = random_vector(rng, -1.0, 1.0).normalized();
    const Vector4 reference = euler_parameters_from_axis_angle(unit, 1.1);
    for (const double scale : {1e200, 1e300, 1e-160, 1e-170, 1e-310}) {
      const Vector4 eps = euler_parameters_from_axis_angle(scale * unit, 1.1);
      ASSERT_TRUE(eps.allFinite()) << "scale " << scale;
      // Round-off: the scaled axis loses at most a few ulp (and the 1e-310 axis, subnormal,
      // keeps ~15 digits of its largest component).
      EXPECT_NEAR(eps.norm(), 1.0, kRoundOff) << "scale " << scale;
      EXPECT_LT((eps - reference).cwiseAbs().maxCoeff(), scale < 1e-300 ? 1e-12 : kRoundOff)
          << "scale " << scale;
    }
  }
  EXPECT_EQ(euler_parameters_from_axis_angle(Vector3(1e200, 0, 0), std::numbers::pi / 2),
            euler_parameters_from_axis_angle(Vector3(1, 0, 0), std::numbers::pi / 2));
}

TEST(Rotation, RotationVectorOfRelativeRotation) {
  // theta of K relative to J: R(from_axis_angle(theta)) equals R(rel) = R_K R_J^T, also when
  // K is close to J (angle near 0) and when K is J turned by nearly pi.
  std::mt19937 rng(9);
  for (int i = 0; i < 50; ++i) {
    const Vector4 ej = random_euler_parameters(rng);
    const Matrix3 rj = rotation_matrix(ej);
    const Vector3 axis = random_vector(rng, -1.0, 1.0);
    for (const double a : {0.0, 1e-12, 1e-7, 0.8, kPi - 1e-7, kPi}) {
      // K = J turned by a about axis (J components): [R_K] = [R(a)] [R_J].
      const Matrix3 rk = rotation_matrix(euler_parameters_from_axis_angle(axis, a)) * rj;
      const Vector4 ek = euler_parameters_from_matrix(rk);
      const Vector4 rel = relative_euler_parameters(ej, ek);
      const Vector3 theta = rotation_vector(rel);
      EXPECT_NEAR(theta.norm(), a, 1e-12);
      const Matrix3 r = rotation_matrix(euler_parameters_from_axis_angle(theta, theta.norm()));
      EXPECT_LT((r - rk * rj.transpose()).cwiseAbs().maxCoeff(), 1e-13) << "angle " << a;
      if (a > 0.0 && a < kPi - 1e-3) {
        EXPECT_LT((theta - a * axis.normalized()).norm(), 1e-12);
      }
    }
  }
}

TEST(Rotation, EulerParametersFromMatrixRoundTrip) {
  std::mt19937 rng(10);
  auto check = [](const Vector4& eps) {
    const Matrix3 r = rotation_matrix(eps);
    const Vector4 back = euler_parameters_from_matrix(r);
    EXPECT_GE(back[3], 0.0);
    EXPECT_NEAR(back.norm(), 1.0, kRoundOff);
    // eps and -eps are the same rotation; the result has e4 >= 0.
    const Vector4 expected = eps[3] >= 0 ? eps : Vector4(-eps);
    EXPECT_LT((back - expected).norm(), 1e-13) << eps.transpose();
    EXPECT_LT((rotation_matrix(back) - r).cwiseAbs().maxCoeff(), kRoundOff);
  };
  for (int i = 0; i < 200; ++i) check(random_euler_parameters(rng));
  // Each branch of the inversion: one dominant component at a time (angle near pi for the
  // first three).
  check(Vector4(0.9, 0.3, -0.2, 0.05).normalized());
  check(Vector4(-0.1, 0.95, 0.2, 0.1).normalized());
  check(Vector4(0.2, -0.1, -0.97, 0.02).normalized());
  check(Vector4(0.1, 0.2, 0.1, 0.95).normalized());
  check(Vector4(1, 0, 0, 0));
  check(Vector4(0, 1, 0, 0));
  check(Vector4(0, 0, 1, 0));
  check(Vector4(0, 0, 0, 1));
}

}  // namespace
}  // namespace kanedyn
