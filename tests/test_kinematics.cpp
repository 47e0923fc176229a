// Eqs. (11)-(17): positions by recursion against the direct sum of Eq. (22), velocities
// against finite differences of the positions along the motion, and {v} = [v,y]{y}.
#include <gtest/gtest.h>

#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/kinematic_equations.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/partials.hpp"
#include "kanedyn/rotation.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

using test::reference_rotation;

struct DirectPositions {
  std::vector<Vector3> p_O, p_G;
};

// Eq. (22) summed directly over K's chain (walking L(K) here, not Model::chain), with the
// root's fixed attachment point q' (inertial) added as the README allows:
//   p_G_K = q'_root + s'_root + sum_{r=0}^{u_K-1} [R_{L^{r+1}(K)}]^T ({q'} + {s'})_{L^r(K)}
//           + [R_K]^T {r'_K}.
DirectPositions direct_positions(const Model& model, const State& state) {
  DirectPositions out;
  for (int k = 0; k < model.num_bodies(); ++k) {
    Vector3 p = Vector3::Zero();
    for (int c = k; c != kGround; c = model.lower_body(c)) {
      const int l = model.lower_body(c);
      const Vector3 qs = model.body(c).joint + state.translation(c);
      p += l == kGround ? qs
                        : Vector3(reference_rotation(state.euler_parameters(l)).transpose() * qs);
    }
    out.p_O.push_back(p);
    out.p_G.push_back(p + reference_rotation(state.euler_parameters(k)).transpose() *
                              model.body(k).com);
  }
  return out;
}

TEST(Kinematics, RecursivePositionsEqualDirectSum) {
  // Round-off: a chain of up to 30 terms of size <= 1.5 gives |p| <= ~45 with an error of
  // ~30 ulp of that (1e-14); 1e-12 absolute leaves a wide margin, while any missing or
  // wrongly rotated term is O(0.1).
  std::mt19937 rng(11);
  for (const Model& model : test::eight_body_and_random_trees(12, 100)) {
    Data data(model);
    const State state = test::random_state(model, rng);
    compute_kinematics(model, state, data);
    const DirectPositions direct = direct_positions(model, state);
    for (int k = 0; k < model.num_bodies(); ++k) {
      const auto i = static_cast<size_t>(k);
      EXPECT_LT((data.kinematics.p_O[i] - direct.p_O[i]).norm(), 1e-12) << "body " << k;
      EXPECT_LT((data.kinematics.p_G[i] - direct.p_G[i]).norm(), 1e-12) << "body " << k;
      EXPECT_LT((data.kinematics.R[i] - reference_rotation(state.euler_parameters(k)))
                    .cwiseAbs()
                    .maxCoeff(),
                1e-14);
      EXPECT_EQ(data.kinematics.qs_b[i], Vector3(model.body(k).joint + state.translation(k)));
    }
  }
}

TEST(Kinematics, EightBodyPositionsAsWrittenInTheNotes) {
  // The notes' worked example for body 8 (L = 7, L(7) = 1), written term by term:
  //   p_O8 = s'_1 + R_1^T(q'_7 + s'_7) + R_7^T(q'_8 + s'_8),  p_G8 = p_O8 + R_8^T r'_8,
  // plus our root attachment q'_1.
  const Model model = test::eight_body_model();
  std::mt19937 rng(13);
  const State s = test::random_state(model, rng);
  Data data(model);
  compute_kinematics(model, s, data);
  auto R = [&](int body) { return reference_rotation(s.euler_parameters(body - 1)); };
  auto q = [&](int body) { return model.body(body - 1).joint; };
  auto sp = [&](int body) { return Vector3(s.translation(body - 1)); };
  const Vector3 p_o8 =
      q(1) + sp(1) + R(1).transpose() * (q(7) + sp(7)) + R(7).transpose() * (q(8) + sp(8));
  EXPECT_LT((data.kinematics.p_O[7] - p_o8).norm(), 1e-13);
  EXPECT_LT((data.kinematics.p_G[7] - (p_o8 + R(8).transpose() * model.body(7).com)).norm(), 1e-13);
  const Vector3 p_o3 =
      q(1) + sp(1) + R(1).transpose() * (q(2) + sp(2)) + R(2).transpose() * (q(3) + sp(3));
  EXPECT_LT((data.kinematics.p_O[2] - p_o3).norm(), 1e-13);
}

