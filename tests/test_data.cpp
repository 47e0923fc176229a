// Data: which parts each public function fills (and that it fills no other), the options, and
// Data(model) for every model.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/partials.hpp"
#include "kanedyn/testing/generate.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

constexpr double kSentinel = -12345.678;

template <typename T>
void fill(std::vector<T>& v) {
  for (T& x : v) x.setConstant(kSentinel);
}
void fill(VectorX& v) { v.setConstant(kSentinel); }
void fill(MatrixX& m) { m.setConstant(kSentinel); }

/// Every public part of data set to the sentinel.
void fill_all(Data& d) {
  for (auto* v : {&d.kinematics.p_O, &d.kinematics.p_G, &d.kinematics.v_O, &d.kinematics.v_G,
                  &d.kinematics.qs_b, &d.loads.force, &d.loads.moment_b})
    fill(*v);
  fill(d.kinematics.R);
  for (auto* v :
       {&d.partials.vO_w, &d.partials.vO_s, &d.partials.vG_w, &d.partials.vG_s,
        &d.partials.vO_w_dot, &d.partials.vO_s_dot, &d.partials.vG_w_dot, &d.partials.vG_s_dot})
    fill(*v);
  for (auto* v : {&d.kane.F_y, &d.kane.f, &d.ydot, &d.xdot}) fill(*v);
  fill(d.kane.A);
}

template <typename T>
bool untouched(const std::vector<T>& v) {
  for (const T& x : v)
    if (!(x.array() == kSentinel).all()) return false;
  return true;
}
bool untouched(const VectorX& v) { return (v.array() == kSentinel).all(); }
bool untouched(const MatrixX& m) { return (m.array() == kSentinel).all(); }
/// No entry left at the sentinel (and every entry finite).
template <typename T>
bool filled(const std::vector<T>& v) {
  for (const T& x : v)
    if ((x.array() == kSentinel).any() || !x.allFinite()) return false;
  return !v.empty();
}
bool filled(const VectorX& v) {
  return v.size() > 0 && !(v.array() == kSentinel).any() && v.allFinite();
}
bool filled(const MatrixX& m) {
  return m.size() > 0 && !(m.array() == kSentinel).any() && m.allFinite();
}

bool kinematics_untouched(const Data& d) {
  const Kinematics& k = d.kinematics;
  return untouched(k.R) && untouched(k.p_O) && untouched(k.p_G) && untouched(k.v_O) &&
         untouched(k.v_G) && untouched(k.qs_b);
}
bool partials_untouched(const Data& d) {
  const Partials& p = d.partials;
  return untouched(p.vO_w) && untouched(p.vO_s) && untouched(p.vG_w) && untouched(p.vG_s) &&
         untouched(p.vO_w_dot) && untouched(p.vO_s_dot) && untouched(p.vG_w_dot) &&
         untouched(p.vG_s_dot);
}
bool loads_untouched(const Data& d) {
  return untouched(d.loads.force) && untouched(d.loads.moment_b);
}
bool kane_untouched(const Data& d) {
  return untouched(d.kane.F_y) && untouched(d.kane.f) && untouched(d.kane.A);
}

/// A load the fused pass does not know (it takes the staged route): a linear drag on G_K.
class Drag final : public ForceElement {
 public:
  explicit Drag(int body) : body_(body) {}
  std::string type() const override { return "test-drag"; }
  int body() const override { return body_; }
  void apply(const Model&, const State&, const Kinematics& kin, Loads& loads) const override {
    loads.force[static_cast<size_t>(body_)] -= 0.5 * kin.v_G[static_cast<size_t>(body_)];
  }

 private:
  int body_;
};

Model with_drag(const Model& base) {
  std::vector<std::shared_ptr<const ForceElement>> forces = base.forces();
  forces.push_back(std::make_shared<Drag>(base.num_bodies() - 1));
  return Model(base.bodies(), base.gravity(), forces, "with drag");
}

// forward_dynamics fills ydot and xdot, and leaves every other public part as it was, on both
// routes, whether the recursive route runs fused (built-in loads) or staged (a load of
// another type): the set of outputs does not depend on the force elements.
TEST(Data, ForwardDynamicsFillsYdotAndXdotOnly) {
  const Model fused = test::eight_body_model();
  const Model staged = with_drag(fused);
  const State state = test::moving_state(fused, 3);
  ASSERT_TRUE(Data(fused).single_pass());
  ASSERT_FALSE(Data(staged).single_pass());
  for (const Model* model : {&fused, &staged})
    for (const Route route : {Route::recursive, Route::assembled}) {
      Data data(*model);
      fill_all(data);
      forward_dynamics(*model, state, data, route);
      EXPECT_TRUE(filled(data.ydot) && filled(data.xdot)) << to_string(route);
      EXPECT_TRUE(kinematics_untouched(data)) << to_string(route) << " " << model->name();
      EXPECT_TRUE(partials_untouched(data)) << to_string(route) << " " << model->name();
      EXPECT_TRUE(loads_untouched(data)) << to_string(route) << " " << model->name();
      EXPECT_TRUE(kane_untouched(data)) << to_string(route) << " " << model->name();
      // The result does not depend on what the public parts held: a fresh Data agrees bit
      // for bit.
      Data fresh(*model);
      forward_dynamics(*model, state, fresh, route);
      EXPECT_EQ(fresh.ydot, data.ydot);
      EXPECT_EQ(fresh.xdot, data.xdot);
    }
}

