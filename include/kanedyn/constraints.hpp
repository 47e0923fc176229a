// The constraint equations of a model and the motion they allow (docs/theory.md,
// "Constraints"): [B(q)]{z} = 0, the rows' accelerations [B]{z dot} + {b} = 0, the holonomic
// rows' position errors, the independent speeds, the projection of a state onto the
// constraints, and the forward dynamics with the reactions.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "kanedyn/model.hpp"

namespace kanedyn {

namespace detail {
class JointDynamics;
}

/// A constraint's equations fail to be defined at a state: a rolling disc's axle along the
/// plane's normal, a distance constraint's points together, a projection that does not converge.
class ConstraintError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The constraint equations of a model at one state at a time. Rows are the constraints' in
/// order: a ball's 3 (inertial x, y, z of the velocity of `at` on body minus that of `other_at`
/// on other), a hinge's 5 (the ball's, then the relative angular velocity along a x p1 and
/// a x p2, a the body's axis and p1, p2 two directions of `other` normal to `other_axis`), a
/// distance's 1 (along the line between the points), a rolling disc's 3 (the velocity of the
/// disc's point at the contact P along the plane normal n, then along t1 and t2, two fixed
/// directions of the plane). Every row is holonomic except a rolling disc's second and third.
class ConstraintEquations {
 public:
  explicit ConstraintEquations(const Model& model);
  ConstraintEquations(const ConstraintEquations&);
  ~ConstraintEquations();

  const Model& model() const;
  int rows() const;            ///< c, the number of equations
  int holonomic_rows() const;  ///< how many of them are holonomic
  bool holonomic(int row) const;
  int first_row(int constraint) const;  ///< constraint i's rows start here
  /// "NAME.1", "NAME.2", ...: a row's name, for messages and inspect.
  std::string row_name(int row) const;
  /// The constraint a row belongs to.
  int constraint_of_row(int row) const;

  /// Evaluates [B] (c x n), {b} = [B dot]{z} (c) and the position errors (c; zero on the
  /// nonholonomic rows) at (q, z), q with unit Euler parameters. Throws ConstraintError where
  /// the equations are not defined (the message names the constraint).
  void evaluate(const VectorX& q, const VectorX& z);
  /// [B], made from the evaluation's [B]^T on the first call after it (so, like evaluate(), not
  /// for concurrent calls on one object).
  const MatrixX& B() const;
  const VectorX& b() const;
  const VectorX& errors() const;
  /// The contact point of a rolling disc, or the point `at` of body (inertial), at the last
  /// evaluate().
  const Vector3& point(int constraint) const;

  /// Constraint i's force on its body (inertial components; applied at its point) and moment
  /// about that point (a hinge's; zero for the others) from the rows' multipliers lambda (c),
  /// at the last evaluate(): {B}^T {lambda} is the generalized force of these loads and of
  /// their opposites on `other`.
  Vector3 force(int constraint, const VectorX& lambda) const;
  Vector3 moment(int constraint, const VectorX& lambda) const;

