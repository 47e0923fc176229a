// Derivatives of forward dynamics, linearization, eigenvalues and static equilibrium
// (docs/analysis.md; docs/theory.md, "Derivatives").
#include "kanedyn/analysis.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "kanedyn/constraints.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/terms.hpp"

#include "constraint_rows.hpp"
#include "dual.hpp"
#include "equations.hpp"
#include "generic_dynamics.hpp"
#include "joint_table.hpp"
#include "tree_loads.hpp"

namespace kanedyn {

namespace {

using namespace tree;  // NOLINT: the generic passes' terms (src/tree_loads.hpp)

// a b and a b^T.
template <typename S>
M3<S> product(const M3<S>& a, const M3<S>& b) {
  M3<S> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      r.a[3 * i + j] =
          a.a[3 * i] * b.a[j] + a.a[3 * i + 1] * b.a[3 + j] + a.a[3 * i + 2] * b.a[6 + j];
  return r;
}
template <typename S>
M3<S> product_transposed(const M3<S>& a, const M3<S>& b) {
  M3<S> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      r.a[3 * i + j] = a.a[3 * i] * b.a[3 * j] + a.a[3 * i + 1] * b.a[3 * j + 1] +
                       a.a[3 * i + 2] * b.a[3 * j + 2];
  return r;
}
using detail::compose;  // K's Euler parameters from J's and K's relative to J
template <typename S>
Eu<S> constant_euler(const Vector4& e) {
  return {{S(e[0]), S(e[1]), S(e[2]), S(e[3])}};
}

// The constant per-body tables of a model.
struct Tables {
  std::vector<Matrix36> translation;  // [T_K], body-J components
  std::vector<unsigned> slides;       // its nonzero columns
  // The force elements that load bodies, and those on joint coordinates (ForceElement).
  std::vector<const ForceElement*> body_elements, joint_elements;
  std::vector<int> speed_body;  // the body of each speed
  // [G_K]'s columns (body K), constant but for a turning first one (universal: the joint
  // table's turning_axis), and the mask of the nonzero ones.
  std::vector<std::array<Vector3, 3>> turn_axes;
  std::vector<unsigned> turns;
  // Whether every force element gives its law for every scalar (ForceElement::any_scalar).
  bool supported = true;
  // Whether the evaluation needs every body's absolute Euler parameters (a bushing measures K
  // relative to J through them) and rotation (a constant force is inertial; a free body below
  // another body turns relative to it through [R_K][R_J]^T); else only E is formed. And
  // whether the loads need the bodies' motion in inertial components (a spring joins points of
  // two bodies): the constraints' Motion, then formed before the loads.
  bool absolute_euler = false, absolute_rotation = false, positions = false;
  // Constraints: each one's two fixed directions (constraints.hpp), and the multipliers whose
  // reactions count among the loads when `reactions` (the linearization about a constrained
  // motion: Q - [B]^T lambda, lambda held).
  std::vector<std::array<Vector3, 2>> constraint_directions;
  int constraint_rows = 0;
  bool reactions = false;
  VectorX lambda;

