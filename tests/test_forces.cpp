// Loads (forces.hpp): the bushing's laws as docs/model-format.md ("Force laws, exactly")
// states them, checked against values worked out by hand; action and reaction between K and
// L(K); constant forces and torques; the per-body resultants of gravity and every element;
// the generalized forces of Eq. (31) against the chain sums and the power of the loads.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/partials.hpp"
#include "kanedyn/rotation.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

using test::reference_rotation;

BodySpec unit_body(const char* name, int lower) {
  BodySpec b;
  b.name = name;
  b.lower_body = lower;
  b.mass = 2.0;
  b.inertia = Vector3(0.3, 0.4, 0.5).asDiagonal();
  return b;
}

// A bushing on body k with random stiffness and damping, drawn one after the other (the
// order of a call's arguments is unspecified, so drawing in them differs between compilers).
std::shared_ptr<Bushing> random_bushing(std::mt19937& rng, int k) {
  const Vector3 stiffness = test::random_vector(rng, 5.0, 100.0);
  const Vector3 damping = test::random_vector(rng, 0.0, 3.0);
  const double torsion = test::uniform(rng, 1.0, 20.0);
  const double torsion_damping = test::uniform(rng, 0.0, 1.0);
  return std::make_shared<Bushing>(k, stiffness, damping, torsion, torsion_damping);
}

// The loads of `model` at `state` (compute_kinematics, then compute_resultants).
Loads loads_at(const Model& model, const State& state) {
  Data data(model);
  compute_kinematics(model, state, data);
  compute_resultants(model, state, data);
  return data.loads;
}

TEST(Forces, BushingTranslationalLawByHand) {
  // A root body on a bushing to the ground, no gravity, identity orientation:
  //   {F'} = -diag(k){s'} - diag(c){s' dot}
  //        = -(100 * 0.01 + 1 * 0.1, 200 * -0.02 + 2 * 0.2, 300 * 0.03 + 3 * -0.3)
  //        = (-1.1, 3.6, -8.1),
  // inertial for a root. It acts at O_K; about G_K = O_K + r' the moment is
  // (O_K - G_K) x F = F x r' = (-1.1, 3.6, -8.1) x (0, 0, 0.5) = (1.8, 0.55, 0).
  // Round-off of a few products of O(1): 1e-14.
  BodySpec b = unit_body("k", kGround);
  b.com = Vector3(0.0, 0.0, 0.5);
  const auto bushing =
      std::make_shared<Bushing>(0, Vector3(100.0, 200.0, 300.0), Vector3(1.0, 2.0, 3.0), 7.0, 0.4);
  const Model model({b}, Vector3::Zero(), {bushing});
  State state(model);
  state.translation(0) = Vector3(0.01, -0.02, 0.03);
  state.translation_rate(0) = Vector3(0.1, 0.2, -0.3);
  const Vector3 expected_force(-1.1, 3.6, -8.1);
  EXPECT_LT((bushing->translational_force_b(state) - expected_force).norm(), 1e-14);
  const Loads loads = loads_at(model, state);
  EXPECT_LT((loads.force[0] - expected_force).norm(), 1e-14);
  EXPECT_LT((loads.moment_b[0] - Vector3(1.8, 0.55, 0.0)).norm(), 1e-14);
  // The same body turned by 90 degrees about z: the force is still (-1.1, 3.6, -8.1) in J's
  // (here inertial) axes; in body-K axes it is [R]F = (3.6, 1.1, -8.1), and r' = (0, 0, 0.5)
  // in K gives the moment (3.6, 1.1, -8.1) x (0, 0, 0.5) = (0.55, -1.8, 0). theta = (0, 0,
  // pi/2) adds -kr theta = (0, 0, -7 pi / 2).
  state.euler_parameters(0) = euler_parameters_from_axis_angle(Vector3::UnitZ(), M_PI / 2);
  const Loads turned = loads_at(model, state);
  EXPECT_LT((turned.force[0] - expected_force).norm(), 1e-14);
  EXPECT_LT((turned.moment_b[0] - Vector3(0.55, -1.8, -3.5 * M_PI)).norm(), 1e-13);
}

