// Constraint equations, speed partitions, projection and constrained forward dynamics
// (docs/theory.md, "Constraints").
#include "kanedyn/constraints.hpp"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "kanedyn/analysis.hpp"
#include "kanedyn/frames.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/terms.hpp"

#include "constraint_rows.hpp"
#include "joint_dynamics.hpp"

namespace kanedyn {

namespace {

size_t at(int i) { return static_cast<size_t>(i); }

// Two unit vectors normal to the unit n and to each other, (t1, t2, n) right-handed: fixed by
// n alone, so the same at every state.
void normal_pair(const Vector3& n, Vector3& t1, Vector3& t2) {
  Eigen::Index least = 0;
  n.cwiseAbs().minCoeff(&least);
  t1 = n.cross(Vector3::Unit(least)).normalized();
  t2 = n.cross(t1);
}

// A point fixed in body k (or the ground): where it is, how it moves, its Jacobian.
struct PointMotion {
  Vector3 r = Vector3::Zero();       // from O_K, inertial (ground: from the origin)
  Vector3 p = Vector3::Zero();       // position
  Vector3 v = Vector3::Zero();       // velocity
  Vector3 a0 = Vector3::Zero();      // acceleration at z dot = 0
  Vector3 w = Vector3::Zero();       // the body's angular velocity
  Vector3 alpha0 = Vector3::Zero();  // its angular acceleration at z dot = 0
};

}  // namespace

struct ConstraintEquations::Impl {
  explicit Impl(const Model& m) : model(m), own(m) {
    const int n = m.num_speeds();
    for (const Constraint& c : m.constraints()) {
      first.push_back(rows);
      for (int i = 0; i < equation_count(c.type); ++i) {
        const bool nonholonomic = c.type == ConstraintType::rolling_disc && i > 0;
        holonomic.push_back(nonholonomic ? 0 : 1);
        owner.push_back(static_cast<int>(first.size()) - 1);
        if (!nonholonomic) ++holonomic_count;
      }
      rows += equation_count(c.type);
      const auto directions = constraint_fixed_directions(c);
      perpendiculars.push_back({directions[0], directions[1]});
    }
    Bt.setZero(n, rows);
    b.setZero(rows);
    errors.setZero(rows);
    points.assign(m.constraints().size(), Vector3::Zero());
    bases.assign(m.constraints().size(), Matrix3::Identity());
    hinge_moment.assign(m.constraints().size(), {Vector3::Zero(), Vector3::Zero()});
  }

  struct Perpendiculars {
    Vector3 p1 = Vector3::Zero(), p2 = Vector3::Zero();
  };

  const Model& model;
  int rows = 0, holonomic_count = 0;
  std::vector<int> first, owner;
  std::vector<char> holonomic;
  std::vector<Perpendiculars> perpendiculars;
  // [B]^T (n x c), each row of [B] a contiguous column; [B] itself is made from it on request.
  MatrixX Bt;
  mutable MatrixX B;
  mutable bool B_current = false;
  VectorX b, errors;
  std::vector<Vector3> points;
  // Per constraint: the directions of its first three rows (columns), inertial; a hinge's last
  // two rows' moment directions in hinge_moment.
  std::vector<Matrix3> bases;
  std::vector<std::array<Vector3, 2>> hinge_moment;
  // The tree's kinematic terms: its own, or those of the evaluation of ConstrainedDynamics'
  // tree (the same functions of (q, z)).
  detail::JointDynamics own;
  detail::JointDynamics* tree = &own;
  detail::JointDynamics::BodyMotion motion;
  using Directions = detail::JointDynamics::RowDirections;

  // Adds sign times the rows of the point at `point` (inertial position) fixed in body k along
  // `directions` to [B] from row `first`; m a point_motion of k (for O_K).
  void add_rows(int k, const PointMotion& m, const Vector3& point, double sign,
                const Directions& directions, int first) {
    if (k != kGround) tree->add_point_rows(k, m.p - m.r, point, sign, directions, Bt, first);
  }

