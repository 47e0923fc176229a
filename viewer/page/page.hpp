// The web page of `kanedyn view` (docs/viewer.md), for the tool and for other front ends
// (the target kanedyn_view): one self-contained HTML file with the viewer bundle, the model
// and a trajectory inlined.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "kanedyn/io/trajectory.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn::view {

/// Above this many rows the page holds every k-th row and the last: a browser plots and
/// scrubs 20,000 rows without lag, and the page stays a few megabytes.
constexpr std::size_t kMaxRows = 20000;

/// True when the viewer bundle was compiled in (KANEDYN_VIEWER); otherwise page() throws.
bool available();
/// Throws std::runtime_error, saying how to get the viewer, unless available().
void require_available();

/// k: the page keeps rows 0, k, 2k, ... and the last; 1 up to kMaxRows rows.
std::size_t stride(std::size_t rows);

/// The page's own columns, the first of io::trajectory_body_columns(model): t, 16 a body and
/// the energy (the inputs' and the constraints' reactions' columns follow them in a run's).
std::size_t required_columns(const Model& model);

/// The one-row trajectory of the state q, z at t = 0 (its notes' state by joint_state,
/// positions by compute_kinematics, energy by total_energy with the joint springs'
/// potentials), in the first required_columns(model) columns of
/// io::trajectory_body_columns(model).
io::Trajectory initial_trajectory(const Model& model, const VectorX& q, const VectorX& z);

/// What a page shows on load beyond the model and its run (docs/viewer.md).
struct PageOptions {
  /// A body the camera follows from the start (its name; "" none).
  std::string follow;
  /// Bodies (their mass centres) and frames whose paths are traced from the start (names).
  std::vector<std::string> trace;
  /// A mode page's coordinates (the linearization's tangent coordinates, named as
  /// tangent_state_names spells them), one row per row of the trajectory: plotted in place of
  /// the energy, which means nothing for a mode's shape. No columns: not a mode page.
  std::vector<std::string> mode_columns;
  std::vector<double> mode_values;  ///< row by row, mode_columns.size() a row
};

/// The page's text. `traj` must have io::trajectory_columns(model) or
/// io::trajectory_body_columns(model), or their first required_columns(model) (without the
/// inputs and reactions), and at least one row (std::invalid_argument otherwise);
/// `model_file` and `source` (the trajectory's name, or "initial state") are shown on the
/// page. When some joint is not free, each body's joint type and axes are given for the page
/// to draw. Throws std::runtime_error when !available().
std::string page(const Model& model, const std::string& model_file, const io::Trajectory& traj,
                 const std::string& source);
/// The same with options: `follow` must name a body and each of `trace` a body or a frame of
/// the model (std::invalid_argument naming it otherwise), `mode_values` hold
/// mode_columns.size() values for every row of `traj`.
std::string page(const Model& model, const std::string& model_file, const io::Trajectory& traj,
                 const std::string& source, const PageOptions& options);

/// Checks the names of `options` against the model: "" or a message naming the first unknown
/// one (e.g. "--follow 'x': the model has no body 'x' (its bodies: a, b)").
std::string check_names(const Model& model, const PageOptions& options);

}  // namespace kanedyn::view
