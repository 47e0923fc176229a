// URDF import (docs/urdf.md): urdfdom parses the XML into links and joints; the tree is then
// walked from the root, massless links folded into the frames of their neighbours, and written
// as a kanedyn-model/1 file with the mapping form of `joint`.
#include "kanedyn/io/urdf.hpp"

#include "urdf_convert.hpp"

#ifdef KANEDYN_HAVE_URDF
#include <console_bridge/console.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "kanedyn/direction.hpp"
#include "kanedyn/io/model_writer.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/model.hpp"
#include "xml_scan.hpp"
#endif

namespace kanedyn::io {

#ifndef KANEDYN_HAVE_URDF

bool urdf_supported() { return false; }

std::string detail::convert_urdf(const std::string&, const std::string& source_name,
                                 const UrdfOptions&, std::vector<std::string>*,
                                 std::optional<ModelFile>*) {
  throw ModelFileError(
      source_name, 0, 0, "",
      "this kanedyn was built without URDF support (configured with KANEDYN_URDF=OFF, "
      "or without liburdfdom): install liburdfdom-dev (scripts/install-deps.sh), "
      "configure with -DKANEDYN_URDF=AUTO and rebuild");
}

#else

bool urdf_supported() { return true; }

namespace {

using Quat = Eigen::Quaterniond;
using Vec = Eigen::Vector3d;

/// A link's place: the frame it is rigidly fixed in (a body, or the ground) and the link
/// frame's pose in it; and its orientation relative to the ground with every joint at zero.
struct Place {
  int body = -1;  ///< index into the bodies written, -1 for the ground
  Vec p = Vec::Zero();
  Quat q = Quat::Identity();
  Quat absolute = Quat::Identity();
};

struct Body {
  std::string name, link, joint, comment;
  int parent = -1;
  double mass = 0.0;
  Eigen::Matrix3d inertia;
  Vec com;
  std::string joint_type;  ///< "free", "weld", "revolute", "prismatic", "planar"
  Vec at = Vec::Zero();
  Quat frame = Quat::Identity();
  Vec axis = Vec::UnitX();
  Quat absolute = Quat::Identity();  ///< written as `initial.rotation` of a free body
  double damping = 0.0;
};

/// The shortest decimal that reads back as the same double, spelled so that YAML 1.1 readers
/// (PyYAML) read a float too (yaml_float: 8.0e-04, not 8e-04). A non-finite value, which only
/// messages quote, as to_chars writes it.
std::string num(double v) {
  if (std::isfinite(v)) return yaml_float(v);
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string vec(const Vec& v) {
  return "[" + num(v.x()) + ", " + num(v.y()) + ", " + num(v.z()) + "]";
}

/// Entries of a rotation within this many units in the last place of 0 are taken as 0. The
/// rpy a URDF writes for a quarter turn (1.5707963267948966, the double nearest pi/2) has a
/// cosine of 6.1e-17, and a quaternion's matrix adds a few ulps more: a turned 0 (a product of
/// inertia, a position's component) would come out as 1e-17 round-off. An angle this close to
/// a multiple of a quarter turn is that multiple as a file writes it; a real angle's sine
/// is never that small (1.4e-14 rad is 3e-9 arc seconds).
constexpr double kRoundOffUlps = 64.0;

/// The rotation matrix of q with that round-off removed: each entry below kRoundOffUlps ulps
/// of 1 becomes 0, and a row left with one nonzero entry becomes the unit vector it is, so a
/// quarter turn is an exact permutation of the axes and a 0 it turns stays 0.
Eigen::Matrix3d rotation(const Quat& q) {
  Eigen::Matrix3d r = q.normalized().toRotationMatrix();
  const double floor = kRoundOffUlps * std::numeric_limits<double>::epsilon();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (std::abs(r(i, j)) < floor) r(i, j) = 0.0;
  for (int i = 0; i < 3; ++i) {
    int nonzero = 0, at = 0;
    for (int j = 0; j < 3; ++j)
      if (r(i, j) != 0.0) ++nonzero, at = j;
    if (nonzero == 1) r(i, at) = r(i, at) > 0.0 ? 1.0 : -1.0;
  }
  return r;
}

/// A unit vector (an axis of a turn) as written: entries below kRoundOffUlps ulps as 0.
std::string written(Vec v) {
  for (double& x : v)
    if (std::abs(x) < kRoundOffUlps * std::numeric_limits<double>::epsilon()) x = 0.0;
  return vec(v);
}

std::string quoted_name(const std::string& kind, const std::string& name) {
  return kind + " '" + printable(name, 60) + "'";
}

/// A YAML double-quoted scalar holding `text` exactly: backslash and quote escaped, control
/// characters as printable() writes them (\n, \t, \xNN, \uNNNN are YAML escapes too).
std::string yaml_string(const std::string& text) {
  std::string s;
  for (const char c : text) {
    if (c == '\\' || c == '"') s += '\\';
    s += c;
  }
  return "\"" + printable(s) + "\"";
}

/// A massless link on a fixed joint: a frame of the body (or the ground) it is fixed to.
struct FrameOut {
  std::string name, link;
  Place at;
};

/// The axis and angle of q, the angle in [0, pi].
std::string axis_angle(Quat q) {
  q.normalize();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const Vec v = q.vec();
  const double s = v.norm();
  const double angle = 2.0 * std::atan2(s, q.w());
  return "{axis: " + written(v / s) + ", angle: " + num(angle) + "}";
}

bool is_identity(const Quat& q) { return q.vec().squaredNorm() == 0.0; }

Quat quat(const urdf::Rotation& r) { return Quat(r.w, r.x, r.y, r.z).normalized(); }
Vec vec3(const urdf::Vector3& v) { return Vec(v.x, v.y, v.z); }

/// Body names: [A-Za-z0-9_-]+, `ground` reserved. Other characters become '_'.
std::string body_name(const std::string& link) {
  std::string name = link;
  for (char& c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) c = '_';
  if (name.empty()) name = "_";
  if (name == "ground") name = "ground_";
  return name;
}

/// Notes of one kind for several elements, so that a 30-joint robot gives one line per kind.
class Notes {
 public:
  /// `kind` is "joint" or "link".
  void add(const std::string& kind, const std::string& text, const std::string& element) {
    auto it = std::find_if(kinds_.begin(), kinds_.end(),
                           [&](const Kind& k) { return k.kind == kind && k.text == text; });
    if (it == kinds_.end()) {
      kinds_.push_back({kind, text, {}});
      it = kinds_.end() - 1;
    }
    it->elements.push_back(element);
  }
  void add_line(const std::string& line) { lines_.push_back(line); }
  std::vector<std::string> lines() const {
    std::vector<std::string> out = lines_;
    constexpr std::size_t kShown = 8;
    for (const Kind& k : kinds_) {
      std::string line = k.kind + (k.elements.size() > 1 ? "s " : " ");
      for (std::size_t i = 0; i < k.elements.size() && i < kShown; ++i)
        line += (i ? ", '" : "'") + printable(k.elements[i], 60) + "'";
      if (k.elements.size() > kShown)
        line += " and " + std::to_string(k.elements.size() - kShown) + " more";
      out.push_back(line + ": " + k.text);
    }
    return out;
  }

 private:
  struct Kind {
    std::string kind, text;
    std::vector<std::string> elements;
  };
  std::vector<Kind> kinds_;
  std::vector<std::string> lines_;
};

/// `--floating` with a massless root link (`base_link`, `world`): the root has no body to free,
/// so the first body with mass below it is freed, and what hung on the root (the other bodies
/// and the frames on the ground) is hung on that body at the same pose, so that the robot moves
/// as one, as a free-flyer joint on the root link would move it. The body freed is the first
/// one fixed to the root (through massless links), else the root's only body on a moving joint,
/// whose joint is then given up (below a massless root it carried no load); with several such
/// bodies and none fixed, freeing one would cut the others' connection: refused. A body on a
/// floating joint stays on the ground: below a massless link it is free of the rest anyway. The
/// freed body is moved to the front, so that it comes before the bodies now hung on it.
template <typename Fail>
void free_below_massless_root(const std::string& root, std::vector<Body>& bodies,
                              std::vector<FrameOut>& frames, Notes& notes, const Fail& fail) {
  const int n = static_cast<int>(bodies.size());
  const auto on_root = [&](int k) {
    return bodies[static_cast<std::size_t>(k)].parent < 0 &&
           bodies[static_cast<std::size_t>(k)].joint_type != "free";
  };
  int chosen = -1;
  for (int k = 0; k < n && chosen < 0; ++k)
    if (on_root(k) && bodies[static_cast<std::size_t>(k)].joint_type == "weld") chosen = k;
  for (int k = 0; k < n && chosen < 0; ++k)
    if (on_root(k)) chosen = k;
  if (chosen < 0) return;  // every body below the root is on a floating joint: free already
  const bool welded = bodies[static_cast<std::size_t>(chosen)].joint_type == "weld";
  for (int k = 0; k < n && !welded; ++k)
    if (k != chosen && on_root(k))
      fail(quoted_name("root link", root),
           "has no mass and moves link '" +
               printable(bodies[static_cast<std::size_t>(chosen)].link, 60) + "' and link '" +
               printable(bodies[static_cast<std::size_t>(k)].link, 60) +
               "' on joints of their own: the option floating cannot free a massless root that "
               "moves several links (give the root link a mass and inertia)");
  // The chosen body first: old index k is new index remap(k).
  const auto remap = [&](int k) { return k == chosen ? 0 : (k < chosen ? k + 1 : k); };
  std::rotate(bodies.begin(), bodies.begin() + chosen, bodies.begin() + chosen + 1);
  for (Body& b : bodies)
    if (b.parent >= 0) b.parent = remap(b.parent);
  for (FrameOut& f : frames)
    if (f.at.body >= 0) f.at.body = remap(f.at.body);

  Body& first = bodies.front();
  // It hung on the ground: its at and frame are its pose in the root's frame.
  const Quat turn = first.frame.conjugate();
  for (std::size_t k = 1; k < bodies.size(); ++k) {
    Body& b = bodies[k];
    if (b.parent >= 0 || b.joint_type == "free") continue;
    b.parent = 0;
    b.at = rotation(turn) * (b.at - first.at);
    b.frame = (turn * b.frame).normalized();
  }
  for (FrameOut& f : frames) {
    if (f.at.body >= 0) continue;
    f.at.body = 0;
    f.at.p = rotation(turn) * (f.at.p - first.at);
    f.at.q = (turn * f.at.q).normalized();
  }
  std::string how = "its fixed joint '" + printable(first.joint, 60) + "' replaced by a free joint";
  if (!welded) {
    how = "its " + first.joint_type + " joint '" + printable(first.joint, 60) +
          "' replaced by a free joint, with the joint's input" +
          (first.damping > 0.0 ? " and damping" : "");
    first.damping = 0.0;
  }
  first.joint_type = "free";
  first.absolute = first.frame;
  first.comment = "freed: the root link " + printable(root) + " has no mass (option floating)";
  notes.add_line(quoted_name("root link", root) + " has no mass: the option floating frees link '" +
                 printable(first.link, 60) + "', the first link with mass below it (" + how +
                 "); what is fixed to the root moves with it");
}

/// urdfdom reports through console_bridge, which prints to the terminal by default: its
/// messages are collected instead (the library never prints), the errors to refuse the file
/// with (urdfdom returns a model even when it could not read an element: a link whose
/// <inertial> is broken comes back massless), the warnings as notes. console_bridge's handler
/// is process-wide: one parse at a time.
class Capture : public console_bridge::OutputHandler {
 public:
  std::vector<std::string> errors, warnings;
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR)
      errors.push_back(text);
    else if (level == console_bridge::CONSOLE_BRIDGE_LOG_WARN)
      warnings.push_back(text);
  }
};

std::mutex& console_mutex() {
  static std::mutex m;
  return m;
}

/// urdfdom's model. Its links own their child links through shared pointers, so the links of
/// a closed loop own each other and would never be freed: they are cut apart when it goes.
class UrdfModel {
 public:
  explicit UrdfModel(urdf::ModelInterfaceSharedPtr model) : model_(std::move(model)) {}
  UrdfModel(UrdfModel&& other) noexcept : model_(std::move(other.model_)) {}
  UrdfModel(const UrdfModel&) = delete;
  UrdfModel& operator=(const UrdfModel&) = delete;
  UrdfModel& operator=(UrdfModel&&) = delete;
  ~UrdfModel() {
    if (!model_) return;
    for (const auto& [name, link] : model_->links_) {
      link->child_links.clear();
      link->child_joints.clear();
    }
  }
  explicit operator bool() const { return model_ != nullptr; }
  const urdf::ModelInterface* operator->() const { return model_.get(); }

