#include "kanedyn/joints.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <utility>

#include "kanedyn/direction.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/rotation.hpp"

#include "equations.hpp"
#include "joint_motion.hpp"

namespace kanedyn {

namespace {

size_t at(int i) { return static_cast<size_t>(i); }

constexpr double kPerpendicularTolerance = 1e-9;  // |a1 . a2| of universal axes
constexpr double kUnitNormTolerance = 1e-6;       // the rule of `euler_parameters`

bool is_free(JointType t) { return t == JointType::free; }
bool has_axis(JointType t) {
  return t == JointType::revolute || t == JointType::prismatic || t == JointType::cylindrical;
}

// The Euler-parameter slice of a body's q (spherical q, or a free body's eps_K), if any.
int euler_slice(JointType t) { return t == JointType::free || t == JointType::spherical ? 4 : 0; }

// Euler parameters of the turn q about a unit axis (the Model normalized it): what
// euler_parameters_from_axis_angle gives without its rescaling of an arbitrary axis.
Vector4 turn_about_unit_axis(const Vector3& axis, double q) {
  const double s = std::sin(0.5 * q);
  return {s * axis.x(), s * axis.y(), s * axis.z(), std::cos(0.5 * q)};
}

bool is_identity(const Vector4& eps) {
  return eps[0] == 0.0 && eps[1] == 0.0 && eps[2] == 0.0 && eps[3] == 1.0;
}

// F's x and y axes in J components, the columns of a planar joint's [T_K]: the first two
// columns of [R(frame)]^T, [R(frame)] mapping J components to F components.
Eigen::Matrix<double, 3, 2> plane_axes_in_j(const Vector4& frame) {
  return rotation_matrix(frame).topRows<2>().transpose();
}

// Each type's name and counts, in the order of the enum (the table of joint.hpp).
struct TypeRow {
  const char* name;
  int coordinates, speeds;
};
constexpr TypeRow kTypeRows[] = {{"free", 7, 6},      {"weld", 0, 0},        {"revolute", 1, 1},
                                 {"prismatic", 1, 1}, {"cylindrical", 2, 2}, {"universal", 2, 2},
                                 {"spherical", 4, 3}, {"planar", 3, 3}};
static_assert(std::size(kTypeRows) == std::size(kJointTypes), "a row for every joint type");

const TypeRow& row(JointType type) { return kTypeRows[static_cast<int>(type)]; }

}  // namespace

const char* to_string(JointType type) { return row(type).name; }

int coordinate_count(JointType type) { return row(type).coordinates; }

int speed_count(JointType type) { return row(type).speeds; }

bool speeds_are_coordinate_rates(JointType type) {
  return row(type).speeds > 0 && row(type).coordinates == row(type).speeds;
}

std::string check_joint(const Joint& joint) {
  if (std::abs(joint.frame.norm() - 1.0) > kUnitNormTolerance)
    return "the joint frame's Euler parameters must have unit norm";
  if (has_axis(joint.type) && !scaled_direction(joint.axis))
    return std::string("the axis of a ") + to_string(joint.type) +
           " joint must be finite and not zero";
  if (joint.type == JointType::universal) {
    const auto a1 = unit_direction(joint.axes[0]), a2 = unit_direction(joint.axes[1]);
    if (!a1 || !a2) return "the axes of a universal joint must be finite and not zero";
    const double c = a1->dot(*a2);
    if (!(std::abs(c) <= kPerpendicularTolerance))
      return "the axes of a universal joint must be perpendicular (|a1 . a2| <= 1e-9)";
  }
  return "";
}

std::string check_joint_coordinates(JointType type, const VectorX& q) {
  const int n = coordinate_count(type);
  if (q.size() != n) {
    std::string s = std::string("a ") + to_string(type) + " joint has " + std::to_string(n);
    s += n == 1 ? " coordinate, not " : " coordinates, not ";
    s += std::to_string(q.size());
    return s;
  }
  if (euler_slice(type) > 0 && !(std::abs(q.head<4>().norm() - 1.0) <= kUnitNormTolerance))
    return std::string("the Euler parameters of a ") + to_string(type) +
           " joint must have unit norm (within 1e-6)";
  return "";
}

std::string check_joint_rates(JointType type, const VectorX& z) {
  const int n = speed_count(type);
  if (z.size() == n) return "";
  std::string s = std::string("a ") + to_string(type) + " joint has " + std::to_string(n);
  s += n == 1 ? " rate, not " : " rates, not ";
  s += std::to_string(z.size());
  return s;
}

Matrix3 axis_angle_rotation(const Vector3& axis, double angle) {
  return rotation_matrix(euler_parameters_from_axis_angle(axis, angle));  // Eqs. (3)-(4)
}

namespace {
// compose_euler_parameters (below), inlined where this file uses it.
inline Vector4 compose(const Vector4& eps_j, const Vector4& rel) {
  const eq::Euler<double> conj_j{{-eps_j[0], -eps_j[1], -eps_j[2], eps_j[3]}};
  return eq::eigen(eq::relative_euler_parameters(conj_j, eq::euler(rel)));
}
}  // namespace

Vector4 compose_euler_parameters(const Vector4& eps_j, const Vector4& rel) {
  // relative_euler_parameters(a, b) = conj(a) b (Hamilton); with a = conj(eps_J) it is
  // eps_J rel, the parameters of K: one implementation of the product.
  return compose(eps_j, rel);
}

namespace detail {

namespace {

// [G_K] (3 x speeds, body-K components): w_rel = [G_K] z_K. Only a universal joint's depends on
// q: a1, fixed in F and in the intermediate frame, is [R(a2, q2)] a1 in K components, and a2 is
// fixed in K; its second turn's Euler parameters go to `second` for the joint's rotation.
inline void rotation_columns(const Joint& jt, const VectorX& q, int o, Matrix36& G,
                             Vector4& second) {
  G.setZero();
  switch (jt.type) {
    case JointType::free:  // the notes' own: w'_K = z_K
    case JointType::spherical:
      G.leftCols<3>().setIdentity();
      break;
    case JointType::revolute:  // n is fixed by the turn about n
    case JointType::cylindrical:
      G.col(0) = jt.axis;
      break;
    case JointType::universal:
      second = turn_about_unit_axis(jt.axes[1], q[o + 1]);
      G.col(0) = rotation_matrix(second) * jt.axes[0];
      G.col(1) = jt.axes[1];
      break;
    case JointType::planar:  // e_z has the same components in F and K
      G.col(2) = Vector3::UnitZ();
      break;
    case JointType::prismatic:
    case JointType::weld:
      break;
  }
}

}  // namespace

void joint_rotation_columns(const Model& model, int k, const VectorX& q, Matrix36& G) {
  Vector4 second;
  rotation_columns(model.joint(k), q, model.coordinate_offset(k), G, second);
}

void joint_motion(const Model& model, int k, const VectorX& q, const double* z_k, JointMotion& m) {
  const Joint& jt = model.joint(k);
  const int o = model.coordinate_offset(k);
  const auto rate = [z_k](int c) { return z_k ? z_k[c] : 0.0; };
  Vector4 second;  // a universal joint's second turn
  rotation_columns(jt, q, o, m.G, second);
  m.w_rel.setZero();
  m.slide.setZero();
  m.slide_rate.setZero();
  m.g_dot_z.setZero();
  Vector4 joint_rel{0.0, 0.0, 0.0, 1.0};  // K relative to F
  switch (jt.type) {
    case JointType::free:  // the notes' own: w'_K = z_K, s'_K dot = the next three
      m.rel = jt.frame;
      m.w_rel = Vector3(rate(0), rate(1), rate(2));
      m.slide = q.segment<3>(o + 4);
      m.slide_rate = Vector3(rate(3), rate(4), rate(5));
      return;
    case JointType::weld:
      m.slide = jt.translation;
      break;
    case JointType::revolute:
      joint_rel = turn_about_unit_axis(jt.axis, q[o]);
      m.w_rel = rate(0) * jt.axis;
      break;
    case JointType::prismatic:
      m.slide = q[o] * model.axis_in_j(k);
      m.slide_rate = rate(0) * model.axis_in_j(k);
      break;
    case JointType::cylindrical:
      joint_rel = turn_about_unit_axis(jt.axis, q[o]);
      m.w_rel = rate(0) * jt.axis;
      m.slide = q[o + 1] * model.axis_in_j(k);
      m.slide_rate = rate(1) * model.axis_in_j(k);
      break;
    case JointType::universal: {
      // a1 first, then a2 as the first turn carried it (rotation_columns); d/dt [R(a2, q2)] a1 =
      // -(q2 dot a2) x [R(a2, q2)] a1.
      joint_rel = compose(turn_about_unit_axis(jt.axes[0], q[o]), second);
      const Vector3 a1_k = m.G.col(0);
      m.w_rel = rate(0) * a1_k + rate(1) * jt.axes[1];
      m.g_dot_z = -rate(0) * rate(1) * jt.axes[1].cross(a1_k);
      break;
    }
    case JointType::spherical:
      joint_rel = q.segment<4>(o);
      m.w_rel = Vector3(rate(0), rate(1), rate(2));
      break;
    case JointType::planar: {
      // q = (x, y, angle): K is F turned by angle about F's z, which is also K's z; the slide
      // x, y along F's x and y axes, constant in J, so [T_K] = [x_F y_F 0] (J components).
      joint_rel = turn_about_unit_axis(Vector3::UnitZ(), q[o + 2]);
      m.w_rel = Vector3(0.0, 0.0, rate(2));
      const Eigen::Matrix<double, 3, 2> t = plane_axes_in_j(jt.frame);
      m.slide = q[o] * t.col(0) + q[o + 1] * t.col(1);
      m.slide_rate = rate(0) * t.col(0) + rate(1) * t.col(1);
      break;
    }
  }
  // A product with the identity is exact: skipping it keeps the bits.
  m.rel = is_identity(jt.frame) ? joint_rel : compose(jt.frame, joint_rel);
}

JointMotion joint_motion(const Model& model, int k, const VectorX& q, const double* z_k) {
  JointMotion m;
  joint_motion(model, k, q, z_k, m);
  return m;
}

void joint_state(const Model& model, const VectorX& q, const VectorX& z, State& state,
                 std::vector<JointMotion>* motion) {
  for (int k = 0; k < model.num_bodies(); ++k) {
    const int j = model.lower_body(k);
    const int o = model.coordinate_offset(k);
    JointMotion own;
    JointMotion& m = motion ? (*motion)[at(k)] : own;
    joint_motion(model, k, q, z.data() + model.speed_offset(k), m);
    if (is_free(model.joint(k).type)) {
      state.euler_parameters(k) = q.segment<4>(o);
      state.angular_velocity(k) = m.w_rel;
    } else if (j == kGround) {  // J is R: eps_J the identity, w'_J = 0
      state.euler_parameters(k) = m.rel;
      state.angular_velocity(k) = m.w_rel;
    } else {  // w'_K = w_rel + [R(rel)] w'_J, [R(rel)] = [R_K][R_J]^T
      state.euler_parameters(k) = compose(state.euler_parameters(j), m.rel);
      state.angular_velocity(k) =
          m.w_rel + eq::eigen(eq::rotate(eq::euler(m.rel), eq::vec(state.angular_velocity(j))));
    }
    state.translation(k) = m.slide;
    state.translation_rate(k) = m.slide_rate;
  }
}

}  // namespace detail

Vector4 joint_relative_rotation(const Model& model, int k, const VectorX& q) {
  return detail::joint_motion(model, k, q, nullptr).rel;
}

Vector3 joint_translation(const Model& model, int k, const VectorX& q) {
  return detail::joint_motion(model, k, q, nullptr).slide;
}

Matrix36 joint_rotation_block(const Model& model, int k, const VectorX& q) {
  Matrix36 G;
  detail::joint_rotation_columns(model, k, q, G);
  return G;
}

Matrix36 joint_translation_block(const Model& model, int k) {
  Matrix36 t = Matrix36::Zero();
  switch (model.joint(k).type) {
    case JointType::free:
      t.rightCols<3>().setIdentity();
      break;
    case JointType::prismatic:
      t.col(0) = model.axis_in_j(k);
      break;
    case JointType::cylindrical:
      t.col(1) = model.axis_in_j(k);
      break;
    case JointType::planar:
      t.leftCols<2>() = plane_axes_in_j(model.joint(k).frame);
      break;
    default:
      break;
  }
  return t;
}

Vector3 joint_rotation_rate_times_speeds(const Model& model, int k, const VectorX& q,
                                         const VectorX& z) {
  return detail::joint_motion(model, k, q, z.data() + model.speed_offset(k)).g_dot_z;
}

Vector3 joint_relative_angular_velocity(const Model& model, int k, const VectorX& q,
                                        const VectorX& z) {
  return detail::joint_motion(model, k, q, z.data() + model.speed_offset(k)).w_rel;
}

void joint_state(const Model& model, const VectorX& q, const VectorX& z, State& state) {
  detail::joint_state(model, q, z, state, nullptr);
}

namespace {

Eigen::Ref<const VectorX> speeds_of(const Model& model, const VectorX& z, int c) {
  return z.segment(model.speed_offset(c), speed_count(model.joint(c).type));
}

}  // namespace

void joint_coordinates(const Model& model, const State& state, VectorX& q, VectorX& z) {
  const int n = model.num_bodies();
  if (state.x.size() != model.num_x() || state.y.size() != model.num_y())
    throw std::invalid_argument("joint_coordinates: the state does not have the model's size (" +
                                std::to_string(model.num_x()) + " + " +
                                std::to_string(model.num_y()) + ")");
  q.resize(model.num_coordinates());
  z.resize(model.num_speeds());
  bool welds = false;
  for (int k = 0; k < n; ++k) {
    const JointType type = model.joint(k).type;
    const int o = model.coordinate_offset(k), p = model.speed_offset(k);
    if (type == JointType::free) {  // the notes' own coordinates and speeds
      q.segment<4>(o) = state.euler_parameters(k);
      q.segment<3>(o + 4) = state.translation(k);
      z.segment<3>(p) = state.angular_velocity(k);
      z.segment<3>(p + 3) = state.translation_rate(k);
    } else if (type == JointType::weld) {
      welds = true;
    } else {
      throw std::invalid_argument("body '" + model.body(k).name + "' has a " + to_string(type) +
                                  " joint, whose coordinates are not taken from the notes' "
                                  "state (x, y): give its joint coordinates q and speeds z");
    }
  }
  if (!welds) return;
  State held(model);
  joint_state(model, q, z, held);
  for (int k = 0; k < n; ++k) {
    if (model.joint(k).type != JointType::weld) continue;
    const auto off = [](const auto& a, const auto& b) {
      return ((a - b).array().abs() > 1e-9 * (1.0 + b.array().abs())).any();
    };
    // Euler parameters of opposite sign are one orientation.
    const bool turned = off(state.euler_parameters(k), held.euler_parameters(k)) &&
                        off(state.euler_parameters(k), Vector4(-held.euler_parameters(k)));
    if (turned || off(state.translation(k), held.translation(k)) ||
        off(state.angular_velocity(k), held.angular_velocity(k)) ||
        off(state.translation_rate(k), held.translation_rate(k)))
      throw std::invalid_argument("body '" + model.body(k).name +
                                  "' is welded, and its pose or speeds in the notes' state are "
                                  "not those of the weld (beyond 1e-9 relative)");
  }
}

double normalize_joint_coordinates(const Model& model, Eigen::Ref<VectorX> q) {
  double worst = 0.0;
  for (int k = 0; k < model.num_bodies(); ++k) {
    if (euler_slice(model.joint(k).type) == 0) continue;
    auto e = q.segment<4>(model.coordinate_offset(k));
    const double norm = e.norm();
    worst = std::max(worst, std::abs(norm - 1.0));
    e /= norm;
  }
  return worst;
}

void joint_coordinate_rates(const Model& model, const VectorX& q, const VectorX& z,
                            Eigen::Ref<VectorX> qdot) {
  for (int k = 0; k < model.num_bodies(); ++k) {
    const int o = model.coordinate_offset(k), p = model.speed_offset(k);
    switch (model.joint(k).type) {
      case JointType::free:  // Eqs. (39)-(41), (40)
        qdot.segment<4>(o) = euler_parameter_rates(q.segment<4>(o), z.segment<3>(p));
        qdot.segment<3>(o + 4) = z.segment<3>(p + 3);
        break;
      case JointType::spherical:  // Eq. (39) for K relative to F, w_rel in body-K components
        qdot.segment<4>(o) = euler_parameter_rates(q.segment<4>(o), z.segment<3>(p));
        break;
      default:
        qdot.segment(o, coordinate_count(model.joint(k).type)) =
            z.segment(p, speed_count(model.joint(k).type));
        break;
    }
  }
}

ConstraintMatrix::ConstraintMatrix(const Model& model) {
  if (!model.has_angular_chains())
    throw ModelError("joints: " + std::to_string(model.angular_chain_entries()) +
                     " angular chain entries are too many for [C] (limit " +
                     std::to_string(Model::kMaxFlatChainEntries) + ")");
  const int n = model.num_bodies();
  w_begin.push_back(0);
  for (int k = 0; k < n; ++k) {
    for (int c : model.angular_chain(k)) w_body.push_back(c);
    w_begin.push_back(static_cast<int>(w_body.size()));
  }
  w_block.assign(w_body.size(), Matrix36::Zero());
  s_block.assign(at(n), Matrix36::Zero());
  R.assign(at(n), Matrix3::Identity());
}

void compute_constraint_matrix(const Model& model, const VectorX& q, const State& state,
                               ConstraintMatrix& C) {
  const int n = model.num_bodies();
  for (int k = 0; k < n; ++k) C.R[at(k)] = rotation_matrix(state.euler_parameters(k));
  for (int k = 0; k < n; ++k) {
    C.s_block[at(k)] = joint_translation_block(model, k);
    for (int b = C.w_begin[at(k)]; b < C.w_begin[at(k + 1)]; ++b) {
      const int c = C.w_body[at(b)];
      // w_rel of c ([G_c] z_c, c components), carried to K components by [R_K][R_c]^T; c < K
      // has its [G_c] already, as the first block of its own chain.
      C.w_block[at(b)] =
          c == k ? joint_rotation_block(model, k, q)
                 : Matrix36(C.R[at(k)] * C.R[at(c)].transpose() * C.w_block[at(C.w_begin[at(c)])]);
    }
  }
}

void constraint_times(const Model& model, const ConstraintMatrix& C, const VectorX& z,
                      Eigen::Ref<VectorX> y) {
  const int n = model.num_bodies();
  for (int k = 0; k < n; ++k) {
    Vector3 w = Vector3::Zero();
    for (int b = C.w_begin[at(k)]; b < C.w_begin[at(k + 1)]; ++b) {
      const int c = C.w_body[at(b)];
      w += C.w_block[at(b)].leftCols(speed_count(model.joint(c).type)) * speeds_of(model, z, c);
    }
    y.segment<3>(3 * k) = w;
    y.segment<3>(3 * n + 3 * k) =
        C.s_block[at(k)].leftCols(speed_count(model.joint(k).type)) * speeds_of(model, z, k);
  }
}

void constraint_transpose_times(const Model& model, const ConstraintMatrix& C, const VectorX& v,
                                Eigen::Ref<VectorX> out) {
  const int n = model.num_bodies();
  out.setZero();
  for (int k = 0; k < n; ++k) {
    for (int b = C.w_begin[at(k)]; b < C.w_begin[at(k + 1)]; ++b) {
      const int c = C.w_body[at(b)], m = speed_count(model.joint(c).type);
      out.segment(model.speed_offset(c), m) +=
          C.w_block[at(b)].leftCols(m).transpose() * v.segment<3>(3 * k);
    }
    const int m = speed_count(model.joint(k).type);
    out.segment(model.speed_offset(k), m) +=
        C.s_block[at(k)].leftCols(m).transpose() * v.segment<3>(3 * n + 3 * k);
  }
}

MatrixX dense_constraint_matrix(const Model& model, const ConstraintMatrix& C) {
  const int n = model.num_bodies();
  MatrixX d = MatrixX::Zero(6 * n, model.num_speeds());
  // Blocks of no columns (welds) are skipped: with no speeds at all d has no storage, and a
  // block of it at a row offset would be an offset from a null pointer.
  for (int k = 0; k < n; ++k) {
    for (int b = C.w_begin[at(k)]; b < C.w_begin[at(k + 1)]; ++b) {
      const int c = C.w_body[at(b)], m = speed_count(model.joint(c).type);
      if (m > 0) d.block(3 * k, model.speed_offset(c), 3, m) = C.w_block[at(b)].leftCols(m);
    }
    const int m = speed_count(model.joint(k).type);
    if (m > 0) d.block(3 * n + 3 * k, model.speed_offset(k), 3, m) = C.s_block[at(k)].leftCols(m);
  }
  return d;
}

void constraint_rate_times_speeds(const Model& model, const ConstraintMatrix& C, const VectorX& q,
                                  const VectorX& z, const State& state, Eigen::Ref<VectorX> out) {
  const int n = model.num_bodies();
  out.setZero();  // the s' dot part: [T_K] is constant in J (prismatic, cylindrical axes)
  for (int k = 0; k < n; ++k) {
    const Joint& jt = model.joint(k);
    if (is_free(jt.type)) continue;  // w'_K = z_K: [C] rows constant
    const Vector3 w_rel = joint_relative_angular_velocity(model, k, q, z);
    Vector3 b = joint_rotation_rate_times_speeds(model, k, q, z);
    const int j = model.lower_body(k);
    if (j != kGround) {
      // d/dt [R_K][R_J]^T = -[w_rel~][R_K][R_J]^T (from d[R]/dt = -[w'~][R], README).
      const Matrix3 r_kj = C.R[at(k)] * C.R[at(j)].transpose();
      b += -w_rel.cross(r_kj * state.angular_velocity(j)) + r_kj * out.segment<3>(3 * j);
    }
    out.segment<3>(3 * k) = b;
  }
}

ProjectedEquations projected_equations(const Model& model, const VectorX& q, const VectorX& z,
                                       Data& data) {
  if (!data.options().kane_terms || !data.options().dense_mass_matrix)
    throw std::invalid_argument(
        "projected_equations needs a Data with DataOptions::kane_terms and dense_mass_matrix");
  ProjectedEquations e;
  e.state = State(model);
  joint_state(model, q, z, e.state);
  ConstraintMatrix C(model);
  compute_constraint_matrix(model, q, e.state, C);
  e.C = dense_constraint_matrix(model, C);
  e.Cdot_z = VectorX::Zero(model.num_y());
  constraint_rate_times_speeds(model, C, q, z, e.state, e.Cdot_z);
  kane_equations(model, e.state, data);  // [A] (Eq. 37) and {f} (Eq. 38) of the free tree
  const MatrixX& A = data.kane.A;
  e.A_z = e.C.transpose() * A * e.C;
  e.f_z = e.C.transpose() * (data.kane.f - A * e.Cdot_z);
  add_joint_forces(model, q, z, e.f_z);
  add_input_joint_forces(model, data.inputs, e.f_z);
  e.zdot = e.A_z.ldlt().solve(e.f_z);
  return e;
}

}  // namespace kanedyn
