// Model files (docs/model-format.md): the examples load, values round-trip, axis-angle input
// gives the expected Euler parameters, and bad input is refused with a message naming the
// file, line:col, key path and problem.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include "../src/io/model_tree.hpp"
#include "file_support.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/model_file.hpp"
#include "sanitizers.hpp"

namespace kanedyn::io {
namespace {

using test::BadCase;
using test::edit;
using test::expect_refused;
using test::locate;
using test::Location;

const std::string kExamples = std::string(KANEDYN_SOURCE_DIR) + "/examples/";

// A small valid model; the bad inputs below are edits of it.
const std::string kBase = R"(format: kanedyn-model/1
name: two bodies
gravity: [0, 0, -9.81]
bodies:
  - name: pelvis
    parent: ground
    mass: 2.0
    inertia: [0.1, 0.2, 0.25]
    initial:
      euler_parameters: [0, 0, 0, 1]
  - name: thigh
    parent: pelvis
    mass: 1.0
    inertia: [0.01, 0.01, 0.015]
    joint: [0, 0, -0.5]
    initial:
      rotation: {axis: [0, 1, 0], angle: 0.3}
forces:
  - type: bushing
    body: thigh
    stiffness: 100
simulation:
  t_end: 1
  integrator: rk4
)";

/// `text` with the one occurrence of `from` replaced by `to`.

TEST(ModelFile, BaseTextIsValid) {
  const ModelFile f = parse_model_file(kBase, "base.yaml");
  EXPECT_EQ(f.model.num_bodies(), 2);
  EXPECT_EQ(f.path, "base.yaml");
}

TEST(ModelFile, LocateCountsFromOne) {
  // The helper itself: "b" of "a\nxb" is line 2, column 2.
  const Location loc = locate("a\nxb", "x^b");
  EXPECT_EQ(loc.line, 2);
  EXPECT_EQ(loc.column, 2);
  const Location first = locate("ab", "^a");
  EXPECT_EQ(first.line, 1);
  EXPECT_EQ(first.column, 1);
}

// ---- The examples -------------------------------------------------------------------------

void expect_eight_body(const ModelFile& f) {
  const Model& m = f.model;
  ASSERT_EQ(m.num_bodies(), 8);
  // L(K) = (0, 1, 2, 2, 1, 1, 1, 7), 1-based with 0 = ground; here 0-based with kGround.
  const std::vector<int> lower = {kGround, 0, 1, 1, 0, 0, 0, 6};
  const std::vector<int> depth = {0, 1, 2, 2, 1, 1, 1, 2};  // u_K of the notes
  for (int k = 0; k < 8; ++k) {
    EXPECT_EQ(m.lower_body(k), lower[static_cast<size_t>(k)]) << "body index " << k;
    EXPECT_EQ(m.depth(k), depth[static_cast<size_t>(k)]) << "body index " << k;
  }
  const std::vector<std::string> names = {"torso", "pelvis",    "right_leg",      "left_leg",
                                          "head",  "right_arm", "left_upper_arm", "left_forearm"};
  for (int k = 0; k < 8; ++k) EXPECT_EQ(m.body(k).name, names[static_cast<size_t>(k)]);
  EXPECT_EQ(m.gravity(), Vector3(0, 0, -9.81));
  // A bushing on every body, the root's to the ground.
  std::vector<int> bushings(8, 0);
  for (const auto& e : m.forces())
    if (e->type() == "bushing") ++bushings[static_cast<size_t>(e->body())];
  for (int k = 0; k < 8; ++k) EXPECT_EQ(bushings[static_cast<size_t>(k)], 1) << names[k];
  // A non-trivial initial state with unit Euler parameters (normalized: round-off only).
  const State& s = f.initial;
  ASSERT_EQ(s.num_bodies(), 8);
  int rotated = 0;
  for (int k = 0; k < 8; ++k) {
    EXPECT_NEAR(s.euler_parameters(k).norm(), 1.0, 1e-15);
    if (s.euler_parameters(k)[3] < 1.0 - 1e-6) ++rotated;
  }
  EXPECT_GE(rotated, 4);
  EXPECT_GT(s.x2().norm(), 0.0);  // translations
  EXPECT_GT(s.y1().norm(), 0.0);  // angular velocities
  EXPECT_GT(s.y2().norm(), 0.0);  // translation rates
  EXPECT_EQ(f.simulation.t_end, 10.0);
  EXPECT_EQ(f.simulation.dt_out, 0.01);
}

TEST(ModelFile, LoadsEightBodyYaml) {
  expect_eight_body(load_model_file(kExamples + "eight_body.yaml"));
}

TEST(ModelFile, LoadsEightBodyJson) {
  expect_eight_body(load_model_file(kExamples + "eight_body.json"));
}

// Both files spell the same decimal numbers, which parse to the same doubles: exact equality.
TEST(ModelFile, YamlAndJsonExamplesAreIdentical) {
  const ModelFile a = load_model_file(kExamples + "eight_body.yaml");
  const ModelFile b = load_model_file(kExamples + "eight_body.json");
  ASSERT_EQ(a.model.num_bodies(), b.model.num_bodies());
  EXPECT_EQ(a.model.name(), b.model.name());
  EXPECT_EQ(a.model.gravity(), b.model.gravity());
  for (int k = 0; k < a.model.num_bodies(); ++k) {
    const BodySpec& p = a.model.body(k);
    const BodySpec& q = b.model.body(k);
    EXPECT_EQ(p.name, q.name);
    EXPECT_EQ(p.lower_body, q.lower_body);
    EXPECT_EQ(p.mass, q.mass);
    EXPECT_EQ(p.inertia, q.inertia);
    EXPECT_EQ(p.com, q.com);
    EXPECT_EQ(p.joint, q.joint);
  }
  ASSERT_EQ(a.model.forces().size(), b.model.forces().size());
  for (size_t i = 0; i < a.model.forces().size(); ++i) {
    const auto* p = dynamic_cast<const Bushing*>(a.model.forces()[i].get());
    const auto* q = dynamic_cast<const Bushing*>(b.model.forces()[i].get());
    ASSERT_TRUE(p && q) << "forces[" << i << "]";
    EXPECT_EQ(p->body(), q->body());
    EXPECT_EQ(p->stiffness, q->stiffness);
    EXPECT_EQ(p->damping, q->damping);
    EXPECT_EQ(p->rotational_stiffness, q->rotational_stiffness);
    EXPECT_EQ(p->rotational_damping, q->rotational_damping);
  }
  EXPECT_EQ(a.initial.x, b.initial.x);
  EXPECT_EQ(a.initial.y, b.initial.y);
  EXPECT_EQ(a.simulation.t_end, b.simulation.t_end);
  EXPECT_EQ(a.simulation.dt_out, b.simulation.dt_out);
  EXPECT_EQ(a.simulation.integrator, b.simulation.integrator);
}

// ---- Values round-trip --------------------------------------------------------------------

// Every number below is compared with the same decimal literal compiled by C++: both are the
// correctly rounded double, so equality is exact.
TEST(ModelFile, ValuesRoundTrip) {
  const std::string text = R"(format: kanedyn-model/1
name: round trip
gravity: [+0.5, -1.25, -9.81]
bodies:
  - name: base-1
    parent: ground
    mass: 3.5
    inertia: [2.0, 3.0, 4.0, 0.1, -0.2, 0.3]
    com: [0.01, 0.02, 0.03]
    joint: [1, 2, 3]
    initial:
      euler_parameters: [0.5, 0.5, 0.5, 0.5]
      translation: [0.4, 0.5, 0.6]
      angular_velocity: [-1, 2, -3]
      translation_rate: [7, 8, 9]
  - name: arm_2
    parent: base-1
    mass: 1e-1
    inertia: [1.5e-3, 2.5E-3, 3.5e-3]
    com: [0, 0, -0.125]
    joint: [-0.5, 0, .25]
forces:
  - type: bushing
    body: arm_2
    stiffness: [10, 20, 30]
    damping: 0.75
  - type: bushing
    body: base-1
    rotational_stiffness: 44
    rotational_damping: 0.5
  - type: force
    body: arm_2
    value: [1, -2, 3]
  - type: torque
    body: base-1
    value: [0.25, 0.5, -0.75]
simulation:
  t_end: 2.5
  dt_out: 0.05
  integrator: rk4
  rtol: 1e-9
  atol: 1e-12
  step: 0.001
  method: kane
)";
  const ModelFile f = parse_model_file(text, "rt.yaml");
  const Model& m = f.model;
  EXPECT_EQ(m.name(), "round trip");
  EXPECT_EQ(m.gravity(), Vector3(0.5, -1.25, -9.81));
  ASSERT_EQ(m.num_bodies(), 2);

