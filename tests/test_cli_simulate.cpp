// `kanedyn simulate` as a user runs it: the trajectory it writes, flags and the model file's
// settings, failures that keep the partial file, checks before the run that leave nothing,
// warnings, signals and exit codes.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "file_support.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/simulate.hpp"
#include "sanitizers.hpp"

namespace fs = std::filesystem;

namespace {

using namespace kanedyn;
using test::parse;
using test::read_csv;
using test::slurp;
using test::temp_dir;

using test::kExamples;
using test::kTool;
using test::run_in;
using Result = test::ToolRun;

// ---------------------------------------------------------------------------------------------
// The command

TEST(SimulateCommand, WritesTheTrajectoryTheLibraryComputes) {
  const fs::path dir = temp_dir("cli_ok");
  const std::string model_path = kExamples + "/eight_body.yaml";
  const Result r = run_in(dir, "simulate '" + model_path + "' --t-end 0.5 --dt-out 0.1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Default output: the model file's name with .csv, in the current folder; no .partial left.
  ASSERT_TRUE(fs::exists(dir / "eight_body.csv"));
  EXPECT_FALSE(fs::exists(dir / "eight_body.csv.partial"));
  EXPECT_NE(r.out.find("trajectory: eight_body.csv (6 rows of 130 columns)"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("accepted"), std::string::npos);
  EXPECT_NE(r.out.find("derivative evaluations"), std::string::npos);
  EXPECT_NE(r.out.find(" J; change "), std::string::npos) << r.out;
  // Free bodies: their Euler parameters drift; bushings with damping: the energy falls.
  EXPECT_NE(r.out.find("Euler-parameter drift"), std::string::npos);
  EXPECT_NE(r.out.find("; not conserved by this run (damping)"), std::string::npos) << r.out;
  EXPECT_EQ(r.err, "");  // stderr is not a terminal: no progress bar

  const auto file = io::load_model_file(model_path);
  const auto rows = read_csv(dir / "eight_body.csv");
  ASSERT_EQ(rows.size(), 7u);
  EXPECT_EQ(rows[0], io::trajectory_columns(file.model));
  // The same run through the library gives the same numbers, bit for bit.
  SimulationSettings s;
  s.t_end = 0.5;
  s.dt_out = 0.1;
  size_t row = 1;
  simulate(file.model, file.initial, s,
           [&](double t, const State& st, const VectorX&, const VectorX&, Data& data) {
             const double energy = total_energy(file.model, st, data);
             ASSERT_LT(row, rows.size());
             EXPECT_EQ(parse(rows[row][0]), t);
             EXPECT_EQ(parse(rows[row][1 + 16 * 7 + 11]),
                       st.angular_velocity(7)[1]);                        // left_forearm.w2
             EXPECT_EQ(parse(rows[row][3]), data.kinematics.p_G[0].z());  // torso.z
             EXPECT_EQ(parse(rows[row].back()), energy);
             ++row;
           });
  EXPECT_EQ(row, 7u);
}

TEST(SimulateCommand, FlagsWinOverTheModelFilesSimulationSection) {
  const fs::path dir = temp_dir("cli_settings");
  std::string text = slurp(kExamples + "/eight_body.yaml");
  const size_t at = text.find("simulation:");
  ASSERT_NE(at, std::string::npos);
  text = text.substr(0, at) +
         "simulation:\n  t_end: 0.2\n  dt_out: 0.1\n  integrator: rk4\n  step: 0.002\n";
  std::ofstream(dir / "m.yaml") << text;
  Result r = run_in(dir, "simulate m.yaml");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("integrator rk4"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("100 accepted"), std::string::npos) << r.out;  // 0.2 / 0.002
  EXPECT_EQ(read_csv(dir / "m.csv").size(), 4u);                      // header + 0, 0.1, 0.2
  r = run_in(dir, "simulate m.yaml --t-end 0.3 --integrator dopri5 --out other.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("integrator dopri5 (rtol 1e-08, atol 1e-10)"), std::string::npos) << r.out;
  EXPECT_EQ(read_csv(dir / "other.csv").size(), 5u);
}

TEST(SimulateCommand, TheRouteComesFromTheFlagOrTheFile) {
  const fs::path dir = temp_dir("cli_route");
  std::string text = slurp(kExamples + "/eight_body.yaml");
  text = text.substr(0, text.find("simulation:"));
  const auto write = [&](const std::string& section) {
    std::ofstream(dir / "m.yaml") << text << "simulation:\n  t_end: 0.02\n" << section;
  };
  write("  route: assembled\n");
  Result r = run_in(dir, "simulate m.yaml");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("route assembled"), std::string::npos) << r.out;
  r = run_in(dir, "simulate m.yaml --route recursive");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("route recursive"), std::string::npos) << r.out;
  // The older spellings: `method: kane` in the file, --method kane on the command line.
  write("  method: kane\n");
  r = run_in(dir, "simulate m.yaml");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("route assembled"), std::string::npos) << r.out;
  write("");
  r = run_in(dir, "simulate m.yaml --method kane");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("route assembled"), std::string::npos) << r.out;
  write("  route: assembled\n  method: recursive\n");
  r = run_in(dir, "simulate m.yaml");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("simulation.method: give `route` or its older spelling `method`, not both"),
            std::string::npos)
      << r.err;
  write("  route: kane\n");  // the new key takes the new names only
  r = run_in(dir, "simulate m.yaml");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("simulation.route"), std::string::npos) << r.err;
}

