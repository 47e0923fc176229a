// URDF import (docs/urdf.md): the mapping of every joint kind, of a turned <inertial> and of
// massless links, checked on the YAML text (read back with libyaml) against transforms
// computed here from the URDF numbers; every refusal; the XML depth limit and its scan; that
// what the import writes loads; `kanedyn import`; and load_model_file of a .urdf.
#include <gtest/gtest.h>
#include <yaml.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <regex>
#include <string>
#include <vector>

#include "../src/io/xml_scan.hpp"
#include "file_support.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/frames.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/urdf.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/rotation.hpp"
#include "test_support.hpp"

namespace kanedyn::io {
namespace {

using Json = nlohmann::json;
using kanedyn::test::slurp;
using Mat = Eigen::Matrix3d;
using Vec = Eigen::Vector3d;

const std::string kData = std::string(KANEDYN_SOURCE_DIR) + "/tests/data/urdf/";

#define REQUIRE_URDF() \
  if (!urdf_supported()) GTEST_SKIP() << "built without URDF support (liburdfdom not found)"

/// The loader reads the mapping form of `joint` (docs/model-format.md, "Joints") once that
/// lands; until then the tests that load a jointed model skip.
bool mapping_form_supported() {
  try {
    parse_model_file(
        "format: kanedyn-model/1\nbodies:\n  - name: a\n    parent: ground\n    mass: 1\n"
        "    inertia: [1, 1, 1]\n    joint: {type: revolute, axis: [0, 0, 1]}\n",
        "probe.yaml");
    return true;
  } catch (const ModelFileError&) {
    return false;
  }
}
#define REQUIRE_MAPPING_FORM()                                                       \
  if (!mapping_form_supported())                                                     \
  GTEST_SKIP() << "the model loader does not read the mapping form of `joint` yet; " \
                  "this test runs once it does"

/// A YAML document as JSON: plain scalars that read as numbers become numbers, the rest text.
Json node_json(yaml_document_t& doc, yaml_node_t* node) {
  switch (node->type) {
    case YAML_SCALAR_NODE: {
      const std::string text(reinterpret_cast<const char*>(node->data.scalar.value),
                             node->data.scalar.length);
      if (node->data.scalar.style == YAML_PLAIN_SCALAR_STYLE) {
        std::size_t used = 0;
        try {
          const double v = std::stod(text, &used);
          if (used == text.size()) return v;
        } catch (const std::exception&) {
        }
      }
      return text;
    }
    case YAML_SEQUENCE_NODE: {
      Json a = Json::array();
      for (yaml_node_item_t* i = node->data.sequence.items.start; i < node->data.sequence.items.top;
           ++i)
        a.push_back(node_json(doc, yaml_document_get_node(&doc, *i)));
      return a;
    }
    case YAML_MAPPING_NODE: {
      Json m = Json::object();
      for (yaml_node_pair_t* p = node->data.mapping.pairs.start; p < node->data.mapping.pairs.top;
           ++p) {
        yaml_node_t* key = yaml_document_get_node(&doc, p->key);
        const std::string k(reinterpret_cast<const char*>(key->data.scalar.value),
                            key->data.scalar.length);
        EXPECT_FALSE(m.contains(k)) << "duplicate key " << k;
        m[k] = node_json(doc, yaml_document_get_node(&doc, p->value));
      }
      return m;
    }
    default:
      return nullptr;
  }
}

Json yaml_json(const std::string& text) {
  yaml_parser_t parser;
  yaml_document_t doc;
  yaml_parser_initialize(&parser);
  yaml_parser_set_input_string(&parser, reinterpret_cast<const unsigned char*>(text.data()),
                               text.size());
  const bool ok = yaml_parser_load(&parser, &doc) != 0;
  EXPECT_TRUE(ok) << parser.problem << "\n" << text;
  Json j;
  if (ok) {
    yaml_node_t* root = yaml_document_get_root_node(&doc);
    if (root) j = node_json(doc, root);
    yaml_document_delete(&doc);
  }
  yaml_parser_delete(&parser);
  return j;
}

Vec vec(const Json& j) {
  EXPECT_EQ(j.size(), 3u) << j;
  return Vec(j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>());
}

/// URDF's rpy: R = Rz(yaw) Ry(pitch) Rx(roll), computed here without urdfdom.
Mat rpy(double r, double p, double y) {
  return (Eigen::AngleAxisd(y, Vec::UnitZ()) * Eigen::AngleAxisd(p, Vec::UnitY()) *
          Eigen::AngleAxisd(r, Vec::UnitX()))
      .toRotationMatrix();
}

/// The rotation of a `frame:` (or `rotation:`) entry; identity when absent.
Mat frame(const Json& joint, const char* key = "frame") {
  if (!joint.contains(key)) return Mat::Identity();
  const Json& f = joint.at(key);
  EXPECT_EQ(f.size(), 2u) << f;
  const Vec axis = vec(f.at("axis"));
  EXPECT_NEAR(axis.norm(), 1.0, 1e-15);
  return Eigen::AngleAxisd(f.at("angle").get<double>(), axis.normalized()).toRotationMatrix();
}

Mat inertia(const Json& body) {
  const Json& i = body.at("inertia");
  EXPECT_EQ(i.size(), 6u);
  Mat m;
  m << i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2];
  return m;
}

const Json& body(const Json& model, const std::string& name) {
  for (const Json& b : model.at("bodies"))
    if (b.at("name") == name) return b;
  ADD_FAILURE() << "no body " << name;
  static const Json none;
  return none;
}

std::string convert(const std::string& file, std::vector<std::string>* notes = nullptr,
                    UrdfOptions options = {}) {
  return urdf_to_model_yaml(slurp(kData + file), file, options, notes);
}

/// The ModelFileError of converting `urdf`, which must fail.
ModelFileError refusal(const std::string& urdf) {
  try {
    urdf_to_model_yaml(urdf, "bad.urdf", {}, nullptr);
  } catch (const ModelFileError& e) {
    return e;
  }
  ADD_FAILURE() << "accepted:\n" << urdf;
  return ModelFileError("", 0, 0, "", "");
}

const std::string kMass = R"(<inertial><mass value="1"/>
  <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>)";
std::string massive(const std::string& name) {
  return "<link name=\"" + name + "\">" + kMass + "</link>\n";
}
std::string joint(const std::string& name, const std::string& type, const std::string& parent,
                  const std::string& child, const std::string& inner = "") {
  const bool limited = type == "revolute" || type == "prismatic";
  return "<joint name=\"" + name + "\" type=\"" + type + "\"><parent link=\"" + parent +
         "\"/><child link=\"" + child + "\"/>" +
         (limited ? "<limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/>" : "") + inner +
         "</joint>\n";
}
std::string robot(const std::string& inner) {
  return "<robot name=\"r\">\n" + inner + "</robot>\n";
}

}  // namespace

