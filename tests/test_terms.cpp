// Terms (inverse dynamics, mass matrix, bias and gravity forces, centre of mass) and the frames'
// accelerations, on random jointed models of every joint type with every kind of load: against
// the dense projected equations (projected_equations: A_z, f_z), the forward dynamics
// (Dynamics), the kinetic energy, the notes' kinematics (compute_kinematics) and central
// differences along a motion; no allocation per call.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/frames.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/terms.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

// A spring from the inertial origin to G_K that reads the kinematics' positions (the built-in
// elements do not), so that the loads need the whole notes' state.
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

struct Case {
  std::string name;
  Model model;
  VectorX q, z;
};

// The model with these joints, a joint spring with damping and a joint force on each joint
// that takes them (probability 2/3) when joint_loads, more body elements, and two frames on
// random bodies (random offsets and axes); a random (q, z).
Case make_case(std::string name, const Model& base, const std::vector<JointType>& types,
               std::mt19937& rng, bool joint_loads = true,
               std::vector<std::shared_ptr<const ForceElement>> more = {}) {
  std::vector<Joint> joints;
  for (JointType t : types) joints.push_back(test::random_joint(rng, t));
  std::vector<std::shared_ptr<const ForceElement>> forces = base.forces();
  forces.insert(forces.end(), more.begin(), more.end());
  for (size_t k = 0; k < joints.size() && joint_loads; ++k) {
    if (!speeds_are_coordinate_rates(joints[k].type) || test::uniform(rng, 0, 1) > 2.0 / 3.0)
      continue;
    const int m = coordinate_count(joints[k].type);
    const auto draw = [&](double lo, double hi) {
      return VectorX(VectorX::NullaryExpr(m, [&] { return test::uniform(rng, lo, hi); }));
    };
    forces.push_back(std::make_shared<const JointLoad>(
        static_cast<int>(k), draw(0.0, 20.0), draw(0.0, 2.0), draw(-0.5, 0.5), draw(-3.0, 3.0)));
  }
  std::vector<Frame> frames;
  const int n = base.num_bodies();
  for (int f = 0; f < 2; ++f)
    frames.push_back(Frame{test::numbered_name("frame", f), test::uniform_int(rng, 0, n - 1),
                           test::random_vector(rng, -0.5, 0.5),
                           test::random_euler_parameters(rng)});
  Case c{std::move(name),
         Model(base.bodies(), base.gravity(), forces, "case", joints, frames),
         {},
         {}};
  test::random_joint_state(c.model, rng, c.q, c.z);
  return c;
}

std::vector<JointType> random_types(std::mt19937& rng, int n) {
  std::vector<JointType> types;
  for (int k = 0; k < n; ++k) types.push_back(test::random_joint_type(rng));
  return types;
}

// Chains of four of each joint type, random forests of 1..12 bodies and a chain of 30, each with
// gravity in a random direction, bushings with damping, constant forces and torques, joint
// springs and forces; forests with gravity and joint loads only (gravity as the ground's
// acceleration); a forest with an element that reads the positions.
std::vector<Case> cases(unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<Case> out;
  for (JointType type : kJointTypes)
    out.push_back(make_case(std::string("chain of ") + to_string(type),
                            test::random_loaded_model(rng, 4, true),
                            std::vector<JointType>(4, type), rng));
  for (int i = 0; i < 25; ++i) {
    const int n = test::uniform_int(rng, 1, 12);
    out.push_back(make_case("forest " + std::to_string(i), test::random_loaded_model(rng, n),
                            random_types(rng, n), rng));
  }
  out.push_back(make_case("deep chain", test::random_loaded_model(rng, 30, true),
                          random_types(rng, 30), rng));
  for (int n : {1, 4, 9, 12}) {
    const Model loaded = test::random_loaded_model(rng, n);
    out.push_back(make_case("gravity and joint loads only, " + std::to_string(n) + " bodies",
                            Model(loaded.bodies(), loaded.gravity(), {}, "unloaded"),
                            random_types(rng, n), rng));
  }
  out.push_back(make_case("an element that reads positions", test::random_loaded_model(rng, 7),
                          random_types(rng, 7), rng, true, {std::make_shared<Tether>(3, 40.0)}));
  return out;
}

