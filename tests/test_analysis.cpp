// Analysis (analysis.hpp): the generic inverse dynamics against Terms, the dual-number
// derivatives of forward dynamics against central differences in tangent coordinates, the
// tangent maps, linearizations against analytic systems (pendulum, torque-free body, spring,
// cart-pole) and against the nonlinear motion, and static equilibrium.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <complex>
#include <memory>
#include <random>
#include <vector>

#include "kanedyn/analysis.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/terms.hpp"

#include "../src/generic_dynamics.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

using test::random_input;
using test::random_joint_state;
using test::random_jointed;
using test::rebuilt;
using test::uniform;
using test::uniform_int;

constexpr double kG = 9.81;

// A random jointed model (every joint type, damped bushings, gravity) with a joint spring on
// one eligible body, a constant force and torque, and one input of each type.
Model random_loaded_jointed(std::mt19937& rng) {
  const Model base = random_jointed(rng, true);
  std::vector<std::shared_ptr<const ForceElement>> forces = base.forces();
  for (int k = 0; k < base.num_bodies(); ++k) {
    const JointType t = base.joint(k).type;
    if (speeds_are_coordinate_rates(t)) {
      const int c = coordinate_count(t);
      // One draw after the other: the order of a call's arguments is unspecified.
      const double stiffness = uniform(rng, 1, 20), damping = uniform(rng, 0, 2);
      const double rest = uniform(rng, -0.5, 0.5), load = uniform(rng, -1, 1);
      forces.push_back(std::make_shared<JointLoad>(
          k, VectorX::Constant(c, stiffness), VectorX::Constant(c, damping),
          VectorX::Constant(c, rest), VectorX::Constant(c, load), "joint_spring"));
      break;
    }
  }
  const int k = uniform_int(rng, 0, base.num_bodies() - 1);
  forces.push_back(std::make_shared<ConstantForce>(k, test::random_vector(rng, -5, 5)));
  forces.push_back(std::make_shared<ConstantTorque>(k, test::random_vector(rng, -1, 1)));
  std::vector<Input> inputs;
  for (const InputType type : {InputType::joint, InputType::force, InputType::torque}) {
    Input in;
    in.name = "u" + std::to_string(inputs.size());
    if (random_input(base, rng, type, in)) inputs.push_back(in);
  }
  return rebuilt(base, forces, inputs);
}

VectorX random_vector_of(std::mt19937& rng, int n, double lo, double hi) {
  return VectorX::NullaryExpr(n, [&] { return uniform(rng, lo, hi); });
}

// The generic equations at S = double are Terms::inverse_dynamics: the same physics, written
// over a generic number type (round-off apart: the operations differ in order).
TEST(GenericDynamics, EqualsTheInverseDynamicsOfTerms) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 40; ++trial) {
    const Model m = random_loaded_jointed(rng);
    ASSERT_TRUE(detail::generic_dynamics_supported(m));
    VectorX q, z;
    random_joint_state(m, rng, q, z);
    const VectorX zdot = random_vector_of(rng, m.num_speeds(), -2, 2);
    const VectorX u = random_vector_of(rng, m.num_inputs(), -3, 3);
    Terms terms(m);
    VectorX expected(m.num_speeds());
    terms.inverse_dynamics(q, z, zdot, expected, &u);
    const VectorX got = detail::generic_inverse_dynamics(m, q, z, zdot, u);
    const double scale = std::max(1.0, expected.cwiseAbs().maxCoeff());
    EXPECT_LE((got - expected).cwiseAbs().maxCoeff(), 1e-12 * scale) << "trial " << trial;
  }
}

// The rotation of exp(-[r~]), by Rodrigues' formula: the reference for the tangent maps.
Matrix3 exp_minus_skew(const Vector3& r) {
  const double a = r.norm();
  if (a == 0.0) return Matrix3::Identity();
  const Matrix3 k = skew(r / a);
  return Matrix3::Identity() - std::sin(a) * k + (1.0 - std::cos(a)) * k * k;
}

