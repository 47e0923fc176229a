// Joints in model files and runs (docs/model-format.md, "Joints"): the mapping form of
// `joint`, initial.joint / joint_rate, joint_spring and joint_force, every refusal with its
// place; runs that keep every joint on every CSV row; energy and momentum; the small-angle
// pendulum, the spring-loaded slider, and the stiff-bushing limit of a ball joint; eom's
// projected equations.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "file_support.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/trajectory.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/simulate.hpp"

namespace kanedyn {
namespace {

using test::BadCase;
using test::edit;
using Vector2 = Eigen::Vector2d;
namespace fs = std::filesystem;

// One body of every joint type, with a joint spring and a joint force.
const std::string kJointed = R"(format: kanedyn-model/1
name: every joint
gravity: [0, 0, -9.81]
bodies:
  - name: base
    parent: ground
    mass: 5.0
    inertia: [0.5, 0.6, 0.7]
    initial:
      translation: [0, 0, 1]
      angular_velocity: [0.1, 0.2, 0.3]
      translation_rate: [0.05, 0, 0.2]
  - name: hinge
    parent: base
    mass: 1.0
    inertia: [0.02, 0.03, 0.025]
    com: [0, 0, -0.2]
    joint:
      at: [0.1, 0, -0.1]
      type: revolute
      frame: {axis: [0, 0, 1], angle: 0.3}
      axis: [1, 0, 0]
    initial:
      joint: [0.4]
      joint_rate: [1.5]
  - name: slider
    parent: hinge
    mass: 0.5
    inertia: [0.01, 0.012, 0.008]
    com: [0, 0.05, 0]
    joint:
      at: [0, 0, -0.4]
      type: prismatic
      axis: [0, 1, 1]
    initial:
      joint: [0.05]
      joint_rate: [-0.3]
  - name: cyl
    parent: base
    mass: 0.8
    inertia: [0.015, 0.02, 0.01]
    com: [0.1, 0, 0]
    joint:
      at: [0.2, 0.1, 0]
      type: cylindrical
      frame: {axis: [1, 1, 0], angle_deg: 40}
      axis: [0, 0, 1]
    initial:
      joint: [-0.2, 0.03]
      joint_rate: [0.7, 0.1]
  - name: uni
    parent: base
    mass: 1.2
    inertia: [0.03, 0.025, 0.02]
    com: [0, 0, -0.15]
    joint:
      at: [-0.1, 0, -0.2]
      type: universal
      frame: {axis: [0, 1, 0], angle: -0.2}
      axes: [[1, 0, 0], [0, 2, 0]]
    initial:
      joint: [0.3, -0.25]
      joint_rate: [-0.4, 0.9]
  - name: ball
    parent: uni
    mass: 0.7
    inertia: [0.012, 0.01, 0.009]
    com: [0, 0, -0.12]
    joint:
      at: [0, 0, -0.3]
      type: spherical
    initial:
      joint: [0, 0, 0.6, 0.8]
      joint_rate: [0.3, -0.2, 0.5]
  - name: welded
    parent: ball
    mass: 0.3
    inertia: [0.004, 0.005, 0.006]
    joint:
      at: [0, 0, -0.2]
      type: weld
      frame: {axis: [1, 0, 0], angle: 0.5}
    initial:
      translation: [0, 0.1, 0]
forces:
  - type: joint_spring
    body: hinge
    stiffness: 3
    rest: [0.1]
  - type: joint_force
    body: cyl
    value: [0.5, -1]
  - type: joint_spring
    body: uni
    stiffness: [2, 1]
  - type: bushing
    body: ball
    rotational_stiffness: 0.8
)";

TEST(JointFiles, TheMappingFormLoadsWithItsCoordinatesAndSpeeds) {
  const io::ModelFile f = io::parse_model_file(kJointed, "jointed.yaml");
  ASSERT_TRUE(f.jointed());
  const Model& tree = f.model;
  // q: base 7, hinge 1, slider 1, cyl 2, uni 2, ball 4, weld 0; z: 6, 1, 1, 2, 2, 3, 0.
  EXPECT_EQ(tree.num_coordinates(), 17);
  EXPECT_EQ(tree.num_speeds(), 15);
  EXPECT_EQ(tree.joint(1).type, JointType::revolute);
  EXPECT_EQ(tree.joint(6).type, JointType::weld);
  EXPECT_EQ(f.model.body(1).joint, Vector3(0.1, 0, -0.1));  // `at` is q'_K
  EXPECT_EQ(tree.joint(4).axes[1], Vector3::UnitY());       // normalized
  const VectorX& q = f.q;
  EXPECT_EQ(q.segment<7>(0), (VectorX(7) << 0, 0, 0, 1, 0, 0, 1).finished());
  EXPECT_EQ(q[7], 0.4);
  EXPECT_EQ(q.segment<2>(9), Vector2(-0.2, 0.03));
  EXPECT_EQ(q.segment<4>(13), Vector4(0, 0, 0.6, 0.8));
  EXPECT_EQ(f.z.segment<6>(0), (VectorX(6) << 0.1, 0.2, 0.3, 0.05, 0, 0.2).finished());
  EXPECT_EQ(f.z.segment<3>(12), Vector3(0.3, -0.2, 0.5));
  EXPECT_EQ(tree.joint(6).translation, Vector3(0, 0.1, 0));
  // The loads: the spring's scalar stiffness stands for its one coordinate; defaults 0.
  std::vector<const JointLoad*> loads;
  for (const auto& element : tree.forces())
    if (const auto* l = dynamic_cast<const JointLoad*>(element.get())) loads.push_back(l);
  ASSERT_EQ(loads.size(), 3u);
  EXPECT_EQ(loads[0]->type(), "joint_spring");
  EXPECT_EQ(loads[0]->stiffness, VectorX::Constant(1, 3.0));
  EXPECT_EQ(loads[0]->rest, VectorX::Constant(1, 0.1));
  EXPECT_EQ(loads[1]->type(), "joint_force");
  EXPECT_EQ(loads[1]->value, Vector2(0.5, -1));
  EXPECT_EQ(loads[1]->stiffness, Vector2::Zero());
  // The initial state is the notes' x, y at (q, z): the hinge is F (J turned 0.3 about z)
  // turned 0.4 about F's x axis, computed here from rotation matrices.
  const Matrix3 r_hinge = rotation_matrix(f.initial.euler_parameters(1));
  const Matrix3 r_base = rotation_matrix(f.initial.euler_parameters(0));
  const Matrix3 expected =
      rotation_matrix(euler_parameters_from_axis_angle(Vector3::UnitX(), 0.4)) *
      rotation_matrix(euler_parameters_from_axis_angle(Vector3::UnitZ(), 0.3)) * r_base;
  EXPECT_LT((r_hinge - expected).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(f.initial.translation(1), Vector3::Zero());
}

TEST(JointFiles, TheListFormAndAFreeMappingMeanTheNotesFreeTree) {
  const std::string list = R"(format: kanedyn-model/1
bodies:
  - name: a
    parent: ground
    mass: 1
    inertia: [1, 2, 2.5]
  - name: b
    parent: a
    mass: 2
    inertia: [1, 1, 1]
    joint: [0.1, 0.2, 0.3]
    initial:
      angular_velocity: [1, 2, 3]
)";
  const io::ModelFile plain = io::parse_model_file(list, "list.yaml");
  const io::ModelFile mapped = io::parse_model_file(
      edit(list, "joint: [0.1, 0.2, 0.3]", "joint: {at: [0.1, 0.2, 0.3], type: free}"), "map.yaml");
  EXPECT_FALSE(plain.jointed());
  EXPECT_FALSE(mapped.jointed());
  EXPECT_EQ(mapped.model.body(1).joint, plain.model.body(1).joint);
  EXPECT_EQ(mapped.initial.x, plain.initial.x);
  EXPECT_EQ(mapped.initial.y, plain.initial.y);
}

std::vector<BadCase> joint_bad_cases() {
  const std::string& b = kJointed;
  return {
      {"unknown joint type",
       edit(b, "type: revolute", "type: hinge"),
       "type: ^hinge",
       "bodies[1].joint.type",
       {"unknown joint type 'hinge'", "revolute"}},
      {"missing type",
       edit(b, "      type: universal\n", ""),
       "joint:\n      ^at: [-0.1",
       "bodies[4].joint.type",
       {"missing required key 'type'"}},
      {"zero axis",
       edit(b, "      axis: [1, 0, 0]\n", "      axis: [0, 0, 0]\n"),
       "axis: ^[0, 0, 0]",
       "bodies[1].joint.axis",
       {"must not be zero"}},
      {"missing axis",
       edit(b, "      axis: [0, 1, 1]\n", ""),
       "joint:\n      ^at: [0, 0, -0.4]",
       "bodies[2].joint.axis",
       {"missing required key 'axis'", "prismatic"}},
      {"axis on a spherical joint",
       edit(b, "type: spherical", "type: spherical\n      axis: [1, 0, 0]"),
       "^axis: [1, 0, 0]\n    initial:\n      joint: [0, 0, 0.6",
       "bodies[5].joint.axis",
       {"'axis' is refused on a spherical joint"}},
      {"axis on a universal joint",
       edit(b, "axes: [[1, 0, 0], [0, 2, 0]]", "axis: [1, 0, 0]"),
       "^axis: [1, 0, 0]\n    initial:\n      joint: [0.3",
       "bodies[4].joint.axis",
       {"'axis' is refused on a universal joint", "'axes'"}},
      {"axes on a revolute joint",
       edit(b, "      axis: [1, 0, 0]\n", "      axes: [[1, 0, 0], [0, 1, 0]]\n"),
       "^axes: [[1, 0, 0], [0, 1, 0]]",
       "bodies[1].joint.axes",
       {"'axes' is refused on a revolute joint"}},
      {"universal axes not perpendicular",
       edit(b, "[[1, 0, 0], [0, 2, 0]]", "[[1, 0, 0], [0.001, 1, 0]]"),
       "axes: ^[[1, 0, 0]",
       "bodies[4].joint.axes",
       {"must be perpendicular", "1e-9"}},
      {"one universal axis",
       edit(b, "[[1, 0, 0], [0, 2, 0]]", "[[1, 0, 0]]"),
       "axes: ^[[1, 0, 0]]",
       "bodies[4].joint.axes",
       {"two axes"}},
      {"frame on a free joint",
       edit(b, "    inertia: [0.5, 0.6, 0.7]\n",
            "    inertia: [0.5, 0.6, 0.7]\n    joint: {type: free, frame: {axis: [1, 0, 0], angle: "
            "1}}\n"),
       "type: free, ^frame",
       "bodies[0].joint.frame",
       {"'frame' is refused on a free joint"}},
      {"frame with a zero axis",
       edit(b, "frame: {axis: [0, 0, 1], angle: 0.3}", "frame: {axis: [0, 0, 0], angle: 0.3}"),
       "frame: {axis: ^[0, 0, 0]",
       "bodies[1].joint.frame.axis",
       {"must not be zero"}},
      {"frame without an angle",
       edit(b, "frame: {axis: [0, 0, 1], angle: 0.3}", "frame: {axis: [0, 0, 1]}"),
       "frame: ^{axis: [0, 0, 1]}",
       "bodies[1].joint.frame.angle",
       {"missing required key 'angle'"}},
      {"too many coordinates",
       edit(b, "joint: [0.4]", "joint: [0.4, 0.1]"),
       "joint: ^[0.4, 0.1]",
       "bodies[1].initial.joint",
       {"a revolute joint has 1 coordinate, got 2 numbers"}},
      {"too few rates",
       edit(b, "joint_rate: [0.3, -0.2, 0.5]", "joint_rate: [0.3, -0.2]"),
       "joint_rate: ^[0.3, -0.2]",
       "bodies[5].initial.joint_rate",
       {"a spherical joint has 3 rates, got 2 numbers"}},
      {"a scalar coordinate",
       edit(b, "joint: [0.05]", "joint: 0.05"),
       "joint: ^0.05",
       "bodies[2].initial.joint",
       {"a prismatic joint has 1 coordinate"}},
      {"spherical q off unit norm",
       edit(b, "joint: [0, 0, 0.6, 0.8]", "joint: [0, 0, 0.6, 0.9]"),
       "joint: ^[0, 0, 0.6, 0.9]",
       "bodies[5].initial.joint",
       {"norm 1 within 1e-06"}},
      {"v1 key on a jointed body",
       edit(b, "joint_rate: [1.5]", "joint_rate: [1.5]\n      angular_velocity: [0, 0, 1]"),
       "^angular_velocity: [0, 0, 1]",
       "bodies[1].initial.angular_velocity",
       {"refused on a body with a revolute joint", "'joint' and 'joint_rate'"}},
      {"translation on a spherical body",
       edit(b, "joint_rate: [0.3, -0.2, 0.5]",
            "joint_rate: [0.3, -0.2, 0.5]\n      translation: [0, 0, 1]"),
       "^translation: [0, 0, 1]\n  - name: welded",
       "bodies[5].initial.translation",
       {"refused on a body with a spherical joint"}},
      {"rotation on a weld",
       edit(b, "translation: [0, 0.1, 0]",
            "translation: [0, 0.1, 0]\n      rotation: {axis: [1, 0, 0], angle: 1}"),
       "^rotation: {axis: [1, 0, 0], angle: 1}",
       "bodies[6].initial.rotation",
       {"refused on a body with a weld joint", "only 'translation'"}},
      {"joint on a weld",
       edit(b, "translation: [0, 0.1, 0]", "joint: []"),
       "^joint: []",
       "bodies[6].initial.joint",
       {"refused on a weld joint", "no coordinates"}},
      {"joint_rate on a free body",
       edit(b, "translation_rate: [0.05, 0, 0.2]", "joint_rate: [0]"),
       "^joint_rate: [0]",
       "bodies[0].initial.joint_rate",
       {"refused on a free joint"}},
      {"joint spring on a free body",
       edit(b, "    body: hinge\n    stiffness: 3", "    body: base\n    stiffness: 3"),
       "body: ^base",
       "forces[0].body",
       {"joint_spring acts on joint coordinates", "free joint",
        "revolute, prismatic, cylindrical, universal, planar and screw joints"}},
      {"joint force on a spherical joint",
       edit(b, "    body: cyl\n", "    body: ball\n"),
       "body: ^ball\n    value",
       "forces[1].body",
       {"joint_force", "spherical joint"}},
      {"joint force on a weld",
       edit(b, "    body: cyl\n", "    body: welded\n"),
       "body: ^welded",
       "forces[1].body",
       {"weld joint"}},
      {"a joint force without its value (not a zero force)",
       edit(b, "    body: cyl\n    value: [0.5, -1]\n", "    body: cyl\n"),
       "- ^type: joint_force",
       "forces[1].value",
       {"missing required key 'value'"}},
      {"a joint force with the wrong count",
       edit(b, "value: [0.5, -1]", "value: [0.5, -1, 2]"),
       "value: ^[0.5, -1, 2]",
       "forces[1].value",
       {"a list of 2 numbers", "cylindrical"}},
      {"negative joint stiffness",
       edit(b, "stiffness: [2, 1]", "stiffness: [2, -1]"),
       "stiffness: ^[2, -1]",
       "forces[2].stiffness",
       {"must be >= 0"}},
      {"rest on a joint force",
       edit(b, "value: [0.5, -1]", "value: [0.5, -1]\n    rest: 0"),
       "^rest: 0",
       "forces[1].rest",
       {"unknown key 'rest'"}},
  };
}

TEST(JointFiles, EveryRefusalNamesThePlaceTheKeyAndTheProblem) {
  const std::vector<BadCase> cases = joint_bad_cases();
  ASSERT_GE(cases.size(), 25u);
  for (const BadCase& c : cases) test::expect_refused(c);
}

/// The largest violation of the joints in a row of the notes' state (x, y), measured from
/// the Euler parameters and speeds alone with rotation matrices (Eqs. 3-4): what each joint
/// type's table row allows of K relative to J.
double joint_violation(const Model& model, const State& s) {
  const Model& tree = model;
  double worst = 0.0;
  const auto note = [&](double v) { worst = std::max(worst, std::abs(v)); };
  for (int k = 0; k < model.num_bodies(); ++k) {
    const Joint& jt = tree.joint(k);
    if (jt.type == JointType::free) continue;
    const int j = model.lower_body(k);
    const Matrix3 r_j = j < 0 ? Matrix3::Identity() : rotation_matrix(s.euler_parameters(j));
    const Vector3 w_j = j < 0 ? Vector3::Zero() : Vector3(s.angular_velocity(j));
    const Matrix3 r_k = rotation_matrix(s.euler_parameters(k));
    const Matrix3 r_f = rotation_matrix(jt.frame) * r_j;  // inertial to F components
    const Matrix3 m = r_k * r_f.transpose();              // F components to K components
    const Vector3 w_rel = s.angular_velocity(k) - r_k * r_j.transpose() * w_j;
    const Vector3 axis_j = rotation_matrix(jt.frame).transpose() * jt.axis;
    const Vector3 sp = s.translation(k), sd = s.translation_rate(k);
    switch (jt.type) {
      case JointType::revolute:
      case JointType::cylindrical:
      case JointType::screw:
        note((m * jt.axis - jt.axis).norm());  // a turn about the axis leaves it
        note(w_rel.cross(jt.axis).norm());
        if (jt.type == JointType::revolute) {
          note(sp.norm());
          note(sd.norm());
        } else {
          note(sp.cross(axis_j).norm());
          note(sd.cross(axis_j).norm());
        }
        break;
      case JointType::prismatic:
      case JointType::weld:
        note((m - Matrix3::Identity()).cwiseAbs().maxCoeff());
        note(w_rel.norm());
        if (jt.type == JointType::weld) {
          note((sp - jt.translation).norm());
          note(sd.norm());
        } else {
          note(sp.cross(axis_j).norm());
          note(sd.cross(axis_j).norm());
        }
        break;
      case JointType::universal:
        // K's a2, in F components, stays perpendicular to F's a1.
        note((m.transpose() * jt.axes[1]).dot(jt.axes[0]));
        note(sp.norm());
        note(sd.norm());
        break;
      case JointType::spherical:
        note(sp.norm());
        note(sd.norm());
        break;
      case JointType::planar: {
        // K turns about F's z only, and s', s' dot stay in F's x-y plane.
        const Vector3 normal_j = rotation_matrix(jt.frame).transpose() * Vector3::UnitZ();
        note((m * Vector3::UnitZ() - Vector3::UnitZ()).norm());
        note(w_rel.cross(Vector3::UnitZ()).norm());
        note(sp.dot(normal_j));
        note(sd.dot(normal_j));
        break;
      }
      case JointType::free:
        break;
    }
  }
  return worst;
}

// A puck on a planar joint whose plane is turned 90 degrees about J's x axis (F's z = -J's y,
// F's x = J's x, F's y = J's z: the vertical x-z plane of J), with a spring on its
// coordinates.
const std::string kPlanar = R"(format: kanedyn-model/1
name: planar puck
gravity: [0, 0, -9.81]
bodies:
  - name: puck
    parent: ground
    mass: 2.0
    inertia: [0.02, 0.03, 0.04]
    com: [0.1, 0, 0]
    joint:
      at: [0, 0, 1]
      type: planar
      frame: {axis: [1, 0, 0], angle_deg: 90}
    initial:
      joint: [0.3, -0.2, 0.5]
      joint_rate: [1.0, 2.0, -0.5]
forces:
  - type: joint_spring
    body: puck
    stiffness: [10, 20, 0.5]
    rest: [0, 0.1, 0]
)";