TEST(Forces, BushingRotationalLawByHand) {
  // M = -kr theta - cr (w_K - w_J) on K, body-K components, theta the rotation vector of K
  // relative to J (K's axes are J's turned right-handed by |theta| in [0, pi]). A root body
  // with r' = 0 and s' = 0 feels only M. kr = 50, cr = 2, w' = (0.2, -0.1, 0.4):
  //   0.6 rad about z: M = -50 (0, 0, 0.6) - 2 (0.2, -0.1, 0.4) = (-0.4, 0.2, -30.8);
  //   4 rad about z is 2 pi - 4 about -z: theta = (0, 0, 4 - 2 pi), M = (-0.4, 0.2,
  //   50 (2 pi - 4) - 0.8).
  // [R] of K turned by a about z is [[c, s, 0], [-s, c, 0], [0, 0, 1]] (Eqs. 3-4): checked too,
  // so that the hand values rest on the convention of the format. Round-off: 1e-13.
  const auto bushing = std::make_shared<Bushing>(0, Vector3::Zero(), Vector3::Zero(), 50.0, 2.0);
  const Model model({unit_body("k", kGround)}, Vector3::Zero(), {bushing});
  State state(model);
  state.angular_velocity(0) = Vector3(0.2, -0.1, 0.4);
  for (const double angle : {0.6, 4.0}) {
    state.euler_parameters(0) = euler_parameters_from_axis_angle(Vector3::UnitZ(), angle);
    Matrix3 r;
    r << std::cos(angle), std::sin(angle), 0, -std::sin(angle), std::cos(angle), 0, 0, 0, 1;
    EXPECT_LT((rotation_matrix(state.euler_parameters(0)) - r).cwiseAbs().maxCoeff(), 1e-15);
    const double theta_z = angle <= M_PI ? angle : angle - 2 * M_PI;
    EXPECT_LT((bushing->rotation_vector(model, state) - Vector3(0, 0, theta_z)).norm(), 1e-14);
    const Vector3 expected(-0.4, 0.2, -50.0 * theta_z - 0.8);
    const Loads loads = loads_at(model, state);
    EXPECT_LT((loads.moment_b[0] - expected).norm(), 1e-13) << "angle " << angle;
    EXPECT_EQ(loads.force[0], Vector3::Zero());
  }
}

