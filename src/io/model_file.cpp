// Model files, format kanedyn-model/1 (docs/model-format.md). Every value is checked where it
// is read, so that an error can name the file, the line and column and the key path; the
// Model constructor then validates again (it is the library's own guard).
#include "kanedyn/io/model_file.hpp"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include "kanedyn/forces.hpp"
#include "kanedyn/rotation.hpp"

namespace kanedyn::io {

namespace {

std::string format_error(const std::string& file, int line, int column, const std::string& key_path,
                         const std::string& problem) {
  std::string s = file;
  if (line > 0) s += ":" + std::to_string(line) + ":" + std::to_string(column);
  s += ": ";
  if (!key_path.empty()) s += key_path + ": ";
  return s + problem;
}

}  // namespace

ModelFileError::ModelFileError(const std::string& file, int line, int column,
                               const std::string& key_path, const std::string& problem)
    : std::runtime_error(format_error(file, line, column, key_path, problem)),
      file_(file),
      key_path_(key_path),
      problem_(problem),
      line_(line),
      column_(column) {}

namespace {

constexpr const char* kFormat = "kanedyn-model/1";
constexpr double kEulerNormTolerance = 1e-6;

/// A value in the file: its node, its key path and where to point at it. For a null value
/// (`key:` with nothing after it) yaml-cpp marks the next token, so the key's mark is used.
struct Field {
  YAML::Node node;
  std::string path;
  YAML::Mark mark;
  YAML::Mark key_mark;  ///< of its key (of the value itself for a list element)
};

std::string join(const std::vector<std::string>& words) {
  std::string s;
  for (const auto& w : words) s += (s.empty() ? "" : ", ") + w;
  return s;
}

std::string child_path(const std::string& parent, const std::string& key) {
  return parent.empty() ? key : parent + "." + key;
}

std::string index_path(const std::string& parent, size_t i) {
  return parent + "[" + std::to_string(i) + "]";
}

/// User text fit for a one-line message: control characters escaped, long text shortened.
std::string printable(const std::string& s) {
  constexpr size_t kMax = 60;
  std::string out;
  for (size_t i = 0; i < s.size() && i < kMax; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c == '\n') {
      out += "\\n";
    } else if (c == '\t') {
      out += "\\t";
    } else if (c < 0x20 || c == 0x7f) {
      static const char* hex = "0123456789abcdef";
      out += std::string("\\x") + hex[c >> 4] + hex[c & 15];
    } else {
      out += static_cast<char>(c);
    }
  }
  if (s.size() > kMax) out += "...";
  return out;
}

std::string quote(const std::string& s) { return "'" + printable(s) + "'"; }

std::string describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
    case YAML::NodeType::Undefined:
      return "nothing (null)";
    case YAML::NodeType::Sequence:
      return "a list of " + std::to_string(node.size());
    case YAML::NodeType::Map:
      return "a mapping";
    case YAML::NodeType::Scalar:
      return quote(node.Scalar());
  }
  return "something else";
}

size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

/// A strict YAML 1.2 / JSON decimal: [-+]? (digits [. digits?] | . digits) ([eE] [-+]? digits)?
bool is_decimal(const std::string& s) {
  size_t i = 0;
  const auto digits = [&] {
    const size_t start = i;
    while (i < s.size() && std::isdigit(static_cast<unsigned char>(s[i]))) ++i;
    return i - start;
  };
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
  size_t mantissa = digits();
  if (i < s.size() && s[i] == '.') {
    ++i;
    mantissa += digits();
  }
  if (mantissa == 0) return false;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
    if (digits() == 0) return false;
  }
  return i == s.size();
}

bool is_yaml_inf_or_nan(const std::string& s) {
  std::string t = s;
  if (!t.empty() && (t[0] == '+' || t[0] == '-')) t.erase(0, 1);
  for (const char* w : {".inf", ".Inf", ".INF", ".nan", ".NaN", ".NAN"})
    if (t == w) return true;
  return false;
}

class Reader;

/// The entries of one mapping, checked for duplicate and non-scalar keys.
class Mapping {
 public:
  Mapping(const Reader& reader, const Field& field);
  /// Refuses keys not in `allowed`, naming the key and listing the allowed ones.
  void allow(std::initializer_list<const char*> allowed) const;
  bool has(const std::string& key) const { return find(key) != nullptr; }
  std::optional<Field> get(const std::string& key) const;
  Field require(const std::string& key) const;
  const Field& field() const { return field_; }