TEST(Tangent, RetractTurnsByTheExponentialAndDifferenceUndoesIt) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 30; ++trial) {
    const Model m = random_jointed(rng, false);
    VectorX q0, z0;
    random_joint_state(m, rng, q0, z0);
    const VectorX dx = random_vector_of(rng, m.num_speeds(), -1, 1);
    const VectorX q = retract(m, q0, dx);
    for (int k = 0; k < m.num_bodies(); ++k) {
      const JointType t = m.joint(k).type;
      if (t != JointType::free && t != JointType::spherical) continue;
      const int o = m.coordinate_offset(k), p = m.speed_offset(k);
      const Matrix3 expected = exp_minus_skew(dx.segment<3>(p)) * rotation_matrix(q0.segment<4>(o));
      EXPECT_LE((rotation_matrix(q.segment<4>(o)) - expected).cwiseAbs().maxCoeff(), 1e-14);
      EXPECT_NEAR(q.segment<4>(o).norm(), 1.0, 1e-15);
    }
    // |r| <= 1 < pi: the difference gives dx back.
    EXPECT_LE((tangent_difference(m, q0, q) - dx).cwiseAbs().maxCoeff(), 1e-13) << trial;
  }
}

// Central differences of F = z dot in tangent coordinates: step h = 1e-5, truncation
// O(h^2 F''') about 1e-10 of F's scale, round-off O(eps F / h) about 1e-11.
MatrixX central_differences(const Model& m, const VectorX& q, const VectorX& z, const VectorX& u) {
  const int n = m.num_speeds(), nu = m.num_inputs();
  MatrixX out(n, 2 * n + nu);
  Dynamics d(m);
  VectorX plus(n), minus(n);
  const double h = 1e-5;
  for (int i = 0; i < 2 * n + nu; ++i) {
    VectorX dx = VectorX::Zero(n), zz = z, uu = u;
    for (const double sign : {1.0, -1.0}) {
      VectorX qq = q;
      zz = z;
      uu = u;
      if (i < n) {
        dx[i] = sign * h;
        qq = retract(m, q, dx);
      } else if (i < 2 * n) {
        zz[i - n] += sign * h;
      } else {
        uu[i - 2 * n] += sign * h;
      }
      d.forward(qq, zz, uu, sign > 0 ? plus : minus);
    }
    out.col(i) = (plus - minus) / (2 * h);
  }
  return out;
}

// The dual-number derivatives of every joint type, with every kind of load and input, agree
// with central differences to 1e-6 of each block's scale (the differences' own error is
// about 1e-10 of it).
TEST(Derivatives, MatchCentralDifferencesInTangentCoordinates) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 30; ++trial) {
    const Model m = trial % 3 == 0 ? random_jointed(rng, true) : random_loaded_jointed(rng);
    VectorX q, z;
    random_joint_state(m, rng, q, z);
    const VectorX u = random_vector_of(rng, m.num_inputs(), -3, 3);
    const int n = m.num_speeds(), nu = m.num_inputs();
    Derivatives derivatives(m);
    ASSERT_TRUE(derivatives.analytic());
    MatrixX dq(n, n), dz(n, n), du(n, nu);
    VectorX zdot;
    derivatives.forward(q, z, u, dq, dz, du, &zdot);
    const MatrixX fd = central_differences(m, q, z, u);
    const auto check = [&](const MatrixX& got, const MatrixX& expected, const char* what) {
      if (got.size() == 0) return;
      const double scale = std::max(1.0, expected.cwiseAbs().maxCoeff());
      EXPECT_LE((got - expected).cwiseAbs().maxCoeff(), 1e-6 * scale)
          << what << ", trial " << trial << "\n"
          << got << "\n\n"
          << expected;
    };
    check(dq, fd.leftCols(n), "d(zdot)/dq");
    check(dz, fd.middleCols(n, n), "d(zdot)/dz");
    check(du, fd.rightCols(nu), "d(zdot)/du");
    // z dot comes from the mass matrix and the bias forces, not from the forward route: the
    // same to round-off.
    VectorX zdot_direct(n);
    Dynamics(m).forward(q, z, u, zdot_direct);
    EXPECT_LE((zdot - zdot_direct).cwiseAbs().maxCoeff(),
              1e-10 * std::max(1.0, zdot_direct.cwiseAbs().maxCoeff()));
  }
}