  const BodySpec& b0 = m.body(0);
  EXPECT_EQ(b0.name, "base-1");
  EXPECT_EQ(b0.lower_body, kGround);
  EXPECT_EQ(b0.mass, 3.5);
  Matrix3 inertia;  // products are the off-diagonal entries of the tensor
  inertia << 2.0, 0.1, -0.2, 0.1, 3.0, 0.3, -0.2, 0.3, 4.0;
  EXPECT_EQ(b0.inertia, inertia);
  EXPECT_EQ(b0.com, Vector3(0.01, 0.02, 0.03));
  EXPECT_EQ(b0.joint, Vector3(1, 2, 3));

  const BodySpec& b1 = m.body(1);
  EXPECT_EQ(b1.name, "arm_2");
  EXPECT_EQ(b1.lower_body, 0);
  EXPECT_EQ(b1.mass, 1e-1);
  EXPECT_EQ(b1.inertia, Vector3(1.5e-3, 2.5e-3, 3.5e-3).asDiagonal().toDenseMatrix());
  EXPECT_EQ(b1.com, Vector3(0, 0, -0.125));
  EXPECT_EQ(b1.joint, Vector3(-0.5, 0, 0.25));

  const State& s = f.initial;
  EXPECT_EQ(s.euler_parameters(0), Vector4(0.5, 0.5, 0.5, 0.5));  // unit already: exact
  EXPECT_EQ(s.translation(0), Vector3(0.4, 0.5, 0.6));
  EXPECT_EQ(s.angular_velocity(0), Vector3(-1, 2, -3));
  EXPECT_EQ(s.translation_rate(0), Vector3(7, 8, 9));
  // Body 2 has no `initial:`: identity, zero.
  EXPECT_EQ(s.euler_parameters(1), Vector4(0, 0, 0, 1));
  EXPECT_EQ(s.translation(1), Vector3::Zero());
  EXPECT_EQ(s.angular_velocity(1), Vector3::Zero());
  EXPECT_EQ(s.translation_rate(1), Vector3::Zero());

  ASSERT_EQ(m.forces().size(), 4u);
  const auto* k1 = dynamic_cast<const Bushing*>(m.forces()[0].get());
  ASSERT_NE(k1, nullptr);
  EXPECT_EQ(k1->body(), 1);
  EXPECT_EQ(k1->stiffness, Vector3(10, 20, 30));
  EXPECT_EQ(k1->damping, Vector3(0.75, 0.75, 0.75));  // a scalar means three equal
  EXPECT_EQ(k1->rotational_stiffness, 0.0);           // missing parts are 0
  EXPECT_EQ(k1->rotational_damping, 0.0);
  const auto* k2 = dynamic_cast<const Bushing*>(m.forces()[1].get());
  ASSERT_NE(k2, nullptr);
  EXPECT_EQ(k2->body(), 0);
  EXPECT_EQ(k2->stiffness, Vector3::Zero());
  EXPECT_EQ(k2->damping, Vector3::Zero());
  EXPECT_EQ(k2->rotational_stiffness, 44.0);
  EXPECT_EQ(k2->rotational_damping, 0.5);
  const auto* force = dynamic_cast<const ConstantForce*>(m.forces()[2].get());
  ASSERT_NE(force, nullptr);
  EXPECT_EQ(force->body(), 1);
  EXPECT_EQ(force->value, Vector3(1, -2, 3));
  const auto* torque = dynamic_cast<const ConstantTorque*>(m.forces()[3].get());
  ASSERT_NE(torque, nullptr);
  EXPECT_EQ(torque->body(), 0);
  EXPECT_EQ(torque->value, Vector3(0.25, 0.5, -0.75));

  const SimulationSection& sim = f.simulation;
  EXPECT_EQ(sim.t_end, 2.5);
  EXPECT_EQ(sim.dt_out, 0.05);
  EXPECT_EQ(sim.integrator, "rk4");
  EXPECT_EQ(sim.rtol, 1e-9);
  EXPECT_EQ(sim.atol, 1e-12);
  EXPECT_EQ(sim.step, 0.001);
  EXPECT_EQ(sim.route, "kane");
}

TEST(ModelFile, DefaultsWhenOptionalKeysAreAbsent) {
  const ModelFile f = parse_model_file(R"(format: kanedyn-model/1
bodies:
  - {name: a, parent: ground, mass: 1, inertia: [1, 1, 1]}
)",
                                       "min.yaml");
  EXPECT_EQ(f.model.name(), "");
  EXPECT_EQ(f.model.gravity(), Vector3::Zero());
  EXPECT_EQ(f.model.body(0).com, Vector3::Zero());
  EXPECT_EQ(f.model.body(0).joint, Vector3::Zero());
  EXPECT_TRUE(f.model.forces().empty());
  EXPECT_EQ(f.initial.x, State(1).x);
  EXPECT_EQ(f.initial.y, State(1).y);
  EXPECT_FALSE(f.simulation.t_end || f.simulation.dt_out || f.simulation.integrator ||
               f.simulation.rtol || f.simulation.atol || f.simulation.step || f.simulation.route);
}

// ---- Rotations ----------------------------------------------------------------------------

Vector4 initial_eps(const std::string& initial_block) {
  const ModelFile f = parse_model_file(
      "format: kanedyn-model/1\nbodies:\n  - name: a\n    parent: ground\n    mass: 1\n"
      "    inertia: [1, 1, 1]\n    initial:\n      " +
          initial_block + "\n",
      "rot.yaml");
  return f.initial.euler_parameters(0);
}

// Expected values from the definition eps = (sin(angle/2) axis/|axis|, cos(angle/2)); the
// two sides differ by a few roundings of O(1) numbers, hence 1e-15.
TEST(ModelFile, RotationAxisAngleGivesEulerParameters) {
  const Vector4 eps = initial_eps("rotation: {axis: [1, 2, 2], angle: 0.8}");
  const double s = std::sin(0.4), c = std::cos(0.4);
  EXPECT_NEAR(eps[0], s * 1.0 / 3.0, 1e-15);
  EXPECT_NEAR(eps[1], s * 2.0 / 3.0, 1e-15);
  EXPECT_NEAR(eps[2], s * 2.0 / 3.0, 1e-15);
  EXPECT_NEAR(eps[3], c, 1e-15);
}