 private:
  friend class ConstrainedDynamics;
  // evaluate() from the kinematic terms of a tree's last evaluation at (q, z).
  void evaluate(detail::JointDynamics& tree);
  // [B]^T (n x c), as the evaluation writes it.
  const MatrixX& B_transpose() const;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The two unit directions a constraint keeps fixed: a hinge's p1, p2 normal to `other_axis`
/// (in other's components), a rolling disc's t1, t2 in the plane (inertial); (t1, t2, n)
/// right-handed. Zero for the other types.
std::array<Vector3, 2> constraint_fixed_directions(const Constraint& c);

/// The reactions' columns of the trajectory CSV for the whole model: reaction_count summed over
/// its constraints.
int reaction_count(const Model& model);

/// The constraints' reactions from the rows' multipliers lambda at the equations' last
/// evaluate(), in the order of the trajectory CSV's columns: per constraint its force on `body`
/// (force()), then a hinge's moment (moment()). out has reaction_count(model) entries.
void constraint_reactions(const ConstraintEquations& equations, const VectorX& lambda,
                          Eigen::Ref<VectorX> out);

/// The independent speeds z_I and the dependent z_D of [B] at a state: y = [C][C_I]z_I
/// (docs/theory.md, "Constraints").
struct SpeedPartition {
  int rank = 0;                     ///< r, the number of independent equations
  std::vector<int> rows;            ///< r independent rows of [B] (the others are redundant)
  std::vector<int> independent;     ///< n - r speeds, ascending
  std::vector<int> dependent;       ///< r speeds, ascending
  std::vector<int> redundant_rows;  ///< rows implied by the others
};

/// The partition at [B] (the model's independent_speeds() when given, else chosen by a QR
/// factorization with column pivoting). Throws ConstraintError when the given independent
/// speeds leave the dependent ones undetermined, naming them.
SpeedPartition partition_speeds(const Model& model, const MatrixX& B);

/// Throws ConstraintError when the model names independent speeds and their count is not n
/// minus the rank of [B] (what partition_speeds checks first, without choosing a partition).
void check_independent_count(const Model& model, const MatrixX& B);

/// [C_I] of a partition of [B] (n x (n - rank)): the identity on the independent speeds and
/// -[B_D]^-1 [B_I] on the dependent ones, over the partition's independent rows, so that
/// z = [C_I] z_I satisfies [B] z = 0. Throws ConstraintError when [B_D] is singular at this
/// [B] (the partition was chosen at another state).
MatrixX independent_basis(const MatrixX& B, const SpeedPartition& partition);

/// What projecting a state onto the constraints changed.
struct Projection {
  double coordinate_change = 0.0;  ///< the largest change of a tangent coordinate
  double speed_change = 0.0;       ///< the largest change of a speed
  double error_before = 0.0;       ///< the largest holonomic error before
  int iterations = 0;              ///< Gauss-Newton steps
};

/// Projects (q, z) onto the constraints: the holonomic errors to below `tolerance` by
/// Gauss-Newton steps on the dependent coordinates only (the minimum-norm step in them), then
/// the speeds by least squares (the smallest change with [B]{z} = 0). A row's tolerance is
/// never below the round-off of its error at the size of q (16 eps (1 + max|q|) times the sum
/// of the row's |B| entries), so long runs whose angles grow stay projectable. Throws
/// ConstraintError naming the constraint with the largest error when 50 steps do not converge,
/// or, when the given independent speeds' count does not fit [B] (check_independent_count),
/// saying so instead.
Projection project_onto_constraints(const Model& model, VectorX& q, VectorX& z,
                                    double tolerance = 1e-12);
/// The same with the equations' workspace of the caller (their model's constraints), which a
/// run projecting at every step keeps instead of building one each time.
Projection project_onto_constraints(ConstraintEquations& equations, VectorX& q, VectorX& z,
                                    double tolerance = 1e-12);

/// Forward dynamics with constraints at (q, z, u): z dot and the rows' multipliers. The
/// unconstrained equations M z dot + b(q, z, u) = [B]^T {lambda}, and [B]{z dot} + {b} = 0.
/// Two routes, equal to round-off: `projected`, Kane's equations in the independent speeds,
/// ([C_I]^T M [C_I]) z_I dot = -[C_I]^T (b + M w), and `multipliers`, z dot = z dot_free + M^-1
/// [B]^T lambda with ([B] M^-1 [B]^T) lambda = -({b} + [B] z dot_free), whose constraint-space
/// solve is c x c. Redundant rows get the minimum-norm multipliers.
class ConstrainedDynamics {
 public:
  enum class Method { projected, multipliers };
  explicit ConstrainedDynamics(const Model& model, Method method = Method::multipliers);
  ~ConstrainedDynamics();
  ConstrainedDynamics(const ConstrainedDynamics&) = delete;
  ConstrainedDynamics& operator=(const ConstrainedDynamics&) = delete;

  Method method() const;
  /// z dot at (q, z, u); lambda() and equations() then hold the multipliers and the equations
  /// at this state.
  void evaluate(const VectorX& q, const VectorX& z, const VectorX& u, Eigen::Ref<VectorX> zdot);
  const VectorX& lambda() const;
  const ConstraintEquations& equations() const;
  /// The partition the projected method used (chosen at its first evaluation, chosen again when
  /// [B_D] becomes ill-conditioned).
  const SpeedPartition& partition() const;
  /// The constraint-space rank at the last evaluation.
  int rank() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kanedyn
