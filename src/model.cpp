#include "kanedyn/model.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <unordered_set>

#include "kanedyn/direction.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/rotation.hpp"

#include "joint_table.hpp"

namespace kanedyn {

namespace {

bool valid_name(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
  });
}

bool all_finite(const auto& m) { return m.allFinite(); }

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw ModelError(where + ": " + what);
}

/// A name as messages show it: cut after 80 bytes, so that a long name cannot make a long
/// message.
std::string shown(const std::string& name) {
  return name.size() <= 80 ? name : name.substr(0, 77) + "...";
}

std::string body_label(int k, const std::string& name) {
  return "body " + std::to_string(k + 1) + " '" + shown(name) + "'";
}

}  // namespace

std::string check_inertia(const Matrix3& inertia) {
  if (!inertia.allFinite()) return "inertia has a non-finite entry";
  const double scale = inertia.cwiseAbs().maxCoeff();
  if ((inertia - inertia.transpose()).cwiseAbs().maxCoeff() > 1e-12 * scale)
    return "inertia is not symmetric";
  const Eigen::SelfAdjointEigenSolver<Matrix3> eig(inertia, Eigen::EigenvaluesOnly);
  const Vector3 p = eig.eigenvalues();  // ascending
  if (!(p[0] > 0.0)) {
    std::ostringstream s;
    s << "inertia is not positive definite (principal moments " << p[0] << ", " << p[1] << ", "
      << p[2] << ")";
    return s.str();
  }
  // Triangle inequalities: each principal moment at most the sum of the other two. A thin
  // rod or a lamina sits on the boundary, so allow round-off there.
  if (p[2] > (p[0] + p[1]) * (1.0 + 1e-12)) {
    std::ostringstream s;
    s << "principal moments " << p[0] << ", " << p[1] << ", " << p[2]
      << " violate the triangle inequality (" << p[2] << " > " << p[0] << " + " << p[1] << ")";
    return s.str();
  }
  return "";
}

