// Block LDL^T of a symmetric positive definite matrix with the sparsity of a tree and blocks of
// varying size (0 to 6 rows per node), such as the projected mass matrix [C]^T [A] [C] of a
// jointed tree (docs/theory.md, "Joints"): node k's block row holds one block per node on its
// chain of ancestors that has a block, itself first. The generalization of src/tree_ldlt.cpp
// (6x6 blocks, every body a node) to nodes of any size, nodes of size 0 skipped. Eliminating
// from the leaves inwards creates no fill-in. Private to the library.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "kanedyn/types.hpp"

namespace kanedyn::detail {

class JointTreeLdlt {
 public:
  JointTreeLdlt() = default;
  /// Nodes 0..size-1 with parent lower[k] < k (or -1) and block size sizes[k] in 0..6. The
  /// unknowns are laid out node by node in numbering order (offset(k)). Allocates everything.
  JointTreeLdlt(const std::vector<int>& sizes, const std::vector<int>& lower);

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

  /// Factors the blocks in place, A = L^T D L (L unit block lower triangular, D block
  /// diagonal). Returns false when a pivot block was not positive definite.
  bool compute();
  /// Solves A x = b in place (b laid out by offset()), after compute().
  void solve_in_place(Eigen::Ref<VectorX> b) const;

 private:
  std::vector<int> size_, offset_, begin_, node_;
  std::vector<long long> data_offset_;
  std::vector<double> data_;
  std::vector<double> row_;                // the current block row of A while a node is eliminated
  std::vector<unsigned char> scalar_row_;  // every node of k's row has size 1
};

}  // namespace kanedyn::detail