TEST(Forces, BushingActionAndReactionBetweenKAndItsLowerBody) {
  // A bushing on K with J = L(K), random states, no gravity, nothing else acting. The laws
  // from the format, written here with an independent rotation vector (Eigen's AngleAxis of
  // [R] = [R_K][R_J]^T, whose transpose turns J's axes into K's):
  //   F' = -diag(k) s'_K - diag(c) s'_K dot (body J), on K at O_K and -F' on J there;
  //   M  = -kr theta - cr (w'_K - [R] w'_J) (body K) on K and -M on J.
  // So F_J = -F_K exactly, the moments about G_K and G_J follow from the point O_K, and the
  // pair has no net moment about the inertial origin: sum p_G x F + [R_I]^T M'_I = 0.
  // Round-off relative to the size of the loads times the lever arms (<= ~2): 1e-12; the
  // rotation vector near pi is ill-conditioned in AngleAxis, so angles above 3 rad are skipped.
  std::mt19937 rng(61);
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    BodySpec j = unit_body("j", kGround), k = unit_body("k", 0);
    for (BodySpec* b : {&j, &k}) {
      b->com = test::random_vector(rng, -0.4, 0.4);
      b->joint = test::random_vector(rng, -0.5, 0.5);
    }
    const auto bushing = random_bushing(rng, 1);
    const Model model({j, k}, Vector3::Zero(), {bushing});
    const State state = test::random_state(model, rng, 0.3, 2.0, 1.0);
    const Matrix3 rj = reference_rotation(state.euler_parameters(0));
    const Matrix3 rk = reference_rotation(state.euler_parameters(1));
    const Matrix3 r = rk * rj.transpose();
    const Eigen::AngleAxisd turn(Matrix3(r.transpose()));
    if (turn.angle() > 3.0) continue;
    ++checked;
    const Vector3 theta = turn.angle() * turn.axis();
    const Vector3 f = -bushing->stiffness.cwiseProduct(state.translation(1)) -
                      bushing->damping.cwiseProduct(state.translation_rate(1));
    const Vector3 m =
        -bushing->rotational_stiffness * theta -
        bushing->rotational_damping * (state.angular_velocity(1) - r * state.angular_velocity(0));
    const Loads loads = loads_at(model, state);
    const double scale = f.norm() + m.norm() + 1.0;
    EXPECT_LT((loads.force[1] - rj.transpose() * f).norm(), 1e-12 * scale);
    EXPECT_EQ(loads.force[0], Vector3(-loads.force[1]));
    EXPECT_LT((loads.moment_b[1] - ((r * f).cross(k.com) + m)).norm(), 1e-12 * scale);
    const Vector3 arm_j = k.joint + state.translation(1) - j.com;  // G_J to O_K, body J
    EXPECT_LT((loads.moment_b[0] - (arm_j.cross(-f) - r.transpose() * m)).norm(), 1e-12 * scale);
    Data data(model);
    compute_kinematics(model, state, data);
    Vector3 net = Vector3::Zero();
    for (int i = 0; i < 2; ++i) {
      const auto ii = static_cast<size_t>(i);
      net += data.kinematics.p_G[ii].cross(loads.force[ii]) +
             data.kinematics.R[ii].transpose() * loads.moment_b[ii];
    }
    EXPECT_LT(net.norm(), 1e-12 * scale * (1.0 + data.kinematics.p_G[1].norm()));
  }
  EXPECT_GT(checked, 150);
}

TEST(Forces, ConstantForceAndTorque) {
  // A constant force at G_K in inertial components and a constant moment in body-K components
  // add to gravity m g unchanged, whatever the state; several on one body add. Exact: the
  // same additions in the same order.
  std::mt19937 rng(62);
  const Vector3 g(0.3, -0.2, -9.81), f1(1.0, -2.0, 3.0), f2(-0.5, 0.25, 4.0);
  const Vector3 t1(0.1, 0.2, -0.3), t2(-1.0, 0.5, 0.75);
  const Model model(
      {unit_body("a", kGround), unit_body("b", 0)}, g,
      {std::make_shared<ConstantForce>(1, f1), std::make_shared<ConstantTorque>(1, t1),
       std::make_shared<ConstantForce>(1, f2), std::make_shared<ConstantTorque>(0, t2)});
  for (int trial = 0; trial < 10; ++trial) {
    const Loads loads = loads_at(model, test::random_state(model, rng));
    EXPECT_EQ(loads.force[0], Vector3(2.0 * g));
    EXPECT_EQ(loads.force[1], Vector3(2.0 * g + f1 + f2));
    EXPECT_EQ(loads.moment_b[0], t2);
    EXPECT_EQ(loads.moment_b[1], t1);
  }
}

