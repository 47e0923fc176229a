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
#include "joint_table.hpp"

namespace kanedyn {

namespace {

size_t at(int i) { return static_cast<size_t>(i); }

constexpr double kPerpendicularTolerance = 1e-9;  // |a1 . a2| of universal axes
constexpr double kUnitNormTolerance = 1e-6;       // the rule of `euler_parameters`

bool is_free(JointType t) { return joint_type_info(t).absolute; }

// The Euler-parameter slice of a body's q (spherical q, or a free body's eps_K), if any.
int euler_slice(JointType t) { return joint_type_info(t).euler ? 4 : 0; }

// Each type's row of the joint table, without its motion, in the order of the enum.
#define KANEDYN_JOINT_INFO(name) detail::JointRow<JointType::name>::info,
constexpr JointTypeInfo kInfo[] = {KANEDYN_JOINT_TYPES(KANEDYN_JOINT_INFO)};
#undef KANEDYN_JOINT_INFO
static_assert(std::size(kInfo) == std::size(kJointTypes), "a row for every joint type");

}  // namespace

const JointTypeInfo& joint_type_info(JointType type) { return kInfo[static_cast<int>(type)]; }

const char* to_string(JointType type) { return joint_type_info(type).name; }

int coordinate_count(JointType type) { return joint_type_info(type).coordinates; }

int speed_count(JointType type) { return joint_type_info(type).speeds; }

bool speeds_are_coordinate_rates(JointType type) {
  const JointTypeInfo& info = joint_type_info(type);
  return info.speeds > 0 && info.coordinates == info.speeds;
}

std::string check_joint(const Joint& joint) {
  if (std::abs(joint.frame.norm() - 1.0) > kUnitNormTolerance)
    return "the joint frame's Euler parameters must have unit norm";
  const JointTypeInfo& info = joint_type_info(joint.type);
  if (info.takes_axis && !scaled_direction(joint.axis))
    return std::string("the axis of a ") + info.name + " joint must be finite and not zero";
  if (info.takes_pitch && !std::isfinite(joint.pitch))
    return std::string("the pitch of a ") + info.name + " joint must be finite";
  if (info.takes_axes) {
    const auto a1 = unit_direction(joint.axes[0]), a2 = unit_direction(joint.axes[1]);
    if (!a1 || !a2)
      return std::string("the axes of a ") + info.name + " joint must be finite and not zero";
    const double c = a1->dot(*a2);
    if (!(std::abs(c) <= kPerpendicularTolerance))
      return std::string("the axes of a ") + info.name +
             " joint must be perpendicular (|a1 . a2| <= 1e-9)";
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

// [G_K] (3 x speeds, body-K components): w_rel = [G_K] z_K. Only a row whose first column turns
// with q (universal) evaluates its motion here.
template <typename Row>
inline void rotation_columns(Row, const Joint& jt, const double* q, Matrix36& G) {
  G.setZero();
  Row::rotation_columns(jt, G);
  if constexpr (Row::info.turning_axis) {
    constexpr double zeros[6] = {};
    JointTerms<double> m;
    Row::template motion<double>(jt, q, zeros, m);
    G.col(0) = eq::eigen(m.g0);
  }
}

}  // namespace

void joint_rotation_columns(const Model& model, int k, const VectorX& q, Matrix36& G) {
  const Joint& jt = model.joint(k);
  const double* qk = q.data() + model.coordinate_offset(k);
  visit_joint_row(jt.type, [&](auto row) { rotation_columns(row, jt, qk, G); });
}

void joint_motion(const Model& model, int k, const VectorX& q, const double* z_k, JointMotion& m) {
  const Joint& jt = model.joint(k);
  const double* qk = q.data() + model.coordinate_offset(k);
  constexpr double zeros[6] = {};
  const double* zk = z_k ? z_k : zeros;
  visit_joint_row(jt.type, [&](auto row) {
    using Row = decltype(row);
    JointTerms<double> t;
    row_terms<double>(row, jt, model.slide_axes_in_j(k), qk, zk, t);
    m.G.setZero();
    Row::rotation_columns(jt, m.G);
    if constexpr (Row::info.turning_axis) m.G.col(0) = eq::eigen(t.g0);
    m.rel = Row::info.absolute ? jt.frame : eq::eigen(t.rel);
    m.w_rel = eq::eigen(t.w_rel);
    m.slide = eq::eigen(t.slide);
    m.slide_rate = eq::eigen(t.slide_rate);
    if constexpr (Row::info.turning_axis)
      m.g_dot_z = eq::eigen(t.g_dot_z);
    else
      m.g_dot_z.setZero();
  });
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
      state.euler_parameters(k) = kanedyn::compose(state.euler_parameters(j), m.rel);
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
  detail::visit_joint_row(model.joint(k).type, [&](auto row) {
    using Row = decltype(row);
    for (int c = 0; c < Row::slide_count; ++c)
      t.col(Row::first_slide + c) = model.slide_axes_in_j(k).col(c);
  });
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
    if (joint_type_info(type).absolute) {  // the notes' own coordinates and speeds
      q.segment<4>(o) = state.euler_parameters(k);
      q.segment<3>(o + 4) = state.translation(k);
      z.segment<3>(p) = state.angular_velocity(k);
      z.segment<3>(p + 3) = state.translation_rate(k);
    } else if (speed_count(type) == 0) {  // a weld: checked below
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
    if (speed_count(model.joint(k).type) != 0 || is_free(model.joint(k).type)) continue;
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
    const JointTypeInfo& info = joint_type_info(model.joint(k).type);
    if (info.euler) {
      // Eq. (39) for eps_K (free) or for K relative to F (spherical, w_rel in body-K
      // components); then the rest of q is the rest of z (Eq. 40 for a free body's s'_K).
      qdot.segment<4>(o) = euler_parameter_rates(q.segment<4>(o), z.segment<3>(p));
      qdot.segment(o + 4, info.coordinates - 4) = z.segment(p + 3, info.speeds - 3);
    } else {
      qdot.segment(o, info.coordinates) = z.segment(p, info.speeds);
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
