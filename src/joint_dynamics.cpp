// Forward dynamics of a jointed tree by two routes (docs/theory.md, "Forward dynamics of a jointed
// tree: the two routes"): an articulated-body recursion (Route::recursive, O(N)) and the projected
// Kane equations [C]^T [A] [C] {z dot} = [C]^T ({f} - [A][C dot]{z}) + Q assembled by joint blocks
// and solved by a tree-ordered LDL^T of variable block size (Route::assembled). Both work with each
// body's velocity V_K = (w_K, v_O_K) in inertial components about its own O_K and the map of
// Eqs. (14)-(15) and joint_state,
//   V_K = [P_K] V_J + [S_K] z_K,
// from which every partial velocity with respect to z is a product of [P]s and one [S]:
// [S_K] = ([R_K]^T [G_K]; [R_J]^T [T_K]) is the joint's motion subspace, made of the same [G_c]
// and s_block as ConstraintMatrix. With force elements the per-body loads come from
// compute_resultants, at the state joint_state gives, with the kinematics of compute_kinematics;
// without them gravity is the ground's acceleration and that state is computed only when asked.
#include "joint_dynamics.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

#include "kanedyn/forces.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/rotation.hpp"

#include "equations.hpp"
#include "joint_motion.hpp"
#include "joint_table.hpp"
#include "spatial.hpp"
#include "spd.hpp"
#include "tree_ldlt.hpp"

namespace kanedyn::detail {

namespace {

size_t at(int i) { return static_cast<size_t>(i); }

// [R_J] of the ground, for a root's joint.
const Matrix3 kIdentity3 = Matrix3::Identity();

// 6 x (speeds of one joint): fixed storage, no heap.
using Block = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, 6>;

using detail::Subspace;  // the shape of [S_K], from the joint table

// Body K's terms of the recursions, in inertial components about O_K (docs/theory.md).
struct Link {
  Matrix6 IA;  // [I_O,K], then the articulated (recursive; a free body's inverted) or composite
               // (assembled) inertia
  Matrix3 R;   // [R_K]
  Vector3 r;   // O_K - O_J = [R_J]^T (q'_K + s'_K)
  Vector3 w;   // w_K = [R_K]^T w'_K
  Vector6 c;   // the acceleration of V_K at z dot = 0 and A_J = 0
  Vector6 p;   // b_K - F_ext,K, then the force passed inwards
  Vector6 A;   // the acceleration of V_K
};

}  // namespace

struct JointDynamics::Impl {
  explicit Impl(const Model& m)
      : model(m),
        data(m, DataOptions::recursive_only()),
        state(m),
        q(VectorX::Zero(m.num_coordinates())),
        z(VectorX::Zero(m.num_speeds())),
        qdot(VectorX::Zero(m.num_coordinates())),
        q_seen(q),
        z_seen(z),
        joint_force(VectorX::Zero(m.num_speeds())),
        u(VectorX::Zero(m.num_speeds())) {
    const Model& t = m;
    const int n = m.num_bodies();
    speeds.assign(at(n), 0);
    offset.assign(at(n), 0);
    joint_type.assign(at(n), JointType::free);
    links.resize(at(n));
    path.reserve(at(n));
    if (m.has_body_force_elements() || m.has_body_inputs()) motions.resize(at(n));
    joint_forces = m.has_joint_force_elements() || m.num_inputs() > 0;
    for (const auto& element : m.forces())
      loads_read_positions = loads_read_positions || element->reads_positions();
    translation.assign(at(n), Matrix36::Zero());
    translation_columns.assign(at(n), 0u);
    for (int k = 0; k < n; ++k) {
      const auto i = at(k);
      speeds[i] = speed_count(t.joint(k).type);
      offset[i] = t.speed_offset(k);
      joint_type[i] = t.joint(k).type;
      // A free body's [T_K] = [0 I] is applied as [R_J]^T (prepare), the others' nonzero
      // columns one by one.
      if (joint_type[i] == JointType::free) continue;
      translation[i] = joint_translation_block(t, k);
      translation_columns[i] = slide_columns(translation[i], speeds[i]);
    }
    S.assign(6 * at(t.num_speeds()), 0.0);
    U = S;
    int doubles = 0;
    d_offset.assign(at(n), 0);
    for (int k = 0; k < n; ++k) {
      d_offset[at(k)] = doubles;
      const int w = speeds[at(k)];
      if (w < 6) doubles += w * w;  // a free joint needs no D^-1 (recursive_inward)
    }
    D_inv.assign(at(doubles), 0.0);
  }