TEST(ModelFile, RotationInDegrees) {
  // 90 degrees about z (axis not unit): (0, 0, sin 45deg, cos 45deg) = (0, 0, 1/sqrt2, 1/sqrt2).
  const Vector4 a = initial_eps("rotation: {axis: [0, 0, 2], angle_deg: 90}");
  EXPECT_NEAR(a[0], 0.0, 1e-15);
  EXPECT_NEAR(a[1], 0.0, 1e-15);
  EXPECT_NEAR(a[2], std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(a[3], std::sqrt(0.5), 1e-15);
  // 120 degrees about (1, 1, 1): sin 60deg / sqrt3 = 1/2 and cos 60deg = 1/2, exactly.
  const Vector4 b = initial_eps("rotation: {axis: [1, 1, 1], angle_deg: 120}");
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(b[i], 0.5, 1e-15);
  // A negative angle about -z is the same rotation as a positive one about +z.
  const Vector4 c = initial_eps("rotation: {axis: [0, 0, -1], angle: -0.6}");
  EXPECT_NEAR(c[2], std::sin(0.3), 1e-15);
  EXPECT_NEAR(c[3], std::cos(0.3), 1e-15);
}

TEST(ModelFile, EulerParametersWithinToleranceAreNormalizedSilently) {
  // |eps| - 1 = +4.8e-7 and -4.8e-7, both inside the 1e-6 tolerance.
  for (const double e4 : {0.8000006, 0.7999994}) {
    const Vector4 given(0.0, 0.6, 0.0, e4);
    ASSERT_LT(std::abs(given.norm() - 1.0), 1e-6);
    ASSERT_GT(std::abs(given.norm() - 1.0), 1e-7);
    Vector4 eps;
    ASSERT_NO_THROW(eps = initial_eps("euler_parameters: [0, 0.6, 0, " +
                                      std::string(e4 > 0.8 ? "0.8000006" : "0.7999994") + "]"));
    EXPECT_NEAR(eps.norm(), 1.0, 1e-15);
    // Same direction as given: the normalized input.
    const double n = std::sqrt(0.36 + e4 * e4);
    EXPECT_NEAR(eps[1], 0.6 / n, 1e-15);
    EXPECT_NEAR(eps[3], e4 / n, 1e-15);
    EXPECT_NE(eps[3], e4);  // it did change
  }
}

// ---- Bad input ----------------------------------------------------------------------------

std::vector<BadCase> bad_cases() {
  const std::string& b = kBase;
  return {
      {"missing format",
       edit(b, "format: kanedyn-model/1\n", ""),
       "^name: two",
       "format",
       {"missing", "format"}},
      {"wrong format",
       edit(b, "kanedyn-model/1", "kanedyn-model/2"),
       "format: ^kanedyn-model/2",
       "format",
       {"unsupported format", "kanedyn-model/1"}},
      {"unknown top-level key",
       edit(b, "gravity:", "gravty:"),
       "^gravty",
       "gravty",
       {"unknown key 'gravty'", "did you mean 'gravity'", "allowed keys", "bodies"}},
      {"unknown body key",
       edit(b, "mass: 2.0", "masss: 2.0"),
       "^masss",
       "bodies[0].masss",
       {"unknown key 'masss'", "did you mean 'mass'", "inertia"}},
      {"parent is a later body",
       edit(b, "parent: ground", "parent: thigh"),
       "parent: ^thigh",
       "bodies[0].parent",
       {"later", "earlier"}},
      {"parent unknown",
       edit(b, "parent: pelvis", "parent: torso"),
       "parent: ^torso",
       "bodies[1].parent",
       {"unknown parent 'torso'", "ground"}},
      {"parent is itself",
       edit(b, "parent: pelvis", "parent: thigh"),
       "parent: ^thigh",
       "bodies[1].parent",
       {"own parent"}},
      {"duplicate body name",
       edit(b, "name: thigh", "name: pelvis"),
       "^pelvis\n    parent: pelvis",
       "bodies[1].name",
       {"duplicate body name", "bodies[0]"}},
      {"body named ground",
       edit(b, "name: thigh", "name: ground"),
       "name: ^ground",
       "bodies[1].name",
       {"reserved"}},
      {"bad body name",
       edit(b, "name: thigh", "name: left thigh"),
       "^left thigh",
       "bodies[1].name",
       {"A-Za-z0-9_-"}},
      {"mass zero", edit(b, "mass: 2.0", "mass: 0"), "mass: ^0", "bodies[0].mass", {"> 0"}},
      {"mass negative",
       edit(b, "mass: 1.0", "mass: -1.0"),
       "mass: ^-1.0",
       "bodies[1].mass",
       {"> 0"}},
      {"mass missing",
       edit(b, "    mass: 1.0\n", ""),
       "- ^name: thigh",
       "bodies[1].mass",
       {"missing required key 'mass'"}},
      {"mass null",
       edit(b, "mass: 2.0", "mass:"),
       "^mass:\n",
       "bodies[0].mass",
       {"expected a number", "null"}},
      {"inertia not positive definite",
       edit(b, "inertia: [0.1, 0.2, 0.25]", "inertia: [1, 1, 1, 2, 0, 0]"),
       "inertia: ^[1, 1, 1",
       "bodies[0].inertia",
       {"positive definite"}},
      {"inertia violates the triangle inequality",
       edit(b, "inertia: [0.1, 0.2, 0.25]", "inertia: [0.1, 0.2, 0.4]"),
       "inertia: ^[0.1, 0.2, 0.4]",
       "bodies[0].inertia",
       {"triangle inequality"}},
      {"inertia of wrong length",
       edit(b, "inertia: [0.1, 0.2, 0.25]", "inertia: [0.1, 0.2]"),
       "inertia: ^[0.1, 0.2]",
       "bodies[0].inertia",
       {"3 numbers", "6 numbers", "list of 2"}},
      {"NaN", edit(b, "mass: 2.0", "mass: .nan"), "mass: ^.nan", "bodies[0].mass", {"non-finite"}},
      {"overflow to infinity",
       edit(b, "joint: [0, 0, -0.5]", "joint: [0, 0, 1e999]"),
       "^1e999",
       "bodies[1].joint[2]",
       {"non-finite"}},
      {"infinity",
       edit(b, "gravity: [0, 0, -9.81]", "gravity: [0, -.inf, -9.81]"),
       "^-.inf",
       "gravity[1]",
       {"non-finite"}},
      {"Euler parameter norm off",
       edit(b, "euler_parameters: [0, 0, 0, 1]", "euler_parameters: [0, 0, 0, 1.00001]"),
       "euler_parameters: ^[0, 0, 0, 1.00001]",
       "bodies[0].initial.euler_parameters",
       {"norm", "1e-06"}},
      {"Euler parameters and rotation",
       edit(b, "      euler_parameters: [0, 0, 0, 1]\n",
            "      euler_parameters: [0, 0, 0, 1]\n      rotation: {axis: [1, 0, 0], angle: 1}\n"),
       "      ^rotation: {axis: [1, 0, 0]",
       "bodies[0].initial",
       {"not both"}},
      {"unknown initial key",
       edit(b, "euler_parameters:", "euler_parameter:"),
       "^euler_parameter:",
       "bodies[0].initial.euler_parameter",
       {"unknown key", "did you mean 'euler_parameters'"}},
      {"rotation axis zero",
       edit(b, "axis: [0, 1, 0]", "axis: [0, 0, 0]"),
       "axis: ^[0, 0, 0]",
       "bodies[1].initial.rotation.axis",
       {"zero"}},
      {"rotation with angle and angle_deg",
       edit(b, "angle: 0.3}", "angle: 0.3, angle_deg: 17}"),
       "^angle_deg: 17",
       "bodies[1].initial.rotation",
       {"not both"}},
      {"unknown rotation key",
       edit(b, "angle: 0.3", "angel: 0.3"),
       "^angel",
       "bodies[1].initial.rotation.angel",
       {"unknown key", "angle_deg"}},
      {"string for a number",
       edit(b, "mass: 2.0", "mass: heavy"),
       "^heavy",
       "bodies[0].mass",
       {"expected a number", "heavy"}},
      {"quoted number",
       edit(b, "mass: 1.0", "mass: \"1.0\""),
       "mass: ^\"1.0\"",
       "bodies[1].mass",
       {"expected a number", "string"}},
      {"scalar for a list",
       edit(b, "joint: [0, 0, -0.5]", "joint: 0.5"),
       "joint: ^0.5",
       "bodies[1].joint",
       {"expected a list of 3 numbers"}},
      {"mapping for a list",
       edit(b, "gravity: [0, 0, -9.81]", "gravity: {x: 1}"),
       "gravity: ^{x: 1}",
       "gravity",
       {"expected a list of 3 numbers", "mapping"}},
      {"joint mapping with an unknown key",
       edit(b, "joint: [0, 0, -0.5]", "joint: {x: 1}"),
       "joint: {^x: 1}",
       "bodies[1].joint.x",
       {"unknown key 'x'", "allowed keys: at, type, frame, axis, axes"}},
      {"duplicate key",
       edit(b, "    mass: 1.0\n", "    mass: 1.0\n    mass: 1.5\n"),
       "^mass: 1.5",
       "bodies[1].mass",
       {"duplicate key 'mass'"}},
      {"bad force type",
       edit(b, "type: bushing", "type: sprung"),
       "^sprung",
       "forces[0].type",
       {"unknown force type 'sprung'", "bushing, force, torque, spring"}},
      {"force on an unknown body",
       edit(b, "body: thigh", "body: shin"),
       "body: ^shin",
       "forces[0].body",
       {"unknown body 'shin'", "pelvis"}},
      {"unknown force key",
       edit(b, "stiffness: 100", "stifness: 100"),
       "^stifness",
       "forces[0].stifness",
       {"did you mean 'stiffness'", "rotational_damping"}},
      {"negative stiffness",
       edit(b, "stiffness: 100", "stiffness: [1, -100, 1]"),
       "stiffness: ^[1, -100",
       "forces[0].stiffness",
       {">= 0"}},
      {"bad simulation.integrator",
       edit(b, "integrator: rk4", "integrator: euler"),
       "integrator: ^euler",
       "simulation.integrator",
       {"unknown integrator 'euler'", "dopri5", "rk4"}},
      {"non-positive simulation.t_end",
       edit(b, "t_end: 1", "t_end: 0"),
       "t_end: ^0",
       "simulation.t_end",
       {"> 0"}},
      {"unknown simulation key",
       edit(b, "t_end: 1\n", "t_end: 1\n  dt: 0.1\n"),
       "^dt: 0.1",
       "simulation.dt",
       {"unknown key", "dt_out"}},
      {"no bodies",
       "format: kanedyn-model/1\nbodies: []\n",
       "bodies: ^[]",
       "bodies",
       {"at least one body"}},
      {"not a mapping", "- 1\n- 2\n", "^- 1", "", {"must be a mapping"}},
      {"two documents",
       b + "---\nformat: kanedyn-model/1\n",
       "^---\nformat",
       "",
       {"more than one YAML document"}},
      // A stray ',' at the top level: a syntax error at its place, not an endless loop.
      {"stray comma at the top level",
       "# comment\n, 7\n" + b,
       "^, 7",
       "",
       {"YAML syntax error", "','"}},
      // A key with a control character: escaped, so the message stays on one line.
      {"tab in a key",
       edit(b, "gravity:", "\"gra\\tvity\":"),
       "^\"gra\\tvity\"",
       "gra\\tvity",
       {"unknown key 'gra\\tvity'", "did you mean 'gravity'"}},
      {"empty file", "", "", "", {"empty"}},
      {"comments only", "# nothing here\n", "", "", {"empty"}},
      {"JSON with a bad value",
       R"({"format": "kanedyn-model/1",
 "bodies": [{"name": "a", "parent": "ground", "mass": -1, "inertia": [1, 1, 1]}]})",
       "\"mass\": ^-1",
       "bodies[0].mass",
       {"> 0"}},
  };
}

