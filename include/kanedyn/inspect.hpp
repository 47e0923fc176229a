// Inspection: every quantity of the notes at one state, per body, in the form the notes print
// them, for output (kanedyn inspect), teaching and checking a model. Two parts: the numbers
// (inspect(), dense views of the block-sparse matrices, O(N) per selected body), and the
// symbolic block structure of the partial velocity matrices and their rates (Eqs. 18-30),
// which depends on L(K) only.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "kanedyn/joints.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/partials.hpp"
#include "kanedyn/state.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn {

/// One body's quantities. Units are the model's (SI in the examples): lengths m, velocities
/// m/s, angular velocities rad/s, forces N, moments N m, generalized forces N or N m.
struct BodyInspection {
  int K = 0;               ///< body number of the notes (1-based)
  std::string name;        ///< the model's name of the body
  int L = 0;               ///< L(K), 0 for the inertial frame
  int u = 0;               ///< u_K, the number of bodies between K and the inertial frame
  std::vector<int> chain;  ///< K, L(K), ..., 0 (1-based, the inertial frame last)
  Matrix3 R;               ///< [R_K] (Eqs. 3-4): inertial -> body-K components
  Vector3 p_O, p_G;        ///< Eqs. (12)-(13), inertial components
  Vector3 v_O, v_G;        ///< Eqs. (15), (17), inertial components
  Vector3 w;               ///< {w'_K}, body-K components
  /// 3 x 6N, columns in the order of {y}: [w'_K,y] (Eq. 8), [v_O_K,y], [v_G_K,y]
  /// (Eqs. 18-21) and the rates (Eqs. 29-30, with the s' dot of Eq. 30 as the seed's README
  /// corrects it).
  MatrixX w_y, v_O_y, v_G_y, v_O_y_dot, v_G_y_dot;
  Vector3 F;    ///< {F_K}: the resultant at G_K of every load on K, inertial (Eq. 31)
  Vector3 M;    ///< {M'_K}: the resultant moment about G_K, body-K components
  VectorX F_y;  ///< K's term of Eq. (31): [v_G_K,y]^T{F_K} + [w'_K,y]^T{M'_K}, 6N
  /// K's generalized inertia force at the solved {y dot}, 6N:
  /// -[v_G_K,y]^T m_K{a_G_K} - [w'_K,y]^T([I'_G_K]{alpha'_K} + [w~'_K][I'_G_K]{w'_K}).
  VectorX F_y_star;
};

/// One body's joint at the inspected (q, z) of a jointed model.
struct JointBodyInspection {
  int K = 0;  ///< body number of the notes (1-based)
  JointType type = JointType::free;
  VectorX q, z;       ///< the body's slices of q and z
  MatrixX C_w, C_sd;  ///< its rows of [C]: w'_K and s'_K dot, 3 x n each
};

/// The joints of a jointed model at (q, z): y = [C] z and the projected equations
/// [C]^T [A] [C] {z dot} = [C]^T ({f} - [A][C dot]{z}) + Q (projected_equations).
struct JointInspection {
  int n = 0;       ///< independent speeds
  VectorX q, z;    ///< the joint coordinates and independent speeds
  MatrixX C;       ///< 6N x n
  VectorX Cdot_z;  ///< [C dot]{z}, 6N
  MatrixX A_z;     ///< [C]^T [A] [C], n x n
  VectorX f_z;     ///< [C]^T ({f} - [A][C dot]{z}) + Q of the joint force elements, n
  VectorX zdot;    ///< the solution of A_z {z dot} = f_z
  VectorX ydot;    ///< the jointed system's {y dot} = [C]{z dot} + [C dot]{z}, 6N
  std::vector<JointBodyInspection> bodies;  ///< the selected bodies, in numbering order
};

/// Every quantity at one state, for the selected bodies; the sums over all bodies.
struct Inspection {
  int N = 0;
  double t = 0.0;    ///< the time of the state (for output; the equations do not depend on it)
  VectorX F_y;       ///< Eq. (31), 6N: the sum of every body's term
  VectorX F_y_star;  ///< the sum of every body's generalized inertia force, 6N
  VectorX ydot;      ///< the solution of Eq. (36), 6N (forward_dynamics, Route::recursive)
  std::vector<BodyInspection> bodies;  ///< the selected bodies, in numbering order
  /// The joints when some joint is not free (the inspect overload with q and z); empty
  /// otherwise.
  std::optional<JointInspection> joints;

