// JointDynamics: the articulated-body route (Route::recursive) and the block-sparse projected
// Kane route (Route::assembled) against the dense projected equations (projected_equations)
// and each other on random jointed trees of every joint type, deep chains, wide trees, all-free
// and all-weld trees; the state, kinematics and loads they leave; no allocation per
// evaluation; derivative() against joint_coordinate_rates and a finite difference along a run;
// energy conservation of a jointed eight-body figure.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <random>
#include <vector>

#include "alloc_counter.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/integrate.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "test_support.hpp"

#include "../src/joint_dynamics.hpp"

namespace kanedyn {
namespace {

using detail::JointDynamics;

// A joint spring with damping and a constant joint force on a loadable joint, with probability
// 2/3 (damping 0 when `damped` is false: a conservative spring).
std::vector<std::shared_ptr<const ForceElement>> random_joint_loads(
    std::mt19937& rng, const std::vector<Joint>& joints, bool damped = true) {
  std::vector<std::shared_ptr<const ForceElement>> loads;
  for (size_t k = 0; k < joints.size(); ++k) {
    if (!speeds_are_coordinate_rates(joints[k].type) || test::uniform(rng, 0, 1) > 2.0 / 3.0)
      continue;
    const int m = coordinate_count(joints[k].type);
    VectorX stiffness = VectorX::NullaryExpr(m, [&] { return test::uniform(rng, 0.0, 20.0); });
    VectorX damping =
        VectorX::NullaryExpr(m, [&] { return damped ? test::uniform(rng, 0.0, 2.0) : 0.0; });
    VectorX rest = VectorX::NullaryExpr(m, [&] { return test::uniform(rng, -0.5, 0.5); });
    VectorX value =
        VectorX::NullaryExpr(m, [&] { return damped ? test::uniform(rng, -3.0, 3.0) : 0.0; });
    loads.push_back(
        std::make_shared<const JointLoad>(static_cast<int>(k), stiffness, damping, rest, value));
  }
  return loads;
}

// A spring from the inertial origin to G_K: -k p_G_K at G_K. It reads the positions of the
// kinematics (ForceElement::reads_positions() is left true), which the built-in elements do not.
class Tether final : public ForceElement {
 public:
  Tether(int body, double k) : body_(body), k_(k) {}
  std::string type() const override { return "tether"; }
  int body() const override { return body_; }
  void apply(const Model&, const State&, const Kinematics& kin, Loads& loads) const override {
    loads.force[static_cast<size_t>(body_)] -= k_ * kin.p_G[static_cast<size_t>(body_)];
  }

