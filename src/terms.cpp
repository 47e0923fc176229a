// Inverse dynamics, mass matrix, bias and gravity forces and the centre of mass over the joints
// (docs/theory.md, "Inverse dynamics, mass matrix, bias and gravity forces"), in the terms of the
// jointed forward dynamics (src/spatial.hpp): V_K = [P_K] V_J + [S_K] z_K, inertial components
// about O_K, and the equation of z_c, sum over B in subtree(c) of (dV_B/dz_c)^T ([I_O,B] A_B +
// b_B - F_ext,B) = Q_c.
#include "kanedyn/terms.hpp"

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/state.hpp"

#include "joint_motion.hpp"
#include "spatial.hpp"

namespace kanedyn {

namespace {

size_t at(int i) { return static_cast<size_t>(i); }

const Matrix3 kIdentity3 = Matrix3::Identity();

// 6 x (speeds of one joint): fixed storage, no heap.
using Block = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, 6>;

// Body K's terms, inertial components.
struct Link {
  Matrix3 R;    // [R_K]
  Vector3 r;    // O_K - O_J = [R_J]^T (q'_K + s'_K)
  Vector3 p;    // O_K
  Vector3 w;    // w_K
  Vector6 c;    // the acceleration of V_K at z dot = 0 and A_J = 0
  Vector6 A;    // the acceleration of V_K
  Vector6 f;    // the force (moment about O_K; force) K needs, then its subtree's
  Vector3 h;    // centre of mass: the first moment of K's subtree about O_K (see there)
  double mass;  // centre of mass: the mass of K's subtree
};

}  // namespace

struct Terms::Impl {
  explicit Impl(const Model& m)
      : model(m),
        joint_force(VectorX::Zero(m.num_speeds())),
        S(6 * at(m.num_speeds()), 0.0),
        S0(S) {
    const int n = m.num_bodies();
    links.resize(at(n));
    composite.resize(at(n));
    for (int k = 0; k < n; ++k) {
      const JointType type = m.joint(k).type;
      lower.push_back(m.lower_body(k));
      types.push_back(type);
      speeds.push_back(speed_count(type));
      offset.push_back(m.speed_offset(k));
      translation.push_back(type == JointType::free ? Matrix36::Zero()
                                                    : joint_translation_block(m, k));
      slides.push_back(detail::slide_columns(translation.back(), speeds.back()));
    }
    if (m.has_body_force_elements() || m.has_body_inputs()) {
      data.emplace(m, DataOptions::recursive_only());
      state.emplace(m);
      motions.resize(at(n));
      for (const auto& element : m.forces())
        loads_read_positions = loads_read_positions || element->reads_positions();
    }
  }

  const Model& model;
  std::vector<int> lower, speeds, offset;
  std::vector<JointType> types;
  std::vector<Matrix36> translation;  // [T_K], J components (constant)
  std::vector<unsigned> slides;       // its nonzero columns
  std::vector<Link> links;
  std::vector<Matrix6> composite;  // mass matrix: the composite inertia of K's subtree about O_K
  VectorX joint_force;             // Q of the force elements on joint coordinates
  // [S_K] about O_K, and about the inertial origin (mass matrix): 6 doubles a speed.
  std::vector<double> S, S0;
  detail::JointMotion motion;
  // The notes' state, its kinematics and loads: only for a model with loads on bodies, whose
  // force elements read them.
  std::optional<Data> data;
  std::optional<State> state;
  std::vector<detail::JointMotion> motions;  // the joint tables joint_state computed with it
  bool loads_read_positions = false;
  bool body_loads = false;  // whether the last own_loads() filled data->loads
  Vector6 ground = Vector6::Zero();