TEST(ModelFile, BadInputsAreRefusedWithLocationKeyPathAndProblem) {
  const std::vector<BadCase> cases = bad_cases();
  ASSERT_GE(cases.size(), 15u);
  for (const BadCase& c : cases) expect_refused(c);
}

// The parser's own position is reported for syntax errors; check the line it names.
TEST(ModelFile, YamlSyntaxErrorReportsLineAndColumn) {
  const std::string text = edit(kBase, "    mass: 2.0\n", "\tmass: 2.0\n");  // tab indent
  const int line = locate(text, "^\tmass").line;
  try {
    parse_model_file(text, "bad.yaml");
    FAIL() << "accepted";
  } catch (const ModelFileError& e) {
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_GT(e.column(), 0);
    const std::string prefix = "bad.yaml:" + std::to_string(line) + ":";
    EXPECT_EQ(std::string(e.what()).substr(0, prefix.size()), prefix) << e.what();
    EXPECT_NE(e.problem().find("syntax"), std::string::npos) << e.what();
  }
  // An unclosed flow list: the error is at or after the line where the list opens.
  const std::string unclosed = edit(kBase, "gravity: [0, 0, -9.81]", "gravity: [0, 0, -9.81");
  try {
    parse_model_file(unclosed, "bad.yaml");
    FAIL() << "accepted";
  } catch (const ModelFileError& e) {
    EXPECT_GE(e.line(), locate(unclosed, "^gravity").line) << e.what();
    EXPECT_NE(e.problem().find("syntax"), std::string::npos) << e.what();
  }
}

TEST(ModelFile, MissingFileIsReportedWithItsPath) {
  const std::string path = "/nonexistent-kanedyn-dir/model.yaml";
  try {
    load_model_file(path);
    FAIL() << "accepted";
  } catch (const ModelFileError& e) {
    EXPECT_EQ(std::string(e.what()), path + ": cannot open: No such file or directory");
    EXPECT_EQ(e.line(), 0);
  }
}

TEST(ModelFile, ErrorsFromAFileNameThatFile) {
  const std::string path = ::testing::TempDir() + "kanedyn_bad_model.yaml";
  const std::string text = edit(kBase, "mass: 1.0", "mass: -3");
  std::ofstream(path) << text;
  try {
    load_model_file(path);
    FAIL() << "accepted";
  } catch (const ModelFileError& e) {
    const Location loc = locate(text, "mass: ^-3");
    const std::string prefix = path + ":" + std::to_string(loc.line) + ":" +
                               std::to_string(loc.column) + ": bodies[1].mass: ";
    EXPECT_EQ(std::string(e.what()).substr(0, prefix.size()), prefix) << e.what();
  }
  std::remove(path.c_str());
}

TEST(ModelFile, ErrorMessageFormat) {
  EXPECT_STREQ(ModelFileError("m.yaml", 3, 7, "bodies[2].mass", "must be > 0").what(),
               "m.yaml:3:7: bodies[2].mass: must be > 0");
  EXPECT_STREQ(ModelFileError("m.yaml", 0, 0, "", "cannot open: x").what(),
               "m.yaml: cannot open: x");
}

// ---- Limits, hostile input, and what messages may contain -----------------------------

/// The error `text` gives; a test failure if it is accepted.
ModelFileError error_of(const std::string& text, const std::string& name = "bad.yaml") {
  try {
    parse_model_file(text, name);
  } catch (const ModelFileError& e) {
    return e;
  }
  ADD_FAILURE() << "accepted";
  return ModelFileError(name, 0, 0, "", "accepted");
}

/// `s` with every byte outside printable ASCII as \xNN, for a trace.
std::string escaped(const std::string& s) {
  std::string out;
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u < 0x7f) {
      out += c;
    } else {
      char buffer[8];
      std::snprintf(buffer, sizeof buffer, "\\x%02x", u);
      out += buffer;
    }
  }
  return out;
}

