// Google Benchmark entries of Dynamics::evaluate() on jointed models: chains of revolute links (the
// generated chain's links, gravity and bushings, every joint revolute about the link's x axis)
// by the articulated-body route (joints_recursive) and the block-sparse projected route
// (joints_assembled, O(N d^2): only the shorter chains), and the jointed human figure of
// examples/human_jointed.yaml (a free torso, revolute, universal and spherical joints) by both.
// The counter `per_body` is the time per evaluation divided by N: flat in N for the recursive
// route. Run e.g.
//   build/bench/kanedyn_bench_joints --benchmark_repetitions=3
// and read `per_body` (the "_min" aggregate is the least disturbed on a shared machine).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "kanedyn/dynamics.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/testing/generate.hpp"

namespace kanedyn {
namespace {

struct JointedChain {
  std::unique_ptr<Model> model;
  VectorX q, z;
};

JointedChain revolute_chain(int n) {
  JointedChain c;
  Joint joint;
  joint.type = JointType::revolute;
  joint.axis = Vector3::UnitX();
  c.model = std::make_unique<Model>(
      with_joints(chain_model(n).model, std::vector<Joint>(static_cast<size_t>(n), joint)));
  // Small bends and rates (a hanging chain in motion), from a fixed seed.
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> angle(-0.05, 0.05), rate(-0.5, 0.5);
  c.q = VectorX::NullaryExpr(n, [&] { return angle(rng); });
  c.z = VectorX::NullaryExpr(n, [&] { return rate(rng); });
  return c;
}

JointedChain human_jointed() {
  io::ModelFile f = io::load_model_file(KANEDYN_SOURCE_DIR "/examples/human_jointed.yaml");
  JointedChain c;
  c.model = std::make_unique<Model>(std::move(f.model));
  c.q = f.q;
  c.z = f.z;
  return c;
}

void run(benchmark::State& bench, const JointedChain& c, Route route) {
  const int n = c.model->num_bodies();
  Dynamics dyn(*c.model, route);
  VectorX zdot(c.model->num_speeds()), qdot(c.model->num_coordinates());
  dyn.evaluate(c.q, c.z, zdot, qdot);  // the assembled route builds its blocks once
  for (auto _ : bench) {
    dyn.evaluate(c.q, c.z, zdot, qdot);
    benchmark::DoNotOptimize(zdot.data());
    benchmark::ClobberMemory();
  }
  bench.counters["per_body"] = benchmark::Counter(
      n, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void register_all() {
  const auto add = [](Route route, const std::string& model, auto make) {
    benchmark::RegisterBenchmark(("joints_" + to_string(route) + "/" + model).c_str(),
                                 [route, make](benchmark::State& b) { run(b, make(), route); })
        ->Unit(benchmark::kMicrosecond)
        ->ComputeStatistics("min", [](const std::vector<double>& v) {
          return *std::min_element(v.begin(), v.end());
        });
  };
  const auto chain = [&add](Route route, int n) {
    add(route, "chain-" + std::to_string(n), [n] { return revolute_chain(n); });
  };
  for (const int n : {64, 512, 4096, 100000}) chain(Route::recursive, n);
  for (const int n : {64, 512}) chain(Route::assembled, n);
  for (const Route route : {Route::recursive, Route::assembled})
    add(route, "human_jointed", human_jointed);
}

}  // namespace
}  // namespace kanedyn

int main(int argc, char** argv) {
  kanedyn::register_all();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
