// Reading a trajectory row back (io::read_trajectory_row) and the commands that evaluate at one
// (`inspect` and `eom` with --trajectory FILE --t T).
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "file_support.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/inspect.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/trajectory.hpp"
#include "kanedyn/kane.hpp"

namespace kanedyn {
namespace {

using namespace test;

const std::string kEight = kExamples + "/eight_body.yaml";

/// A 0.1 s run of the eight-body example, rows every 0.01 s: written once per test.
fs::path eight_body_run(const std::string& name) {
  const fs::path dir = temp_dir(name);
  const ToolRun r = run_in(dir, "simulate " + kEight + " --t-end 0.1 --dt-out 0.01 -o run.csv");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return dir;
}

TEST(TrajectoryRead, TheRowsStateIsItsNumbersExactly) {
  const fs::path dir = eight_body_run("traj_read_exact");
  const auto rows = read_csv(dir / "run.csv");
  ASSERT_EQ(rows.size(), 12u);  // header + t = 0, 0.01, ..., 0.1
  const io::ModelFile file = io::load_model_file(kEight);
  const int n = file.model.num_bodies();
  for (size_t i = 1; i < rows.size(); ++i) {
    const double t = parse(rows[i][0]);
    const io::TrajectoryRow row =
        io::read_trajectory_row(file.model, (dir / "run.csv").string(), t);
    EXPECT_EQ(row.t, t);
    EXPECT_EQ(row.line, static_cast<int>(i) + 1);
    for (int k = 0; k < n; ++k) {
      const auto& f = rows[i];
      const size_t b = 1 + 16 * static_cast<size_t>(k);
      for (int c = 0; c < 4; ++c)
        EXPECT_EQ(row.state.euler_parameters(k)[c], parse(f[b + 3 + static_cast<size_t>(c)]));
      for (int c = 0; c < 3; ++c) {
        const size_t cc = static_cast<size_t>(c);
        EXPECT_EQ(row.state.translation(k)[c], parse(f[b + 7 + cc]));
        EXPECT_EQ(row.state.angular_velocity(k)[c], parse(f[b + 10 + cc]));
        EXPECT_EQ(row.state.translation_rate(k)[c], parse(f[b + 13 + cc]));
      }
    }
  }
  // The first row is the model's initial state (normalized, which it already is).
  const io::TrajectoryRow first =
      io::read_trajectory_row(file.model, (dir / "run.csv").string(), 0);
  EXPECT_EQ(first.state.y, file.initial.y);
}

TEST(TrajectoryRead, AnyTimeWithinHalfAStepSelectsTheRow) {
  const fs::path dir = eight_body_run("traj_read_window");
  const io::ModelFile file = io::load_model_file(kEight);
  const std::string csv = (dir / "run.csv").string();
  EXPECT_EQ(io::read_trajectory_row(file.model, csv, 0.0149).t, 0.01);
  EXPECT_EQ(io::read_trajectory_row(file.model, csv, 0.0151).t, 0.02);
  EXPECT_EQ(io::read_trajectory_row(file.model, csv, -0.004).t, 0.0);
  EXPECT_EQ(io::read_trajectory_row(file.model, csv, 0.104).t, 0.1);
  try {
    io::read_trajectory_row(file.model, csv, 0.2);
    ADD_FAILURE() << "accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), csv +
                                         ": no row at t = 0.2: the rows run from t = 0 to 0.1 "
                                         "(the nearest is t = 0.1, line 12)");
  }
  EXPECT_THROW(io::read_trajectory_row(file.model, csv, -0.006), std::runtime_error);
}

TEST(TrajectoryRead, ATrajectoryOfAnotherModelOrBrokenRowsIsRefused) {
  const fs::path dir = eight_body_run("traj_read_bad");
  const io::ModelFile racket = io::load_model_file(kExamples + "/tennis_racket.yaml");
  const io::ModelFile eight = io::load_model_file(kEight);
  const std::string csv = (dir / "run.csv").string();
  try {
    io::read_trajectory_row(racket.model, csv, 0.0);
    ADD_FAILURE() << "accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(csv + ":1: column 2 is 'torso.x' where this model's "
                                               "trajectory has 'racket.x'"),
              std::string::npos)
        << e.what();
  }
  // A row cut short, a field that is not a number.
  std::string text = slurp(dir / "run.csv");
  const size_t third = text.find('\n', text.find('\n', text.find('\n') + 1) + 1);
  std::ofstream(dir / "short.csv") << text.substr(0, text.rfind(',', third)) << "\n";
  EXPECT_THROW(io::read_trajectory_row(eight.model, (dir / "short.csv").string(), 0.0),
               std::runtime_error);
  std::string bad = text;
  bad.replace(bad.find(',', bad.find('\n')) + 1, 1, "x");
  std::ofstream(dir / "bad.csv") << bad;
  try {
    io::read_trajectory_row(eight.model, (dir / "bad.csv").string(), 0.0);
    ADD_FAILURE() << "accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv:2: column 'torso.x'"), std::string::npos)
        << e.what();
  }
  std::ofstream(dir / "header.csv") << text.substr(0, text.find('\n') + 1);
  EXPECT_THROW(io::read_trajectory_row(eight.model, (dir / "header.csv").string(), 0.0),
               std::runtime_error);
  EXPECT_THROW(io::read_trajectory_row(eight.model, (dir / "missing.csv").string(), 0.0),
               std::runtime_error);
}

