// Inspection: the notes' printed block forms of the partial velocity matrices and their rates,
// the per-body shares of Eq. (31) and of the inertia forces (Kane's equations: F_y + F_y* = 0),
// and `kanedyn inspect --json` against the library bit for bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "file_support.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/inspect.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/partials.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

using test::kExamples;

// The forms the notes print after Eq. (27) for body 8 of the eight-body example, in ASCII.
TEST(Inspect, SymbolicPartialsOfBodyEightAreTheNotes) {
  const Model model = test::eight_body_model();
  EXPECT_EQ(format_symbolic(model, 7, Point::G, false, 1),
            "[v_G8,y1] = -[ [R_1]^T([q~'_7]+[s~'_7]), 0, 0, 0, 0, 0, [R_7]^T([q~'_8]+[s~'_8]), "
            "[R_8]^T[r~'_8] ]");
  EXPECT_EQ(format_symbolic(model, 7, Point::G, false, 2),
            "[v_G8,y2] = [ I, 0, 0, 0, 0, 0, [R_1]^T, [R_7]^T ]");
  // O_8 has no block at body 8 itself (Eqs. 22-25).
  EXPECT_EQ(
      format_symbolic(model, 7, Point::O, false, 1),
      "[v_O8,y1] = -[ [R_1]^T([q~'_7]+[s~'_7]), 0, 0, 0, 0, 0, [R_7]^T([q~'_8]+[s~'_8]), 0 ]");
  // The root: [v_O1,y] = [0, I] and its rate vanishes.
  EXPECT_EQ(format_symbolic(model, 0, Point::O, false, 1), "[v_O1,y1] = 0");
  EXPECT_EQ(format_symbolic(model, 0, Point::O, true, 1), "[v_O1,y1 dot] = 0");
  EXPECT_EQ(format_symbolic(model, 0, Point::O, true, 2), "[v_O1,y2 dot] = 0");
  EXPECT_EQ(format_symbolic(model, 0, Point::G, true, 1),
            "[v_G1,y1 dot] = -[ [R_1]^T[w~'_1][r~'_1], 0, 0, 0, 0, 0, 0, 0 ]");
}

// The notes' expansions of Eq. (30) for bodies 2 and 3, with the s' dot of the seed's README
// (printed [s~'_K] in the notes, [sd~'_K] here).
TEST(Inspect, SymbolicRatesOfBodiesTwoAndThreeAreTheNotes) {
  const Model model = test::eight_body_model();
  EXPECT_EQ(format_symbolic(model, 1, Point::O, true, 1),
            "[v_O2,y1 dot] = -[ [R_1]^T([w~'_1]([q~'_2]+[s~'_2])+[sd~'_2]), 0, 0, 0, 0, 0, 0, 0 ]");
  EXPECT_EQ(format_symbolic(model, 1, Point::O, true, 2),
            "[v_O2,y2 dot] = [ 0, [R_1]^T[w~'_1], 0, 0, 0, 0, 0, 0 ]");
  EXPECT_EQ(format_symbolic(model, 2, Point::O, true, 1),
            "[v_O3,y1 dot] = -[ [R_1]^T([w~'_1]([q~'_2]+[s~'_2])+[sd~'_2]), "
            "[R_2]^T([w~'_2]([q~'_3]+[s~'_3])+[sd~'_3]), 0, 0, 0, 0, 0, 0 ]");
  EXPECT_EQ(format_symbolic(model, 2, Point::O, true, 2),
            "[v_O3,y2 dot] = [ 0, [R_1]^T[w~'_1], [R_2]^T[w~'_2], 0, 0, 0, 0, 0 ]");
  // G_2 adds the rate of -[R_2]^T[r~'_2] at body 2 (Eq. 29).
  EXPECT_EQ(format_symbolic(model, 1, Point::G, true, 1),
            "[v_G2,y1 dot] = -[ [R_1]^T([w~'_1]([q~'_2]+[s~'_2])+[sd~'_2]), "
            "[R_2]^T[w~'_2][r~'_2], 0, 0, 0, 0, 0, 0 ]");
}

