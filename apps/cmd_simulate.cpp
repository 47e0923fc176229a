// `kanedyn simulate MODEL`: integrate the model from its initial state and write the
// trajectory CSV (docs/simulation.md). Rows stream to OUT.partial, renamed to OUT at the end;
// an interrupted or failed run keeps OUT.partial and says so.
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "commands.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/io/trajectory.hpp"
#include "kanedyn/joint.hpp"
#include "kanedyn/simulate.hpp"
#include "options.hpp"
#include "stop_signals.hpp"

namespace kanedyn::cli {
namespace {

// The defaults where neither the command line nor the model file says otherwise are
// SimulationSettings' own (io::simulation_settings).
const SimulationSettings kDefaults{};

struct Options {
  std::string model;
  std::string out;
  bool no_output = false;
  double t_end = kDefaults.t_end, dt_out = kDefaults.dt_out;
  std::string integrator, route;
  std::string inputs, inputs_hold = "zero-order";
  double rtol = kDefaults.rtol, atol = kDefaults.atol, step = kDefaults.step;
  // Which flags were given (they win over the model file's `simulation:` section).
  CLI::Option *t_end_opt = nullptr, *dt_out_opt = nullptr, *integrator_opt = nullptr,
              *route_opt = nullptr, *method_opt = nullptr, *rtol_opt = nullptr, *atol_opt = nullptr,
              *step_opt = nullptr;
};

using Clock = std::chrono::steady_clock;
double seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// ---------------------------------------------------------------------------------------------
// Progress: a bar on stderr, only when stderr is a terminal and the run has lasted a second.

class Progress {
 public:
  Progress(double t_start, double t_end)
      : t_start_(t_start), t_end_(t_end), tty_(::isatty(STDERR_FILENO) == 1) {}
  /// Returns true about once a second (the caller flushes the trajectory then).
  bool update(double t) {
    const auto now = Clock::now();
    const double elapsed = seconds(now - start_);
    if (tty_ && elapsed > 1.0 && seconds(now - last_draw_) >= 0.1) {
      draw(t, elapsed);
      last_draw_ = now;
    }
    if (seconds(now - last_tick_) >= 1.0) {
      last_tick_ = now;
      return true;
    }
    return false;
  }
  void clear() {
    if (drawn_) std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
  }

 private:
  void draw(double t, double elapsed) {
    const double span = t_end_ - t_start_;
    const double fraction = span > 0.0 ? std::clamp((t - t_start_) / span, 0.0, 1.0) : 1.0;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth);
    char bar[kWidth + 1];
    for (int i = 0; i < kWidth; ++i) bar[i] = i < filled ? '#' : '.';
    bar[kWidth] = '\0';
    const double eta = fraction > 0.0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
    std::fprintf(stderr, "\r[%s] %5.1f%%  t = %.4g of %.4g  elapsed %.1f s  left ~%.0f s ", bar,
                 100.0 * fraction, t, t_end_, elapsed, eta);
    std::fflush(stderr);
    drawn_ = true;
  }

  double t_start_, t_end_;
  bool tty_;
  bool drawn_ = false;
  Clock::time_point start_ = Clock::now(), last_draw_ = start_, last_tick_ = start_;
};

// ---------------------------------------------------------------------------------------------

SimulationSettings settings_from(const Options& o, const io::SimulationSection& file) {
  SimulationSettings s = io::simulation_settings(file);
  const auto given = [](const CLI::Option* flag) { return flag && flag->count() > 0; };
  if (given(o.t_end_opt)) s.t_end = o.t_end;
  if (given(o.dt_out_opt)) s.dt_out = o.dt_out;
  if (given(o.rtol_opt)) s.rtol = o.rtol;
  if (given(o.atol_opt)) s.atol = o.atol;
  if (given(o.step_opt)) s.step = o.step;
  if (given(o.integrator_opt)) s.integrator = parse_integrator(o.integrator);
  if (given(o.route_opt) || given(o.method_opt)) s.route = parse_route(o.route);
  return s;
}

std::string default_output(const std::string& model_path) {
  return std::filesystem::path(model_path).stem().string() + ".csv";
}

std::string format(const char* fmt, double value) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, value);
  return buf;
}

