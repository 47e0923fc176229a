// Inverse dynamics of a trajectory (`kanedyn inverse`): the spline's accelerations and the
// generalized forces of a model's own motion.
#include <gtest/gtest.h>

#include <cmath>

#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/trajectory.hpp"
#include "kanedyn/simulate.hpp"
#include "kanedyn/terms.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

// The spline's slopes of sin(3t) on uneven knots: third order in the spacing. The bound 60 h^3
// (the third derivative is 27; the end cubics' error constant is about twice that) holds at
// every h, and the error falls by more than 6 when h halves (8 for exact third order).
TEST(InverseTrajectory, SplineSlopesAreThirdOrder) {
  double previous = 0.0;
  for (const double h : {0.02, 0.01, 0.005}) {
    std::vector<double> t;
    for (double s = 0.0; s <= 2.0; s += h) t.push_back(s + 0.2 * h * std::sin(37.0 * s));
    VectorX y(static_cast<Eigen::Index>(t.size()));
    for (size_t i = 0; i < t.size(); ++i) y[static_cast<Eigen::Index>(i)] = std::sin(3.0 * t[i]);
    const VectorX m = io::spline_slopes(t, y);
    double error = 0.0;
    for (size_t i = 0; i < t.size(); ++i)
      error =
          std::max(error, std::abs(m[static_cast<Eigen::Index>(i)] - 3.0 * std::cos(3.0 * t[i])));
    EXPECT_LE(error, 60.0 * h * h * h) << h;
    if (previous > 0.0) {
      EXPECT_GT(previous / error, 6.0) << h;
    }
    previous = error;
  }
  // Two and three knots: the line and the parabola, exact for them.
  const VectorX line = io::spline_slopes({0.0, 2.0}, (VectorX(2) << 1.0, 5.0).finished());
  EXPECT_DOUBLE_EQ(line[0], 2.0);
  const VectorX parabola =
      io::spline_slopes({0.0, 1.0, 3.0}, (VectorX(3) << 0.0, 1.0, 9.0).finished());
  EXPECT_NEAR(parabola[2], 6.0, 1e-14);
}

// The motion of the arm left to itself needs no force beyond its own: the generalized forces of
// its trajectory (dopri5 at 1e-12, rows 2.5 ms apart) are the spline's error times the mass
// matrix, below 1e-2 of the largest gravity torque (the error falls as h^3: 8 times per halving).
TEST(InverseTrajectory, OwnMotionNeedsNoForce) {
  const io::ModelFile file =
      io::load_model_file(std::string(KANEDYN_SOURCE_DIR) + "/examples/urdf/arm.urdf");
  const Model& m = file.model;
  SimulationSettings s;
  s.t_end = 1.0;
  s.dt_out = 0.0025;
  s.rtol = s.atol = 1e-12;
  io::Trajectory traj{io::trajectory_columns(m), {}};
  const SimulationStats st =
      simulate(m, file.q, file.z, s,
               [&](double t, const State& state, const VectorX& q, const VectorX& z, Data&) {
                 traj.values.push_back(t);
                 (void)state;
                 // The columns the reader uses: the free bodies' notes' columns and the joint
                 // columns.
                 size_t b = 0;
                 std::vector<double> row(traj.columns.size() - 1, 0.0);
                 for (int k = 0; k < m.num_bodies(); ++k) {
                   const JointType type = m.joint(k).type;
                   if (type == JointType::free) {
                     for (int i = 0; i < 7; ++i)
                       row[b + 3 + static_cast<size_t>(i)] = q[m.coordinate_offset(k) + i];
                     for (int i = 0; i < 6; ++i)
                       row[b + 10 + static_cast<size_t>(i)] = z[m.speed_offset(k) + i];
                   } else if (type != JointType::weld) {
                     const int jq = coordinate_count(type), jz = speed_count(type);
                     for (int i = 0; i < jq; ++i)
                       row[b + 16 + static_cast<size_t>(i)] = q[m.coordinate_offset(k) + i];
                     for (int i = 0; i < jz; ++i)
                       row[b + 16 + static_cast<size_t>(jq + i)] = z[m.speed_offset(k) + i];
                     b += static_cast<size_t>(jq + jz);
                   }
                   b += 16;
                 }
                 traj.values.insert(traj.values.end(), row.begin(), row.end());
               });
  ASSERT_TRUE(st.ok());
  const io::TrajectoryMotion motion = io::trajectory_motion(m, traj, "arm.csv");
  Terms terms(m);
  VectorX g(m.num_speeds()), Q(m.num_speeds());
  terms.gravity_forces(file.q, g);
  const double scale = g.cwiseAbs().maxCoeff();
  ASSERT_GT(scale, 1.0);
  double worst = 0.0;
  for (size_t r = 0; r < motion.t.size(); ++r) {
    const auto c = static_cast<Eigen::Index>(r);
    terms.inverse_dynamics(motion.q.col(c), motion.z.col(c), motion.zdot.col(c), Q);
    worst = std::max(worst, Q.cwiseAbs().maxCoeff());
  }
  EXPECT_LE(worst, 1e-2 * scale);
  EXPECT_GT(worst, 0.0);
}

}  // namespace
}  // namespace kanedyn
