// The reduced linearization (docs/analysis.md, "Steady motions: the reduced system"): a
// linearization with its ignorable coordinates dropped. A coordinate is ignorable when the
// state rate does not depend on it: a free root's position and its heading about the vertical,
// a wheel's spin angle. About a steady motion (a rolling coin's circle, a bicycle riding
// straight) the rest of the state is time-invariant, and its eigenvalues decide stability.
#pragma once

#include <string>
#include <vector>

#include "kanedyn/analysis.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn {

/// One dropped coordinate: a symmetry direction of the motion, named by the state entry it
/// replaces.
struct DroppedCoordinate {
  int index = 0;     ///< its entry in Linearization::state
  std::string name;  ///< that entry's name, e.g. "disc.s1", "disc.r3"
  /// What moves along it: "coordinate" (that entry alone: a position, a joint angle),
  /// "heading" (a free root body turned about the vertical, with what it carries) or "spin"
  /// (a free body turned about its axis of symmetry).
  std::string kind;
};

/// The linearization with the ignorable coordinates dropped.
struct ReducedLinearization {
  std::vector<DroppedCoordinate> dropped;
  std::vector<int> kept;           ///< the entries of Linearization::state kept, in order
  std::vector<std::string> state;  ///< their names
  /// The reduced state's rate matrix and input matrix; with nothing dropped, the
  /// linearization's A and B.
  MatrixX A, B;
  /// The eigenvalues of A (sorted as Linearization::eigenvalues) and, when asked, the modes.
  Eigen::VectorXcd eigenvalues;
  Eigen::MatrixXcd modes;
  /// The largest rate of the reduced state at the operating point (0 at a steady motion: the
  /// motion is then the operating point carried along the dropped directions), and whether it
  /// is within the tolerance of zero, scaled as `zero_rate`.
  double reduced_rate = 0.0;
  bool steady = true;
  /// The speed of each dropped direction in the nominal motion (rad/s for heading and spin):
  /// its coefficient in the state's rate.
  std::vector<double> rates;
  /// The full state deviation (the linearization's state) of a reduced state deviation y:
  /// lift * y, the dropped directions' components zero.
  MatrixX lift;
};

/// The relative size below which a column, a reduced rate, counts as zero: the derivatives are
/// exact to round-off, about 1e-14 of |A| (1e-12 after a constrained model's solves), and a
/// physical dependence (a spring, gravity's moment) is of order |A|; 1e-9 lies between.
inline constexpr double kIgnorableTolerance = 1e-9;

/// The ignorable coordinates of lin (found from its A and the model's symmetries: the
/// coordinate columns that vanish outside the ignorable rows; a free root body's turn about
/// the vertical (the rolling plane's normal, else gravity's direction); a childless free body's
/// turn about its axis of symmetry, in the frame that spins with it), and the system without
/// them. Both rotations are checked against A: a direction stays only if the rates do not
/// depend on it, to kIgnorableTolerance of |A|.
ReducedLinearization reduce(const Model& model, const Linearization& lin, bool modes = false);

/// reduce()'s dropped coordinates alone (no eigenvalues): what a summary names as neutral.
std::vector<DroppedCoordinate> ignorable_coordinates(const Model& model, const Linearization& lin);

}  // namespace kanedyn