  const Model& model;
  Data data;
  State state;
  VectorX q, z, qdot;      // derivative()'s (q; z) and q dot
  VectorX q_seen, z_seen;  // the (q, z) of the last evaluate(), for state() and data()
  bool state_current = true;
  // data.kinematics holds the positions and velocities of the state too (not only R), and
  // whether the force elements need them in every evaluation (ForceElement::reads_positions).
  bool kinematics_complete = true;
  bool loads_read_positions = false;
  VectorX joint_force;  // Q of the force elements on joint coordinates, in the order of z
  // Whether joint_force can be nonzero (joint force elements or inputs).
  bool joint_forces = false;
  VectorX u;  // recursive: Q_K - [S_K]^T p_K per joint
  // The acceleration of the ground: -g when gravity enters as the ground's acceleration (no
  // force element), zero when compute_resultants supplies it with the other loads.
  Vector6 ground = Vector6::Zero();
  // Per body: the joint's speed count, speed offset and type (constant).
  std::vector<int> speeds, offset;
  std::vector<JointType> joint_type;
  // Per body: [T_K] (joint_translation_block, constant, J components) and the mask of its
  // nonzero columns (none for a free body, handled apart).
  std::vector<Matrix36> translation;
  std::vector<unsigned> translation_columns;
  std::vector<Link> links;
  // The joint tables at (q, z): of all bodies when the state is computed with them (force
  // elements), else one body's at a time.
  std::vector<detail::JointMotion> motions;
  detail::JointMotion scratch_motion;
  // Pools by speed: [S_K] and [U_K] = IA_K [S_K] in inertial components, 6 doubles a column,
  // at 6 speed_offset(K); D_K^-1 (speed_count^2 doubles at d_offset[K]). A spherical joint's
  // U, D^-1 and u are those of ([I]; 0) (recursive_inward).
  std::vector<double> S, U, D_inv;
  std::vector<int> d_offset;
  // The assembled route's blocks of [C]^T [A] [C] and their factor, made on its first use.
  std::optional<TreeLdlt> ldlt;
  // solve_mass: whether the last evaluation left the articulated-body factorization, and per
  // body 6 x c blocks of the forces passed inwards and of the accelerations (body k's at 6 c k),
  // and c flags of whether its subtree passes it a nonzero force (body k's at c k).
  bool factored = false;
  std::vector<double> column_force, column_acceleration;
  std::vector<char> column_loaded;
  const Matrix3 identity3 = Matrix3::Identity();  // [R_J] of the ground