// The symbolic blocks sit exactly where the numbers are nonzero, on random trees: the
// structure and the values come from different code.
TEST(Inspect, SymbolicBlocksAreWhereTheNumbersAre) {
  std::mt19937 rng(41);
  for (int trial = 0; trial < 20; ++trial) {
    test::RandomTreeOptions opt;
    opt.bushings = true;
    const Model model = test::random_tree(rng, opt);
    const State state = test::moving_state(model, 40u + static_cast<unsigned>(trial));
    const Inspection in = inspect(model, state);
    const int n = model.num_bodies();
    for (int k = 0; k < n; ++k) {
      const BodyInspection& b = in.bodies[static_cast<size_t>(k)];
      for (const bool rate : {false, true})
        for (const Point point : {Point::O, Point::G}) {
          const MatrixX& m =
              point == Point::O ? (rate ? b.v_O_y_dot : b.v_O_y) : (rate ? b.v_G_y_dot : b.v_G_y);
          const SymbolicPartial s = symbolic_partial(model, k, point, rate);
          for (int part = 0; part < 2; ++part) {
            std::vector<bool> symbolic(static_cast<size_t>(n), false);
            for (const SymbolicBlock& blk : part == 0 ? s.y1 : s.y2)
              symbolic[static_cast<size_t>(blk.body - 1)] = true;
            for (int c = 0; c < n; ++c) {
              const bool nonzero = !m.block<3, 3>(0, 3 * n * part + 3 * c).isZero(0.0);
              // A symbolic block may happen to be zero (r'_K = 0, w'_J = 0); a nonzero
              // number never sits where the notes have [0].
              if (nonzero) {
                EXPECT_TRUE(symbolic[static_cast<size_t>(c)]) << k << " " << c;
              }
            }
          }
        }
    }
  }
}

// Kane's equations, body by body: sum_K (F_y + F_y*) = {f} - [A]{y dot} = 0 at the solved
// {y dot} (the recursive route's, which holds Newton-Euler for each body to round-off): ~6N
// eps times the size of the terms; 1e-12 relative to the largest per-body term leaves a
// margin of ~100.
TEST(Inspect, GeneralizedForcesAndInertiaForcesCancel) {
  std::mt19937 rng(42);
  for (int trial = 0; trial < 30; ++trial) {
    test::RandomTreeOptions opt;
    opt.bushings = opt.forces = opt.torques = true;
    const Model model = test::random_tree(rng, opt);
    const State state = test::random_state(model, rng);
    const Inspection in = inspect(model, state);
    double scale = 0.0;
    VectorX fy = VectorX::Zero(6 * in.N), fy_star = fy;
    for (const BodyInspection& b : in.bodies) {
      scale = std::max({scale, test::max_abs(b.F_y), test::max_abs(b.F_y_star)});
      fy += b.F_y;
      fy_star += b.F_y_star;
    }
    EXPECT_LT(test::max_abs(in.F_y + in.F_y_star), 1e-12 * scale) << "N " << in.N;
    EXPECT_EQ(fy, in.F_y);  // the top-level sums are the bodies' sums, in body order
    EXPECT_EQ(fy_star, in.F_y_star);
    // Eq. (31) body by body equals the library's O(N) inward pass.
    Data data(model);
    kane_equations(model, state, data);
    EXPECT_LT(test::max_abs(in.F_y - data.kane.F_y), 1e-12 * scale);
    // {y dot} is the recursive route's; the assembled route's agrees to the 1e-10 the routes
    // are held to (tests/test_speed_routes.cpp).
    Data recursive(model, DataOptions::recursive_only());
    forward_dynamics(model, state, recursive, Route::recursive);
    EXPECT_EQ(in.ydot, recursive.ydot);
    EXPECT_LE((in.ydot - data.ydot).norm(), 1e-10 * data.ydot.norm());
  }
}

