// The jointed models of the peer comparison and their description for the engines.
#include "jointed.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <stdexcept>

#include "kanedyn/constraints.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/testing/generate.hpp"

namespace peers {
namespace {

using kanedyn::Joint;
using kanedyn::JointLoad;
using kanedyn::JointType;
using kanedyn::Vector3;
using kanedyn::Vector4;
using kanedyn::VectorX;

size_t at(int i) { return static_cast<size_t>(i); }

// describe_jointed casts JointType to JointKind: the same enumerators in the same order.
static_assert(std::size(kanedyn::kJointTypes) == static_cast<size_t>(JointKind::screw) + 1 &&
                  static_cast<int>(JointType::screw) == static_cast<int>(JointKind::screw),
              "peer.hpp's JointKind must list kanedyn's joint types");

// Uniform in [lo, hi] from the raw 32-bit output (std::uniform_real_distribution's results
// differ between standard libraries).
double uniform(std::mt19937& rng, double lo, double hi) {
  return lo + (hi - lo) * (static_cast<double>(rng()) / 4294967295.0);
}

Vector3 random_unit(std::mt19937& rng) {
  for (;;) {
    // Braces: the three draws in order (a constructor call's argument order is unspecified,
    // and g++ and clang differ, so the two builds would time different cases).
    const Vector3 v{uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)};
    if (v.norm() > 0.1 && v.norm() <= 1.0) return v.normalized();
  }
}

Vector4 random_turn(std::mt19937& rng, double max_angle) {
  const Vector3 axis = random_unit(rng);
  return kanedyn::euler_parameters_from_axis_angle(axis, uniform(rng, 0, max_angle));
}

Joint joint(JointType type, Vector3 axis = Vector3::UnitX()) {
  Joint j;
  j.type = type;
  j.axis = axis;
  return j;
}

std::shared_ptr<const kanedyn::ForceElement> load(int body, int count, double stiffness,
                                                  double damping, double rest = 0,
                                                  double value = 0) {
  return std::make_shared<const JointLoad>(
      body, VectorX::Constant(count, stiffness), VectorX::Constant(count, damping),
      VectorX::Constant(count, rest), VectorX::Constant(count, value));
}

// The model's bodies and gravity with only the bushings on the given bodies.
kanedyn::Model with_bushings_on(const kanedyn::Model& m, const std::vector<int>& keep,
                                const std::string& name) {
  std::vector<std::shared_ptr<const kanedyn::ForceElement>> forces;
  for (const auto& f : m.forces())
    if (std::find(keep.begin(), keep.end(), f->body()) != keep.end()) forces.push_back(f);
  return kanedyn::Model(m.bodies(), m.gravity(), std::move(forces), name);
}

void size_state(JointedCase& c) {
  c.q = VectorX::Zero(c.model.num_coordinates());
  c.z = VectorX::Zero(c.model.num_speeds());
  for (int k = 0; k < c.model.num_bodies(); ++k) {
    const int o = c.model.coordinate_offset(k);
    if (c.model.joint(k).type == JointType::free || c.model.joint(k).type == JointType::spherical)
      c.q[o + 3] = 1.0;  // identity Euler parameters (e4 scalar)
  }
}

}  // namespace

std::unique_ptr<JointedCase> jointed_eight_body(const std::string& file) {
  const kanedyn::io::ModelFile f = kanedyn::io::load_model_file(file);
  const kanedyn::Model& m = f.model;
  // Body order of the file: torso, pelvis, right_leg, left_leg, head, right_arm,
  // left_upper_arm, left_forearm.
  if (m.num_bodies() != 8)
    throw std::runtime_error(file + ": not the eight-body figure (" +
                             std::to_string(m.num_bodies()) + " bodies)");
  std::vector<Joint> joints(8);
  joints[0] = joint(JointType::free);
  joints[1] = joint(JointType::revolute, Vector3::UnitY());  // lumbar flexion
  for (int k : {2, 3}) {
    joints[at(k)] = joint(JointType::universal);
    joints[at(k)].axes = {Vector3::UnitY(), Vector3::UnitX()};  // flexion, then abduction
  }
  for (int k : {4, 5, 6}) joints[at(k)] = joint(JointType::spherical);
  // The elbow's axis: the upper arm's y turned 10 degrees about its long axis (a joint frame).
  joints[7] = joint(JointType::revolute, Vector3::UnitY());
  joints[7].frame = kanedyn::euler_parameters_from_axis_angle(Vector3::UnitZ(), 10 * M_PI / 180);
  std::vector<std::shared_ptr<const kanedyn::ForceElement>> loads{
      load(1, 1, 1500, 30), load(2, 2, 400, 8), load(3, 2, 400, 8), load(7, 1, 25, 0.3, 0.5)};
  auto c = std::make_unique<JointedCase>(
      "eight-body-jointed", with_bushings_on(m, {0}, "eight-body-jointed"), joints, loads);
  size_state(*c);
  return c;
}

