// Inline rotation helpers for the evaluation loops (src/dynamics.cpp, src/forces.cpp): the
// same quantities as rotation.hpp, written out for speed, without a call to atan2.
#pragma once

#include <cmath>

#include "kanedyn/types.hpp"

namespace kanedyn::detail {

/// Euler parameters of K relative to J from the absolute ones (as
/// kanedyn::relative_euler_parameters): [R(rel)] = [R_K][R_J]^T maps body-J to body-K
/// components.
inline Vector4 relative_euler_parameters(const double* ej, const double* ek) {
  // rel = conj(J) * K in Hamilton quaternion algebra (see rotation.cpp).
  const double a1 = -ej[0], a2 = -ej[1], a3 = -ej[2], sj = ej[3];
  const double b1 = ek[0], b2 = ek[1], b3 = ek[2], sk = ek[3];
  return {sj * b1 + sk * a1 + (a2 * b3 - a3 * b2), sj * b2 + sk * a2 + (a3 * b1 - a1 * b3),
          sj * b3 + sk * a3 + (a1 * b2 - a2 * b1), sj * sk - (a1 * b1 + a2 * b2 + a3 * b3)};
}

/// [R] of Eqs. (3)-(4) (as kanedyn::rotation_matrix).
inline Matrix3 rotation_matrix(const Vector4& eps) {
  const double e1 = eps[0], e2 = eps[1], e3 = eps[2], e4 = eps[3];
  const double e11 = e1 * e1, e22 = e2 * e2, e33 = e3 * e3, e44 = e4 * e4;
  const double e12 = e1 * e2, e13 = e1 * e3, e14 = e1 * e4;
  const double e23 = e2 * e3, e24 = e2 * e4, e34 = e3 * e4;
  Matrix3 r;
  r(0, 0) = e11 - e22 - e33 + e44;
  r(0, 1) = 2.0 * (e12 + e34);
  r(0, 2) = 2.0 * (e13 - e24);
  r(1, 0) = 2.0 * (e12 - e34);
  r(1, 1) = -e11 + e22 - e33 + e44;
  r(1, 2) = 2.0 * (e23 + e14);
  r(2, 0) = 2.0 * (e13 + e24);
  r(2, 1) = 2.0 * (e23 - e14);
  r(2, 2) = -e11 - e22 + e33 + e44;
  return r;
}

/// [R(eps)]{v} without forming [R]: (e4^2 - e.e){v} + 2{e}(e.v) - 2 e4 {e x v}.
inline Vector3 rotate(const double* eps, const Vector3& v) {
  const Vector3 e(eps[0], eps[1], eps[2]);
  const double e4 = eps[3];
  return (e4 * e4 - e.squaredNorm()) * v + (2.0 * e.dot(v)) * e - (2.0 * e4) * e.cross(v);
}

/// Rotation vector theta = 2 atan2(|e|, e4) e / |e| (sign of eps chosen so that e4 >= 0, angle
/// in [0, pi]), as kanedyn::rotation_vector to about an ulp, without atan2. The half angle is
/// phi = atan(t) with t = |e| / e4, or pi/2 - atan(t) with t = e4 / |e| when |e| > e4; then
/// atan(t) = atan(c_k) + atan((t - c_k) / (1 + t c_k)) with c_k the double nearest
/// tan(k pi/12), k = 0..3, so that the reduced argument is at most tan(pi/24), where the series
/// t (1 - t^2/3 + t^4/5 - ...) to t^17 is exact to 1e-17 relative. Rotations below 15 degrees
/// (k = 0) need no sqrt and no division by |e|.
inline Vector3 rotation_vector(const Vector4& eps) {
  Vector3 v = eps.head<3>();
  double s = eps[3];
  if (s < 0.0) {
    v = -v;
    s = -s;
  }
  const auto atan_over_t = [](double t2) {  // atan(t) / t for t^2 <= tan^2(pi/24)
    return 1.0 -
           t2 * (1.0 / 3 -
                 t2 * (1.0 / 5 -
                       t2 * (1.0 / 7 -
                             t2 * (1.0 / 9 -
                                   t2 * (1.0 / 11 -
                                         t2 * (1.0 / 13 - t2 * (1.0 / 15 - t2 * (1.0 / 17))))))));
  };
  constexpr double kTan24 = 0.13165249758739586;  // tan(pi/24)
  const double n2 = v.squaredNorm();
  if (n2 <= s * s * (kTan24 * kTan24)) {  // phi / |e| = atan(t) / (t s), t = |e| / s
    const double inv_s = 1.0 / s;
    return (2.0 * inv_s * atan_over_t(n2 * inv_s * inv_s)) * v;
  }
  constexpr double kC[4] = {0.0, 0.2679491924311227, 0.5773502691896257, 1.0};  // c_k
  constexpr double kAtanC[4] = {0.0, 0.2617993877991494, 0.5235987755982988,
                                0.7853981633974483};  // atan(c_k), correctly rounded
  // tan((2k+1) pi/24), k = 0..2: where the nearest k changes.
  constexpr double kBound[3] = {kTan24, 0.41421356237309503, 0.7673269879789604};
  const double n = std::sqrt(n2);
  const bool large = n > s;
  const double t = large ? s / n : n / s;  // in [0, 1]
  const int k = (t > kBound[0]) + (t > kBound[1]) + (t > kBound[2]);
  const double r = (t - kC[k]) / (1.0 + t * kC[k]);
  const double a = kAtanC[k] + r * atan_over_t(r * r);
  const double phi = large ? 1.5707963267948966 - a : a;
  return (2.0 * phi / n) * v;
}

}  // namespace kanedyn::detail