TEST(SimulateCommand, FailureKeepsThePartialFileAndExitsNonzero) {
  // A stiff bushing (1000 rad/s) with rk4 steps of 0.01 s: far outside RK4's stability
  // region, the state grows ~400x per step and passes kStateBound (1e150) after about 0.6 s.
  const fs::path dir = temp_dir("cli_blowup");
  std::ofstream(dir / "blowup.yaml") << R"(format: kanedyn-model/1
bodies:
  - name: rattler
    parent: ground
    mass: 1.0
    inertia: [0.1, 0.1, 0.1]
    initial: {translation: [0.01, 0, 0]}
forces:
  - {type: bushing, body: rattler, stiffness: 1.0e6, damping: 0,
     rotational_stiffness: 0, rotational_damping: 0}
)";
  const Result r =
      run_in(dir, "simulate blowup.yaml --integrator rk4 --step 0.01 --dt-out 0.01 --t-end 5");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_FALSE(fs::exists(dir / "blowup.csv"));
  ASSERT_TRUE(fs::exists(dir / "blowup.csv.partial"));
  EXPECT_NE(r.err.find("kanedyn: error: diverged in the step from t = "), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("body 'rattler'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("kept in blowup.csv.partial"), std::string::npos) << r.err;
  const auto rows = read_csv(dir / "blowup.csv.partial");  // whole rows only
  EXPECT_GT(rows.size(), 20u);
  // Every field is a finite number, the states within kStateBound; times increase by dt_out.
  for (size_t i = 1; i < rows.size(); ++i) {
    for (size_t j = 0; j < rows[i].size(); ++j) {
      const double v = parse(rows[i][j]);
      EXPECT_TRUE(std::isfinite(v)) << "row " << i << " column " << j;
      if (j + 1 < rows[i].size()) {
        EXPECT_LE(std::abs(v), kStateBound) << "row " << i;
      }
    }
    EXPECT_NEAR(parse(rows[i][0]), 0.01 * static_cast<double>(i - 1), 1e-12);
  }
  // The step is 3.5x RK4's stability limit for this bushing: the command said so first.
  EXPECT_NE(r.err.find("kanedyn: warning: the rk4 step 0.01 exceeds the stability limit of "
                       "about 0.00283 set by the stiffest bushing (forces[0], on body 'rattler')"),
            std::string::npos)
      << r.err;
}

TEST(SimulateCommand, WriteErrorStopsTheRunAndKeepsWholeRows) {
  // A file size limit (ulimit -f: 100 or 200 KB, in the shell's blocks) stands in for a full
  // disk: the writer's thread gets EFBIG (the command ignores SIGXFSZ), the run stops with
  // the file's name, and the partial file holds the whole rows the message counts.
  const fs::path dir = temp_dir("cli_write_error");
  const Result r = run_in(dir, "simulate '" + kExamples + "/eight_body.yaml'", "ulimit -f 200 && ");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("kanedyn: error: cannot write 'eight_body.csv.partial'"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir / "eight_body.csv"));
  const auto rows = read_csv(dir / "eight_body.csv.partial");  // whole rows only
  ASSERT_GT(rows.size(), 1u);
  EXPECT_LT(rows.size(), 1002u);
  EXPECT_NE(r.err.find("partial trajectory (" + std::to_string(rows.size() - 1) +
                       " rows) kept in eight_body.csv.partial"),
            std::string::npos)
      << r.err;
}

