// The tool's commands as a careless or hostile user runs them: outputs that are devices,
// FIFOs or an input of the same command; readers given a FIFO, a device or a directory;
// trajectory rows that are not states; and the ways to ask for no output or for standard
// output. Device nodes are made in the test's folder (as root), never /dev itself.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/sysmacros.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "file_support.hpp"

namespace fs = std::filesystem;

namespace {

using namespace kanedyn;
using test::edit;
using test::kExamples;
using test::run_in;
using test::slurp;
using test::temp_dir;
using Result = test::ToolRun;

bool make_char_device(const fs::path& path, unsigned minor) {
  return ::mknod(path.c_str(), S_IFCHR | 0666, makedev(1, minor)) == 0;
}

mode_t kind(const fs::path& path) {
  struct stat st {};
  return ::lstat(path.c_str(), &st) == 0 ? (st.st_mode & S_IFMT) : 0;
}

const std::string kEight = "'" + kExamples + "/eight_body.yaml'";

/// Whether the tool has the viewer (`view` says so and stops otherwise: its cases are left out).
constexpr bool kViewer = KANEDYN_TEST_VIEWER;

/// `commands` without those that run `view` when the tool has no viewer.
std::vector<std::string> runnable(std::vector<std::string> commands) {
  if (!kViewer)
    std::erase_if(commands, [](const std::string& c) { return c.starts_with("view "); });
  return commands;
}

TEST(CommandOutputs, DevicesAndFifosAreRefusedAndLeftAsTheyWere) {
  const fs::path dir = temp_dir("cli_files_devices");
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  std::vector<std::string> targets{"fifo"};
  if (make_char_device(dir / "null", 3) && make_char_device(dir / "full", 7)) {
    targets.push_back("null");
    targets.push_back("full");
  }
  const std::string urdf = "'" + kExamples + "/urdf/arm.urdf'";
  for (const std::string& target : targets) {
    const mode_t before = kind(dir / target);
    for (const std::string& args :
         runnable({"simulate " + kEight + " --t-end 0.05 -o " + target,
                   "view " + kEight + " -o " + target, "import " + urdf + " -o " + target})) {
      const Result r = run_in(dir, args);
      EXPECT_EQ(r.exit_code, 1) << args;
      EXPECT_NE(r.err.find("kanedyn: error: output '" + target + "' is a"), std::string::npos)
          << args << ": " << r.err;
      EXPECT_EQ(r.out, "") << args;  // refused before any work: no summary
      EXPECT_EQ(kind(dir / target), before) << args << " replaced " << target;
      EXPECT_FALSE(fs::exists(dir / (target + ".partial"))) << args;
    }
  }
}

TEST(CommandOutputs, NoOutputAndStandardOutputAreAskedForByName) {
  const fs::path dir = temp_dir("cli_files_no_output");
  Result r = run_in(dir, "simulate " + kEight + " --t-end 0.05 --no-output");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("trajectory: none (--no-output)"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::is_empty(dir / "stdout.txt") == false);
  EXPECT_FALSE(fs::exists(dir / "eight_body.csv"));
  EXPECT_FALSE(fs::exists(dir / "eight_body.csv.partial"));
  r = run_in(dir, "simulate " + kEight + " --no-output -o run.csv");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("excludes"), std::string::npos) << r.err;

  // view and import: "-" is standard output, and no file of that name is made.
  if (kViewer) {
    r = run_in(dir, "view " + kEight + " -o -");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.out.rfind("<!DOCTYPE html>", 0), 0u) << r.out.substr(0, 80);
    EXPECT_NE(r.out.find("id=\"kanedyn-data\""), std::string::npos);
  }
  r = run_in(dir, "import '" + kExamples + "/urdf/arm.urdf' -o -");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("format: kanedyn-model/1"), std::string::npos) << r.out.substr(0, 200);
  EXPECT_FALSE(fs::exists(dir / "-"));
}