TEST(JointFiles, APlanarJointReadsXYAngleInItsFramesPlane) {
  const io::ModelFile f = io::parse_model_file(kPlanar, "planar.yaml");
  ASSERT_TRUE(f.jointed());
  const Model& m = f.model;
  EXPECT_EQ(m.joint(0).type, JointType::planar);
  EXPECT_EQ(m.num_coordinates(), 3);
  EXPECT_EQ(m.num_speeds(), 3);
  EXPECT_EQ(f.q, Vector3(0.3, -0.2, 0.5));  // (x, y, angle) in the file's order
  EXPECT_EQ(f.z, Vector3(1.0, 2.0, -0.5));
  // s'_K = x F's x + y F's y in J (here inertial) components: F's x = (1, 0, 0), F's y =
  // (0, 0, 1); one turn of Euler parameters (round-off 1e-16).
  EXPECT_LT((f.initial.translation(0) - Vector3(0.3, 0, -0.2)).norm(), 1e-15);
  EXPECT_LT((f.initial.translation_rate(0) - Vector3(1.0, 0, 2.0)).norm(), 1e-15);
  // K is F turned 0.5 about F's z: w'_K = -0.5 e_z (K components).
  EXPECT_LT((f.initial.angular_velocity(0) - Vector3(0, 0, -0.5)).norm(), 1e-15);
  const Matrix3 expected =
      rotation_matrix(euler_parameters_from_axis_angle(Vector3::UnitZ(), 0.5)) *
      rotation_matrix(euler_parameters_from_axis_angle(Vector3::UnitX(), M_PI / 2));
  EXPECT_LT((rotation_matrix(f.initial.euler_parameters(0)) - expected).cwiseAbs().maxCoeff(),
            1e-15);
  // The spring: one entry per coordinate.
  ASSERT_EQ(m.forces().size(), 1u);
  const auto* spring = dynamic_cast<const JointLoad*>(m.forces()[0].get());
  ASSERT_NE(spring, nullptr);
  EXPECT_EQ(spring->stiffness, Vector3(10, 20, 0.5));
  EXPECT_EQ(spring->rest, Vector3(0, 0.1, 0));
  // Q = -k (q - rest) - c z on the joint's speeds (no damping given).
  VectorX Q = VectorX::Zero(3);
  add_joint_forces(m, f.q, f.z, Q);
  EXPECT_LT((Q - Vector3(-3.0, 6.0, -0.25)).norm(), 1e-15);
}

