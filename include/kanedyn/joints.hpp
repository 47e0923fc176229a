// Joints by the orthogonal-complement method (docs/theory.md, "Joints"): the joint
// coordinates q and independent speeds z of a tree, the notes' state (x, y) they give, the
// constraint matrix y = [C] z, [C dot]{z}, the kinematic equations dq/dt, and the projected
// equations [C]^T [A] [C] {z dot} = [C]^T ({f} - [A][C dot]{z}) built on Eq. (36).
//
// Layout of q and z, body by body in numbering order (index k):
//   free:        q = (eps_K (4), s'_K (3)),  z = (w'_K (3), s'_K dot (3))  -- the notes' own
//   weld:        q = (),                     z = ()
//   revolute:    q = (angle),                z = (d angle/dt)
//   prismatic:   q = (d),                    z = (dd/dt)
//   cylindrical: q = (angle, d),             z = (d angle/dt, dd/dt)
//   universal:   q = (a1, a2),               z = (da1/dt, da2/dt)
//   spherical:   q = (e1, e2, e3, e4) of K relative to F, z = angular velocity of K relative
//                to J, body-K components (the spec's `joint_rate`)
// Angles in radians, lengths in model units, rates per second.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn {

enum class JointType { free, weld, revolute, prismatic, cylindrical, universal, spherical };

/// "free", "weld", "revolute", ... as the model format spells them.
const char* to_string(JointType type);

/// The joint of body K at Q_K, relative to J = L(K) (the inertial frame for a root).
struct Joint {
  JointType type = JointType::free;
  /// The joint frame F as Euler parameters of F relative to J (e4 scalar, unit): J's axes turned
  /// into F's, so [R(frame)] maps body-J components to F components. Unused by free joints.
  Vector4 frame{0.0, 0.0, 0.0, 1.0};
  /// Revolute, prismatic, cylindrical: the axis in F components (normalized by JointTree).
  Vector3 axis = Vector3::UnitX();
  /// Universal: a1, a2 in F components (normalized by JointTree), perpendicular.
  std::array<Vector3, 2> axes{Vector3::UnitX(), Vector3::UnitY()};
  /// Weld: the constant s'_K, body-J components.
  Vector3 translation = Vector3::Zero();
};

/// Entries of a body's slice of q: 7 for free (eps_K, s'_K), 0 weld, 1 revolute and
/// prismatic, 2 cylindrical and universal, 4 spherical.
int coordinate_count(JointType type);
/// Entries of a body's slice of z: 6 free, 0 weld, 1 revolute and prismatic, 2 cylindrical
/// and universal, 3 spherical.
int speed_count(JointType type);

/// The problem with a joint description, or "" when it is usable: a zero axis, universal axes
/// zero or not perpendicular (|a1 . a2| > 1e-9 after normalizing), frame Euler parameters off
/// unit norm by more than 1e-6.
std::string check_joint(const Joint& joint);
/// The problem with one body's slice of q, or "": a wrong count, or Euler parameters (a
/// spherical q, a free body's eps_K) whose norm is off 1 by more than 1e-6.
std::string check_joint_coordinates(JointType type, const VectorX& q);
/// The problem with one body's slice of z (its `joint_rate`), or "": a wrong count.
std::string check_joint_rates(JointType type, const VectorX& z);

/// Rotation by `angle` (rad) about the unit `axis` (Eq. 3 of its Euler parameters): maps the
/// components of a frame to those of the frame turned by `angle` about `axis`.
Matrix3 axis_angle_rotation(const Vector3& axis, double angle);

/// Euler parameters of K from those of J and of K relative to J (the inverse of
/// relative_euler_parameters): [R(result)] = [R(rel)] [R(eps_j)].
Vector4 compose_euler_parameters(const Vector4& eps_j, const Vector4& rel);

/// A load on one body's joint coordinates (the model format's joint_spring and joint_force):
/// for coordinate i, Q_i = value_i - stiffness_i (q_i - rest_i) - damping_i dq_i/dt, potential
/// energy 1/2 stiffness_i (q_i - rest_i)^2. Revolute, prismatic, cylindrical and universal
/// joints only (there z = dq/dt). Each vector has coordinate_count() entries (a loader expands
/// scalars); a joint_force has zero stiffness and damping, a joint_spring zero value.
struct JointLoad {
  int body = 0;
  VectorX stiffness, damping, rest, value;
};