/// Every message: one short line, no control characters (C0, DEL, C1 as UTF-8).
void expect_clean(const std::string& what) {
  EXPECT_LT(what.size(), 500u) << what.substr(0, 600);
  for (size_t i = 0; i < what.size(); ++i) {
    const auto c = static_cast<unsigned char>(what[i]);
    EXPECT_FALSE(c < 0x20 || c == 0x7f) << "byte " << int(c) << " at " << i << " in " << what;
    if (c == 0xc2 && i + 1 < what.size()) {
      EXPECT_FALSE(static_cast<unsigned char>(what[i + 1]) <= 0x9f) << "C1 control in " << what;
    }
  }
}

std::string body_line(int k, const std::string& parent) {
  return "  - {name: b" + std::to_string(k) + ", parent: " + parent +
         ", mass: 1, inertia: [1, 1, 1]}\n";
}

/// A chain of `n` bodies b0, b1, ... in flow style, one line each.
std::string chain_text(int n) {
  std::string text = "format: kanedyn-model/1\nbodies:\n";
  for (int k = 0; k < n; ++k) text += body_line(k, k == 0 ? "ground" : "b" + std::to_string(k - 1));
  return text;
}

TEST(ModelFile, FileLargerThanTheLimitIsRefusedWithoutReadingIt) {
  const std::string path = ::testing::TempDir() + "kanedyn_huge_model.yaml";
  std::ofstream(path) << "format: kanedyn-model/1\n";
  ASSERT_EQ(::truncate(path.c_str(), (off_t{256} << 20) + 1), 0);  // sparse: no disk used
  try {
    load_model_file(path);
    ADD_FAILURE() << "accepted";
  } catch (const ModelFileError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path + ": the file is larger than 256 MiB", 0), 0u)
        << e.what();
    EXPECT_EQ(e.line(), 0);
  }
  std::remove(path.c_str());
}

TEST(ModelFile, NonRegularFilesAreRefusedNotReadForever) {
  for (const std::string path : {"/dev/zero", "/dev/urandom"}) {
    try {
      load_model_file(path);
      ADD_FAILURE() << path << " accepted";
    } catch (const ModelFileError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << e.what();
      EXPECT_NE(e.problem().find("not a regular file"), std::string::npos) << e.what();
    }
  }
  // A FIFO without a writer: opening it for reading must not wait for one.
  const std::string fifo = ::testing::TempDir() + "kanedyn_model_fifo";
  std::remove(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    load_model_file(fifo);
    ADD_FAILURE() << "FIFO accepted";
  } catch (const ModelFileError& e) {
    EXPECT_NE(e.problem().find("not a regular file"), std::string::npos) << e.what();
  }
  std::remove(fifo.c_str());
}

#if KANEDYN_TEST_ADDRESS_SANITIZER || KANEDYN_TEST_THREAD_SANITIZER
#define KANEDYN_TEST_SANITIZED 1
#endif

/// In a death-test child: parses `text` with the address space capped 32 MB above what the
/// process uses, and exits 0 if that gave the out-of-memory ModelFileError. (Unused under the
/// sanitizers.)
[[noreturn, maybe_unused]] void load_with_little_memory(const std::string& text) {
  std::ifstream statm("/proc/self/statm");
  long pages = 0;
  statm >> pages;
  const rlim_t used = static_cast<rlim_t>(pages) * static_cast<rlim_t>(sysconf(_SC_PAGESIZE));
  const rlimit limit{used + (rlim_t{32} << 20), used + (rlim_t{32} << 20)};
  setrlimit(RLIMIT_AS, &limit);
  try {
    parse_model_file(text, "big.yaml");
  } catch (const ModelFileError& e) {
    _exit(std::string(e.what()) == "big.yaml: out of memory while loading the model file" ? 0 : 2);
  } catch (...) {
    _exit(3);
  }
  _exit(4);
}

// Out of memory while loading: a ModelFileError naming the file, not std::bad_alloc. The
// address space of a child process is capped just above what it uses (not under the
// sanitizers, which reserve terabytes of it).
TEST(ModelFile, OutOfMemoryIsAModelFileErrorNamingTheFile) {
#ifdef KANEDYN_TEST_SANITIZED
  GTEST_SKIP() << "address-space limits and sanitizers do not mix";
#else
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const std::string text = chain_text(200000);
  EXPECT_EXIT(load_with_little_memory(text), ::testing::ExitedWithCode(0), "");
#endif
}

TEST(ModelFile, NulByteIsNamedWithItsLineAndColumn) {
  const std::string text = edit(kBase, "name: two bodies", std::string("name: two\0bodies", 16));
  const ModelFileError e = error_of(text);
  expect_clean(e.what());
  EXPECT_EQ(e.line(), 2);
  EXPECT_EQ(e.column(), 10);
  EXPECT_NE(e.problem().find("NUL byte"), std::string::npos) << e.what();
}

TEST(ModelFile, MessagesCarryNoControlCharactersFromTheFile) {
  // Escapes in double quotes make control characters; the message shows them escaped.
  for (const std::string value :
       {"\"\\e[31mred\"", "\"a\\0b\"", "\"a\\rb\"", "\"a\\x85b\"", "\"a\\u2028b\"", "\"\\x7f\""}) {
    SCOPED_TRACE(value);
    const ModelFileError e = error_of(edit(kBase, "type: bushing", "type: " + value));
    expect_clean(e.what());
    EXPECT_EQ(e.key_path(), "forces[0].type");
  }
  // Raw control bytes in the file, refused by the parser: its message is escaped too.
  for (const std::string raw : {"\x1b[31m", "\x01", "\x08", "\x7f", "\xff"}) {
    SCOPED_TRACE(escaped(raw));
    const ModelFileError e = error_of(edit(kBase, "name: two bodies", "name: two" + raw));
    expect_clean(e.what());
    EXPECT_EQ(e.line(), 2) << e.what();
  }
  // The parser's own messages, too.
  const ModelFileError e = error_of(edit(kBase, "name: two bodies", "name: \"two\\q\""));
  expect_clean(e.what());
  EXPECT_NE(e.problem().find("syntax error"), std::string::npos) << e.what();
}

// Names are quoted cut short: a body named by a megabyte makes a short message, whether the
// loader or the Model refuses it, and a byte order mark or a bidirectional control inside a
// quoted value is shown escaped, not as an invisible character.
TEST(ModelFile, LongNamesAndInvisibleCharactersMakeShortVisibleMessages) {
  const std::string huge(1 << 20, 'n');
  for (const std::string& text :
       {edit(kBase, "name: pelvis", "name: " + huge),
        edit(kBase, "parent: pelvis", "parent: " + huge),
        edit(kBase, "body: thigh", "body: " + huge),
        edit(edit(kBase, "name: pelvis", "name: " + huge), "name: thigh", "name: " + huge)}) {
    const ModelFileError e = error_of(text);
    expect_clean(e.what());
  }
  for (const std::string value : {"\"\ufeffbushing\"", "\"bush\u202eing\"", "\"a\u200bb\""}) {
    SCOPED_TRACE(value);
    const ModelFileError e = error_of(edit(kBase, "type: bushing", "type: " + value));
    expect_clean(e.what());
    const std::string what = e.what();
    EXPECT_TRUE(what.find("\\ufeff") != std::string::npos ||
                what.find("\\u202e") != std::string::npos ||
                what.find("\\u200b") != std::string::npos)
        << what;
  }
}

// A file that is no mapping is no model file, whichever file the user named by mistake: its
// content is not quoted back.
TEST(ModelFile, PlainTextIsRefusedWithoutQuotingIt) {
  const ModelFileError e = error_of("root:x:0:0:root:/root:/bin/bash\nsecret words\n", "passwd");
  const std::string what = e.what();
  EXPECT_NE(what.find("must be a mapping"), std::string::npos) << what;
  EXPECT_NE(what.find("not shown"), std::string::npos) << what;
  EXPECT_EQ(what.find("root:x"), std::string::npos) << what;
  EXPECT_EQ(what.find("secret"), std::string::npos) << what;
}

