// The O(N) route of forward_dynamics(Method::recursive), fused and evaluated for kLanes bodies
// at once (docs/theory.md, "O(N) forward dynamics"). Each body is free, so with all loads on
// it known, Newton-Euler for that body alone gives its accelerations, and s''_K follows from
// the acceleration of O_K relative to J = L(K). Two passes over the bodies, roots first (J < K),
// kLanes bodies at a time:
//   1. K's Euler parameters relative to J, [R] = [R_K][R_J]^T (body J -> body K), the loads on K
//      in body-K components (gravity and constant loads, K's bushing); then the bushing's
//      reaction, in body-J components, added to the loads of J (done before K, or in the same
//      group and stored just before);
//   2. alpha'_K and a_O_K by Newton-Euler for K alone, s''_K (J's terms taken after the group's
//      own results are stored), and Eqs. (39)-(41).
// Pass 2 of a group runs as soon as pass 1 has done the groups of all its bodies' children
// (for a chain: one group later), so that its data is still in cache.
// Lane arithmetic uses GCC vector extensions (2 doubles with SSE2, 4 with AVX).
#include "fused.hpp"

#include <algorithm>
#include <cstring>

#include "kanedyn/detail/fast_rotation.hpp"
#include "kanedyn/forces.hpp"

namespace kanedyn::fused {

namespace {

#if defined(__AVX__)
constexpr int kLanes = 4;
#else
constexpr int kLanes = 2;
#endif
using Pack = double __attribute__((vector_size(8 * kLanes)));

size_t at(long long i) { return static_cast<size_t>(i); }

// Per-body constants, one field after the other, each kLanes doubles (one per body of the
// group). Body-K components unless stated.
enum Param : int {
  kInvMass = 0,        // 1 / m_K
  kInertia = 1,        // [I'_GK]: xx, yy, zz, xy, xz, yz
  kInvInertia = 7,     // its inverse, same order
  kCom = 13,           // r'_K
  kJoint = 16,         // q'_K, body J
  kArm = 19,           // q'_K - r'_J, body J (q'_K for a root): Q_K from G_J
  kForce = 22,         // m_K g + constant forces, inertial
  kMoment = 25,        // constant torques
  kStiffness = 28,     // bushing k, body-J axes, summed over K's bushings
  kDamping = 31,       // bushing c
  kRotStiffness = 34,  // kr
  kRotDamping = 35,    // cr
  kParamFields = 36
};
// Per-body results of passes 1 and 2, same layout.
enum Scratch : int {
  kLoadForce = 0,   // force at G_K, body K: K's own loads plus its children's reactions
  kLoadMoment = 3,  // moment about G_K, body K
  kAccelO = 6,      // a_O_K, body K
  kScratchFields = 9
};

struct P3 {
  Pack x, y, z;
};
inline P3 operator+(const P3& a, const P3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline P3 operator-(const P3& a, const P3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline P3 operator*(const Pack& s, const P3& a) { return {s * a.x, s * a.y, s * a.z}; }
inline P3 operator*(double s, const P3& a) { return {s * a.x, s * a.y, s * a.z}; }
inline P3 cross(const P3& a, const P3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline Pack dot(const P3& a, const P3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
struct PMat {  // 3x3, row by row
  Pack a[9];
};
inline P3 operator*(const PMat& m, const P3& v) {
  return {m.a[0] * v.x + m.a[1] * v.y + m.a[2] * v.z, m.a[3] * v.x + m.a[4] * v.y + m.a[5] * v.z,
          m.a[6] * v.x + m.a[7] * v.y + m.a[8] * v.z};
}
inline P3 transpose_times(const PMat& m, const P3& v) {
  return {m.a[0] * v.x + m.a[3] * v.y + m.a[6] * v.z, m.a[1] * v.x + m.a[4] * v.y + m.a[7] * v.z,
          m.a[2] * v.x + m.a[5] * v.y + m.a[8] * v.z};
}
inline P3 symmetric_times(const Pack* m, const P3& v) {  // xx, yy, zz, xy, xz, yz
  return {m[0] * v.x + m[3] * v.y + m[4] * v.z, m[3] * v.x + m[1] * v.y + m[5] * v.z,
          m[4] * v.x + m[5] * v.y + m[2] * v.z};
}

// Lane-interleaved fields of one group.
inline Pack load(const double* p) {
  Pack v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void store(double* p, const Pack& v) { std::memcpy(p, &v, sizeof v); }
inline P3 load3(const double* group, int field) {
  return {load(group + field * kLanes), load(group + (field + 1) * kLanes),
          load(group + (field + 2) * kLanes)};
}
inline void store3(double* group, int field, const P3& v) {
  store(group + field * kLanes, v.x);
  store(group + (field + 1) * kLanes, v.y);
  store(group + (field + 2) * kLanes, v.z);
}
// Per-body arrays (the state, ydot, xdot): component i of the kLanes bodies at p[lane].
inline Pack gather(const double* const* p, int i) {
  Pack v;
  for (int l = 0; l < kLanes; ++l) v[l] = p[l][i];
  return v;
}
inline P3 gather3(const double* const* p) { return {gather(p, 0), gather(p, 1), gather(p, 2)}; }

// Eqs. (3)-(4).
inline PMat rotation(const Pack* e) {
  const Pack e11 = e[0] * e[0], e22 = e[1] * e[1], e33 = e[2] * e[2], e44 = e[3] * e[3];
  const Pack e12 = e[0] * e[1], e13 = e[0] * e[2], e14 = e[0] * e[3];
  const Pack e23 = e[1] * e[2], e24 = e[1] * e[3], e34 = e[2] * e[3];
  return {{e11 - e22 - e33 + e44, 2.0 * (e12 + e34), 2.0 * (e13 - e24),   //
           2.0 * (e12 - e34), -e11 + e22 - e33 + e44, 2.0 * (e23 + e14),  //
           2.0 * (e13 + e24), 2.0 * (e23 - e14), -e11 - e22 + e33 + e44}};
}

// [R(eps)]{v} = (e4^2 - e.e){v} + 2{e}(e.v) - 2 e4 {e x v}.
inline P3 rotate(const Pack* eps, const P3& v) {
  const P3 e{eps[0], eps[1], eps[2]};
  return (eps[3] * eps[3] - dot(e, e)) * v + (2.0 * dot(e, v)) * e - (2.0 * eps[3]) * cross(e, v);
}

constexpr double kIdentity[4] = {0.0, 0.0, 0.0, 1.0};
constexpr double kZero[4] = {0.0, 0.0, 0.0, 0.0};

// Pointers to the per-body state of the bodies of group g (k >= n: a body at rest).
struct GroupState {
  const double *eps[kLanes], *s[kLanes], *w[kLanes], *sd[kLanes];
  const double *eps_j[kLanes], *w_j[kLanes];  // of J = L(K); identity and zero for R
  int body[kLanes], lower[kLanes];

  GroupState(const State& state, const std::vector<int>& lower_bodies, int n, int g) {
    const double* x = state.x.data();
    const double* y = state.y.data();
    for (int l = 0; l < kLanes; ++l) {
      const int k = g * kLanes + l;
      const int j = lower_bodies[at(k)];
      body[l] = k;
      lower[l] = j;
      const bool real = k < n;
      eps[l] = real ? x + 4 * k : kIdentity;
      s[l] = real ? x + 4 * n + 3 * k : kZero;
      w[l] = real ? y + 3 * k : kZero;
      sd[l] = real ? y + 3 * n + 3 * k : kZero;
      eps_j[l] = j == kGround ? kIdentity : x + 4 * j;
      w_j[l] = j == kGround ? kZero : y + 3 * j;
    }
  }
};

// The rotation vector of q lane by lane (as detail::rotation_vector), zero where kr = 0. When
// every lane turns by less than 15 degrees (the usual case for a bushing) the lanes take the
// series branch of detail::rotation_vector together, with the same operations.
inline P3 rotation_vector(const Pack* q, const Pack& kr) {
  constexpr double kTan24 = 0.13165249758739586;  // tan(pi/24), as in detail::rotation_vector
  const Pack one = Pack{} + 1.0;
  const Pack sign = q[3] < 0.0 ? -one : one;  // the same rotation with e4 >= 0
  const Pack s = sign * q[3];
  const P3 v = sign * P3{q[0], q[1], q[2]};
  const Pack n2 = dot(v, v);
  bool series = true;
  for (int l = 0; l < kLanes; ++l) series = series && n2[l] <= s[l] * s[l] * (kTan24 * kTan24);
  if (series) {
    const Pack inv_s = 1.0 / s;
    const Pack t2 = n2 * inv_s * inv_s;
    const Pack p =
        1.0 - t2 * (1.0 / 3 -
                    t2 * (1.0 / 5 -
                          t2 * (1.0 / 7 -
                                t2 * (1.0 / 9 - t2 * (1.0 / 11 -
                                                      t2 * (1.0 / 13 -
                                                            t2 * (1.0 / 15 - t2 * (1.0 / 17))))))));
    return (2.0 * inv_s * p) * v;
  }
  P3 theta{};
  for (int l = 0; l < kLanes; ++l) {
    if (kr[l] == 0.0) continue;
    const Vector3 t = detail::rotation_vector(Vector4(q[0][l], q[1][l], q[2][l], q[3][l]));
    theta.x[l] = t[0];
    theta.y[l] = t[1];
    theta.z[l] = t[2];
  }
  return theta;
}

// Euler parameters of K (e) relative to J: rel = conj(J) * K (as
// detail::relative_euler_parameters; exactly e for a root, whose J is the identity).
inline void relative(const GroupState& gs, Pack* e, Pack* q) {
  Pack ej[4];
  for (int i = 0; i < 4; ++i) {
    e[i] = gather(gs.eps, i);
    ej[i] = gather(gs.eps_j, i);
  }
  const Pack a1 = -ej[0], a2 = -ej[1], a3 = -ej[2], sj = ej[3];
  q[0] = sj * e[0] + e[3] * a1 + (a2 * e[2] - a3 * e[1]);
  q[1] = sj * e[1] + e[3] * a2 + (a3 * e[0] - a1 * e[2]);
  q[2] = sj * e[2] + e[3] * a3 + (a1 * e[1] - a2 * e[0]);
  q[3] = sj * e[3] - (a1 * e[0] + a2 * e[1] + a3 * e[2]);
}

// Pass 1 for group g; the groups of the lower bodies are done.
void body_loads(const GroupState& gs, const double* p, double* out, double* scratch) {
  Pack e[4], q[4];
  relative(gs, e, q);
  const PMat R = rotation(q);  // body J -> body K
  const P3 s = gather3(gs.s), sd = gather3(gs.sd), w = gather3(gs.w), wj = gather3(gs.w_j);
  const P3 com = load3(p, kCom);

  // K's bushing (docs/model-format.md): {F'} = -k s' - c s' dot (body J) on K at O_K and, reversed,
  // on J at the point of J at O_K; M = -kr theta - cr (w_K - w_J) on K, -M on J.
  const P3 stiffness = load3(p, kStiffness), damping = load3(p, kDamping);
  const P3 f_j{-(stiffness.x * s.x + damping.x * sd.x), -(stiffness.y * s.y + damping.y * sd.y),
               -(stiffness.z * s.z + damping.z * sd.z)};
  const P3 f_k = R * f_j;
  const Pack kr = load(p + kRotStiffness * kLanes), cr = load(p + kRotDamping * kLanes);
  const P3 m_k = -cr * (w - R * wj) - kr * rotation_vector(q, kr);

  // Loads at G_K, body K: gravity and constant forces (inertial -> body K), constant torques,
  // the bushing's force at O_K ((O_K - G_K) x F) and its moment.
  store3(out, kLoadForce, rotate(e, load3(p, kForce)) + f_k);
  store3(out, kLoadMoment, load3(p, kMoment) + cross(f_k, com) + m_k);
  // Reaction on J, body J: -F' at Q_K + s'_K (arm from G_J), -M.
  const P3 react_moment = cross(f_j, load3(p, kArm) + s) - transpose_times(R, m_k);
  for (int l = 0; l < kLanes; ++l) {
    const int j = gs.lower[l];
    if (j == kGround) continue;
    double* to = scratch + at(j / kLanes) * kScratchFields * kLanes + j % kLanes;
    to[(kLoadForce + 0) * kLanes] -= f_j.x[l];
    to[(kLoadForce + 1) * kLanes] -= f_j.y[l];
    to[(kLoadForce + 2) * kLanes] -= f_j.z[l];
    to[(kLoadMoment + 0) * kLanes] += react_moment.x[l];
    to[(kLoadMoment + 1) * kLanes] += react_moment.y[l];
    to[(kLoadMoment + 2) * kLanes] += react_moment.z[l];
  }
}

// Pass 2 for group g; the groups of the lower bodies are done.
void body_accelerations(const GroupState& gs, int n, const double* p, double* out,
                        const double* scratch, double* ydot, double* xdot) {
  const P3 w = gather3(gs.w), sd = gather3(gs.sd), s = gather3(gs.s), wj = gather3(gs.w_j);
  const P3 com = load3(p, kCom);
  Pack e[4], q[4];  // recomputed rather than stored: less memory traffic for large N
  relative(gs, e, q);
  const PMat R = rotation(q);  // body J -> body K

  // Newton-Euler for K alone: I alpha' + w' x I w' = M', m a_G = F; a_O = a_G - alpha' x r'
  // - w' x (w' x r') (body K).
  Pack inertia[6], inv_inertia[6];
  for (int i = 0; i < 6; ++i) {
    inertia[i] = load(p + (kInertia + i) * kLanes);
    inv_inertia[i] = load(p + (kInvInertia + i) * kLanes);
  }
  const P3 moment = load3(out, kLoadMoment);
  const P3 alpha = symmetric_times(inv_inertia, moment - cross(w, symmetric_times(inertia, w)));
  const P3 a_O = load(p + kInvMass * kLanes) * load3(out, kLoadForce) - cross(alpha, com) -
                 cross(w, cross(w, com));
  store3(out, kAccelO, a_O);
  // s''_K = [R]^T a_O_K - a_O_J - 2 w'_J x s' dot - alpha'_J x (q'+s') - w'_J x (w'_J x (q'+s'))
  // (body J), from a_O_K = a_O_J + [R_J]^T(s'' + 2 w'_J x s'dot + alpha'_J x (q'+s')
  // + w'_J x (w'_J x (q'+s'))).
  const P3 qs = load3(p, kJoint) + s;
  P3 sdd = transpose_times(R, a_O) - 2.0 * cross(wj, sd) - cross(wj, cross(wj, qs));
  for (int l = 0; l < kLanes; ++l) {  // alpha' (Eq. 10) first: a lower body may be in the group
    if (gs.body[l] >= n) continue;
    double* a = ydot + 3 * gs.body[l];
    a[0] = alpha.x[l];
    a[1] = alpha.y[l];
    a[2] = alpha.z[l];
  }
  P3 a_Oj{}, alpha_j{};
  for (int l = 0; l < kLanes; ++l) {
    const int j = gs.lower[l];
    if (j == kGround) continue;  // a root: R does not accelerate
    const double* sj = scratch + at(j / kLanes) * kScratchFields * kLanes + j % kLanes;
    a_Oj.x[l] = sj[kAccelO * kLanes];
    a_Oj.y[l] = sj[(kAccelO + 1) * kLanes];
    a_Oj.z[l] = sj[(kAccelO + 2) * kLanes];
    alpha_j.x[l] = ydot[3 * j];
    alpha_j.y[l] = ydot[3 * j + 1];
    alpha_j.z[l] = ydot[3 * j + 2];
  }
  sdd = sdd - a_Oj - cross(alpha_j, qs);

  // Eqs. (39)-(41): eps dot = 1/2 [Ebar'_K]^T w'_K, s' dot = y2.
  const Pack r0 = 0.5 * (e[3] * w.x - e[2] * w.y + e[1] * w.z);
  const Pack r1 = 0.5 * (e[2] * w.x + e[3] * w.y - e[0] * w.z);
  const Pack r2 = 0.5 * (-e[1] * w.x + e[0] * w.y + e[3] * w.z);
  const Pack r3 = -0.5 * (e[0] * w.x + e[1] * w.y + e[2] * w.z);
  for (int l = 0; l < kLanes; ++l) {
    const int k = gs.body[l];
    if (k >= n) continue;
    double* a = ydot + 3 * n + 3 * k;
    a[0] = sdd.x[l];
    a[1] = sdd.y[l];
    a[2] = sdd.z[l];
    double* ed = xdot + 4 * k;
    ed[0] = r0[l];
    ed[1] = r1[l];
    ed[2] = r2[l];
    ed[3] = r3[l];
    double* v = xdot + 4 * n + 3 * k;
    v[0] = sd.x[l];
    v[1] = sd.y[l];
    v[2] = sd.z[l];
  }
}

}  // namespace

bool compile(const Model& model, Data& data) {
  const int n = model.num_bodies();
  const int groups = (n + kLanes - 1) / kLanes;
  const auto padded = at(groups) * kLanes;
  data.fused_lower.assign(padded, kGround);
  data.fused_ready.assign(at(groups), 0);
  for (int g = 0; g < groups; ++g) data.fused_ready[at(g)] = g;
  data.fused_params.assign(at(groups) * kParamFields * kLanes, 0.0);
  data.fused_scratch.assign(at(groups) * kScratchFields * kLanes, 0.0);
  const auto param = [&](int k, int field) -> double& {
    return data
        .fused_params[at(k / kLanes) * kParamFields * kLanes + at(field) * kLanes + at(k % kLanes)];
  };
  const auto set3 = [&](int k, int field, const Vector3& v) {
    for (int i = 0; i < 3; ++i) param(k, field + i) = v[i];
  };
  const auto set_symmetric = [&](int k, int field, const Matrix3& m) {
    const double v[6] = {m(0, 0), m(1, 1), m(2, 2), m(0, 1), m(0, 2), m(1, 2)};
    for (int i = 0; i < 6; ++i) param(k, field + i) = v[i];
  };
  for (int k = 0; k < static_cast<int>(padded); ++k) {
    if (k >= n) {  // padding: a unit body at rest, so that its lanes stay finite
      param(k, kInvMass) = 1.0;
      set_symmetric(k, kInertia, Matrix3::Identity());
      set_symmetric(k, kInvInertia, Matrix3::Identity());
      continue;
    }
    const BodySpec& b = model.body(k);
    const int j = b.lower_body;
    data.fused_lower[at(k)] = j;
    if (j != kGround)  // J's loads are complete once K's group has done pass 1
      data.fused_ready[at(j / kLanes)] = std::max(data.fused_ready[at(j / kLanes)], k / kLanes);
    param(k, kInvMass) = 1.0 / b.mass;
    set_symmetric(k, kInertia, b.inertia);
    set_symmetric(k, kInvInertia, model.inverse_inertia(k));
    set3(k, kCom, b.com);
    set3(k, kJoint, b.joint);
    set3(k, kArm, j == kGround ? b.joint : Vector3(b.joint - model.body(j).com));
    set3(k, kForce, b.mass * model.gravity());
  }
  // Loads grouped per body: the laws are linear in k, c, kr, cr and in the constant loads.
  for (const auto& element : model.forces()) {
    const int k = element->body();
    if (const auto* bushing = dynamic_cast<const Bushing*>(element.get())) {
      for (int i = 0; i < 3; ++i) {
        param(k, kStiffness + i) += bushing->stiffness[i];
        param(k, kDamping + i) += bushing->damping[i];
      }
      param(k, kRotStiffness) += bushing->rotational_stiffness;
      param(k, kRotDamping) += bushing->rotational_damping;
    } else if (const auto* force = dynamic_cast<const ConstantForce*>(element.get())) {
      for (int i = 0; i < 3; ++i) param(k, kForce + i) += force->value[i];
    } else if (const auto* torque = dynamic_cast<const ConstantTorque*>(element.get())) {
      for (int i = 0; i < 3; ++i) param(k, kMoment + i) += torque->value[i];
    } else {
      return false;
    }
  }
  return true;
}

void forward_dynamics(const Model& model, const State& state, Data& data) {
  const int n = model.num_bodies();
  const int groups = (n + kLanes - 1) / kLanes;
  const double* params = data.fused_params.data();
  double* scratch = data.fused_scratch.data();
  const auto group_params = [&](int g) { return params + at(g) * kParamFields * kLanes; };
  const auto group_scratch = [&](int g) { return scratch + at(g) * kScratchFields * kLanes; };
  const auto accelerations = [&](int g) {
    body_accelerations(GroupState(state, data.fused_lower, n, g), n, group_params(g),
                       group_scratch(g), scratch, data.ydot.data(), data.xdot.data());
  };
  int next = 0;  // the next group for pass 2
  for (int g = 0; g < groups; ++g) {
    // 1. Every body's loads, its bushing's reaction added to its lower body's.
    body_loads(GroupState(state, data.fused_lower, n, g), group_params(g), group_scratch(g),
               scratch);
    // 2. Accelerations of the groups whose loads are complete.
    for (; next <= g && data.fused_ready[at(next)] <= g; ++next) accelerations(next);
  }
  for (; next < groups; ++next) accelerations(next);
}

}  // namespace kanedyn::fused
