// The peer comparison's common language: a model and state described in plain numbers (no
// kanedyn or Eigen types, so that each engine's translation unit can be compiled with the
// flags its library needs, e.g. Simbody's without NDEBUG), and the interface every engine
// implements.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace peers {

using Vec3 = std::array<double, 3>;
using Quat = std::array<double, 4>;  ///< (w, x, y, z), Hamilton convention, w scalar
using Mat3 = std::array<double, 9>;  ///< row-major

/// One body K of the notes (0-based index k = K-1).
struct Body {
  std::string name;
  int parent = -1;  ///< L(K) as a 0-based index, -1 for the ground
  double mass = 0;  ///< m_K
  Mat3 inertia{};   ///< about G_K, body-K axes
  Vec3 com{};       ///< r'_K, O_K to G_K, body-K axes
  Vec3 joint{};     ///< q'_K, O_J to Q_K, body-J axes (inertial for a root)
  Vec3 k{}, c{};    ///< summed bushing stiffness / damping on s'_K (J axes); 0 if none
  double kr = 0;    ///< summed rotational bushing stiffness
  double cr = 0;    ///< summed rotational bushing damping
  Vec3 force{};     ///< summed constant force at G_K, inertial
  Vec3 torque_b{};  ///< summed constant moment, body-K axes
};

/// The state of body K relative to its lower body J (the ground for a root), in the forms
/// the engines' joint coordinates take.
struct BodyState {
  Quat q_rel{};    ///< rotation taking J's axes into K's: R(q_rel) maps K components to J's
  Vec3 s{};        ///< s'_K, J axes
  Vec3 s_dot{};    ///< s'_K dot, J axes
  Vec3 w_rel_k{};  ///< w_K - w_J, K axes
  Vec3 w_rel_j{};  ///< w_K - w_J, J axes
};

/// Per-body inertial quantities an engine reports (and kanedyn's, for reference).
struct BodyMotion {
  Vec3 p_G{}, v_G{};  ///< mass-centre position and velocity, inertial
  Vec3 w{};           ///< angular velocity, inertial
  Vec3 a_G{};         ///< mass-centre acceleration, inertial
  Vec3 alpha{};       ///< angular acceleration, inertial
};

/// Rates of a body's joint speeds: d/dt of s'_K dot (J axes) and d/dt of the components of
/// w_rel_k (the speeds of a ball joint in child axes).
struct JointAcceleration {
  Vec3 s_ddot{};
  Vec3 w_rel_dot_k{};
};

/// Pose and velocity of body K at an engine's integrated state (kanedyn_peers_trajectory).
struct BodyPose {
  Vec3 p_G{};  ///< mass-centre position, inertial
  Mat3 R{};    ///< body-K components -> inertial components (K's unit vectors as columns)
  Vec3 v_G{};  ///< mass-centre velocity, inertial
  Vec3 w{};    ///< angular velocity, inertial
};

/// How an engine integrates the motion with its own integrator. Each engine reads the knob
/// its integrator has: the accuracy of an error-controlled integrator, or the step of a
/// fixed-step one.
struct IntegratorSettings {
  std::string method;      ///< engine-specific name ("rkmerson", "rk4", ...); empty: default
  double accuracy = 1e-9;  ///< error-controlled integrators: the engine's accuracy setting
  double step = 1e-4;      ///< fixed-step integrators: the largest step
};

/// What start() set up.
struct IntegratorInfo {
  std::string description;  ///< e.g. "RungeKuttaMerson, accuracy 1e-09"; empty: not supported
  bool fixed_step = false;  ///< refined by IntegratorSettings::step (else by ::accuracy)
  double order = 0;         ///< nominal order of the global error in the step or the accuracy
};

struct System {
  std::string name;
  std::vector<Body> bodies;
  Vec3 gravity{};
  std::vector<BodyState> state;
  bool has_constant_loads = false;
};

/// One engine holding one System at its state.
class Engine {
 public:
  virtual ~Engine() = default;
  /// One forward-dynamics evaluation at the state, as a user of the engine would write it
  /// (the timed call).
  virtual void evaluate() = 0;
  /// Body motion after evaluate(), in kanedyn's body order.
  virtual std::vector<BodyMotion> motion() = 0;
  /// For engines that solve M qacc = f in joint coordinates: the componentwise backward error
  /// max_i |M qacc - f|_i / (|M| |qacc| + |f|)_i of the engine's own qacc and of the given
  /// joint accelerations (kanedyn's), after evaluate(). Empty if not implemented.
  virtual std::vector<double> backward_errors(const std::vector<JointAcceleration>&) { return {}; }

