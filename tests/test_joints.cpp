// Joints by the orthogonal-complement method: the state each joint type gives against the
// spec's table (written here with Rodrigues' formula, not the library's rotations), y = [C] z,
// finite differences of x and of [C] z along a motion of (q, z), validation messages, and the
// projected equations on a pendulum, a slider in free fall and an unconstrained tree.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematic_equations.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/simulate.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

using test::reference_rotation;

// "F turned by angle about the unit n": the matrix from F components to the turned frame's
// (Rodrigues, passive): cos [I] + (1 - cos) n n^T - sin [n~]. Written here, independently.
Matrix3 turn(const Vector3& n, double angle) {
  return std::cos(angle) * Matrix3::Identity() + (1.0 - std::cos(angle)) * n * n.transpose() -
         std::sin(angle) * skew(n);
}

// A model with joints and a random state (q, z).
struct Jointed {
  Model model;
  VectorX q, z;
};

Jointed make_jointed(const Model& base, const std::vector<JointType>& types, std::mt19937& rng) {
  std::vector<Joint> joints;
  for (JointType t : types) joints.push_back(test::random_joint(rng, t));
  Jointed j{with_joints(base, joints), {}, {}};
  test::random_joint_state(j.model, rng, j.q, j.z);
  return j;
}

// The notes' eight-body system with every joint type: a free torso (1), spherical (2),
// revolute (3), universal (4), cylindrical (5), prismatic (6), weld (7), revolute (8).
Jointed eight_body_jointed(std::mt19937& rng) {
  return make_jointed(
      test::eight_body_model(),
      {JointType::free, JointType::spherical, JointType::revolute, JointType::universal,
       JointType::cylindrical, JointType::prismatic, JointType::weld, JointType::revolute},
      rng);
}

// Random forests of up to 12 bodies, each joint type equally likely; and chains of three with
// `type` at every body (small trees of one type, every body attached to the one before).
std::vector<Jointed> test_trees(unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<Jointed> out;
  out.push_back(eight_body_jointed(rng));
  for (JointType type : kJointTypes) {
    test::RandomTreeOptions opt;
    opt.min_bodies = opt.max_bodies = 3;
    opt.chain = true;
    out.push_back(make_jointed(test::random_tree(rng, opt), {type, type, type}, rng));
  }
  for (int i = 0; i < 40; ++i) {
    test::RandomTreeOptions opt;
    opt.max_bodies = 12;
    Model model = test::random_tree(rng, opt);
    std::vector<JointType> types;
    for (int k = 0; k < model.num_bodies(); ++k) types.push_back(test::random_joint_type(rng));
    out.push_back(make_jointed(std::move(model), types, rng));
  }
  return out;
}

State state_of(const Jointed& j, const VectorX& q, const VectorX& z) {
  State s(j.model);
  joint_state(j.model, q, z, s);
  return s;
}

// ---------------------------------------------------------------------------------------------
// (c) each body sits and moves as the spec's table says

// Round-off: a state is a product of at most ~12 rotations with O(1) entries and sums of
// O(1) terms, so errors are ~1e-14 (all below 1e-14 here); 1e-12 leaves a margin of 100, while
// a wrong axis, frame or sign is O(0.1).
constexpr double kRoundOff = 1e-12;

