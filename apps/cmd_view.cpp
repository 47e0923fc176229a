// `kanedyn view MODEL [TRAJ.csv] [-o FILE.html]`: one self-contained web page (docs/viewer.md)
// that animates the model along the trajectory and plots its columns. With --mode K, the motion
// is mode K of the linearization about the operating point (docs/analysis.md, "Modes"). The page is
// the viewer bundle (viewer/, built by esbuild and compiled into the tool) with the model and the
// trajectory inlined as JSON and base64 arrays: it opens from disk, offline.
#include <cmath>
#include <complex>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "commands.hpp"
#include "kanedyn/analysis.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/io/trajectory.hpp"
#include "options.hpp"
#include "page.hpp"

namespace kanedyn::cli {
namespace {

struct Options {
  std::string model, trajectory, out;
  int mode = 0;  // 1-based; 0: none
  double amplitude = 0.2;
  std::string state_file;
  StateChoice state;
  std::string follow;
  std::vector<std::string> trace;
};

// Mode K about the operating point as a trajectory: x(t) = a Re(v e^(i w t)) over two periods
// (w the eigenvalue's imaginary part; a real eigenvalue's shape swings as a sin(pi t) over 2 s),
// the coordinates by retract() and the speeds z0 + x's speed part. The decay or growth is left
// out, so that the shape stays in view; the label says so.
// The page plots the mode's coordinates (x's first n entries, named as the linearization names
// them), into `page`'s mode columns, one row per row of the trajectory.
io::Trajectory mode_trajectory(const io::ModelFile& file, const Options& o, std::string& label,
                               view::PageOptions& page) {
  const Model& model = file.model;
  const OperatingPoint op = operating_point(file, o.state, o.state_file);
  const Linearization lin = linearize(model, op.q, op.z, op.u, true);
  const int count = static_cast<int>(lin.eigenvalues.size());
  if (o.mode < 1 || o.mode > count)
    throw std::runtime_error("--mode " + std::to_string(o.mode) + ": the linearization has " +
                             std::to_string(count) + " modes (1.." + std::to_string(count) +
                             "; kanedyn linearize lists them)");
  // The mode in the full tangent state (dx; dz): with constraints the dependent coordinates
  // and speeds follow the independent ones.
  const int n = model.num_speeds();
  const std::complex<double> lambda = lin.eigenvalues[o.mode - 1];
  const Eigen::VectorXcd v = lin.full_state.size() > 0
                                 ? Eigen::VectorXcd(lin.full_state.cast<std::complex<double>>() *
                                                    lin.modes.col(o.mode - 1))
                                 : Eigen::VectorXcd(lin.modes.col(o.mode - 1));
  const double shape = v.head(n).cwiseAbs().maxCoeff();
  if (!(shape > 0.0))
    throw std::runtime_error("--mode " + std::to_string(o.mode) +
                             ": it moves only speeds, not coordinates: there is no shape to show");
  const double a = o.amplitude / shape;
  const double w = std::abs(lambda.imag());
  const bool oscillates = w > 1e-9 * std::max(1.0, std::abs(lambda));
  const double duration = oscillates ? 2.0 * (2.0 * std::numbers::pi / w) : 2.0;
  const int rows = 241;
  io::Trajectory out;
  const std::vector<std::string> names = tangent_state_names(model);
  page.mode_columns.assign(names.begin(), names.begin() + n);
  page.mode_values.clear();
  for (int r = 0; r < rows; ++r) {
    const double t = duration * r / (rows - 1);
    const std::complex<double> phase =
        oscillates ? std::exp(std::complex<double>(0.0, w * t))
                   : std::complex<double>(std::sin(std::numbers::pi * t), 0.0);
    const VectorX x = a * (v * phase).real();
    page.mode_values.insert(page.mode_values.end(), x.data(), x.data() + n);
    const VectorX q = retract(model, op.q, x.head(n));
    const VectorX z = op.z + x.tail(n);
    io::Trajectory row = view::initial_trajectory(model, q, z);
    if (out.columns.empty()) out.columns = row.columns;
    row.values[0] = t;
    out.values.insert(out.values.end(), row.values.begin(), row.values.end());
  }
  const ModeReading reading = read_eigenvalue(lambda, 0.0);
  char text[200];
  std::snprintf(text, sizeof text,
                "mode %d of %d about %s: eigenvalue %.4g %+.4gi, %.4g Hz, damping %.3f "
                "(the shape; growth or decay not shown)",
                o.mode, count, op.where.c_str(), lambda.real(), lambda.imag(), reading.frequency_hz,
                reading.damping_ratio);
  label = text;
  return out;
}

void run(const Options& o) {
  // Before reading anything: a tool without the viewer says so whatever the files.
  view::require_available();
  const io::ModelFile file = io::load_model_file(o.model);
  const bool have_traj = !o.trajectory.empty();
  const std::string& named = have_traj ? o.trajectory : o.model;
  std::string out = o.out;
  if (out.empty()) out = std::filesystem::path(named).filename().replace_extension(".html");
  const bool to_stdout = out == "-";
  // Every input, by identity: the default page name of a model called run.html is the model.
  // Checked before the trajectory, which may be long, is read.
  if (!to_stdout) io::check_output_path(out, input_files());
  if (have_traj && o.mode > 0)
    throw std::runtime_error("--mode animates a mode, not a trajectory: give one of the two");
  view::PageOptions options;
  options.follow = o.follow;
  options.trace = o.trace;
  if (const std::string bad = view::check_names(file.model, options); !bad.empty())
    throw std::runtime_error(io::printable(o.model) + ": " + bad);
  std::string source =
      have_traj ? std::filesystem::path(o.trajectory).filename().string() : "initial state";
  const io::Trajectory traj = have_traj    ? io::read_trajectory(file.model, o.trajectory)
                              : o.mode > 0 ? mode_trajectory(file, o, source, options)
                                           : view::initial_trajectory(file.model, file.q, file.z);
  std::string text;
  try {
    text = view::page(file.model, file.path, traj, source, options);
  } catch (const std::invalid_argument& e) {
    if (o.mode == 0) throw;
    std::ostringstream m;
    m << "--mode " << o.mode << " --amplitude " << o.amplitude
      << ": the mode's shape at this amplitude cannot be drawn (" << e.what()
      << "); choose a smaller amplitude";
    throw std::runtime_error(m.str());
  }
  if (to_stdout) {
    io::write_to_stdout(text);
    return;
  }
  io::write_file_atomically(out, text, input_files());
  std::printf("wrote %s (%.1f kB; ", io::printable(out).c_str(), text.size() / 1000.0);
  if (have_traj)
    std::printf("%zu rows", traj.rows());
  else if (o.mode > 0)
    std::printf("%s", source.c_str());
  else
    std::printf("the initial state");
  if (view::stride(traj.rows()) > 1)
    std::printf(", decimated to 1 row in %zu", view::stride(traj.rows()));
  std::printf(")\n");
}

void add_view(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "view", "Write a self-contained web page that animates the model and plots its trajectory");
  auto o = std::make_shared<Options>();
  cmd->footer(
      "The page needs no server and makes no network request: open it from disk in a browser. "
      "Without a trajectory it shows the model's initial state. Trajectories of more than 20000 "
      "rows are decimated (the page says so). Written to OUT.partial, renamed to OUT at the end; "
      "OUT must be a regular file or not exist, and not one of the inputs. -o - writes the "
      "page to standard output.");
  add_input_file(cmd, "MODEL", o->model, kModelHelp)->required();
  add_input_file(cmd, "TRAJECTORY", o->trajectory,
                 "trajectory CSV of this model (kanedyn simulate)");
  cmd->add_option("--out,-o", o->out,
                  "web page (default: the trajectory's, else the model's, name with .html, in "
                  "the current folder; - for standard output)");
  cmd->add_option("--mode", o->mode,
                  "animate mode K (1-based, in the order kanedyn linearize lists them) of the "
                  "linearization about the initial state (or --state, --trajectory/--t)")
      ->check(CLI::Range(1, 1 << 30));
  cmd->add_option("--amplitude", o->amplitude,
                  "with --mode: the largest coordinate's swing (radians or model units; "
                  "default 0.2)")
      ->check(positive_number());
  cmd->add_option("--follow", o->follow,
                  "the camera follows this body's mass centre from the start, closer in (the "
                  "page's \"follow\" control)");
  cmd->add_option("--trace", o->trace,
                  "trace the path of this body's mass centre or this frame of the model "
                  "(repeatable, or names separated by commas; the page's \"trace\" controls)")
      ->delimiter(',')
      ->allow_extra_args(false);
  add_input_file(cmd, "--state", o->state_file,
                 "with --mode: the operating point is this model file's initial state");
  add_state_options(cmd, o->state);
  cmd->callback([o] { run(*o); });
}

}  // namespace
KANEDYN_COMMAND(35, add_view);
}  // namespace kanedyn::cli