// A number too small for a double underflows however it is written: with an exponent, or as
// 400 zeros after the point (once reported as overflowing).
TEST(ModelFile, NumbersOutOfRangeSayWhichWay) {
  for (const std::string& tiny : {std::string("1e-400"), "0." + std::string(400, '0') + "1",
                                  "-0.000" + std::string(400, '0') + "5e2"}) {
    const ModelFileError e = error_of(edit(kBase, "stiffness: 100", "stiffness: " + tiny));
    EXPECT_NE(e.problem().find("is too small for a double (it underflows)"), std::string::npos)
        << e.what();
  }
  for (const std::string& huge : {std::string("1e400"), "1" + std::string(400, '0'),
                                  std::string("0.001e312"), std::string("-0.01e311")}) {
    const ModelFileError e = error_of(edit(kBase, "stiffness: 100", "stiffness: " + huge));
    EXPECT_NE(e.problem().find("overflows a double"), std::string::npos) << e.what();
  }
}

TEST(ModelFile, NestingIsCappedWithoutRecursion) {
  for (const int depth : {65, 499, 200000}) {
    SCOPED_TRACE(depth);
    const std::string text = "format: kanedyn-model/1\nbodies: " + std::string(depth, '[') +
                             std::string(depth, ']') + "\n";
    const ModelFileError e = error_of(text);
    expect_clean(e.what());
    EXPECT_NE(e.problem().find("nesting deeper than 64 levels"), std::string::npos) << e.what();
    EXPECT_EQ(e.line(), 2);
    EXPECT_EQ(e.column(), 9 + 63);  // the 64th '[', the 65th level under the top mapping
  }
  // 64 levels are within the cap: the error is about the content.
  const ModelFileError e = error_of("format: kanedyn-model/1\nbodies: " + std::string(63, '[') +
                                    std::string(63, ']') + "\n");
  EXPECT_EQ(e.problem().find("nesting"), std::string::npos) << e.what();
}

TEST(ModelFile, UnknownParentOrBodyMessagesStayShort) {
  // Few bodies: all are listed.
  const ModelFileError few = error_of(chain_text(3) + body_line(3, "c1"));
  EXPECT_NE(few.problem().find("earlier body: b0, b1, b2"), std::string::npos) << few.what();
  // Many: the nearest, not the list.
  const std::string text = chain_text(100000) + body_line(100000, "b4242x");
  const ModelFileError many = error_of(text);
  expect_clean(many.what());
  EXPECT_EQ(many.key_path(), "bodies[100000].parent");
  EXPECT_NE(many.problem().find("did you mean 'b4242'?"), std::string::npos) << many.what();
  // The same for a force on an unknown body.
  const ModelFileError force =
      error_of(chain_text(1000) + "forces:\n  - {type: bushing, body: b77y}\n");
  expect_clean(force.what());
  EXPECT_EQ(force.key_path(), "forces[0].body");
  EXPECT_NE(force.problem().find("did you mean 'b77'?"), std::string::npos) << force.what();
}

TEST(ModelFile, ForceEntryWithAnUnknownKeyInsteadOfTypeNamesTheKey) {
  const std::string text = edit(kBase, "  - type: bushing", "  - kind: bushing");
  const ModelFileError e = error_of(text);
  EXPECT_EQ(e.key_path(), "forces[0].kind") << e.what();
  EXPECT_NE(e.problem().find("unknown key 'kind'"), std::string::npos) << e.what();
  EXPECT_NE(e.problem().find("type"), std::string::npos) << e.what();
  const Location loc = locate(text, "- ^kind");
  EXPECT_EQ(e.line(), loc.line);
  EXPECT_EQ(e.column(), loc.column);
}

std::string with_breaks(const std::string& text, const std::string& line_break) {
  std::string out;
  for (const char c : text) out += c == '\n' ? line_break : std::string(1, c);
  return out;
}

const std::string kBaseJson = R"({"format": "kanedyn-model/1",
 "bodies": [{"name": "a", "parent": "ground", "mass": 1,
             "inertia": [1, 1, 1]},
            {"name": "b", "parent": "a", "mass": 2, "inertia": [1, 1, 1]}]}
)";

TEST(ModelFile, CrCrlfAndLfLineBreaksAllLoadAndCountLines) {
  for (const std::string line_break : {"\n", "\r\n", "\r"}) {
    SCOPED_TRACE(escaped(line_break));
    EXPECT_EQ(parse_model_file(with_breaks(kBase, line_break), "b.yaml").model.num_bodies(), 2);
    EXPECT_EQ(parse_model_file(with_breaks(kBaseJson, line_break), "b.json").model.num_bodies(), 2);
    const std::string yaml = edit(kBase, "mass: 1.0", "mass: -1.0");
    const Location y = locate(yaml, "mass: ^-1.0");
    const ModelFileError ey = error_of(with_breaks(yaml, line_break));
    EXPECT_EQ(ey.line(), y.line) << ey.what();
    EXPECT_EQ(ey.column(), y.column) << ey.what();
    const std::string json = edit(kBaseJson, "\"mass\": 2", "\"mass\": -2");
    const Location j = locate(json, "\"mass\": ^-2");
    const ModelFileError ej = error_of(with_breaks(json, line_break));
    EXPECT_EQ(ej.line(), j.line) << ej.what();
    EXPECT_EQ(ej.column(), j.column) << ej.what();
    // A NUL byte's position is counted by the loader itself, the same way.
    const std::string nul = edit(kBase, "t_end: 1", std::string("t_end: 1\0", 9));
    const ModelFileError en = error_of(with_breaks(nul, line_break));
    EXPECT_EQ(en.line(), locate(kBase, "^t_end").line) << en.what();
  }
}

TEST(ModelFile, JsonAsUsersWriteIt) {
  // No spaces after ':' and ','.
  const std::string tight =
      R"({"format":"kanedyn-model/1","bodies":[{"name":"a","parent":"ground","mass":1,)"
      R"("inertia":[1,1,1],"initial":{"rotation":{"axis":[0,0,1],"angle_deg":90}}}]})";
  EXPECT_EQ(parse_model_file(tight, "t.json").model.num_bodies(), 1);
  // Tab indentation, also before the opening brace; escaped '/' in a string.
  const std::string tabs =
      "\t{\n\t\"format\": \"kanedyn-model/1\",\n\t\"name\": \"a\\/b\",\n\t\"bodies\": [\n"
      "\t\t{\"name\": \"a\",\t\"parent\": \"ground\", \"mass\": 1, \"inertia\": [1, 1, 1]}\n"
      "\t]\n}\n";
  const ModelFile f = parse_model_file(tabs, "t.json");
  EXPECT_EQ(f.model.name(), "a/b");
  const std::string bad = edit(tabs, "\"mass\": 1", "\"mass\": \"1\"");
  const ModelFileError e = error_of(bad, "t.json");
  EXPECT_NE(e.problem().find("quoted string"), std::string::npos) << e.what();
  EXPECT_EQ(e.line(), locate(bad, "^\t\t{\"name\"").line);
}

TEST(ModelFile, RotationAxisOfAnyNonZeroSizeIsADirection) {
  const Vector4 reference = initial_eps("rotation: {axis: [1, 0, 0], angle_deg: 90}");
  for (const std::string axis :
       {"[1e200, 0, 0]", "[1e-170, 0, 0]", "[1e-160, 0, 0]", "[1.7e308, 0, 0]", "[1e-300, 0, 0]"}) {
    SCOPED_TRACE(axis);
    const Vector4 eps = initial_eps("rotation: {axis: " + axis + ", angle_deg: 90}");
    EXPECT_NEAR(eps.norm(), 1.0, 1e-15);
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(eps[i], reference[i], 1e-15);
  }
  // Mixed sizes: the direction of (1e200, 1e200, 0) is that of (1, 1, 0).
  const Vector4 mixed = initial_eps("rotation: {axis: [1e200, 1e200, 0], angle: 1}");
  const Vector4 unit = initial_eps("rotation: {axis: [1, 1, 0], angle: 1}");
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(mixed[i], unit[i], 1e-15);
  EXPECT_NE(error_of(edit(kBase, "axis: [0, 1, 0]", "axis: [0, -0.0, 0]")).problem().find("zero"),
            std::string::npos);
}

