#include "kanedyn/tree_ldlt.hpp"

#include <algorithm>
#include <string>

namespace kanedyn {

namespace {

size_t at(long long i) { return static_cast<size_t>(i); }

// The inverse of a symmetric 3x3 matrix by cofactors; false unless its leading minors are
// all positive (the matrix is positive definite).
bool invert_spd3(const Matrix3& a, Matrix3& inv) {
  const double c00 = a(1, 1) * a(2, 2) - a(1, 2) * a(1, 2);
  const double c01 = a(1, 2) * a(0, 2) - a(0, 1) * a(2, 2);
  const double c02 = a(0, 1) * a(1, 2) - a(1, 1) * a(0, 2);
  const double det = a(0, 0) * c00 + a(0, 1) * c01 + a(0, 2) * c02;
  const double r = 1.0 / det;
  inv(0, 0) = c00 * r;
  inv(0, 1) = inv(1, 0) = c01 * r;
  inv(0, 2) = inv(2, 0) = c02 * r;
  inv(1, 1) = (a(0, 0) * a(2, 2) - a(0, 2) * a(0, 2)) * r;
  inv(1, 2) = inv(2, 1) = (a(0, 2) * a(0, 1) - a(0, 0) * a(1, 2)) * r;
  inv(2, 2) = (a(0, 0) * a(1, 1) - a(0, 1) * a(0, 1)) * r;
  return a(0, 0) > 0.0 && a(0, 0) * a(1, 1) - a(0, 1) * a(0, 1) > 0.0 && det > 0.0;
}

// In place: d (symmetric positive definite) becomes its inverse, through its 3x3 blocks
// [P Q; Q^T S]: with T = P^-1 Q and the Schur complement S - Q^T T,
// d^-1 = [P^-1 + T Z T^T, -T Z; -Z T^T, Z], Z = (S - Q^T T)^-1. Returns false when d is not
// positive definite (P or the Schur complement is not).
bool invert_spd6(Matrix6& d) {
  const Matrix3 q = d.topRightCorner<3, 3>();
  Matrix3 p_inv, z;
  bool ok = invert_spd3(d.topLeftCorner<3, 3>(), p_inv);
  const Matrix3 t = p_inv * q;
  ok = invert_spd3(d.bottomRightCorner<3, 3>() - q.transpose() * t, z) && ok;
  const Matrix3 tz = t * z;
  d.topLeftCorner<3, 3>() = p_inv + tz * t.transpose();
  d.topRightCorner<3, 3>() = -tz;
  d.bottomLeftCorner<3, 3>() = -tz.transpose();
  d.bottomRightCorner<3, 3>() = z;
  return ok;
}

}  // namespace

TreeLdlt::TreeLdlt(const Model& model) {
  if (!model.has_flat_chains())
    throw ModelError("model: " + std::to_string(model.chain_entries()) +
                     " chain entries are too many for the block-sparse [A] (limit " +
                     std::to_string(Model::kMaxFlatChainEntries) +
                     "); use the recursive route (DataOptions::recursive_only())");
  int max_depth = 0;
  for (int k = 0; k < model.num_bodies(); ++k) max_depth = std::max(max_depth, model.depth(k));
  factor_.assign(at(model.chain_entries()), Matrix6::Zero());
  row_.assign(at(max_depth) + 1, Matrix6::Zero());
  z_.assign(at(model.num_bodies()), Vector6::Zero());
}

void TreeLdlt::compute(const Model& model, const std::vector<Matrix6>& a_blocks) {
  info_ = Eigen::Success;
  factor_ = a_blocks;  // same size: copies without allocating
  // Eliminate body K (leaves first): D_K = A_KK, L_KI = D_K^-1 A_KI for I on K's chain, and
  // A_IJ -= A_KI^T D_K^-1 A_KJ for every pair I, J on K's chain: those are already nonzero
  // blocks (one of I, J is on the other's chain), so there is no fill-in.
  for (int k = model.num_bodies() - 1; k >= 0; --k) {
    const size_t o = at(model.chain_offset(k));
    const int u = model.depth(k);
    const Model::Chain chain = model.chain(k);
    if (!invert_spd6(factor_[o])) info_ = Eigen::NumericalIssue;
    for (int r = 1; r <= u; ++r) {
      row_[at(r)] = factor_[o + at(r)];
      factor_[o + at(r)].noalias() = factor_[o] * row_[at(r)];  // L_KI = D_K^-1 A_KI
    }
    for (int r1 = 1; r1 <= u; ++r1) {
      const size_t oi = at(model.chain_offset(chain[r1]));
      const Matrix6& l1 = factor_[o + at(r1)];
      for (int r2 = r1; r2 <= u; ++r2)  // block (I, L^{r2-r1}(I)) = (I, chain[r2])
        factor_[oi + at(r2 - r1)].noalias() -= l1.transpose() * row_[at(r2)];
    }
  }
}

void TreeLdlt::solve_in_place(const Model& model, Eigen::Ref<VectorX> b) {
  const int n = model.num_bodies();
  for (int k = 0; k < n; ++k) {
    z_[at(k)].head<3>() = b.segment<3>(3 * k);
    z_[at(k)].tail<3>() = b.segment<3>(3 * n + 3 * k);
  }
  // L^T w = b from the leaves inwards, then y = D^-1 w.
  for (int k = n - 1; k >= 0; --k) {
    const size_t o = at(model.chain_offset(k));
    const Model::Chain chain = model.chain(k);
    Vector6& zk = z_[at(k)];
    for (int r = 1; r < chain.size; ++r)
      z_[at(chain[r])].noalias() -= factor_[o + at(r)].transpose() * zk;
    zk = (factor_[o] * zk).eval();  // D_K^-1
  }
  // L x = y from the roots outwards.
  for (int k = 0; k < n; ++k) {
    const size_t o = at(model.chain_offset(k));
    const Model::Chain chain = model.chain(k);
    Vector6& zk = z_[at(k)];
    for (int r = 1; r < chain.size; ++r) zk.noalias() -= factor_[o + at(r)] * z_[at(chain[r])];
    b.segment<3>(3 * k) = zk.head<3>();
    b.segment<3>(3 * n + 3 * k) = zk.tail<3>();
  }
}

std::size_t TreeLdlt::memory_bytes() const {
  return factor_.capacity() * sizeof(Matrix6) + row_.capacity() * sizeof(Matrix6) +
         z_.capacity() * sizeof(Vector6);
}

}  // namespace kanedyn
