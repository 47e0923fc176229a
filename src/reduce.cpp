// The reduced linearization (docs/analysis.md, "Steady motions: the reduced system").
//
// A motion with a symmetry (a group acting on the state that maps motions to motions: a
// translation of a free root body, its turn about the vertical, the spin of a body about its
// axis of symmetry, a wheel's angle) is steady when it is the operating point carried along the
// symmetry directions at constant rates: x0(t) = g(t) x0(0). In coordinates that move with g(t)
// the linearized motion is time-invariant,
//   y' = (A + T') y,  T' the rate of the change of coordinates at t = 0,
// and the symmetry directions X_j (the generators at x0) span an invariant subspace of it with
// zero eigenvalues: (A + T') X_j = 0. The quotient by that subspace is the reduced system: in
// the basis [X, E_R] (E_R the unit vectors of the kept entries) its matrix is L (A + T') E_R,
// with L = [I on the kept entries, -G_R G_P^-1 on the dropped ones], G_P the generators' rows at
// the dropped entries (the pivots).
//
// Body-K components of a free body's rotation vector r and angular velocity w turn with the
// body: a body spinning at s about its axis a has, in the frame spinning with it, r' = E r and
// w' = E w with E = exp(s t [a~]), so T' = s [a~] on both. A turn about the vertical n at the
// rate W leaves r and w alone (they are body-K components) and turns the inertial translation
// rate: T' = -W [n~] on s'_K dot.
#include "kanedyn/reduce.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "kanedyn/joints.hpp"
#include "kanedyn/rotation.hpp"