  PointMotion point_motion(int k, const Vector3& offset) {
    PointMotion m;
    if (k == kGround) {
      m.p = offset;
      m.r = offset;
      return m;
    }
    tree->body_motion(k, motion);
    m.r = motion.R.transpose() * offset;
    m.p = motion.p + m.r;
    m.w = motion.w;
    m.v = motion.v + m.w.cross(m.r);
    m.alpha0 = motion.alpha;
    m.a0 = motion.a + motion.alpha.cross(m.r) + m.w.cross(m.w.cross(m.r));
    return m;
  }

  const Matrix3& rotation(int k) const { return tree->body_rotation(k); }

  // The end of a constraint at body k (or the ground) for detail::constraint_rows: its point's
  // motion m at z dot = 0, and the body's rotation and rates.
  detail::ConstraintEnd<double> end(int k, const PointMotion& m) const {
    detail::ConstraintEnd<double> e;
    e.point = {eq::vec(m.r), eq::vec(m.p), eq::vec(m.v), eq::vec(m.a0)};
    e.R = eq::mat(k == kGround ? Matrix3::Identity() : rotation(k));
    e.w = eq::vec(m.w);
    e.alpha = eq::vec(m.alpha0);
    return e;
  }

  // The rows at the tree's last evaluation.
  void compute_rows();
};

void ConstraintEquations::Impl::compute_rows() {
  Bt.setZero();
  B_current = false;
  b.setZero();
  errors.setZero();
  for (auto& m : hinge_moment) m = {Vector3::Zero(), Vector3::Zero()};
  Directions directions;
  detail::ConstraintRows<double> out;
  for (size_t i = 0; i < model.constraints().size(); ++i) {
    const Constraint& c = model.constraints()[i];
    const int row = first[i];
    const bool two_points = c.type != ConstraintType::rolling_disc;
    const PointMotion p1 = point_motion(c.body, c.at);
    const PointMotion p2 = two_points ? point_motion(c.other, c.other_at) : PointMotion{};
    // The rows, written once for every scalar (src/constraint_rows.hpp), at z dot = 0: their
    // accelerations are {b}.
    detail::constraint_rows(c, {perpendiculars[i].p1, perpendiculars[i].p2}, end(c.body, p1),
                            end(two_points ? c.other : kGround, p2), out);
    const int count = out.linear_count + out.angular_count;
    for (int r = 0; r < count; ++r) {
      b[row + r] = out.acc[at(r)];
      errors[row + r] = out.err[at(r)];
    }
    directions.linear_count = out.linear_count;
    directions.angular_count = out.angular_count;
    for (int r = 0; r < out.linear_count; ++r) {
      directions.linear[at(r)] = eq::eigen(out.linear[at(r)]);
      bases[i].col(r) = directions.linear[at(r)];
    }
    for (int k = 0; k < out.angular_count; ++k) {
      directions.angular[at(k)] = eq::eigen(out.angular[at(k)]);
      hinge_moment[i][at(k)] = directions.angular[at(k)];
    }
    points[i] = eq::eigen(out.point);
    add_rows(c.body, p1, points[i], 1.0, directions, row);
    if (two_points) add_rows(c.other, p2, p2.p, -1.0, directions, row);
  }
}

ConstraintEquations::ConstraintEquations(const Model& model)
    : impl_(std::make_unique<Impl>(model)) {}
ConstraintEquations::ConstraintEquations(const ConstraintEquations& other)
    : impl_(std::make_unique<Impl>(other.impl_->model)) {}
ConstraintEquations::~ConstraintEquations() = default;
const Model& ConstraintEquations::model() const { return impl_->model; }
int ConstraintEquations::rows() const { return impl_->rows; }
int ConstraintEquations::holonomic_rows() const { return impl_->holonomic_count; }
bool ConstraintEquations::holonomic(int row) const { return impl_->holonomic[at(row)] != 0; }
int ConstraintEquations::first_row(int constraint) const { return impl_->first[at(constraint)]; }
int ConstraintEquations::constraint_of_row(int row) const { return impl_->owner[at(row)]; }
std::string ConstraintEquations::row_name(int row) const {
  const int c = constraint_of_row(row);
  return impl_->model.constraints()[at(c)].name + "." + std::to_string(row - first_row(c) + 1);
}
void ConstraintEquations::evaluate(const VectorX& q, const VectorX& z) {
  Impl& s = *impl_;
  s.own.kinematics(q, z);
  s.tree = &s.own;
  s.compute_rows();
}
void ConstraintEquations::evaluate(detail::JointDynamics& tree) {
  Impl& s = *impl_;
  s.tree = &tree;
  s.compute_rows();
  s.tree = &s.own;
}
const MatrixX& ConstraintEquations::B() const {
  const Impl& s = *impl_;
  if (!s.B_current) {
    s.B = s.Bt.transpose();
    s.B_current = true;
  }
  return s.B;
}
const MatrixX& ConstraintEquations::B_transpose() const { return impl_->Bt; }
const VectorX& ConstraintEquations::b() const { return impl_->b; }
const VectorX& ConstraintEquations::errors() const { return impl_->errors; }
const Vector3& ConstraintEquations::point(int constraint) const {
  return impl_->points[at(constraint)];
}

Vector3 ConstraintEquations::force(int constraint, const VectorX& lambda) const {
  const Impl& s = *impl_;
  const Constraint& c = s.model.constraints()[at(constraint)];
  const int row = s.first[at(constraint)];
  if (c.type == ConstraintType::distance) return lambda[row] * s.bases[at(constraint)].col(0);
  return s.bases[at(constraint)] * lambda.segment<3>(row);
}

Vector3 ConstraintEquations::moment(int constraint, const VectorX& lambda) const {
  const Impl& s = *impl_;
  const Constraint& c = s.model.constraints()[at(constraint)];
  if (c.type != ConstraintType::hinge || s.hinge_moment.empty()) return Vector3::Zero();
  const int row = s.first[at(constraint)] + 3;
  return s.hinge_moment[at(constraint)][0] * lambda[row] +
         s.hinge_moment[at(constraint)][1] * lambda[row + 1];
}

std::array<Vector3, 2> constraint_fixed_directions(const Constraint& c) {
  Vector3 t1 = Vector3::Zero(), t2 = Vector3::Zero();
  if (c.type == ConstraintType::hinge) normal_pair(c.other_axis, t1, t2);
  if (c.type == ConstraintType::rolling_disc) normal_pair(c.plane_normal, t1, t2);
  return {t1, t2};
}

int reaction_count(const Model& model) {
  int count = 0;
  for (const Constraint& c : model.constraints()) count += reaction_count(c.type);
  return count;
}

void constraint_reactions(const ConstraintEquations& equations, const VectorX& lambda,
                          Eigen::Ref<VectorX> out) {
  const Model& model = equations.model();
  if (out.size() != reaction_count(model))
    throw std::invalid_argument("constraint_reactions: out is not the model's reaction count");
  Eigen::Index i = 0;
  for (int k = 0; k < model.num_constraints(); ++k) {
    out.segment<3>(i) = equations.force(k, lambda);
    i += 3;
    if (model.constraints()[static_cast<size_t>(k)].type != ConstraintType::hinge) continue;
    out.segment<3>(i) = equations.moment(k, lambda);
    i += 3;
  }
}

// ---- Partition ----

namespace {

// Relative threshold of the rank decisions: a row or column whose pivot is below 1e-9 of the
// largest counts as dependent. Round-off in [B] is about 1e-16 of its entries, so a genuinely
// independent equation would need a conditioning of 1e9 to be taken for a redundant one.
constexpr double kRankThreshold = 1e-9;

// A complete orthogonal decomposition of `a` whose rank threshold is set before it is
// computed: Eigen forms the Z factor for the rank found at compute() time, so a threshold set
// afterwards can make solve() apply Z for a rank it never formed (reading coefficients never
// set: NaN in some builds, wrong numbers in others).
Eigen::CompleteOrthogonalDecomposition<MatrixX> rank_revealing(const MatrixX& a) {
  Eigen::CompleteOrthogonalDecomposition<MatrixX> cod(a.rows(), a.cols());
  cod.setThreshold(kRankThreshold);
  cod.compute(a);
  return cod;
}

[[noreturn]] void throw_independent_count(size_t given, int rank, int n) {
  std::ostringstream m;
  m << "independent_speeds: " << given << " speeds given, but the " << rank
    << " independent constraint equations leave " << n - rank << " speeds free";
  throw ConstraintError(m.str());
}

}  // namespace

void check_independent_count(const Model& model, const MatrixX& B) {
  const size_t given = model.independent_speeds().size();
  if (given == 0) return;
  int rank = 0;
  if (B.rows() > 0) {
    Eigen::ColPivHouseholderQR<MatrixX> qr(B.transpose());
    qr.setThreshold(kRankThreshold);
    rank = static_cast<int>(qr.rank());
  }
  const int n = static_cast<int>(B.cols());
  if (static_cast<int>(given) != n - rank) throw_independent_count(given, rank, n);
}

SpeedPartition partition_speeds(const Model& model, const MatrixX& B) {
  const int c = static_cast<int>(B.rows()), n = static_cast<int>(B.cols());
  SpeedPartition p;
  if (c == 0) {
    for (int i = 0; i < n; ++i) p.independent.push_back(i);
    return p;
  }
  // Independent rows: QR with column pivoting of [B]^T.
  Eigen::ColPivHouseholderQR<MatrixX> rows_qr(B.transpose());
  rows_qr.setThreshold(kRankThreshold);
  p.rank = static_cast<int>(rows_qr.rank());
  std::vector<char> kept(at(c), 0);
  for (int i = 0; i < p.rank; ++i) kept[at(rows_qr.colsPermutation().indices()[i])] = 1;
  for (int i = 0; i < c; ++i) (kept[at(i)] ? p.rows : p.redundant_rows).push_back(i);
  MatrixX Br(p.rank, n);
  for (int i = 0; i < p.rank; ++i) Br.row(i) = B.row(p.rows[at(i)]);
  std::vector<char> dependent(at(n), 0);
  if (!model.independent_speeds().empty()) {
    std::vector<char> independent(at(n), 0);
    for (const int i : model.independent_speeds()) independent[at(i)] = 1;
    for (int i = 0; i < n; ++i)
      if (!independent[at(i)]) dependent[at(i)] = 1;
  } else {
    Eigen::ColPivHouseholderQR<MatrixX> cols_qr(Br);
    for (int i = 0; i < p.rank; ++i) dependent[at(cols_qr.colsPermutation().indices()[i])] = 1;
  }
  for (int i = 0; i < n; ++i) (dependent[at(i)] ? p.dependent : p.independent).push_back(i);
  if (static_cast<int>(p.dependent.size()) != p.rank)
    throw_independent_count(p.independent.size(), p.rank, n);
  if (p.rank > 0) {
    MatrixX BD(p.rank, p.rank);
    for (int j = 0; j < p.rank; ++j) BD.col(j) = Br.col(p.dependent[at(j)]);
    Eigen::ColPivHouseholderQR<MatrixX> check(BD);
    check.setThreshold(kRankThreshold);
    if (check.rank() < p.rank)
      throw ConstraintError(
          "independent_speeds: the constraints do not determine the other speeds from "
          "these (their columns of [B] are dependent); choose others");
  }
  return p;
}

MatrixX independent_basis(const MatrixX& B, const SpeedPartition& p) {
  const int n = static_cast<int>(B.cols()), r = p.rank, ni = n - r;
  MatrixX BD(r, r), BI(r, ni);
  for (int i = 0; i < r; ++i) {
    for (int j = 0; j < r; ++j) BD(i, j) = B(p.rows[at(i)], p.dependent[at(j)]);
    for (int j = 0; j < ni; ++j) BI(i, j) = B(p.rows[at(i)], p.independent[at(j)]);
  }
  MatrixX CI = MatrixX::Zero(n, ni);
  for (int j = 0; j < ni; ++j) CI(p.independent[at(j)], j) = 1.0;
  if (r == 0) return CI;
  Eigen::ColPivHouseholderQR<MatrixX> qr(BD);
  qr.setThreshold(kRankThreshold);
  if (qr.rank() < r)
    throw ConstraintError(
        "the dependent speeds' columns of [B] are dependent at this state: the speed partition "
        "chosen elsewhere does not determine them here");
  const MatrixX D = qr.solve(BI);
  for (int i = 0; i < r; ++i) CI.row(p.dependent[at(i)]) = -D.row(i);
  return CI;
}

// ---- Projection ----

Projection project_onto_constraints(const Model& model, VectorX& q, VectorX& z, double tolerance) {
  if (model.num_constraints() == 0) return {};
  ConstraintEquations eq(model);
  return project_onto_constraints(eq, q, z, tolerance);
}

Projection project_onto_constraints(ConstraintEquations& eq, VectorX& q, VectorX& z,
                                    double tolerance) {
  Projection out;
  const Model& model = eq.model();
  if (model.num_constraints() == 0) return out;
  normalize_joint_coordinates(model, q);
  const int n = model.num_speeds();
  std::vector<int> hol;
  eq.evaluate(q, z);
  for (int i = 0; i < eq.rows(); ++i)
    if (eq.holonomic(i)) hol.push_back(i);
  for (const int i : hol) out.error_before = std::max(out.error_before, std::abs(eq.errors()[i]));
  const VectorX q0 = q;
  if (!hol.empty()) {
    // The dependent coordinates: pivot columns of the holonomic rows (d phi/dx = those rows of
    // [B] at x = 0, as the tangent rates are the speeds).
    MatrixX Bh(static_cast<Eigen::Index>(hol.size()), n);
    for (size_t r = 0; r < hol.size(); ++r)
      Bh.row(static_cast<Eigen::Index>(r)) = eq.B().row(hol[r]);
    // The coordinates of the dependent speeds when the model names the independent ones (the
    // step is then the least-squares one in them); else the pivot columns.
    std::vector<int> cols;
    if (!model.independent_speeds().empty()) {
      std::vector<char> independent(at(n), 0);
      for (const int i : model.independent_speeds()) independent[at(i)] = 1;
      for (int i = 0; i < n; ++i)
        if (!independent[at(i)]) cols.push_back(i);
    } else {
      Eigen::ColPivHouseholderQR<MatrixX> qr(Bh);
      qr.setThreshold(kRankThreshold);
      for (int i = 0; i < qr.rank(); ++i) cols.push_back(qr.colsPermutation().indices()[i]);
    }
    const int rank = static_cast<int>(cols.size());
    // Round-off in an error is about machine epsilon times the size of the coordinates
    // times the row's sensitivity to them (a joint angle of -8194 rad has a spacing of
    // 1.8e-12 rad): no step can remove that much, so a row's tolerance is never below it.
    const double q_scale = 1.0 + q.cwiseAbs().maxCoeff();
    VectorX floor(static_cast<Eigen::Index>(hol.size()));
    const auto error_floor = [&] {
      for (size_t r = 0; r < hol.size(); ++r)
        floor[static_cast<Eigen::Index>(r)] =
            std::max(tolerance, 16.0 * std::numeric_limits<double>::epsilon() * q_scale *
                                    eq.B().row(hol[r]).cwiseAbs().sum());
    };
    error_floor();
    const auto worst_excess = [&](int* worst) {
      double excess = 0.0, error = 0.0;
      for (size_t r = 0; r < hol.size(); ++r) {
        const double e = std::abs(eq.errors()[hol[r]]);
        const double x = e / floor[static_cast<Eigen::Index>(r)];
        if (x >= excess) {
          excess = x;
          error = e;
          *worst = hol[r];
        }
      }
      return std::pair{excess, error};
    };
    VectorX phi(static_cast<Eigen::Index>(hol.size()));
    double previous = std::numeric_limits<double>::infinity();
    for (;;) {
      int worst = 0;
      const auto [excess, e] = worst_excess(&worst);
      if (excess <= 1.0) break;
      if (rank == 0 || out.iterations >= 50 || !(e < 1e6 * std::max(1.0, previous))) {
        // A wrong count of given independent speeds leaves too few dependent coordinates to
        // remove the errors (none when every speed is named): that, not the state, is the
        // reason then. Checked here, where a projection fails, and not at every step's.
        if (!model.independent_speeds().empty()) check_independent_count(model, eq.B());
        std::ostringstream m;
        m << "constraint '" << model.constraints()[at(eq.constraint_of_row(worst))].name
          << "': the projection onto the constraints did not converge (error " << e << " after "
          << out.iterations << " Gauss-Newton steps)";
        throw ConstraintError(m.str());
      }
      previous = e;
      MatrixX J(static_cast<Eigen::Index>(hol.size()), rank);
      for (size_t r = 0; r < hol.size(); ++r) {
        phi[static_cast<Eigen::Index>(r)] = eq.errors()[hol[r]];
        for (int j = 0; j < rank; ++j)
          J(static_cast<Eigen::Index>(r), j) = eq.B()(hol[r], cols[at(j)]);
      }
      const VectorX step = Eigen::CompleteOrthogonalDecomposition<MatrixX>(J).solve(-phi);
      VectorX dx = VectorX::Zero(n);
      for (int j = 0; j < rank; ++j) dx[cols[at(j)]] = step[j];
      q = retract(model, q, dx);
      ++out.iterations;
      eq.evaluate(q, z);
      error_floor();
    }
    out.coordinate_change = tangent_difference(model, q0, q).cwiseAbs().maxCoeff();
  }
  // Speeds: the least change with [B] z = 0.
  const VectorX residual = eq.B() * z;
  const VectorX dz = rank_revealing(eq.B()).solve(residual);
  z -= dz;
  out.speed_change = dz.size() ? dz.cwiseAbs().maxCoeff() : 0.0;
  return out;
}

// ---- Constrained dynamics ----

namespace {

// The Cholesky factor L (lower triangle, in place; the reciprocals of its diagonal in
// inverse) of the symmetric positive definite a, or false when a pivot sqrt(d_j) is not above
// `least` (a singular or nearly singular a). Written out because the constraint space is small
// (a few rows): Eigen's blocked LLT of dynamic size costs several times the arithmetic there.
// Only the lower triangle of a is read. Each row is scaled by a reciprocal rather than
// divided, so that the c divisions are all that wait on one another.
bool cholesky_in_place(MatrixX& a, VectorX& inverse, double least) {
  const Eigen::Index c = a.rows();
  inverse.resize(c);
  double* const l = a.data();
  for (Eigen::Index j = 0; j < c; ++j) {
    double d = l[j + j * c];
    for (Eigen::Index k = 0; k < j; ++k) d -= l[j + k * c] * l[j + k * c];
    if (!(d > least * least)) return false;
    const double pivot = std::sqrt(d), reciprocal = 1.0 / pivot;
    l[j + j * c] = pivot;
    inverse[j] = reciprocal;
    for (Eigen::Index i = j + 1; i < c; ++i) {
      double v = l[i + j * c];
      for (Eigen::Index k = 0; k < j; ++k) v -= l[i + k * c] * l[j + k * c];
      l[i + j * c] = v * reciprocal;
    }
  }
  return true;
}

// x := (L L^T)^-1 x, L and the reciprocals of its diagonal from cholesky_in_place.
void cholesky_solve_in_place(const MatrixX& a, const VectorX& inverse, VectorX& x) {
  const Eigen::Index c = a.rows();
  const double* const l = a.data();
  for (Eigen::Index i = 0; i < c; ++i) {
    double v = x[i];
    for (Eigen::Index k = 0; k < i; ++k) v -= l[i + k * c] * x[k];
    x[i] = v * inverse[i];
  }
  for (Eigen::Index i = c - 1; i >= 0; --i) {
    double v = x[i];
    for (Eigen::Index k = i + 1; k < c; ++k) v -= l[k + i * c] * x[k];
    x[i] = v * inverse[i];
  }
}

}  // namespace

struct ConstrainedDynamics::Impl {
  Impl(const Model& m, Method how)
      : model(m), method(how), equations(m), terms(m), tree(m), n(m.num_speeds()) {
    M.resize(n, n);
    bias.resize(n);
    lambda = VectorX::Zero(equations.rows());
  }
  const Model& model;
  Method method;
  ConstraintEquations equations;
  Terms terms;
  detail::JointDynamics tree;  // the unconstrained tree's O(N) route
  int n;
  MatrixX M, Y, S, correction;
  VectorX bias, lambda, rhs;
  MatrixX factor;       // the Cholesky factor of S
  VectorX reciprocals;  // of its diagonal
  SpeedPartition partition;
  bool partitioned = false;
  int rank = 0;
  // Redundant rows: whether [B] has been found (or met) to have fewer independent rows than
  // rows, and the rank-revealing decomposition of [B]^T the multipliers then come from.
  bool rows_checked = false;
  bool redundant = false;
  Eigen::CompleteOrthogonalDecomposition<MatrixX> rows_cod;
  MatrixX Yr, Br_t;
  VectorX rhs_r, lambda_r;

