// Eqs. (18)-(30): partial velocity matrices by recursion, directly, and by a third dense
// implementation written here from Eq. (18); the notes' body-8 block patterns; finite
// differences with respect to y and along the motion.
#include <gtest/gtest.h>

#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/partials.hpp"
#include "kanedyn/rotation.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

using test::angular_velocity_selection;
using test::reference_rotation;
using test::translation_rate_selection;

struct DensePartials {
  std::vector<MatrixX> v_O, v_G;  // 3 x 6N each
};

// Eq. (18) with dense 3 x 6N matrices, literally:
//   [v_O_K,y] = [v_O_J,y] - [R_J]^T([q~'_K] + [s~'_K])[w'_J,y] + [R_J]^T [J v'_O_K,y],
// [J v'_O_K,y] = [[0]_{3x3N}, [0 .. I .. 0]] (Eqs. 19-20), [w'_J,y] the selection of Eq. (8);
// for a root {v_O} = {s' dot} (inertial components). Eq. (21):
//   [v_G_K,y] = [v_O_K,y] - [R_K]^T [r~'_K][w'_K,y].
DensePartials dense_partials(const Model& model, const State& state) {
  const int n = model.num_bodies();
  DensePartials out;
  for (int k = 0; k < n; ++k) {
    const int j = model.lower_body(k);
    MatrixX v_o;
    if (j == kGround) {
      v_o = translation_rate_selection(n, k);
    } else {
      const Matrix3 rj_t = reference_rotation(state.euler_parameters(j)).transpose();
      const Vector3 qs = model.body(k).joint + state.translation(k);
      v_o = out.v_O[static_cast<size_t>(j)] - rj_t * skew(qs) * angular_velocity_selection(n, j) +
            rj_t * translation_rate_selection(n, k);
    }
    const Matrix3 rk_t = reference_rotation(state.euler_parameters(k)).transpose();
    out.v_G.push_back(v_o - rk_t * skew(model.body(k).com) * angular_velocity_selection(n, k));
    out.v_O.push_back(std::move(v_o));
  }
  return out;
}

// Recursive and direct routes and the dense Eq. (18) sum the same O(1) terms (|q'+s'| <= 0.9,
// rotations orthogonal): entries are sums of <= 30 products, so errors of ~30 ulp
// (~1e-14). Tolerance 1e-12, a margin of ~100 over that; a wrong block is O(0.1).
constexpr double kAgree = 1e-12;

TEST(Partials, RecursiveDirectAndDenseAgree) {
  std::mt19937 rng(21);
  for (const Model& model : test::eight_body_and_random_trees(22, 200)) {
    const State state = test::random_state(model, rng);
    Data rec(model), dir(model);
    compute_kinematics(model, state, rec);
    compute_kinematics(model, state, dir);
    compute_partials_recursive(model, state, rec);
    compute_partials_direct(model, state, dir);
    const DensePartials dense = dense_partials(model, state);
    for (int k = 0; k < model.num_bodies(); ++k) {
      const auto i = static_cast<size_t>(k);
      for (const Point p : {Point::O, Point::G}) {
        const MatrixX a = partial_velocity(model, rec, k, p);
        const MatrixX b = partial_velocity(model, dir, k, p);
        const MatrixX& c = p == Point::O ? dense.v_O[i] : dense.v_G[i];
        EXPECT_LT(test::max_abs(a - b), kAgree) << "body " << k << " N " << model.num_bodies();
        EXPECT_LT(test::max_abs(a - c), kAgree) << "body " << k << " N " << model.num_bodies();
      }
    }
  }
}