 private:
  int body_;
  double k_;
};

// A model with joints (and joint loads) and a random (q, z).
struct Case {
  std::string name;
  Model model;
  VectorX q, z;
};

Case make_case(std::string name, Model model, const std::vector<JointType>& types,
               std::mt19937& rng, bool joint_loads = true) {
  std::vector<Joint> joints;
  for (JointType t : types) joints.push_back(test::random_joint(rng, t));
  std::vector<std::shared_ptr<const ForceElement>> loads;
  if (joint_loads) loads = random_joint_loads(rng, joints);
  Case c{std::move(name), with_joints(model, joints, loads), {}, {}};
  test::random_joint_state(c.model, rng, c.q, c.z);
  return c;
}

std::vector<JointType> random_types(std::mt19937& rng, int n) {
  std::vector<JointType> types;
  for (int k = 0; k < n; ++k) types.push_back(test::random_joint_type(rng));
  return types;
}

// A loaded model (gravity in a random direction, bushings with damping, forces, torques) with
// the given lower bodies.
Model loaded_model(std::mt19937& rng, const std::vector<int>& lower) {
  Model base = test::random_loaded_model(rng, static_cast<int>(lower.size()));
  std::vector<BodySpec> bodies = base.bodies();
  for (size_t k = 0; k < lower.size(); ++k) bodies[k].lower_body = lower[k];
  return Model(bodies, base.gravity(), base.forces(), "shaped");
}

// The comparison cases: random forests of 1..12 bodies with random joint types, chains of
// each single type, deep chains (depth 30 and 40) of mixed types and one of 35 revolute and
// prismatic joints, wide trees (a star of 30 on one root, two levels of 6 x 5), every one
// with bushings, forces, torques, joint springs and forces with damping, and gravity; then
// random trees and a deep chain with gravity and joint loads only.
std::vector<Case> comparison_cases(unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<Case> out;
  for (JointType type : kJointTypes) {
    Model m = test::random_loaded_model(rng, 4, true);
    out.push_back(make_case(std::string("chain of ") + to_string(type), std::move(m),
                            std::vector<JointType>(4, type), rng));
  }
  for (int i = 0; i < 40; ++i) {
    const int n = test::uniform_int(rng, 1, 12);
    Model m = test::random_loaded_model(rng, n);
    out.push_back(
        make_case("forest " + std::to_string(i), std::move(m), random_types(rng, n), rng));
  }
  {  // revolute and prismatic only: every row of [A_z] scalar (the factor's axpy path)
    std::vector<JointType> types;
    for (int k = 0; k < 35; ++k)
      types.push_back(test::uniform_int(rng, 0, 3) == 0 ? JointType::prismatic
                                                        : JointType::revolute);
    Model deep = test::random_loaded_model(rng, 35, true);
    out.push_back(make_case("deep chain of 1-DOF joints", std::move(deep), types, rng));
  }
  for (int n : {30, 40}) {
    Model m = test::random_loaded_model(rng, n, true);
    out.push_back(
        make_case("deep chain " + std::to_string(n), std::move(m), random_types(rng, n), rng));
  }
  {
    std::vector<int> star(31, 0);
    star[0] = kGround;
    // One draw after the other: the order of a call's arguments is unspecified.
    Model star_model = loaded_model(rng, star);
    out.push_back(make_case("star of 30", std::move(star_model), random_types(rng, 31), rng));
    std::vector<int> two_levels{kGround};
    for (int a = 0; a < 6; ++a) {
      two_levels.push_back(0);
      const int arm = static_cast<int>(two_levels.size()) - 1;
      for (int b = 0; b < 5; ++b) two_levels.push_back(arm);
    }
    Model levels = loaded_model(rng, two_levels);
    out.push_back(make_case("two levels of 6 x 5", std::move(levels),
                            random_types(rng, static_cast<int>(two_levels.size())), rng));
  }
  // Gravity and joint loads only: with no force element the routes take gravity as the
  // ground's acceleration and leave the notes' state until it is asked for.
  for (int n : {1, 3, 5, 8, 12, 12, 40}) {
    const Model loaded = test::random_loaded_model(rng, n, n == 40);
    out.push_back(make_case("gravity and joint loads only, " + std::to_string(n) + " bodies",
                            Model(loaded.bodies(), loaded.gravity(), {}, "unloaded"),
                            random_types(rng, n), rng));
  }
  // An element that needs the positions (the built-in ones do not): the kinematics are then
  // computed whole in every evaluation.
  {
    const Model loaded = test::random_loaded_model(rng, 6);
    std::vector<std::shared_ptr<const ForceElement>> forces = loaded.forces();
    forces.push_back(std::make_shared<Tether>(3, 40.0));
    out.push_back(make_case("a force element that reads positions",
                            Model(loaded.bodies(), loaded.gravity(), forces, "tethered"),
                            random_types(rng, 6), rng));
  }
  return out;
}

double relative_difference(const VectorX& a, const VectorX& b) {
  return test::max_abs(a - b) / (1.0 + test::max_abs(b));
}

// Tolerance of the route comparisons: each route solves the same well-conditioned n x n system
// (masses 0.5..5, lengths ~0.5, so the eigenvalues of [C]^T [A] [C] spread over a few orders)
// in a different order of operations; their round-off is ~1e-14 relative (measured at most
// 2e-13, on the deep chains). 1e-10 relative leaves room for the deeper chains while a wrong term
// (a missing [C dot]{z} or bias, a joint load, a load on the wrong body) shows at O(1).
constexpr double kRouteTolerance = 1e-10;

TEST(JointDynamics, BothRoutesAgreeWithTheProjectedEquations) {
  for (const Case& c : comparison_cases(1)) {
    SCOPED_TRACE(c.name);
    Data reference(c.model);  // with the dense [A] (at most 41 bodies here)
    const ProjectedEquations e = projected_equations(c.model, c.q, c.z, reference);
    JointDynamics dyn(c.model);
    VectorX recursive(c.model.num_speeds()), assembled(c.model.num_speeds());
    dyn.evaluate(c.q, c.z, Route::recursive, recursive);
    dyn.evaluate(c.q, c.z, Route::assembled, assembled);
    EXPECT_LT(relative_difference(recursive, e.zdot), kRouteTolerance);
    EXPECT_LT(relative_difference(assembled, e.zdot), kRouteTolerance);
    EXPECT_LT(relative_difference(recursive, assembled), kRouteTolerance);
  }
}

// solve_mass applies the articulated-body factorization of the last recursive evaluation to
// columns: [A_z]^-1 Q against the dense [A_z] of the projected equations (its LDL^T solve), on
// every comparison case (free joints at the root and inside, spherical, welded, planar ...), at
// column counts 1, 3 and 7; the same tolerance as the routes (one well-conditioned solve each,
// in different orders of operations). Then no allocation on later calls with as many columns,
// and a call without a recursive evaluation before it is refused.
// A case's dense [A_z] (its LDL^T) and its recursive evaluation, for solve_mass and
// inverse_mass_gram.
struct Factored {
  explicit Factored(const Case& c) : dyn(c.model), zdot(c.model.num_speeds()) {
    Data reference(c.model);
    dense.compute(projected_equations(c.model, c.q, c.z, reference).A_z);
    dyn.evaluate(c.q, c.z, Route::recursive, zdot);
  }
  Eigen::LDLT<MatrixX> dense;
  JointDynamics dyn;
  VectorX zdot;
};

// Random columns zero on the speeds of body k in column col unless (k * k_step + col) % 3 is 0
// (as a constraint's rows are zero off its bodies' chains).
MatrixX sparse_columns(const Model& m, int columns, int k_step, std::mt19937& rng) {
  MatrixX Q =
      MatrixX::NullaryExpr(m.num_speeds(), columns, [&] { return test::uniform(rng, -1, 1); });
  for (int k = 0; k < m.num_bodies(); ++k)
    for (int col = 0; col < columns; ++col)
      if ((k_step * k + col) % 3 != 0)
        Q.col(col).segment(m.speed_offset(k), m.speed_offset(k + 1) - m.speed_offset(k)).setZero();
  return Q;
}

TEST(JointDynamics, SolveMassAppliesTheInverseMassMatrix) {
  std::mt19937 rng(17);
  for (const Case& c : comparison_cases(2)) {
    SCOPED_TRACE(c.name);
    Factored f(c);
    const Eigen::LDLT<MatrixX>& dense = f.dense;
    JointDynamics& dyn = f.dyn;
    VectorX& zdot = f.zdot;
    const int n = c.model.num_speeds();
    for (int columns : {1, 3, 7}) {
      const MatrixX Q = MatrixX::NullaryExpr(n, columns, [&] { return test::uniform(rng, -1, 1); });
      MatrixX x = Q;
      dyn.solve_mass(x);
      const MatrixX expected = dense.solve(Q);
      EXPECT_LT(test::max_abs(x - expected) / (1.0 + test::max_abs(expected)), kRouteTolerance)
          << columns << " columns";
    }
    // Columns zero on some joints' speeds (as a constraint's rows are off its bodies' chains):
    // the inward pass skips the subtrees that hold no load, and must give the same.
    const MatrixX Q = sparse_columns(c.model, 4, 1, rng);
    MatrixX x = Q;
    dyn.solve_mass(x);
    const MatrixX expected = dense.solve(Q);
    EXPECT_LT(test::max_abs(x - expected) / (1.0 + test::max_abs(expected)), kRouteTolerance);
    if (alloc_counter::available()) {
      MatrixX ones = MatrixX::Ones(n, 7);
      alloc_counter::count = 0;
      alloc_counter::counting = true;
      dyn.solve_mass(ones);
      alloc_counter::counting = false;
      EXPECT_EQ(alloc_counter::count.load(), 0);
    }
    dyn.evaluate(c.q, c.z, Route::assembled, zdot);
    MatrixX one = MatrixX::Ones(n, 1);
    EXPECT_THROW(dyn.solve_mass(one), std::logic_error);
  }
}

// inverse_mass_gram: Q^T [A_z]^-1 Q from the inward pass alone, against the dense [A_z] (its
// LDL^T solve), on every comparison case, with full columns and with columns zero on some
// joints; the lower triangle is compared (the upper is zero). The same tolerance as solve_mass.
TEST(JointDynamics, InverseMassGramIsTheInverseMassMatrixBetweenColumns) {
  std::mt19937 rng(23);
  for (const Case& c : comparison_cases(2)) {
    SCOPED_TRACE(c.name);
    Factored f(c);
    JointDynamics& dyn = f.dyn;
    const int n = c.model.num_speeds();
    for (const bool sparse : {false, true}) {
      const MatrixX Q = sparse
                            ? sparse_columns(c.model, 5, 2, rng)
                            : MatrixX::NullaryExpr(n, 5, [&] { return test::uniform(rng, -1, 1); });
      MatrixX x = Q, gram;
      dyn.inverse_mass_gram(x, gram);
      const MatrixX expected = Q.transpose() * f.dense.solve(Q);
      const MatrixX lower = expected.triangularView<Eigen::Lower>();
      EXPECT_LT(test::max_abs(gram - lower) / (1.0 + test::max_abs(expected)), kRouteTolerance)
          << (sparse ? "sparse" : "full") << " columns";
    }
    dyn.evaluate(c.q, c.z, Route::assembled, f.zdot);
    MatrixX x = MatrixX::Ones(n, 1), gram;
    EXPECT_THROW(dyn.inverse_mass_gram(x, gram), std::logic_error);
  }
}

// state() is joint_state's (the same function: exact), data() the kinematics and loads of that
// state (compute_kinematics and compute_resultants on it: exact), after either route.
TEST(JointDynamics, StateKinematicsAndLoadsAreThoseOfTheJointState) {
  for (const Case& c : comparison_cases(2)) {
    SCOPED_TRACE(c.name);
    State expected(c.model);
    joint_state(c.model, c.q, c.z, expected);
    Data fresh(c.model, DataOptions::recursive_only());
    compute_kinematics(c.model, expected, fresh);
    compute_resultants(c.model, expected, fresh);
    for (Route route : {Route::recursive, Route::assembled}) {
      JointDynamics dyn(c.model);
      VectorX zdot(c.model.num_speeds());
      dyn.evaluate(c.q, c.z, route, zdot);
      EXPECT_EQ(dyn.state().x, expected.x);
      EXPECT_EQ(dyn.state().y, expected.y);
      for (int k = 0; k < c.model.num_bodies(); ++k) {
        const auto i = static_cast<size_t>(k);
        EXPECT_EQ(dyn.data().kinematics.R[i], fresh.kinematics.R[i]);
        EXPECT_EQ(dyn.data().kinematics.p_G[i], fresh.kinematics.p_G[i]);
        EXPECT_EQ(dyn.data().kinematics.v_G[i], fresh.kinematics.v_G[i]);
        EXPECT_EQ(dyn.data().loads.force[i], fresh.loads.force[i]);
        EXPECT_EQ(dyn.data().loads.moment_b[i], fresh.loads.moment_b[i]);
      }
    }
  }
}

// With no force element the state is computed when asked for, and with the built-in ones the
// kinematics' positions and velocities: they must be the last evaluation's, whichever of
// state() and data() is asked first, and however often.
TEST(JointDynamics, StateIsTheLastEvaluationsWhenAskedLater) {
  for (const Case& c : comparison_cases(3)) {
    SCOPED_TRACE(c.name);
    std::mt19937 rng(7);
    VectorX q2, z2;
    test::random_joint_state(c.model, rng, q2, z2);
    JointDynamics dyn(c.model);
    VectorX zdot(c.model.num_speeds());
    for (const bool data_first : {false, true}) {
      for (const bool second : {false, true}) {
        const VectorX& q = second ? q2 : c.q;
        const VectorX& z = second ? z2 : c.z;
        dyn.evaluate(q, z, Route::recursive, zdot);
        State expected(c.model);
        joint_state(c.model, q, z, expected);
        Data fresh(c.model, DataOptions::recursive_only());
        compute_kinematics(c.model, expected, fresh);
        if (data_first) {
          EXPECT_EQ(dyn.data().kinematics.p_O.back(), fresh.kinematics.p_O.back());
        }
        EXPECT_EQ(dyn.state().x, expected.x);
        EXPECT_EQ(dyn.state().y, expected.y);
        EXPECT_EQ(dyn.data().kinematics.R.back(), fresh.kinematics.R.back());
        EXPECT_EQ(dyn.data().kinematics.p_G.back(), fresh.kinematics.p_G.back());
        EXPECT_EQ(dyn.data().kinematics.v_G.back(), fresh.kinematics.v_G.back());
      }
    }
  }
}

// Every joint free: z holds the notes' y body by body, and both routes are Eq. (36) of the free
// model (forward_dynamics), to the round-off of two solves of one well-conditioned 6N system.
TEST(JointDynamics, AllFreeIsForwardDynamicsOfTheFreeModel) {
  std::mt19937 rng(3);
  for (const Model& model : test::models_of_every_size(rng)) {
    SCOPED_TRACE(model.num_bodies());
    const int n = model.num_bodies();
    const Model& tree = model;  // every joint free, the default
    VectorX q, z;
    test::random_joint_state(tree, rng, q, z);
    JointDynamics dyn(tree);
    Data free(model);
    for (Route route : {Route::recursive, Route::assembled}) {
      VectorX zdot(tree.num_speeds());
      dyn.evaluate(q, z, route, zdot);
      VectorX ydot(6 * n);
      for (int k = 0; k < n; ++k) {
        ydot.segment<3>(3 * k) = zdot.segment<3>(6 * k);
        ydot.segment<3>(3 * n + 3 * k) = zdot.segment<3>(6 * k + 3);
      }
      for (Route free_route : {Route::recursive, Route::assembled}) {
        forward_dynamics(model, dyn.state(), free, free_route);
        EXPECT_LT(relative_difference(ydot, free.ydot), kRouteTolerance)
            << to_string(route) << " against the free model's " << to_string(free_route);
      }
    }
  }
}

// A free root with every other body welded (random frames, translations, shapes): one rigid
// body, one 6-DOF joint; both routes against the projected equations and the one rigid body's
// Newton-Euler (its mass centre moves by the total force over the total mass).
TEST(JointDynamics, AllWeldToOneFreeRoot) {
  std::mt19937 rng(4);
  for (int n : {2, 5, 12}) {
    for (bool chain : {true, false}) {
      std::vector<int> lower{kGround};
      for (int k = 1; k < n; ++k) lower.push_back(chain ? k - 1 : test::uniform_int(rng, 0, k - 1));
      Model model = loaded_model(rng, lower);
      std::vector<JointType> types(static_cast<size_t>(n), JointType::weld);
      types[0] = JointType::free;
      const Case c = make_case("welded", std::move(model), types, rng);
      ASSERT_EQ(c.model.num_speeds(), 6);
      Data reference(c.model);
      const ProjectedEquations e = projected_equations(c.model, c.q, c.z, reference);
      JointDynamics dyn(c.model);
      for (Route route : {Route::recursive, Route::assembled}) {
        VectorX zdot(6);
        dyn.evaluate(c.q, c.z, route, zdot);
        EXPECT_LT(relative_difference(zdot, e.zdot), kRouteTolerance) << to_string(route);
        // The system's mass centre: m a_G = sum of the external forces (the welds' reactions
        // cancel). a_G of each body from the root's motion: a_Gk = a_O1 + alpha x d + w x (w x d)
        // with d = p_Gk - p_O1 (inertial); a_O1 from s''_1 (a root: inertial, s'_1 = p_O1).
        const Kinematics& kin = dyn.data().kinematics;
        const Matrix3 r1t = kin.R[0].transpose();
        const Vector3 w = r1t * dyn.state().angular_velocity(0);
        const Vector3 alpha = r1t * zdot.head<3>();
        const Vector3 a_o = zdot.tail<3>();
        Vector3 momentum_rate = Vector3::Zero(), force = Vector3::Zero();
        for (int k = 0; k < n; ++k) {
          const Vector3 d = kin.p_G[static_cast<size_t>(k)] - kin.p_O[0];
          momentum_rate += c.model.body(k).mass * (a_o + alpha.cross(d) + w.cross(w.cross(d)));
          force += dyn.data().loads.force[static_cast<size_t>(k)];
        }
        EXPECT_LT((momentum_rate - force).norm(), 1e-10 * (1.0 + force.norm()));
      }
    }
  }
}

// A copy is a workspace of its own: evaluating it leaves the original's state and data as they
// were, and it computes what a new workspace computes.
TEST(JointDynamics, CopiesAreIndependentWorkspaces) {
  std::mt19937 rng(10);
  Model forest = test::random_loaded_model(rng, 10);
  Case c = make_case("forest", std::move(forest), random_types(rng, 10), rng);
  VectorX q2, z2;
  test::random_joint_state(c.model, rng, q2, z2);
  for (Route route : {Route::recursive, Route::assembled}) {
    JointDynamics dyn(c.model);
    VectorX zdot(c.model.num_speeds()), copied(c.model.num_speeds()), fresh(c.model.num_speeds());
    dyn.evaluate(c.q, c.z, route, zdot);
    const State before = dyn.state();
    const std::vector<Vector3> forces = dyn.data().loads.force;
    JointDynamics copy(dyn);
    copy.evaluate(q2, z2, route, copied);
    EXPECT_EQ(dyn.state().x, before.x);
    EXPECT_EQ(dyn.state().y, before.y);
    EXPECT_EQ(dyn.data().loads.force, forces);
    JointDynamics(c.model).evaluate(q2, z2, route, fresh);
    EXPECT_EQ(copied, fresh);
    EXPECT_NE(copy.state().x, before.x);
  }
}

TEST(JointDynamics, NoAllocationPerEvaluation) {
  if (!alloc_counter::available())
    GTEST_SKIP() << "malloc is the sanitizer's here: Eigen's allocations are not counted";
  for (const Case& c : comparison_cases(5)) {
    SCOPED_TRACE(c.name);
    JointDynamics dyn(c.model);
    VectorX zdot(c.model.num_speeds());
    VectorX qz(c.model.num_coordinates() + c.model.num_speeds()), dqz(qz.size());
    qz << c.q, c.z;
    for (Route route : {Route::recursive, Route::assembled}) {
      dyn.evaluate(c.q, c.z, route, zdot);  // the first call may build the route's structures
      alloc_counter::count = 0;
      alloc_counter::counting = true;
      for (int i = 0; i < 3; ++i) {
        dyn.evaluate(c.q, c.z, route, zdot);
        dyn.derivative(qz, route, dqz);
      }
      alloc_counter::counting = false;
      EXPECT_EQ(alloc_counter::count.load(), 0) << to_string(route);
    }
  }
}

// derivative(): the q part is joint_coordinate_rates at the normalized q, the z part
// evaluate() there.
TEST(JointDynamics, DerivativeIsTheCoordinateRatesAndTheAccelerations) {
  for (const Case& c : comparison_cases(6)) {
    SCOPED_TRACE(c.name);
    const int nq = c.model.num_coordinates(), nz = c.model.num_speeds();
    VectorX q = c.q;
    // Off unit norm by up to 1e-7 (what an integrator's step leaves): derivative() normalizes.
    for (int k = 0; k < c.model.num_bodies(); ++k) {
      const JointType t = c.model.joint(k).type;
      if (t == JointType::free || t == JointType::spherical)
        q.segment<4>(c.model.coordinate_offset(k)) *= 1.0 + 1e-7;
    }
    VectorX qz(nq + nz), dqz(nq + nz), zdot(nz), qdot(nq);
    qz << q, c.z;
    JointDynamics dyn(c.model);
    for (Route route : {Route::recursive, Route::assembled}) {
      dyn.derivative(qz, route, dqz);
      VectorX qn = q;
      normalize_joint_coordinates(c.model, qn);
      joint_coordinate_rates(c.model, qn, c.z, qdot);
      EXPECT_EQ(dqz.head(nq), qdot);
      dyn.evaluate(qn, c.z, route, zdot);
      EXPECT_EQ(dqz.tail(nz), zdot);
    }
  }
}

// Along an RK4 run of (q, z) by the recursive route with h = 1e-4, the central difference
// (x(t+h) - x(t-h)) / 2h of the trajectory matches derivative() at t by either route: the
// error is (h^2/6) x''' plus RK4's local error over h, measured 2e-5 at |dx| ~ 100 (and 2e-3
// at h = 1e-3: it scales as h^2); tolerance 1e-5 relative, while a route that differs in any
// term of z dot shows at O(1).
TEST(JointDynamics, FiniteDifferenceOfARunMatchesTheDerivative) {
  std::mt19937 rng(7);
  std::vector<Case> cases;
  cases.push_back(make_case(
      "eight-body", test::eight_body_model(),
      {JointType::free, JointType::spherical, JointType::revolute, JointType::universal,
       JointType::cylindrical, JointType::prismatic, JointType::weld, JointType::revolute},
      rng));
  cases.push_back(
      make_case("eight-body with planar joints", test::eight_body_model(),
                {JointType::free, JointType::planar, JointType::planar, JointType::universal,
                 JointType::cylindrical, JointType::planar, JointType::weld, JointType::revolute},
                rng));
  Model forest = test::random_loaded_model(rng, 9);
  cases.push_back(make_case("forest", std::move(forest), random_types(rng, 9), rng));
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    JointDynamics dyn(c.model);
    const int size = c.model.num_coordinates() + c.model.num_speeds();
    Rk4 rk4(size, [&](double, const VectorX& x, VectorX& dx) {
      dyn.derivative(x, Route::recursive, dx);
    });
    VectorX x(size);
    x << c.q, c.z;
    const double h = 1e-4;
    std::vector<VectorX> run{x};
    for (int i = 0; i < 4; ++i) {
      rk4.step(i * h, h, x);
      run.push_back(x);
    }
    for (Route route : {Route::recursive, Route::assembled}) {
      for (int i = 1; i + 1 < static_cast<int>(run.size()); ++i) {
        VectorX d(size);
        dyn.derivative(run[static_cast<size_t>(i)], route, d);
        const VectorX fd =
            (run[static_cast<size_t>(i + 1)] - run[static_cast<size_t>(i - 1)]) / (2 * h);
        EXPECT_LT(test::max_abs(fd - d), 1e-5 * (1.0 + test::max_abs(d))) << to_string(route);
      }
    }
  }
}

// One body on a planar joint at the ground (random frame F, mass centre c, inertia, gravity g
// and rates), zero angle rate at first, then any: the plane pushes along F's z only and its
// moments have no component along F's z = K's z, so Euler's equation about G along z is
// I_zz angle_ddot + (w e_z x [I] w e_z) . e_z = I_zz angle_ddot = 0, and G accelerates at g's
// in-plane part. The joint point O_K = G - c then accelerates at a_G - w x (w x c) =
// g_par + w^2 c_par: x ddot, y ddot are that along F's x and y axes (inertial components for a
// root). Both routes and the projected equations solve 3x3 systems of O(1)-O(10) entries:
// round-off ~1e-14; tolerance 1e-11 absolute, while a wrong axis, sign or missing term of
// [C dot]{z} is O(1).
TEST(JointDynamics, PlanarBodyFallsInItsPlaneWithoutSpinningUp) {
  std::mt19937 rng(11);
  for (int i = 0; i < 20; ++i) {
    test::RandomTreeOptions opt;
    opt.min_bodies = opt.max_bodies = 1;
    opt.gravity = test::random_vector(rng, -10, 10);
    Model base = test::random_tree(rng, opt);
    const Case c = make_case("planar", std::move(base), {JointType::planar}, rng, false);
    const Matrix3 r_f = test::reference_rotation(c.model.joint(0).frame);
    const Vector3 x_f = r_f.transpose() * Vector3::UnitX(),
                  y_f = r_f.transpose() * Vector3::UnitY();
    for (const double spin : {0.0, c.z[2]}) {
      VectorX z = c.z;
      z[2] = spin;
      State s(c.model);
      joint_state(c.model, c.q, z, s);
      const Vector3 com =
          test::reference_rotation(s.euler_parameters(0)).transpose() * c.model.body(0).com;
      const Vector3 a_o = c.model.gravity() + spin * spin * com;  // the z parts drop out below
      const Vector3 expected(a_o.dot(x_f), a_o.dot(y_f), 0.0);
      Data reference(c.model);
      EXPECT_LT((projected_equations(c.model, c.q, z, reference).zdot - expected).norm(), 1e-11);
      JointDynamics dyn(c.model);
      for (Route route : {Route::recursive, Route::assembled}) {
        VectorX zdot(3);
        dyn.evaluate(c.q, z, route, zdot);
        EXPECT_LT((zdot - expected).norm(), 1e-11) << to_string(route) << " spin " << spin;
      }
    }
  }
}

// A body on a vertical plane (F's z horizontal) under gravity -9.81 z, at rest at first, falls
// at g within the plane with no spin; with no gravity and its mass centre on K's z axis (the
// axis of the turn) it keeps its angle rate and its place. RK4 with h = 1e-3 over 1 s of a motion
// whose exact solution is a polynomial of degree 2 in t (falling) or linear (spinning): RK4 is
// exact on those, so the differences are round-off over 1000 steps (~1e-13); tolerance 1e-10.
TEST(JointDynamics, PlanarKnownMotions) {
  BodySpec b;
  b.name = "puck";
  b.mass = 1.5;
  b.inertia = Vector3(0.02, 0.03, 0.04).asDiagonal();
  Joint planar;
  planar.type = JointType::planar;
  // F's z along the inertial x axis: a turn of 90 degrees about y; the plane is x = const, so
  // gravity along -z lies in it.
  planar.frame = Vector4(0.0, std::sin(M_PI / 4), 0.0, std::cos(M_PI / 4));
  for (const bool falling : {true, false}) {
    SCOPED_TRACE(falling ? "falling in a vertical plane" : "spinning with no gravity");
    b.com = falling ? Vector3(0.1, -0.2, 0.05) : Vector3(0.0, 0.0, 0.3);  // on K's z: the axis
    const Vector3 g = falling ? Vector3(0, 0, -9.81) : Vector3::Zero();
    const Model model({b}, g, {}, "puck", {planar});
    const Matrix3 r_f = test::reference_rotation(model.joint(0).frame);
    const Vector3 g_f = r_f * g;          // gravity in F components: its z part is zero
    EXPECT_LT(std::abs(g_f.z()), 1e-14);  // 9.81 times the round-off of cos(pi / 4)
    JointDynamics dyn(model);
    const double rate = falling ? 0.0 : 2.5;
    VectorX x(6);
    x << 0.1, -0.2, 0.3, 0.0, 0.0, rate;
    const VectorX x0 = x;
    Rk4 rk4(6, [&](double, const VectorX& xx, VectorX& dx) {
      dyn.derivative(xx, Route::recursive, dx);
    });
    const double h = 1e-3;
    for (int i = 0; i < 1000; ++i) rk4.step(i * h, h, x);
    const double t = 1.0;
    VectorX expected(6);
    expected << x0[0] + 0.5 * g_f.x() * t * t, x0[1] + 0.5 * g_f.y() * t * t, x0[2] + rate * t,
        g_f.x() * t, g_f.y() * t, rate;
    EXPECT_LT(test::max_abs(x - expected), 1e-10) << x.transpose();
  }
}

// The notes' eight-body figure jointed with every joint type (and again with planar joints at
// bodies 3, 5 and 8) under gravity, conservative bushings and undamped joint springs: the total
// energy (kinetic, gravity, bushings, joint springs) is constant. Dopri5 at rtol = atol = 1e-12
// over 10 s on the recursive route (about 11,000 steps): measured 1e-10 of the scale |E0| + max
// kinetic energy; tolerance 1e-8, while a wrong [C dot]{z}, bias or joint-load term changes the
// energy at O(1).
void energy_is_conserved_on_the_jointed_eight_body(const std::vector<JointType>& types) {
  std::mt19937 rng(8);
  const Model model = test::eight_body(Vector3(0, 0, -9.81), true, 0.0);
  std::vector<Joint> joints;
  for (JointType t : types) joints.push_back(test::random_joint(rng, t));

  const Model tree = with_joints(model, joints, random_joint_loads(rng, joints, false));
  ASSERT_TRUE(tree.has_joint_force_elements());
  VectorX q, z;
  test::random_joint_state(tree, rng, q, z);
  JointDynamics dyn(tree);
  const int nq = tree.num_coordinates(), size = nq + tree.num_speeds();
  Data data(model, DataOptions::recursive_only());
  auto energy = [&](const VectorX& x) {
    State s(model);
    VectorX qq = x.head(nq);
    normalize_joint_coordinates(tree, qq);
    joint_state(tree, qq, x.tail(size - nq), s);
    return total_energy(model, s, data) + joint_potential_energy(tree, qq);
  };
  Dopri5Options opt;
  opt.rtol = opt.atol = 1e-12;
  Dopri5 solver(
      size, [&](double, const VectorX& x, VectorX& dx) { dyn.derivative(x, Route::recursive, dx); },
      opt);
  VectorX x0(size);
  x0 << q, z;
  ASSERT_EQ(solver.start(0.0, x0, 10.0), StepStatus::ok);
  const double e0 = energy(x0);
  double kinetic_max = 0.0;
  while (solver.time() < 10.0) {
    ASSERT_EQ(solver.step(), StepStatus::ok);
    normalize_joint_coordinates(tree, solver.mutable_state().head(nq));
    State s(model);
    joint_state(tree, solver.state().head(nq), solver.state().tail(size - nq), s);
    kinetic_max = std::max(kinetic_max, kinetic_energy(model, s, data));
  }
  const double scale = std::abs(e0) + kinetic_max;
  EXPECT_LT(std::abs(energy(solver.state()) - e0), 1e-8 * scale)
      << "e0 " << e0 << " steps " << solver.steps_accepted();
  EXPECT_GT(kinetic_max, 1.0);  // the figure moves
}

TEST(JointDynamics, EnergyIsConservedOnTheJointedEightBody) {
  for (const bool planar : {false, true}) {
    SCOPED_TRACE(planar ? "with planar joints" : "every type but planar");
    energy_is_conserved_on_the_jointed_eight_body(
        planar
            ? std::vector<JointType>{JointType::free, JointType::spherical, JointType::planar,
                                     JointType::universal, JointType::planar, JointType::prismatic,
                                     JointType::weld, JointType::planar}
            : std::vector<JointType>{JointType::free, JointType::spherical, JointType::revolute,
                                     JointType::universal, JointType::cylindrical,
                                     JointType::prismatic, JointType::weld, JointType::revolute});
  }
}

// Past the flat-chain limit (a 6000-link chain of revolute joints: 1.8e7 blocks), the
// assembled route and [C] refuse, and the recursive route runs in O(N) memory. Its z dot is
// checked by the energy balance: with gravity only, E = kinetic + gravity has dE/dt =
// grad E . (q dot, z dot) = 0, so (E(x + h dx) - E(x - h dx)) / 2h = O(h^2) plus the round-off
// of E (~1e8 here) over 2h. Measured 3e-8 of the power scale sum m |g . v_G| (2e6) at
// h = 1e-5, where scaling z dot by 1.001 gives 2e-3: tolerance 1e-6 of the scale.
TEST(JointDynamics, LongChainsRunOnlyTheRecursiveRoute) {
  const int n = 6000;
  std::vector<BodySpec> bodies(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    BodySpec& b = bodies[static_cast<size_t>(k)];
    b.name = test::numbered_name("l", k);
    b.lower_body = k - 1;
    b.mass = 1.0;
    b.inertia = Vector3(0.02, 0.02, 0.001).asDiagonal();
    b.com = Vector3(0, 0, -0.25);
    b.joint = k == 0 ? Vector3::Zero() : Vector3(0, 0, -0.5);
  }
  const Model model(bodies, Vector3(0, 0, -9.81));
  Joint j;
  j.type = JointType::revolute;
  j.axis = Vector3::UnitX();
  const Model tree = with_joints(model, std::vector<Joint>(static_cast<size_t>(n), j));
  EXPECT_FALSE(tree.has_angular_chains());
  EXPECT_THROW(ConstraintMatrix{tree}, ModelError);
  JointDynamics dyn(tree);
  std::mt19937 rng(9);
  VectorX x(2 * n), dx(2 * n);
  for (int i = 0; i < n; ++i) {
    x[i] = test::uniform(rng, -0.01, 0.01);
    x[n + i] = test::uniform(rng, -0.01, 0.01);
  }
  EXPECT_THROW(dyn.evaluate(x.head(n), x.tail(n), Route::assembled, dx.tail(n)), ModelError);
  dyn.derivative(x, Route::recursive, dx);
  ASSERT_TRUE(dx.allFinite());
  double power_scale = 0.0;
  for (int k = 0; k < n; ++k)
    power_scale += std::abs(model.gravity().dot(dyn.data().kinematics.v_G[static_cast<size_t>(k)]));
  Data data(model, DataOptions::recursive_only());
  auto energy = [&](const VectorX& xx) {
    State s(model);
    joint_state(tree, xx.head(n), xx.tail(n), s);
    return total_energy(model, s, data);
  };
  const double h = 1e-5;
  const double rate = (energy(x + h * dx) - energy(x - h * dx)) / (2 * h);
  EXPECT_LT(std::abs(rate), 1e-6 * power_scale) << "scale " << power_scale;
}

}  // namespace
}  // namespace kanedyn