  explicit Tables(const Model& model) {
    for (const Constraint& c : model.constraints()) {
      constraint_directions.push_back(constraint_fixed_directions(c));
      constraint_rows += equation_count(c.type);
    }
    for (int k = 0; k < model.num_bodies(); ++k) {
      for (int c = 0; c < speed_count(model.joint(k).type); ++c) speed_body.push_back(k);
      const Joint& jt = model.joint(k);
      std::array<Vector3, 3> axes{Vector3::UnitX(), Vector3::UnitY(), Vector3::UnitZ()};
      unsigned turning = 0;
      detail::visit_joint_row(jt.type, [&](auto row) {
        using Row = decltype(row);
        Matrix36 G = Matrix36::Zero();
        Row::rotation_columns(jt, G);
        for (int c = 0; c < 3; ++c) {
          if (!G.col(c).isZero(0.0)) axes[at(c)] = G.col(c);
          if (!G.col(c).isZero(0.0) || (c == 0 && Row::info.turning_axis)) turning |= 1u << c;
        }
      });
      turn_axes.push_back(axes);
      turns.push_back(turning);
      translation.push_back(joint_translation_block(model, k));
      unsigned mask = 0;
      for (int c = 0; c < speed_count(model.joint(k).type); ++c)
        if (!translation.back().col(c).isZero(0.0)) mask |= 1u << c;
      slides.push_back(mask);
    }
    for (const auto& element : model.forces()) {
      supported = supported && element->any_scalar();
      (element->acts_on_joints() ? joint_elements : body_elements).push_back(element.get());
      const ForceElement::Needs needs = element->needs();
      absolute_euler = absolute_euler || needs.euler;
      absolute_rotation = absolute_rotation || needs.rotation;
      positions = positions || needs.positions;
    }
    for (int k = 0; k < model.num_bodies(); ++k)
      if (joint_type_info(model.joint(k).type).absolute && model.lower_body(k) != kGround)
        absolute_rotation = true;
  }
};

// Body K's joint over S (its row of the joint table, src/joint_table.hpp): eps, R, E, slide,
// sd, w_rel and a turning first column of [G_K] into b (the other columns are constant:
// Tables::turn_axes), [G dot] z_K into g_dot_z where that column turns (turning set); J's terms
// in lower (null for a root).
template <typename S>
void joint_terms(const Model& model, const Tables& tables, int k, const S* q, const S* z,
                 const Body<S>* lower, Body<S>& b, V3<S>& g_dot_z, bool& turning) {
  const Joint& jt = model.joint(k);
  const int o = model.coordinate_offset(k);
  const JointTypeInfo& info = joint_type_info(jt.type);
  detail::JointTerms<S> t;
  detail::joint_terms(jt, model.slide_axes_in_j(k), q + o, z + model.speed_offset(k), t);
  b.w_rel = t.w_rel;
  b.slide = t.slide;
  b.sd = t.slide_rate;
  turning = info.turning_axis;
  if (turning) {
    b.g0 = t.g0;
    g_dot_z = t.g_dot_z;
  }
  if (info.absolute) {  // the notes' own: eps_K in q
    b.eps = {{q[o], q[o + 1], q[o + 2], q[o + 3]}};
    b.R = eq::rotation_matrix(b.eps);
    b.E = lower ? product_transposed(b.R, lower->R) : b.R;
    return;
  }
  b.E = eq::rotation_matrix(t.rel);
  if (tables.absolute_euler) b.eps = lower ? compose(lower->eps, t.rel) : t.rel;
  if (tables.absolute_rotation) b.R = lower ? product(b.E, lower->R) : b.E;
}

// The loads on the bodies of the force elements (each its own law, ForceElement::apply_generic)
// and of the inputs at u, into load_force (at G_K) and load_moment, body-K components; gravity
// is not among them (the ground's acceleration -g carries it). motion: every body's, when some
// law asks for it (Tables::positions).
template <typename S>
void body_loads(const Model& model, const Tables& tables, const S* q, const S* z, const S* u,
                std::vector<Body<S>>& bodies, const std::vector<Motion<S>>* motion) {
  const S zero{};
  for (auto& b : bodies) {
    b.load_force = {zero, zero, zero};
    b.load_moment = {zero, zero, zero};
  }
  detail::TreeLoads<S> loads(model, bodies, motion, q, z, nullptr);
  for (const ForceElement* element : tables.body_elements) element->apply_generic(loads);
  detail::input_body_loads(model, u, loads);
}

// The constraints' part of an evaluation over S: every body's Motion, and the rows' velocity
// residuals [B] z, acceleration residuals [B] z dot + {b} and position errors (c each, in this
// order), as ConstraintEquations gives them in double.
template <typename S>
struct ConstraintWork {
  std::vector<Motion<S>> motion;
  std::vector<S> rows;
};

template <typename S>
M3<S> transposed(const M3<S>& m) {
  return {{m.a[0], m.a[3], m.a[6], m.a[1], m.a[4], m.a[7], m.a[2], m.a[5], m.a[8]}};
}

// After the outward pass (E, r, sd, w, alpha and a of every body; a holds the acceleration
// less g, which stands for gravity).
// Not inlined into the flattened dual passes: compiled once per number type, not once per pass
// and target (the passes' compile time), and a small part of a constrained model's pass.
template <typename S>
__attribute__((noinline)) void absolute_motion(const Model& model,
                                               const std::vector<Body<S>>& bodies,
                                               std::vector<Motion<S>>& out) {
  const V3<S> g = constant<S>(model.gravity());
  for (int k = 0; k < model.num_bodies(); ++k) {
    const Body<S>& b = bodies[at(k)];
    const int j = model.lower_body(k);
    Motion<S>& m = out[at(k)];
    m.R = j == kGround ? b.E : product(b.E, out[at(j)].R);
    m.w = eq::transpose_times(m.R, b.w);
    m.alpha = eq::transpose_times(m.R, b.alpha);
    m.a = eq::transpose_times(m.R, b.a) + g;
    if (j == kGround) {
      m.p = b.r;
      m.v = b.sd;
    } else {
      const Motion<S>& l = out[at(j)];
      const V3<S> r = eq::transpose_times(l.R, b.r);
      m.p = l.p + r;
      m.v = l.v + eq::cross(l.w, r) + eq::transpose_times(l.R, b.sd);
    }
  }
}

// A load on body k: a force f at the point r from O_K and a moment m (inertial), added to its
// resultants (at G_K, body-K components).
template <typename S>
void add_load(const Model& model, std::vector<Body<S>>& bodies,
              const std::vector<Motion<S>>& motion, int k, const V3<S>& r, const V3<S>& f,
              const V3<S>& m) {
  if (k == kGround) return;
  Body<S>& b = bodies[at(k)];
  const M3<S>& R = motion[at(k)].R;
  const V3<S> f_b = R * f;
  V3<S> arm = R * r;
  add_constant(arm, Vector3(-model.body(k).com));
  b.load_force = b.load_force + f_b;
  b.load_moment = b.load_moment + eq::cross(arm, f_b) + R * m;
}

// The constraints' rows at the motion (detail::constraint_rows, src/constraint_rows.hpp: the
// velocity, acceleration and position residuals), and with tables.reactions the loads of the
// multipliers tables.lambda on the bodies.
template <typename S>
__attribute__((noinline)) void constraint_terms(const Model& model, const Tables& tables,
                                                std::vector<Body<S>>& bodies,
                                                ConstraintWork<S>& work) {
  const S zero{};
  const V3<S> none{zero, zero, zero};
  const int rows = tables.constraint_rows;
  S* vel = work.rows.data();
  S* acc = vel + rows;
  S* err = acc + rows;
  const std::vector<Motion<S>>& motion = work.motion;
  const auto end = [&](int k, const Vector3& offset) {
    detail::ConstraintEnd<S> e;
    e.point = point_motion(motion, k, offset);
    if (k == kGround) {
      const S one = zero + 1.0;
      e.R = {{one, zero, zero, zero, one, zero, zero, zero, one}};
      e.w = e.alpha = none;
    } else {
      e.R = motion[at(k)].R;
      e.w = motion[at(k)].w;
      e.alpha = motion[at(k)].alpha;
    }
    return e;
  };
  detail::ConstraintRows<S> out;
  int row = 0;
  for (size_t i = 0; i < model.constraints().size(); ++i) {
    const Constraint& c = model.constraints()[i];
    const bool two_points = c.type != ConstraintType::rolling_disc;
    const detail::ConstraintEnd<S> a = end(c.body, c.at);
    const detail::ConstraintEnd<S> b =
        two_points ? end(c.other, c.other_at) : end(kGround, Vector3::Zero());
    detail::constraint_rows(c, tables.constraint_directions[i], a, b, out);
    const int count = out.linear_count + out.angular_count;
    for (int r = 0; r < count; ++r) {
      vel[row + r] = out.velocity(r);
      acc[row + r] = out.acc[at(r)];
      err[row + r] = out.err[at(r)];
    }
    if (tables.reactions) {
      const double* lambda = tables.lambda.data() + row;
      V3<S> f = none, m = none;
      for (int r = 0; r < out.linear_count; ++r) f = f + lambda[r] * out.linear[at(r)];
      for (int k = 0; k < out.angular_count; ++k)
        m = m + lambda[out.linear_count + k] * out.angular[at(k)];
      add_load(model, bodies, motion, c.body, out.r, f, m);
      if (two_points) add_load(model, bodies, motion, c.other, b.point.r, -f, -m);
    }
    row += equation_count(c.type);
  }
}

// Q = the generalized inertia forces minus the active forces at (q, z, zdot, u), over S
// (src/terms.cpp's Newton-Euler in body axes; generic_dynamics.hpp).
template <typename S>
void inverse_dynamics(const Model& model, const Tables& tables, const S* q, const S* z,
                      const double* zdot, const S* u, S* Q, std::vector<Body<S>>& bodies,
                      ConstraintWork<S>& work, bool constraint_rows) {
  const int n = model.num_bodies();
  const S zero{};
  const V3<S> none{zero, zero, zero};
  // A uniform -g on every body's acceleration stands for gravity (docs/theory.md).
  const V3<S> ground_a = constant<S>(-model.gravity());
  for (int k = 0; k < n; ++k) {
    const int j = model.lower_body(k);
    Body<S>* lower = j == kGround ? nullptr : &bodies[at(j)];
    Body<S>& b = bodies[at(k)];
    const bool free = joint_type_info(model.joint(k).type).absolute;
    V3<S> g_dot_z{};  // set where [G_K]'s first column turns (a universal joint)
    bool turning = false;
    joint_terms(model, tables, k, q, z, lower, b, g_dot_z, turning);
    b.r = b.slide;
    add_constant(b.r, model.body(k).joint);
    b.w = free || !lower ? b.w_rel : b.w_rel + b.E * lower->w;
    const int p = model.speed_offset(k);
    const int m = speed_count(model.joint(k).type);
    const unsigned turns = tables.turns[at(k)], slides = tables.slides[at(k)];
    // The acceleration of O_K in body-J components (Eqs. 28 and 30), then in K's.
    V3<S> a_j = lower ? lower->a : ground_a;
    if (lower) {
      a_j = a_j + eq::cross(lower->alpha, b.r) + eq::transport_acceleration(lower->w, b.sd, b.r);
    }
    // [G_K] z dot_K and [T_K] z dot_K: constant columns add to the values only.
    V3<S> alpha = none;
    for (int c = 0; c < m; ++c) {
      const double rate = zdot[p + c];
      if (turning && c == 0)
        alpha = alpha + rate * b.g0;
      else if (turns & (1u << c))
        add_constant(alpha, Vector3(rate * tables.turn_axes[at(k)][at(c)]));
      if (slides & (1u << c)) add_constant(a_j, Vector3(rate * tables.translation[at(k)].col(c)));
    }
    b.a = b.E * a_j;
    if (!free) {
      if (lower) alpha = alpha + b.E * lower->alpha;
      alpha = alpha + eq::cross(b.w, b.w_rel);
      if (turning) alpha = alpha + g_dot_z;
    }
    b.alpha = alpha;
    const BodySpec& body = model.body(k);
    const V3<S> a_g = b.a + cross(alpha, body.com) + eq::cross(b.w, cross(b.w, body.com));
    b.force = body.mass * a_g;
    b.moment = times(body.inertia, alpha) + eq::cross(b.w, times(body.inertia, b.w));
  }
  const bool motion = constraint_rows || tables.positions;
  if (motion) absolute_motion(model, bodies, work.motion);
  body_loads(model, tables, q, z, u, bodies, motion ? &work.motion : nullptr);
  if (constraint_rows) constraint_terms(model, tables, bodies, work);
  for (auto& b : bodies) {
    b.force = b.force - b.load_force;
    b.moment = b.moment - b.load_moment;
  }
  for (int k = 0; k < n; ++k) {
    Body<S>& b = bodies[at(k)];
    b.moment = b.moment + cross(model.body(k).com, b.force);
  }
  for (int k = n - 1; k >= 0; --k) {
    const Body<S>& b = bodies[at(k)];
    const V3<S> moment_j = eq::transpose_times(b.E, b.moment);
    const V3<S> force_j = eq::transpose_times(b.E, b.force);
    const int p = model.speed_offset(k);
    const bool turning = joint_type_info(model.joint(k).type).turning_axis;
    for (int c = 0; c < speed_count(model.joint(k).type); ++c) {
      S sum = zero;
      if (turning && c == 0)
        sum = eq::dot(b.g0, b.moment);
      else if (tables.turns[at(k)] & (1u << c))
        sum = dot_constant(tables.turn_axes[at(k)][at(c)], b.moment);
      if (tables.slides[at(k)] & (1u << c))
        sum = sum + dot_constant(Vector3(tables.translation[at(k)].col(c)), force_j);
      Q[p + c] = sum;
    }
    const int j = model.lower_body(k);
    if (j == kGround) continue;
    Body<S>& bj = bodies[at(j)];
    bj.moment = bj.moment + eq::cross(b.r, force_j);
    if (!joint_type_info(model.joint(k).type).absolute) bj.moment = bj.moment + moment_j;
    bj.force = bj.force + force_j;
  }
  // The loads on joint coordinates (the joint springs' and forces'), and the joint inputs on
  // joints other than free.
  detail::TreeLoads<S> joint_loads(model, bodies, nullptr, q, z, Q);
  for (const ForceElement* element : tables.joint_elements) element->apply_generic(joint_loads);
  detail::input_joint_forces(model, u, joint_loads);
}

// The dual passes, one per width, each compiled for AVX2 and for the baseline and chosen when
// the program is loaded (KANEDYN_DUAL_ATTRIBUTES, src/dual.hpp).
#define KANEDYN_DUAL_PASS(N)                                                                \
  KANEDYN_DUAL_ATTRIBUTES void dual_inverse_dynamics_##N(                                   \
      const Model& model, const Tables& tables, const Dual<N>* q, const Dual<N>* z,         \
      const double* zdot, const Dual<N>* u, Dual<N>* Q, std::vector<Body<Dual<N>>>& bodies, \
      ConstraintWork<Dual<N>>& work, bool rows) {                                           \
    inverse_dynamics(model, tables, q, z, zdot, u, Q, bodies, work, rows);                  \
  }
KANEDYN_DUAL_PASS(8)
KANEDYN_DUAL_PASS(12)
KANEDYN_DUAL_PASS(16)
#undef KANEDYN_DUAL_PASS

void dual_inverse_dynamics(const Model& model, const Tables& tables, const Dual<8>* q,
                           const Dual<8>* z, const double* zdot, const Dual<8>* u, Dual<8>* Q,
                           std::vector<Body<Dual<8>>>& bodies, ConstraintWork<Dual<8>>& work,
                           bool rows) {
  dual_inverse_dynamics_8(model, tables, q, z, zdot, u, Q, bodies, work, rows);
}
void dual_inverse_dynamics(const Model& model, const Tables& tables, const Dual<12>* q,
                           const Dual<12>* z, const double* zdot, const Dual<12>* u, Dual<12>* Q,
                           std::vector<Body<Dual<12>>>& bodies, ConstraintWork<Dual<12>>& work,
                           bool rows) {
  dual_inverse_dynamics_12(model, tables, q, z, zdot, u, Q, bodies, work, rows);
}
void dual_inverse_dynamics(const Model& model, const Tables& tables, const Dual<16>* q,
                           const Dual<16>* z, const double* zdot, const Dual<16>* u, Dual<16>* Q,
                           std::vector<Body<Dual<16>>>& bodies, ConstraintWork<Dual<16>>& work,
                           bool rows) {
  dual_inverse_dynamics_16(model, tables, q, z, zdot, u, Q, bodies, work, rows);
}

// Whether tangent entry c of body k is a rotation-vector entry (the first three of a joint whose
// q holds Euler parameters: free, spherical).
bool is_rotation_entry(JointType type, int c) { return joint_type_info(type).euler && c < 3; }

// The coordinate a non-rotation tangent entry c of body k moves: a free body's s'_K entries
// follow its four Euler parameters; every other joint's coordinates are its speeds' own.
int coordinate_of_entry(const Model& model, int k, int c) {
  const int o = model.coordinate_offset(k);
  return joint_type_info(model.joint(k).type).euler ? o + 4 + (c - 3) : o + c;
}

}  // namespace

