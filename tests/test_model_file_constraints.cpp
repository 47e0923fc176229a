// The `constraints` and `independent_speeds` sections of model files (docs/model-format.md,
// "Constraints"): every type with every key, the defaults, every refusal as a one-line message
// naming the file, line, column, key path and problem, the round trip through the writer, and
// a study's key paths into constraints.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "../src/io/model_tree.hpp"
#include "file_support.hpp"
#include "kanedyn/analysis.hpp"
#include "kanedyn/constraint.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/model_writer.hpp"

namespace kanedyn::io {
namespace {

using test::BadCase;
using test::edit;
using test::expect_refused;
using test::locate;
using test::Location;

// A bicycle-like tree: a free frame, a fork on a revolute joint, two wheels on revolute
// joints, an arm on a spherical joint, and a free lever; every constraint type, with every key
// given. Every constraint holds at the initial state, each closing its own loop: the rear
// wheel touches the plane (its centre 0.395 + 0.03 high, radius 0.3: the plane at 0.125); the
// fork's point and the arm's meet at the frame's [1, 0, 0], off the fork's stationary angle;
// the lever, turned a quarter turn about z, has its point at [1, 0, 0] and its x axis along
// the ground's y; the front wheel's point and the frame's origin are 1.2 apart (0.72, 0,
// -0.96). The independent speeds are the frame's rotation and the rear wheel's (the rolling
// contact leaves those), the arm's spin, and the lever's turn about the hinge. The frame's
// initial speeds are not on the constraints: the loader projects them.
const std::string kBase = R"(format: kanedyn-model/1
gravity: [0, 0, -9.81]
bodies:
  - name: frame
    parent: ground
    mass: 10.0
    inertia: [1, 1, 1]
    joint: [0, 0, 0.395]
    initial: {angular_velocity: [0.1, 0.2, 0.3], translation_rate: [1, 0, 0.05]}
  - name: rear_wheel
    parent: frame
    mass: 2.0
    inertia: [0.1, 0.2, 0.1]
    joint: {at: [-0.5, 0, 0], type: revolute, axis: [0, 1, 0]}
    initial: {joint_rate: [-3.0]}
  - name: fork
    parent: frame
    mass: 1.0
    inertia: [0.1, 0.1, 0.1]
    joint: {at: [0.5, 0, 0], type: revolute, axis: [0, 0, 1]}
  - name: front_wheel
    parent: fork
    mass: 2.0
    inertia: [0.1, 0.2, 0.1]
    joint: {type: revolute, axis: [0, 1, 0]}
  - name: arm
    parent: frame
    mass: 1.0
    inertia: [0.1, 0.1, 0.1]
    joint: {at: [1.0, -0.2, -0.4], type: spherical}
  - name: lever
    parent: ground
    mass: 1.0
    inertia: [0.1, 0.1, 0.1]
    joint: [1.0, -0.25, 0]
    initial: {rotation: {axis: [0, 0, 1], angle: 1.5707963267948966}}
constraints:
  - name: rear_contact
    type: rolling_disc
    body: rear_wheel
    center: [0.01, 0.02, 0.03]
    axis: [0, 2, 0]
    radius: 0.3
    plane: {normal: [0, 0, 3], offset: 0.125}
  - name: pin
    type: ball
    body: fork
    at: [0.5, 0, 0]
    other: arm
    other_at: [0, 0.2, 0.4]
  - name: axle
    type: hinge
    body: lever
    at: [0.25, 0, 0]
    axis: [1, 0, 0]
    other: ground
    other_at: [1.0, 0, 0]
    other_axis: [0, 1, 0]
  - name: rod
    type: distance
    body: front_wheel
    at: [0.22, 0, -0.96]
    other: frame
    other_at: [0, 0, 0]
    length: 1.2
independent_speeds: [frame.w1, frame.w2, rear_wheel.jd1, arm.w3, lever.w1, frame.w3]
)";

/// kBase's independent speeds, as written there.
const std::string kSpeeds = "[frame.w1, frame.w2, rear_wheel.jd1, arm.w3, lever.w1, frame.w3]";

const Constraint& named(const Model& m, const std::string& name) {
  const int i = m.constraint_index(name);
  EXPECT_GE(i, 0) << name;
  return m.constraints()[static_cast<size_t>(i)];
}

TEST(ModelFileConstraints, EveryTypeWithEveryKey) {
  const ModelFile file = parse_model_file(kBase, "bike.yaml");
  const Model& m = file.model;
  ASSERT_EQ(m.num_constraints(), 4);
  EXPECT_EQ(m.constraints()[0].name, "rear_contact");  // in the order given
  EXPECT_EQ(m.constraints()[3].name, "rod");

  const Constraint& disc = named(m, "rear_contact");
  EXPECT_EQ(disc.type, ConstraintType::rolling_disc);
  EXPECT_EQ(disc.body, m.body_index("rear_wheel"));
  EXPECT_EQ(disc.at, Vector3(0.01, 0.02, 0.03));  // `center` goes to `at`
  EXPECT_EQ(disc.axis, Vector3(0, 1, 0));         // normalized
  EXPECT_EQ(disc.radius, 0.3);
  EXPECT_EQ(disc.plane_normal, Vector3(0, 0, 1));
  EXPECT_EQ(disc.plane_offset, 0.125);

  const Constraint& pin = named(m, "pin");
  EXPECT_EQ(pin.type, ConstraintType::ball);
  EXPECT_EQ(pin.body, m.body_index("fork"));
  EXPECT_EQ(pin.at, Vector3(0.5, 0, 0));
  EXPECT_EQ(pin.other, m.body_index("arm"));
  EXPECT_EQ(pin.other_at, Vector3(0, 0.2, 0.4));

  const Constraint& axle = named(m, "axle");
  EXPECT_EQ(axle.type, ConstraintType::hinge);
  EXPECT_EQ(axle.body, m.body_index("lever"));
  EXPECT_EQ(axle.at, Vector3(0.25, 0, 0));
  EXPECT_EQ(axle.axis, Vector3(1, 0, 0));
  EXPECT_EQ(axle.other, kGround);
  EXPECT_EQ(axle.other_at, Vector3(1.0, 0, 0));
  EXPECT_EQ(axle.other_axis, Vector3(0, 1, 0));

  const Constraint& rod = named(m, "rod");
  EXPECT_EQ(rod.type, ConstraintType::distance);
  EXPECT_EQ(rod.body, m.body_index("front_wheel"));
  EXPECT_EQ(rod.at, Vector3(0.22, 0, -0.96));
  EXPECT_EQ(rod.other, m.body_index("frame"));
  EXPECT_EQ(rod.other_at, Vector3(0, 0, 0));
  EXPECT_EQ(rod.length, 1.2);

  // z: frame w1..3 sd1..3 (0-5), rear_wheel jd1 (6), fork jd1 (7), front_wheel jd1 (8),
  // arm w1..3 (9-11), lever w1..3 sd1..3 (12-17). A set: the order given does not matter.
  EXPECT_EQ(m.independent_speeds(), (std::vector<int>{0, 1, 2, 6, 11, 12}));
  // 12 independent equations (3 + 3 + 5 + 1) leave these 6 free, and the others follow.
  EXPECT_EQ(file.partition.rank, 12);
  EXPECT_TRUE(file.partition.redundant_rows.empty());
  EXPECT_EQ(file.partition.independent, m.independent_speeds());
}

// Mechanisms of one degree of freedom in which every speed moves, so that each speed alone is
// a valid choice of the independent speeds: a free body hinged to the ground on a skew axis
// (its speeds w1..3, sd1..3), a crank and a link on revolute joints with the link's end at a
// fixed distance from a ground point (jd1), and a body on a spherical joint with one of its
// points held by a ball (w1..3; the ball's third row is redundant there).
const std::vector<std::string> kOneFreeSpeed = {
    R"(format: kanedyn-model/1
bodies:
  - {name: frame, parent: ground, mass: 1, inertia: [1, 1, 1], joint: [0.1, 0.2, 0.3]}
constraints:
  - {name: h, type: hinge, body: frame, at: [0.3, -0.2, 0.5], axis: [1, 2, 3],
     other_at: [0.4, 0, 0.8], other_axis: [1, 2, 3]}
)",
    R"(format: kanedyn-model/1
bodies:
  - {name: crank, parent: ground, mass: 1, inertia: [1, 1, 1],
     joint: {type: revolute, axis: [0, 0, 1]}}
  - {name: link, parent: crank, mass: 1, inertia: [1, 1, 1],
     joint: {at: [1, 0, 0], type: revolute, axis: [0, 0, 1]}}
constraints:
  - {name: d, type: distance, body: link, at: [1, 0, 0], other_at: [1.4, 0.8, 0], length: 1}
)",
    R"(format: kanedyn-model/1
