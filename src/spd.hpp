// The inverse of a small symmetric positive definite matrix: the pivot blocks of the tree LDL^T
// (src/tree_ldlt.cpp) and the joint-space inertias D = [S]^T [I_A] [S] of the articulated-body
// recursion (src/joint_dynamics.cpp), of 1, 2, 3 or 6 rows (a joint's speed count). The one
// solver of the library for these blocks: by cofactors up to 3 x 3, and a 6 x 6 through its
// 3 x 3 blocks. Each returns false when the matrix is not positive definite (a pivot, a leading
// minor or a Schur complement not positive). Private to the library.
#pragma once

#include <Eigen/Core>

#include "kanedyn/types.hpp"

namespace kanedyn::detail {

/// 1 x 1.
inline bool invert_spd1(double a, double& inv) {
  inv = 1.0 / a;
  return a > 0.0;
}

/// 2 x 2 by cofactors, reading all four entries.
inline bool invert_spd2(const Eigen::Matrix2d& a, Eigen::Matrix2d& inv) {
  const double det = a(0, 0) * a(1, 1) - a(1, 0) * a(0, 1);
  const double r = 1.0 / det;
  inv(0, 0) = a(1, 1) * r;
  inv(1, 0) = -a(1, 0) * r;
  inv(0, 1) = -a(0, 1) * r;
  inv(1, 1) = a(0, 0) * r;
  return a(0, 0) > 0.0 && det > 0.0;
}

/// 3 x 3 by cofactors, from the upper triangle (the result is symmetric).
inline bool invert_spd3(const Matrix3& a, Matrix3& inv) {
  const double c00 = a(1, 1) * a(2, 2) - a(1, 2) * a(1, 2);
  const double c01 = a(1, 2) * a(0, 2) - a(0, 1) * a(2, 2);
  const double c02 = a(0, 1) * a(1, 2) - a(1, 1) * a(0, 2);
  const double det = a(0, 0) * c00 + a(0, 1) * c01 + a(0, 2) * c02;
  const double r = 1.0 / det;
  inv(0, 0) = c00 * r;
  inv(0, 1) = inv(1, 0) = c01 * r;
  inv(0, 2) = inv(2, 0) = c02 * r;
  inv(1, 1) = (a(0, 0) * a(2, 2) - a(0, 2) * a(0, 2)) * r;
  inv(1, 2) = inv(2, 1) = (a(0, 2) * a(0, 1) - a(0, 0) * a(1, 2)) * r;
  inv(2, 2) = (a(0, 0) * a(1, 1) - a(0, 1) * a(0, 1)) * r;
  return a(0, 0) > 0.0 && a(0, 0) * a(1, 1) - a(0, 1) * a(0, 1) > 0.0 && det > 0.0;
}

/// 6 x 6 in place, through its 3x3 blocks [P Q; Q^T S]: with T = P^-1 Q and the Schur
/// complement S - Q^T T, d^-1 = [P^-1 + T Z T^T, -T Z; -Z T^T, Z], Z = (S - Q^T T)^-1.
template <typename Six>
inline bool invert_spd6(Six&& d) {
  const Matrix3 q = d.template topRightCorner<3, 3>();
  Matrix3 p_inv, z;
  bool ok = invert_spd3(d.template topLeftCorner<3, 3>(), p_inv);
  const Matrix3 t = p_inv * q;
  ok = invert_spd3(d.template bottomRightCorner<3, 3>() - q.transpose() * t, z) && ok;
  const Matrix3 tz = t * z;
  d.template topLeftCorner<3, 3>() = p_inv + tz * t.transpose();
  d.template topRightCorner<3, 3>() = -tz;
  d.template bottomLeftCorner<3, 3>() = -tz.transpose();
  d.template bottomRightCorner<3, 3>() = z;
  return ok;
}

/// An M x M matrix (M = 1, 2, 3 or 6) in place.
template <int M>
inline bool invert_spd(Eigen::Matrix<double, M, M>& d) {
  static_assert(M == 1 || M == 2 || M == 3 || M == 6, "a joint has 1, 2, 3 or 6 speeds");
  if constexpr (M == 1) {
    return invert_spd1(d(0, 0), d(0, 0));
  } else if constexpr (M == 2) {
    const Eigen::Matrix2d a = d;
    return invert_spd2(a, d);
  } else if constexpr (M == 3) {
    const Matrix3 a = d;
    return invert_spd3(a, d);
  } else {
    return invert_spd6(d);
  }
}

/// The m x m column-major block at d (m = 1, 2, 3 or 6) in place.
inline bool invert_spd(double* d, int m) {
  switch (m) {
    case 1:
      return invert_spd1(d[0], d[0]);
    case 2: {
      Eigen::Map<Eigen::Matrix2d> a(d);
      Eigen::Matrix2d inv;
      const bool ok = invert_spd2(a, inv);
      a = inv;
      return ok;
    }
    case 3: {
      Eigen::Map<Matrix3> a(d);
      Matrix3 inv;
      const bool ok = invert_spd3(a, inv);
      a = inv;
      return ok;
    }
    default:
      return invert_spd6(Eigen::Map<Matrix6>(d));
  }
}

}  // namespace kanedyn::detail
