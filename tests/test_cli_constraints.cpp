// `kanedyn inspect` of models with constraints: the "constraints" object of --json and the text
// block, on the four-bar (a hinge closing a loop, 3 of its 5 equations redundant) and the
// bicycle (two rolling discs).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "file_support.hpp"
#include "kanedyn/analysis.hpp"
#include "kanedyn/io/model_file.hpp"

namespace fs = std::filesystem;

namespace {

using namespace kanedyn;
using Json = nlohmann::ordered_json;
using test::kExamples;
using test::run_in;
using test::slurp;
using test::temp_dir;

MatrixX matrix(const Json& j) {
  MatrixX m(static_cast<Eigen::Index>(j.size()), j.empty() ? 0 : j[0].size());
  for (size_t r = 0; r < j.size(); ++r)
    for (size_t c = 0; c < j[r].size(); ++c)
      m(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = j[r][c].get<double>();
  return m;
}

VectorX vector(const Json& j) {
  VectorX v(static_cast<Eigen::Index>(j.size()));
  for (size_t i = 0; i < j.size(); ++i) v[static_cast<Eigen::Index>(i)] = j[i].get<double>();
  return v;
}

Json inspect_json(const fs::path& dir, const std::string& model) {
  const auto r = run_in(dir, "inspect '" + model + "' --json");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return Json::parse(r.out);
}

// What every model with constraints must satisfy: [B][C_I] = 0, [B]{z dot} + {b} = 0, the
// sizes and names consistent with the model.
void check_consistent(const Json& c, const Model& model) {
  const int n = model.num_speeds();
  const MatrixX B = matrix(c["B"]), CI = matrix(c["C_I"]);
  const VectorX b = vector(c["b"]), zdot = vector(c["zdot"]);
  const int rows = static_cast<int>(c["rows"].size());
  const int rank = c["rank"].get<int>();
  ASSERT_EQ(B.rows(), rows);
  ASSERT_EQ(B.cols(), n);
  ASSERT_EQ(CI.rows(), n);
  ASSERT_EQ(CI.cols(), n - rank);
  EXPECT_EQ(c["holonomic"].size(), static_cast<size_t>(rows));
  EXPECT_EQ(c["errors"].size(), static_cast<size_t>(rows));
  EXPECT_EQ(c["lambda"].size(), static_cast<size_t>(rows));
  EXPECT_EQ(c["independent_speeds"].size() + c["dependent_speeds"].size(), static_cast<size_t>(n));
  EXPECT_EQ(c["redundant_rows"].size(), static_cast<size_t>(rows - rank));
  EXPECT_LT((B * CI).cwiseAbs().maxCoeff(), 1e-12 * std::max(1.0, B.cwiseAbs().maxCoeff()));
  EXPECT_LT((B * zdot + b).cwiseAbs().maxCoeff(), 1e-9 * std::max(1.0, zdot.cwiseAbs().maxCoeff()));
  // C_I is the identity on the independent speeds' rows, found by name.
  const std::vector<std::string> names = tangent_state_names(model);
  for (size_t j = 0; j < c["independent_speeds"].size(); ++j) {
    const std::string name = c["independent_speeds"][j];
    int row = -1;
    for (int i = 0; i < n; ++i)
      if (names[static_cast<size_t>(n + i)] == name) row = i;
    ASSERT_GE(row, 0) << name;
    for (Eigen::Index k = 0; k < CI.cols(); ++k)
      EXPECT_EQ(CI(row, k), k == static_cast<Eigen::Index>(j) ? 1.0 : 0.0) << name;
  }
  ASSERT_EQ(c["reactions"].size(), model.constraints().size());
  for (size_t i = 0; i < model.constraints().size(); ++i) {
    EXPECT_EQ(c["reactions"][i]["name"], model.constraints()[i].name);
    EXPECT_EQ(c["reactions"][i]["point"].size(), 3u);
    EXPECT_EQ(c["reactions"][i]["force"].size(), 3u);
  }
}

TEST(InspectConstraints, FourBarHasRankTwoAndThreeRedundantRows) {
  const fs::path dir = temp_dir("cli_inspect_four_bar");
  const std::string path = kExamples + "/four_bar.yaml";
  const Json j = inspect_json(dir, path);
  // The existing keys stay as they were, the constraints come last.
  std::vector<std::string> keys;
  for (const auto& item : j.items()) keys.push_back(item.key());
  EXPECT_EQ(keys, (std::vector<std::string>{"N", "t", "F_y", "F_y_star", "ydot", "bodies", "joints",
                                            "constraints"}));
  const Json& c = j["constraints"];
  const io::ModelFile file = io::load_model_file(path);
  check_consistent(c, file.model);
  EXPECT_EQ(c["rank"], 2);
  EXPECT_EQ(c["rows"], (std::vector<std::string>{"closure.1", "closure.2", "closure.3", "closure.4",
                                                 "closure.5"}));
  EXPECT_EQ(c["holonomic"], (std::vector<bool>(5, true)));
  EXPECT_EQ(c["redundant_rows"].size(), 3u);
  EXPECT_EQ(c["independent_speeds"], (std::vector<std::string>{"crank.jd1"}));
  EXPECT_EQ(c["dependent_speeds"], (std::vector<std::string>{"coupler.jd1", "rocker.jd1"}));
  // The loader projected the state: the loop is closed to round-off.
  EXPECT_LT(vector(c["errors"]).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(c["redundant_rows"], (std::vector<std::string>{"closure.3", "closure.4", "closure.5"}));
  // A hinge reports a moment. Its rows (and the ball's out-of-plane one) are the redundant
  // ones, whose minimum-norm multipliers are zero: the planar linkage carries no moment.
  ASSERT_TRUE(c["reactions"][0].contains("moment"));
  EXPECT_LT(vector(c["reactions"][0]["moment"]).norm(), 1e-9);
  EXPECT_LT(std::abs(c["reactions"][0]["force"][2].get<double>()), 1e-9);
  EXPECT_GT(vector(c["reactions"][0]["force"]).norm(), 1.0);
  EXPECT_EQ(c["reactions"][0]["type"], "hinge");
  // The point is the rocker's far end, at D = (1, 0, 0).
  EXPECT_NEAR(c["reactions"][0]["point"][0].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(c["reactions"][0]["point"][1].get<double>(), 0.0, 1e-9);
}

TEST(InspectConstraints, BicycleAtRestCarriesItsWeightOnTheContacts) {
  const fs::path dir = temp_dir("cli_inspect_bicycle");
  // The example with every initial speed removed: the bicycle stands, balanced for an
  // instant, and its contacts carry the whole weight.
  const std::string moving = slurp(kExamples + "/bicycle.yaml");
  std::string still = std::regex_replace(
      moving, std::regex(R"((translation_rate|angular_velocity): \[[^\]]*\])"), "$1: [0, 0, 0]");
  still = std::regex_replace(still, std::regex(R"(joint_rate: \[[^\]]*\])"), "joint_rate: [0]");
  ASSERT_NE(still, moving);
  std::ofstream(dir / "still.yaml") << still;
  const Json j = inspect_json(dir, "still.yaml");
  const io::ModelFile file = io::load_model_file((dir / "still.yaml").string());
  ASSERT_LT(file.z.cwiseAbs().maxCoeff(), 1e-15);
  const Json& c = j["constraints"];
  check_consistent(c, file.model);
  EXPECT_EQ(c["rank"], 6);
  EXPECT_TRUE(c["redundant_rows"].empty());
  EXPECT_EQ(c["holonomic"], (std::vector<bool>{true, false, false, true, false, false}));
  double normal = 0.0, lateral = 0.0;
  for (const Json& r : c["reactions"]) {
    EXPECT_EQ(r["type"], "rolling_disc");
    EXPECT_FALSE(r.contains("moment"));
    normal += r["force"][2].get<double>();  // the plane's normal is +z
    lateral += r["force"][1].get<double>();
    EXPECT_GT(r["force"][2].get<double>(), 0.0);           // each wheel is pressed, neither lifts
    EXPECT_NEAR(r["point"][2].get<double>(), 0.0, 1e-12);  // on the ground
  }
  const double weight = 94.0 * 9.81;
  EXPECT_NEAR(normal, weight, 1e-9 * weight);
  EXPECT_NEAR(lateral, 0.0, 1e-9 * weight);
  // At rest the constraints' rates vanish, as do the ground's holonomic errors.
  EXPECT_LT(vector(c["b"]).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(vector(c["errors"]).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(InspectConstraints, MovingBicycleAndTheTextBlock) {
  const fs::path dir = temp_dir("cli_inspect_bicycle_moving");
  const std::string path = kExamples + "/bicycle.yaml";
  const Json j = inspect_json(dir, path);
  const io::ModelFile file = io::load_model_file(path);
  check_consistent(j["constraints"], file.model);
  // Moving, the rolling constraints have rates: b is not zero, so B zdot + b = 0 tests zdot.
  EXPECT_GT(vector(j["constraints"]["b"]).cwiseAbs().maxCoeff(), 1e-3);
  // The human-readable form names the same things.
  const auto r = run_in(dir, "inspect '" + path + "' --body 1 --quantity R");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* needle :
       {"constraints: 6 equations, rank 6", "independent speeds: rear_frame.w1, rear_wheel.jd1",
        "rear_contact.2", "[C_I]", "front_contact (rolling_disc) at", "z dot"})
    EXPECT_NE(r.out.find(needle), std::string::npos) << needle << "\n" << r.out;
  // The constraints' block keeps within 100 columns, as the symbolic forms do.
  std::istringstream lines(r.out.substr(r.out.find("\nconstraints:")));
  for (std::string line; std::getline(lines, line);) EXPECT_LE(line.size(), 100u) << line;
}

TEST(InspectConstraints, ModelsWithoutConstraintsHaveNoConstraintsKey) {
  const fs::path dir = temp_dir("cli_inspect_no_constraints");
  const Json j = inspect_json(dir, kExamples + "/double_pendulum.yaml");
  EXPECT_FALSE(j.contains("constraints"));
  const auto r = run_in(dir, "inspect '" + kExamples + "/double_pendulum.yaml'");
  EXPECT_EQ(r.out.find("constraints:"), std::string::npos);
}

// inverse would answer for the tree without its constraints: refused, with a nonzero exit and a
// message naming the file.
TEST(ConstraintsNotYetHandled, InverseRefusesModelsWithConstraints) {
  const fs::path dir = temp_dir("cli_constraints_refused");
  const std::string model = kExamples + "/four_bar.yaml";
  const auto sim = run_in(dir, "simulate '" + model + "' --t-end 0.1 -o run.csv");
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const auto inv = run_in(dir, "inverse '" + model + "' run.csv");
  EXPECT_NE(inv.exit_code, 0);
  EXPECT_NE(inv.err.find("four_bar.yaml: inverse does not handle models with constraints"),
            std::string::npos)
      << inv.err;
}

}  // namespace