bodies:
  - {name: arm, parent: ground, mass: 1, inertia: [1, 1, 1], joint: {type: spherical}}
constraints:
  - {name: b, type: ball, body: arm, at: [1, 2, 3], other_at: [1, 2, 3]}
)"};

TEST(ModelFileConstraints, SpeedNamesAreTheLinearizationsAndMapToTheirIndex) {
  std::vector<std::string> seen;
  for (const std::string& base : kOneFreeSpeed) {
    const ModelFile file = parse_model_file(base, "one.yaml");
    ASSERT_EQ(file.partition.independent.size(), 1u) << base;
    const std::vector<std::string> state = tangent_state_names(file.model);
    const int n = file.model.num_speeds();
    ASSERT_EQ(state.size(), static_cast<size_t>(2 * n));
    for (int i = 0; i < n; ++i) {
      const std::string& speed = state[static_cast<size_t>(n + i)];
      SCOPED_TRACE(speed);
      seen.push_back(speed);
      const ModelFile chosen =
          parse_model_file(base + "independent_speeds: [" + speed + "]\n", "one.yaml");
      EXPECT_EQ(chosen.model.independent_speeds(), std::vector<int>{i});
      EXPECT_EQ(chosen.partition.independent, std::vector<int>{i});
    }
  }
  // Every kind of speed name: a free body's, a 1-DOF joint's, a spherical joint's.
  EXPECT_EQ(seen, (std::vector<std::string>{"frame.w1", "frame.w2", "frame.w3", "frame.sd1",
                                            "frame.sd2", "frame.sd3", "crank.jd1", "link.jd1",
                                            "arm.w1", "arm.w2", "arm.w3"}));
}