TEST(Partials, EightBodyBlockPatternsOfTheNotes) {
  const Model model = test::eight_body_model();
  const int n = 8;
  std::mt19937 rng(23);
  const State state = test::random_state(model, rng);
  for (auto compute : {compute_partials_recursive, compute_partials_direct}) {
    Data data(model);
    compute_kinematics(model, state, data);
    compute(model, state, data);
    const MatrixX v = partial_velocity(model, data, 7, Point::G);  // body 8
    auto RT = [&](int body) -> Matrix3 {
      return data.kinematics.R[static_cast<size_t>(body - 1)].transpose();
    };
    auto qs = [&](int body) -> Matrix3 {
      return skew(model.body(body - 1).joint + state.translation(body - 1));
    };
    auto y1 = [&](int body) { return v.block<3, 3>(0, 3 * (body - 1)); };
    auto y2 = [&](int body) { return v.block<3, 3>(0, 3 * n + 3 * (body - 1)); };
    // [v_G8,y1] = -[R_1^T(q~7+s~7), 0,0,0,0,0, R_7^T(q~8+s~8), R_8^T r~8]
    // [v_G8,y2] = [I, 0,0,0,0,0, R_1^T, R_7^T]
    const Matrix3 expected_y1[8] = {
        -RT(1) * qs(7),  Matrix3::Zero(), Matrix3::Zero(), Matrix3::Zero(),
        Matrix3::Zero(), Matrix3::Zero(), -RT(7) * qs(8),  -RT(8) * skew(model.body(7).com)};
    const Matrix3 expected_y2[8] = {
        Matrix3::Identity(), Matrix3::Zero(), Matrix3::Zero(), Matrix3::Zero(),
        Matrix3::Zero(),     Matrix3::Zero(), RT(1),           RT(7)};
    for (int b = 1; b <= 8; ++b) {
      EXPECT_LT((y1(b) - expected_y1[b - 1]).cwiseAbs().maxCoeff(), 1e-14) << "y1 block " << b;
      EXPECT_LT((y2(b) - expected_y2[b - 1]).cwiseAbs().maxCoeff(), 1e-14) << "y2 block " << b;
      // Nonzero exactly where the notes say (blocks 1, 7, 8 in both parts).
      const bool on_chain = b == 1 || b == 7 || b == 8;
      EXPECT_EQ(y1(b).isZero(0.0), !on_chain) << "y1 block " << b;
      EXPECT_EQ(y2(b).isZero(0.0), !on_chain) << "y2 block " << b;
    }
    // Body 3 (chain 3, 2, 1): [v_G3,y2] = [I, R_1^T, R_2^T, 0 ...].
    const MatrixX v3 = partial_velocity(model, data, 2, Point::G);
    EXPECT_LT((v3.block<3, 3>(0, 3 * n) - Matrix3::Identity()).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_LT((v3.block<3, 3>(0, 3 * n + 3) - RT(1)).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_LT((v3.block<3, 3>(0, 3 * n + 6) - RT(2)).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_TRUE(v3.rightCols(3 * n - 9).isZero(0.0));
    EXPECT_TRUE(v3.block(0, 9, 3, 3 * n - 9).isZero(0.0));
  }
}

TEST(Partials, PartialVelocityIsDerivativeOfVelocityWithRespectToY) {
  // {v_G} is linear in {y}: (v_G(y + h e_i) - v_G(y - h e_i)) / 2h is exactly column i for any
  // h; with h = 1 only round-off of |v| <= ~100 remains (1e-13). Tolerance 1e-12.
  std::mt19937 rng(24);
  for (const Model& model : test::eight_body_and_random_trees(25, 20)) {
    const State state = test::random_state(model, rng);
    Data data(model), dp(model), dm(model);
    compute_kinematics(model, state, data);
    compute_partials_recursive(model, state, data);
    for (int i = 0; i < model.num_y(); ++i) {
      State sp = state, sm = state;
      sp.y[i] += 1.0;
      sm.y[i] -= 1.0;
      compute_kinematics(model, sp, dp);
      compute_kinematics(model, sm, dm);
      for (int k = 0; k < model.num_bodies(); ++k) {
        const auto kk = static_cast<size_t>(k);
        const Vector3 col_g = partial_velocity(model, data, k, Point::G).col(i);
        const Vector3 col_o = partial_velocity(model, data, k, Point::O).col(i);
        EXPECT_LT((0.5 * (dp.kinematics.v_G[kk] - dm.kinematics.v_G[kk]) - col_g).norm(), 1e-12)
            << k << " " << i;
        EXPECT_LT((0.5 * (dp.kinematics.v_O[kk] - dm.kinematics.v_O[kk]) - col_o).norm(), 1e-12)
            << k << " " << i;
      }
    }
  }
}

TEST(Partials, RatesEqualFiniteDifferenceAlongTheMotion) {
  // [v_O,y dot] (Eq. 30, with s' dot in the third term) and [v_G,y dot] (Eq. 29) against the
  // central difference of the dense partial matrices along x + h xdot (they depend on x
  // only). Entries are O(1) with rates O(|w| + |s' dot|); truncation h^2/6 times the third
  // derivative (<= ~|w|^3 ~ 30) is <= 5e-9 for h = 1e-5, round-off 1e-16/h = 1e-11.
  // Tolerance 1e-7; the literal misprint [s~'] instead of [s'dot~] errs by O(0.1).
  const double h = 1e-5;
  std::mt19937 rng(26);
  for (const Model& model : test::eight_body_and_random_trees(27, 60)) {
    const State state = test::random_state(model, rng);
    const int n = model.num_bodies();
    VectorX xdot(7 * n);
    for (int k = 0; k < n; ++k)
      xdot.segment<4>(4 * k) =
          euler_parameter_rates(state.euler_parameters(k), state.angular_velocity(k));
    xdot.tail(3 * n) = state.y.tail(3 * n);
    const State sp = test::advance(state, xdot, VectorX(), h);
    const State sm = test::advance(state, xdot, VectorX(), -h);
    Data data(model), dp(model), dm(model);
    compute_kinematics(model, state, data);
    compute_partial_rates(model, state, data);
    compute_kinematics(model, sp, dp);
    compute_partials_recursive(model, sp, dp);
    compute_kinematics(model, sm, dm);
    compute_partials_recursive(model, sm, dm);
    for (int k = 0; k < n; ++k) {
      for (const Point p : {Point::O, Point::G}) {
        const MatrixX fd =
            (partial_velocity(model, dp, k, p) - partial_velocity(model, dm, k, p)) / (2 * h);
        EXPECT_LT(test::max_abs(partial_velocity_rate(model, data, k, p) - fd), 1e-7)
            << "body " << k << (p == Point::O ? " O" : " G") << " N " << n;
      }
    }
  }
}

TEST(Partials, RatesOfRootsAndEightBodyExample) {
  // Spot values written from the notes: [v_O1,y dot] = 0 and
  // [v_G1,y dot] = -[R_1]^T [w~'_1][r~'_1][w'_1,y].
  const Model model = test::eight_body_model();
  std::mt19937 rng(28);
  const State state = test::random_state(model, rng);
  Data data(model);
  compute_kinematics(model, state, data);
  compute_partial_rates(model, state, data);
  EXPECT_TRUE(partial_velocity_rate(model, data, 0, Point::O).isZero(0.0));
  const MatrixX expected = -data.kinematics.R[0].transpose() * skew(state.angular_velocity(0)) *
                           skew(model.body(0).com) * angular_velocity_selection(8, 0);
  EXPECT_LT(test::max_abs(partial_velocity_rate(model, data, 0, Point::G) - expected), 1e-14);
  // [v_O2,y dot] = -R_1^T(w~_1(q~_2 + s~_2) + s'dot~_2)[w'_1,y] + R_1^T w~_1 [1 v'_O2,y].
  const Matrix3 r1t = data.kinematics.R[0].transpose();
  const Matrix3 w1 = skew(state.angular_velocity(0));
  const MatrixX expected2 = -r1t *
                                (w1 * skew(model.body(1).joint + state.translation(1)) +
                                 skew(state.translation_rate(1))) *
                                angular_velocity_selection(8, 0) +
                            r1t * w1 * translation_rate_selection(8, 1);
  EXPECT_LT(test::max_abs(partial_velocity_rate(model, data, 1, Point::O) - expected2), 1e-13);
}

TEST(Partials, AngularVelocityPartialIsTheSelection) {
  std::mt19937 rng(29);
  const Model model = test::random_tree(rng);
  for (int k = 0; k < model.num_bodies(); ++k) {
    const MatrixX w = angular_velocity_partial(model, k);
    ASSERT_EQ(w.rows(), 3);
    ASSERT_EQ(w.cols(), model.num_y());
    EXPECT_EQ(w, angular_velocity_selection(model.num_bodies(), k));
  }
}

}  // namespace
}  // namespace kanedyn