TEST(SimulateCommand, UsageAndSettingErrors) {
  const fs::path dir = temp_dir("cli_usage");
  const std::string model = "'" + kExamples + "/eight_body.yaml'";
  Result r = run_in(dir, "simulate " + model + " --integrator euler");
  EXPECT_GE(r.exit_code, 2);
  r = run_in(dir, "simulate " + model + " --t-end -1");
  EXPECT_GE(r.exit_code, 2);
  r = run_in(dir, "simulate " + model + " --integrator rk4 --step 1e-25");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("the rk4 step 1e-25 cannot be honoured"), std::string::npos) << r.err;
  r = run_in(dir, "simulate " + model + " --dt-out 1e-300");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("at most 1e+12 are allowed"), std::string::npos) << r.err;
  r = run_in(dir, "simulate no-such-model.yaml");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no-such-model.yaml"), std::string::npos) << r.err;
  // None of these started a run, so none left a file behind.
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_NE(entry.path().extension(), ".partial") << entry.path();
  EXPECT_FALSE(fs::exists(dir / "eight_body.csv"));
}

// Signals are seen between steps, so a step must not take long whatever the model: the
// four-bar with its hinge written 1000 times (5000 rows, 2 independent) once spent minutes on
// each step's c x c system and took 196 s to stop. A hang check with room for a loaded or
// sanitized build, not a speed measurement: the benchmark of the route is bench/.
TEST(SimulateCommand, ManyRedundantConstraintRowsStillStopAtOnce) {
  const fs::path dir = temp_dir("cli_sigterm_rows");
  const std::string text = slurp(kExamples + "/four_bar.yaml");
  const size_t from = text.find("  - name: closure"), to = text.find("independent_speeds:");
  ASSERT_NE(from, std::string::npos);
  ASSERT_NE(to, std::string::npos);
  {
    std::ofstream out(dir / "many.yaml");
    out << text.substr(0, from);
    for (int i = 0; i < 1000; ++i) {
      std::string hinge = text.substr(from, to - from);
      hinge.replace(hinge.find("closure"), 7, "c" + std::to_string(i));
      out << hinge;
    }
    out << text.substr(to);
  }
  const pid_t pid = test::spawn_in(dir, {"simulate", "many.yaml", "--t-end", "1e6", "-o", "m.csv"});
  ASSERT_GE(pid, 0);
  const fs::path partial = dir / "m.csv.partial";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(partial) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(fs::exists(partial)) << slurp(dir / "stderr.txt");
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_EQ(kill(pid, SIGTERM), 0);
  const auto sent = std::chrono::steady_clock::now();
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  const double waited =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - sent).count();
  EXPECT_LT(waited, 5.0);
  ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGTERM) << slurp(dir / "stderr.txt");
  // The summary names the first redundant rows, not all 4998, in lines of a readable length.
  const std::string out = slurp(dir / "stdout.txt");
  EXPECT_NE(out.find("... (4986 more)"), std::string::npos) << out.substr(0, 2000);
  for (const std::string& line : test::split(out, '\n')) EXPECT_LT(line.size(), 1000u);
}

TEST(SimulateCommand, SigtermKeepsThePartialFile) {
  const fs::path dir = temp_dir("cli_sigterm");
  const std::string model = kExamples + "/chain64.yaml";
  const pid_t pid = test::spawn_in(dir, {"simulate", model, "--t-end", "1e6", "--dt-out", "0.001"});
  ASSERT_GE(pid, 0);
  // Wait until the run has begun (the header is written at once), then a little more.
  const fs::path partial = dir / "chain64.csv.partial";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!fs::exists(partial) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_EQ(kill(pid, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGTERM);
  EXPECT_FALSE(fs::exists(dir / "chain64.csv"));
  ASSERT_TRUE(fs::exists(partial));
  const auto rows = read_csv(partial);
  EXPECT_GE(rows.size(), 2u);  // the header and at least the row at t = 0
  EXPECT_EQ(rows[0].size(), 2u + 16u * 64u);
  const std::string err = slurp(dir / "stderr.txt");
  EXPECT_NE(err.find("kanedyn: SIGTERM: interrupted at t = "), std::string::npos) << err;
  EXPECT_NE(err.find("kept in chain64.csv.partial"), std::string::npos) << err;
}

// ---------------------------------------------------------------------------------------------
// Checks before the run: each fails at once (the runs asked for would take hours: a test that
// started one would time out) and leaves no file behind.

/// Every file of dir but the command's stdout.txt and stderr.txt and the given inputs.
std::vector<std::string> files_left(const fs::path& dir, const std::vector<std::string>& inputs) {
  std::vector<std::string> left;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    const std::string name = fs::relative(entry.path(), dir).string();
    if (name == "stdout.txt" || name == "stderr.txt" || entry.is_directory()) continue;
    if (std::find(inputs.begin(), inputs.end(), name) == inputs.end()) left.push_back(name);
  }
  return left;
}