TEST(Inspect, SelectsBodiesButSumsOverAll) {
  const Model model = test::eight_body_model();
  const State state = test::moving_state(model, 43);
  const Inspection all = inspect(model, state);
  const Inspection two = inspect(model, state, 1.5, {7, 2});
  ASSERT_EQ(two.bodies.size(), 2u);
  EXPECT_EQ(two.bodies[0].K, 3);  // numbering order
  EXPECT_EQ(two.bodies[1].K, 8);
  EXPECT_EQ(two.t, 1.5);
  EXPECT_EQ(two.F_y, all.F_y);
  EXPECT_EQ(two.bodies[1].v_G_y, all.bodies[7].v_G_y);
  EXPECT_EQ(two.bodies[1].chain, (std::vector<int>{8, 7, 1, 0}));
  EXPECT_THROW(inspect(model, state, 0.0, {8}), std::out_of_range);
}

// A jointed model: the inspection at (q, z) is the free tree's at joint_state(q, z) plus the
// joints, whose [C] rows per body are the rows of the whole [C], and whose jointed y dot is the
// velocities' rate [C]{z dot} + [C dot]{z}; the y dot [C]{z dot} would give alone differs.
TEST(Inspect, JointedModelAddsTheJointsAtItsJointState) {
  const io::ModelFile file = io::load_model_file(kExamples + "/human_jointed.yaml");
  ASSERT_TRUE(file.jointed());
  const Model& tree = file.model;
  const Inspection in = inspect(file.model, file.q, file.z, 0.25, {1, 7});
  const Inspection free = inspect(file.model, file.initial, 0.25, {1, 7});
  EXPECT_EQ(in.ydot, free.ydot);
  EXPECT_EQ(in.bodies[1].v_G_y, free.bodies[1].v_G_y);
  EXPECT_FALSE(free.joints);
  ASSERT_TRUE(in.joints);
  const JointInspection& j = *in.joints;
  EXPECT_EQ(j.n, tree.num_speeds());
  EXPECT_EQ(j.q, file.q);
  ASSERT_EQ(j.bodies.size(), 2u);
  const int n = file.model.num_bodies();
  for (const JointBodyInspection& b : j.bodies) {
    const int k = b.K - 1;
    EXPECT_EQ(b.type, tree.joint(k).type);
    EXPECT_EQ(b.q.size(), coordinate_count(b.type));
    EXPECT_EQ(b.z, file.z.segment(tree.speed_offset(k), speed_count(b.type)));
    EXPECT_EQ(b.C_w, j.C.middleRows(3 * k, 3));
    EXPECT_EQ(b.C_sd, j.C.middleRows(3 * n + 3 * k, 3));
  }
  EXPECT_EQ(j.bodies[0].K, 2);
  EXPECT_EQ(j.bodies[1].K, 8);
  EXPECT_LT((j.A_z * j.zdot - j.f_z).norm(), 1e-10 * j.f_z.norm());
  EXPECT_EQ(j.ydot, VectorX(j.C * j.zdot + j.Cdot_z));
  EXPECT_GT(j.Cdot_z.norm(), 0.0);  // a moving figure: [C dot]{z} is not zero
}

// [A]'s structure from L(K) alone against the numbers of Eq. (37): a block the structure
// leaves out is exactly zero, and every block it lists is nonzero at a generic state.
TEST(Inspect, MassMatrixStructureIsWhereTheBlocksAre) {
  std::mt19937 rng(44);
  for (int trial = 0; trial < 10; ++trial) {
    test::RandomTreeOptions opt;
    opt.bushings = true;
    const Model model = test::random_tree(rng, opt);
    const State state = test::random_state(model, rng);
    Data data(model);
    kane_equations(model, state, data);
    const int n = model.num_bodies();
    const std::vector<std::vector<int>> rows = mass_matrix_structure(model);
    ASSERT_EQ(rows.size(), static_cast<size_t>(n));
    for (int k = 0; k < n; ++k)
      for (int i = 0; i < n; ++i) {
        const bool listed =
            std::find(rows[static_cast<size_t>(k)].begin(), rows[static_cast<size_t>(k)].end(),
                      i + 1) != rows[static_cast<size_t>(k)].end();
        double largest = 0.0;
        for (int p = 0; p < 2; ++p)
          for (int q = 0; q < 2; ++q)
            largest = std::max(largest, test::max_abs(data.kane.A.block<3, 3>(3 * n * p + 3 * k,
                                                                              3 * n * q + 3 * i)));
        EXPECT_EQ(listed, largest > 0.0) << k << " " << i;
      }
  }
}

