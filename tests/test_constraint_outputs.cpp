// The constraints' reactions in a run's outputs and the trajectory CSV: the columns, their
// values against Newton's second law for motions solved by hand, the lift of a rolling disc
// in the stats and as the tool's warning.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "constraint_models.hpp"
#include "file_support.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/study.hpp"
#include "kanedyn/io/trajectory.hpp"
#include "kanedyn/simulate.hpp"

namespace fs = std::filesystem;

namespace kanedyn {
namespace {

using test::parse;
using test::read_csv;
using test::temp_dir;

constexpr double kG = 9.81;
const Vector3 kGravity(0, 0, -kG);

using test::hinged_rod;
using test::kRodLength;
using test::kRodMass;
constexpr auto rod_state = test::hinged_rod_state;

// A thin disc of radius r and mass m rolling upright on z = 0 along x at `speed`, its axle body
// y. `input`: with an input of type force along body z at the centre, named lift (inertial z
// while the disc stands upright and still).
constexpr double kDiscMass = 2.0, kDiscRadius = 0.3;

Model disc_model(const Vector3& gravity, bool input) {
  BodySpec b;
  b.name = "disc";
  b.mass = kDiscMass;
  const double r2 = kDiscRadius * kDiscRadius;
  b.inertia = Vector3(kDiscMass * r2 / 4, kDiscMass * r2 / 2, kDiscMass * r2 / 4).asDiagonal();
  Constraint c;
  c.name = "contact";
  c.type = ConstraintType::rolling_disc;
  c.axis = Vector3::UnitY();
  c.radius = kDiscRadius;
  std::vector<Input> inputs;
  if (input) {
    Input in;
    in.name = "lift";
    in.type = InputType::force;
    in.direction = Vector3::UnitZ();
    inputs.push_back(in);
  }
  return Model({b}, gravity, {}, "disc", {}, {}, inputs, {c});
}

void disc_state(double speed, VectorX& q, VectorX& z) {
  q = VectorX::Zero(7);
  z = VectorX::Zero(6);
  q << 0, 0, 0, 1, 0, 0, kDiscRadius;
  z << 0, speed / kDiscRadius, 0, speed, 0, 0;
}

TEST(ConstraintColumns, FollowTheInputsConstraintByConstraint) {
  const auto hinge = io::trajectory_columns(hinged_rod());
  ASSERT_GE(hinge.size(), 8u);
  const std::vector<std::string> hinge_tail(hinge.end() - 7, hinge.end());
  EXPECT_EQ(hinge_tail, (std::vector<std::string>{"energy", "pin.f1", "pin.f2", "pin.f3", "pin.m1",
                                                  "pin.m2", "pin.m3"}));
  const auto disc = io::trajectory_columns(disc_model(kGravity, true));
  const std::vector<std::string> disc_tail(disc.end() - 5, disc.end());
  EXPECT_EQ(disc_tail, (std::vector<std::string>{"energy", "input.lift", "contact.f1", "contact.f2",
                                                 "contact.f3"}));
  EXPECT_EQ(reaction_count(hinged_rod()), 6);
  EXPECT_EQ(reaction_count(disc_model(kGravity, false)), 3);
}

// Hanging at rest the hinge carries the weight: f = m g up, no moment.
TEST(ConstraintReactions, AHingedRodAtRestHangsOnItsWeight) {
  const Model m = hinged_rod();
  VectorX q, z;
  rod_state(0.0, 0.0, q, z);
  SimulationSettings s;
  s.t_end = 1.0;
  s.dt_out = 0.25;
  int rows = 0;
  const SimulationStats stats =
      simulate(m, q, z, s, [&](double, const State&, const VectorX&, const VectorX&, Data& data) {
        ASSERT_EQ(data.reactions.size(), 6);
        EXPECT_NEAR(data.reactions[0], 0.0, 1e-10);
        EXPECT_NEAR(data.reactions[1], 0.0, 1e-10);
        EXPECT_NEAR(data.reactions[2], kRodMass * kG, 1e-10);
        EXPECT_LE(data.reactions.tail<3>().cwiseAbs().maxCoeff(), 1e-10);
        ++rows;
      });
  EXPECT_EQ(rows, 5);
  ASSERT_TRUE(stats.ok());
  ASSERT_EQ(stats.normal_force_negative_at.size(), 1u);
  EXPECT_TRUE(std::isnan(stats.normal_force_negative_at[0]));  // not a disc
}

// The swinging rod, by hand: a pendulum about a fixed axis, I_p = m L^2 / 3 about the pin,
// d = L / 2 to G. With theta the angle from the bottom, theta'' = -m g d sin(theta) / I_p, and
// G accelerates by d theta'' along the tangent and d omega^2 towards the pin; the hinge's force
// is f = m (a_G - g). At the bottom of the swing that is m g + m d omega^2 up. A hinge about
// the rod's principal axis x carries no moment.
TEST(ConstraintReactions, ASwingingRodsHingeForceIsNewtonsSecondLaw) {
  const Model m = hinged_rod();
  const double d = kRodLength / 2, Ip = kRodMass * kRodLength * kRodLength / 3;
  VectorX q, z;
  const double omega0 = 2.5;
  rod_state(0.0, omega0, q, z);
  SimulationSettings s;
  s.t_end = 3.0;
  s.dt_out = 0.05;
  s.rtol = 1e-10;
  s.atol = 1e-12;
  int rows = 0;
  simulate(m, q, z, s, [&](double t, const State&, const VectorX&, const VectorX& zz, Data& data) {
    const Vector3 G = data.kinematics.p_G[0];
    ASSERT_NEAR(G.x(), 0.0, 1e-10);
    const double theta = std::atan2(G.y(), -G.z()), omega = zz[0];
    const double alpha = -kRodMass * kG * d * std::sin(theta) / Ip;
    const Vector3 tangent(0, std::cos(theta), std::sin(theta));
    const Vector3 inward(0, -std::sin(theta), std::cos(theta));
    const Vector3 a_G = d * alpha * tangent + d * omega * omega * inward;
    const Vector3 expected = kRodMass * (a_G - kGravity);
    const Vector3 f = data.reactions.head<3>();
    EXPECT_LE((f - expected).norm(), 1e-8 * kRodMass * kG) << "t = " << t;
    EXPECT_LE(data.reactions.tail<3>().norm(), 1e-8 * kRodMass * kG * d) << "t = " << t;
    if (t == 0.0) {
      EXPECT_NEAR(f.z(), kRodMass * kG + kRodMass * d * omega0 * omega0, 1e-10);
      EXPECT_NEAR(f.y(), 0.0, 1e-10);
    }
    ++rows;
  });
  EXPECT_EQ(rows, 61);
}

// Rolling upright in a straight line at constant speed, nothing but gravity acts: the plane
// pushes up with m g and there is no friction along it.
TEST(ConstraintReactions, AnUprightDiscRollingStraightIsPushedUpByItsWeight) {
  const Model m = disc_model(kGravity, false);
  VectorX q, z;
  disc_state(2.0, q, z);
  SimulationSettings s;
  s.t_end = 2.0;
  s.dt_out = 0.1;
  int rows = 0;
  const SimulationStats stats =
      simulate(m, q, z, s, [&](double, const State&, const VectorX&, const VectorX&, Data& data) {
        ASSERT_EQ(data.reactions.size(), 3);
        EXPECT_NEAR(data.reactions[2], kDiscMass * kG, 1e-9);
        EXPECT_NEAR(data.reactions[0], 0.0, 1e-9);
        EXPECT_NEAR(data.reactions[1], 0.0, 1e-9);
        ++rows;
      });
  EXPECT_EQ(rows, 21);
  ASSERT_TRUE(stats.ok());
  ASSERT_EQ(stats.normal_force_negative_at.size(), 1u);
  EXPECT_TRUE(std::isnan(stats.normal_force_negative_at[0]));
}

// A disc standing still, pulled up by a force of 3 m g from t = 0.5 on: the plane would have
// to hold it down with 2 m g. The stats hold the first output time with a negative normal
// force, and the run goes on with the disc held on the plane.
TEST(ConstraintReactions, ADiscPulledOffItsPlaneIsReportedOnceAndTheRunGoesOn) {
  const Model m = disc_model(kGravity, true);
  VectorX q, z;
  disc_state(0.0, q, z);
  SimulationSettings s;
  s.t_end = 1.0;
  s.dt_out = 0.1;
  MatrixX u(2, 1);
  u << 0.0, 3.0 * kDiscMass * kG;
  s.inputs = std::make_shared<const InputTable>(std::vector<double>{0.0, 0.5}, u);
  std::vector<double> normal;
  const SimulationStats stats =
      simulate(m, q, z, s, [&](double, const State&, const VectorX&, const VectorX&, Data& data) {
        normal.push_back(data.reactions[2]);
      });
  ASSERT_TRUE(stats.ok()) << stats.message;
  ASSERT_EQ(normal.size(), 11u);
  for (size_t i = 0; i < 5; ++i) EXPECT_NEAR(normal[i], kDiscMass * kG, 1e-9) << i;
  for (size_t i = 5; i < 11; ++i) EXPECT_NEAR(normal[i], -2.0 * kDiscMass * kG, 1e-9) << i;
  ASSERT_EQ(stats.normal_force_negative_at.size(), 1u);
  EXPECT_DOUBLE_EQ(stats.normal_force_negative_at[0], 0.5);
}

// The CSV of the library's writer: the reaction columns hold data.reactions, and the reader of
// `inverse` and `linearize --trajectory` reads such a file back.
TEST(ConstraintColumns, TheWriterWritesThemAndTheReaderReadsThem) {
  const fs::path dir = temp_dir("constraint_columns");
  const Model m = hinged_rod();
  VectorX q, z;
  rod_state(0.3, 0.0, q, z);
  SimulationSettings s;
  s.t_end = 0.5;
  s.dt_out = 0.1;
  const std::string path = (dir / "rod.csv").string();
  std::vector<VectorX> reactions;
  {
    io::BackgroundTrajectoryWriter writer(m, path);
    simulate(m, q, z, s,
             [&](double t, const State& state, const VectorX& jq, const VectorX& jz, Data& data) {
               writer.write_row(t, state, jq, jz, nullptr, &data.reactions);
               reactions.push_back(data.reactions);
             });
    writer.finish();
  }
  const auto rows = read_csv(path);
  ASSERT_EQ(rows.size(), 7u);
  EXPECT_EQ(rows[0], io::trajectory_columns(m));
  for (size_t r = 1; r < rows.size(); ++r)
    for (int i = 0; i < 6; ++i)
      EXPECT_EQ(parse(rows[r][rows[r].size() - 6 + static_cast<size_t>(i)]), reactions[r - 1][i]);
  const io::Trajectory traj = io::read_trajectory(m, path);
  EXPECT_EQ(traj.rows(), 6u);
  const io::TrajectoryRow row = io::read_trajectory_row(m, path, 0.2);
  EXPECT_EQ(row.t, 0.2);
  EXPECT_EQ(io::trajectory_motion(m, traj, path).z.cols(), 6);
  // A model with constraints has no default for its reactions.
  io::BackgroundTrajectoryWriter other(m, (dir / "other.csv").string());
  EXPECT_THROW(other.write_row(0.0, State(m), q, z), std::invalid_argument);
}

// ---- The tool --------------------------------------------------------------------------------

// The disc of disc_model, standing upright and still on z = 0, with its input `lift`.
const char* const kDiscFile = R"(format: kanedyn-model/1
name: disc
gravity: [0, 0, -9.81]
bodies:
  - name: disc
    parent: ground
    mass: 2.0
    inertia: [0.045, 0.09, 0.045]
    initial:
      translation: [0, 0, 0.3]
inputs:
  - {name: lift, type: force, body: disc, direction: [0, 0, 1]}
constraints:
  - name: contact
    type: rolling_disc
    body: disc
    axis: [0, 1, 0]
    radius: 0.3
)";

TEST(ConstraintColumns, SimulateWritesTheFourBarsHingeReactions) {
  const fs::path dir = temp_dir("constraint_cli_four_bar");
  const std::string model_path = test::kExamples + "/four_bar.yaml";
  const test::ToolRun r =
      test::run_in(dir, "simulate '" + model_path + "' --t-end 1 --dt-out 0.1 -o fb.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const auto file = io::load_model_file(model_path);
  const auto rows = read_csv(dir / "fb.csv");
  ASSERT_EQ(rows.size(), 12u);
  EXPECT_EQ(rows[0], io::trajectory_columns(file.model));
  const std::vector<std::string> tail(rows[0].end() - 6, rows[0].end());
  EXPECT_EQ(tail, (std::vector<std::string>{"closure.f1", "closure.f2", "closure.f3", "closure.m1",
                                            "closure.m2", "closure.m3"}));
  // The same run through the library gives the same reactions, bit for bit.
  SimulationSettings s;
  s.t_end = 1.0;
  s.dt_out = 0.1;
  size_t row = 1;
  simulate(file.model, file.q, file.z, s,
           [&](double, const State&, const VectorX&, const VectorX&, Data& data) {
             ASSERT_LT(row, rows.size());
             for (int i = 0; i < 6; ++i)
               EXPECT_EQ(parse(rows[row][rows[row].size() - 6 + static_cast<size_t>(i)]),
                         data.reactions[i]);
             // A planar linkage in the x-y plane: the minimum-norm reactions have no force out
             // of the plane and no moment about an axis in it, nor about z (a hinge about z).
             EXPECT_LE(std::abs(data.reactions[2]), 1e-9);
             EXPECT_LE(data.reactions.tail<3>().cwiseAbs().maxCoeff(), 1e-9);
             ++row;
           });
  EXPECT_EQ(row, rows.size());
}

TEST(ConstraintColumns, SimulateWarnsOnceWhenTheWheelWouldLift) {
  const fs::path dir = temp_dir("constraint_cli_lift");
  {
    std::ofstream(dir / "disc.yaml") << kDiscFile;
    std::ofstream(dir / "lift.csv") << "t,lift\n0,0\n0.5,60\n";
  }
  const test::ToolRun quiet = test::run_in(dir, "simulate disc.yaml --t-end 1 --dt-out 0.1");
  ASSERT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_EQ(quiet.err, "");
  const auto rows = read_csv(dir / "disc.csv");
  ASSERT_EQ(rows.size(), 12u);
  EXPECT_EQ(rows[0].back(), "contact.f3");
  EXPECT_NEAR(parse(rows[1].back()), 2.0 * kG, 1e-9);

  const test::ToolRun lifted =
      test::run_in(dir, "simulate disc.yaml --t-end 1 --dt-out 0.1 --inputs lift.csv");
  ASSERT_EQ(lifted.exit_code, 0) << lifted.err;
  EXPECT_EQ(lifted.err,
            "kanedyn: warning: constraint 'contact': the normal force becomes negative at t = 0.5 "
            "(the wheel would lift); the run goes on as if it held\n");
  const auto lifted_rows = read_csv(dir / "disc.csv");
  ASSERT_EQ(lifted_rows.size(), 12u);
  EXPECT_NEAR(parse(lifted_rows.back().back()), 2.0 * kG - 60.0, 1e-9);
}

// A sweep's run of the four-bar with the crank's mass at the file's own value: its kept
// trajectory is the tool's file byte for byte, reaction columns included, and an output reads
// a reaction column.
TEST(ConstraintColumns, ASweepKeepsAndReadsThem) {
  const fs::path dir = temp_dir("constraint_sweep");
  const test::ToolRun r = test::run_in(
      dir, "simulate '" + test::kExamples + "/four_bar.yaml' --t-end 0.3 --dt-out 0.1 -o fb.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::Study study = io::parse_study(R"(format: kanedyn-study/1
model: four_bar.yaml
vary:
  - key: bodies[crank].mass
    grid: [1.0]
simulate: {t_end: 0.3, dt_out: 0.1}
outputs:
  - max: closure.f2
trajectories: all
)",
                                          "s.yaml", test::kExamples);
  const io::StudyRun run = io::run_study_run(study, 0);
  ASSERT_EQ(run.status, "ok");
  EXPECT_EQ(run.trajectory, test::slurp(dir / "fb.csv"));
  const auto rows = read_csv(dir / "fb.csv");
  const size_t f2 = rows[0].size() - 5;
  ASSERT_EQ(rows[0][f2], "closure.f2");
  double max = -1e300;
  for (size_t i = 1; i < rows.size(); ++i) max = std::max(max, parse(rows[i][f2]));
  const auto fields = test::split(run.row, ',');
  ASSERT_EQ(fields.size(), 5u);  // run, the mass, the output, status, wall_s
  EXPECT_EQ(parse(fields[2]), max);
}

}  // namespace
}  // namespace kanedyn