TEST(ModelFileConstraints, IndependentSpeedsOfTheWrongCountAreRefusedAtTheKey) {
  expect_refused({"one speed",
                  edit(kBase, kSpeeds, "[frame.w1]"),
                  "independent_speeds: ^[frame.w1]",
                  "independent_speeds",
                  {"1 speeds given, but the 12 independent constraint equations leave 6 speeds "
                   "free"}});
  expect_refused({"seven speeds",
                  edit(kBase, kSpeeds,
                       "[frame.w1, frame.w2, frame.w3, frame.sd1, rear_wheel.jd1, "
                       "arm.w3, lever.w1]"),
                  "independent_speeds: ^[frame.w1",
                  "independent_speeds",
                  {"7 speeds given, but the 12 independent constraint equations leave 6 speeds "
                   "free"}});
  // In a mechanism of one degree of freedom, two speeds are one too many.
  expect_refused({"two of one",
                  kOneFreeSpeed[0] + "independent_speeds: [frame.w1, frame.sd1]\n",
                  "independent_speeds: ^[frame.w1",
                  "independent_speeds",
                  {"2 speeds given, but the 5 independent constraint equations leave 1 speeds "
                   "free"}});
  // Every speed of the four-bar, and two of its three: refused at the key, before the
  // projection (which once crashed on the first, and blamed the initial state on the second).
  const std::string four_bar = test::slurp(KANEDYN_SOURCE_DIR "/examples/four_bar.yaml");
  expect_refused({"every speed",
                  edit(four_bar, "independent_speeds: [crank.jd1]",
                       "independent_speeds: [crank.jd1, coupler.jd1, rocker.jd1]"),
                  "independent_speeds: ^[crank.jd1",
                  "independent_speeds",
                  {"3 speeds given, but the 2 independent constraint equations leave 1 speeds "
                   "free"}});
  expect_refused({"two of three",
                  edit(four_bar, "independent_speeds: [crank.jd1]",
                       "independent_speeds: [crank.jd1, rocker.jd1]"),
                  "independent_speeds: ^[crank.jd1",
                  "independent_speeds",
                  {"2 speeds given, but the 2 independent constraint equations leave 1 speeds "
                   "free"}});
}

TEST(ModelFileConstraints, IndependentSpeedsThatLeaveTheOthersUndeterminedAreRefused) {
  // With the arm's w1 kept instead of its w3, the pin's rows would have to be solved for the
  // fork's rate and the arm's w2 and w3; the point the pin holds is at (0, 0.2, 0.4) on the arm,
  // and turning the arm about its x or z axis both move it along x only.
  expect_refused(
      {"arm.w1 for arm.w3",
       edit(kBase, "arm.w3,", "arm.w1,"),
       "independent_speeds: ^[frame.w1",
       "independent_speeds",
       {"the constraints do not determine the other speeds from these", "choose others"}});
  // The rod holds the front wheel's angle: its rate cannot be independent.
  expect_refused({"the front wheel's",
                  edit(kBase, "lever.w1,", "front_wheel.jd1,"),
                  "independent_speeds: ^[frame.w1",
                  "independent_speeds",
                  {"the constraints do not determine the other speeds from these"}});
}

// Each constraint with its optional keys left out, on bodies placed where it holds: a disc of
// radius 0.5 centred 0.5 above the default plane z = 0, one 2.5 high over the plane z = 2 (b
// is 2 above a), one 0.5 from the plane x = 0; d and e at the origin, where the ball and the
// hinge put them; f 2 from the origin.
const std::string kDefaults = R"(format: kanedyn-model/1
bodies:
  - {name: a, parent: ground, mass: 1, inertia: [1, 1, 1], joint: [0, 0, 0.5]}
  - {name: b, parent: a, mass: 1, inertia: [1, 1, 1], joint: [0, 0, 2]}
  - {name: c, parent: ground, mass: 1, inertia: [1, 1, 1], joint: [0.5, 0, 0]}
  - {name: d, parent: ground, mass: 1, inertia: [1, 1, 1]}
  - {name: e, parent: ground, mass: 1, inertia: [1, 1, 1]}
  - {name: f, parent: ground, mass: 1, inertia: [1, 1, 1], joint: [2, 0, 0]}
