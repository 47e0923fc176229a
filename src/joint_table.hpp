// The joint table (docs/theory.md, "Joints"; docs/model-format.md, "Joints"): one row per joint
// type, and nothing about a joint type anywhere else. A row gives
// - what the type is (JointTypeInfo: counts, the keys it takes, Euler parameters in q, ...),
//   read by the model reader and writer, `info`, the frames and the outputs;
// - the constant columns of [G_K] (body-K components: w_rel = [G_K] z_K) and of [T_K] (F
//   components; s'_K dot = [T_K] z_K once taken to J), and which speeds slide;
// - the shape of [S_K] for the articulated-body recursions (JointDynamics);
// - its motion for any scalar S (double for the evaluation routes, the dual numbers for the
//   derivatives): K relative to F, w_rel, and [G_K]'s first column and [G_K dot] z_K where
//   that column turns with q.
// joint_terms (below) adds what every row shares: the frame F, the slides s'_K = [T_K] q and
// their rates. Adding a joint type: one entry in KANEDYN_JOINT_TYPES (kanedyn/joint.hpp), its
// keys in Joint if it has new ones, one row here.
#pragma once

#include <cmath>

#include "kanedyn/joint.hpp"
#include "kanedyn/types.hpp"

#include "equations.hpp"

namespace kanedyn::detail {

/// Where [S_K] = ([S_w]; [S_v]) has nonzero rows: the products with it skip the zero half.
/// ball: a spherical joint's [S] = ([R_K]^T; 0).
enum class Subspace { none, angular, ball, linear, general, free };

/// Body K's joint at (q, z) over S: K relative to J (the frame F composed; a free body's own
/// eps_K is in q, not here), w_rel = [G_K] z_K (body-K components), s'_K and s'_K dot (body-J
/// components), and for a row whose first column of [G_K] turns with q
/// (JointTypeInfo::turning_axis) that column g0 and [G_K dot] z_K (not written otherwise). A
/// row's motion<S>() writes rel (K relative to F) and w_rel when it turns, and g0 and g_dot_z
/// when its axis turns; joint_terms() the rest.
template <typename S>
struct JointTerms {
  eq::Euler<S> rel;
  eq::Vec3<S> w_rel, g0, g_dot_z, slide, slide_rate;
};

// s v for a constant v: one multiply per entry (a dual number times a double).
template <typename S>
eq::Vec3<S> scaled(const S& s, const Vector3& v) {
  return {s * v.x(), s * v.y(), s * v.z()};
}
template <typename S>
eq::Vec3<S> zero_vec() {
  return {S{}, S{}, S{}};
}
template <typename S>
eq::Euler<S> no_turn() {
  return {{S{}, S{}, S{}, S{} + 1.0}};
}
/// The turn by `angle` about a unit axis (the Model normalized it), Eq. (3)'s parameters.
template <typename S>
eq::Euler<S> turn(const Vector3& axis, const S& angle) {
  using std::cos;
  using std::sin;
  const S half = 0.5 * angle;
  const S s = sin(half);
  return {{s * axis.x(), s * axis.y(), s * axis.z(), cos(half)}};
}
/// The Euler parameters of K from J's and K's relative to J ([R] = [R(rel)][R_J]): J rel in
/// Hamilton algebra, relative_euler_parameters of conj(J).
template <typename S>
eq::Euler<S> compose(const eq::Euler<S>& j, const eq::Euler<S>& rel) {
  const eq::Euler<S> conj{{-j.e[0], -j.e[1], -j.e[2], j.e[3]}};
  return eq::relative_euler_parameters(conj, rel);
}

template <JointType T>
struct JointRow;

// Every row below: info, subspace, the slide speeds [first_slide, first_slide + slide_count)
// (coordinate index = speed index + slide_coordinate_offset), rotation_columns() and
// translation_columns() (the constant columns of [G_K], and of [T_K] in F components, into
// matrices that arrive zeroed) and motion<S>().

template <>
struct JointRow<JointType::free> {  // the notes' own body
  static constexpr JointTypeInfo info{"free", 7,     6,     "the notes' own: eps_K, s'_K",
                                      false,  false, false, false,
                                      true,   true,  true,  true,
                                      false,  false};
  static constexpr Subspace subspace = Subspace::free;
  static constexpr int first_slide = 3, slide_count = 3, slide_coordinate_offset = 1;
  static void rotation_columns(const Joint&, Matrix36& G) { G.leftCols<3>().setIdentity(); }
  static void translation_columns(const Joint&, Matrix36& T) { T.rightCols<3>().setIdentity(); }
  template <typename S>
  static void motion(const Joint&, const S*, const S* z, JointTerms<S>& m) {
    m.w_rel = {z[0], z[1], z[2]};  // w'_K itself
  }
};

template <>
struct JointRow<JointType::weld> {
  static constexpr JointTypeInfo info{"weld", 0,     0,     "none", false, false, false,
                                      true,   false, false, false,  false, false, true};
  static constexpr Subspace subspace = Subspace::none;
  static constexpr int first_slide = 0, slide_count = 0, slide_coordinate_offset = 0;
  static void rotation_columns(const Joint&, Matrix36&) {}
  static void translation_columns(const Joint&, Matrix36&) {}
  template <typename S>
  static void motion(const Joint&, const S*, const S*, JointTerms<S>&) {}
};

template <>
struct JointRow<JointType::revolute> {
  static constexpr JointTypeInfo info{"revolute", 1,     1,     "angle about the axis",
                                      true,       false, false, true,
                                      false,      false, false, true,
                                      false,      false};
  static constexpr Subspace subspace = Subspace::angular;
  static constexpr int first_slide = 0, slide_count = 0, slide_coordinate_offset = 0;
  static void rotation_columns(const Joint& jt, Matrix36& G) { G.col(0) = jt.axis; }
  static void translation_columns(const Joint&, Matrix36&) {}
  template <typename S>
  static void motion(const Joint& jt, const S* q, const S* z, JointTerms<S>& m) {
    m.rel = turn(jt.axis, q[0]);
    m.w_rel = scaled(z[0], jt.axis);
  }
};

template <>
struct JointRow<JointType::prismatic> {
  static constexpr JointTypeInfo info{"prismatic", 1,     1,     "distance along the axis",
                                      true,        false, false, true,
                                      false,       false, true,  false,
                                      false,       false};
  static constexpr Subspace subspace = Subspace::linear;
  static constexpr int first_slide = 0, slide_count = 1, slide_coordinate_offset = 0;
  static void rotation_columns(const Joint&, Matrix36&) {}
  static void translation_columns(const Joint& jt, Matrix36& T) { T.col(0) = jt.axis; }
  template <typename S>
  static void motion(const Joint&, const S*, const S*, JointTerms<S>&) {}
};

template <>
struct JointRow<JointType::cylindrical> {
  static constexpr JointTypeInfo info{
      "cylindrical", 2,     2,    "angle, distance", true, false, false, true, false, false, true,
      true,          false, false};
  static constexpr Subspace subspace = Subspace::general;
  static constexpr int first_slide = 1, slide_count = 1, slide_coordinate_offset = 0;
  static void rotation_columns(const Joint& jt, Matrix36& G) { G.col(0) = jt.axis; }
  static void translation_columns(const Joint& jt, Matrix36& T) { T.col(1) = jt.axis; }
  template <typename S>
  static void motion(const Joint& jt, const S* q, const S* z, JointTerms<S>& m) {
    m.rel = turn(jt.axis, q[0]);
    m.w_rel = scaled(z[0], jt.axis);
  }
};

template <>
struct JointRow<JointType::universal> {
  static constexpr JointTypeInfo info{
      "universal", 2,    2,    "angles about a1, a2", false, true, false, true, false, false, false,
      true,        true, false};
  static constexpr Subspace subspace = Subspace::angular;
  static constexpr int first_slide = 0, slide_count = 0, slide_coordinate_offset = 0;
  // The first column turns with q: motion() gives it.
  static void rotation_columns(const Joint& jt, Matrix36& G) { G.col(1) = jt.axes[1]; }
  static void translation_columns(const Joint&, Matrix36&) {}
  // a1 first, then a2 as the first turn carried it: a1, fixed in F and in the intermediate
  // frame, is [R(a2, q2)] a1 in K components, and d/dt [R(a2, q2)] a1 = -(q2 dot a2) x
  // [R(a2, q2)] a1; a2 is fixed in K.
  template <typename S>
  static void motion(const Joint& jt, const S* q, const S* z, JointTerms<S>& m) {
    const eq::Euler<S> second = turn(jt.axes[1], q[1]);
    const eq::Mat3<S> r2 = eq::rotation_matrix(second);
    const Vector3& a1 = jt.axes[0];
    m.g0 = {r2.a[0] * a1.x() + r2.a[1] * a1.y() + r2.a[2] * a1.z(),
            r2.a[3] * a1.x() + r2.a[4] * a1.y() + r2.a[5] * a1.z(),
            r2.a[6] * a1.x() + r2.a[7] * a1.y() + r2.a[8] * a1.z()};
    m.rel = compose(turn(jt.axes[0], q[0]), second);
    const Vector3& a2 = jt.axes[1];
    m.w_rel = z[0] * m.g0 + scaled(z[1], a2);
    const S zz = z[0] * z[1];
    // -(z0 z1) a2 x g0
    m.g_dot_z = {-(zz * (a2.y() * m.g0.z - a2.z() * m.g0.y)),
                 -(zz * (a2.z() * m.g0.x - a2.x() * m.g0.z)),
                 -(zz * (a2.x() * m.g0.y - a2.y() * m.g0.x))};
  }
};

template <>
struct JointRow<JointType::spherical> {
  static constexpr JointTypeInfo info{"spherical", 4,     3,     "Euler parameters of K rel. F",
                                      false,       false, false, true,
                                      true,        false, false, true,
                                      false,       false};
  static constexpr Subspace subspace = Subspace::ball;
  static constexpr int first_slide = 0, slide_count = 0, slide_coordinate_offset = 0;
  static void rotation_columns(const Joint&, Matrix36& G) { G.leftCols<3>().setIdentity(); }
  static void translation_columns(const Joint&, Matrix36&) {}
  template <typename S>
  static void motion(const Joint&, const S* q, const S* z, JointTerms<S>& m) {
    m.rel = {{q[0], q[1], q[2], q[3]}};
    m.w_rel = {z[0], z[1], z[2]};  // the spec's joint_rate: K rel. J, body-K components
  }
};

template <>
struct JointRow<JointType::planar> {
  static constexpr JointTypeInfo info{
      "planar", 3,     3,     "x, y in F's x-y plane, angle about F's z",
      false,    false, false, true,
      false,    false, true,  true,
      false,    false};
  static constexpr Subspace subspace = Subspace::general;
  static constexpr int first_slide = 0, slide_count = 2, slide_coordinate_offset = 0;
  // The turn about F's z, which is also K's z; the slides along F's x and y.
  static void rotation_columns(const Joint&, Matrix36& G) { G.col(2) = Vector3::UnitZ(); }
  static void translation_columns(const Joint&, Matrix36& T) {
    T.col(0) = Vector3::UnitX();
    T.col(1) = Vector3::UnitY();
  }
  template <typename S>
  static void motion(const Joint&, const S* q, const S* z, JointTerms<S>& m) {
    m.rel = turn(Vector3(Vector3::UnitZ()), q[2]);
    m.w_rel = {S{}, S{}, z[2]};
  }
};

template <>
struct JointRow<JointType::screw> {
  static constexpr JointTypeInfo info{
      "screw", 1,     1,    "angle about the axis, pitch * angle along it",
      true,    false, true, true,
      false,   false, true, true,
      false,   false};
  static constexpr Subspace subspace = Subspace::general;
  static constexpr int first_slide = 0, slide_count = 1, slide_coordinate_offset = 0;
  // One coordinate: the turn about the axis, and pitch times it along the axis.
  static void rotation_columns(const Joint& jt, Matrix36& G) { G.col(0) = jt.axis; }
  static void translation_columns(const Joint& jt, Matrix36& T) { T.col(0) = jt.pitch * jt.axis; }
  template <typename S>
  static void motion(const Joint& jt, const S* q, const S* z, JointTerms<S>& m) {
    m.rel = turn(jt.axis, q[0]);
    m.w_rel = scaled(z[0], jt.axis);
  }
};

/// f(JointRow<type>{}): the one switch over the joint types.
template <typename F>
decltype(auto) visit_joint_row(JointType type, F&& f) {
  switch (type) {
#define KANEDYN_JOINT_ROW_CASE(name) \
  case JointType::name:              \
    return f(JointRow<JointType::name>{});
    KANEDYN_JOINT_TYPES(KANEDYN_JOINT_ROW_CASE)
#undef KANEDYN_JOINT_ROW_CASE
  }
  return f(JointRow<JointType::free>{});
}

/// Body K's joint at (q, z) over S, what every row shares added: the frame F, the slides
/// s'_K = [T_K] q and their rates (slides_j: the sliding columns of [T_K] taken to J,
/// Model::slide_axes_in_j), the turn and rates of a row that has none. Inlined by force: it
/// runs once per body in the evaluation routes' outward pass and in every dual pass.
template <typename S, typename Row>
[[gnu::always_inline]] inline void row_terms(Row, const Joint& jt, const Matrix3& slides_j,
                                             const S* q, const S* z, JointTerms<S>& m) {
  if constexpr (!Row::info.turns) {
    m.rel = no_turn<S>();
    m.w_rel = zero_vec<S>();
  }
  Row::template motion<S>(jt, q, z, m);
  if constexpr (Row::info.absolute) {  // the notes' own: s'_K and its rate in q and z
    m.rel = no_turn<S>();
    m.slide = {q[4], q[5], q[6]};
    m.slide_rate = {z[3], z[4], z[5]};
    return;
  }
  if constexpr (Row::info.fixed_translation) {
    m.slide = {S(jt.translation.x()), S(jt.translation.y()), S(jt.translation.z())};
    m.slide_rate = zero_vec<S>();
  } else if constexpr (Row::slide_count == 0) {
    m.slide = zero_vec<S>();
    m.slide_rate = zero_vec<S>();
  } else {
    for (int c = 0; c < Row::slide_count; ++c) {
      const Vector3 t = slides_j.col(c);
      const int speed = Row::first_slide + c;
      const eq::Vec3<S> s = scaled(q[speed + Row::slide_coordinate_offset], t);
      const eq::Vec3<S> sd = scaled(z[speed], t);
      m.slide = c == 0 ? s : m.slide + s;
      m.slide_rate = c == 0 ? sd : m.slide_rate + sd;
    }
  }
  const Vector4& f = jt.frame;
  // A product with the identity is exact: skipping it keeps the bits.
  const bool identity = f[0] == 0.0 && f[1] == 0.0 && f[2] == 0.0 && f[3] == 1.0;
  if (!identity) m.rel = compose(eq::Euler<S>{{S(f[0]), S(f[1]), S(f[2]), S(f[3])}}, m.rel);
}

template <typename S>
inline void joint_terms(const Joint& jt, const Matrix3& slides_j, const S* q, const S* z,
                        JointTerms<S>& m) {
  visit_joint_row(jt.type, [&](auto row) { row_terms<S>(row, jt, slides_j, q, z, m); });
}

}  // namespace kanedyn::detail
