// The page `kanedyn view` writes (docs/viewer.md): the viewer bundle of viewer/, compiled in
// at build time, with the model and a trajectory inlined as JSON and base64 arrays.
#include "page.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "kanedyn/constraint.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/rotation.hpp"

#ifdef KANEDYN_HAVE_VIEWER
namespace kanedyn::view {
// The page template, generated at build time from viewer/ (cmake/embed_viewer.cmake), in
// pieces to be joined.
extern const char* const kViewerTemplate[];
extern const std::size_t kViewerTemplateParts;
}  // namespace kanedyn::view
#endif

namespace kanedyn::view {
namespace {

using Json = nlohmann::ordered_json;

// Where the bundle's page template takes the data.
constexpr std::string_view kDataMarker = "__KANEDYN_DATA__";

#ifdef KANEDYN_HAVE_VIEWER
constexpr bool kAvailable = true;
std::string viewer_template() {
  std::string page;
  for (std::size_t i = 0; i < kViewerTemplateParts; ++i) page += kViewerTemplate[i];
  return page;
}
#else
constexpr bool kAvailable = false;
std::string viewer_template() { return {}; }
#endif

std::string base64(const unsigned char* data, std::size_t size) {
  static const char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < size; i += 3) {
    const unsigned v = (data[i] << 16) | (data[i + 1] << 8) | data[i + 2];
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i + 1 == size) {
    const unsigned v = data[i] << 16;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == size) {
    const unsigned v = (data[i] << 16) | (data[i + 1] << 8);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

// The page decodes with Float64Array/Float32Array, which use the platform's byte order; every
// browser platform is little-endian, so the file is written little-endian.
static_assert(std::endian::native == std::endian::little, "the page's arrays are little-endian");

template <typename T>
std::string base64_of(const std::vector<T>& v) {
  return base64(reinterpret_cast<const unsigned char*>(v.data()), v.size() * sizeof(T));
}

Json vec(const Vector3& v) { return Json::array({v.x(), v.y(), v.z()}); }

/// The solid ellipsoid of the body's mass and inertia about G_K: semi-axes a_i with
/// I_i = m (a_j^2 + a_k^2) / 5, so a_i^2 = 5 (I_j + I_k - I_i) / (2 m), along the principal
/// axes. A flat or needle-like body (a triangle inequality near equality) keeps a visible
/// thickness of 2% of its largest semi-axis.
Json body_json(const Model& model, int k) {
  const BodySpec& b = model.body(k);
  const Eigen::SelfAdjointEigenSolver<Matrix3> eig(b.inertia);
  Matrix3 axes = eig.eigenvectors();
  if (axes.determinant() < 0) axes.col(2) = -axes.col(2);  // a rotation, for the quaternion
  const Vector3 moments = eig.eigenvalues();
  Vector3 semi;
  for (int i = 0; i < 3; ++i) {
    const double sq =
        5.0 * (moments[(i + 1) % 3] + moments[(i + 2) % 3] - moments[i]) / (2.0 * b.mass);
    semi[i] = std::sqrt(std::max(sq, 0.0));
  }
  const double largest = semi.maxCoeff();
  for (int i = 0; i < 3; ++i) semi[i] = std::max(semi[i], 0.02 * largest);
  const Eigen::Quaterniond q(axes);  // principal axes -> body-K axes
  Json o;
  o["name"] = b.name;
  o["L"] = b.lower_body;  // 0-based, -1 for the inertial frame
  o["mass"] = b.mass;
  o["inertia"] = Json::array();  // [I'_GK], body-K components, row by row
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) o["inertia"].push_back(b.inertia(i, j));
  o["com"] = vec(b.com);
  o["joint"] = vec(b.joint);
  o["semi_axes"] = vec(semi);
  o["principal"] = Json::array({q.x(), q.y(), q.z(), q.w()});
  return o;
}

/// The joint of body k as the page draws it: each axis as a unit vector in the components of
/// the body it is fixed in, "parent" (J, or the inertial frame for a root) or "body" (K), and
/// whether K turns about it and slides along it. A joint's `axis` (revolute, prismatic,
/// cylindrical, screw: the joint table's takes_axis) is fixed in both and given in J, where Q_K
/// is too;
/// a universal joint's a1 is fixed in J and its a2, about which K turns last, in K (at zero
/// angles K's axes are F's, so a2's K components are its F components). A planar joint's
/// plane normal, F's z axis, is fixed in both and given in J.
void add_joint_json(const Model& model, int k, Json& o) {
  const Joint& jt = model.joint(k);
  o["joint_type"] = to_string(jt.type);
  Json axes = Json::array();
  const auto axis = [&](const Vector3& v, const char* in, bool turn, bool slide) {
    axes.push_back(
        Json{{"axis", vec(v.normalized())}, {"in", in}, {"turn", turn}, {"slide", slide}});
  };
  const JointTypeInfo& info = joint_type_info(jt.type);
  if (info.takes_axis) {
    // [R(frame)] maps J components to F components. The first sliding column of [T_K] is along
    // the axis (zero for a screw of pitch 0).
    axis(rotation_matrix(jt.frame).transpose() * jt.axis, "parent", info.turns,
         info.slides && !model.slide_axes_in_j(k).col(0).isZero(0.0));
  }
  switch (jt.type) {
    case JointType::universal:
      // [R(frame)] maps J components to F components.
      axis(rotation_matrix(jt.frame).transpose() * jt.axes[0], "parent", true, false);
      axis(jt.axes[1], "body", true, false);
      break;
    case JointType::planar:
      axis(rotation_matrix(jt.frame).transpose() * Vector3::UnitZ(), "parent", true, false);
      break;
    default:
      break;
  }
  o["joint_axes"] = std::move(axes);
}

/// A constraint as the page draws it (docs/viewer.md, "What the page holds"): the fields of
/// struct Constraint its type uses, body indices 0-based and -1 for the ground; vectors in
/// the components they are given in (body K's, the other body's, or inertial for the ground
/// and a disc's plane), axes normalized by the Model.
Json constraint_json(const Constraint& c) {
  Json o;
  o["name"] = c.name;
  o["type"] = to_string(c.type);
  o["body"] = c.body;
  o["at"] = vec(c.at);
  if (c.type == ConstraintType::rolling_disc) {
    o["axis"] = vec(c.axis);
    o["radius"] = c.radius;
    o["plane_normal"] = vec(c.plane_normal);
    o["plane_offset"] = c.plane_offset;
    return o;
  }
  if (c.type == ConstraintType::hinge) o["axis"] = vec(c.axis);
  o["other"] = c.other == kGround ? -1 : c.other;
  o["other_at"] = vec(c.other_at);
  if (c.type == ConstraintType::hinge) o["other_axis"] = vec(c.other_axis);
  if (c.type == ConstraintType::distance) o["length"] = c.length;
  return o;
}

/// Whether body k's links O_J -> Q_K -> O_K stand for something that joins K to J: a joint
/// other than free (drawn at Q_K), a bushing on K, or a joint input on one of a free body's
/// translation speeds (a force between K and J, as a bushing's). A free body with none of
/// these moves on its own: a line from O_J (the origin, for a root) would read as a tether.
bool linked(const Model& model, int k) {
  if (!model.all_free() && model.joint(k).type != JointType::free) return true;
  for (const auto& f : model.forces())
    if (f->type() == "bushing" && f->body() == k) return true;
  for (const Input& u : model.inputs())
    if (u.type == InputType::joint && u.body == k && u.speed >= 3 &&
        (model.all_free() || model.joint(k).type == JointType::free))
      return true;
  return false;
}

/// A model frame as the page draws it: its body (0-based, -1 for the ground), origin from O_K
/// (body-K components; the ground's: inertial) and its axes as a quaternion x, y, z, w from
/// frame to body-K axes: [R(rotation)] maps body-K to frame components, so its transpose, the
/// quaternion (e1, e2, e3; e4), maps frame to body-K components, as a body's Euler parameters
/// map body to inertial components on the page.
Json frame_json(const Frame& f) {
  Json o;
  o["name"] = f.name;
  o["body"] = f.body == kGround ? -1 : f.body;
  o["at"] = vec(f.at);
  o["rotation"] = Json::array({f.rotation[0], f.rotation[1], f.rotation[2], f.rotation[3]});
  return o;
}

std::string list_names(const std::vector<std::string>& names) {
  std::string out;
  const std::size_t shown = std::min<std::size_t>(names.size(), 12);
  for (std::size_t i = 0; i < shown; ++i) out += (i ? ", " : "") + io::printable(names[i], 60);
  if (names.size() > shown) out += ", ... " + std::to_string(names.size() - shown) + " more";
  return out;
}

}  // namespace

std::string check_names(const Model& model, const PageOptions& options) {
  std::vector<std::string> bodies, frames;
  for (const BodySpec& b : model.bodies()) bodies.push_back(b.name);
  for (const Frame& f : model.frames()) frames.push_back(f.name);
  if (!options.follow.empty() && model.body_index(options.follow) < 0)
    return "--follow '" + io::printable(options.follow, 60) + "': the model has no body '" +
           io::printable(options.follow, 60) + "' (its bodies: " + list_names(bodies) + ")";
  for (const std::string& t : options.trace) {
    if (model.body_index(t) >= 0 || model.frame_index(t) >= 0) continue;
    std::string m = "--trace '" + io::printable(t, 60) + "': the model has no body or frame '" +
                    io::printable(t, 60) + "' (its bodies: " + list_names(bodies);
    m += frames.empty() ? "; no frames)" : "; its frames: " + list_names(frames) + ")";
    return m;
  }
  return "";
}

std::size_t required_columns(const Model& model) {
  return 2 + 16 * static_cast<std::size_t>(model.num_bodies());
}

io::Trajectory initial_trajectory(const Model& model, const VectorX& q, const VectorX& z) {
  State initial(model);
  joint_state(model, q, z, initial);
  Data data(model);
  compute_kinematics(model, initial, data);
  io::Trajectory out;
  out.columns = io::trajectory_body_columns(model);
  // The page's own columns only: the inputs' and reactions' columns after the energy are
  // values of a run, not of a state (page() takes them when a trajectory has them).
  out.columns.resize(required_columns(model));
  out.values.push_back(0.0);
  for (int k = 0; k < model.num_bodies(); ++k) {
    const auto put = [&](const auto& v) {
      for (Eigen::Index i = 0; i < v.size(); ++i) out.values.push_back(v[i]);
    };
    put(data.kinematics.p_G[static_cast<std::size_t>(k)]);
    put(initial.euler_parameters(k));
    put(initial.translation(k));
    put(initial.angular_velocity(k));
    put(initial.translation_rate(k));
  }
  out.values.push_back(total_energy_of_kinematics(model, initial, q, data));
  return out;
}

std::size_t stride(std::size_t rows) {
  return rows <= kMaxRows ? 1 : (rows + kMaxRows - 1) / kMaxRows;
}

namespace {

/// The JSON the page reads (docs/viewer.md, "What the page holds").
/// The trajectory with only the columns of the free-body layout, in its order: a jointed
/// model's j and jd columns are left out (the page draws the bodies from their poses). The
/// layout's first required_columns() (t, the bodies', the energy) must be there; the inputs'
/// and the constraints' reactions' after them are kept when the trajectory has them all.
io::Trajectory body_columns(const Model& model, const io::Trajectory& traj) {
  std::vector<std::string> wanted = io::trajectory_body_columns(model);
  const std::size_t required = required_columns(model);
  std::vector<std::size_t> from;
  std::size_t c = 0;
  for (std::size_t i = 0; i < wanted.size(); ++i) {
    while (c < traj.columns.size() && traj.columns[c] != wanted[i]) ++c;
    if (c == traj.columns.size()) {
      if (i < required)
        throw std::invalid_argument("view::page: the trajectory's columns are not the model's");
      // Without the run's columns (an initial state, a mode): the page's own only.
      wanted.resize(required);
      from.resize(required);
      break;
    }
    from.push_back(c++);
  }
  io::Trajectory out;
  out.columns = wanted;
  out.values.reserve(traj.rows() * wanted.size());
  for (std::size_t r = 0; r < traj.rows(); ++r)
    for (const std::size_t f : from) out.values.push_back(traj.at(r, f));
  return out;
}

std::string page_data(const Model& model, const std::string& model_file,
                      const io::Trajectory& given, const std::string& source,
                      const PageOptions& options) {
  const bool plain = given.columns == io::trajectory_body_columns(model);
  const io::Trajectory filtered = plain ? io::Trajectory{} : body_columns(model, given);
  const io::Trajectory& traj = plain ? given : filtered;
  const std::size_t rows = traj.rows(), width = traj.columns.size();
  if (rows == 0) throw std::invalid_argument("view::page: the trajectory has no rows");
  // Every stride-th row, and the last one, so that the page ends where the run ends.
  const std::size_t stride = view::stride(rows);
  std::vector<std::size_t> kept;
  for (std::size_t r = 0; r < rows; r += stride) kept.push_back(r);
  if (kept.back() != rows - 1) kept.push_back(rows - 1);
  // Time and the mass centres in float64: float32's 6e-8 relative step would be 6 um at
  // 100 m, coarser than the page's promise that it draws the CSV's positions. The energy
  // too: a conservative run's drift (1e-7 J of 100 J, say) is below float32's step, which
  // would plot as a staircase of rounding. The rest (Euler parameters, speeds: drawing and
  // plotting only) in float32.
  std::vector<double> f64;
  std::vector<float> f32;
  Json f64_columns = Json::array(), f32_columns = Json::array();
  const std::size_t energy = required_columns(model) - 1;  // after t and 16 a body
  for (std::size_t c = 0; c < width; ++c) {
    const bool centre = c >= 1 && c < energy && (c - 1) % 16 < 3;  // NAME.x, .y, .z
    const bool wide = c == 0 || centre || c == energy;
    (wide ? f64_columns : f32_columns).push_back(c);
    for (const std::size_t r : kept) {
      // A page of NaN draws nothing and plots nothing: refused, naming the first such value.
      const double v = traj.at(r, c);
      if (!std::isfinite(v) || (!wide && std::abs(v) > std::numeric_limits<float>::max())) {
        std::ostringstream m;
        m << "view::page: column '" << io::printable(traj.columns[c], 60)
          << "' at t = " << traj.at(r, 0) << " is "
          << (std::isfinite(v) ? "beyond a float's range" : "not finite") << " (" << v
          << "): the page would draw nothing there";
        throw std::invalid_argument(m.str());
      }
      if (wide)
        f64.push_back(traj.at(r, c));
      else
        f32.push_back(static_cast<float>(traj.at(r, c)));
    }
  }
  // A mode's coordinates follow the trajectory's columns, as float32 (plotted only).
  const std::size_t extra = options.mode_columns.size();
  if (options.mode_values.size() != rows * extra)
    throw std::invalid_argument("view::page: " + std::to_string(options.mode_values.size()) +
                                " mode values for " + std::to_string(rows) + " rows of " +
                                std::to_string(extra) + " columns");
  for (std::size_t c = 0; c < extra; ++c) {
    f32_columns.push_back(width + c);
    for (const std::size_t r : kept) {
      const double v = options.mode_values[r * extra + c];
      if (!std::isfinite(v) || std::abs(v) > std::numeric_limits<float>::max())
        throw std::invalid_argument("view::page: mode column '" +
                                    io::printable(options.mode_columns[c], 60) +
                                    "' is not finite or beyond a float's range");
      f32.push_back(static_cast<float>(v));
    }
  }
  Json d;
  d["format"] = "kanedyn-view/1";
  Json m;
  m["name"] = model.name();
  m["file"] = model_file;
  m["gravity"] = vec(model.gravity());
  m["bodies"] = Json::array();
  for (int k = 0; k < model.num_bodies(); ++k) {
    Json b = body_json(model, k);
    if (!model.all_free()) add_joint_json(model, k, b);
    b["linked"] = linked(model, k);
    m["bodies"].push_back(std::move(b));
  }
  if (!model.frames().empty()) {
    m["frames"] = Json::array();
    for (const Frame& f : model.frames()) m["frames"].push_back(frame_json(f));
  }
  if (model.num_constraints() > 0) {
    m["constraints"] = Json::array();
    for (const Constraint& c : model.constraints()) m["constraints"].push_back(constraint_json(c));
  }
  d["model"] = std::move(m);
  d["source"] = source;
  d["rows_in_file"] = rows;
  d["stride"] = stride;
  d["rows"] = kept.size();
  Json columns = traj.columns;
  Json mode = Json::array();
  for (const std::string& c : options.mode_columns) {
    columns.push_back("mode." + c);
    mode.push_back("mode." + c);
  }
  d["columns"] = std::move(columns);
  if (!options.mode_columns.empty()) d["mode_columns"] = std::move(mode);
  if (!options.follow.empty()) d["follow"] = options.follow;
  if (!options.trace.empty()) d["trace"] = options.trace;
  d["f64_columns"] = std::move(f64_columns);
  d["f32_columns"] = std::move(f32_columns);
  d["f64"] = base64_of(f64);
  d["f32"] = base64_of(f32);
  // Inside <script>, "</script" would close the element and "<!--" followed by "<script"
  // would put the tokenizer in its double-escaped state, where the element's own end tag no
  // longer closes it. With no '<' at all, neither can happen; '>' and '&' go too, so the data
  // means the same wherever an HTML parser meets it. These characters occur only inside JSON
  // strings, where \u escapes are the same text.
  const std::string text = d.dump(-1, ' ', false, Json::error_handler_t::replace);
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    if (c == '<')
      out += "\\u003c";
    else if (c == '>')
      out += "\\u003e";
    else if (c == '&')
      out += "\\u0026";
    else
      out += c;
  }
  return out;
}

}  // namespace

std::string page(const Model& model, const std::string& model_file, const io::Trajectory& traj,
                 const std::string& source) {
  return page(model, model_file, traj, source, PageOptions{});
}

std::string page(const Model& model, const std::string& model_file, const io::Trajectory& traj,
                 const std::string& source, const PageOptions& options) {
  require_available();
  if (const std::string bad = check_names(model, options); !bad.empty())
    throw std::invalid_argument("view::page: " + bad);
  const std::string page = viewer_template();
  const std::size_t at = page.find(kDataMarker);
  if (at == std::string::npos)
    throw std::logic_error("the viewer bundle has no data marker: the build is broken");
  const std::string data = page_data(model, model_file, traj, source, options);
  std::string text;
  text.reserve(page.size() + data.size());
  text.append(page, 0, at);
  text.append(data);
  text.append(page, at + kDataMarker.size());
  return text;
}

bool available() { return kAvailable; }

void require_available() {
  if (!kAvailable)
    throw std::runtime_error(
        "this kanedyn was built without the viewer (configured with KANEDYN_VIEWER=OFF, or "
        "without node and npm): install them (scripts/install-deps.sh), configure with "
        "-DKANEDYN_VIEWER=AUTO and rebuild");
}

}  // namespace kanedyn::view