Model::Model(std::vector<BodySpec> bodies, Vector3 gravity,
             std::vector<std::shared_ptr<const ForceElement>> forces, std::string name,
             std::vector<Joint> joints, std::vector<Frame> frames, std::vector<Input> inputs,
             std::vector<Constraint> constraints, std::vector<int> independent_speeds)
    : bodies_(std::move(bodies)),
      gravity_(std::move(gravity)),
      forces_(std::move(forces)),
      name_(std::move(name)),
      joints_(std::move(joints)),
      frames_(std::move(frames)),
      inputs_(std::move(inputs)),
      constraints_(std::move(constraints)),
      independent_speeds_(std::move(independent_speeds)) {
  const int n = num_bodies();
  if (n == 0) throw ModelError("model: a model needs at least one body");
  if (!gravity_.allFinite()) fail("gravity", "has a non-finite component");
  std::unordered_set<std::string> names;
  for (int k = 0; k < n; ++k) {
    const BodySpec& b = bodies_[static_cast<size_t>(k)];
    const std::string where = body_label(k, b.name);
    if (!valid_name(b.name)) fail(where, "name must be non-empty and use only [A-Za-z0-9_-]");
    if (!names.insert(b.name).second) fail(where, "duplicate body name '" + shown(b.name) + "'");
    if (b.lower_body != kGround && (b.lower_body < 0 || b.lower_body >= k))
      fail(where, "parent must be 'ground' or an earlier body (L(K) < K), got index " +
                      std::to_string(b.lower_body + 1));
    if (!std::isfinite(b.mass) || !(b.mass > 0.0)) fail(where, "mass must be a finite number > 0");
    if (const std::string e = check_inertia(b.inertia); !e.empty()) fail(where, e);
    if (!all_finite(b.com)) fail(where, "com has a non-finite component");
    if (!all_finite(b.joint)) fail(where, "joint has a non-finite component");
  }

  depth_.resize(static_cast<size_t>(n));
  root_.resize(static_cast<size_t>(n));
  lower_.resize(static_cast<size_t>(n));
  children_.assign(static_cast<size_t>(n), {});
  for (int k = 0; k < n; ++k) {
    const auto i = static_cast<size_t>(k);
    const int j = lower_body(k);
    lower_[i] = j;
    depth_[i] = j == kGround ? 0 : depth_[static_cast<size_t>(j)] + 1;
    root_[i] = j == kGround ? k : root_[static_cast<size_t>(j)];
    if (j != kGround) children_[static_cast<size_t>(j)].push_back(k);
    chain_entries_ += depth_[i] + 1;
  }
  // Flat chains cost sum (u_K + 1) ints: fine for the Kane route's models, not for a
  // 100,000-body chain (5e9 entries); there chain(k) walks L instead.
  if (chain_entries_ <= kMaxFlatChainEntries) {
    chain_offset_.reserve(static_cast<size_t>(n) + 1);
    chain_flat_.reserve(static_cast<size_t>(chain_entries_));
    chain_offset_.push_back(0);
    for (int k = 0; k < n; ++k) {
      for (int a = k; a != kGround; a = lower_body(a)) chain_flat_.push_back(a);
      chain_offset_.push_back(static_cast<int>(chain_flat_.size()));
    }
  }
  set_up_joints();
  inverse_inertia_.resize(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    inverse_inertia_[static_cast<size_t>(k)] = body(k).inertia.inverse();
    total_mass_ += body(k).mass;
  }
  for (size_t i = 0; i < forces_.size(); ++i) {
    const auto& f = forces_[i];
    const std::string where = "forces[" + std::to_string(i) + "]";
    if (!f) fail(where, "is empty");
    if (f->body() < 0 || f->body() >= n)
      fail(where, "body index " + std::to_string(f->body()) + " out of range");
    if (const std::string e = f->validate(*this); !e.empty()) fail(where, e);
    if (f->acts_on_joints())
      joint_elements_.push_back(f.get());
    else
      body_forces_ = true;
  }
  std::unordered_set<std::string> frame_names;
  for (size_t i = 0; i < frames_.size(); ++i) {
    Frame& f = frames_[i];
    const std::string where = "frame " + std::to_string(i + 1) + " '" + shown(f.name) + "'";
    if (!valid_name(f.name)) fail(where, "name must be non-empty and use only [A-Za-z0-9_-]");
    if (!frame_names.insert(f.name).second)
      fail(where, "duplicate frame name '" + shown(f.name) + "'");
    if (names.count(f.name))
      fail(where, "a body has this name too; a frame needs a name of its own");
    if (f.body != kGround && (f.body < 0 || f.body >= n))
      fail(where, "body index " + std::to_string(f.body) + " out of range");
    if (!all_finite(f.at)) fail(where, "at has a non-finite component");
    if (!all_finite(f.rotation) || std::abs(f.rotation.norm() - 1.0) > 1e-6)
      fail(where, "rotation: Euler parameters must have unit norm (within 1e-6)");
    f.rotation.normalize();
  }
  set_up_inputs();
  set_up_constraints();
}

void Model::set_up_constraints() {
  const int n = num_bodies();
  std::unordered_set<std::string> names;
  const auto unit = [](Vector3& v) {
    const std::optional<Vector3> u = unit_direction(v);
    if (u) v = *u;
    return u.has_value();
  };
  for (size_t i = 0; i < constraints_.size(); ++i) {
    Constraint& c = constraints_[i];
    const std::string where = "constraint " + std::to_string(i + 1) + " '" + shown(c.name) + "'";
    if (!valid_name(c.name)) fail(where, "name must be non-empty and use only [A-Za-z0-9_-]");
    if (!names.insert(c.name).second)
      fail(where, "duplicate constraint name '" + shown(c.name) + "'");
    if (c.body < 0 || c.body >= n)
      fail(where, "body index " + std::to_string(c.body) + " out of range");
    if (!all_finite(c.at)) fail(where, "at has a non-finite component");
    switch (c.type) {
      case ConstraintType::rolling_disc:
        if (!unit(c.axis)) fail(where, "axis must be a finite non-zero vector");
        if (!unit(c.plane_normal)) fail(where, "plane normal must be a finite non-zero vector");
        if (!std::isfinite(c.radius) || !(c.radius > 0.0)) fail(where, "radius must be > 0");
        if (!std::isfinite(c.plane_offset)) fail(where, "plane offset must be finite");
        break;
      case ConstraintType::hinge:
        if (!unit(c.axis)) fail(where, "axis must be a finite non-zero vector");
        if (!unit(c.other_axis)) fail(where, "other_axis must be a finite non-zero vector");
        [[fallthrough]];
      case ConstraintType::ball:
      case ConstraintType::distance:
        if (c.other != kGround && (c.other < 0 || c.other >= n))
          fail(where, "other body index " + std::to_string(c.other) + " out of range");
        if (c.other == c.body) fail(where, "other must be a body other than `body`, or ground");
        if (!all_finite(c.other_at)) fail(where, "other_at has a non-finite component");
        if (c.type == ConstraintType::distance && (!std::isfinite(c.length) || !(c.length > 0.0)))
          fail(where, "length must be > 0");
        break;
    }
  }
  std::vector<int> sorted = independent_speeds_;
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 0; i < sorted.size(); ++i) {
    if (sorted[i] < 0 || sorted[i] >= num_speeds())
      fail("independent_speeds", "speed index " + std::to_string(sorted[i]) + " out of range");
    if (i > 0 && sorted[i] == sorted[i - 1])
      fail("independent_speeds", "speed index " + std::to_string(sorted[i]) + " given twice");
  }
  if (!independent_speeds_.empty() && constraints_.empty())
    fail("independent_speeds", "given without constraints");
  independent_speeds_ = std::move(sorted);
}