/// One joint per body of a Model, validated once, with the offsets of each body's slices of q
/// and z and the structure of [C]. Immutable; copies the topology it needs from the Model.
class JointTree {
 public:
  /// Throws ModelError naming the body when joints.size() != N, check_joint() refuses one, or
  /// a load is on a free, weld or spherical joint or has the wrong number of entries.
  JointTree(const Model& model, std::vector<Joint> joints, std::vector<JointLoad> loads = {});

  int num_bodies() const { return static_cast<int>(joints_.size()); }
  int num_coordinates() const { return q_offset_.back(); }                     ///< size of q
  int num_speeds() const { return z_offset_.back(); }                          ///< n, size of z
  const Joint& joint(int k) const { return joints_[static_cast<size_t>(k)]; }  ///< normalized
  int lower_body(int k) const { return lower_[static_cast<size_t>(k)]; }
  int coordinate_offset(int k) const { return q_offset_[static_cast<size_t>(k)]; }
  int speed_offset(int k) const { return z_offset_[static_cast<size_t>(k)]; }
  /// The axis of a revolute, prismatic or cylindrical joint in body-J components.
  const Vector3& axis_in_j(int k) const { return axis_j_[static_cast<size_t>(k)]; }
  const std::vector<JointLoad>& loads() const { return loads_; }
  /// True when some joint is not free (the model is not the notes' free tree).
  bool has_constraints() const { return constrained_; }
  /// The bodies whose z enter w'_K: K (if it has speeds), then down its chain through welds
  /// and joints up to and including the first free body (a free body's w' is its own z).
  /// Only when has_angular_chains() (empty otherwise).
  const std::vector<int>& angular_chain(int k) const { return w_chain_[static_cast<size_t>(k)]; }
  /// The sum of the angular chains' lengths (the blocks of [C]'s w' rows), N^2/2 for a chain
  /// of joints.
  long long angular_chain_entries() const { return chain_entries_; }
  /// True when the angular chains are stored: angular_chain_entries() <=
  /// Model::kMaxFlatChainEntries. ConstraintMatrix and projected_equations need them; the
  /// recursive route of JointDynamics does not.
  bool has_angular_chains() const { return chain_entries_ <= Model::kMaxFlatChainEntries; }

 private:
  std::vector<Joint> joints_;
  std::vector<JointLoad> loads_;
  bool constrained_ = false;
  long long chain_entries_ = 0;
  std::vector<int> lower_, q_offset_, z_offset_;
  std::vector<Vector3> axis_j_;
  std::vector<std::vector<int>> w_chain_;
};

/// Euler parameters of K relative to J (frame, then the joint's own rotation) from q; not for
/// free joints.
Vector4 joint_relative_rotation(const JointTree& tree, int k, const VectorX& q);
/// s'_K of a jointed body from q (body-J components); not for free joints.
Vector3 joint_translation(const JointTree& tree, int k, const VectorX& q);
/// [G_K] of body k at q, 3 x speed_count(type) (the first columns of a 3x6): w_rel = [G_K] z_K,
/// body-K components (the table under ConstraintMatrix).
Matrix36 joint_rotation_block(const JointTree& tree, int k, const VectorX& q);
/// [T_K] of body k, 3 x speed_count(type): s'_K dot = [T_K] z_K, body-J components; constant.
Matrix36 joint_translation_block(const JointTree& tree, int k);
/// [G_K dot] z_K at (q, z), body-K components: nonzero only for a universal joint.
Vector3 joint_rotation_rate_times_speeds(const JointTree& tree, int k, const VectorX& q,
                                         const VectorX& z);
/// Angular velocity of K relative to J, body-K components, from q and z ([G_K] z_K below).
Vector3 joint_relative_angular_velocity(const JointTree& tree, int k, const VectorX& q,
                                        const VectorX& z);

/// The notes' state from the joint coordinates: eps_K = eps_J composed with the relative
/// rotation, s'_K from the table, w'_K = w_rel + [R_K][R_J]^T w'_J, s'_K dot from z_K; free
/// bodies copy their slices. Needs state sized for N bodies. Unit spherical q assumed.
void joint_state(const JointTree& tree, const VectorX& q, const VectorX& z, State& state);

/// Rescales every spherical q and every free eps_K to unit norm (the integrator's
/// normalization, as State::normalize_euler_parameters); returns the largest | |e| - 1 |.
double normalize_joint_coordinates(const JointTree& tree, Eigen::Ref<VectorX> q);

