// Model: what does not change during a run. Topology from the
// body-connection array L(K), mass properties, offsets q'_K and r'_K, every body's joint,
// gravity and force elements. Built and validated once, immutable afterwards.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "kanedyn/constraint.hpp"
#include "kanedyn/joint.hpp"
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

/// A named point with axes fixed in a body or in the ground (docs/model-format.md, "Frames"): a
/// tool point, a sensor, a marker. frames.hpp gives its pose, velocity and Jacobian.
struct Frame {
  std::string name;                      ///< unique among frames and bodies, [A-Za-z0-9_-]+
  int body = kGround;                    ///< the body K (0-based index) or kGround
  Vector3 at = Vector3::Zero();          ///< origin from O_K, body-K components (inertial: ground)
  Vector4 rotation{0.0, 0.0, 0.0, 1.0};  ///< Euler parameters of the frame's axes relative to
                                         ///< K's: [R(rotation)] maps body-K to frame components
};

/// What an input's value drives (docs/model-format.md, "Inputs").
enum class InputType {
  joint,   ///< u adds to the generalized force on one speed z of the body
  force,   ///< a force u {d} at a point fixed in the body
  torque,  ///< a moment u {a} on the body (and -u {a} on L(K) when `reaction`)
};

/// An input u_i: a scalar that a controller, a file or a program sets while the system moves.
/// Its load is linear in u_i; a value nobody sets is 0.
struct Input {
  std::string name;  ///< unique among inputs, [A-Za-z0-9_-]+
  InputType type = InputType::joint;
  int body = 0;   ///< the body K (0-based index)
  int speed = 0;  ///< joint: 0-based index into the body's speeds (free: w'_K 1..3, s'_K dot 1..3)
  Vector3 direction = Vector3::UnitZ();  ///< force: {d}, body-K components (normalized)
  Vector3 point = Vector3::Zero();       ///< force: from O_K, body-K components
  Vector3 axis = Vector3::UnitZ();       ///< torque: {a}, body-K components (normalized)
  bool reaction = false;                 ///< torque: the opposite moment on J = L(K) too
};

/// A tree (or forest) of N rigid bodies, each with its joint to its lower body. Body indices
/// are 0-based: index k is body K = k+1 of the notes; lower_body(k) == kGround (-1) means
/// L(K) = 0. With every joint free (the default) it is the notes' unconstrained tree.
///
/// The state of every model is its joint coordinates q (num_coordinates()) and independent
/// speeds z (num_speeds()), body by body (joint.hpp). The notes' {x} (7N) and {y} (6N) are a
/// view computed from them (joint_state); for an all-free model they hold the same numbers.
class Model {
 public:
  /// Validates everything (see docs/model-format.md) and derives the topology; throws
  /// ModelError with a message naming the body or element at fault. joints: one per body, or
  /// empty for every body free.
  Model(std::vector<BodySpec> bodies, Vector3 gravity = Vector3::Zero(),
        std::vector<std::shared_ptr<const ForceElement>> forces = {}, std::string name = "",
        std::vector<Joint> joints = {}, std::vector<Frame> frames = {},
        std::vector<Input> inputs = {}, std::vector<Constraint> constraints = {},
        std::vector<int> independent_speeds = {});

  int num_bodies() const { return static_cast<int>(bodies_.size()); }  ///< N
  int num_y() const { return 6 * num_bodies(); }                       ///< 6N, size of {y}
  int num_x() const { return 7 * num_bodies(); }                       ///< 7N, size of {x}
  int num_coordinates() const { return q_offset_.back(); }             ///< size of q
  int num_speeds() const { return z_offset_.back(); }                  ///< n, size of z
  const std::string& name() const { return name_; }

  /// Body k's joint (axes and frame normalized).
  const Joint& joint(int k) const { return joints_[static_cast<size_t>(k)]; }
  /// True when every joint is free: the model is the notes' free tree, q and z are {x} and
  /// {y} body by body.
  bool all_free() const { return all_free_; }
  /// Offset of body k's slice of q (k = N gives the size of q).
  int coordinate_offset(int k) const { return q_offset_[static_cast<size_t>(k)]; }
  /// Offset of body k's slice of z (k = N gives the size of z).
  int speed_offset(int k) const { return z_offset_[static_cast<size_t>(k)]; }
  /// The sliding columns of body k's [T_K] in body-J components, column c for the joint's
  /// c-th sliding speed (the joint table's first_slide onwards; src/joint_table.hpp): a
  /// prismatic joint's axis, a planar joint's F x and y axes, a screw's pitch times its axis.
  const Matrix3& slide_axes_in_j(int k) const { return slides_j_[static_cast<size_t>(k)]; }
  /// The bodies whose z enter w'_K: K (if it has speeds), then down its chain through welds
  /// and joints up to and including the first free body (a free body's w' is its own z).
  /// Only when has_angular_chains() (empty otherwise).
  const std::vector<int>& angular_chain(int k) const { return w_chain_[static_cast<size_t>(k)]; }
  /// The sum of the angular chains' lengths (the blocks of [C]'s w' rows), N^2/2 for a chain
  /// of joints.
  long long angular_chain_entries() const { return w_chain_entries_; }
  /// True when the angular chains are stored: angular_chain_entries() <=
  /// kMaxFlatChainEntries. ConstraintMatrix and projected_equations need them; the
  /// recursive route does not.
  bool has_angular_chains() const { return w_chain_entries_ <= kMaxFlatChainEntries; }

