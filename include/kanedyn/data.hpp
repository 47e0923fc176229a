// Data: the workspace of one evaluation. Every intermediate result of the
// notes lives here, allocated once per Model, so the evaluation path never touches the heap.
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "kanedyn/model.hpp"
#include "kanedyn/tree_ldlt.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn {

namespace fused {
struct Plan;
}

/// What a Data workspace allocates. The partial velocity blocks and the blocks of [A] take
/// sum over K of (u_K + 1) blocks each (model.chain_entries()); the O(N) recursive route needs
/// neither, and a 100,000-body chain should not pay for them: use DataOptions{false, false}.
struct DataOptions {
  bool partials = true;  ///< chain-layout partial velocity matrices (Eqs. 18-30): outputs, tests
  /// The Kane route: the nonzero 6x6 blocks of [A] (Eq. 37) and their tree LDL^T; also the
  /// dense 6N x 6N copy data.A unless dense_mass_matrix is false.
  bool mass_matrix = true;
  /// With mass_matrix: keep the dense [A] in data.A (filled by kane_equations, for `eom`,
  /// teaching and tests). Costs 36 N^2 doubles; forward_dynamics does not fill it.
  bool dense_mass_matrix = true;
  /// Widest SIMD kernel the O(N) recursive route may use: 2, 4 (AVX) or 8 (AVX-512F) bodies
  /// per pass; the widest the running CPU has up to this is taken (Data::fused_lanes). Every
  /// width gives the same bits; a smaller cap is for comparisons and tests.
  int max_simd_lanes = 8;
};

/// Workspace for one Model. Frames: "inertial" columns are unprimed in the notes, "_b" are
/// body components. Partial velocity blocks are stored per chain entry: for body k,
/// entry model.chain_offset(k) + r belongs to body L^r(K) = model.chain(k)[r] and holds the
/// 3x3 coefficient of that body's w' (the "_w" arrays, y1 part) or s' dot (the "_s" arrays,
/// y2 part). Every other block of the 3 x 6N matrix is zero.
struct Data {
  explicit Data(const Model& model, DataOptions options = {});

  /// Heap bytes held by the workspace (for memory tables; O(number of members)).
  std::size_t memory_bytes() const;

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

  VectorX F_y;  ///< generalized forces, Eq. (31), 6N
  /// Generalized mass matrix, Eq. (37), 6N x 6N, dense (DataOptions::dense_mass_matrix):
  /// filled from A_blocks by kane_equations() or dense_mass_matrix().
  MatrixX A;
  VectorX f;  ///< right side, Eq. (38), 6N

  /// The nonzero 6x6 blocks of [A] in chain layout (DataOptions::mass_matrix): entry
  /// model.chain_offset(k) + r is the block of rows K, columns L^r(K), each in the order
  /// (w'_K, s'_K dot) of that body's speeds; r = 0 is the diagonal block. The blocks above the
  /// diagonal are their transposes; every other block of [A] is zero.
  std::vector<Matrix6> A_blocks;
  TreeLdlt A_factor;  ///< tree-ordered block LDL^T of A_blocks (no fill-in)

  VectorX ydot;  ///< 6N, solution of Eq. (36)
  VectorX xdot;  ///< 7N, Eqs. (39)-(40)

  // Scratch of the staged O(N) recursive route: a_G inertial; a_O and alpha_b body-K
  // components.
  std::vector<Vector3> a_G, a_O, alpha_b;

  // The fused O(N) route (forward_dynamics with Method::recursive, src/recursive/fused.hpp).
  bool fused_loads = false;  ///< every force element is a known type (else staged)
  int fused_lanes = 0;       ///< bodies per SIMD pass of the kernel chosen: 2, 4 or 8
  /// The route compiled from the Model for that width: per-body constants with the loads
  /// grouped per body, in a layout private to src/; immutable, shared by copies of this Data.
  /// Null when fused_loads is false.
  std::shared_ptr<const fused::Plan> fused_plan;
  std::vector<double> fused_scratch;  ///< per-body loads and accelerations of one evaluation

  // Scratch of the Kane route (src/kane.cpp): per body.
  std::vector<Vector3> bias_O;    ///< velocity-dependent part of a_O_K, inertial
  std::vector<Vector3> h_b;       ///< first mass moment of K's subtree about O_K, body K
  std::vector<Vector3> load_sum;  ///< subtree sums of the loads, inertial
  std::vector<double> subtree_mass;
  std::vector<Matrix36> composite;  ///< S_K = sum over K's subtree of m [v_G,y] blocks at K
};

}  // namespace kanedyn