  /// The first quantity with a number that is not finite ("ydot", "body 3 p_O",
  /// "joints A_z", ...), or "" when every number is finite: a state far out of range (a
  /// prismatic coordinate of 1e300) gives finite positions and overflowing products.
  std::string first_non_finite() const;
};

/// Evaluates the notes' quantities at the state and fills an Inspection: the kinematics, the
/// partial velocity matrices and their rates, the resultants, and {y dot} by the O(N)
/// recursive route (which solves Eq. 36 as the assembled route does, to round-off, without
/// its O(N d^2) factorization). `bodies` lists 0-based indices to include (empty: every body);
/// the sums F_y, F_y_star and ydot are over every body regardless. Cost: O(sum of chain
/// lengths) in time and memory for the partials and the sums, plus O(N) per selected body for
/// its dense 3 x 6N matrices. Throws ModelError for a
/// model whose chains are too long for the partial velocity blocks
/// (Model::kMaxFlatChainEntries) and std::out_of_range for an index outside 0..N-1.
Inspection inspect(const Model& model, const State& state, double t = 0.0,
                   const std::vector<int>& bodies = {}, const VectorX& inputs = VectorX());

/// inputs: the inputs' values (model.num_inputs(); empty: zero).
/// The same at the model's state q, z (its notes' state from joint_state). When some joint is
/// not free, Inspection::joints holds the joints: Inspection::ydot stays the free tree's
/// Eq. (36) at that state, and joints.ydot is the jointed system's; this forms the dense
/// projected equations (O(N^2) memory: for inspection) and also throws ModelError when the
/// model's angular chains are not stored (has_angular_chains()).
Inspection inspect(const Model& model, const VectorX& q, const VectorX& z, double t = 0.0,
                   const std::vector<int>& bodies = {}, const VectorX& inputs = VectorX());

/// One nonzero 3x3 block of a partial velocity matrix (or its rate) in the notes' symbols.
struct SymbolicBlock {
  int body = 0;        ///< the 1-based body whose speed the block multiplies (its column)
  std::string symbol;  ///< e.g. "[R_7]^T([q~'_8]+[s~'_8])", "I"
};

/// A 3 x 6N partial velocity matrix as the notes print it after Eq. (27): the y1 part
/// (coefficients of w'_1 .. w'_N) with its common sign, and the y2 part (s'_1 dot ..).
struct SymbolicPartial {
  bool y1_negated = true;         ///< the y1 blocks are printed as -[ ... ]
  std::vector<SymbolicBlock> y1;  ///< nonzero blocks, in body order
  std::vector<SymbolicBlock> y2;
};

/// The symbolic block structure of [v_P_K,y] (rate = false, Eqs. 22-27) or of its time
/// derivative (rate = true, Eqs. 29-30) for body index k and P = O_K or G_K. Symbols:
/// [R_J]^T, [q~'_K], [s~'_K], [sd~'_K] (the skew matrix of s'_K dot), [r~'_K], [w~'_J], I.
SymbolicPartial symbolic_partial(const Model& model, int k, Point point, bool rate);

/// The notes' one-line form of one part ("y1" or "y2") of a symbolic partial, e.g.
/// "[v_G8,y1] = -[ [R_1]^T([q~'_7]+[s~'_7]), 0, 0, 0, 0, 0, [R_7]^T([q~'_8]+[s~'_8]),
/// [R_8]^T[r~'_8] ]". With N > max_dense_blocks the zero blocks are summarised: only the
/// nonzero ones are listed, each with its body ("1: [R_1]^T, 7: [R_7]^T; 0 elsewhere").
std::string format_symbolic(const Model& model, int k, Point point, bool rate, int part,
                            int max_dense_blocks = 12);

/// The block structure of [A] (Eq. 37): for each body index k, the bodies I (1-based,
/// ascending) whose 6x6 block (K, I) can be nonzero: I on K's chain or K on I's chain (every
/// other block is zero whatever the state, docs/theory.md). O(N d) entries for depth d.
std::vector<std::vector<int>> mass_matrix_structure(const Model& model);

}  // namespace kanedyn