// K's orientation and relative motion against the table, from the state alone: [R_rel] =
// [R_K][R_J]^T, w_rel = w'_K - [R_rel] w'_J (body K), s'_K, s'_K dot (body J).
void expect_body_follows_joint(const Jointed& j, const State& s, int k) {
  const Joint& jt = j.model.joint(k);
  if (jt.type == JointType::free) return;
  const int l = j.model.lower_body(k);
  const Matrix3 r_j =
      l == kGround ? Matrix3::Identity() : reference_rotation(s.euler_parameters(l));
  const Vector3 w_j = l == kGround ? Vector3::Zero() : Vector3(s.angular_velocity(l));
  const Matrix3 r_rel = reference_rotation(s.euler_parameters(k)) * r_j.transpose();
  const Vector3 w_rel = s.angular_velocity(k) - r_rel * w_j;
  const Matrix3 r_f = reference_rotation(jt.frame);
  const Matrix3 r_fk = r_rel * r_f.transpose();  // F to K components
  const Vector3 n = jt.axis, n_j = r_f.transpose() * jt.axis;
  const Vector3 s_k = s.translation(k), sd_k = s.translation_rate(k);
  const int o = j.model.coordinate_offset(k), p = j.model.speed_offset(k);
  const VectorX& q = j.q;
  const VectorX& z = j.z;
  Matrix3 r_expected = Matrix3::Identity();
  Vector3 w_expected = Vector3::Zero(), s_expected = Vector3::Zero(), sd_expected = Vector3::Zero();
  switch (jt.type) {
    case JointType::weld:
      s_expected = jt.translation;
      break;
    case JointType::revolute:
      r_expected = turn(n, q[o]);
      w_expected = z[p] * n;
      EXPECT_LT((w_rel.cross(n)).norm(), kRoundOff) << "revolute: w_rel along the axis";
      EXPECT_LT((r_fk * n - n).norm(), kRoundOff) << "revolute: the axis is fixed in F and K";
      break;
    case JointType::prismatic:
      s_expected = q[o] * n_j;
      sd_expected = z[p] * n_j;
      EXPECT_LT(s_k.cross(n_j).norm(), kRoundOff) << "prismatic: s' along the axis";
      break;
    case JointType::cylindrical:
      r_expected = turn(n, q[o]);
      w_expected = z[p] * n;
      s_expected = q[o + 1] * n_j;
      sd_expected = z[p + 1] * n_j;
      EXPECT_LT((w_rel.cross(n)).norm(), kRoundOff) << "cylindrical: w_rel along the axis";
      EXPECT_LT(s_k.cross(n_j).norm(), kRoundOff) << "cylindrical: s' along the axis";
      break;
    case JointType::universal: {
      const Vector3 a1 = jt.axes[0], a2 = jt.axes[1];
      r_expected = turn(a2, q[o + 1]) * turn(a1, q[o]);
      w_expected = z[p] * turn(a2, q[o + 1]) * a1 + z[p + 1] * a2;
      // The cross stays square: a1 (fixed in F) and a2 (fixed in K) stay perpendicular, and
      // K never turns about a1 x a2.
      const Vector3 a1_k = r_fk * a1;
      EXPECT_LT(std::abs(a1_k.dot(a2)), kRoundOff) << "universal: a1 and a2 perpendicular";
      EXPECT_LT(std::abs(w_rel.dot(a1_k.cross(a2))), kRoundOff) << "universal: no third turn";
      break;
    }
    case JointType::spherical:
      r_expected = reference_rotation(q.segment<4>(o));
      w_expected = z.segment<3>(p);
      break;
    case JointType::screw:  // the turn about n, and pitch times it along n
      r_expected = turn(n, q[o]);
      w_expected = z[p] * n;
      s_expected = jt.pitch * q[o] * n_j;
      sd_expected = jt.pitch * z[p] * n_j;
      EXPECT_LT((w_rel.cross(n)).norm(), kRoundOff) << "screw: w_rel along the axis";
      EXPECT_LT(s_k.cross(n_j).norm(), kRoundOff) << "screw: s' along the axis";
      break;
    case JointType::planar: {
      // x, y along F's x and y axes (J components), the turn about F's z axis.
      const Vector3 x_j = r_f.transpose() * Vector3::UnitX(),
                    y_j = r_f.transpose() * Vector3::UnitY();
      const Vector3 z_j = r_f.transpose() * Vector3::UnitZ();
      r_expected = turn(Vector3::UnitZ(), q[o + 2]);
      w_expected = z[p + 2] * Vector3::UnitZ();
      s_expected = q[o] * x_j + q[o + 1] * y_j;
      sd_expected = z[p] * x_j + z[p + 1] * y_j;
      EXPECT_LT(std::abs(s_k.dot(z_j)), kRoundOff) << "planar: s' in the plane";
      EXPECT_LT(std::abs(sd_k.dot(z_j)), kRoundOff) << "planar: s' dot in the plane";
      EXPECT_LT((r_fk * Vector3::UnitZ() - Vector3::UnitZ()).norm(), kRoundOff)
          << "planar: the normal is fixed in F and K";
      break;
    }
    case JointType::free:
      break;
  }
  EXPECT_LT(test::max_abs(r_fk - r_expected), kRoundOff) << to_string(jt.type) << " body " << k;
  EXPECT_LT((w_rel - w_expected).norm(), kRoundOff) << to_string(jt.type) << " body " << k;
  EXPECT_LT((s_k - s_expected).norm(), kRoundOff) << to_string(jt.type) << " body " << k;
  EXPECT_LT((sd_k - sd_expected).norm(), kRoundOff) << to_string(jt.type) << " body " << k;
}

TEST(Joints, CountsOfTheSpecTable) {
  const int q[] = {7, 0, 1, 1, 2, 2, 4, 3, 1}, z[] = {6, 0, 1, 1, 2, 2, 3, 3, 1};
  ASSERT_EQ(std::size(kJointTypes), std::size(q));
  for (size_t i = 0; i < std::size(q); ++i) {
    EXPECT_EQ(coordinate_count(kJointTypes[i]), q[i]) << to_string(kJointTypes[i]);
    EXPECT_EQ(speed_count(kJointTypes[i]), z[i]) << to_string(kJointTypes[i]);
  }
}