using Json = nlohmann::json;

void expect_vector(const Json& j, const VectorX& v, const std::string& what) {
  ASSERT_EQ(j.size(), static_cast<size_t>(v.size())) << what;
  for (Eigen::Index i = 0; i < v.size(); ++i)
    EXPECT_EQ(j[static_cast<size_t>(i)].get<double>(), v[i]) << what << "[" << i << "]";
}

void expect_matrix(const Json& j, const MatrixX& m, const std::string& what) {
  ASSERT_EQ(j.size(), static_cast<size_t>(m.rows())) << what;
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    expect_vector(j[static_cast<size_t>(r)], m.row(r).transpose(), what);
}

// The JSON of the spec's "Inspection output", every number read back to the library's double.
TEST(InspectCommand, JsonIsTheLibrarysValuesBitForBit) {
  const std::string eight = kExamples + "/eight_body.yaml";
  const test::ToolRun r =
      test::run_in(test::temp_dir("inspect_json"), "inspect " + eight + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  const nlohmann::ordered_json ordered = nlohmann::ordered_json::parse(r.out);
  std::vector<std::string> top;
  for (const auto& [key, value] : ordered.items()) top.push_back(key);
  EXPECT_EQ(top, (std::vector<std::string>{"N", "t", "F_y", "F_y_star", "ydot", "bodies"}));
  const io::ModelFile file = io::load_model_file(eight);
  const Inspection in = inspect(file.model, file.initial);
  EXPECT_EQ(j["N"], 8);
  EXPECT_EQ(j["t"].get<double>(), 0.0);
  expect_vector(j["F_y"], in.F_y, "F_y");
  expect_vector(j["F_y_star"], in.F_y_star, "F_y_star");
  expect_vector(j["ydot"], in.ydot, "ydot");
  ASSERT_EQ(j["bodies"].size(), 8u);
  const std::vector<std::string> keys = {
      "K", "name", "L",     "u",     "chain",     "R",         "p_O", "p_G", "v_O", "v_G",
      "w", "w_y",  "v_O_y", "v_G_y", "v_O_y_dot", "v_G_y_dot", "F",   "M",   "F_y", "F_y_star"};
  for (size_t k = 0; k < 8; ++k) {
    const Json& b = j["bodies"][k];
    const BodyInspection& e = in.bodies[k];
    std::vector<std::string> got;
    for (const auto& [key, value] : ordered["bodies"][k].items()) got.push_back(key);
    EXPECT_EQ(got, keys);  // the spec's order
    EXPECT_EQ(b["K"], e.K);
    EXPECT_EQ(b["name"], e.name);
    EXPECT_EQ(b["L"], e.L);
    EXPECT_EQ(b["u"], e.u);
    EXPECT_EQ(b["chain"].get<std::vector<int>>(), e.chain);
    expect_matrix(b["R"], e.R, "R");
    expect_vector(b["p_O"], e.p_O, "p_O");
    expect_vector(b["p_G"], e.p_G, "p_G");
    expect_vector(b["v_O"], e.v_O, "v_O");
    expect_vector(b["v_G"], e.v_G, "v_G");
    expect_vector(b["w"], e.w, "w");
    expect_matrix(b["w_y"], e.w_y, "w_y");
    expect_matrix(b["v_O_y"], e.v_O_y, "v_O_y");
    expect_matrix(b["v_G_y"], e.v_G_y, "v_G_y");
    expect_matrix(b["v_O_y_dot"], e.v_O_y_dot, "v_O_y_dot");
    expect_matrix(b["v_G_y_dot"], e.v_G_y_dot, "v_G_y_dot");
    expect_vector(b["F"], e.F, "F");
    expect_vector(b["M"], e.M, "M");
    expect_vector(b["F_y"], e.F_y, "F_y");
    expect_vector(b["F_y_star"], e.F_y_star, "F_y_star");
  }
}

TEST(InspectCommand, SelectionAndErrors) {
  const std::string eight = kExamples + "/eight_body.yaml";
  const auto dir = test::temp_dir("inspect_select");
  test::ToolRun r =
      test::run_in(dir, "inspect " + eight + " --json --body left_forearm --body 3 --quantity p_G");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json j = Json::parse(r.out);
  ASSERT_EQ(j["bodies"].size(), 2u);
  EXPECT_EQ(j["bodies"][0]["K"], 3);
  EXPECT_EQ(j["bodies"][1]["K"], 8);
  EXPECT_TRUE(j["bodies"][1].contains("p_G"));
  EXPECT_FALSE(j["bodies"][1].contains("R"));
  EXPECT_EQ(j["F_y"].size(), 48u);  // the sums stay whole
  r = test::run_in(dir, "inspect " + eight + " --body left_forarm");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--body left_forarm: no such body"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("did you mean 'left_forearm'?"), std::string::npos) << r.err;
  r = test::run_in(dir, "inspect " + eight + " --body 9");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("give 1..8"), std::string::npos) << r.err;
  r = test::run_in(dir, "inspect " + eight + " --quantity v_Q_y");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_EQ(r.err,
            "kanedyn: error: --quantity v_Q_y: no such quantity (did you mean 'v_O_y'? "
            "see kanedyn inspect --help)\n");
  // The text names the notes' forms.
  r = test::run_in(dir, "inspect " + eight + " --body 8 --quantity v_G_y");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("[v_G8,y2] = [ I, 0, 0, 0, 0, 0, [R_1]^T, [R_7]^T ]"), std::string::npos)
      << r.out;
  for (const std::string& line : test::split(r.out, '\n')) EXPECT_LE(line.size(), 100u) << line;
}

