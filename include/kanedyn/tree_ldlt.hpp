// Block LDL^T of a symmetric positive definite matrix with the sparsity of a tree, such as
// [A] of Eq. (37): one 6x6 block per body pair, nonzero only when one body lies on the
// other's chain. Eliminating the bodies from the leaves inwards creates no fill-in
// (docs/theory.md, "O(N) forward dynamics").
#pragma once

#include <vector>

#include <Eigen/Core>

#include "kanedyn/model.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn {

/// A = L^T D L with L unit block lower triangular in body order (L_{K,I} nonzero only for I an
/// ancestor of K: the sparsity of A itself) and D block diagonal with SPD 6x6 blocks. Blocks are
/// in chain layout: entry model.chain_offset(k) + r is block (K, L^r(K)); r = 0 the diagonal.
/// Within a body's block the speed order is (w'_K, s'_K dot). Needs model.has_flat_chains().
/// Cost: sum over K of u_K (u_K + 1) / 2 products of 6x6 blocks (O(N d^2), d the depth) to
/// factor; one pass over the blocks to solve. No allocation after construction.
class TreeLdlt {
 public:
  TreeLdlt() = default;
  /// Allocates the factor and the scratch for this model's topology.
  explicit TreeLdlt(const Model& model);

  /// Factors the blocks of A (chain layout, as Data::A_blocks; only the block (K, L^r(K)) for
  /// r >= 0 is read, the blocks above the diagonal being their transposes).
  void compute(const Model& model, const std::vector<Matrix6>& a_blocks);

  /// Solves A x = b in place; b is in the layout of Eq. (1): (w'_1 .. w'_N, s'_1 dot ..).
  void solve_in_place(const Model& model, Eigen::Ref<VectorX> b);

  /// Eigen::Success, or Eigen::NumericalIssue when a pivot block was not positive definite.
  Eigen::ComputationInfo info() const { return info_; }

  /// The factor, chain layout: r >= 1 holds L_{K, L^r(K)}; r = 0 holds D_K^-1.
  const std::vector<Matrix6>& factor() const { return factor_; }

  /// Heap bytes held.
  std::size_t memory_bytes() const;

 private:
  std::vector<Matrix6> factor_;
  std::vector<Matrix6> row_;  // the current row of A while body K is eliminated
  std::vector<Vector6> z_;    // body-blocked right side while solving
  Eigen::ComputationInfo info_ = Eigen::Success;
};

}  // namespace kanedyn