// Every width of pass, and the split of the directions among passes: chains of 3 to 13
// revolute joints have 6 to 26 directions (passes of 8; 12; 16; 16 and 8; 16 and 12; 16 and 16),
// against central differences as above.
TEST(Derivatives, EveryPassWidthMatchesCentralDifferences) {
  std::mt19937 rng(31);
  for (int bodies = 3; bodies <= 13; ++bodies) {
    test::RandomTreeOptions opt;
    opt.min_bodies = opt.max_bodies = bodies;
    opt.chain = true;
    opt.gravity = Vector3(0, 0, -9.81);
    const Model tree = test::random_tree(rng, opt);
    std::vector<Joint> joints;
    for (int k = 0; k < bodies; ++k) joints.push_back(test::random_joint(rng, JointType::revolute));
    const Model m = with_joints(tree, joints);
    VectorX q, z;
    random_joint_state(m, rng, q, z);
    const int n = m.num_speeds();
    MatrixX dq(n, n), dz(n, n), du(n, 0);
    Derivatives(m).forward(q, z, VectorX(), dq, dz, du);
    const MatrixX fd = central_differences(m, q, z, VectorX());
    EXPECT_LE((dq - fd.leftCols(n)).cwiseAbs().maxCoeff(),
              1e-6 * std::max(1.0, fd.leftCols(n).cwiseAbs().maxCoeff()))
        << bodies << " bodies";
    EXPECT_LE((dz - fd.rightCols(n)).cwiseAbs().maxCoeff(),
              1e-6 * std::max(1.0, fd.rightCols(n).cwiseAbs().maxCoeff()))
        << bodies << " bodies";
  }
}

// Above 48 speeds the mass matrix is factored by LAPACK: a chain of 20 free and spherical
// bodies (n = 90) against central differences as above.
TEST(Derivatives, LargerModelsMatchCentralDifferences) {
  std::mt19937 rng(29);
  test::RandomTreeOptions opt;
  opt.min_bodies = opt.max_bodies = 20;
  opt.chain = true;
  opt.gravity = Vector3(0, 0, -9.81);
  const Model tree = test::random_tree(rng, opt);
  std::vector<Joint> joints;
  for (int k = 0; k < tree.num_bodies(); ++k)
    joints.push_back(test::random_joint(rng, k % 2 ? JointType::spherical : JointType::free));
  const Model m = with_joints(tree, joints);
  ASSERT_GT(m.num_speeds(), 48);
  VectorX q, z;
  random_joint_state(m, rng, q, z);
  const int n = m.num_speeds();
  MatrixX dq(n, n), dz(n, n), du(n, 0);
  Derivatives(m).forward(q, z, VectorX(), dq, dz, du);
  const MatrixX fd = central_differences(m, q, z, VectorX());
  EXPECT_LE((dq - fd.leftCols(n)).cwiseAbs().maxCoeff(),
            1e-6 * std::max(1.0, fd.leftCols(n).cwiseAbs().maxCoeff()));
  EXPECT_LE((dz - fd.rightCols(n)).cwiseAbs().maxCoeff(),
            1e-6 * std::max(1.0, fd.rightCols(n).cwiseAbs().maxCoeff()));
}

// The inverse dynamics' derivatives: dQ/dz dot is the mass matrix, so [M] d(z dot)/dx = -dQ/dx
// ties the two calls together.
TEST(Derivatives, InverseDerivativesGiveTheForwardOnesThroughTheMassMatrix) {
  std::mt19937 rng(9);
  for (int trial = 0; trial < 10; ++trial) {
    const Model m = random_loaded_jointed(rng);
    VectorX q, z;
    random_joint_state(m, rng, q, z);
    const VectorX u = random_vector_of(rng, m.num_inputs(), -3, 3);
    const int n = m.num_speeds(), nu = m.num_inputs();
    Derivatives derivatives(m);
    MatrixX fq(n, n), fz(n, n), fu(n, nu), iq(n, n), iz(n, n), iu(n, nu), M(n, n);
    VectorX zdot;
    derivatives.forward(q, z, u, fq, fz, fu, &zdot);
    derivatives.inverse(q, z, zdot, u, iq, iz, iu);
    Terms(m).mass_matrix(q, M);
    const double scale = std::max(1.0, iq.cwiseAbs().maxCoeff());
    EXPECT_LE((M * fq + iq).cwiseAbs().maxCoeff(), 1e-10 * scale);
    EXPECT_LE((M * fz + iz).cwiseAbs().maxCoeff(), 1e-10 * scale);
    if (nu > 0) {
      EXPECT_LE((M * fu + iu).cwiseAbs().maxCoeff(),
                1e-10 * std::max(1.0, iu.cwiseAbs().maxCoeff()));
    }
  }
}