 private:
  struct Entry {
    std::string key;
    YAML::Mark key_mark;
    YAML::Node value;
  };
  const Entry* find(const std::string& key) const;

  const Reader& reader_;
  Field field_;
  std::vector<Entry> entries_;
};

class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const YAML::Mark& mark, const std::string& path,
                         const std::string& problem) const {
    const bool known = !mark.is_null() && mark.line >= 0;
    throw ModelFileError(file_, known ? mark.line + 1 : 0, known ? mark.column + 1 : 0, path,
                         problem);
  }
  [[noreturn]] void fail(const Field& f, const std::string& problem) const {
    fail(f.mark, f.path, problem);
  }

  /// The one YAML document of the file, which must be a mapping.
  YAML::Node load(const std::string& text) const {
    const std::vector<YAML::Mark> starts = document_starts(text);
    if (starts.empty())
      fail(YAML::Mark::null_mark(), "",
           "the file is empty; a model file is a mapping starting with 'format: " +
               std::string(kFormat) + "'");
    if (starts.size() > 1)
      fail(starts[1], "",
           "the file holds more than one YAML document; a model file is exactly one");
    YAML::Node root;
    try {
      root = YAML::Load(text);
    } catch (const YAML::Exception& e) {
      fail(e.mark, "", "YAML syntax error: " + e.msg);
    }
    if (root.IsNull())
      fail(YAML::Mark::null_mark(), "",
           "the file is empty; a model file is a mapping starting with 'format: " +
               std::string(kFormat) + "'");
    if (!root.IsMap())
      fail(root.Mark(), "",
           "a model file must be a mapping (key: value lines), got " + describe(root));
    return root;
  }

  /// Where the documents of a YAML stream start (at most three are looked for). yaml-cpp 0.7's
  /// LoadAll loops without end, allocating, on some bad input (a stray ',' at the top level,
  /// jbeder/yaml-cpp#1040): its parser then starts document after document at the same token.
  /// Here the loop is bounded and that case is reported as the syntax error it is.
  std::vector<YAML::Mark> document_starts(const std::string& text) const {
    struct Starts final : YAML::EventHandler {
      std::vector<YAML::Mark> marks;
      void OnDocumentStart(const YAML::Mark& mark) override { marks.push_back(mark); }
      void OnDocumentEnd() override {}
      void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
      void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
      void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t,
                    const std::string&) override {}
      void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                           YAML::EmitterStyle::value) override {}
      void OnSequenceEnd() override {}
      void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                      YAML::EmitterStyle::value) override {}
      void OnMapEnd() override {}
    } starts;
    std::istringstream in(text);
    try {
      YAML::Parser parser(in);
      while (starts.marks.size() < 3 && parser.HandleNextDocument(starts)) {
        const size_t n = starts.marks.size();
        if (n >= 2 && starts.marks[n - 1].pos == starts.marks[n - 2].pos) {
          const YAML::Mark& at = starts.marks[n - 1];
          const size_t pos = static_cast<size_t>(std::max(at.pos, 0));
          fail(at, "",
               "YAML syntax error: unexpected " +
                   (pos < text.size() ? quote(text.substr(pos, 1)) : "end of file"));
        }
      }
    } catch (const YAML::Exception& e) {
      fail(e.mark, "", "YAML syntax error: " + e.msg);
    }
    return starts.marks;
  }

  Field element(const Field& list, size_t i) const {
    const YAML::Node node = list.node[i];
    const YAML::Mark mark = node.IsNull() ? list.mark : node.Mark();
    return {node, index_path(list.path, i), mark, mark};
  }

  std::vector<Field> list(const Field& f, const std::string& what) const {
    if (!f.node.IsSequence()) fail(f, "expected a list of " + what + ", got " + describe(f.node));
    std::vector<Field> items;
    for (size_t i = 0; i < f.node.size(); ++i) items.push_back(element(f, i));
    return items;
  }

  double number(const Field& f) const {
    if (!f.node.IsScalar()) fail(f, "expected a number, got " + describe(f.node));
    const std::string& s = f.node.Scalar();
    const std::string& tag = f.node.Tag();
    if (tag == "!" || tag.find(":str") != std::string::npos)
      fail(f, "expected a number, got the quoted string " + quote(s));
    if (is_yaml_inf_or_nan(s))
      fail(f, "non-finite number " + quote(s) + "; numbers must be finite");
    if (!is_decimal(s)) fail(f, "expected a number, got " + quote(s));
    // from_chars: locale-independent, unlike strtod. It takes no leading '+'.
    const char* first = s.data() + (s[0] == '+' ? 1 : 0);
    double value = 0.0;
    const auto [end, error] = std::from_chars(first, s.data() + s.size(), value);
    if (error == std::errc::result_out_of_range) {
      const size_t e = s.find_first_of("eE");
      if (e != std::string::npos && s[e + 1] == '-')
        fail(f, quote(s) + " is too small for a double (it underflows)");
      fail(f, "non-finite number: " + quote(s) + " overflows a double");
    }
    if (error != std::errc() || end != s.data() + s.size() || !std::isfinite(value))
      fail(f, "expected a number, got " + quote(s));
    return value;
  }

  double positive(const Field& f) const {
    const double v = number(f);
    if (!(v > 0.0)) fail(f, "must be > 0, got " + f.node.Scalar());
    return v;
  }

  double non_negative(const Field& f) const {
    const double v = number(f);
    if (v < 0.0) fail(f, "must be >= 0, got " + f.node.Scalar());
    return v;
  }

  /// A list of exactly `n` numbers.
  VectorX numbers(const Field& f, int n) const {
    const std::string what = std::to_string(n) + " numbers";
    if (!f.node.IsSequence() || f.node.size() != static_cast<size_t>(n))
      fail(f, "expected a list of " + what + ", got " + describe(f.node));
    VectorX v(n);
    for (int i = 0; i < n; ++i) v[i] = number(element(f, static_cast<size_t>(i)));
    return v;
  }

  Vector3 vector3(const Field& f) const { return numbers(f, 3); }

  /// A list of 3 numbers, or one number standing for three equal ones.
  Vector3 vector3_or_scalar(const Field& f) const {
    if (f.node.IsScalar()) return Vector3::Constant(number(f));
    if (!f.node.IsSequence())
      fail(f, "expected a number or a list of 3 numbers, got " + describe(f.node));
    return vector3(f);
  }

  std::string text(const Field& f) const {
    if (!f.node.IsScalar()) fail(f, "expected a text value, got " + describe(f.node));
    return f.node.Scalar();
  }

  /// A text value that must be one of `choices`.
  std::string choice(const Field& f, std::initializer_list<const char*> choices,
                     const std::string& what) const {
    const std::string s = text(f);
    std::vector<std::string> allowed(choices.begin(), choices.end());
    if (std::find(allowed.begin(), allowed.end(), s) == allowed.end())
      fail(f, "unknown " + what + " " + quote(s) + "; allowed: " + join(allowed));
    return s;
  }

  Mapping mapping(const Field& f) const { return Mapping(*this, f); }

 private:
  std::string file_;
};

