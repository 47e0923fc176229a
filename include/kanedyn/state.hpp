// State: x = (eps, s') and y = (w', s' dot) in the layout of Eq. (1). Nothing else lives here.
#pragma once

#include "kanedyn/model.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn {

/// The system state of Eq. (1):
///   {x} (7N) = ({eps_1} .. {eps_N}, {s'_1} .. {s'_N}),
///   {y} (6N) = ({w'_1} .. {w'_N}, {s'_1 dot} .. {s'_N dot}).
/// eps_K = (e1, e2, e3, e4), e4 scalar; w'_K in body-K components; s'_K and its rate in
/// body-J components (J = L(K); inertial for a root).
struct State {
  VectorX x;
  VectorX y;

  State() = default;
  /// Zero state of N bodies: identity orientations (e4 = 1), zero translations and speeds.
  explicit State(int num_bodies);
  explicit State(const Model& model) : State(model.num_bodies()) {}

  int num_bodies() const { return static_cast<int>(y.size() / 6); }

  // Named per-body views (k is the 0-based body index).
  auto euler_parameters(int k) { return x.segment<4>(4 * k); }
  auto euler_parameters(int k) const { return x.segment<4>(4 * k); }
  auto translation(int k) { return x.segment<3>(4 * num_bodies() + 3 * k); }
  auto translation(int k) const { return x.segment<3>(4 * num_bodies() + 3 * k); }
  auto angular_velocity(int k) { return y.segment<3>(3 * k); }
  auto angular_velocity(int k) const { return y.segment<3>(3 * k); }
  auto translation_rate(int k) { return y.segment<3>(3 * num_bodies() + 3 * k); }
  auto translation_rate(int k) const { return y.segment<3>(3 * num_bodies() + 3 * k); }

  // The partitions of Eq. (1).
  auto x1() { return x.head(4 * num_bodies()); }  ///< {eps}
  auto x1() const { return x.head(4 * num_bodies()); }
  auto x2() { return x.tail(3 * num_bodies()); }  ///< {s'}
  auto x2() const { return x.tail(3 * num_bodies()); }
  auto y1() { return y.head(3 * num_bodies()); }  ///< {w'}
  auto y1() const { return y.head(3 * num_bodies()); }
  auto y2() { return y.tail(3 * num_bodies()); }  ///< {s' dot}
  auto y2() const { return y.tail(3 * num_bodies()); }

  /// Rescales every eps_K to unit norm; returns the largest | |eps_K| - 1 | found before.
  double normalize_euler_parameters();
};

/// Speed index of w'_K component i (0..2) in {y}, and of s'_K dot component i.
inline int speed_index_w(int num_bodies, int k, int i = 0) {
  (void)num_bodies;
  return 3 * k + i;
}
inline int speed_index_sdot(int num_bodies, int k, int i = 0) { return 3 * num_bodies + 3 * k + i; }

}  // namespace kanedyn
