// kanedyn_peers' urdf section: URDF files loaded by kanedyn's importer and by DART's own
// loader (dart::utils::DartLoader), the joint-space mass matrices and forward-dynamics joint
// accelerations compared at random states (docs/performance.md, "URDF files against DART's
// loader").
#pragma once

#include <string>
#include <vector>

namespace peers {

struct UrdfOptions {
  std::vector<std::string> files;  ///< URDF files to compare
  unsigned seed = 1;
  int states = 4;  ///< random states per file
  /// Largest accepted relative difference of the mass matrices, and of the accelerations where
  /// the mass matrix is well conditioned (10 cond(M) eps where that is larger).
  double tolerance = 1e-12;
};

/// Prints one table row per file (or why it was skipped). Returns false when DART's mass
/// matrix or accelerations disagree with kanedyn's beyond the tolerance, or when a file could
/// not be compared for another reason than a floating joint or having no joints (one side
/// cannot read it, or the two read different joints).
bool run_urdf_section(const UrdfOptions& options);

}  // namespace peers
