// Data: the workspace of one Model. Every quantity of the notes lives here, grouped by the
// stage that computes it, allocated once, so that no evaluation touches the heap. Each public
// function fills a fixed, documented set of these parts (see its header) and no other; the
// routes of forward_dynamics work in a private scratch and leave every part but ydot and xdot
// as it was.
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "kanedyn/model.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn {

namespace detail {
struct Workspace;
}

/// Eqs. (2)-(17) for every body (index k), inertial components unless a name ends in _b.
/// Filled by compute_kinematics() (kinematics.hpp).
struct Kinematics {
  std::vector<Matrix3> R;         ///< [R_K]: inertial -> body-K components, Eqs. (2)-(4)
  std::vector<Vector3> p_O, p_G;  ///< positions of O_K and G_K, Eqs. (11)-(13)
  std::vector<Vector3> v_O, v_G;  ///< velocities of O_K and G_K, Eqs. (14)-(17)
  std::vector<Vector3> qs_b;      ///< {q'_K} + {s'_K}, body-J components (J = L(K))
};

/// Eqs. (18)-(30): [v_O_K,y] and [v_G_K,y] and their time derivatives, block-sparse. For body
/// k, entry model.chain_offset(k) + r belongs to body L^r(K) = model.chain(k)[r] and holds the
/// 3x3 coefficient of that body's w' (the _w arrays, y1 part) or s' dot (the _s arrays, y2
/// part); every other block of the 3 x 6N matrix is zero. Filled by compute_partials_*() and
/// compute_partial_rates() (partials.hpp); allocated with DataOptions::partials.
struct Partials {
  std::vector<Matrix3> vO_w, vO_s, vG_w, vG_s;                  ///< Eqs. (18)-(27)
  std::vector<Matrix3> vO_w_dot, vO_s_dot, vG_w_dot, vG_s_dot;  ///< Eqs. (29)-(30)
};

/// Per-body resultants of gravity and every force element: {F_K} at G_K, inertial
/// components, and {M'_K}, body-K components (Eq. 31). Filled by compute_resultants()
/// (forces.hpp).
struct Loads {
  std::vector<Vector3> force, moment_b;
};

/// Eqs. (31)-(38) in the speed order of Eq. (1). Filled by kane_equations() (kane.hpp);
/// allocated with DataOptions::kane_terms.
struct KaneTerms {
  VectorX F_y;  ///< generalized active forces, Eq. (31), 6N
  /// [A] of Eq. (37), dense 6N x 6N, with DataOptions::dense_mass_matrix; else empty (the
  /// routes keep it block-sparse, in their scratch).
  MatrixX A;
  VectorX f;  ///< right side of Eq. (36), Eq. (38), 6N
};

/// What a Data allocates. Every option is a named field: DataOptions{.partials = false}.
/// The chain-layout parts (the partials and the assembled route's blocks of [A]) take
/// model.chain_entries() blocks each, the sum over K of u_K + 1, which grows as N^2 for a
/// chain; the O(N) recursive route needs none of them.
struct DataOptions {
  bool partials = true;  ///< Data::partials, Eqs. (18)-(30)
  /// Data::kane and the scratch of the assembled route: kane_equations() and
  /// forward_dynamics(..., Route::assembled) need it.
  bool kane_terms = true;
  bool dense_mass_matrix = true;  ///< with kane_terms: the dense [A] in Data::kane.A
  /// Widest SIMD kernel the recursive route may use: 2, 4 (AVX) or 8 (AVX-512F) bodies per
  /// pass; the widest the running CPU has up to this is taken (Data::simd_lanes()). Every
  /// width gives the same bits; a smaller cap is for comparisons and tests.
  int max_simd_lanes = 8;

  /// Only what the recursive route needs: no partials, no Kane terms.
  static DataOptions recursive_only(int max_simd_lanes = 8);
  /// What Data(model) allocates: everything when model.chain_entries() <= kFullChainEntries
  /// (the dense [A] only when also N <= kFullDenseBodies), else recursive_only().
  static DataOptions for_model(const Model& model);
  static constexpr long long kFullChainEntries = 65536;  ///< 37 MB of partial blocks
  static constexpr int kFullDenseBodies = 500;           ///< a dense [A] of 72 MB
};

/// The workspace of one Model: the notes' quantities by stage, the outputs of the dynamics, and
/// the routes' private scratch. Copies are independent workspaces (the recursive route's
/// compiled plan, which never changes, is shared).
class Data {
 public:
  /// With DataOptions::for_model(model): works for every model.
  explicit Data(const Model& model);
  /// Exactly these parts; throws ModelError when the model's chains are too long for the
  /// chain-layout parts asked for (more than Model::kMaxFlatChainEntries entries).
  Data(const Model& model, const DataOptions& options);
  Data(const Data& other);
  Data& operator=(const Data& other);
  Data(Data&&) noexcept;
  Data& operator=(Data&&) noexcept;
  ~Data();

  const DataOptions& options() const { return options_; }
  /// Bodies per SIMD pass of the recursive route's kernel: 2, 4 or 8.
  int simd_lanes() const;
  /// Whether the recursive route runs as one fused pass (every force element on bodies a
  /// linear body load: ForceElement::linear_body_load) rather than stage by stage. Both give
  /// ydot, xdot.
  bool single_pass() const;
  /// Heap bytes held (for memory tables).
  std::size_t memory_bytes() const;

  Kinematics kinematics;
  Partials partials;
  Loads loads;
  KaneTerms kane;
  /// u: the inputs' values (model.num_inputs(), zero at first), read by every evaluation that
  /// works in this Data (compute_resultants, forward_dynamics, Dynamics).
  VectorX inputs;
  /// The constraints' reactions at an output of simulate() (reaction_count(model) entries,
  /// zero at first): per constraint the force on its body, then a hinge's moment, inertial
  /// components, in the order of the trajectory CSV's columns (constraints.hpp,
  /// constraint_reactions). simulate() fills them for its observer; nothing else reads them.
  VectorX reactions;
  VectorX ydot;  ///< 6N: {y dot}, the solution of Eq. (36)
  VectorX xdot;  ///< 7N: {x dot}, Eqs. (39)-(40)

 private:
  friend detail::Workspace& workspace(Data& data);
  friend const detail::Workspace& workspace(const Data& data);
  DataOptions options_;
  std::unique_ptr<detail::Workspace> work_;
};

}  // namespace kanedyn
