// Analysis of any model (docs/analysis.md): the derivatives of its forward dynamics, its
// linearization about an operating point, the eigenvalues and modes, and static equilibrium.
//
// Positions are perturbed in tangent coordinates (docs/model-format.md, "Linearization output"):
// for a set of Euler parameters (a free body's eps_K, a spherical joint's q) the small rotation
// vector r, body-K components, with [R] = exp(-[r~]) [R_nominal]; for every other coordinate its
// deviation. A body's slice of the tangent has as many entries as its speeds, so the tangent of
// q has n = num_speeds() entries, in the order of z.
#pragma once

#include <complex>
#include <memory>
#include <string>
#include <vector>

#include "kanedyn/model.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn {

/// q0 (+) dx: the coordinates at the tangent deviation dx (size n) from q0, exactly (each
/// rotation vector through the exponential map).
VectorX retract(const Model& model, const VectorX& q0, const VectorX& dx);
/// q (-) q0: the tangent deviation that retract() maps q0 to q (rotation vectors of at most pi).
VectorX tangent_difference(const Model& model, const VectorX& q0, const VectorX& q);
/// The names of the linearization's state, as the spec spells them: every body's coordinates
/// (NAME.r1..r3 and NAME.s1..s3 for a free body, NAME.r1..r3 for a spherical joint,
/// NAME.j1..jn for any other), then its speeds (NAME.w1..w3 and NAME.sd1..sd3, NAME.w1..w3,
/// NAME.jd1..jdn), 2n names.
std::vector<std::string> tangent_state_names(const Model& model);

/// The derivatives of forward dynamics z dot = F(q, z, u) of one model: d(z dot)/dq in tangent
/// coordinates, d(z dot)/dz and d(z dot)/du (each n rows). They are analytic: forward-mode dual
/// numbers carried through the model's inverse dynamics Q(q, z, z dot, u) (every joint type,
/// gravity, the built-in force elements and the inputs, written once over a generic number type
/// with the equations of src/equations.inc), then d(z dot)/dx = -[M]^-1 dQ/dx at z dot = F
/// (docs/theory.md, "Derivatives"). A model with a force element of a type the library does not
/// define (a C++ subclass of ForceElement) is differentiated by central differences of F in
/// tangent coordinates instead; analytic() says which. Not for concurrent calls on one object.
class Derivatives {
 public:
  explicit Derivatives(const Model& model);
  Derivatives(const Derivatives&) = delete;
  Derivatives& operator=(const Derivatives&) = delete;
  ~Derivatives();

  const Model& model() const;
  /// True when the derivatives are those of dual numbers (every force element gives its law
  /// for every scalar: ForceElement::any_scalar, as the built-in ones do); else they are
  /// central differences.
  bool analytic() const;
  /// What computes them, for output.
  std::string method() const;

