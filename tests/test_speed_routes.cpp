// The fast routes against their oracles: block-sparse [A] and {f} against the dense
// Eqs. (37)-(38) (the tree LDL^T itself: test_tree_ldlt.cpp), the fused O(N) pass against the
// staged recursive route and against the Kane route, the rotation vector against long double,
// and the equations of src/equations.inc on double against the same on SIMD lanes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematic_equations.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/partials.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/testing/generate.hpp"
#include "kanedyn/testing/oracles.hpp"

#include "test_support.hpp"

#include "../src/equations.hpp"
#include "../src/recursive/fused.hpp"
#include "../src/staged.hpp"
#include "../src/workspace.hpp"

namespace kanedyn {
namespace {

// Unit Euler parameters (absolute, independent per body: relative rotations of any angle, so
// every sector of the rotation vector occurs), s' within 5 cm, speeds of order 1.
State random_state(std::mt19937& rng, const Model& model) {
  return test::random_state(model, rng, 0.05, 2.0, 0.5);
}

TEST(SpeedRoutes, RotationVectorIsCorrectToRoundOff) {
  // The rotation vector (sector reduction and a series, no atan2; src/equations.inc) against
  // the formula 2 atan2(|e|, e4) e / |e| in long double from the same double inputs. Its
  // roundings (t, the reduced argument, the table angle, the series, phi / |e|, the product
  // with e) add to a few ulp; cancellation in atan(c_k) + atan(r) at the low end of a sector
  // costs up to 2 ulp more. 8e-16 relative is 4 ulp of the norm.
  std::mt19937 rng(1);
  std::vector<double> angles = {0.0, 1e-300, 1e-12, 1e-8, 1e-3, 0.1, 3.14159, M_PI};
  for (int i = 0; i < 8; ++i)  // sector boundaries of the half angle, (2i+1) pi/24, +- 1e-9
    for (double d : {-1e-9, 0.0, 1e-9}) angles.push_back((2 * i + 1) * M_PI / 12 + d);
  for (int i = 0; i < 20000; ++i) angles.push_back(test::uniform(rng, 0.0, M_PI));
  for (int i = 0; i < 2000; ++i) angles.push_back(test::uniform(rng, 0.0, 0.3));
  for (const double angle : angles) {
    for (const double sign : {1.0, -1.0}) {
      const Vector3 axis = test::random_vector(rng, -1.0, 1.0);
      const Vector4 eps = sign * euler_parameters_from_axis_angle(axis, angle);
      long double v[3] = {eps[0], eps[1], eps[2]}, s = eps[3];
      if (s < 0) {
        for (long double& c : v) c = -c;
        s = -s;
      }
      const long double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
      const long double scale = n == 0 ? 2.0L / s : 2.0L * std::atan2(n, s) / n;
      const Vector3 expected(static_cast<double>(scale * v[0]), static_cast<double>(scale * v[1]),
                             static_cast<double>(scale * v[2]));
      EXPECT_LE((rotation_vector(eps) - expected).norm(), 8e-16 * expected.norm())
          << "angle " << angle << " sign " << sign;
    }
  }
}

}  // namespace

// Two lanes of doubles as the fused kernel's number type (src/recursive/fused_kernel.inc does the
// same with intrinsics).
using Pack2 = double __attribute__((vector_size(16)));
template <>
struct eq::Lanes<Pack2> {
  static Pack2 sqrt(const Pack2& v) { return Pack2{std::sqrt(v[0]), std::sqrt(v[1])}; }
  template <typename Mask>
  static bool all(const Mask& m) {
    return m[0] && m[1];
  }
};

namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(SpeedRoutes, EquationsGiveTheSameBitsOnDoubleAndOnLanes) {
  // src/equations.inc is instantiated with double by the staged route and with lane packs by
  // the fused kernel: every lane must give what double gives, bit for bit, also when one lane
  // takes the rotation vector's large-angle branch and the other the series.
  std::mt19937 rng(2);
  const auto lanes = [](double a, double b) { return Pack2{a, b}; };
  for (int i = 0; i < 400; ++i) {
    Vector4 e[2], f[2];
    Vector3 v[2];
    for (int l = 0; l < 2; ++l) {
      const double angle =
          (i + l) % 3 == 0 ? test::uniform(rng, 0.0, 0.2) : test::uniform(rng, 0.0, 6.3);
      e[l] = euler_parameters_from_axis_angle(test::random_vector(rng, -1.0, 1.0), angle);
      f[l] = test::random_euler_parameters(rng);
      v[l] = test::random_vector(rng, -1.0, 1.0);
    }
    eq::Euler<Pack2> ep, fp;
    for (int c = 0; c < 4; ++c) {
      ep.e[c] = lanes(e[0][c], e[1][c]);
      fp.e[c] = lanes(f[0][c], f[1][c]);
    }
    const eq::Vec3<Pack2> vp{lanes(v[0].x(), v[1].x()), lanes(v[0].y(), v[1].y()),
                             lanes(v[0].z(), v[1].z())};
    const eq::Euler<Pack2> rel = eq::relative_euler_parameters(fp, ep);
    const eq::Mat3<Pack2> r = eq::rotation_matrix(rel);
    const eq::Vec3<Pack2> turned = eq::rotate(ep, vp), theta = eq::rotation_vector(rel);
    const eq::Euler<Pack2> rates = eq::euler_parameter_rates(ep, vp);
    for (int l = 0; l < 2; ++l) {
      const Vector4 rel1 = relative_euler_parameters(f[l], e[l]);
      const Matrix3 r1 = rotation_matrix(rel1);
      const Vector3 theta1 = rotation_vector(rel1);
      const Vector3 turned1 = eq::eigen(eq::rotate(eq::euler(e[l]), eq::vec(v[l])));
      const Vector4 rates1 = euler_parameter_rates(e[l], v[l]);
      for (int c = 0; c < 4; ++c) {
        EXPECT_TRUE(same_bits(rel.e[c][l], rel1[c]));
        EXPECT_TRUE(same_bits(rates.e[c][l], rates1[c]));
      }
      for (int c = 0; c < 9; ++c) EXPECT_TRUE(same_bits(r.a[c][l], r1(c / 3, c % 3)));
      for (int c = 0; c < 3; ++c) {
        const double t[3] = {theta.x[l], theta.y[l], theta.z[l]};
        const double u[3] = {turned.x[l], turned.y[l], turned.z[l]};
        EXPECT_TRUE(same_bits(t[c], theta1[c])) << "lane " << l;
        EXPECT_TRUE(same_bits(u[c], turned1[c]));
      }
      // [R]{v} without forming [R] (the kernel's gravity into body axes): Eqs. (3)-(4).
      EXPECT_LT((turned1 - rotation_matrix(e[l]) * v[l]).norm(), 1e-15);
    }
  }
}

TEST(SpeedRoutes, BlockMassMatrixEqualsDenseOracle) {
  // Eq. (37) two ways: the dense sum over the pairs of partial blocks of every chain, and the
  // block-sparse assembly from subtree sums. The sums are the same products in another order
  // and the fast route uses [R][R]^T = [I] (true to 1e-16): round-off relative to max |A|;
  // 1e-12 leaves a margin of ~100 over the ~N ulp of sums of N terms.
  std::mt19937 rng(3);
  for (const Model& model : test::models_of_every_size(rng)) {
    const State state = random_state(rng, model);
    Data data(model);
    compute_kinematics(model, state, data);
    compute_partials_recursive(model, state, data);
    const MatrixX oracle = oracles::mass_matrix_term_by_term(model, data);
    kane_equations(model, state, data);
    EXPECT_LT(test::max_abs(data.kane.A - oracle), 1e-12 * test::max_abs(oracle))
        << "N " << model.num_bodies();
    // Blocks outside the chains are exactly zero in both.
    for (int a = 0; a < model.num_bodies(); ++a)
      for (int b = 0; b < model.num_bodies(); ++b) {
        if (model.on_chain(a, b) || model.on_chain(b, a)) continue;
        for (int p = 0; p < 2; ++p)
          for (int q = 0; q < 2; ++q) {
            const int n = model.num_bodies();
            const Matrix3 block = data.kane.A.block<3, 3>(3 * n * p + 3 * a, 3 * n * q + 3 * b);
            EXPECT_TRUE(block.isZero(0.0));
          }
      }
    EXPECT_EQ(data.kane.A, data.kane.A.transpose());
  }
}

TEST(SpeedRoutes, TreeForceVectorEqualsOracle) {
  // Eq. (38) by subtree sums against the notes' term-by-term sum over every body's chain of
  // [v_G,y]^T blocks. Round-off relative to the size of the largest load term (the entries
  // themselves can cancel). Eq. (31) by subtree sums: Forces.GeneralizedForcesEqualChainSums.
  std::mt19937 rng(4);
  for (const Model& model : test::models_of_every_size(rng)) {
    const State state = random_state(rng, model);
    Data data(model);
    compute_kinematics(model, state, data);
    compute_partials_recursive(model, state, data);
    compute_partial_rates(model, state, data);
    compute_resultants(model, state, data);
    const VectorX f_oracle = oracles::force_vector_term_by_term(model, state, data);
    double scale = 0.0;
    for (int k = 0; k < model.num_bodies(); ++k) {
      const BodySpec& b = model.body(k);
      const Vector3 w = state.angular_velocity(k);
      const MatrixX v = partial_velocity(model, data, k, Point::G);
      const MatrixX vdot = partial_velocity_rate(model, data, k, Point::G);
      const double lever = test::max_abs(v);
      scale = std::max({scale, lever * data.loads.force[static_cast<size_t>(k)].norm(),
                        lever * b.mass * (vdot * state.y).norm(),
                        data.loads.moment_b[static_cast<size_t>(k)].norm(),
                        w.cross(b.inertia * w).norm()});
    }
    kane_equations(model, state, data);  // the same state: the same partials and loads
    EXPECT_LT((data.kane.f - f_oracle).cwiseAbs().maxCoeff(), 1e-12 * scale)
        << "N " << model.num_bodies();
  }
}

TEST(SpeedRoutes, KaneEquationsFillTheDenseMatrixAndSolveEquation36) {
  std::mt19937 rng(7);
  for (const Model& model : test::models_of_every_size(rng)) {
    const State state = random_state(rng, model);
    Data data(model);
    kane_equations(model, state, data);
    const MatrixX oracle = oracles::mass_matrix_term_by_term(model, data);
    EXPECT_LT(test::max_abs(data.kane.A - oracle), 1e-12 * test::max_abs(oracle));
    const VectorX residual = data.kane.A * data.ydot - data.kane.f;
    // Backward stable elimination: |A ydot - f| ~ 6N eps (|A| |ydot| + |f|).
    EXPECT_LT(residual.cwiseAbs().maxCoeff(),
              1e-14 * model.num_y() *
                  (test::max_abs(data.kane.A) * data.ydot.cwiseAbs().maxCoeff() +
                   test::max_abs(data.kane.f)));
    Data lean(model, DataOptions{.partials = false, .dense_mass_matrix = false});
    kane_equations(model, state, lean);
    EXPECT_EQ(lean.kane.A.size(), 0);
    EXPECT_EQ(lean.ydot, data.ydot);  // the same operations without the extras
  }
}

// Same algorithm (body-frame Newton-Euler, then s'') in two codings: the fused pass with
// relative Euler parameters vs the staged one in inertial components. Round-off of chains
// of transformations: 1e-12 relative to |ydot|.
void expect_fused_equals_staged(const Model& model, const State& state) {
  Data fused(model, DataOptions::recursive_only());
  ASSERT_TRUE(fused.single_pass());
  forward_dynamics(model, state, fused, Route::recursive);
  Data staged(model, DataOptions::recursive_only());
  detail::staged_forward_dynamics(model, state, staged, Route::recursive);
  EXPECT_LE((fused.ydot - staged.ydot).norm(), 1e-12 * staged.ydot.norm())
      << "N " << model.num_bodies();
  EXPECT_EQ(fused.xdot, staged.xdot);  // the same expressions, exactly
}

TEST(SpeedRoutes, FusedPassEqualsStagedRecursiveRoute) {
  std::mt19937 rng(8);
  for (const Model& model : test::models_of_every_size(rng))
    for (int trial = 0; trial < 3; ++trial)
      expect_fused_equals_staged(model, random_state(rng, model));
}

// The fused kernel is compiled for 2, 4 and 8 bodies per SIMD pass (src/recursive/fused.hpp) with
// only lane-wise IEEE operations and no FMA, so every width this CPU runs gives the same bits as
// the 2-lane kernel: at random states (large relative rotations: the scalar rotation-vector
// fallback) and near rest (small ones: the lanes' series branch).
TEST(SpeedRoutes, EverySimdWidthGivesTheSameBits) {
  std::mt19937 rng(12);
  int widths_run = 0;
  for (const Model& model : test::models_of_every_size(rng)) {
    State near_rest = random_state(rng, model);
    for (int k = 0; k < model.num_bodies(); ++k)
      near_rest.euler_parameters(k) =
          Vector4(test::random_vector(rng, -0.02, 0.02).homogeneous()).normalized();
    for (const State& state : {random_state(rng, model), near_rest}) {
      Data base(model, DataOptions::recursive_only(2));
      ASSERT_EQ(base.simd_lanes(), 2);
      forward_dynamics(model, state, base, Route::recursive);
      for (int cap : {4, 8}) {
        Data wide(model, DataOptions::recursive_only(cap));
        ASSERT_TRUE(wide.simd_lanes() == 2 || wide.simd_lanes() == 4 || wide.simd_lanes() == 8);
        ASSERT_LE(wide.simd_lanes(), cap);
        if (wide.simd_lanes() == 2) continue;  // the CPU has no wider kernel
        ++widths_run;
        forward_dynamics(model, state, wide, Route::recursive);
        EXPECT_EQ(wide.ydot, base.ydot) << "lanes " << wide.simd_lanes();
        EXPECT_EQ(wide.xdot, base.xdot) << "lanes " << wide.simd_lanes();
      }
    }
  }
  if (widths_run == 0) GTEST_SKIP() << "this CPU runs only the 2-lane kernel";
}

// Groups of bodies whose constants are equal bit for bit share one copy (src/recursive/fused.cpp):
// a chain of identical links needs two (the root's group differs), a link changed by one ulp gets a
// copy of its own, and the results stay those of the staged route.
TEST(SpeedRoutes, GroupsOfEqualConstantsAreShared) {
  const auto distinct = [](const Data& d) {
    return std::set<int>(workspace(d).plan->param_group.begin(),
                         workspace(d).plan->param_group.end())
        .size();
  };
  const GeneratedSystem chain = chain_model(600, 3);
  Data shared(chain.model, DataOptions::recursive_only());
  EXPECT_EQ(workspace(shared).plan->param_group.size(),
            static_cast<size_t>(600 / shared.simd_lanes()));
  EXPECT_EQ(distinct(shared), 2u);
  expect_fused_equals_staged(chain.model, chain.initial);
  for (const double factor : {std::nextafter(1.0, 2.0), 2.0}) {
    std::vector<BodySpec> bodies = chain.model.bodies();
    bodies[300].mass *= factor;
    const Model changed(bodies, chain.model.gravity(), chain.model.forces(), "changed");
    Data own(changed, DataOptions::recursive_only());
    EXPECT_EQ(distinct(own), 3u) << factor;
    expect_fused_equals_staged(changed, chain.initial);
  }
  std::mt19937 rng(4);
  const Model tree = test::random_loaded_model(rng, 64);  // distinct masses: nothing shared
  Data none(tree, DataOptions::recursive_only());
  EXPECT_EQ(distinct(none), workspace(none).plan->param_group.size());
}

// Past fused::kKeepLimit bodies pass 1 keeps its results for pass 2 only where pass 2 follows
// soon (a chain, whose scratch is then a small ring); a random tree's pass 2 gathers and
// recomputes them. Both codings give the staged route's results.
TEST(SpeedRoutes, LargeModelsKeepOrRecomputeForPassTwo) {
  const int n = fused::kKeepLimit + 1000;
  const GeneratedSystem chain = chain_model(n, 5), tree = random_tree_model(n, 5);
  const Data chain_data(chain.model, DataOptions::recursive_only());
  EXPECT_TRUE(workspace(chain_data).plan->keep);
  // A chain's pass 2 follows one group later: its scratch is a ring of 4 groups, not n
  // bodies' worth.
  EXPECT_EQ(workspace(chain_data).plan->scratch_mask, 3);
  EXPECT_LT(workspace(chain_data).fused_scratch.size(), 2000u);
  EXPECT_FALSE(workspace(Data(tree.model, DataOptions::recursive_only())).plan->keep);
  EXPECT_TRUE(
      workspace(Data(random_tree_model(fused::kKeepLimit, 5).model, DataOptions::recursive_only()))
          .plan->keep);
  expect_fused_equals_staged(chain.model, chain.initial);
  expect_fused_equals_staged(tree.model, tree.initial);
}

TEST(SpeedRoutes, RecursiveAndKaneRoutesAgreeOnLargeTreesAndDeepChains) {
  // Two algorithms for Eq. (36), required to agree to 1e-10 relative. The Kane route's error is the
  // condition of [A] times round-off; for these models cond(A) stays below ~1e5.
  std::mt19937 rng(9);
  std::vector<Model> models = test::models_of_every_size(rng);
  for (int n : {100, 200}) models.push_back(test::random_loaded_model(rng, n));
  for (int n : {50, 100, 200}) models.push_back(test::random_loaded_model(rng, n, true));
  for (const Model& model : models) {
    const State state = random_state(rng, model);
    Data kane(model, DataOptions{.partials = false, .dense_mass_matrix = false}),
        rec(model, DataOptions::recursive_only());
    forward_dynamics(model, state, kane, Route::assembled);
    forward_dynamics(model, state, rec, Route::recursive);
    EXPECT_LE((kane.ydot - rec.ydot).norm(), 1e-10 * rec.ydot.norm()) << "N " << model.num_bodies();
    EXPECT_EQ(kane.xdot, rec.xdot);
  }
}

// A force element the fused pass does not know: it must take the staged route.
class Spring final : public ForceElement {
 public:
  explicit Spring(int body) : body_(body) {}
  std::string type() const override { return "test-spring"; }
  int body() const override { return body_; }
  void apply(const Model&, const State&, const Kinematics& kin, Loads& loads) const override {
    loads.force[static_cast<size_t>(body_)] -= 100.0 * kin.p_G[static_cast<size_t>(body_)];
  }

