// The private scratch of a Data: what the routes of forward_dynamics and the assembly of
// Kane's equations compute on the way, kept apart from the public parts so that a route never
// leaves a value there that the documentation of its function does not promise.
#pragma once

#include <memory>
#include <vector>

#include "kanedyn/data.hpp"

#include "tree_ldlt.hpp"

namespace kanedyn {

namespace fused {
struct Plan;
}

namespace detail {

/// The assembled route (Eqs. 37-38, src/kane.cpp), per body unless stated.
struct AssembledScratch {
  /// The nonzero 6x6 blocks of [A] in chain layout: entry model.chain_offset(k) + r is the
  /// block of rows K, columns L^r(K), each in the order (w'_K, s'_K dot) of that body's
  /// speeds; r = 0 is the diagonal block. The blocks above the diagonal are their
  /// transposes; every other block of [A] is zero.
  std::vector<Matrix6> A_blocks;
  TreeLdlt factor;              ///< tree-ordered block LDL^T of A_blocks (no fill-in)
  std::vector<Vector3> bias_O;  ///< velocity-dependent part of a_O_K, inertial
  std::vector<Vector3> h_b;     ///< first mass moment of K's subtree about O_K, body K
  std::vector<double> subtree_mass;
  std::vector<Matrix36> composite;  ///< S_K = sum over K's subtree of m [v_G,y] blocks at K
};

struct Workspace {
  /// The kinematics and loads the staged routes evaluate (force elements read and write
  /// them), distinct from Data::kinematics and Data::loads.
  Kinematics kinematics;
  Loads loads;
  std::vector<Vector3> load_sum;  ///< subtree sums of the loads (Eqs. 31, 38), inertial
  /// The staged recursive route: a_O in body-K components, alpha' (body K).
  std::vector<Vector3> a_O, alpha_b;
  AssembledScratch assembled;  ///< allocated with DataOptions::kane_terms
  /// The fused recursive route: its compiled plan (src/recursive/fused.hpp), immutable and
  /// shared by copies, or null when a force element is not of a known type; the width it was
  /// compiled for; the per-body loads and accelerations of one evaluation.
  std::shared_ptr<const fused::Plan> plan;
  int lanes = 2;
  std::vector<double> fused_scratch;
};

}  // namespace detail

detail::Workspace& workspace(Data& data);
const detail::Workspace& workspace(const Data& data);

}  // namespace kanedyn