TEST(Urdf, EveryJointKindMapsToItsJoint) {
  REQUIRE_URDF();
  std::vector<std::string> notes;
  const Json m = yaml_json(convert("joints.urdf", &notes));
  EXPECT_EQ(m.at("format"), "kanedyn-model/1");
  EXPECT_EQ(m.at("name"), "joint_kinds");
  EXPECT_EQ(vec(m.at("gravity")), Vec(0, 0, -9.81));
  // Depth first from the root, the children of a link by joint name: every parent earlier.
  std::vector<std::string> names;
  for (const Json& b : m.at("bodies")) names.push_back(b.at("name"));
  EXPECT_EQ(names, (std::vector<std::string>{"base", "drone", "upper", "fore", "carriage"}));

  // fixed -> weld, on the massless root: attached to the ground.
  const Json& base = body(m, "base");
  EXPECT_EQ(base.at("parent"), "ground");
  EXPECT_EQ(base.at("mass"), 4.0);
  EXPECT_EQ(vec(base.at("com")), Vec(0, 0, 0.05));
  EXPECT_EQ(inertia(base), Vec(0.04, 0.05, 0.06).asDiagonal().toDenseMatrix());
  EXPECT_EQ(base.at("joint").at("type"), "weld");
  EXPECT_EQ(vec(base.at("joint").at("at")), Vec(0.1, -0.2, 0.3));
  EXPECT_TRUE(frame(base.at("joint")).isApprox(rpy(0, 0, 0.5), 1e-15));
  EXPECT_FALSE(base.at("joint").contains("axis"));

  // revolute: at, frame from rpy, axis in the joint frame.
  const Json& upper = body(m, "upper");
  EXPECT_EQ(upper.at("parent"), "base");
  const Json& shoulder = upper.at("joint");
  EXPECT_EQ(shoulder.at("type"), "revolute");
  EXPECT_EQ(vec(shoulder.at("at")), Vec(0, 0, 0.2));
  EXPECT_TRUE(frame(shoulder).isApprox(rpy(0.3, -0.4, 1.2), 1e-15));
  EXPECT_EQ(vec(shoulder.at("axis")), Vec(0, 1, 0));

  // continuous -> revolute, the default axis 1 0 0, no rpy: no frame.
  const Json& elbow = body(m, "fore").at("joint");
  EXPECT_EQ(elbow.at("type"), "revolute");
  EXPECT_EQ(vec(elbow.at("at")), Vec(0.5, 0, 0));
  EXPECT_FALSE(elbow.contains("frame"));
  EXPECT_EQ(vec(elbow.at("axis")), Vec(1, 0, 0));

  // prismatic: the axis as written (the loader normalizes it).
  const Json& slide = body(m, "carriage").at("joint");
  EXPECT_EQ(slide.at("type"), "prismatic");
  EXPECT_EQ(vec(slide.at("at")), Vec(0.4, 0, 0));
  EXPECT_TRUE(frame(slide).isApprox(rpy(std::numbers::pi / 2, 0, 0), 1e-15));
  EXPECT_EQ(vec(slide.at("axis")), Vec(0, 0, 2));

  // floating -> free: the list form (the point Q_K) and the absolute orientation at zero
  // joint positions: the root's weld turned by the floating joint's rpy.
  const Json& drone = body(m, "drone");
  EXPECT_EQ(drone.at("parent"), "base");
  EXPECT_EQ(vec(drone.at("joint")), Vec(1, 2, 3));
  EXPECT_TRUE(
      frame(drone.at("initial"), "rotation").isApprox(rpy(0, 0, 0.5) * rpy(0.1, 0.2, 0.3), 1e-15));

  // <dynamics damping> -> joint_spring with that damping, in body order.
  const Json& forces = m.at("forces");
  ASSERT_EQ(forces.size(), 2u);
  EXPECT_EQ(forces[0], Json::parse(R"({"type": "joint_spring", "body": "fore", "damping": 0.7})"));
  EXPECT_EQ(forces[1],
            Json::parse(R"({"type": "joint_spring", "body": "carriage", "damping": 3.0})"));

  // What is dropped: once per kind, naming the joints.
  EXPECT_EQ(notes, (std::vector<std::string>{
                       "joints 'shoulder', 'slide': position, velocity and effort limits are "
                       "ignored",
                       "joint 'elbow': friction is ignored"}));
}

// A link on a URDF planar joint (motion in the plane normal to <axis>, turning about it).
std::string planar_robot(const std::string& origin, const std::string& axis) {
  const std::string puck = R"(<link name="puck"><inertial><origin xyz="0.1 0.2 0.3"/>
    <mass value="2"/><inertia ixx="0.1" iyy="0.2" izz="0.3" ixy="0" ixz="0" iyz="0"/>
    </inertial></link>
)";
  return robot("<link name=\"world\"/>" + puck +
               joint("slide", "planar", "world", "puck", origin + "<axis xyz=\"" + axis + "\"/>"));
}

/// The puck's joint accelerations by both routes at (q, z).
VectorX planar_zdot(const Model& model, const VectorX& q, const VectorX& z) {
  Dynamics by_recursion(model, Route::recursive), by_assembly(model, Route::assembled);
  VectorX recursive(3), assembled(3), qdot(model.num_coordinates());
  by_recursion.evaluate(q, z, recursive, qdot);
  by_assembly.evaluate(q, z, assembled, qdot);
  EXPECT_LT((recursive - assembled).norm(), 1e-12);
  return recursive;
}

// URDF planar -> kanedyn planar with a frame whose z is the URDF axis. Its link moves in the
// plane through the joint origin normal to the axis, and turns about the axis only: at random
// states, O_K - origin and its velocity are normal to the axis, and the body's z is the axis
// (inertial components). Forward dynamics agrees with hand-built model files of the same
// joint: axis z (F is the origin's frame, the mass properties as in the URDF), and axis x
// (F turned 90 degrees about y, the importer's smallest turn taking z to x: the mass
// properties in F components written here by hand). Round-off of one 3x3 solve and a few
// rotations: 1e-12.
TEST(Urdf, PlanarJointMovesInThePlaneNormalToItsAxis) {
  REQUIRE_URDF();
  std::mt19937 rng(5);
  {
    std::vector<std::string> notes;
    const std::string yaml = urdf_to_model_yaml(
        planar_robot("<origin xyz=\"0.5 -0.2 1\" rpy=\"0.3 -0.2 0.5\"/>", "0 1 1"), "p.urdf", {},
        &notes);
    const ModelFile f = parse_model_file(yaml, "p.yaml");
    const Model& m = f.model;
    ASSERT_EQ(m.joint(0).type, JointType::planar);
    EXPECT_NE(yaml.find("body frame: the link frame turned"), std::string::npos) << yaml;
    ASSERT_EQ(notes.size(), 1u);
    EXPECT_NE(notes[0].find("joint 'slide': is planar about an axis other than its z"),
              std::string::npos)
        << notes[0];
    const Vec origin(0.5, -0.2, 1);
    const Vec axis = rpy(0.3, -0.2, 0.5) * Vec(0, 1, 1).normalized();
    for (int i = 0; i < 10; ++i) {
      VectorX q(3), z(3);
      for (int c = 0; c < 3; ++c) {
        q[c] = kanedyn::test::uniform(rng, -2, 2);
        z[c] = kanedyn::test::uniform(rng, -2, 2);
      }
      State s(m);
      joint_state(m, q, z, s);
      const Vec p_o = m.body(0).joint + Vec(s.translation(0));
      EXPECT_NEAR(m.body(0).joint.dot(axis), origin.dot(axis), 1e-15);
      EXPECT_LT(std::abs((p_o - origin).dot(axis)), 1e-14);
      EXPECT_LT(std::abs(Vec(s.translation_rate(0)).dot(axis)), 1e-14);
      const Mat r_k = rotation_matrix(s.euler_parameters(0));  // inertial to K components
      EXPECT_LT((r_k.transpose() * Vec::UnitZ() - axis).norm(), 1e-14);
      EXPECT_LT(std::abs(q.head<2>().norm() - (p_o - origin).norm()), 1e-14);
    }
  }
  const auto hand_built = [](const std::string& joint_and_mass) {
    return parse_model_file(
        "format: kanedyn-model/1\ngravity: [0, 0, -9.81]\nbodies:\n"
        "  - name: puck\n    parent: ground\n" +
            joint_and_mass,
        "hand.yaml");
  };
  struct Case {
    std::string origin, axis, yaml;
  };
  const std::vector<Case> cases = {
      {"<origin xyz=\"0.5 -0.2 1\" rpy=\"0.4 0 0\"/>", "0 0 1",
       "    mass: 2\n    inertia: [0.1, 0.2, 0.3]\n    com: [0.1, 0.2, 0.3]\n"
       "    joint: {type: planar, at: [0.5, -0.2, 1], frame: {axis: [1, 0, 0], angle: 0.4}}\n"},
      // F's z = the link's x: a link vector v has F components (-v_z, v_y, v_x).
      {"<origin xyz=\"0 0 0\"/>", "1 0 0",
       "    mass: 2\n    inertia: [0.3, 0.2, 0.1]\n    com: [-0.3, 0.2, 0.1]\n"
       "    joint: {type: planar, frame: {axis: [0, 1, 0], angle_deg: 90}}\n"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.axis);
    const ModelFile imported = parse_model_file(
        urdf_to_model_yaml(planar_robot(c.origin, c.axis), "p.urdf", {}, nullptr), "p.yaml");
    const ModelFile hand = hand_built(c.yaml);
    for (int i = 0; i < 5; ++i) {
      VectorX q(3), z(3);
      for (int k = 0; k < 3; ++k) {
        q[k] = kanedyn::test::uniform(rng, -2, 2);
        z[k] = kanedyn::test::uniform(rng, -2, 2);
      }
      const VectorX a = planar_zdot(imported.model, q, z), b = planar_zdot(hand.model, q, z);
      EXPECT_LT((a - b).norm(), 1e-12 * (1.0 + b.norm()))
          << a.transpose() << " / " << b.transpose();
    }
  }
}