TEST(JointFiles, APlanarRunStaysInItsPlane) {
  const fs::path dir = test::temp_dir("joint_planar_run");
  std::ofstream(dir / "planar.yaml") << kPlanar;
  const test::ToolRun run = test::run_in(dir, "simulate planar.yaml -o run.csv --t-end 2");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const io::ModelFile f = io::parse_model_file(kPlanar, "planar.yaml");
  const io::Trajectory traj = io::read_trajectory(f.model, (dir / "run.csv").string());
  ASSERT_GT(traj.rows(), 10u);
  // time, 16 columns of the notes' state, j1..j3, jd1..jd3, and one more (as in the long run).
  ASSERT_EQ(traj.columns.size(), 2u + 16u + 6u);
  EXPECT_EQ(traj.columns[17], "puck.j1");
  EXPECT_EQ(traj.columns[19], "puck.j3");
  EXPECT_EQ(traj.columns[20], "puck.jd1");
  EXPECT_EQ(traj.columns[22], "puck.jd3");
  State s(f.model);
  double worst = 0.0;
  for (std::size_t r = 0; r < traj.rows(); ++r) {
    for (int i = 0; i < 4; ++i) s.euler_parameters(0)[i] = traj.at(r, 4 + i);
    for (int i = 0; i < 3; ++i) {
      s.translation(0)[i] = traj.at(r, 8 + i);
      s.angular_velocity(0)[i] = traj.at(r, 11 + i);
      s.translation_rate(0)[i] = traj.at(r, 14 + i);
    }
    worst = std::max(worst, joint_violation(f.model, s));
  }
  // Round-off of one composed rotation per row (the CSV's decimals round-trip): 1e-13.
  EXPECT_LT(worst, 1e-13);
}

