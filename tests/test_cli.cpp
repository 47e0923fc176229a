// The kanedyn tool as a user runs it: output, JSON form and exit codes of `info`, `eom` and
// `bench`.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "file_support.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematic_equations.hpp"

namespace fs = std::filesystem;

namespace {

using kanedyn::test::slurp;
using kanedyn::test::ToolRun;

/// Runs the tool in a folder of the running test's own (ctest runs tests in parallel).
ToolRun run_tool(const std::string& args) {
  const std::string test = ::testing::UnitTest::GetInstance()->current_test_info()->name();
  return kanedyn::test::run_in(kanedyn::test::temp_dir("cli_" + test), args);
}

const std::string kEight = std::string(KANEDYN_SOURCE_DIR) + "/examples/eight_body.yaml";

}  // namespace

TEST(Cli, InfoPrintsTheNotesTopology) {
  const ToolRun r = run_tool("info " + kEight);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("N = 8 bodies"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("L(K) = (0, 1, 2, 2, 1, 1, 1, 7)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("u_K  = (0, 1, 2, 2, 1, 1, 1, 2)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("8 -> 7 -> 1 -> 0"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("3 -> 2 -> 1 -> 0"), std::string::npos) << r.out;
  const auto file = kanedyn::io::load_model_file(kEight);
  std::ostringstream mass;
  mass << "total mass = " << file.model.total_mass();
  EXPECT_NE(r.out.find(mass.str()), std::string::npos) << r.out;
}

TEST(Cli, EomJsonIsTheSpecifiedObjectAtFullPrecision) {
  const ToolRun r = run_tool("eom --json " + kEight);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::ordered_json::parse(r.out);
  std::vector<std::string> keys;
  for (const auto& [key, value] : j.items()) keys.push_back(key);
  EXPECT_EQ(keys, (std::vector<std::string>{"N", "L", "u", "A", "f", "ydot", "xdot"}));
  EXPECT_EQ(j["N"], 8);
  EXPECT_EQ(j["L"], nlohmann::ordered_json::parse("[0,1,2,2,1,1,1,7]"));
  EXPECT_EQ(j["u"], nlohmann::ordered_json::parse("[0,1,2,2,1,1,1,2]"));
  ASSERT_EQ(j["A"].size(), 48u);
  ASSERT_EQ(j["f"].size(), 48u);
  ASSERT_EQ(j["ydot"].size(), 48u);
  ASSERT_EQ(j["xdot"].size(), 56u);

  // The printed numbers read back as exactly the library's doubles (full precision).
  const auto file = kanedyn::io::load_model_file(kEight);
  kanedyn::Data data(file.model);
  kanedyn::kane_equations(file.model, file.initial, data);
  for (int i = 0; i < 48; ++i) {
    ASSERT_EQ(j["A"][i].size(), 48u);
    for (int k = 0; k < 48; ++k) EXPECT_EQ(j["A"][i][k].get<double>(), data.kane.A(i, k));
    EXPECT_EQ(j["f"][i].get<double>(), data.kane.f[i]);
    EXPECT_EQ(j["ydot"][i].get<double>(), data.ydot[i]);
  }
  for (int i = 0; i < 56; ++i) EXPECT_EQ(j["xdot"][i].get<double>(), data.xdot[i]);
}

TEST(Cli, EomTablesAreLabelled) {
  const ToolRun r = run_tool("eom " + kEight);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* s : {"[A] (Eq. 37), 48 x 48", "{f} (Eq. 38)", "{y dot} (Eq. 36)",
                        "{x dot} (Eqs. 39-40)", "w8.3", "sd1.1", "e8.4", "s8.3"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s;
}

TEST(Cli, BadModelGivesOneLineErrorAndExitCode1) {
  const fs::path bad = fs::temp_directory_path() / "kanedyn_cli_bad.yaml";
  std::ofstream(bad) << "format: kanedyn-model/1\nbodies:\n  - name: a\n    parent: ground\n"
                        "    mass: -1\n    inertia: [1, 1, 1]\n";
  for (const std::string cmd : {"info ", "eom ", "eom --json "}) {
    const ToolRun r = run_tool(cmd + bad.string());
    EXPECT_EQ(r.exit_code, 1) << cmd;
    EXPECT_EQ(r.out, "") << cmd;
    EXPECT_EQ(r.err.rfind("kanedyn: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(bad.string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("mass"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
}

TEST(Cli, MissingFileAndUsageErrorsAreNonzero) {
  const ToolRun missing = run_tool("info /nonexistent/model.yaml");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("/nonexistent/model.yaml"), std::string::npos) << missing.err;
  EXPECT_NE(run_tool("info").exit_code, 0);
  EXPECT_NE(run_tool("frobnicate").exit_code, 0);
}

TEST(Cli, AloneItPrintsTheHelp) {
  // `kanedyn` with no word is `kanedyn --help`: the same text on stdout, exit code 0.
  const ToolRun alone = run_tool("");
  const ToolRun help = run_tool("--help");
  EXPECT_EQ(alone.exit_code, 0) << alone.err;
  EXPECT_EQ(alone.err, "");
  EXPECT_EQ(alone.out, help.out);
  for (const char* command : {"simulate", "eom", "import", "equilibrium"})
    EXPECT_NE(alone.out.find(command), std::string::npos) << command;
}

TEST(Cli, HelpSaysEveryModelArgumentReadsUrdfAndHidesTheOlderSpellings) {
  const std::string arm = "'" + std::string(KANEDYN_SOURCE_DIR) + "/examples/urdf/arm.urdf'";
  for (const std::string command : {"info", "eom", "inspect", "simulate", "bench", "linearize",
                                    "equilibrium", "inverse", "view"}) {
    const ToolRun r = run_tool(command + " --help");
    ASSERT_EQ(r.exit_code, 0) << command << r.err;
    EXPECT_NE(r.out.find("MODEL"), std::string::npos) << command;
    EXPECT_NE(r.out.find("model file: YAML, JSON or URDF (.urdf)"), std::string::npos)
        << command << "\n"
        << r.out;
    EXPECT_EQ(r.out.find("YAML or JSON)"), std::string::npos) << command << "\n" << r.out;
    // --method and the route name kane still work (below) but are not offered.
    EXPECT_EQ(r.out.find("--method"), std::string::npos) << command << "\n" << r.out;
    EXPECT_EQ(r.out.find("kane}"), std::string::npos) << command << "\n" << r.out;
    EXPECT_EQ(r.out.find(",kane"), std::string::npos) << command << "\n" << r.out;
    EXPECT_EQ(r.out.find("older spelling"), std::string::npos) << command << "\n" << r.out;
    // And the claim holds: the command reads the URDF arm (help is enough for view and
    // inverse, which need more arguments or write files).
    if (command == "info" || command == "eom" || command == "inspect") {
      EXPECT_EQ(run_tool(command + " " + arm).exit_code, 0) << command;
    }
  }
  // The hidden spellings are still read.
  EXPECT_EQ(run_tool("bench --method kane --reps 5 " + arm).exit_code, 0);
  EXPECT_EQ(run_tool("simulate --method kane --t-end 0.01 --no-output " + arm).exit_code, 0);
}

TEST(Cli, EomOfAJointedModelPrintsItsJointSpaceEquationsFirst) {
  const std::string arm = "'" + std::string(KANEDYN_SOURCE_DIR) + "/examples/urdf/arm.urdf'";
  const ToolRun r = run_tool("eom " + arm);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // n, A_z, f_z and z dot come before the notes' 6N system they are projected from.
  const auto n = r.out.find("n = 6 independent speeds");
  const auto a_z = r.out.find("A_z = [C]^T [A] [C], 6 x 6");
  const auto zdot = r.out.find("z dot", a_z);  // the column of the table after A_z
  const auto notes = r.out.find("[A]{ydot} = {f} (Eq. 36)");
  const auto a = r.out.find("[A] (Eq. 37)");
  ASSERT_NE(n, std::string::npos) << r.out;
  ASSERT_NE(a_z, std::string::npos) << r.out;
  ASSERT_NE(zdot, std::string::npos) << r.out;
  ASSERT_NE(notes, std::string::npos) << r.out;
  ASSERT_NE(a, std::string::npos) << r.out;
  EXPECT_LT(n, a_z);
  EXPECT_LT(a_z, zdot);
  EXPECT_LT(zdot, notes);
  EXPECT_LT(notes, a);
  // The 6 x 6 matrix within the first screenful.
  EXPECT_LT(std::count(r.out.begin(), r.out.begin() + static_cast<long>(a_z), '\n'), 10);
  // The JSON object is the spec's, in its order: the notes' quantities, then the projected.
  const ToolRun j = run_tool("eom --json " + arm);
  ASSERT_EQ(j.exit_code, 0) << j.err;
  const auto object = nlohmann::ordered_json::parse(j.out);
  std::vector<std::string> keys;
  for (const auto& [key, value] : object.items()) keys.push_back(key);
  EXPECT_EQ(keys, (std::vector<std::string>{"N", "L", "u", "inputs", "u_K", "A", "f", "ydot",
                                            "xdot", "n", "C", "A_z", "f_z", "zdot"}));
}

TEST(Cli, BenchJsonIsTheSpecifiedObject) {
  const ToolRun r = run_tool("bench --json --reps 50 " + kEight);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::ordered_json::parse(r.out);
  std::vector<std::string> keys;
  for (const auto& [key, value] : j.items()) keys.push_back(key);
  EXPECT_EQ(keys, (std::vector<std::string>{"model", "N", "evaluates", "results"}));
  EXPECT_EQ(j["model"], kEight);
  EXPECT_EQ(j["evaluates"], "d/dt of ({x}; {y}) of Eq. (1)");
  EXPECT_EQ(j["N"], 8);
  ASSERT_EQ(j["results"].size(), 2u);  // default: both routes
  EXPECT_EQ(j["results"][0]["route"], "recursive");
  EXPECT_EQ(j["results"][1]["route"], "assembled");
  for (const auto& result : j["results"]) {
    std::vector<std::string> fields;
    for (const auto& [key, value] : result.items()) fields.push_back(key);
    EXPECT_EQ(fields, (std::vector<std::string>{"route", "kernel", "ns_per_eval_median",
                                                "ns_per_eval_min", "reps"}));
    EXPECT_EQ(result["reps"], 50);
    // simulate's kernel of the route: the fused pass (every element of eight_body.yaml is
    // built in) or the assembled [A].
    EXPECT_EQ(result["kernel"].get<std::string>().find(result["route"] == "recursive"
                                                           ? "fused O(N) pass"
                                                           : "assembled [A] (Eqs. 37-38)"),
              0u)
        << result["kernel"];
    EXPECT_GT(result["ns_per_eval_min"].get<double>(), 0.0);
    EXPECT_GE(result["ns_per_eval_median"].get<double>(), result["ns_per_eval_min"].get<double>());
  }
}

TEST(Cli, BenchOfAJointedModelTimesItsJointedRoutes) {
  // What simulate integrates for a jointed model: z dot and q dot, by both jointed routes.
  const std::string arm = "'" + std::string(KANEDYN_SOURCE_DIR) + "/examples/urdf/arm.urdf'";
  ToolRun r = run_tool("bench --json --reps 20 " + arm);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::ordered_json::parse(r.out);
  EXPECT_EQ(j["evaluates"], "d/dt of (q; z)");
  ASSERT_EQ(j["results"].size(), 2u);
  EXPECT_EQ(j["results"][0]["route"], "recursive");
  EXPECT_EQ(j["results"][0]["kernel"], "articulated-body recursion over the joints");
  EXPECT_EQ(j["results"][1]["route"], "assembled");
  EXPECT_EQ(j["results"][1]["kernel"], "projected Kane equations, tree LDL^T");
  r = run_tool("bench --route recursive --reps 20 " + arm);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("forward dynamics (d/dt of (q; z), as simulate evaluates it)"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("recursive: articulated-body recursion over the joints"), std::string::npos)
      << r.out;
  // The free tree's SIMD kernel is not what runs here, so no width is named.
  EXPECT_EQ(r.out.find("SIMD pass"), std::string::npos) << r.out;
}

TEST(Cli, BenchTextNamesTheSimdWidthAndTakesACap) {
  const ToolRun r = run_tool("bench --method recursive --reps 20 --simd-lanes 2 " + kEight);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("recursive: fused O(N) pass, 2 bodies per SIMD pass"), std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("kane"), std::string::npos) << r.out;
  const ToolRun bad = run_tool("bench --simd-lanes 3 " + kEight);
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("--simd-lanes"), std::string::npos) << bad.err;
}

namespace {

// Past eight bodies eom prints [A]'s block structure: '#' exactly where one body is on the
// other's chain (the blocks the tree LDL^T keeps), '.' elsewhere; --full prints the table.
TEST(Cli, EomPrintsTheBlockStructureOfLargeModels) {
  const std::string chain = kanedyn::test::kExamples + "/chain64.yaml";
  const fs::path dir = kanedyn::test::temp_dir("cli_eom_blocks");
  // A tree: the chain's links 33..64 re-hung from link 16, so that both '#' and '.' occur.
  std::string text = slurp(chain);
  const size_t at = text.find("name: link33");
  ASSERT_NE(at, std::string::npos);
  const size_t parent = text.find("parent: link32", at);
  ASSERT_NE(parent, std::string::npos);
  text.replace(parent, 14, "parent: link16");
  std::ofstream(dir / "tree.yaml") << text;
  ToolRun r = kanedyn::test::run_in(dir, "eom tree.yaml");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto file = kanedyn::io::load_model_file((dir / "tree.yaml").string());
  const kanedyn::Model& model = file.model;
  ASSERT_EQ(model.lower_body(32), 15);
  int rows = 0;
  for (const std::string& line : kanedyn::test::split(r.out, '\n')) {
    int k = 0;
    char cells[128];
    if (std::sscanf(line.c_str(), "%d %127s", &k, cells) != 2 || std::strlen(cells) != 64) continue;
    if (cells[0] != '#' && cells[0] != '.') continue;
    ++rows;
    for (int i = 0; i < 64; ++i)
      EXPECT_EQ(cells[i] == '#', model.on_chain(k - 1, i) || model.on_chain(i, k - 1))
          << k << " " << i + 1;
  }
  EXPECT_EQ(rows, 64);
  EXPECT_EQ(r.out.find("[A] (Eq. 37), 384 x 384\n"), std::string::npos);
  r = kanedyn::test::run_in(dir, "eom tree.yaml --full");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("[A] (Eq. 37), 384 x 384\n"), std::string::npos);
  EXPECT_GT(r.out.size(), 384u * 384u * 10u);  // every entry printed
}

}  // namespace