  /// d(z dot)/dq (n x n, tangent columns), d(z dot)/dz (n x n) and d(z dot)/du (n x m) at
  /// (q, z, u); zdot, when not null, gets z dot itself. A model with constraints throws
  /// std::invalid_argument (these would be the tree's; linearize() handles constraints).
  void forward(const VectorX& q, const VectorX& z, const VectorX& u, Eigen::Ref<MatrixX> dq,
               Eigen::Ref<MatrixX> dz, Eigen::Ref<MatrixX> du, VectorX* zdot = nullptr);
  /// The derivatives of inverse dynamics Q(q, z, z dot, u) (Terms::inverse_dynamics with the
  /// inputs): dQ/dq (tangent columns), dQ/dz and dQ/du; dQ/d(z dot) is the mass matrix.
  /// Analytic models only (throws std::logic_error otherwise).
  void inverse(const VectorX& q, const VectorX& z, const VectorX& zdot, const VectorX& u,
               Eigen::Ref<MatrixX> dq, Eigen::Ref<MatrixX> dz, Eigen::Ref<MatrixX> du);
  /// With constraints (constraints.hpp): the derivatives along (q tangent, z, u), columns as
  /// in inverse() side by side (n + n + m), of Q - [B]^T lambda with the multipliers lambda
  /// held (dQ, n rows), and of the constraints' rows (drows, 3c rows): the velocity residuals
  /// [B] z, the acceleration residuals [B] z dot + {b} at this z dot, the position errors.
  /// Analytic models only (throws std::logic_error otherwise).
  void constrained(const VectorX& q, const VectorX& z, const VectorX& zdot, const VectorX& u,
                   const VectorX& lambda, Eigen::Ref<MatrixX> dQ, MatrixX& drows);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The linearized motion about the nominal motion through (q, z, u) (docs/model-format.md,
/// "Linearization output"): the state is the tangent deviation of q, then the deviation of z.
struct Linearization {
  int n = 0;  ///< speeds (with constraints: the independent ones)
  int m = 0;  ///< inputs
  /// 2n names (tangent_state_names); with constraints the independent coordinates (those
  /// not fixed by holonomic constraints), then the independent speeds.
  std::vector<std::string> state;
  std::vector<std::string> inputs;  ///< m names
  VectorX q, z, u;                  ///< the operating point
  VectorX zdot;                     ///< z dot there (zero at an equilibrium)
  MatrixX A;                        ///< d(state rate)/d(state), square, state's size
  MatrixX B;                        ///< d(state rate)/du, state's size x m
  /// The eigenvalues of A, sorted by decreasing real part, then decreasing imaginary part.
  Eigen::VectorXcd eigenvalues;
  /// With modes: column i is the eigenvector of eigenvalues[i], scaled so that its largest
  /// entry is 1 (real and positive); empty otherwise.
  Eigen::MatrixXcd modes;
  /// With constraints: the full tangent deviation (dx; dz) (2 x num_speeds()) of a state
  /// deviation, to first order: the dependent coordinates and speeds follow the independent
  /// ones. Empty without constraints (the state is (dx; dz) itself).
  MatrixX full_state;
  /// True when a free body turns at the operating point (w0 != 0): the linear system is then
  /// periodic, and its eigenvalues at one instant do not decide stability.
  bool periodic = false;
};

/// A, B and the eigenvalues (and the eigenvectors when modes) at (q, z, u). Throws
/// std::invalid_argument for wrong sizes.
Linearization linearize(const Model& model, const VectorX& q, const VectorX& z, const VectorX& u,
                        bool modes = false);

/// The linearization at rest (z = 0) of the motion in which only the tangent coordinates `free`
/// move and the others are locked (held by reactions): the state is the free coordinates, then
/// their speeds; zdot the free speeds' rates there. With every coordinate free it equals
/// linearize() at z = 0. Analytic models only (std::invalid_argument otherwise).
Linearization linearize_at_rest(const Model& model, const VectorX& q, const VectorX& u,
                                const std::vector<int>& free);

/// The eigenvalues (and, when vectors is not null, the eigenvectors, scaled as in
/// Linearization::modes) of a square matrix, sorted as Linearization::eigenvalues.
Eigen::VectorXcd sorted_eigenvalues(const MatrixX& a, Eigen::MatrixXcd* vectors = nullptr);

/// One eigenvalue's reading: frequency, damping ratio, time constant.
struct ModeReading {
  double frequency_hz = 0.0;   ///< |Im| / 2 pi (0 for a real eigenvalue)
  double damping_ratio = 0.0;  ///< -Re / |lambda| (1 or -1 for a real one; 0 for lambda = 0)
  double time_constant = 0.0;  ///< 1 / |Re| (infinity for Re = 0)
  bool stable = false;         ///< Re < -tolerance
  bool unstable = false;       ///< Re > tolerance
};
/// The reading of lambda, with tolerance the scale below which Re counts as zero.
ModeReading read_eigenvalue(std::complex<double> lambda, double tolerance);

/// Static equilibrium (docs/analysis.md): the coordinates at which the model rests, z = 0.
/// The largest tolerance equilibrium() takes.
inline constexpr double kMaxEquilibriumTolerance = 1e-3;

struct EquilibriumOptions {
  /// Which tangent coordinates (0..n-1) Newton moves; empty: all. The others keep their values
  /// (held by reactions that the result does not report).
  std::vector<int> free;
  /// On the largest generalized force, relative to the scale below: in (0, 1e-3].
  double tolerance = 1e-10;
  int max_iterations = 50;  ///< at least 1
};

struct EquilibriumResult {
  bool converged = false;
  int iterations = 0;
  VectorX q;  ///< the rest pose (the last iterate when not converged)
  /// The generalized forces Q at q on the free coordinates (with constraints, [C_I]^T Q: along
  /// the independent speeds).
  VectorX residual;
  double residual_norm = 0.0;  ///< their largest magnitude
  double scale = 0.0;          ///< the force scale the tolerance is relative to
  std::string message;         ///< why it stopped, and what to fix when it failed
  /// The tangent coordinates Newton moved: options.free (all when empty) or, with constraints,
  /// the independent speeds (it moved along their directions, the dependent ones following).
  std::vector<int> free;
  /// Tangent coordinates with no restoring force at the end (the Jacobian's null space): what to
  /// hold fixed.
  std::vector<int> unrestrained;
  /// The eigenvalues of the motion about the rest pose with the held coordinates locked (the
  /// free coordinates and their speeds), sorted as Linearization::eigenvalues: stable when
  /// every real part is negative.
  Eigen::VectorXcd eigenvalues;
};

/// Newton's method with the analytic Jacobian on Q(q) = 0 over the free coordinates, with
/// Q the generalized active forces at z = 0 and z dot = 0 (the inverse dynamics, equal to
/// [M] z dot at z = 0), from q0, at inputs u. Throws std::invalid_argument for options out of
/// range.
EquilibriumResult equilibrium(const Model& model, const VectorX& q0, const VectorX& u,
                              const EquilibriumOptions& options = {});

}  // namespace kanedyn