TEST(JointFiles, PlanarRefusalsNameTheKey) {
  const std::string& b = kPlanar;
  const std::vector<BadCase> cases = {
      {"axis on a planar joint",
       edit(b, "      type: planar\n", "      type: planar\n      axis: [0, 0, 1]\n"),
       "^axis: [0, 0, 1]",
       "bodies[0].joint.axis",
       {"'axis' is refused on a planar joint", "'frame'"}},
      {"axes on a planar joint",
       edit(b, "      type: planar\n", "      type: planar\n      axes: [[1, 0, 0], [0, 1, 0]]\n"),
       "^axes: [[1, 0, 0], [0, 1, 0]]",
       "bodies[0].joint.axes",
       {"'axes' is refused on a planar joint", "'frame'"}},
      {"two planar coordinates",
       edit(b, "joint: [0.3, -0.2, 0.5]", "joint: [0.3, -0.2]"),
       "joint: ^[0.3, -0.2]",
       "bodies[0].initial.joint",
       {"a planar joint has 3 coordinates, got 2 numbers"}},
      {"four planar rates",
       edit(b, "joint_rate: [1.0, 2.0, -0.5]", "joint_rate: [1.0, 2.0, -0.5, 0]"),
       "joint_rate: ^[1.0, 2.0, -0.5, 0]",
       "bodies[0].initial.joint_rate",
       {"a planar joint has 3 rates, got 4 numbers"}},
      {"a planar spring with two stiffnesses",
       edit(b, "stiffness: [10, 20, 0.5]", "stiffness: [10, 20]"),
       "stiffness: ^[10, 20]",
       "forces[0].stiffness",
       {"a list of 3 numbers", "planar"}},
      {"v1 key on a planar body",
       edit(b, "joint_rate: [1.0, 2.0, -0.5]",
            "joint_rate: [1.0, 2.0, -0.5]\n      translation: [0, 0, 1]"),
       "^translation: [0, 0, 1]",
       "bodies[0].initial.translation",
       {"refused on a body with a planar joint"}},
  };
  for (const BadCase& c : cases) test::expect_refused(c);
}

