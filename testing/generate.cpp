#include "kanedyn/testing/generate.hpp"

#include <cstdint>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "kanedyn/forces.hpp"
#include "kanedyn/rotation.hpp"

namespace kanedyn {

namespace {

using P = LinkParameters;

// std::uniform_real_distribution and friends are implementation-defined; these transforms of
// std::mt19937's raw output (which the standard fixes) give the same numbers everywhere.
class PortableRandom {
 public:
  explicit PortableRandom(unsigned seed) : engine_(seed) {}

  /// Uniform in [0, 1) with 53 random bits.
  double unit() {
    const std::uint64_t high = engine_() >> 5;  // 27 bits
    const std::uint64_t low = engine_() >> 6;   // 26 bits
    return static_cast<double>((high << 26) | low) * 0x1.0p-53;
  }
  double uniform(double a, double b) { return a + (b - a) * unit(); }
  /// Uniform integer in [0, m) (multiply-shift; bias below 2^-32 * m).
  int below(int m) {
    return static_cast<int>(
        (static_cast<std::uint64_t>(engine_()) * static_cast<std::uint64_t>(m)) >> 32);
  }
  Vector3 uniform_vector(double half_range) {
    Vector3 v;
    for (int i = 0; i < 3; ++i) v[i] = uniform(-half_range, half_range);
    return v;
  }
  /// A random direction (rejection sampling in the unit ball, so it is isotropic).
  Vector3 unit_vector() {
    for (;;) {
      const Vector3 v = uniform_vector(1.0);
      const double n = v.norm();
      if (n > 0.1 && n <= 1.0) return v / n;
    }
  }

 private:
  std::mt19937 engine_;
};

// Central inertia of a homogeneous box, width w along x and y, length l along z.
Matrix3 box_inertia(double mass, double width, double length) {
  const double side = mass * (width * width + length * length) / 12.0;
  return Vector3(side, side, mass * (2.0 * width * width) / 12.0).asDiagonal();
}

BodySpec link(int k, int lower_body, double mass, double width) {
  BodySpec b;
  b.name = "link" + std::to_string(k + 1);
  b.lower_body = lower_body;
  b.mass = mass;
  b.inertia = box_inertia(mass, width, P::link_length);
  b.com = Vector3(0.0, 0.0, -0.5 * P::link_length);  // mid-link
  b.joint = lower_body == kGround ? Vector3::Zero() : Vector3(0.0, 0.0, -P::link_length);
  return b;
}

std::vector<std::shared_ptr<const ForceElement>> bushings(int n) {
  std::vector<std::shared_ptr<const ForceElement>> forces;
  forces.reserve(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k)
    forces.push_back(std::make_shared<Bushing>(k, Vector3::Constant(P::stiffness),
                                               Vector3::Constant(P::damping), P::rot_stiffness,
                                               P::rot_damping));
  return forces;
}

void check_size(int n, const char* what) {
  if (n < 1) throw std::invalid_argument(std::string(what) + ": need at least one body");
}

}  // namespace

State random_initial_state(const Model& model, unsigned seed) {
  PortableRandom random(seed);
  State state(model);
  std::vector<Matrix3> R(static_cast<size_t>(model.num_bodies()));
  for (int k = 0; k < model.num_bodies(); ++k) {
    const Vector3 axis = random.unit_vector();
    const double angle = random.uniform(0.0, kMaxInitialRelativeAngle);
    // [R_K] = [R(rel)] [R_J]: the relative rotation turns J's axes into K's.
    const Matrix3 relative = rotation_matrix(euler_parameters_from_axis_angle(axis, angle));
    const int j = model.lower_body(k);
    R[static_cast<size_t>(k)] = j == kGround ? relative : relative * R[static_cast<size_t>(j)];
    state.euler_parameters(k) = euler_parameters_from_matrix(R[static_cast<size_t>(k)]);
    state.translation(k) = random.uniform_vector(0.01);
    state.angular_velocity(k) = random.uniform_vector(1.0);
    state.translation_rate(k) = random.uniform_vector(0.1);
  }
  state.normalize_euler_parameters();
  return state;
}

GeneratedSystem chain_model(int n, unsigned seed) {
  check_size(n, "chain_model");
  std::vector<BodySpec> bodies;
  bodies.reserve(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k)
    bodies.push_back(link(k, k == 0 ? kGround : k - 1, P::link_mass, P::link_width));
  Model model(std::move(bodies), Vector3(0.0, 0.0, P::gravity_z), bushings(n),
              "chain-" + std::to_string(n));
  State initial = random_initial_state(model, seed);
  return {std::move(model), std::move(initial)};
}

GeneratedSystem random_tree_model(int n, unsigned seed) {
  check_size(n, "random_tree_model");
  PortableRandom random(seed);
  std::vector<BodySpec> bodies;
  bodies.reserve(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    const int lower = k == 0 ? kGround : random.below(k);
    const double mass = P::link_mass * random.uniform(0.5, 2.0);
    const double width = P::link_width * random.uniform(0.5, 2.0);
    bodies.push_back(link(k, lower, mass, width));
  }
  Model model(std::move(bodies), Vector3(0.0, 0.0, P::gravity_z), bushings(n),
              "random-tree-" + std::to_string(n) + "-" + std::to_string(seed));
  // A different stream for the state than for the topology (golden-ratio offset).
  State initial = random_initial_state(model, seed + 0x9E3779B9u);
  return {std::move(model), std::move(initial)};
}

}  // namespace kanedyn
