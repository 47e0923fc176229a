// The trajectory CSV (io/csv.hpp): its columns, rows read back bit for bit, the .partial
// protocol (also against planted links and leftover files), the background writer, write
// errors and non-finite rows.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/resource.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "file_support.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/simulate.hpp"
#include "kanedyn/testing/generate.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;

namespace {

using namespace kanedyn;
using test::parse;
using test::read_csv;
using test::slurp;
using test::temp_dir;

using test::eight_body;
using test::moving_state;

TEST(TrajectoryCsv, HeaderIsTheSpecifiedColumns) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const auto columns = io::trajectory_columns(model);
  ASSERT_EQ(columns.size(), 2u + 16u * 8u);
  EXPECT_EQ(columns.front(), "t");
  EXPECT_EQ(columns.back(), "energy");
  const char* expected[] = {"x",  "y",  "z",  "e1", "e2", "e3",  "e4",  "s1",
                            "s2", "s3", "w1", "w2", "w3", "sd1", "sd2", "sd3"};
  for (int k = 0; k < 8; ++k)
    for (int i = 0; i < 16; ++i)
      EXPECT_EQ(columns[static_cast<size_t>(1 + 16 * k + i)],
                "body" + std::to_string(k + 1) + "." + expected[i]);
}

TEST(TrajectoryCsv, RowsRoundTripAndFinishRenames) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const State state = moving_state(model, 4);
  Data data(model);
  compute_kinematics(model, state, data);
  const fs::path dir = temp_dir("roundtrip");
  const std::string path = (dir / "traj.csv").string();
  {
    io::TrajectoryWriter writer(model, path);
    EXPECT_TRUE(fs::exists(path + ".partial"));
    EXPECT_FALSE(fs::exists(path));
    writer.write_row(0.1, state, data, -1.0 / 3.0);
    writer.write_row(0.2, state, data, 1e-300);
    EXPECT_EQ(writer.rows(), 2);
    writer.finish();
  }
  EXPECT_FALSE(fs::exists(path + ".partial"));
  const auto rows = read_csv(path);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0], io::trajectory_columns(model));
  EXPECT_EQ(parse(rows[1][0]), 0.1);
  EXPECT_EQ(parse(rows[2].back()), 1e-300);
  EXPECT_EQ(parse(rows[1].back()), -1.0 / 3.0);  // bit for bit
  for (int k = 0; k < 8; ++k) {
    const auto& r = rows[1];
    const size_t o = 1 + 16 * static_cast<size_t>(k);
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(parse(r[o + i]), data.kinematics.p_G[static_cast<size_t>(k)][i]);
      EXPECT_EQ(parse(r[o + 7 + i]), state.translation(k)[i]);
      EXPECT_EQ(parse(r[o + 10 + i]), state.angular_velocity(k)[i]);
      EXPECT_EQ(parse(r[o + 13 + i]), state.translation_rate(k)[i]);
    }
    for (int i = 0; i < 4; ++i) EXPECT_EQ(parse(r[o + 3 + i]), state.euler_parameters(k)[i]);
  }
}

TEST(TrajectoryCsv, EnergyOfTheKinematicsIsTotalEnergy) {
  // The command writes total_energy_of_kinematics (the kinematics simulate() computed for
  // the observer) where it wrote total_energy before: the same value, bit for bit.
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  Data a(model), b(model, DataOptions::recursive_only());
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const State state = moving_state(model, seed);
    const double reference = total_energy(model, state, a);
    compute_kinematics(model, state, b);
    EXPECT_EQ(total_energy_of_kinematics(model, state, b), reference);
  }
}

TEST(TrajectoryCsv, UnfinishedWriterLeavesOnlyThePartialFile) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const State state(model);
  Data data(model);
  compute_kinematics(model, state, data);
  const fs::path dir = temp_dir("unfinished");
  const std::string path = (dir / "traj.csv").string();
  {
    io::TrajectoryWriter writer(model, path);
    for (int i = 0; i < 3000; ++i) writer.write_row(i * 0.01, state, data, 0.0);  // > 64 KiB
  }  // destroyed without finish(), as when an exception unwinds
  EXPECT_FALSE(fs::exists(path));
  const auto rows = read_csv(path + ".partial");
  EXPECT_EQ(rows.size(), 3001u);
  EXPECT_THROW(io::TrajectoryWriter(model, (dir / "no-such-dir" / "x.csv").string()),
               std::runtime_error);
}

