// Google Benchmark suite of the internals: each stage of both routes of forward dynamics on the
// eight-body example and on generated chains and random trees. The counter `per_body` is the
// time per iteration divided by N. Run e.g.
//   build/bench/kanedyn_bench_internals --benchmark_filter='recursive_fused'
// and see docs/performance-internal.md for numbers. With --benchmark_repetitions=R the
// aggregates include the minimum over the repetitions ("_min"), the figure least disturbed
// by other processes on a shared machine.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematic_equations.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/partials.hpp"
#include "kanedyn/testing/generate.hpp"
#include "kanedyn/testing/oracles.hpp"

#include "../src/assembled.hpp"
#include "../src/staged.hpp"
#include "../src/workspace.hpp"

namespace kanedyn {
namespace {

struct System {
  std::string name;
  std::shared_ptr<const Model> model;
  State state;
};

std::vector<System> systems() {
  std::vector<System> out;
  const io::ModelFile eight =
      io::load_model_file(std::string(KANEDYN_SOURCE_DIR) + "/examples/eight_body.yaml");
  out.push_back({"eight-body", std::make_shared<const Model>(eight.model), eight.initial});
  for (const int n : {8, 64, 512, 4096}) {
    GeneratedSystem g = chain_model(n);
    out.push_back({"chain-" + std::to_string(n), std::make_shared<const Model>(std::move(g.model)),
                   g.initial});
  }
  for (const int n : {64, 512, 4096}) {
    GeneratedSystem g = random_tree_model(n, 1);
    out.push_back({"tree-" + std::to_string(n), std::make_shared<const Model>(std::move(g.model)),
                   g.initial});
  }
  return out;
}

// Pairs of blocks the tree LDL^T updates: sum over K of u_K (u_K + 1) / 2.
double factor_cost(const Model& model) {
  double cost = 0.0;
  for (int k = 0; k < model.num_bodies(); ++k) cost += 0.5 * model.depth(k) * (model.depth(k) + 1);
  return cost;
}

using Stage = std::function<void(const Model&, const State&, Data&)>;

void run(benchmark::State& bench, const System& system, DataOptions options, const Stage& prepare,
         const Stage& stage) {
  const Model& model = *system.model;
  Data data(model, options);
  prepare(model, system.state, data);
  for (auto _ : bench) {
    stage(model, system.state, data);
    benchmark::DoNotOptimize(data.ydot.data());
    benchmark::ClobberMemory();
  }
  bench.counters["per_body"] =
      benchmark::Counter(model.num_bodies(), benchmark::Counter::kIsIterationInvariantRate |
                                                 benchmark::Counter::kInvert);
}

void nothing(const Model&, const State&, Data&) {}

void kinematics(const Model& model, const State& state, Data& data) {
  compute_kinematics(model, state, data);
}

void loads(const Model& model, const State& state, Data& data) {
  compute_kinematics(model, state, data);
  compute_resultants(model, state, data);
}

void register_all() {
  static const std::vector<System> all = systems();
  const DataOptions recursive = DataOptions::recursive_only();
  const DataOptions kane{.partials = false, .dense_mass_matrix = false};
  const DataOptions with_partials{.dense_mass_matrix = false};
  for (const System& s : all) {
    const auto add = [&](const std::string& stage, DataOptions options, Stage prepare, Stage work) {
      benchmark::RegisterBenchmark(
          (stage + "/" + s.name).c_str(),
          [&s, options, prepare, work](benchmark::State& b) { run(b, s, options, prepare, work); })
          ->Unit(benchmark::kMicrosecond)
          ->ComputeStatistics("min", [](const std::vector<double>& v) {
            return *std::min_element(v.begin(), v.end());
          });
    };
    // The recursive route.
    add("kinematics", recursive, nothing, kinematics);
    add("resultants", recursive, kinematics,
        [](const Model& m, const State& x, Data& d) { compute_resultants(m, x, d); });
    add("recursive_staged", recursive, nothing, [](const Model& m, const State& x, Data& d) {
      detail::staged_forward_dynamics(m, x, d, Route::recursive);
    });
    add("recursive_fused", recursive, nothing, [](const Model& m, const State& x, Data& d) {
      forward_dynamics(m, x, d, Route::recursive);
    });
    // The same at each SIMD width this CPU runs (recursive_fused takes the widest).
    for (const int lanes : {2, 4, 8}) {
      if (Data(*s.model, DataOptions::recursive_only(lanes)).simd_lanes() != lanes) continue;
      add("recursive_fused_lanes" + std::to_string(lanes), DataOptions::recursive_only(lanes),
          nothing, [](const Model& m, const State& x, Data& d) {
            forward_dynamics(m, x, d, Route::recursive);
          });
    }
    // The Kane route, where [A] fits (a chain's [A] is dense: O(N^3) to factor).
    const Model& model = *s.model;
    if (model.chain_entries() > 200000 || factor_cost(model) > 3e7) continue;
    if (model.chain_entries() <= 20000)
      add("partials", with_partials, kinematics,
          [](const Model& m, const State& x, Data& d) { compute_partials_recursive(m, x, d); });
    add("mass_matrix_blocks", kane, kinematics, [](const Model& m, const State&, Data& d) {
      assembled::mass_matrix(m, d.kinematics, workspace(d).assembled);
    });
    add("force_vector", kane, loads, [](const Model& m, const State& x, Data& d) {
      detail::Workspace& w = workspace(d);
      assembled::force_vector(m, x, d.kinematics, d.loads, w.assembled, w.load_sum, d.kane.f);
    });
    add(
        "tree_ldlt_factor", kane,
        [](const Model& m, const State& x, Data& d) {
          compute_kinematics(m, x, d);
          assembled::mass_matrix(m, d.kinematics, workspace(d).assembled);
        },
        [](const Model& m, const State&, Data& d) {
          detail::AssembledScratch& a = workspace(d).assembled;
          a.factor.compute(m, a.A_blocks);
        });
    add(
        "tree_ldlt_solve", kane,
        [](const Model& m, const State& x, Data& d) { kane_equations(m, x, d); },
        [](const Model& m, const State&, Data& d) {
          d.ydot = d.kane.f;
          workspace(d).assembled.factor.solve_in_place(m, d.ydot);
        });
    add("kane", kane, nothing, [](const Model& m, const State& x, Data& d) {
      forward_dynamics(m, x, d, Route::assembled);
    });
    if (model.num_bodies() <= 64)
      add(
          "mass_matrix_dense_oracle", DataOptions{},
          [](const Model& m, const State& x, Data& d) {
            compute_kinematics(m, x, d);
            compute_partials_recursive(m, x, d);
          },
          [](const Model& m, const State&, Data& d) {
            benchmark::DoNotOptimize(oracles::mass_matrix_term_by_term(m, d).data());
          });
  }
}

}  // namespace
}  // namespace kanedyn

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  kanedyn::register_all();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
