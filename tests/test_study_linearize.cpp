// Studies' `linearize` outputs (docs/studies.md, "Linearize outputs") on pendulums whose
// eigenvalues are known in closed form, their located refusals, and the outputs of a caller's
// function (what kanedyn.Study's function computes).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "file_support.hpp"
#include "kanedyn/io/study.hpp"

namespace kanedyn::test {
namespace {

// Two pendulums hung from the ground on their own hinges about y: each a mass m on a massless
// rod of length L (its com L below the pivot) with inertia J about its centre. About an angle
// q0 at rest, a hinge's motion is I_p q'' = -m g L sin q, I_p = J + m L^2, so A = [[0, 1],
// [-k, 0]] with k = m g L cos(q0) / I_p: eigenvalues +-i sqrt(k) hanging (cos q0 > 0) and
// +-sqrt(-k) upright (cos q0 < 0). The two pendulums do not act on each other.
const std::string kTwoPendulums = R"(format: kanedyn-model/1
name: two pendulums
gravity: [0, 0, -9.81]
bodies:
  - name: short
    parent: ground
    mass: 2.0
    inertia: [0.01, 0.01, 0.001]
    com: [0, 0, -0.5]
    joint: {type: revolute, at: [0, 0, 0], axis: [0, 1, 0]}
    initial: {joint: [0.0], joint_rate: [0.0]}
  - name: long
    parent: ground
    mass: 3.0
    inertia: [0.02, 0.02, 0.001]
    com: [0, 0, -1.5]
    joint: {type: revolute, at: [1, 0, 0], axis: [0, 1, 0]}
    initial: {joint: [0.0], joint_rate: [0.0]}
)";

constexpr double g = 9.81;

/// k = m g L cos(q0) / (J + m L^2) of one pendulum.
double stiffness(double m, double L, double J, double q0) {
  return m * g * L * std::cos(q0) / (J + m * L * L);
}

const std::string kStudy = R"(format: kanedyn-study/1
model: two.yaml
vary:
  - key: bodies[long].com[2]
    grid: [-1.5, -2.0]
  - key: bodies[short].initial.joint[0]
    values: [0.0, 3.141592653589793]
outputs:
  - linearize: max_real
  - linearize: {mode: fast, value: imag}
  - linearize: {mode: fast, value: frequency}
  - linearize: {mode: slow, rank: 2, value: imag}
  - linearize: {mode: long, of: [long.j1, long.jd1], value: imag}
  - linearize: {mode: long, of: [long.j1, long.jd1], value: damping}
  - linearize: {mode: short, of: [short.j1, short.jd1]}
)";

io::Study study_of(const std::string& study, const std::string& model = kTwoPendulums) {
  return io::parse_study(study, "s.yaml", "", &model);
}

/// A run's row split at its commas (the statuses here hold none).
std::vector<std::string> fields(const io::StudyRun& r) { return split(r.row, ','); }