// A force element written outside the library: central differences, which agree with the
// dual numbers of the same load from a built-in element.
class PushAlongX final : public ForceElement {
 public:
  explicit PushAlongX(int body) : body_(body) {}
  std::string type() const override { return "push"; }
  int body() const override { return body_; }
  void apply(const Model&, const State&, const Kinematics&, Loads& loads) const override {
    loads.force[static_cast<size_t>(body_)] += Vector3(3.0, 0.0, 0.0);
  }

 private:
  int body_;
};

TEST(Derivatives, AnElementOfAnotherTypeIsDifferentiatedByCentralDifferences) {
  std::mt19937 rng(13);
  const Model base = random_jointed(rng, true);
  std::vector<std::shared_ptr<const ForceElement>> custom = base.forces(), builtin = base.forces();
  custom.push_back(std::make_shared<PushAlongX>(0));
  builtin.push_back(std::make_shared<ConstantForce>(0, Vector3(3.0, 0.0, 0.0)));
  const Model a = rebuilt(base, custom, {}), b = rebuilt(base, builtin, {});
  VectorX q, z;
  random_joint_state(a, rng, q, z);
  const int n = a.num_speeds();
  Derivatives da(a), db(b);
  EXPECT_FALSE(da.analytic());
  EXPECT_TRUE(db.analytic());
  EXPECT_NE(da.method().find("central differences"), std::string::npos);
  MatrixX aq(n, n), az(n, n), au(n, 0), bq(n, n), bz(n, n), bu(n, 0);
  da.forward(q, z, VectorX(), aq, az, au);
  db.forward(q, z, VectorX(), bq, bz, bu);
  EXPECT_LE((aq - bq).cwiseAbs().maxCoeff(), 1e-6 * std::max(1.0, bq.cwiseAbs().maxCoeff()));
  EXPECT_LE((az - bz).cwiseAbs().maxCoeff(), 1e-6 * std::max(1.0, bz.cwiseAbs().maxCoeff()));
  MatrixX iq(n, n), iz(n, n), iu(n, 0);
  EXPECT_THROW(da.inverse(q, z, z, VectorX(), iq, iz, iu), std::logic_error);
}

// ---- Analytic systems ----

BodySpec body(const std::string& name, int lower, double mass, const Vector3& inertia,
              const Vector3& com, const Vector3& joint = Vector3::Zero()) {
  BodySpec b;
  b.name = name;
  b.lower_body = lower;
  b.mass = mass;
  b.inertia = inertia.asDiagonal();
  b.com = com;
  b.joint = joint;
  return b;
}

Joint joint(JointType type, const Vector3& axis = Vector3::UnitX()) {
  Joint j;
  j.type = type;
  j.axis = axis;
  return j;
}

bool contains(const Eigen::VectorXcd& values, std::complex<double> lambda, double tol) {
  for (Eigen::Index i = 0; i < values.size(); ++i)
    if (std::abs(values[i] - lambda) <= tol * std::max(1.0, std::abs(lambda))) return true;
  return false;
}

// A compound pendulum hanging on a revolute joint: lambda = +-i sqrt(m g l / (I_G + m l^2)).
TEST(Linearize, PendulumEigenvaluesAreItsFrequency) {
  const double m = 2.0, l = 0.7, ig = 0.05;
  const Model model({body("bob", kGround, m, Vector3(ig, ig, ig), Vector3(0, 0, -l))},
                    Vector3(0, 0, -kG), {}, "pendulum", {joint(JointType::revolute)});
  const Linearization lin = linearize(model, VectorX::Zero(1), VectorX::Zero(1), VectorX());
  const double w = std::sqrt(m * kG * l / (ig + m * l * l));
  ASSERT_EQ(lin.eigenvalues.size(), 2);
  EXPECT_NEAR(lin.eigenvalues[0].real(), 0.0, 1e-12 * w);
  EXPECT_NEAR(lin.eigenvalues[0].imag(), w, 1e-12 * w);
  EXPECT_NEAR(lin.eigenvalues[1].imag(), -w, 1e-12 * w);
  EXPECT_EQ(lin.state, (std::vector<std::string>{"bob.j1", "bob.jd1"}));
  EXPECT_FALSE(lin.periodic);
  // Upside down, the same pendulum falls at the real rate sqrt(...).
  VectorX up(1);
  up << std::numbers::pi;
  const Linearization inverted = linearize(model, up, VectorX::Zero(1), VectorX());
  EXPECT_NEAR(inverted.eigenvalues[0].real(), w, 1e-12 * w);
  EXPECT_NEAR(inverted.eigenvalues[1].real(), -w, 1e-12 * w);
}

