// Forward dynamics of a jointed tree (docs/theory.md, "Joints"): {z dot} at the joint
// coordinates q and independent speeds z, by the route of the user's choice, and the
// derivative of the integrated state (q; z).
#pragma once

#include <array>
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

  /// gram := x^T [M]^-1 x (c x c, its lower triangle; the upper is zero) for the c columns of x,
  /// by solve_mass's inward pass alone: that pass maps each column Q to the joints' u_K, and
  /// Q^T [M]^-1 Q' = sum over the joints of u_K^T D_K^-1 u'_K. x is overwritten (with the
  /// u_K). O(N c^2) with no outward pass; the same conditions as solve_mass.
  void inverse_mass_gram(Eigen::Ref<MatrixX> x, MatrixX& gram);

  /// The kinematics alone of an evaluation at (q, z): the joint tables, [R_K], w_K and the
  /// terms body_motion() and add_point_rows() read, without the inertias, loads and
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
  /// Directions onto which add_point_rows projects a point's velocity (linear, up to 3) and
  /// its body's angular velocity (angular, up to 2), inertial.
  struct RowDirections {
    std::array<Vector3, 3> linear;
    int linear_count = 0;
    std::array<Vector3, 2> angular;
    int angular_count = 0;
  };
  /// Adds sign times the Jacobian rows e^T J_v of the velocity of the point at `point`
  /// (inertial position) fixed in body k, for each linear direction e, and then f^T J_w of k's
  /// angular velocity for each angular direction f, to consecutive columns of rows_t (n rows:
  /// each column a row of a Jacobian) from column `first`, at the last evaluate() or
  /// kinematics(), `origin` being O_K there (body_motion's p): each joint c on k's chain
  /// contributes its [S_c] columns, turned about O_c (the point seen from a free body c's
  /// ancestors is O_c, and they do not turn it). O(depth). The directions are 3 linear and 0
  /// angular, 1 and 0, or 3 and 2 (std::invalid_argument otherwise).
  void add_point_rows(int k, const Vector3& origin, const Vector3& point, double sign,
                      const RowDirections& directions, Eigen::Ref<MatrixX> rows_t, int first);

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