VectorX random_vector(std::mt19937& rng, int n) {
  return VectorX::NullaryExpr(n, [&] { return test::uniform(rng, -1.0, 1.0); });
}

// Tolerance of the comparisons with the dense projected equations: both sides sum the same
// products of inertias (masses 0.5..5, lengths ~0.5) in different orders; the round-off of
// either is a few ulp of the largest term, measured at most 6e-15 relative to the largest
// entry here. 1e-12 leaves room while a wrong term (a missing [C dot]{z}, a load on the wrong
// body, a free body's cut) shows at O(1).
constexpr double kTolerance = 1e-12;

TEST(Terms, MassMatrixIsTheProjectedOneAndGivesTheKineticEnergy) {
  for (const Case& c : cases(1)) {
    SCOPED_TRACE(c.name);
    Data data(c.model);
    const ProjectedEquations e = projected_equations(c.model, c.q, c.z, data);
    Terms terms(c.model);
    const int n = c.model.num_speeds();
    MatrixX M = MatrixX::Constant(n, n, 7.0);  // every entry must be written
    terms.mass_matrix(c.q, M);
    EXPECT_LE(test::max_abs(M - e.A_z), kTolerance * test::max_abs(e.A_z));
    EXPECT_EQ(test::max_abs(M - M.transpose()), 0.0);
    const double kinetic = kinetic_energy(c.model, c.q, c.z, data);
    EXPECT_NEAR(0.5 * c.z.dot(M * c.z), kinetic, kTolerance * kinetic);
  }
}

// Q = M z dot - f_z for any z dot; zero at the forward dynamics' z dot.
TEST(Terms, InverseDynamicsIsTheProjectedEquationsResidual) {
  std::mt19937 rng(11);
  for (const Case& c : cases(2)) {
    SCOPED_TRACE(c.name);
    Data data(c.model);
    const ProjectedEquations e = projected_equations(c.model, c.q, c.z, data);
    Terms terms(c.model);
    const int n = c.model.num_speeds();
    const VectorX zdot = random_vector(rng, n);
    VectorX Q(n);
    terms.inverse_dynamics(c.q, c.z, zdot, Q);
    const VectorX expected = e.A_z * zdot - e.f_z;
    const double scale = test::max_abs(e.A_z * zdot) + test::max_abs(e.f_z);
    EXPECT_LE(test::max_abs(Q - expected), kTolerance * scale);

    Dynamics dynamics(c.model);
    VectorX forward(n);
    dynamics.evaluate(c.q, c.z, forward);
    terms.inverse_dynamics(c.q, c.z, forward, Q);
    EXPECT_LE(test::max_abs(Q), kTolerance * (test::max_abs(e.A_z * forward) + scale));
  }
}

