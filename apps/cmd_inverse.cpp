// `kanedyn inverse MODEL TRAJ.csv -o Q.csv`: the generalized forces that, added to the model's
// own loads, give a trajectory's motion (docs/model-format.md, "Generalized forces output"), by
// the O(N) inverse dynamics (Terms) at every row, the accelerations from a cubic spline through
// the rows (io::read_trajectory_motion: simulate's CSV, or a plain table of joint coordinates).
#include <charconv>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "commands.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/io/trajectory.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/terms.hpp"
#include "options.hpp"

namespace kanedyn::cli {
namespace {

void put(std::string& out, double v) {
  char buf[32];
  const auto end = std::to_chars(buf, buf + sizeof buf, v).ptr;
  out.append(buf, end);
}

void add_inverse(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "inverse",
      "Inverse dynamics of a trajectory: the generalized forces on every speed that, added to "
      "the model's own loads, give its motion");
  struct Options {
    std::string model, trajectory, out;
  };
  auto o = std::make_shared<Options>();
  cmd->footer(
      "TRAJECTORY is simulate's CSV, or a table of t and each jointed body's NAME.j1.. (its "
      "joint coordinates), with NAME.jd1.. (their rates) and input.NAME if known. Rates not "
      "given are the slopes of a cubic spline through each coordinate's column (error O(h^3) "
      "in the row spacing h); the accelerations are the slopes of the spline through each "
      "rate's column (O(h^3) from given rates, O(h^2) from differentiated ones). The model's "
      "own loads are gravity, its force elements and its inputs at the file's input columns. "
      "Output columns: t, then NAME.Q1..Qk for each body with speeds (a free body's w'_K, then "
      "s'_K dot).");
  add_input_file(cmd, "MODEL", o->model, kModelHelp)->required();
  add_input_file(cmd, "TRAJECTORY", o->trajectory,
                 "trajectory CSV of this model (simulate's, or a table of t and joint coordinates)")
      ->required();
  cmd->add_option("--out,-o", o->out,
                  "generalized forces CSV (default: the trajectory's name with .Q.csv; - for "
                  "standard output)");
  cmd->callback([o] {
    const io::ModelFile file = io::load_model_file(o->model);
    const Model& model = file.model;
    // The tree's generalized forces would ignore what the constraints carry: a wrong answer.
    if (model.num_constraints() > 0)
      throw std::runtime_error(o->model +
                               ": inverse does not handle models with constraints yet (the "
                               "tree's forces would ignore what the constraints carry)");
    std::string out = o->out;
    if (out.empty()) {
      const std::string& t = o->trajectory;
      out = (t.size() > 4 && t.compare(t.size() - 4, 4, ".csv") == 0 ? t.substr(0, t.size() - 4)
                                                                     : t) +
            ".Q.csv";
    }
    // -o - writes the table to standard output, and the report goes to standard error.
    const bool to_stdout = out == "-";
    if (!to_stdout) io::check_output_path(out, input_files());
    const io::TrajectoryMotion motion = io::read_trajectory_motion(model, o->trajectory);
    std::string text = "t";
    for (int k = 0; k < model.num_bodies(); ++k)
      for (int i = 1; i <= speed_count(model.joint(k).type); ++i)
        text += "," + model.body(k).name + ".Q" + std::to_string(i);
    text += "\n";
    Terms terms(model);
    VectorX q, z, zdot, u, Q(model.num_speeds());
    for (size_t r = 0; r < motion.t.size(); ++r) {
      const auto c = static_cast<Eigen::Index>(r);
      q = motion.q.col(c);
      z = motion.z.col(c);
      zdot = motion.zdot.col(c);
      u = motion.u.col(c);
      terms.inverse_dynamics(q, z, zdot, Q, &u);
      if (!Q.allFinite())
        throw std::runtime_error(o->trajectory + ":" + std::to_string(motion.lines[r]) +
                                 ": the generalized forces at t = " +
                                 io::printable(std::to_string(motion.t[r])) + " are not finite");
      put(text, motion.t[r]);
      for (Eigen::Index i = 0; i < Q.size(); ++i) {
        text += ',';
        put(text, Q[i]);
      }
      text += '\n';
    }
    if (to_stdout) {
      io::write_to_stdout(text);
      std::fprintf(stderr, "inverse dynamics of %s: %zu rows, %d generalized forces each\n",
                   io::printable(o->trajectory).c_str(), motion.t.size(), model.num_speeds());
      return;
    }
    io::write_file_atomically(out, text, input_files());
    std::printf("inverse dynamics of %s: %zu rows, %d generalized forces each, written to %s\n",
                io::printable(o->trajectory).c_str(), motion.t.size(), model.num_speeds(),
                io::printable(out).c_str());
  });
}

}  // namespace
KANEDYN_COMMAND(32, add_inverse);
}  // namespace kanedyn::cli
