// Generated systems (include/kanedyn/testing/generate.hpp): sizes, topology, mass properties,
// bushings, determinism and the documented ranges of the initial state.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <stdexcept>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/testing/generate.hpp"

namespace kanedyn {
namespace {

using P = LinkParameters;

// Properties every generated system must have, whatever its topology.
void expect_common_properties(const GeneratedSystem& g, int n) {
  const Model& m = g.model;
  ASSERT_EQ(m.num_bodies(), n);
  ASSERT_EQ(g.initial.num_bodies(), n);
  ASSERT_EQ(g.initial.x.size(), 7 * n);
  EXPECT_EQ(m.gravity(), Vector3(0.0, 0.0, P::gravity_z));
  // One bushing per body, each on a different body.
  std::set<int> bushed;
  for (const auto& f : m.forces()) {
    ASSERT_EQ(f->type(), "bushing");
    const auto& b = dynamic_cast<const Bushing&>(*f);
    EXPECT_EQ(b.stiffness, Vector3::Constant(P::stiffness));
    EXPECT_EQ(b.damping, Vector3::Constant(P::damping));
    EXPECT_EQ(b.rotational_stiffness, P::rot_stiffness);
    EXPECT_EQ(b.rotational_damping, P::rot_damping);
    bushed.insert(b.body());
  }
  EXPECT_EQ(m.forces().size(), static_cast<size_t>(n));
  EXPECT_EQ(bushed.size(), static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    const BodySpec& b = m.body(k);
    // r' at mid-link; q' at the lower link's far end (the origin for a root).
    EXPECT_EQ(b.com, Vector3(0.0, 0.0, -0.5 * P::link_length)) << "body " << k;
    const Vector3 joint =
        b.lower_body == kGround ? Vector3::Zero() : Vector3(0.0, 0.0, -P::link_length);
    EXPECT_EQ(b.joint, joint) << "body " << k;
    // A box about its long axis z: Ixx = Iyy > Izz, no products.
    EXPECT_EQ(b.inertia(0, 0), b.inertia(1, 1));
    EXPECT_GT(b.inertia(0, 0), b.inertia(2, 2));
    EXPECT_TRUE(b.inertia.isDiagonal(0.0));
  }
}

// The initial state lies in the ranges generate.hpp documents and is not trivial.
void expect_initial_state_in_range(const GeneratedSystem& g) {
  const Model& m = g.model;
  const State& s = g.initial;
  double largest_angle = 0.0;
  for (int k = 0; k < m.num_bodies(); ++k) {
    const Vector4 eps = s.euler_parameters(k);
    // Unit norm to round-off (a few ulps after normalization).
    EXPECT_NEAR(eps.norm(), 1.0, 4e-16) << "body " << k;
    const int j = m.lower_body(k);
    const Vector4 rel = j == kGround ? eps : relative_euler_parameters(s.euler_parameters(j), eps);
    const double angle = rotation_vector(rel).norm();
    // The angle is recovered from a composed matrix, so allow round-off above the bound.
    EXPECT_LE(angle, kMaxInitialRelativeAngle + 1e-12) << "body " << k;
    largest_angle = std::max(largest_angle, angle);
    EXPECT_LE(s.translation(k).cwiseAbs().maxCoeff(), 0.01);
    EXPECT_LE(s.angular_velocity(k).cwiseAbs().maxCoeff(), 1.0);
    EXPECT_LE(s.translation_rate(k).cwiseAbs().maxCoeff(), 0.1);
  }
  // Non-trivial: bodies are turned and moving (a uniform draw in [0, 0.4] over many bodies).
  if (m.num_bodies() >= 8) {
    EXPECT_GT(largest_angle, 0.1);
  }
  EXPECT_GT(s.y.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT(s.x2().cwiseAbs().maxCoeff(), 0.0);
}

TEST(Generate, ChainHasChainTopology) {
  for (int n : {1, 2, 8, 64}) {
    const GeneratedSystem g = chain_model(n);
    expect_common_properties(g, n);
    for (int k = 0; k < n; ++k) {
      EXPECT_EQ(g.model.lower_body(k), k == 0 ? kGround : k - 1);
      EXPECT_EQ(g.model.depth(k), k);  // u_K = K-1
      EXPECT_EQ(g.model.body(k).mass, P::link_mass);
    }
    expect_initial_state_in_range(g);
  }
}

TEST(Generate, RandomTreeHasTreeTopology) {
  const int n = 200;
  const GeneratedSystem g = random_tree_model(n, 7);
  expect_common_properties(g, n);
  EXPECT_EQ(g.model.lower_body(0), kGround);
  int not_a_chain = 0, max_depth = 0;
  std::set<double> masses;
  for (int k = 1; k < n; ++k) {
    const int l = g.model.lower_body(k);
    EXPECT_GE(l, 0) << "only body 1 is attached to the ground";
    EXPECT_LT(l, k);
    not_a_chain += l != k - 1;
    max_depth = std::max(max_depth, g.model.depth(k));
    const double m = g.model.body(k).mass;
    EXPECT_GE(m, 0.5 * P::link_mass);
    EXPECT_LE(m, 2.0 * P::link_mass);
    masses.insert(m);
  }
  // A uniform parent among the earlier bodies: P(L(K) = K-1) = 1/(K-1), so nearly every body
  // branches off; the expected depth of a random recursive tree is about e ln n ~ 14 for
  // n = 200, far from a chain's 199.
  EXPECT_GT(not_a_chain, n / 2);
  EXPECT_LT(max_depth, n / 4);
  EXPECT_GT(masses.size(), static_cast<size_t>(n / 2)) << "masses should differ";
  expect_initial_state_in_range(g);
}

TEST(Generate, ParentChoiceIsSpreadOverEarlierBodies) {
  // With n = 2000 the number of children of body 1 is sum_{K=2..n} 1/(K-1) ~ ln n + 0.58 ~ 8,
  // and bodies 1..10 get about sum_K min(10, K-1)/(K-1) ~ 10 (ln(n/10) + 1) ~ 63 children in
  // all; a generator stuck on one choice (always 0 or always K-1) fails both bounds.
  const GeneratedSystem g = random_tree_model(2000, 3);
  int children_of_first_ten = 0;
  for (int k = 0; k < 10; ++k)
    children_of_first_ten += static_cast<int>(g.model.children(k).size());
  EXPECT_GT(children_of_first_ten, 30);
  EXPECT_LT(children_of_first_ten, 120);
}

TEST(Generate, SameSeedSameSystemOtherSeedOtherSystem) {
  const GeneratedSystem a = random_tree_model(100, 11), b = random_tree_model(100, 11);
  const GeneratedSystem c = random_tree_model(100, 12);
  bool same_topology_as_c = true;
  for (int k = 0; k < 100; ++k) {
    EXPECT_EQ(a.model.lower_body(k), b.model.lower_body(k));
    EXPECT_EQ(a.model.body(k).mass, b.model.body(k).mass);
    EXPECT_EQ(a.model.body(k).inertia, b.model.body(k).inertia);
    same_topology_as_c = same_topology_as_c && a.model.lower_body(k) == c.model.lower_body(k);
  }
  EXPECT_EQ(a.initial.x, b.initial.x);
  EXPECT_EQ(a.initial.y, b.initial.y);
  EXPECT_FALSE(same_topology_as_c);
  EXPECT_NE(a.initial.y, c.initial.y);

  EXPECT_EQ(chain_model(20).initial.x, chain_model(20).initial.x);
  EXPECT_EQ(chain_model(20, 5).initial.y, chain_model(20, 5).initial.y);
  EXPECT_NE(chain_model(20, 5).initial.y, chain_model(20, 6).initial.y);
}

TEST(Generate, RandomInitialStateWorksForAnyModel) {
  const GeneratedSystem g = chain_model(10);
  const State s = random_initial_state(g.model, 99);
  EXPECT_EQ(s.x, random_initial_state(g.model, 99).x);
  EXPECT_NE(s.x, g.initial.x);
  expect_initial_state_in_range({g.model, s});
}

TEST(Generate, RejectsEmptySystems) {
  EXPECT_THROW(chain_model(0), std::invalid_argument);
  EXPECT_THROW(random_tree_model(-1, 1), std::invalid_argument);
}

TEST(Generate, InitialStateEvaluatesToFiniteAccelerations) {
  for (const GeneratedSystem& g : {chain_model(16), random_tree_model(16, 2)}) {
    Data data(g.model);
    forward_dynamics(g.model, g.initial, data, Route::recursive);
    EXPECT_TRUE(data.ydot.allFinite());
    EXPECT_GT(data.ydot.cwiseAbs().maxCoeff(), 0.0);
  }
}

}  // namespace
}  // namespace kanedyn