// Forward dynamics of the model with the inverse dynamics' Q added as joint forces returns z
// dot. Joint forces act on the joints whose speeds are coordinate rates (and welds have no
// speed), so these models have only those.
TEST(Terms, ForwardDynamicsOfTheInverseDynamicsGivesZdotBack) {
  std::mt19937 rng(3);
  const std::vector<JointType> loadable{JointType::weld,      JointType::revolute,
                                        JointType::prismatic, JointType::cylindrical,
                                        JointType::universal, JointType::planar};
  for (int i = 0; i < 30; ++i) {
    const int n_bodies = test::uniform_int(rng, 1, 14);
    std::vector<JointType> types;
    for (int k = 0; k < n_bodies; ++k)
      types.push_back(loadable[static_cast<size_t>(test::uniform_int(rng, 0, 5))]);
    const Case c =
        make_case("forest", test::random_loaded_model(rng, n_bodies, i % 3 == 0), types, rng);
    SCOPED_TRACE(i);
    const int n = c.model.num_speeds();
    const VectorX zdot = random_vector(rng, n);
    VectorX Q(n);
    Terms(c.model).inverse_dynamics(c.q, c.z, zdot, Q);
    std::vector<std::shared_ptr<const ForceElement>> forces = c.model.forces();
    for (int k = 0; k < c.model.num_bodies(); ++k) {
      const int m = speed_count(c.model.joint(k).type);
      if (m == 0) continue;
      const VectorX zero = VectorX::Zero(m);
      forces.push_back(std::make_shared<const JointLoad>(
          k, zero, zero, zero, Q.segment(c.model.speed_offset(k), m), "joint_force"));
    }
    std::vector<Joint> joints;
    for (int k = 0; k < c.model.num_bodies(); ++k) joints.push_back(c.model.joint(k));
    const Model driven(c.model.bodies(), c.model.gravity(), forces, "driven", joints);
    VectorX back(n);
    Dynamics(driven).evaluate(c.q, c.z, back);
    EXPECT_LE(test::max_abs(back - zdot), kTolerance * test::max_abs(zdot));
  }
}

// b = -f_z at (q, z) with every load; g = -f_z at (q, 0) of the model with gravity alone.
TEST(Terms, BiasAndGravityForcesAreMinusTheProjectedForces) {
  for (const Case& c : cases(4)) {
    SCOPED_TRACE(c.name);
    Data data(c.model);
    const ProjectedEquations e = projected_equations(c.model, c.q, c.z, data);
    Terms terms(c.model);
    const int n = c.model.num_speeds();
    VectorX b(n), g(n);
    terms.bias_forces(c.q, c.z, b);
    EXPECT_LE(test::max_abs(b + e.f_z), kTolerance * (1.0 + test::max_abs(e.f_z)));

    std::vector<Joint> joints;
    for (int k = 0; k < c.model.num_bodies(); ++k) joints.push_back(c.model.joint(k));
    const Model gravity_only(c.model.bodies(), c.model.gravity(), {}, "gravity", joints);
    Data gravity_data(gravity_only);
    const ProjectedEquations eg =
        projected_equations(gravity_only, c.q, VectorX::Zero(n), gravity_data);
    terms.gravity_forces(c.q, g);
    EXPECT_LE(test::max_abs(g + eg.f_z), kTolerance * (1.0 + test::max_abs(eg.f_z)));
    // The gravity-only model's bias at rest is its gravity forces.
    VectorX b0(n);
    Terms(gravity_only).bias_forces(c.q, VectorX::Zero(n), b0);
    EXPECT_LE(test::max_abs(b0 - g), kTolerance * (1.0 + test::max_abs(g)));
  }
}

