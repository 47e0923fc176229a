// The equations of src/equations.inc for the staged route (S = double), in namespace
// kanedyn::eq, plus the copies between Eigen types and the templates' small arrays. Private to
// the library; the fused kernel includes equations.inc itself (see there).
#pragma once

#include <cmath>
#include <type_traits>

#include "kanedyn/types.hpp"

namespace kanedyn {

#include "equations.inc"

namespace eq {

inline Vec3<double> vec(const Vector3& v) { return {v.x(), v.y(), v.z()}; }
inline Vector3 eigen(const Vec3<double>& v) { return {v.x, v.y, v.z}; }
/// Adds (subtracts) v to an Eigen column component by component: an Eigen temporary made from
/// v would be stored as scalars and loaded as a packet, which stalls store-to-load forwarding.
inline void add_to(Vector3& target, const Vec3<double>& v) {
  target.x() += v.x;
  target.y() += v.y;
  target.z() += v.z;
}
inline void subtract_from(Vector3& target, const Vec3<double>& v) {
  target.x() -= v.x;
  target.y() -= v.y;
  target.z() -= v.z;
}
inline void store(double* target, const Vec3<double>& v) {
  target[0] = v.x;
  target[1] = v.y;
  target[2] = v.z;
}
inline Euler<double> euler(const double* e) { return {{e[0], e[1], e[2], e[3]}}; }
inline Euler<double> euler(const Vector4& e) { return euler(e.data()); }
inline Vector4 eigen(const Euler<double>& e) { return {e.e[0], e.e[1], e.e[2], e.e[3]}; }
inline Mat3<double> mat(const Matrix3& m) {
  return {{m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2)}};
}
inline Matrix3 eigen(const Mat3<double>& m) {
  Matrix3 r;
  r << m.a[0], m.a[1], m.a[2], m.a[3], m.a[4], m.a[5], m.a[6], m.a[7], m.a[8];
  return r;
}
/// Euler parameters of body k relative to body j (J = L(K)) from the state's {x}: exactly k's
/// own for j = kGround, whose frame is the identity.
inline Euler<double> relative_euler(const double* x, int j, int k) {
  const Euler<double> eps_k = euler(x + 4 * k);
  return j == kGround ? eps_k : relative_euler_parameters(euler(x + 4 * j), eps_k);
}
/// The upper triangle of a symmetric matrix (an inertia), as the kernel stores it.
inline Sym3<double> sym(const Matrix3& m) {
  return {{m(0, 0), m(1, 1), m(2, 2), m(0, 1), m(0, 2), m(1, 2)}};
}

}  // namespace eq

}  // namespace kanedyn
