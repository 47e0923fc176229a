// `kanedyn equilibrium MODEL [--free NAMES] [-o REST.yaml]`: the rest pose by Newton's method
// with the analytic derivatives (docs/analysis.md, "Static equilibrium"), its residual and the
// eigenvalues there, and the model file with the rest pose as its initial state.
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "commands.hpp"
#include "kanedyn/analysis.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/model_writer.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/joints.hpp"
#include "options.hpp"

namespace kanedyn::cli {

namespace {

struct Options {
  std::string model, out;
  std::vector<std::string> free;
  std::vector<std::string> inputs;
  double tolerance = 1e-10;
  int max_iterations = 50;
};

// The tangent coordinates a --free name stands for: a body's (every coordinate of its joint),
// or one coordinate by its state name (NAME.j2, NAME.r1, NAME.s3).
std::vector<int> free_coordinates(const Model& model, const std::vector<std::string>& given) {
  const std::vector<std::string> state = tangent_state_names(model);
  const int n = model.num_speeds();
  std::vector<std::string> choices;
  for (int k = 0; k < model.num_bodies(); ++k)
    if (speed_count(model.joint(k).type) > 0) choices.push_back(model.body(k).name);
  choices.insert(choices.end(), state.begin(), state.begin() + n);
  std::vector<bool> chosen(static_cast<size_t>(n), false);
  for (const std::string& name : given) {
    bool found = false;
    for (int k = 0; k < model.num_bodies(); ++k)
      if (model.body(k).name == name) {
        for (int c = 0; c < speed_count(model.joint(k).type); ++c)
          chosen[static_cast<size_t>(model.speed_offset(k) + c)] = true;
        found = speed_count(model.joint(k).type) > 0;
        if (!found)
          throw std::runtime_error("--free " + io::printable(name, 60) + ": body " + name +
                                   " is welded: it has no coordinates to free");
      }
    for (int i = 0; i < n && !found; ++i)
      if (state[static_cast<size_t>(i)] == name) {
        chosen[static_cast<size_t>(i)] = true;
        found = true;
      }
    if (!found) {
      const std::string near = io::closest_word(name, choices);
      throw std::runtime_error("--free " + io::printable(name, 60) +
                               ": not a body with coordinates or a coordinate of the model" +
                               (near.empty() ? "" : " (did you mean '" + near + "'?)"));
    }
  }
  std::vector<int> out;
  for (int i = 0; i < n; ++i)
    if (chosen[static_cast<size_t>(i)]) out.push_back(i);
  return out;
}

std::string names_of(const std::vector<std::string>& state, const std::vector<int>& indices) {
  std::string out;
  for (const int i : indices) out += (out.empty() ? "" : ", ") + state[static_cast<size_t>(i)];
  return out;
}

void run(const Options& o) {
  const io::ModelFile file = io::load_model_file(o.model);
  const Model& model = file.model;
  // A model with constraints: its constraints choose the independent coordinates.
  if (model.num_constraints() > 0 && !o.free.empty())
    throw std::runtime_error(o.model +
                             ": --free: a model with constraints moves along its independent "
                             "speeds (independent_speeds); leave --free out");
  // -o - writes the model to standard output, and the report goes to standard error.
  const bool to_stdout = o.out == "-";
  std::FILE* const report = to_stdout ? stderr : stdout;
  if (!o.out.empty() && !to_stdout) io::check_output_path(o.out, input_files());
  StateChoice choice;
  choice.inputs = o.inputs;
  const OperatingPoint op = operating_point(file, choice, "");
  EquilibriumOptions options;
  options.free = free_coordinates(model, o.free);
  if (!o.free.empty() && options.free.empty())
    throw std::runtime_error("--free: no coordinates chosen");
  options.tolerance = o.tolerance;
  options.max_iterations = o.max_iterations;
  const std::vector<std::string> state = tangent_state_names(model);
  const int n = model.num_speeds();
  const int f = options.free.empty() ? n : static_cast<int>(options.free.size());
  if (model.num_constraints() > 0)
    std::fprintf(report,
                 "static equilibrium of %s from its initial state: Newton along its independent "
                 "speeds, the constraints' reactions balancing the rest\n",
                 io::printable(file.path).c_str());
  else
    std::fprintf(
        report,
        "static equilibrium of %s from its initial state: Newton on %d of %d coordinate%s\n",
        io::printable(file.path).c_str(), f, n, n == 1 ? "" : "s");
  const EquilibriumResult rest = equilibrium(model, op.q, op.u, options);
  std::fprintf(report, "  %s\n", rest.message.c_str());
  if (!rest.converged) {
    std::ostringstream why;
    why << "no rest pose found from the initial state: after " << rest.iterations
        << (rest.iterations == 1 ? " iteration" : " iterations")
        << " the largest generalized force is " << rest.residual_norm << ".";
    if (!rest.unrestrained.empty())
      why << " Nothing restrains " << names_of(state, rest.unrestrained)
          << ": hold them (leave them out of --free) or add a bushing or joint_spring there.";
    else
      why << " Start nearer the rest pose, or hold some coordinates (--free).";
    throw std::runtime_error(why.str());
  }
  const VectorX dx = tangent_difference(model, op.q, rest.q);
  std::fprintf(report, "  moved from the initial state by:");
  int shown = 0;
  for (int i = 0; i < n; ++i)
    if (std::abs(dx[i]) > 1e-9 && shown++ < 12)
      std::fprintf(report, " %s %+.4g", state[static_cast<size_t>(i)].c_str(), dx[i]);
  if (shown > 12) std::fprintf(report, " ... (%d more)", shown - 12);
  if (shown == 0) std::fprintf(report, " nothing (it rests there)");
  std::fprintf(report, "\n");
  if (!rest.unrestrained.empty())
    std::fprintf(report, "  neutral (no restoring force): %s\n",
                 names_of(state, rest.unrestrained).c_str());
  int unstable = 0, marginal = 0;
  const double scale =
      rest.eigenvalues.size() ? std::max(1.0, rest.eigenvalues.cwiseAbs().maxCoeff()) : 1.0;
  // As linearize: a double eigenvalue is found to about sqrt(eps |A|), |A| >= the largest.
  const double tol = 10.0 * std::sqrt(std::numeric_limits<double>::epsilon() * scale);
  for (Eigen::Index i = 0; i < rest.eigenvalues.size(); ++i) {
    const double re = rest.eigenvalues[i].real();
    if (re > tol) ++unstable;
    if (std::abs(re) <= tol) ++marginal;
  }
  std::fprintf(report,
               "  eigenvalues there (held coordinates locked): %lld, largest real part %+.4g\n",
               static_cast<long long>(rest.eigenvalues.size()),
               rest.eigenvalues.size() ? rest.eigenvalues[0].real() : 0.0);
  std::fprintf(report, "  the rest pose is %s\n",
               unstable > 0   ? "unstable (an upright balance: a push topples it)"
               : marginal > 0 ? "neutrally stable (marginal eigenvalues: no damping, or a "
                                "coordinate without a restoring force)"
                              : "stable");
  if (o.out.empty()) return;
  std::ostringstream comment;
  comment << "The rest pose of " << file.path << ", found by kanedyn equilibrium: largest\n"
          << "generalized force " << rest.residual_norm << " after " << rest.iterations
          << (rest.iterations == 1 ? " Newton iteration." : " Newton iterations.");
  // The file's parameters and expressions are kept; the pose and speeds it changed are numbers.
  const std::string text = io::model_file_text(model, rest.q, VectorX::Zero(n), file.simulation,
                                               comment.str(), file.parameters);
  if (to_stdout) {
    io::write_to_stdout(text);
    return;
  }
  io::write_file_atomically(o.out, text, input_files());
  std::fprintf(report, "wrote %s (the model with the rest pose as its initial state)\n",
               io::printable(o.out).c_str());
}

void add_equilibrium(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "equilibrium",
      "Find where the model rests (z = 0, z dot = 0) by Newton's method, and write the model "
      "with that pose as its initial state");
  auto o = std::make_shared<Options>();
  cmd->footer(
      "Newton's method with the analytic derivatives moves the free coordinates (default: all) "
      "from the initial state until every generalized force on them is below the tolerance "
      "times the largest one at the start (at least 1). The others keep their values, held by "
      "reactions. A run that does not converge exits 1, writes nothing, and names the "
      "coordinates that nothing restrains. docs/analysis.md.");
  add_input_file(cmd, "MODEL", o->model, kModelHelp)->required();
  cmd->add_option("--out,-o", o->out,
                  "write the model file (YAML) with the rest pose as its initial state (- for "
                  "standard output; the report then goes to standard error)");
  cmd->add_option("--free", o->free,
                  "the bodies (every coordinate of their joints) or coordinates (NAME.j1, "
                  "NAME.r2, NAME.s3) that move; the others are held (default: all move)")
      ->delimiter(',');
  cmd->add_option("--input", o->inputs, "NAME=VALUE: an input's value (repeatable); others 0");
  cmd->add_option("--tolerance", o->tolerance,
                  "largest generalized force at rest, relative to the largest at the start "
                  "(at most 1e-3)")
      ->check(positive_number())
      ->check(CLI::Range(0.0, kMaxEquilibriumTolerance));
  cmd->add_option("--max-iterations", o->max_iterations, "Newton iterations at most")
      ->check(CLI::Range(1, 10000));
  cmd->callback([o] { run(*o); });
}

}  // namespace
KANEDYN_COMMAND(34, add_equilibrium);
}  // namespace kanedyn::cli
