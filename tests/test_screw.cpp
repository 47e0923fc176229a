// The screw joint (docs/model-format.md, "Joints"): one coordinate, the turn about the axis and
// pitch times it along the axis. Its row of the joint table is all the library knows of it;
// these tests check the row against closed forms (a nut under gravity, a nut on a spring),
// against the revolute row (pitch 0) and a hand-coupled cylindrical joint, against physics
// (energy over a tumbling chain), the derivatives against central differences, and the model
// file's keys, refusals and writer.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "file_support.hpp"
#include "kanedyn/analysis.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/model_writer.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/terms.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

using test::BadCase;
using test::edit;

constexpr double kG = 9.81;

// A nut of mass m on a vertical screw (axis J's z, pitch p), its mass centre on the axis.
const std::string kNut = R"(format: kanedyn-model/1
name: nut
gravity: [0, 0, -9.81]
bodies:
  - name: nut
    parent: ground
    mass: 2.0
    inertia: [0.3, 0.4, 0.15]
    com: [0, 0, 0.1]
    joint:
      at: [0, 0, 1]
      type: screw
      axis: [0, 0, 2]
      pitch: 0.02
    initial:
      joint: [0.4]
      joint_rate: [3.0]
)";

// T = 1/2 (Izz + m p^2) qdot^2 and V = m g p q: (Izz + m p^2) qddot = -m g p, whatever q and
// qdot (the mass centre on the axis has no centripetal term along it).
TEST(Screw, ANutFallsWithTheClosedFormAcceleration) {
  const io::ModelFile f = io::parse_model_file(kNut, "nut.yaml");
  const Model& m = f.model;
  ASSERT_EQ(m.joint(0).type, JointType::screw);
  ASSERT_EQ(m.num_coordinates(), 1);
  ASSERT_EQ(m.num_speeds(), 1);
  const double mass = 2.0, izz = 0.15, p = 0.02;
  const double expected = -mass * kG * p / (izz + mass * p * p);
  for (const Route route : {Route::recursive, Route::assembled}) {
    Dynamics dyn(m, route);
    VectorX zdot(1), qdot(1);
    dyn.evaluate(f.q, f.z, zdot, qdot);
    // Round-off of a few operations on numbers of order 1.
    EXPECT_NEAR(zdot[0], expected, 1e-14)
        << (route == Route::recursive ? "recursive" : "assembled");
    EXPECT_EQ(qdot[0], 3.0);
  }
  // The nut's O_K is at J's z = 1 + p q: s'_K = p q along the axis.
  EXPECT_NEAR(f.initial.translation(0).z(), p * 0.4, 1e-16);
  EXPECT_LT(f.initial.translation(0).head<2>().norm(), 1e-16);
  // The torque that holds it: the inverse dynamics at zdot = 0, q dot = 0 is m g p.
  Terms terms(m);
  VectorX Q(1);
  terms.inverse_dynamics(f.q, VectorX::Zero(1), VectorX::Zero(1), Q);
  EXPECT_NEAR(Q[0], mass * kG * p, 1e-14);
}

// On a joint spring of stiffness k the nut oscillates at w^2 = k / (Izz + m p^2) about the
// rest q* = -m g p / k: the linearization's eigenvalues are +- i w.
TEST(Screw, ANutOnASpringHasTheClosedFormFrequency) {
  const std::string text = kNut + R"(forces:
  - type: joint_spring
    body: nut
    stiffness: 5.0
)";
  const io::ModelFile f = io::parse_model_file(text, "nut.yaml");
  const double mass = 2.0, izz = 0.15, p = 0.02, k = 5.0;
  const double w = std::sqrt(k / (izz + mass * p * p));
  VectorX q(1);
  q << -mass * kG * p / k;
  const Linearization lin = linearize(f.model, q, VectorX::Zero(1), VectorX::Zero(0));
  const Eigen::VectorXcd ev = sorted_eigenvalues(lin.A);
  ASSERT_EQ(ev.size(), 2);
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(ev[i].real(), 0.0, 1e-12);
    EXPECT_NEAR(std::abs(ev[i].imag()), w, 1e-12 * w);
  }
}

