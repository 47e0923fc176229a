#include "joint_ldlt.hpp"

#include <Eigen/Cholesky>
#include <algorithm>

namespace kanedyn::detail {

namespace {

size_t at(long long i) { return static_cast<size_t>(i); }

// At most 6 x 6 (a free joint's block): fixed storage, no heap.
using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 6, 6>;

// In place: the m x m column-major SPD block d becomes its inverse (by Cholesky); false when it
// is not positive definite.
bool invert_spd(double* d, int m) {
  Eigen::Map<Eigen::MatrixXd> a(d, m, m);
  if (m == 1) {
    const bool ok = a(0, 0) > 0.0;
    a(0, 0) = 1.0 / a(0, 0);
    return ok;
  }
  const Small copy = a;
  const Eigen::LLT<Small> llt(copy);
  Small inverse = Small::Identity(m, m);
  llt.solveInPlace(inverse);
  a = inverse;
  return llt.info() == Eigen::Success;
}

}  // namespace

long long JointTreeLdlt::count_blocks(const std::vector<int>& sizes,
                                      const std::vector<int>& lower) {
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

JointTreeLdlt::JointTreeLdlt(const std::vector<int>& sizes, const std::vector<int>& lower)
    : size_(sizes) {
  const size_t n = sizes.size();
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
}

bool JointTreeLdlt::compute() {
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
    // row_ holds the blocks A_kI (r >= 1), each m x 6 at most, at 36 doubles apart.
    for (int r = 1; r < len; ++r) {
      const int w = size(row_node(k, r));
      Eigen::Map<Eigen::MatrixXd> a(block(k, r), m, w);
      Eigen::Map<Eigen::MatrixXd> saved(row_.data() + 36 * r, m, w);
      saved = a;
      a.noalias() = d_inv.lazyProduct(saved);
    }
    for (int r1 = 1; r1 < len; ++r1) {
      const int i = row_node(k, r1), wi = size(i);
      const double* l1 = block(k, r1);  // m x wi
      for (int r2 = r1; r2 < len; ++r2) {
        const int wj = size(row_node(k, r2));
        const double* a_kj = row_.data() + 36 * r2;  // m x wj
        double* target = block(i, r2 - r1);          // wi x wj
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

void JointTreeLdlt::solve_in_place(Eigen::Ref<VectorX> b) const {
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
      for (int ci = 0; ci < wi; ++ci) {
        double s = 0.0;
        for (int t = 0; t < m; ++t) s += l[t + m * ci] * zk[t];
        zi[ci] -= s;
      }
    }
    double w[6];
    const double* d = block(k, 0);
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
      for (int t = 0; t < m; ++t) {
        double s = 0.0;
        for (int ci = 0; ci < wi; ++ci) s += l[t + m * ci] * xi[ci];
        zk[t] -= s;
      }
    }
  }
}

}  // namespace kanedyn::detail
