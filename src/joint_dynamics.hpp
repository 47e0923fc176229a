// Forward dynamics of a jointed tree (docs/theory.md, "Joints"): {z dot} at the joint
// coordinates q and independent speeds z, by the route of the user's choice, and the
// derivative of the integrated state (q; z).
#pragma once

#include <memory>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn::detail {

/// The workspace of one Model, which must outlive it. Copies are independent.
class JointDynamics {
 public:
  explicit JointDynamics(const Model& model);
  JointDynamics(const JointDynamics& other);
  JointDynamics& operator=(const JointDynamics&) = delete;
  ~JointDynamics();

  /// {z dot} at (q, z) into zdot (size n): Route::recursive is the O(N) articulated-body
  /// route, Route::assembled the projected Kane equations [C]^T [A] [C] {z dot} =
  /// [C]^T ({f} - [A][C dot]{z}) + Q. Both include the force elements on joint coordinates.
  /// Afterwards state() is the notes' (x, y) at (q, z) and data() its kinematics
  /// (compute_kinematics) and loads (compute_resultants): computed here as far as the model's force
  /// elements need them (the state, [R_K] and the loads for the built-in ones; everything for an
  /// element whose ForceElement::reads_positions() is true), the rest on the first call of state()
  /// or data() after this evaluation (the same functions on the same state: the same bits).
  /// Spherical q and free eps_K are used as given (unit norm assumed). Route::recursive
  /// needs O(N) memory for any tree; Route::assembled builds its blocks (one per pair of
  /// joints on one chain) on its first call and throws ModelError when there would be more
  /// than Model::kMaxFlatChainEntries. After each route's first call,
  /// evaluate() and derivative() do not allocate.
  void evaluate(const VectorX& q, const VectorX& z, Route route, Eigen::Ref<VectorX> zdot);

  /// d/dt (q; z) at (q; z) (size num_coordinates() + num_speeds()): joint_coordinate_rates
  /// at q with its spherical and free Euler parameters normalized, and evaluate() there.
  void derivative(const VectorX& qz, Route route, Eigen::Ref<VectorX> dqz);

  /// Overwrites each column Q of x (n rows) with [M]^-1 Q, [M] = [C]^T [A] [C] the joint-space
  /// mass matrix at the last evaluate(), which must have taken Route::recursive: the
  /// articulated-body factorization it left (U, D^-1 per joint, the free bodies' articulated
  /// inertias) applied to Q with no velocity terms, one inward and one outward pass over all
  /// columns, O(N c). Allocates only when the column count grows.
  void solve_mass(Eigen::Ref<MatrixX> x);

  /// The kinematics alone of an evaluation at (q, z): the joint tables, [R_K], w_K and the
  /// terms body_motion() and add_point_jacobian() read, without the inertias, loads and
  /// solution (and without a factorization for solve_mass).
  void kinematics(const VectorX& q, const VectorX& z);

  /// Body k's origin O_K at the last evaluate() or kinematics(), inertial components: its
  /// position, angular velocity, velocity, and angular and linear accelerations at z dot = 0
  /// (the velocity-product terms, without gravity). O(depth of k), from the per-body terms of the
  /// recursion: p_O,K = p_O,J + r_K, v_O,K = v_O,J + w_J x r_K + ([S_K] z_K)_v, A_K = [P_K] A_J
  /// + c_K.
  struct BodyMotion {
    Matrix3 R;  ///< [R_K]
    Vector3 p, w, v, alpha, a;
  };
  void body_motion(int k, BodyMotion& out);
  /// [R_K] at the last evaluate() or kinematics().
  const Matrix3& body_rotation(int k) const;
  /// Adds sign times the Jacobian of the velocity of the point at `point` (inertial position)
  /// fixed in body k into Jv (3 x n) and of k's angular velocity into Jw, at the last evaluate()
  /// or kinematics(), `origin` being O_K there (body_motion's p): each joint c on k's chain
  /// contributes its [S_c] columns, turned about O_c (the point seen from a free body c's
  /// ancestors is O_c, and they do not turn it). O(depth).
  void add_point_jacobian(int k, const Vector3& origin, const Vector3& point, double sign,
                          Eigen::Ref<MatrixX> Jv, Eigen::Ref<MatrixX> Jw);

  /// The notes' state at the last evaluation's (q, z) (State(model) before the first). Not
  /// const: it may compute the state (see evaluate()), so, like evaluate(), it is not for
  /// concurrent calls on one object.
  const State& state();
  /// Its kinematics and loads (see evaluate()).
  Data& data();
  const Model& model() const;
  /// The inputs' values every later evaluation uses (the Data's inputs; size checked by the
  /// caller).
  void set_inputs(const VectorX& u);
  const VectorX& inputs() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kanedyn::detail