TEST(ModelFile, LargeMappingsAreCheckedInLinearTime) {
  // 100,000 keys in one mapping: the duplicate at the end is found, and the first unknown key.
  std::string keys = "format: kanedyn-model/1\n";
  for (int k = 0; k < 100000; ++k) keys += "k" + std::to_string(k) + ": 1\n";
  const ModelFileError dup = error_of(keys + "k5: 2\n");
  EXPECT_EQ(dup.key_path(), "k5") << dup.what();
  EXPECT_NE(dup.problem().find("first given on line 7"), std::string::npos) << dup.what();
  EXPECT_EQ(dup.line(), 100002);
  const ModelFileError unknown = error_of(keys);
  EXPECT_EQ(unknown.key_path(), "k0") << unknown.what();
  expect_clean(unknown.what());
}

TEST(ModelFile, AliasesShareTheAnchoredValueAndNonStandardTagsAreRefused) {
  // An alias reads as the anchored value (YAML's meaning), with the key path of where it is
  // used; a value refused through an alias points at the anchored value.
  const ModelFile f = parse_model_file(
      edit(edit(kBase, "mass: 2.0", "mass: &m 2.0"), "mass: 1.0", "mass: *m"), "ok.yaml");
  EXPECT_EQ(f.model.body(1).mass, f.model.body(0).mass);
  const std::string bad = edit(edit(kBase, "mass: 2.0", "mass: &m -1.0"), "mass: 1.0", "mass: *m");
  const ModelFileError neg = error_of(bad);
  EXPECT_EQ(neg.key_path(), "bodies[0].mass") << neg.what();  // the anchor's own use first
  const ModelFileError unknown = error_of(edit(kBase, "mass: 1.0", "mass: *nothing"));
  EXPECT_NE(unknown.problem().find("alias '*nothing' names no anchor"), std::string::npos)
      << unknown.what();
  EXPECT_EQ(unknown.line(), locate(edit(kBase, "mass: 1.0", "mass: *nothing"), "mass: ^*").line);
  // A value holding an alias to itself would be a cycle: refused where the alias stands.
  const ModelFileError cycle =
      error_of(edit(kBase, "gravity: [0, 0, -9.81]", "gravity: &g [0, *g, 1]"));
  EXPECT_NE(cycle.problem().find("stands inside the value it names"), std::string::npos)
      << cycle.what();
  // Nested aliases (a "billion laughs") cost nothing: each names one shared node, and the
  // readers refuse the wrong shape at its first level.
  std::string laughs = kBase + "x0: &a0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n";
  for (int i = 1; i <= 9; ++i)
    laughs += "x" + std::to_string(i) + ": &a" + std::to_string(i) + " [" + [&] {
      std::string l;
      for (int k = 0; k < 10; ++k) l += (k ? ", *a" : "*a") + std::to_string(i - 1);
      return l;
    }() + "]\n";
  const ModelFileError bomb = error_of(laughs);
  EXPECT_NE(bomb.problem().find("unknown key 'x0'"), std::string::npos) << bomb.what();
  const std::string tag = edit(kBase, "mass: 1.0", "mass: !kg 1.0");
  const ModelFileError t = error_of(tag);
  EXPECT_NE(t.problem().find("tag '!kg'"), std::string::npos) << t.what();
  EXPECT_EQ(t.line(), locate(tag, "^mass: !kg").line);
  // The standard ones are accepted; !!str makes text, which is no number.
  EXPECT_NO_THROW(parse_model_file(edit(kBase, "mass: 1.0", "mass: !!float 1.0"), "ok.yaml"));
  const ModelFileError s = error_of(edit(kBase, "mass: 1.0", "mass: !!str 1.0"));
  EXPECT_NE(s.problem().find("quoted string"), std::string::npos) << s.what();
}

// ---- The fast front end against libyaml --------------------------------------------------

/// Both front ends on `text`: where the fast scanner reads it, the trees must be the same
/// node by node (positions too), and libyaml must read it as well. Returns whether the fast
/// scanner read it.
bool fast_reads(const std::string& text) {
  const detail::FrontEnds r = detail::compare_front_ends(text);
  EXPECT_EQ(r.difference, "") << escaped(text.substr(0, 300));
  if (r.fast_accepted) {
    EXPECT_TRUE(r.libyaml_accepted) << r.libyaml_error;
  }
  return r.fast_accepted;
}

std::string file_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(ModelFileFrontEnds, AgreeOnEveryCommittedModelFile) {
  namespace fs = std::filesystem;
  const std::string root = KANEDYN_SOURCE_DIR;
  size_t files = 0, read_fast = 0;
  for (const char* dir : {"/examples", "/fuzz/corpus", "/fuzz/regression"}) {
    std::vector<fs::path> paths;
    for (const auto& entry : fs::directory_iterator(root + dir))
      if (entry.is_regular_file()) paths.push_back(entry.path());
    std::sort(paths.begin(), paths.end());
    for (const fs::path& path : paths) {
      SCOPED_TRACE(path.string());
      const bool fast = fast_reads(file_text(path));
      ++files;
      read_fast += fast;
      // Every example model is in the subset: the fast scanner is what loads them.
      const std::string ext = path.extension().string();
      if (std::string(dir) == "/examples" && (ext == ".yaml" || ext == ".json")) {
        EXPECT_TRUE(fast);
      }
    }
  }
  EXPECT_GT(files, 60u);
  EXPECT_GT(read_fast, 40u);
}

TEST(ModelFileFrontEnds, AgreeOnGeneratedChainsAndTheBaseTexts) {
  EXPECT_TRUE(fast_reads(chain_text(500)));
  EXPECT_TRUE(fast_reads(kBase));
  EXPECT_TRUE(fast_reads(kBaseJson));
  EXPECT_TRUE(fast_reads(with_breaks(kBase, "\r\n")));
  EXPECT_TRUE(fast_reads(with_breaks(kBaseJson, "\r\n")));
  EXPECT_FALSE(fast_reads(with_breaks(kBase, "\r")));  // lone CR: libyaml's
}