Mapping::Mapping(const Reader& reader, const Field& field) : reader_(reader), field_(field) {
  if (!field.node.IsMap()) reader.fail(field, "expected a mapping, got " + describe(field.node));
  // yaml-cpp keeps every pair of a mapping, duplicates included; refuse them here.
  for (auto it = field.node.begin(); it != field.node.end(); ++it) {
    const YAML::Node key = it->first;  // copies: the iterator hands out temporaries
    if (!key.IsScalar())
      reader.fail(key.Mark(), field.path, "keys must be plain words, got " + describe(key));
    if (const Entry* previous = find(key.Scalar()))
      reader.fail(key.Mark(), child_path(field.path, printable(key.Scalar())),
                  "duplicate key " + quote(key.Scalar()) + " (first given on line " +
                      std::to_string(previous->key_mark.line + 1) + ")");
    const YAML::Node value = it->second;
    entries_.push_back({key.Scalar(), key.Mark(), value});
  }
}

void Mapping::allow(std::initializer_list<const char*> allowed) const {
  const std::vector<std::string> words(allowed.begin(), allowed.end());
  for (const Entry& e : entries_) {
    if (std::find(words.begin(), words.end(), e.key) != words.end()) continue;
    std::string problem = "unknown key " + quote(e.key);
    for (const std::string& w : words)
      if (edit_distance(e.key, w) <= 2) {
        problem += " (did you mean " + quote(w) + "?)";
        break;
      }
    reader_.fail(e.key_mark, child_path(field_.path, printable(e.key)),
                 problem + "; allowed keys: " + join(words));
  }
}