/// rows states of a moving system, as a trajectory would give them.
std::vector<State> some_states(const Model& model, int rows) {
  std::vector<State> states;
  for (int i = 0; i < rows; ++i) states.push_back(moving_state(model, 100 + i % 37));
  return states;
}

/// The file TrajectoryWriter writes for these rows, with the kinematics and energy the command
/// used to compute on its own thread.
std::string inline_writer_bytes(const Model& model, const std::vector<State>& states,
                                const std::string& path) {
  Data data(model, DataOptions::recursive_only());
  io::TrajectoryWriter writer(model, path);
  for (size_t i = 0; i < states.size(); ++i) {
    compute_kinematics(model, states[i], data);
    writer.write_row(0.01 * static_cast<double>(i), states[i], data,
                     total_energy_of_kinematics(model, states[i], data));
  }
  writer.finish();
  return slurp(path);
}

TEST(TrajectoryCsv, BackgroundWriterWritesTheSameBytes) {
  // The eight-body model queues up to 256 states, the 2048-body chain 19 (about 4 MB): 3000
  // and 120 rows go round each ring several times, with the producer waiting when it is full.
  const Model eight = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const Model chain = chain_model(2048).model;
  const fs::path dir = temp_dir("background");
  for (const auto& [model, rows] : {std::pair<const Model*, int>{&eight, 3000}, {&chain, 120}}) {
    const std::vector<State> states = some_states(*model, rows);
    const std::string expected = inline_writer_bytes(*model, states, (dir / "inline.csv").string());
    const std::string path = (dir / "background.csv").string();
    io::BackgroundTrajectoryWriter writer(*model, path);
    EXPECT_TRUE(fs::exists(path + ".partial"));  // with its header, at once
    for (size_t i = 0; i < states.size(); ++i) {
      writer.write_row(0.01 * static_cast<double>(i), states[i]);
      if (i % 500 == 7) writer.flush();
    }
    EXPECT_EQ(writer.rows(), rows);
    writer.finish();
    EXPECT_EQ(writer.rows(), rows);
    EXPECT_FALSE(fs::exists(path + ".partial"));
    EXPECT_EQ(slurp(path), expected) << model->num_bodies() << " bodies";
    EXPECT_THROW(writer.write_row(0.0, states[0]), std::logic_error);
  }
}

TEST(TrajectoryCsv, BackgroundWriterUnfinishedLeavesEveryQueuedRowInThePartialFile) {
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const std::vector<State> states = some_states(model, 1500);
  const fs::path dir = temp_dir("background_unfinished");
  const std::string path = (dir / "traj.csv").string();
  {
    io::BackgroundTrajectoryWriter writer(model, path);
    for (size_t i = 0; i < states.size(); ++i) writer.write_row(0.01 * i, states[i]);
  }  // destroyed without finish(), as when an exception unwinds
  EXPECT_FALSE(fs::exists(path));
  EXPECT_EQ(read_csv(path + ".partial").size(), 1501u);
  EXPECT_THROW(io::BackgroundTrajectoryWriter(model, (dir / "no-such-dir" / "x.csv").string()),
               std::runtime_error);
}

TEST(TrajectoryCsv, BackgroundWriterReportsAWriteErrorAndKeepsWholeRows) {
  // A file size limit makes write() fail (EFBIG) on the writer's thread, as a full disk would.
  // The error reaches the producer at its next call, names the file, and is thrown once more
  // by finish(); close() then does not repeat it, and the partial file ends with a whole row.
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const std::vector<State> states = some_states(model, 200);
  const fs::path dir = temp_dir("background_error");
  const std::string path = (dir / "traj.csv").string();
  constexpr rlim_t kLimit = 150000;  // about 55 rows of 2.7 KB
  struct rlimit old_limit {};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit limit = old_limit;
  limit.rlim_cur = kLimit;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &limit), 0);
  std::string message;
  long queued = 0;
  {
    io::BackgroundTrajectoryWriter writer(model, path);
    try {
      for (int round = 0; round < 100 && message.empty(); ++round)
        for (size_t i = 0; i < states.size(); ++i, ++queued) {
          writer.write_row(0.01 * queued, states[i]);
          if (i % 20 == 0) writer.flush();
        }
    } catch (const std::runtime_error& e) {
      message = e.what();
    }
    EXPECT_THROW(writer.finish(), std::runtime_error);
    EXPECT_NO_THROW(writer.close());
    EXPECT_LT(writer.rows(), queued);
  }
  setrlimit(RLIMIT_FSIZE, &old_limit);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_NE(message.find("cannot write '" + path + ".partial'"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(path));
  const std::string bytes = slurp(path + ".partial");
  ASSERT_FALSE(bytes.empty());
  EXPECT_LE(bytes.size(), kLimit);
  EXPECT_GT(read_csv(path + ".partial").size(), 1u);  // whole rows of the header's width
}