TEST(Urdf, TurnedInertialOriginTurnsTheInertiaIntoLinkAxes) {
  REQUIRE_URDF();
  const Json m = yaml_json(convert("rotated_inertial.urdf"));
  ASSERT_EQ(m.at("bodies").size(), 1u);
  const Json& b = m.at("bodies")[0];
  EXPECT_EQ(b.at("name"), "brick");
  EXPECT_EQ(b.at("parent"), "ground");
  EXPECT_EQ(b.at("joint"), Json::parse(R"({"type": "weld", "at": [0, 0, 0]})"));
  EXPECT_EQ(b.at("mass"), 3.0);
  EXPECT_EQ(vec(b.at("com")), Vec(0.1, 0.2, 0.3));
  // I_link = R I R^T, entry by entry from the URDF's numbers, R from rpy by explicit sums.
  Mat in;
  in << 0.5, 0.01, -0.02, 0.01, 0.4, 0.03, -0.02, 0.03, 0.3;
  const Mat r = rpy(0.4, 0.5, 0.6);
  Mat expected = Mat::Zero();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int a = 0; a < 3; ++a)
        for (int c = 0; c < 3; ++c) expected(i, j) += r(i, a) * in(a, c) * r(j, c);
  const Mat got = inertia(b);
  EXPECT_LT((got - expected).cwiseAbs().maxCoeff(), 1e-15) << got << "\n\n" << expected;
  // A turn keeps the trace and the principal moments.
  EXPECT_NEAR(got.trace(), 1.2, 1e-15);
  EXPECT_GT((got - in).cwiseAbs().maxCoeff(), 0.01);  // and it did turn
}

TEST(Urdf, FloatingOptionFreesAMassiveRoot) {
  REQUIRE_URDF();
  UrdfOptions options;
  options.floating = true;
  const Json m = yaml_json(convert("rotated_inertial.urdf", nullptr, options));
  const Json& b = m.at("bodies")[0];
  EXPECT_EQ(vec(b.at("joint")), Vec(0, 0, 0));  // the list form: free
  EXPECT_FALSE(b.contains("initial"));
}

/// The poses of the bodies and the frames of a converted model at its initial state: the
/// rotation [R] and the position of O, body by body and then frame by frame.
std::vector<std::pair<Mat, Vec>> poses(const std::string& yaml) {
  const ModelFile f = parse_model_file(yaml, "converted.yaml");
  Data data(f.model);
  compute_kinematics(f.model, f.initial, data);
  std::vector<std::pair<Mat, Vec>> out;
  for (int k = 0; k < f.model.num_bodies(); ++k)
    out.emplace_back(data.kinematics.R[static_cast<size_t>(k)],
                     data.kinematics.p_O[static_cast<size_t>(k)]);
  for (int i = 0; i < static_cast<int>(f.model.frames().size()); ++i) {
    const FrameState s = frame_state(f.model, i, f.initial, data.kinematics);
    out.emplace_back(s.R, s.position);
  }
  return out;
}

bool has_note(const std::vector<std::string>& notes, const std::string& text) {
  for (const std::string& n : notes)
    if (n.find(text) != std::string::npos) return true;
  return false;
}

TEST(Urdf, FloatingOptionFreesTheFirstMassiveLinkBelowAMasslessRoot) {
  REQUIRE_URDF();
  REQUIRE_MAPPING_FORM();
  // world (massless) carries base on a fixed joint, a camera frame and an arm on a revolute
  // joint: with the option, base is free where the fixed joint put it, and the camera and the
  // arm hang on base, so that the robot moves as one.
  const auto origin = [](const std::string& xyz, const std::string& rpy) {
    return "<origin xyz=\"" + xyz + "\" rpy=\"" + rpy + "\"/>";
  };
  const std::string urdf =
      robot("<link name=\"world\"/><link name=\"camera\"/>" + massive("base") + massive("arm") +
            joint("mount", "fixed", "world", "base", origin("0.1 -0.2 0.3", "0.2 -0.1 0.5")) +
            joint("optics", "fixed", "world", "camera", origin("0.4 0.5 -0.6", "-0.3 0.7 0.1")) +
            joint("swing", "revolute", "world", "arm",
                  origin("-0.7 0.2 0.9", "0.6 0.1 -0.4") + "<axis xyz=\"0 1 0\"/>"));
  UrdfOptions floating;
  floating.floating = true;
  std::vector<std::string> notes;
  const std::string welded_yaml = urdf_to_model_yaml(urdf, "r.urdf", {}, nullptr);
  const std::string free_yaml = urdf_to_model_yaml(urdf, "r.urdf", floating, &notes);
  const Json m = yaml_json(free_yaml);
  EXPECT_EQ(vec(body(m, "base").at("joint")), Vec(0.1, -0.2, 0.3));  // the list form: free
  EXPECT_EQ(body(m, "arm").at("parent"), "base");
  EXPECT_EQ(body(m, "arm").at("joint").at("type"), "revolute");
  ASSERT_EQ(m.at("frames").size(), 1u);
  EXPECT_EQ(m.at("frames")[0].at("body"), "base");
  EXPECT_TRUE(has_note(notes,
                       "root link 'world' has no mass: the option floating frees link "
                       "'base', the first link with mass below it (its fixed joint "
                       "'mount' replaced by a free joint)"))
      << ::testing::PrintToString(notes);
  // The same poses at the initial state as the welded robot: each a product of two or three
  // turns and shifts of size 1, so round-off of a few units of 1e-16.
  const auto a = poses(welded_yaml), b = poses(free_yaml);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_LT((a[i].first - b[i].first).cwiseAbs().maxCoeff(), 1e-15) << i;
    EXPECT_LT((a[i].second - b[i].second).cwiseAbs().maxCoeff(), 1e-15) << i;
  }
  // The free body moves the rest: its 6 speeds and the arm's 1.
  EXPECT_EQ(parse_model_file(free_yaml, "f.yaml").model.num_speeds(), 7);
}

TEST(Urdf, FloatingOptionBelowAMasslessRootOnAMovingJoint) {
  REQUIRE_URDF();
  UrdfOptions floating;
  floating.floating = true;
  // One link on a revolute joint from a massless root: the link is freed, and its joint (which
  // a massless root could not load) goes, with its input and its damping.
  std::vector<std::string> notes;
  const std::string one = robot("<link name=\"world\"/>" + massive("arm") +
                                joint("swing", "revolute", "world", "arm",
                                      "<axis xyz=\"0 0 1\"/><dynamics damping=\"0.5\"/>"));
  const Json m = yaml_json(urdf_to_model_yaml(one, "r.urdf", floating, &notes));
  EXPECT_EQ(vec(body(m, "arm").at("joint")), Vec(0, 0, 0));
  EXPECT_FALSE(m.contains("inputs"));
  EXPECT_FALSE(m.contains("forces"));
  EXPECT_TRUE(has_note(notes,
                       "(its revolute joint 'swing' replaced by a free joint, with the "
                       "joint's input and damping)"))
      << ::testing::PrintToString(notes);
  // A link fixed to the root is freed before one on a moving joint, though the walk (joints by
  // name) meets it second; it comes first in the file, before the arm now hung on it.
  const std::string fixed_second =
      robot("<link name=\"world\"/>" + massive("arm") + massive("leg") +
            joint("a_swing", "revolute", "world", "arm", "<axis xyz=\"0 0 1\"/>") +
            joint("b_step", "fixed", "world", "leg"));
  const Json m2 = yaml_json(urdf_to_model_yaml(fixed_second, "r.urdf", floating, nullptr));
  EXPECT_EQ(m2.at("bodies")[0].at("name"), "leg");
  EXPECT_EQ(vec(m2.at("bodies")[0].at("joint")), Vec(0, 0, 0));
  EXPECT_EQ(body(m2, "arm").at("parent"), "leg");
  // Two on moving joints: freeing one would cut the other's connection through the root;
  // refused, saying why.
  const std::string two = robot("<link name=\"world\"/>" + massive("arm") + massive("leg") +
                                joint("a_swing", "revolute", "world", "arm") +
                                joint("b_turn", "continuous", "world", "leg"));
  try {
    urdf_to_model_yaml(two, "r.urdf", floating, nullptr);
    ADD_FAILURE() << "accepted";
  } catch (const ModelFileError& e) {
    EXPECT_EQ(e.key_path(), "root link 'world'");
    EXPECT_NE(e.problem().find("cannot free a massless root that moves several links"),
              std::string::npos)
        << e.what();
  }
  // Without the option nothing changes: the massless root is the ground.
  const Json welded = yaml_json(urdf_to_model_yaml(two, "r.urdf", {}, nullptr));
  EXPECT_EQ(body(welded, "arm").at("parent"), "ground");
  EXPECT_EQ(body(welded, "leg").at("parent"), "ground");
}