constraints:
  - {name: disc, type: rolling_disc, body: a, axis: [0, 1, 0], radius: 0.5}
  - {name: disc2, type: rolling_disc, body: b, axis: [0, 1, 0], radius: 0.5, plane: {offset: 2}}
  - {name: disc3, type: rolling_disc, body: c, axis: [0, 1, 0], radius: 0.5, plane: {normal: [1, 0, 0]}}
  - {name: ball, type: ball, body: d}
  - {name: hinge, type: hinge, body: e, axis: [0, 0, 1], other_axis: [0, 0, 1]}
  - {name: rod, type: distance, body: f, length: 2}
)";

TEST(ModelFileConstraints, Defaults) {
  const ModelFile file = parse_model_file(kDefaults, "d.yaml");
  const Model& m = file.model;
  ASSERT_EQ(m.num_constraints(), 6);
  const Constraint& disc = named(m, "disc");
  EXPECT_EQ(disc.at, Vector3::Zero());
  EXPECT_EQ(disc.plane_normal, Vector3::UnitZ());
  EXPECT_EQ(disc.plane_offset, 0.0);
  EXPECT_EQ(named(m, "disc2").plane_normal, Vector3::UnitZ());
  EXPECT_EQ(named(m, "disc2").plane_offset, 2.0);
  EXPECT_EQ(named(m, "disc3").plane_normal, Vector3::UnitX());
  EXPECT_EQ(named(m, "disc3").plane_offset, 0.0);
  for (const char* name : {"ball", "hinge", "rod"}) {
    SCOPED_TRACE(name);
    const Constraint& c = named(m, name);
    EXPECT_EQ(c.at, Vector3::Zero());
    EXPECT_EQ(c.other, kGround);
    EXPECT_EQ(c.other_at, Vector3::Zero());
  }
  // None named: the Model keeps none, and the loader chose them at the initial state by
  // pivoting, n - r of them (36 speeds, 3 + 3 + 3 + 3 + 5 + 1 equations).
  EXPECT_TRUE(m.independent_speeds().empty());
  EXPECT_EQ(file.partition.rank, 18);
  EXPECT_EQ(file.partition.independent.size(), 18u);
  // Already on the constraints: the projection changed nothing.
  EXPECT_EQ(file.projection.coordinate_change, 0.0);
  // No constraints: the sections are optional.
  const ModelFile none = parse_model_file(
      "format: kanedyn-model/1\nbodies:\n  - {name: a, parent: ground, mass: 1, inertia: [1, 1, "
      "1]}\n",
      "n.yaml");
  EXPECT_EQ(none.model.num_constraints(), 0);
  EXPECT_TRUE(none.model.independent_speeds().empty());
}

/// kBase with `from` (unique) made `to`.
std::string base_with(const std::string& from, const std::string& to) {
  return edit(kBase, from, to);
}