// The centre of mass: sum m_K p_G_K / m and sum m_K v_G_K / m of the notes' kinematics; its
// Jacobian times z is that velocity, and each column is the central difference of the position
// along the motion of that speed alone, q(h) = q + h dq/dt(q, e_i) (Euler parameters
// renormalized, which is of second order in h and symmetric). With h = 1e-5 and positions of
// order 1 the truncation (h^2/6 times the third derivative) and the round-off (1e-16 / h) are
// both near 1e-11; 1e-7 relative is far above either and far below any wrong column.
TEST(Terms, CentreOfMassAndItsJacobian) {
  for (const Case& c : cases(5)) {
    SCOPED_TRACE(c.name);
    const Model& model = c.model;
    State state(model);
    joint_state(model, c.q, c.z, state);
    Data data(model, DataOptions::recursive_only());
    compute_kinematics(model, state, data);
    Vector3 position = Vector3::Zero(), velocity = Vector3::Zero();
    for (int k = 0; k < model.num_bodies(); ++k) {
      position += model.body(k).mass * data.kinematics.p_G[static_cast<size_t>(k)];
      velocity += model.body(k).mass * data.kinematics.v_G[static_cast<size_t>(k)];
    }
    position /= model.total_mass();
    velocity /= model.total_mass();
    Terms terms(model);
    EXPECT_LE((terms.centre_of_mass(c.q) - position).norm(), kTolerance * (1.0 + position.norm()));
    EXPECT_LE((terms.centre_of_mass_velocity(c.q, c.z) - velocity).norm(),
              kTolerance * (1.0 + velocity.norm()));
    const int n = model.num_speeds();
    MatrixX J(3, n);
    terms.centre_of_mass_jacobian(c.q, J);
    EXPECT_LE((J * c.z - velocity).norm(), kTolerance * (1.0 + velocity.norm()));
    const double h = 1e-5;
    for (int i = 0; i < n; ++i) {
      const VectorX e = VectorX::Unit(n, i);
      VectorX qdot(model.num_coordinates());
      joint_coordinate_rates(model, c.q, e, qdot);
      VectorX plus = c.q + h * qdot, minus = c.q - h * qdot;
      normalize_joint_coordinates(model, plus);
      normalize_joint_coordinates(model, minus);
      const Vector3 column = (terms.centre_of_mass(plus) - terms.centre_of_mass(minus)) / (2 * h);
      EXPECT_LE((J.col(i) - column).norm(), 1e-7 * (1.0 + column.norm())) << "speed " << i;
    }
  }
}

// The frame's and body's velocity from the notes' kinematics at (q(t), z(t)) along a motion
// q(t) = q + t dq/dt, z(t) = z + t z dot (renormalized; any z dot): its central difference is
// the acceleration at t = 0. With h = 2e-5, velocities of order 1-10 and their third
// derivatives of order 100, the truncation is near h^2/6 * 100 = 7e-9 and the round-off near
// 1e-15 / h = 5e-11; 1e-7 relative to 1 + |a| bounds both and still sees a missing term
// (a velocity product of order |w|^2 |r| ~ 0.1 at least).
TEST(Frames, AccelerationIsTheRateOfTheVelocity) {
  std::mt19937 rng(6);
  for (const Case& c : cases(6)) {
    SCOPED_TRACE(c.name);
    const Model& model = c.model;
    const int n = model.num_speeds();
    const VectorX zdot = random_vector(rng, n);
    VectorX qdot(model.num_coordinates());
    joint_coordinate_rates(model, c.q, c.z, qdot);
    State state(model);
    Data data(model, DataOptions::recursive_only());
    // The velocities (v, w) of frame f (f = -1 - k: body k's own frame) at q + t qdot.
    const auto velocities = [&](double t, int f) {
      VectorX q = c.q + t * qdot;
      normalize_joint_coordinates(model, q);
      joint_state(model, q, c.z + t * zdot, state);
      compute_kinematics(model, state, data);
      const FrameState s = f >= 0 ? frame_state(model, f, state, data.kinematics)
                                  : body_frame_state(model, -1 - f, state, data.kinematics);
      return std::pair<Vector3, Vector3>(s.velocity, s.angular_velocity);
    };
    const double h = 2e-5;
    std::vector<int> frames{0, 1};
    for (int k = 0; k < model.num_bodies(); ++k) frames.push_back(-1 - k);
    for (const int f : frames) {
      SCOPED_TRACE(f);
      const auto [v_plus, w_plus] = velocities(h, f);
      const auto [v_minus, w_minus] = velocities(-h, f);
      joint_state(model, c.q, c.z, state);
      compute_kinematics(model, state, data);
      const FrameAcceleration a =
          f >= 0 ? frame_acceleration(model, f, c.q, c.z, zdot, state, data.kinematics)
                 : body_acceleration(model, -1 - f, c.q, c.z, zdot, state, data.kinematics);
      const Vector3 linear = (v_plus - v_minus) / (2 * h);
      const Vector3 angular = (w_plus - w_minus) / (2 * h);
      EXPECT_LE((a.linear - linear).norm(), 1e-7 * (1.0 + linear.norm()));
      EXPECT_LE((a.angular - angular).norm(), 1e-7 * (1.0 + angular.norm()));
    }
  }
}

