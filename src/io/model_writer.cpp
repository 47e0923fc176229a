// Writing a model file (include/kanedyn/io/model_writer.hpp).
#include "kanedyn/io/model_writer.hpp"

#include <charconv>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "kanedyn/analysis.hpp"
#include "kanedyn/constraint.hpp"
#include "kanedyn/direction.hpp"
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

/// Numbers as the writer writes them, each at its key path (as the reader's messages spell it):
/// the file's expression where the source gave one whose value is the number written, else the
/// number (docs/model-format.md, "Parameters").
class Numbers {
 public:
  explicit Numbers(const Parameters& source) : source_(source) {
    for (const Parameters::Number& n : source.numbers) by_path_.emplace(n.key_path, &n);
  }

  std::string number(const std::string& path, double v) const {
    const Parameters::Number* n = find(path);
    return n && !n->text.empty() && same(n->value, v) ? expression(n->text) : yaml_float(v);
  }

  template <typename Vec>
  std::string vector(const std::string& path, const Vec& v) const {
    if (source_.numbers.empty()) return list(v);
    std::string out = "[";
    for (Eigen::Index i = 0; i < v.size(); ++i)
      out += (i > 0 ? ", " : "") + number(element(path, i), v[i]);
    return out + "]";
  }

  /// A unit vector the model made of the file's direction at `path`: the file's components,
  /// expressions and all, when they give it bit for bit (unit_direction, as the Model does).
  std::string direction(const std::string& path, const Vector3& v) const {
    if (source_.numbers.empty()) return list(v);
    Vector3 raw;
    std::string out = "[";
    bool any = false;
    for (int i = 0; i < 3; ++i) {
      const Parameters::Number* n = find(element(path, i));
      if (!n) return vector(path, v);
      raw[i] = n->value;
      any = any || !n->text.empty();
      out += (i > 0 ? ", " : "") + (n->text.empty() ? yaml_float(n->value) : expression(n->text));
    }
    const std::optional<Vector3> u = unit_direction(raw);
    if (!any || !u || !same(u->x(), v.x()) || !same(u->y(), v.y()) || !same(u->z(), v.z()))
      return vector(path, v);
    return out + "]";
  }

