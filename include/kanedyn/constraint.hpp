// What a constraint is (docs/model-format.md, "Constraints"): bodies joined beyond the tree, a
// closed loop or a wheel rolling without slip. Each constraint is a set of equations in the
// speeds, [B]{z} = 0 (docs/theory.md, "Constraints"); constraints.hpp evaluates them.
#pragma once

#include <string>

#include "kanedyn/types.hpp"

namespace kanedyn {

enum class ConstraintType {
  rolling_disc,  ///< a thin disc on a plane, no slip: 3 equations (1 holonomic, 2 not)
  ball,          ///< a point of `body` and a point of `other` coincide: 3, holonomic
  hinge,         ///< a ball, and `axis` stays parallel to `other_axis`: 5, holonomic
  distance,      ///< two points stay `length` apart: 1, holonomic
};

/// "rolling_disc", "ball", "hinge", "distance".
const char* to_string(ConstraintType type);

/// One constraint. Body indices are 0-based; `other` may be kGround.
struct Constraint {
  std::string name;  ///< unique among constraints, [A-Za-z0-9_-]+
  ConstraintType type = ConstraintType::ball;
  int body = 0;  ///< the body K the constraint acts on (its reaction is reported on K)
  /// ball, hinge, distance: the point, from O_K, body-K components. rolling_disc: the disc's
  /// centre C.
  Vector3 at = Vector3::Zero();
  /// hinge: the axis in body-K components; rolling_disc: the axle. Normalized by the Model.
  Vector3 axis = Vector3::UnitZ();
  double radius = 0.0;                      ///< rolling_disc: > 0
  Vector3 plane_normal = Vector3::UnitZ();  ///< rolling_disc: n, inertial, normalized
  double plane_offset = 0.0;                ///< rolling_disc: the plane n . p = offset
  int other = kGround;                      ///< ball, hinge, distance: the other body
  Vector3 other_at = Vector3::Zero();       ///< from other's O (ground: inertial origin)
  Vector3 other_axis = Vector3::UnitZ();    ///< hinge: in other's components, normalized
  double length = 0.0;                      ///< distance: > 0
};

/// Number of equations of a constraint of this type (3, 3, 5, 1).
int equation_count(ConstraintType type);

/// Number of reaction columns a constraint of this type has in the trajectory CSV: its force
/// on `body` (3), and for a hinge its moment too (6).
int reaction_count(ConstraintType type);

}  // namespace kanedyn