// Every number of the converted files reads as a float under YAML 1.1 too (PyYAML's pattern
// wants a '.' in the mantissa: `8e-04` would be a string; python/tests/test_written_yaml.py
// reads the files with PyYAML itself).
TEST(Urdf, EveryNumberWrittenIsAYaml11Float) {
  REQUIRE_URDF();
  const std::regex number(R"((?:^|[\[ ,:])(-?[0-9][0-9.eE+-]*)(?=[,\]\n]))");
  const std::regex yaml11_float(R"(^[-+]?([0-9][0-9_]*)?\.[0-9.]*([eE][-+][0-9]+)?$)");
  UrdfOptions floating;
  floating.floating = true;
  for (const std::string file : {"joints.urdf", "flange.urdf", "rotated_inertial.urdf"})
    for (const UrdfOptions& options : {UrdfOptions{}, floating}) {
      const std::string text = convert(file, nullptr, options);
      int floats = 0;
      for (auto it = std::sregex_iterator(text.begin(), text.end(), number);
           it != std::sregex_iterator(); ++it) {
        EXPECT_TRUE(std::regex_match((*it)[1].str(), yaml11_float)) << file << ": " << (*it)[1];
        ++floats;
      }
      EXPECT_GT(floats, 10) << file;
    }
}

TEST(Urdf, GravityOption) {
  REQUIRE_URDF();
  UrdfOptions options;
  options.gravity = {0, -9.80665, 0};
  EXPECT_EQ(vec(yaml_json(convert("rotated_inertial.urdf", nullptr, options)).at("gravity")),
            Vec(0, -9.80665, 0));
}

TEST(Urdf, MasslessLinksFoldIntoTheirNeighbours) {
  REQUIRE_URDF();
  const Json m = yaml_json(convert("flange.urdf"));
  std::vector<std::string> names;
  for (const Json& b : m.at("bodies")) names.push_back(b.at("name"));
  // base_link is the ground; pedestal, flange and tcp are frames.
  EXPECT_EQ(names, (std::vector<std::string>{"link1", "tool"}));

  // j1 hangs on the ground through the pedestal: at = p_ped + R_ped xyz, frame = R_ped.
  const Mat r_ped = rpy(0, 0, 0.3);
  const Vec p_ped(0, 0, 0.1);
  const Json& j1 = body(m, "link1").at("joint");
  EXPECT_EQ(body(m, "link1").at("parent"), "ground");
  EXPECT_LT((vec(j1.at("at")) - (p_ped + r_ped * Vec(0.02, 0, 0.3))).norm(), 1e-16);
  EXPECT_TRUE(frame(j1).isApprox(r_ped, 1e-15));
  EXPECT_EQ(vec(j1.at("axis")), Vec(0, 0, 1));  // in F, untouched by the folding

  // tool_joint hangs on link1 through the flange.
  const Mat r_fl = rpy(0.1, 0.2, 0.785398163397);
  const Vec p_fl(0, 0.01, 0.4);
  const Json& tool = body(m, "tool");
  EXPECT_EQ(tool.at("parent"), "link1");
  EXPECT_LT((vec(tool.at("joint").at("at")) - (p_fl + r_fl * Vec(0.05, 0, 0))).norm(), 1e-16);
  EXPECT_TRUE(frame(tool.at("joint")).isApprox(r_fl * rpy(0.2, 0, 0), 1e-15));
  EXPECT_EQ(vec(tool.at("joint").at("axis")), Vec(0, 0, 1));
}

TEST(Urdf, DeepTreeListsEveryParentFirst) {
  REQUIRE_URDF();
  // A 30-link chain, each link also carrying a leaf on a fixed joint every third link.
  std::string x;
  for (int i = 0; i < 30; ++i) x += massive("c" + std::to_string(i));
  for (int i = 1; i < 30; ++i)
    x += joint("j" + std::to_string(i), i % 2 ? "revolute" : "prismatic",
               "c" + std::to_string(i - 1), "c" + std::to_string(i),
               "<origin xyz=\"0 0 " + std::to_string(i) + "\" rpy=\"0.1 0 0\"/>");
  for (int i = 0; i < 30; i += 3) {
    x += massive("leaf" + std::to_string(i));
    x += joint("k" + std::to_string(i), "fixed", "c" + std::to_string(i),
               "leaf" + std::to_string(i));
  }
  const Json m = yaml_json(urdf_to_model_yaml(robot(x), "deep.urdf", {}, nullptr));
  const Json& bodies = m.at("bodies");
  ASSERT_EQ(bodies.size(), 40u);
  std::vector<std::string> seen{"ground"};
  int chain = 0;
  for (const Json& b : bodies) {
    const std::string parent = b.at("parent");
    EXPECT_NE(std::find(seen.begin(), seen.end(), parent), seen.end())
        << b.at("name") << "'s parent " << parent << " comes later";
    const std::string name = b.at("name");
    if (name[0] == 'c') {
      const int i = std::stoi(name.substr(1));
      EXPECT_EQ(i, chain++);  // the chain in order
      EXPECT_EQ(parent, i == 0 ? "ground" : "c" + std::to_string(i - 1));
      if (i > 0) {
        EXPECT_EQ(b.at("joint").at("type"), i % 2 ? "revolute" : "prismatic");
        EXPECT_EQ(vec(b.at("joint").at("at")), Vec(0, 0, i));
      }
    } else {
      EXPECT_EQ(parent, "c" + name.substr(4));
      EXPECT_EQ(b.at("joint").at("type"), "weld");
    }
    seen.push_back(name);
  }
  EXPECT_EQ(chain, 30);
}

TEST(Urdf, LongChainNeedsNoRecursion) {
  REQUIRE_URDF();
  std::string x;
  constexpr int kLinks = 3000;
  for (int i = 0; i < kLinks; ++i) x += massive("c" + std::to_string(i));
  for (int i = 1; i < kLinks; ++i)
    x += joint("j" + std::to_string(i), "continuous", "c" + std::to_string(i - 1),
               "c" + std::to_string(i));
  const Json m = yaml_json(urdf_to_model_yaml(robot(x), "long.urdf", {}, nullptr));
  ASSERT_EQ(m.at("bodies").size(), static_cast<std::size_t>(kLinks));
  EXPECT_EQ(m.at("bodies")[kLinks - 1].at("parent"), "c" + std::to_string(kLinks - 2));
}

TEST(Urdf, NumbersRoundTrip) {
  REQUIRE_URDF();
  const std::string x = robot(
      "<link name=\"a\"><inertial><origin xyz=\"0.1 0.30000000000000004 "
      "1e-300\"/><mass value=\"0.7000000000000001\"/><inertia ixx=\"0.1\" iyy=\"0.1\" "
      "izz=\"0.1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>");
  const Json b = yaml_json(urdf_to_model_yaml(x, "n.urdf", {}, nullptr)).at("bodies")[0];
  EXPECT_EQ(b.at("mass").get<double>(), 0.7000000000000001);
  EXPECT_EQ(vec(b.at("com")), Vec(0.1, 0.30000000000000004, 1e-300));
}

TEST(Urdf, LinkNamesOutsideTheBodyAlphabetAreSanitizedAndNoted) {
  REQUIRE_URDF();
  std::vector<std::string> notes;
  const std::string x = robot(massive("arm.link/1") + massive("ground") +
                              joint("j", "fixed", "arm.link/1", "ground"));
  const Json m = yaml_json(urdf_to_model_yaml(x, "n.urdf", {}, &notes));
  EXPECT_EQ(m.at("bodies")[0].at("name"), "arm_link_1");
  EXPECT_EQ(m.at("bodies")[1].at("name"), "ground_");
  EXPECT_EQ(m.at("bodies")[1].at("parent"), "arm_link_1");
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_NE(notes[0].find("link 'arm.link/1': is the body 'arm_link_1'"), std::string::npos);
  // Two links that sanitize to one name are refused.
  const ModelFileError e =
      refusal(robot(massive("a.b") + massive("a_b") + joint("j", "fixed", "a.b", "a_b")));
  EXPECT_EQ(e.key_path(), "link 'a_b'");
  EXPECT_NE(e.problem().find("link 'a.b'"), std::string::npos) << e.what();
}