TEST(JointFiles, EveryRowOfALongRunHoldsEveryJoint) {
  const fs::path dir = test::temp_dir("joint_long_run");
  std::ofstream(dir / "jointed.yaml") << kJointed;
  const test::ToolRun run =
      test::run_in(dir, "simulate jointed.yaml -o run.csv --t-end 20 --dt-out 0.01");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const io::ModelFile f = io::parse_model_file(kJointed, "jointed.yaml");
  const io::Trajectory traj = io::read_trajectory(f.model, (dir / "run.csv").string());
  ASSERT_EQ(traj.rows(), 2001u);
  EXPECT_EQ(traj.columns.size(), 2u + 16u * 7u + (2 + 2 + 4 + 4 + 7));
  EXPECT_EQ(traj.columns[16], "base.sd3");
  EXPECT_EQ(traj.columns[33], "hinge.j1");
  EXPECT_EQ(traj.columns[34], "hinge.jd1");
  State s(f.model);
  double worst = 0.0;
  for (std::size_t r = 0; r < traj.rows(); ++r) {
    std::size_t c = 1;
    for (int k = 0; k < 7; ++k) {
      for (int i = 0; i < 4; ++i) s.euler_parameters(k)[i] = traj.at(r, c + 3 + i);
      for (int i = 0; i < 3; ++i) {
        s.translation(k)[i] = traj.at(r, c + 7 + i);
        s.angular_velocity(k)[i] = traj.at(r, c + 10 + i);
        s.translation_rate(k)[i] = traj.at(r, c + 13 + i);
      }
      const JointType t = f.model.joint(k).type;
      c +=
          16 +
          (t == JointType::free || t == JointType::weld ? 0 : coordinate_count(t) + speed_count(t));
    }
    worst = std::max(worst, joint_violation(f.model, s));
  }
  // Round-off: the poses are compositions of a few rotations of unit Euler parameters
  // (the CSV's shortest round-trip decimals are exact), so a few hundred ulp of O(1)
  // quantities at most; drift would grow with the 2000 rows and their ~10^4 steps.
  EXPECT_LT(worst, 1e-13);
}