 private:
  /// The file's number at `path`, or nullptr (a hash map: a file may hold 100,000 bodies).
  const Parameters::Number* find(const std::string& path) const {
    const auto it = by_path_.find(path);
    return it == by_path_.end() ? nullptr : it->second;
  }
  static bool same(double a, double b) { return a == b && std::signbit(a) == std::signbit(b); }
  // Single-quoted: an expression holds no quote, and a plain `*a` would read as an alias.
  static std::string expression(const std::string& text) { return "'= " + text + "'"; }
  static std::string element(const std::string& path, Eigen::Index i) {
    return path + "[" + std::to_string(i) + "]";
  }
  const Parameters& source_;
  std::unordered_map<std::string_view, const Parameters::Number*> by_path_;
};

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
                            const SimulationSection& simulation, const std::string& comment,
                            const Parameters& parameters) {
  if (q.size() != model.num_coordinates() || z.size() != model.num_speeds())
    throw std::invalid_argument("model_file_text: q or z of the wrong size");
  std::ostringstream out;
  if (!comment.empty()) {
    std::istringstream lines(comment);
    for (std::string line; std::getline(lines, line);) out << "# " << line << "\n";
  }
  out << "format: kanedyn-model/1\n";
  if (!model.name().empty()) out << "name: " << name(model.name()) << "\n";
  const Numbers num(parameters);
  if (!parameters.parameters.empty()) {
    // As the file gave them: a number, or its expression.
    out << "parameters:\n";
    for (const Parameters::Parameter& p : parameters.parameters)
      out << "  " << p.name << ": " << (p.text.empty() ? yaml_float(p.value) : "'= " + p.text + "'")
          << "\n";
  }
  out << "gravity: " << num.vector("gravity", model.gravity()) << "\n";
  out << "bodies:\n";
  for (int k = 0; k < model.num_bodies(); ++k) {
    const BodySpec& b = model.body(k);
    const Joint& jt = model.joint(k);
    const int o = model.coordinate_offset(k), p = model.speed_offset(k);
    const std::string at = "bodies[" + std::to_string(k) + "].";
    out << "  - name: " << name(b.name) << "\n";
    out << "    parent: "
        << (b.lower_body == kGround ? std::string("ground") : name(model.body(b.lower_body).name))
        << "\n";
    out << "    mass: " << num.number(at + "mass", b.mass) << "\n";
    const Matrix3& I = b.inertia;
    out << "    inertia: "
        << num.vector(at + "inertia", Eigen::Matrix<double, 6, 1>(I(0, 0), I(1, 1), I(2, 2),
                                                                  I(0, 1), I(0, 2), I(1, 2)))
        << "\n";
    out << "    com: " << num.vector(at + "com", b.com) << "\n";
    const JointTypeInfo& info = joint_type_info(jt.type);
    if (info.absolute) {
      out << "    joint: " << num.vector(at + "joint", b.joint) << "\n";
      out << "    initial:\n";
      out << "      euler_parameters: " << list(Vector4(q.segment<4>(o))) << "\n";
      out << "      translation: "
          << num.vector(at + "initial.translation", Vector3(q.segment<3>(o + 4))) << "\n";
      out << "      angular_velocity: "
          << num.vector(at + "initial.angular_velocity", Vector3(z.segment<3>(p))) << "\n";
      out << "      translation_rate: "
          << num.vector(at + "initial.translation_rate", Vector3(z.segment<3>(p + 3))) << "\n";
      continue;
    }
    out << "    joint:\n";
    out << "      at: " << num.vector(at + "joint.at", b.joint) << "\n";
    out << "      type: " << to_string(jt.type) << "\n";
    if (!is_identity(jt.frame)) out << "      frame: " << axis_angle(jt.frame) << "\n";
    if (info.takes_axis) out << "      axis: " << num.direction(at + "joint.axis", jt.axis) << "\n";
    if (info.takes_axes)
      out << "      axes: [" << list(jt.axes[0]) << ", " << list(jt.axes[1]) << "]\n";
    if (info.takes_pitch) out << "      pitch: " << yaml_float(jt.pitch) << "\n";
    if (info.fixed_translation) {
      out << "    initial:\n      translation: "
          << num.vector(at + "initial.translation", jt.translation) << "\n";
      continue;
    }
    out << "    initial:\n";
    out << "      joint: "
        << num.vector(at + "initial.joint", VectorX(q.segment(o, coordinate_count(jt.type))))
        << "\n";
    out << "      joint_rate: "
        << num.vector(at + "initial.joint_rate", VectorX(z.segment(p, speed_count(jt.type))))
        << "\n";
  }
  if (!model.forces().empty()) {
    out << "forces:\n";
    size_t index = 0;  // of the entry written, as the file that reads it back numbers them
    for (const auto& element : model.forces()) {
      const std::string body = name(model.body(element->body()).name);
      const std::vector<ForceElement::FileEntry> entries = element->file_entries();
      if (entries.empty())
        throw std::invalid_argument("a force element of type '" + element->type() + "' on body " +
                                    model.body(element->body()).name +
                                    " cannot be written to a model file");
      for (const ForceElement::FileEntry& entry : entries) {
        const std::string at = "forces[" + std::to_string(index++) + "].";
        out << "  - type: " << entry.type << "\n    body: " << body << "\n";
        for (const ForceElement::FileKey& key : entry.keys) {
          out << "    " << key.key << ": ";
          if (key.body != -2)
            out << (key.body == kGround ? std::string("ground") : name(model.body(key.body).name));
          else if (key.scalar)
            out << num.number(at + key.key, key.value[0]);
          else
            out << num.vector(at + key.key, key.value);
          out << "\n";
        }
      }
    }
  }
  if (!model.inputs().empty()) {
    out << "inputs:\n";
    for (size_t i = 0; i < model.inputs().size(); ++i) {
      const Input& in = model.inputs()[i];
      const std::string at = "inputs[" + std::to_string(i) + "].";
      out << "  - name: " << name(in.name) << "\n    type: " << input_type(in.type)
          << "\n    body: " << name(model.body(in.body).name) << "\n";
      switch (in.type) {
        case InputType::joint:
          out << "    speed: " << in.speed + 1 << "\n";
          break;
        case InputType::force:
          out << "    direction: " << num.direction(at + "direction", in.direction)
              << "\n    point: " << num.vector(at + "point", in.point) << "\n";
          break;
        case InputType::torque:
          out << "    axis: " << num.direction(at + "axis", in.axis)
              << "\n    reaction: " << (in.reaction ? "true" : "false") << "\n";
          break;
      }
    }
  }
  if (!model.frames().empty()) {
    out << "frames:\n";
    for (size_t i = 0; i < model.frames().size(); ++i) {
      const Frame& f = model.frames()[i];
      out << "  - name: " << name(f.name) << "\n    body: "
          << (f.body == kGround ? std::string("ground") : name(model.body(f.body).name)) << "\n";
      out << "    at: " << num.vector("frames[" + std::to_string(i) + "].at", f.at) << "\n";
      if (!is_identity(f.rotation)) out << "    rotation: " << axis_angle(f.rotation) << "\n";
    }
  }
  if (!model.constraints().empty()) {
    // Every key of the constraint's type, defaults too, so that the file says what it means.
    out << "constraints:\n";
    const auto body_name = [&](int k) {
      return k == kGround ? std::string("ground") : name(model.body(k).name);
    };
    for (size_t i = 0; i < model.constraints().size(); ++i) {
      const Constraint& c = model.constraints()[i];
      const std::string at = "constraints[" + std::to_string(i) + "].";
      out << "  - name: " << name(c.name) << "\n    type: " << to_string(c.type)
          << "\n    body: " << body_name(c.body) << "\n";
      if (c.type == ConstraintType::rolling_disc) {
        out << "    center: " << num.vector(at + "center", c.at)
            << "\n    axis: " << num.direction(at + "axis", c.axis)
            << "\n    radius: " << num.number(at + "radius", c.radius)
            << "\n    plane: {normal: " << num.direction(at + "plane.normal", c.plane_normal)
            << ", offset: " << num.number(at + "plane.offset", c.plane_offset) << "}\n";
        continue;
      }
      out << "    at: " << num.vector(at + "at", c.at) << "\n";
      if (c.type == ConstraintType::hinge)
        out << "    axis: " << num.direction(at + "axis", c.axis) << "\n";
      out << "    other: " << body_name(c.other)
          << "\n    other_at: " << num.vector(at + "other_at", c.other_at) << "\n";
      if (c.type == ConstraintType::hinge)
        out << "    other_axis: " << num.direction(at + "other_axis", c.other_axis) << "\n";
      if (c.type == ConstraintType::distance)
        out << "    length: " << num.number(at + "length", c.length) << "\n";
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
    if (s.t_end) out << "  t_end: " << num.number("simulation.t_end", *s.t_end) << "\n";
    if (s.dt_out) out << "  dt_out: " << num.number("simulation.dt_out", *s.dt_out) << "\n";
    if (s.integrator) out << "  integrator: " << *s.integrator << "\n";
    if (s.rtol) out << "  rtol: " << num.number("simulation.rtol", *s.rtol) << "\n";
    if (s.atol) out << "  atol: " << num.number("simulation.atol", *s.atol) << "\n";
    if (s.step) out << "  step: " << num.number("simulation.step", *s.step) << "\n";
    if (s.route)
      out << "  route: " << (*s.route == "kane" ? std::string("assembled") : *s.route) << "\n";
  }
  return out.str();
}

}  // namespace kanedyn::io
