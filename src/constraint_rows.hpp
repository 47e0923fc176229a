// The rows of one constraint at a motion, written once for any scalar (docs/theory.md,
// "Constraints"): their directions (the relative velocity of the constraint's two points, or of
// a disc's contact point, along `linear`; the relative angular velocity along `angular`), their
// accelerations and their position errors. The double route (ConstraintEquations,
// src/constraints.cpp) takes the directions into [B] and the accelerations at z dot = 0 as {b};
// the generic passes of src/analysis.cpp (the dual-number derivatives) take the velocity,
// acceleration and position residuals at the motion. Adding a constraint type: its case here,
// its count in equation_count and its keys in the model reader.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "kanedyn/constraints.hpp"

#include "tree_loads.hpp"

namespace kanedyn::detail {

/// One end of a constraint: the point fixed in its body (or in the ground), and the body's
/// rotation [R] (inertial -> body), angular velocity and acceleration (inertial components;
/// the identity and zero for the ground).
template <typename S>
struct ConstraintEnd {
  tree::PointMotion<S> point;
  tree::M3<S> R;
  tree::V3<S> w, alpha;
};

/// The rows of one constraint: linear rows first, then angular (a hinge's last two). acc is
/// each row's d/dt of its velocity residual from the ends' accelerations (at z dot = 0: {b});
/// err its position error (zero for a nonholonomic row). point and r: where the rows' force
/// acts on the constraint's body, and that point from O_K (inertial); v_rel, w_rel: what the
/// velocity residuals read.
template <typename S>
struct ConstraintRows {
  std::array<tree::V3<S>, 3> linear;
  std::array<tree::V3<S>, 2> angular;
  int linear_count = 0, angular_count = 0;
  std::array<S, 5> acc, err;
  tree::V3<S> point, r, v_rel, w_rel;

  /// The velocity residual of row i: [B] z.
  S velocity(int i) const {
    return i < linear_count ? eq::dot(linear[static_cast<size_t>(i)], v_rel)
                            : eq::dot(angular[static_cast<size_t>(i - linear_count)], w_rel);
  }
};

/// The rows of constraint c between ends a (its body) and b (its other body, or the ground),
/// with its two fixed directions (constraint_fixed_directions). Throws ConstraintError where
/// they are undefined: a distance's points coinciding, a disc's axle along the plane's normal.
template <typename S>
void constraint_rows(const Constraint& c, const std::array<Vector3, 2>& fixed,
                     const ConstraintEnd<S>& a, const ConstraintEnd<S>& b, ConstraintRows<S>& out) {
  using tree::constant;
  using tree::value_of;
  using V3 = tree::V3<S>;
  const S zero{};
  const auto where = [&c] { return "constraint '" + c.name + "'"; };
  out.acc.fill(zero);
  out.err.fill(zero);
  out.angular_count = 0;
  out.w_rel = {zero, zero, zero};
  switch (c.type) {
    case ConstraintType::ball:
    case ConstraintType::hinge:
    case ConstraintType::distance: {
      const V3 d = a.point.p - b.point.p, arel = a.point.a - b.point.a;
      out.point = a.point.p;
      out.r = a.point.r;
      out.v_rel = a.point.v - b.point.v;
      if (c.type == ConstraintType::distance) {
        const S length = tree::norm_of(d);
        double size = value_of(length);
        if (!std::isfinite(size)) {  // past 1e154 the squares overflow
          const Vector3 dv(value_of(d.x), value_of(d.y), value_of(d.z));
          size = dv.stableNorm();
        }
        if (!(size > 1e-12 * std::max(1.0, c.length))) {
          std::ostringstream m;
          m.precision(3);
          m << where() << ": its two points are " << size << " apart";
          if (size == 0.0)
            m << " (they coincide)";
          else
            m << ", too close beside its length " << c.length;
          m << ", so the direction between them is undefined";
          throw ConstraintError(m.str());
        }
        const V3 e = (1.0 / length) * d;
        const S along = eq::dot(e, out.v_rel);
        out.linear[0] = e;
        out.linear_count = 1;
        out.acc[0] = (eq::dot(out.v_rel, out.v_rel) - along * along) / length + eq::dot(e, arel);
        out.err[0] = length - c.length;
      } else {
        const S one = zero + 1.0;
        out.linear = {V3{one, zero, zero}, V3{zero, one, zero}, V3{zero, zero, one}};
        out.linear_count = 3;
        out.acc = {arel.x, arel.y, arel.z, zero, zero};
        out.err = {d.x, d.y, d.z, zero, zero};
      }
      if (c.type == ConstraintType::hinge) {
        // The axis fixed in the body stays perpendicular to two directions fixed in the other:
        // rows (axis x e) . w_rel, errors axis . e.
        const V3 axis = eq::transpose_times(a.R, constant<S>(c.axis));
        out.w_rel = a.w - b.w;
        const V3 alpha_rel = a.alpha - b.alpha;
        const V3 axis_rate = eq::cross(a.w, axis);
        for (int k = 0; k < 2; ++k) {
          const V3 e = eq::transpose_times(b.R, constant<S>(fixed[static_cast<size_t>(k)]));
          const V3 m = eq::cross(axis, e);
          const V3 e_rate = eq::cross(b.w, e);
          out.angular[static_cast<size_t>(k)] = m;
          out.acc[static_cast<size_t>(3 + k)] =
              eq::dot(alpha_rel, m) +
              eq::dot(out.w_rel, eq::cross(axis_rate, e) + eq::cross(axis, e_rate));
          out.err[static_cast<size_t>(3 + k)] = eq::dot(axis, e);
        }
        out.angular_count = 2;
      }
      return;
    }
    case ConstraintType::rolling_disc: {
      // The contact point of a disc on a plane: from the centre along d, in the disc's plane
      // and down the plane's normal; its velocity as a point of the disc is zero (rows along
      // the normal, holonomic, and along the two fixed directions in the plane).
      const V3 axle = eq::transpose_times(a.R, constant<S>(c.axis));
      const V3 n = constant<S>(c.plane_normal);
      const V3 u = eq::cross(axle, n);
      const S s = tree::norm_of(u);
      if (!(value_of(s) > 1e-9))
        throw ConstraintError(where() +
                              ": the disc's axle is along the plane's normal, so its "
                              "contact point is undefined");
      const S an = eq::dot(axle, n);
      const V3 d = (1.0 / s) * (an * axle - n);
      const V3 rd = c.radius * d;
      out.point = a.point.p + rd;
      out.r = a.point.r + rd;
      out.v_rel = a.point.v + eq::cross(a.w, rd);
      // d moves over the disc: d dot from the axle's rate w x a (not w x d).
      const V3 a_rate = eq::cross(a.w, axle);
      const V3 u_rate = eq::cross(a_rate, n);
      const V3 d_rate = (1.0 / s) * (an * a_rate + eq::dot(a_rate, n) * axle) -
                        (eq::dot(u, u_rate) / (s * s)) * d;
      // d/dt of the disc point's velocity at the moving contact: a_C + alpha x (r d) +
      // w x (r d dot).
      const V3 acc = a.point.a + eq::cross(a.alpha, rd) + eq::cross(a.w, c.radius * d_rate);
      out.linear = {n, constant<S>(fixed[0]), constant<S>(fixed[1])};
      out.linear_count = 3;
      for (size_t i = 0; i < 3; ++i) out.acc[i] = eq::dot(out.linear[i], acc);
      out.err[0] = eq::dot(n, out.point) - c.plane_offset;
      return;
    }
  }
}

}  // namespace kanedyn::detail