TEST(CommandOutputs, NoOutputIsAnInputOfTheSameCommand) {
  if (!kViewer) GTEST_SKIP() << "the tool was built without the viewer";
  const fs::path dir = temp_dir("cli_files_view_inputs");
  const std::string model = slurp(kExamples + "/eight_body.yaml");
  std::ofstream(dir / "m.yaml") << model;
  ASSERT_EQ(run_in(dir, "simulate m.yaml --t-end 0.05 -o t.csv").exit_code, 0);
  const std::string csv = slurp(dir / "t.csv");
  // A model file named like the page view writes by default.
  std::ofstream(dir / "run.html") << model;
  const struct {
    std::string args, message;
  } cases[] = {
      {"view m.yaml t.csv -o m.yaml", "output 'm.yaml' is the input file 'm.yaml'"},
      {"view m.yaml t.csv -o ./t.csv", "output './t.csv' is the input file 't.csv'"},
      {"view run.html", "output 'run.html' is the input file 'run.html'"},
  };
  for (const auto& c : cases) {
    const Result r = run_in(dir, c.args);
    EXPECT_EQ(r.exit_code, 1) << c.args;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << c.args << ": " << r.err;
  }
  EXPECT_EQ(slurp(dir / "m.yaml"), model);
  EXPECT_EQ(slurp(dir / "run.html"), model);
  EXPECT_EQ(slurp(dir / "t.csv"), csv);
  // A hard link is the same file by another name.
  ASSERT_EQ(::link((dir / "m.yaml").c_str(), (dir / "page.html").c_str()), 0);
  const Result r = run_in(dir, "view m.yaml -o page.html");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("is the input file 'm.yaml'"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(dir / "m.yaml"), model);
}

TEST(CommandInputs, ReadersRefuseWhatIsNotARegularFileAtOnce) {
  const fs::path dir = temp_dir("cli_files_readers");
  ASSERT_EQ(::mkfifo((dir / "fifo.csv").c_str(), 0600), 0);
  fs::create_directory(dir / "folder.csv");
  std::vector<std::pair<std::string, std::string>> inputs{{"fifo.csv", "is a FIFO"},
                                                          {"folder.csv", "is a directory"}};
  if (make_char_device(dir / "zero.csv", 5)) inputs.emplace_back("zero.csv", "character device");
  for (const auto& [name, problem] : inputs) {
    // A FIFO without a writer would block a reader that opens it as a file: these return.
    for (const std::string& args : runnable(
             {"view " + kEight + " " + name, "eom " + kEight + " --trajectory " + name + " --t 0",
              "inspect " + kEight + " --trajectory " + name + " --t 0"})) {
      const Result r = run_in(dir, args);
      EXPECT_EQ(r.exit_code, 1) << args;
      EXPECT_NE(r.err.find("kanedyn: error: " + name + ": "), std::string::npos)
          << args << ": " << r.err;
      EXPECT_NE(r.err.find(problem), std::string::npos) << args << ": " << r.err;
    }
  }
}

/// `csv` with the numbers of `columns` in data row `row` (1 = the first after the header)
/// replaced by `values`.
std::string with_row_values(const std::string& csv, int row,
                            const std::vector<std::string>& columns,
                            const std::vector<std::string>& values) {
  std::vector<std::string> lines = test::split(csv, '\n');
  std::vector<std::string> header = test::split(lines[0], ',');
  std::vector<std::string> fields = test::split(lines[static_cast<size_t>(row)], ',');
  for (size_t i = 0; i < columns.size(); ++i) {
    const auto at = std::find(header.begin(), header.end(), columns[i]);
    EXPECT_NE(at, header.end()) << columns[i];
    fields[static_cast<size_t>(at - header.begin())] = values[i];
  }
  std::string line;
  for (size_t i = 0; i < fields.size(); ++i) line += (i ? "," : "") + fields[i];
  lines[static_cast<size_t>(row)] = line;
  std::string out;
  for (size_t i = 0; i < lines.size(); ++i) out += lines[i] + (i + 1 < lines.size() ? "\n" : "");
  return out;
}