std::unique_ptr<JointedCase> revolute_chain(int n, unsigned seed) {
  const kanedyn::GeneratedSystem g = kanedyn::chain_model(n, seed);
  std::vector<Joint> joints;
  std::vector<std::shared_ptr<const kanedyn::ForceElement>> loads;
  for (int k = 0; k < n; ++k) {
    joints.push_back(joint(JointType::revolute, k % 2 == 0 ? Vector3::UnitY() : Vector3::UnitX()));
    loads.push_back(load(k, 1, 0, 0.1));
  }
  const std::string name = "revolute-chain-" + std::to_string(n);
  auto c = std::make_unique<JointedCase>(name, with_bushings_on(g.model, {}, name), joints, loads);
  size_state(*c);
  return c;
}

std::unique_ptr<JointedCase> every_joint_type(unsigned seed) {
  const kanedyn::GeneratedSystem g = kanedyn::random_tree_model(8, seed);
  std::mt19937 rng(seed + 17);
  const JointType types[8] = {JointType::free,        JointType::revolute,  JointType::prismatic,
                              JointType::cylindrical, JointType::universal, JointType::spherical,
                              JointType::weld,        JointType::revolute};
  std::vector<Joint> joints;
  std::vector<std::shared_ptr<const kanedyn::ForceElement>> loads;
  for (int k = 0; k < 8; ++k) {
    Joint j = joint(types[k], random_unit(rng));
    if (types[k] != JointType::free) j.frame = random_turn(rng, M_PI);
    const Vector3 a1 = random_unit(rng);
    j.axes = {a1, a1.cross(random_unit(rng)).normalized()};
    j.translation = Vector3{uniform(rng, -0.05, 0.05), uniform(rng, -0.05, 0.05), -0.02};
    const int count = kanedyn::coordinate_count(types[k]);
    if (types[k] != JointType::free && types[k] != JointType::spherical &&
        types[k] != JointType::weld) {
      const double stiffness = uniform(rng, 5, 50), damping = uniform(rng, 0.1, 1);
      const double rest = uniform(rng, -0.3, 0.3), constant = uniform(rng, -2, 2);
      loads.push_back(load(k, count, stiffness, damping, rest, constant));
    }
    joints.push_back(j);
  }
  auto c = std::make_unique<JointedCase>(
      "every-joint-type", with_bushings_on(g.model, {0}, "every-joint-type"), joints, loads);
  size_state(*c);
  return c;
}

// Five bodies of random_tree_model on the given joints in random frames, each with a joint
// spring and a constant joint force (and a screw's random pitch).
static std::unique_ptr<JointedCase> five_joints(const std::string& name, unsigned seed,
                                                unsigned stream,
                                                const std::array<JointType, 5>& types) {
  const kanedyn::GeneratedSystem g = kanedyn::random_tree_model(5, seed);
  std::mt19937 rng(seed + stream);
  std::vector<Joint> joints;
  std::vector<std::shared_ptr<const kanedyn::ForceElement>> loads;
  for (size_t k = 0; k < types.size(); ++k) {
    Joint j = joint(types[k], random_unit(rng));
    j.frame = random_turn(rng, M_PI);
    // Lengths per radian, of the bodies' size.
    if (types[k] == JointType::screw) j.pitch = uniform(rng, -0.2, 0.2);
    loads.push_back(load(static_cast<int>(k), kanedyn::coordinate_count(types[k]),
                         uniform(rng, 5, 50), uniform(rng, 0.1, 1), uniform(rng, -0.3, 0.3),
                         uniform(rng, -2, 2)));
    joints.push_back(j);
  }
  auto c = std::make_unique<JointedCase>(name, with_bushings_on(g.model, {}, name), joints, loads);
  size_state(*c);
  return c;
}

