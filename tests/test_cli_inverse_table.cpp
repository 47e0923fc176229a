// `kanedyn inverse` of a plain table of joint coordinates (t, NAME.j*, optionally NAME.jd* and
// input.*) instead of simulate's full CSV: the same forces where the table has the rates, the
// differencing's order where it has not, a pendulum driven along a known motion, and every
// refusal.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "file_support.hpp"

namespace kanedyn {
namespace {

using namespace kanedyn::test;

// An arm of four joints (revolute, universal, revolute, prismatic), with joint springs and two
// inputs: every kind of column a table of joint coordinates has.
const char* const kArmModel =
    "format: kanedyn-model/1\n"
    "name: test arm\n"
    "gravity: [0, 0, -9.81]\n"
    "bodies:\n"
    "  - name: base\n"
    "    parent: ground\n"
    "    mass: 3.0\n"
    "    inertia: [0.02, 0.02, 0.03]\n"
    "    com: [0.05, 0, 0.1]\n"
    "    joint: {type: revolute, axis: [0, 0, 1]}\n"
    "    initial: {joint: [0.3], joint_rate: [1.5]}\n"
    "  - name: upper\n"
    "    parent: base\n"
    "    mass: 2.0\n"
    "    inertia: [0.04, 0.04, 0.005]\n"
    "    com: [0, 0, 0.25]\n"
    "    joint: {at: [0, 0, 0.2], type: universal, axes: [[0, 1, 0], [1, 0, 0]]}\n"
    "    initial: {joint: [0.4, -0.2], joint_rate: [0.5, 1.0]}\n"
    "  - name: fore\n"
    "    parent: upper\n"
    "    mass: 1.0\n"
    "    inertia: [0.02, 0.02, 0.002]\n"
    "    com: [0, 0, 0.2]\n"
    "    joint: {at: [0, 0, 0.5], type: revolute, axis: [0, 1, 0]}\n"
    "    initial: {joint: [0.8], joint_rate: [-1.0]}\n"
    "  - name: slide\n"
    "    parent: fore\n"
    "    mass: 0.5\n"
    "    inertia: [0.001, 0.001, 0.001]\n"
    "    joint: {at: [0, 0, 0.4], type: prismatic, axis: [0, 0, 1]}\n"
    "    initial: {joint: [0.05], joint_rate: [0.2]}\n"
    "forces:\n"
    "  - {type: joint_spring, body: slide, stiffness: 50, damping: 1, rest: [0.1]}\n"
    "  - {type: joint_spring, body: base, damping: 0.3}\n"
    "inputs:\n"
    "  - {name: pan, type: joint, body: base}\n"
    "  - {name: lift, type: joint, body: upper, speed: 2}\n"
    "simulation:\n"
    "  t_end: 1\n"
    "  dt_out: 0.01\n";

void write(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary);
  out << text;
}

/// The columns `names` of a CSV (rows[0] is the header), in that order, as CSV text.
std::string cut(const std::vector<std::vector<std::string>>& rows,
                const std::vector<std::string>& names) {
  std::vector<size_t> at;
  for (const std::string& name : names) {
    size_t c = 0;
    while (c < rows[0].size() && rows[0][c] != name) ++c;
    EXPECT_LT(c, rows[0].size()) << name;
    at.push_back(c);
  }
  std::string text;
  for (const auto& row : rows) {
    for (size_t i = 0; i < at.size(); ++i) text += (i ? "," : "") + row[at[i]];
    text += '\n';
  }
  return text;
}

/// The header names of a CSV that end in one of the suffix families: ".j<digit>" (coordinates),
/// ".jd<digit>" (rates), or start with "input.".
std::vector<std::string> columns_of(const std::vector<std::string>& header, bool coordinates,
                                    bool rates, bool inputs) {
  std::vector<std::string> out{"t"};
  for (const std::string& h : header) {
    const size_t dot = h.rfind('.');
    if (dot == std::string::npos) continue;
    const std::string suffix = h.substr(dot + 1);
    const bool is_rate = suffix.size() > 2 && suffix.compare(0, 2, "jd") == 0;
    const bool is_coordinate = !is_rate && suffix.size() > 1 && suffix[0] == 'j' &&
                               std::isdigit(static_cast<unsigned char>(suffix[1]));
    if ((coordinates && is_coordinate) || (rates && is_rate) ||
        (inputs && h.compare(0, 6, "input.") == 0))
      out.push_back(h);
  }
  return out;
}

/// The generalized forces of an inverse run's output, rows x columns (without t).
std::vector<std::vector<double>> forces(const fs::path& p) {
  std::vector<std::vector<double>> out;
  const auto rows = read_csv(p);
  for (size_t r = 1; r < rows.size(); ++r) {
    out.emplace_back();
    for (size_t c = 1; c < rows[r].size(); ++c) out.back().push_back(parse(rows[r][c]));
  }
  return out;
}

double max_difference(const std::vector<std::vector<double>>& a,
                      const std::vector<std::vector<double>>& b) {
  EXPECT_EQ(a.size(), b.size());
  double worst = 0.0;
  for (size_t r = 0; r < std::min(a.size(), b.size()); ++r)
    for (size_t c = 0; c < a[r].size(); ++c) worst = std::max(worst, std::abs(a[r][c] - b[r][c]));
  return worst;
}

// With every rate given, the table is read into the same q, z and inputs as the full CSV (the
// writer's shortest round-trip decimals read back to the same doubles) and z dot comes from the
// same spline: the output is the full CSV's, byte for byte, whatever the order of the columns.
TEST(InverseTable, RatesGivenGiveTheFullCsvsForces) {
  const fs::path dir = temp_dir("inverse_table_rates");
  write(dir / "arm.yaml", kArmModel);
  ASSERT_EQ(run_in(dir, "simulate arm.yaml --t-end 0.3 --dt-out 0.01 -o run.csv").exit_code, 0);
  const auto rows = read_csv(dir / "run.csv");
  ASSERT_GT(rows.size(), 3u);
  std::vector<std::string> names = columns_of(rows[0], true, true, true);
  ASSERT_EQ(names.size(), 1u + 5u + 5u + 2u);  // t, five coordinates, five rates, two inputs
  write(dir / "table.csv", cut(rows, names));
  std::reverse(names.begin(), names.end());
  write(dir / "reversed.csv", cut(rows, names));
  ASSERT_EQ(run_in(dir, "inverse arm.yaml run.csv -o full.Q.csv").exit_code, 0);
  const auto table = run_in(dir, "inverse arm.yaml table.csv -o table.Q.csv");
  ASSERT_EQ(table.exit_code, 0) << table.err;
  EXPECT_NE(table.out.find("inverse dynamics of table.csv: 31 rows"), std::string::npos)
      << table.out;
  ASSERT_EQ(run_in(dir, "inverse arm.yaml reversed.csv -o reversed.Q.csv").exit_code, 0);
  EXPECT_EQ(slurp(dir / "table.Q.csv"), slurp(dir / "full.Q.csv"));
  EXPECT_EQ(slurp(dir / "reversed.Q.csv"), slurp(dir / "full.Q.csv"));
}

// From the coordinates alone, z is the spline's slope of q (O(h^3)) and z dot the slope of that
// (O(h^2): the first slope's error at the end rows, differentiated again). Against the full
// CSV's forces (whose own z dot is O(h^3)) the difference falls by 4 per halving of the rows'
// spacing for exact second order; more than 3 is asked (3.3, then 3.7 as h shrinks). At
// h = 2.5 ms it is below 1e-2 N m, under 1e-3 of the gravity torque on the upper arm when level
// (2 kg at 0.25 m, 1 kg at 0.7 m, 0.5 kg at 0.95 m beyond its joint: about 16 N m).
TEST(InverseTable, CoordinatesAloneAreSecondOrder) {
  const fs::path dir = temp_dir("inverse_table_order");
  write(dir / "arm.yaml", kArmModel);
  std::vector<double> error;
  for (const char* dt : {"0.01", "0.005", "0.0025"}) {
    const std::string d(dt);
    ASSERT_EQ(run_in(dir, "simulate arm.yaml --t-end 0.4 --dt-out " + d +
                              " --rtol 1e-12 --atol 1e-12 -o run" + d + ".csv")
                  .exit_code,
              0);
    const auto rows = read_csv(dir / ("run" + d + ".csv"));
    write(dir / ("q" + d + ".csv"), cut(rows, columns_of(rows[0], true, false, false)));
    ASSERT_EQ(run_in(dir, "inverse arm.yaml run" + d + ".csv -o full.Q.csv").exit_code, 0);
    const auto r = run_in(dir, "inverse arm.yaml q" + d + ".csv -o q.Q.csv");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    error.push_back(max_difference(forces(dir / "q.Q.csv"), forces(dir / "full.Q.csv")));
  }
  for (size_t i = 1; i < error.size(); ++i) {
    EXPECT_GT(error[i - 1] / error[i], 3.0) << error[i - 1] << " then " << error[i];
  }
  EXPECT_LT(error.back(), 1e-2);
  EXPECT_GT(error.back(), 0.0);
}

// A pendulum driven along q(t) = A sin(w t) needs tau = J q'' + m g l sin q (J = I_yy + m l^2,
// about the hinge), in closed form. With the rates given, z dot is the spline's slope of
// z = A w cos(w t): its error is at most about f'''' h^3 / 4 = A w^5 h^3 / 4 at the ends (the
// cubic through the end rows); with the coordinates alone the first slope's end error
// A w^4 h^3 / 4, differentiated by the end cubic's weights (their absolute sum is 20/3 / h),
// bounds z dot's by about 1.7 A w^4 h^2 (an upper bound: the first slope's end error decays
// away from the end, and the measured error is about a tenth of it). The tolerances are J
// times twice those bounds; on rows spaced unevenly (by up to 20 %) the largest errors fall as
// those orders say, and on an even grid the errors in the middle half of the rows, far from the
// ends, fall as h^4 (16 per halving; more than 12 is asked) either way.
TEST(InverseTable, DrivenPendulumMatchesTheClosedForm) {
  const fs::path dir = temp_dir("inverse_table_pendulum");
  const double m = 2.0, l = 0.5, Iyy = 0.1, g = 9.81, A = 0.8, w = 3.0;
  const double J = Iyy + m * l * l;
  write(dir / "pendulum.yaml",
        "format: kanedyn-model/1\n"
        "gravity: [0, 0, -9.81]\n"
        "bodies:\n"
        "  - name: link\n"
        "    parent: ground\n"
        "    mass: 2.0\n"
        "    inertia: [0.1, 0.1, 0.02]\n"
        "    com: [0, 0, -0.5]\n"
        "    joint: {type: revolute, axis: [0, 1, 0]}\n");
  // The largest error over all rows and over the middle half, of the table with rows h apart
  // (jittered by `jitter` h), with its rates or without.
  struct Errors {
    double all = 0.0, middle = 0.0;
  };
  const auto errors = [&](double h, double jitter, bool rates) {
    std::string text = rates ? "t,link.j1,link.jd1\n" : "t,link.j1\n";
    std::vector<double> tau;
    for (int i = 0; i * h <= 2.0 + 1e-12; ++i) {
      const double t = i * h + jitter * h * std::sin(37.0 * i * h);
      const double q = A * std::sin(w * t), qd = A * w * std::cos(w * t);
      tau.push_back(J * (-A * w * w * std::sin(w * t)) + m * g * l * std::sin(q));
      char line[128];
      if (rates)
        std::snprintf(line, sizeof line, "%.17g,%.17g,%.17g\n", t, q, qd);
      else
        std::snprintf(line, sizeof line, "%.17g,%.17g\n", t, q);
      text += line;
    }
    write(dir / "table.csv", text);
    Errors e;
    const auto r = run_in(dir, "inverse pendulum.yaml table.csv -o Q.csv");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const auto Q = forces(dir / "Q.csv");
    EXPECT_EQ(Q.size(), tau.size());
    if (Q.size() != tau.size()) return e;
    for (size_t i = 0; i < Q.size(); ++i) {
      const double d = std::abs(Q[i][0] - tau[i]);
      e.all = std::max(e.all, d);
      if (4 * i >= Q.size() && 4 * i < 3 * Q.size()) e.middle = std::max(e.middle, d);
    }
    return e;
  };
  std::vector<double> with_rates, alone;
  for (const double h : {0.02, 0.01, 0.005}) {
    with_rates.push_back(errors(h, 0.2, true).all);
    EXPECT_LE(with_rates.back(), J * 2.0 * A * std::pow(w, 5) * h * h * h / 4.0) << h;
    alone.push_back(errors(h, 0.2, false).all);
    EXPECT_LE(alone.back(), J * 2.0 * 1.7 * A * std::pow(w, 4) * h * h) << h;
  }
  for (size_t i = 1; i < alone.size(); ++i) {
    EXPECT_GT(with_rates[i - 1] / with_rates[i], 6.0) << "third order: 8 per halving";
    EXPECT_GT(alone[i - 1] / alone[i], 3.0) << "second order: 4 per halving";
  }
  for (const bool rates : {true, false}) {
    const double coarse = errors(0.02, 0.0, rates).middle, fine = errors(0.01, 0.0, rates).middle;
    EXPECT_GT(coarse / fine, 12.0)
        << (rates ? "rates given: " : "coordinates alone: ") << coarse << " then " << fine;
  }
}

// A spherical joint's rates are angular velocities (body-K components), not dq/dt: from its
// Euler parameters alone they come through the kinematic equation. A spherical pendulum with a
// revolute link below it, swinging in 3D: the table of its coordinates alone gives the full
// CSV's forces to second order, and with its rates, exactly.
TEST(InverseTable, SphericalJointFromItsEulerParameters) {
  const fs::path dir = temp_dir("inverse_table_spherical");
  write(dir / "ball.yaml",
        "format: kanedyn-model/1\n"
        "gravity: [0, 0, -9.81]\n"
        "bodies:\n"
        "  - name: ball\n"
        "    parent: ground\n"
        "    mass: 1.5\n"
        "    inertia: [0.05, 0.07, 0.03]\n"
        "    com: [0.1, 0, -0.4]\n"
        "    joint: {type: spherical}\n"
        "    initial:\n"
        "      joint: [0.2, 0.1, 0, 0.97467943448]\n"
        "      joint_rate: [1.0, -0.5, 2.0]\n"
        "  - name: link\n"
        "    parent: ball\n"
        "    mass: 1.0\n"
        "    inertia: [0.02, 0.02, 0.01]\n"
        "    com: [0, 0, -0.3]\n"
        "    joint: {at: [0, 0, -0.6], type: revolute, axis: [1, 0, 0]}\n"
        "    initial:\n"
        "      joint: [0.4]\n");
  std::vector<double> error;
  for (const char* dt : {"0.01", "0.005"}) {
    const std::string d(dt);
    ASSERT_EQ(run_in(dir, "simulate ball.yaml --t-end 0.5 --dt-out " + d +
                              " --rtol 1e-12 --atol 1e-12 -o run.csv")
                  .exit_code,
              0);
    const auto rows = read_csv(dir / "run.csv");
    write(dir / "q.csv", cut(rows, columns_of(rows[0], true, false, false)));
    write(dir / "qz.csv", cut(rows, columns_of(rows[0], true, true, false)));
    ASSERT_EQ(run_in(dir, "inverse ball.yaml run.csv -o full.Q.csv").exit_code, 0);
    const auto r = run_in(dir, "inverse ball.yaml q.csv -o q.Q.csv");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    ASSERT_EQ(run_in(dir, "inverse ball.yaml qz.csv -o qz.Q.csv").exit_code, 0);
    EXPECT_EQ(slurp(dir / "qz.Q.csv"), slurp(dir / "full.Q.csv"));
    error.push_back(max_difference(forces(dir / "q.Q.csv"), forces(dir / "full.Q.csv")));
  }
  // Second order (4 per halving), and small against the gravity torque on the ball (1.5 kg at
  // 0.4 m, 1 kg at 0.9 m: about 15 N m when level): below 1e-2 N m at h = 5 ms.
  EXPECT_GT(error[0] / error[1], 3.0) << error[0] << " then " << error[1];
  EXPECT_LT(error[1], 1e-2);
}

struct Refusal {
  std::string label, text, message;
};

// Every refusal names the file, the line (or the column) and the problem, exits with 1 and
// leaves no output behind, not even a part of it.
TEST(InverseTable, RefusalsNameTheFileThePlaceAndTheProblem) {
  const fs::path dir = temp_dir("inverse_table_refusals");
  write(dir / "pendulum.yaml",
        "format: kanedyn-model/1\n"
        "name: swing\n"
        "gravity: [0, 0, -9.81]\n"
        "bodies:\n"
        "  - name: link\n"
        "    parent: ground\n"
        "    mass: 1.0\n"
        "    inertia: [0.1, 0.1, 0.02]\n"
        "    com: [0, 0, -0.5]\n"
        "    joint: {type: revolute, axis: [0, 1, 0]}\n"
        "  - name: ball\n"
        "    parent: link\n"
        "    mass: 1.0\n"
        "    inertia: [0.1, 0.1, 0.02]\n"
        "    com: [0, 0, -0.5]\n"
        "    joint: {at: [0, 0, -1], type: spherical}\n");
  const std::string ok_rows = "0,0.1,0,0,0,1\n0.1,0.2,0,0,0,1\n0.2,0.3,0,0,0,1\n";
  const std::vector<Refusal> cases = {
      {"missing body column", "t,ball.j1,ball.j2,ball.j3,ball.j4\n0,0,0,0,1\n",
       "table.csv:1: the header has no column 'link.j1' (body 'link'"},
      {"unknown column", "t,lnk.j1,ball.j1,ball.j2,ball.j3,ball.j4\n" + ok_rows,
       "table.csv:1: column 2 'lnk.j1' is not a column of a table of 'swing' (did you mean "
       "'link.j1'?)"},
      {"a coordinate the joint does not have",
       "t,link.j1,link.j2,ball.j1,ball.j2,ball.j3,ball.j4\n",
       "table.csv:1: column 3 'link.j2' is not a column of a table of 'swing'"},
      {"repeated column", "t,link.j1,ball.j1,ball.j2,ball.j3,ball.j4,link.j1\n" + ok_rows,
       "table.csv:1: column 7 'link.j1' repeats column 2"},
      {"no t", "link.j1,ball.j1,ball.j2,ball.j3,ball.j4\n0,0,0,0,1\n",
       "table.csv:1: the header has no 't' column"},
      {"some rates", "t,link.j1,ball.j1,ball.j2,ball.j3,ball.j4,ball.jd1\n",
       "table.csv:1: the header has 'ball.jd1' but no column 'ball.jd2': give all of body "
       "'ball''s rates"},
      {"t repeats", "t,link.j1,ball.j1,ball.j2,ball.j3,ball.j4\n" + ok_rows + "0.2,0.4,0,0,0,1\n",
       "table.csv:5: t = 0.2 does not come after the previous row's t = 0.2 (line 4)"},
      {"t goes back", "t,link.j1,ball.j1,ball.j2,ball.j3,ball.j4\n" + ok_rows + "0.1,0.4,0,0,0,1\n",
       "table.csv:5: t = 0.1 does not come after the previous row's t = 0.2"},
      {"too few rows", "t,link.j1,ball.j1,ball.j2,ball.j3,ball.j4\n0,0,0,0,0,1\n\n0.1,0,0,0,0,1\n",
       "table.csv: the accelerations of coordinates without rates need at least 3 rows (the "
       "parabola through them); the table has 2"},
      {"no rows", "t,link.j1,ball.j1,ball.j2,ball.j3,ball.j4\n",
       "table.csv: the table has a header but no rows"},
      {"nan", "t,link.j1,ball.j1,ball.j2,ball.j3,ball.j4\n0,0,0,0,0,1\n0.1,nan,0,0,0,1\n",
       "table.csv:3: column 'link.j1': 'nan' is not a finite number"},
      {"overflow", "t,link.j1,ball.j1,ball.j2,ball.j3,ball.j4\n0,0,0,0,0,1\n0.1,1e999,0,0,0,1\n",
       "table.csv:3: column 'link.j1': '1e999' overflows a double"},
      {"short row", "t,link.j1,ball.j1,ball.j2,ball.j3,ball.j4\n0,0,0,0,0,1\n0.1,0,0,0,1\n",
       "table.csv:3: the row has 5 fields, the header 6"},
      {"not unit", "t,link.j1,ball.j1,ball.j2,ball.j3,ball.j4\n0,0,0,0,0,1\n0.1,0,0,0,0,1.1\n",
       "table.csv:3: columns 'ball.j1' to 'ball.j4' are not a spherical joint's Euler parameters: "
       "their norm is 1.1"},
      {"sign flip", "t,link.j1,ball.j1,ball.j2,ball.j3,ball.j4\n0,0,0,0,0,1\n0.1,0,0,0,0,-1\n",
       "table.csv:3: columns 'ball.j1' to 'ball.j4' change sign from the previous row's (line 2)"},
      {"empty", "", "table.csv: the trajectory is empty"},
  };
  for (const Refusal& c : cases) {
    SCOPED_TRACE(c.label);
    write(dir / "table.csv", c.text);
    const auto r = run_in(dir, "inverse pendulum.yaml table.csv -o Q.csv");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    for (const auto& entry : fs::directory_iterator(dir)) {
      const std::string name = entry.path().filename().string();
      EXPECT_EQ(name.find("Q.csv"), std::string::npos) << name << " left behind";
    }
  }
  // An output already there stays as it was.
  write(dir / "table.csv", cases[0].text);
  write(dir / "old.Q.csv", "t,link.Q1\n0,1\n");
  EXPECT_EQ(run_in(dir, "inverse pendulum.yaml table.csv -o old.Q.csv").exit_code, 1);
  EXPECT_EQ(slurp(dir / "old.Q.csv"), "t,link.Q1\n0,1\n");
  // A table of the coordinates cannot give a free body's motion.
  write(dir / "table.csv", "t\n0\n0.1\n0.2\n");
  const auto free = run_in(dir, "inverse '" + kExamples + "/eight_body.yaml' table.csv -o Q.csv");
  EXPECT_EQ(free.exit_code, 1);
  EXPECT_NE(free.err.find("table.csv: body '"), std::string::npos) << free.err;
  EXPECT_NE(free.err.find("' has a free joint: a table of joint coordinates does not give its "
                          "motion; give simulate's trajectory CSV"),
            std::string::npos)
      << free.err;
  EXPECT_FALSE(fs::exists(dir / "Q.csv"));
  // A header with simulate's columns is read as simulate's CSV, whose reader names the column.
  write(dir / "table.csv", "t,link.y\n0,0\n");
  const auto full = run_in(dir, "inverse pendulum.yaml table.csv -o Q.csv");
  EXPECT_EQ(full.exit_code, 1);
  EXPECT_NE(full.err.find("table.csv:1: column 2 is 'link.y' where this model's trajectory has "
                          "'link.x'"),
            std::string::npos)
      << full.err;
}

}  // namespace
}  // namespace kanedyn