/// What makes the total energy change in this run besides the integrator's error: damping,
/// loads without a potential (constant forces and torques, joint forces) and driven inputs.
std::vector<std::string> energy_not_conserved_by(const Model& model, const SimulationSettings& s) {
  bool damping = false, loads = false;
  for (const auto& e : model.forces()) {
    damping = damping || e->dissipative();
    // An element whose work is not all in the energy: constant loads, joint forces, and any
    // element that does not say it is conservative.
    loads = loads || !e->conservative();
  }
  std::vector<std::string> why;
  if (damping) why.emplace_back("damping");
  if (loads) why.emplace_back("loads without a potential");
  if (s.inputs) why.emplace_back("driven inputs");
  return why;
}

bool has_euler_parameters(const Model& model) {
  for (int k = 0; k < model.num_bodies(); ++k) {
    const JointType t = model.joint(k).type;
    if (joint_type_info(t).euler) return true;
  }
  return false;
}

/// The energy line of the summary: the absolute change always, the relative one only against
/// the energy that moved in the run (SimulationStats::energy_scale), never against the initial
/// energy, whose size is that of the potential's datum and can be round-off.
std::string energy_line(const Model& model, const SimulationSettings& s,
                        const SimulationStats& st) {
  std::string line = "energy: " + format("%.10g", st.energy_initial) + " -> " +
                     format("%.10g", st.energy_final) + " J; change " +
                     format("%.3g", st.energy_change()) + " J";
  if (st.energy_scale > 0.0)
    line += ", " + format("%.3g", st.relative_energy_change()) + " of " +
            format("%.3g", st.energy_scale) +
            " J (the run's largest kinetic energy or potential-energy swing)";
  else
    line +=
        " (no relative change: the kinetic energy and the potential energy's swing stayed "
        "at round-off)";
  const std::vector<std::string> why = energy_not_conserved_by(model, s);
  if (!why.empty()) {
    line += "; not conserved by this run (";
    for (std::size_t i = 0; i < why.size(); ++i) line += (i ? ", " : "") + why[i];
    line += ")";
  }
  return line;
}

void print_summary(const io::ModelFile& file, const SimulationSettings& s,
                   const SimulationStats& st, const std::string& where, long rows, long columns) {
  const Model& model = file.model;
  const std::string name = model.name().empty() ? file.path : model.name();
  std::printf("simulated %s: %d %s, t = %s to %s (%s)\n", io::printable(name).c_str(),
              model.num_bodies(), model.num_bodies() == 1 ? "body" : "bodies",
              format("%.6g", s.t_start).c_str(), format("%.6g", st.t_reached).c_str(),
              to_string(st.status).c_str());
  if (s.integrator == Integrator::dopri5)
    std::printf("  integrator dopri5 (rtol %.3g, atol %.3g), route %s\n", s.rtol, s.atol,
                to_string(s.route).c_str());
  else
    std::printf("  integrator rk4 (step <= %.3g), route %s\n", s.step, to_string(s.route).c_str());
  if (s.inputs)
    std::printf("  inputs: %d, from a table of %d rows (%s hold)\n", model.num_inputs(),
                s.inputs->rows(), to_string(s.inputs->hold()).c_str());
  else if (model.num_inputs() > 0)
    std::printf("  inputs: %d, all 0 (none driven: --inputs FILE.csv drives them)\n",
                model.num_inputs());
  std::printf("  steps: %ld accepted, %ld rejected; %ld derivative evaluations; wall time %.3g s\n",
              st.steps_accepted, st.steps_rejected, st.evaluations, st.wall_seconds);
  std::printf("  %s\n", energy_line(file.model, s, st).c_str());
  if (has_euler_parameters(model))
    std::printf("  largest Euler-parameter drift before projection: %.3g\n", st.max_euler_drift);
  if (model.num_constraints() > 0) {
    std::printf("  constraints: %s\n", constraint_summary(file).c_str());
    std::printf("  largest holonomic constraint error before projection: %.3g\n",
                st.max_constraint_error);
  }
  std::printf("  trajectory: %s (%s%ld rows of %ld columns)\n", where.c_str(),
              st.ok() ? "" : "incomplete: ", rows, columns);
  std::fflush(stdout);
}

// ---------------------------------------------------------------------------------------------
// Checks before the run: they warn where a run may go wrong, in a way the user can act on.

void warn(const std::string& text) {
  std::fprintf(stderr, "kanedyn: warning: %s\n", text.c_str());
  std::fflush(stderr);
}