std::vector<BadCase> bad_cases() {
  const std::string b = kBase;
  return {
      {"unknown key, with its nearest",
       base_with("    radius: 0.3\n", "    radius: 0.3\n    raduis: 1\n"),
       "^raduis",
       "constraints[0].raduis",
       {"unknown key 'raduis'", "did you mean 'radius'?", "allowed keys: name, type, body"}},
      {"a key of another type",
       base_with("    length: 1.2\n", "    length: 1.2\n    radius: 0.3\n"),
       "length: 1.2\n    ^radius",
       "constraints[3].radius",
       {"'radius' is refused on a distance constraint", "it is for rolling_disc",
        "allowed keys: name, type, body, at, other, other_at, length"}},
      {"missing name",
       base_with("  - name: pin\n    type: ball", "  - type: ball"),
       "  - ^type: ball",
       "constraints[1].name",
       {"missing required key 'name'"}},
      {"bad name",
       base_with("name: pin", "name: \"p in\""),
       "name: ^\"p in\"",
       "constraints[1].name",
       {"constraint name 'p in'", "[A-Za-z0-9_-]"}},
      {"duplicate name",
       base_with("name: rod", "name: pin"),
       "name: ^pin\n    type: distance",
       "constraints[3].name",
       {"duplicate constraint name 'pin'", "constraints[1]"}},
      {"missing type",
       base_with("    type: ball\n", ""),
       "  - ^name: pin",
       "constraints[1].type",
       {"missing required key 'type'"}},
      {"unknown type",
       base_with("type: ball", "type: balll"),
       "type: ^balll",
       "constraints[1].type",
       {"unknown constraint type 'balll'", "allowed: rolling_disc, ball, hinge, distance"}},
      {"missing body",
       base_with("    body: fork\n", ""),
       "  - ^name: pin",
       "constraints[1].body",
       {"missing required key 'body'"}},
      {"unknown body",
       base_with("body: fork\n    at", "body: frok\n    at"),
       "body: ^frok",
       "constraints[1].body",
       {"unknown body 'frok'", "bodies: frame"}},
      {"ground as body",
       base_with("body: fork\n    at", "body: ground\n    at"),
       "body: ^ground\n    at: [0.5",
       "constraints[1].body",
       {"not on the ground", "ground as 'other'"}},
      {"unknown other",
       base_with("other: arm", "other: amr"),
       "other: ^amr",
       "constraints[1].other",
       {"unknown body 'amr'"}},
      {"other is body",
       base_with("other: arm", "other: fork"),
       "other: ^fork",
       "constraints[1].other",
       {"own body 'fork'", "another body, or ground"}},
      {"disc without axis",
       base_with("    axis: [0, 2, 0]\n", ""),
       "  - ^name: rear_contact",
       "constraints[0].axis",
       {"missing required key 'axis'", "rolling_disc"}},
      {"disc without radius",
       base_with("    radius: 0.3\n", ""),
       "  - ^name: rear_contact",
       "constraints[0].radius",
       {"missing required key 'radius'", "rolling_disc"}},
      {"zero radius",
       base_with("radius: 0.3", "radius: 0"),
       "radius: ^0",
       "constraints[0].radius",
       {"must be > 0"}},
      {"zero axle",
       base_with("axis: [0, 2, 0]", "axis: [0, 0, 0]"),
       "axis: ^[0, 0, 0]",
       "constraints[0].axis",
       {"must not be zero"}},
      {"zero normal",
       base_with("normal: [0, 0, 3]", "normal: [0, 0, 0]"),
       "normal: ^[0, 0, 0]",
       "constraints[0].plane.normal",
       {"must not be zero"}},
      {"unknown plane key",
       base_with("offset: 0.125", "ofset: 0.125"),
       "^ofset",
       "constraints[0].plane.ofset",
       {"unknown key 'ofset'", "did you mean 'offset'?"}},
      {"plane not a mapping",
       base_with("plane: {normal: [0, 0, 3], offset: 0.125}", "plane: 1"),
       "plane: ^1",
       "constraints[0].plane",
       {"expected a mapping"}},
      {"bad offset",
       base_with("offset: 0.125", "offset: x"),
       "offset: ^x",
       "constraints[0].plane.offset",
       {"expected a number, got 'x'"}},
      {"hinge without axis",
       base_with("    axis: [1, 0, 0]\n", ""),
       "  - ^name: axle",
       "constraints[2].axis",
       {"missing required key 'axis'", "hinge"}},
      {"hinge without other_axis",
       base_with("    other_axis: [0, 1, 0]\n", ""),
       "  - ^name: axle",
       "constraints[2].other_axis",
       {"missing required key 'other_axis'", "hinge"}},
      {"zero other_axis",
       base_with("other_axis: [0, 1, 0]", "other_axis: [0, 0, 0]"),
       "other_axis: ^[0, 0, 0]",
       "constraints[2].other_axis",
       {"must not be zero"}},
      {"short at",
       base_with("at: [0.25, 0, 0]", "at: [0.25, 0]"),
       "at: ^[0.25, 0]",
       "constraints[2].at",
       {"expected a list of 3 numbers"}},
      {"bad other_at",
       base_with("other_at: [0, 0.2, 0.4]", "other_at: [0, 0.2, .inf]"),
       "other_at: [0, 0.2, ^.inf]",
       "constraints[1].other_at[2]",
       {"non-finite number"}},
      {"distance without length",
       base_with("    length: 1.2\n", ""),
       "  - ^name: rod",
       "constraints[3].length",
       {"missing required key 'length'", "distance"}},
      {"negative length",
       base_with("length: 1.2", "length: -1.2"),
       "length: ^-1.2",
       "constraints[3].length",
       {"must be > 0"}},
      {"constraints not a list",
       b.substr(0, b.find("constraints:")) + "constraints: {name: pin}\n",
       "constraints: ^{",
       "constraints",
       {"expected a list of constraint entries"}},
      {"entry not a mapping",
       base_with("constraints:\n  - name: rear_contact",
                 "constraints:\n  - 3\n  - name: rear_contact"),
       "  - ^3",
       "constraints[0]",
       {"expected a mapping"}},
      {"unknown speed",
       base_with("frame.w2,", "fork.jd2,"),
       "^fork.jd2",
       "independent_speeds[1]",
       {"unknown speed 'fork.jd2'", "speeds: frame.w1, frame.w2, frame.w3, frame.sd1"}},
      {"speed of a free body by a joint's name",
       base_with("frame.w1,", "frame.jd1,"),
       "^frame.jd1",
       "independent_speeds[0]",
       {"unknown speed 'frame.jd1'"}},
      {"speed named twice",
       base_with("arm.w3,", "frame.w2,"),
       "rear_wheel.jd1, ^frame.w2",
       "independent_speeds[3]",
       {"speed 'frame.w2' is named twice", "independent_speeds[1]"}},
      {"speeds not a list",
       base_with(kSpeeds, "frame.w1"),
       "independent_speeds: ^frame.w1",
       "independent_speeds",
       {"expected a list of speed names"}},
      {"empty speeds",
       base_with(kSpeeds, "[]"),
       "independent_speeds: ^[]",
       "independent_speeds",
       {"an empty list names no speed"}},
      {"speeds without constraints",
       b.substr(0, b.find("constraints:")) + "independent_speeds: [frame.w1]\n",
       "^independent_speeds",
       "independent_speeds",
       {"the model has no constraints"}},
  };
}