TEST(StudyLinearize, PendulumsGiveTheirClosedFormEigenvalues) {
  const io::Study s = study_of(kStudy);
  const std::vector<std::string> expected_columns{"run",
                                                  "bodies[long].com[2]",
                                                  "bodies[short].initial.joint[0]",
                                                  "linearize:max_real",
                                                  "linearize:fast.imag",
                                                  "linearize:fast.frequency",
                                                  "linearize:slow.imag",
                                                  "linearize:long.imag",
                                                  "linearize:long.damping",
                                                  "linearize:short.real",
                                                  "status",
                                                  "wall_s"};
  EXPECT_EQ(s.columns(), expected_columns);
  ASSERT_EQ(s.runs, 4);
  EXPECT_FALSE(s.simulates());
  for (long run = 0; run < s.runs; ++run) {
    SCOPED_TRACE(run);
    const io::StudyRun r = io::run_study_run(s, run);
    ASSERT_EQ(r.status, "ok") << r.row;
    const std::vector<std::string> f = fields(r);
    const double L_long = -parse(f[1]);
    const double q_short = parse(f[2]);
    const double k_short = stiffness(2.0, 0.5, 0.01, q_short);
    const double k_long = stiffness(3.0, L_long, 0.02, 0.0);
    const double w_long = std::sqrt(k_long);
    // The derivatives are exact (dual numbers); A's eigenvalues then carry the eigen-solver's
    // round-off, a few ulps of the largest eigenvalue (about 6/s): 1e-12 leaves room for it.
    constexpr double tol = 1e-12;
    const bool upright = k_short < 0.0;
    // max_real: the inverted short pendulum's growth rate, 0 when both hang.
    EXPECT_NEAR(parse(f[3]), upright ? std::sqrt(-k_short) : 0.0, tol);
    // The modes ranked by frequency: hanging, the short one is faster (k 19.2 against 6.5 or
    // 4.9); upright, it has no frequency and the long one's pair is first.
    const double fast = upright ? w_long : std::sqrt(k_short);
    const double slow = upright ? 0.0 : w_long;
    EXPECT_NEAR(parse(f[4]), fast, tol);
    EXPECT_NEAR(parse(f[5]), fast / (2 * std::numbers::pi), tol);
    EXPECT_NEAR(parse(f[6]), slow, tol);
    // The long pendulum's own block: its frequency whatever the other does, undamped.
    EXPECT_NEAR(parse(f[7]), w_long, tol);
    EXPECT_NEAR(parse(f[8]), 0.0, tol);
    // The short one's block, rank 1: +sqrt(-k) upright (ranked by real part among the two
    // real roots), a real part 0 hanging.
    EXPECT_NEAR(parse(f[9]), upright ? std::sqrt(-k_short) : 0.0, tol);
  }
}

TEST(StudyLinearize, AModeThatIsNotThereFailsTheRunNotTheStudy) {
  // Rank 2 of the short pendulum's block: two real roots upright, one pair hanging.
  const io::Study s = study_of(edit(kStudy, "{mode: short, of: [short.j1, short.jd1]}",
                                    "{mode: short, rank: 2, of: [short.j1, short.jd1]}"));
  const io::StudyRun hanging = io::run_study_run(s, 0);
  EXPECT_EQ(hanging.status, "linearize: linearize:short.real: rank 2, but the block has 1 mode");
  // A failed run's outputs are empty: run, two values, seven empty cells, then the status
  // (quoted: it holds a comma) and wall_s.
  EXPECT_EQ(hanging.row.substr(0, hanging.row.find('"')), "0,-1.5,0,,,,,,,,") << hanging.row;
  const io::StudyRun upright = io::run_study_run(s, 1);
  ASSERT_EQ(upright.status, "ok");
  EXPECT_NEAR(parse(fields(upright)[9]), -std::sqrt(-stiffness(2.0, 0.5, 0.01, M_PI)), 1e-12);
}

TEST(StudyLinearize, ABlockCoupledBothWaysFailsTheRun) {
  // Its rows depend on the rest while the rest depends on it: its eigenvalues are not A's.
  // The coordinate without its speed: q' = z leaves the block, z' = -k q enters it.
  const io::Study s = study_of(edit(kStudy, "{mode: long, of: [long.j1, long.jd1], value: imag}",
                                    "{mode: long, of: [long.j1], value: imag}"));
  const io::StudyRun r = io::run_study_run(s, 0);
  EXPECT_NE(r.status.find("linearize: linearize:long.imag: the block is coupled to the rest of A "
                          "both ways (the rate of 'long.j1' depends on 'long.jd1', A = 1)"),
            std::string::npos)
      << r.status;
}

