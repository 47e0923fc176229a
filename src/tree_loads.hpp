// The generic passes' terms of each body over any scalar S (double, or the dual numbers of the
// analytic derivatives), and TreeLoads<S>: what a force element's law reads of them and where it
// adds its loads (ForceElement::apply_generic). The passes themselves are src/analysis.cpp's;
// the laws are the elements' own (src/forces.cpp). Private to the library.
#pragma once

#include <cmath>
#include <vector>

#include "kanedyn/model.hpp"
#include "kanedyn/types.hpp"

#include "dual.hpp"
#include "equations.hpp"

namespace kanedyn {

namespace eq {
template <int N>
struct Lanes<Dual<N>> {
  static Dual<N> sqrt(const Dual<N>& v) { return kanedyn::sqrt(v); }
  static bool all(bool b) { return b; }
};
}  // namespace eq

namespace tree {

inline size_t at(int i) { return static_cast<size_t>(i); }

template <typename S>
using V3 = eq::Vec3<S>;
template <typename S>
using M3 = eq::Mat3<S>;
template <typename S>
using Eu = eq::Euler<S>;

/// The value of a number, without its derivatives.
inline double value_of(double v) { return v; }
template <int N>
double value_of(const Dual<N>& v) {
  return v.v;
}

template <typename S>
V3<S> constant(const Vector3& v) {
  return {S(v.x()), S(v.y()), S(v.z())};
}
template <typename S>
V3<S> times(const Matrix3& m, const V3<S>& v) {
  return {m(0, 0) * v.x + m(0, 1) * v.y + m(0, 2) * v.z,
          m(1, 0) * v.x + m(1, 1) * v.y + m(1, 2) * v.z,
          m(2, 0) * v.x + m(2, 1) * v.y + m(2, 2) * v.z};
}
template <typename S>
S dot_constant(const Vector3& a, const V3<S>& b) {
  return a.x() * b.x + a.y() * b.y + a.z() * b.z;
}
// Products with a constant vector: a dual number times a double is one multiply per pack, where
// a constant made a dual number would take two and an add.
template <typename S>
V3<S> scale(const S& s, const Vector3& v) {
  return {s * v.x(), s * v.y(), s * v.z()};
}
template <typename S>
void add_constant(V3<S>& a, const Vector3& v) {
  a.x += v.x();
  a.y += v.y();
  a.z += v.z();
}
template <typename S>
V3<S> cross(const V3<S>& a, const Vector3& b) {
  return {a.y * b.z() - a.z * b.y(), a.z * b.x() - a.x * b.z(), a.x * b.y() - a.y * b.x()};
}
template <typename S>
V3<S> cross(const Vector3& a, const V3<S>& b) {
  return {b.z * a.y() - b.y * a.z(), b.x * a.z() - b.z * a.x(), b.y * a.x() - b.x * a.y()};
}
template <typename S>
V3<S> times_constant(const M3<S>& m, const Vector3& v) {
  return {m.a[0] * v.x() + m.a[1] * v.y() + m.a[2] * v.z(),
          m.a[3] * v.x() + m.a[4] * v.y() + m.a[5] * v.z(),
          m.a[6] * v.x() + m.a[7] * v.y() + m.a[8] * v.z()};
}
template <typename S>
S norm_of(const V3<S>& v) {
  using std::sqrt;
  return sqrt(eq::dot(v, v));
}

/// Body K's terms in one evaluation, body-K components unless said.
template <typename S>
struct Body {
  Eu<S> eps;                      ///< eps_K, absolute (when some law needs it)
  M3<S> R;                        ///< [R_K] (when some law needs it)
  M3<S> E;                        ///< [R_K][R_J]^T
  V3<S> r;                        ///< q'_K + s'_K, body-J components
  V3<S> sd;                       ///< s'_K dot, body-J components
  V3<S> slide;                    ///< s'_K, body-J components
  V3<S> w, w_rel;                 ///< w'_K; [G_K] z_K
  V3<S> g0;                       ///< a universal joint's first column of [G_K]
  V3<S> alpha, a;                 ///< alpha'_K; the acceleration of O_K
  V3<S> moment, force;            ///< what K (then its subtree) needs, about O_K
  V3<S> load_force, load_moment;  ///< the resultants on K: a force at G_K, a moment
};

/// A body's motion in inertial components: what the constraints and the laws that join points
/// of two bodies need of it.
template <typename S>
struct Motion {
  M3<S> R;                  ///< [R_K]: inertial -> body K
  V3<S> p, v, a, w, alpha;  ///< O_K's position, velocity, acceleration; w_K and alpha_K
};

/// A point fixed in body k (offset in body-K components) or in the ground (inertial).
template <typename S>
struct PointMotion {
  V3<S> r, p, v, a;  ///< from O_K, position, velocity, acceleration (inertial)
};

template <typename S>
PointMotion<S> point_motion(const std::vector<Motion<S>>& motion, int k, const Vector3& offset) {
  const S zero{};
  const V3<S> none{zero, zero, zero};
  if (k == kGround) return {constant<S>(offset), constant<S>(offset), none, none};
  const Motion<S>& b = motion[at(k)];
  PointMotion<S> pm;
  pm.r = eq::transpose_times(b.R, constant<S>(offset));
  pm.p = b.p + pm.r;
  pm.v = b.v + eq::cross(b.w, pm.r);
  pm.a = b.a + eq::cross(b.alpha, pm.r) + eq::cross(b.w, eq::cross(b.w, pm.r));
  return pm;
}

}  // namespace tree

namespace detail {

/// What a force element's law reads of a generic pass and where it adds its loads: the loads
/// on the bodies go to Body::load_force (at G_K) and Body::load_moment, body-K components; the
/// generalized forces on joint coordinates are subtracted from Q (the pass computes the
/// inertia forces less the active ones). Reads what ForceElement::needs() asked for.
template <typename S>
class TreeLoads {
 public:
  using Scalar = S;
  TreeLoads(const Model& model, std::vector<tree::Body<S>>& bodies,
            const std::vector<tree::Motion<S>>* motion, const S* q, const S* z, S* Q)
      : model_(model), bodies_(bodies), motion_(motion), q_(q), z_(z), Q_(Q) {}