TEST(Data, EachStageFillsItsOwnPart) {
  const Model model = test::eight_body_model();
  const State state = test::moving_state(model, 4);
  Data data(model);
  fill_all(data);
  compute_kinematics(model, state, data);
  EXPECT_TRUE(filled(data.kinematics.R) && filled(data.kinematics.p_O) &&
              filled(data.kinematics.p_G) && filled(data.kinematics.v_O) &&
              filled(data.kinematics.v_G) && filled(data.kinematics.qs_b));
  EXPECT_TRUE(partials_untouched(data) && loads_untouched(data) && kane_untouched(data));
  EXPECT_TRUE(untouched(data.ydot) && untouched(data.xdot));
  compute_resultants(model, state, data);
  EXPECT_TRUE(filled(data.loads.force) && filled(data.loads.moment_b));
  EXPECT_TRUE(partials_untouched(data) && kane_untouched(data) && untouched(data.ydot));
  compute_partials_recursive(model, state, data);
  EXPECT_TRUE(filled(data.partials.vO_w) && filled(data.partials.vG_s));
  EXPECT_TRUE(untouched(data.partials.vO_w_dot) && kane_untouched(data));
  compute_generalized_forces(model, data);
  EXPECT_TRUE(filled(data.kane.F_y));
  EXPECT_TRUE(untouched(data.kane.f) && untouched(data.kane.A) && untouched(data.ydot));
  // kane_equations fills every part.
  fill_all(data);
  kane_equations(model, state, data);
  EXPECT_TRUE(filled(data.kinematics.R) && filled(data.kinematics.v_G));
  EXPECT_TRUE(filled(data.partials.vO_w) && filled(data.partials.vG_s_dot));
  EXPECT_TRUE(filled(data.loads.force) && filled(data.loads.moment_b));
  EXPECT_TRUE(filled(data.kane.F_y) && filled(data.kane.A) && filled(data.kane.f));
  EXPECT_TRUE(filled(data.ydot) && filled(data.xdot));
}

TEST(Data, WorksForEveryModelAndAllocatesWhatIsAskedFor) {
  // A small model: every part.
  const Model small = test::eight_body_model();
  const Data full(small);
  EXPECT_TRUE(full.options().partials && full.options().kane_terms &&
              full.options().dense_mass_matrix);
  EXPECT_EQ(full.kane.A.rows(), 48);
  EXPECT_EQ(full.partials.vO_w.size(), static_cast<size_t>(small.chain_entries()));
  // Recursive only: none of the chain-layout parts, and the functions that need them say so.
  Data lean(small, DataOptions::recursive_only());
  EXPECT_TRUE(lean.partials.vO_w.empty());
  EXPECT_EQ(lean.kane.A.size(), 0);
  const State state = test::moving_state(small, 5);
  EXPECT_THROW(kane_equations(small, state, lean), std::invalid_argument);
  EXPECT_THROW(forward_dynamics(small, state, lean, Route::assembled), std::invalid_argument);
  compute_kinematics(small, state, lean);
  EXPECT_THROW(compute_partials_recursive(small, state, lean), std::invalid_argument);
  EXPECT_THROW(compute_generalized_forces(small, lean), std::invalid_argument);
  // Without the dense [A], kane_equations still gives ydot, the same bits.
  Data sparse(small, DataOptions{.dense_mass_matrix = false});
  Data dense(small);
  kane_equations(small, state, sparse);
  kane_equations(small, state, dense);
  EXPECT_EQ(sparse.kane.A.size(), 0);
  EXPECT_EQ(sparse.ydot, dense.ydot);
  // A chain of 20,000 bodies (2e8 chain entries): Data(model) holds the O(N) parts only.
  const GeneratedSystem chain = chain_model(20000);
  Data big(chain.model);
  EXPECT_FALSE(big.options().partials || big.options().kane_terms);
  EXPECT_LT(big.memory_bytes(), 200u * 20000u * sizeof(double));
  forward_dynamics(chain.model, chain.initial, big);
  EXPECT_TRUE(filled(big.ydot) && filled(big.xdot));
  // A random tree of 2000 bodies fits the chain-layout parts but not a dense [A] by default.
  const GeneratedSystem tree = random_tree_model(2000, 7);
  ASSERT_LE(tree.model.chain_entries(), DataOptions::kFullChainEntries);
  const DataOptions tree_options = DataOptions::for_model(tree.model);
  EXPECT_TRUE(tree_options.partials && tree_options.kane_terms);
  EXPECT_FALSE(tree_options.dense_mass_matrix);
}

TEST(Data, CopiesAreIndependentWorkspaces) {
  const Model model = test::eight_body_model();
  const State a = test::moving_state(model, 6), b = test::moving_state(model, 7);
  for (const Route route : {Route::recursive, Route::assembled}) {
    Data first(model);
    forward_dynamics(model, a, first, route);
    Data second = first;
    forward_dynamics(model, b, second, route);
    Data reference(model);
    forward_dynamics(model, b, reference, route);
    EXPECT_EQ(second.ydot, reference.ydot);
    forward_dynamics(model, a, first, route);  // the copy's scratch did not change first's
    Data again(model);
    forward_dynamics(model, a, again, route);
    EXPECT_EQ(first.ydot, again.ydot);
    Data assigned(test::eight_body_model(Vector3::Zero()));
    assigned = second;
    EXPECT_EQ(assigned.ydot, second.ydot);
    forward_dynamics(model, a, assigned, route);
    EXPECT_EQ(assigned.ydot, again.ydot);
  }
}

TEST(Data, RouteNamesRoundTrip) {
  for (const Route route : {Route::recursive, Route::assembled})
    EXPECT_EQ(parse_route(to_string(route)), route);
  EXPECT_EQ(parse_route("kane"), Route::assembled);  // the older spelling
  EXPECT_THROW(parse_route("Kane"), std::invalid_argument);
  EXPECT_THROW(parse_route(""), std::invalid_argument);
}

}  // namespace
}  // namespace kanedyn