  // Trajectories (kanedyn_peers_trajectory): the engine integrates the motion from the
  // System's state at t = 0 with its own integrator. The integration keeps its own state,
  // apart from the one evaluate() uses.

  /// Starts (or restarts) at t = 0. Returns an empty description if the engine cannot
  /// integrate; throws std::invalid_argument for a method it does not know.
  virtual IntegratorInfo start(const IntegratorSettings&) { return {}; }
  /// Advances to time t (after the current time). Fixed-step integrators split the interval
  /// into equal steps no longer than IntegratorSettings::step, so t is reached by a step;
  /// error-controlled ones stop at t without interpolating. Throws std::runtime_error when
  /// the integrator fails.
  virtual void advance_to(double t) { (void)t; }
  /// Body poses at the current integrated state, in kanedyn's body order.
  virtual std::vector<BodyPose> pose() { return {}; }
  /// Steps taken since start().
  virtual long steps() const { return 0; }
};

/// What an engine needs to be able to skip cases it cannot run here.
struct EngineInfo {
  std::string name;
  std::string version;
  /// Bytes the engine allocates for this system, roughly (dense caches dominate).
  double (*bytes)(const System&);
  /// A number proportional to one evaluation's cost, to extrapolate from measured cases.
  double (*cost)(const System&);
  std::unique_ptr<Engine> (*make)(const System&);
};

EngineInfo simbody_engine();
EngineInfo mujoco_engine();
#ifdef KANEDYN_PEERS_HAVE_DART
EngineInfo dart_engine();
#endif

/// Sum over bodies of (number of degrees of freedom from the body down to the ground) and
/// of its square: the sizes of dense-fill mass-matrix factorizations in joint coordinates.
double ancestor_dofs(const System& system, int power);

/// Number of equal fixed steps, each at most `step` (to round-off), that span `span` seconds.
inline long equal_steps(double span, double step) {
  return std::max(1L, static_cast<long>(std::ceil(span / step * (1 - 1e-12))));
}

// ---------------------------------------------------------------------------------------------
// Jointed trees (kanedyn::JointTree): the same bodies with one joint each, in the joint
// coordinates q and independent speeds z of kanedyn's layout (include/kanedyn/joints.hpp).

/// kanedyn::JointType in plain terms, in the same order (jointed.cpp checks the count).
enum class JointKind {
  free,
  weld,
  revolute,
  prismatic,
  cylindrical,
  universal,
  spherical,
  planar,
  screw
};

/// The joint of body K at Q_K, relative to its lower body J, in plain numbers.
struct JointSpec {
  JointKind type = JointKind::free;
  Quat frame{1, 0, 0, 0};  ///< F relative to J (Hamilton: maps F components to J components)
  Vec3 axis{1, 0, 0};      ///< revolute, prismatic, cylindrical, screw axis; universal a1 (F)
                           ///< (a planar joint moves in F's x-y plane and turns about F's z)
  Vec3 axis2{0, 1, 0};     ///< universal a2 (unit, F components, perpendicular to a1)
  Vec3 translation{};      ///< weld: the constant s'_K, body-J components
  double pitch = 0;        ///< screw: translation along the axis per radian of turn
  /// Joint load on coordinate i of kanedyn's q (revolute, prismatic, cylindrical, universal,
  /// planar): Q_i = value_i - stiffness_i (q_i - rest_i) - damping_i dq_i/dt.
  std::array<double, 3> stiffness{}, damping{}, rest{}, value{};
};

/// A constraint closing a loop of a jointed tree (kanedyn::Constraint's ball, hinge and
/// distance; docs/model-format.md, "Constraints"), in plain numbers.
struct ConstraintSpec {
  enum class Kind { ball, hinge, distance };
  std::string name;
  Kind type = Kind::ball;
  int body = 0;             ///< K, whose reaction is reported
  int other = -1;           ///< the other body, -1 for the ground
  Vec3 at{}, other_at{};    ///< from O_K (K axes), from other's O (its axes; ground: inertial)
  Vec3 axis{0, 0, 1};       ///< hinge: a, K axes (unit)
  std::array<Vec3, 2> p{};  ///< hinge: two unit directions of other normal to other_axis
  double length = 0;        ///< distance
};