TEST(Forces, ResultantsAreGravityPlusEveryElement) {
  // compute_resultants against the sum of the loads of each element applied alone to zero
  // loads, plus m_K g: superposition, to round-off of sums of O(100) loads (1e-12 relative
  // to the sum of their sizes). Without elements and gravity, the loads are exactly zero.
  std::mt19937 rng(63);
  test::RandomTreeOptions opt;
  opt.bushings = opt.forces = opt.torques = true;
  opt.second_bushing_probability = 0.25;
  for (const Model& model : test::eight_body_and_random_trees(64, 30, opt)) {
    const State state = test::random_state(model, rng);
    Data data(model);
    compute_kinematics(model, state, data);
    compute_resultants(model, state, data);
    const int n = model.num_bodies();
    std::vector<Vector3> force(static_cast<size_t>(n)), moment(static_cast<size_t>(n));
    std::vector<double> scale(static_cast<size_t>(n));
    for (int k = 0; k < n; ++k) {
      const auto i = static_cast<size_t>(k);
      force[i] = model.body(k).mass * model.gravity();
      moment[i].setZero();
      scale[i] = force[i].norm();
    }
    for (const auto& element : model.forces()) {
      Loads alone = data.loads;
      for (int k = 0; k < n; ++k) {
        alone.force[static_cast<size_t>(k)].setZero();
        alone.moment_b[static_cast<size_t>(k)].setZero();
      }
      element->apply(model, state, data.kinematics, alone);
      for (int k = 0; k < n; ++k) {
        const auto i = static_cast<size_t>(k);
        force[i] += alone.force[i];
        moment[i] += alone.moment_b[i];
        scale[i] += alone.force[i].norm() + alone.moment_b[i].norm();
      }
    }
    for (int k = 0; k < n; ++k) {
      const auto i = static_cast<size_t>(k);
      EXPECT_LT((data.loads.force[i] - force[i]).norm(), 1e-12 * (1.0 + scale[i])) << k;
      EXPECT_LT((data.loads.moment_b[i] - moment[i]).norm(), 1e-12 * (1.0 + scale[i])) << k;
    }
    const Model bare(model.bodies());
    const Loads none = loads_at(bare, state);
    for (int k = 0; k < n; ++k) {
      EXPECT_EQ(none.force[static_cast<size_t>(k)], Vector3::Zero());
      EXPECT_EQ(none.moment_b[static_cast<size_t>(k)], Vector3::Zero());
    }
  }
}

// Eq. (31) in chain layout, the oracle of compute_generalized_forces: sum over every body's
// chain of [v_G_K,y]^T {F_K} block by block, plus [w'_K,y]^T {M'_K}. Needs the partials.
VectorX generalized_forces_from_partials(const Model& model, const Data& data) {
  const int n = model.num_bodies();
  VectorX fy = VectorX::Zero(6 * n);
  for (int k = 0; k < n; ++k) {
    const Model::Chain chain = model.chain(k);
    const auto o = static_cast<size_t>(model.chain_offset(k));
    const Vector3& F = data.loads.force[static_cast<size_t>(k)];
    for (int r = 0; r < chain.size; ++r) {
      const int c = chain[r];
      fy.segment<3>(3 * c) += data.partials.vG_w[o + static_cast<size_t>(r)].transpose() * F;
      fy.segment<3>(3 * n + 3 * c) +=
          data.partials.vG_s[o + static_cast<size_t>(r)].transpose() * F;
    }
    fy.segment<3>(3 * k) += data.loads.moment_b[static_cast<size_t>(k)];
  }
  return fy;
}

TEST(Forces, GeneralizedForcesEqualChainSums) {
  // Eq. (31) by subtree sums (compute_generalized_forces, and the F_y kane_equations fills)
  // against the chain-layout sums of [v_G,y]^T blocks. Round-off relative to the size of the
  // largest load term (the entries themselves can cancel).
  std::mt19937 rng(4);
  for (const Model& model : test::models_of_every_size(rng)) {
    const State state = test::random_state(model, rng, 0.05, 2.0, 0.5);
    Data data(model);
    compute_kinematics(model, state, data);
    compute_partials_recursive(model, state, data);
    compute_resultants(model, state, data);
    const VectorX fy_oracle = generalized_forces_from_partials(model, data);
    double scale = 0.0;
    for (int k = 0; k < model.num_bodies(); ++k) {
      const double lever = test::max_abs(partial_velocity(model, data, k, Point::G));
      scale = std::max({scale, lever * data.loads.force[static_cast<size_t>(k)].norm(),
                        data.loads.moment_b[static_cast<size_t>(k)].norm()});
    }
    compute_generalized_forces(model, data);
    EXPECT_LT(test::max_abs(data.kane.F_y - fy_oracle), 1e-12 * scale)
        << "N " << model.num_bodies();
    const VectorX staged = data.kane.F_y;
    kane_equations(model, state, data);  // the same state: the same loads
    EXPECT_LT(test::max_abs(data.kane.F_y - fy_oracle), 1e-12 * scale)
        << "N " << model.num_bodies();
    EXPECT_EQ(data.kane.F_y, staged);
  }
}