TEST(Joints, EachJointConfinesTheRelativeMotionAsTheTableSays) {
  for (const Jointed& j : test_trees(31)) {
    const State s = state_of(j, j.q, j.z);
    for (int k = 0; k < j.model.num_bodies(); ++k) {
      expect_body_follows_joint(j, s, k);
      if (j.model.joint(k).type == JointType::free) {  // a free body keeps its own x, y
        const int o = j.model.coordinate_offset(k), p = j.model.speed_offset(k);
        EXPECT_EQ(VectorX(s.euler_parameters(k)), VectorX(j.q.segment<4>(o)));
        EXPECT_EQ(VectorX(s.translation(k)), VectorX(j.q.segment<3>(o + 4)));
        EXPECT_EQ(VectorX(s.angular_velocity(k)), VectorX(j.z.segment<3>(p)));
        EXPECT_EQ(VectorX(s.translation_rate(k)), VectorX(j.z.segment<3>(p + 3)));
      }
      // Unit Euler parameters for every body (composition keeps the norm).
      EXPECT_NEAR(s.euler_parameters(k).norm(), 1.0, kRoundOff);
    }
  }
}

TEST(Joints, VelocitiesAreConstraintMatrixTimesSpeeds) {
  std::mt19937 rng(32);
  for (const Jointed& j : test_trees(33)) {
    const State s = state_of(j, j.q, j.z);
    ConstraintMatrix C(j.model);
    compute_constraint_matrix(j.model, j.q, s, C);
    const MatrixX dense = dense_constraint_matrix(j.model, C);
    ASSERT_EQ(dense.rows(), 6 * j.model.num_bodies());
    ASSERT_EQ(dense.cols(), j.model.num_speeds());
    VectorX y(6 * j.model.num_bodies());
    constraint_times(j.model, C, j.z, y);
    EXPECT_LT(test::max_abs(dense * j.z - s.y), kRoundOff);
    EXPECT_LT(test::max_abs(y - s.y), kRoundOff);
    const VectorX v = test::random_vector(rng, -1, 1).replicate(2 * j.model.num_bodies(), 1);
    VectorX ct_v(j.model.num_speeds());
    constraint_transpose_times(j.model, C, v, ct_v);
    EXPECT_LT(test::max_abs(dense.transpose() * v - ct_v), kRoundOff);
  }
}

// The blocks of [C] follow the chain down to the first free body: in the jointed eight-body
// system (L = 0, 1, 2, 2, 1, 1, 1, 7; 1 free, 7 welded) w'_3 depends on z_3, z_2, z_1, w'_8
// on z_8 and z_1 (7 has no speeds), and w'_1 on z_1 only; every s' dot on its own z.
TEST(Joints, ConstraintBlocksFollowTheChainToTheFirstFreeBody) {
  std::mt19937 rng(45);
  const Jointed j = eight_body_jointed(rng);
  using Chain = std::vector<int>;
  EXPECT_EQ(j.model.angular_chain(0), (Chain{0}));
  EXPECT_EQ(j.model.angular_chain(2), (Chain{2, 1, 0}));
  EXPECT_EQ(j.model.angular_chain(6), (Chain{0}));
  EXPECT_EQ(j.model.angular_chain(7), (Chain{7, 0}));
  EXPECT_EQ(j.model.num_speeds(), 6 + 3 + 1 + 2 + 2 + 1 + 0 + 1);
  const State s = state_of(j, j.q, j.z);
  ConstraintMatrix C(j.model);
  compute_constraint_matrix(j.model, j.q, s, C);
  const MatrixX dense = dense_constraint_matrix(j.model, C);
  // Column by column: [C] e_i is y for the unit speed i, which joint_state gives as well.
  for (int i = 0; i < j.model.num_speeds(); ++i) {
    const VectorX e = VectorX::Unit(j.model.num_speeds(), i);
    EXPECT_LT(test::max_abs(dense.col(i) - state_of(j, j.q, e).y), kRoundOff) << "column " << i;
  }
  // Body 8's w' rows: nothing from bodies 2..6 (columns 6..14).
  EXPECT_EQ(test::max_abs(dense.block(21, 6, 3, 9)), 0.0);
}

// ---------------------------------------------------------------------------------------------
// (a), (b): finite differences along a motion of (q, z)

// q(t) from q(0) by one classical Runge-Kutta step of the joints' kinematic equations, with
// z(t) = z + t zd. Its error is O(t^5) (~1e-25 at t = 1e-5), far below what is measured.
VectorX coordinates_at(const Model& tree, const VectorX& q, const VectorX& z, const VectorX& zd,
                       double t) {
  auto f = [&](const VectorX& qq, double tt) {
    VectorX r(tree.num_coordinates());
    joint_coordinate_rates(tree, qq, VectorX(z + tt * zd), r);
    return r;
  };
  const VectorX k1 = f(q, 0), k2 = f(q + 0.5 * t * k1, 0.5 * t), k3 = f(q + 0.5 * t * k2, 0.5 * t),
                k4 = f(q + t * k3, t);
  return q + t / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
}

