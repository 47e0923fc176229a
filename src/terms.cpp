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

// Body K's terms of the inverse dynamics, in body-K axes about O_K: the recursion needs only
// [R(rel)] = [R_K][R_J]^T between neighbours, not [R_K].
struct LocalLink {
  Matrix3 E;  // [R_K][R_J]^T: body-J components to body-K components
  Vector3 r;  // q'_K + s'_K, body-J components
  Vector3 w;  // w'_K
  Vector6 A;  // (alpha'_K, a_O_K), body-K components
  Vector6 f;  // the force (moment about O_K; force) K needs, then its subtree's, body-K axes
  Matrix3 R;  // [R_K], kept only where a free body below another body needs it
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
    local.resize(at(n));
    composite.resize(at(n));
    for (int k = 0; k < n; ++k) {
      const JointType type = m.joint(k).type;
      lower.push_back(m.lower_body(k));
      types.push_back(type);
      speeds.push_back(speed_count(type));
      offset.push_back(m.speed_offset(k));
      translation.push_back(joint_translation_block(m, k));  // [0 I] for a free body
      slides.push_back(detail::slide_columns(translation.back(), speeds.back()));
      absolute_rotations =
          absolute_rotations || (type == JointType::free && m.lower_body(k) != kGround);
    }
    motions.resize(at(n));
    if (m.has_body_force_elements() || m.has_body_inputs()) {
      data.emplace(m, DataOptions::recursive_only());
      state.emplace(m);
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
  std::vector<LocalLink> local;
  // A free body below another body: [R(rel)] = [R(eps_K)][R_J]^T needs [R_J], so [R_K] is
  // carried outward (without body loads, which bring it with the notes' kinematics).
  bool absolute_rotations = false;
  detail::JointMotion motion;
  // The notes' state, its kinematics and loads: only for a model with loads on bodies, whose
  // force elements read them.
  std::optional<Data> data;
  std::optional<State> state;
  // The joint tables at (q, z): joint_state's with the notes' state, else newton_euler's.
  std::vector<detail::JointMotion> motions;
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
                                std::to_string(model.num_inputs()) +
                                (model.num_inputs() == 1 ? " input" : " inputs"));
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

// Newton-Euler over the joints, after own_loads() (or with body_loads false and ground set), in
// body-K axes about O_K: the same equations as in inertial axes (docs/theory.md), but each body
// needs only E = [R(rel)] = [R_K][R_J]^T, where inertial axes need [R_K] = E [R_J] and [R_K]^T
// on every vector. With r = q'_K + s'_K and sd = s'_K dot (body-J components), w_rel = [G_K] z_K
// (body-K components) and a = 0 for a free body (its w'_K is its own speed), else 1, outward:
//   w'_K     = a E w'_J + w_rel
//   alpha'_K = a E alpha'_J + w'_K x w_rel + [G_K dot] z_K + [G_K] z dot_K
//   a_O_K    = E (a_O_J + alpha'_J x r + 2 w'_J x sd + w'_J x (w'_J x r) + [T_K] z dot_K)
// (Eqs. 28 and 30; A_J = the ground's acceleration for a root, z dot = 0 when null, w' = 0
// when z is null), and the force K needs about O_K, F = m a_G - F_K with a_G = a_O + alpha' x r'
// + w' x (w' x r') (Eq. 17 differentiated), n = [I'_G] alpha' + w' x [I'_G] w' - M'_K + r' x F
// (Euler's equation about G_K, moved to O_K). Inward, K = N..1: tau_K = [S_K]^T f_K, its
// angular half [G_K]^T n and its linear half [T_K]^T (E^T F) in body-J components, and f_J +=
// [P_K]^T f_K, (a E^T n + r x E^T F; E^T F) about O_J in body-J axes: the generalized inertia
// forces minus the active forces of z_K (Eqs. 31-35 projected), the joint reactions absent
// ([C]^T {F_c} = 0).
void Terms::Impl::newton_euler(const VectorX& q, const VectorX* z, const VectorX* zdot,
                               Eigen::Ref<VectorX> tau) {
  const int n = model.num_bodies();
  const bool carry_r = absolute_rotations && !body_loads;
  for (int k = 0; k < n; ++k) {
    const auto i = at(k);
    const int j = lower[i];
    const bool root = j == kGround;
    const JointType type = types[i];
    const bool is_free = type == JointType::free;
    const int off = offset[i];
    const int m = speeds[i];
    detail::JointMotion& jm = motions[i];
    if (!body_loads) detail::joint_motion(model, k, q, z ? z->data() + off : nullptr, jm);
    LocalLink& l = local[i];
    const LocalLink* lj = root ? nullptr : &local[at(j)];
    // E: a free body's joint table holds its frame, not its rotation relative to J.
    if (!is_free) {
      l.E = eq::eigen(eq::rotation_matrix(eq::euler(jm.rel)));  // Eqs. (3)-(4)
    } else if (body_loads) {
      l.E = data->kinematics.R[i];
      if (!root) l.E *= data->kinematics.R[at(j)].transpose();
    } else {
      l.E = rotation_matrix(q.segment<4>(model.coordinate_offset(k)));
      if (!root) l.E *= lj->R.transpose();
    }
    if (carry_r) {
      if (root)
        l.R = l.E;
      else
        l.R.noalias() = l.E * lj->R;
    }
    l.r = model.body(k).joint + jm.slide;
    // w'_K: the notes' state has it when the loads computed it.
    if (body_loads) {
      l.w = state->angular_velocity(k);
    } else if (z) {
      l.w = jm.w_rel;
      if (!is_free && !root) l.w.noalias() += l.E * lj->w;
    } else {
      l.w.setZero();
    }
    // J's terms in body-J components, turned into K's axes by one product with E: alpha'_J and
    // the acceleration of O_K (as a point of J, and its slide).
    const Vector6& a_j = root ? ground : lj->A;
    Eigen::Matrix<double, 3, 2> from_j;
    from_j.col(0) = a_j.head<3>();
    from_j.col(1) = a_j.tail<3>() + a_j.head<3>().cross(l.r);
    if (z && !root) {
      const Vector3& w_j = lj->w;
      if (slides[i] != 0)
        from_j.col(1) += eq::eigen(
            eq::transport_acceleration(eq::vec(w_j), eq::vec(jm.slide_rate), eq::vec(l.r)));
      else  // sd = 0
        from_j.col(1) += eq::eigen(eq::centripetal_acceleration(eq::vec(w_j), eq::vec(l.r)));
    }
    Vector3 alpha = Vector3::Zero();
    if (zdot)  // [G_K] z dot_K, and [T_K] z dot_K (a free body's [T_K] = [0 I])
      for (int col = 0; col < m; ++col) {
        const double rate = (*zdot)[off + col];
        alpha += rate * jm.G.col(col);
        if (slides[i] & (1u << col)) from_j.col(1) += rate * translation[i].col(col);
      }
    Eigen::Matrix<double, 3, 2> in_k;
    in_k.noalias() = l.E * from_j;
    l.A.tail<3>() = in_k.col(1);
    if (!is_free) {
      alpha += in_k.col(0);
      if (z) {
        alpha += l.w.cross(jm.w_rel);
        if (joint_type_info(type).turning_axis) alpha += jm.g_dot_z;
      }
    }
    l.A.head<3>() = alpha;
    const BodySpec& body = model.body(k);
    Vector3 a_g = l.A.tail<3>() + alpha.cross(body.com);
    Eigen::Matrix<double, 3, 2> aw;  // alpha' and w', then [I'_G] times them
    aw.col(0) = alpha;
    aw.col(1) = l.w;
    const Eigen::Matrix<double, 3, 2> i_aw = body.inertia * aw;
    Vector3 moment = i_aw.col(0);
    if (z) {
      a_g += eq::eigen(eq::centripetal_acceleration(eq::vec(l.w), eq::vec(body.com)));
      moment += l.w.cross(i_aw.col(1));
    }
    Vector3 force = body.mass * a_g;
    if (body_loads) {
      force.noalias() -= data->kinematics.R[i] * data->loads.force[i];
      moment -= data->loads.moment_b[i];
    }
    moment += body.com.cross(force);
    l.f.head<3>() = moment;
    l.f.tail<3>() = force;
  }
  for (int k = n - 1; k >= 0; --k) {
    const auto i = at(k);
    const LocalLink& l = local[i];
    // (F, n) turned into J's axes by one product with E^T.
    const Eigen::Map<const Eigen::Matrix<double, 3, 2>> nf(l.f.data());
    Eigen::Matrix<double, 3, 2> in_j;
    in_j.noalias() = l.E.transpose() * nf;
    const auto moment_j = in_j.col(0);
    const auto force_j = in_j.col(1);
    const detail::JointMotion& jm = motions[i];
    for (int col = 0; col < speeds[i]; ++col) {
      double sum = jm.G.col(col).dot(l.f.head<3>());
      if (slides[i] & (1u << col)) sum += translation[i].col(col).dot(force_j);
      tau[offset[i] + col] = sum;
    }
    if (lower[i] != kGround) {
      Vector6& f = local[at(lower[i])].f;
      f.head<3>() += l.r.cross(force_j);
      if (types[i] != JointType::free) f.head<3>() += moment_j;
      f.tail<3>() += force_j;
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
