// The spatial terms of the jointed routes (docs/theory.md, "Forward dynamics of a jointed tree"):
// every body described by its velocity V_K = (w_K, v_O_K) in inertial components about its own
// O_K, mapped from J's by V_K = [P_K] V_J + [S_K] z_K. Shared by the forward dynamics
// (src/joint_dynamics.cpp) and the inverse dynamics, mass matrix and centre of mass
// (src/terms.cpp), so that each term is written once.
#pragma once

#include "kanedyn/joint.hpp"
#include "kanedyn/types.hpp"

#include "equations.hpp"
#include "joint_motion.hpp"

namespace kanedyn::detail {

// The spatial inertia of body K about O_K for V = (w, v_O), inertial components: the kinetic
// energy is 1/2 V^T [I_O] V, and [I_O] V = (angular momentum about O_K, linear momentum).
//   [I_O] = | [I_G] - m [c~][c~]   m [c~] |     c = G_K - O_K, [I_G] = [R_K]^T [I'_G] [R_K]
//           | -m [c~]              m [I]  |
// [R]^T [I'] [R] for a symmetric [I'] (an inertia in body axes, [R] = [R_K]): its six distinct
// entries, each the dot product of a column of [R] with [I'] times another.
inline Matrix3 inertial_axes(const Matrix3& inertia, const Matrix3& r) {
  Matrix3 ir;
  ir.noalias() = inertia * r;
  Matrix3 out;
  for (int c = 0; c < 3; ++c)
    for (int row = 0; row <= c; ++row) out(row, c) = out(c, row) = r.col(row).dot(ir.col(c));
  return out;
}

// With [c~][c~] = c c^T - (c.c)[I].
inline void spatial_inertia(double mass, const Vector3& c, const Matrix3& inertia_g, Matrix6& i) {
  const Vector3 mc = mass * c;
  const Matrix3 mcx = skew(mc);
  auto tl = i.topLeftCorner<3, 3>();
  tl = inertia_g;
  tl.noalias() -= mc * c.transpose();
  tl.diagonal().array() += mc.dot(c);
  i.topRightCorner<3, 3>() = mcx;
  i.bottomLeftCorner<3, 3>() = -mcx;
  i.bottomRightCorner<3, 3>() = mass * Matrix3::Identity();
}

// [P_K] = | a [I]     0   |  (a = 1; a = 0 for a free body), applied by blocks, with
//          | -[r~]   [I] |
// r = O_K - O_J = [R_J]^T (q'_K + s'_K) in inertial components: every spatial quantity here is
// in inertial axes about the body's own O_K, so carrying one from K to J shifts its point and
// turns nothing.
struct BodyMap {
  const Vector3& r;
  bool angular;  // a = 1: w_K carries w_J
};

// [P] V_J: (a w, v + w x r).
inline Vector6 map_velocity(const BodyMap& m, const Vector6& v) {
  Vector6 out;
  out.head<3>() = m.angular ? Vector3(v.head<3>()) : Vector3::Zero();
  out.tail<3>() = v.tail<3>() + v.head<3>().cross(m.r);
  return out;
}

// [P]^T f for f = (moment about O_K, force): the same about O_J, (a n + r x F, F).
template <typename Column>
inline Vector6 carry_force(const BodyMap& m, const Column& f) {
  const Vector3 force = f.template tail<3>();
  Vector6 out;
  out.template head<3>() = m.r.cross(force);
  if (m.angular) out.template head<3>() += f.template head<3>();
  out.template tail<3>() = force;
  return out;
}

// target += [P]^T M [P] for a symmetric M = [A B; B^T C]: with W = C [r~] (so W^T = -[r~] C,
// [r~]^T = -[r~]), the result is
//   [a A - a (B[r~] + (B[r~])^T) + W^T [r~],  a B - W^T;  (a B - W^T)^T,  C],
// its symmetric blocks from their upper triangles. Each product with [r~] is written out by
// rows, u [r~] = (u2 r3 - u3 r2, u3 r1 - u1 r3, u1 r2 - u2 r1) for a row u: 18 products where a
// product with the 3x3 skew matrix takes 27, and 6 entries of W^T [r~] where 9 would be formed.
inline void add_carried_inertia(const BodyMap& m, const Matrix6& M, Matrix6& target) {
  const double rx = m.r.x(), ry = m.r.y(), rz = m.r.z();
  double w[3][3];  // W = C [r~], by rows of C
  double x[3][3];  // B [r~], by rows of B
#pragma GCC unroll 3
  for (int i = 0; i < 3; ++i) {
    const double c0 = M(3 + i, 3), c1 = M(3 + i, 4), c2 = M(3 + i, 5);
    w[i][0] = c1 * rz - c2 * ry;
    w[i][1] = c2 * rx - c0 * rz;
    w[i][2] = c0 * ry - c1 * rx;
    const double b0 = M(i, 3), b1 = M(i, 4), b2 = M(i, 5);
    x[i][0] = b1 * rz - b2 * ry;
    x[i][1] = b2 * rx - b0 * rz;
    x[i][2] = b0 * ry - b1 * rx;
  }
#pragma GCC unroll 3
  for (int i = 0; i < 3; ++i) {
    // Row i of W^T [r~] is column i of W times [r~].
    const double u0 = w[0][i], u1 = w[1][i], u2 = w[2][i];
    const double y[3] = {u1 * rz - u2 * ry, u2 * rx - u0 * rz, u0 * ry - u1 * rx};
#pragma GCC unroll 3
    for (int j = i; j < 3; ++j) {
      double tl = y[j];
      if (m.angular) tl += M(i, j) - x[i][j] - x[j][i];
      target(i, j) += tl;
      if (j != i) target(j, i) += tl;
      const double br = M(3 + i, 3 + j);
      target(3 + i, 3 + j) += br;
      if (j != i) target(3 + j, 3 + i) += br;
    }
#pragma GCC unroll 3
    for (int j = 0; j < 3; ++j) {
      const double tr = (m.angular ? M(i, 3 + j) : 0.0) - w[j][i];
      target(i, 3 + j) += tr;
      target(3 + j, i) += tr;
    }
  }
}

// [S_K] = ([R_K]^T [G_K]; [R_J]^T [T_K]) into the m columns at s (6 doubles a column): the
// angular rows from [G_K] (none for a prismatic joint), the linear rows from the columns of
// [T_K] set in the mask `slides` ([T] = [0 I] for a free body: [R_J]^T, not read from T).
// Inlined by force: called once per body in the forward route's outward pass, where a call
// (the compiler's choice once the function left that file) cost about 1% of an evaluation.
[[gnu::always_inline]] inline void motion_subspace(JointType type, int m, const Matrix3& rk,
                                                   const Matrix3& rj, const Matrix36& G,
                                                   const Matrix36& T, unsigned slides, double* s) {
  Eigen::Map<Eigen::Matrix<double, 6, Eigen::Dynamic>> out(s, 6, m);
  if (!joint_type_info(type).turns) {
    out.topRows<3>().setZero();
  } else {
    for (int col = 0; col < m; ++col)
      out.col(col).head<3>().noalias() = rk.transpose() * G.col(col);
  }
  out.bottomRows<3>().setZero();
  if (type == JointType::free)
    out.bottomRightCorner<3, 3>() = rj.transpose();
  else
    for (int col = 0; col < m; ++col)
      if (slides & (1u << col)) out.col(col).tail<3>().noalias() = rj.transpose() * T.col(col);
}

// The mask of the nonzero columns of [T_K] (joint_translation_block), for motion_subspace.
inline unsigned slide_columns(const Matrix36& T, int m) {
  unsigned mask = 0;
  for (int col = 0; col < m; ++col)
    if (!T.col(col).isZero(0.0)) mask |= 1u << col;
  return mask;
}

// c_K = d/dt V_K at z dot = 0 with J's acceleration zero (w_j = 0 for a root). With
// d/dt ([R]^T u) = w x [R]^T u + [R]^T du/dt, w_rel = w_K - a w_J and the slide rate
// sd = [R_J]^T [T_K] z_K (dr/dt = w_J x r + sd):
//   angular  w_K x w_rel + [R_K]^T [G_K dot] z_K        (0 for a free body: w_rel = w_K)
//   linear   w_J x (w_J x r) + 2 w_J x sd
inline void velocity_product_acceleration(JointType type, bool root, const Vector3& w_k,
                                          const Vector3& w_j, const Matrix3& rk, const Matrix3& rj,
                                          const JointMotion& jm, const Vector3& r, Vector6& c) {
  if (type == JointType::free) {
    c.head<3>().setZero();
  } else {
    c.head<3>() = w_k.cross(w_k - w_j);
    if (joint_type_info(type).turning_axis) c.head<3>().noalias() += rk.transpose() * jm.g_dot_z;
  }
  if (root) {
    c.tail<3>().setZero();
  } else {
    const Vector3 sd = rj.transpose() * jm.slide_rate;
    eq::store(c.data() + 3, eq::transport_acceleration(eq::vec(w_j), eq::vec(sd), eq::vec(r)));
  }
}

}  // namespace kanedyn::detail
