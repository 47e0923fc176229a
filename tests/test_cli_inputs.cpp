// Inputs on the command line: `simulate --inputs`, `eom --input`, `inverse`, and their errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "file_support.hpp"
#include "kanedyn/inputs.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/trajectory.hpp"
#include "kanedyn/simulate.hpp"

namespace fs = std::filesystem;

namespace {

using namespace kanedyn;
using test::kExamples;
using test::parse;
using test::read_csv;
using test::run_in;
using test::slurp;
using test::temp_dir;

const std::string kArm = kExamples + "/urdf/arm.urdf";
const std::string kTorques = kExamples + "/urdf/arm_torques.csv";

size_t column(const std::vector<std::string>& header, const std::string& name) {
  const auto it = std::find(header.begin(), header.end(), name);
  EXPECT_NE(it, header.end()) << name;
  return static_cast<size_t>(it - header.begin());
}

// The rows hold the table's values (zero-order hold: a row's value from its time on) and the
// state is the library's run with the same table, read back to the same doubles.
TEST(InputsCommand, SimulateDrivesTheInputsFromATable) {
  const fs::path dir = temp_dir("cli_inputs");
  const auto r = run_in(dir, "simulate '" + kArm + "' --inputs '" + kTorques +
                                 "' --t-end 2 --dt-out 0.25 -o run.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("inputs: 6, from a table of 4 rows (zero-order hold)"), std::string::npos)
      << r.out;
  const auto rows = read_csv(dir / "run.csv");
  ASSERT_EQ(rows.size(), 10u);
  const size_t lift = column(rows[0], "input.shoulder_lift"),
               pan = column(rows[0], "input.shoulder_pan");
  EXPECT_EQ(rows[0].back(), "input.wrist_3");
  const double expected[] = {0, 0, 40, 40, -40, -40, 0, 0, 0};  // t = 0, 0.25, ..., 2
  for (size_t i = 1; i < rows.size(); ++i) {
    EXPECT_EQ(parse(rows[i][lift]), expected[i - 1]) << "t = " << rows[i][0];
    EXPECT_EQ(parse(rows[i][pan]), 0.0);
  }
  // The same run through the library.
  const io::ModelFile file = io::load_model_file(kArm);
  SimulationSettings s;
  s.t_end = 2.0;
  s.dt_out = 0.25;
  s.inputs = std::make_shared<const InputTable>(
      io::read_input_table(file.model, kTorques, InputHold::zero_order));
  VectorX q_end;
  ASSERT_TRUE(
      simulate(file.model, file.q, file.z, s,
               [&](double, const State&, const VectorX& q, const VectorX&, Data&) { q_end = q; })
          .ok());
  const io::TrajectoryRow last =
      io::read_trajectory_row(file.model, (dir / "run.csv").string(), 2.0);
  EXPECT_EQ(last.q, q_end);
  EXPECT_EQ(last.inputs[1], 0.0);
}

TEST(InputsCommand, LinearHoldInterpolates) {
  const fs::path dir = temp_dir("cli_inputs_linear");
  const auto r = run_in(dir, "simulate '" + kArm + "' --inputs '" + kTorques +
                                 "' --inputs-hold linear --t-end 1 --dt-out 0.25 -o run.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rows = read_csv(dir / "run.csv");
  const size_t lift = column(rows[0], "input.shoulder_lift");
  EXPECT_EQ(parse(rows[2][lift]), 20.0);  // t = 0.25: halfway from 0 to 40
  EXPECT_EQ(parse(rows[4][lift]), 0.0);   // t = 0.75: halfway from 40 to -40
}

TEST(InputsCommand, BadTablesAreRefusedBeforeTheRun) {
  const fs::path dir = temp_dir("cli_inputs_bad");
  const auto refuses = [&](const std::string& table, const std::string& words) {
    std::ofstream(dir / "u.csv") << table;
    const auto r = run_in(dir, "simulate '" + kArm + "' --inputs u.csv -o run.csv");
    EXPECT_EQ(r.exit_code, 1) << table;
    EXPECT_NE(r.err.find(words), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("u.csv"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "run.csv"));
    EXPECT_FALSE(fs::exists(dir / "run.csv.partial"));
  };
  refuses("t,elbw\n0,1\n", "did you mean 'elbow'");
  refuses("elbow\n1\n", "no 't' column");
  refuses("t,elbow\n0,1\n0,2\n", "does not come after");
  refuses("t,elbow\n0,1\n1,x\n", "not a finite number");
  refuses("t,elbow,elbow\n0,1,2\n", "named twice");
  refuses("t,elbow\n", "no rows");
  refuses("t,elbow\n0,1\n1,1e-400\n", "'1e-400' is too small for a double (it underflows)");
  refuses("t,elbow\n0,1\n1,0." + std::string(400, '0') + "1\n", "underflows");
  refuses("t,elbow\n0,1\n1,1e400\n", "'1e400' overflows a double");
  // An empty file is named once, and says what is missing.
  {
    std::ofstream(dir / "u.csv").flush();
    const auto r = run_in(dir, "simulate '" + kArm + "' --inputs u.csv -o run.csv");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find("error: u.csv: the file is empty; its first line is the header"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(r.err.find("u.csv: u.csv"), std::string::npos) << r.err;
  }
  // A model without inputs.
  std::ofstream(dir / "u.csv") << "t,a\n0,1\n";
  const auto r = run_in(dir, "simulate '" + kExamples + "/eight_body.yaml' --inputs u.csv");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("has no inputs"), std::string::npos) << r.err;
}

// Spreadsheets save CSV with a byte order mark: it is no part of the header's first name.
TEST(InputsCommand, ATableWithAByteOrderMarkIsRead) {
  const fs::path dir = temp_dir("cli_inputs_bom");
  std::ofstream(dir / "u.csv") << "\xEF\xBB\xBF" << slurp(kTorques);
  const auto r = run_in(dir, "simulate '" + kArm + "' --inputs u.csv --t-end 0.1 -o run.csv");
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

// The inputs table is an input like the model: no output of the run may replace it, by any
// name (docs/cli.md, "Files"), and '' names no file.
TEST(InputsCommand, NoOutputReplacesTheInputsTable) {
  const fs::path dir = temp_dir("cli_inputs_identity");
  const std::string table = slurp(kTorques);
  std::ofstream(dir / "u.csv") << table;
  std::ofstream(dir / "u.csv.partial") << table;
  fs::create_directory(dir / "sub");
  const struct {
    std::string args, message;
  } cases[] = {
      {"--inputs u.csv -o u.csv", "output 'u.csv' is the input file 'u.csv'"},
      {"--inputs u.csv -o ./u.csv", "output './u.csv' is the input file 'u.csv'"},
      {"--inputs u.csv -o sub/../u.csv", "output 'sub/../u.csv' is the input file 'u.csv'"},
      {"--inputs u.csv.partial -o u.csv",
       "output 'u.csv.partial' is the input file 'u.csv.partial'"},
      {"--inputs ''", "--inputs: an empty file name"},
  };
  for (const auto& c : cases) {
    const auto r = run_in(dir, "simulate '" + kArm + "' --t-end 0.1 " + c.args);
    EXPECT_NE(r.exit_code, 0) << c.args;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << c.args << ": " << r.err;
  }
  EXPECT_EQ(slurp(dir / "u.csv"), table);
  EXPECT_EQ(slurp(dir / "u.csv.partial"), table);
}

// One value per input: the same input given twice would drop one of them.
TEST(InputsCommand, AnInputGivenTwiceIsRefused) {
  const fs::path dir = temp_dir("cli_inputs_twice");
  const auto r = run_in(dir, "eom '" + kArm + "' --input elbow=1 --input elbow=2");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--input elbow=2: input 'elbow' is given twice"), std::string::npos)
      << r.err;
  const auto tiny = run_in(dir, "eom '" + kArm + "' --input elbow=1e-400");
  EXPECT_EQ(tiny.exit_code, 1);
  EXPECT_NE(tiny.err.find("'1e-400' is too small for a double"), std::string::npos) << tiny.err;
}

TEST(InputsCommand, EomTakesInputValues) {
  const fs::path dir = temp_dir("cli_inputs_eom");
  const auto r = run_in(dir, "eom '" + kArm + "' --json --input elbow=2.5");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"u\":[0.0,0.0,2.5,0.0,0.0,0.0]"), std::string::npos)
      << r.out.substr(0, 200);
  EXPECT_NE(r.out.find("\"inputs\":[\"shoulder_pan\""), std::string::npos);
  EXPECT_NE(r.out.find("\"u_K\":["), std::string::npos);
  const auto bad = run_in(dir, "eom '" + kArm + "' --input elbo=1");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("did you mean 'elbow'"), std::string::npos) << bad.err;
}

// inverse of the arm's own motion: the spec's header, a row per trajectory row, and forces far
// below the arm's gravity torques (tests/test_inverse_trajectory.cpp bounds them closely).
TEST(InputsCommand, InverseWritesTheGeneralizedForces) {
  const fs::path dir = temp_dir("cli_inverse");
  ASSERT_EQ(run_in(dir, "simulate '" + kArm + "' --t-end 0.5 --dt-out 0.005 -o run.csv").exit_code,
            0);
  const auto r = run_in(dir, "inverse '" + kArm + "' run.csv -o Q.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rows = read_csv(dir / "Q.csv");
  ASSERT_EQ(rows.size(), 102u);
  EXPECT_EQ(rows[0][0], "t");
  EXPECT_EQ(rows[0][1], "shoulder_link.Q1");
  EXPECT_EQ(rows[0].size(), 7u);
  for (size_t i = 1; i < rows.size(); ++i)
    for (size_t c = 1; c < rows[i].size(); ++c) EXPECT_LT(std::abs(parse(rows[i][c])), 0.5);
  // The default name, and a trajectory of another model refused.
  EXPECT_EQ(run_in(dir, "inverse '" + kArm + "' run.csv").exit_code, 0);
  EXPECT_TRUE(fs::exists(dir / "run.Q.csv"));
  // -o - is standard output, as for view and import; the report goes to standard error.
  const auto piped = run_in(dir, "inverse '" + kArm + "' run.csv -o -");
  ASSERT_EQ(piped.exit_code, 0) << piped.err;
  EXPECT_EQ(piped.out, slurp(dir / "Q.csv"));
  EXPECT_NE(piped.err.find("inverse dynamics of run.csv: 101 rows"), std::string::npos)
      << piped.err;
  EXPECT_FALSE(fs::exists(dir / "-"));
  const auto other = run_in(dir, "inverse '" + kExamples + "/eight_body.yaml' run.csv -o X.csv");
  EXPECT_EQ(other.exit_code, 1);
  EXPECT_FALSE(fs::exists(dir / "X.csv"));
}

}  // namespace