namespace detail {

bool generic_dynamics_supported(const Model& model) { return Tables(model).supported; }

VectorX generic_inverse_dynamics(const Model& model, const VectorX& q, const VectorX& z,
                                 const VectorX& zdot, const VectorX& u) {
  const Tables tables(model);
  if (!tables.supported)
    throw std::invalid_argument("generic_inverse_dynamics: a force element of an unknown type");
  std::vector<Body<double>> bodies(at(model.num_bodies()));
  ConstraintWork<double> work;
  work.motion.resize(at(model.num_bodies()));
  VectorX Q(model.num_speeds());
  const VectorX u0 = u.size() == model.num_inputs() ? u : VectorX::Zero(model.num_inputs());
  inverse_dynamics(model, tables, q.data(), z.data(), zdot.data(), u0.data(), Q.data(), bodies,
                   work, false);
  return Q;
}

}  // namespace detail

// ---- Tangent coordinates ----

namespace {

// The exponential map: the Euler parameters of exp(-[r~]), the turn by |r| about r.
Vector4 small_rotation(const Vector3& r) {
  const double angle = r.norm();
  if (angle == 0.0) return {0.0, 0.0, 0.0, 1.0};
  const double s = std::sin(0.5 * angle) / angle;
  return {s * r.x(), s * r.y(), s * r.z(), std::cos(0.5 * angle)};
}

// What answers for the tree and would ignore a model's constraints refuses such a model: the
// tree's answer would be a wrong one, not a partial one. linearize() and
// Derivatives::constrained handle constraints.
void refuse_constraints(const Model& model, const char* what) {
  if (model.num_constraints() > 0)
    throw std::invalid_argument(std::string(what) +
                                ": the model has constraints, and this would answer for the tree "
                                "without them (a wrong answer); linearize handles them");
}

void check_size(const char* what, Eigen::Index size, Eigen::Index expected) {
  if (size != expected)
    throw std::invalid_argument(std::string(what) + ": " + std::to_string(size) +
                                " values where the model has " + std::to_string(expected));
}

}  // namespace

VectorX retract(const Model& model, const VectorX& q0, const VectorX& dx) {
  check_size("retract: q", q0.size(), model.num_coordinates());
  check_size("retract: dx", dx.size(), model.num_speeds());
  VectorX q = q0;
  for (int k = 0; k < model.num_bodies(); ++k) {
    const JointType type = model.joint(k).type;
    const int o = model.coordinate_offset(k);
    const int p = model.speed_offset(k);
    const int m = speed_count(type);
    int c = 0;
    if (joint_type_info(type).euler) {
      // [R] = exp(-[r~]) [R_0]: the parameters of R_0 composed with the small turn.
      q.segment<4>(o) =
          compose_euler_parameters(q0.segment<4>(o), small_rotation(dx.segment<3>(p)));
      c = 3;
    }
    for (; c < m; ++c) q[coordinate_of_entry(model, k, c)] += dx[p + c];
  }
  return q;
}

VectorX tangent_difference(const Model& model, const VectorX& q0, const VectorX& q) {
  check_size("tangent_difference: q0", q0.size(), model.num_coordinates());
  check_size("tangent_difference: q", q.size(), model.num_coordinates());
  VectorX dx(model.num_speeds());
  for (int k = 0; k < model.num_bodies(); ++k) {
    const JointType type = model.joint(k).type;
    const int o = model.coordinate_offset(k);
    const int p = model.speed_offset(k);
    const int m = speed_count(type);
    int c = 0;
    if (joint_type_info(type).euler) {
      // The turn from R_0 to R: [R][R_0]^T, whose rotation vector r has [R(r)] = exp(-[r~]).
      dx.segment<3>(p) =
          rotation_vector(relative_euler_parameters(q0.segment<4>(o), q.segment<4>(o)));
      c = 3;
    }
    for (; c < m; ++c) {
      const int i = coordinate_of_entry(model, k, c);
      dx[p + c] = q[i] - q0[i];
    }
  }
  return dx;
}

std::vector<std::string> tangent_state_names(const Model& model) {
  std::vector<std::string> coordinates, speeds;
  for (int k = 0; k < model.num_bodies(); ++k) {
    const std::string& name = model.body(k).name;
    const JointType type = model.joint(k).type;
    const int m = speed_count(type);
    for (int c = 0; c < m; ++c) {
      if (joint_type_info(type).absolute) {
        const std::string i = std::to_string(c % 3 + 1);
        coordinates.push_back(name + (c < 3 ? ".r" : ".s") + i);
        speeds.push_back(name + (c < 3 ? ".w" : ".sd") + i);
      } else if (joint_type_info(type).euler) {
        coordinates.push_back(name + ".r" + std::to_string(c + 1));
        speeds.push_back(name + ".w" + std::to_string(c + 1));
      } else {
        coordinates.push_back(name + ".j" + std::to_string(c + 1));
        speeds.push_back(name + ".jd" + std::to_string(c + 1));
      }
    }
  }
  coordinates.insert(coordinates.end(), speeds.begin(), speeds.end());
  return coordinates;
}

// ---- Derivatives ----

// ---- The mass matrix's Cholesky factor ----

extern "C" void dpotrf_(const char* uplo, const int* n, double* a, const int* lda, int* info);
extern "C" void dpotrs_(const char* uplo, const int* n, const int* nrhs, const double* a,
                        const int* lda, double* b, const int* ldb, int* info);

// [M] = [L][L]^T and solves with it: Eigen's below 48 rows, LAPACK's above, where the 2n + m
// right-hand sides of the derivatives make the solve O(n^3) and the blocked, vectorized BLAS
// of OpenBLAS is several times Eigen's baseline build.
class Cholesky {
 public:
  void compute(const MatrixX& m) {
    n_ = static_cast<int>(m.rows());
    if (n_ <= 48) {
      small_.compute(m);
      if (small_.info() != Eigen::Success)
        throw std::runtime_error("the mass matrix is not positive definite");
      return;
    }
    factor_ = m;
    int info = 0;
    const char lower = 'L';
    dpotrf_(&lower, &n_, factor_.data(), &n_, &info);
    if (info != 0) throw std::runtime_error("the mass matrix is not positive definite");
  }
  // b = [M]^-1 b, in place.
  template <typename Matrix>
  void solve_in_place(Matrix& b) const {
    if (n_ <= 48) {
      small_.solveInPlace(b);
      return;
    }
    const int cols = static_cast<int>(b.cols()), ld = static_cast<int>(b.outerStride());
    int info = 0;
    const char lower = 'L';
    dpotrs_(&lower, &n_, &cols, factor_.data(), &n_, b.data(), &ld, &info);
  }

 private:
  int n_ = 0;
  Eigen::LLT<MatrixX> small_;
  MatrixX factor_;
};

// One width of dual pass: the numbers of one evaluation, N directions each.
template <int N>
struct Pass {
  std::vector<Body<Dual<N>>> bodies;
  std::vector<Dual<N>> q, z, u, Q;
  // A body's seeded half rotation, and whether it has one (kept between passes: no allocation).
  std::vector<Eu<Dual<N>>> half;
  std::vector<char> turned;
  // Every body's Motion for the constraints' rows and the laws that join points
  // (Tables::positions), and the rows: sized only for a model that has them (a Motion of
  // 16 directions is some 4 kB a body).
  ConstraintWork<Dual<N>> constraints;

