// Studies: the model document, the study file's checks, the runs' values, and `kanedyn sweep`
// (threads, resume after a stop or a kill, failures, the output folder).
#include <gtest/gtest.h>

#include <dirent.h>
#include <malloc.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <chrono>
#include <cmath>
#include <set>
#include <thread>

#include "file_support.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/study.hpp"
#include "kanedyn/threads.hpp"
#include "sanitizers.hpp"

namespace kanedyn::test {
namespace {

const std::string kEightBody = kExamples + "/eight_body.yaml";
const std::string kRacket = kExamples + "/tennis_racket.yaml";

/// The lines of a results.csv with the last field (wall_s, the only one that may differ
/// between two runs of a study) cut off.
std::vector<std::string> without_wall(const fs::path& results) {
  std::vector<std::string> lines = split(slurp(results), '\n');
  for (std::string& line : lines) line = line.substr(0, line.rfind(','));
  return lines;
}

void write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

// ---- ModelDocument ---------------------------------------------------------------------------

TEST(StudyModelDocument, BuildWithoutChangesIsTheFile) {
  const auto doc = io::ModelDocument::load(kEightBody);
  const io::ModelFile file = io::load_model_file(kEightBody);
  const io::ModelFile built = doc.build({});
  ASSERT_EQ(built.model.num_bodies(), file.model.num_bodies());
  for (int k = 0; k < file.model.num_bodies(); ++k)
    EXPECT_EQ(built.model.body(k).mass, file.model.body(k).mass);
  EXPECT_EQ(built.q, file.q);
  EXPECT_EQ(built.z, file.z);
}

TEST(StudyModelDocument, AChangedNumberIsTheEditedFile) {
  // The document changed in its tree must give the model of the file edited as text.
  const std::string text = slurp(kRacket);
  const auto doc = io::ModelDocument::parse(text, "racket.yaml");
  const auto mass = doc.find_number("bodies[racket].mass");
  EXPECT_EQ(mass.value, 0.3);
  const Location at = locate(text, "mass: ^0.3");
  EXPECT_EQ(mass.line, at.line);
  EXPECT_EQ(mass.column, at.column);
  const auto w = doc.find_number("bodies[1].initial.angular_velocity[1]");
  EXPECT_EQ(w.value, 6.0);
  const std::vector<std::pair<uint32_t, double>> changes{{mass.node, 0.45}, {w.node, 5.5}};
  const io::ModelFile built = doc.build(changes);
  const io::ModelFile edited = io::parse_model_file(
      edit(edit(text, "mass: 0.3", "mass: 0.45"), "[0.001, 6.0, 0]", "[0.001, 5.5, 0]"),
      "racket.yaml");
  EXPECT_EQ(built.model.body(0).mass, edited.model.body(0).mass);
  EXPECT_EQ(built.model.body(0).mass, 0.45);
  EXPECT_EQ(built.z, edited.z);
  EXPECT_EQ(built.q, edited.q);
  // The document itself is unchanged.
  EXPECT_EQ(doc.build({}).model.body(0).mass, 0.3);
}

TEST(StudyModelDocument, AnInvalidValueIsRefusedAtItsNumber) {
  const std::string text = slurp(kRacket);
  const auto doc = io::ModelDocument::parse(text, "racket.yaml");
  const auto mass = doc.find_number("bodies[racket].mass");
  const std::vector<std::pair<uint32_t, double>> changes{{mass.node, -1.0}};
  try {
    doc.build(changes);
    ADD_FAILURE() << "accepted";
  } catch (const io::ModelFileError& e) {
    const Location at = locate(text, "mass: ^0.3");
    EXPECT_EQ(e.file(), "racket.yaml");
    EXPECT_EQ(e.line(), at.line);
    EXPECT_EQ(e.column(), at.column);
    EXPECT_NE(e.problem().find("must be > 0"), std::string::npos) << e.what();
  }
}

TEST(StudyModelDocument, KeyPathsThatNameNothingGetTheClosestKey) {
  const auto doc = io::ModelDocument::load(kEightBody);
  const auto problem = [&](const std::string& key) -> std::string {
    try {
      doc.find_number(key);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    ADD_FAILURE() << key << " accepted";
    return "";
  };
  EXPECT_NE(problem("bodies[head].mas").find("closest: 'mass'"), std::string::npos);
  EXPECT_NE(problem("bodies[haed].mass").find("closest: 'head'"), std::string::npos);
  EXPECT_NE(problem("bodies[9].mass").find("numbered 1 to 8"), std::string::npos);
  EXPECT_NE(problem("bodies[0].mass").find("numbered 1 to 8"), std::string::npos);
  EXPECT_NE(problem("forces[0].stiffness").find("forces[0].stiffness[0]"), std::string::npos);
  EXPECT_NE(problem("forces[99].stiffness").find("numbered from 0"), std::string::npos);
  EXPECT_NE(problem("forces[0].type").find("not a number"), std::string::npos);
  EXPECT_NE(problem("gravty[2]").find("closest: 'gravity'"), std::string::npos);
  EXPECT_NO_THROW(doc.find_number("forces[1].stiffness"));
  EXPECT_NO_THROW(doc.find_number("bodies[1].mass"));
}

// ---- The study file --------------------------------------------------------------------------

const std::string kGridStudy =
    "format: kanedyn-study/1\n"
    "model: MODEL\n"
    "runs: 2\n"
    "vary:\n"
    "  - key: bodies[head].mass\n"
    "    grid: [4.0, 5.0]\n"
    "  - key: forces[1].stiffness\n"
    "    values: [1.0e4, 2.0e4, 4.0e4]\n"
    "simulate: {t_end: 0.05, dt_out: 0.01}\n"
    "outputs:\n"
    "  - final: head.z\n"
    "  - max: energy\n";

std::string with_model(const std::string& study, const std::string& model) {
  return edit(study, "model: MODEL", "model: " + model);
}

TEST(StudyFile, GridsMakeTheirProductInFileOrderLastFastest) {
  const io::Study s = io::parse_study(with_model(kGridStudy, kEightBody), "grid.yaml", "");
  EXPECT_EQ(s.grid_points, 6);
  EXPECT_EQ(s.runs, 12);
  // Run i: grid point i / 2 (two runs each); the second grid varies fastest.
  const double mass[] = {4, 4, 4, 4, 4, 4, 5, 5, 5, 5, 5, 5};
  const double k[] = {1e4, 1e4, 2e4, 2e4, 4e4, 4e4, 1e4, 1e4, 2e4, 2e4, 4e4, 4e4};
  for (long i = 0; i < 12; ++i) {
    const auto p = s.parameters(i);
    EXPECT_EQ(p[0], mass[i]) << i;
    EXPECT_EQ(p[1], k[i]) << i;
  }
  const std::vector<std::string> columns{"run",          "bodies[head].mass", "forces[1].stiffness",
                                         "final:head.z", "max:energy",        "status",
                                         "wall_s"};
  EXPECT_EQ(s.columns(), columns);
}

TEST(StudyFile, DrawsDependOnSeedAndRunAlone) {
  const std::string text = "format: kanedyn-study/1\nmodel: " + kRacket +
                           "\nseed: 7\nruns: 4000\nvary:\n"
                           "  - key: bodies[1].mass\n    normal: {mean: 2.0, std: 0.5}\n"
                           "  - key: bodies[1].initial.angular_velocity[0]\n"
                           "    uniform: [-1.0, 3.0]\n"
                           "  - key: bodies[1].initial.angular_velocity[2]\n"
                           "    choice: [1.0, 2.0, 5.0]\n";
  const io::Study a = io::parse_study(text, "a.yaml", "");
  const io::Study b = io::parse_study(text, "b.yaml", "");
  const io::Study other = io::parse_study(edit(text, "seed: 7", "seed: 8"), "c.yaml", "");
  double sum = 0, sum2 = 0;
  std::set<double> choices;
  for (long i = 0; i < a.runs; ++i) {
    const auto p = a.parameters(i);
    EXPECT_EQ(p, b.parameters(i));
    EXPECT_NE(p[0], other.parameters(i)[0]);
    sum += p[0];
    sum2 += (p[0] - 2.0) * (p[0] - 2.0);
    EXPECT_GE(p[1], -1.0);
    EXPECT_LT(p[1], 3.0);
    choices.insert(p[2]);
  }
  // The sample mean of n normal draws has standard deviation std / sqrt(n) = 0.0079: 5 of
  // them (a chance of 6e-7 to fail for a correct generator).
  EXPECT_NEAR(sum / 4000.0, 2.0, 5 * 0.5 / std::sqrt(4000.0));
  // The sample variance's standard deviation is about std^2 sqrt(2 / n) = 0.0056: 5 of them.
  EXPECT_NEAR(sum2 / 4000.0, 0.25, 5 * 0.25 * std::sqrt(2.0 / 4000.0));
  EXPECT_EQ(choices, (std::set<double>{1.0, 2.0, 5.0}));
}

struct StudyBadCase {
  std::string label, from, to, at, key_path;
  std::vector<std::string> words;
};

TEST(StudyFile, RefusalsAreLocatedOneLineErrors) {
  const std::string base = with_model(kGridStudy, kEightBody);
  const std::vector<StudyBadCase> cases = {
      {"key names nothing",
       "bodies[head].mass",
       "bodies[head].mas",
       "key: ^bodies[head].mas",
       "vary[0].key",
       {"names nothing", "closest: 'mass'"}},
      {"unknown study key", "runs: 2", "rusn: 2", "^rusn", "rusn", {"unknown key", "'runs'"}},
      {"unknown column",
       "final: head.z",
       "final: head.zz",
       "final: ^head.zz",
       "outputs[0].final",
       {"no trajectory column", "closest: 'head.z'"}},
      {"bad grid",
       "grid: [4.0, 5.0]",
       "grid: [4.0, five]",
       "grid: [4.0, ^five]",
       "vary[0].grid[1]",
       {"expected a number"}},
      {"two kinds",
       "    grid: [4.0, 5.0]\n",
       "    grid: [4.0, 5.0]\n    uniform: [1, 2]\n",
       "- ^key: bodies",
       "vary[0]",
       {"exactly one of"}},
      {"draw without seed", "grid: [4.0, 5.0]", "uniform: [4.0, 5.0]", "", "seed", {"needs one"}},
      {"bad format",
       "kanedyn-study/1",
       "kanedyn-study/2",
       "format: ^kanedyn",
       "format",
       {"unsupported format"}},
      {"bad settings", "t_end: 0.05", "t_end: -1", "t_end: ^-1", "simulate.t_end", {"must be > 0"}},
      {"bad trajectories",
       "  - max: energy\n",
       "  - max: energy\ntrajectories: some\n",
       "trajectories: ^some",
       "trajectories",
       {"every N"}},
      {"missing model",
       "model: " + kEightBody,
       "model: nowhere.yaml",
       "model: ^nowhere.yaml",
       "model",
       {"'nowhere.yaml'", "cannot open"}},
      {"unknown input",
       "bodies[head].mass",
       "inputs[0]",
       "key: ^inputs[0]",
       "vary[0].key",
       {"no inputs"}},
      // One number under two spellings: each run would take the later value, the table show
      // the first's.
      {"one number, two spellings",
       "forces[1].stiffness",
       "bodies[5].mass",
       "key: ^bodies[5].mass",
       "vary[1].key",
       {"'bodies[5].mass'", "vary[0].key 'bodies[head].mass'", "varies already"}},
      // The study's simulate.t_end overrides the model's in every run: its values would not
      // be used.
      {"varied setting overridden",
       "forces[1].stiffness",
       "simulation.t_end",
       "key: ^simulation.t_end",
       "vary[1].key",
       {"'simulation.t_end'", "simulate.t_end overrides"}},
      {"too many runs",
       "runs: 2",
       "runs: 1000000000",
       "runs: ^1000000000",
       "runs",
       {"'1000000000' is more than 10^7 runs", "Limits"}},
      {"too many runs with the grids",
       "runs: 2",
       "runs: 2000000",
       "runs: ^2000000",
       "runs",
       {"the grids times `runs` make more than 10^7 runs"}},
  };
  for (const StudyBadCase& c : cases) {
    SCOPED_TRACE(c.label);
    const std::string text = edit(base, c.from, c.to);
    try {
      io::parse_study(text, "bad.yaml", "");
      ADD_FAILURE() << "accepted";
    } catch (const io::StudyFileError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      EXPECT_EQ(e.file(), "bad.yaml");
      EXPECT_EQ(e.key_path(), c.key_path) << what;
      if (!c.at.empty()) {
        const Location loc = locate(text, c.at);
        EXPECT_EQ(e.line(), loc.line) << what;
        EXPECT_EQ(e.column(), loc.column) << what;
      }
      for (const std::string& w : c.words)
        EXPECT_NE(e.problem().find(w), std::string::npos) << "'" << w << "' not in: " << what;
    }
  }
}

// ---- Runs ------------------------------------------------------------------------------------

TEST(StudyRun, AnInvalidValueIsTheRunsStatusNotTheStudys) {
  const std::string text =
      edit(with_model(kGridStudy, kEightBody), "grid: [4.0, 5.0]", "grid: [4.0, -5.0]");
  const io::Study s = io::parse_study(text, "s.yaml", "");
  const io::StudyRun ok = io::run_study_run(s, 0);
  EXPECT_EQ(ok.status, "ok");
  const io::StudyRun bad = io::run_study_run(s, 6);
  EXPECT_EQ(io::status_kind(bad.status), "invalid model");
  // The model named as the study names it, at the number's place, with the model's problem.
  EXPECT_NE(bad.status.find(kEightBody + ":"), std::string::npos) << bad.status;
  EXPECT_NE(bad.status.find("must be > 0"), std::string::npos) << bad.status;
  // Its output cells are empty and the status is one quoted field.
  const auto fields = split(bad.row, ',');
  EXPECT_EQ(fields[0], "6");
  EXPECT_EQ(fields[2 + 1], "");
  EXPECT_EQ(fields[2 + 2], "");
}

// ---- kanedyn sweep ---------------------------------------------------------------------------

/// A study of the racket in `dir`: 24 runs of 0.5 s, draws and a grid, every 4th trajectory.
fs::path racket_study(const fs::path& dir, long runs = 12, double t_end = 0.5) {
  fs::copy_file(kRacket, dir / "racket.yaml");
  write(dir / "study.yaml",
        "format: kanedyn-study/1\nmodel: racket.yaml\nseed: 3\nruns: " + std::to_string(runs) +
            "\nvary:\n"
            "  - key: bodies[racket].initial.angular_velocity[0]\n"
            "    uniform: [0.0005, 0.002]\n"
            "  - key: bodies[racket].initial.angular_velocity[1]\n"
            "    grid: [5.0, 6.0]\n"
            "simulate: {t_end: " +
            std::to_string(t_end) +
            ", dt_out: 0.01}\n"
            "outputs:\n  - final: racket.w2\n  - min: racket.w2\n"
            "  - mean: racket.w1\n  - rms: racket.w1\n  - max: energy\n"
            "trajectories: every 4\n");
  return dir / "study.yaml";
}

TEST(StudySweep, RunIAloneIsRowI) {
  const fs::path dir = temp_dir("study_alone");
  racket_study(dir);
  const ToolRun r = run_in(dir, "sweep study.yaml -o out -j 2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rows = read_csv(dir / "out/results.csv");
  ASSERT_EQ(rows.size(), 25u);
  const std::string model = slurp(dir / "racket.yaml");
  for (const long i : {0L, 4L, 13L}) {
    SCOPED_TRACE(i);
    const auto& row = rows[static_cast<size_t>(i) + 1];
    ASSERT_EQ(row[0], std::to_string(i));
    // The model file with run i's numbers, from the table, simulated by `kanedyn simulate`.
    write(dir / "alone.yaml",
          edit(model, "[0.001, 6.0, 0]", "[" + row[1] + ", " + row[2] + ", 0]"));
    const ToolRun s = run_in(dir, "simulate alone.yaml --t-end 0.5 --dt-out 0.01 -o alone.csv");
    ASSERT_EQ(s.exit_code, 0) << s.err;
    const auto traj = read_csv(dir / "alone.csv");
    const auto column = [&](const std::string& name) {
      const auto it = std::find(traj[0].begin(), traj[0].end(), name);
      EXPECT_NE(it, traj[0].end());
      return static_cast<size_t>(it - traj[0].begin());
    };
    const size_t w1 = column("racket.w1"), w2 = column("racket.w2"), e = column("energy");
    double min_w2 = INFINITY, max_e = -INFINITY, sum = 0, sum2 = 0;
    for (size_t k = 1; k < traj.size(); ++k) {
      min_w2 = std::min(min_w2, parse(traj[k][w2]));
      max_e = std::max(max_e, parse(traj[k][e]));
      sum += parse(traj[k][w1]);
      sum2 += parse(traj[k][w1]) * parse(traj[k][w1]);
    }
    const double n = static_cast<double>(traj.size() - 1);
    // The same numbers through the same code: equal bits (the CSV's numbers round-trip).
    EXPECT_EQ(parse(row[3]), parse(traj.back()[w2]));
    EXPECT_EQ(parse(row[4]), min_w2);
    EXPECT_EQ(parse(row[5]), sum / n);
    EXPECT_EQ(parse(row[6]), std::sqrt(sum2 / n));
    EXPECT_EQ(parse(row[7]), max_e);
    EXPECT_EQ(row[8], "ok");
    if (i % 4 == 0) {
      char name[32];
      std::snprintf(name, sizeof name, "out/runs/run_%06ld.csv", i);
      EXPECT_EQ(slurp(dir / name), slurp(dir / "alone.csv"));
    }
  }
}

TEST(StudySweep, AnInputsValueHoldsForTheWholeRun) {
  // inputs[NAME] is a constant input: the run is `simulate --inputs` with a one-row table.
  const fs::path dir = temp_dir("study_inputs");
  write(dir / "racket.yaml", slurp(kRacket) +
                                 "inputs:\n  - name: spin\n    type: torque\n    body: racket\n"
                                 "    axis: [0, 0, 1]\n");
  write(dir / "study.yaml",
        "format: kanedyn-study/1\nmodel: racket.yaml\nvary:\n"
        "  - key: inputs[spin]\n    values: [0.0, 0.02]\n"
        "simulate: {t_end: 0.3, dt_out: 0.01}\n"
        "outputs:\n  - final: racket.w3\n  - max: input.spin\ntrajectories: all\n");
  const ToolRun r = run_in(dir, "sweep study.yaml -o out");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rows = read_csv(dir / "out/results.csv");
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0][1], "inputs[spin]");
  EXPECT_EQ(parse(rows[2][3]), 0.02);  // held from the start to the end
  write(dir / "u.csv", "t,spin\n0,0.02\n");
  const ToolRun s =
      run_in(dir, "simulate racket.yaml --t-end 0.3 --dt-out 0.01 --inputs u.csv -o alone.csv");
  ASSERT_EQ(s.exit_code, 0) << s.err;
  EXPECT_EQ(slurp(dir / "out/runs/run_000001.csv"), slurp(dir / "alone.csv"));
  EXPECT_NE(parse(rows[1][2]), parse(rows[2][2]));  // the torque changed w3
}

TEST(StudySweep, OneTwoAndFourThreadsGiveTheSameTable) {
  const fs::path dir = temp_dir("study_threads");
  racket_study(dir, 10);
  for (const char* j : {"1", "2", "4"}) {
    const ToolRun r = run_in(dir, std::string("sweep study.yaml -o out") + j + " -j " + j);
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  const auto one = without_wall(dir / "out1/results.csv");
  EXPECT_EQ(one.size(), 22u);
  EXPECT_EQ(one, without_wall(dir / "out2/results.csv"));
  EXPECT_EQ(one, without_wall(dir / "out4/results.csv"));
  for (const char* f : {"run_000000.csv", "run_000004.csv", "run_000016.csv"})
    EXPECT_EQ(slurp(dir / "out1/runs" / f), slurp(dir / "out4/runs" / f)) << f;
}

/// A study of the eight-body figure in `dir`: `runs` draws of one bushing's stiffness at each of
/// two head masses, `t_end` long, every 50th trajectory kept.
fs::path eight_body_study(const fs::path& dir, long runs, double t_end) {
  fs::copy_file(kEightBody, dir / "eight_body.yaml");
  write(dir / "study.yaml",
        "format: kanedyn-study/1\nmodel: eight_body.yaml\nseed: 11\nruns: " + std::to_string(runs) +
            "\nvary:\n"
            "  - key: bodies[head].mass\n    grid: [4.0, 6.0]\n"
            "  - key: forces[1].stiffness\n    uniform: [2.0e4, 8.0e4]\n"
            "simulate: {t_end: " +
            std::to_string(t_end) +
            ", dt_out: 0.01}\n"
            "outputs:\n  - final: head.z\n  - max: energy\n"
            "trajectories: every 50\n");
  return dir / "study.yaml";
}

/// Waits up to 20 s for the first manifest part of `out`.
bool wait_for_part(const fs::path& out) {
  for (int i = 0; i < 400; ++i) {
    if (fs::exists(out / "manifest/part_000001.csv")) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

TEST(StudySweep, StoppedOrKilledAndStartedAgainGivesTheSameTable) {
  // ThreadSanitizer holds asynchronous signals and runs the handler at points of its own (see
  // SimulateCommand's signal test); this test checks the signal and resume paths, not a race:
  // the other builds run it, and the TSan build runs the threaded tests above.
  if (kThreadSanitizer) GTEST_SKIP() << "signal delivery under ThreadSanitizer";
  const fs::path dir = temp_dir("study_resume");
  // 1000 runs of 2 s of the eight-body figure: about 5 s on one thread, so that the stops land
  // in the middle of the study. AddressSanitizer's debug build runs them several times slower,
  // so there runs of 0.4 s take about as long.
  eight_body_study(dir, 500, kAddressSanitizer ? 0.4 : 2.0);
  ASSERT_EQ(run_in(dir, "sweep study.yaml -o whole -j 2").exit_code, 0);
  const auto whole = without_wall(dir / "whole/results.csv");

  // Ctrl-C: stops within a second, keeps the finished runs, says how to resume.
  const pid_t pid = spawn_in(dir, {"sweep", "study.yaml", "-o", "out", "-j", "1"});
  ASSERT_TRUE(wait_for_part(dir / "out"));
  const auto sent = std::chrono::steady_clock::now();
  kill(pid, SIGINT);
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - sent).count(), 1.0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 130);
  const std::string err = slurp(dir / "stderr.txt");
  EXPECT_NE(err.find("resume with: kanedyn sweep study.yaml -o out"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "out/results.csv"));

  // SIGKILL in the middle: whatever it leaves (here also a temporary file cut short, as a
  // kill mid-write leaves) is not taken for a finished run.
  const pid_t again = spawn_in(dir, {"sweep", "study.yaml", "-o", "out", "-j", "1"});
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  kill(again, SIGKILL);
  waitpid(again, &status, 0);
  write(dir / "out/manifest/part_000999.csv.partial", "# kanedyn-study manifest 1, fing");
  write(dir / "out/runs/run_000050.csv.partial", "t,racket.x\n0,");
  const ToolRun resumed = run_in(dir, "sweep study.yaml -o out -j 2");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  EXPECT_NE(resumed.out.find("done before, resumed"), std::string::npos) << resumed.out;
  EXPECT_EQ(without_wall(dir / "out/results.csv"), whole);
  for (const auto& e : fs::recursive_directory_iterator(dir / "out"))
    EXPECT_FALSE(e.path().string().ends_with(".partial")) << e.path();
  // Started again when done, it runs nothing and writes the same table.
  const ToolRun done = run_in(dir, "sweep study.yaml -o out");
  EXPECT_EQ(done.exit_code, 0);
  EXPECT_NE(done.out.find("0 run now"), std::string::npos) << done.out;
  EXPECT_EQ(without_wall(dir / "out/results.csv"), whole);
}

TEST(StudySweep, EveryRunFailingExitsNonzeroWithTheFailuresByKind) {
  const fs::path dir = temp_dir("study_fail");
  fs::copy_file(kRacket, dir / "racket.yaml");
  write(dir / "study.yaml",
        "format: kanedyn-study/1\nmodel: racket.yaml\nvary:\n"
        "  - key: bodies[racket].mass\n    grid: [-1, 0]\n"
        "  - key: bodies[racket].inertia[0]\n    grid: [0.0022, 1.0]\n"
        "simulate: {t_end: 0.1}\ntrajectories: all\n");
  const ToolRun r = run_in(dir, "sweep study.yaml -o out");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.out.find("failed: 4"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("invalid model: 4"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("every run of the study failed"), std::string::npos) << r.err;
  // The header and one row per run (the statuses hold commas: count lines).
  EXPECT_EQ(split(slurp(dir / "out/results.csv"), '\n').size(), 6u);
  // Runs refused before they began have no trajectory, and are done: nothing runs again.
  EXPECT_TRUE(fs::is_empty(dir / "out/runs"));
  const ToolRun again = run_in(dir, "sweep study.yaml -o out");
  EXPECT_NE(again.out.find("0 run now"), std::string::npos) << again.out;
}

TEST(StudySweep, AFullDiskStopsTheStudyKeepingTheRunsDone) {
  const fs::path dir = temp_dir("study_full");
  fs::copy_file(kRacket, dir / "racket.yaml");
  // The model's own t_end is varied: the last run's trajectory (301 rows, about 100 kB) is
  // over the file size limit of 16 kB, the first two (6 and 7 rows) are not.
  write(dir / "study.yaml",
        "format: kanedyn-study/1\nmodel: racket.yaml\nvary:\n"
        "  - key: simulation.t_end\n    grid: [0.05, 0.06, 3.0]\n"
        "outputs:\n  - final: racket.w2\ntrajectories: all\n");
  const ToolRun r = run_in(dir, "sweep study.yaml -o out -j 1", "ulimit -f 16 && ");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("run_000002.csv.partial': File too large"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("2 of 3 runs are kept"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out/results.csv"));
  EXPECT_FALSE(fs::exists(dir / "out/runs/run_000002.csv.partial"));
  EXPECT_TRUE(fs::exists(dir / "out/runs/run_000001.csv"));
  const ToolRun resumed = run_in(dir, "sweep study.yaml -o out -j 1");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  EXPECT_NE(resumed.out.find("1 run now"), std::string::npos) << resumed.out;
  EXPECT_EQ(split(slurp(dir / "out/results.csv"), '\n').size(), 5u);
}

TEST(StudySweep, AManifestPartCutShortIsRefusedNamingIt) {
  // Parts are renamed when whole; one cut short all the same (a crash of the machine before
  // the disk had it) is not taken for finished runs.
  const fs::path dir = temp_dir("study_cut");
  racket_study(dir, 2, 0.1);
  ASSERT_EQ(run_in(dir, "sweep study.yaml -o out").exit_code, 0);
  const fs::path part = dir / "out/manifest/part_000001.csv";
  const std::string text = slurp(part);
  write(part, text.substr(0, text.size() - 5));
  const ToolRun r = run_in(dir, "sweep study.yaml -o out");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("part_000001.csv' line 6: not a whole row"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("remove the file to run its runs again"), std::string::npos) << r.err;
  fs::remove(part);
  const ToolRun again = run_in(dir, "sweep study.yaml -o out");
  EXPECT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.out.find("4 run now"), std::string::npos) << again.out;
}

TEST(StudySweep, WritesNothingOutsideItsFolderAndRefusesAnotherStudys) {
  const fs::path dir = temp_dir("study_folder");
  racket_study(dir, 2, 0.1);
  const auto listing = [&] {
    std::set<std::string> names;
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (!e.path().string().starts_with((dir / "out").string()))
        names.insert(fs::relative(e.path(), dir).string());
    return names;
  };
  const std::set<std::string> before = listing();
  const ToolRun r = run_in(dir, "sweep study.yaml -o out");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::set<std::string> after = listing();
  after.erase("stdout.txt");
  after.erase("stderr.txt");
  EXPECT_EQ(after, before);
  std::set<std::string> out;
  for (const auto& e : fs::directory_iterator(dir / "out")) out.insert(e.path().filename());
  EXPECT_EQ(out, (std::set<std::string>{"study.yaml", "results.csv", "manifest", "runs"}));
  EXPECT_EQ(slurp(dir / "out/study.yaml"), slurp(dir / "study.yaml"));
  // The same folder for a changed study is refused: its runs would not be this study's.
  write(dir / "study.yaml", edit(slurp(dir / "study.yaml"), "seed: 3", "seed: 4"));
  const ToolRun other = run_in(dir, "sweep study.yaml -o out");
  EXPECT_EQ(other.exit_code, 1);
  EXPECT_NE(other.err.find("holds the runs of another study"), std::string::npos) << other.err;
}

// ---- Refusals of what a study names ----------------------------------------------------------

TEST(StudyFile, AnInputUnderTwoSpellingsIsRefused) {
  const std::string model = slurp(kRacket) +
                            "inputs:\n  - name: spin\n    type: torque\n    body: racket\n"
                            "    axis: [0, 0, 1]\n";
  const std::string text =
      "format: kanedyn-study/1\nmodel: racket.yaml\nvary:\n"
      "  - key: inputs[0]\n    values: [0.0, 0.02]\n"
      "  - key: inputs[spin]\n    values: [0.1]\n";
  try {
    io::parse_study(text, "s.yaml", "", &model);
    ADD_FAILURE() << "accepted";
  } catch (const io::StudyFileError& e) {
    const Location at = locate(text, "key: ^inputs[spin]");
    EXPECT_EQ(e.line(), at.line) << e.what();
    EXPECT_EQ(e.column(), at.column) << e.what();
    EXPECT_EQ(e.key_path(), "vary[1].key");
    EXPECT_NE(e.problem().find("'inputs[spin]' is the number that vary[0].key 'inputs[0]'"),
              std::string::npos)
        << e.what();
  }
}

TEST(StudyFile, AModelThatIsNotAModelFileIsNotQuoted) {
  // `model:` may name any file; a refusal of its contents would show them.
  const fs::path dir = temp_dir("study_foreign_model");
  const std::vector<std::pair<std::string, std::string>> foreign = {
      {"passwd", "root:x:0:0:SECRET:/root:/bin/bash\ndaemon:x:1:1:daemon\n"},
      {"config.yaml", "password: SECRET\nuser: me\n"},
      {"study.yaml", "format: kanedyn-study/1\nmodel: SECRET.yaml\n"},
      {"binary", std::string("\x7f"
                             "ELF\x02\x01\x01\0\0SECRET\x01\x02[{",
                             18)},
      {"broken.yaml", "{SECRET: [unclosed\n"},
  };
  for (const auto& [name, contents] : foreign) {
    SCOPED_TRACE(name);
    write(dir / name, contents);
    const std::string text =
        "format: kanedyn-study/1\nmodel: " + (dir / name).string() + "\nruns: 2\n";
    for (const bool given : {false, true}) {  // read from the file, or given as text (dask)
      try {
        io::parse_study(text, "s.yaml", "", given ? &contents : nullptr);
        ADD_FAILURE() << "accepted";
      } catch (const io::ModelFileError& e) {
        const std::string what = e.what();
        EXPECT_EQ(what.find("SECRET"), std::string::npos) << what;
        EXPECT_NE(what.find("is not a model file"), std::string::npos) << what;
        EXPECT_EQ(e.key_path(), "model") << what;
        EXPECT_EQ(e.line(), 2) << what;
      }
    }
  }
  // A model file refused is still told where and why, in its own words.
  const std::string racket = edit(slurp(kRacket), "mass: 0.3", "mass: -0.3");
  write(dir / "racket.yaml", racket);
  try {
    io::parse_study("format: kanedyn-study/1\nmodel: racket.yaml\n", "s.yaml", dir.string());
    ADD_FAILURE() << "accepted";
  } catch (const io::ModelFileError& e) {
    EXPECT_EQ(e.line(), locate(racket, "mass: ^-0.3").line) << e.what();
    EXPECT_NE(e.problem().find("must be > 0"), std::string::npos) << e.what();
  }
}

// ---- Limits ----------------------------------------------------------------------------------

/// The bytes malloc has handed out and not had back (0 under the sanitizers, which own malloc).
long heap_bytes() {
#if KANEDYN_TEST_ADDRESS_SANITIZER || KANEDYN_TEST_THREAD_SANITIZER
  return 0;
#else
  const struct mallinfo2 m = mallinfo2();
  return static_cast<long>(m.uordblks + m.hblkhd);
#endif
}

TEST(StudyFolder, TheMostRunsCostNothingBeforeTheyRun) {
  // 10^7 runs (the most a study may have): opening the folder and sweeping a few of them holds
  // nothing per run of the study (a list of the missing runs was 80 MB).
  const fs::path dir = temp_dir("study_many_runs");
  fs::copy_file(kRacket, dir / "racket.yaml");
  write(dir / "study.yaml",
        "format: kanedyn-study/1\nmodel: racket.yaml\nseed: 1\nruns: 10000000\nvary:\n"
        "  - key: bodies[racket].initial.angular_velocity[0]\n    uniform: [0.0005, 0.002]\n"
        "simulate: {t_end: 0.01, dt_out: 0.01}\noutputs:\n  - final: racket.w2\n");
  const io::Study study = io::load_study((dir / "study.yaml").string());
  EXPECT_EQ(study.runs, io::kMaxStudyRuns);
  const long before = heap_bytes();
  io::StudyFolder folder(study, (dir / "out").string());
  EXPECT_EQ(folder.next_missing(0), 0);
  EXPECT_LT(heap_bytes() - before, 1L << 20);
  long peak = 0;
  const auto start = std::chrono::steady_clock::now();
  io::SweepOptions options;
  options.threads = 2;
  options.stop = [&] {
    peak = std::max(peak, heap_bytes() - before);
    return std::chrono::steady_clock::now() - start > std::chrono::milliseconds(500);
  };
  const io::SweepResult result = io::sweep(study, folder, options);
  EXPECT_TRUE(result.stopped);
  EXPECT_GT(folder.done(), 0);
  EXPECT_LT(peak, 16L << 20) << folder.done() << " runs done";
  // Started again, the folder has the runs done, and the first missing run after them.
  io::StudyFolder again(study, (dir / "out").string());
  EXPECT_EQ(again.done(), folder.done());
  EXPECT_FALSE(again.is_done(again.next_missing(0)));
}

/// The threads of this process.
int task_count() {
  int n = 0;
  if (DIR* d = opendir("/proc/self/task")) {
    while (const dirent* e = readdir(d)) n += e->d_name[0] != '.';
    closedir(d);
  }
  return n;
}

TEST(StudySweep, MoreThreadsThanTheMachineRunsAreCapped) {
  const fs::path dir = temp_dir("study_600_threads");
  eight_body_study(dir, 100, kAddressSanitizer ? 0.4 : 2.0);
  const io::Study study = io::load_study((dir / "study.yaml").string());
  io::StudyFolder folder(study, (dir / "out").string());
  const int hardware = hardware_threads();
  const int before = task_count();
  int most = 0;
  io::SweepOptions options;
  options.threads = 600;
  options.progress = [&](long, long) { most = std::max(most, task_count() - before); };
  const io::SweepResult result = io::sweep(study, folder, options);
  EXPECT_FALSE(result.stopped);
  EXPECT_EQ(result.threads, std::min(hardware, 200));
  EXPECT_LE(most, hardware);
  EXPECT_GT(most, 0);
  // The tool says how many ran.
  const ToolRun r = run_in(dir, "sweep study.yaml -o out600 -j 600");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string threads = std::to_string(std::min(hardware, 200)) + " thread";
  EXPECT_NE(r.out.find("run now on " + threads), std::string::npos) << r.out;
}

struct Limit {
  int resource;
  rlim_t value;
};

/// spawn_in's `kanedyn ARGS...` in DIR, under resource limits (setrlimit before exec), with
/// `env` ("NAME=VALUE") added to the environment.
pid_t spawn_limited(const fs::path& dir, const std::vector<std::string>& args,
                    const std::vector<Limit>& limits, std::vector<std::string> env = {}) {
  std::vector<std::string> words{"kanedyn"};
  words.insert(words.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);
  std::vector<char*> envp;
  for (std::string& e : env) envp.push_back(e.data());
  for (char** e = environ; *e; ++e) envp.push_back(*e);
  envp.push_back(nullptr);
  const pid_t pid = fork();
  if (pid != 0) return pid;
  // The child: only async-signal-safe calls until exec.
  if (chdir(dir.c_str()) != 0) _exit(99);
  for (const Limit& l : limits) {
    const struct rlimit r { l.value, l.value };
    if (setrlimit(l.resource, &r) != 0) _exit(96);
  }
  const int in = open("/dev/null", O_RDONLY);
  const int out = open("stdout.txt", O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const int err = open("stderr.txt", O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (in < 0 || out < 0 || err < 0 || dup2(in, 0) < 0 || dup2(out, 1) < 0 || dup2(err, 2) < 0)
    _exit(97);
  execve(kTool.c_str(), argv.data(), envp.data());
  _exit(98);
}

/// Waits up to `seconds` for `pid`; its wait status, or -1 (then it is killed) when it has not
/// ended.
int wait_for(pid_t pid, double seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > until) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return status;
}

/// The resident memory of process `pid`, in bytes; -1 if unknown.
long resident_bytes(pid_t pid) {
  const std::string status = slurp("/proc/" + std::to_string(pid) + "/status");
  const size_t at = status.find("VmRSS:");
  return at == std::string::npos ? -1 : 1024 * std::atol(status.c_str() + at + 6);
}

/// The runs of the rows of `out`'s manifest, and the runs of its kept trajectories.
std::pair<std::set<long>, std::set<long>> recorded_runs(const fs::path& out) {
  std::set<long> rows, trajectories;
  for (const auto& e : fs::directory_iterator(out / "manifest")) {
    const auto lines = split(slurp(e.path()), '\n');
    for (size_t i = 2; i < lines.size(); ++i)
      if (!lines[i].empty()) rows.insert(std::atol(lines[i].c_str()));
  }
  if (fs::exists(out / "runs"))
    for (const auto& e : fs::directory_iterator(out / "runs"))
      trajectories.insert(std::atol(e.path().filename().string().substr(4).c_str()));
  return {rows, trajectories};
}

constexpr rlim_t kMiB = 1 << 20;

TEST(StudySweep, AThreadThatCannotStartIsAnErrorNotAnAbort) {
  // Threads' stacks of 1 GiB (glibc takes their size from RLIMIT_STACK) in an address space of
  // 512 MiB: no thread can start (RLIMIT_NPROC would do for a user, but root is exempt).
  // OpenBLAS is told to start none of its own: it raises SIGINT when it cannot.
  if (kAddressSanitizer || kThreadSanitizer)
    GTEST_SKIP() << "the sanitizers need the address space";
  const fs::path dir = temp_dir("study_no_thread");
  racket_study(dir, 2, 0.1);
  const pid_t pid = spawn_limited(dir, {"sweep", "study.yaml", "-o", "out", "-j", "600"},
                                  {{RLIMIT_STACK, 1024 * kMiB}, {RLIMIT_AS, 512 * kMiB}},
                                  {"OPENBLAS_NUM_THREADS=1"});
  const int status = wait_for(pid, 60);
  ASSERT_TRUE(WIFEXITED(status)) << status;
  EXPECT_EQ(WEXITSTATUS(status), 1);
  const std::string err = slurp(dir / "stderr.txt");
  EXPECT_NE(err.find("kanedyn: error: cannot start thread 1 of "), std::string::npos) << err;
  EXPECT_NE(err.find("ask for fewer threads"), std::string::npos) << err;
  EXPECT_EQ(err.find("terminate"), std::string::npos) << err;
  // Nothing ran; without the limits it does.
  EXPECT_FALSE(fs::exists(dir / "out/results.csv"));
  const ToolRun r = run_in(dir, "sweep study.yaml -o out -j 600");
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

/// A study of a million runs of the racket, each a few steps long, keeping every trajectory:
/// runs finish faster than their trajectories are written.
void quick_runs_study(const fs::path& dir) {
  fs::copy_file(kRacket, dir / "racket.yaml");
  write(dir / "study.yaml",
        "format: kanedyn-study/1\nmodel: racket.yaml\nseed: 5\nruns: 1000000\nvary:\n"
        "  - key: bodies[racket].initial.angular_velocity[0]\n    uniform: [0.0005, 0.002]\n"
        "simulate: {t_end: 0.01, dt_out: 0.01}\noutputs:\n  - final: racket.w2\n"
        "trajectories: all\n");
}

TEST(StudySweep, TheRunsWaitForTheWriter) {
  // The thread that writes stalls for a second (in the stop callback, which it calls between
  // the writes of trajectories): the threads running quick runs wait for it, and the memory
  // does not grow (it grew by every run finished meanwhile, with its trajectory).
  const fs::path dir = temp_dir("study_writer_stalls");
  quick_runs_study(dir);
  const io::Study study = io::load_study((dir / "study.yaml").string());
  io::StudyFolder folder(study, (dir / "out").string());
  io::SweepOptions options;
  options.threads = 2;
  int polls = 0;
  long grew = 0;
  options.stop = [&] {
    if (++polls < 3) return false;
    const long before = heap_bytes();
    std::this_thread::sleep_for(std::chrono::seconds(1));
    grew = heap_bytes() - before;
    return true;
  };
  const io::SweepResult result = io::sweep(study, folder, options);
  EXPECT_TRUE(result.stopped);
  EXPECT_LT(grew, 1L << 20) << grew;
  // What finished was recorded, each run with its trajectory.
  const auto [rows, trajectories] = recorded_runs(dir / "out");
  EXPECT_EQ(static_cast<long>(rows.size()), folder.done());
  EXPECT_EQ(rows, trajectories);
}

TEST(StudySweep, WritingTrajectoriesSlowsTheRunsNotTheMemory) {
  // Runs that finish faster than their trajectories are written wait for the writer: the
  // memory stays bounded (an address-space limit too), rows are recorded within about a
  // second (what a SIGKILL keeps), and a Ctrl-C is honoured within a second.
  if (kAddressSanitizer || kThreadSanitizer)
    GTEST_SKIP() << "the sanitizers' memory and timing are their own";
  const fs::path dir = temp_dir("study_backpressure");
  quick_runs_study(dir);
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = spawn_limited(dir, {"sweep", "study.yaml", "-o", "out", "-j", "2"},
                                  {{RLIMIT_AS, 1024 * kMiB}});
  bool recorded = false;
  while (!recorded && std::chrono::steady_clock::now() - start < std::chrono::seconds(3)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    recorded = fs::exists(dir / "out/manifest/part_000001.csv");
  }
  EXPECT_TRUE(recorded) << "no row recorded within 3 s";
  const long first = resident_bytes(pid);
  std::this_thread::sleep_until(start + std::chrono::seconds(3));
  const long later = resident_bytes(pid);
  EXPECT_GT(first, 0);
  EXPECT_LT(later - first, static_cast<long>(32 * kMiB)) << first << " -> " << later;
  EXPECT_LT(later, static_cast<long>(256 * kMiB));
  const auto sent = std::chrono::steady_clock::now();
  kill(pid, SIGINT);
  const int status = wait_for(pid, 30);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - sent).count(), 1.0);
  ASSERT_TRUE(WIFEXITED(status)) << status << slurp(dir / "stderr.txt");
  EXPECT_EQ(WEXITSTATUS(status), 130) << slurp(dir / "stderr.txt");
  // Every run recorded has its trajectory, and every trajectory its row.
  const auto [rows, trajectories] = recorded_runs(dir / "out");
  EXPECT_GT(rows.size(), 0u);
  EXPECT_EQ(rows, trajectories);
}

TEST(StudySweep, AFileSizeLimitWhileTheRunsWaitFailsCleanly) {
  // 300 runs of a few steps, then 300 whose trajectories (about 55 kB) are over a file size
  // limit of 32 kiB: the first of those ends the sweep while the threads wait for the writer.
  if (kAddressSanitizer || kThreadSanitizer)
    GTEST_SKIP() << "the sanitizers need the address space";
  const fs::path dir = temp_dir("study_file_size");
  fs::copy_file(kRacket, dir / "racket.yaml");
  write(dir / "study.yaml",
        "format: kanedyn-study/1\nmodel: racket.yaml\nruns: 300\nvary:\n"
        "  - key: simulation.t_end\n    grid: [0.01, 3.0]\n"
        "outputs:\n  - final: racket.w2\ntrajectories: all\n");
  const pid_t pid = spawn_limited(dir, {"sweep", "study.yaml", "-o", "out", "-j", "2"},
                                  {{RLIMIT_AS, 1024 * kMiB}, {RLIMIT_FSIZE, 32 * 1024}});
  const int status = wait_for(pid, 60);
  const std::string err = slurp(dir / "stderr.txt");
  ASSERT_TRUE(WIFEXITED(status)) << status << err;
  EXPECT_EQ(WEXITSTATUS(status), 1) << err;
  EXPECT_NE(err.find(".csv.partial': File too large"), std::string::npos) << err;
  EXPECT_NE(err.find(" of 600 runs are kept in out"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "out/results.csv"));
  const auto [rows, trajectories] = recorded_runs(dir / "out");
  EXPECT_EQ(rows, trajectories);
  for (const auto& e : fs::recursive_directory_iterator(dir / "out"))
    EXPECT_FALSE(e.path().string().ends_with(".partial")) << e.path();
  // Without the limit it resumes and completes.
  const ToolRun resumed = run_in(dir, "sweep study.yaml -o out -j 2");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  EXPECT_EQ(split(slurp(dir / "out/results.csv"), '\n').size(), 602u);
}

TEST(StudySweep, AFolderNotTheStudysIsRefusedNamingWhatIsInTheWay) {
  const fs::path dir = temp_dir("study_not_ours");
  racket_study(dir, 2, 0.1);
  // Beside the study file itself: its study.yaml is the study, not a copy of it.
  const ToolRun here = run_in(dir, "sweep study.yaml -o .");
  EXPECT_EQ(here.exit_code, 1);
  EXPECT_NE(here.err.find("'.' is not empty"), std::string::npos) << here.err;
  EXPECT_NE(here.err.find("'./racket.yaml' is in the way"), std::string::npos) << here.err;
  EXPECT_FALSE(fs::exists(dir / "manifest"));
  // Another folder with a results.csv and runs of its own: left as it was.
  fs::create_directories(dir / "old/runs");
  write(dir / "old/results.csv", "mine\n");
  write(dir / "old/runs/run_000000.csv", "mine too\n");
  const ToolRun old = run_in(dir, "sweep study.yaml -o old");
  EXPECT_EQ(old.exit_code, 1);
  EXPECT_NE(old.err.find("'old/results.csv' is in the way"), std::string::npos) << old.err;
  EXPECT_EQ(slurp(dir / "old/results.csv"), "mine\n");
  EXPECT_EQ(slurp(dir / "old/runs/run_000000.csv"), "mine too\n");
  EXPECT_FALSE(fs::exists(dir / "old/study.yaml"));
  // An empty folder is taken, and then is the study's.
  fs::create_directories(dir / "empty");
  const ToolRun empty = run_in(dir, "sweep study.yaml -o empty");
  EXPECT_EQ(empty.exit_code, 0) << empty.err;
  const ToolRun again = run_in(dir, "sweep study.yaml -o empty");
  EXPECT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.out.find("0 run now"), std::string::npos) << again.out;
}

}  // namespace
}  // namespace kanedyn::test