// A mass on a prismatic joint with a joint spring and damper: m s^2 + c s + k = 0.
TEST(Linearize, MassOnASpringAndDamper) {
  const double m = 3.0, k = 40.0;
  for (const double c : {0.0, 2.0}) {
    const Model model(
        {body("mass", kGround, m, Vector3(1, 1, 1), Vector3::Zero())}, Vector3::Zero(),
        {std::make_shared<JointLoad>(0, VectorX::Constant(1, k), VectorX::Constant(1, c),
                                     VectorX::Zero(1), VectorX::Zero(1))},
        "spring", {joint(JointType::prismatic)});
    const Linearization lin = linearize(model, VectorX::Zero(1), VectorX::Zero(1), VectorX());
    const std::complex<double> root =
        (-c + std::sqrt(std::complex<double>(c * c - 4 * m * k))) / (2 * m);
    EXPECT_TRUE(contains(lin.eigenvalues, root, 1e-12)) << lin.eigenvalues.transpose();
    EXPECT_TRUE(contains(lin.eigenvalues, std::conj(root), 1e-12));
  }
}

// A torque-free rigid body spinning at w0 about principal axis i: the perturbations of the other
// two rates grow or turn at lambda^2 = w0^2 (I_i - I_j)(I_k - I_i) / (I_j I_k) (Euler's
// equations); real for the intermediate axis (the tennis racket), imaginary for the others.
TEST(Linearize, TorqueFreeBodyAboutEachPrincipalAxis) {
  const Vector3 I(1.0, 2.0, 3.0);
  const double w0 = 2.5;
  const Model model({body("racket", kGround, 1.0, I, Vector3::Zero())});
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    VectorX q = VectorX::Zero(7), z = VectorX::Zero(6);
    q[3] = 1.0;
    z[i] = w0;
    const Linearization lin = linearize(model, q, z, VectorX());
    EXPECT_TRUE(lin.periodic);
    const double l2 = w0 * w0 * (I[i] - I[j]) * (I[k] - I[i]) / (I[j] * I[k]);
    const std::complex<double> lambda = std::sqrt(std::complex<double>(l2));
    EXPECT_TRUE(contains(lin.eigenvalues, lambda, 1e-10))
        << i << ": " << lin.eigenvalues.transpose();
    EXPECT_TRUE(contains(lin.eigenvalues, -lambda, 1e-10));
    if (i == 1) {
      EXPECT_GT(lin.eigenvalues[0].real(), 0.1);  // the intermediate axis is unstable
    } else {
      EXPECT_LE(lin.eigenvalues[0].real(), 1e-10);
    }
  }
}