// Central differences with h = 1e-5: truncation h^2/6 |third derivative| ~ 2e-11 |x'''|, and
// |x'''| is O(1)-O(10) for speeds <= 1 on trees of depth <= 12; round-off ~1e-16 |y| / h ~
// 1e-11 |y| with |y| up to ~10. The largest differences seen are 1.5e-10; tolerance 1e-8
// absolute, while a wrong or missing term of [C] or [C dot] is O(0.1).
constexpr double kStep = 1e-5;
constexpr double kFiniteDifference = 1e-8;

TEST(Joints, CoordinatesMoveAtTheRateOfTheNotesKinematicEquations) {
  for (const Jointed& j : test_trees(35)) {
    const VectorX zd = VectorX::Zero(j.z.size());
    const State s0 = state_of(j, j.q, j.z);
    const State sp = state_of(j, coordinates_at(j.model, j.q, j.z, zd, kStep), j.z);
    const State sm = state_of(j, coordinates_at(j.model, j.q, j.z, zd, -kStep), j.z);
    VectorX xdot(j.model.num_x());
    compute_xdot(j.model, s0, xdot);  // Eqs. (39)-(40) with y = [C] z
    EXPECT_LT(test::max_abs((sp.x - sm.x) / (2 * kStep) - xdot), kFiniteDifference)
        << "N " << j.model.num_bodies();
  }
}

TEST(Joints, ConstraintRateTimesSpeedsIsTheDerivativeOfConstraintTimesSpeeds) {
  std::mt19937 rng(36);
  for (const Jointed& j : test_trees(37)) {
    const Model& tree = j.model;
    const int n6 = 6 * j.model.num_bodies();
    VectorX zd(j.z.size());
    for (int i = 0; i < zd.size(); ++i) zd[i] = test::uniform(rng, -1, 1);
    auto c_times = [&](const VectorX& q, const VectorX& v) {
      const State s = state_of(j, q, j.z);
      ConstraintMatrix C(tree);
      compute_constraint_matrix(tree, q, s, C);
      VectorX y(n6);
      constraint_times(tree, C, v, y);
      return y;
    };
    const State s0 = state_of(j, j.q, j.z);
    ConstraintMatrix C(tree);
    compute_constraint_matrix(tree, j.q, s0, C);
    VectorX cdot_z(n6);
    constraint_rate_times_speeds(tree, C, j.q, j.z, s0, cdot_z);
    const VectorX zero = VectorX::Zero(zd.size());
    // (b) [C dot]{z} = d/dt ([C(q(t))] {z}) with z held fixed.
    const VectorX fd = (c_times(coordinates_at(tree, j.q, j.z, zero, kStep), j.z) -
                        c_times(coordinates_at(tree, j.q, j.z, zero, -kStep), j.z)) /
                       (2 * kStep);
    EXPECT_LT(test::max_abs(fd - cdot_z), kFiniteDifference) << "N " << j.model.num_bodies();
    // {y dot} = [C]{z dot} + [C dot]{z} along a motion with z(t) = z + t zd.
    auto y_at = [&](double t) {
      return state_of(j, coordinates_at(tree, j.q, j.z, zd, t), VectorX(j.z + t * zd)).y;
    };
    VectorX c_zd(n6);
    constraint_times(tree, C, zd, c_zd);
    EXPECT_LT(test::max_abs((y_at(kStep) - y_at(-kStep)) / (2 * kStep) - (c_zd + cdot_z)),
              kFiniteDifference)
        << "N " << j.model.num_bodies();
  }
}

TEST(Joints, SphericalRatesAreTheRelativeAngularVelocity) {
  // Eq. (5) inverts Eq. (39): {w} = 2 [Ebar'] {q dot}, to round-off for unit q.
  std::mt19937 rng(38);
  Jointed j = make_jointed(test::random_tree(rng, {.min_bodies = 1, .max_bodies = 1}),
                           {JointType::spherical}, rng);
  VectorX qdot(4);
  joint_coordinate_rates(j.model, j.q, j.z, qdot);
  EXPECT_LT((angular_velocity_from_rates(j.q.head<4>(), qdot.head<4>()) - j.z.head<3>()).norm(),
            1e-14);
  EXPECT_LT(std::abs(j.q.head<4>().dot(qdot)), 1e-15);  // keeps |q| = 1
}

TEST(Joints, NormalizeRescalesEulerParametersOnly) {
  std::mt19937 rng(39);
  Jointed j = make_jointed(test::random_tree(rng, {.min_bodies = 3, .max_bodies = 3}),
                           {JointType::free, JointType::spherical, JointType::revolute}, rng);
  VectorX q = j.q;
  q.head<4>() *= 1.5;      // free eps
  q.segment<4>(7) *= 0.5;  // spherical q
  q[11] = 2.5;             // the revolute angle, unchanged
  EXPECT_NEAR(normalize_joint_coordinates(j.model, q), 0.5, 1e-15);
  EXPECT_LT((q.head<4>() - j.q.head<4>()).norm(), 1e-15);
  EXPECT_LT((q.segment<4>(7) - j.q.segment<4>(7)).norm(), 1e-15);
  EXPECT_EQ(q[11], 2.5);
}

