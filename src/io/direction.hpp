// The one rule for an axis, shared by the model loader (model_file.cpp) and the URDF import
// (urdf.cpp), so that the import never writes an axis the loader refuses or refuses one the
// loader reads (docs/model-format.md, docs/urdf.md).
#pragma once

#include <optional>

#include "kanedyn/types.hpp"

namespace kanedyn::io::detail {

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

}  // namespace kanedyn::io::detail