// The cart-pole at the upright pose against the textbook A and B: with p = I (M + m) + M m l^2,
//   x''  = -m^2 g l^2 / p theta + (I + m l^2) / p F
//   th'' = (M + m) m g l / p theta - m l / p F.
TEST(Linearize, CartPoleAgainstTheTextbook) {
  const double M = 1.5, m = 0.4, l = 0.6, I = 0.02;
  Joint slide = joint(JointType::prismatic, Vector3::UnitX());
  Joint hinge = joint(JointType::revolute, Vector3::UnitY());
  Input push;
  push.name = "push";
  push.type = InputType::joint;
  push.body = 0;
  const Model model({body("cart", kGround, M, Vector3(0.1, 0.1, 0.1), Vector3::Zero()),
                     body("pole", 0, m, Vector3(I, I, I), Vector3(0, 0, l))},
                    Vector3(0, 0, -kG), {}, "cart-pole", {slide, hinge}, {}, {push});
  const Linearization lin = linearize(model, VectorX::Zero(2), VectorX::Zero(2), VectorX::Zero(1));
  const double p = I * (M + m) + M * m * l * l;
  MatrixX A = MatrixX::Zero(4, 4), B = MatrixX::Zero(4, 1);
  A(0, 2) = A(1, 3) = 1.0;
  A(2, 1) = -m * m * kG * l * l / p;
  A(3, 1) = (M + m) * m * kG * l / p;
  B(2, 0) = (I + m * l * l) / p;
  B(3, 0) = -m * l / p;
  EXPECT_LE((lin.A - A).cwiseAbs().maxCoeff(), 1e-12 * A.cwiseAbs().maxCoeff()) << lin.A;
  EXPECT_LE((lin.B - B).cwiseAbs().maxCoeff(), 1e-12 * B.cwiseAbs().maxCoeff()) << lin.B;
  EXPECT_EQ(lin.state, (std::vector<std::string>{"cart.j1", "pole.j1", "cart.jd1", "pole.jd1"}));
  EXPECT_EQ(lin.inputs, std::vector<std::string>{"push"});
  EXPECT_GT(lin.eigenvalues[0].real(), 1.0);  // upright is unstable
}

// ---- Equilibrium, and the linear motion against the nonlinear one ----

// A free body on a bushing to the ground, a spherical joint with a bushing below it, and a
// revolute pendulum below that: a rest pose exists, off the initial pose.
Model hanging_three() {
  std::vector<BodySpec> bodies = {
      body("base", kGround, 3.0, Vector3(0.2, 0.3, 0.25), Vector3(0.05, 0, -0.1)),
      body("ball", 0, 1.5, Vector3(0.05, 0.06, 0.04), Vector3(0.1, 0.02, -0.2),
           Vector3(0, 0, -0.2)),
      body("arm", 1, 0.8, Vector3(0.02, 0.03, 0.01), Vector3(0, 0.05, -0.3), Vector3(0, 0, -0.4))};
  std::vector<std::shared_ptr<const ForceElement>> forces = {
      std::make_shared<Bushing>(0, Vector3(400, 500, 600), Vector3(8, 8, 8), 80.0, 2.0),
      std::make_shared<Bushing>(1, Vector3::Zero(), Vector3::Zero(), 30.0, 0.5),
      std::make_shared<JointLoad>(2, VectorX::Constant(1, 5.0), VectorX::Constant(1, 0.3),
                                  VectorX::Constant(1, 0.4), VectorX::Zero(1))};
  return Model(bodies, Vector3(0, 0, -kG), forces, "three",
               {joint(JointType::free), joint(JointType::spherical),
                joint(JointType::revolute, Vector3(1, 0.2, 0))});
}

VectorX identity_pose(const Model& m) {
  VectorX q = VectorX::Zero(m.num_coordinates());
  for (int k = 0; k < m.num_bodies(); ++k)
    if (m.joint(k).type == JointType::free || m.joint(k).type == JointType::spherical)
      q[m.coordinate_offset(k) + 3] = 1.0;
  return q;
}