const std::string kForever = " --t-end 1e9 ";  // hours of run, if it ever started

TEST(SimulateCommand, AnOutputThatCannotBeWrittenFailsBeforeTheRun) {
  const fs::path dir = temp_dir("cli_output_checks");
  const std::string model = "'" + kExamples + "/eight_body.yaml'";
  fs::create_directories(dir / "sub");
  std::ofstream(dir / "plain.txt") << "a file\n";
  const struct {
    std::string out, message;
  } cases[] = {
      {"sub", "output 'sub' is a directory: give a file name, e.g. 'sub/run.csv'"},
      {"sub/", "output 'sub/' ends with '/': give a file name, e.g. 'sub/run.csv'"},
      {".", "output '.' is a directory"},
      {"missing/run.csv", "cannot write 'missing/run.csv': its folder 'missing' does not exist"},
      {"plain.txt/run.csv", "cannot write 'plain.txt/run.csv': 'plain.txt' is not a directory"},
  };
  for (const auto& c : cases) {
    const Result r = run_in(dir, "simulate " + model + kForever + "-o '" + c.out + "'");
    EXPECT_EQ(r.exit_code, 1) << c.out;
    EXPECT_EQ(r.out, "") << c.out;  // no summary: no run
    EXPECT_NE(r.err.find("kanedyn: error: " + c.message), std::string::npos) << r.err;
    EXPECT_EQ(files_left(dir, {"plain.txt"}), std::vector<std::string>{}) << c.out;
  }
}

TEST(SimulateCommand, AnOutputThatIsTheInputIsRefused) {
  const fs::path dir = temp_dir("cli_output_is_input");
  const std::string text = slurp(kExamples + "/eight_body.yaml");
  // -o naming the model; a model named like the default output (traj.yaml -> traj.csv is
  // fine, but traj.csv -> traj.csv is not); and the partial file of -o being the model.
  std::ofstream(dir / "m.yaml") << text;
  std::ofstream(dir / "traj.csv") << text;
  std::ofstream(dir / "run.csv.partial") << text;
  const struct {
    std::string args, message;
  } cases[] = {
      {"m.yaml -o m.yaml", "output 'm.yaml' is the input file 'm.yaml'"},
      {"m.yaml -o ./m.yaml", "output './m.yaml' is the input file 'm.yaml'"},
      {"traj.csv", "output 'traj.csv' is the input file 'traj.csv'"},
      {"run.csv.partial -o run.csv",
       "output 'run.csv.partial' is the input file 'run.csv.partial'"},
  };
  for (const auto& c : cases) {
    const Result r = run_in(dir, "simulate " + c.args + kForever);
    EXPECT_EQ(r.exit_code, 1) << c.args;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
  }
  for (const char* name : {"m.yaml", "traj.csv", "run.csv.partial"})
    EXPECT_EQ(slurp(dir / name), text) << name << " was changed";
  EXPECT_EQ(files_left(dir, {"m.yaml", "traj.csv", "run.csv.partial"}), std::vector<std::string>{});
}

