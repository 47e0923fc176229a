// `kanedyn bench MODEL [--route recursive|assembled] [--reps R] [--json]`: how long one forward
// dynamics evaluation takes at the model's initial state, the one simulate integrates ({y dot}
// and {x dot} for the free tree, z dot and q dot for a jointed model), in the manner of
// MuJoCo's testspeed. Evaluations are timed in batches long enough for the clock (about 50 us);
// the median and the minimum of the per-batch averages are reported.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "commands.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/io/model_file.hpp"
#include "options.hpp"

namespace kanedyn::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct BenchResult {
  Route route;
  double median_ns = 0.0;  ///< median over batches of ns per evaluation
  double min_ns = 0.0;     ///< minimum over batches
  long reps = 0;           ///< evaluations timed
  long batch = 0;          ///< evaluations per batch
  int lanes = 0;           ///< bodies per SIMD pass of the recursive route's kernel
  std::string kernel;      ///< what runs (Dynamics::kernel)
  std::string evaluates;   ///< what one evaluation computes: "d/dt of " Dynamics::layout
};

double elapsed_ns(Clock::time_point since) {
  return std::chrono::duration<double, std::nano>(Clock::now() - since).count();
}

/// Times `evaluate` (one evaluation per call). reps <= 0: about 2 s worth, at most 100,000.
template <typename Evaluate>
BenchResult time_calls(Route route, long reps, const Evaluate& evaluate) {
  // A first estimate of the time per evaluation, over at least 1 ms.
  long count = 0;
  const auto start = Clock::now();
  do {
    evaluate();
    ++count;
  } while (elapsed_ns(start) < 1e6);
  const double estimate = elapsed_ns(start) / static_cast<double>(count);
  if (reps <= 0) reps = std::clamp(static_cast<long>(2e9 / estimate), 1L, 100000L);
  // Batches of about 50 us; exactly `reps` evaluations, spread evenly over the batches.
  const long target = std::clamp(static_cast<long>(std::ceil(5e4 / estimate)), 1L, reps);
  const long batches = (reps + target - 1) / target;
  std::vector<double> per_eval;
  per_eval.reserve(static_cast<size_t>(batches));
  for (long b = 0; b < batches; ++b) {
    const long size = reps / batches + (b < reps % batches ? 1 : 0);
    const auto t0 = Clock::now();
    for (long i = 0; i < size; ++i) evaluate();
    per_eval.push_back(elapsed_ns(t0) / static_cast<double>(size));
  }
  std::sort(per_eval.begin(), per_eval.end());
  const size_t m = per_eval.size();
  BenchResult r;
  r.route = route;
  r.median_ns = m % 2 ? per_eval[m / 2] : 0.5 * (per_eval[m / 2 - 1] + per_eval[m / 2]);
  r.min_ns = per_eval.front();
  r.reps = reps;
  r.batch = (reps + batches - 1) / batches;
  return r;
}

/// Times the evaluation `simulate` integrates, at the model's initial state: the derivative
/// of Dynamics (the route dispatch simulate runs), and names its kernel.
BenchResult time_route(const io::ModelFile& file, Route route, long reps, int max_lanes) {
  Dynamics dynamics(file.model, route, max_lanes);
  VectorX v(dynamics.size()), rates(dynamics.size());
  dynamics.pack(file.q, file.z, v);
  dynamics.derivative(v, rates);  // warm-up (the assembled route builds its blocks)
  if (!rates.allFinite())
    throw std::runtime_error("the equations of motion are not finite at the initial state");
  BenchResult r = time_calls(route, reps, [&] { dynamics.derivative(v, rates); });
  r.lanes = dynamics.simd_lanes();
  r.kernel = dynamics.kernel();
  r.evaluates = "d/dt of " + dynamics.layout();
  return r;
}

void print_text(const io::ModelFile& file, const std::vector<BenchResult>& results) {
  const int n = file.model.num_bodies();
  std::printf("model: %s", file.path.c_str());
  if (!file.model.name().empty()) std::printf(" (%s)", file.model.name().c_str());
  std::printf(", N = %d\nforward dynamics (%s, as simulate evaluates it) at the initial state\n\n",
              n, results.front().evaluates.c_str());
  std::printf("%-10s %11s %7s %15s %13s %15s %12s\n", "route", "evaluations", "batch",
              "median ns/eval", "min ns/eval", "median ns/body", "min ns/body");
  for (const BenchResult& r : results)
    std::printf("%-10s %11ld %7ld %15.1f %13.1f %15.2f %12.2f\n", to_string(r.route).c_str(),
                r.reps, r.batch, r.median_ns, r.min_ns, r.median_ns / n, r.min_ns / n);
  std::printf("\n");
  for (const BenchResult& r : results)
    std::printf("%s: %s%s\n", to_string(r.route).c_str(), r.kernel.c_str(),
                r.lanes == 8   ? " (AVX-512F)"
                : r.lanes == 4 ? " (AVX)"
                : r.lanes > 0  ? " (SSE2 or generic)"
                               : "");
}