// Pitch 0 is a revolute joint, and any pitch is a cylindrical joint whose slide is held at
// pitch times its angle: the accelerations agree (round-off of different operation orders).
TEST(Screw, PitchZeroIsRevoluteAndAnyPitchIsACoupledCylinder) {
  std::mt19937 rng(71);
  for (int trial = 0; trial < 10; ++trial) {
    const Model base = test::random_jointed(rng, true);
    std::vector<Joint> screws, revolutes;
    for (int k = 0; k < base.num_bodies(); ++k) {
      Joint j = test::random_joint(rng, JointType::screw);
      j.pitch = 0.0;
      screws.push_back(j);
      j.type = JointType::revolute;
      revolutes.push_back(j);
    }
    const Model screw = with_joints(base, screws), revolute = with_joints(base, revolutes);
    VectorX q, z;
    test::random_joint_state(screw, rng, q, z);
    VectorX a(z.size()), b(z.size());
    Dynamics(screw).evaluate(q, z, a);
    Dynamics(revolute).evaluate(q, z, b);
    EXPECT_LT((a - b).norm(), 1e-12 * (1.0 + b.norm())) << "trial " << trial;
  }
  // A single body, where the coupling is one line: on a cylindrical joint with generalized
  // speeds (qdot, p qdot), M_screw = [1 p] M_cyl [1 p]^T and f_screw = [1 p] f_cyl.
  for (int trial = 0; trial < 10; ++trial) {
    const Model base = test::random_jointed(rng, false);
    Joint screw = test::random_joint(rng, JointType::screw);
    Joint cylinder = screw;
    cylinder.type = JointType::cylindrical;
    std::vector<Joint> js(static_cast<size_t>(base.num_bodies()), Joint{}),
        jc(static_cast<size_t>(base.num_bodies()), Joint{});
    js[0] = screw;
    jc[0] = cylinder;
    const Model ms = with_joints(base, js), mc = with_joints(base, jc);
    VectorX qs, zs;
    test::random_joint_state(ms, rng, qs, zs);
    // The same motion in the cylinder's coordinates: its slide p angle, rate p angle rate.
    VectorX qc(qs.size() + 1), zc(zs.size() + 1);
    qc << qs[0], screw.pitch * qs[0], qs.tail(qs.size() - 1);
    zc << zs[0], screw.pitch * zs[0], zs.tail(zs.size() - 1);
    Terms ts(ms), tc(mc);
    MatrixX Ms(zs.size(), zs.size()), Mc(zc.size(), zc.size());
    VectorX bs(zs.size()), bc(zc.size());
    ts.mass_matrix(qs, Ms);
    tc.mass_matrix(qc, Mc);
    ts.bias_forces(qs, zs, bs);
    tc.bias_forces(qc, zc, bc);
    // [Y] maps the screw's speeds to the cylinder's: z_c = [Y] z_s.
    MatrixX Y = MatrixX::Zero(zc.size(), zs.size());
    Y(0, 0) = 1.0;
    Y(1, 0) = screw.pitch;
    Y.bottomRightCorner(zs.size() - 1, zs.size() - 1).setIdentity();
    const MatrixX M_expected = Y.transpose() * Mc * Y;
    const VectorX b_expected = Y.transpose() * bc;
    EXPECT_LT((Ms - M_expected).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + Mc.cwiseAbs().maxCoeff()))
        << "trial " << trial;
    EXPECT_LT((bs - b_expected).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + bc.cwiseAbs().maxCoeff()))
        << "trial " << trial;
  }
}

// A tumbling chain of screws (random axes, frames and pitches; gravity, no damping) keeps its
// energy: RK4 at h = 1e-3 over 0.5 s, speeds ~1 rad/s, truncation ~(w h)^4 per unit time
// (1e-12); tolerance 1e-9 relative, while a wrong [T_K] or [C dot]{z} drifts at O(1).
TEST(Screw, AScrewChainKeepsItsEnergy) {
  std::mt19937 rng(73);
  const Model base = test::random_tree(rng, {.min_bodies = 4, .max_bodies = 4});
  std::vector<Joint> joints;
  for (int k = 0; k < base.num_bodies(); ++k)
    joints.push_back(test::random_joint(rng, JointType::screw));
  const Model m = with_joints(base, joints);
  VectorX q, z;
  test::random_joint_state(m, rng, q, z);
  Dynamics dyn(m);
  Data data(m);
  const auto rates = [&](const VectorX& qq, const VectorX& zz, VectorX& qd, VectorX& zd) {
    qd.resize(qq.size());
    zd.resize(zz.size());
    dyn.evaluate(qq, zz, zd, qd);
  };
  const double e0 = total_energy(m, q, z, data);
  const double scale = std::abs(e0) + kinetic_energy(m, q, z, data);
  const double h = 1e-3;
  VectorX q1, z1, q2, z2, q3, z3, q4, z4;
  for (int step = 0; step < 500; ++step) {
    rates(q, z, q1, z1);
    rates(q + 0.5 * h * q1, z + 0.5 * h * z1, q2, z2);
    rates(q + 0.5 * h * q2, z + 0.5 * h * z2, q3, z3);
    rates(q + h * q3, z + h * z3, q4, z4);
    q += h / 6 * (q1 + 2 * q2 + 2 * q3 + q4);
    z += h / 6 * (z1 + 2 * z2 + 2 * z3 + z4);
  }
  EXPECT_LT(std::abs(total_energy(m, q, z, data) - e0), 1e-9 * scale);
}