TEST(TrajectoryCsv, OutputPathsAreCheckedBeforeAnythingIsCreated) {
  const fs::path dir = temp_dir("output_checks");
  const std::string d = dir.string();
  auto problem = [](const std::string& path, const std::string& input = "") {
    try {
      io::check_output_path(path, {input});
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  std::ofstream(dir / "model.yaml") << "format: kanedyn-model/1\n";
  EXPECT_EQ(problem(d + "/run.csv"), "(accepted)");
  EXPECT_EQ(problem(d + "/run.csv", d + "/model.yaml"), "(accepted)");
  EXPECT_NE(problem(d).find("is a directory"), std::string::npos);
  EXPECT_NE(problem(d + "/").find("ends with '/'"), std::string::npos);
  EXPECT_NE(problem("").find("empty"), std::string::npos);
  EXPECT_NE(problem(d + "/nope/run.csv").find("does not exist"), std::string::npos);
  EXPECT_NE(problem(d + "/model.yaml/run.csv").find("is not a directory"), std::string::npos);
  EXPECT_NE(problem(d + "/model.yaml", d + "/model.yaml").find("is the input file"),
            std::string::npos);
  EXPECT_NE(problem(d + "/../" + dir.filename().string() + "/model.yaml", d + "/model.yaml")
                .find("is the input file"),
            std::string::npos);
  EXPECT_NE(problem(d + "/model", d + "/model.yaml").find("(accepted)"), std::string::npos);
  std::ofstream(dir / "run.csv.partial") << "x\n";
  EXPECT_NE(problem(d + "/run.csv", d + "/run.csv.partial")
                .find("'" + d +
                      "/run.csv.partial' is "
                      "the input file"),
            std::string::npos);
  // The writer checks too, and creates nothing for a refused path.
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  EXPECT_THROW(io::TrajectoryWriter(model, d), std::runtime_error);
  EXPECT_FALSE(fs::exists(d + ".partial"));
}

TEST(TrajectoryCsv, TheWriterNeverWritesThroughALink) {
  const fs::path dir = temp_dir("symlink");
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const std::string path = (dir / "run.csv").string();
  std::ofstream(dir / "victim") << "keep me\n";
  fs::create_symlink(dir / "victim", path + ".partial");
  try {
    io::TrajectoryWriter writer(model, path);
    ADD_FAILURE() << "wrote through the link";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("is a symbolic link"), std::string::npos) << e.what();
  }
  EXPECT_EQ(slurp(dir / "victim"), "keep me\n");
  // A directory of that name is refused the same way, and a leftover file is replaced.
  fs::remove(path + ".partial");
  fs::create_directory(path + ".partial");
  EXPECT_THROW(io::TrajectoryWriter(model, path), std::runtime_error);
  fs::remove(path + ".partial");
  std::ofstream(path + ".partial") << "stale rows\n";
  {
    io::TrajectoryWriter writer(model, path);
    writer.finish();
  }
  EXPECT_EQ(read_csv(path).size(), 1u);  // the header alone
}

TEST(TrajectoryCsv, ARowWithANonFiniteNumberIsRefused) {
  const fs::path dir = temp_dir("non_finite_row");
  const Model model = eight_body(Vector3(0, 0, -9.81), true, 1.0);
  const std::string path = (dir / "run.csv").string();
  const State state = moving_state(model, 3);
  Data data(model);
  compute_kinematics(model, state, data);
  io::TrajectoryWriter writer(model, path);
  writer.write_row(0.0, state, data, 1.0);
  try {
    writer.write_row(0.1, state, data, -std::numeric_limits<double>::quiet_NaN());
    ADD_FAILURE() << "a NaN energy was written";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("non-finite output at t = 0.1: column 'energy' is -nan"),
              std::string::npos)
        << e.what();
  }
  data.kinematics.p_G[2].y() = std::numeric_limits<double>::infinity();
  try {
    writer.write_row(0.2, state, data, 1.0);
    ADD_FAILURE() << "an infinite position was written";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("column 'body3.y' is inf"), std::string::npos) << e.what();
  }
  writer.close();
  const auto rows = read_csv(path + ".partial");
  ASSERT_EQ(rows.size(), 2u);  // the header and the one good row
  EXPECT_EQ(parse(rows[1][0]), 0.0);
}

}  // namespace
