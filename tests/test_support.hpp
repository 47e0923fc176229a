// Test support: models built in C++ (the notes' eight-body system, random trees), random
// states, finite-difference helpers and reference formulas written independently of src/.
// Header-only on purpose (tests/CMakeLists.txt globs only tests/test_*.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <iterator>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/partials.hpp"
#include "kanedyn/state.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn::test {

// ---------------------------------------------------------------------------------------------
// Random numbers

inline double uniform(std::mt19937& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

inline int uniform_int(std::mt19937& rng, int lo, int hi) {  // inclusive bounds
  return std::uniform_int_distribution<int>(lo, hi)(rng);
}

inline Vector3 random_vector(std::mt19937& rng, double lo, double hi) {
  return {uniform(rng, lo, hi), uniform(rng, lo, hi), uniform(rng, lo, hi)};
}

/// Uniformly distributed unit Euler parameters (normalized Gaussian 4-vector), either sign of
/// e4.
inline Vector4 random_euler_parameters(std::mt19937& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Vector4 e;
  do {
    e = {normal(rng), normal(rng), normal(rng), normal(rng)};
  } while (e.norm() < 1e-3);
  return e.normalized();
}

// ---------------------------------------------------------------------------------------------
// Reference formulas, written from the README of the notes and not from src/

/// [R] of Eqs. (3)-(4) in the compact form (e4^2 - e.e)[I] + 2{e}{e}^T - 2 e4 [e~].
inline Matrix3 reference_rotation(const Vector4& eps) {
  const Vector3 e = eps.head<3>();
  const double e4 = eps[3];
  return (e4 * e4 - e.dot(e)) * Matrix3::Identity() + 2.0 * e * e.transpose() - 2.0 * e4 * skew(e);
}

/// A proper orthogonal matrix from random Euler parameters.
inline Matrix3 random_rotation(std::mt19937& rng) {
  return reference_rotation(random_euler_parameters(rng));
}

/// A full inertia matrix (with products) about G: principal moments built from positive
/// second moments (Ixx = Syy + Szz, ...), so every triangle inequality holds strictly, then
/// turned to random principal axes.
inline Matrix3 random_inertia(std::mt19937& rng, double mass) {
  const Vector3 second = mass * random_vector(rng, 0.02, 0.3);
  const Vector3 principal(second[1] + second[2], second[0] + second[2], second[0] + second[1]);
  const Matrix3 q = random_rotation(rng);
  const Matrix3 inertia = q * principal.asDiagonal() * q.transpose();
  return 0.5 * (inertia + inertia.transpose());
}

// ---------------------------------------------------------------------------------------------
// Models

/// prefix + number. Appending (rather than "literal" + std::to_string(...)) avoids g++ 12's
/// false -Werror=restrict in std::string's operator+ at -O3 (GCC bug 105329).
inline std::string numbered_name(const char* prefix, int number) {
  std::string name(prefix);
  name += std::to_string(number);
  return name;
}

/// The notes' eight-body system, L(K) = (0, 1, 2, 2, 1, 1, 1, 7): non-trivial masses, full
/// inertias with products, com offsets r', joint offsets q' (the root's q'_1 too, the
/// extension of the README), a bushing on every body and gravity.
inline Model eight_body_model(Vector3 gravity = Vector3(0.0, 0.0, -9.81), bool bushings = true) {
  const int lower[8] = {kGround, 0, 1, 1, 0, 0, 0, 6};  // L(K) - 1
  const double mass[8] = {12.0, 3.5, 2.0, 2.2, 1.4, 1.1, 4.0, 1.7};
  std::vector<BodySpec> bodies(8);
  for (int k = 0; k < 8; ++k) {
    BodySpec& b = bodies[static_cast<size_t>(k)];
    b.name = numbered_name("body", k + 1);
    b.lower_body = lower[k];
    b.mass = mass[k];
    const double s = 0.1 * mass[k];
    const double a = 0.05 * (k + 1);
    // Diagonal in [0.95 s, 1.4 s] with products of up to 0.15 s: by Gershgorin the principal
    // moments lie in [0.69 s, 1.66 s], positive; the Model constructor checks the triangle
    // inequalities (they hold: the spread is small).
    b.inertia << s * (1.0 + a), 0.07 * s, -0.11 * s,  //
        0.07 * s, s * 1.2, 0.05 * s * (k % 3 + 1),    //
        -0.11 * s, 0.05 * s * (k % 3 + 1), s * (1.35 - a);
    b.com = Vector3(0.03 * k - 0.1, 0.12 - 0.02 * k, 0.25 + 0.01 * k);
    b.joint = Vector3(0.1 + 0.05 * k, -0.2 + 0.03 * k, 0.3 - 0.07 * k);
  }
  std::vector<std::shared_ptr<const ForceElement>> forces;
  if (bushings) {
    for (int k = 0; k < 8; ++k)
      forces.push_back(std::make_shared<Bushing>(k, Vector3(200.0 + 10 * k, 150.0, 300.0 - 5 * k),
                                                 Vector3(2.0, 1.5 + 0.1 * k, 3.0), 20.0 + k,
                                                 0.5 + 0.05 * k));
  }
  return Model(std::move(bodies), gravity, std::move(forces), "eight-body");
}

/// The notes' eight-body system with bushings of its own on every body (or all but the
/// root: a free system), with the given damping factor (0: energy is conserved).
inline Model eight_body(Vector3 gravity, bool ground_bushing, double damping) {
  const Model base = eight_body_model(gravity, false);
  std::vector<std::shared_ptr<const ForceElement>> forces;
  for (int k = ground_bushing ? 0 : 1; k < 8; ++k)
    forces.push_back(std::make_shared<Bushing>(k, Vector3(200.0 + 10 * k, 150.0, 300.0 - 5 * k),
                                               damping * Vector3(2.0, 1.5, 3.0), 20.0 + k,
                                               damping * 0.5));
  return Model(base.bodies(), gravity, std::move(forces), "eight-body");
}

struct RandomTreeOptions {
  int min_bodies = 1;
  int max_bodies = 30;
  Vector3 gravity = Vector3(0.0, 0.0, -9.81);
  bool bushings = false;  ///< a bushing on each body with probability bushing_probability
  double bushing_probability = 0.8;
  bool damping = true;          ///< nonzero bushing damping
  bool ground_bushings = true;  ///< false: roots get no bushing (a floating system)
  bool forces = false;          ///< random constant forces on some bodies
  bool torques = false;         ///< random constant torques on some bodies
  bool chain = false;           ///< L(K) = K - 1: one chain instead of a random forest
  /// With bushings: a second bushing on a body that has one, with this probability (the
  /// loads of several elements on one body add).
  double second_bushing_probability = 0.0;
};

/// A random forest: N uniform in [min_bodies, max_bodies], L(K) uniform in 0..K-1 (so 0, the
/// ground, may repeat and the model may hold several trees), masses in [0.5, 5], random full
/// inertias, random q' and r', optional random force elements.
inline Model random_tree(std::mt19937& rng, const RandomTreeOptions& opt = {}) {
  const int n = uniform_int(rng, opt.min_bodies, opt.max_bodies);
  std::vector<BodySpec> bodies(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    BodySpec& b = bodies[static_cast<size_t>(k)];
    b.name = numbered_name("b", k + 1);
    // L(K) uniform in 0..K-1, 0 -> kGround; a chain draws nothing here.
    b.lower_body = opt.chain ? k - 1 : uniform_int(rng, 0, k) - 1;
    b.mass = uniform(rng, 0.5, 5.0);
    b.inertia = random_inertia(rng, b.mass);
    b.com = random_vector(rng, -0.4, 0.4);
    b.joint = random_vector(rng, -0.5, 0.5);
  }
  std::vector<std::shared_ptr<const ForceElement>> forces;
  for (int k = 0; k < n; ++k) {
    const bool root = bodies[static_cast<size_t>(k)].lower_body == kGround;
    if (opt.bushings && (opt.ground_bushings || !root) &&
        uniform(rng, 0.0, 1.0) < opt.bushing_probability) {
      const double c = opt.damping ? 1.0 : 0.0;
      const int count = opt.second_bushing_probability > 0.0 &&
                                uniform(rng, 0.0, 1.0) < opt.second_bushing_probability
                            ? 2
                            : 1;
      for (int i = 0; i < count; ++i) {
        // One draw after the other: the order of a call's arguments is unspecified.
        const Vector3 stiffness = random_vector(rng, 5.0, 100.0);
        const Vector3 damping = c * random_vector(rng, 0.0, 3.0);
        const double torsion = uniform(rng, 1.0, 20.0),
                     torsion_damping = c * uniform(rng, 0.0, 1.0);
        forces.push_back(
            std::make_shared<Bushing>(k, stiffness, damping, torsion, torsion_damping));
      }
    }
    if (opt.forces && uniform(rng, 0.0, 1.0) < 0.5)
      forces.push_back(std::make_shared<ConstantForce>(k, random_vector(rng, -10.0, 10.0)));
    if (opt.torques && uniform(rng, 0.0, 1.0) < 0.5)
      forces.push_back(std::make_shared<ConstantTorque>(k, random_vector(rng, -2.0, 2.0)));
  }
  return Model(std::move(bodies), opt.gravity, std::move(forces), "random");
}

/// The eight-body system followed by `count` random forests drawn with `opt` from `seed`.
inline std::vector<Model> eight_body_and_random_trees(unsigned seed, int count,
                                                      const RandomTreeOptions& opt = {}) {
  std::vector<Model> models;
  models.push_back(eight_body_model());
  std::mt19937 rng(seed);
  for (int i = 0; i < count; ++i) models.push_back(random_tree(rng, opt));
  return models;
}

/// A random forest (or chain) of exactly n bodies with loads of every kind: gravity in a
/// random direction, bushings with damping (a third of the bodies none, a sixth two),
/// constant forces and torques on some bodies.
inline Model random_loaded_model(std::mt19937& rng, int n, bool chain = false) {
  RandomTreeOptions opt;
  opt.min_bodies = opt.max_bodies = n;
  opt.chain = chain;
  opt.gravity = random_vector(rng, -10.0, 10.0);
  opt.bushings = opt.forces = opt.torques = true;
  opt.bushing_probability = 2.0 / 3.0;
  opt.second_bushing_probability = 0.25;
  return random_tree(rng, opt);
}

/// The models the comparisons between routes run on: the eight-body system, loaded forests
/// of 1 to 60 bodies and chains of 2 to 25.
inline std::vector<Model> models_of_every_size(std::mt19937& rng) {
  std::vector<Model> models;
  models.push_back(eight_body_model());
  for (int n : {1, 2, 3, 5, 8, 13, 30, 60}) models.push_back(random_loaded_model(rng, n));
  for (int n : {2, 7, 25}) models.push_back(random_loaded_model(rng, n, true));
  return models;
}

/// A random state: unit Euler parameters, s' in [-s_max, s_max], w' in [-w_max, w_max],
/// s' dot in [-v_max, v_max].
inline State random_state(const Model& model, std::mt19937& rng, double s_max = 0.3,
                          double w_max = 2.0, double v_max = 1.0) {
  State state(model);
  for (int k = 0; k < model.num_bodies(); ++k) {
    state.euler_parameters(k) = random_euler_parameters(rng);
    state.translation(k) = random_vector(rng, -s_max, s_max);
    state.angular_velocity(k) = random_vector(rng, -w_max, w_max);
    state.translation_rate(k) = random_vector(rng, -v_max, v_max);
  }
  return state;
}

/// A random moving state of the kind the simulation tests start from.
inline State moving_state(const Model& model, unsigned seed) {
  std::mt19937 rng(seed);
  return random_state(model, rng, 0.05, 1.5, 0.3);
}

/// The state at x + h xdot, y + h ydot, Euler parameters renormalized (a path on the
/// manifold whose tangent at h = 0 is (xdot, ydot), because eps . eps_dot = 0).
inline State advance(const State& state, const VectorX& xdot, const VectorX& ydot, double h) {
  State s = state;
  s.x += h * xdot;
  if (ydot.size() > 0) s.y += h * ydot;
  s.normalize_euler_parameters();
  return s;
}

/// Mass-centre accelerations from ydot (Eq. 33): a_G = [v_G,y] ydot + [v_G,y dot] y. Needs a
/// Data in which kane_equations() (partials and their rates) has run at `state`.
inline std::vector<Vector3> mass_centre_accelerations(const Model& model, const State& state,
                                                      const Data& data, const VectorX& ydot) {
  std::vector<Vector3> a;
  for (int k = 0; k < model.num_bodies(); ++k)
    a.push_back(partial_velocity(model, data, k, Point::G) * ydot +
                partial_velocity_rate(model, data, k, Point::G) * state.y);
  return a;
}

/// ydot and xdot by the given route, plus the partials and their rates at the state (for
/// a_G, mass_centre_accelerations).
struct Evaluated {
  Data data;
  VectorX ydot, xdot;
};
inline Evaluated evaluate(const Model& model, const State& state, Route route) {
  Evaluated e{Data(model), VectorX(), VectorX()};
  forward_dynamics(model, state, e.data, route);
  e.ydot = e.data.ydot;
  e.xdot = e.data.xdot;
  kane_equations(model, state, e.data);  // partials and rates at the state
  return e;
}

/// Largest absolute entry of a difference, for messages and scale-aware tolerances.
inline double max_abs(const MatrixX& m) { return m.size() == 0 ? 0.0 : m.cwiseAbs().maxCoeff(); }

/// Dense 3 x 6N selection of {s'_K dot} from {y} (Eq. 20 placed in the y2 part).
inline MatrixX translation_rate_selection(int num_bodies, int k) {
  MatrixX m = MatrixX::Zero(3, 6 * num_bodies);
  m.block<3, 3>(0, 3 * num_bodies + 3 * k).setIdentity();
  return m;
}

/// Dense 3 x 6N selection of {w'_K} from {y} (Eq. 8), written here independently.
inline MatrixX angular_velocity_selection(int num_bodies, int k) {
  MatrixX m = MatrixX::Zero(3, 6 * num_bodies);
  m.block<3, 3>(0, 3 * k).setIdentity();
  return m;
}

// ---- Jointed trees (joints.hpp) ----

// A joint type drawn uniformly from kJointTypes (joint.hpp), so that a new type enters every
// random test.
inline JointType random_joint_type(std::mt19937& rng) {
  constexpr int n = static_cast<int>(std::size(kJointTypes));
  return kJointTypes[uniform_int(rng, 0, n - 1)];
}

inline Vector3 random_unit(std::mt19937& rng) { return random_vector(rng, -1, 1).normalized(); }

// A random joint of the given type: random frame, unnormalized axes (the Model normalizes).
inline Joint random_joint(std::mt19937& rng, JointType type) {
  Joint j;
  j.type = type;
  j.frame = random_euler_parameters(rng);
  j.axis = uniform(rng, 0.5, 2.0) * random_unit(rng);
  const Vector3 a1 = random_unit(rng);
  j.axes = {2.0 * a1, a1.cross(random_unit(rng)).normalized()};
  j.translation = random_vector(rng, -0.3, 0.3);
  j.pitch = uniform(rng, -0.3, 0.3);
  return j;
}

// Random joint coordinates and speeds: angles in [-3, 3], slides (and planar x, y) in [-0.5, 0.5],
// Euler parameters uniform (free bodies' s'_K in [-0.3, 0.3]); speeds in [-1, 1].
inline void random_joint_state(const Model& tree, std::mt19937& rng, VectorX& q, VectorX& z) {
  q = VectorX::Zero(tree.num_coordinates());
  z = VectorX::Zero(tree.num_speeds());
  for (int k = 0; k < tree.num_bodies(); ++k) {
    const int o = tree.coordinate_offset(k);
    switch (tree.joint(k).type) {
      case JointType::free:
        q.segment<4>(o) = random_euler_parameters(rng);
        q.segment<3>(o + 4) = random_vector(rng, -0.3, 0.3);
        break;
      case JointType::spherical:
        q.segment<4>(o) = random_euler_parameters(rng);
        break;
      case JointType::revolute:
      case JointType::screw:
        q[o] = uniform(rng, -3, 3);
        break;
      case JointType::prismatic:
        q[o] = uniform(rng, -0.5, 0.5);
        break;
      case JointType::cylindrical:
        q[o] = uniform(rng, -3, 3);
        q[o + 1] = uniform(rng, -0.5, 0.5);
        break;
      case JointType::universal:
        q[o] = uniform(rng, -3, 3);
        q[o + 1] = uniform(rng, -3, 3);
        break;
      case JointType::planar:
        q[o] = uniform(rng, -0.5, 0.5);
        q[o + 1] = uniform(rng, -0.5, 0.5);
        q[o + 2] = uniform(rng, -3, 3);
        break;
      case JointType::weld:
        break;
    }
  }
  for (int i = 0; i < z.size(); ++i) z[i] = uniform(rng, -1, 1);
}

inline std::vector<Joint> joints_of(const Model& m) {
  std::vector<Joint> joints;
  for (int k = 0; k < m.num_bodies(); ++k) joints.push_back(m.joint(k));
  return joints;
}

inline Model rebuilt(const Model& m, std::vector<std::shared_ptr<const ForceElement>> forces,
                     std::vector<Input> inputs, std::vector<Frame> frames = {}) {
  return Model(m.bodies(), m.gravity(), std::move(forces), m.name(), joints_of(m),
               std::move(frames), std::move(inputs));
}

// A random tree with random joints (every type), gravity and, unless conservative, damped
// bushings; no constant loads (they would not be conservative).
inline Model random_jointed(std::mt19937& rng, bool damping) {
  RandomTreeOptions opt;
  opt.min_bodies = 2;
  opt.max_bodies = 7;
  opt.gravity = Vector3(0.3, -0.2, -9.81);
  opt.damping = damping;
  const Model tree = random_tree(rng, opt);
  std::vector<Joint> joints;
  for (int k = 0; k < tree.num_bodies(); ++k)
    joints.push_back(random_joint(rng, random_joint_type(rng)));
  return with_joints(tree, joints);
}

// One input of the given type on a body of the model that can take it (a body with speeds for
// a joint input), with random parameters; false when there is none.
inline bool random_input(const Model& m, std::mt19937& rng, InputType type, Input& in) {
  std::vector<int> candidates;
  for (int k = 0; k < m.num_bodies(); ++k)
    if (type != InputType::joint || speed_count(m.joint(k).type) > 0) candidates.push_back(k);
  if (candidates.empty()) return false;
  in.type = type;
  in.body = candidates[static_cast<size_t>(uniform_int(rng, 0, int(candidates.size()) - 1))];
  in.speed = uniform_int(rng, 0, std::max(0, speed_count(m.joint(in.body).type) - 1));
  in.direction = random_vector(rng, -1, 1);
  in.point = random_vector(rng, -0.5, 0.5);
  in.axis = random_vector(rng, -1, 1);
  in.reaction = uniform(rng, 0, 1) < 0.5;
  return true;
}

}  // namespace kanedyn::test