  void update_state(std::vector<detail::JointMotion>* tables = nullptr, bool complete = true);
  void complete_kinematics();
  void prepare(const VectorX& qq, const VectorX& zz, bool dynamics = true);
  std::vector<int> path;  // body_motion's chain, root first
  void recursive(Eigen::Ref<VectorX> zdot);
  void assembled(Eigen::Ref<VectorX> zdot);
  BodyMap body_map(int k) const { return {links[at(k)].r, joint_type[at(k)] != JointType::free}; }
  // A'_K = [P_K] A_J + c_K, A_J the ground's for a root. Inlined by force into the outward
  // pass (the compiler stopped inlining it when [P_K] moved to src/spatial.hpp).
  [[gnu::always_inline]] Vector6 carried_acceleration(int k) const {
    const Link& l = links[at(k)];
    const int j = model.lower_body(k);
    return l.c + map_velocity(body_map(k), j == kGround ? ground : links[at(j)].A);
  }
  // IA_J += [P_K]^T IA_K [P_K], p_J += [P_K]^T p_K.
  void pass_inward(int k) {
    const Link& l = links[at(k)];
    Link& lower = links[at(model.lower_body(k))];
    const BodyMap map = body_map(k);
    add_carried_inertia(map, l.IA, lower.IA);
    lower.p += carry_force(map, l.p);
  }
  template <int M, Subspace Shape>
  void recursive_inward(int k);
  template <int M, Subspace Shape>
  void recursive_outward(int k, Eigen::Ref<VectorX> zdot);
  template <int M, Subspace Shape>
  void solve_inward(int k, Eigen::Ref<MatrixX> x);
  template <int M, Subspace Shape>
  void solve_outward(int k, Eigen::Ref<MatrixX> x);
  // Body k's [S_K], [U_K] and D_K^-1 (M speeds), copied: the column passes store into x and
  // their columns, which the compiler must assume could alias the pools.
  template <int M>
  struct JointFactor {
    Eigen::Matrix<double, 6, M> s, u;
    Eigen::Matrix<double, M, M> d_inv;
  };
  template <int M>
  JointFactor<M> joint_factor(int k) const {
    const int off = offset[at(k)];
    return {Eigen::Map<const Eigen::Matrix<double, 6, M>>(S.data() + 6 * off),
            Eigen::Map<const Eigen::Matrix<double, 6, M>>(U.data() + 6 * off),
            Eigen::Map<const Eigen::Matrix<double, M, M>>(D_inv.data() + d_offset[at(k)])};
  }
  template <int L, int A>
  void point_rows(int k, Vector3 origin, const Vector3& point, double sign,
                  const RowDirections& directions, Eigen::Ref<MatrixX> rows_t, int first);
  // solve_mass's checks and inward pass (`caller` names the public function in errors).
  void solve_mass_inward(Eigen::Ref<MatrixX> x, const char* caller);
};

// The notes' state at the last (q, z), its kinematics (only [R_K] when not complete: the
// positions and velocities follow in complete_kinematics) and its loads (and each body's joint
// table into tables when not null).
void JointDynamics::Impl::update_state(std::vector<detail::JointMotion>* tables, bool complete) {
  detail::joint_state(model, q_seen, z_seen, state, tables);
  if (complete)
    compute_kinematics(model, state, data);
  else
    compute_rotations(model, state, data);
  compute_resultants(model, state, data);
  state_current = true;
  kinematics_complete = complete;
}

// The rest of compute_kinematics after update_state(..., false): the same functions in the
// same order, so the same bits as computing them at once.
void JointDynamics::Impl::complete_kinematics() {
  compute_positions(model, state, data);
  compute_velocities(model, state, data);
  kinematics_complete = true;
}

// Per body [P_K], [S_K], c_K and p_K = b_K - F_ext,K in inertial components about O_K, and
// the joint loads' Q. The notes' state is computed here only when force elements need it.
// With dynamics false, the kinematic terms only ([R_K], w_K, r_K, [S_K], c_K).
void JointDynamics::Impl::prepare(const VectorX& qq, const VectorX& zz, bool dynamics) {
  if (dynamics) {
    joint_force.setZero();
    add_joint_forces(model, qq, zz, joint_force);
    if (model.num_inputs() > 0) add_input_joint_forces(model, data.inputs, joint_force);
  }
  q_seen = qq;
  z_seen = zz;
  const bool loads = dynamics && (model.has_body_force_elements() || model.has_body_inputs());
  if (loads)  // the joint tables come with the state, [R_K] with its kinematics
    update_state(&motions, loads_read_positions);
  else
    state_current = false;
  ground.tail<3>() = loads ? Vector3::Zero() : Vector3(-model.gravity());
  const int n = model.num_bodies();
  for (int k = 0; k < n; ++k) {
    const auto i = at(k);
    const int j = model.lower_body(k);
    const bool root = j == kGround;
    const JointType type = joint_type[i];
    const bool is_free = type == JointType::free;
    const int off = offset[i];
    if (!loads) detail::joint_motion(model, k, qq, zz.data() + off, scratch_motion);
    const detail::JointMotion& jm = loads ? motions[i] : scratch_motion;
    Link& l = links[i];
    const Matrix3& rj = root ? kIdentity3 : links[at(j)].R;
    // [R_K]: the free body's own Euler parameters, else [R(rel)] [R_J].
    if (loads)
      l.R = data.kinematics.R[i];
    else if (is_free)
      l.R = rotation_matrix(qq.segment<4>(model.coordinate_offset(k)));
    else if (root)
      l.R = rotation_matrix(jm.rel);
    else
      l.R.noalias() = rotation_matrix(jm.rel) * rj;
    const Matrix3& rk = l.R;
    // Eqs. (14)-(15) in inertial components: w_K = a w_J + [R_K]^T [G_K] z_K (a = 0 for a free
    // body, whose w'_K is z_K itself) and v_O,K = v_O,J + w_J x r + [R_J]^T [T_K] z_K, with
    // r = [R_J]^T (q'_K + s'_K). The coefficients of z_K are the columns of [S_K].
    const Vector3 w_j = root ? Vector3::Zero() : links[at(j)].w;
    l.w.noalias() = rk.transpose() * jm.w_rel;
    if (!is_free) l.w += w_j;
    l.r.noalias() = rj.transpose() * (model.body(k).joint + jm.slide);
    if (speeds[i] > 0)
      motion_subspace(type, speeds[i], rk, rj, jm.G, translation[i], translation_columns[i],
                      S.data() + 6 * off);
    velocity_product_acceleration(type, root, l.w, w_j, rk, rj, jm, l.r, l.c);
    if (!dynamics) continue;
    // Newton-Euler about O_K in inertial components, with A = d/dt V (a_O the acceleration of
    // the material point O_K): [I_O] A + b is the force needed, b = (w x [I_G] w + m c x
    // (w x (w x c)), m w x (w x c)), c = [R_K]^T r'_K. The external force about O_K is
    // ([R_K]^T M'_K + c x F_K, F_K): every force element and gravity, or, with no force
    // element, nothing, gravity being the ground's acceleration -g: a uniform -g on every A
    // shifts [I_O] A by -(c x m g, m g), the weight about O_K.
    // The terms of Newton-Euler are the notes' (src/equations.inc), in inertial components.
    const BodySpec& body = model.body(k);
    const eq::Mat3<double> r_k = eq::mat(rk);
    const eq::Vec3<double> w = eq::vec(l.w);
    const eq::Vec3<double> cg = eq::transpose_times(r_k, eq::vec(body.com));
    const Matrix3 inertia_g = inertial_axes(body.inertia, rk);
    const eq::Vec3<double> wwc = eq::centripetal_acceleration(w, cg);
    spatial_inertia(body.mass, eq::eigen(cg), inertia_g, l.IA);
    eq::store(l.p.data(),
              eq::gyroscopic_moment(eq::sym(inertia_g), w) + body.mass * eq::cross(cg, wwc));
    eq::store(l.p.data() + 3, body.mass * wwc);
    if (loads) {
      const Vector3& f = data.loads.force[i];
      l.p.head<3>() -= eq::eigen(eq::transpose_times(r_k, eq::vec(data.loads.moment_b[i])) +
                                 eq::cross(cg, eq::vec(f)));
      l.p.tail<3>() -= f;
    }
  }
}

// Inward step of the articulated-body recursion at body k with M = speed_count and the shape of
// [S_K]: the joint's [U] = IA [S], D = [S]^T [U], u = Q - [S]^T p, and what K's subtree passes
// to J:
//   IA_J += [P]^T (IA - [U] D^-1 [U]^T) [P],   p_J += [P]^T (p + Ia c + [U] D^-1 u).
// A revolute, universal or spherical joint has [S] = (S_w; 0) and a prismatic one (0; S_v): the
// products with [S] then take three columns of IA (three entries of p) only. IA_K and p_K are
// updated in place (the outward pass reads U, D^-1 and u only).
template <int M, Subspace Shape>
void JointDynamics::Impl::recursive_inward(int k) {
  Link& l = links[at(k)];
  const int j = model.lower_body(k);
  if constexpr (Shape == Subspace::free) {
    // [S] (M = 6) is invertible: IA - [U] D^-1 [U]^T = 0 and p + [U] D^-1 u = [S]^-T Q = 0 (no
    // joint loads on a free body), so K passes nothing on, and its acceleration is the free
    // body's, A_K = -IA^-1 p (then z dot_K = [S]^-1 (A_K - [P] A_J - c), outward).
    // Inverted in place: nothing reads a free body's IA after this but solve_mass, which
    // needs the inverse.
    invert_spd6(l.IA);
    l.A.noalias() = -(l.IA * l.p);
    return;
  } else {
    if constexpr (M > 0) {
      const int off = offset[at(k)];
      [[maybe_unused]] const Eigen::Map<const Eigen::Matrix<double, 6, M>> s(S.data() + 6 * off);
      Eigen::Map<Eigen::Matrix<double, 6, M>> uk(U.data() + 6 * off);
      Eigen::Map<Eigen::Matrix<double, M, M>> d_inv(D_inv.data() + d_offset[at(k)]);
      auto uu = u.segment<M>(off);
      Eigen::Matrix<double, M, M> d;
      if constexpr (Shape == Subspace::ball) {
        // [S] = [S'] [R_K]^T with [S'] = ([I]; 0): [U] D^-1 [U]^T and [U] D^-1 u are those of
        // [S'] ([U'] = IA [S'], D' = [S']^T [U'], u' = [R_K]^T Q - [S']^T p, Q the joint's
        // generalized forces, since z = [R_K] z'), and z dot_K = [R_K] z', z' their solution
        // (outward). U, D^-1 and u hold the primed ones.
        uk = l.IA.leftCols<3>();
        d = l.IA.topLeftCorner<3, 3>();
        uu = -l.p.head<3>();
        if (joint_forces) uu.noalias() += l.R.transpose() * joint_force.segment<3>(off);
      } else if constexpr (Shape == Subspace::angular) {
        const auto sw = s.template topRows<3>();
        uk.noalias() = l.IA.leftCols<3>() * sw;
        d.noalias() = sw.transpose() * uk.template topRows<3>();
        uu = joint_force.segment<M>(off) - sw.transpose() * l.p.head<3>();
      } else if constexpr (Shape == Subspace::linear) {
        const auto sv = s.template bottomRows<3>();
        uk.noalias() = l.IA.rightCols<3>() * sv;
        d.noalias() = sv.transpose() * uk.template bottomRows<3>();
        uu = joint_force.segment<M>(off) - sv.transpose() * l.p.tail<3>();
      } else {
        uk.noalias() = l.IA * s;
        d.noalias() = s.transpose() * uk;
        uu = joint_force.segment<M>(off) - s.transpose() * l.p;
      }
      invert_spd<M>(d);
      d_inv = d;
      if (j == kGround) return;  // a root passes nothing on
      const Eigen::Matrix<double, 6, M> ud = uk * d_inv;
      l.IA.noalias() -= ud * uk.transpose();
      l.p.noalias() += ud * uu;
    }
    if (j == kGround) return;
    l.p.noalias() += l.IA * l.c;
    pass_inward(k);
  }
}

// Outward step: A' = [P] A_J + c, z dot_K = D^-1 (u - [U]^T A'), A_K = A' + [S] z dot_K.
template <int M, Subspace Shape>
void JointDynamics::Impl::recursive_outward(int k, Eigen::Ref<VectorX> zdot) {
  Link& l = links[at(k)];
  Vector6 a = carried_acceleration(k);
  if constexpr (Shape == Subspace::free) {
    // [S]^-1 = diag([R_K], [R_J]) for a free joint ([G] = [I], [T] = [0 I], [R_J] = [I] for a
    // root); A_K is the inward pass's.
    const Vector6 rel = l.A - a;
    auto zk = zdot.segment<6>(offset[at(k)]);
    zk.head<3>().noalias() = l.R * rel.head<3>();
    if (model.lower_body(k) == kGround)
      zk.tail<3>() = rel.tail<3>();
    else
      zk.tail<3>().noalias() = links[at(model.lower_body(k))].R * rel.tail<3>();
    return;
  } else {
    if constexpr (M > 0) {
      const int off = offset[at(k)];
      [[maybe_unused]] const Eigen::Map<const Eigen::Matrix<double, 6, M>> s(S.data() + 6 * off);
      const Eigen::Map<const Eigen::Matrix<double, 6, M>> uk(U.data() + 6 * off);
      const Eigen::Map<const Eigen::Matrix<double, M, M>> d_inv(D_inv.data() + d_offset[at(k)]);
      auto zk = zdot.segment<M>(off);
      if constexpr (Shape == Subspace::ball) {
        const Vector3 primed = d_inv * (u.segment<3>(off) - uk.transpose() * a);
        zk.noalias() = l.R * primed;
        a.head<3>() += primed;
      } else {
        zk.noalias() = d_inv * (u.segment<M>(off) - uk.transpose() * a);
        if constexpr (Shape == Subspace::angular)
          a.head<3>().noalias() += s.template topRows<3>() * zk;
        else if constexpr (Shape == Subspace::linear)
          a.tail<3>().noalias() += s.template bottomRows<3>() * zk;
        else
          a.noalias() += s * zk;
      }
    }
    l.A = a;
  }
}

// [M]^-1 Q by the articulated-body factorization (solve_mass): the recursion of
// recursive_inward/recursive_outward with the velocity terms c_K, b_K and the ground's
// acceleration zero and Q in place of the joint loads, so that only [U], D^-1 and the free
// bodies' articulated inertias enter; a column of x at a time, in fixed-size products (no
// allocation). Inward, F_K the force K's subtree passes to K: u = Q - [S]^T F,
// F_J += [P]^T (F + [U] D^-1 u), u kept in x's rows.
template <int M, Subspace Shape>
void JointDynamics::Impl::solve_inward(int k, Eigen::Ref<MatrixX> x) {
  const Link& l = links[at(k)];
  const int j = model.lower_body(k);
  const int c = static_cast<int>(x.cols());
  const int off = offset[at(k)];
  const Eigen::Index stride = x.outerStride();
  // Column col of a body's forces at 6 col from its first.
  double* const f = column_force.data() + 6 * c * k;
  double* const f_lower = j == kGround ? nullptr : column_force.data() + 6 * c * j;
  const char* const loaded = column_loaded.data() + c * k;
  char* const loaded_lower = j == kGround ? nullptr : column_loaded.data() + c * j;
  // A column with no load on K's subtree (its rows there zero: a constraint's Jacobian is
  // zero off its bodies' chains) gives u = 0 and passes nothing: skipped.
  const auto idle = [&](int col) {
    if (loaded[col]) return false;
    for (int i = 0; i < M; ++i)
      if (x(off + i, col) != 0.0) return false;
    return true;
  };
  const BodyMap map = body_map(k);
  const auto pass_on = [&](int col, const Vector6& force) {
    loaded_lower[col] = 1;
    Eigen::Map<Vector6>(f_lower + 6 * col) += carry_force(map, force);
  };
  if constexpr (Shape == Subspace::free) {
    // [S] invertible: F + [U] D^-1 u = [S]^-T Q, [S]^-T = [S] = diag([R_K]^T, [R_J]^T), and
    // the body's acceleration IA^-1 ([S]^-T Q - F) needs nothing from J (outward). The inward
    // pass left IA^-1 in IA (recursive_inward).
    const Matrix6& ia_inv = l.IA;
    const Matrix3& rk = l.R;
    const Matrix3& rj = j == kGround ? identity3 : links[at(j)].R;
    double* const a = column_acceleration.data() + 6 * c * k;
    for (int col = 0; col < c; ++col) {
      if (idle(col)) {
        Eigen::Map<Vector6>(a + 6 * col).setZero();
        continue;
      }
      const Eigen::Map<const Vector6> q(x.data() + col * stride + off);
      Vector6 g;
      g.head<3>().noalias() = rk.transpose() * q.head<3>();
      g.tail<3>().noalias() = rj.transpose() * q.tail<3>();
      if (f_lower) pass_on(col, g);
      // [S]^-T Q - F replaces Q in x: the outward pass does not read it, inverse_mass_gram
      // does.
      g -= Eigen::Map<const Vector6>(f + 6 * col);
      Eigen::Map<Vector6>(x.data() + col * stride + off) = g;
      Eigen::Map<Vector6>(a + 6 * col).noalias() = ia_inv * g;
    }
  } else {
    if constexpr (M > 0) {
      const auto [s_k, u_k, d_inv] = joint_factor<M>(k);
      for (int col = 0; col < c; ++col) {
        if (idle(col)) continue;
        Vector6 passed = Eigen::Map<const Vector6>(f + 6 * col);
        Eigen::Map<Eigen::Matrix<double, M, 1>> uu(x.data() + col * stride + off);
        if constexpr (Shape == Subspace::ball) {
          // the primed u' = [R_K]^T Q - [S']^T F (recursive_inward)
          const Vector3 primed = l.R.transpose() * uu - passed.head<3>();
          uu = primed;
        } else if constexpr (Shape == Subspace::angular) {
          uu.noalias() -= s_k.template topRows<3>().transpose() * passed.head<3>();
        } else if constexpr (Shape == Subspace::linear) {
          uu.noalias() -= s_k.template bottomRows<3>().transpose() * passed.tail<3>();
        } else {
          uu.noalias() -= s_k.transpose() * passed;
        }
        if (!f_lower) continue;
        const Eigen::Matrix<double, M, 1> scaled = d_inv * uu;
        passed.noalias() += u_k * scaled;
        pass_on(col, passed);
      }
    } else if (f_lower) {
      for (int col = 0; col < c; ++col)
        if (!idle(col)) pass_on(col, Eigen::Map<const Vector6>(f + 6 * col));
    }
  }
}

// Outward: A' = [P] A_J, z dot_K = D^-1 (u - [U]^T A'), A_K = A' + [S] z dot_K.
template <int M, Subspace Shape>
void JointDynamics::Impl::solve_outward(int k, Eigen::Ref<MatrixX> x) {
  const Link& l = links[at(k)];
  const int j = model.lower_body(k);
  const int c = static_cast<int>(x.cols());
  const int off = offset[at(k)];
  const Eigen::Index stride = x.outerStride();
  double* const a = column_acceleration.data() + 6 * c * k;
  const double* const a_lower = j == kGround ? nullptr : column_acceleration.data() + 6 * c * j;
  const BodyMap map = body_map(k);
  // [P] A_J (zero for a root).
  const auto carried = [&](int col) -> Vector6 {
    if (!a_lower) return Vector6::Zero();
    return map_velocity(map, Eigen::Map<const Vector6>(a_lower + 6 * col));
  };
  if constexpr (Shape == Subspace::free) {
    // A_K from the inward pass; z dot_K = [S]^-1 (A_K - A') = (R_K rel_w, R_J rel_v).
    const Matrix3& rk = l.R;
    const Matrix3& rj = j == kGround ? identity3 : links[at(j)].R;
    for (int col = 0; col < c; ++col) {
      const Vector6 rel = Eigen::Map<const Vector6>(a + 6 * col) - carried(col);
      Eigen::Map<Vector6> out(x.data() + col * stride + off);
      out.head<3>().noalias() = rk * rel.head<3>();
      out.tail<3>().noalias() = rj * rel.tail<3>();
    }
  } else {
    [[maybe_unused]] const Matrix3& rk = l.R;
    if constexpr (M > 0) {
      const auto [s_k, u_k, d_inv] = joint_factor<M>(k);
      for (int col = 0; col < c; ++col) {
        Vector6 acc = carried(col);
        Eigen::Map<Eigen::Matrix<double, M, 1>> zk(x.data() + col * stride + off);
        const Eigen::Matrix<double, M, 1> rates = d_inv * (zk - u_k.transpose() * acc);
        if constexpr (Shape == Subspace::ball) {
          zk.noalias() = rk * rates;
          acc.head<3>() += rates;
        } else {
          zk = rates;
          if constexpr (Shape == Subspace::angular)
            acc.head<3>().noalias() += s_k.template topRows<3>() * rates;
          else if constexpr (Shape == Subspace::linear)
            acc.tail<3>().noalias() += s_k.template bottomRows<3>() * rates;
          else
            acc.noalias() += s_k * rates;
        }
        Eigen::Map<Vector6>(a + 6 * col) = acc;
      }
    } else {
      for (int col = 0; col < c; ++col) Eigen::Map<Vector6>(a + 6 * col) = carried(col);
    }
  }
}

// Each joint type's speed count and shape of [S] (its row of the joint table), for the
// templates above.
template <typename Step>
void dispatch_joint_type(JointType type, Step&& step) {
  detail::visit_joint_row(type, [&step](auto row) {
    using Row = decltype(row);
    step.template operator()<Row::info.speeds, Row::subspace>();
  });
}

void JointDynamics::Impl::recursive(Eigen::Ref<VectorX> zdot) {
  const int n = model.num_bodies();
  factored = true;
  for (int k = n - 1; k >= 0; --k)
    dispatch_joint_type(joint_type[at(k)],
                        [this, k]<int M, Subspace Shape>() { recursive_inward<M, Shape>(k); });
  for (int k = 0; k < n; ++k)
    dispatch_joint_type(joint_type[at(k)], [this, k, &zdot]<int M, Subspace Shape>() {
      recursive_outward<M, Shape>(k, zdot);
    });
}

void JointDynamics::Impl::assembled(Eigen::Ref<VectorX> zdot) {
  const int n = model.num_bodies();
  if (!ldlt) {
    std::vector<int> sizes, lower;
    for (int k = 0; k < n; ++k) {
      sizes.push_back(speeds[at(k)]);
      lower.push_back(model.lower_body(k));
    }
    const long long blocks = TreeLdlt::count_blocks(sizes, lower);
    if (blocks > Model::kMaxFlatChainEntries)
      throw ModelError("joints: " + std::to_string(blocks) +
                       " blocks of [C]^T [A] [C] are too many for Route::assembled (limit " +
                       std::to_string(Model::kMaxFlatChainEntries) + "); use Route::recursive");
    ldlt.emplace(sizes, lower);
  }
  TreeLdlt& f = *ldlt;
  // A_K at z dot = 0 (outward), then the force each body needs at that motion,
  // [I_O] A_K + b_K - F_ext,K, and [I_O] itself, summed over subtrees through [P]^T (inward):
  // the composite inertia and force of K's subtree about O_K. Every body of K's subtree has
  // V = [P]..[P] V_K + (speeds of the subtree), so its partial velocities with respect to z_c,
  // c on K's chain, are [P]..[P] times K's: [C]^T [A] [C] and [C]^T ({f} - [A][C dot] z) are sums
  // over subtrees.
  for (int k = 0; k < n; ++k) {
    Link& l = links[at(k)];
    l.A = carried_acceleration(k);
    l.p.noalias() += l.IA * l.A;  // IA_K is [I_O,K] until the inward pass
  }
  for (int k = n - 1; k >= 0; --k) {
    const Link& l = links[at(k)];
    const int j = model.lower_body(k);
    const int m = f.size(k);
    if (m > 0) {
      const int off = offset[at(k)];
      const Eigen::Map<const Eigen::Matrix<double, 6, Eigen::Dynamic>> s(S.data() + 6 * off, 6, m);
      // f_z = Q - [S_K]^T (composite force); block (K, K) = [S_K]^T IC_K [S_K]; then up K's
      // chain, F = [P]^T F carries IC_K [S_K] to each ancestor I, block (K, I) = F^T [S_I].
      // Lazy (coefficient-based) products: these blocks are at most 6 x 6, and Eigen's
      // blocked product of dynamic sizes could ask for a workspace.
      zdot.segment(off, m) = joint_force.segment(off, m);
      zdot.segment(off, m).noalias() -= s.transpose().lazyProduct(l.p);
      Block force(6, m);
      force.noalias() = l.IA.lazyProduct(s);
      Eigen::Map<Eigen::MatrixXd>(f.block(k, 0), m, m).noalias() = s.transpose().lazyProduct(force);
      int r = 1;
      for (int e = k, a = j; a != kGround; e = a, a = model.lower_body(a)) {
        const BodyMap map = body_map(e);
        for (int col = 0; col < m; ++col) force.col(col) = carry_force(map, force.col(col));
        const int w = f.size(a);
        if (w == 0) continue;
        const Eigen::Map<const Eigen::Matrix<double, 6, Eigen::Dynamic>> sa(
            S.data() + 6 * offset[at(a)], 6, w);
        Eigen::Map<Eigen::MatrixXd>(f.block(k, r), m, w).noalias() =
            force.transpose().lazyProduct(sa);
        ++r;
      }
    }
    if (j != kGround) pass_inward(k);
  }
  if (!f.compute())
    throw std::runtime_error("JointDynamics: [C]^T [A] [C] is not positive definite");
  f.solve_in_place(zdot);
}

JointDynamics::JointDynamics(const Model& model) : impl_(std::make_unique<Impl>(model)) {}
JointDynamics::JointDynamics(const JointDynamics& other)
    : impl_(std::make_unique<Impl>(*other.impl_)) {}
JointDynamics::~JointDynamics() = default;

// The state and its kinematics and loads, computed on the first request after an evaluation
// that did not need them.
const State& JointDynamics::state() {
  if (!impl_->state_current) impl_->update_state();
  return impl_->state;
}
Data& JointDynamics::data() {
  if (!impl_->state_current)
    impl_->update_state();
  else if (!impl_->kinematics_complete)
    impl_->complete_kinematics();
  return impl_->data;
}
const Model& JointDynamics::model() const { return impl_->model; }
void JointDynamics::set_inputs(const VectorX& u) {
  impl_->data.inputs = u;
  impl_->state_current = false;  // data()'s loads follow the new values
}
const VectorX& JointDynamics::inputs() const { return impl_->data.inputs; }

void JointDynamics::evaluate(const VectorX& q, const VectorX& z, Route route,
                             Eigen::Ref<VectorX> zdot) {
  Impl& s = *impl_;
  s.factored = false;
  s.prepare(q, z);
  if (route == Route::recursive)
    s.recursive(zdot);
  else
    s.assembled(zdot);
}

void JointDynamics::derivative(const VectorX& qz, Route route, Eigen::Ref<VectorX> dqz) {
  Impl& s = *impl_;
  const int nq = s.model.num_coordinates(), nz = s.model.num_speeds();
  s.q = qz.head(nq);
  s.z = qz.tail(nz);
  normalize_joint_coordinates(s.model, s.q);
  joint_coordinate_rates(s.model, s.q, s.z, s.qdot);
  dqz.head(nq) = s.qdot;
  evaluate(s.q, s.z, route, dqz.tail(nz));
}

void JointDynamics::kinematics(const VectorX& q, const VectorX& z) {
  Impl& s = *impl_;
  s.factored = false;
  s.prepare(q, z, false);
}

const Matrix3& JointDynamics::body_rotation(int k) const { return impl_->links[at(k)].R; }

void JointDynamics::body_motion(int k, BodyMotion& out) {
  Impl& s = *impl_;
  s.path.clear();
  for (const int c : s.model.chain(k)) s.path.push_back(c);
  Vector3 p = Vector3::Zero(), v = Vector3::Zero(), alpha = Vector3::Zero(), a = Vector3::Zero();
  Vector3 w_j = Vector3::Zero();
  for (auto it = s.path.rbegin(); it != s.path.rend(); ++it) {
    const int c = *it;
    const Link& l = s.links[at(c)];
    const int m = s.speeds[at(c)];
    // [P_c]: the linear parts move by w_J x r and alpha_J x r, the angular ones carry J's
    // unless c is free (its w'_c is absolute).
    a += alpha.cross(l.r) + l.c.tail<3>();
    alpha = (s.joint_type[at(c)] == JointType::free ? Vector3::Zero() : alpha) + l.c.head<3>();
    v += w_j.cross(l.r);
    for (int col = s.offset[at(c)]; col < s.offset[at(c)] + m; ++col)
      v += s.z_seen[col] * Eigen::Map<const Vector3>(s.S.data() + 6 * col + 3);
    p += l.r;
    w_j = l.w;
  }
  out.R = s.links[at(k)].R;
  out.p = p;
  out.w = s.links[at(k)].w;
  out.v = v;
  out.alpha = alpha;
  out.a = a;
}

// add_point_rows with L linear and A angular directions (a ball's or a disc's 3 and 0, a
// distance's 1 and 0, a hinge's 3 and 2), unrolled.
template <int L, int A>
void JointDynamics::Impl::point_rows(int k, Vector3 origin, const Vector3& point, double sign,
                                     const RowDirections& directions, Eigen::Ref<MatrixX> rows_t,
                                     int first) {
  Vector3 moved = point;
  bool turns = A > 0;
  for (const int c : model.chain(k)) {
    const int m = speeds[at(c)];
    const int off = offset[at(c)];
    const Vector3 lever = moved - origin;
    for (int col = off; col < off + m; ++col) {
      const Eigen::Map<const Vector3> sw(S.data() + 6 * col), sv(S.data() + 6 * col + 3);
      const Vector3 v = sign * (sv + sw.cross(lever));
      for (int r = 0; r < L; ++r) rows_t(col, first + r) += directions.linear[at(r)].dot(v);
      if (A > 0 && turns)
        for (int r = 0; r < A; ++r)
          rows_t(col, first + L + r) += sign * directions.angular[at(r)].dot(sw);
    }
    if (joint_type[at(c)] == JointType::free) {
      moved = origin;
      turns = false;
    }
    origin -= links[at(c)].r;  // O_J
  }
}

void JointDynamics::add_point_rows(int k, const Vector3& origin, const Vector3& point, double sign,
                                   const RowDirections& directions, Eigen::Ref<MatrixX> rows_t,
                                   int first) {
  Impl& s = *impl_;
  const int linear = directions.linear_count, angular = directions.angular_count;
  if (linear == 3 && angular == 0)
    s.point_rows<3, 0>(k, origin, point, sign, directions, rows_t, first);
  else if (linear == 1 && angular == 0)
    s.point_rows<1, 0>(k, origin, point, sign, directions, rows_t, first);
  else if (linear == 3 && angular == 2)
    s.point_rows<3, 2>(k, origin, point, sign, directions, rows_t, first);
  else
    throw std::invalid_argument("JointDynamics::add_point_rows: " + std::to_string(linear) +
                                " linear and " + std::to_string(angular) +
                                " angular directions (3 and 0, 1 and 0, or 3 and 2)");
}

void JointDynamics::Impl::solve_mass_inward(Eigen::Ref<MatrixX> x, const char* caller) {
  if (!factored)
    throw std::logic_error(std::string("JointDynamics::") + caller +
                           ": needs an evaluation by Route::recursive");
  if (x.rows() != model.num_speeds())
    throw std::invalid_argument(std::string("JointDynamics::") + caller + ": " +
                                std::to_string(x.rows()) + " rows, expected " +
                                std::to_string(model.num_speeds()));
  const int n = model.num_bodies(), c = static_cast<int>(x.cols());
  if (c == 0) return;
  const size_t size = 6 * at(c) * at(n);
  if (column_force.size() < size) {
    column_force.resize(size);
    column_acceleration.resize(size);
    column_loaded.resize(at(c) * at(n));
  }
  std::fill_n(column_force.begin(), size, 0.0);
  std::fill_n(column_loaded.begin(), at(c) * at(n), 0);
  for (int k = n - 1; k >= 0; --k)
    dispatch_joint_type(joint_type[at(k)],
                        [this, k, &x]<int M, Subspace Shape>() { solve_inward<M, Shape>(k, x); });
}

void JointDynamics::solve_mass(Eigen::Ref<MatrixX> x) {
  Impl& s = *impl_;
  s.solve_mass_inward(x, "solve_mass");
  const int n = s.model.num_bodies();
  if (x.cols() == 0) return;
  for (int k = 0; k < n; ++k)
    dispatch_joint_type(s.joint_type[at(k)],
                        [&s, k, &x]<int M, Subspace Shape>() { s.solve_outward<M, Shape>(k, x); });
}

// The inward pass maps Q to each joint's u_K (the innovations: u_K = Q_K - [S_K]^T F_K, a free
// joint's g_K = [S_K]^-T Q_K - F_K), and the outward pass maps those to z dot; with D_K the
// inverse of what the inward pass kept (a free body's IA_K), Q^T [M]^-1 Q' is the sum over the
// joints of u_K^T D_K^-1 u'_K (docs/theory.md, "Constraints").
void JointDynamics::inverse_mass_gram(Eigen::Ref<MatrixX> x, MatrixX& gram) {
  Impl& s = *impl_;
  s.solve_mass_inward(x, "inverse_mass_gram");
  const int n = s.model.num_bodies(), c = static_cast<int>(x.cols());
  gram.setZero(c, c);
  for (int k = 0; k < n; ++k) {
    const int off = s.offset[at(k)], m = s.speeds[at(k)];
    if (m == 0) continue;
    if (s.joint_type[at(k)] == JointType::free) {
      // g_K^T IA_K^-1 g'_K, IA_K^-1 g'_K the acceleration the inward pass kept.
      const double* const a = s.column_acceleration.data() + 6 * at(c) * at(k);
      for (int j = 0; j < c; ++j) {
        const Eigen::Map<const Vector6> aj(a + 6 * j);
        for (int i = j; i < c; ++i) gram(i, j) += x.col(i).segment<6>(off).dot(aj);
      }
      continue;
    }
    const double* const d_inv = s.D_inv.data() + s.d_offset[at(k)];
    if (m == 1) {  // revolute and prismatic joints: d^-1 u_K u'_K
      for (int j = 0; j < c; ++j) {
        const double scaled = d_inv[0] * x(off, j);
        if (scaled == 0.0) continue;
        for (int i = j; i < c; ++i) gram(i, j) += x(off, i) * scaled;
      }
      continue;
    }
    for (int j = 0; j < c; ++j) {
      for (int r = 0; r < m; ++r) {
        // (D^-1 u'_K)_r
        double scaled = 0.0;
        for (int t = 0; t < m; ++t) scaled += d_inv[r + t * m] * x(off + t, j);
        if (scaled == 0.0) continue;
        for (int i = j; i < c; ++i) gram(i, j) += x(off + r, i) * scaled;
      }
    }
  }
}

}  // namespace kanedyn::detail
