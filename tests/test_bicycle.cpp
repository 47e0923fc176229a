// The Whipple bicycle of examples/bicycle.yaml (Meijaard et al. 2007; docs/bicycle.md): its
// statics, and its nonlinear motion below and inside the self-stable speed range.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "kanedyn/analysis.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/simulate.hpp"

namespace kanedyn {
namespace {

size_t at(Eigen::Index i) { return static_cast<size_t>(i); }

const char* const kBicycle = KANEDYN_SOURCE_DIR "/examples/bicycle.yaml";

// The rear frame's roll: the tilt of its lateral (y) axis out of the ground plane.
double roll(const VectorX& q) {
  const Matrix3 R = rotation_matrix(q.head<4>());  // inertial -> rear frame
  const Vector3 lateral = R.transpose() * Vector3::UnitY();
  return std::asin(std::clamp(lateral.z(), -1.0, 1.0));
}

// Upright, rolling forward at v (the rear frame's translation rate, each wheel's spin v / r),
// with a roll rate of 0.05 rad/s, projected onto the constraints.
void at_speed(const io::ModelFile& f, double v, VectorX& q, VectorX& z) {
  q = f.q;
  z = VectorX::Zero(f.model.num_speeds());
  z[0] = 0.05;  // roll rate
  z[3] = v;
  z[f.model.speed_offset(1)] = v / 0.3;
  z[f.model.speed_offset(3)] = v / 0.35;
  project_onto_constraints(f.model, q, z);
}

// At rest, upright, the bicycle is in (unstable) equilibrium: no acceleration, and the contact
// forces are the statics of a beam on two supports: normal forces summing to the weight,
// split by the mass centre's position along the wheelbase, no tangential force. Round-off:
// 1e-12 of the weight.
TEST(Bicycle, AtRestTheNormalForcesCarryTheWeight) {
  const io::ModelFile f = io::load_model_file(kBicycle);
  const Model& m = f.model;
  const VectorX z = VectorX::Zero(m.num_speeds());
  ConstrainedDynamics d(m);
  VectorX zdot(m.num_speeds());
  d.evaluate(f.q, z, VectorX(), zdot);
  EXPECT_LE(zdot.cwiseAbs().maxCoeff(), 1e-12);
  const double weight = m.total_mass() * 9.81;
  // The mass centre's x: rear frame 85 kg at 0.3, rear wheel at 0, front frame 4 kg at 0.9,
  // front wheel 3 kg at the wheelbase 1.02 (Table 1).
  const double w = 1.02, x = (85 * 0.3 + 4 * 0.9 + 3 * 1.02) / m.total_mass();
  const Vector3 rear = d.equations().force(0, d.lambda());
  const Vector3 front = d.equations().force(1, d.lambda());
  EXPECT_NEAR(rear.z() + front.z(), weight, 1e-12 * weight);
  EXPECT_NEAR(rear.z(), weight * (w - x) / w, 1e-12 * weight);
  EXPECT_NEAR(front.z(), weight * x / w, 1e-12 * weight);
  EXPECT_NEAR(rear.head<2>().norm() + front.head<2>().norm(), 0.0, 1e-12 * weight);
}

// Between the weave speed (4.29 m/s) and the capsize speed (6.02 m/s) the bicycle rights itself:
// at 5 m/s a roll rate of 0.05 rad/s leans it by less than 0.01 rad, and 10 s later it leans by
// less than 0.0005 rad (the slowest mode, capsize, decays at 0.32/s: e^-3.2 of the first lean).
// Rolling does no work: the energy is conserved to the integrator's tolerance.
TEST(Bicycle, SelfStableAtFiveMetresPerSecond) {
  const io::ModelFile f = io::load_model_file(kBicycle);
  VectorX q, z;
  at_speed(f, 5.0, q, z);
  SimulationSettings s;
  s.t_end = 10.0;
  s.dt_out = 0.1;
  s.rtol = 1e-10;
  s.atol = 1e-12;
  double largest = 0.0, last = 0.0;
  const SimulationStats st = simulate(
      f.model, q, z, s, [&](double, const State&, const VectorX& qq, const VectorX&, Data&) {
        last = roll(qq);
        largest = std::max(largest, std::abs(last));
      });
  ASSERT_TRUE(st.ok()) << st.message;
  EXPECT_LT(largest, 0.01);
  EXPECT_GT(largest, 0.002);  // it did lean
  EXPECT_LT(std::abs(last), 0.0005);
  EXPECT_LT(std::abs(st.relative_energy_change()), 1e-8);
  EXPECT_LT(st.max_constraint_error, 1e-9);
}

// At 2 m/s the weave mode grows at 2.7/s (Table 2): the same push makes it fall, past 0.3 rad of
// roll within 3 s (thirty times the largest lean at 5 m/s). What follows is no longer small:
// the bicycle either falls flat or, steered hard into the fall, runs a tight leaning turn.
TEST(Bicycle, FallsOverAtTwoMetresPerSecond) {
  const io::ModelFile f = io::load_model_file(kBicycle);
  VectorX q, z;
  at_speed(f, 2.0, q, z);
  SimulationSettings s;
  s.t_end = 3.0;
  s.dt_out = 0.05;
  double largest = 0.0;
  simulate(f.model, q, z, s, [&](double, const State&, const VectorX& qq, const VectorX&, Data&) {
    largest = std::max(largest, std::abs(roll(qq)));
  });
  EXPECT_GT(largest, 0.3);
}

// Upright straight running at v: the file's configuration, no roll rate, each wheel spinning
// at v / r.
void straight_running(const io::ModelFile& f, double v, VectorX& q, VectorX& z) {
  q = f.q;
  z = VectorX::Zero(f.model.num_speeds());
  z[3] = v;
  z[f.model.speed_offset(1)] = v / 0.3;
  z[f.model.speed_offset(3)] = v / 0.35;
}

nlohmann::json published() {
  std::ifstream in(KANEDYN_SOURCE_DIR "/tests/data/meijaard2007.json");
  return nlohmann::json::parse(in);
}

// The linearization about straight running in the independent coordinates and speeds: 7
// coordinates (roll, yaw, the rear frame's x and y, the three joint angles: the rear frame's
// height and pitch are fixed by the contacts) and 3 speeds (roll rate, the rear wheel's spin,
// the steer rate). Its 10 eigenvalues are the paper's 4 of roll and steer (Table 2, at 1e-12 of
// their size, and of 1/s for the small ones: double-precision results, as the paper's are; the
// capsize root near its crossing, -0.004/s at 6 m/s, carries the round-off of the whole matrix,
// 4e-13/s) and 6 zeros for the ignorable coordinates and the forward speed (isolated by
// sorted_eigenvalues before its QR iteration: exact, or the round-off of A's entries, 1e-16).
TEST(Bicycle, LinearizationGivesThePublishedEigenvalues) {
  const io::ModelFile f = io::load_model_file(kBicycle);
  const nlohmann::json paper = published();
  int speeds = 0;
  for (const auto& entry : paper["eigenvalues_published"]) {
    const double v = entry["v"].get<double>();
    VectorX q, z;
    straight_running(f, v, q, z);
    const Linearization lin = linearize(f.model, q, z, VectorX());
    ASSERT_EQ(lin.state.size(), 10u);
    EXPECT_EQ(lin.n, 3);
    std::vector<std::complex<double>> ours(lin.eigenvalues.data(),
                                           lin.eigenvalues.data() + lin.eigenvalues.size());
    for (const auto& pair : entry["eigenvalues"]) {
      const std::complex<double> expected(pair[0].get<double>(), pair[1].get<double>());
      auto nearest = std::min_element(ours.begin(), ours.end(), [&](auto a, auto b) {
        return std::abs(a - expected) < std::abs(b - expected);
      });
      EXPECT_LE(std::abs(*nearest - expected), 1e-12 * std::max(1.0, std::abs(expected)))
          << "v = " << v << ": " << expected << " against " << *nearest;
      ours.erase(nearest);
    }
    ASSERT_EQ(ours.size(), 6u);
    for (const auto& zero : ours) EXPECT_LE(std::abs(zero), 1e-12) << "v = " << v;
    ++speeds;
  }
  EXPECT_EQ(speeds, 11);
}

// The largest real part among the eigenvalues of the roll and steer block of A (roll, steer and
// their rates: the other states do not act on them), oscillating ones (weave) or real ones
// (capsize), at v.
double growth(const io::ModelFile& f, double v, bool weave) {
  VectorX q, z;
  straight_running(f, v, q, z);
  const Linearization lin = linearize(f.model, q, z, VectorX());
  std::vector<Eigen::Index> block;
  for (const char* name : {"rear_frame.r1", "front_frame.j1", "rear_frame.w1", "front_frame.jd1"})
    block.push_back(std::find(lin.state.begin(), lin.state.end(), name) - lin.state.begin());
  MatrixX a(4, 4);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) a(i, j) = lin.A(block[at(i)], block[at(j)]);
  const Eigen::VectorXcd values = sorted_eigenvalues(a);
  double largest = -1e300;
  for (Eigen::Index i = 0; i < values.size(); ++i)
    if ((std::abs(values[i].imag()) > 0.0) == weave) largest = std::max(largest, values[i].real());
  return largest;
}

// The weave speed (the oscillating pair crosses the imaginary axis) and the capsize speed (a
// real root crosses zero), by bisection on v to 1e-12 m/s, against the paper's 4.29238253634111
// and 6.02426201538837 (its characteristic speeds, given to 15 digits): within 1e-10.
TEST(Bicycle, WeaveAndCapsizeSpeedsFollow) {
  const io::ModelFile f = io::load_model_file(kBicycle);
  const nlohmann::json paper = published()["characteristic_speeds_published"];
  const auto bisect = [&](double lo, double hi, bool weave) {
    // Growing at lo, decaying at hi (weave); decaying at lo, growing at hi (capsize).
    const double sign_lo = growth(f, lo, weave);
    while (hi - lo > 1e-12) {
      const double mid = 0.5 * (lo + hi);
      ((growth(f, mid, weave) > 0) == (sign_lo > 0) ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  };
  const double v_w = bisect(4.0, 5.0, true), v_c = bisect(6.0, 6.5, false);
  EXPECT_NEAR(v_w, std::stod(paper["v_w"].get<std::string>()), 1e-10);
  EXPECT_NEAR(v_c, std::stod(paper["v_c"].get<std::string>()), 1e-10);
}

}  // namespace
}  // namespace kanedyn