TEST(JointFiles, EnergyIsConservedWithoutDampingAndLostWithIt) {
  SimulationSettings s;
  s.t_end = 10.0;
  s.dt_out = 1.0;
  s.rtol = 1e-11;
  s.atol = 1e-12;
  // The joint force is a constant generalized force: not conservative, and left out of the
  // energy; this model has only zero-damping springs and gravity otherwise, so take it out.
  const io::ModelFile g = io::parse_model_file(edit(kJointed, "value: [0.5, -1]", "value: [0, 0]"),
                                               "conservative.yaml");
  const SimulationStats c = simulate(g.model, g.q, g.z, s);
  ASSERT_TRUE(c.ok()) << c.message;
  // The spec's bound: 1e-8 relative over 10 s at rtol 1e-10 and below.
  EXPECT_LT(std::abs(c.relative_energy_change()), 1e-8)
      << c.energy_initial << " " << c.energy_final;
  // With joint damping, energy only falls.
  const io::ModelFile d =
      io::parse_model_file(edit(edit(kJointed, "value: [0.5, -1]", "value: [0, 0]"), "stiffness: 3",
                                "stiffness: 3\n    damping: 0.5"),
                           "damped.yaml");
  const SimulationStats dd = simulate(d.model, d.q, d.z, s);
  ASSERT_TRUE(dd.ok());
  EXPECT_LT(dd.energy_final, dd.energy_initial - 1e-3);
}

TEST(JointFiles, AFreeFloatingJointedSystemKeepsItsMomentum) {
  // No gravity, no ground joint but the free base: linear and angular momentum are constant.
  const io::ModelFile f = io::parse_model_file(
      edit(kJointed, "gravity: [0, 0, -9.81]", "gravity: [0, 0, 0]"), "float.yaml");
  SimulationSettings s;
  s.t_end = 5.0;
  s.dt_out = 0.5;
  s.rtol = 1e-11;
  s.atol = 1e-12;
  Data data(f.model);
  std::vector<Vector3> p, h;
  const Observer obs = [&](double, const State& state, const VectorX&, const VectorX&, Data&) {
    p.push_back(linear_momentum(f.model, state, data));
    h.push_back(angular_momentum(f.model, state, data));
  };
  ASSERT_TRUE(simulate(f.model, f.q, f.z, s, obs).ok());
  ASSERT_EQ(p.size(), 11u);
  // The joint force (internal: equal and opposite on the two bodies) changes neither.
  for (std::size_t i = 1; i < p.size(); ++i) {
    EXPECT_LT((p[i] - p[0]).norm(), 1e-9 * p[0].norm()) << i;
    EXPECT_LT((h[i] - h[0]).norm(), 1e-9 * h[0].norm()) << i;
  }
}

const std::string kPendulum = R"(format: kanedyn-model/1
gravity: [0, 0, -9.81]
bodies:
  - name: rod
    parent: ground
    mass: 2.0
    inertia: [0.05, 0.04, 0.01]
    com: [0, 0, -0.8]
    joint:
      type: revolute
      frame: {axis: [0, 0, 1], angle: 0.7}
      axis: [1, 0, 0]
    initial:
      joint: [0.001]
)";

TEST(JointFiles, ASimplePendulumHasItsSmallAnglePeriod) {
  const io::ModelFile f = io::parse_model_file(kPendulum, "pendulum.yaml");
  // omega^2 = m g l / (I_G + m l^2) about the hinge axis (F's x = J's x turned about z: the
  // body's x axis, Ixx = 0.05).
  const double omega = std::sqrt(2.0 * 9.81 * 0.8 / (0.05 + 2.0 * 0.64));
  const double period = 2.0 * std::numbers::pi / omega;
  SimulationSettings s;
  s.t_end = 3.0 * period;
  s.dt_out = period / 400.0;
  s.rtol = 1e-12;
  s.atol = 1e-14;
  std::vector<double> t, q;
  const Observer obs = [&](double time, const State&, const VectorX& jq, const VectorX&, Data&) {
    t.push_back(time);
    q.push_back(jq[0]);
  };
  ASSERT_TRUE(simulate(f.model, f.q, f.z, s, obs).ok());
  // Downward zero crossings, linearly interpolated between rows 1/400 of a period apart.
  std::vector<double> crossings;
  for (std::size_t i = 1; i < q.size(); ++i)
    if (q[i - 1] > 0.0 && q[i] <= 0.0)
      crossings.push_back(t[i - 1] + (t[i] - t[i - 1]) * q[i - 1] / (q[i - 1] - q[i]));
  ASSERT_GE(crossings.size(), 3u);
  const double measured = (crossings.back() - crossings.front()) / double(crossings.size() - 1);
  // The amplitude's correction to the period is theta0^2 / 16 = 6e-8; linear interpolation
  // of a sine near its zero errs by about (pi/400)^2 * theta0 / 6 in q, far below that in t.
  EXPECT_NEAR(measured / period, 1.0, 2e-7);
}