 private:
  urdf::ModelInterfaceSharedPtr model_;
};

UrdfModel parse_urdf(const std::string& text, const std::string& source,
                     std::vector<std::string>& warnings) {
  // TinyXML recurses once per element level: a deep file would overflow the stack.
  if (const detail::XmlScan scan = detail::scan_xml(text, kMaxUrdfDepth); !scan.problem.empty())
    throw ModelFileError(source, scan.line, scan.column, "", scan.problem);
  // TinyXML steps past the terminating NUL at the end of an unterminated comment, CDATA
  // section or quoted value (by the length of the delimiter it looked for): the padding keeps
  // those reads inside the string, where they meet NULs and stop. The scan refused any NUL in
  // the text, so TinyXML reads all of it.
  std::string padded;
  padded.reserve(text.size() + 8);
  padded.append(text).append(8, '\0');
  std::lock_guard<std::mutex> lock(console_mutex());
  Capture capture;
  const console_bridge::LogLevel level = console_bridge::getLogLevel();
  console_bridge::useOutputHandler(&capture);
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_WARN);
  struct Restore {
    console_bridge::LogLevel level;
    ~Restore() {
      console_bridge::restorePreviousOutputHandler();
      console_bridge::setLogLevel(level);
    }
  } restore{level};
  urdf::ModelInterfaceSharedPtr parsed;
  try {
    parsed = urdf::parseURDF(padded);
  } catch (const std::exception& e) {
    capture.errors.push_back(e.what());
  }
  UrdfModel model(std::move(parsed));
  if (!model || !capture.errors.empty()) {
    // urdfdom quotes the file's bytes; printable() cuts its input, and a control byte becomes
    // four characters: 200 keeps the message under 1000.
    std::string why;
    for (const std::string& e : capture.errors) why += (why.empty() ? "" : "; ") + e;
    if (why.empty()) why = "no reason given";
    throw ModelFileError(
        source, 0, 0, "",
        "not a valid URDF file (urdfdom could not parse it): " + printable(why, 200));
  }
  for (const std::string& w : capture.warnings) warnings.push_back("urdfdom: " + w);
  return model;
}

}  // namespace

