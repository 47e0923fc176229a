// kanedyn_peers' springs section: kanedyn's point-to-point spring (kanedyn::Spring,
// docs/model-format.md, "type: spring") against Simbody's Force::TwoPointLinearSpring and
// Force::TwoPointLinearDamper on the same bodies: three free bodies hung from the ground and
// from each other, and three links on revolute joints (Simbody's Pin), each with springs between
// off-centre points, nonzero rest lengths and damping. Accelerations are compared at random
// states and timed; the undamped models are integrated by both, their motions compared and
// their energies checked for conservation (docs/performance.md, "Springs against Simbody's
// TwoPointLinearSpring").
#pragma once

#include "timing.hpp"

namespace peers {

struct SpringOptions {
  unsigned seed = 1;
  int states = 4;  ///< random states per model at which the accelerations are compared
  TimingBudget budget;
  /// Largest accepted relative difference of z dot (of the largest |z dot|) at a state: both
  /// engines evaluate the same closed-form forces and solve small, well-conditioned systems.
  double tolerance = 1e-10;
  double t_end = 1.0;       ///< s, the undamped runs
  double dt_out = 0.01;     ///< s between compared states
  double rtol = 1e-12;      ///< kanedyn's dopri5 (atol = rtol / 100)
  double accuracy = 1e-10;  ///< Simbody's RungeKuttaMerson
  /// Over the run, kanedyn's integration error (rtol 1e-12) is far below Simbody's, whose error
  /// e is estimated from a second Simbody run at 10 times the accuracy (the runs differ by about
  /// 9 e). Coordinates and speeds agree when kanedyn's difference from Simbody is at most
  /// safety * e + floor, and each engine's energy drift (relative to the largest kinetic
  /// energy) is accepted up to safety times its own error in the energy (from its run at 10
  /// times its tolerance likewise) + energy_floor (round-off in summing energies some ten
  /// times the kinetic one).
  double safety = 3.0;
  double floor = 1e-10;         ///< rad, m, rad/s, m/s
  double energy_floor = 1e-12;  ///< of the largest kinetic energy
};

/// Runs the section, printing what it compares and times. Returns false when Simbody disagrees
/// with kanedyn beyond the tolerances or an engine's energy drifts beyond them.
bool run_spring_section(const SpringOptions& options);

}  // namespace peers