TEST(JointFiles, ASpringLoadedSliderIsTheAnalyticOscillator) {
  const std::string text = R"(format: kanedyn-model/1
gravity: [0, 0, -9.81]
bodies:
  - name: cart
    parent: ground
    mass: 1.5
    inertia: [0.1, 0.1, 0.1]
    joint:
      type: prismatic
      frame: {axis: [0, 1, 0], angle_deg: 90}
      axis: [0, 0, 1]
    initial:
      joint: [0.3]
      joint_rate: [0.4]
forces:
  - type: joint_spring
    body: cart
    stiffness: 6
    rest: 0.1
  - type: joint_force
    body: cart
    value: 1.2
)";
  // F's z axis is J's z turned 90 degrees about y: the inertial x axis, horizontal, so
  // gravity does no work on d. m d'' = -k (d - rest) + value: oscillation about
  // d_eq = rest + value / k with omega = sqrt(k / m).
  const io::ModelFile f = io::parse_model_file(text, "slider.yaml");
  const double m = 1.5, k = 6.0, d_eq = 0.1 + 1.2 / 6.0, omega = std::sqrt(k / m);
  const double a = 0.3 - d_eq, b = 0.4 / omega;
  SimulationSettings s;
  s.t_end = 10.0;
  s.dt_out = 0.1;
  s.rtol = 1e-12;
  s.atol = 1e-14;
  double worst = 0.0;
  const Observer obs = [&](double t, const State& state, const VectorX& q, const VectorX& z,
                           Data&) {
    worst = std::max(worst,
                     std::abs(q[0] - (d_eq + a * std::cos(omega * t) + b * std::sin(omega * t))));
    worst = std::max(worst,
                     std::abs(z[0] - omega * (-a * std::sin(omega * t) + b * std::cos(omega * t))));
    // The slide is along the inertial x axis.
    EXPECT_NEAR(state.translation(0)[0], q[0], 1e-15);
    EXPECT_NEAR(state.translation(0)[2], 0.0, 1e-15);
  };
  ASSERT_TRUE(simulate(f.model, f.q, f.z, s, obs).ok());
  // Truncation of dopri5 at rtol 1e-12 over 10 periods/(2 pi): well below 1e-9.
  EXPECT_LT(worst, 1e-9);
}

TEST(JointFiles, ABallJointIsTheLimitOfEverStifferBushings) {
  // A body hanging from a ball joint, and the same body free with a translational bushing of
  // stiffness k holding O_K at Q_K: the bushing's body follows the joint's ever closer.
  const std::string jointed = R"(format: kanedyn-model/1
gravity: [0, 0, -9.81]
bodies:
  - name: bob
    parent: ground
    mass: 1.0
    inertia: [0.02, 0.03, 0.04]
    com: [0.1, 0, -0.5]
    joint: {type: spherical}
    initial:
      joint: [0.2, 0, 0, 0.9797958971132712]
      joint_rate: [0.5, 1.0, -0.3]
)";
  const io::ModelFile f = io::parse_model_file(jointed, "ball.yaml");
  SimulationSettings s;
  s.t_end = 1.0;
  s.dt_out = 1.0;
  s.rtol = 1e-10;
  s.atol = 1e-12;
  Vector3 p_joint;
  Data data(f.model);
  const Observer jobs = [&](double t, const State& state, const VectorX&, const VectorX&, Data&) {
    compute_kinematics(f.model, state, data);
    if (t == 1.0) p_joint = data.kinematics.p_G[0];
  };
  ASSERT_TRUE(simulate(f.model, f.q, f.z, s, jobs).ok());
  std::vector<double> gaps;
  for (const double k : {1e4, 1e5, 1e6}) {
    std::vector<std::shared_ptr<const ForceElement>> forces{
        std::make_shared<Bushing>(0, Vector3::Constant(k), Vector3::Zero(), 0.0, 0.0)};
    const Model free(f.model.bodies(), f.model.gravity(), forces);
    Vector3 p_free;
    const Observer obs = [&](double t, const State&, const VectorX&, const VectorX&, Data& d) {
      if (t == 1.0) p_free = d.kinematics.p_G[0];
    };
    ASSERT_TRUE(simulate(free, f.initial, s, obs).ok());
    gaps.push_back((p_free - p_joint).norm());
  }
  // The gap is of the order of the bushing's static stretch m g / k and its oscillation:
  // it shrinks about tenfold per decade of k; ask for fivefold.
  EXPECT_LT(gaps[1], gaps[0] / 5.0) << gaps[0] << " " << gaps[1];
  EXPECT_LT(gaps[2], gaps[1] / 5.0) << gaps[1] << " " << gaps[2];
  EXPECT_LT(gaps[2], 1e-4);
}

TEST(JointFiles, EomPrintsTheProjectedEquations) {
  const fs::path dir = test::temp_dir("joint_eom");
  std::ofstream(dir / "jointed.yaml") << kJointed;
  std::ofstream(dir / "pendulum.yaml") << kPendulum;
  const test::ToolRun run = test::run_in(dir, "eom --json jointed.yaml");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto j = nlohmann::ordered_json::parse(run.out);
  std::vector<std::string> keys;
  for (auto it = j.begin(); it != j.end(); ++it) keys.push_back(it.key());
  EXPECT_EQ(keys, (std::vector<std::string>{"N", "L", "u", "A", "f", "ydot", "xdot", "n", "C",
                                            "A_z", "f_z", "zdot"}));
  const int n = j["n"], six_n = 42;
  EXPECT_EQ(n, 15);
  const auto mat = [](const nlohmann::json& m) {
    MatrixX out(m.size(), m[0].size());
    for (std::size_t r = 0; r < m.size(); ++r)
      for (std::size_t c = 0; c < m[r].size(); ++c) out(r, c) = m[r][c];
    return out;
  };
  const auto vec = [](const nlohmann::json& v) {
    VectorX out(v.size());
    for (std::size_t i = 0; i < v.size(); ++i) out[i] = v[i];
    return out;
  };
  const MatrixX A = mat(j["A"]), C = mat(j["C"]), A_z = mat(j["A_z"]);
  ASSERT_EQ(C.rows(), six_n);
  ASSERT_EQ(C.cols(), n);
  // The printed A_z is [C]^T [A] [C] of the printed [A] and [C], and z dot solves it.
  EXPECT_LT((A_z - C.transpose() * A * C).cwiseAbs().maxCoeff(), 1e-12 * A.cwiseAbs().maxCoeff());
  EXPECT_LT((A_z * vec(j["zdot"]) - vec(j["f_z"])).norm(), 1e-10 * vec(j["f_z"]).norm());
  // A free tree prints no projected terms.
  const test::ToolRun plain =
      test::run_in(dir, "eom --json '" + test::kExamples + "/eight_body.yaml'");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_FALSE(nlohmann::json::parse(plain.out).contains("n"));
  // The pendulum: I_O theta'' = -m g l sin(theta).
  const test::ToolRun p = test::run_in(dir, "eom --json pendulum.yaml");
  ASSERT_EQ(p.exit_code, 0) << p.err;
  const auto pj = nlohmann::json::parse(p.out);
  EXPECT_NEAR(double(pj["zdot"][0]), -2.0 * 9.81 * 0.8 * std::sin(0.001) / (0.05 + 2.0 * 0.64),
              1e-15);
}

}  // namespace
}  // namespace kanedyn