  void redundant_multipliers(const MatrixX& Bt, Eigen::Ref<VectorX> zdot);

  void multipliers(const VectorX& q, const VectorX& z, const VectorX& u, Eigen::Ref<VectorX> zdot);
  void projected(const VectorX& q, const VectorX& z, const VectorX& u, Eigen::Ref<VectorX> zdot);
};

void ConstrainedDynamics::Impl::multipliers(const VectorX& q, const VectorX& z, const VectorX& u,
                                            Eigen::Ref<VectorX> zdot) {
  tree.set_inputs(u);
  tree.evaluate(q, z, Route::recursive, zdot);  // the tree without the constraints, O(N)
  equations.evaluate(tree);                     // the rows from the same kinematic terms
  // [B]^T: each row of [B] a contiguous column for the products below.
  const MatrixX& Bt = equations.B_transpose();
  const Eigen::Index c = Bt.cols();
  // Redundant rows are usually the mechanism's (a planar hinge's three), found at the first
  // evaluation, before a c x c system is formed; rows that become dependent later (a singular
  // pose) are found by the Cholesky factorization below failing. Either way, from then on.
  if (!rows_checked) {
    rows_checked = true;
    rows_cod.setThreshold(kRankThreshold);
    rows_cod.compute(Bt);
    redundant = rows_cod.rank() < c;
  }
  if (redundant) {
    redundant_multipliers(Bt, zdot);
    return;
  }
  // S = [B] M^-1 [B]^T (its lower triangle, all the Cholesky factorization reads) from the
  // articulated-body factorization the evaluation left: the inward pass over the c columns of
  // [B]^T, O(N c^2), no mass matrix and no outward pass.
  Y = Bt;
  tree.inverse_mass_gram(Y, S);
  // The right-hand side -b - [B] z dot_tree, by contiguous columns of [B]^T.
  rhs.resize(c);
  for (Eigen::Index i = 0; i < c; ++i) rhs[i] = -equations.b()[i] - Bt.col(i).dot(zdot);
  // Independent rows (the usual case): S is positive definite and its Cholesky factor gives
  // lambda. Redundant rows make it singular: redundant_multipliers() then works on the
  // independent rows alone.
  const double largest = c > 0 ? std::sqrt(S.diagonal().maxCoeff()) : 0.0;
  factor = S;
  if (c > 0 && cholesky_in_place(factor, reciprocals, 1e-6 * largest)) {
    lambda = rhs;
    cholesky_solve_in_place(factor, reciprocals, lambda);
    rank = static_cast<int>(c);
  } else {
    redundant = true;
    redundant_multipliers(Bt, zdot);
    return;
  }
  // z dot += M^-1 [B]^T lambda: one more solve, of one column.
  correction.noalias() = Bt * lambda;
  tree.solve_mass(correction);
  zdot += correction.col(0);
}

// With redundant rows the cost follows the rank r, not the row count c: a complete orthogonal
// decomposition of [B]^T (n x c, O(n c r)) picks r independent rows; their r x r system
// [B_r] M^-1 [B_r]^T lambda_r = -(b_r + [B_r] z dot_tree) gives the motion (any solution of
// the whole system gives the same [B]^T lambda), and the minimum-norm multipliers over all c
// rows are the minimum-norm solution of [B]^T lambda = [B_r]^T lambda_r, from the same
// decomposition. A mechanism with a thousand copies of one hinge costs about what one does.
void ConstrainedDynamics::Impl::redundant_multipliers(const MatrixX& Bt, Eigen::Ref<VectorX> zdot) {
  rows_cod.setThreshold(kRankThreshold);
  rows_cod.compute(Bt);
  const Eigen::Index r = rows_cod.rank();
  Yr.resize(Bt.rows(), r);
  rhs_r.resize(r);
  for (Eigen::Index j = 0; j < r; ++j) {
    const Eigen::Index row = rows_cod.colsPermutation().indices()[j];
    Yr.col(j) = Bt.col(row);
    rhs_r[j] = -equations.b()[row] - Bt.col(row).dot(zdot);
  }
  Br_t = Yr;
  tree.inverse_mass_gram(Yr, S);
  const double largest = r > 0 ? std::sqrt(S.diagonal().maxCoeff()) : 0.0;
  factor = S;
  lambda_r = rhs_r;
  if (r > 0 && cholesky_in_place(factor, reciprocals, 1e-9 * largest)) {
    cholesky_solve_in_place(factor, reciprocals, lambda_r);
  } else if (r > 0) {
    for (Eigen::Index i = 0; i < r; ++i)
      for (Eigen::Index j = i + 1; j < r; ++j) S(i, j) = S(j, i);
    lambda_r = rank_revealing(S).solve(rhs_r);
  }
  correction.noalias() = Br_t * lambda_r;
  lambda = rows_cod.solve(correction.col(0));
  rank = static_cast<int>(r);
  tree.solve_mass(correction);
  zdot += correction.col(0);
}

void ConstrainedDynamics::Impl::projected(const VectorX& q, const VectorX& z, const VectorX& u,
                                          Eigen::Ref<VectorX> zdot) {
  const MatrixX& B = equations.B();
  if (!partitioned) {
    partition = partition_speeds(model, B);
    partitioned = true;
  }
  // [C_I], and w, a particular solution of [B] z dot = -b (Kane's [C_I dot] z_I terms): z dot =
  // [C_I] z_I dot + w whichever w (two differ by a motion [C_I] absorbs); the minimum-norm one.
  MatrixX CI;
  try {
    CI = independent_basis(B, partition);
  } catch (const ConstraintError&) {
    // [B_D] singular here: choose the dependent speeds again (the motion does not depend on
    // the choice).
    partitioned = false;
    projected(q, z, u, zdot);
    return;
  }
  const int r = partition.rank;
  // One complete orthogonal decomposition of [B]^T serves w (its transposed solve, the
  // minimum-norm solution of [B] w = -b) and the reactions below.
  const Eigen::CompleteOrthogonalDecomposition<MatrixX> cod = rank_revealing(B.transpose());
  const VectorX w = cod.transpose().solve(-equations.b());
  terms.mass_matrix(q, M);
  terms.bias_forces(q, z, bias, u.size() ? &u : nullptr);
  const MatrixX Mhat = CI.transpose() * M * CI;
  const VectorX fhat = -CI.transpose() * (bias + M * w);
  const VectorX zi_dot = Mhat.llt().solve(fhat);
  zdot = CI * zi_dot + w;
  // The reactions from the dependent equations: [B]^T lambda = M z dot + b, least squares with
  // the minimum norm over redundant rows.
  const VectorX residual = M * zdot + bias;
  lambda = cod.solve(residual);
  rank = r;
}

ConstrainedDynamics::ConstrainedDynamics(const Model& model, Method method)
    : impl_(std::make_unique<Impl>(model, method)) {}
ConstrainedDynamics::~ConstrainedDynamics() = default;
ConstrainedDynamics::Method ConstrainedDynamics::method() const { return impl_->method; }

void ConstrainedDynamics::evaluate(const VectorX& q, const VectorX& z, const VectorX& u,
                                   Eigen::Ref<VectorX> zdot) {
  Impl& s = *impl_;
  if (s.method == Method::multipliers) {
    s.multipliers(q, z, u, zdot);
  } else {
    s.equations.evaluate(q, z);
    s.projected(q, z, u, zdot);
  }
}

const VectorX& ConstrainedDynamics::lambda() const { return impl_->lambda; }
const ConstraintEquations& ConstrainedDynamics::equations() const { return impl_->equations; }
const SpeedPartition& ConstrainedDynamics::partition() const {
  Impl& s = *impl_;
  if (!s.partitioned) {
    s.partition = partition_speeds(s.model, s.equations.B());
    s.partitioned = true;
  }
  return s.partition;
}
int ConstrainedDynamics::rank() const { return impl_->rank; }

}  // namespace kanedyn