// xdot written here from Eqs. (39)-(41): eps_dot per body, s' dot = y2.
VectorX reference_xdot(const Model& model, const State& state) {
  const int n = model.num_bodies();
  VectorX xdot(7 * n);
  for (int k = 0; k < n; ++k)
    xdot.segment<4>(4 * k) =
        euler_parameter_rates(state.euler_parameters(k), state.angular_velocity(k));
  xdot.tail(3 * n) = state.y.tail(3 * n);
  return xdot;
}

TEST(Kinematics, VelocitiesEqualFiniteDifferenceOfPositions) {
  // Central difference of p(x + h xdot) with h = 1e-5 (Euler parameters renormalized).
  // Truncation h^2/6 |p'''|: |p'''| is bounded by ~ N |w|^3 |offset| <= 30 * 27 * 1.5, so
  // <= 2e-8 at worst and ~1e-10 typically; round-off eps |p| / h <= 1e-16 * 45 / 1e-5 = 5e-10.
  // Tolerance 1e-7 on velocities of size O(1..30); a wrong term (e.g. a missing w x (q+s)
  // or r' term) is O(0.1) or more.
  const double h = 1e-5;
  std::mt19937 rng(14);
  for (const Model& model : test::eight_body_and_random_trees(15, 60)) {
    Data data(model), dp(model), dm(model);
    const State state = test::random_state(model, rng);
    compute_kinematics(model, state, data);
    const VectorX xdot = reference_xdot(model, state);
    const VectorX no_ydot;
    compute_kinematics(model, test::advance(state, xdot, no_ydot, h), dp);
    compute_kinematics(model, test::advance(state, xdot, no_ydot, -h), dm);
    for (int k = 0; k < model.num_bodies(); ++k) {
      const auto i = static_cast<size_t>(k);
      const Vector3 fd_o = (dp.kinematics.p_O[i] - dm.kinematics.p_O[i]) / (2 * h);
      const Vector3 fd_g = (dp.kinematics.p_G[i] - dm.kinematics.p_G[i]) / (2 * h);
      EXPECT_LT((data.kinematics.v_O[i] - fd_o).norm(), 1e-7)
          << "body " << k << " of " << model.num_bodies();
      EXPECT_LT((data.kinematics.v_G[i] - fd_g).norm(), 1e-7)
          << "body " << k << " of " << model.num_bodies();
    }
  }
}

TEST(Kinematics, VelocitiesEqualPartialVelocityTimesSpeeds) {
  // {v_G} = [v_G,y]{y}, {v_O} = [v_O,y]{y} (Eqs. 18, 21): the same sums in another order,
  // so round-off only (|v| <= ~100, 1e-12 absolute).
  std::mt19937 rng(16);
  for (const Model& model : test::eight_body_and_random_trees(17, 60)) {
    Data data(model);
    const State state = test::random_state(model, rng);
    compute_kinematics(model, state, data);
    compute_partials_recursive(model, state, data);
    for (int k = 0; k < model.num_bodies(); ++k) {
      const auto i = static_cast<size_t>(k);
      const Vector3 vg = partial_velocity(model, data, k, Point::G) * state.y;
      const Vector3 vo = partial_velocity(model, data, k, Point::O) * state.y;
      EXPECT_LT((vg - data.kinematics.v_G[i]).norm(), 1e-12) << "body " << k;
      EXPECT_LT((vo - data.kinematics.v_O[i]).norm(), 1e-12) << "body " << k;
      // {w'_K} = [w'_K,y]{y} (Eq. 7).
      EXPECT_EQ(Vector3(angular_velocity_partial(model, k) * state.y),
                Vector3(state.angular_velocity(k)));
    }
  }
}

TEST(Kinematics, RootAttachmentAndZeroState) {
  // At the zero state (identity orientations, s' = 0) the origins sit at the sums of the
  // joint offsets and each G_K at O_K + r'_K; all velocities vanish.
  const Model model = test::eight_body_model();
  const State state(model);
  Data data(model);
  compute_kinematics(model, state, data);
  for (int k = 0; k < model.num_bodies(); ++k) {
    Vector3 p = Vector3::Zero();
    for (int c = k; c != kGround; c = model.lower_body(c)) p += model.body(c).joint;
    const auto i = static_cast<size_t>(k);
    EXPECT_LT((data.kinematics.p_O[i] - p).norm(), 1e-15);
    EXPECT_LT((data.kinematics.p_G[i] - p - model.body(k).com).norm(), 1e-15);
    EXPECT_EQ(data.kinematics.v_O[i], Vector3::Zero());
    EXPECT_EQ(data.kinematics.v_G[i], Vector3::Zero());
  }
}

}  // namespace
}  // namespace kanedyn