std::string detail::convert_urdf(const std::string& urdf_text, const std::string& source_name,
                                 const UrdfOptions& options, std::vector<std::string>* notes_out,
                                 std::optional<ModelFile>* loaded) {
  std::vector<std::string> warnings;
  const UrdfModel model = parse_urdf(urdf_text, source_name, warnings);
  const auto fail = [&](const std::string& element, const std::string& problem) -> void {
    throw ModelFileError(source_name, 0, 0, element, problem);
  };
  Notes notes;
  for (const std::string& w : warnings) notes.add_line(w);

  // The joints below each link, in urdfdom's order (by joint name); each link the child of one
  // joint at most: a second one closes a loop.
  std::unordered_map<std::string, std::vector<const urdf::Joint*> > below;
  std::unordered_map<std::string, const urdf::Joint*> above;
  for (const auto& [name, joint] : model->joints_) {
    if (const auto [it, fresh] = above.emplace(joint->child_link_name, joint.get()); !fresh)
      fail(quoted_name("link", joint->child_link_name),
           "is the child of two joints, '" + printable(it->second->name, 60) + "' and '" +
               printable(name, 60) +
               "': the joints form a closed loop, and the import builds a tree (import the tree, "
               "then close the loop with a constraint of the model file: docs/urdf.md)");
    below[joint->parent_link_name].push_back(joint.get());
  }

  const urdf::LinkConstSharedPtr root = model->getRoot();
  const auto mass_of = [&](const urdf::Link& link) {
    if (!link.inertial) return 0.0;
    const double m = link.inertial->mass;
    if (!std::isfinite(m) || m < 0.0)
      fail(quoted_name("link", link.name), "mass must be a finite number >= 0, got " + num(m));
    return m;
  };

  std::vector<Body> bodies;
  std::unordered_map<std::string, std::string> body_link;  // body name -> link
  const auto add_body = [&](const urdf::Link& link, const urdf::Joint* joint, const Place& at) {
    Body b;
    b.link = link.name;
    b.name = body_name(link.name);
    if (b.name != link.name)
      notes.add("link",
                "is the body '" + b.name +
                    "' (body names use only [A-Za-z0-9_-], and 'ground' is reserved)",
                link.name);
    if (const auto [it, fresh] = body_link.emplace(b.name, link.name); !fresh)
      fail(quoted_name("link", link.name),
           "its body name '" + b.name + "' is that of " + quoted_name("link", it->second) +
               " too (body names use only [A-Za-z0-9_-]): rename one of them");
    const urdf::Inertial& in = *link.inertial;
    b.mass = in.mass;
    Eigen::Matrix3d i;
    i << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
    const Eigen::Matrix3d r = rotation(quat(in.origin.rotation));
    b.inertia = r * i * r.transpose();
    b.inertia = (0.5 * (b.inertia + b.inertia.transpose())).eval();
    if (!b.inertia.allFinite())
      fail(quoted_name("link", link.name), "inertia has a non-finite entry");
    if (const std::string problem = check_inertia(b.inertia); !problem.empty())
      fail(quoted_name("link", link.name), problem + " (about the mass centre, in link axes)");
    b.com = vec3(in.origin.position);
    if (!b.com.allFinite()) fail(quoted_name("link", link.name), "inertial origin is not finite");
    b.parent = at.body;
    b.at = at.p;
    b.frame = at.q;
    b.absolute = at.absolute;
    if (joint) b.joint = joint->name;
    bodies.push_back(std::move(b));
    return static_cast<int>(bodies.size()) - 1;
  };

  std::vector<FrameOut> frames;

  std::unordered_map<std::string, Place> place;
  // Depth first, without recursion (a chain may be thousands of links long): a body is
  // written when its joint comes off the stack, so each subtree is written whole.
  std::vector<const urdf::Joint*> stack;
  const auto push_below = [&](const urdf::Link& link) {
    const auto it = below.find(link.name);
    if (it == below.end()) return;
    // In reverse, so that the joints come off in urdfdom's order.
    for (auto j = it->second.rbegin(); j != it->second.rend(); ++j) stack.push_back(*j);
  };
  const double root_mass = mass_of(*root);
  if (root_mass > 0.0) {
    const int k = add_body(*root, nullptr, Place{});
    bodies[k].joint_type = options.floating ? "free" : "weld";
    place[root->name] = Place{k, Vec::Zero(), Quat::Identity(), Quat::Identity()};
  } else {
    place[root->name] = Place{};
  }
  bool geometry = root->visual || root->collision;
  push_below(*root);
  std::size_t visited = 1;
  while (!stack.empty()) {
    const urdf::Joint& joint = *stack.back();
    stack.pop_back();
    ++visited;
    const Place from = place.at(joint.parent_link_name);
    {
      const std::string jname = quoted_name("joint", joint.name);
      const urdf::LinkConstSharedPtr child = model->getLink(joint.child_link_name);
      if (!child)
        fail(jname, "its child link '" + printable(joint.child_link_name, 60) + "' is not defined");
      if (joint.mimic)
        fail(jname,
             "mimics joint '" + printable(joint.mimic->joint_name, 60) +
                 "': kanedyn has no coupled joints (give it its own coordinate, or make it fixed)");
      std::string type;
      switch (joint.type) {
        case urdf::Joint::REVOLUTE:
        case urdf::Joint::CONTINUOUS:
          type = "revolute";
          break;
        case urdf::Joint::PRISMATIC:
          type = "prismatic";
          break;
        case urdf::Joint::FIXED:
          type = "weld";
          break;
        case urdf::Joint::FLOATING:
          type = "free";
          break;
        case urdf::Joint::PLANAR:
          type = "planar";
          break;
        default:
          fail(jname, "has an unknown type");
      }
      const urdf::Pose& o = joint.parent_to_joint_origin_transform;
      const Vec xyz = vec3(o.position);
      if (!xyz.allFinite() ||
          !Eigen::Vector4d(o.rotation.x, o.rotation.y, o.rotation.z, o.rotation.w).allFinite())
        fail(jname, "origin is not finite");
      // The child's frame at zero joint position, in the frame `from` is fixed in.
      Place to{from.body, from.p + rotation(from.q) * xyz, (from.q * quat(o.rotation)).normalized(),
               (from.absolute * quat(o.rotation)).normalized()};
      // Each origin is finite, but their sum through folded links need not be (1.5e308 twice).
      if (!to.p.allFinite())
        fail(jname, "origin composed with those of the fixed joints above its massless parent " +
                        quoted_name("link", joint.parent_link_name) + " (folded into " +
                        (from.body < 0 ? std::string("the ground")
                                       : "body '" + bodies[from.body].name + "'") +
                        ") is not finite: " + vec(to.p));
      const double mass = mass_of(*child);
      if (mass > 0.0) {
        const int k = add_body(*child, &joint, to);
        bodies[k].joint_type = type;
        if (type == "revolute" || type == "prismatic") {
          // The loader's rule (kanedyn/direction.hpp): any finite axis that is not all zero.
          bodies[k].axis = vec3(joint.axis);
          if (!scaled_direction(bodies[k].axis))
            fail(jname, "axis must be a nonzero finite vector, got " + vec(bodies[k].axis));
        }
        to = Place{k, Vec::Zero(), Quat::Identity(), to.absolute};
        if (type == "planar") {
          // URDF's planar joint moves in the plane normal to its axis (joint frame components);
          // kanedyn's moves in F's x-y plane, turns about F's z, and K is F at zero. So F, and
          // with it the body frame, is the link frame turned by a, which takes z onto the
          // axis: the mass properties are rewritten in F, and the link hangs in the body
          // turned back by a^-1.
          const Vec axis = vec3(joint.axis);
          const std::optional<Vec> n = scaled_direction(axis);
          if (!n) fail(jname, "axis must be a nonzero finite vector, got " + vec(axis));
          const Quat a = Quat::FromTwoVectors(Vec::UnitZ(), n->normalized());
          if (!is_identity(a)) {
            Body& b = bodies[static_cast<std::size_t>(k)];
            const Eigen::Matrix3d r = rotation(a);  // F components to link components
            b.frame = (b.frame * a).normalized();
            b.com = r.transpose() * b.com;
            b.inertia = r.transpose() * b.inertia * r;
            b.inertia = (0.5 * (b.inertia + b.inertia.transpose())).eval();
            b.comment = "body frame: the link frame turned so that its z is the planar axis";
            notes.add("joint",
                      "is planar about an axis other than its z: its link's body frame is the "
                      "link frame turned to put z on the axis (kanedyn's plane is F's x-y plane)",
                      joint.name);
            to.q = a.conjugate();
          }
        }
      } else if (type == "weld") {
        frames.push_back({body_name(child->name), child->name, to});
      } else {
        fail(quoted_name("link", child->name),
             "has no mass, but " + jname + " (" +
                 (type == "free" ? std::string("floating") : type) +
                 ") moves it: a massless link must hang on a fixed joint (give it a mass and "
                 "inertia, or make the joint fixed)");
      }
      // What the mapping leaves out, said once per kind.
      const bool moving = type == "revolute" || type == "prismatic";
      if (joint.limits && (moving || type == "planar"))
        notes.add("joint",
                  joint.type == urdf::Joint::CONTINUOUS
                      ? "velocity and effort limits are ignored"
                      : "position, velocity and effort limits are ignored",
                  joint.name);
      if (joint.safety) notes.add("joint", "safety controller is ignored", joint.name);
      if (joint.calibration) notes.add("joint", "calibration is ignored", joint.name);
      if (joint.dynamics) {
        const double d = joint.dynamics->damping, f = joint.dynamics->friction;
        if (!std::isfinite(d) || d < 0.0)
          fail(jname, "damping must be a finite number >= 0, got " + num(d));
        if (f != 0.0) notes.add("joint", "friction is ignored", joint.name);
        if (d > 0.0) {
          if (moving && mass > 0.0)
            bodies.back().damping = d;
          else  // a planar joint's one damping would mix N s/m and N m s/rad
            notes.add("joint",
                      "damping is ignored (kanedyn damps revolute and prismatic joints only)",
                      joint.name);
        }
      }
      place[child->name] = to;
      geometry = geometry || child->visual || child->collision;
      push_below(*child);
    }
  }
  if (visited != model->links_.size()) {
    for (const auto& [name, link] : model->links_)
      if (!place.count(name))
        fail(quoted_name("link", name),
             "cannot be reached from the root link '" + printable(root->name, 60) +
                 "': its joints form a closed loop, and the import builds a tree (import the "
                 "tree, then close the loop with a constraint of the model file: docs/urdf.md)");
  }
  if (bodies.empty())
    fail(quoted_name("robot", model->getName()),
         "no link has a mass: there is no body to simulate");
  if (options.floating && root_mass <= 0.0)
    free_below_massless_root(root->name, bodies, frames, notes, fail);
  if (geometry) notes.add_line("visual and collision geometry is ignored");
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const FrameOut& frame = frames[f];
    if (const auto it = body_link.find(frame.name); it != body_link.end())
      fail(quoted_name("link", frame.link),
           "its frame name '" + frame.name + "' is the body name of " +
               quoted_name("link", it->second) + " (names use only [A-Za-z0-9_-]): rename one");
    for (std::size_t g = 0; g < f; ++g)
      if (frames[g].name == frame.name)
        fail(quoted_name("link", frame.link),
             "its frame name '" + frame.name + "' is that of " +
                 quoted_name("link", frames[g].link) +
                 " too (names use only [A-Za-z0-9_-]): rename one of them");
    notes.add("link",
              "has no mass and a fixed joint: it is a frame of " +
                  (frame.at.body < 0 ? std::string("the ground")
                                     : "body '" + bodies[frame.at.body].name + "'"),
              frame.link);
  }

  std::string y;
  y += "# Converted from " + printable(source_name) + " by kanedyn's URDF import (docs/urdf.md).\n";
  y += "# Each body is the link of its name, with the link frame as the body frame (a planar\n";
  y += "# joint's body says so where its frame is turned).\n";
  y += "format: kanedyn-model/1\n";
  if (!model->getName().empty()) y += "name: " + yaml_string(model->getName()) + "\n";
  y += "gravity: " + vec(Vec(options.gravity[0], options.gravity[1], options.gravity[2])) + "\n";
  y += "bodies:\n";
  for (const Body& b : bodies) {
    y += "  - name: \"" + b.name + "\"";
    y += b.joint.empty() ? "  # root link\n"
                         : "  # joint " + printable(b.joint) +
                               (b.comment.empty() ? std::string() : "; " + b.comment) + "\n";
    y += "    parent: " +
         (b.parent < 0 ? std::string("ground") : "\"" + bodies[b.parent].name + "\"") + "\n";
    y += "    mass: " + num(b.mass) + "\n";
    const Eigen::Matrix3d& i = b.inertia;
    y += "    inertia: [" + num(i(0, 0)) + ", " + num(i(1, 1)) + ", " + num(i(2, 2)) + ", " +
         num(i(0, 1)) + ", " + num(i(0, 2)) + ", " + num(i(1, 2)) + "]\n";
    y += "    com: " + vec(b.com) + "\n";
    if (b.joint_type == "free") {
      // The list form: the point Q_K, orientation absolute (every joint above at zero).
      y += "    joint: " + vec(b.at) + "\n";
      if (!is_identity(b.absolute))
        y += "    initial:\n      rotation: " + axis_angle(b.absolute) + "\n";
      continue;
    }
    y += "    joint:\n      type: " + b.joint_type + "\n      at: " + vec(b.at) + "\n";
    if (!is_identity(b.frame)) y += "      frame: " + axis_angle(b.frame) + "\n";
    if (b.joint_type == "revolute" || b.joint_type == "prismatic")
      y += "      axis: " + vec(b.axis) + "\n";
  }
  bool forces = false;
  for (const Body& b : bodies) {
    if (b.damping <= 0.0) continue;
    if (!forces) y += "forces:\n";
    forces = true;
    y += "  - type: joint_spring  # <dynamics> of joint " + printable(b.joint) + "\n";
    y += "    body: \"" + b.name + "\"\n    damping: " + num(b.damping) + "\n";
  }
  if (!frames.empty()) y += "frames:  # massless links on fixed joints\n";
  for (const FrameOut& f : frames) {
    y += "  - name: \"" + f.name + "\"  # link " + printable(f.link) + "\n";
    y += "    body: " +
         (f.at.body < 0 ? std::string("ground") : "\"" + bodies[f.at.body].name + "\"") + "\n";
    y += "    at: " + vec(f.at.p) + "\n";
    if (!is_identity(f.at.q)) y += "    rotation: " + axis_angle(f.at.q) + "\n";
  }
  // Every revolute, continuous and prismatic joint is an actuator: a joint input named after it
  // (u on its speed, the joint torque or force), so that a controller can drive the robot.
  {
    std::vector<std::string> used;
    bool any = false;
    for (const Body& b : bodies) {
      if (b.joint_type != "revolute" && b.joint_type != "prismatic") continue;
      std::string name = body_name(b.joint);
      for (int n = 2; std::find(used.begin(), used.end(), name) != used.end(); ++n)
        name = body_name(b.joint) + "-" + std::to_string(n);
      used.push_back(name);
      if (!any) y += "inputs:  # the joints' torques and forces\n";
      any = true;
      y += "  - {name: \"" + name + "\", type: joint, body: \"" + b.name + "\"}  # joint " +
           printable(b.joint) + "\n";
    }
  }
  // What is written must load: read it back with the loader's own rules, so that no command
  // refuses a file the import wrote. A refusal here is a value the checks above let through
  // (a number that reads back out of range, say); it names the URDF's link.
  try {
    ModelFile file = parse_model_file(y, source_name);
    if (loaded) loaded->emplace(std::move(file));
  } catch (const ModelFileError& e) {
    std::string element;
    const std::string& path = e.key_path();
    if (path.starts_with("bodies[")) {
      std::size_t k = 0;
      const auto [end, error] = std::from_chars(path.data() + 7, path.data() + path.size(), k);
      if (error == std::errc() && end != path.data() + path.size() && *end == ']' &&
          k < bodies.size())
        element = quoted_name("link", bodies[k].link);
    }
    throw ModelFileError(source_name, 0, 0, element,
                         "the converted model does not load (" +
                             (path.empty() ? std::string() : path + ": ") + e.problem() + ")");
  }
  if (notes_out) *notes_out = notes.lines();
  return y;
}

#endif

std::string urdf_to_model_yaml(const std::string& urdf_text, const std::string& source_name,
                               const UrdfOptions& options, std::vector<std::string>* notes) {
  return detail::convert_urdf(urdf_text, source_name, options, notes, nullptr);
}

}  // namespace kanedyn::io
