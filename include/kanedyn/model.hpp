// Model: what does not change during a run. Topology from the
// body-connection array L(K), mass properties, offsets q'_K and r'_K, gravity and force
// elements. Built and validated once, immutable afterwards.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "kanedyn/types.hpp"

namespace kanedyn {

class ForceElement;

/// Thrown when a model is invalid; the message says which body or element and why.
class ModelError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What the user says about one body K (index k = K-1).
struct BodySpec {
  std::string name;                   ///< unique, [A-Za-z0-9_-]+
  int lower_body = kGround;           ///< L(K) as a 0-based index of an earlier body, or kGround
  double mass = 0.0;                  ///< m_K > 0
  Matrix3 inertia = Matrix3::Zero();  ///< [I'_GK] about G_K, body-K components
  Vector3 com = Vector3::Zero();      ///< {r'_K}: O_K to G_K, body-K components
  Vector3 joint = Vector3::Zero();  ///< {q'_K}: O_J to Q_K, body-J components (inertial for roots)
};

/// An unconstrained tree (or forest) of N rigid bodies. Body indices are 0-based: index k is
/// body K = k+1 of the notes; lower_body(k) == kGround (-1) means L(K) = 0.
class Model {
 public:
  /// Validates everything (see docs/model-format.md) and derives the topology; throws
  /// ModelError with a message naming the body or element at fault.
  Model(std::vector<BodySpec> bodies, Vector3 gravity = Vector3::Zero(),
        std::vector<std::shared_ptr<const ForceElement>> forces = {}, std::string name = "");

  int num_bodies() const { return static_cast<int>(bodies_.size()); }  ///< N
  int num_speeds() const { return 6 * num_bodies(); }                  ///< 6N, size of {y}
  int num_coordinates() const { return 7 * num_bodies(); }             ///< 7N, size of {x}
  const std::string& name() const { return name_; }

  const BodySpec& body(int k) const { return bodies_[static_cast<size_t>(k)]; }
  const std::vector<BodySpec>& bodies() const { return bodies_; }
  /// Index of the body with this name, or -2 if there is none.
  int body_index(const std::string& name) const;

  int lower_body(int k) const { return bodies_[static_cast<size_t>(k)].lower_body; }  ///< L(K)
  /// u_K: number of bodies below K in its own tree (0 for a body attached to R).
  int depth(int k) const { return depth_[static_cast<size_t>(k)]; }
  /// The root of k's tree: L^{u_K}(K).
  int root(int k) const { return root_[static_cast<size_t>(k)]; }
  const std::vector<int>& children(int k) const { return children_[static_cast<size_t>(k)]; }

  /// k's chain down to the inertial frame: (K, L(K), L^2(K), ..., root), length u_K + 1.
  /// chain(k)[r] = L^r(K). Block-sparse partials are stored in this order. Indexing is O(1)
  /// when has_flat_chains(), otherwise it walks L (iteration is O(1) per step either way).
  class Chain {
   public:
    class iterator {
     public:
      int operator*() const { return body_; }
      iterator& operator++() {
        if (++r_ < chain_->size) body_ = chain_->first ? chain_->first[r_] : chain_->lower[body_];
        return *this;
      }
      bool operator==(const iterator& o) const { return r_ == o.r_; }
      bool operator!=(const iterator& o) const { return r_ != o.r_; }

     private:
      friend class Chain;
      iterator(const Chain* c, int r, int body) : chain_(c), r_(r), body_(body) {}
      const Chain* chain_;
      int r_, body_;
    };
    const int* first;  ///< the flat entries, or nullptr (walk `lower` instead)
    const int* lower;  ///< L of every body
    int start;         ///< the body K
    int size;          ///< u_K + 1
    int root;          ///< L^{u_K}(K)
    iterator begin() const { return {this, 0, start}; }
    iterator end() const { return {this, size, root}; }
    int operator[](int r) const {
      if (first) return first[r];
      int a = start;
      while (r-- > 0) a = lower[a];
      return a;
    }
    int back() const { return root; }
  };
  Chain chain(int k) const {
    const auto i = static_cast<size_t>(k);
    const int* flat = chain_flat_.empty() ? nullptr : chain_flat_.data() + chain_offset_[i];
    return {flat, lower_.data(), k, depth_[i] + 1, root_[i]};
  }
  /// True when the chains are stored flat (chain_entries() <= kMaxFlatChainEntries). The
  /// block-sparse partials and the Kane route's block-sparse [A] use the flat chain layout
  /// (chain_offset), so they need it; the O(N) recursive route does not (a 100,000-body chain
  /// has 5e9 chain entries).
  bool has_flat_chains() const { return !chain_flat_.empty(); }
  static constexpr long long kMaxFlatChainEntries = 1LL << 24;
  /// Offset of k's chain in flat per-chain arrays (e.g. Data's partial velocity blocks).
  /// Only when has_flat_chains().
  int chain_offset(int k) const { return chain_offset_[static_cast<size_t>(k)]; }
  /// Total number of chain entries, sum over K of (u_K + 1) = N + the number of
  /// (ancestor, descendant) pairs.
  long long chain_entries() const { return chain_entries_; }
  /// True when a is k or one of k's ancestors.
  bool on_chain(int a, int k) const;

  const Vector3& gravity() const { return gravity_; }  ///< {g}, inertial components
  const std::vector<std::shared_ptr<const ForceElement>>& forces() const { return forces_; }
  double total_mass() const { return total_mass_; }
  /// Inverse of [I'_GK], precomputed.
  const Matrix3& inverse_inertia(int k) const { return inverse_inertia_[static_cast<size_t>(k)]; }

 private:
  std::vector<BodySpec> bodies_;
  Vector3 gravity_;
  std::vector<std::shared_ptr<const ForceElement>> forces_;
  std::string name_;
  std::vector<int> depth_, root_, lower_;
  std::vector<std::vector<int>> children_;
  long long chain_entries_ = 0;
  std::vector<int> chain_offset_;
  std::vector<int> chain_flat_;
  std::vector<Matrix3> inverse_inertia_;
  double total_mass_ = 0.0;
};

/// Checks that an inertia matrix is symmetric positive definite and that its principal
/// moments satisfy the triangle inequalities; returns an empty string or the problem.
std::string check_inertia(const Matrix3& inertia);

}  // namespace kanedyn