TEST(ModelFileConstraints, RefusalsAreLocatedOneLineMessages) {
  const std::vector<BadCase> cases = bad_cases();
  ASSERT_GE(cases.size(), 30u);
  for (const BadCase& c : cases) expect_refused(c);
  // A message from the whole file's reader (libyaml's) and from the fast scanner's agree:
  // parse_model_file reads a refused text again with libyaml; check one case by that path.
  try {
    detail::parse_model_file_with_libyaml(cases[0].text, "bad.yaml");
    ADD_FAILURE() << "accepted";
  } catch (const ModelFileError& e) {
    EXPECT_EQ(e.key_path(), "constraints[0].raduis");
  }
}

TEST(ModelFileConstraints, AFileWithoutConstraintsRefusesIndependentSpeedsEvenWhenEmpty) {
  const std::string text = kBase.substr(0, kBase.find("constraints:")) + "constraints: []\n" +
                           "independent_speeds: [frame.w1]\n";
  expect_refused(
      {"empty constraints", text, "^independent_speeds", "independent_speeds", {"no constraints"}});
}

TEST(ModelFileConstraints, ConstraintsThatCannotBeAssembledAreRefusedAtTheirEntry) {
  // The rod's front-wheel point is 0.985 from the front wheel's joint, which is 0.5 from the
  // frame's origin: no turn of the fork or the wheel puts it 2 from there.
  expect_refused({"rod too long",
                  edit(kBase, "length: 1.2", "length: 2"),
                  "  - ^name: rod",
                  "constraints[3]",
                  {"at the initial state: the projection onto the constraints did not converge",
                   "Gauss-Newton steps"}});
  // Nor can the pin's two points meet when the arm's is 3.007 from the arm's joint: the fork's
  // point is never more than 0.67 + 0.5 from there.
  expect_refused({"pin out of reach",
                  edit(kBase, "other_at: [0, 0.2, 0.4]", "other_at: [0, 0.2, 3]"),
                  "  - ^name: pin",
                  "constraints[1]",
                  {"at the initial state: the projection onto the constraints did not converge"}});
}