TEST(Urdf, RobotNameIsQuotedExactly) {
  REQUIRE_URDF();
  const std::string x =
      "<robot name=\"a &quot;quoted&quot; \\ name: #1\">" + massive("a") + "</robot>";
  EXPECT_EQ(yaml_json(urdf_to_model_yaml(x, "n.urdf", {}, nullptr)).at("name"),
            "a \"quoted\" \\ name: #1");
}

TEST(Urdf, RefusalsNameTheFileAndTheElement) {
  REQUIRE_URDF();
  struct Case {
    std::string urdf, key_path, problem;
  };
  const std::string base = "<link name=\"world\"/>";
  const std::vector<Case> cases = {
      {robot(base + massive("a") +
             joint("slider", "planar", "world", "a", "<axis xyz=\"0 0 0\"/>")),
       "joint 'slider'", "axis must be a nonzero finite vector"},
      {robot(base + massive("a") + massive("b") + joint("j1", "revolute", "world", "a") +
             joint("j2", "revolute", "a", "b", "<mimic joint=\"j1\"/>")),
       "joint 'j2'", "mimics joint 'j1'"},
      {robot(base + massive("a") + massive("b") + joint("j1", "fixed", "world", "a") +
             joint("j2", "fixed", "a", "b") + joint("j3", "fixed", "b", "a")),
       "link 'a'", "closed loop"},
      {robot(base + massive("a") + massive("b") + joint("j1", "fixed", "a", "b") +
             joint("j2", "fixed", "b", "a")),
       "link 'a'", "cannot be reached from the root link 'world'"},
      {robot(massive("a") + massive("b") + joint("j1", "fixed", "a", "b") +
             joint("j2", "fixed", "b", "a")),
       "", "not a valid URDF file (urdfdom could not parse it): Failed to find root link"},
      {robot(base + "<link name=\"hub\"/>" + massive("a") +
             joint("j1", "continuous", "world", "hub") + joint("j2", "fixed", "hub", "a")),
       "link 'hub'", "has no mass, but joint 'j1' (revolute) moves it"},
      {robot(base + "<link name=\"hub\"/>" + joint("j1", "floating", "world", "hub")), "link 'hub'",
       "joint 'j1' (floating) moves it"},
      {"<robot name=\"r\"><link name=\"a\"></robot>", "",
       "not a valid URDF file (urdfdom could not parse it): Error reading end tag."},
      {"", "", "not a valid URDF file (urdfdom could not parse it): Error document empty."},
      {robot("<link name=\"a\"><inertial><mass value=\"1\"/></inertial></link>"), "",
       "Inertial element must have inertia element"},
      {robot(base + massive("a") +
             "<joint name=\"j\" type=\"revolute\"><parent "
             "link=\"world\"/><child link=\"a\"/></joint>"),
       "", "does not specify limits"},
      {robot("<link name=\"a\"><inertial><mass value=\"-1\"/><inertia ixx=\"1\" iyy=\"1\" "
             "izz=\"1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>"),
       "link 'a'", "mass must be a finite number >= 0, got -1"},
      {robot("<link name=\"a\"><inertial><mass value=\"1\"/><inertia ixx=\"1\" iyy=\"1\" "
             "izz=\"3\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>"),
       "link 'a'", "violate the triangle inequality"},
      {robot("<link name=\"a\"><inertial><mass value=\"1\"/><inertia ixx=\"0\" iyy=\"0\" "
             "izz=\"0\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>"),
       "link 'a'", "not positive definite"},
      {robot(base + massive("a") + joint("j", "prismatic", "world", "a", "<axis xyz=\"0 0 0\"/>")),
       "joint 'j'", "axis must be a nonzero finite vector"},
      {robot(base + "<link name=\"b\"/>" + joint("j", "fixed", "world", "b")), "robot 'r'",
       "no link has a mass"},
  };
  for (const Case& c : cases) {
    const ModelFileError e = refusal(c.urdf);
    EXPECT_EQ(e.file(), "bad.urdf") << c.urdf;
    EXPECT_EQ(e.line(), 0);
    EXPECT_EQ(e.key_path(), c.key_path) << e.what();
    EXPECT_NE(e.problem().find(c.problem), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  }
}

TEST(Urdf, ParsingPrintsNothing) {
  REQUIRE_URDF();
  // urdfdom logs through console_bridge, to stderr unless told otherwise: the library
  // collects the messages instead.
  ::testing::internal::CaptureStderr();
  refusal("<robot name=\"r\"><link name=\"a\"></robot>");
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

TEST(Urdf, WithoutUrdfSupportImportSaysSo) {
  if (urdf_supported()) GTEST_SKIP() << "this build has URDF support";
  const ModelFileError e = refusal(robot(massive("a")));
  EXPECT_NE(e.problem().find("built without URDF support"), std::string::npos) << e.what();
}

TEST(Urdf, LoadModelFileReadsAUrdfFile) {
  REQUIRE_URDF();
  // A free body only: the list form, read by every loader.
  const ModelFile f = load_model_file(kData + "floating.urdf");
  ASSERT_EQ(f.model.num_bodies(), 1);
  const BodySpec& b = f.model.body(0);
  EXPECT_EQ(b.name, "capsule");
  EXPECT_EQ(b.mass, 2.0);
  EXPECT_EQ(b.joint, Vec(0.5, -1, 2));
  EXPECT_EQ(b.com, Vec(0, 0, 0.1));
  const Mat r = rpy(0, 0, 0.7);
  EXPECT_LT(
      (b.inertia - r * Vec(0.3, 0.2, 0.25).asDiagonal() * r.transpose()).cwiseAbs().maxCoeff(),
      1e-16);
  EXPECT_EQ(f.model.gravity(), Vec(0, 0, -9.81));
  // Its initial orientation is the joint's rpy.
  EXPECT_LT((rotation_matrix(Eigen::Vector4d(f.initial.euler_parameters(0))).transpose() -
             rpy(0.3, -0.2, 0.9))
                .cwiseAbs()
                .maxCoeff(),
            1e-15);
  // An error in it names the .urdf.
  try {
    load_model_file(kData + "missing.urdf");
    ADD_FAILURE();
  } catch (const ModelFileError& e) {
    EXPECT_EQ(e.file(), kData + "missing.urdf");
  }
}

TEST(Urdf, LoadModelFileReadsJointedUrdf) {
  REQUIRE_URDF();
  REQUIRE_MAPPING_FORM();
  const ModelFile f = load_model_file(kData + "joints.urdf");
  ASSERT_EQ(f.model.num_bodies(), 5);
  const std::vector<std::string> names{"base", "drone", "upper", "fore", "carriage"};
  const std::vector<int> parents{kGround, 0, 0, 2, 3};
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(f.model.body(k).name, names[k]);
    EXPECT_EQ(f.model.lower_body(k), parents[k]);
  }
  EXPECT_EQ(f.model.body(2).joint, Vec(0, 0, 0.2));
  EXPECT_EQ(f.model.body(3).com, Vec(0.2, 0, 0));
  const ModelFile g = load_model_file(kData + "flange.urdf");
  EXPECT_EQ(g.model.num_bodies(), 2);
  const ModelFile arm = load_model_file(kanedyn::test::kExamples + "/urdf/arm.urdf");
  EXPECT_GE(arm.model.num_bodies(), 6);
}

namespace {

/// A link frame in the inertial frame: its axes (columns) and origin.
struct Pose {
  Mat r;
  Vec p;
};
/// URDF's forward kinematics, one joint: the child at `turn` (a rotation about `axis`) or
/// `slide` (along it), the origin given by xyz and rpy.
Pose child(const Pose& parent, const Vec& xyz, const Mat& origin, const Vec& axis = Vec::UnitX(),
           double turn = 0.0, double slide = 0.0) {
  const Mat r0 = parent.r * origin;
  return {r0 * Eigen::AngleAxisd(turn, axis.normalized()).toRotationMatrix(),
          parent.p + parent.r * xyz + r0 * axis.normalized() * slide};
}

/// Places every body of `file` at joint coordinates q and compares each with `expected`.
void expect_poses(const ModelFile& file, const VectorX& q, const std::vector<Pose>& expected) {
  ASSERT_TRUE(file.jointed());
  State state(file.model);
  joint_state(file.model, q, VectorX::Zero(file.model.num_speeds()), state);
  Data data(file.model);
  compute_kinematics(file.model, state, data);
  ASSERT_EQ(expected.size(), static_cast<std::size_t>(file.model.num_bodies()));
  for (int k = 0; k < file.model.num_bodies(); ++k) {
    // [R_K] maps inertial components to body-K ones: its transpose holds K's axes.
    EXPECT_LT((data.kinematics.R[k].transpose() - expected[k].r).cwiseAbs().maxCoeff(), 1e-14)
        << file.model.body(k).name;
    EXPECT_LT((data.kinematics.p_O[k] - expected[k].p).norm(), 1e-14) << file.model.body(k).name;
  }
}

}  // namespace

TEST(Urdf, JointedModelPlacesEveryLinkAsUrdfDoes) {
  REQUIRE_URDF();
  REQUIRE_MAPPING_FORM();
  {
    const ModelFile f = load_model_file(kData + "joints.urdf");
    ASSERT_TRUE(f.jointed());
    VectorX q = f.q;
    const double a = 0.6, b = -1.1, d = 0.25;  // shoulder, elbow, slide
    q[f.model.coordinate_offset(2)] = a;
    q[f.model.coordinate_offset(3)] = b;
    q[f.model.coordinate_offset(4)] = d;
    const Pose ground{Mat::Identity(), Vec::Zero()};
    const Pose base = child(ground, Vec(0.1, -0.2, 0.3), rpy(0, 0, 0.5));
    const Pose drone = child(base, Vec(1, 2, 3), rpy(0.1, 0.2, 0.3));
    const Pose upper = child(base, Vec(0, 0, 0.2), rpy(0.3, -0.4, 1.2), Vec::UnitY(), a);
    const Pose fore = child(upper, Vec(0.5, 0, 0), Mat::Identity(), Vec::UnitX(), b);
    const Pose carriage =
        child(fore, Vec(0.4, 0, 0), rpy(std::numbers::pi / 2, 0, 0), Vec(0, 0, 2), 0.0, d);
    expect_poses(f, q, {base, drone, upper, fore, carriage});
  }
  {
    const ModelFile f = load_model_file(kData + "flange.urdf");
    VectorX q = f.q;
    const double a = 0.7, b = -0.4;  // j1, tool_joint
    q[f.model.coordinate_offset(0)] = a;
    q[f.model.coordinate_offset(1)] = b;
    const Pose pedestal = child({Mat::Identity(), Vec::Zero()}, Vec(0, 0, 0.1), rpy(0, 0, 0.3));
    const Pose link1 = child(pedestal, Vec(0.02, 0, 0.3), Mat::Identity(), Vec::UnitZ(), a);
    const Pose flange = child(link1, Vec(0, 0.01, 0.4), rpy(0.1, 0.2, 0.785398163397));
    const Pose tool = child(flange, Vec(0.05, 0, 0), rpy(0.2, 0, 0), Vec::UnitZ(), b);
    expect_poses(f, q, {link1, tool});
    // The massless links on fixed joints are frames, placed as URDF places the links.
    const Pose tcp = child(tool, Vec(0, 0, 0.12), Mat::Identity());
    State state(f.model);
    joint_state(f.model, q, VectorX::Zero(f.model.num_speeds()), state);
    Data data(f.model);
    compute_kinematics(f.model, state, data);
    const std::vector<std::pair<std::string, Pose>> frames{
        {"pedestal", pedestal}, {"flange", flange}, {"tcp", tcp}};
    ASSERT_EQ(f.model.frames().size(), frames.size());
    for (const auto& [name, pose] : frames) {
      const int i = f.model.frame_index(name);
      ASSERT_GE(i, 0) << name;
      const FrameState s = frame_state(f.model, i, state, data.kinematics);
      EXPECT_LT((s.R.transpose() - pose.r).cwiseAbs().maxCoeff(), 1e-14) << name;
      EXPECT_LT((s.position - pose.p).norm(), 1e-14) << name;
    }
    EXPECT_EQ(f.model.frame(f.model.frame_index("pedestal")).body, kGround);
    EXPECT_EQ(f.model.frame(f.model.frame_index("tcp")).body, 1);
  }
}

// ---- hostile input: XML depth, composed numbers, the axis rule ----

namespace {

std::string repeat(const std::string& s, int n) {
  std::string out;
  out.reserve(s.size() * static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) out += s;
  return out;
}

/// A robot with one massive link whose XML nests `levels` deep: <robot> is level 1, and
/// <gazebo> elements, which urdfdom skips, nest below it.
std::string nested_robot(int levels) {
  return "<robot name=\"deep\">\n" + massive("a") + repeat("<gazebo>", levels - 1) +
         repeat("</gazebo>", levels - 1) + "\n</robot>\n";
}

detail::XmlScan scan(const std::string& text) { return detail::scan_xml(text, kMaxUrdfDepth); }

const std::string kTooDeep = "nested deeper than " + std::to_string(kMaxUrdfDepth);

}  // namespace

TEST(UrdfDepth, DeepFilesAreRefusedBeforeTheParserRecurses) {
  REQUIRE_URDF();
  // 100,000 levels overflowed the stack inside TinyXML; 30,000 took over 10 s.
  for (const int levels : {100000, 30000}) {
    const std::string text =
        "<robot name=\"r\">" + repeat("<a>", levels - 1) + repeat("</a>", levels - 1) + "</robot>";
    const ModelFileError e = refusal(text);
    EXPECT_EQ(e.file(), "bad.urdf");
    EXPECT_NE(e.problem().find(kTooDeep), std::string::npos) << e.what();
    // At the '<' of the first element too deep: level kMaxUrdfDepth + 1.
    EXPECT_EQ(e.line(), 1);
    EXPECT_EQ(e.column(), 17 + 3 * (kMaxUrdfDepth - 1)) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
  }
}

TEST(UrdfDepth, TheLimitItselfIsAccepted) {
  REQUIRE_URDF();
  EXPECT_EQ(scan(nested_robot(kMaxUrdfDepth)).max_depth, kMaxUrdfDepth);
  // The whole import, not only the scan: the file converts.
  const std::string yaml = urdf_to_model_yaml(nested_robot(kMaxUrdfDepth), "ok.urdf", {}, nullptr);
  EXPECT_EQ(parse_model_file(yaml, "ok.yaml").model.num_bodies(), 1);
  const ModelFileError e = refusal(nested_robot(kMaxUrdfDepth + 1));
  EXPECT_NE(e.problem().find(kTooDeep), std::string::npos) << e.what();
  EXPECT_EQ(e.line(), 4) << e.what();
}

TEST(UrdfDepth, ASelfClosingElementIsALevel) {
  const std::string inner = "<robot>" + repeat("<a>", kMaxUrdfDepth - 2);
  EXPECT_EQ(scan(inner + "<b/>").problem, "");
  EXPECT_EQ(scan(inner + "<b/>").max_depth, kMaxUrdfDepth);
  EXPECT_NE(scan(inner + "<a><b/>").problem.find(kTooDeep), std::string::npos);
}

TEST(UrdfDepth, MarkupThatIsNotAnElementIsNotALevel) {
  const std::string deep = repeat("<a>", 2 * kMaxUrdfDepth);
  // Comments, CDATA sections, DOCTYPE and the XML declaration hold no elements.
  for (const std::string& s : std::vector<std::string>{
           "<robot><!--" + deep + "--></robot>", "<robot><![CDATA[" + deep + "]]></robot>",
           "<!DOCTYPE robot><?xml version=\"1.0\"?><robot><!-- -- > --></robot>"}) {
    const detail::XmlScan r = scan(s);
    EXPECT_EQ(r.problem, "") << s;
    EXPECT_EQ(r.max_depth, 1) << s;
  }
  // Quoted attribute values may hold '>', "/>" and end tags: the tag goes on.
  EXPECT_EQ(scan("<robot a=\"/>\" b='>' c=\"</robot>\"><c/></robot>").max_depth, 2);
  EXPECT_NE(scan("<robot a=\"</robot>\" b='/>'>" + deep).problem.find(kTooDeep), std::string::npos);
  // An end tag outside every element closes nothing (TinyXML skips it).
  EXPECT_NE(scan(repeat("</a>", 50) + "<robot>" + deep).problem.find(kTooDeep), std::string::npos);
}

TEST(UrdfDepth, TheScanReadsAsTinyXmlDoes) {
  // TinyXML ends "<?pi ...>" (anything but "<?xml") at the first '>', as XML would not: what
  // follows is an element to it, and so to the scan.
  EXPECT_EQ(scan("<robot><?pi > <a></a> ?></robot>").max_depth, 2);
  // TinyXML reads "&#...;" to the next ';' when the characters before it are digits back to a
  // '#', whatever lies between: here every end tag, so each <a> nests in the one before.
  const detail::XmlScan hidden = scan("<robot>" + repeat("<a>&#</a>#1;", kMaxUrdfDepth));
  EXPECT_NE(hidden.problem.find(kTooDeep), std::string::npos) << hidden.problem;
  // Where the digits do not reach the '#', TinyXML stops with an error: nothing after is read.
  EXPECT_EQ(scan("<robot><a>&#</a>x1;" + repeat("<a>", 2 * kMaxUrdfDepth)).problem, "");
}

TEST(UrdfDepth, TheScanIsOnePassOverAWideFile) {
  // A million sibling elements: a scan that went back over the text would not finish.
  const std::string wide = "<robot>" + repeat("<link name=\"a&#62;\"/>", 1000000) + "</robot>";
  const detail::XmlScan r = scan(wide);
  EXPECT_EQ(r.problem, "");
  EXPECT_EQ(r.max_depth, 2);
}

TEST(UrdfDepth, AnElementWithTooManyAttributesIsRefused) {
  REQUIRE_URDF();
  // TinyXML's duplicate-attribute check is quadratic: 60,000 attributes took 11.5 s.
  const auto attributes = [](int n) {
    std::string a;
    for (int i = 0; i < n; ++i) a += " a" + std::to_string(i) + "=\"1\"";
    return a;
  };
  const std::string head = "<robot name=\"r\">\n<link name=\"l\"";
  // The link's name is one of its attributes.
  EXPECT_EQ(scan(head + attributes(detail::kMaxXmlAttributes - 1) + "/></robot>").problem, "");
  EXPECT_NE(scan(head + attributes(detail::kMaxXmlAttributes) + "/></robot>").problem, "");
  const ModelFileError e = refusal(head + attributes(60000) + "/></robot>");
  EXPECT_NE(e.problem().find("an element with more than " +
                             std::to_string(detail::kMaxXmlAttributes) + " attributes"),
            std::string::npos)
      << e.what();
  // At the first attribute too many, on the link's line.
  EXPECT_EQ(e.line(), 2);
  EXPECT_EQ(e.column(), static_cast<int>(std::string("<link name=\"l\"").size() +
                                         attributes(detail::kMaxXmlAttributes - 1).size()) +
                            2)
      << e.what();
}

TEST(UrdfDepth, TextTheParserWouldMisreadIsRefused) {
  REQUIRE_URDF();
  struct Case {
    std::string text, problem;
    int line, column;
  };
  const std::vector<Case> cases = {
      {robot(massive("a")) + std::string(1, '\0') + "<a>", "a NUL byte", 5, 1},
      {"<robot name=\"\xe9t\xe9\">", "not valid UTF-8", 1, 14},
      {"<robot>\n  <link name=\"\xef\xbb\xbf\"/>", "U+FEFF", 2, 15},
      {"<robot name=\"\xc0\xaf\"/>", "not valid UTF-8", 1, 14},
  };
  for (const Case& c : cases) {
    const ModelFileError e = refusal(c.text);
    EXPECT_NE(e.problem().find(c.problem), std::string::npos) << e.what();
    EXPECT_EQ(e.line(), c.line) << e.what();
    EXPECT_EQ(e.column(), c.column) << e.what();
  }
  // A byte order mark at the start is no error, nor is UTF-8 text.
  const std::string yaml = urdf_to_model_yaml(
      "\xef\xbb\xbf<robot name=\"r\xc3\xa9\">" + massive("\xe2\x98\x83") + "</robot>", "bom.urdf",
      {}, nullptr);
  EXPECT_EQ(parse_model_file(yaml, "bom.yaml").model.num_bodies(), 1);
}

TEST(UrdfImportLoads, OriginsThatSumPastADoubleAreRefusedNamingTheJoint) {
  REQUIRE_URDF();
  // Each origin is finite; through the folded massless link 'plate' they sum to infinity.
  const std::string text =
      robot("<link name=\"world\"/><link name=\"plate\"/>" + massive("a") +
            joint("mount", "fixed", "world", "plate", "<origin xyz=\"1.5e308 0 0\"/>") +
            joint("j", "fixed", "plate", "a", "<origin xyz=\"1.5e308 0 0\"/>"));
  const ModelFileError e = refusal(text);
  EXPECT_EQ(e.file(), "bad.urdf");
  EXPECT_EQ(e.key_path(), "joint 'j'");
  EXPECT_NE(e.problem().find("massless parent link 'plate' (folded into the ground) is not "
                             "finite: [inf, 0.0, 0.0]"),
            std::string::npos)
      << e.what();
  // The same through a body: folded onto 'a', the link 'tip' carries 'b' out of range.
  const std::string below =
      robot("<link name=\"world\"/><link name=\"tip\"/>" + massive("a") + massive("b") +
            joint("j1", "revolute", "world", "a") +
            joint("tip_mount", "fixed", "a", "tip", "<origin xyz=\"0 -1e308 0\"/>") +
            joint("j2", "revolute", "tip", "b", "<origin xyz=\"0 -1e308 0\"/>"));
  const ModelFileError f = refusal(below);
  EXPECT_EQ(f.key_path(), "joint 'j2'");
  EXPECT_NE(f.problem().find("(folded into body 'a') is not finite: [0.0, -inf, 0.0]"),
            std::string::npos)
      << f.what();
}

TEST(UrdfImportLoads, WhatTheLoaderRefusesIsRefusedByTheImport) {
  REQUIRE_URDF();
  // A value no element check covers (here the gravity option) is caught by reading the
  // converted text back: the error names the URDF file, not a line of the YAML.
  UrdfOptions options;
  options.gravity = {0.0, 0.0, std::numeric_limits<double>::infinity()};
  try {
    urdf_to_model_yaml(robot(massive("a")), "g.urdf", options, nullptr);
    ADD_FAILURE() << "accepted a non-finite gravity";
  } catch (const ModelFileError& e) {
    EXPECT_EQ(e.file(), "g.urdf");
    EXPECT_EQ(e.line(), 0);
    EXPECT_NE(e.problem().find("the converted model does not load (gravity"), std::string::npos)
        << e.what();
  }
}

TEST(UrdfImportLoads, OneAxisRuleForTheImportAndTheLoader) {
  REQUIRE_URDF();
  REQUIRE_MAPPING_FORM();
  // Any finite axis not all zero is a direction, however small: the import and the loader
  // agree (the import refused [1e-200, 0, 0] as zero, the loader read it as the x axis).
  for (const std::string x : {"1e-200", "1e-320", "1e200", "-3"}) {
    const std::string text =
        robot("<link name=\"world\"/>" + massive("a") +
              joint("j", "revolute", "world", "a", "<axis xyz=\"" + x + " 0 0\"/>"));
    const std::string yaml = urdf_to_model_yaml(text, "axis.urdf", {}, nullptr);
    const ModelFile f = parse_model_file(yaml, "axis.yaml");
    ASSERT_TRUE(f.jointed()) << yaml;
    const Vec axis = f.model.joint(0).axis.normalized();
    EXPECT_EQ(axis, Vec(x[0] == '-' ? -1 : 1, 0, 0)) << x;
    // The loader takes the same axis written by hand.
    EXPECT_NO_THROW(parse_model_file(
        "format: kanedyn-model/1\nbodies:\n  - name: a\n    parent: ground\n    mass: 1\n"
        "    inertia: [1, 1, 1]\n    joint: {type: revolute, axis: [" +
            x + ", 0, 0]}\n",
        "hand.yaml"))
        << x;
  }
  // And both refuse a zero axis.
  EXPECT_NE(refusal(robot("<link name=\"world\"/>" + massive("a") +
                          joint("j", "revolute", "world", "a", "<axis xyz=\"0 0 0\"/>")))
                .problem()
                .find("axis must be a nonzero finite vector"),
            std::string::npos);
  EXPECT_THROW(parse_model_file(
                   "format: kanedyn-model/1\nbodies:\n  - name: a\n    parent: ground\n    mass: "
                   "1\n    inertia: [1, 1, 1]\n    joint: {type: revolute, axis: [0, 0, 0]}\n",
                   "hand.yaml"),
               ModelFileError);
}

// ---- kanedyn import ----

namespace {
kanedyn::test::ToolRun run_tool(const std::string& args, std::filesystem::path* dir = nullptr) {
  const std::string test = ::testing::UnitTest::GetInstance()->current_test_info()->name();
  const auto d = kanedyn::test::temp_dir("urdf_" + test);
  if (dir) *dir = d;
  return kanedyn::test::run_in(d, args);
}
}  // namespace

TEST(UrdfCli, ImportWritesTheModelAndPrintsTheNotes) {
  REQUIRE_URDF();
  std::filesystem::path dir;
  const auto r = run_tool("import " + kData + "joints.urdf -o robot.yaml", &dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("wrote robot.yaml"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("kanedyn: note: joint 'elbow': friction is ignored\n"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("kanedyn: note: joints 'shoulder', 'slide': position"), std::string::npos)
      << r.err;
  EXPECT_EQ(slurp(dir / "robot.yaml"),
            urdf_to_model_yaml(slurp(kData + "joints.urdf"), kData + "joints.urdf", {}, nullptr));
  EXPECT_FALSE(std::filesystem::exists(dir / "robot.yaml.partial"));
}

TEST(UrdfCli, FloatingFlagFreesTheRoot) {
  REQUIRE_URDF();
  std::filesystem::path dir;
  const auto r = run_tool("import --floating " + kData + "rotated_inertial.urdf -o m.yaml", &dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const Json m = yaml_json(slurp(dir / "m.yaml"));
  EXPECT_EQ(vec(m.at("bodies")[0].at("joint")), Vec(0, 0, 0));
  // The file loads as it is (a free body needs no joint support).
  EXPECT_EQ(load_model_file((dir / "m.yaml").string()).model.num_bodies(), 1);
}

TEST(UrdfCli, ErrorsAreOneLineAndWriteNothing) {
  REQUIRE_URDF();
  std::filesystem::path dir;
  {
    std::ofstream(kanedyn::test::temp_dir("urdf_bad_input") / "bad.urdf")
        << robot("<link name=\"w\"/><link name=\"hub\"/>" + massive("a") +
                 joint("j1", "continuous", "w", "hub") + joint("j2", "fixed", "hub", "a"));
  }
  const std::string bad =
      (std::filesystem::path(KANEDYN_BINARY_DIR) / "tests/tmp/urdf_bad_input/bad.urdf").string();
  auto r = run_tool("import " + bad + " -o m.yaml", &dir);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "kanedyn: error: " + bad +
                       ": link 'hub': has no mass, but joint 'j1' (revolute) moves it: a massless "
                       "link must hang on a fixed joint (give it a mass and inertia, or make the "
                       "joint fixed)\n");
  EXPECT_FALSE(std::filesystem::exists(dir / "m.yaml"));
  r = run_tool("import " + kData + "nothing.urdf -o m.yaml", &dir);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("nothing.urdf: cannot open"), std::string::npos) << r.err;
  // -o is required: a usage error.
  r = run_tool("import " + kData + "joints.urdf", &dir);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  // The output must not be the input.
  r = run_tool("import " + kData + "joints.urdf -o " + kData + "joints.urdf", &dir);
  EXPECT_EQ(r.exit_code, 1) << r.err;
}

TEST(UrdfCli, ImportWritesNothingWhenTheOriginsOverflow) {
  REQUIRE_URDF();
  const auto in = kanedyn::test::temp_dir("urdf_overflow_input") / "sum.urdf";
  std::ofstream(in) << robot(
      "<link name=\"world\"/><link name=\"plate\"/>" + massive("a") +
      joint("mount", "fixed", "world", "plate", "<origin xyz=\"1.5e308 0 0\"/>") +
      joint("j", "fixed", "plate", "a", "<origin xyz=\"1.5e308 0 0\"/>"));
  std::filesystem::path dir;
  const auto r = run_tool("import " + in.string() + " -o m.yaml", &dir);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(in.string() + ": joint 'j': origin composed"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "m.yaml"));
  EXPECT_FALSE(std::filesystem::exists(dir / "m.yaml.partial"));
}

TEST(UrdfCli, ImportRefusesADeepFileInOneLine) {
  REQUIRE_URDF();
  const auto in = kanedyn::test::temp_dir("urdf_deep_input") / "deep.urdf";
  std::ofstream(in) << "<robot>" + repeat("<a>", 100000) + repeat("</a>", 100000) + "</robot>";
  std::filesystem::path dir;
  const auto r = run_tool("info " + in.string(), &dir);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "kanedyn: error: " + in.string() +
                       ":1:" + std::to_string(8 + 3 * (kMaxUrdfDepth - 1)) + ": elements " +
                       kTooDeep + " levels, the limit for a URDF file (a robot needs under 20)\n");
}