  Pass(const Model& m, const Tables& tables)
      : bodies(at(m.num_bodies())),
        q(at(m.num_coordinates())),
        z(at(m.num_speeds())),
        u(at(m.num_inputs())),
        Q(at(m.num_speeds())),
        half(at(m.num_bodies())),
        turned(at(m.num_bodies()), 0) {
    if (tables.positions || m.num_constraints() > 0) constraints.motion.resize(at(m.num_bodies()));
    if (m.num_constraints() == 0) return;
    int rows = 0;
    for (const Constraint& c : m.constraints()) rows += equation_count(c.type);
    constraints.rows.resize(at(3 * rows));
  }

  // dQ along the directions dirs[first..first+N) into out's columns of the same index:
  // direction d < n the tangent of q, n <= d < 2n z, 2n + i input i.
  void run(const Model& model, const Tables& tables, const VectorX& q0, const VectorX& z0,
           const VectorX& zdot, const VectorX& u0, const std::vector<int>& dirs, size_t first,
           Eigen::Ref<MatrixX> out, MatrixX* rows_out = nullptr);
};

template <int N>
void Pass<N>::run(const Model& model, const Tables& tables, const VectorX& q0, const VectorX& z0,
                  const VectorX& zdot, const VectorX& u0, const std::vector<int>& dirs,
                  size_t first, Eigen::Ref<MatrixX> out, MatrixX* rows_out) {
  using D = Dual<N>;
  const int n = model.num_speeds();
  const size_t count = std::min(dirs.size() - first, static_cast<size_t>(N));
  for (size_t i = 0; i < q.size(); ++i) q[i] = D(q0[static_cast<Eigen::Index>(i)]);
  for (size_t i = 0; i < z.size(); ++i) z[i] = D(z0[static_cast<Eigen::Index>(i)]);
  for (size_t i = 0; i < u.size(); ++i) u[i] = D(u0[static_cast<Eigen::Index>(i)]);
  // Seed: slot s is direction dirs[first + s]. A rotation vector r enters through the Euler
  // parameters of exp(-[r~]) composed with the nominal ones, (r/2, 1) to first order.
  std::fill(turned.begin(), turned.end(), 0);
  for (size_t s = 0; s < count; ++s) {
    const int dir = dirs[first + s];
    if (dir >= 2 * n) {
      u[at(dir - 2 * n)].set_derivative(static_cast<int>(s), 1.0);
    } else if (dir >= n) {
      z[at(dir - n)].set_derivative(static_cast<int>(s), 1.0);
    } else {
      const int k = tables.speed_body[at(dir)];
      const int c = dir - model.speed_offset(k);
      if (is_rotation_entry(model.joint(k).type, c)) {
        if (!turned[at(k)]) half[at(k)] = Eu<D>{{D(0.0), D(0.0), D(0.0), D(1.0)}};
        half[at(k)].e[c].set_derivative(static_cast<int>(s), 0.5);
        turned[at(k)] = 1;
      } else {
        q[at(coordinate_of_entry(model, k, c))].set_derivative(static_cast<int>(s), 1.0);
      }
    }
  }
  for (int k = 0; k < model.num_bodies(); ++k) {
    if (!turned[at(k)]) continue;
    const int o = model.coordinate_offset(k);
    const Eu<D> e = compose(constant_euler<D>(q0.segment<4>(o)), half[at(k)]);
    for (int i = 0; i < 4; ++i) q[at(o + i)] = e.e[i];
  }
  dual_inverse_dynamics(model, tables, q.data(), z.data(), zdot.data(), u.data(), Q.data(), bodies,
                        constraints, rows_out != nullptr);
  for (size_t s = 0; s < count; ++s)
    for (int row = 0; row < n; ++row)
      out(row, dirs[first + s]) = Q[at(row)].derivative(static_cast<int>(s));
  if (rows_out)
    for (size_t s = 0; s < count; ++s)
      for (Eigen::Index row = 0; row < rows_out->rows(); ++row)
        (*rows_out)(row, dirs[first + s]) =
            constraints.rows[static_cast<size_t>(row)].derivative(static_cast<int>(s));
}

struct Derivatives::Impl {
  explicit Impl(const Model& m) : model(m), tables(m), terms(m) {
    const int n = m.num_speeds();
    M.resize(n, n);
    zdot0.resize(n);
  }

  const Model& model;
  Tables tables;
  Terms terms;
  // Made on first use: a pass of 16 directions holds some 10 kB a body, and most models use
  // one width; the forward route only for the central differences.
  std::unique_ptr<Pass<8>> pass8;
  std::unique_ptr<Pass<12>> pass12;
  std::unique_ptr<Pass<16>> pass16;
  std::unique_ptr<Dynamics> forward_route;

  template <int N>
  Pass<N>& pass(std::unique_ptr<Pass<N>>& p) {
    if (!p) p = std::make_unique<Pass<N>>(model, tables);
    return *p;
  }
  Dynamics& dynamics() {
    if (!forward_route) forward_route = std::make_unique<Dynamics>(model);
    return *forward_route;
  }
  MatrixX M;
  Cholesky llt;
  VectorX zdot0;
  std::vector<int> dirs;

  // dQ along every direction: columns 0..n-1 the tangent of q, n..2n-1 z, 2n..2n+m-1 u, into
  // out (n x (2n + m)).
  // With rows_out (3c x (2n + m)), also the derivatives of the constraints' rows (velocity,
  // acceleration and position residuals: ConstraintWork).
  void inverse_directions(const VectorX& q0, const VectorX& z0, const VectorX& zdot,
                          const VectorX& u0, Eigen::Ref<MatrixX> out, MatrixX* rows_out = nullptr);
  // Central differences of F in tangent coordinates (a model with an element of another type).
  void forward_differences(const VectorX& q0, const VectorX& z0, const VectorX& u0,
                           Eigen::Ref<MatrixX> out);
};

void Derivatives::Impl::inverse_directions(const VectorX& q0, const VectorX& z0,
                                           const VectorX& zdot, const VectorX& u0,
                                           Eigen::Ref<MatrixX> out, MatrixX* rows_out) {
  const int n = model.num_speeds();
  if (rows_out) rows_out->setZero();
  dirs.clear();
  for (int d = 0; d < 2 * n; ++d) dirs.push_back(d);
  // A joint input on a joint other than free adds u to one generalized force: its column of dQ
  // is minus that unit column, exactly; the others go through the dual numbers.
  const auto& inputs = model.inputs();
  for (size_t i = 0; i < inputs.size(); ++i) {
    const Input& in = inputs[i];
    const int col = 2 * n + static_cast<int>(i);
    if (in.type == InputType::joint && !joint_type_info(model.joint(in.body).type).absolute) {
      out.col(col).setZero();
      out(model.speed_offset(in.body) + in.speed, col) = -1.0;
    } else {
      dirs.push_back(col);
    }
  }
  // Passes of 16 directions, the last of 12 or 8 when that is enough: the cost of a pass grows
  // with its width (the six-joint arm's 12 directions take 5.5x its forward dynamics in a pass
  // of 12, 6.4x in one of 16), and each width is compiled twice (AVX2 and baseline).
  for (size_t first = 0; first < dirs.size();) {
    if (dirs.size() - first > 12) {
      pass(pass16).run(model, tables, q0, z0, zdot, u0, dirs, first, out, rows_out);
      first += 16;
    } else if (dirs.size() - first > 8) {
      pass(pass12).run(model, tables, q0, z0, zdot, u0, dirs, first, out, rows_out);
      first += 12;
    } else {
      pass(pass8).run(model, tables, q0, z0, zdot, u0, dirs, first, out, rows_out);
      first += 8;
    }
  }
}

// Step rule: h = 2^-17 (about the cube root of the unit round-off, which balances the O(h^2)
// truncation against the O(eps/h) round-off of a central difference) times max(1, |x|).
void Derivatives::Impl::forward_differences(const VectorX& q0, const VectorX& z0, const VectorX& u0,
                                            Eigen::Ref<MatrixX> out) {
  const int n = model.num_speeds();
  const int m = model.num_inputs();
  const double base = std::ldexp(1.0, -17);
  VectorX plus(n), minus(n);
  Dynamics& dynamics = this->dynamics();
  dynamics.set_inputs(u0);
  for (int i = 0; i < n; ++i) {  // q, in tangent coordinates
    VectorX dx = VectorX::Zero(n);
    const double h = base;
    dx[i] = h;
    dynamics.evaluate(retract(model, q0, dx), z0, plus);
    dx[i] = -h;
    dynamics.evaluate(retract(model, q0, dx), z0, minus);
    out.col(i) = (plus - minus) / (2.0 * h);
  }
  for (int i = 0; i < n; ++i) {
    VectorX z = z0;
    const double h = base * std::max(1.0, std::abs(z0[i]));
    z[i] = z0[i] + h;
    dynamics.evaluate(q0, z, plus);
    z[i] = z0[i] - h;
    dynamics.evaluate(q0, z, minus);
    out.col(n + i) = (plus - minus) / (2.0 * h);
  }
  for (int i = 0; i < m; ++i) {
    VectorX u = u0;
    const double h = base * std::max(1.0, std::abs(u0[i]));
    u[i] = u0[i] + h;
    dynamics.set_inputs(u);
    dynamics.evaluate(q0, z0, plus);
    u[i] = u0[i] - h;
    dynamics.set_inputs(u);
    dynamics.evaluate(q0, z0, minus);
    out.col(2 * n + i) = (plus - minus) / (2.0 * h);
  }
  dynamics.set_inputs(u0);
}