TEST(SimulateCommand, SettingsTheModelCannotRunFailBeforeTheRun) {
  // A chain of 5800 links has 5800 * 5801 / 2 = 16.8 million chain entries, more than the
  // Kane route builds (2^24): refused before any file exists, in the user's words.
  const fs::path dir = temp_dir("cli_kane_too_large");
  {
    std::ofstream out(dir / "long.yaml");
    out << "format: kanedyn-model/1\nbodies:\n";
    for (int k = 1; k <= 5800; ++k)
      out << "  - {name: l" << k
          << ", parent: " << (k == 1 ? "ground" : "l" + std::to_string(k - 1))
          << ", mass: 1, inertia: [1, 1, 1]}\n";
  }
  Result r = run_in(dir, "simulate long.yaml --method kane" + kForever);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("kanedyn: error: long.yaml: simulate: the model's 5800 bodies have "
                       "16822900 chain entries"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("use the recursive route"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("DataOptions"), std::string::npos) << r.err;
  EXPECT_EQ(files_left(dir, {"long.yaml"}), std::vector<std::string>{});
  // eom prints the dense [A]: refused past kMaxEomBodies, naming the file.
  r = run_in(dir, "eom long.yaml");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("kanedyn: error: long.yaml: eom prints the dense 6N x 6N [A]"),
            std::string::npos)
      << r.err;
  // bench: the Kane route only where it can be built (by default it is left out, saying so).
  r = run_in(dir, "bench long.yaml --reps 3 --method kane");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("use --route recursive"), std::string::npos) << r.err;
  r = run_in(dir, "bench long.yaml --reps 3 --json");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("timing the recursive route alone"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("\"kane\""), std::string::npos) << r.out;
}

