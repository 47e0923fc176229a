#include "kanedyn/state.hpp"

#include <cmath>

namespace kanedyn {

State::State(int num_bodies) : x(VectorX::Zero(7 * num_bodies)), y(VectorX::Zero(6 * num_bodies)) {
  for (int k = 0; k < num_bodies; ++k) x[4 * k + 3] = 1.0;
}

double State::normalize_euler_parameters() {
  double drift = 0.0;
  for (int k = 0; k < num_bodies(); ++k) {
    auto e = euler_parameters(k);
    const double n = e.norm();
    drift = std::max(drift, std::abs(n - 1.0));
    e /= n;
  }
  return drift;
}

}  // namespace kanedyn