TEST(ModelFileFrontEnds, AgreeOnTrickyTextsInTheSubset) {
  // Each is read by the fast scanner, and its tree must be libyaml's.
  const std::string f = "format: kanedyn-model/1\n";
  for (const std::string& text : std::vector<std::string>{
           f + "name: a # a comment at the end of a line\n",
           f + "# a comment line\n   # an indented one\n\nname: a\n",
           f + "gravity: []\nbodies: [ ]\nforces: {}\n", f + "\"quoted key\": 1\n\"k\" : 2\n",
           f + "name: \"a \\\"b\\\" \\\\ c \\/ d \\n \\t \\r \\b \\f\"\n",
           f + "name: \"\\\\\"\n",  // an escape whose value happens to stand in the text
           f + "x: [1e5, .5, -0, +1, -.5e-3, 1E+05, 0.1e2, 17.000000000000004]\n",
           f + "a key with spaces: 1\nkey  two : 2\n", f + "x: [a b, c  d ,e]\n",
           f + "x: null\ny: ~\nz: Null\nw: NULL\nv:\nu: [null, ~]\n", f + "~: 1\nnull: 2\n",
           f + "x:\n  - 1\n  -\n  - 2\n  - # comment\n  -\n",
           f + "x:\n- 1\n- a: 1\n  b: 2\n-\n  c: 3\ny: 2\n",
           f + "x:\n  a:\n    b:\n      c: 1\n  d: 2\n", f + "x:\ny:\n", f + "x:", f + "x: 1",
           f + "x: [1,\n  2,\n    3\n  ]\n", f + "x: {a: 1, b: [2, {c: 3}], \"d\":4}\n",
           f + "x: [ # comment\n  1, # another\n  2 ]\n", f + "x: {a:\n  1}\n",
           "- a\n- b: 1\n  c: 2\n-\n", "  format: kanedyn-model/1\n  name: indented root\n",
           "{\"format\":\"kanedyn-model/1\",\"x\":[1,2,{\"y\":[]}],\"z\":{}}",
           "{\n  \"format\": \"kanedyn-model/1\",\n  \"x\": [\n    1.5,\n    -2\n  ]\n}\n",
           "{\"a\": true, \"b\": false, \"c\": null}\n# after\n\n", "[1, 2]\n",
           f + "x: (a) b/c ~d e_f g.h\n",
           // UTF-8 in comments and quoted scalars: libyaml counts characters, not bytes.
           "# caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80\n" + f + "x:\ny: 1\n",
           f + "name: \"caf\xc3\xa9\"\nx: [1, \"\xe2\x82\xac\", 2]\ny:\n",
           f + "x: # \xc3\xa9\xc3\xa9\n  - # \xf0\x9f\x98\x80\n  -\ny: {\"\xc3\xa9\": 1, b: 2}\n",
           f + "\"cl\xc3\xa9\": 1\nz:\n- \"\xc3\xa9\": 2\n",
           f + "x: \"\xc3\xa9\\n\xc3\xa9\"\r\ny: 2 # \xc2\xa0\r\nz:\r\n",
           f + "x:\n- \"\xc3\xa9\": 1\n  b: 2\n",
           f + "x: - a\n",  // refused by libyaml; declined
       }) {
    SCOPED_TRACE(escaped(text));
    const bool fast = fast_reads(text);
    if (text.find("x: - a") == std::string::npos) {
      EXPECT_TRUE(fast);
    }
  }
}

TEST(ModelFileFrontEnds, TheFastScannerDeclinesWhatItIsNotSureAbout) {
  const std::string f = "format: kanedyn-model/1\n";
  for (const std::string& text : std::vector<std::string>{
           std::string(""),
           std::string("# only a comment\n"),
           "\xef\xbb\xbf" + f,
           f + "x: \t1\n",
           "\t" + f,
           f + "x: &a 1\ny: *a\n",
           f + "x: !!float 1\n",
           f + "x: 'single'\n",
           f + "x: |\n  block\n",
           f + "x: >\n  folded\n",
           f + "? x\n: 1\n",
           "%YAML 1.1\n---\n" + f,
           "---\n" + f,
           f + "...\n",
           f + "x: a\n  continued\n",
           f + "x: \"two\n  lines\"\n",
           f + "x: [a\n  b]\n",
           f + "x: [1, 2,]\n",
           f + "x: [1, , 2]\n",
           f + "x: {a}\n",
           f + "x: {a: }\n",
           f + "x: [a: 1]\n",
           f + "x: a:b\n",
           f + "x: {a:1}\n",
           f + "x: \"\\u00e9\"\n",
           f + "x: \"\\x41\"\n",
           f + "x: \"\\0\"\n",
           f + "x: caf\xc3\xa9\n",
           f + "# \xc2\x85\n",
           f + "x: \"\xe2\x80\xa8\"\n",
           f + "# \xef\xbb\xbf\n",
           f + "# \xc3\n",
           f + "# \xc2\x9f\n",
           f + "# \xed\xa0\x80\n",
           f + "# \xe0\x80\xaf\n",
           f + "x: \"\xef\xbf\xbf\"\n",

           f + "x: 1\ry: 2\n",
           f + "x: [1,\n2]\n",
           f + "- - a\n",
           f + "x: a, b\n",
           f + "x: \"a\"#c\n",
           f + "x: a#b\n",
           f + "x: 1\n y: 2\n",
           f + "x:\n  1\n",
           f + "x:\n    a: 1\n  b: 2\n",
           f + std::string(1100, 'k') + ": 1\n",
           "format: kanedyn-model/1\nbodies: " + std::string(64, '[') + std::string(64, ']') + "\n",
       }) {
    SCOPED_TRACE(escaped(text));
    EXPECT_FALSE(fast_reads(text));
  }
  // 63 levels under the top mapping are read (libyaml's limit is 64 open collections).
  EXPECT_TRUE(fast_reads("format: kanedyn-model/1\nbodies: " + std::string(63, '[') +
                         std::string(63, ']')));
}

/// What the loader makes of `text`: "accepted" and the number of bodies, or the message.
std::string outcome(const std::string& text, bool libyaml_only) {
  try {
    const ModelFile f = libyaml_only ? detail::parse_model_file_with_libyaml(text, "e.yaml")
                                     : parse_model_file(text, "e.yaml");
    return "accepted, N = " + std::to_string(f.model.num_bodies());
  } catch (const ModelFileError& e) {
    return e.what();
  }
}

TEST(ModelFileFrontEnds, AgreeOnEverySingleCharacterEditOfTheBaseTexts) {
  // Deletions, insertions of the characters that matter to YAML, and doubled characters: the
  // fast scanner either reads the result exactly as libyaml does or declines it.
  const std::string inserts = " -:,#[]{}\"\\\n.e0a~";
  size_t texts = 0, read_fast = 0;
  for (const std::string& base : {kBase, kBaseJson}) {
    for (size_t i = 0; i <= base.size(); ++i) {
      std::vector<std::string> variants;
      if (i < base.size()) {
        variants.push_back(base.substr(0, i) + base.substr(i + 1));
        variants.push_back(base.substr(0, i + 1) + base.substr(i));
      }
      for (const char c : inserts) variants.push_back(base.substr(0, i) + c + base.substr(i));
      for (const std::string& text : variants) {
        const detail::FrontEnds r = detail::compare_front_ends(text);
        ASSERT_EQ(r.difference, "") << escaped(text);
        // And the whole load: accepted or refused with the same message either way.
        if (r.fast_accepted) {
          ASSERT_EQ(outcome(text, false), outcome(text, true)) << escaped(text);
        }
        ++texts;
        read_fast += r.fast_accepted;
      }
    }
  }
  EXPECT_GT(read_fast, texts / 4);  // not a test of declining only
}

TEST(ModelFileFrontEnds, AFileTheFastScannerReadsIsRefusedWithLibyamlsMessage) {
  // Every refusal of the bad-input table and of the committed files, both ways.
  for (const BadCase& c : bad_cases())
    EXPECT_EQ(outcome(c.text, false), outcome(c.text, true)) << c.label;
  for (const char* dir : {"/fuzz/corpus", "/fuzz/regression"})
    for (const auto& entry :
         std::filesystem::directory_iterator(KANEDYN_SOURCE_DIR + std::string(dir)))
      if (entry.is_regular_file()) {
        const std::string text = file_text(entry.path());
        EXPECT_EQ(outcome(text, false), outcome(text, true)) << entry.path();
      }
  // The check fails on the fast scanner's tree; the message is the one the libyaml path gives
  // (line and column in characters as libyaml counts them), also after CRLF breaks.
  for (const std::string line_break : {"\n", "\r\n"}) {
    const std::string text = with_breaks(edit(kBase, "mass: 1.0", "mass: [1]"), line_break);
    ASSERT_TRUE(fast_reads(text));
    const ModelFileError e = error_of(text);
    const Location at = locate(edit(kBase, "mass: 1.0", "mass: [1]"), "mass: ^[1]");
    EXPECT_EQ(e.line(), at.line) << e.what();
    EXPECT_EQ(e.column(), at.column) << e.what();
    EXPECT_EQ(e.key_path(), "bodies[1].mass");
  }
}

}  // namespace
}  // namespace kanedyn::io