std::unique_ptr<JointedCase> planar_joints(unsigned seed) {
  return five_joints("planar-joints", seed, 23,
                     {JointType::planar, JointType::revolute, JointType::planar, JointType::planar,
                      JointType::prismatic});
}

// Screw joints (a turn about the axis and pitch times it along it) among others.
std::unique_ptr<JointedCase> screw_joints(unsigned seed) {
  return five_joints("screw-joints", seed, 29,
                     {JointType::screw, JointType::revolute, JointType::screw, JointType::screw,
                      JointType::prismatic});
}

void random_joint_state(JointedCase& c, std::mt19937& rng) {
  size_state(c);
  for (int k = 0; k < c.model.num_bodies(); ++k) {
    const int o = c.model.coordinate_offset(k);
    switch (c.model.joint(k).type) {
      case JointType::free:
        c.q.segment<4>(o) = random_turn(rng, 1.2);
        for (int i = 0; i < 3; ++i) c.q[o + 4 + i] = uniform(rng, -0.02, 0.02);
        break;
      case JointType::spherical:
        c.q.segment<4>(o) = random_turn(rng, 1.2);
        break;
      case JointType::revolute:
      case JointType::universal:
      case JointType::screw:
        for (int i = 0; i < kanedyn::coordinate_count(c.model.joint(k).type); ++i)
          c.q[o + i] = uniform(rng, -1.2, 1.2);
        break;
      case JointType::prismatic:
        c.q[o] = uniform(rng, -0.1, 0.1);
        break;
      case JointType::cylindrical:
        c.q[o] = uniform(rng, -1.2, 1.2);
        c.q[o + 1] = uniform(rng, -0.1, 0.1);
        break;
      case JointType::planar:
        c.q[o] = uniform(rng, -0.1, 0.1);
        c.q[o + 1] = uniform(rng, -0.1, 0.1);
        c.q[o + 2] = uniform(rng, -1.2, 1.2);
        break;
      case JointType::weld:
        break;
    }
  }
  for (int i = 0; i < c.z.size(); ++i) c.z[i] = uniform(rng, -1, 1);
}