int Model::constraint_index(const std::string& name) const {
  for (size_t i = 0; i < constraints_.size(); ++i)
    if (constraints_[i].name == name) return static_cast<int>(i);
  return -2;
}

const char* to_string(ConstraintType type) {
  switch (type) {
    case ConstraintType::rolling_disc:
      return "rolling_disc";
    case ConstraintType::ball:
      return "ball";
    case ConstraintType::hinge:
      return "hinge";
    case ConstraintType::distance:
      return "distance";
  }
  return "?";
}

int equation_count(ConstraintType type) {
  switch (type) {
    case ConstraintType::rolling_disc:
    case ConstraintType::ball:
      return 3;
    case ConstraintType::hinge:
      return 5;
    case ConstraintType::distance:
      return 1;
  }
  return 0;
}

int reaction_count(ConstraintType type) { return type == ConstraintType::hinge ? 6 : 3; }

void Model::set_up_inputs() {
  const int n = num_bodies();
  std::unordered_set<std::string> input_names;
  for (size_t i = 0; i < inputs_.size(); ++i) {
    Input& in = inputs_[i];
    const std::string where = "input " + std::to_string(i + 1) + " '" + shown(in.name) + "'";
    if (!valid_name(in.name)) fail(where, "name must be non-empty and use only [A-Za-z0-9_-]");
    if (in.name == "t")
      fail(where, "name 't' is the time column of inputs tables, so no table could drive it");
    if (!input_names.insert(in.name).second)
      fail(where, "duplicate input name '" + shown(in.name) + "'");
    if (in.body < 0 || in.body >= n)
      fail(where, "body index " + std::to_string(in.body) + " out of range");
    const Joint& jt = joint(in.body);
    switch (in.type) {
      case InputType::joint: {
        const int speeds = speed_count(jt.type);
        if (speeds == 0)
          fail(where, "speed: body '" + shown(body(in.body).name) + "' has a " +
                          to_string(jt.type) + " joint, which has no speeds to drive");
        if (in.speed < 0 || in.speed >= speeds)
          fail(where, "speed: " + std::to_string(in.speed + 1) + " is out of range; body '" +
                          body(in.body).name + "' has " + std::to_string(speeds) + " speed" +
                          (speeds == 1 ? "" : "s") + " (1.." + std::to_string(speeds) + ")");
        if (jt.type == JointType::free) body_inputs_ = true;
        break;
      }
      case InputType::force:
        if (!all_finite(in.direction) || !all_finite(in.point))
          fail(where, "direction and point must be finite");
        if (const auto u = unit_direction(in.direction))
          in.direction = *u;
        else
          fail(where, "direction: a zero vector has no direction");
        body_inputs_ = true;
        break;
      case InputType::torque:
        if (!all_finite(in.axis)) fail(where, "axis must be finite");
        if (const auto u = unit_direction(in.axis))
          in.axis = *u;
        else
          fail(where, "axis: a zero vector has no direction");
        body_inputs_ = true;
        break;
    }
  }
}