/// {q dot} from z: z_K itself, except spherical (1/2 [Ebar'(q)]^T w_rel, the form of Eq. 39)
/// and free (Eq. 39 for eps_K, Eq. 40 for s'_K). qdot must have size num_coordinates().
void joint_coordinate_rates(const JointTree& tree, const VectorX& q, const VectorX& z,
                            Eigen::Ref<VectorX> qdot);

/// y = [C] z, block-sparse. w'_K = sum over c in angular_chain(K) of w_block * z_c, with
/// w_block = [R_K][R_c]^T [G_c] (3 x speed_count(c), the first columns of a 3x6); s'_K dot =
/// s_block[K] z_K. [G_c]: free [I 0]; revolute n; cylindrical [n 0]; universal
/// [R(a2, q2) a1, a2]; spherical [I]; prismatic 0. s_block: free [0 I]; prismatic n_J;
/// cylindrical [0 n_J]; else 0.
struct ConstraintMatrix {
  explicit ConstraintMatrix(const JointTree& tree);
  std::vector<int> w_begin;       ///< N + 1: body k's blocks are w_begin[k] .. w_begin[k+1]-1
  std::vector<int> w_body;        ///< the body c of each block (angular_chain order)
  std::vector<Matrix36> w_block;  ///< coefficient of z_c in w'_K (body-K components)
  std::vector<Matrix36> s_block;  ///< per body: coefficient of z_K in s'_K dot (body J)
  std::vector<Matrix3> R;         ///< [R_K] of the state it was computed at (Eqs. 3-4)
};

/// (The constructor throws ModelError unless tree.has_angular_chains().)
/// Fills C at the state joint_state() gave for q (its eps_K give the [R_K]).
void compute_constraint_matrix(const JointTree& tree, const VectorX& q, const State& state,
                               ConstraintMatrix& C);
/// y = [C] z (6N), from the blocks.
void constraint_times(const JointTree& tree, const ConstraintMatrix& C, const VectorX& z,
                      Eigen::Ref<VectorX> y);
/// [C]^T v (n) for a 6N column v (e.g. generalized forces), from the blocks.
void constraint_transpose_times(const JointTree& tree, const ConstraintMatrix& C, const VectorX& v,
                                Eigen::Ref<VectorX> out);
/// Dense 6N x n view of [C], rows in the order of {y}, columns in the order of z.
MatrixX dense_constraint_matrix(const JointTree& tree, const ConstraintMatrix& C);

/// [C dot]{z} (6N) at the state of C: w'_K part [G_K dot] z_K - w_rel x ([R_K][R_J]^T w'_J)
/// + [R_K][R_J]^T ([C dot]{z})_J (zero at a free body); the s' dot part is zero.
void constraint_rate_times_speeds(const JointTree& tree, const ConstraintMatrix& C,
                                  const VectorX& q, const VectorX& z, const State& state,
                                  Eigen::Ref<VectorX> out);

/// Adds the joint loads' generalized forces Q (n, in the order of z) at (q, z) to Q.
void add_joint_load_forces(const JointTree& tree, const VectorX& q, const VectorX& z,
                           Eigen::Ref<VectorX> Q);
/// Sum of the joint springs' potentials 1/2 stiffness_i (q_i - rest_i)^2.
double joint_load_potential_energy(const JointTree& tree, const VectorX& q);
/// Power removed by the joint springs' damping, sum of damping_i (dq_i/dt)^2 (>= 0).
double joint_load_damping_power(const JointTree& tree, const VectorX& z);

/// The projected equations at (q, z), dense, for output and as the reference route.
struct ProjectedEquations {
  MatrixX C;       ///< 6N x n
  VectorX Cdot_z;  ///< 6N
  MatrixX A_z;     ///< [C]^T [A] [C], n x n
  VectorX f_z;     ///< [C]^T ({f} - [A][C dot]{z}) + the joint loads' Q, n
  VectorX zdot;    ///< the solution of A_z {z dot} = f_z
  State state;     ///< the notes' (x, y) at (q, z)
};
/// Forms and solves the projected equations with kane_equations() (its dense [A], {f}):
/// data needs DataOptions::kane_terms and dense_mass_matrix (throws std::invalid_argument
/// otherwise); allocates (a reference route).
ProjectedEquations projected_equations(const Model& model, const JointTree& tree, const VectorX& q,
                                       const VectorX& z, Data& data);

}  // namespace kanedyn