JointedSystem describe_jointed(const JointedCase& c) {
  const kanedyn::Model& m = c.model;
  const kanedyn::Model& tree = c.model;
  JointedSystem sys;
  sys.name = c.name;
  sys.gravity = {m.gravity().x(), m.gravity().y(), m.gravity().z()};
  auto arr = [](const Vector3& v) { return Vec3{v.x(), v.y(), v.z()}; };
  for (int k = 0; k < m.num_bodies(); ++k) {
    const kanedyn::BodySpec& b = m.body(k);
    Body body;
    body.name = b.name;
    body.parent = b.lower_body;
    body.mass = b.mass;
    for (int r = 0; r < 3; ++r)
      for (int col = 0; col < 3; ++col) body.inertia[at(3 * r + col)] = b.inertia(r, col);
    body.com = arr(b.com);
    body.joint = arr(b.joint);
    sys.bodies.push_back(body);

    const Joint& j = tree.joint(k);
    JointSpec spec;
    spec.type = static_cast<JointKind>(static_cast<int>(j.type));
    // kanedyn's [R(frame)] maps J components to F's; the Hamilton quaternion with the same
    // numbers (scalar first) maps F components to J's (as in describe()).
    spec.frame = {j.frame[3], j.frame[0], j.frame[1], j.frame[2]};
    spec.axis = j.type == JointType::universal ? arr(j.axes[0]) : arr(j.axis);
    spec.axis2 = arr(j.axes[1]);
    spec.translation = arr(j.translation);
    spec.pitch = j.pitch;
    sys.joints.push_back(spec);
    sys.q_offset.push_back(tree.coordinate_offset(k));
    sys.z_offset.push_back(tree.speed_offset(k));
  }
  sys.q_offset.push_back(tree.num_coordinates());
  sys.z_offset.push_back(tree.num_speeds());
  std::vector<bool> loaded(sys.joints.size(), false);
  for (const auto& element : m.forces()) {
    const auto* load = dynamic_cast<const JointLoad*>(element.get());
    if (!load) continue;
    const JointLoad& l = *load;
    // One load per body: two springs with different rests would need their sum re-centred.
    if (loaded[at(l.body())])
      throw std::runtime_error("peers: " + c.name + ": more than one joint load on body " +
                               sys.bodies[at(l.body())].name);
    loaded[at(l.body())] = true;
    JointSpec& spec = sys.joints[at(l.body())];
    for (int i = 0; i < l.stiffness.size(); ++i) {
      spec.stiffness[at(i)] = l.stiffness[i];
      spec.damping[at(i)] = l.damping[i];
      spec.rest[at(i)] = l.rest[i];
      spec.value[at(i)] = l.value[i];
    }
  }
  for (const auto& f : m.forces()) {
    if (f->acts_on_joints()) continue;  // the joint loads above
    if (const auto* spring = dynamic_cast<const kanedyn::Spring*>(f.get())) {
      // A point force: the same on any joint type.
      sys.springs.push_back({spring->body(),
                             spring->other() == kanedyn::kGround ? -1 : spring->other(),
                             arr(spring->at), arr(spring->other_at), spring->stiffness,
                             spring->damping, spring->rest_length});
      continue;
    }
    const int k = f->body();
    const auto* bushing = dynamic_cast<const kanedyn::Bushing*>(f.get());
    if (!bushing || tree.joint(k).type != JointType::free)
      throw std::runtime_error("peers: " + c.name + ": no peer translation for a " + f->type() +
                               " on a " + kanedyn::to_string(tree.joint(k).type) + " joint");
    Body& b = sys.bodies[at(k)];
    for (int i = 0; i < 3; ++i) {
      b.k[at(i)] += bushing->stiffness[i];
      b.c[at(i)] += bushing->damping[i];
    }
    b.kr += bushing->rotational_stiffness;
    b.cr += bushing->rotational_damping;
  }
  for (const kanedyn::Constraint& k : m.constraints()) {
    ConstraintSpec spec;
    spec.name = k.name;
    switch (k.type) {
      case kanedyn::ConstraintType::ball:
        spec.type = ConstraintSpec::Kind::ball;
        break;
      case kanedyn::ConstraintType::hinge:
        spec.type = ConstraintSpec::Kind::hinge;
        break;
      case kanedyn::ConstraintType::distance:
        spec.type = ConstraintSpec::Kind::distance;
        break;
      case kanedyn::ConstraintType::rolling_disc:
        throw std::runtime_error("peers: " + c.name + ": no peer translation for the " +
                                 kanedyn::to_string(k.type) + " constraint " + k.name);
    }
    spec.body = k.body;
    spec.other = k.other == kanedyn::kGround ? -1 : k.other;
    spec.at = arr(k.at);
    spec.other_at = arr(k.other_at);
    spec.axis = arr(k.axis);
    // The hinge's own p1, p2 (kanedyn's rows keep a normal to both), so that each engine's
    // alignment equations are the same two.
    const std::array<Vector3, 2> p = kanedyn::constraint_fixed_directions(k);
    spec.p = {arr(p[0]), arr(p[1])};
    spec.length = k.length;
    sys.constraints.push_back(spec);
  }
  sys.q.assign(c.q.data(), c.q.data() + c.q.size());
  sys.z.assign(c.z.data(), c.z.data() + c.z.size());
  if (const int k = nonroot_free_joint(sys); k >= 0)
    throw std::runtime_error("peers: " + c.name + ": the peers take free joints on roots only (" +
                             sys.bodies[at(k)].name + ")");
  return sys;
}

}  // namespace peers
