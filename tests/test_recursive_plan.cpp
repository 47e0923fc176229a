// The fused route's plan (src/recursive/): a model not numbered depth first is renumbered so
// from fused::kRenumberFrom bodies on, and the results come back in the user's numbering.
// Checked here: the plan's numbering is a permutation with every body after its lower body;
// random trees and forests, small and large (bushy ones past the kept-scratch limit, where
// pass 2 recomputes), renumbered or not, give the staged route's ydot to round-off and its
// xdot exactly, in the user's numbering; renumbering changes no bit (children reach their
// lower body's loads in the same order), without allocating; and a chain keeps its numbering.
#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <vector>

#include "alloc_counter.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/kinematic_equations.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/testing/generate.hpp"
#include "test_support.hpp"

#include "../src/recursive/fused.hpp"
#include "../src/staged.hpp"
#include "../src/workspace.hpp"

namespace kanedyn {
namespace {

using test::moving_state;
using test::random_state;
using test::random_tree;
using test::RandomTreeOptions;

size_t at(int i) { return static_cast<size_t>(i); }

// The plan's numbering: user is a permutation of 0..N-1 (or empty: the Model's numbering), the
// plan's lower bodies are the Model's renumbered, and each comes before its body.
void expect_valid_numbering(const Model& model, const fused::Plan& plan) {
  const int n = model.num_bodies();
  if (plan.user.empty()) {
    for (int k = 0; k < n; ++k) EXPECT_EQ(plan.lower[at(k)], model.body(k).lower_body);
    return;
  }
  ASSERT_EQ(plan.user.size(), at(n));
  std::vector<int> rank(at(n), -1);
  for (int k = 0; k < n; ++k) {
    const int u = plan.user[at(k)];
    ASSERT_GE(u, 0);
    ASSERT_LT(u, n);
    ASSERT_EQ(rank[at(u)], -1) << "body " << u << " twice";
    rank[at(u)] = k;
  }
  for (int k = 0; k < n; ++k) {
    const int j = model.body(plan.user[at(k)]).lower_body;
    const int plan_j = plan.lower[at(k)];
    EXPECT_EQ(plan_j, j == kGround ? kGround : rank[at(j)]) << "plan body " << k;
    EXPECT_LT(plan_j, k) << "plan body " << k;
  }
}

// ydot and xdot of the fused route with that plan.
void evaluate(const Model& model, const State& state, std::shared_ptr<const fused::Plan> plan,
              Data& data) {
  detail::Workspace& w = workspace(data);
  w.fused_scratch.assign(plan->scratch_size, 0.0);
  w.plan = std::move(plan);
  fused::forward_dynamics(model, state, data);
}

// The staged recursive route (kinematics, resultants of the force elements, Newton-Euler, s''),
// in inertial components: the same algorithm in another coding.
void staged(const Model& model, const State& state, Data& data) {
  detail::staged_forward_dynamics(model, state, data, Route::recursive);
}

// Renumbered (from 0 bodies on) and not (the Model's numbering), each SIMD width this CPU runs:
// the same bits, and the staged route's results to 1e-12 relative (ydot) and exactly (xdot).
void expect_renumbering_exact(const Model& model, const State& state, bool renumbered) {
  Data reference(model, DataOptions::recursive_only());
  staged(model, state, reference);
  for (const int lanes : {2, 4, 8}) {
    if (fused::chosen_lanes(lanes) != lanes) continue;
    const auto plain = fused::compile(model, lanes, model.num_bodies() + 1);
    const auto plan = fused::compile(model, lanes, 0);
    ASSERT_TRUE(plain && plan);
    EXPECT_TRUE(plain->user.empty());
    EXPECT_EQ(plan->user.empty(), !renumbered) << "N " << model.num_bodies();
    expect_valid_numbering(model, *plan);
    Data a(model, DataOptions::recursive_only()), b(model, DataOptions::recursive_only());
    evaluate(model, state, plain, a);
    evaluate(model, state, plan, b);
    EXPECT_EQ(a.ydot, b.ydot) << "N " << model.num_bodies() << ", lanes " << lanes;
    EXPECT_EQ(a.xdot, b.xdot) << "N " << model.num_bodies() << ", lanes " << lanes;
    EXPECT_LE((b.ydot - reference.ydot).norm(), 1e-12 * reference.ydot.norm())
        << "N " << model.num_bodies() << ", lanes " << lanes;
    EXPECT_EQ(b.xdot, reference.xdot) << "N " << model.num_bodies() << ", lanes " << lanes;
  }
}

TEST(RecursivePlan, RandomTreesRenumberedGiveTheSameBitsAndTheStagedRoute) {
  // Bushy trees past kKeepLimit (pass 2 recomputes) and below it (keeps).
  for (const int n : {9, 100, 1000, 9000, fused::kKeepLimit + 3000})
    for (const unsigned seed : {1u, 2u, 3u}) {
      const GeneratedSystem g = random_tree_model(n, seed);
      const State moving = moving_state(g.model, seed + 10);
      expect_renumbering_exact(g.model, g.initial, true);
      expect_renumbering_exact(g.model, moving, true);
      if (n > fused::kKeepLimit) {
        EXPECT_FALSE(fused::compile(g.model, fused::chosen_lanes(8), 0)->keep) << n;
      }
    }
}

TEST(RecursivePlan, RandomForestsWithConstantLoadsRenumbered) {
  // Several roots (L(K) may be the ground), full inertias, bushings on some bodies only,
  // constant forces and torques: every per-body constant goes through the renumbering.
  std::mt19937 rng(21);
  RandomTreeOptions options;
  options.min_bodies = 20;
  options.max_bodies = 300;
  options.bushings = true;
  options.forces = true;
  options.torques = true;
  for (int trial = 0; trial < 12; ++trial) {
    const Model model = random_tree(rng, options);
    const State state = random_state(model, rng);
    // A random forest this size is depth first only by chance; the test needs it renumbered.
    const bool renumbered = !fused::compile(model, 2, 0)->user.empty();
    EXPECT_TRUE(renumbered) << "N " << model.num_bodies();
    expect_renumbering_exact(model, state, renumbered);
  }
}

TEST(RecursivePlan, AChainAndADepthFirstTreeKeepTheirNumbering) {
  const GeneratedSystem chain = chain_model(300, 2);
  expect_renumbering_exact(chain.model, chain.initial, false);
  // A tree numbered depth first already: body k + 1 hangs on k or on an earlier body of the
  // path from the root to k (here: alternately on k and on the root).
  std::vector<BodySpec> bodies = chain.model.bodies();
  for (int k = 2; k < 300; k += 2) bodies[at(k)].lower_body = 0;
  const Model tree(bodies, chain.model.gravity(), chain.model.forces(), "depth-first");
  expect_renumbering_exact(tree, chain.initial, false);
}

TEST(RecursivePlan, LargeRandomTreeIsRenumberedByDefault) {
  // Past kRenumberFrom the plan Data builds is renumbered; bushy, so pass 2 recomputes.
  const int n = fused::kRenumberFrom + 4000;
  const GeneratedSystem g = random_tree_model(n, 7);
  Data fused_data(g.model, DataOptions::recursive_only());
  ASSERT_TRUE(workspace(fused_data).plan);
  const fused::Plan& plan = *workspace(fused_data).plan;
  EXPECT_FALSE(plan.user.empty());
  EXPECT_FALSE(plan.keep);
  expect_valid_numbering(g.model, plan);
  forward_dynamics(g.model, g.initial, fused_data, Route::recursive);
  // The copies into and out of the plan's numbering live in the scratch: nothing allocated
  // (operator new counted by tests/test_no_alloc.cpp, malloc by the shared counter).
  alloc_counter::count = 0;
  alloc_counter::counting = true;
  forward_dynamics(g.model, g.initial, fused_data, Route::recursive);
  alloc_counter::counting = false;
  EXPECT_EQ(alloc_counter::count.load(), 0);
  Data reference(g.model, DataOptions::recursive_only());
  staged(g.model, g.initial, reference);
  EXPECT_LE((fused_data.ydot - reference.ydot).norm(), 1e-12 * reference.ydot.norm());
  EXPECT_EQ(fused_data.xdot, reference.xdot);
  // And the Model's numbering gives the same bits.
  Data plain(g.model, DataOptions::recursive_only());
  evaluate(g.model, g.initial, fused::compile(g.model, plan.lanes, n + 1), plain);
  EXPECT_EQ(plain.ydot, fused_data.ydot);
  EXPECT_EQ(plain.xdot, fused_data.xdot);
}

}  // namespace
}  // namespace kanedyn
