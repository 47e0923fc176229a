// Block LDL^T of a symmetric positive definite matrix with the sparsity of a tree and blocks of
// the nodes' sizes (0, 1, 2, 3 or 6 rows): [A] of Eq. (37), one 6-row node per body, and the
// projected mass matrix [C]^T [A] [C] of a jointed tree (docs/theory.md, "Joints"), one node
// per joint with its speed count. Node k's block row holds one block per node on its chain of
// ancestors that has a block, itself first; nodes of size 0 are skipped. Eliminating from the
// leaves inwards creates no fill-in (docs/theory.md, "Tree LDL^T without fill-in"). Private to
// the library.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "kanedyn/model.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn::detail {

/// A = L^T D L with L unit block lower triangular (L_{k,I} nonzero only for I an ancestor of k:
/// the sparsity of A itself) and D block diagonal. Cost: per node, its row's blocks times the
/// rest of its row to factor; one pass over the blocks to solve. No allocation after
/// construction.
class TreeLdlt {
 public:
  TreeLdlt() = default;
  /// Nodes 0..size-1 with parent lower[k] < k (or -1) and block size sizes[k] in {0, 1, 2, 3,
  /// 6}. The unknowns are laid out node by node in numbering order (offset(k)). Allocates
  /// everything.
  TreeLdlt(const std::vector<int>& sizes, const std::vector<int>& lower);
  /// [A] of Eq. (37): one node of 6 per body, its row the body's chain, so that the blocks are
  /// in the chain layout of the assembled route (block r of k's row is block (K, L^r(K))).
  /// Needs model.has_flat_chains() (throws ModelError otherwise).
  explicit TreeLdlt(const Model& model);

  /// The number of stored blocks (the sum over nodes with a block of their chain's nodes with a
  /// block): what the constructor allocates, before it does.
  static long long count_blocks(const std::vector<int>& sizes, const std::vector<int>& lower);

  int size(int k) const { return size_[static_cast<size_t>(k)]; }
  int offset(int k) const { return offset_[static_cast<size_t>(k)]; }
  /// Blocks in k's row: 1 + the ancestors with a block (0 when k has none).
  int row_length(int k) const {
    return begin_[static_cast<size_t>(k) + 1] - begin_[static_cast<size_t>(k)];
  }
  /// The node of block r of k's row (r = 0: k itself; r increases towards the root).
  int row_node(int k, int r) const {
    return node_[static_cast<size_t>(begin_[static_cast<size_t>(k)] + r)];
  }
  /// Block r of k's row, size(k) x size(row_node(k, r)), column-major: the matrix's block (k, I)
  /// (I = row_node(k, r)) before compute(), the factor's afterwards (r = 0: D_k^-1; r >= 1:
  /// L_{k,I}).
  double* block(int k, int r) {
    return data_.data() + data_offset_[static_cast<size_t>(begin_[static_cast<size_t>(k)] + r)];
  }
  const double* block(int k, int r) const {
    return data_.data() + data_offset_[static_cast<size_t>(begin_[static_cast<size_t>(k)] + r)];
  }

  /// Factors the blocks in place, A = L^T D L. Returns false when a pivot block was not
  /// positive definite.
  bool compute();
  /// Solves A x = b in place (b laid out by offset()), after compute().
  void solve_in_place(Eigen::Ref<VectorX> b) const;

  /// The assembled route's use (made with the Model): copies the chain-layout blocks of [A]
  /// (only block (K, L^r(K)) for r >= 0 is read) and factors them; info() tells the outcome.
  void compute(const Model& model, const std::vector<Matrix6>& a_blocks);
  /// Solves [A] x = b in place, b in the layout of Eq. (1): (w'_1 .. w'_N, s'_1 dot ..).
  void solve_in_place(const Model& model, Eigen::Ref<VectorX> b);
  /// Eigen::Success, or Eigen::NumericalIssue when the last compute(model, blocks) met a pivot
  /// block that was not positive definite.
  Eigen::ComputationInfo info() const { return info_; }

  /// Heap bytes held.
  std::size_t memory_bytes() const;

 private:
  std::vector<int> size_, offset_, begin_, node_;
  std::vector<long long> data_offset_;
  std::vector<double> data_;
  std::vector<double> row_;                // the current block row of A while a node is eliminated
  std::vector<unsigned char> scalar_row_;  // every node of k's row has size 1
  std::vector<unsigned char> six_row_;     // every node of k's row has size 6
  VectorX blocked_;                        // solve_in_place(model, b)'s b, node by node
  Eigen::ComputationInfo info_ = Eigen::Success;
};

}  // namespace kanedyn::detail
