#include "tree_ldlt.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "spd.hpp"

namespace kanedyn::detail {

namespace {

size_t at(long long i) { return static_cast<size_t>(i); }

// A pair of 6-row nodes (two bodies of [A] of Eq. 37, or two free joints) takes Eigen's
// fixed-size products, the others the loops below. Every 6x6 block starts at an even number of
// doubles (the storage is 16-byte aligned), so that it is as aligned as a Matrix6.
using Block6 = Eigen::Map<Matrix6, Eigen::Aligned16>;
using ConstBlock6 = Eigen::Map<const Matrix6, Eigen::Aligned16>;

}  // namespace

long long TreeLdlt::count_blocks(const std::vector<int>& sizes, const std::vector<int>& lower) {
  // Row length of k: 1 + the row length of the nearest ancestor with a block.
  std::vector<long long> length(sizes.size(), 0);
  long long total = 0;
  for (size_t k = 0; k < sizes.size(); ++k) {
    const int j = lower[k];
    const long long below = j < 0 ? 0 : length[at(j)];
    length[k] = below + (sizes[k] > 0 ? 1 : 0);  // a node of size 0 passes its chain on
    if (sizes[k] > 0) total += length[k];
  }
  return total;
}

TreeLdlt::TreeLdlt(const std::vector<int>& sizes, const std::vector<int>& lower) : size_(sizes) {
  const size_t n = sizes.size();
  for (const int m : sizes)
    if (m < 0 || m == 4 || m == 5 || m > 6)
      throw std::invalid_argument("TreeLdlt: a node has 0, 1, 2, 3 or 6 rows");
  offset_.assign(n + 1, 0);
  begin_.assign(n + 1, 0);
  // The nearest node with a block at or below k (k itself if it has one), or -1.
  std::vector<int> nearest(n, -1);
  for (size_t k = 0; k < n; ++k) {
    offset_[k + 1] = offset_[k] + sizes[k];
    const int j = lower[k];
    nearest[k] = sizes[k] > 0 ? static_cast<int>(k) : (j < 0 ? -1 : nearest[at(j)]);
  }
  long long doubles = 0;
  size_t longest = 0;
  for (size_t k = 0; k < n; ++k) {
    if (sizes[k] > 0) {
      const size_t first = node_.size();
      for (int c = static_cast<int>(k); c >= 0;) {
        if (sizes[k] == 6 && sizes[at(c)] == 6) doubles += doubles % 2;  // see Block6
        node_.push_back(c);
        data_offset_.push_back(doubles);
        doubles += static_cast<long long>(sizes[k]) * sizes[at(c)];
        const int j = lower[at(c)];
        c = j < 0 ? -1 : nearest[at(j)];
      }
      longest = std::max(longest, node_.size() - first);
    }
    begin_[k + 1] = static_cast<int>(node_.size());
  }
  data_.assign(at(doubles), 0.0);
  row_.assign(longest * 36, 0.0);
  // A row of size-1 nodes only; its ancestors' rows, the rest of it, are then so too.
  scalar_row_.assign(n, 0);
  for (size_t k = 0; k < n; ++k) {
    if (sizes[k] != 1) continue;
    bool scalar = true;
    for (int r = 0; r < row_length(static_cast<int>(k)); ++r)
      scalar = scalar && sizes[at(row_node(static_cast<int>(k), r))] == 1;
    scalar_row_[k] = scalar ? 1 : 0;
  }
  // A row of 6-row nodes only: its blocks, and those of its ancestors' rows, are consecutive
  // 6x6 blocks.
  six_row_.assign(n, 0);
  for (size_t k = 0; k < n; ++k) {
    if (sizes[k] != 6) continue;
    bool six = true;
    for (int r = 0; r < row_length(static_cast<int>(k)); ++r)
      six = six && sizes[at(row_node(static_cast<int>(k), r))] == 6;
    six_row_[k] = six ? 1 : 0;
  }
}

namespace {

std::vector<int> model_lower(const Model& model) {
  if (!model.has_flat_chains())
    throw ModelError("model: " + std::to_string(model.chain_entries()) +
                     " chain entries are too many for the block-sparse [A] (limit " +
                     std::to_string(Model::kMaxFlatChainEntries) +
                     "); use the recursive route (DataOptions::recursive_only())");
  std::vector<int> lower;
  for (int k = 0; k < model.num_bodies(); ++k) lower.push_back(model.lower_body(k));
  return lower;
}

}  // namespace

TreeLdlt::TreeLdlt(const Model& model)
    : TreeLdlt(std::vector<int>(at(model.num_bodies()), 6), model_lower(model)) {
  // Every body is a node of 6 rows whose row is its chain: the rows' blocks are the chain
  // layout of the assembled route, 36 doubles each.
  for (int k = 0; k <= model.num_bodies(); ++k)
    if (begin_[at(k)] != (k < model.num_bodies() ? model.chain_offset(k) : model.chain_entries()))
      throw std::logic_error("TreeLdlt: the rows differ from the model's chain layout");
  blocked_ = VectorX::Zero(6 * static_cast<Eigen::Index>(model.num_bodies()));
}

bool TreeLdlt::compute() {
  bool ok = true;
  const int n = static_cast<int>(size_.size());
  // Eliminate node k (leaves first): D_k = A_kk, L_kI = D_k^-1 A_kI for I on k's row, and
  // A_IJ -= A_kI^T D_k^-1 A_kJ for every pair I, J on k's row, J at or beyond I: the block
  // (I, J) is in I's row at position r2 - r1 (I's row is the rest of k's row from I on), so
  // there is no fill-in.
  for (int k = n - 1; k >= 0; --k) {
    const int m = size(k);
    if (m == 0) continue;
    const int len = row_length(k);
    double* d = block(k, 0);
    ok = invert_spd(d, m) && ok;
    if (len == 1) continue;  // no ancestor with a block: nothing below to update or to read
    const Eigen::Map<const Eigen::MatrixXd> d_inv(d, m, m);
    if (scalar_row_[at(k)]) {
      // Every node on k's row has one unknown (a chain of revolute or prismatic joints): the
      // blocks of each row are consecutive doubles, so A_I,J for J from I on is one
      // contiguous run, updated as one axpy.
      const double* a_k = block(k, 1);
      double* l = block(k, 1);
      std::copy(a_k, a_k + (len - 1), row_.begin());
      for (int r = 1; r < len; ++r) l[r - 1] = d[0] * row_[at(r - 1)];
      for (int r1 = 1; r1 < len; ++r1) {
        const double l1 = l[r1 - 1];
        double* target = block(row_node(k, r1), 0);
        const double* a = row_.data() + (r1 - 1);
        const int count = len - r1;
        for (int t = 0; t < count; ++t) target[t] -= l1 * a[t];
      }
      continue;
    }
    if (six_row_[at(k)]) {
      // The loops below with every block 6x6: k's row and each I's are runs of 36 doubles.
      double* a_k = block(k, 0);
      for (int r = 1; r < len; ++r) {
        double* saved = row_.data() + 36 * r;
        std::copy(a_k + 36 * r, a_k + 36 * (r + 1), saved);
        Block6(a_k + 36 * r).noalias() = ConstBlock6(d) * ConstBlock6(saved);
      }
      for (int r1 = 1; r1 < len; ++r1) {
        const ConstBlock6 l1(a_k + 36 * r1);
        double* row_i = block(row_node(k, r1), 0);
        for (int r2 = r1; r2 < len; ++r2)
          Block6(row_i + 36 * (r2 - r1)).noalias() -=
              l1.transpose() * ConstBlock6(row_.data() + 36 * r2);
      }
      continue;
    }
    // row_ holds the blocks A_kI (r >= 1), each m x 6 at most, at 36 doubles apart.
    for (int r = 1; r < len; ++r) {
      const int w = size(row_node(k, r));
      double* saved = row_.data() + 36 * r;
      std::copy(block(k, r), block(k, r) + m * w, saved);
      if (m == 6 && w == 6)
        Block6(block(k, r)).noalias() = ConstBlock6(d) * ConstBlock6(saved);
      else
        Eigen::Map<Eigen::MatrixXd>(block(k, r), m, w).noalias() =
            d_inv.lazyProduct(Eigen::Map<const Eigen::MatrixXd>(saved, m, w));
    }
    for (int r1 = 1; r1 < len; ++r1) {
      const int i = row_node(k, r1), wi = size(i);
      const double* l1 = block(k, r1);  // m x wi
      for (int r2 = r1; r2 < len; ++r2) {
        const int wj = size(row_node(k, r2));
        const double* a_kj = row_.data() + 36 * r2;  // m x wj
        double* target = block(i, r2 - r1);          // wi x wj
        if (m == 6 && wi == 6 && wj == 6) {
          Block6(target).noalias() -= ConstBlock6(l1).transpose() * ConstBlock6(a_kj);
          continue;
        }
        for (int cj = 0; cj < wj; ++cj)
          for (int ci = 0; ci < wi; ++ci) {
            double s = 0.0;
            for (int t = 0; t < m; ++t) s += l1[t + m * ci] * a_kj[t + m * cj];
            target[ci + wi * cj] -= s;
          }
      }
    }
  }
  return ok;
}

void TreeLdlt::solve_in_place(Eigen::Ref<VectorX> b) const {
  const int n = static_cast<int>(size_.size());
  // L^T w = b from the leaves inwards, then y = D^-1 w.
  for (int k = n - 1; k >= 0; --k) {
    const int m = size(k);
    if (m == 0) continue;
    double* zk = b.data() + offset(k);
    for (int r = 1; r < row_length(k); ++r) {
      const int i = row_node(k, r), wi = size(i);
      const double* l = block(k, r);  // m x wi
      double* zi = b.data() + offset(i);
      if (m == 6 && wi == 6) {
        Eigen::Map<Vector6>(zi).noalias() -=
            ConstBlock6(l).transpose() * Eigen::Map<const Vector6>(zk);
        continue;
      }
      for (int ci = 0; ci < wi; ++ci) {
        double s = 0.0;
        for (int t = 0; t < m; ++t) s += l[t + m * ci] * zk[t];
        zi[ci] -= s;
      }
    }
    const double* d = block(k, 0);
    if (m == 6) {
      Eigen::Map<Vector6> z6(zk);
      z6 = (ConstBlock6(d) * z6).eval();
      continue;
    }
    double w[6];
    for (int i = 0; i < m; ++i) {
      double s = 0.0;
      for (int t = 0; t < m; ++t) s += d[i + m * t] * zk[t];
      w[i] = s;
    }
    std::copy(w, w + m, zk);
  }
  // L x = y from the roots outwards.
  for (int k = 0; k < n; ++k) {
    const int m = size(k);
    if (m == 0) continue;
    double* zk = b.data() + offset(k);
    for (int r = 1; r < row_length(k); ++r) {
      const int i = row_node(k, r), wi = size(i);
      const double* l = block(k, r);
      const double* xi = b.data() + offset(i);
      if (m == 6 && wi == 6) {
        Eigen::Map<Vector6>(zk).noalias() -= ConstBlock6(l) * Eigen::Map<const Vector6>(xi);
        continue;
      }
      for (int t = 0; t < m; ++t) {
        double s = 0.0;
        for (int ci = 0; ci < wi; ++ci) s += l[t + m * ci] * xi[ci];
        zk[t] -= s;
      }
    }
  }
}

void TreeLdlt::compute(const Model& model, const std::vector<Matrix6>& a_blocks) {
  for (long long e = 0; e < model.chain_entries(); ++e)
    Block6(data_.data() + data_offset_[at(e)]) = a_blocks[at(e)];
  info_ = compute() ? Eigen::Success : Eigen::NumericalIssue;
}

void TreeLdlt::solve_in_place(const Model& model, Eigen::Ref<VectorX> b) {
  const int n = model.num_bodies();
  for (int k = 0; k < n; ++k) {
    blocked_.segment<3>(6 * k) = b.segment<3>(3 * k);
    blocked_.segment<3>(6 * k + 3) = b.segment<3>(3 * n + 3 * k);
  }
  solve_in_place(blocked_);
  for (int k = 0; k < n; ++k) {
    b.segment<3>(3 * k) = blocked_.segment<3>(6 * k);
    b.segment<3>(3 * n + 3 * k) = blocked_.segment<3>(6 * k + 3);
  }
}

std::size_t TreeLdlt::memory_bytes() const {
  return (size_.capacity() + offset_.capacity() + begin_.capacity() + node_.capacity()) *
             sizeof(int) +
         data_offset_.capacity() * sizeof(long long) +
         (data_.capacity() + row_.capacity() + static_cast<size_t>(blocked_.size())) *
             sizeof(double) +
         scalar_row_.capacity() + six_row_.capacity();
}

}  // namespace kanedyn::detail
