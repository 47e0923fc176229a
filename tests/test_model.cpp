// The Model's own validation (model.hpp), in C++ without files: every refusal names the body
// or force entry and the problem; the topology it derives (depth u_K, roots, chains).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "kanedyn/forces.hpp"
#include "kanedyn/model.hpp"

namespace kanedyn {
namespace {

BodySpec body(const std::string& name, int lower, double mass = 1.0) {
  BodySpec b;
  b.name = name;
  b.lower_body = lower;
  b.mass = mass;
  b.inertia = Vector3(0.1, 0.2, 0.25).asDiagonal();
  return b;
}

/// The ModelError message of building this model, or "(accepted)".
std::string refusal(std::vector<BodySpec> bodies, Vector3 gravity = Vector3::Zero(),
                    std::vector<std::shared_ptr<const ForceElement>> forces = {}) {
  try {
    Model model(std::move(bodies), gravity, std::move(forces));
  } catch (const ModelError& e) {
    return e.what();
  }
  return "(accepted)";
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(Model, RefusesEachInvalidBodyNamingIt) {
  EXPECT_EQ(refusal({body("a", kGround), body("b", 0)}), "(accepted)");
  EXPECT_NE(refusal({}).find("at least one body"), std::string::npos);
  EXPECT_NE(refusal({body("a", kGround), body("a", 0)}).find("body 2 'a': duplicate body name"),
            std::string::npos);
  EXPECT_NE(refusal({body("bad name", kGround)}).find("body 1 'bad name': name must be"),
            std::string::npos);
  EXPECT_NE(refusal({body("", kGround)}).find("name must be non-empty"), std::string::npos);
  // L(K) < K: a later body, the body itself, or an index out of range.
  EXPECT_NE(refusal({body("a", 1), body("b", kGround)}).find("body 1 'a': parent must be"),
            std::string::npos);
  EXPECT_NE(refusal({body("a", kGround), body("b", 1)}).find("body 2 'b': parent"),
            std::string::npos);
  EXPECT_NE(refusal({body("a", -7)}).find("parent"), std::string::npos);
  for (const double m : {0.0, -1.0, kNaN, std::numeric_limits<double>::infinity()})
    EXPECT_NE(refusal({body("a", kGround, m)}).find("body 1 'a': mass must be a finite number > 0"),
              std::string::npos)
        << m;
  BodySpec com = body("a", kGround);
  com.com.y() = kNaN;
  EXPECT_NE(refusal({com}).find("com has a non-finite component"), std::string::npos);
  BodySpec joint = body("a", kGround);
  joint.joint.z() = std::numeric_limits<double>::infinity();
  EXPECT_NE(refusal({joint}).find("joint has a non-finite component"), std::string::npos);
  EXPECT_NE(refusal({body("a", kGround)}, Vector3(0, 0, kNaN)).find("gravity"), std::string::npos);
}

TEST(Model, InertiaMustBeAPhysicalTensor) {
  EXPECT_EQ(check_inertia(Vector3(1, 2, 2.5).asDiagonal()), "");
  EXPECT_EQ(check_inertia(Vector3(1, 1, 2).asDiagonal()), "");  // a lamina: on the boundary
  EXPECT_NE(check_inertia(Vector3(1, 1, 3).asDiagonal()).find("triangle inequality"),
            std::string::npos);
  EXPECT_NE(check_inertia(Vector3(1, 0, 1).asDiagonal()).find("not positive definite"),
            std::string::npos);
  Matrix3 asymmetric = Vector3(1, 1, 1).asDiagonal();
  asymmetric(0, 1) = 0.1;
  EXPECT_NE(check_inertia(asymmetric).find("not symmetric"), std::string::npos);
  // 1.5 I + 0.5 (ones): principal moments 3, 1.5, 1.5, on the triangle boundary.
  Matrix3 products = Vector3(2, 2, 2).asDiagonal();
  products(0, 1) = products(1, 0) = 0.5;
  products(0, 2) = products(2, 0) = 0.5;
  products(1, 2) = products(2, 1) = 0.5;
  EXPECT_EQ(check_inertia(products), "");
  BodySpec b = body("a", kGround);
  b.inertia = Vector3(1, 1, 3).asDiagonal();
  EXPECT_NE(refusal({b}).find("body 1 'a': principal moments"), std::string::npos);
}

TEST(Model, RefusesForceElementsOnMissingBodiesOrWithBadParameters) {
  const auto bushing = [](int k, double stiffness, double damping) {
    return std::make_shared<Bushing>(k, Vector3::Constant(stiffness), Vector3::Constant(damping),
                                     stiffness, damping);
  };
  EXPECT_EQ(refusal({body("a", kGround)}, Vector3::Zero(), {bushing(0, 1, 1)}), "(accepted)");
  EXPECT_NE(refusal({body("a", kGround)}, Vector3::Zero(), {bushing(1, 1, 1)}).find("force"),
            std::string::npos);
  EXPECT_NE(
      refusal({body("a", kGround)}, Vector3::Zero(), {bushing(0, -1, 0)}).find("stiffness must"),
      std::string::npos);
  EXPECT_NE(
      refusal({body("a", kGround)}, Vector3::Zero(), {bushing(0, 1, -1)}).find("damping must"),
      std::string::npos);
  EXPECT_NE(refusal({body("a", kGround)}, Vector3::Zero(), {bushing(0, kNaN, 0)}).find("finite"),
            std::string::npos);
}

TEST(Model, DerivesTheNotesTopology) {
  // The notes' L = (0, 1, 2, 2, 1, 1, 1, 7): u_K = (0, 1, 2, 2, 1, 1, 1, 2), chains to 0.
  const int lower[] = {0, 1, 2, 2, 1, 1, 1, 7};
  std::vector<BodySpec> bodies;
  for (int k = 0; k < 8; ++k) bodies.push_back(body("b" + std::to_string(k + 1), lower[k] - 1));
  const Model model(std::move(bodies), Vector3::Zero());
  const int depth[] = {0, 1, 2, 2, 1, 1, 1, 2};
  for (int k = 0; k < 8; ++k) {
    EXPECT_EQ(model.lower_body(k), lower[k] - 1);
    EXPECT_EQ(model.depth(k), depth[k]) << "body " << k + 1;
  }
  std::vector<int> chain;
  for (const int c : model.chain(7)) chain.push_back(c);
  EXPECT_EQ(chain, (std::vector<int>{7, 6, 0}));  // 8 -> 7 -> 1, 0-based
  EXPECT_EQ(model.chain_entries(), 8 + 0 + 1 + 2 + 2 + 1 + 1 + 1 + 2);
  EXPECT_DOUBLE_EQ(model.total_mass(), 8.0);
}

}  // namespace
}  // namespace kanedyn
