// Loads a model from text and simulates it through the installed headers of kanedyn::io and
// kanedyn::core: a body released at rest falls 0.5 g t^2 in t = 1 s.
#include <cmath>
#include <cstdio>
#include <kanedyn/io/model_file.hpp>
#include <kanedyn/simulate.hpp>

int main() {
  const auto file = kanedyn::io::parse_model_file(
      "format: kanedyn-model/1\ngravity: [0, 0, -9.81]\n"
      "bodies:\n  - {name: ball, parent: ground, mass: 1, inertia: [1, 1, 1]}\n",
      "consumer.yaml");
  kanedyn::SimulationSettings settings;
  settings.t_end = 1.0;
  double z = 0.0;
  const auto stats = kanedyn::simulate(
      file.model, file.q, file.z, settings,
      [&](double, const kanedyn::State& state, const kanedyn::VectorX&, const kanedyn::VectorX&,
          kanedyn::Data&) { z = state.translation(0).z(); });
  std::printf("consumer (io): z(1 s) = %.12f\n", z);
  return stats.ok() && std::abs(z + 0.5 * 9.81) < 1e-9 ? 0 : 1;
}
