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
// joints, and an arm on a spherical joint; every constraint type, with every key given.
const std::string kBase = R"(format: kanedyn-model/1
gravity: [0, 0, -9.81]
bodies:
  - name: frame
    parent: ground
    mass: 10.0
    inertia: [1, 1, 1]
    joint: [0, 0, 0.5]
  - name: rear_wheel
    parent: frame
    mass: 2.0
    inertia: [0.1, 0.2, 0.1]
    joint: {at: [-0.5, 0, 0], type: revolute, axis: [0, 1, 0]}
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
    joint: {at: [0, 0, 0.3], type: spherical}
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
    other_at: [0, 0, 0.4]
  - name: axle
    type: hinge
    body: arm
    at: [0.25, 0, 0]
    axis: [1, 0, 0]
    other: ground
    other_at: [1.0, 0, 0]
    other_axis: [0, 1, 0]
  - name: rod
    type: distance
    body: front_wheel
    at: [0, 0, -1]
    other: frame
    other_at: [0, 0, 0]
    length: 1.2
independent_speeds: [frame.w1, fork.jd1, rear_wheel.jd1, arm.w3, frame.sd2]
)";

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
  EXPECT_EQ(pin.other_at, Vector3(0, 0, 0.4));

  const Constraint& axle = named(m, "axle");
  EXPECT_EQ(axle.type, ConstraintType::hinge);
  EXPECT_EQ(axle.body, m.body_index("arm"));
  EXPECT_EQ(axle.at, Vector3(0.25, 0, 0));
  EXPECT_EQ(axle.axis, Vector3(1, 0, 0));
  EXPECT_EQ(axle.other, kGround);
  EXPECT_EQ(axle.other_at, Vector3(1.0, 0, 0));
  EXPECT_EQ(axle.other_axis, Vector3(0, 1, 0));

  const Constraint& rod = named(m, "rod");
  EXPECT_EQ(rod.type, ConstraintType::distance);
  EXPECT_EQ(rod.body, m.body_index("front_wheel"));
  EXPECT_EQ(rod.at, Vector3(0, 0, -1));
  EXPECT_EQ(rod.other, m.body_index("frame"));
  EXPECT_EQ(rod.other_at, Vector3(0, 0, 0));
  EXPECT_EQ(rod.length, 1.2);

  // z: frame w1..3 sd1..3 (0-5), rear_wheel jd1 (6), fork jd1 (7), front_wheel jd1 (8),
  // arm w1..3 (9-11). A set: the order given does not matter.
  EXPECT_EQ(m.independent_speeds(), (std::vector<int>{0, 4, 6, 7, 11}));
}

TEST(ModelFileConstraints, SpeedNamesAreTheLinearizationsAndMapToTheirIndex) {
  const ModelFile file = parse_model_file(kBase, "bike.yaml");
  const std::vector<std::string> state = tangent_state_names(file.model);
  const int n = file.model.num_speeds();
  ASSERT_EQ(state.size(), static_cast<size_t>(2 * n));
  for (int i = 0; i < n; ++i) {
    const std::string& speed = state[static_cast<size_t>(n + i)];
    SCOPED_TRACE(speed);
    const std::string text =
        edit(kBase, "[frame.w1, fork.jd1, rear_wheel.jd1, arm.w3, frame.sd2]", "[" + speed + "]");
    EXPECT_EQ(parse_model_file(text, "bike.yaml").model.independent_speeds(), std::vector<int>{i});
  }
}

const std::string kDefaults = R"(format: kanedyn-model/1
bodies:
  - {name: a, parent: ground, mass: 1, inertia: [1, 1, 1]}
  - {name: b, parent: a, mass: 1, inertia: [1, 1, 1], joint: [1, 0, 0]}
constraints:
  - {name: disc, type: rolling_disc, body: a, axis: [0, 1, 0], radius: 0.5}
  - {name: disc2, type: rolling_disc, body: b, axis: [0, 1, 0], radius: 0.5, plane: {offset: 2}}
  - {name: disc3, type: rolling_disc, body: b, axis: [0, 1, 0], radius: 0.5, plane: {normal: [1, 0, 0]}}
  - {name: ball, type: ball, body: b}
  - {name: hinge, type: hinge, body: b, axis: [0, 0, 1], other_axis: [0, 0, 1]}
  - {name: rod, type: distance, body: a, length: 2}
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
  EXPECT_EQ(m.independent_speeds(),
            std::vector<int>{0});  // crank.jd1  // chosen later, by pivoting
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
       base_with("other_at: [0, 0, 0.4]", "other_at: [0, 0, .inf]"),
       "other_at: [0, 0, ^.inf]",
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
       base_with("fork.jd1,", "fork.jd2,"),
       "^fork.jd2",
       "independent_speeds[1]",
       {"unknown speed 'fork.jd2'", "speeds: frame.w1, frame.w2, frame.w3, frame.sd1"}},
      {"speed of a free body by a joint's name",
       base_with("frame.w1,", "frame.jd1,"),
       "^frame.jd1",
       "independent_speeds[0]",
       {"unknown speed 'frame.jd1'"}},
      {"speed named twice",
       base_with("arm.w3,", "fork.jd1,"),
       "rear_wheel.jd1, ^fork.jd1",
       "independent_speeds[3]",
       {"speed 'fork.jd1' is named twice", "independent_speeds[1]"}},
      {"speeds not a list",
       base_with("[frame.w1, fork.jd1, rear_wheel.jd1, arm.w3, frame.sd2]", "frame.w1"),
       "independent_speeds: ^frame.w1",
       "independent_speeds",
       {"expected a list of speed names"}},
      {"empty speeds",
       base_with("[frame.w1, fork.jd1, rear_wheel.jd1, arm.w3, frame.sd2]", "[]"),
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
  // Numbers that need every digit, and axes that are not along a coordinate axis.
  std::string text = edit(kBase, "radius: 0.3", "radius: 0.30000000000000004");
  text = edit(text, "axis: [0, 2, 0]", "axis: [0.1, 2, -0.3]");
  text = edit(text, "normal: [0, 0, 3], offset: 0.125", "normal: [0.2, 0.1, 3], offset: -1e-7");
  text = edit(text, "at: [0.25, 0, 0]", "at: [0.1234567890123, -1e-300, 7]");
  text = edit(text, "axis: [1, 0, 0]", "axis: [1, 1, 1]");
  text = edit(text, "other_axis: [0, 1, 0]", "other_axis: [0, 1, 1e-3]");
  text = edit(text, "length: 1.2", "length: 0.1");
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
  EXPECT_NE(text.find("independent_speeds: [\"frame.w1\", \"frame.sd2\", \"rear_wheel.jd1\", "
                      "\"fork.jd1\", \"arm.w3\"]\n"),
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
  const std::vector<std::pair<uint32_t, double>> changes{
      {radius.node, 0.35}, {offset.node, -0.5}, {length.node, 1.5}, {other_at.node, 0.45}};
  const ModelFile built = doc.build(changes);
  std::string text = edit(kBase, "radius: 0.3", "radius: 0.35");
  text = edit(text, "offset: 0.125", "offset: -0.5");
  text = edit(text, "length: 1.2", "length: 1.5");
  text = edit(text, "other_at: [0, 0, 0.4]", "other_at: [0, 0, 0.45]");
  const ModelFile edited = parse_model_file(text, "bike.yaml");
  expect_same_constraints(built.model, edited.model);
  EXPECT_EQ(named(built.model, "rear_contact").radius, 0.35);
  EXPECT_EQ(named(built.model, "rod").length, 1.5);
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