// The derivatives are the dual numbers' (the row's motion over any scalar), with no code of
// the screw's own: they agree with central differences of the forward dynamics. Steps of 1e-6
// on quantities of order 1: truncation ~1e-12, round-off ~1e-10 of the accelerations' size.
TEST(Screw, DerivativesAreAnalyticAndAgreeWithCentralDifferences) {
  std::mt19937 rng(79);
  const Model base = test::random_jointed(rng, true);
  std::vector<Joint> joints;
  for (int k = 0; k < base.num_bodies(); ++k)
    joints.push_back(
        test::random_joint(rng, k % 2 ? JointType::screw : test::random_joint_type(rng)));
  const Model m = with_joints(base, joints);
  VectorX q, z;
  test::random_joint_state(m, rng, q, z);
  Derivatives d(m);
  EXPECT_TRUE(d.analytic()) << d.method();
  const int n = m.num_speeds();
  MatrixX dq(n, n), dz(n, n), du(n, 0);
  VectorX zdot;
  d.forward(q, z, VectorX::Zero(0), dq, dz, du, &zdot);
  Dynamics dyn(m);
  const auto accel = [&](const VectorX& qq, const VectorX& zz) {
    VectorX a(n);
    dyn.evaluate(qq, zz, a);
    return a;
  };
  const double h = 1e-6;
  const double scale = 1.0 + zdot.cwiseAbs().maxCoeff();
  for (int c = 0; c < n; ++c) {
    VectorX e = VectorX::Zero(n);
    e[c] = h;
    const VectorX fd_q = (accel(retract(m, q, e), z) - accel(retract(m, q, -e), z)) / (2 * h);
    const VectorX fd_z = (accel(q, z + e) - accel(q, z - e)) / (2 * h);
    EXPECT_LT((dq.col(c) - fd_q).cwiseAbs().maxCoeff(), 1e-7 * scale) << "q column " << c;
    EXPECT_LT((dz.col(c) - fd_z).cwiseAbs().maxCoeff(), 1e-7 * scale) << "z column " << c;
  }
}

TEST(Screw, TheModelFileReadsWritesAndRefusesItsKeys) {
  const io::ModelFile f = io::parse_model_file(kNut, "nut.yaml");
  EXPECT_EQ(f.model.joint(0).pitch, 0.02);
  EXPECT_EQ(f.model.joint(0).axis, Vector3(0, 0, 1));  // normalized
  // The writer keeps the type, axis and pitch: the text reads back to the same model.
  const std::string written = io::model_file_text(f.model, f.q, f.z);
  EXPECT_NE(written.find("type: screw"), std::string::npos) << written;
  EXPECT_NE(written.find("pitch: 0.02"), std::string::npos) << written;
  const io::ModelFile back = io::parse_model_file(written, "written.yaml");
  EXPECT_EQ(back.model.joint(0).type, JointType::screw);
  EXPECT_EQ(back.model.joint(0).pitch, 0.02);
  EXPECT_EQ(back.q, f.q);
  EXPECT_EQ(back.z, f.z);

  const std::string& b = kNut;
  const std::vector<BadCase> cases = {
      {"missing pitch",
       edit(b, "      pitch: 0.02\n", ""),
       "joint:\n      ^at: [0, 0, 1]",
       "bodies[0].joint.pitch",
       {"missing required key 'pitch'", "screw"}},
      {"missing axis",
       edit(b, "      axis: [0, 0, 2]\n", ""),
       "joint:\n      ^at: [0, 0, 1]",
       "bodies[0].joint.axis",
       {"missing required key 'axis'", "screw"}},
      {"pitch not a number",
       edit(b, "pitch: 0.02", "pitch: fine"),
       "pitch: ^fine",
       "bodies[0].joint.pitch",
       {"expected a number"}},
      {"pitch not finite",
       edit(b, "pitch: 0.02", "pitch: .inf"),
       "pitch: ^.inf",
       "bodies[0].joint.pitch",
       {"finite"}},
      {"pitch on a revolute joint",
       edit(b, "type: screw", "type: revolute"),
       "^pitch: 0.02",
       "bodies[0].joint.pitch",
       {"'pitch' is refused on a revolute joint", "screw"}},
      {"two screw coordinates",
       edit(b, "joint: [0.4]", "joint: [0.4, 0]"),
       "joint: ^[0.4, 0]",
       "bodies[0].initial.joint",
       {"a screw joint has 1 coordinate, got 2 numbers"}},
      {"axes on a screw joint",
       edit(b, "      axis: [0, 0, 2]\n", "      axes: [[1, 0, 0], [0, 1, 0]]\n"),
       "^axes: [[1, 0, 0], [0, 1, 0]]",
       "bodies[0].joint.axes",
       {"'axes' is refused on a screw joint"}},
  };
  for (const BadCase& c : cases) test::expect_refused(c);
}

}  // namespace
}  // namespace kanedyn