Derivatives::Derivatives(const Model& model) : impl_(std::make_unique<Impl>(model)) {}
Derivatives::~Derivatives() = default;
const Model& Derivatives::model() const { return impl_->model; }
bool Derivatives::analytic() const { return impl_->tables.supported; }
std::string Derivatives::method() const {
  return analytic() ? "forward-mode dual numbers through the inverse dynamics, 8, 12 or 16 "
                      "directions a pass"
                    : "central differences in tangent coordinates (a force element gives its "
                      "law for double alone: ForceElement::any_scalar)";
}

void Derivatives::forward(const VectorX& q, const VectorX& z, const VectorX& u,
                          Eigen::Ref<MatrixX> dq, Eigen::Ref<MatrixX> dz, Eigen::Ref<MatrixX> du,
                          VectorX* zdot) {
  Impl& s = *impl_;
  const Model& model = s.model;
  refuse_constraints(model, "Derivatives::forward");
  const int n = model.num_speeds();
  const int m = model.num_inputs();
  check_size("Derivatives: q", q.size(), model.num_coordinates());
  check_size("Derivatives: z", z.size(), n);
  check_size("Derivatives: u", u.size(), m);
  MatrixX all(n, 2 * n + m);
  if (s.tables.supported) {
    // z dot = -[M]^-1 Q(q, z, 0, u) (the bias), with the factor the derivatives need anyway:
    // half the cost of another forward evaluation.
    s.terms.mass_matrix(q, s.M);
    s.llt.compute(s.M);
    s.terms.bias_forces(q, z, s.zdot0, &u);
    s.llt.solve_in_place(s.zdot0);
    s.zdot0 = -s.zdot0;
    s.inverse_directions(q, z, s.zdot0, u, all);
    // [M] d(z dot) + dQ = 0 at z dot = F(q, z, u), where Q vanishes.
    s.llt.solve_in_place(all);
    all = -all;
  } else {
    s.dynamics().forward(q, z, u, s.zdot0);
    s.forward_differences(q, z, u, all);
  }
  check_size("Derivatives: dq rows", dq.rows(), n);
  dq = all.leftCols(n);
  dz = all.middleCols(n, n);
  du = all.rightCols(m);
  if (zdot) *zdot = s.zdot0;
}

void Derivatives::inverse(const VectorX& q, const VectorX& z, const VectorX& zdot, const VectorX& u,
                          Eigen::Ref<MatrixX> dq, Eigen::Ref<MatrixX> dz, Eigen::Ref<MatrixX> du) {
  Impl& s = *impl_;
  refuse_constraints(s.model, "Derivatives::inverse");
  if (!s.tables.supported)
    throw std::logic_error(
        "Derivatives::inverse: a force element of a type the library does not define");
  const int n = s.model.num_speeds();
  const int m = s.model.num_inputs();
  check_size("Derivatives: q", q.size(), s.model.num_coordinates());
  check_size("Derivatives: z", z.size(), n);
  check_size("Derivatives: zdot", zdot.size(), n);
  check_size("Derivatives: u", u.size(), m);
  MatrixX all(n, 2 * n + m);
  s.inverse_directions(q, z, zdot, u, all);
  dq = all.leftCols(n);
  dz = all.middleCols(n, n);
  du = all.rightCols(m);
}

void Derivatives::constrained(const VectorX& q, const VectorX& z, const VectorX& zdot,
                              const VectorX& u, const VectorX& lambda, Eigen::Ref<MatrixX> dQ,
                              MatrixX& drows) {
  Impl& s = *impl_;
  if (!s.tables.supported)
    throw std::logic_error(
        "Derivatives::constrained: a force element of a type the library does not define");
  const int n = s.model.num_speeds();
  const int m = s.model.num_inputs();
  check_size("Derivatives: q", q.size(), s.model.num_coordinates());
  check_size("Derivatives: z", z.size(), n);
  check_size("Derivatives: zdot", zdot.size(), n);
  check_size("Derivatives: u", u.size(), m);
  check_size("Derivatives: lambda", lambda.size(), s.tables.constraint_rows);
  drows.resize(3 * s.tables.constraint_rows, 2 * n + m);
  s.tables.reactions = true;
  s.tables.lambda = lambda;
  s.inverse_directions(q, z, zdot, u, dQ, &drows);
  s.tables.reactions = false;
}

// ---- Linearization and eigenvalues ----

// Below this size Eigen's solver is used: LAPACK's (OpenBLAS's) would wake its threads for a
// matrix that takes microseconds, which on a loaded machine costs far more.
constexpr int kSmallEigenproblem = 48;

extern "C" void dgeevx_(const char* balanc, const char* jobvl, const char* jobvr, const char* sense,
                        const int* n, double* a, const int* lda, double* wr, double* wi, double* vl,
                        const int* ldvl, double* vr, const int* ldvr, int* ilo, int* ihi,
                        double* scale, double* abnrm, double* rconde, double* rcondv, double* work,
                        const int* lwork, int* iwork, int* info);

Eigen::VectorXcd sorted_eigenvalues(const MatrixX& a, Eigen::MatrixXcd* vectors) {
  if (a.rows() != a.cols()) throw std::invalid_argument("sorted_eigenvalues: a square matrix");
  const int n = static_cast<int>(a.rows());
  Eigen::VectorXcd values(n);
  if (vectors) vectors->resize(n, n);
  if (n == 0) return values;
  if (!a.allFinite()) throw std::invalid_argument("sorted_eigenvalues: a matrix with NaN or inf");
  VectorX wr(n), wi(n);
  Eigen::MatrixXcd raw;
  if (n <= kSmallEigenproblem && !vectors) {
    // Eigenvalues isolated by permutations first, as dgebal's first step does: a row or column
    // zero off the diagonal (among the rows and columns left) gives its diagonal entry exactly,
    // and the others are those of the matrix without it. The ignorable coordinates of a
    // linearization (a rolling vehicle's position and heading) are such: isolated, their zeros
    // are exact and the QR iteration does not see their Jordan blocks, which would perturb the
    // other eigenvalues by up to sqrt(eps).
    std::vector<int> left(at(n));
    for (int i = 0; i < n; ++i) left[at(i)] = i;
    int found = 0;
    for (bool again = true; again;) {
      again = false;
      for (size_t j = 0; j < left.size(); ++j) {
        const int c = left[j];
        bool column = true, row = true;
        for (const int i : left) {
          if (i == c) continue;
          column = column && a(i, c) == 0.0;
          row = row && a(c, i) == 0.0;
        }
        if (!column && !row) continue;
        wr[found] = a(c, c);
        wi[found] = 0.0;
        ++found;
        left.erase(left.begin() + static_cast<std::ptrdiff_t>(j));
        again = true;
        break;
      }
    }
    if (!left.empty()) {
      MatrixX rest(static_cast<Eigen::Index>(left.size()), static_cast<Eigen::Index>(left.size()));
      for (size_t i = 0; i < left.size(); ++i)
        for (size_t j = 0; j < left.size(); ++j)
          rest(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = a(left[i], left[j]);
      // Eigen's EigenSolver: a few microseconds at this size, with no threads to wake.
      const Eigen::EigenSolver<MatrixX> solver(rest, false);
      if (solver.info() != Eigen::Success)
        throw std::runtime_error("eigenvalues: the QR iteration did not converge");
      wr.tail(n - found) = solver.eigenvalues().real();
      wi.tail(n - found) = solver.eigenvalues().imag();
    }
  } else if (n <= kSmallEigenproblem) {
    // With the vectors, of the whole matrix (LAPACK's path isolates as above itself).
    const Eigen::EigenSolver<MatrixX> solver(a, true);
    if (solver.info() != Eigen::Success)
      throw std::runtime_error("eigenvalues: the QR iteration did not converge");
    wr = solver.eigenvalues().real();
    wi = solver.eigenvalues().imag();
    raw = solver.eigenvectors();
  } else {
    // LAPACK's dgeevx (Hessenberg reduction and the multishift QR, blocked): a general matrix
    // of 1,000 rows in under a second where Eigen's EigenSolver takes twenty. Balanced by
    // permutations only, as Eigen's solver is not at all: the diagonal scaling that dgeev always
    // applies took a quarter of the time on the 512-link chain's A (its sweeps read rows across
    // the column-major matrix) and moved its eigenvalues 1e-8 of their size away from an
    // extended-precision reference, where the unscaled ones are within 1e-10 (scaling can harm
    // as well as help: Watkins, "A case where balancing is harmful", ETNA 23, 2006).
    MatrixX work_a = a;
    MatrixX vr(vectors ? n : 1, vectors ? n : 1);
    const char balanc = 'P', jobvl = 'N', jobvr = vectors ? 'V' : 'N', sense = 'N';
    const int ldvr = vectors ? n : 1, one = 1;
    int info = 0, lwork = -1, ilo = 0, ihi = 0;
    double query = 0.0, dummy = 0.0, abnrm = 0.0;
    VectorX scale(n);
    const auto call = [&](double* work) {
      dgeevx_(&balanc, &jobvl, &jobvr, &sense, &n, work_a.data(), &n, wr.data(), wi.data(), &dummy,
              &one, vr.data(), &ldvr, &ilo, &ihi, scale.data(), &abnrm, &dummy, &dummy, work,
              &lwork, nullptr, &info);
    };
    call(&query);
    lwork = std::max(1, static_cast<int>(query));
    std::vector<double> work(at(lwork));
    call(work.data());
    if (info != 0)
      throw std::runtime_error("eigenvalues: LAPACK dgeevx did not converge (info " +
                               std::to_string(info) + ")");
    if (vectors) {
      // dgeevx stores a complex pair's vector as two real columns j, j+1: v = vr_j +- i vr_j+1.
      raw.resize(n, n);
      for (int j = 0; j < n; ++j) {
        if (wi[j] == 0.0) {
          raw.col(j) = vr.col(j).cast<std::complex<double>>();
        } else if (wi[j] > 0.0 && j + 1 < n) {
          for (int r = 0; r < n; ++r) {
            raw(r, j) = {vr(r, j), vr(r, j + 1)};
            raw(r, j + 1) = {vr(r, j), -vr(r, j + 1)};
          }
          ++j;
        }
      }
    }
  }
  std::vector<int> order(at(n));
  for (int i = 0; i < n; ++i) order[at(i)] = i;
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) {
    if (wr[x] != wr[y]) return wr[x] > wr[y];
    return wi[x] > wi[y];
  });
  for (int i = 0; i < n; ++i) values[i] = {wr[order[at(i)]], wi[order[at(i)]]};
  if (vectors) {
    for (int i = 0; i < n; ++i) {
      Eigen::VectorXcd v = raw.col(order[at(i)]);
      Eigen::Index big = 0;
      v.cwiseAbs().maxCoeff(&big);
      if (std::abs(v[big]) > 0.0) v /= v[big];  // the largest entry 1, real and positive
      vectors->col(i) = v;
    }
  }
  return values;
}

