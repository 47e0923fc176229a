// Static equilibrium of models with constraints (docs/analysis.md, "Static equilibrium"): the
// rest pose against an analytic one (a rod hanging from a hinge) and against the constrained
// forward dynamics (the four-bar at rest has no acceleration there, by the multipliers route,
// which shares nothing with the equilibrium's residual but the tree); the CLI's command.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <filesystem>

#include "constraint_models.hpp"
#include "file_support.hpp"
#include "kanedyn/analysis.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/rotation.hpp"

namespace kanedyn {
namespace {

namespace fs = std::filesystem;

using test::hinged_rod;

// Released 50 degrees from hanging, the rod's rest pose hangs straight down: its centre of mass
// at (0, 0, -0.75). Newton stops at a generalized force of 1e-10 of the weight's moment, so
// the angle is within 1e-10 / (m g L/2) rad; the hinge holds to the projection's 1e-12.
TEST(ConstrainedEquilibrium, AHingedRodHangsStraightDown) {
  const Model m = hinged_rod();
  VectorX q = VectorX::Zero(7);
  const double angle = 50.0 * std::acos(-1.0) / 180.0;
  q.head<4>() << std::sin(angle / 2), 0, 0, std::cos(angle / 2);
  const EquilibriumResult rest = equilibrium(m, q, VectorX());
  ASSERT_TRUE(rest.converged) << rest.message;
  EXPECT_EQ(rest.residual.size(), 1);  // one independent speed: the turn about the hinge
  // The centre of mass: [R]^T c' + the origin, which the hinge holds at the ground's origin.
  const Matrix3 R = rotation_matrix(Vector4(rest.q.head<4>()));
  const Vector3 centre = R.transpose() * Vector3(0, 0, -0.75) + Vector3(rest.q.segment<3>(4));
  EXPECT_NEAR(centre.x(), 0.0, 1e-9);
  EXPECT_NEAR(centre.y(), 0.0, 1e-9);
  EXPECT_NEAR(centre.z(), -0.75, 1e-9);
  ConstraintEquations eq(m);
  eq.evaluate(rest.q, VectorX::Zero(6));
  EXPECT_LT(eq.errors().cwiseAbs().maxCoeff(), 1e-10);
  // Hanging: a pendulum's two imaginary eigenvalues, sqrt(m g (L/2) / I_O) = sqrt(3 g / (2 L)).
  ASSERT_EQ(rest.eigenvalues.size(), 2);
  const double omega = std::sqrt(3.0 * 9.81 / (2.0 * 1.5));
  for (Eigen::Index i = 0; i < 2; ++i) {
    EXPECT_NEAR(rest.eigenvalues[i].real(), 0.0, 1e-6);
    EXPECT_NEAR(std::abs(rest.eigenvalues[i].imag()), omega, 1e-6);
  }
}

// The four-bar under gravity comes to rest where the constrained forward dynamics, by the
// multipliers route, gives it no acceleration: z dot = 0 to 1e-8 / s^2 (the residual's 1e-10
// of the weights' moments over the linkage's smallest inertia, ~0.01). Newton finds the
// stationary point of the potential nearest the start, here a maximum (the linkage balanced
// over its top): a conservative system's eigenvalues there are a real pair +-lambda (at a
// minimum an imaginary one), so lambda^2 is real and the pair sums to zero.
TEST(ConstrainedEquilibrium, TheFourBarRestsWhereItsAccelerationVanishes) {
  const io::ModelFile f = io::load_model_file(test::kExamples + "/four_bar.yaml");
  const EquilibriumResult rest = equilibrium(f.model, f.q, VectorX());
  ASSERT_TRUE(rest.converged) << rest.message;
  const VectorX zero = VectorX::Zero(f.model.num_speeds());
  Dynamics dyn(f.model, Route::recursive);
  VectorX zdot(f.model.num_speeds());
  dyn.evaluate(rest.q, zero, zdot);
  EXPECT_LT(zdot.cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT(dyn.constraint_error(), 1e-10);
  // And it moved: the initial state swings (its acceleration is not small).
  dyn.evaluate(f.q, zero, zdot);
  EXPECT_GT(zdot.cwiseAbs().maxCoeff(), 1.0);
  ASSERT_EQ(rest.eigenvalues.size(), 2);
  const std::complex<double> square = rest.eigenvalues[0] * rest.eigenvalues[0];
  EXPECT_GT(std::abs(square), 1.0);
  EXPECT_LT(std::abs(square.imag()), 1e-6 * std::abs(square));
  EXPECT_LT(std::abs(rest.eigenvalues[0] + rest.eigenvalues[1]), 1e-6 * std::abs(square));
  // Over the top: the pair is real, the pose unstable.
  EXPECT_GT(rest.eigenvalues[0].real(), 1.0);
}

TEST(ConstrainedEquilibrium, HoldingCoordinatesIsRefused) {
  const Model m = hinged_rod();
  EquilibriumOptions options;
  options.free = {0};
  VectorX q = VectorX::Zero(7);
  q[3] = 1.0;
  EXPECT_THROW(equilibrium(m, q, VectorX(), options), std::invalid_argument);
}

// The command: finds the four-bar's rest pose and writes it; the file loads and rests there.
TEST(ConstrainedEquilibrium, TheCommandWritesTheRestPose) {
  const fs::path dir = test::temp_dir("constrained_equilibrium_cli");
  const std::string model = test::kExamples + "/four_bar.yaml";
  const auto r = test::run_in(dir, "equilibrium '" + model + "' -o rest.yaml");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("independent speeds"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("the rest pose is unstable"), std::string::npos) << r.out;
  const io::ModelFile rest = io::load_model_file((dir / "rest.yaml").string());
  Dynamics dyn(rest.model, Route::recursive);
  VectorX zdot(rest.model.num_speeds());
  dyn.evaluate(rest.q, VectorX::Zero(rest.model.num_speeds()), zdot);
  // The file's numbers round-trip exactly; the loader's projection moves them by at most its
  // tolerance.
  EXPECT_LT(zdot.cwiseAbs().maxCoeff(), 1e-7);
  const auto held = test::run_in(dir, "equilibrium '" + model + "' --free crank");
  EXPECT_NE(held.exit_code, 0);
  EXPECT_NE(held.err.find("leave --free out"), std::string::npos) << held.err;
}

}  // namespace
}  // namespace kanedyn
