// Small constrained models shared by the constraint tests. Header-only (tests/CMakeLists.txt
// globs only tests/test_*.cpp).
#pragma once

#include <cmath>

#include "kanedyn/model.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn::test {

// A slender rod (mass kRodMass, length kRodLength: inertia m L^2 / 12 about its centre's x and
// y, a hundredth of that about its axis) as a free body held by a hinge about x at its top end
// O_K, which sits at the inertial origin; its mass centre L / 2 down its body z; gravity 9.81
// along -z.
inline constexpr double kRodMass = 2.0, kRodLength = 1.5, kRodGravity = 9.81;

inline Model hinged_rod() {
  BodySpec b;
  b.name = "rod";
  b.lower_body = kGround;
  b.mass = kRodMass;
  const double side = kRodMass * kRodLength * kRodLength / 12.0;
  b.inertia = Vector3(side, side, 0.01 * side).asDiagonal();
  b.com = Vector3(0, 0, -kRodLength / 2);
  b.joint = Vector3::Zero();
  Constraint c;
  c.name = "pin";
  c.type = ConstraintType::hinge;
  c.body = 0;
  c.at = Vector3::Zero();
  c.axis = Vector3::UnitX();
  c.other = kGround;
  c.other_at = Vector3::Zero();
  c.other_axis = Vector3::UnitX();
  return Model({b}, Vector3(0, 0, -kRodGravity), {}, "hinged rod", {}, {}, {}, {c});
}

// The hinged rod's (q, z) turned by theta about x, turning at rate omega (w' about body x =
// inertial x).
inline void hinged_rod_state(double theta, double omega, VectorX& q, VectorX& z) {
  q = VectorX::Zero(7);
  z = VectorX::Zero(6);
  q.head<4>() << std::sin(theta / 2), 0, 0, std::cos(theta / 2);
  z[0] = omega;
}

}  // namespace kanedyn::test