ModeReading read_eigenvalue(std::complex<double> lambda, double tolerance) {
  ModeReading r;
  const double re = lambda.real(), im = lambda.imag();
  const double size = std::abs(lambda);
  r.frequency_hz = std::abs(im) / (2.0 * std::numbers::pi);
  r.damping_ratio = size > 0.0 ? -re / size : 0.0;
  r.time_constant = re != 0.0 ? 1.0 / std::abs(re) : std::numeric_limits<double>::infinity();
  r.stable = re < -tolerance;
  r.unstable = re > tolerance;
  return r;
}

namespace {

// The tangent coordinates' rates to first order about the nominal motion: d(r)/dt = (w - w0)
// - w0 x r for a rotation vector (the spec's "Linearization output"), the speed's deviation for
// every other entry: d(dx)/dt = [K] dx + dz, [K] the -[w0~] blocks. Also whether a free body
// turns (the linear system is then periodic).
MatrixX rotation_rate_block(const Model& model, const VectorX& z, bool* periodic) {
  const int n = model.num_speeds();
  MatrixX K = MatrixX::Zero(n, n);
  for (int k = 0; k < model.num_bodies(); ++k) {
    const JointType type = model.joint(k).type;
    if (!joint_type_info(type).euler) continue;
    const int p = model.speed_offset(k);
    const Vector3 w0 = z.segment<3>(p);
    K.block<3, 3>(p, p) = -skew(w0);
    if (joint_type_info(type).absolute && !w0.isZero(0.0) && periodic) *periodic = true;
  }
  return K;
}

// The linearization of a model with constraints (docs/theory.md, "Linearization with
// constraints", after Peterson, Gede and Hubbard 2015): the state is the independent
// coordinates dx_I and the independent speeds dz_I. The dependent coordinates follow from the
// holonomic constraints to first order (Phi dx = 0), the dependent speeds from the velocity
// constraints ([B] dz + d([B] z)/dx dx = 0), and the accelerations and the multipliers' change
// from the linearized equations of motion and acceleration constraints,
//   [M -B^T; B 0] (dzdot; dlambda) = -(d(Q - B^T lambda) dx + ... ; d([B] zdot + b) ...).
Linearization linearize_constrained(const Model& model, const VectorX& q_in, const VectorX& z_in,
                                    const VectorX& u, bool modes) {
  const int n = model.num_speeds();
  const int m = model.num_inputs();
  Linearization lin;
  lin.m = m;
  for (const Input& in : model.inputs()) lin.inputs.push_back(in.name);
  VectorX q = q_in, z = z_in;
  project_onto_constraints(model, q, z);
  lin.q = q;
  lin.z = z;
  lin.u = u;
  ConstrainedDynamics dynamics(model);
  VectorX zdot(n);
  dynamics.evaluate(q, z, u, zdot);
  lin.zdot = zdot;
  const ConstraintEquations& eq = dynamics.equations();
  const int c = eq.rows();
  Derivatives derivatives(model);
  if (!derivatives.analytic())
    throw std::invalid_argument(
        "linearize: a model with constraints and a force element of a type the library does "
        "not define (its derivatives would be central differences, too coarse here)");
  MatrixX dQ(n, 2 * n + m), drows;
  derivatives.constrained(q, z, zdot, u, dynamics.lambda(), dQ, drows);
  const auto dvel = drows.topRows(c), dacc = drows.middleRows(c, c), derr = drows.bottomRows(c);

  // Independent coordinates: all but the pivot columns of the holonomic rows' d(error)/dx.
  std::vector<int> holonomic;
  for (int i = 0; i < c; ++i)
    if (eq.holonomic(i)) holonomic.push_back(i);
  MatrixX Phi(static_cast<Eigen::Index>(holonomic.size()), n);
  for (size_t i = 0; i < holonomic.size(); ++i)
    Phi.row(static_cast<Eigen::Index>(i)) = derr.row(holonomic[i]).leftCols(n);
  std::vector<char> dependent_q(at(n), 0);
  if (Phi.rows() > 0) {
    Eigen::ColPivHouseholderQR<MatrixX> qr(Phi);
    qr.setThreshold(1e-9);
    for (int i = 0; i < qr.rank(); ++i) dependent_q[at(qr.colsPermutation().indices()[i])] = 1;
  }
  std::vector<int> qi, qd;
  for (int i = 0; i < n; ++i) (dependent_q[at(i)] ? qd : qi).push_back(i);
  const int nqi = static_cast<int>(qi.size());
  // dx = Tx dx_I.
  MatrixX Tx = MatrixX::Zero(n, nqi);
  for (int j = 0; j < nqi; ++j) Tx(qi[at(j)], j) = 1.0;
  if (!qd.empty()) {
    MatrixX PD(Phi.rows(), static_cast<Eigen::Index>(qd.size())), PI(Phi.rows(), nqi);
    for (size_t j = 0; j < qd.size(); ++j) PD.col(static_cast<Eigen::Index>(j)) = Phi.col(qd[j]);
    for (int j = 0; j < nqi; ++j) PI.col(j) = Phi.col(qi[at(j)]);
    const MatrixX X = Eigen::CompleteOrthogonalDecomposition<MatrixX>(PD).solve(-PI);
    for (size_t j = 0; j < qd.size(); ++j) Tx.row(qd[j]) = X.row(static_cast<Eigen::Index>(j));
  }

  // Independent speeds: dz = Tz dz_I + Szx dx_I from the independent velocity rows.
  const SpeedPartition& part = dynamics.partition();
  const int r = part.rank, nzi = n - r;
  MatrixX Br(r, n), Vx(r, n);
  for (int i = 0; i < r; ++i) {
    Br.row(i) = eq.B().row(part.rows[at(i)]);
    Vx.row(i) = dvel.row(part.rows[at(i)]).leftCols(n);
  }
  MatrixX BD(r, r), BI(r, nzi);
  for (int j = 0; j < r; ++j) BD.col(j) = Br.col(part.dependent[at(j)]);
  for (int j = 0; j < nzi; ++j) BI.col(j) = Br.col(part.independent[at(j)]);
  const Eigen::PartialPivLU<MatrixX> lu_d(BD);
  MatrixX Tz = MatrixX::Zero(n, nzi), Szx = MatrixX::Zero(n, nqi);
  for (int j = 0; j < nzi; ++j) Tz(part.independent[at(j)], j) = 1.0;
  if (r > 0) {
    const MatrixX dz_dzi = lu_d.solve(-BI);
    const MatrixX dz_dx = lu_d.solve(-(Vx * Tx));
    for (int i = 0; i < r; ++i) {
      Tz.row(part.dependent[at(i)]) = dz_dzi.row(i);
      Szx.row(part.dependent[at(i)]) = dz_dx.row(i);
    }
  }

  // Accelerations: [M -Br^T; Br 0] (dzdot; dlambda) = -(dQ; dacc) along (dx_I, dz_I, du).
  MatrixX M(n, n);
  Terms(model).mass_matrix(q, M);
  MatrixX kkt = MatrixX::Zero(n + r, n + r);
  kkt.topLeftCorner(n, n) = M;
  kkt.topRightCorner(n, r) = -Br.transpose();
  kkt.bottomLeftCorner(r, n) = Br;
  const int cols = nqi + nzi + m;
  MatrixX rhs(n + r, cols);
  const auto Qx = dQ.leftCols(n), Qz = dQ.middleCols(n, n), Qu = dQ.rightCols(m);
  MatrixX Ax(r, n), Az(r, n);
  for (int i = 0; i < r; ++i) {
    Ax.row(i) = dacc.row(part.rows[at(i)]).leftCols(n);
    Az.row(i) = dacc.row(part.rows[at(i)]).middleCols(n, n);
  }
  const MatrixX dx_of_xi = Tx, dz_of_xi = Szx;
  rhs.topLeftCorner(n, nqi) = -(Qx * dx_of_xi + Qz * dz_of_xi);
  rhs.bottomLeftCorner(r, nqi) = -(Ax * dx_of_xi + Az * dz_of_xi);
  rhs.block(0, nqi, n, nzi) = -(Qz * Tz);
  rhs.block(n, nqi, r, nzi) = -(Az * Tz);
  if (m > 0) {
    rhs.topRightCorner(n, m) = -Qu;
    rhs.bottomRightCorner(r, m).setZero();
  }
  const MatrixX sol = kkt.partialPivLu().solve(rhs);
  const auto dzdot = sol.topRows(n);

  // The state's rates: coordinates d(dx)/dt = [K] dx + dz, rows qi; speeds rows of the
  // independent speeds.
  const MatrixX K = rotation_rate_block(model, z, &lin.periodic);
  const MatrixX xrate_xi = K * Tx + Szx;
  lin.n = nzi;
  lin.A = MatrixX::Zero(nqi + nzi, nqi + nzi);
  lin.B = MatrixX::Zero(nqi + nzi, m);
  for (int i = 0; i < nqi; ++i) {
    lin.A.row(i).head(nqi) = xrate_xi.row(qi[at(i)]);
    lin.A.row(i).tail(nzi) = Tz.row(qi[at(i)]);
  }
  for (int i = 0; i < nzi; ++i) {
    const int row = part.independent[at(i)];
    lin.A.row(nqi + i).head(nqi) = dzdot.row(row).head(nqi);
    lin.A.row(nqi + i).tail(nzi) = dzdot.row(row).segment(nqi, nzi);
    if (m > 0) lin.B.row(nqi + i) = dzdot.row(row).tail(m);
  }
  lin.full_state = MatrixX::Zero(2 * n, nqi + nzi);
  lin.full_state.topLeftCorner(n, nqi) = Tx;
  lin.full_state.bottomLeftCorner(n, nqi) = Szx;
  lin.full_state.bottomRightCorner(n, nzi) = Tz;
  const std::vector<std::string> names = tangent_state_names(model);
  for (const int i : qi) lin.state.push_back(names[at(i)]);
  for (const int i : part.independent) lin.state.push_back(names[at(n + i)]);
  lin.eigenvalues = sorted_eigenvalues(lin.A, modes ? &lin.modes : nullptr);
  return lin;
}

}  // namespace

