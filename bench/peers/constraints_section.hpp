// kanedyn_peers' constraints section: model files whose loops are closed by constraints (the
// four-bar and the RSSR linkage of examples/) built in Simbody too, their joint accelerations
// and reactions compared at the initial state, and their motions and reactions compared over
// time, each engine with its own integrator (docs/performance.md, "Closed loops against
// Simbody").
#pragma once

#include <string>
#include <vector>

namespace peers {

struct ConstraintOptions {
  std::vector<std::string> files;  ///< model files with ball, hinge or distance constraints
  double t_end = 3.0;              ///< s
  double dt_out = 0.01;            ///< s between compared states
  double rtol = 1e-12;             ///< kanedyn's dopri5 (atol = rtol / 100)
  double accuracy = 1e-10;         ///< Simbody's RungeKuttaMerson
  /// At the initial state (one state, no integration): the largest accepted relative
  /// difference of z dot and of the reactions.
  double instant_tolerance = 1e-10;
  /// Over the run, kanedyn's integration error (rtol 1e-12) is far below Simbody's, whose
  /// error e is estimated from a second Simbody run at 10 times the accuracy: with the error
  /// proportional to the accuracy, the two runs differ by 9 e. A measure (joint coordinates in
  /// rad or m, a spherical joint's by the angle between the orientations; speeds in rad/s or
  /// m/s; reactions relative to the largest) agrees when kanedyn's difference from Simbody is
  /// at most safety * e + floor.
  double safety = 3.0;
  double floor = 1e-10;
};

/// Runs the section, printing what it compares. Returns false when an engine disagrees with
/// kanedyn beyond the tolerances, or a file cannot be compared.
bool run_constraint_section(const ConstraintOptions& options);

}  // namespace peers
