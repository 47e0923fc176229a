// Simulate a model file with the library, without writing files: print the torso's height
// and the total energy every half second.
//   build/examples/simulate_example [MODEL]   (default: examples/eight_body.yaml)
#include <cstdio>

#include "kanedyn/energy.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/simulate.hpp"

int main(int argc, char** argv) {
  const char* path = argc > 1 ? argv[1] : KANEDYN_EXAMPLES_DIR "/eight_body.yaml";
  const kanedyn::io::ModelFile file = kanedyn::io::load_model_file(path);

  kanedyn::SimulationSettings settings;  // dopri5, rtol 1e-8, atol 1e-10
  settings.t_end = 3.0;
  settings.dt_out = 0.5;
  const kanedyn::SimulationStats stats =
      kanedyn::simulate(file.model, file.q, file.z, settings,
                        [&](double t, const kanedyn::State&, const kanedyn::VectorX& q,
                            const kanedyn::VectorX& z, kanedyn::Data& data) {
                          const double energy = kanedyn::total_energy(file.model, q, z, data);
                          std::printf("t = %.2f  body 1 G_z = %.5f m  energy = %.6f J\n", t,
                                      data.kinematics.p_G[0].z(), energy);
                        });
  std::printf("%ld steps, %ld evaluations: %s\n", stats.steps_accepted, stats.evaluations,
              stats.ok() ? "completed" : stats.message.c_str());
  return stats.ok() ? 0 : 1;
}
