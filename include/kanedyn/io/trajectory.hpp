// Reading a trajectory CSV back (docs/model-format.md, "Trajectory output"): the state of one
// row, for inspecting or evaluating the equations of motion at a time of a run.
#pragma once

#include <string>
#include <vector>

#include "kanedyn/inputs.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn::io {

/// One row of a trajectory: its time and the state x, y of Eq. (1).
struct TrajectoryRow {
  double t = 0.0;
  State state;
  int line = 0;  ///< the row's line in the file (1 is the header)
  /// The joint coordinates and speeds, the model's state (j, jd columns; a free body's are its
  /// e, s and w, sd columns).
  VectorX q, z;
  /// The inputs in force at the row (its input.NAME columns; empty for a model without inputs).
  VectorX inputs;
};

/// The row of the trajectory at `path` whose time is nearest to t, when it lies within half
/// the spacing of the rows around it (exactly the row's time otherwise needs no care: any t in
/// that window selects it). The state is the row's numbers as written (the writer's shortest
/// round-trip decimals read back to the same doubles). Throws std::runtime_error naming the
/// file, the line and the problem: a header that is not this model's (the first differing
/// column), a row with the wrong number of fields or a field that is not a number, no rows,
/// or no row within half a step of t (naming the range of times, or the nearest rows).
/// The header is trajectory_columns(model).
TrajectoryRow read_trajectory_row(const Model& model, const std::string& path, double t);

/// A whole trajectory: every row, as written.
struct Trajectory {
  std::vector<std::string> columns;  ///< the header: trajectory_columns(model)
  std::vector<double> values;        ///< row-major: rows() x columns.size()
  std::size_t rows() const { return columns.empty() ? 0 : values.size() / columns.size(); }
  double at(std::size_t row, std::size_t column) const {
    return values[row * columns.size() + column];
  }
};

/// Every row of the trajectory at `path`. Throws std::runtime_error naming the file, the line
/// and the problem, as read_trajectory_row does, and also for a time that goes backwards.
Trajectory read_trajectory(const Model& model, const std::string& path);

/// The motion of a trajectory, row by row (columns of the matrices): the model's state (q, z),
/// the inputs in force (the input columns; none: zero) and the accelerations z dot, each speed's
/// column differentiated by a cubic spline through the rows (docs/model-format.md, "Generalized
/// forces output"): interpolating, with the end slopes of the cubics through the first and the
/// last four rows, so O(h^3) in the row spacing h for a smooth motion. Needs 2 rows or more
/// (2: the line; 3: the parabola); throws std::runtime_error naming the file otherwise, and for
/// rows with equal times.
struct TrajectoryMotion {
  std::vector<double> t;
  MatrixX q, z, zdot, u;   ///< one column per row
  std::vector<int> lines;  ///< each row's line in the file (1 is the header)
};
TrajectoryMotion trajectory_motion(const Model& model, const Trajectory& trajectory,
                                   const std::string& path);

/// The motion of a plain table of joint coordinates (docs/cli.md, "inverse"): a header of `t`,
/// every jointed body's NAME.j1..NAME.jn (its q, named as in the trajectory CSV), optionally all
/// of a body's NAME.jd1..NAME.jdm (its speeds z) and input.NAME columns (none: 0), in any order;
/// then rows of finite numbers with increasing t. A body without its jd columns gets z from its q
/// by spline_slopes (a spherical joint: w_rel from the slopes of its Euler parameters through
/// the kinematic equation), then z dot as in trajectory_motion; so z is O(h^3) in the row spacing
/// and z dot O(h^2) for such a body, O(h^3) with its rates given. Needs 2 rows or more, 3 when
/// some body's rates are differentiated. Throws std::runtime_error naming the file, the line
/// or the column and the problem: a free body (its motion is not in joint coordinates), a
/// column that is unknown (with the closest name), repeated or missing (a body's q, some but not
/// all of its rates, t), a row of the wrong width or with a field that is not a finite number,
/// times that do not increase, a spherical joint's q off unit norm by more than 1e-6 or changing
/// sign from the previous row, too few rows.
TrajectoryMotion read_joint_table_motion(const Model& model, const std::string& path);

/// The motion of the trajectory at `path` for inverse dynamics: simulate's CSV (read_trajectory,
/// then trajectory_motion) when its header has any of simulate's body columns (NAME.x ..
/// NAME.sd3) or `energy`, else a plain table of joint coordinates (read_joint_table_motion).
TrajectoryMotion read_trajectory_motion(const Model& model, const std::string& path);

/// The derivative at every knot t_i of the cubic spline through (t_i, y_i) described at
/// TrajectoryMotion (t strictly increasing, at least 2 knots).
VectorX spline_slopes(const std::vector<double>& t, const VectorX& y);

/// The inputs CSV of `simulate --inputs` (docs/model-format.md, "Inputs"): a header `t` and
/// input names (any order, each at most once; an input not named is 0), then rows of numbers
/// with strictly increasing t. Throws std::runtime_error naming the file, the line and the
/// problem: an unknown name (with the closest input name), a repeated or missing `t` column, a
/// row of the wrong width or with a field that is not a finite number, times that do not
/// increase, no rows, or a model without inputs.
InputTable read_input_table(const Model& model, const std::string& path, InputHold hold);

}  // namespace kanedyn::io