/// A point-to-point spring-damper (kanedyn::Spring; docs/model-format.md, "type: spring"): with
/// d = P' - P, L = |d|, u = d / L, the force (stiffness (L - rest_length) + damping dL/dt) u on
/// `body` at P and its opposite on `other` at P'.
struct SpringSpec {
  int body = 0;           ///< the body of P
  int other = -1;         ///< the body of P', -1 for the ground
  Vec3 at{}, other_at{};  ///< from O_K (K axes), from other's O (its axes; ground: inertial)
  double stiffness = 0, damping = 0, rest_length = 0;
};

/// A jointed tree at a state. Free joints are roots only (a free joint is then the notes' own
/// free body: z = (w'_K body-K components, s'_K dot inertial)), and only they carry the
/// bushing fields of Body.
struct JointedSystem {
  std::string name;
  std::vector<Body> bodies;
  std::vector<JointSpec> joints;
  Vec3 gravity{};
  std::vector<double> q, z;             ///< kanedyn's joint coordinates and speeds
  std::vector<int> q_offset, z_offset;  ///< per body, N + 1 entries
  /// Constraints closing loops (empty for a tree). The state satisfies them.
  std::vector<ConstraintSpec> constraints;
  /// Point-to-point springs (their potential energy counts in JointedEngine::energy()).
  std::vector<SpringSpec> springs;
};

/// One engine holding one JointedSystem at its state.
class JointedEngine {
 public:
  virtual ~JointedEngine() = default;
  /// One forward-dynamics evaluation at the state (the timed call).
  virtual void evaluate() = 0;
  /// The engine's joint accelerations after evaluate(), mapped to kanedyn's z order and
  /// convention (d/dt of kanedyn's z).
  virtual std::vector<double> zdot() = 0;
  /// Trajectories, as Engine's: integrated from the system's state at t = 0.
  virtual IntegratorInfo start(const IntegratorSettings&) { return {}; }
  virtual void advance_to(double t) { (void)t; }
  virtual std::vector<BodyPose> pose() { return {}; }
  virtual long steps() const { return 0; }

  /// Whether the engine has the calls below (kanedyn's Terms beside the engine's own).
  virtual bool has_terms() const { return false; }
  /// The joint accelerations of the next inverse_dynamics(), as kanedyn's z dot (untimed).
  virtual void set_zdot(const std::vector<double>& zdot) { (void)zdot; }
  /// The engine's inverse dynamics at the state and set_zdot()'s accelerations (the timed call).
  virtual void inverse_dynamics() {}
  /// Its result in kanedyn's z order and convention: the generalized forces to add to the
  /// model's own loads (gravity, bushings, joint loads) for the motion (Terms::inverse_dynamics).
  virtual std::vector<double> generalized_forces() { return {}; }
  /// The engine's joint-space mass matrix at the state (the timed call).
  virtual void mass_matrix() {}
  /// Its result in kanedyn's z order and convention, n x n by columns (Terms::mass_matrix).
  virtual std::vector<double> mass_matrix_in_z() { return {}; }

  // With constraints (JointedSystem::constraints), at the state of evaluate() or at the
  // integrated one:
  /// The constraints' reactions after evaluate(), in the order and convention of kanedyn's
  /// trajectory CSV: per constraint its force on `body` at `at`, then for a hinge its moment on
  /// `body` about `at`, inertial components. Empty if not implemented.
  virtual std::vector<double> reactions() { return {}; }
  /// The joint coordinates (kanedyn's q; a spherical joint's Euler parameters with either sign),
  /// speeds (kanedyn's z) and reactions at the current integrated state.
  virtual void integrated_state(std::vector<double>& q, std::vector<double>& z,
                                std::vector<double>& reactions) {
    (void)q, (void)z, (void)reactions;
  }
  /// The engine's own total energy (kinetic, gravity's and the springs' potential) at the
  /// current integrated state, with gravity's zero at the origin; NaN if not implemented.
  virtual double energy() { return std::nan(""); }
};

struct JointedEngineInfo {
  std::string name;
  std::string version;
  /// Why the engine cannot build this system, or "" when it can.
  std::string (*unsupported)(const JointedSystem&);
  std::unique_ptr<JointedEngine> (*make)(const JointedSystem&);
};

JointedEngineInfo simbody_jointed_engine();
JointedEngineInfo mujoco_jointed_engine();
#ifdef KANEDYN_PEERS_HAVE_DART
JointedEngineInfo dart_jointed_engine();
#endif

/// The first free joint that is not on a root, or -1 (the peers' free joints are roots).
inline int nonroot_free_joint(const JointedSystem& s) {
  for (size_t k = 0; k < s.joints.size(); ++k)
    if (s.joints[k].type == JointKind::free && s.bodies[k].parent >= 0) return static_cast<int>(k);
  return -1;
}

}  // namespace peers