namespace kanedyn {

namespace {

size_t at(int i) { return static_cast<size_t>(i); }

enum class Kind { coordinate, heading, spin };

const char* kind_name(Kind k) {
  switch (k) {
    case Kind::heading:
      return "heading";
    case Kind::spin:
      return "spin";
    case Kind::coordinate:
      break;
  }
  return "coordinate";
}

// A symmetry direction: its generator in the full tangent (2n: dx, dz), and its body and axis
// (body-K components for spin, inertial for heading) for the change of coordinates.
struct Candidate {
  Kind kind = Kind::coordinate;
  int body = -1;
  Vector3 axis = Vector3::Zero();
  VectorX full;   ///< 2n
  VectorX state;  ///< its entries at the linearization's state
};

bool is_free(const Model& model, int k) { return model.joint(k).type == JointType::free; }

// The vertical: the rolling plane's normal when every rolling disc rolls on planes of one
// normal, else against gravity; zero when neither says.
Vector3 vertical(const Model& model) {
  Vector3 n = Vector3::Zero();
  for (const Constraint& c : model.constraints()) {
    if (c.type != ConstraintType::rolling_disc) continue;
    if (n.isZero(0.0))
      n = c.plane_normal;
    else if ((n - c.plane_normal).norm() > 1e-12)
      return Vector3::Zero();
  }
  if (!n.isZero(0.0)) return n.normalized();
  const double g = model.gravity().norm();
  return g > 0.0 ? Vector3(-model.gravity() / g) : Vector3::Zero();
}

// A body's axis of symmetry (body-K components): the principal axis of its inertia whose
// moment differs from the two equal others, with the mass centre on it; for equal moments the
// axle of a rolling disc on the body. Zero when it has none.
Vector3 symmetry_axis(const Model& model, int k) {
  const BodySpec& b = model.body(k);
  Eigen::SelfAdjointEigenSolver<Matrix3> eig(b.inertia);
  const Vector3 p = eig.eigenvalues();
  const double tol = 1e-12 * p.cwiseAbs().maxCoeff();
  Vector3 axis = Vector3::Zero();
  const bool low_pair = std::abs(p[0] - p[1]) <= tol, high_pair = std::abs(p[1] - p[2]) <= tol;
  if (low_pair && high_pair) {
    for (const Constraint& c : model.constraints())
      if (c.type == ConstraintType::rolling_disc && c.body == k) axis = c.axis;
  } else if (low_pair) {
    axis = eig.eigenvectors().col(2);
  } else if (high_pair) {
    axis = eig.eigenvectors().col(0);
  }
  if (axis.isZero(0.0) || b.com.cross(axis).norm() > 1e-12 * std::max(1.0, b.com.norm()))
    return Vector3::Zero();
  return axis.normalized();
}

Matrix3 orientation(const Model& model, const VectorX& q, int k) {
  return rotation_matrix(q.segment<4>(model.coordinate_offset(k)));  // inertial -> body K
}

// The candidates: every coordinate entry that is not part of a rotation vector; each free root
// body's turn about the vertical (with its free descendants, whose orientations are absolute);
// each childless free body's spin about its axis of symmetry.
std::vector<Candidate> candidates(const Model& model, const Linearization& lin,
                                  const std::vector<int>& full_of, int coordinates) {
  const int n = model.num_speeds();
  std::vector<Candidate> out;
  std::vector<char> rotation(at(n), 0);
  for (int k = 0; k < model.num_bodies(); ++k) {
    const JointType t = model.joint(k).type;
    if (t == JointType::free || t == JointType::spherical)
      for (int c = 0; c < 3; ++c) rotation[at(model.speed_offset(k) + c)] = 1;
  }
  // A coordinate's column must vanish outside the rows of the other candidates; the rows that
  // the moving coordinates change, and the rotation rows a turn may replace, are left to the
  // full check.
  std::vector<char> candidate(at(static_cast<int>(lin.state.size())), 0),
      checked_later(candidate.size(), 0);
  for (int i = 0; i < coordinates; ++i) candidate[at(i)] = !rotation[at(full_of[at(i)])];
  const Vector3 up = vertical(model);
  std::vector<char> moving(at(2 * n), 0);  // the rows the moving coordinates change
  for (int k = 0; k < model.num_bodies(); ++k) {
    if (!is_free(model, k)) continue;
    const int p = model.speed_offset(k);
    if (model.children(k).empty() && !symmetry_axis(model, k).isZero(0.0))
      for (int c = 0; c < 3; ++c) moving[at(p + c)] = moving[at(n + p + c)] = 1;
    if (model.lower_body(k) == kGround && !up.isZero(0.0))
      for (int c = 0; c < 3; ++c) moving[at(p + c)] = moving[at(n + p + 3 + c)] = 1;
  }
  for (size_t i = 0; i < candidate.size(); ++i) checked_later[i] = moving[at(full_of[i])];
  const double scale = std::max(1.0, lin.A.cwiseAbs().rowwise().sum().maxCoeff());
  for (bool changed = true; changed;) {
    changed = false;
    for (int i = 0; i < coordinates; ++i) {
      if (!candidate[at(i)]) continue;
      for (Eigen::Index r = 0; r < lin.A.rows(); ++r)
        if (!candidate[at(static_cast<int>(r))] && !checked_later[at(static_cast<int>(r))] &&
            std::abs(lin.A(r, i)) > kIgnorableTolerance * scale) {
          candidate[at(i)] = 0;
          changed = true;
          break;
        }
    }
  }
  for (int i = 0; i < coordinates; ++i) {
    if (!candidate[at(i)]) continue;
    Candidate c;
    c.full = VectorX::Zero(2 * n);
    c.full[full_of[at(i)]] = 1.0;
    out.push_back(c);
  }
  for (int k = 0; k < model.num_bodies(); ++k) {
    if (!is_free(model, k)) continue;
    const int p = model.speed_offset(k);
    if (model.lower_body(k) == kGround && !up.isZero(0.0)) {
      Candidate c;
      c.kind = Kind::heading;
      c.body = k;
      c.axis = up;
      c.full = VectorX::Zero(2 * n);
      for (int d = k; d < model.num_bodies(); ++d)
        if ((d == k || model.on_chain(k, d)) && is_free(model, d))
          c.full.segment<3>(model.speed_offset(d)) = orientation(model, lin.q, d) * up;
      c.full.segment<3>(n + p + 3) = up.cross(Vector3(lin.z.segment<3>(p + 3)));
      out.push_back(c);
    }
    const Vector3 a = symmetry_axis(model, k);
    if (model.children(k).empty() && !a.isZero(0.0)) {
      Candidate c;
      c.kind = Kind::spin;
      c.body = k;
      c.axis = a;
      c.full = VectorX::Zero(2 * n);
      c.full.segment<3>(p) = a;
      c.full.segment<3>(n + p) = Vector3(lin.z.segment<3>(p)).cross(a);
      out.push_back(c);
    }
  }
  return out;
}

// The rate of the change to moving coordinates for the candidates' rates, as 3 x 3 blocks on
// the diagonal of the full tangent (2n x 2n): (first row and column, block).
std::vector<std::pair<int, Matrix3>> moving_frame_rate(const Model& model,
                                                       const std::vector<Candidate>& cs,
                                                       const std::vector<double>& rates) {
  const int n = model.num_speeds();
  std::vector<std::pair<int, Matrix3>> T;
  for (size_t j = 0; j < cs.size(); ++j) {
    if (rates[j] == 0.0 || cs[j].kind == Kind::coordinate) continue;
    const int p = model.speed_offset(cs[j].body);
    if (cs[j].kind == Kind::spin) {
      const Matrix3 s = rates[j] * skew(cs[j].axis);
      T.emplace_back(p, s);
      T.emplace_back(n + p, s);
    } else {
      T.emplace_back(n + p + 3, -rates[j] * skew(cs[j].axis));
    }
  }
  return T;
}

// Pivots: for each generator in turn the coordinate entry where what is left of it (after the
// earlier pivots are eliminated) is largest. -1 for a generator that the earlier ones span.
std::vector<int> pivots(const MatrixX& G, int coordinates) {
  MatrixX g = G;
  std::vector<int> out;
  std::vector<char> used(at(static_cast<int>(G.rows())), 0);
  for (Eigen::Index j = 0; j < g.cols(); ++j) {
    int best = -1;
    double size = 0.0;
    for (int i = 0; i < coordinates; ++i)
      if (!used[at(i)] && std::abs(g(i, j)) > size) {
        size = std::abs(g(i, j));
        best = i;
      }
    if (best < 0 || size <= 1e-6 * G.col(j).cwiseAbs().maxCoeff()) {
      out.push_back(-1);
      continue;
    }
    used[at(best)] = 1;
    out.push_back(best);
    for (Eigen::Index l = j + 1; l < g.cols(); ++l)
      g.col(l) -= (g(best, l) / g(best, j)) * g.col(j);
  }
  return out;
}

}  // namespace

namespace {

// The dropped directions and the quotient: the pivots P (dropped entries), the kept entries R,
// C = G_R G_P^-1 (so that L x = x_R - C x_P) and A + T' (the moving coordinates' rate matrix).
struct Quotient {
  std::vector<Candidate> generators;
  std::vector<int> pivots, kept;
  std::vector<double> rates;
  MatrixX C, At;
  VectorX rate;  ///< the state's rate at the operating point
  /// L m: the quotient's coordinates of each column of m.
  MatrixX apply(const MatrixX& m) const {
    MatrixX out(static_cast<Eigen::Index>(kept.size()), m.cols());
    // No columns (B of a model without inputs): a row of no storage would be an offset from a
    // null pointer.
    if (m.cols() == 0) return out;
    for (size_t i = 0; i < kept.size(); ++i) out.row(static_cast<Eigen::Index>(i)) = m.row(kept[i]);
    if (!pivots.empty()) {
      MatrixX mp(static_cast<Eigen::Index>(pivots.size()), m.cols());
      for (size_t j = 0; j < pivots.size(); ++j)
        mp.row(static_cast<Eigen::Index>(j)) = m.row(pivots[j]);
      out -= C * mp;
    }
    return out;
  }
};

Quotient quotient(const Model& model, const Linearization& lin) {
  const int n = model.num_speeds();
  const int N = static_cast<int>(lin.state.size());
  const int coordinates = N - lin.n;
  // The state's entries in the full tangent (2n), by name.
  const std::vector<std::string> names = tangent_state_names(model);
  std::vector<int> full_of;
  for (const std::string& s : lin.state)
    full_of.push_back(static_cast<int>(std::find(names.begin(), names.end(), s) - names.begin()));
  const bool whole = lin.full_state.size() == 0;  // the state is the full tangent
  const auto restrict = [&](const VectorX& full) {
    VectorX v(N);
    for (int i = 0; i < N; ++i) v[i] = full[full_of[at(i)]];
    return v;
  };
  Quotient out;
  VectorX full_rate(2 * n);
  full_rate << lin.z, lin.zdot;
  out.rate = restrict(full_rate);
  const double scale = std::max(1.0, lin.A.cwiseAbs().rowwise().sum().maxCoeff());

  std::vector<Candidate>& cs = out.generators;
  for (Candidate& c : candidates(model, lin, full_of, coordinates)) {
    c.state = restrict(c.full);
    // A symmetry moves along the constraints: the state's entries give back the whole.
    if (whole || (lin.full_state * c.state - c.full).cwiseAbs().maxCoeff() <=
                     kIgnorableTolerance * std::max(1.0, c.full.cwiseAbs().maxCoeff()))
      cs.push_back(std::move(c));
  }
  for (;;) {
    const int k = static_cast<int>(cs.size());
    MatrixX G(N, k);
    for (int j = 0; j < k; ++j) G.col(j) = cs[at(j)].state;
    out.pivots = pivots(G, coordinates);
    if (const auto bad = std::find(out.pivots.begin(), out.pivots.end(), -1);
        bad != out.pivots.end()) {
      cs.erase(cs.begin() + (bad - out.pivots.begin()));
      continue;
    }
    std::vector<char> dropped(at(N), 0);
    for (const int p : out.pivots) dropped[at(p)] = 1;
    out.kept.clear();
    for (int i = 0; i < N; ++i)
      if (!dropped[at(i)]) out.kept.push_back(i);
    const int r = static_cast<int>(out.kept.size());
    MatrixX GP(k, k), GR(r, k);
    for (int j = 0; j < k; ++j) GP.row(j) = G.row(out.pivots[at(j)]);
    // With no directions G has no columns, and a row of no storage would be an offset from a
    // null pointer.
    if (k > 0)
      for (int i = 0; i < r; ++i) GR.row(i) = G.row(out.kept[at(i)]);
    const Eigen::PartialPivLU<MatrixX> lu(GP);
    // The rates along the directions: the pivots' rows of the state's rate.
    VectorX rate_p(k);
    for (int j = 0; j < k; ++j) rate_p[j] = out.rate[out.pivots[at(j)]];
    const VectorX c = k > 0 ? VectorX(lu.solve(rate_p)) : VectorX();
    out.rates.assign(c.data(), c.data() + c.size());
    out.C = k > 0 ? MatrixX(GR * lu.inverse()) : MatrixX::Zero(r, 0);
    // A + S T' F: S the state's rows of the full tangent, F the full tangent of a state.
    out.At = lin.A;
    for (const auto& [first, block] : moving_frame_rate(model, cs, out.rates))
      for (int i = 0; i < N; ++i) {
        const int row = full_of[at(i)] - first;
        if (row < 0 || row >= 3) continue;
        if (whole) {
          for (int c = 0; c < 3; ++c) out.At(i, first + c) += block(row, c);
        } else {
          out.At.row(i) += block.row(row) * lin.full_state.middleRows(first, 3);
        }
      }
    // Keep the directions on which the reduced rates do not depend: L (A + T') X_j = 0.
    const MatrixX moved = out.apply(out.At * G);
    std::vector<Candidate> kept_cs;
    for (int j = 0; j < k; ++j)
      if (moved.col(j).cwiseAbs().maxCoeff() <=
          kIgnorableTolerance * scale * G.col(j).cwiseAbs().maxCoeff())
        kept_cs.push_back(cs[at(j)]);
    if (kept_cs.size() == cs.size()) break;
    cs = std::move(kept_cs);
  }
  return out;
}

}  // namespace

std::vector<DroppedCoordinate> ignorable_coordinates(const Model& model, const Linearization& lin) {
  const Quotient q = quotient(model, lin);
  std::vector<DroppedCoordinate> out;
  for (size_t j = 0; j < q.generators.size(); ++j)
    out.push_back({q.pivots[j], lin.state[at(q.pivots[j])], kind_name(q.generators[j].kind)});
  return out;
}

ReducedLinearization reduce(const Model& model, const Linearization& lin, bool modes) {
  const Quotient q = quotient(model, lin);
  ReducedLinearization red;
  for (size_t j = 0; j < q.generators.size(); ++j)
    red.dropped.push_back(
        {q.pivots[j], lin.state[at(q.pivots[j])], kind_name(q.generators[j].kind)});
  red.kept = q.kept;
  for (const int i : red.kept) red.state.push_back(lin.state[at(i)]);
  red.rates = q.rates;
  const int N = static_cast<int>(lin.state.size()), r = static_cast<int>(red.kept.size());
  red.lift = MatrixX::Zero(N, r);
  for (int i = 0; i < r; ++i) red.lift(red.kept[at(i)], i) = 1.0;
  MatrixX AtR(N, r);  // (A + T') E_R: the kept columns
  for (int i = 0; i < r; ++i) AtR.col(i) = q.At.col(red.kept[at(i)]);
  red.A = q.apply(AtR);
  red.B = q.apply(lin.B);
  const VectorX reduced_rate = q.apply(q.rate);
  red.reduced_rate = reduced_rate.size() ? reduced_rate.cwiseAbs().maxCoeff() : 0.0;
  red.steady =
      red.reduced_rate <=
      kIgnorableTolerance * std::max(1.0, q.rate.size() ? q.rate.cwiseAbs().maxCoeff() : 0.0);
  red.eigenvalues = sorted_eigenvalues(red.A, modes ? &red.modes : nullptr);
  return red;
}

}  // namespace kanedyn