TEST(StudyLinearize, OnlyLinearizeOutputsDoNotSimulate) {
  int polls = 0;
  const auto stop = [&polls] {
    ++polls;
    return true;  // a simulation would end at its first step, interrupted
  };
  const io::Study s = study_of(kStudy);
  const io::StudyRun r = io::run_study_run(s, 0, stop);
  EXPECT_EQ(r.status, "ok");
  EXPECT_FALSE(r.interrupted);
  EXPECT_EQ(polls, 0);
  // With a trajectory output beside them it simulates.
  const io::Study both = study_of(edit(kStudy, "outputs:\n", "outputs:\n  - final: long.j1\n"));
  EXPECT_TRUE(both.simulates());
  EXPECT_TRUE(io::run_study_run(both, 0, stop).interrupted);
  EXPECT_GT(polls, 0);
}

TEST(StudyLinearize, TheOperatingPointIsTheRunsInitialState) {
  // Not a rest pose: the motion through q0 = 1 rad at rest, whose A has k ~ cos q0.
  const io::Study s =
      study_of(edit(kStudy, "    values: [0.0, 3.141592653589793]", "    values: [1.0]"));
  const io::StudyRun r = io::run_study_run(s, 0);
  ASSERT_EQ(r.status, "ok");
  EXPECT_NEAR(parse(fields(r)[9]), 0.0, 1e-12);
  EXPECT_NEAR(parse(fields(r)[4]), std::sqrt(stiffness(2.0, 0.5, 0.01, 1.0)), 1e-12);
}

TEST(StudyLinearize, ASweepWritesTheSameTableAsTheRuns) {
  const io::Study s = study_of(kStudy);
  const fs::path dir = temp_dir("study_linearize_sweep");
  io::StudyFolder folder(s, (dir / "out").string());
  io::SweepOptions options;
  options.threads = 2;
  const io::SweepResult done = io::sweep(s, folder, options);
  EXPECT_FALSE(done.stopped);
  const std::vector<std::string> lines = split(slurp(dir / "out" / "results.csv"), '\n');
  ASSERT_GE(lines.size(), 5u);
  for (long run = 0; run < 4; ++run) {
    const std::string row = io::run_study_run(s, run).row;
    const std::string& line = lines[static_cast<size_t>(run) + 1];
    EXPECT_EQ(line.substr(0, line.rfind(',')), row.substr(0, row.rfind(',')));
  }
}

struct BadCase {
  std::string label, from, to, at, key_path;
  std::vector<std::string> words;
};