// ---------------------------------------------------------------------------------------------
// (d) refusals

TEST(Joints, ValidationNamesEachProblem) {
  Joint j;
  j.type = JointType::revolute;
  j.axis = Vector3::Zero();
  EXPECT_EQ(check_joint(j), "the axis of a revolute joint must be finite and not zero");
  j.type = JointType::prismatic;
  EXPECT_EQ(check_joint(j), "the axis of a prismatic joint must be finite and not zero");
  j.type = JointType::cylindrical;
  EXPECT_EQ(check_joint(j), "the axis of a cylindrical joint must be finite and not zero");
  j.type = JointType::spherical;  // no axis to check
  EXPECT_EQ(check_joint(j), "");

  Joint u;
  u.type = JointType::universal;
  u.axes = {Vector3(1, 0, 0), Vector3(2e-9, 1, 0)};  // cos = 2e-9 / |a2|, just over 1e-9
  EXPECT_EQ(check_joint(u),
            "the axes of a universal joint must be perpendicular (|a1 . a2| <= 1e-9)");
  u.axes = {Vector3(3, 0, 0), Vector3(0.5e-9, 2, 0)};  // cos 2.5e-10: accepted, normalized
  EXPECT_EQ(check_joint(u), "");
  u.axes[1] = Vector3::Zero();
  EXPECT_EQ(check_joint(u), "the axes of a universal joint must be finite and not zero");

  Joint f;
  f.frame = Vector4(0, 0, 0, 1.00001);
  EXPECT_EQ(check_joint(f), "the joint frame's Euler parameters must have unit norm");

  EXPECT_EQ(check_joint_coordinates(JointType::revolute, VectorX::Zero(2)),
            "a revolute joint has 1 coordinate, not 2");
  EXPECT_EQ(check_joint_coordinates(JointType::universal, VectorX::Zero(1)),
            "a universal joint has 2 coordinates, not 1");
  EXPECT_EQ(check_joint_coordinates(JointType::weld, VectorX::Zero(1)),
            "a weld joint has 0 coordinates, not 1");
  EXPECT_EQ(check_joint_coordinates(JointType::spherical, VectorX::Zero(3)),
            "a spherical joint has 4 coordinates, not 3");
  Vector4 e(0, 0, 0, 1 + 2e-6);  // off by 2e-6: refused; by 5e-7: accepted
  EXPECT_EQ(check_joint_coordinates(JointType::spherical, e),
            "the Euler parameters of a spherical joint must have unit norm (within 1e-6)");
  e[3] = 1 + 5e-7;
  EXPECT_EQ(check_joint_coordinates(JointType::spherical, e), "");
  EXPECT_EQ(check_joint_rates(JointType::spherical, VectorX::Zero(4)),
            "a spherical joint has 3 rates, not 4");
  EXPECT_EQ(check_joint_rates(JointType::prismatic, VectorX::Zero(1)), "");
  EXPECT_EQ(check_joint_coordinates(JointType::planar, VectorX::Zero(2)),
            "a planar joint has 3 coordinates, not 2");
  EXPECT_EQ(check_joint_rates(JointType::planar, VectorX::Zero(1)),
            "a planar joint has 3 rates, not 1");

  Joint p;  // a planar joint has no axis: a zero one is no problem
  p.type = JointType::planar;
  p.axis = Vector3::Zero();
  EXPECT_EQ(check_joint(p), "");
}

// The names are the model format's, and the joints that take joint_spring and joint_force are
// those whose speeds are the coordinates' rates.
TEST(Joints, NamesAndLoadableTypesOfTheSpecTable) {
  const char* names[] = {"free",      "weld",      "revolute", "prismatic", "cylindrical",
                         "universal", "spherical", "planar",   "screw"};
  const bool loadable[] = {false, false, true, true, true, true, false, true, true};
  ASSERT_EQ(std::size(kJointTypes), std::size(names));
  for (size_t i = 0; i < std::size(names); ++i) {
    EXPECT_EQ(std::string(to_string(kJointTypes[i])), names[i]);
    EXPECT_EQ(speeds_are_coordinate_rates(kJointTypes[i]), loadable[i]) << names[i];
  }
}

TEST(Joints, TreeRefusesBadJointsNamingTheBody) {
  std::mt19937 rng(40);
  const Model model = test::random_tree(rng, {.min_bodies = 2, .max_bodies = 2});
  Joint bad;
  bad.type = JointType::revolute;
  bad.axis = Vector3::Zero();
  try {
    (void)with_joints(model, {Joint{}, bad});
    ADD_FAILURE() << "accepted";
  } catch (const ModelError& e) {
    EXPECT_EQ(std::string(e.what()),
              "body 2 'b2': the axis of a revolute joint must be finite and not zero");
  }
  EXPECT_THROW((void)with_joints(model, {Joint{}}), ModelError);
}

