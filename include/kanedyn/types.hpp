// Common numeric types and small helpers used by every stage of the notes.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products

namespace kanedyn {

using Vector3 = Eigen::Vector3d;
using Vector4 = Eigen::Vector4d;
using Matrix3 = Eigen::Matrix3d;
using Matrix4 = Eigen::Matrix4d;
using VectorX = Eigen::VectorXd;
using MatrixX = Eigen::MatrixXd;
using Vector6 = Eigen::Matrix<double, 6, 1>;  ///< one body's speeds (w'_K, s'_K dot)
using Matrix6 = Eigen::Matrix<double, 6, 6>;  ///< one body pair's block of [A]
using Matrix36 = Eigen::Matrix<double, 3, 6>;

/// Index of the inertial frame R in lower_body(); body indices are 0-based (body K of the
/// notes is index K-1).
inline constexpr int kGround = -1;

/// The skew matrix [a~] of the notes: [a~]{b} = {a x b}.
inline Matrix3 skew(const Vector3& a) {
  Matrix3 m;
  m << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return m;
}

}  // namespace kanedyn
