// Data: the workspace of one evaluation (GUIDE: "Data"). Every intermediate result of the
// notes lives here, allocated once per Model, so the evaluation path never touches the heap.
#pragma once

#include <vector>

#include <Eigen/Cholesky>

#include "kanedyn/model.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn {

/// What a Data workspace allocates. The partial velocity blocks take
/// sum over K of (u_K + 1) blocks each; the O(N) recursive route does not need them, and a
/// 100,000-body chain should not pay for them.
struct DataOptions {
  bool partials = true;     ///< block-sparse partial velocity matrices (Eqs. 18-30)
  bool mass_matrix = true;  ///< the dense 6N x 6N [A] of Eq. (37) and its factorization
};

/// Workspace for one Model. Frames: "inertial" columns are unprimed in the notes, "_b" are
/// body components. Partial velocity blocks are stored per chain entry: for body k,
/// entry model.chain_offset(k) + r belongs to body L^r(K) = model.chain(k)[r] and holds the
/// 3x3 coefficient of that body's w' (the "_w" arrays, y1 part) or s' dot (the "_s" arrays,
/// y2 part). Every other block of the 3 x 6N matrix is zero.
struct Data {
  explicit Data(const Model& model, DataOptions options = {});

  DataOptions options;

  // Eqs. (2)-(4).
  std::vector<Matrix3> R;  ///< [R_K]: inertial -> body-K components

  // Eqs. (11)-(17), inertial components.
  std::vector<Vector3> p_O, p_G;  ///< positions of O_K and G_K
  std::vector<Vector3> v_O, v_G;  ///< velocities of O_K and G_K
  std::vector<Vector3> qs_b;      ///< {q'_K} + {s'_K}, body-J components

  // Eqs. (18)-(27): [v_O_K,y] and [v_G_K,y], block-sparse (see above).
  std::vector<Matrix3> vO_w, vO_s, vG_w, vG_s;
  // Eqs. (29)-(30): their time derivatives, same layout.
  std::vector<Matrix3> vO_w_dot, vO_s_dot, vG_w_dot, vG_s_dot;

  // Per-body resultants of all loads (gravity and force elements): force at G_K in inertial
  // components, moment in body-K components (the {F_K} and {M'_K} of Eq. 31).
  std::vector<Vector3> force, moment_b;

  VectorX F_y;                   ///< generalized forces, Eq. (31), 6N
  MatrixX A;                     ///< generalized mass matrix, Eq. (37), 6N x 6N
  VectorX f;                     ///< right side, Eq. (38), 6N
  Eigen::LLT<MatrixX> A_factor;  ///< Cholesky factor of A

  VectorX ydot;  ///< 6N, solution of Eq. (36)
  VectorX xdot;  ///< 7N, Eqs. (39)-(40)

  // Scratch of the O(N) recursive route (body accelerations, inertial / body components).
  std::vector<Vector3> a_G, a_O, alpha_b;
};

}  // namespace kanedyn
