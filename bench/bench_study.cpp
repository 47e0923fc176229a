// A study's cost per run beside the simulation it wraps (docs/performance.md, "Studies"): one
// run of the eight-body figure for 1 s as `kanedyn sweep` does it (build the model from the
// parsed document with two numbers changed, simulate, reduce four outputs, format the row),
// the same simulation alone, and the build alone.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/study.hpp"
#include "kanedyn/simulate.hpp"

namespace {

using namespace kanedyn;

const std::string kModel = std::string(KANEDYN_SOURCE_DIR) + "/examples/eight_body.yaml";

const io::Study& study() {
  static const io::Study s = io::parse_study(
      "format: kanedyn-study/1\nmodel: " + kModel +
          "\nseed: 1\nruns: 1000\nvary:\n"
          "  - key: forces[1].stiffness\n    uniform: [2.0e4, 8.0e4]\n"
          "  - key: bodies[head].mass\n    normal: {mean: 5.0, std: 0.5}\n"
          "simulate: {t_end: 1.0, dt_out: 0.01}\n"
          "outputs:\n  - final: head.z\n  - max: head.z\n  - rms: torso.w1\n  - min: energy\n",
      "bench.yaml", "");
  return s;
}

// Run 0 each time, so that the simulation is the same one simulation_alone times.
void study_run(benchmark::State& state) {
  const io::Study& s = study();
  for (auto _ : state) benchmark::DoNotOptimize(io::run_study_run(s, 0));
}
BENCHMARK(study_run)->Unit(benchmark::kMillisecond);

// The same run with one output that needs neither the kinematics nor the energy of the rows.
void study_run_rates_only(benchmark::State& state) {
  static const io::Study s =
      io::parse_study("format: kanedyn-study/1\nmodel: " + kModel +
                          "\nseed: 1\nruns: 1000\nvary:\n"
                          "  - key: forces[1].stiffness\n    uniform: [2.0e4, 8.0e4]\n"
                          "  - key: bodies[head].mass\n    normal: {mean: 5.0, std: 0.5}\n"
                          "simulate: {t_end: 1.0, dt_out: 0.01}\noutputs:\n  - rms: torso.w1\n",
                      "bench.yaml", "");
  for (auto _ : state) benchmark::DoNotOptimize(io::run_study_run(s, 0));
}
BENCHMARK(study_run_rates_only)->Unit(benchmark::kMillisecond);

/// Run 0's model, built once.
io::ModelFile run0() {
  const io::Study& s = study();
  const std::vector<double> p = s.parameters(0);
  const std::vector<std::pair<uint32_t, double>> changes{{s.vary[0].node, p[0]},
                                                         {s.vary[1].node, p[1]}};
  return s.model.build(changes);
}

void simulation_alone(benchmark::State& state) {
  const io::ModelFile file = run0();
  SimulationSettings settings = study().settings(file);
  settings.observer_kinematics = false;
  for (auto _ : state) benchmark::DoNotOptimize(simulate(file.model, file.q, file.z, settings));
}
BENCHMARK(simulation_alone)->Unit(benchmark::kMillisecond);

void model_build(benchmark::State& state) {
  const io::Study& s = study();
  const std::vector<std::pair<uint32_t, double>> changes{{s.vary[0].node, 3.0e4},
                                                         {s.vary[1].node, 5.5}};
  for (auto _ : state) benchmark::DoNotOptimize(s.model.build(changes));
}
BENCHMARK(model_build)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
