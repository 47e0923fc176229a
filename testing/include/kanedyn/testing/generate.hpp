// Generated systems for tests, benchmarks and the peer comparison (bench/peers): chains and
// random trees of N identical-style links held together by bushings, each with a
// deterministic, non-trivial initial state.
#pragma once

#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

/// A model and the state to start from.
struct GeneratedSystem {
  Model model;
  State initial;
};

/// The constants every generated link uses (SI units). A link is a homogeneous box hanging
/// from its origin O_K along its own -z axis: length `link_length`, square cross-section
/// `link_width`; r'_K = (0, 0, -length/2) (mid-link) and q' of a body attached to it is
/// (0, 0, -length) (the far end of the lower link). Every body, roots included, carries a
/// bushing to its lower body (or the ground) with these parameters; gravity is {g}.
struct LinkParameters {
  static constexpr double link_length = 0.5;    ///< m
  static constexpr double link_width = 0.05;    ///< m
  static constexpr double link_mass = 1.0;      ///< kg (chain); random trees scale it
  static constexpr double stiffness = 1.0e4;    ///< translational k, N/m, each axis
  static constexpr double damping = 10.0;       ///< translational c, N s/m, each axis
  static constexpr double rot_stiffness = 100;  ///< kr, N m/rad
  static constexpr double rot_damping = 0.1;    ///< cr, N m s/rad
  static constexpr double gravity_z = -9.81;    ///< {g} = (0, 0, gravity_z), m/s^2
};

/// A chain of n identical links: body K (index k) has L(K) = K-1 (index k-1; the first body is
/// attached to the ground at the origin), mass link_mass, the box's central inertia, bushings
/// and gravity as in LinkParameters. The initial state is drawn from std::mt19937(seed) (see
/// random_initial_state). Throws std::invalid_argument for n < 1.
GeneratedSystem chain_model(int n, unsigned seed = 1);

/// A random tree of n links: body 1 is attached to the ground, and for K > 1 L(K) is drawn
/// uniformly among the earlier bodies 1..K-1. Masses are drawn in [0.5, 2] x link_mass and
/// box widths in [0.5, 2] x link_width (length fixed), so the bodies differ; bushings and
/// gravity as in LinkParameters. Topology and mass properties come from std::mt19937(seed),
/// the initial state from random_initial_state(model, seed + 0x9E3779B9), both through
/// portable transformations of the engine's raw 32-bit output, so the same (n, seed) gives
/// the same system on every platform. Throws std::invalid_argument for n < 1.
GeneratedSystem random_tree_model(int n, unsigned seed);

/// A deterministic non-trivial state for any model: each body is turned relative to its lower
/// body (or the ground) by an angle in [0, 0.4] rad about a random axis; s'_K components in
/// [-0.01, 0.01] m, w'_K components in [-1, 1] rad/s, s'_K dot components in [-0.1, 0.1] m/s,
/// all uniform and drawn from std::mt19937(seed). Euler parameters have unit norm.
State random_initial_state(const Model& model, unsigned seed);

/// The largest relative rotation angle random_initial_state uses, rad.
inline constexpr double kMaxInitialRelativeAngle = 0.4;

}  // namespace kanedyn
