// kanedyn_peers' jointed sections: the same jointed trees (jointed.hpp) in kanedyn
// (Dynamics) and the peers; joint accelerations compared at random states, forward
// dynamics timed, and kanedyn's time per body on revolute chains (docs/performance.md,
// "Jointed models").
#pragma once

#include <string>
#include <vector>

#include "timing.hpp"

namespace peers {

struct JointedOptions {
  std::vector<std::string> models;   ///< names to run; empty: every jointed model
  std::vector<std::string> engines;  ///< simbody, mujoco, dart (others are ignored)
  std::string eight_body;            ///< the eight-body example's model file
  unsigned seed = 1;
  int chain = 512;                 ///< links of the compared revolute chain
  int states = 4;                  ///< random states per model for the accelerations
  std::vector<int> scaling_sizes;  ///< revolute chains timed for kanedyn's time per body
  TimingBudget budget;
  double max_eval_seconds = 60;  ///< skip a scaling case predicted to take longer per evaluation
  /// Largest accepted relative difference of joint accelerations where the mass matrix is well
  /// conditioned (the tolerance is 10 cond(M) eps where that is larger).
  double tolerance = 1e-10;
  bool compare = true;  ///< the jointed models: accelerations and timing
  bool scaling = true;  ///< kanedyn's time per body
  bool terms = false;   ///< inverse dynamics and mass matrix beside the peers' own
};

/// Runs the selected jointed sections, printing as the free-body section does. Returns false
/// when some engine's accelerations disagree with kanedyn's beyond the tolerance.
bool run_jointed_sections(const JointedOptions& options);

}  // namespace peers