/// rk4 steps above the stability limit of the stiffest element make the run diverge.
void warn_rk4_stability(const Model& model, const SimulationSettings& s) {
  if (s.integrator != Integrator::rk4) return;
  int index = -1;
  const double limit = rk4_step_limit(model, &index);
  // The step taken: each output interval split evenly into steps no longer than s.step.
  const double h = s.dt_out / static_cast<double>(rk4_substeps(s.dt_out, s.step));
  if (!(h > limit) || index < 0) return;
  const int body = model.forces()[static_cast<size_t>(index)]->body();
  warn("the rk4 step " + format("%.3g", h) + " exceeds the stability limit of about " +
       format("%.3g", limit) + " set by the stiffest " +
       model.forces()[static_cast<size_t>(index)]->type() + " (forces[" + std::to_string(index) +
       "], on body '" + model.body(body).name + "'); the run will likely diverge: use --step " +
       format("%.2g", 0.5 * limit) + " or smaller, or --integrator dopri5");
}

/// A trajectory larger than the free space of its folder fails when the disk fills.
void warn_disk_space(const io::ModelFile& file, const SimulationSettings& s,
                     const std::string& out) {
  const std::filesystem::path folder = std::filesystem::path(out).has_parent_path()
                                           ? std::filesystem::path(out).parent_path()
                                           : std::filesystem::path(".");
  struct statvfs fs {};
  if (::statvfs(folder.c_str(), &fs) != 0) return;
  const double free_bytes = static_cast<double>(fs.f_bavail) * static_cast<double>(fs.f_frsize);
  const double rows = std::floor((s.t_end - s.t_start) / s.dt_out) + 2;
  // A number takes 18-22 characters in its shortest form, with its separator.
  const double columns = static_cast<double>(io::trajectory_columns(file.model).size());
  const double bytes = rows * columns * 20.0;
  if (bytes > free_bytes)
    warn("the trajectory will take about " + format("%.3g", bytes / 1e9) + " GB (" +
         format("%.3g", rows) + " rows), more than the " + format("%.3g", free_bytes / 1e9) +
         " GB free in '" + folder.string() + "'; a larger --dt-out writes fewer rows");
}

/// After the run: a rolling disc whose normal force became negative would have lifted off its
/// plane; the run held it there.
void warn_lift(const Model& model, const SimulationStats& stats) {
  for (size_t k = 0; k < stats.normal_force_negative_at.size(); ++k) {
    const double t = stats.normal_force_negative_at[k];
    if (std::isnan(t)) continue;
    warn("constraint '" + model.constraints()[k].name +
         "': the normal force becomes negative at t = " + format("%.10g", t) +
         " (the wheel would lift); the run goes on as if it held");
  }
}

/// Watches the progress of the run: a step size that has collapsed far below dt_out for
/// seconds of wall time means a stiff model that will take very long. Says so once.
/// A wall time for people: "40 s", "12 min", "3.5 h", "9.1 days".
std::string duration(double seconds) {
  if (seconds < 120.0) return format("%.2g s", seconds);
  if (seconds < 7200.0) return format("%.0f min", seconds / 60.0);
  if (seconds < 172800.0) return format("%.2g h", seconds / 3600.0);
  return format("%.2g days", seconds / 86400.0);
}

class StepWatch {
 public:
  /// `table`: the inputs table driving the run, if any (its rows cut the steps).
  StepWatch(double t_start, double t_end, double dt_out, const InputTable* table)
      : t_end_(t_end), dt_out_(dt_out), window_t_(t_start), table_(table) {}
  void step(double t) {
    ++steps_;
    if (warned_ || (steps_ & 255) != 0) return;  // the clock every 256 steps
    const auto now = Clock::now();
    const double window = seconds(now - window_start_);
    if (window < kWindowSeconds) return;
    const double mean_step = (t - window_t_) / static_cast<double>(steps_ - window_steps_);
    if (seconds(now - start_) >= kWindowSeconds && mean_step < kCollapsedFraction * dt_out_) {
      const double rate = (t - window_t_) / window;  // simulated time per wall second
      // Every row of an inputs table ends a step: when the rows crossed are most of the
      // steps, the table, not the model, sets the step.
      const long steps = steps_ - window_steps_;
      const long rows = table_ ? rows_between(window_t_, t) : 0;
      const std::string cause =
          4 * rows >= steps
              ? ". The inputs table sets the steps: it has " + std::to_string(rows) +
                    " rows in this stretch, and the integrator restarts at every row "
                    "(docs/simulation.md, \"Inputs and controllers\"); a table with fewer rows "
                    "runs faster"
              : ". The model is stiff (a very stiff bushing on a light body, say): see "
                "docs/simulation.md, \"Stiff models\"";
      warn("the steps have averaged " + format("%.3g", mean_step) + " over the last " +
           format("%.2g", window) + " s of wall time (" + format("%.2g", mean_step / dt_out_) +
           " of dt_out); at this rate t_end is " +
           (rate > 0.0 ? "about " + duration((t_end_ - t) / rate) + " away"
                       : std::string("never reached")) +
           cause);
      warned_ = true;
    }
    window_start_ = now;
    window_t_ = t;
    window_steps_ = steps_;
  }