TEST(Equilibrium, NewtonFindsTheRestPose) {
  const Model m = hanging_three();
  const VectorX q0 = identity_pose(m);
  const EquilibriumResult rest = equilibrium(m, q0, VectorX());
  ASSERT_TRUE(rest.converged) << rest.message;
  EXPECT_LE(rest.iterations, 20);
  // At rest: z dot = 0 at z = 0, by the forward dynamics (not the residual Newton used).
  const int n = m.num_speeds();
  VectorX zdot(n);
  Dynamics(m).evaluate(rest.q, VectorX::Zero(n), zdot);
  EXPECT_LE(zdot.cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_GT(tangent_difference(m, q0, rest.q).norm(), 1e-3);  // it moved
  // Damped and restrained: every eigenvalue in the left half plane.
  const Linearization lin = linearize(m, rest.q, VectorX::Zero(n), VectorX());
  EXPECT_LT(lin.eigenvalues[0].real(), 0.0);
  EXPECT_TRUE(rest.unrestrained.empty());
}

TEST(Equilibrium, AHeldCoordinateKeepsItsValue) {
  const Model m = hanging_three();
  const VectorX q0 = identity_pose(m);
  EquilibriumOptions options;
  for (int i = 0; i < m.num_speeds() - 1; ++i) options.free.push_back(i);  // hold the arm
  const EquilibriumResult rest = equilibrium(m, q0, VectorX(), options);
  ASSERT_TRUE(rest.converged) << rest.message;
  EXPECT_EQ(rest.q[m.coordinate_offset(2)], q0[m.coordinate_offset(2)]);
  EXPECT_EQ(rest.residual.size(), m.num_speeds() - 1);
}

// With every coordinate free, the linearization at rest is linearize() at z = 0; with one held,
// it is the system without that coordinate: its rows and columns left out of M and dQ.
TEST(Equilibrium, LinearizationAtRestLocksTheHeldCoordinates) {
  const Model m = hanging_three();
  const EquilibriumResult rest = equilibrium(m, identity_pose(m), VectorX());
  ASSERT_TRUE(rest.converged);
  const int n = m.num_speeds();
  std::vector<int> all;
  for (int i = 0; i < n; ++i) all.push_back(i);
  const Linearization whole = linearize(m, rest.q, VectorX::Zero(n), VectorX());
  const Linearization at_rest = linearize_at_rest(m, rest.q, VectorX(), all);
  EXPECT_LE((whole.A - at_rest.A).cwiseAbs().maxCoeff(), 1e-9 * whole.A.cwiseAbs().maxCoeff());
  EXPECT_EQ(whole.state, at_rest.state);
  // Hold everything but the arm's hinge: a damped pendulum on a spring, whose eigenvalues are
  // those of the 1-speed system M s^2 + D s + K = 0 from the whole model's matrices.
  const int hinge = n - 1;
  const Linearization one = linearize_at_rest(m, rest.q, VectorX(), {hinge});
  ASSERT_EQ(one.A.rows(), 2);
  MatrixX M(n, n), dq(n, n), dz(n, n), du(n, 0);
  Terms(m).mass_matrix(rest.q, M);
  Derivatives(m).inverse(rest.q, VectorX::Zero(n), VectorX::Zero(n), VectorX(), dq, dz, du);
  const double a = M(hinge, hinge), b = dz(hinge, hinge), c = dq(hinge, hinge);
  const std::complex<double> root =
      (-b + std::sqrt(std::complex<double>(b * b - 4 * a * c))) / (2 * a);
  EXPECT_TRUE(contains(one.eigenvalues, root, 1e-12)) << one.eigenvalues.transpose();
  EXPECT_EQ(one.state, (std::vector<std::string>{"arm.j1", "arm.jd1"}));
}

TEST(Equilibrium, AFallingBodyFailsAndSaysWhatIsUnrestrained) {
  const Model m({body("rock", kGround, 1.0, Vector3(1, 1, 1), Vector3::Zero())},
                Vector3(0, 0, -kG));
  VectorX q0 = VectorX::Zero(7);
  q0[3] = 1.0;
  const EquilibriumResult rest = equilibrium(m, q0, VectorX());
  EXPECT_FALSE(rest.converged);
  EXPECT_NEAR(rest.residual_norm, kG, 1e-12);
  EXPECT_NE(rest.message.find("did not converge"), std::string::npos);
  EXPECT_EQ(rest.unrestrained.size(), 6u);
}

// RK4 of the nonlinear equations in (q, z), Euler parameters normalized after each step.
void nonlinear_rk4(const Model& m, VectorX& q, VectorX& z, double t_end, int steps) {
  Dynamics d(m);
  const int n = m.num_speeds(), nq = m.num_coordinates();
  const double h = t_end / steps;
  VectorX k1q(nq), k2q(nq), k3q(nq), k4q(nq), k1z(n), k2z(n), k3z(n), k4z(n);
  for (int s = 0; s < steps; ++s) {
    d.evaluate(q, z, k1z, k1q);
    d.evaluate(q + 0.5 * h * k1q, z + 0.5 * h * k1z, k2z, k2q);
    d.evaluate(q + 0.5 * h * k2q, z + 0.5 * h * k2z, k3z, k3q);
    d.evaluate(q + h * k3q, z + h * k3z, k4z, k4q);
    q += h / 6 * (k1q + 2 * k2q + 2 * k3q + k4q);
    z += h / 6 * (k1z + 2 * k2z + 2 * k3z + k4z);
    for (int k = 0; k < m.num_bodies(); ++k)
      if (m.joint(k).type == JointType::free || m.joint(k).type == JointType::spherical)
        q.segment<4>(m.coordinate_offset(k)).normalize();
  }
}

VectorX linear_rk4(const MatrixX& A, VectorX x, double t_end, int steps) {
  const double h = t_end / steps;
  for (int s = 0; s < steps; ++s) {
    const VectorX k1 = A * x, k2 = A * (x + 0.5 * h * k1), k3 = A * (x + 0.5 * h * k2),
                  k4 = A * (x + h * k3);
    x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  return x;
}

// From a perturbation of size a about the rest pose, the linear motion differs from the
// nonlinear one by O(a^2): halving a quarters the difference (between 3.5x and 4.5x; the RK4
// error of both, 1e-11, is far below the differences, 1e-6 and up).
TEST(Linearize, LinearMotionFollowsTheNonlinearToSecondOrder) {
  const Model m = hanging_three();
  const EquilibriumResult rest = equilibrium(m, identity_pose(m), VectorX());
  ASSERT_TRUE(rest.converged);
  const int n = m.num_speeds();
  const Linearization lin = linearize(m, rest.q, VectorX::Zero(n), VectorX());
  std::mt19937 rng(17);
  const VectorX direction = random_vector_of(rng, 2 * n, -1, 1);
  double previous = 0.0;
  for (const double a : {2e-2, 1e-2}) {
    const VectorX x0 = a * direction;
    VectorX q = retract(m, rest.q, x0.head(n)), z = x0.tail(n);
    nonlinear_rk4(m, q, z, 0.5, 2000);
    const VectorX x_lin = linear_rk4(lin.A, x0, 0.5, 2000);
    VectorX x_nl(2 * n);
    x_nl << tangent_difference(m, rest.q, q), z;
    const double difference = (x_nl - x_lin).norm();
    if (previous > 0.0) {
      EXPECT_GT(previous / difference, 3.5);
      EXPECT_LT(previous / difference, 4.5);
    }
    previous = difference;
  }
}

TEST(Eigenvalues, SortedByRealPartThenImaginaryWithUnitVectors) {
  MatrixX a(3, 3);
  a << 0, -2, 0, 2, 0, 0, 0, 0, -1;  // +-2i and -1
  Eigen::MatrixXcd vectors;
  const Eigen::VectorXcd values = sorted_eigenvalues(a, &vectors);
  EXPECT_NEAR(values[0].imag(), 2.0, 1e-15);
  EXPECT_NEAR(values[1].imag(), -2.0, 1e-15);
  EXPECT_NEAR(values[2].real(), -1.0, 1e-15);
  for (int i = 0; i < 3; ++i) {
    const Eigen::VectorXcd v = vectors.col(i);
    EXPECT_LE((a.cast<std::complex<double>>() * v - values[i] * v).norm(), 1e-14);
    EXPECT_NEAR(v.cwiseAbs().maxCoeff(), 1.0, 1e-15);
  }
}

// Above 48 rows LAPACK's dgeevx computes them: the same values as Eigen's solver, and vectors
// with A v = lambda v (round-off: 1e-10 of |A| on a 60 x 60 matrix).
TEST(Eigenvalues, LapackAndEigenAgreeOnALargerMatrix) {
  std::mt19937 rng(23);
  const MatrixX a = MatrixX::NullaryExpr(60, 60, [&] { return uniform(rng, -1, 1); });
  Eigen::MatrixXcd vectors;
  const Eigen::VectorXcd values = sorted_eigenvalues(a, &vectors);
  const Eigen::VectorXcd reference = Eigen::EigenSolver<MatrixX>(a, false).eigenvalues();
  for (Eigen::Index i = 0; i < reference.size(); ++i)
    EXPECT_TRUE(contains(values, reference[i], 1e-10)) << reference[i];
  for (Eigen::Index i = 0; i + 1 < values.size(); ++i)
    EXPECT_GE(values[i].real(), values[i + 1].real());
  const Eigen::MatrixXcd ac = a.cast<std::complex<double>>();
  for (Eigen::Index i = 0; i < values.size(); ++i)
    EXPECT_LE((ac * vectors.col(i) - values[i] * vectors.col(i)).norm(), 1e-10 * 60);
}

}  // namespace
}  // namespace kanedyn