TEST(UrdfCli, ExampleArmImports) {
  REQUIRE_URDF();
  std::filesystem::path dir;
  const auto r =
      run_tool("import " + kanedyn::test::kExamples + "/urdf/arm.urdf -o arm.yaml", &dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Json m = yaml_json(slurp(dir / "arm.yaml"));
  int revolute = 0;
  for (const Json& b : m.at("bodies")) revolute += b.at("joint").at("type") == "revolute";
  EXPECT_EQ(revolute, 6);
}

}  // namespace kanedyn::io

namespace kanedyn::io {
namespace {

// A turn by the rpy a URDF writes for 90 degrees (1.5707963267948966, the double nearest pi/2)
// has cos = 6.1e-17, not 0: a product of inertia that is zero in the file, or a position
// component the turn carries onto 0, came out as 1e-17 round-off. It is written as an exact 0
// (docs/urdf.md, "Zeros stay zeros"): the turns are rotation matrices without their
// round-off, so a quarter turn permutes the axes exactly. A small number the file gives alone
// is not round-off of anything, and stays.
TEST(Urdf, RoundOffOfATurnIsWrittenAsZero) {
  REQUIRE_URDF();
  const std::string quarter = "1.5707963267948966";
  const std::string urdf = robot(
      massive("base") + "<link name=\"arm\"><inertial><origin xyz=\"0 0 0.5\" rpy=\"" + quarter +
      " 0 0\"/><mass value=\"1\"/><inertia ixx=\"0.1\" iyy=\"0.2\" izz=\"0.3\" ixy=\"0\" "
      "ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
      "<link name=\"flange\"/>\n" +
      "<link name=\"tool\"><inertial><origin xyz=\"0 0 1e-17\"/><mass value=\"1\"/><inertia "
      "ixx=\"0.1\" iyy=\"0.1\" izz=\"0.1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n" +
      joint("shoulder", "revolute", "base", "arm",
            "<origin xyz=\"0 0 1\" rpy=\"0 " + quarter + " 0\"/><axis xyz=\"0 0 1\"/>") +
      joint("mount", "fixed", "arm", "flange",
            "<origin xyz=\"0 0 0.1\" rpy=\"" + quarter + " 0 0\"/>") +
      joint("tip", "fixed", "flange", "tool", "<origin xyz=\"0 0.04 0\"/>"));
  const std::string text = urdf_to_model_yaml(urdf, "turns.urdf", {}, nullptr);
  const Json m = yaml_json(text);
  // R_x(90 deg) diag(0.1, 0.2, 0.3) R_x^T = diag(0.1, 0.3, 0.2): the off-diagonal entries are
  // written as 0, the diagonal is the turned one to round-off.
  const Json& arm = body(m, "arm");
  const Json& i = arm.at("inertia");
  for (int k = 3; k < 6; ++k) EXPECT_EQ(i[k].get<double>(), 0.0) << text;
  EXPECT_NEAR(i[0].get<double>(), 0.1, 1e-16);
  EXPECT_NEAR(i[1].get<double>(), 0.3, 1e-16);
  EXPECT_NEAR(i[2].get<double>(), 0.2, 1e-16);
  // The tool is welded through the massless flange: Q = (0, 0, 0.1) + R_x(90 deg) (0, 0.04, 0)
  // = (0, 0.04 cos, 0.1 + 0.04 sin): the y component is written as 0, not 2.4e-18.
  const Json& tool = body(m, "tool");
  const Vec at = vec(tool.at("joint").at("at"));
  EXPECT_EQ(at.x(), 0.0);
  EXPECT_EQ(at.y(), 0.0) << text;
  EXPECT_NEAR(at.z(), 0.14, 1e-16);
  // A small number the file gives alone is kept: the tool's com of 1e-17 has no larger
  // neighbour whose round-off it could be.
  EXPECT_EQ(vec(tool.at("com")), Vec(0, 0, 1e-17));
}

}  // namespace
}  // namespace kanedyn::io
