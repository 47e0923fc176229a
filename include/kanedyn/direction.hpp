// The one rule for a direction (a joint's or a constraint's axis, an input's direction or
// axis), read by the model loader, the URDF import and the Model itself, so that none of them
// reads a direction another refuses, and none normalizes a vector whose norm overflows or
// underflows (docs/model-format.md, docs/urdf.md).
#pragma once

#include <optional>

#include "kanedyn/types.hpp"

namespace kanedyn {

/// A direction is three finite numbers, not all zero; its size does not matter ([1e-200, 0, 0]
/// and [1e200, 0, 0] are both the x axis). Returns `v` divided by its largest absolute
/// component (so its norm is in [1, sqrt(3)] and normalizing it neither overflows nor
/// underflows), or nothing when `v` is not a direction.
inline std::optional<Vector3> scaled_direction(const Vector3& v) {
  if (!v.allFinite()) return std::nullopt;
  const double largest = v.cwiseAbs().maxCoeff();
  if (largest == 0.0) return std::nullopt;
  return Vector3(v / largest);
}

/// The unit vector along `v` (scaled first, as scaled_direction), or nothing when `v` is not
/// a direction.
inline std::optional<Vector3> unit_direction(const Vector3& v) {
  std::optional<Vector3> u = scaled_direction(v);
  if (u) u->normalize();
  return u;
}

}  // namespace kanedyn