 private:
  int body_;
};

TEST(SpeedRoutes, UnknownForceElementTakesTheStagedRoute) {
  std::mt19937 rng(10);
  const Model base = test::random_loaded_model(rng, 6);
  std::vector<std::shared_ptr<const ForceElement>> forces = base.forces();
  forces.push_back(std::make_shared<Spring>(3));
  const Model model(base.bodies(), base.gravity(), forces);
  const State state = random_state(rng, model);
  Data rec(model, DataOptions::recursive_only()), kane(model);
  EXPECT_FALSE(rec.single_pass());
  forward_dynamics(model, state, rec, Route::recursive);
  forward_dynamics(model, state, kane, Route::assembled);
  EXPECT_LE((kane.ydot - rec.ydot).norm(), 1e-10 * rec.ydot.norm());
  // ...and the spring does act: without it the accelerations differ.
  Data plain(base, DataOptions::recursive_only());
  forward_dynamics(base, state, plain, Route::recursive);
  EXPECT_GT((plain.ydot - rec.ydot).norm(), 1e-3 * rec.ydot.norm());
}

TEST(SpeedRoutes, KaneRouteNeedsTheMassMatrixOption) {
  std::mt19937 rng(11);
  const Model model = test::random_loaded_model(rng, 3);
  const State state = random_state(rng, model);
  Data data(model, DataOptions::recursive_only());
  EXPECT_THROW(forward_dynamics(model, state, data, Route::assembled), std::invalid_argument);
  EXPECT_NO_THROW(forward_dynamics(model, state, data, Route::recursive));
}

TEST(SpeedRoutes, DeepChainWithoutFlatChainStorage) {
  // 6000 bodies: 18,003,000 chain entries > Model::kMaxFlatChainEntries. Chains walk L, the
  // Kane route and the partials refuse with a message, the recursive route runs.
  std::mt19937 rng(12);
  const int n = 6000;
  std::vector<BodySpec> bodies(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    BodySpec& b = bodies[static_cast<size_t>(k)];
    b.name = test::numbered_name("link", k);
    b.lower_body = k - 1;
    b.mass = 1.0;
    b.inertia = Vector3(0.02, 0.02, 0.001).asDiagonal();
    b.com = Vector3(0, 0, -0.25);
    b.joint = k == 0 ? Vector3::Zero() : Vector3(0, 0, -0.5);
  }
  std::vector<std::shared_ptr<const ForceElement>> forces;
  for (int k = 0; k < n; ++k)
    forces.push_back(
        std::make_shared<Bushing>(k, Vector3::Constant(1e4), Vector3::Constant(10), 100.0, 0.1));
  const Model model(std::move(bodies), Vector3(0, 0, -9.81), std::move(forces));
  ASSERT_GT(model.chain_entries(), Model::kMaxFlatChainEntries);
  EXPECT_FALSE(model.has_flat_chains());
  EXPECT_EQ(model.chain_entries(), static_cast<long long>(n) * (n + 1) / 2);
  for (const int k : {0, 1, 2500, n - 1}) {
    const Model::Chain chain = model.chain(k);
    EXPECT_EQ(chain.size, k + 1);
    EXPECT_EQ(chain.back(), 0);
    EXPECT_EQ(model.root(k), 0);
    int r = 0;
    for (const int c : chain) {
      EXPECT_EQ(c, k - r);
      EXPECT_EQ(chain[r], k - r);
      ++r;
    }
    EXPECT_EQ(r, k + 1);
    EXPECT_TRUE(model.on_chain(k / 2, k));
    EXPECT_TRUE(model.on_chain(k, k));
    EXPECT_TRUE(model.on_chain(0, k));
    if (k + 1 < n) {  // the last body has no later one; the checks above hold for it too
      EXPECT_FALSE(model.on_chain(k + 1, k));
    }
  }
  // Data(model) leaves out what the model's size does not allow; asked for, it is refused.
  EXPECT_FALSE(Data(model).options().partials);
  EXPECT_FALSE(Data(model).options().kane_terms);
  EXPECT_THROW(Data(model, DataOptions{}), ModelError);
  EXPECT_THROW(Data(model, DataOptions{.partials = false}), ModelError);
  State state(model);
  for (int k = 0; k < n; ++k) {
    const Vector4 e = test::random_euler_parameters(rng);
    state.euler_parameters(k) = e;  // large relative angles along the chain
    state.angular_velocity(k) = test::random_vector(rng, -1.0, 1.0);
  }
  expect_fused_equals_staged(model, state);
}

TEST(SpeedRoutes, FlatAndWalkedChainsAgree) {
  std::mt19937 rng(13);
  const Model model = test::random_loaded_model(rng, 40);
  ASSERT_TRUE(model.has_flat_chains());
  for (int k = 0; k < model.num_bodies(); ++k) {
    const Model::Chain flat = model.chain(k);
    Model::Chain walked = flat;
    walked.first = nullptr;
    int r = 0;
    for (const int c : walked) EXPECT_EQ(c, flat[r++]);
    EXPECT_EQ(r, flat.size);
    for (int i = 0; i < flat.size; ++i) EXPECT_EQ(walked[i], flat[i]);
    EXPECT_EQ(flat.back(), model.root(k));
    EXPECT_EQ(model.root(k), flat[flat.size - 1]);
  }
}

}  // namespace
}  // namespace kanedyn