const Mapping::Entry* Mapping::find(const std::string& key) const {
  for (const Entry& e : entries_)
    if (e.key == key) return &e;
  return nullptr;
}

std::optional<Field> Mapping::get(const std::string& key) const {
  const Entry* e = find(key);
  if (!e) return std::nullopt;
  return Field{e->value, child_path(field_.path, key),
               e->value.IsNull() || e->value.Mark().is_null() ? e->key_mark : e->value.Mark(),
               e->key_mark};
}

Field Mapping::require(const std::string& key) const {
  if (auto f = get(key)) return *f;
  reader_.fail(field_.mark, child_path(field_.path, key), "missing required key " + quote(key));
}

// ---- Sections -----------------------------------------------------------------------------

bool valid_body_name(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
  });
}

/// Inertia [Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]; products are the tensor's
/// off-diagonal entries.
Matrix3 read_inertia(const Reader& r, const Field& f) {
  const size_t n = f.node.IsSequence() ? f.node.size() : 0;
  if (n != 3 && n != 6)
    r.fail(f,
           "expected a list of 3 numbers [Ixx, Iyy, Izz] or 6 numbers "
           "[Ixx, Iyy, Izz, Ixy, Ixz, Iyz], got " +
               describe(f.node));
  const VectorX v = r.numbers(f, static_cast<int>(n));
  Matrix3 inertia = v.head<3>().asDiagonal();
  if (n == 6) {
    inertia(0, 1) = inertia(1, 0) = v[3];
    inertia(0, 2) = inertia(2, 0) = v[4];
    inertia(1, 2) = inertia(2, 1) = v[5];
  }
  if (const std::string problem = check_inertia(inertia); !problem.empty()) r.fail(f, problem);
  return inertia;
}

/// `rotation: {axis, angle | angle_deg}` as Euler parameters (absolute orientation).
Vector4 read_rotation(const Reader& r, const Field& f) {
  const Mapping m = r.mapping(f);
  m.allow({"axis", "angle", "angle_deg"});
  const Field axis_field = m.require("axis");
  const Vector3 axis = r.vector3(axis_field);
  if (axis.norm() == 0.0) r.fail(axis_field, "the rotation axis must not be zero");
  const auto angle = m.get("angle");
  const auto angle_deg = m.get("angle_deg");
  if (angle && angle_deg)
    r.fail(angle_deg->key_mark, f.path, "give either 'angle' (radians) or 'angle_deg', not both");
  if (!angle && !angle_deg)
    r.fail(f.mark, child_path(f.path, "angle"),
           "missing required key 'angle' (radians) or 'angle_deg' (degrees)");
  const double theta = angle ? r.number(*angle) : r.number(*angle_deg) * (std::numbers::pi / 180.0);
  return euler_parameters_from_axis_angle(axis, theta);
}

Vector4 read_euler_parameters(const Reader& r, const Field& f) {
  const Vector4 eps = r.numbers(f, 4);
  const double norm = eps.norm();
  if (!(std::abs(norm - 1.0) <= kEulerNormTolerance)) {
    std::ostringstream s;
    s << "Euler parameters (e1, e2, e3, e4; e4 scalar) must have norm 1 within "
      << kEulerNormTolerance;
    s.precision(12);
    s << ", got norm " << norm;
    r.fail(f, s.str());
  }
  return eps / norm;
}

void read_initial(const Reader& r, const Field& f, int k, State& state) {
  const Mapping m = r.mapping(f);
  m.allow({"euler_parameters", "rotation", "translation", "angular_velocity", "translation_rate"});
  const auto eps = m.get("euler_parameters");
  const auto rotation = m.get("rotation");
  if (eps && rotation)
    r.fail(rotation->key_mark, f.path, "give either 'euler_parameters' or 'rotation', not both");
  if (eps) state.euler_parameters(k) = read_euler_parameters(r, *eps);
  if (rotation) state.euler_parameters(k) = read_rotation(r, *rotation);
  if (auto v = m.get("translation")) state.translation(k) = r.vector3(*v);
  if (auto v = m.get("angular_velocity")) state.angular_velocity(k) = r.vector3(*v);
  if (auto v = m.get("translation_rate")) state.translation_rate(k) = r.vector3(*v);
}