void print_json(const io::ModelFile& file, const std::vector<BenchResult>& results) {
  using Json = nlohmann::ordered_json;
  Json out;
  out["model"] = file.path;
  out["N"] = file.model.num_bodies();
  out["evaluates"] = results.front().evaluates;
  out["results"] = Json::array();
  for (const BenchResult& r : results)
    out["results"].push_back({{"route", to_string(r.route)},
                              {"kernel", r.kernel},
                              {"ns_per_eval_median", r.median_ns},
                              {"ns_per_eval_min", r.min_ns},
                              {"reps", r.reps}});
  std::printf("%s\n", out.dump().c_str());
}

void add_bench(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "bench", "Time forward-dynamics evaluations at the model's initial state (ns per eval)");
  struct Options {
    std::string path;
    std::vector<std::string> routes, methods;  ///< --route, and --method, its older name
    long reps = 0;
    int simd_lanes = 8;
    bool json = false;
  };
  auto opt = std::make_shared<Options>();
  add_input_file(cmd, "MODEL", opt->path, kModelHelp)->required();
  cmd->add_option("--route", opt->routes, "recursive | assembled (repeatable; default: both)")
      ->check(route_names());
  cmd->add_option("--method", opt->methods)->check(route_names())->group("");
  cmd->add_option("--reps", opt->reps,
                  "evaluations to time per route (default: about 2 s worth, at most 100000)")
      ->check(CLI::PositiveNumber);
  cmd->add_option(
         "--simd-lanes", opt->simd_lanes,
         "widest SIMD kernel of the recursive route: 2, 4 or 8 bodies per pass (default: "
         "8; the widest this CPU runs up to this is used; every width gives the same bits)")
      ->check(CLI::IsMember({2, 4, 8}));
  cmd->add_flag("--json", opt->json,
                "print {\"model\", \"N\", \"results\": [{\"route\", \"ns_per_eval_median\", "
                "\"ns_per_eval_min\", \"reps\"}]}");
  cmd->callback([opt] {
    const io::ModelFile file = io::load_model_file(opt->path);
    std::vector<Route> routes;
    std::vector<std::string> names = opt->routes;
    names.insert(names.end(), opt->methods.begin(), opt->methods.end());
    for (const std::string& m : names) {
      const Route route = parse_route(m);
      if (std::find(routes.begin(), routes.end(), route) == routes.end()) routes.push_back(route);
    }
    // The assembled route needs the flat chains (simulate's rule, validate_settings); a
    // jointed model's also builds its blocks on its first evaluation, and says when they
    // would be too many.
    const bool assembled_fits = file.model.has_flat_chains();
    if (routes.empty()) {
      // By default both routes; the assembled route only where it can be built.
      routes = {Route::recursive};
      if (assembled_fits)
        routes.push_back(Route::assembled);
      else
        std::fprintf(stderr,
                     "kanedyn: note: %s: the assembled route is not built for %lld chain "
                     "entries (more than %lld); timing the recursive route alone\n",
                     opt->path.c_str(), file.model.chain_entries(), Model::kMaxFlatChainEntries);
    } else if (!assembled_fits &&
               std::find(routes.begin(), routes.end(), Route::assembled) != routes.end()) {
      throw std::runtime_error(
          opt->path + ": the model's " + std::to_string(file.model.num_bodies()) + " bodies have " +
          std::to_string(file.model.chain_entries()) + " chain entries, more than the " +
          std::to_string(Model::kMaxFlatChainEntries) +
          " for which the assembled route is built; use --route recursive");
    }
    std::vector<BenchResult> results;
    const bool asked = !opt->routes.empty();
    for (const Route route : routes) {
      try {
        results.push_back(time_route(file, route, opt->reps, opt->simd_lanes));
      } catch (const ModelError& e) {
        if (asked || route != Route::assembled)
          throw std::runtime_error(opt->path + ": " + e.what());
        std::fprintf(stderr, "kanedyn: note: %s: %s; timing the recursive route alone\n",
                     opt->path.c_str(), e.what());
      }
    }
    if (opt->json)
      print_json(file, results);
    else
      print_text(file, results);
  });
}

}  // namespace
KANEDYN_COMMAND(40, add_bench);
}  // namespace kanedyn::cli