int Model::input_index(const std::string& name) const {
  for (size_t i = 0; i < inputs_.size(); ++i)
    if (inputs_[i].name == name) return static_cast<int>(i);
  return -2;
}

int Model::frame_index(const std::string& name) const {
  for (size_t f = 0; f < frames_.size(); ++f)
    if (frames_[f].name == name) return static_cast<int>(f);
  return -2;
}

void Model::set_up_joints() {
  const int n = num_bodies();
  const auto at = [](int i) { return static_cast<size_t>(i); };
  if (joints_.empty()) joints_.resize(at(n));
  if (static_cast<int>(joints_.size()) != n)
    throw ModelError("joints: " + std::to_string(joints_.size()) + " joints for " +
                     std::to_string(n) + " bodies");
  q_offset_.assign(at(n + 1), 0);
  z_offset_.assign(at(n + 1), 0);
  slides_j_.assign(at(n), Matrix3::Zero());
  w_chain_.resize(at(n));
  for (int k = 0; k < n; ++k) {
    Joint& jt = joints_[at(k)];
    const std::string problem = check_joint(jt);
    if (!problem.empty()) fail(body_label(k, body(k).name), problem);
    jt.frame.normalize();
    // Scaled before the norm: an axis of 1e200 or 1e-200 is a direction (check_joint).
    if (const auto u = unit_direction(jt.axis)) jt.axis = *u;
    for (Vector3& a : jt.axes)
      if (const auto u = unit_direction(a)) a = *u;
    q_offset_[at(k + 1)] = q_offset_[at(k)] + coordinate_count(jt.type);
    z_offset_[at(k + 1)] = z_offset_[at(k)] + speed_count(jt.type);
    // The sliding columns of [T_K] in J components: [R(frame)] maps J to F components.
    detail::visit_joint_row(jt.type, [&](auto row) {
      using Row = decltype(row);
      Matrix36 T = Matrix36::Zero();
      Row::translation_columns(jt, T);
      // A joint without a frame (free: the notes' own body) has its slides in J already.
      const Matrix3 to_j = Row::info.takes_frame ? Matrix3(rotation_matrix(jt.frame).transpose())
                                                 : Matrix3::Identity();
      for (int c = 0; c < Row::slide_count; ++c)
        slides_j_[at(k)].col(c) = to_j * T.col(Row::first_slide + c);
    });
    if (jt.type != JointType::free) all_free_ = false;
  }
  // The angular chains' total length grows as N^2 along a chain of joints; they are stored up
  // to the limit for flat chains (the recursive route needs none of them). An all-free model
  // has one entry a body.
  std::vector<long long> length(at(n), 0);
  for (int k = 0; k < n; ++k) {
    const int j = lower_body(k);
    const JointType t = joints_[at(k)].type;
    length[at(k)] =
        (speed_count(t) > 0 ? 1 : 0) + (t == JointType::free || j == kGround ? 0 : length[at(j)]);
    w_chain_entries_ += length[at(k)];
  }
  if (w_chain_entries_ > kMaxFlatChainEntries) return;
  for (int k = 0; k < n; ++k) {
    // w'_K = w_rel + [R_K][R_J]^T w'_J down to the first free body, whose w' is its own z.
    for (int c = k; c != kGround; c = lower_body(c)) {
      if (speed_count(joints_[at(c)].type) > 0) w_chain_[at(k)].push_back(c);
      if (joints_[at(c)].type == JointType::free) break;
    }
  }
}

Model with_joints(const Model& model, std::vector<Joint> joints,
                  std::vector<std::shared_ptr<const ForceElement>> more_forces) {
  std::vector<std::shared_ptr<const ForceElement>> forces = model.forces();
  forces.insert(forces.end(), more_forces.begin(), more_forces.end());
  return Model(model.bodies(), model.gravity(), std::move(forces), model.name(), std::move(joints),
               model.frames(), model.inputs(), model.constraints(), model.independent_speeds());
}

int Model::body_index(const std::string& name) const {
  for (int k = 0; k < num_bodies(); ++k)
    if (body(k).name == name) return k;
  return -2;
}

bool Model::on_chain(int a, int k) const {
  if (a < 0 || depth(a) > depth(k)) return false;
  return chain(k)[depth(k) - depth(a)] == a;
}

}  // namespace kanedyn