TEST(ModelFileConstraints, TheInitialStateIsOnTheConstraints) {
  // kBase's frame starts with speeds the rolling contact does not allow; the edited files start
  // off the constraints by millimetres (the plane, the rod), centimetres (the pin) or metres
  // (the hinge's point on the free lever).
  const std::vector<std::string> texts = {
      kBase,
      edit(kBase, "offset: 0.125", "offset: 0.12"),
      edit(kBase, "length: 1.2", "length: 1.203"),
      edit(kBase, "other_at: [0, 0.2, 0.4]", "other_at: [0, 0.2, 0.45]"),
      edit(kBase, "at: [0.25, 0, 0]", "at: [0.25, 2, -1]"),
      kDefaults};
  for (const std::string& text : texts) {
    SCOPED_TRACE(text);
    const ModelFile file = parse_model_file(text, "bike.yaml");
    ConstraintEquations equations(file.model);
    equations.evaluate(file.q, file.z);
    ASSERT_GT(equations.rows(), 0);
    EXPECT_LE(equations.errors().cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LE((equations.B() * file.z).cwiseAbs().maxCoeff(), 1e-12);
  }
  // kBase's coordinates were on the constraints already; its speeds were not.
  const ModelFile base = parse_model_file(kBase, "bike.yaml");
  EXPECT_LE(base.projection.error_before, 1e-12);
  EXPECT_LE(base.projection.coordinate_change, 1e-12);
  EXPECT_GT(base.projection.speed_change, 0.1);
}

// What the reader does not check itself the Model does; its messages about a constraint are
// then placed at that constraint's entry. Every Model check is made by the reader first (with a
// finer place), so no file reaches this: the message parsing is checked on its own.
TEST(ModelFileConstraints, ModelMessagesAboutAConstraintNameItsEntry) {
  using detail::model_error_entry;
  const auto e = model_error_entry("constraint 2 'pin': length must be > 0", "constraint");
  ASSERT_TRUE(e);
  EXPECT_EQ(e->first, 1u);
  EXPECT_EQ(e->second, "length must be > 0");
  const auto f =
      model_error_entry("constraint 12 'a-b_c': other body index 7 out of range", "constraint");
  ASSERT_TRUE(f);
  EXPECT_EQ(f->first, 11u);
  EXPECT_EQ(f->second, "other body index 7 out of range");
  for (const char* other :
       {"independent_speeds: given without constraints", "constraint 0 'x': y",
        "constraints 1 'x': y", "constraint x 'x': y", "constraint 1 x: y", "constraint 1 'x'",
        "body 1 'x': mass must be a finite number > 0", "constraint"})
    EXPECT_FALSE(model_error_entry(other, "constraint")) << other;
}

ModelFile round_trip(const ModelFile& file) {
  const std::string text = model_file_text(file.model, file.q, file.z);
  SCOPED_TRACE(text);
  return parse_model_file(text, "written.yaml");
}

void expect_same_constraints(const Model& a, const Model& b) {
  ASSERT_EQ(a.num_constraints(), b.num_constraints());
  for (int i = 0; i < a.num_constraints(); ++i) {
    const Constraint& x = a.constraints()[static_cast<size_t>(i)];
    const Constraint& y = b.constraints()[static_cast<size_t>(i)];
    SCOPED_TRACE(x.name);
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.type, y.type);
    EXPECT_EQ(x.body, y.body);
    EXPECT_EQ(x.other, y.other);
    // Points, radii, lengths and offsets bit for bit; directions, normalized again on reading,
    // within a unit or two in the last place.
    EXPECT_EQ(x.at, y.at);
    EXPECT_EQ(x.other_at, y.other_at);
    EXPECT_EQ(x.radius, y.radius);
    EXPECT_EQ(x.length, y.length);
    EXPECT_EQ(x.plane_offset, y.plane_offset);
    EXPECT_LE((x.axis - y.axis).cwiseAbs().maxCoeff(), 1e-15);
    EXPECT_LE((x.other_axis - y.other_axis).cwiseAbs().maxCoeff(), 1e-15);
    EXPECT_LE((x.plane_normal - y.plane_normal).cwiseAbs().maxCoeff(), 1e-15);
  }
  EXPECT_EQ(a.independent_speeds(), b.independent_speeds());
}

TEST(ModelFileConstraints, RoundTripThroughTheWriter) {
  // Numbers that need every digit, and axes that are not along a coordinate axis; the
  // constraints can still be assembled from there (the lever is free: its point goes where the
  // hinge's is; the lever's quarter turn takes its (1, 1, 1) to (-1, 1, 1), a few hundredths of
  // a degree from the ground's axis; the rod's length is off by one unit in the last place).
  std::string text = edit(kBase, "radius: 0.3", "radius: 0.30000000000000004");
  text = edit(text, "axis: [0, 2, 0]", "axis: [0.1, 2, -0.3]");
  text = edit(text, "normal: [0, 0, 3], offset: 0.125", "normal: [0.2, 0.1, 3], offset: -1e-7");
  text = edit(text, "at: [0.25, 0, 0]", "at: [0.1234567890123, -1e-300, 7]");
  text = edit(text, "axis: [1, 0, 0]", "axis: [1, 1, 1]");
  text = edit(text, "other_axis: [0, 1, 0]", "other_axis: [-1, 1, 1.001]");
  text = edit(text, "length: 1.2", "length: 1.2000000000000002");
  const ModelFile file = parse_model_file(text, "bike.yaml");
  const ModelFile back = round_trip(file);
  expect_same_constraints(file.model, back.model);
  // And again, from what was read back.
  expect_same_constraints(back.model, round_trip(back).model);
  // The defaults are written out and come back.
  const ModelFile defaults = parse_model_file(kDefaults, "d.yaml");
  expect_same_constraints(defaults.model, round_trip(defaults).model);
}