Linearization linearize(const Model& model, const VectorX& q, const VectorX& z, const VectorX& u,
                        bool modes) {
  const int n = model.num_speeds();
  const int m = model.num_inputs();
  check_size("linearize: q", q.size(), model.num_coordinates());
  check_size("linearize: z", z.size(), n);
  check_size("linearize: u", u.size(), m);
  if (model.num_constraints() > 0) return linearize_constrained(model, q, z, u, modes);
  Linearization lin;
  lin.n = n;
  lin.m = m;
  lin.state = tangent_state_names(model);
  for (const Input& in : model.inputs()) lin.inputs.push_back(in.name);
  lin.q = q;
  lin.z = z;
  lin.u = u;
  lin.A = MatrixX::Zero(2 * n, 2 * n);
  lin.B = MatrixX::Zero(2 * n, m);
  Derivatives derivatives(model);
  // B's block through a matrix of its own: a block of a matrix without columns would offset a
  // null pointer.
  MatrixX du(n, m);
  derivatives.forward(q, z, u, lin.A.bottomLeftCorner(n, n), lin.A.bottomRightCorner(n, n), du,
                      &lin.zdot);
  if (m > 0) lin.B.bottomRows(n) = du;
  // The coordinates' rates: d(r)/dt = (w - w0) - w0 x r for a rotation vector (the spec's
  // "Linearization output"), d(deviation)/dt = the speed's deviation for every other entry.
  lin.A.topRightCorner(n, n).setIdentity();
  lin.A.topLeftCorner(n, n) = rotation_rate_block(model, z, &lin.periodic);
  lin.eigenvalues = sorted_eigenvalues(lin.A, modes ? &lin.modes : nullptr);
  return lin;
}

Linearization linearize_at_rest(const Model& model, const VectorX& q, const VectorX& u,
                                const std::vector<int>& free) {
  refuse_constraints(model, "linearize_at_rest");
  const int n = model.num_speeds();
  const int m = model.num_inputs();
  const int f = static_cast<int>(free.size());
  check_size("linearize_at_rest: q", q.size(), model.num_coordinates());
  check_size("linearize_at_rest: u", u.size(), m);
  for (const int i : free)
    if (i < 0 || i >= n)
      throw std::invalid_argument("linearize_at_rest: coordinate " + std::to_string(i) +
                                  " outside 0.." + std::to_string(n - 1));
  Derivatives derivatives(model);
  if (!derivatives.analytic())
    throw std::invalid_argument(
        "linearize_at_rest: the model has a force element of a type the library does not define");
  const VectorX zero = VectorX::Zero(n);
  MatrixX dq(n, n), dz(n, n), du(n, m), M(n, n);
  derivatives.inverse(q, zero, zero, u, dq, dz, du);
  Terms(model).mass_matrix(q, M);
  // The free rows (and, square, columns) of a matrix.
  const auto rows = [&](const MatrixX& a, bool square) {
    MatrixX out(f, square ? f : a.cols());
    for (int r = 0; r < f; ++r)
      for (Eigen::Index c = 0; c < out.cols(); ++c)
        out(r, c) = a(free[at(r)], square ? free[at(static_cast<int>(c))] : c);
    return out;
  };
  // [M_ff] d(z_f)/dt = -Q_f - dQ_f/dq_f dq_f - dQ_f/dz_f dz_f - dQ_f/du du, and d(q_f)/dt = z_f
  // (a rotation vector's too: w0 = 0).
  const Eigen::LLT<MatrixX> llt(rows(M, true));
  const VectorX residual = detail::generic_inverse_dynamics(model, q, zero, zero, u);
  Linearization lin;
  lin.n = f;
  lin.m = m;
  const std::vector<std::string> names = tangent_state_names(model);
  for (const int i : free) lin.state.push_back(names[at(i)]);
  for (const int i : free) lin.state.push_back(names[at(n + i)]);
  for (const Input& in : model.inputs()) lin.inputs.push_back(in.name);
  lin.q = q;
  lin.z = zero;
  lin.u = u;
  VectorX rf(f);
  for (int i = 0; i < f; ++i) rf[i] = residual[free[at(i)]];
  lin.zdot = -llt.solve(rf);
  lin.A = MatrixX::Zero(2 * f, 2 * f);
  lin.B = MatrixX::Zero(2 * f, m);
  lin.A.topRightCorner(f, f).setIdentity();
  lin.A.bottomLeftCorner(f, f) = -llt.solve(rows(dq, true));
  lin.A.bottomRightCorner(f, f) = -llt.solve(rows(dz, true));
  if (m > 0) lin.B.bottomRows(f) = -llt.solve(rows(du, false));
  if (lin.A.allFinite()) lin.eigenvalues = sorted_eigenvalues(lin.A);
  return lin;
}

// ---- Static equilibrium ----