TEST(TrajectoryRead, InspectAndEomEvaluateAtTheRow) {
  const fs::path dir = eight_body_run("traj_read_commands");
  const io::ModelFile file = io::load_model_file(kEight);
  const io::TrajectoryRow row =
      io::read_trajectory_row(file.model, (dir / "run.csv").string(), 0.05);
  ToolRun r = run_in(dir, "inspect " + kEight + " --json --trajectory run.csv --t 0.05");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  nlohmann::json j = nlohmann::json::parse(r.out);
  const Inspection in = inspect(file.model, row.state, row.t);
  EXPECT_EQ(j["t"].get<double>(), 0.05);
  for (int i = 0; i < 48; ++i)
    EXPECT_EQ(j["ydot"][static_cast<size_t>(i)].get<double>(), in.ydot[i]);
  for (int c = 0; c < 3; ++c)
    EXPECT_EQ(j["bodies"][7]["p_G"][static_cast<size_t>(c)].get<double>(), in.bodies[7].p_G[c]);
  r = run_in(dir, "eom " + kEight + " --json --trajectory run.csv --t 0.05");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  Data data(file.model);
  kane_equations(file.model, row.state, data);
  for (int i = 0; i < 48; ++i) {
    EXPECT_EQ(j["f"][static_cast<size_t>(i)].get<double>(), data.kane.f[i]);
    EXPECT_EQ(j["ydot"][static_cast<size_t>(i)].get<double>(), data.ydot[i]);
  }
  r = run_in(dir, "eom " + kEight + " --trajectory run.csv --t 0.05");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("at t = 0.05 of run.csv (line 7)"), std::string::npos) << r.out;
  // Errors: exit 1 with one line naming the file; the options need each other (usage, 2).
  r = run_in(dir, "inspect " + kEight + " --trajectory run.csv --t 7");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err,
            "kanedyn: error: run.csv: no row at t = 7: the rows run from t = 0 to 0.1 "
            "(the nearest is t = 0.1, line 12)\n");
  r = run_in(dir, "inspect " + kExamples + "/tennis_racket.yaml --trajectory run.csv --t 0");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("the trajectory is not of"), std::string::npos) << r.err;
  r = run_in(dir, "eom " + kEight + " --t 0.05");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  r = run_in(dir, "inspect " + kEight + " --trajectory run.csv");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  r = run_in(dir, "inspect " + kEight + " --trajectory run.csv --t 0x1");
  EXPECT_EQ(r.exit_code, 2) << r.err;
}

}  // namespace
}  // namespace kanedyn