TEST(ModelFileConstraints, WrittenSectionsFollowTheFormat) {
  const ModelFile file = parse_model_file(kBase, "bike.yaml");
  const std::string text = model_file_text(file.model, file.q, file.z);
  EXPECT_NE(text.find("constraints:\n  - name: \"rear_contact\"\n    type: rolling_disc\n"
                      "    body: \"rear_wheel\"\n    center: [0.01, 0.02, 0.03]\n"
                      "    axis: [0.0, 1.0, 0.0]\n    radius: 0.3\n"
                      "    plane: {normal: [0.0, 0.0, 1.0], offset: 0.125}\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("    other: ground\n"), std::string::npos) << text;
  // In z's order: the Model keeps the choice as a set.
  EXPECT_NE(text.find("independent_speeds: [\"frame.w1\", \"frame.w2\", \"frame.w3\", "
                      "\"rear_wheel.jd1\", \"arm.w3\", \"lever.w1\"]\n"),
            std::string::npos)
      << text;
}

TEST(ModelFileConstraints, AStudyChangesNumbersInsideConstraints) {
  const ModelDocument doc = ModelDocument::parse(kBase, "bike.yaml");
  EXPECT_EQ(doc.base().model.num_constraints(), 4);
  const auto radius = doc.find_number("constraints[0].radius");
  EXPECT_EQ(radius.value, 0.3);
  const Location at = locate(kBase, "radius: ^0.3");
  EXPECT_EQ(radius.line, at.line);
  EXPECT_EQ(radius.column, at.column);
  const auto offset = doc.find_number("constraints[0].plane.offset");
  EXPECT_EQ(offset.value, 0.125);
  const auto length = doc.find_number("constraints[3].length");
  const auto other_at = doc.find_number("constraints[1].other_at[2]");
  EXPECT_EQ(other_at.value, 0.4);
  // Changes the loader can still assemble: the frame drops 0.575 onto the plane, the front
  // wheel turns to lengthen the rod, the fork and the arm turn to meet again.
  const std::vector<std::pair<uint32_t, double>> changes{
      {radius.node, 0.35}, {offset.node, -0.5}, {length.node, 1.25}, {other_at.node, 0.45}};
  const ModelFile built = doc.build(changes);
  std::string text = edit(kBase, "radius: 0.3", "radius: 0.35");
  text = edit(text, "offset: 0.125", "offset: -0.5");
  text = edit(text, "length: 1.2", "length: 1.25");
  text = edit(text, "other_at: [0, 0.2, 0.4]", "other_at: [0, 0.2, 0.45]");
  const ModelFile edited = parse_model_file(text, "bike.yaml");
  expect_same_constraints(built.model, edited.model);
  EXPECT_EQ(named(built.model, "rear_contact").radius, 0.35);
  EXPECT_EQ(named(built.model, "rod").length, 1.25);
  // Both were assembled anew, the same way.
  EXPECT_EQ(built.q, edited.q);
  EXPECT_EQ(built.z, edited.z);
  // The document is unchanged.
  EXPECT_EQ(named(doc.build({}).model, "rear_contact").radius, 0.3);
  // A value the reader refuses is refused at its number.
  const std::vector<std::pair<uint32_t, double>> bad{{radius.node, -1.0}};
  try {
    doc.build(bad);
    ADD_FAILURE() << "accepted";
  } catch (const ModelFileError& e) {
    EXPECT_EQ(e.line(), at.line);
    EXPECT_EQ(e.column(), at.column);
    EXPECT_EQ(e.key_path(), "constraints[0].radius");
    EXPECT_NE(e.problem().find("must be > 0"), std::string::npos) << e.what();
  }
  // Key paths that name nothing say so.
  try {
    doc.find_number("constraints[0].raduis");
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("closest: 'radius'"), std::string::npos) << e.what();
  }
  try {
    doc.find_number("constraints[pin].at[0]");
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("numbered from 0"), std::string::npos) << e.what();
  }
}

TEST(ModelFileConstraints, FourBarExampleLoads) {
  const ModelFile file = load_model_file(test::kExamples + "/four_bar.yaml");
  const Model& m = file.model;
  EXPECT_EQ(m.num_bodies(), 3);
  int revolute = 0;
  for (int k = 0; k < m.num_bodies(); ++k) revolute += m.joint(k).type == JointType::revolute;
  EXPECT_EQ(revolute, 3);
  ASSERT_EQ(m.num_constraints(), 1);
  const Constraint& c = m.constraints()[0];
  EXPECT_EQ(c.type, ConstraintType::hinge);
  EXPECT_EQ(c.body, m.body_index("rocker"));
  EXPECT_EQ(c.other, kGround);
  EXPECT_EQ(c.at, Vector3(0.9, 0, 0));
  EXPECT_EQ(c.other_at, Vector3(1.0, 0, 0));
  EXPECT_EQ(c.axis, Vector3::UnitZ());
  EXPECT_EQ(c.other_axis, Vector3::UnitZ());
  EXPECT_EQ(m.gravity(), Vector3(0, -9.81, 0));
  EXPECT_EQ(m.independent_speeds(), std::vector<int>{0});  // crank.jd1
  // The loop closes at the initial angles to within 1e-4 (the loader's projection does the
  // rest): the rocker's far end sits near D.
  const double t1 = file.q[0], t2 = t1 + file.q[1], t3 = t2 + file.q[2];
  const double x = 0.4 * std::cos(t1) + 1.2 * std::cos(t2) + 0.9 * std::cos(t3);
  const double y = 0.4 * std::sin(t1) + 1.2 * std::sin(t2) + 0.9 * std::sin(t3);
  EXPECT_NEAR(x, 1.0, 1e-4);
  EXPECT_NEAR(y, 0.0, 1e-4);
}

}  // namespace
}  // namespace kanedyn::io
