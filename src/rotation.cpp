#include "kanedyn/rotation.hpp"

#include <cmath>

#include "equations.hpp"

namespace kanedyn {

Matrix3 rotation_matrix(const Vector4& eps) {
  return eq::eigen(eq::rotation_matrix(eq::euler(eps)));  // Eqs. (3)-(4)
}

Matrix4 euler_matrix(const Vector4& eps) {
  const double e1 = eps[0], e2 = eps[1], e3 = eps[2], e4 = eps[3];
  Matrix4 e;              // Eq. (5)
  e << e4, e3, -e2, -e1,  //
      -e3, e4, e1, -e2,   //
      e2, -e1, e4, -e3,   //
      e1, e2, e3, e4;
  return e;
}

Eigen::Matrix<double, 4, 3> euler_matrix_bar_transpose(const Vector4& eps) {
  const double e1 = eps[0], e2 = eps[1], e3 = eps[2], e4 = eps[3];
  Eigen::Matrix<double, 4, 3> m;  // Eq. (41)
  m << e4, -e3, e2,               //
      e3, e4, -e1,                //
      -e2, e1, e4,                //
      -e1, -e2, -e3;
  return m;
}

Vector4 euler_parameter_rates(const Vector4& eps, const Vector3& w_b) {
  return eq::eigen(eq::euler_parameter_rates(eq::euler(eps), eq::vec(w_b)));  // Eqs. (39), (41)
}

Vector3 angular_velocity_from_rates(const Vector4& eps, const Vector4& eps_dot) {
  return 2.0 * euler_matrix_bar_transpose(eps).transpose() * eps_dot;
}

Vector4 euler_parameters_from_axis_angle(const Vector3& axis, double angle) {
  // Divided by its largest component first, the axis has a norm in [1, sqrt(3)]: no overflow
  // for 1e200, no underflow (or lost digits) for 1e-170 or subnormal components.
  const double largest = axis.cwiseAbs().maxCoeff();
  if (!(largest > 0.0)) return {0.0, 0.0, 0.0, 1.0};
  const Vector3 scaled = axis / largest;
  const Vector3 e = std::sin(0.5 * angle) / scaled.norm() * scaled;
  return {e.x(), e.y(), e.z(), std::cos(0.5 * angle)};
}

Vector4 euler_parameters_from_matrix(const Matrix3& r) {
  // Inverse of Eqs. (3)-(4) (Shepperd's method: divide by the largest component).
  const double tr = r.trace();
  Vector4 e;
  if (tr >= r(0, 0) && tr >= r(1, 1) && tr >= r(2, 2)) {
    const double e4 = 0.5 * std::sqrt(1.0 + tr);
    e << (r(1, 2) - r(2, 1)) / (4 * e4), (r(2, 0) - r(0, 2)) / (4 * e4),
        (r(0, 1) - r(1, 0)) / (4 * e4), e4;
  } else if (r(0, 0) >= r(1, 1) && r(0, 0) >= r(2, 2)) {
    const double e1 = 0.5 * std::sqrt(1.0 + 2 * r(0, 0) - tr);
    e << e1, (r(0, 1) + r(1, 0)) / (4 * e1), (r(0, 2) + r(2, 0)) / (4 * e1),
        (r(1, 2) - r(2, 1)) / (4 * e1);
  } else if (r(1, 1) >= r(2, 2)) {
    const double e2 = 0.5 * std::sqrt(1.0 + 2 * r(1, 1) - tr);
    e << (r(0, 1) + r(1, 0)) / (4 * e2), e2, (r(1, 2) + r(2, 1)) / (4 * e2),
        (r(2, 0) - r(0, 2)) / (4 * e2);
  } else {
    const double e3 = 0.5 * std::sqrt(1.0 + 2 * r(2, 2) - tr);
    e << (r(0, 2) + r(2, 0)) / (4 * e3), (r(1, 2) + r(2, 1)) / (4 * e3), e3,
        (r(0, 1) - r(1, 0)) / (4 * e3);
  }
  if (e[3] < 0) e = -e;
  return e.normalized();
}

Vector4 relative_euler_parameters(const Vector4& eps_j, const Vector4& eps_k) {
  return eq::eigen(eq::relative_euler_parameters(eq::euler(eps_j), eq::euler(eps_k)));
}

Vector3 rotation_vector(const Vector4& eps) {
  return eq::eigen(eq::rotation_vector(eq::euler(eps)));
}

}  // namespace kanedyn
