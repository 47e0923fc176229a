// Writing a model file (include/kanedyn/io/model_writer.hpp).
#include "kanedyn/io/model_writer.hpp"

#include <charconv>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "kanedyn/analysis.hpp"
#include "kanedyn/constraint.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/joints.hpp"

namespace kanedyn::io {

namespace {

// A name as a YAML scalar: names are [A-Za-z0-9_-]+, but one such as `yes`, `null` or `1e3`
// would read as something else; quoted, every name is a string.
std::string name(const std::string& text) { return "\"" + text + "\""; }

template <typename Vec>
std::string list(const Vec& v) {
  std::string out = "[";
  for (Eigen::Index i = 0; i < v.size(); ++i) {
    if (i > 0) out += ", ";
    out += yaml_float(v[i]);
  }
  return out + "]";
}

// Euler parameters as {axis, angle}: the turn by 2 atan2(|e|, e4) about e.
std::string axis_angle(const Vector4& eps) {
  const Vector3 e = eps.head<3>();
  const double n = e.norm();
  const double angle = 2.0 * std::atan2(n, eps[3]);
  return "{axis: " + list(Vector3(e / n)) + ", angle: " + yaml_float(angle) + "}";
}

bool is_identity(const Vector4& e) {
  return e[0] == 0.0 && e[1] == 0.0 && e[2] == 0.0 && e[3] == 1.0;
}

const char* input_type(InputType t) {
  switch (t) {
    case InputType::joint:
      return "joint";
    case InputType::force:
      return "force";
    case InputType::torque:
      return "torque";
  }
  return "joint";
}

}  // namespace

std::string yaml_float(double v) {
  if (!std::isfinite(v)) throw std::invalid_argument("yaml_float: not a finite number");
  char buf[40];
  const auto end = std::to_chars(buf, buf + sizeof buf, v).ptr;
  std::string s(buf, end);
  // YAML 1.1 reads a float only with a '.' in the mantissa (and a signed exponent, which
  // to_chars always writes): 8e-04 -> 8.0e-04, 3 -> 3.0.
  const size_t e = s.find('e');
  const std::string mantissa = s.substr(0, e);
  if (mantissa.find('.') == std::string::npos)
    s.insert(e == std::string::npos ? s.size() : e, ".0");
  return s;
}

std::string model_file_text(const Model& model, const VectorX& q, const VectorX& z,
                            const SimulationSection& simulation, const std::string& comment) {
  if (q.size() != model.num_coordinates() || z.size() != model.num_speeds())
    throw std::invalid_argument("model_file_text: q or z of the wrong size");
  std::ostringstream out;
  if (!comment.empty()) {
    std::istringstream lines(comment);
    for (std::string line; std::getline(lines, line);) out << "# " << line << "\n";
  }
  out << "format: kanedyn-model/1\n";
  if (!model.name().empty()) out << "name: " << name(model.name()) << "\n";
  out << "gravity: " << list(model.gravity()) << "\n";
  out << "bodies:\n";
  for (int k = 0; k < model.num_bodies(); ++k) {
    const BodySpec& b = model.body(k);
    const Joint& jt = model.joint(k);
    const int o = model.coordinate_offset(k), p = model.speed_offset(k);
    out << "  - name: " << name(b.name) << "\n";
    out << "    parent: "
        << (b.lower_body == kGround ? std::string("ground") : name(model.body(b.lower_body).name))
        << "\n";
    out << "    mass: " << yaml_float(b.mass) << "\n";
    const Matrix3& I = b.inertia;
    out << "    inertia: "
        << list(Eigen::Matrix<double, 6, 1>(I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2)))
        << "\n";
    out << "    com: " << list(b.com) << "\n";
    if (jt.type == JointType::free) {
      out << "    joint: " << list(b.joint) << "\n";
      out << "    initial:\n";
      out << "      euler_parameters: " << list(Vector4(q.segment<4>(o))) << "\n";
      out << "      translation: " << list(Vector3(q.segment<3>(o + 4))) << "\n";
      out << "      angular_velocity: " << list(Vector3(z.segment<3>(p))) << "\n";
      out << "      translation_rate: " << list(Vector3(z.segment<3>(p + 3))) << "\n";
      continue;
    }
    out << "    joint:\n";
    out << "      at: " << list(b.joint) << "\n";
    out << "      type: " << to_string(jt.type) << "\n";
    if (!is_identity(jt.frame)) out << "      frame: " << axis_angle(jt.frame) << "\n";
    if (jt.type == JointType::revolute || jt.type == JointType::prismatic ||
        jt.type == JointType::cylindrical)
      out << "      axis: " << list(jt.axis) << "\n";
    if (jt.type == JointType::universal)
      out << "      axes: [" << list(jt.axes[0]) << ", " << list(jt.axes[1]) << "]\n";
    if (jt.type == JointType::weld) {
      out << "    initial:\n      translation: " << list(jt.translation) << "\n";
      continue;
    }
    out << "    initial:\n";
    out << "      joint: " << list(VectorX(q.segment(o, coordinate_count(jt.type)))) << "\n";
    out << "      joint_rate: " << list(VectorX(z.segment(p, speed_count(jt.type)))) << "\n";
  }
  if (!model.forces().empty()) {
    out << "forces:\n";
    for (const auto& element : model.forces()) {
      const std::string body = name(model.body(element->body()).name);
      const std::vector<ForceElement::FileEntry> entries = element->file_entries();
      if (entries.empty())
        throw std::invalid_argument("a force element of type '" + element->type() + "' on body " +
                                    model.body(element->body()).name +
                                    " cannot be written to a model file");
      for (const ForceElement::FileEntry& entry : entries) {
        out << "  - type: " << entry.type << "\n    body: " << body << "\n";
        for (const ForceElement::FileKey& key : entry.keys) {
          out << "    " << key.key << ": ";
          if (key.body != -2)
            out << (key.body == kGround ? std::string("ground") : name(model.body(key.body).name));
          else if (key.scalar)
            out << yaml_float(key.value[0]);
          else
            out << list(key.value);
          out << "\n";
        }
      }
    }
  }
  if (!model.inputs().empty()) {
    out << "inputs:\n";
    for (const Input& in : model.inputs()) {
      out << "  - name: " << name(in.name) << "\n    type: " << input_type(in.type)
          << "\n    body: " << name(model.body(in.body).name) << "\n";
      switch (in.type) {
        case InputType::joint:
          out << "    speed: " << in.speed + 1 << "\n";
          break;
        case InputType::force:
          out << "    direction: " << list(in.direction) << "\n    point: " << list(in.point)
              << "\n";
          break;
        case InputType::torque:
          out << "    axis: " << list(in.axis)
              << "\n    reaction: " << (in.reaction ? "true" : "false") << "\n";
          break;
      }
    }
  }
  if (!model.frames().empty()) {
    out << "frames:\n";
    for (const Frame& f : model.frames()) {
      out << "  - name: " << name(f.name) << "\n    body: "
          << (f.body == kGround ? std::string("ground") : name(model.body(f.body).name)) << "\n";
      out << "    at: " << list(f.at) << "\n";
      if (!is_identity(f.rotation)) out << "    rotation: " << axis_angle(f.rotation) << "\n";
    }
  }
  if (!model.constraints().empty()) {
    // Every key of the constraint's type, defaults too, so that the file says what it means.
    out << "constraints:\n";
    const auto body_name = [&](int k) {
      return k == kGround ? std::string("ground") : name(model.body(k).name);
    };
    for (const Constraint& c : model.constraints()) {
      out << "  - name: " << name(c.name) << "\n    type: " << to_string(c.type)
          << "\n    body: " << body_name(c.body) << "\n";
      if (c.type == ConstraintType::rolling_disc) {
        out << "    center: " << list(c.at) << "\n    axis: " << list(c.axis)
            << "\n    radius: " << yaml_float(c.radius)
            << "\n    plane: {normal: " << list(c.plane_normal)
            << ", offset: " << yaml_float(c.plane_offset) << "}\n";
        continue;
      }
      out << "    at: " << list(c.at) << "\n";
      if (c.type == ConstraintType::hinge) out << "    axis: " << list(c.axis) << "\n";
      out << "    other: " << body_name(c.other) << "\n    other_at: " << list(c.other_at) << "\n";
      if (c.type == ConstraintType::hinge) out << "    other_axis: " << list(c.other_axis) << "\n";
      if (c.type == ConstraintType::distance) out << "    length: " << yaml_float(c.length) << "\n";
    }
  }
  if (!model.independent_speeds().empty()) {
    // The speeds by the linearization's names: the second half of the tangent state's.
    const std::vector<std::string> names = tangent_state_names(model);
    const size_t n = static_cast<size_t>(model.num_speeds());
    out << "independent_speeds: [";
    for (size_t i = 0; i < model.independent_speeds().size(); ++i)
      out << (i > 0 ? ", " : "")
          << name(names[n + static_cast<size_t>(model.independent_speeds()[i])]);
    out << "]\n";
  }
  const SimulationSection& s = simulation;
  if (s.t_end || s.dt_out || s.integrator || s.rtol || s.atol || s.step || s.route) {
    out << "simulation:\n";
    if (s.t_end) out << "  t_end: " << yaml_float(*s.t_end) << "\n";
    if (s.dt_out) out << "  dt_out: " << yaml_float(*s.dt_out) << "\n";
    if (s.integrator) out << "  integrator: " << *s.integrator << "\n";
    if (s.rtol) out << "  rtol: " << yaml_float(*s.rtol) << "\n";
    if (s.atol) out << "  atol: " << yaml_float(*s.atol) << "\n";
    if (s.step) out << "  step: " << yaml_float(*s.step) << "\n";
    if (s.route)
      out << "  route: " << (*s.route == "kane" ? std::string("assembled") : *s.route) << "\n";
  }
  return out.str();
}

}  // namespace kanedyn::io
