// `kanedyn view MODEL [TRAJ.csv] [-o FILE.html]`: one self-contained web page (docs/viewer.md)
// that animates the model along the trajectory and plots its columns. The page is the viewer
// bundle (viewer/, built by esbuild and compiled into the tool) with the model and the
// trajectory inlined as JSON and base64 arrays: it opens from disk, offline.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "commands.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/io/trajectory.hpp"
#include "page.hpp"

namespace kanedyn::cli {
namespace {

struct Options {
  std::string model, trajectory, out;
};

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
  const std::vector<std::string> inputs{o.model, o.trajectory};
  if (!to_stdout) io::check_output_path(out, inputs);
  const io::Trajectory traj = have_traj ? io::read_trajectory(file.model, o.trajectory)
                                        : view::initial_trajectory(file.model, file.q, file.z);
  const std::string text = view::page(
      file.model, file.path, traj,
      have_traj ? std::filesystem::path(o.trajectory).filename().string() : "initial state");
  if (to_stdout) {
    io::write_to_stdout(text);
    return;
  }
  io::write_file_atomically(out, text, inputs);
  std::printf("wrote %s (%.1f kB; ", io::printable(out).c_str(), text.size() / 1000.0);
  if (have_traj)
    std::printf("%zu rows", traj.rows());
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
  cmd->add_option("MODEL", o->model, "model file (YAML or JSON)")->required();
  cmd->add_option("TRAJECTORY", o->trajectory, "trajectory CSV of this model (kanedyn simulate)");
  cmd->add_option("--out,-o", o->out,
                  "web page (default: the trajectory's, else the model's, name with .html, in "
                  "the current folder; - for standard output)");
  cmd->callback([o] { run(*o); });
}

}  // namespace
KANEDYN_COMMAND(35, add_view);
}  // namespace kanedyn::cli