// A body's own frame: its pose and velocity are the notes' O_K, [R_K], v_O_K, w_K, and its
// Jacobian gives them back from z.
TEST(Frames, BodyFrameStateAndJacobian) {
  for (const Case& c : cases(7)) {
    SCOPED_TRACE(c.name);
    const Model& model = c.model;
    State state(model);
    joint_state(model, c.q, c.z, state);
    Data data(model, DataOptions::recursive_only());
    compute_kinematics(model, state, data);
    MatrixX Jv(3, model.num_speeds()), Jw(3, model.num_speeds());
    for (int k = 0; k < model.num_bodies(); ++k) {
      const auto i = static_cast<size_t>(k);
      const FrameState s = body_frame_state(model, k, state, data.kinematics);
      EXPECT_EQ(s.position, data.kinematics.p_O[i]);
      EXPECT_EQ(s.R, data.kinematics.R[i]);
      EXPECT_EQ(s.velocity, data.kinematics.v_O[i]);
      body_jacobian(model, k, c.q, data.kinematics, Jv, Jw);
      EXPECT_LE((Jv * c.z - s.velocity).norm(), kTolerance * (1.0 + s.velocity.norm()));
      EXPECT_LE((Jw * c.z - s.angular_velocity).norm(),
                kTolerance * (1.0 + s.angular_velocity.norm()));
    }
  }
}

TEST(Terms, CopiesAreIndependentWorkspaces) {
  const Case c = cases(8)[10];
  Terms terms(c.model);
  const int n = c.model.num_speeds();
  VectorX first(n), again(n);
  terms.bias_forces(c.q, c.z, first);
  const Terms copy = terms;
  Terms moved_on = copy;
  moved_on.bias_forces(c.q, VectorX::Zero(n), again);
  terms.bias_forces(c.q, c.z, again);
  EXPECT_EQ(first, again);
}

TEST(Terms, NoAllocationPerCall) {
  if (!alloc_counter::available())
    GTEST_SKIP() << "malloc is the sanitizer's here: Eigen's allocations are not counted";
  for (const Case& c : cases(9)) {
    SCOPED_TRACE(c.name);
    const Model& model = c.model;
    const int n = model.num_speeds();
    Terms terms(model);
    VectorX zdot = VectorX::Ones(n), Q(n), b(n), g(n);
    MatrixX M(n, n), J(3, n), Jv(3, n), Jw(3, n);
    State state(model);
    joint_state(model, c.q, c.z, state);
    Data data(model, DataOptions::recursive_only());
    compute_kinematics(model, state, data);
    Vector3 sink = Vector3::Zero();
    alloc_counter::count = 0;
    alloc_counter::counting = true;
    for (int i = 0; i < 3; ++i) {
      terms.inverse_dynamics(c.q, c.z, zdot, Q);
      terms.bias_forces(c.q, c.z, b);
      terms.gravity_forces(c.q, g);
      terms.mass_matrix(c.q, M);
      terms.centre_of_mass_jacobian(c.q, J);
      sink += terms.centre_of_mass(c.q) + terms.centre_of_mass_velocity(c.q, c.z);
      sink += frame_acceleration(model, 0, c.q, c.z, zdot, state, data.kinematics).linear;
      sink += body_acceleration(model, 0, c.q, c.z, zdot, state, data.kinematics).angular;
      body_jacobian(model, 0, c.q, data.kinematics, Jv, Jw);
    }
    alloc_counter::counting = false;
    EXPECT_EQ(alloc_counter::count.load(), 0);
    EXPECT_TRUE(sink.allFinite());
  }
}

}  // namespace
}  // namespace kanedyn