/// Body names in numbering order, with a hash index so that loading stays O(N).
struct BodyNames {
  std::vector<std::string> names;
  std::unordered_map<std::string, int> index;
};

/// Index of the body named by `f`, which must be one of `bodies`.
int body_reference(const Reader& r, const Field& f, const BodyNames& bodies) {
  const std::string name = r.text(f);
  const auto it = bodies.index.find(name);
  if (it == bodies.index.end()) {
    // List the bodies when there are few; a long list helps nobody.
    const std::string list = bodies.names.size() <= 20 ? "; bodies: " + join(bodies.names) : "";
    r.fail(f, "unknown body " + quote(name) + list);
  }
  return it->second;
}

struct BodiesSection {
  std::vector<BodySpec> specs;
  std::vector<std::optional<Field>> initial;  // the `initial:` entries, where given
};

BodiesSection read_bodies(const Reader& r, const Field& f) {
  const std::vector<Field> items = r.list(f, "bodies");
  if (items.empty()) r.fail(f, "a model needs at least one body");
  // First pass: mappings and names, so that a parent can be looked up (and a later one
  // recognised as such).
  std::vector<Mapping> maps;
  std::vector<std::string> names;
  std::unordered_map<std::string, size_t> index_of;  // name -> list index: O(N) loading
  for (size_t i = 0; i < items.size(); ++i) {
    const Mapping& m = maps.emplace_back(r.mapping(items[i]));
    m.allow({"name", "parent", "mass", "inertia", "com", "joint", "initial"});
    const Field name_field = m.require("name");
    const std::string name = r.text(name_field);
    if (!valid_body_name(name))
      r.fail(name_field,
             "body name " + quote(name) + " must be non-empty and use only [A-Za-z0-9_-]");
    if (name == "ground")
      r.fail(name_field, "'ground' is reserved for the inertial frame; choose another body name");
    if (const auto it = index_of.find(name); it != index_of.end())
      r.fail(name_field, "duplicate body name " + quote(name) + " (already used by " +
                             index_path("bodies", it->second) + ")");
    index_of.emplace(name, i);
    names.push_back(name);
  }
  BodiesSection section;
  for (size_t i = 0; i < items.size(); ++i) {
    const Mapping& m = maps[i];
    const int k = static_cast<int>(i);
    BodySpec b;
    b.name = names[i];
    const Field parent_field = m.require("parent");
    const std::string parent = r.text(parent_field);
    if (parent == "ground") {
      b.lower_body = kGround;
    } else {
      const auto it = index_of.find(parent);
      const int j =
          it == index_of.end() ? static_cast<int>(names.size()) : static_cast<int>(it->second);
      if (it == index_of.end()) {
        const std::vector<std::string> earlier(names.begin(), names.begin() + k);
        r.fail(parent_field, "unknown parent " + quote(parent) + "; expected 'ground'" +
                                 (earlier.empty() ? "" : " or an earlier body: " + join(earlier)));
      }
      if (j == k) r.fail(parent_field, "a body cannot be its own parent");
      if (j > k)
        r.fail(parent_field, "parent " + quote(parent) + " is " +
                                 index_path("bodies", static_cast<size_t>(j)) +
                                 ", a later body; a parent must be 'ground' or an earlier body " +
                                 "(L(K) < K): reorder the list");
      b.lower_body = j;
    }
    b.mass = r.positive(m.require("mass"));
    b.inertia = read_inertia(r, m.require("inertia"));
    if (auto v = m.get("com")) b.com = r.vector3(*v);
    if (auto v = m.get("joint")) b.joint = r.vector3(*v);
    section.specs.push_back(std::move(b));
    section.initial.push_back(m.get("initial"));
  }
  return section;
}

