// The joint of one body (docs/theory.md, "Joints"): its type, frame and axes, and the sizes of
// its slices of the joint coordinates q and independent speeds z. Every body of a Model has
// one; free, the default, is the notes' own body.
//
// Layout of q and z, body by body in numbering order (index k):
//   free:        q = (eps_K (4), s'_K (3)),  z = (w'_K (3), s'_K dot (3))  -- the notes' own
//   weld:        q = (),                     z = ()
//   revolute:    q = (angle),                z = (d angle/dt)
//   prismatic:   q = (d),                    z = (dd/dt)
//   cylindrical: q = (angle, d),             z = (d angle/dt, dd/dt)
//   universal:   q = (a1, a2),               z = (da1/dt, da2/dt)
//   spherical:   q = (e1, e2, e3, e4) of K relative to F, z = angular velocity of K relative
//                to J, body-K components (the spec's `joint_rate`)
//   planar:      q = (x, y, angle),          z = (dx/dt, dy/dt, d angle/dt): x, y along F's x
//                and y axes, the turn about F's z axis
//   screw:       q = (angle),                z = (d angle/dt): the turn about the axis and
//                pitch * angle along it
// Each type is one row of the joint table (src/joint_table.hpp): its counts, the keys it takes
// and its motion for any scalar.
// Angles in radians, lengths in model units, rates per second.
#pragma once

#include <array>
#include <string>

#include "kanedyn/types.hpp"

namespace kanedyn {

// Every joint type, in the order of the enum: one entry per row of the joint table
// (src/joint_table.hpp), the one list that readers, messages and tests iterate over.
#define KANEDYN_JOINT_TYPES(X) \
  X(free)                      \
  X(weld) X(revolute) X(prismatic) X(cylindrical) X(universal) X(spherical) X(planar) X(screw)

#define KANEDYN_JOINT_TYPE_ENTRY(name) name,
enum class JointType { KANEDYN_JOINT_TYPES(KANEDYN_JOINT_TYPE_ENTRY) };
#undef KANEDYN_JOINT_TYPE_ENTRY

#define KANEDYN_JOINT_TYPE_ENTRY(name) JointType::name,
inline constexpr JointType kJointTypes[] = {KANEDYN_JOINT_TYPES(KANEDYN_JOINT_TYPE_ENTRY)};
#undef KANEDYN_JOINT_TYPE_ENTRY

/// What a joint type is, as the model reader and writer, `info`, the frames, the outputs and the
/// algorithms ask it: its row of the joint table (src/joint_table.hpp), without the motion.
struct JointTypeInfo {
  const char* name;        ///< as the model format spells it
  int coordinates;         ///< entries of the body's slice of q
  int speeds;              ///< entries of its slice of z
  const char* meaning;     ///< what q holds, for `info`
  bool takes_axis;         ///< the `axis` key (required)
  bool takes_axes;         ///< the `axes` key of two perpendicular axes (required)
  bool takes_pitch;        ///< the `pitch` key (required)
  bool takes_frame;        ///< the `frame` key (every type but free)
  bool euler;              ///< q begins with 4 Euler parameters (free: eps_K; spherical: K rel. F)
  bool absolute;           ///< the notes' own body: q = (eps_K, s'_K), z = (w'_K, s'_K dot)
  bool slides;             ///< s'_K may move with q ([T_K] has columns)
  bool turns;              ///< K may turn relative to J ([G_K] has columns)
  bool turning_axis;       ///< [G_K]'s first column turns with q ([G_K dot] z_K is not zero)
  bool fixed_translation;  ///< a constant s'_K, `initial.translation` (weld)
};

/// The row of `type`.
const JointTypeInfo& joint_type_info(JointType type);

/// Whether the joint's q holds Euler parameters of K relative to F (spherical), as opposed to
/// the notes' own free body, whose eps_K are absolute.
inline bool relative_euler_joint(JointType type) {
  return joint_type_info(type).euler && !joint_type_info(type).absolute;
}

/// "free", "weld", "revolute", ... as the model format spells them.
const char* to_string(JointType type);

/// The joint of body K at Q_K, relative to J = L(K) (the inertial frame for a root).
struct Joint {
  JointType type = JointType::free;
  /// The joint frame F as Euler parameters of F relative to J (e4 scalar, unit): J's axes turned
  /// into F's, so [R(frame)] maps body-J components to F components. Unused by free joints; a
  /// planar joint's plane is F's x-y plane.
  Vector4 frame{0.0, 0.0, 0.0, 1.0};
  /// Revolute, prismatic, cylindrical, screw: the axis in F components (normalized by the
  /// Model).
  Vector3 axis = Vector3::UnitX();
  /// Universal: a1, a2 in F components (normalized by the Model), perpendicular.
  std::array<Vector3, 2> axes{Vector3::UnitX(), Vector3::UnitY()};
  /// Weld: the constant s'_K, body-J components.
  Vector3 translation = Vector3::Zero();
  /// Screw: the translation along the axis per radian of turn (length units per radian).
  double pitch = 0.0;
};

/// Entries of a body's slice of q: 7 for free (eps_K, s'_K), 0 weld, 1 revolute, prismatic and
/// screw, 2 cylindrical and universal, 4 spherical, 3 planar.
int coordinate_count(JointType type);
/// Entries of a body's slice of z: 6 free, 0 weld, 1 revolute, prismatic and screw, 2
/// cylindrical and universal, 3 spherical and planar.
int speed_count(JointType type);
/// Whether z_K = dq_K/dt entry by entry (a joint with coordinates, as many as speeds: revolute,
/// prismatic, cylindrical, universal, planar, screw): the joints that joint_spring and
/// joint_force act on.
bool speeds_are_coordinate_rates(JointType type);

/// The problem with a joint description, or "" when it is usable: a zero axis, universal axes
/// zero or not perpendicular (|a1 . a2| > 1e-9 after normalizing), frame Euler parameters off
/// unit norm by more than 1e-6, a pitch that is not finite.
std::string check_joint(const Joint& joint);
/// The problem with one body's slice of q, or "": a wrong count, or Euler parameters (a
/// spherical q, a free body's eps_K) whose norm is off 1 by more than 1e-6.
std::string check_joint_coordinates(JointType type, const VectorX& q);
/// The problem with one body's slice of z (its `joint_rate`), or "": a wrong count.
std::string check_joint_rates(JointType type, const VectorX& z);

}  // namespace kanedyn