 private:
  /// The table's rows with a time in (from, to].
  long rows_between(double from, double to) const {
    const std::vector<double>& times = table_->times();
    return std::upper_bound(times.begin(), times.end(), to) -
           std::upper_bound(times.begin(), times.end(), from);
  }

  static constexpr double kWindowSeconds = 2.0;
  static constexpr double kCollapsedFraction = 1e-3;
  double t_end_, dt_out_;
  double window_t_;
  const InputTable* table_;
  long steps_ = 0, window_steps_ = 0;
  bool warned_ = false;
  Clock::time_point start_ = Clock::now(), window_start_ = start_;
};

// ---------------------------------------------------------------------------------------------

/// Runs the command; returns the exit code for an interrupted run (0 otherwise) and throws
/// for a failed one.
int run(const Options& o) {
  const io::ModelFile file = io::load_model_file(o.model);
  const Model& model = file.model;
  const SimulationSettings base = settings_from(o, file.simulation);
  const std::string out =
      o.no_output ? std::string() : (o.out.empty() ? default_output(o.model) : o.out);
  // Everything that can be checked is checked before the output file exists.
  try {
    validate_settings(model, base);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(o.model + ": " + e.what());
  }
  if (!o.no_output) {
    io::check_output_path(out, input_files());
    warn_disk_space(file, base, out);
  }
  warn_rk4_stability(model, base);
  SimulationSettings settings = base;
  if (!o.inputs.empty()) {
    settings.inputs = std::make_shared<const InputTable>(
        io::read_input_table(model, o.inputs, parse_input_hold(o.inputs_hold)));
    try {
      validate_settings(model, settings);
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(o.inputs + ": " + e.what());
    }
  }

  // The handlers first: from the moment OUT.partial exists, a signal leaves it whole.
  StopSignals signals;
  // Rows are formatted and written on a thread of their own (their kinematics and energy
  // too): the integrating thread only copies each output state (docs/performance.md). The
  // file is created with the first row, once the initial state has passed simulate()'s
  // checks: a run refused at its start leaves no file.
  std::optional<io::BackgroundTrajectoryWriter> writer;
  const auto open_writer = [&]() -> io::BackgroundTrajectoryWriter& {
    if (!writer) writer.emplace(model, out);
    return *writer;
  };
  Progress progress(base.t_start, base.t_end);
  StepWatch watch(base.t_start, base.t_end, base.dt_out, settings.inputs.get());
  settings.observer_kinematics = false;
  settings.on_step = [&](double t) {
    if (progress.update(t) && writer) writer->flush();
    watch.step(t);
    return StopSignals::received() == 0;
  };
  const Observer observer = [&](double t, const State& state, const VectorX& q, const VectorX& z,
                                Data& data) {
    if (!o.no_output) open_writer().write_row(t, state, q, z, &data.inputs, &data.reactions);
  };
  const auto kept = [&](bool with_time, double t) {
    if (!writer)
      return std::string(o.no_output ? "no trajectory written (--no-output)"
                                     : "nothing written to " + io::printable(out));
    return "partial trajectory (" + std::to_string(writer->rows()) + " rows" +
           (with_time ? ", up to t = " + format("%.10g", t) : std::string()) + ") kept in " +
           io::printable(writer->partial_path());
  };
  SimulationStats stats;
  try {
    stats = simulate(model, file.q, file.z, settings, observer);
  } catch (const std::exception& e) {
    progress.clear();
    try {
      if (writer) writer->close();
    } catch (...) {  // e is the error to report; the partial file keeps whole rows
    }
    throw std::runtime_error(std::string(e.what()) + "; " + kept(false, 0.0));
  }
  progress.clear();
  warn_lift(model, stats);
  const long columns = static_cast<long>(io::trajectory_columns(model).size());
  const long rows = writer ? writer->rows() : 0;
  if (stats.ok()) {
    if (o.no_output) {
      print_summary(file, settings, stats, "none (--no-output)", 0, columns);
      return 0;
    }
    io::BackgroundTrajectoryWriter& w = open_writer();
    w.finish();
    print_summary(file, settings, stats, io::printable(w.path()), w.rows(), columns);
    return 0;
  }
  if (writer) writer->close();
  print_summary(file, settings, stats,
                writer ? io::printable(writer->partial_path()) : std::string("none"),
                writer ? writer->rows() : rows, columns);
  if (stats.status == SimulationStatus::interrupted) {
    const int sig = StopSignals::received();
    std::fprintf(stderr, "kanedyn: %s: %s; %s\n", signal_name(sig), stats.message.c_str(),
                 kept(true, stats.t_reached).c_str());
    return 128 + sig;
  }
  throw std::runtime_error(stats.message + "; " + kept(true, stats.t_reached));
}