  const Model& model() const { return model_; }

  // ---- Reads ----
  /// Euler parameters of K relative to J = L(K) (needs().euler).
  tree::Eu<S> relative_euler(int k) const {
    const int j = model_.lower_body(k);
    const tree::Body<S>& b = bodies_[tree::at(k)];
    return j == kGround ? b.eps : eq::relative_euler_parameters(bodies_[tree::at(j)].eps, b.eps);
  }
  /// [R_K]: inertial -> body K (needs().rotation).
  const tree::M3<S>& rotation(int k) const { return bodies_[tree::at(k)].R; }
  // References, not copies: a vector of dual numbers is hundreds of bytes.
  const tree::V3<S>& translation(int k) const { return bodies_[tree::at(k)].slide; }    // body J
  const tree::V3<S>& translation_rate(int k) const { return bodies_[tree::at(k)].sd; }  // body J
  const tree::V3<S>& angular_velocity(int k) const { return bodies_[tree::at(k)].w; }   // body K
  /// A point fixed in body k, or in the ground (needs().positions).
  tree::PointMotion<S> point(int k, const Vector3& offset) const {
    return tree::point_motion(*motion_, k, offset);
  }
  const S& coordinate(int i) const { return q_[i]; }
  const S& speed(int i) const { return z_[i]; }

  // ---- Loads ----
  /// A moment on K, body-K components.
  void add_moment(int k, const tree::V3<S>& m) {
    tree::Body<S>& b = bodies_[tree::at(k)];
    b.load_moment = b.load_moment + m;
  }
  /// A force at G_K in inertial components (needs().rotation).
  void add_force_at_com(int k, const tree::V3<S>& f) {
    tree::Body<S>& b = bodies_[tree::at(k)];
    b.load_force = b.load_force + b.R * f;
  }
  /// A force at G_K in body-K components.
  void add_force_at_com_b(int k, const tree::V3<S>& f) {
    tree::Body<S>& b = bodies_[tree::at(k)];
    b.load_force = b.load_force + f;
  }
  /// A force at G_K given in the components of J = L(K) (inertial for a root) as f_j and, the
  /// same force, in K's as f_k: each workspace takes the one it keeps.
  void add_force_at_com_lower(int k, const tree::V3<S>& /*f_j*/, const tree::V3<S>& f_k) {
    add_force_at_com_b(k, f_k);
  }
  /// A force f (inertial components) at the point `offset` (from O_K, body-K components) of
  /// body k; nothing for the ground (needs().positions).
  void add_force(int k, const Vector3& offset, const tree::V3<S>& f) {
    if (k == kGround) return;
    tree::Body<S>& b = bodies_[tree::at(k)];
    const tree::V3<S> f_b = (*motion_)[tree::at(k)].R * f;
    b.load_force = b.load_force + f_b;
    b.load_moment =
        b.load_moment + eq::cross(tree::constant<S>(Vector3(offset - model_.body(k).com)), f_b);
  }
  /// A force f_j, in the components of J = L(K) (inertial for a root), at O_K on body K.
  void add_force_at_origin_lower(int k, const tree::V3<S>& f_j) {
    tree::Body<S>& b = bodies_[tree::at(k)];
    const tree::V3<S> f_k = b.E * f_j;
    b.load_force = b.load_force + f_k;
    b.load_moment = b.load_moment - eq::cross(tree::constant<S>(model_.body(k).com), f_k);
  }
  /// The reaction -m of a moment m on K (body-K components) on J = L(K); nothing for a root.
  void add_reaction_moment(int k, const tree::V3<S>& m) {
    const int j = model_.lower_body(k);
    if (j == kGround) return;
    tree::Body<S>& bj = bodies_[tree::at(j)];
    bj.load_moment = bj.load_moment - eq::transpose_times(bodies_[tree::at(k)].E, m);
  }
  /// A generalized force on speed i (the joint coordinates' loads).
  void add_generalized_force(int i, const S& value) { Q_[i] = Q_[i] - value; }