namespace kanedyn {
namespace {

TEST(JointFiles, InfoPrintsEachBodysJointAndCoordinates) {
  const std::filesystem::path dir = test::temp_dir("joint_info");
  std::ofstream(dir / "jointed.yaml") << kJointed;
  const test::ToolRun run = test::run_in(dir, "info jointed.yaml");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("17 joint coordinates q, 15 independent speeds z"), std::string::npos)
      << run.out;
  for (const char* line :
       {"hinge              revolute     [0.4]", "cyl                cylindrical  [-0.2, 0.03]",
        "ball               spherical    [0, 0, 0.6, 0.8]", "welded             weld         none"})
    EXPECT_NE(run.out.find(line), std::string::npos) << line << "\n" << run.out;
  const test::ToolRun plain = test::run_in(dir, "info '" + test::kExamples + "/eight_body.yaml'");
  EXPECT_EQ(plain.out.find("joints:"), std::string::npos);
}

}  // namespace
}  // namespace kanedyn

namespace kanedyn {
namespace {

TEST(JointFiles, TheJointedExamplesRunWithTheirJointsHeld) {
  for (const char* name : {"human_jointed.yaml", "cart_pendulum.yaml"}) {
    SCOPED_TRACE(name);
    const io::ModelFile f = io::load_model_file(test::kExamples + "/" + name);
    ASSERT_TRUE(f.jointed());
    SimulationSettings s;
    s.t_end = 1.0;
    s.dt_out = 0.05;
    double worst = 0.0;
    long rows = 0;
    const Observer obs = [&](double, const State& state, const VectorX&, const VectorX&, Data&) {
      worst = std::max(worst, joint_violation(f.model, state));
      ++rows;
    };
    const SimulationStats stats = simulate(f.model, f.q, f.z, s, obs);
    ASSERT_TRUE(stats.ok()) << stats.message;
    EXPECT_EQ(rows, 21);
    EXPECT_LT(worst, 1e-13);  // round-off, as in the long run above
  }
}

}  // namespace
}  // namespace kanedyn

namespace kanedyn {
namespace {

TEST(JointFiles, InspectShowsTheJointsAndTheJointedYdot) {
  const std::filesystem::path dir = test::temp_dir("joint_inspect");
  const std::string model = "'" + test::kExamples + "/cart_pendulum.yaml'";
  const double h = 1e-4;
  ASSERT_EQ(test::run_in(dir, "simulate " + model +
                                  " -o run.csv --t-end 2e-4 --dt-out 1e-4 --integrator rk4 "
                                  "--step 1e-5")
                .exit_code,
            0);
  const test::ToolRun run =
      test::run_in(dir, "inspect --json " + model + " --trajectory run.csv --t 1e-4");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  ASSERT_TRUE(j.contains("joints"));
  const auto& joints = j["joints"];
  EXPECT_EQ(joints["n"], 2);
  EXPECT_EQ(joints["bodies"][1]["type"], "revolute");
  // Each body's w' is its rows of [C] times z.
  for (int k = 0; k < 2; ++k)
    for (int r = 0; r < 3; ++r) {
      double w = 0.0;
      for (int c = 0; c < 2; ++c)
        w += double(joints["bodies"][k]["C_w"][r][c]) * double(joints["z"][c]);
      EXPECT_NEAR(w, double(j["bodies"][k]["w"][r]), 1e-15);
    }
  // The jointed y dot against central differences of the CSV's y columns: truncation
  // h^2 / 6 |y'''| with |y'''| of order 100 here, 2e-7.
  const auto rows = test::read_csv(dir / "run.csv");
  ASSERT_EQ(rows.size(), 4u);
  const std::vector<std::string>& header = rows[0];
  const auto column = [&](const std::string& name) {
    return static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  const char* names[] = {"w1", "w2", "w3"};
  for (int k = 0; k < 2; ++k)
    for (int r = 0; r < 3; ++r) {
      const std::size_t c = column((k == 0 ? "cart." : "pendulum.") + std::string(names[r]));
      const double fd = (test::parse(rows[3][c]) - test::parse(rows[1][c])) / (2 * h);
      EXPECT_NEAR(fd, double(joints["ydot"][3 * k + r]), 1e-6) << k << " " << r;
    }
  for (int r = 0; r < 3; ++r) {
    const std::size_t c = column("cart.sd" + std::to_string(r + 1));
    const double fd = (test::parse(rows[3][c]) - test::parse(rows[1][c])) / (2 * h);
    EXPECT_NEAR(fd, double(joints["ydot"][6 + r]), 1e-6) << r;
  }
  // The text names every joint.
  const test::ToolRun text = test::run_in(dir, "inspect " + model);
  EXPECT_NE(text.out.find("body 2 'pendulum': revolute joint, q =  0.5"), std::string::npos)
      << text.out;
}

}  // namespace
}  // namespace kanedyn