std::shared_ptr<const ForceElement> read_force(const Reader& r, const Field& f,
                                               const BodyNames& names) {
  const Mapping m = r.mapping(f);
  const std::string type =
      r.choice(m.require("type"), {"bushing", "force", "torque"}, "force type");
  if (type == "bushing") {
    m.allow({"type", "body", "stiffness", "damping", "rotational_stiffness", "rotational_damping"});
  } else {
    m.allow({"type", "body", "value"});
  }
  const int body = body_reference(r, m.require("body"), names);
  if (type == "bushing") {
    const auto non_negative3 = [&](const char* key) -> Vector3 {
      const auto v = m.get(key);
      if (!v) return Vector3::Zero();
      const Vector3 value = r.vector3_or_scalar(*v);
      if ((value.array() < 0.0).any()) r.fail(*v, std::string(key) + " must be >= 0");
      return value;
    };
    const auto non_negative1 = [&](const char* key) {
      const auto v = m.get(key);
      return v ? r.non_negative(*v) : 0.0;
    };
    return std::make_shared<Bushing>(body, non_negative3("stiffness"), non_negative3("damping"),
                                     non_negative1("rotational_stiffness"),
                                     non_negative1("rotational_damping"));
  }
  const Vector3 value = r.vector3(m.require("value"));
  if (type == "force") return std::make_shared<ConstantForce>(body, value);
  return std::make_shared<ConstantTorque>(body, value);
}

SimulationSection read_simulation(const Reader& r, const Field& f) {
  const Mapping m = r.mapping(f);
  m.allow({"t_end", "dt_out", "integrator", "rtol", "atol", "step", "method"});
  SimulationSection s;
  if (auto v = m.get("t_end")) s.t_end = r.positive(*v);
  if (auto v = m.get("dt_out")) s.dt_out = r.positive(*v);
  if (auto v = m.get("integrator")) s.integrator = r.choice(*v, {"dopri5", "rk4"}, "integrator");
  if (auto v = m.get("rtol")) s.rtol = r.positive(*v);
  if (auto v = m.get("atol")) s.atol = r.positive(*v);
  if (auto v = m.get("step")) s.step = r.positive(*v);
  if (auto v = m.get("method")) s.method = r.choice(*v, {"recursive", "kane"}, "method");
  return s;
}

}  // namespace

ModelFile parse_model_file(const std::string& text, const std::string& source_name) {
  const Reader r(source_name);
  const YAML::Node root_node = r.load(text);
  const Field root{root_node, "", root_node.Mark(), root_node.Mark()};
  const Mapping top = r.mapping(root);

  // The format first: a file of some other kind should be told so, not about its keys.
  const auto format_field = top.get("format");
  if (!format_field)
    r.fail(root.mark, "format",
           "missing required key 'format'; a model file starts with 'format: " +
               std::string(kFormat) + "'");
  const Field& format = *format_field;
  if (const std::string f = r.text(format); f != kFormat)
    r.fail(format, "unsupported format " + quote(f) +
                       "; this version reads 'format: " + std::string(kFormat) + "'");
  top.allow({"format", "name", "gravity", "bodies", "forces", "simulation"});

  const std::string name = top.has("name") ? r.text(*top.get("name")) : "";
  const Vector3 gravity = top.has("gravity") ? r.vector3(*top.get("gravity")) : Vector3::Zero();
  const Field bodies_field = top.require("bodies");
  BodiesSection bodies = read_bodies(r, bodies_field);

  BodyNames names;
  for (const BodySpec& b : bodies.specs) {
    names.index.emplace(b.name, static_cast<int>(names.names.size()));
    names.names.push_back(b.name);
  }
  std::vector<std::shared_ptr<const ForceElement>> forces;
  if (const auto forces_field = top.get("forces"))
    for (const Field& item : r.list(*forces_field, "force entries"))
      forces.push_back(read_force(r, item, names));

  SimulationSection simulation;
  if (const auto v = top.get("simulation")) simulation = read_simulation(r, *v);

  State initial(static_cast<int>(bodies.specs.size()));
  for (size_t i = 0; i < bodies.initial.size(); ++i)
    if (bodies.initial[i]) read_initial(r, *bodies.initial[i], static_cast<int>(i), initial);

  try {
    Model model(std::move(bodies.specs), gravity, std::move(forces), name);
    return ModelFile{std::move(model), std::move(initial), std::move(simulation), source_name};
  } catch (const ModelError& e) {
    // Everything the Model checks was checked above with a location; this is a safety net,
    // and the Model's message names the body or force entry.
    r.fail(YAML::Mark::null_mark(), "", e.what());
  }
}

ModelFile load_model_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw ModelFileError(path, 0, 0, "", "cannot open: is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw ModelFileError(path, 0, 0, "", std::string("cannot open: ") + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad())
    throw ModelFileError(path, 0, 0, "", std::string("cannot read: ") + std::strerror(errno));
  return parse_model_file(text.str(), path);
}

}  // namespace kanedyn::io