namespace {

// Newton's method on forces(q) = 0 from result.q, each step halved until the largest residual
// shrinks (at most 40 times): jacobian(q) returns dforces/dstep at q, moved(q, step) the
// iterate a step away. residual and size hold forces(result.q) and its largest magnitude on
// entry and on return; result.iterations and result.converged say how it ended.
template <typename Forces, typename Jacobian, typename Move>
void halving_newton(EquilibriumResult& result, VectorX& residual, double& size, double target,
                    int max_iterations, const Forces& forces, const Jacobian& jacobian,
                    const Move& moved) {
  for (int iteration = 0; iteration <= max_iterations; ++iteration) {
    result.iterations = iteration;
    if (!(size > target)) {
      result.converged = std::isfinite(size);
      break;
    }
    if (iteration == max_iterations) break;
    const VectorX step =
        -Eigen::CompleteOrthogonalDecomposition<MatrixX>(jacobian(result.q)).solve(residual);
    double t = 1.0;
    bool improved = false;
    for (int halving = 0; halving < 40; ++halving, t *= 0.5) {
      const VectorX q_try = moved(result.q, VectorX(t * step));
      const VectorX r_try = forces(q_try);
      const double s_try = r_try.cwiseAbs().maxCoeff();
      if (s_try < size) {
        result.q = q_try;
        residual = r_try;
        size = s_try;
        improved = true;
        break;
      }
    }
    if (!improved) break;
  }
}

// The columns of a rank-deficient Jacobian that its null space moves: those with an entry of at
// least 1e-6 of the largest in some kernel vector (what nothing restrains).
std::vector<int> kernel_columns(const Eigen::FullPivLU<MatrixX>& lu) {
  const MatrixX kernel = lu.kernel();
  std::vector<int> out;
  for (Eigen::Index i = 0; i < kernel.rows(); ++i)
    for (Eigen::Index c = 0; c < kernel.cols(); ++c)
      if (std::abs(kernel(i, c)) > 1e-6 * kernel.col(c).cwiseAbs().maxCoeff()) {
        out.push_back(static_cast<int>(i));
        break;
      }
  return out;
}

// Static equilibrium with constraints (docs/analysis.md, "Static equilibrium"): at rest the
// reactions balance the generalized forces, Q = [B]^T lambda, so their components along the
// motions the constraints allow vanish, [C_I]^T Q = 0, with [C_I] the independent speeds'
// basis of the null space of [B] (y = [C][C_I] z_I). Newton moves q along [C_I] (the
// independent speeds' directions) and projects the holonomic rows back after each step; the
// Jacobian of [C_I]^T Q along them is taken by central differences (the rows' second
// derivatives are not formed analytically), whose error, O(h^2) relative with h = 1e-6, only
// slows the convergence near the root without moving it.
EquilibriumResult constrained_equilibrium(const Model& model, const VectorX& q0, const VectorX& u,
                                          const EquilibriumOptions& options) {
  if (!options.free.empty())
    throw std::invalid_argument(
        "equilibrium: holding coordinates of a model with constraints is not supported (its "
        "constraints already choose the independent ones); leave `free` empty");
  const int n = model.num_speeds();
  const VectorX zero = VectorX::Zero(n);
  ConstraintEquations equations(model);
  VectorX q = q0, z = zero;
  project_onto_constraints(model, q, z);
  equations.evaluate(q, zero);
  const SpeedPartition partition = partition_speeds(model, equations.B());
  const int r = partition.rank, f = n - r;
  // [C_I] at q for the partition chosen at the start.
  const auto basis = [&](const VectorX& at_q) {
    equations.evaluate(at_q, zero);
    return independent_basis(equations.B(), partition);
  };
  const auto forces = [&](const VectorX& at_q) -> VectorX {
    return basis(at_q).transpose() * detail::generic_inverse_dynamics(model, at_q, zero, zero, u);
  };
  // A step delta along the independent directions, then back onto the holonomic constraints.
  const auto moved = [&](const VectorX& from, const VectorX& delta) {
    VectorX to = retract(model, from, basis(from) * delta), rates = zero;
    project_onto_constraints(model, to, rates);
    return to;
  };
  EquilibriumResult result;
  result.q = q;
  result.free = partition.independent;
  VectorX residual = forces(q);
  result.scale = std::max(1.0, f > 0 ? residual.cwiseAbs().maxCoeff() : 0.0);
  const double target = options.tolerance * result.scale;
  double size = f > 0 ? residual.cwiseAbs().maxCoeff() : 0.0;
  const double h = 1e-6;
  const auto jacobian = [&](const VectorX& at_q) {
    MatrixX J(f, f);
    for (int j = 0; j < f; ++j) {
      VectorX d = VectorX::Zero(f);
      d[j] = h;
      J.col(j) = (forces(moved(at_q, d)) - forces(moved(at_q, -d))) / (2.0 * h);
    }
    return J;
  };
  halving_newton(result, residual, size, target, options.max_iterations, forces, jacobian, moved);
  result.residual = residual;
  result.residual_norm = size;
  if (f > 0) {
    Eigen::FullPivLU<MatrixX> lu(jacobian(result.q));
    lu.setThreshold(1e-8);  // a central-difference Jacobian: 1e-10 relative is its noise
    if (lu.rank() < f)
      for (const int i : kernel_columns(lu))
        result.unrestrained.push_back(partition.independent[static_cast<size_t>(i)]);
    const Linearization lin = linearize(model, result.q, zero, u);
    if (lin.A.allFinite()) result.eigenvalues = lin.eigenvalues;
  }
  std::ostringstream msg;
  msg.precision(3);
  msg << (result.converged ? "converged in " : "Newton did not converge after ")
      << result.iterations << (result.iterations == 1 ? " Newton iteration" : " Newton iterations")
      << " on the " << f << " independent speeds' directions: largest generalized force along them "
      << result.residual_norm << " (tolerance " << target << ")";
  result.message = msg.str();
  return result;
}

}  // namespace

EquilibriumResult equilibrium(const Model& model, const VectorX& q0, const VectorX& u,
                              const EquilibriumOptions& options) {
  // A looser tolerance would call a pose with a good part of its forces unbalanced a rest.
  if (!(options.tolerance > 0.0 && options.tolerance <= kMaxEquilibriumTolerance)) {
    std::ostringstream m;
    m << "equilibrium: tolerance " << options.tolerance
      << " is not in (0, 1e-3]: a rest leaves at most that fraction of the starting forces "
         "unbalanced";
    throw std::invalid_argument(m.str());
  }
  if (options.max_iterations < 1)
    throw std::invalid_argument("equilibrium: max_iterations " +
                                std::to_string(options.max_iterations) + " is not at least 1");
  if (model.num_constraints() > 0) {
    check_size("equilibrium: q", q0.size(), model.num_coordinates());
    check_size("equilibrium: u", u.size(), model.num_inputs());
    return constrained_equilibrium(model, q0, u, options);
  }
  const int n = model.num_speeds();
  check_size("equilibrium: q", q0.size(), model.num_coordinates());
  check_size("equilibrium: u", u.size(), model.num_inputs());
  std::vector<int> free = options.free;
  if (free.empty())
    for (int i = 0; i < n; ++i) free.push_back(i);
  for (const int i : free)
    if (i < 0 || i >= n)
      throw std::invalid_argument("equilibrium: free coordinate " + std::to_string(i) +
                                  " outside 0.." + std::to_string(n - 1));
  const int f = static_cast<int>(free.size());
  Derivatives derivatives(model);
  if (!derivatives.analytic())
    throw std::invalid_argument(
        "equilibrium: the model has a force element of a type the library does not define");
  const VectorX zero = VectorX::Zero(n);
  MatrixX dq(n, n), dz(n, n), du(n, model.num_inputs());
  const auto forces = [&](const VectorX& q) {  // Q on the free coordinates at z = 0, z dot = 0
    const VectorX all = detail::generic_inverse_dynamics(model, q, zero, zero, u);
    VectorX out(f);
    for (int i = 0; i < f; ++i) out[i] = all[free[at(i)]];
    return out;
  };
  EquilibriumResult result;
  result.q = q0;
  result.free = free;
  VectorX residual = forces(q0);
  // The force scale: the largest generalized force of gravity, the elements and the inputs at
  // the start, or 1 where they all vanish there.
  result.scale = std::max(1.0, residual.cwiseAbs().maxCoeff());
  const double target = options.tolerance * result.scale;
  double size = f > 0 ? residual.cwiseAbs().maxCoeff() : 0.0;
  MatrixX J(f, f);
  // Q's analytic Jacobian on the free coordinates at q, into J.
  const auto jacobian = [&](const VectorX& at_q) -> const MatrixX& {
    derivatives.inverse(at_q, zero, zero, u, dq, dz, du);
    for (int r = 0; r < f; ++r)
      for (int c = 0; c < f; ++c) J(r, c) = dq(free[at(r)], free[at(c)]);
    return J;
  };
  const auto moved = [&](const VectorX& from, const VectorX& step) {
    VectorX dx = VectorX::Zero(n);
    for (int i = 0; i < f; ++i) dx[free[at(i)]] = step[i];
    return retract(model, from, dx);
  };
  halving_newton(result, residual, size, target, options.max_iterations, forces, jacobian, moved);
  result.residual = residual;
  result.residual_norm = size;
  // Which free coordinates nothing restrains at the end: the null space of dQ/dq.
  jacobian(result.q);
  if (f > 0) {
    Eigen::ColPivHouseholderQR<MatrixX> qr(J);
    qr.setThreshold(1e-10);
    if (qr.rank() < f) {
      Eigen::FullPivLU<MatrixX> lu(J);
      lu.setThreshold(1e-10);
      for (const int i : kernel_columns(lu)) result.unrestrained.push_back(free[at(i)]);
    }
  }
  // Stable or not: the motion about q with the held coordinates locked.
  if (f > 0) {
    const Linearization held = linearize_at_rest(model, result.q, u, free);
    if (held.A.allFinite()) result.eigenvalues = sorted_eigenvalues(held.A);
  }
  std::ostringstream msg;
  msg.precision(3);
  if (result.converged) {
    msg << "converged in " << result.iterations
        << (result.iterations == 1 ? " Newton iteration" : " Newton iterations")
        << ": largest generalized force " << result.residual_norm << " (tolerance " << target
        << ")";
  } else {
    msg << "Newton did not converge after " << result.iterations
        << (result.iterations == 1 ? " iteration" : " iterations") << ": largest generalized force "
        << result.residual_norm << " (tolerance " << target << ")";
  }
  result.message = msg.str();
  return result;
}

}  // namespace kanedyn