TEST(Forces, GeneralizedForcesPassThePowerCheck) {
  // Eq. (31) is the statement that F_y . y is the power of the loads:
  //   F_y . y = sum_K F_K . v_G_K + M'_K . w'_K  for every y.
  // Loads and velocities are evaluated at the same random y (the damping terms depend on y,
  // which does not matter for the identity). Round-off relative to the sum of |terms|.
  // compute_generalized_forces after the stages it needs, then kane_equations: both.
  std::mt19937 rng(36);
  test::RandomTreeOptions opt;
  opt.bushings = opt.forces = opt.torques = true;
  for (const Model& model : test::eight_body_and_random_trees(37, 50, opt)) {
    Data data(model);
    for (int trial = 0; trial < 3; ++trial) {
      const State state = test::random_state(model, rng, 0.3, 3.0, 2.0);
      compute_kinematics(model, state, data);
      compute_resultants(model, state, data);
      compute_generalized_forces(model, data);
      double power = 0.0, scale = 0.0;
      for (int k = 0; k < model.num_bodies(); ++k) {
        const auto i = static_cast<size_t>(k);
        const double pf = data.loads.force[i].dot(data.kinematics.v_G[i]);
        const double pm = data.loads.moment_b[i].dot(state.angular_velocity(k));
        power += pf + pm;
        scale += std::abs(pf) + std::abs(pm);
      }
      EXPECT_NEAR(data.kane.F_y.dot(state.y), power, 1e-12 * scale) << "N " << model.num_bodies();
      kane_equations(model, state, data);
      EXPECT_NEAR(data.kane.F_y.dot(state.y), power, 1e-12 * scale) << "N " << model.num_bodies();
    }
  }
}

TEST(Forces, GeneralizedForcesOfOneBushing) {
  // A bushing alone (no gravity) does work only through the relative motion it resists: its
  // power is F' . s'_K dot + M . (w'_K - [R] w'_J), so Eq. (31) gives {F'} on s'_K dot (body-J
  // components, as s'_K), M on w'_K, -[R]^T M on w'_J and zero elsewhere (docs/theory.md,
  // "Force laws"). Round-off relative to the loads times lever arms: 1e-12.
  std::mt19937 rng(65);
  for (int trial = 0; trial < 30; ++trial) {
    test::RandomTreeOptions opt;
    opt.min_bodies = 2;
    opt.max_bodies = 12;
    opt.gravity = Vector3::Zero();
    Model bare = test::random_tree(rng, opt);
    const int n = bare.num_bodies();
    const int k = test::uniform_int(rng, 0, n - 1);
    const auto bushing = random_bushing(rng, k);
    const Model model(bare.bodies(), Vector3::Zero(), {bushing});
    const State state = test::random_state(model, rng);
    Data data(model);
    compute_kinematics(model, state, data);
    compute_resultants(model, state, data);
    compute_generalized_forces(model, data);
    const int j = model.lower_body(k);
    const Vector3 f = bushing->translational_force_b(state);
    Matrix3 r = Matrix3::Identity();
    Vector3 w_rel = state.angular_velocity(k);
    if (j != kGround) {
      r = reference_rotation(state.euler_parameters(k)) *
          reference_rotation(state.euler_parameters(j)).transpose();
      w_rel -= r * state.angular_velocity(j);
    }
    const Vector3 m = -bushing->rotational_stiffness * bushing->rotation_vector(model, state) -
                      bushing->rotational_damping * w_rel;
    VectorX expected = VectorX::Zero(6 * n);
    expected.segment<3>(3 * n + 3 * k) = f;
    expected.segment<3>(3 * k) = m;
    if (j != kGround) expected.segment<3>(3 * j) = -r.transpose() * m;
    EXPECT_LT(test::max_abs(data.kane.F_y - expected), 1e-12 * (1.0 + f.norm() + m.norm()))
        << "N " << n << " K " << k;
  }
}

}  // namespace
}  // namespace kanedyn