// ---------------------------------------------------------------------------------------------
// The projected equations (Eq. 36 premultiplied by [C]^T)

// One body on a revolute joint about the inertial z axis at its origin, mass centre at
// (0, -l, 0) in body axes, gravity -g y: theta'' = -(m g l / I_O) sin(theta), I_O = I_zz + m l^2.
TEST(JointsProjected, RevolutePendulum) {
  const double m = 2.0, l = 0.7, g = 9.81, izz = 0.05;
  BodySpec b;
  b.name = "bob";
  b.mass = m;
  b.inertia = Vector3(0.08, 0.03, izz).asDiagonal();
  b.com = Vector3(0, -l, 0);
  Joint joint;
  joint.type = JointType::revolute;
  joint.axis = Vector3::UnitZ();
  const Model model({b}, Vector3(0, -g, 0), {}, "", {joint});
  Data data(model);
  for (double theta : {0.0, 0.3, -1.2, 2.5}) {
    for (double rate : {0.0, 1.7}) {
      const ProjectedEquations e =
          projected_equations(model, VectorX::Constant(1, theta), VectorX::Constant(1, rate), data);
      const double expected = -(m * g * l / (izz + m * l * l)) * std::sin(theta);
      // Round-off of a 6x6 system with O(10) entries: 1e-12.
      EXPECT_NEAR(e.zdot[0], expected, 1e-12) << "theta " << theta << " rate " << rate;
    }
  }
}

// A prismatic joint along a unit axis n (frame and axis random): the slide accelerates at
// g . n whatever the slide, its rate and the body's mass properties.
TEST(JointsProjected, PrismaticFreeFallIsGravityAlongTheAxis) {
  std::mt19937 rng(41);
  for (int i = 0; i < 20; ++i) {
    test::RandomTreeOptions opt;
    opt.min_bodies = opt.max_bodies = 1;
    opt.gravity = test::random_vector(rng, -10, 10);
    Jointed j = make_jointed(test::random_tree(rng, opt), {JointType::prismatic}, rng);
    Data data(j.model);
    const ProjectedEquations e = projected_equations(j.model, j.q, j.z, data);
    const Vector3 n =
        reference_rotation(j.model.joint(0).frame).transpose() * j.model.joint(0).axis;
    EXPECT_NEAR(e.zdot[0], j.model.gravity().dot(n), 1e-12);
  }
}

// -[d~][d~] = |d|^2 [I] - d d^T: the inertia of a unit mass at d about the origin.
Matrix3 point_inertia(const Vector3& d) {
  return d.squaredNorm() * Matrix3::Identity() - d * d.transpose();
}

// A free body with a second body welded to it (random frame and translation) moves as the one
// rigid body they make: mass m1 + m2, mass centre and inertia combined in body-1 axes (the
// parallel-axis theorem, written here), under the same gravity and initial motion.
TEST(JointsProjected, WeldedPairIsOneRigidBody) {
  std::mt19937 rng(43);
  for (int i = 0; i < 20; ++i) {
    test::RandomTreeOptions opt;
    opt.min_bodies = opt.max_bodies = 2;
    opt.chain = true;
    opt.gravity = test::random_vector(rng, -10, 10);
    Jointed j = make_jointed(test::random_tree(rng, opt), {JointType::free, JointType::weld}, rng);
    const BodySpec &b1 = j.model.body(0), &b2 = j.model.body(1);
    const Matrix3 r_f = reference_rotation(j.model.joint(1).frame);  // body 1 to body 2 axes
    const Vector3 p2 = b2.joint + j.model.joint(1).translation + r_f.transpose() * b2.com;
    BodySpec one = b1;
    one.mass = b1.mass + b2.mass;
    one.com = (b1.mass * b1.com + b2.mass * p2) / one.mass;
    one.inertia = b1.inertia + b1.mass * point_inertia(b1.com - one.com) +
                  r_f.transpose() * b2.inertia * r_f + b2.mass * point_inertia(p2 - one.com);
    const Model rigid({one}, j.model.gravity());
    Data data(j.model), rigid_data(rigid);
    const ProjectedEquations e = projected_equations(j.model, j.q, j.z, data);
    State s(rigid);
    s.x << e.state.euler_parameters(0), e.state.translation(0);
    s.y << e.state.angular_velocity(0), e.state.translation_rate(0);
    forward_dynamics(rigid, s, rigid_data);
    // Two 6x6 solves of O(10) systems formed differently: round-off ~1e-13; 1e-10 relative.
    EXPECT_LT(test::max_abs(e.zdot - rigid_data.ydot),
              1e-10 * (1.0 + test::max_abs(rigid_data.ydot)));
  }
}