void add_simulate(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "simulate", "Integrate the model from its initial state and write the trajectory CSV");
  auto o = std::make_shared<Options>();
  cmd->footer(
      "Settings not given here come from the model file's `simulation:` section, else the "
      "defaults above. The trajectory streams to OUT.partial, renamed to OUT when the run "
      "completes; a summary goes to stdout. Exit codes: 0 completed; 1 error (the partial file "
      "is kept); 130/143 interrupted by SIGINT/SIGTERM (kept too).");
  add_input_file(cmd, "MODEL", o->model, kModelHelp)->required();
  o->t_end_opt =
      cmd->add_option("--t-end", o->t_end, "end time (default 10)")->check(positive_number());
  o->dt_out_opt = cmd->add_option("--dt-out", o->dt_out, "time between output rows (default 0.01)")
                      ->check(positive_number());
  o->integrator_opt = cmd->add_option("--integrator", o->integrator, "dopri5 (default) or rk4")
                          ->check(CLI::IsMember({"dopri5", "rk4"}));
  o->rtol_opt = cmd->add_option("--rtol", o->rtol, "dopri5 relative tolerance (default 1e-8)")
                    ->check(positive_number());
  o->atol_opt = cmd->add_option("--atol", o->atol, "dopri5 absolute tolerance (default 1e-10)")
                    ->check(positive_number());
  o->step_opt = cmd->add_option("--step", o->step,
                                "rk4 step; output intervals are split evenly (default 1e-3)")
                    ->check(positive_number());
  o->route_opt =
      cmd->add_option("--route", o->route,
                      "recursive (O(N), default) or assembled (assemble [A] and {f}, Eqs. 37-38, "
                      "and solve Eq. 36)")
          ->check(route_names());
  o->method_opt = cmd->add_option("--method", o->route)->check(route_names())->group("");
  auto* out_opt = cmd->add_option(
      "--out,-o", o->out,
      "trajectory CSV (default: the model file's name with .csv, in the current folder); "
      "a regular file or none, not the model file");
  auto* no_output = cmd->add_flag("--no-output", o->no_output,
                                  "write no trajectory: the run and its summary only");
  out_opt->excludes(no_output);
  auto* inputs_opt = add_input_file(
      cmd, "--inputs", o->inputs,
      "CSV of input values over time: a header 't' and input names, then rows; held between "
      "rows (zero-order) unless --inputs-hold linear; the integrator restarts at every row");
  cmd->add_option("--inputs-hold", o->inputs_hold, "zero-order (default) or linear")
      ->check(CLI::IsMember({"zero-order", "linear"}))
      ->needs(inputs_opt);
  cmd->callback([o] {
    const int code = run(*o);
    if (code != 0) {
      std::fflush(nullptr);
      std::exit(code);
    }
  });
}

}  // namespace
KANEDYN_COMMAND(30, add_simulate);
}  // namespace kanedyn::cli