TEST(StudyLinearize, BadKeysAreLocatedOneLineErrors) {
  const std::vector<BadCase> cases = {
      {"unknown word",
       "linearize: max_real",
       "linearize: max_rael",
       "linearize: ^max_rael",
       "outputs[0].linearize",
       {"expected max_real or a mapping", "'max_rael'"}},
      {"unknown statistic",
       "linearize: max_real",
       "linearise: max_real",
       "^linearise",
       "outputs[0].linearise",
       {"unknown key", "did you mean 'linearize'"}},
      {"unknown key in a mode",
       "{mode: fast, value: imag}",
       "{mode: fast, vaule: imag}",
       "mode: fast, ^vaule",
       "outputs[1].linearize.vaule",
       {"unknown key", "did you mean 'value'"}},
      {"missing mode",
       "{mode: fast, value: imag}",
       "{value: imag}",
       "linearize: ^{value: imag}",
       "outputs[1].linearize",
       {"missing required key 'mode'"}},
      {"bad mode name",
       "{mode: fast, value: imag}",
       "{mode: 'fa st', value: imag}",
       "mode: ^'fa st'",
       "outputs[1].linearize.mode",
       {"letters, digits"}},
      {"unknown value",
       "{mode: fast, value: imag}",
       "{mode: fast, value: iamg}",
       "value: ^iamg",
       "outputs[1].linearize.value",
       {"unknown value 'iamg'", "did you mean 'imag'"}},
      {"rank beyond the entries",
       "{mode: slow, rank: 2, value: imag}",
       "{mode: slow, rank: 5, value: imag}",
       "rank: ^5",
       "outputs[3].linearize.rank",
       {"must be from 1 to 4"}},
      {"rank beyond the block",
       "{mode: short, of: [short.j1, short.jd1]}",
       "{mode: short, rank: 3, of: [short.j1, short.jd1]}",
       "rank: ^3",
       "outputs[6].linearize.rank",
       {"must be from 1 to 2"}},
      {"unknown state name",
       "{mode: long, of: [long.j1, long.jd1], value: imag}",
       "{mode: long, of: [long.j1, lnog.jd1], value: imag}",
       "long.j1, ^lnog.jd1], value: imag",
       "outputs[4].linearize.of[1]",
       {"no entry 'lnog.jd1'", "closest: 'long.jd1'"}},
      {"state name twice",
       "{mode: long, of: [long.j1, long.jd1], value: imag}",
       "{mode: long, of: [long.j1, long.j1], value: imag}",
       "long.j1, ^long.j1], value: imag",
       "outputs[4].linearize.of[1]",
       {"named twice"}},
      {"empty block",
       "{mode: long, of: [long.j1, long.jd1], value: imag}",
       "{mode: long, of: [], value: imag}",
       "of: ^[], value: imag",
       "outputs[4].linearize.of",
       {"non-empty list"}},
      {"the same output twice",
       "{mode: long, of: [long.j1, long.jd1], value: damping}",
       "{mode: long, of: [long.j1, long.jd1], value: imag}",
       "",
       "outputs[5]",
       {"'linearize:long.imag' is asked for twice"}},
  };
  for (const BadCase& c : cases) {
    SCOPED_TRACE(c.label);
    const std::string text = edit(kStudy, c.from, c.to);
    try {
      study_of(text);
      ADD_FAILURE() << "accepted";
    } catch (const io::StudyFileError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      EXPECT_EQ(e.file(), "s.yaml");
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

TEST(StudyLinearize, StateNamesAreTheModelsOwn) {
  // A free body's entries are r1..r3, s1..s3, w1..w3, sd1..sd3.
  const std::string free_body = R"(format: kanedyn-model/1
bodies:
  - name: box
    parent: ground
    mass: 1
    inertia: [1, 2, 3]
    com: [0, 0, 0]
    joint: [0, 0, 0]
    initial: {angular_velocity: [0, 0, 0]}
)";
  const std::string study = R"(format: kanedyn-study/1
model: box.yaml
outputs:
  - linearize: {mode: m, of: [box.r1, box.w4]}
)";
  try {
    study_of(study, free_body);
    ADD_FAILURE() << "accepted";
  } catch (const io::StudyFileError& e) {
    EXPECT_NE(e.problem().find("closest: 'box.w1'"), std::string::npos) << e.what();
    EXPECT_EQ(e.key_path(), "outputs[0].linearize.of[1]");
  }
  // Its rotation about x and that rotation's rate make a block (the rate's row is 0 at rest).
  const io::Study s = study_of(edit(study, "box.w4", "box.w1"), free_body);
  EXPECT_EQ(io::run_study_run(s, 0).status, "ok");
}

// ---- The bicycle's stability map -------------------------------------------------------------

TEST(StudyLinearize, TheBicycleStudyCrossesZeroAtTheWeaveAndCapsizeSpeeds) {
  const io::Study s = io::load_study(kExamples + "/studies/bicycle_speed.yaml");
  const std::vector<std::string> columns = s.columns();
  const auto column = [&](const std::string& name) {
    const auto it = std::find(columns.begin(), columns.end(), name);
    EXPECT_NE(it, columns.end()) << name;
    return static_cast<size_t>(it - columns.begin());
  };
  const size_t speed = column("parameters.speed"), weave = column("linearize:weave.real"),
               capsize = column("linearize:capsize.real");
  std::vector<double> v, w, c;
  for (long run = 0; run < s.runs; ++run) {
    const io::StudyRun r = io::run_study_run(s, run);
    ASSERT_EQ(r.status, "ok") << r.row;
    const std::vector<std::string> f = fields(r);
    v.push_back(parse(f[speed]));
    w.push_back(parse(f[weave]));
    c.push_back(parse(f[capsize]));
    // Table 2 of Meijaard et al. (2007), to its 6 digits, at 5 m/s.
    if (v.back() == 5.0) {
      EXPECT_NEAR(w.back(), -0.775342, 1e-6);
      EXPECT_NEAR(c.back(), -0.322866, 1e-6);
    }
  }
  // The zero crossing between the two grid speeds around it, by linear interpolation: its error
  // is at most h^2/8 |f''|/|f'|, with h = 0.1 m/s and |f''/f'| below 1.1 s/m near both
  // crossings (the table's second differences), 1.4e-3 m/s: 3e-3 m/s is twice that.
  const auto crossing = [&](const std::vector<double>& f, double sign) {
    for (size_t i = 0; i + 1 < v.size(); ++i)
      if (sign * f[i] < 0.0 && sign * f[i + 1] >= 0.0)
        return v[i] + (v[i + 1] - v[i]) * f[i] / (f[i] - f[i + 1]);
    ADD_FAILURE() << "no crossing";
    return 0.0;
  };
  EXPECT_NEAR(crossing(w, -1.0), 4.29238253634111, 3e-3);  // the weave speed
  EXPECT_NEAR(crossing(c, 1.0), 6.02426201538837, 3e-3);   // the capsize speed
}

// ---- A caller's function ---------------------------------------------------------------------

TEST(StudyFunction, ItsValuesAreColumnsAndItsExceptionsFailures) {
  io::Study s = study_of(kStudy);
  const std::uint64_t plain = s.fingerprint;
  s.set_function_outputs({"mass", "L"});
  EXPECT_NE(s.fingerprint, plain);  // a folder of the plain study is another study's
  EXPECT_EQ(s.columns()[10], "mass");
  EXPECT_EQ(s.columns()[11], "L");
  EXPECT_THROW(io::run_study_run(s, 0), std::logic_error);
  // The function sees the run's model: its varied length.
  const io::StudyFunction f = [](const io::ModelFile& file, long run) -> std::vector<double> {
    if (run == 3) throw std::runtime_error("no luck,\nrun 3");
    return {file.model.body(1).mass, -file.model.body(1).com.z()};
  };
  for (long run = 0; run < 4; ++run) {
    const io::StudyRun r = io::run_study_run(s, run, {}, f);
    const std::vector<std::string> cells = split(r.row, ',');
    if (run == 3) {
      // The message on one line, quoted in the CSV for its comma.
      EXPECT_EQ(r.status, "function: no luck,\\nrun 3");
      EXPECT_NE(r.row.find(",\"function: no luck,\\nrun 3\","), std::string::npos) << r.row;
      continue;
    }
    ASSERT_EQ(r.status, "ok");
    ASSERT_EQ(cells.size(), 14u);
    EXPECT_EQ(parse(cells[10]), 3.0);
    EXPECT_EQ(parse(cells[11]), -parse(cells[1]));
  }
  const io::StudyFunction short_of_one = [](const io::ModelFile&, long) {
    return std::vector<double>{1.0};
  };
  EXPECT_EQ(io::run_study_run(s, 0, {}, short_of_one).status,
            "function: gave 1 value for 2 outputs");
  EXPECT_THROW(s.set_function_outputs({"status"}), std::invalid_argument);
  EXPECT_THROW(s.set_function_outputs({"a", "a"}), std::invalid_argument);
  EXPECT_THROW(s.set_function_outputs({""}), std::invalid_argument);
  EXPECT_THROW(s.set_function_outputs({"a\nb"}), std::invalid_argument);
  s.set_function_outputs({});
  EXPECT_EQ(s.fingerprint, plain);
}

}  // namespace
}  // namespace kanedyn::test