 private:
  const Model& model_;
  std::vector<tree::Body<S>>& bodies_;
  const std::vector<tree::Motion<S>>* motion_;
  const S* q_;
  const S* z_;
  S* Q_;
};

/// The inputs' loads at the values u (docs/model-format.md, "Inputs"; docs/theory.md,
/// "Inputs"), over any loads context (TreeLoads, or the double routes' StateLoads of
/// src/forces.cpp), in input order. Body loads: force and torque inputs, and joint inputs on
/// free bodies (a moment u e_i on K for w'_K i; for s'_K dot i a force u e_i, body-J
/// components, on K at O_K and reversed on J at the point of J coinciding with O_K, whose
/// generalized force is u on that speed alone, as a bushing's).
template <typename L>
void input_body_loads(const Model& model, const typename L::Scalar* u, L& loads) {
  using S = typename L::Scalar;
  const S zero{};
  const auto& inputs = model.inputs();
  for (size_t i = 0; i < inputs.size(); ++i) {
    const Input& in = inputs[i];
    const S& value = u[i];
    const int k = in.body;
    switch (in.type) {
      case InputType::force: {
        const tree::V3<S> f = value * tree::constant<S>(in.direction);  // body K
        loads.add_force_at_com_b(k, f);
        loads.add_moment(k, eq::cross(tree::constant<S>(Vector3(in.point - model.body(k).com)), f));
        break;
      }
      case InputType::torque: {
        const tree::V3<S> m = value * tree::constant<S>(in.axis);  // body K
        loads.add_moment(k, m);
        if (in.reaction) loads.add_reaction_moment(k, m);
        break;
      }
      case InputType::joint: {
        if (model.joint(k).type != JointType::free) break;  // a generalized force, below
        if (in.speed < 3) {
          tree::V3<S> m{zero, zero, zero};
          (in.speed == 0 ? m.x : in.speed == 1 ? m.y : m.z) = value;
          loads.add_moment(k, m);
          break;
        }
        tree::V3<S> f_j{zero, zero, zero};  // body J
        (in.speed == 3 ? f_j.x : in.speed == 4 ? f_j.y : f_j.z) = value;
        loads.add_force_at_origin_lower(k, f_j);
        const int j = model.lower_body(k);
        if (j == kGround) break;
        loads.add_force_at_com_b(j, -f_j);
        // Arm from G_J to O_K in body J: q'_K + s'_K - r'_J.
        const tree::V3<S> arm = tree::constant<S>(model.body(k).joint) + loads.translation(k) -
                                tree::constant<S>(model.body(j).com);
        loads.add_moment(j, -eq::cross(arm, f_j));
        break;
      }
    }
  }
}

/// The generalized force u_i on its speed of every joint input on a joint other than free.
template <typename L>
void input_joint_forces(const Model& model, const typename L::Scalar* u, L& loads) {
  const auto& inputs = model.inputs();
  for (size_t i = 0; i < inputs.size(); ++i) {
    const Input& in = inputs[i];
    if (in.type != InputType::joint || model.joint(in.body).type == JointType::free) continue;
    loads.add_generalized_force(model.speed_offset(in.body) + in.speed, u[i]);
  }
}

}  // namespace detail

}  // namespace kanedyn