// With every joint free, [C] = [I], [C dot] = 0 and the projected equations are Eq. (36).
TEST(JointsProjected, AllFreeIsTheUnconstrainedTree) {
  std::mt19937 rng(42);
  for (const Model& model : test::models_of_every_size(rng)) {
    if (model.num_bodies() > 30) continue;
    const Model& tree = model;  // every joint free, the default
    VectorX q, z;
    test::random_joint_state(tree, rng, q, z);
    Data data(model);
    const ProjectedEquations e = projected_equations(model, q, z, data);
    // [C] only reorders: z is body by body, y is (w', s' dot); [C]^T [C] = [I] exactly.
    const int n = tree.num_speeds();
    EXPECT_EQ(test::max_abs(e.C.transpose() * e.C - MatrixX::Identity(n, n)), 0.0);
    EXPECT_EQ(test::max_abs(e.Cdot_z), 0.0);
    Data free(model);
    forward_dynamics(model, e.state, free, Route::assembled);
    // Both solve the same 6N system, by LDL^T of different orderings: 1e-10 relative.
    EXPECT_LT(test::max_abs(e.C * e.zdot - free.ydot), 1e-10 * (1.0 + test::max_abs(free.ydot)));
  }
}

// One classical Runge-Kutta step of (q, z) by the projected equations: the joints hold by
// construction, so only energy and momentum can show an error of the dynamics.
void projected_rk4_step(const Model& model, Data& data, VectorX& q, VectorX& z, double h) {
  auto rates = [&](const VectorX& qq, const VectorX& zz, VectorX& dq, VectorX& dz) {
    dq.resize(qq.size());
    joint_coordinate_rates(model, qq, zz, dq);
    dz = projected_equations(model, qq, zz, data).zdot;
  };
  VectorX q1, z1, q2, z2, q3, z3, q4, z4;
  rates(q, z, q1, z1);
  rates(q + 0.5 * h * q1, z + 0.5 * h * z1, q2, z2);
  rates(q + 0.5 * h * q2, z + 0.5 * h * z2, q3, z3);
  rates(q + h * q3, z + h * z3, q4, z4);
  q += h / 6 * (q1 + 2 * q2 + 2 * q3 + q4);
  z += h / 6 * (z1 + 2 * z2 + 2 * z3 + z4);
  normalize_joint_coordinates(model, q);
}

// The jointed eight-body system (every joint type) under gravity, no damping: the energy of
// the notes' state stays constant; without gravity the momenta do too. RK4 with h = 1e-3
// over 0.5 s, speeds up to ~5 rad/s: its error is bounded by ~(w h)^4 = 6e-10 relative per
// unit time; measured 2e-15 (energy) and 2e-15 (momenta). Tolerance 1e-10 relative, while a
// wrong [C dot]{z} or [A_z] gains or loses energy at O(1) relative rates.
TEST(JointsProjected, EnergyAndMomentumAreConservedOnTheJointedEightBody) {
  for (const bool gravity : {true, false}) {
    std::mt19937 rng(44);
    const Model model =
        test::eight_body_model(gravity ? Vector3(0, 0, -9.81) : Vector3::Zero(), false);
    Jointed j = make_jointed(
        model,
        {JointType::free, JointType::spherical, JointType::revolute, JointType::universal,
         JointType::cylindrical, JointType::prismatic, JointType::weld, JointType::revolute},
        rng);
    Data data(j.model);
    auto state = [&] { return state_of(j, j.q, j.z); };
    const double e0 = total_energy(j.model, state(), data);
    const Vector3 p0 = linear_momentum(j.model, state(), data);
    const Vector3 h0 = angular_momentum(j.model, state(), data);
    for (int step = 0; step < 500; ++step) projected_rk4_step(j.model, data, j.q, j.z, 1e-3);
    const double scale = std::abs(e0) + kinetic_energy(j.model, state(), data);
    EXPECT_LT(std::abs(total_energy(j.model, state(), data) - e0), 1e-10 * scale);
    if (!gravity) {
      EXPECT_LT((linear_momentum(j.model, state(), data) - p0).norm(), 1e-10 * (1 + p0.norm()));
      EXPECT_LT((angular_momentum(j.model, state(), data) - h0).norm(), 1e-10 * (1 + h0.norm()));
    }
  }
}

}  // namespace
}  // namespace kanedyn