  detail::BodyMap body_map(int k) const {
    return {links[at(k)].r, types[at(k)] != JointType::free};
  }
  void outward(const VectorX& q);
  void own_loads(const VectorX& q, const VectorX& z, const VectorX* u);
  void newton_euler(const VectorX& q, const VectorX* z, const VectorX* zdot,
                    Eigen::Ref<VectorX> tau);
  void subtree_masses();
};

// [R_K], r_K, O_K and [S_K] of every body at q.
void Terms::Impl::outward(const VectorX& q) {
  const int n = model.num_bodies();
  for (int k = 0; k < n; ++k) {
    const auto i = at(k);
    const int j = lower[i];
    const bool root = j == kGround;
    const JointType type = types[i];
    const int off = offset[i];
    detail::joint_motion(model, k, q, nullptr, motion);
    Link& l = links[i];
    const Matrix3& rj = root ? kIdentity3 : links[at(j)].R;
    if (type == JointType::free)
      l.R = rotation_matrix(q.segment<4>(model.coordinate_offset(k)));
    else if (root)
      l.R = rotation_matrix(motion.rel);
    else
      l.R.noalias() = rotation_matrix(motion.rel) * rj;
    l.r.noalias() = rj.transpose() * (model.body(k).joint + motion.slide);
    l.p = root ? l.r : Vector3(links[at(j)].p + l.r);
    if (speeds[i] > 0)
      detail::motion_subspace(type, speeds[i], l.R, rj, motion.G, translation[i], slides[i],
                              S.data() + 6 * off);
  }
}

// The model's own loads at (q, z), in one place: the generalized forces of the force elements
// on joint coordinates into joint_force, and either the per-body resultants of gravity and the
// force elements on bodies (compute_resultants at the notes' state, into data->loads) or, with
// no element on a body, gravity alone as the ground's acceleration -g (docs/theory.md: a
// uniform -g on every A_K shifts [I_O,K] A_K by minus K's weight about O_K).
void Terms::Impl::own_loads(const VectorX& q, const VectorX& z, const VectorX* u) {
  // The inputs' loads come with the elements': on bodies through the resultants (Data::inputs),
  // on joint coordinates into joint_force.
  if (u && u->size() != model.num_inputs())
    throw std::invalid_argument("inputs: " + std::to_string(u->size()) + " values for " +
                                std::to_string(model.num_inputs()) + " inputs");
  joint_force.setZero();
  if (model.has_joint_force_elements()) add_joint_forces(model, q, z, joint_force);
  if (u && model.num_inputs() > 0) add_input_joint_forces(model, *u, joint_force);
  body_loads = model.has_body_force_elements() || (u && model.has_body_inputs());
  if (body_loads) {
    if (model.num_inputs() > 0) {
      if (u)
        data->inputs = *u;
      else
        data->inputs.setZero();
    }
    detail::joint_state(model, q, z, *state, &motions);
    if (loads_read_positions)
      compute_kinematics(model, *state, *data);
    else
      compute_rotations(model, *state, *data);
    compute_resultants(model, *state, *data);
  }
  ground.setZero();
  if (!body_loads) ground.tail<3>() = -model.gravity();
}

// Newton-Euler over the joints, after own_loads() (or with body_loads false and ground set):
// outward, body K's [R_K], r_K, w_K, [S_K] and c_K as in outward() (from the joint tables and
// [R_K] of the notes' state when the loads computed it), A_K = [P_K] A_J + [S_K] z dot_K + c_K
// (A_J = ground for a root; z dot = 0 when null; w = 0 and c = 0 when z is null) and the force
// K needs about O_K, f_K = [I_O,K] A_K + b_K - F_ext,K; inward, f_J += [P_K]^T f_K and
// tau_K = [S_K]^T f_K: the generalized inertia forces minus the active forces of z_K (Eqs.
// 31-35 projected), the joint reactions absent ([C]^T {F_c} = 0).
void Terms::Impl::newton_euler(const VectorX& q, const VectorX* z, const VectorX* zdot,
                               Eigen::Ref<VectorX> tau) {
  const int n = model.num_bodies();
  for (int k = 0; k < n; ++k) {
    const auto i = at(k);
    const int j = lower[i];
    const bool root = j == kGround;
    const JointType type = types[i];
    const int off = offset[i];
    const int m = speeds[i];
    if (!body_loads) detail::joint_motion(model, k, q, z ? z->data() + off : nullptr, motion);
    const detail::JointMotion& jm = body_loads ? motions[i] : motion;
    Link& l = links[i];
    const Link* lj = root ? nullptr : &links[at(j)];
    const Matrix3& rj = root ? kIdentity3 : lj->R;
    if (body_loads)
      l.R = data->kinematics.R[i];
    else if (type == JointType::free)
      l.R = rotation_matrix(q.segment<4>(model.coordinate_offset(k)));
    else if (root)
      l.R = rotation_matrix(jm.rel);
    else
      l.R.noalias() = rotation_matrix(jm.rel) * rj;
    const Matrix3& rk = l.R;
    l.r.noalias() = rj.transpose() * (model.body(k).joint + jm.slide);
    double* s = S.data() + 6 * off;
    if (m > 0) detail::motion_subspace(type, m, rk, rj, jm.G, translation[i], slides[i], s);
    // A_K = [P_K] A_J + c_K + [S_K] z dot_K.
    const Vector6& a_j = root ? ground : lj->A;
    l.A.head<3>() = type == JointType::free ? Vector3::Zero() : Vector3(a_j.head<3>());
    l.A.tail<3>() = a_j.tail<3>() + a_j.head<3>().cross(l.r);
    if (z) {
      const Vector3 w_j = root ? Vector3::Zero() : lj->w;
      l.w.noalias() = rk.transpose() * jm.w_rel;
      if (type != JointType::free) l.w += w_j;
      detail::velocity_product_acceleration(type, root, l.w, w_j, rk, rj, jm, l.r, l.c);
      l.A += l.c;
    }
    if (zdot)
      for (int col = 0; col < m; ++col) {
        const double rate = (*zdot)[off + col];
        for (int e = 0; e < 6; ++e) l.A[e] += rate * s[6 * col + e];
      }
    // [I_O] A + b written out, with c = G_K - O_K: F = m a_G, a_G = a_O + alpha x c +
    // w x (w x c) (Eq. 17 differentiated), and the moment about O_K [I_G] alpha + w x [I_G] w
    // + c x F, its first two terms Euler's in body-K axes, where [I'_G] is given.
    const BodySpec& body = model.body(k);
    const Vector3 cg = rk.transpose() * body.com;
    const Vector3 alpha = l.A.head<3>();
    Vector3 a_g = l.A.tail<3>() + alpha.cross(cg);
    Vector3 euler = body.inertia * (rk * alpha);
    if (z) {
      a_g += eq::eigen(eq::centripetal_acceleration(eq::vec(l.w), eq::vec(cg)));
      const Vector3 w_b = rk * l.w;
      euler += w_b.cross(body.inertia * w_b);
    }
    if (body_loads) euler -= data->loads.moment_b[i];
    Vector3 moment = rk.transpose() * euler;
    Vector3 force = body.mass * a_g;
    if (body_loads) force -= data->loads.force[i];
    moment += cg.cross(force);
    l.f.head<3>() = moment;
    l.f.tail<3>() = force;
  }
  for (int k = n - 1; k >= 0; --k) {
    const auto i = at(k);
    const Link& l = links[i];
    const double* s = S.data() + 6 * offset[i];
    for (int col = 0; col < speeds[i]; ++col) {
      double sum = 0.0;
      for (int e = 0; e < 6; ++e) sum += s[6 * col + e] * l.f[e];
      tau[offset[i] + col] = sum;
    }
    if (lower[i] != kGround) {
      Vector6& f = links[at(lower[i])].f;
      f.head<3>() += l.r.cross(l.f.tail<3>());
      if (types[i] != JointType::free) f.head<3>() += l.f.head<3>();
      f.tail<3>() += l.f.tail<3>();
    }
  }
}

Terms::Terms(const Model& model) : impl_(std::make_unique<Impl>(model)) {}
Terms::Terms(const Terms& other) : impl_(std::make_unique<Impl>(*other.impl_)) {}
Terms::~Terms() = default;
const Model& Terms::model() const { return impl_->model; }

void Terms::inverse_dynamics(const VectorX& q, const VectorX& z, const VectorX& zdot,
                             Eigen::Ref<VectorX> Q, const VectorX* u) {
  Impl& s = *impl_;
  s.own_loads(q, z, u);
  s.newton_euler(q, &z, &zdot, Q);
  Q -= s.joint_force;
}

void Terms::bias_forces(const VectorX& q, const VectorX& z, Eigen::Ref<VectorX> b,
                        const VectorX* u) {
  Impl& s = *impl_;
  s.own_loads(q, z, u);
  s.newton_euler(q, &z, nullptr, b);
  b -= s.joint_force;
}

void Terms::gravity_forces(const VectorX& q, Eigen::Ref<VectorX> g) {
  Impl& s = *impl_;
  s.body_loads = false;
  s.ground.setZero();
  s.ground.tail<3>() = -s.model.gravity();
  s.newton_euler(q, nullptr, nullptr, g);
}

// Block (c, d) of M for d on c's chain is (dV/dz_d)^T IC_c [S_c] carried down the chain
// (docs/theory.md). About the inertial origin a force does not change as it is carried
// through a joint that keeps the angular velocity ([P]^T only moves the point it is taken
// about), so F0 = IC_c [S_c] about the origin meets every [S_d] about the origin, S0, as it
// is: one 6-product per pair of speeds. A free body e on the way keeps only the force, through
// O_e: its w'_e is its own speed, so the joints below it move its subtree only by translating
// O_e ([P_e]^T drops the moment).
void Terms::mass_matrix(const VectorX& q, Eigen::Ref<MatrixX> M) {
  Impl& s = *impl_;
  s.outward(q);
  const Model& model = s.model;
  const int n = model.num_bodies();
  for (int k = 0; k < n; ++k) {
    const Link& l = s.links[at(k)];
    const BodySpec& body = model.body(k);
    detail::spatial_inertia(body.mass, l.R.transpose() * body.com,
                            detail::inertial_axes(body.inertia, l.R), s.composite[at(k)]);
    // (w, v_O) about O_K is (w, v_O + p x w) about the origin.
    for (int col = s.offset[at(k)]; col < s.offset[at(k)] + s.speeds[at(k)]; ++col) {
      const double* from = s.S.data() + 6 * col;
      double* to = s.S0.data() + 6 * col;
      const Vector3 w(from[0], from[1], from[2]);
      const Vector3 v = Vector3(from[3], from[4], from[5]) + l.p.cross(w);
      for (int e = 0; e < 3; ++e) {
        to[e] = w[e];
        to[3 + e] = v[e];
      }
    }
  }
  M.setZero();
  Block force;
  for (int k = n - 1; k >= 0; --k) {
    const auto i = at(k);
    const int m = s.speeds[i];
    const int j = s.lower[i];
    const Matrix6& ic = s.composite[i];
    if (m > 0) {
      const int oc = s.offset[i];
      const Eigen::Map<const Eigen::Matrix<double, 6, Eigen::Dynamic>> sc(s.S.data() + 6 * oc, 6,
                                                                          m);
      force.resize(6, m);
      force.noalias() = ic.lazyProduct(sc);
      for (int a = 0; a < m; ++a)
        for (int b = a; b < m; ++b)
          M(oc + a, oc + b) = M(oc + b, oc + a) = sc.col(a).dot(force.col(b));
      const Vector3& p = s.links[i].p;
      for (int col = 0; col < m; ++col)
        force.col(col).head<3>() += p.cross(force.col(col).tail<3>());
      for (int e = k, d = j; d != kGround; e = d, d = s.lower[at(d)]) {
        if (s.types[at(e)] == JointType::free) {
          const Vector3& pe = s.links[at(e)].p;
          for (int col = 0; col < m; ++col)
            force.col(col).head<3>() = pe.cross(force.col(col).tail<3>());
        }
        const int md = s.speeds[at(d)];
        const int od = s.offset[at(d)];
        const double* sd = s.S0.data() + 6 * od;
        for (int a = 0; a < m; ++a) {
          const double* f = force.data() + 6 * a;
          for (int b = 0; b < md; ++b) {
            const double* t = sd + 6 * b;
            const double v =
                f[0] * t[0] + f[1] * t[1] + f[2] * t[2] + f[3] * t[3] + f[4] * t[4] + f[5] * t[5];
            M(oc + a, od + b) = v;
            M(od + b, oc + a) = v;
          }
        }
      }
    }
    if (j != kGround) detail::add_carried_inertia(s.body_map(k), ic, s.composite[at(j)]);
  }
}

// Per body the mass of its subtree and h, its first moment about O_K, carried inwards as a
// force is: h_J += a h_K + m_K r_K (a = 0 across a free body, whose subtree the joints below
// it only translate, with O_K). The column of a speed with [S] column (s_w; s_v) is then
// (m_c s_v + s_w x h_c) / m: sum over B of m_B (s_v + s_w x (G_B - O_c)).
void Terms::Impl::subtree_masses() {
  const int n = model.num_bodies();
  for (int k = 0; k < n; ++k) {
    Link& l = links[at(k)];
    l.mass = model.body(k).mass;
    l.h = l.mass * (l.R.transpose() * model.body(k).com);
  }
  for (int k = n - 1; k >= 0; --k) {
    const Link& l = links[at(k)];
    const int j = lower[at(k)];
    if (j == kGround) continue;
    Link& lj = links[at(j)];
    lj.mass += l.mass;
    lj.h += l.mass * l.r;
    if (types[at(k)] != JointType::free) lj.h += l.h;
  }
}

Vector3 Terms::centre_of_mass(const VectorX& q) {
  Impl& s = *impl_;
  s.outward(q);
  Vector3 moment = Vector3::Zero();
  for (int k = 0; k < s.model.num_bodies(); ++k) {
    const Link& l = s.links[at(k)];
    const BodySpec& body = s.model.body(k);
    moment += body.mass * (l.p + l.R.transpose() * body.com);
  }
  return moment / s.model.total_mass();
}

void Terms::centre_of_mass_jacobian(const VectorX& q, Eigen::Ref<MatrixX> J) {
  Impl& s = *impl_;
  s.outward(q);
  s.subtree_masses();
  const double total = s.model.total_mass();
  for (int k = 0; k < s.model.num_bodies(); ++k) {
    const Link& l = s.links[at(k)];
    for (int col = s.offset[at(k)]; col < s.offset[at(k)] + s.speeds[at(k)]; ++col) {
      const double* sc = s.S.data() + 6 * col;
      const Vector3 sw(sc[0], sc[1], sc[2]), sv(sc[3], sc[4], sc[5]);
      J.col(col) = (l.mass * sv + sw.cross(l.h)) / total;
    }
  }
}

Vector3 Terms::centre_of_mass_velocity(const VectorX& q, const VectorX& z) {
  Impl& s = *impl_;
  s.outward(q);
  s.subtree_masses();
  Vector3 momentum = Vector3::Zero();
  for (int k = 0; k < s.model.num_bodies(); ++k) {
    const Link& l = s.links[at(k)];
    for (int col = s.offset[at(k)]; col < s.offset[at(k)] + s.speeds[at(k)]; ++col) {
      const double* sc = s.S.data() + 6 * col;
      const Vector3 sw(sc[0], sc[1], sc[2]), sv(sc[3], sc[4], sc[5]);
      momentum += z[col] * (l.mass * sv + sw.cross(l.h));
    }
  }
  return momentum / s.model.total_mass();
}

}  // namespace kanedyn