// Explaining a row: every body with a share is listed with the library's numbers, largest
// first, and the sums cancel.
TEST(InspectCommand, RowListsEachBodysShareAndChecksTheSum) {
  const std::string eight = kExamples + "/eight_body.yaml";
  const auto dir = test::temp_dir("inspect_row");
  const io::ModelFile file = io::load_model_file(eight);
  const Inspection in = inspect(file.model, file.initial);
  // w2.1 is row 4 (w'_2 component 1): bodies 2, 3 and 4 (body 2's subtree) have shares.
  for (const std::string& row : {std::string("4"), std::string("w2.1")}) {
    const test::ToolRun r = test::run_in(dir, "inspect " + eight + " --row " + row);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.out.find("row 4 of Kane's equations (speed w2.1"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("(3 of 8 bodies contribute)"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find(": cancels"), std::string::npos) << r.out;
    double last = INFINITY;
    int listed = 0;
    for (const std::string& line : test::split(r.out, '\n')) {
      int k = 0;
      char name[64];
      double fy = 0, fy_star = 0;
      if (std::sscanf(line.c_str(), " %d %63s %lf %lf", &k, name, &fy, &fy_star) != 4) continue;
      ++listed;
      const BodyInspection& b = in.bodies[static_cast<size_t>(k - 1)];
      EXPECT_EQ(std::string(name), b.name);
      EXPECT_NEAR(fy, b.F_y[3], 1e-8 * std::abs(b.F_y[3]));  // printed to 9 digits
      EXPECT_NEAR(fy_star, b.F_y_star[3], 1e-8 * std::abs(b.F_y_star[3]));
      EXPECT_LE(std::max(std::abs(fy), std::abs(fy_star)), last);  // largest first
      last = std::max(std::abs(fy), std::abs(fy_star));
    }
    EXPECT_EQ(listed, 3);
  }
  test::ToolRun r = test::run_in(dir, "inspect " + eight + " --row sd9.1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--row sd9.1: no such row (give 1..48"), std::string::npos) << r.err;
  r = test::run_in(dir, "inspect " + eight + " --row 49");
  EXPECT_EQ(r.exit_code, 1);
  r = test::run_in(dir, "inspect " + eight + " --row 1 --json");
  EXPECT_EQ(r.exit_code, 2);
}

}  // namespace
}  // namespace kanedyn