namespace kanedyn {
namespace {

// Dynamics, the one entry point: for an all-free model its z dot and q dot are forward_dynamics'
// {y dot} and {x dot} body by body (the same kernel: the same bits); for any other model they
// are JointDynamics' z dot and the joint coordinate rates; derivative() is what simulate
// integrates in the layout size() names.
TEST(Dynamics, IsTheNotesKernelForAnAllFreeModelAndJointDynamicsOtherwise) {
  std::mt19937 rng(71);
  for (const Route route : {Route::recursive, Route::assembled}) {
    const Model model = test::eight_body_model();
    const State s = test::random_state(model, rng);
    VectorX q, z;
    joint_coordinates(model, s, q, z);
    Dynamics dyn(model, route);
    EXPECT_EQ(dyn.size(), 13 * model.num_bodies());
    VectorX zdot(model.num_speeds()), qdot(model.num_coordinates());
    dyn.evaluate(q, z, zdot, qdot);
    Data data(model);
    forward_dynamics(model, s, data, route);
    State rates(model);
    rates.x = data.xdot;
    rates.y = data.ydot;
    VectorX eq, ez;
    joint_coordinates(model, rates, eq, ez);  // the same permutation as (q, z) of (x, y)
    EXPECT_EQ(zdot, ez);
    EXPECT_EQ(qdot, eq);
    VectorX zdot_alone(model.num_speeds());
    dyn.evaluate(q, z, zdot_alone);  // z dot without q dot: the same bits
    EXPECT_EQ(zdot_alone, zdot);
    EXPECT_EQ(dyn.state().x, s.x);
    EXPECT_EQ(dyn.data().kinematics.R.size(), 8u);
    EXPECT_EQ(dyn.kernel(),
              route == Route::recursive
                  ? "fused O(N) pass, " + std::to_string(dyn.simd_lanes()) + " bodies per SIMD pass"
                  : "assembled [A] (Eqs. 37-38), tree LDL^T");
  }
  for (const Case& c : comparison_cases(72)) {
    if (c.model.all_free()) continue;
    for (const Route route : {Route::recursive, Route::assembled}) {
      Dynamics dyn(c.model, route);
      EXPECT_EQ(dyn.size(), c.model.num_coordinates() + c.model.num_speeds());
      VectorX zdot(c.model.num_speeds()), qdot(c.model.num_coordinates());
      dyn.evaluate(c.q, c.z, zdot, qdot);
      JointDynamics reference(c.model);
      VectorX expected(c.model.num_speeds()), expected_q(c.model.num_coordinates());
      reference.evaluate(c.q, c.z, route, expected);
      joint_coordinate_rates(c.model, c.q, c.z, expected_q);
      EXPECT_EQ(zdot, expected) << c.name;
      EXPECT_EQ(qdot, expected_q) << c.name;
      VectorX zdot_alone(c.model.num_speeds());
      dyn.evaluate(c.q, c.z, zdot_alone);
      EXPECT_EQ(zdot_alone, zdot) << c.name;
      VectorX v(dyn.size()), dv(dyn.size()), dqz(dyn.size());
      dyn.pack(c.q, c.z, v);
      dyn.derivative(v, dv);
      reference.derivative(v, route, dqz);
      EXPECT_EQ(dv, dqz) << c.name;
      EXPECT_EQ(dyn.kernel(), route == Route::recursive
                                  ? "articulated-body recursion over the joints"
                                  : "projected Kane equations, tree LDL^T");
    }
  }
}

}  // namespace
}  // namespace kanedyn