namespace kanedyn {
namespace {

// The model's state from the notes' state: an all-free model's (q, z) are its x, y body by
// body, exactly, and back; a joint with coordinates of its own is refused by name; a weld is
// checked against its lower body.
TEST(JointCoordinates, AllFreeIsTheNotesStateBodyByBody) {
  std::mt19937 rng(61);
  for (const Model& model : test::models_of_every_size(rng)) {
    if (model.num_bodies() > 50) continue;
    const State s = test::random_state(model, rng);
    VectorX q, z;
    joint_coordinates(model, s, q, z);
    ASSERT_EQ(q.size(), 7 * model.num_bodies());
    for (int k = 0; k < model.num_bodies(); ++k) {
      EXPECT_EQ(q.segment<4>(7 * k), s.euler_parameters(k));
      EXPECT_EQ(q.segment<3>(7 * k + 4), s.translation(k));
      EXPECT_EQ(z.segment<3>(6 * k), s.angular_velocity(k));
      EXPECT_EQ(z.segment<3>(6 * k + 3), s.translation_rate(k));
    }
    State back(model);
    joint_state(model, q, z, back);
    EXPECT_EQ(back.x, s.x);
    EXPECT_EQ(back.y, s.y);
  }
}

TEST(JointCoordinates, RefusesJointsWithCoordinatesAndChecksWelds) {
  std::mt19937 rng(62);
  const Model base = test::random_tree(rng, {.min_bodies = 3, .max_bodies = 3});
  Joint hinge;
  hinge.type = JointType::revolute;
  const Model hinged = with_joints(base, {Joint{}, hinge, Joint{}});
  VectorX q, z;
  try {
    joint_coordinates(hinged, State(hinged), q, z);
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("body 'b2' has a revolute joint"), std::string::npos)
        << e.what();
  }
  Joint weld;
  weld.type = JointType::weld;
  weld.translation = Vector3(0.1, 0.2, 0.3);
  const Model welded = with_joints(base, {Joint{}, weld, Joint{}});
  VectorX q0 = VectorX::Zero(welded.num_coordinates()), z0 = VectorX::Zero(welded.num_speeds());
  q0[3] = q0[10] = 1.0;  // identity Euler parameters of the two free bodies
  z0[0] = 0.7;           // the root turns: the weld's body turns with it
  State held(welded);
  joint_state(welded, q0, z0, held);
  joint_coordinates(welded, held, q, z);
  EXPECT_EQ(q, q0);
  EXPECT_EQ(z, z0);
  State moved = held;
  moved.translation(1).x() += 1e-6;  // beyond 1e-9 relative: not the weld's pose
  EXPECT_THROW(joint_coordinates(welded, moved, q, z), std::invalid_argument);
  EXPECT_THROW(joint_coordinates(welded, State(2), q, z), std::invalid_argument);
}

// A joint spring's energy needs q: the functions of the notes' state refuse such a model, and
// those of (q, z) add 1/2 k (q - rest)^2 to the bodies' energy.
TEST(JointCoordinates, EnergyOfAModelWithJointSpringsTakesTheJointCoordinates) {
  std::mt19937 rng(63);
  const Model base = test::random_tree(rng, {.min_bodies = 2, .max_bodies = 2});
  Joint hinge;
  hinge.type = JointType::revolute;
  const auto spring =
      std::make_shared<const JointLoad>(1, VectorX::Constant(1, 4.0), VectorX::Constant(1, 0.5),
                                        VectorX::Constant(1, 0.25), VectorX::Zero(1));
  const Model sprung = with_joints(base, {Joint{}, hinge}, {spring});
  const Model bare = with_joints(base, {Joint{}, hinge});
  VectorX q, z;
  test::random_joint_state(sprung, rng, q, z);
  Data data(sprung);
  State s(sprung);
  joint_state(sprung, q, z, s);
  EXPECT_THROW(total_energy(sprung, s, data), std::invalid_argument);
  EXPECT_THROW(potential_energy(sprung, s, data), std::invalid_argument);
  EXPECT_THROW(damping_power(sprung, s, data), std::invalid_argument);
  const double d = q[7] - 0.25;
  // The spring's term is added last to the same sums: round-off of one addition.
  EXPECT_NEAR(total_energy(sprung, q, z, data), total_energy(bare, s, data) + 0.5 * 4.0 * d * d,
              1e-15 * (1.0 + std::abs(total_energy(bare, s, data))));
  EXPECT_NEAR(damping_power(sprung, q, z, data), damping_power(bare, s, data) + 0.5 * z[6] * z[6],
              1e-15 * (1.0 + damping_power(bare, s, data)));
  EXPECT_EQ(kinetic_energy(sprung, q, z, data), kinetic_energy(bare, s, data));
}

// One observer for every model: an all-free run's (q, z) at each output are its notes' state
// body by body, the same bits.
TEST(JointCoordinates, SimulateGivesTheObserverTheModelsState) {
  const Model model = test::eight_body_model(Vector3(0, 0, -9.81), true);
  std::mt19937 rng(64);
  const State initial = test::random_state(model, rng);
  SimulationSettings settings;
  settings.t_end = 0.2;
  settings.dt_out = 0.05;
  int rows = 0;
  const auto stats =
      simulate(model, initial, settings,
               [&](double, const State& s, const VectorX& q, const VectorX& z, Data&) {
                 VectorX eq, ez;
                 joint_coordinates(model, s, eq, ez);
                 EXPECT_EQ(q, eq);
                 EXPECT_EQ(z, ez);
                 ++rows;
               });
  ASSERT_TRUE(stats.ok()) << stats.message;
  EXPECT_EQ(rows, 5);
}

}  // namespace
}  // namespace kanedyn