  const BodySpec& body(int k) const { return bodies_[static_cast<size_t>(k)]; }
  const std::vector<BodySpec>& bodies() const { return bodies_; }
  /// Index of the body with this name, or -2 if there is none.
  int body_index(const std::string& name) const;

  /// The model's frames (rotations normalized), in the order given.
  const std::vector<Frame>& frames() const { return frames_; }
  const Frame& frame(int f) const { return frames_[static_cast<size_t>(f)]; }
  /// Index of the frame with this name, or -2 if there is none.
  int frame_index(const std::string& name) const;

  /// The inputs u_1 .. u_m (directions and axes normalized), in the order given.
  const std::vector<Input>& inputs() const { return inputs_; }
  int num_inputs() const { return static_cast<int>(inputs_.size()); }  ///< m
  /// Index of the input with this name, or -2 if there is none.
  int input_index(const std::string& name) const;
  /// The constraints beyond the tree (axes and normals normalized), in the order given.
  const std::vector<Constraint>& constraints() const { return constraints_; }
  int num_constraints() const { return static_cast<int>(constraints_.size()); }
  /// Index of the constraint with this name, or -2 if there is none.
  int constraint_index(const std::string& name) const;
  /// The speeds (indices into z, ascending) the user chose to keep independent, or empty:
  /// chosen by pivoting on [B] (constraints.hpp).
  const std::vector<int>& independent_speeds() const { return independent_speeds_; }
  /// True when some input loads bodies (force and torque inputs, and joint inputs on free
  /// bodies, whose speeds' generalized forces are body loads); the others add to the joints'
  /// generalized forces only.
  bool has_body_inputs() const { return body_inputs_; }

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
  /// True when some force element loads bodies (ForceElement::apply), not only joint
  /// coordinates (ForceElement::acts_on_joints).
  bool has_body_force_elements() const { return body_forces_; }
  /// True when some force element acts on joint coordinates.
  bool has_joint_force_elements() const { return !joint_elements_.empty(); }
  /// The force elements that act on joint coordinates, in the order of forces().
  const std::vector<const ForceElement*>& joint_force_elements() const { return joint_elements_; }
  double total_mass() const { return total_mass_; }
  /// Inverse of [I'_GK], precomputed.
  const Matrix3& inverse_inertia(int k) const { return inverse_inertia_[static_cast<size_t>(k)]; }

 private:
  void set_up_joints();
  void set_up_inputs();
  void set_up_constraints();

  std::vector<BodySpec> bodies_;
  Vector3 gravity_;
  std::vector<std::shared_ptr<const ForceElement>> forces_;
  std::string name_;
  std::vector<Joint> joints_;
  std::vector<Frame> frames_;
  std::vector<Input> inputs_;
  std::vector<Constraint> constraints_;
  std::vector<int> independent_speeds_;
  bool all_free_ = true, body_forces_ = false, body_inputs_ = false;
  std::vector<const ForceElement*> joint_elements_;
  std::vector<int> q_offset_, z_offset_;
  std::vector<Matrix3> slides_j_;
  std::vector<std::vector<int>> w_chain_;
  long long w_chain_entries_ = 0;
  std::vector<int> depth_, root_, lower_;
  std::vector<std::vector<int>> children_;
  long long chain_entries_ = 0;
  std::vector<int> chain_offset_;
  std::vector<int> chain_flat_;
  std::vector<Matrix3> inverse_inertia_;
  double total_mass_ = 0.0;
};

/// The same bodies, gravity, force elements, name, frames and inputs with these joints (one per
/// body), and more force elements (e.g. joint springs on the new joints) after the model's
/// own.
Model with_joints(const Model& model, std::vector<Joint> joints,
                  std::vector<std::shared_ptr<const ForceElement>> more_forces = {});

/// Checks that an inertia matrix is symmetric positive definite and that its principal
/// moments satisfy the triangle inequalities; returns an empty string or the problem.
std::string check_inertia(const Matrix3& inertia);

}  // namespace kanedyn