TEST(SimulateCommand, PlantedLinksAreNeverWrittenThrough) {
  const fs::path dir = temp_dir("cli_symlink");
  std::ofstream(dir / "victim.txt") << "precious\n";
  fs::create_symlink("victim.txt", dir / "run.csv.partial");
  const std::string model = "'" + kExamples + "/eight_body.yaml'";
  Result r = run_in(dir, "simulate " + model + " --t-end 0.1 -o run.csv");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("cannot create 'run.csv.partial': it exists and is a symbolic link"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(slurp(dir / "victim.txt"), "precious\n");
  EXPECT_TRUE(fs::is_symlink(dir / "run.csv.partial"));
  EXPECT_FALSE(fs::exists(dir / "run.csv"));
  // A dangling link too (O_CREAT alone would create its target).
  fs::remove(dir / "run.csv.partial");
  fs::create_symlink("created_through_link.txt", dir / "run.csv.partial");
  r = run_in(dir, "simulate " + model + " --t-end 0.1 -o run.csv");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_FALSE(fs::exists(dir / "created_through_link.txt"));
  // A leftover regular partial file from an earlier run is replaced, not appended to.
  fs::remove(dir / "run.csv.partial");
  std::ofstream(dir / "run.csv.partial") << "left over from an interrupted run\n";
  r = run_in(dir, "simulate " + model + " --t-end 0.1 --dt-out 0.05 -o run.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(fs::exists(dir / "run.csv.partial"));
  EXPECT_EQ(read_csv(dir / "run.csv").size(), 4u);  // header, t = 0, 0.05, 0.1
}

TEST(SimulateCommand, UsageErrorsExitWithTwoAndSuggest) {
  const fs::path dir = temp_dir("cli_usage_codes");
  const std::string model = "'" + kExamples + "/eight_body.yaml'";
  const struct {
    std::string args, message;
  } cases[] = {
      {"simulat " + model, "unknown command 'simulat'; did you mean 'simulate'?"},
      {"simulate " + model + " --tend 5",
       "unknown option '--tend' for 'simulate'; did you mean "
       "'--t-end'?"},
      {"simulate " + model + " --rtol 0", "--rtol: must be a decimal number > 0, got '0'"},
      {"simulate " + model + " --atol 0", "--atol: must be a decimal number > 0, got '0'"},
      {"simulate " + model + " --rtol 1e-400",
       "--rtol: '1e-400' is too small for a double (it underflows)"},
      {"simulate " + model + " --t-end 0x10", "--t-end: must be a decimal number > 0, got '0x10'"},
      {"simulate " + model + " --t-end inf", "--t-end: must be a decimal number > 0, got 'inf'"},
      {"simulate " + model + " --t-end 1e999", "--t-end: '1e999' overflows a double"},
      {"simulate " + model + " --integrator euler", "--integrator"},
      {"simulate", "MODEL is required"},
      {"info", "MODEL is required"},
  };
  for (const auto& c : cases) {
    const Result r = run_in(dir, c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_EQ(r.err.rfind("kanedyn: error: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  EXPECT_EQ(files_left(dir, {}), std::vector<std::string>{});
  EXPECT_EQ(run_in(dir, "simulate --help").exit_code, 0);
  EXPECT_EQ(run_in(dir, "--version").exit_code, 0);
}

// ---------------------------------------------------------------------------------------------
// Failures during the run

TEST(SimulateCommand, ANonFiniteOutputIsAFailure) {
  // Gravity of 1e300: the forces m g overflow at once. Nothing non-finite reaches the file.
  const fs::path dir = temp_dir("cli_huge_gravity");
  std::string text = slurp(kExamples + "/eight_body.yaml");
  const size_t at = text.find("gravity: [0, 0, -9.81]");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 22, "gravity: [0, 0, -1e300]");
  std::ofstream(dir / "g.yaml") << text;
  const Result r = run_in(dir, "simulate g.yaml --t-end 1");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_FALSE(fs::exists(dir / "g.csv"));
  EXPECT_NE(r.out.find("(non-finite state)"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("kept in g.csv.partial"), std::string::npos) << r.err;
  const std::string partial = slurp(dir / "g.csv.partial");
  EXPECT_EQ(partial.find("nan"), std::string::npos);
  EXPECT_EQ(partial.find("inf"), std::string::npos);
}

TEST(SimulateCommand, TheSummarySaysBodyForOne) {
  const fs::path dir = temp_dir("cli_one_body");
  const std::string model = "'" + kExamples + "/tennis_racket.yaml'";
  Result r = run_in(dir, "simulate " + model + " --t-end 0.1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find(": 1 body, t = 0 to 0.1 (completed)"), std::string::npos) << r.out;
  r = run_in(dir, "info " + model);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("N = 1 body, 7 coordinates x"), std::string::npos) << r.out;
}

TEST(SimulateCommand, ATinyDtOutRunStopsAtOnceOnSignals) {
  // dt_out = 1e-9 puts about 1e5 output rows into each step: the command must still see
  // SIGINT and SIGTERM between them, and stop with the partial file kept.
  // ThreadSanitizer holds asynchronous signals and runs the handler at points of its own; in one
  // run of the TSan build a SIGINT never reached the tool's handler and the run filled the disk
  // (the same test passes in every other build, and in the TSan build run alone). The test
  // checks the signal path, not a race between threads: the other builds run it.
  if (test::kThreadSanitizer) GTEST_SKIP() << "signal delivery under ThreadSanitizer";
  for (const int sig : {SIGINT, SIGTERM}) {
    const fs::path dir = temp_dir("cli_tiny_dt_out");
    const std::string model = kExamples + "/eight_body.yaml";
    const pid_t pid =
        test::spawn_in(dir, {"simulate", model, "--dt-out", "1e-9", "-o", "tiny.csv"});
    ASSERT_GE(pid, 0);
    // Once rows are flowing (the file has grown past its header), signal.
    const fs::path partial = dir / "tiny.csv.partial";
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    std::error_code ec;
    while (!(fs::exists(partial, ec) && fs::file_size(partial, ec) > 100000) &&
           std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ASSERT_EQ(kill(pid, sig), 0);
    const auto signalled = std::chrono::steady_clock::now();
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    const double stop_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - signalled).count();
    ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);
    EXPECT_EQ(WEXITSTATUS(status), 128 + sig);
    // Not a speed measurement: without the check between rows the run went on until the disk
    // was full. Stopping takes milliseconds; 5 s allows for a loaded machine and sanitizers.
    EXPECT_LT(stop_seconds, 5.0);
    EXPECT_GE(read_csv(partial).size(), 2u);
  }
}

TEST(SimulateCommand, AStiffModelWhoseStepsCollapseIsReported) {
  // k = 1e12 N/m on 1e-6 kg (omega = 1e9 rad/s) under dopri5: steps of ~1e-10 s, 1e-8 of
  // dt_out. After a few seconds of wall time the command says so on stderr. (The starting
  // step guess of this model, 5e-21 s, lies below the smallest step: the integrator starts
  // from the smallest step instead of giving up.)
  const fs::path dir = temp_dir("cli_stiff");
  std::ofstream(dir / "stiff.yaml") << R"(format: kanedyn-model/1
bodies:
  - {name: bead, parent: ground, mass: 1.0e-6, inertia: [1.0e-9, 1.0e-9, 1.0e-9],
     initial: {translation: [0.01, 0, 0]}}
forces:
  - {type: bushing, body: bead, stiffness: 1.0e12}
)";
  const pid_t pid = test::spawn_in(dir, {"simulate", "stiff.yaml", "--t-end", "1"});
  ASSERT_GE(pid, 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  std::string err;
  while (err.find("The model is stiff") == std::string::npos &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    err = slurp(dir / "stderr.txt");
  }
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_NE(err.find("kanedyn: warning: the steps have averaged "), std::string::npos) << err;
  EXPECT_NE(err.find("of dt_out); at this rate t_end is about "), std::string::npos) << err;
  EXPECT_NE(err.find("docs/simulation.md"), std::string::npos) << err;
}

TEST(InfoCommand, ControlBytesFromTheFileAreEscaped) {
  const fs::path dir = temp_dir("cli_escape");
  std::ofstream(dir / "m.yaml") << "format: kanedyn-model/1\nname: \"red\\e[31m alert\"\n"
                                   "bodies:\n  - {name: a, parent: ground, mass: 1, "
                                   "inertia: [1, 1, 1]}\n";
  const Result r = run_in(dir, "info m.yaml");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos);
  EXPECT_NE(r.out.find("(red\\x1b[31m alert)"), std::string::npos) << r.out;
}

TEST(Examples, MakeChainNamesTheFileItWrites) {
  if (std::system("python3 --version > /dev/null 2>&1") != 0) GTEST_SKIP() << "no python3";
  const fs::path dir = temp_dir("make_chain");
  const std::string script = kExamples + "/make_chain.py";
  ASSERT_EQ(
      std::system(("python3 '" + script + "' 5 -o '" + (dir / "c5.yaml").string() + "'").c_str()),
      0);
  const std::string text = slurp(dir / "c5.yaml");
  EXPECT_NE(text.find("#   build/kanedyn simulate " + (dir / "c5.yaml").string() + "\n"),
            std::string::npos)
      << text.substr(0, 600);
  EXPECT_EQ(io::load_model_file((dir / "c5.yaml").string()).model.num_bodies(), 5);
  EXPECT_FALSE(fs::exists(dir / "c5.yaml.partial"));
}

// A jointed double pendulum released horizontally: E0 is round-off (cos(pi/2) L g), and the
// summary's ratio is to the energy that moved, not to E0 (which gave -8.7e+07).
TEST(SimulateCommand, EnergyLineNeverDividesByRoundOff) {
  const fs::path dir = temp_dir("cli_energy_line");
  const std::string model = KANEDYN_SOURCE_DIR "/tests/data/horizontal_pendulum.yaml";
  fs::copy_file(model, dir / "pendulum.yaml");
  const Result r = run_in(dir, "simulate pendulum.yaml --t-end 1 --no-output");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string key = " of ";
  const auto change = r.out.find(" J; change ");
  ASSERT_NE(change, std::string::npos) << r.out;
  const auto of = r.out.find(key, change);
  ASSERT_NE(of, std::string::npos) << r.out;
  EXPECT_NE(r.out.find("J (the run's largest kinetic energy or potential-energy swing)"),
            std::string::npos)
      << r.out;
  // The ratio, between ", " and " of ": dopri5 at rtol 1e-8 keeps it near 1e-8.
  const auto comma = r.out.rfind(", ", of);
  const double ratio = parse(r.out.substr(comma + 2, of - comma - 2));
  EXPECT_LT(std::abs(ratio), 1e-5) << r.out;
  // Revolute joints have no Euler parameters, and nothing here takes energy out.
  EXPECT_EQ(r.out.find("Euler-parameter"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("not conserved"), std::string::npos) << r.out;

  // Hanging at rest nothing moves: the absolute change alone, and why.
  std::string text = slurp(model);
  text.replace(text.find("1.5707963267948966"), 18, "0.0");
  std::ofstream(dir / "hanging.yaml") << text;
  const Result h = run_in(dir, "simulate hanging.yaml --t-end 1 --no-output");
  ASSERT_EQ(h.exit_code, 0) << h.err;
  EXPECT_NE(h.out.find("J; change 0 J (no relative change: the kinetic energy and the potential "
                       "energy's swing stayed at round-off)"),
            std::string::npos)
      << h.out;
}

}  // namespace