TEST(CommandInputs, TrajectoryRowsAreStates) {
  const fs::path dir = temp_dir("cli_files_row_states");
  ASSERT_EQ(run_in(dir, "simulate " + kEight + " --t-end 0.05 --dt-out 0.01 -o t.csv").exit_code,
            0);
  const std::string csv = slurp(dir / "t.csv");
  // Row 3 (line 4, t = 0.02): the torso's Euler parameters zero, then off unit norm by 1e-4.
  for (const auto& values :
       std::vector<std::vector<std::string>>{{"0", "0", "0", "0"}, {"0", "0", "0", "1.0001"}}) {
    std::ofstream(dir / "bad.csv")
        << with_row_values(csv, 3, {"torso.e1", "torso.e2", "torso.e3", "torso.e4"}, values);
    for (const std::string& args : runnable({"eom " + kEight + " --trajectory bad.csv --t 0.02",
                                             "inspect " + kEight + " --trajectory bad.csv --t 0.02",
                                             "view " + kEight + " bad.csv"})) {
      const Result r = run_in(dir, args);
      EXPECT_EQ(r.exit_code, 1) << args;
      EXPECT_NE(r.err.find("kanedyn: error: bad.csv:4: columns 'torso.e1' to 'torso.e4' are not "
                           "Euler parameters"),
                std::string::npos)
          << args << ": " << r.err;
    }
  }
  // Within 1e-6 of unit norm, as in the model file: accepted.
  std::ofstream(dir / "near.csv") << with_row_values(
      csv, 3, {"torso.e1", "torso.e2", "torso.e3", "torso.e4"}, {"0", "0", "0", "1.0000005"});
  EXPECT_EQ(run_in(dir, "eom " + kEight + " --trajectory near.csv --t 0.02").exit_code, 0);

  // A spherical joint's q (j1..j4) follows the same rule.
  const std::string human = "'" + kExamples + "/human_jointed.yaml'";
  ASSERT_EQ(run_in(dir, "simulate " + human + " --t-end 0.02 --dt-out 0.01 -o h.csv").exit_code, 0);
  std::ofstream(dir / "hbad.csv") << with_row_values(
      slurp(dir / "h.csv"), 2, {"head.j1", "head.j2", "head.j3", "head.j4"}, {"0", "0", "0", "2"});
  const Result r = run_in(dir, "eom " + human + " --trajectory hbad.csv --t 0.01");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("hbad.csv:3: columns 'head.j1' to 'head.j4' are not a spherical joint's "
                       "Euler parameters"),
            std::string::npos)
      << r.err;
}

TEST(CommandInputs, AStateOutOfRangeIsRefusedByEveryCommand) {
  // The cart 1e300 m along its rail on a stiff spring: a finite coordinate whose joint
  // force, -1e10 * 1e300, overflows (the free tree's quantities stay finite).
  const fs::path dir = temp_dir("cli_files_far_state");
  std::ofstream(dir / "far.yaml") << edit(
      edit(slurp(kExamples + "/cart_pendulum.yaml"), "joint: [0.0]", "joint: [1e300]"),
      "stiffness: 5.0", "stiffness: 1e10");
  for (const char* args :
       {"eom far.yaml", "eom far.yaml --json", "inspect far.yaml", "inspect far.yaml --json"}) {
    const Result r = run_in(dir, args);
    EXPECT_EQ(r.exit_code, 1) << args << ": " << r.out.substr(0, 200);
    EXPECT_NE(r.err.find("far.yaml: "), std::string::npos) << args << ": " << r.err;
    EXPECT_NE(r.err.find("not finite"), std::string::npos) << args << ": " << r.err;
    EXPECT_EQ(r.out.find("nan"), std::string::npos) << args;
    EXPECT_EQ(r.out.find("null"), std::string::npos) << args;
  }
  // simulate refuses it at the start, and nothing is written: no file, no partial file.
  const Result r = run_in(dir, "simulate far.yaml -o far.csv");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("nothing written to far.csv"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "far.csv"));
  EXPECT_FALSE(fs::exists(dir / "far.csv.partial"));
}

TEST(CommandText, InfoOfALongChainIsLinearInItsLength) {
  const fs::path dir = temp_dir("cli_files_info_chain");
  {
    std::ofstream out(dir / "chain.yaml");
    out << "format: kanedyn-model/1\nbodies:\n";
    for (int k = 1; k <= 3000; ++k)
      out << "  - {name: l" << k
          << ", parent: " << (k == 1 ? "ground" : "l" + std::to_string(k - 1))
          << ", mass: 1, inertia: [1, 1, 1]}\n";
  }
  const Result r = run_in(dir, "info chain.yaml");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Body 3000's chain: its first six bodies, how many more, its root.
  EXPECT_NE(r.out.find("3000 -> 2999 -> 2998 -> 2997 -> 2996 -> 2995 -> ...2993 more... -> 1 -> 0"),
            std::string::npos);
  EXPECT_NE(r.out.find("  7 -> 6 -> 5 -> 4 -> 3 -> 2 -> 1 -> 0\n"), std::string::npos);
  // The whole chain of every body would be 4.5 million numbers; this is a few per body.
  EXPECT_LT(r.out.size(), 3000u * 200u);
}

}  // namespace
