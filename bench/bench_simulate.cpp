// How much of `kanedyn simulate`'s time goes outside {y dot} (docs/performance.md, "simulate:
// time outside ydot"). The main benchmark, simulate_share, times in every iteration
//   (a) the eight-body example simulated as the command does it (defaults: dopri5, rtol 1e-8,
//       atol 1e-10, 10 s, a row every 0.01 s): BackgroundTrajectoryWriter to a real file (its
//       thread computes the energy of every row), the per-step callback reading the clock as the
//       progress bar does, rename;
//   (b) as many forward_dynamics calls as (a) made, cycling over the run's 1001 output states;
// and reports the share outside {y dot}, 1 - (b)/(a), from the minima and from the medians of
// both over the iterations (the two are interleaved, so a slow spell of a shared machine hits
// both), and from the medians of the thread's CPU time. The other benchmarks split (a) up:
// the integrator alone (no output), one CSV row, and one number written by std::to_chars;
// simulate_share_inline_writer is simulate_share with the rows written on the integrating
// thread (io::TrajectoryWriter), as the command did before it had a writer thread. Run e.g.
//   build/bench/kanedyn_bench_simulate --benchmark_filter=simulate_share
#include <benchmark/benchmark.h>
#include <time.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/io/csv.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/simulate.hpp"

namespace kanedyn {
namespace {

using Clock = std::chrono::steady_clock;
double seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

/// CPU time of the calling thread (user and system), s: unlike the wall time it does not grow
/// while another process has the core.
double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

const io::ModelFile& eight_body() {
  static const io::ModelFile file =
      io::load_model_file(std::string(KANEDYN_SOURCE_DIR) + "/examples/eight_body.yaml");
  return file;
}

std::string csv_path() {
  return (std::filesystem::temp_directory_path() / "kanedyn_bench_simulate.csv").string();
}

volatile std::sig_atomic_t g_stop = 0;  // as the command's signal flag

/// (a): the run of apps/cmd_simulate.cpp without its model loading and printing. Keep in step
/// with that file: writer, observer, on_step (Progress::update reads the clock every step).
template <class Writer>
SimulationStats simulate_like_the_command(const io::ModelFile& file, const std::string& path) {
  const Model& model = file.model;
  Writer writer(model, path);
  SimulationSettings settings;  // the command's defaults
  const Clock::time_point start = Clock::now();
  Clock::time_point last_tick = start;
  settings.on_step = [&](double) {
    const Clock::time_point now = Clock::now();
    if (seconds(now - last_tick) >= 1.0) {
      last_tick = now;
      writer.flush();
    }
    return g_stop == 0;
  };
  Observer observer;
  if constexpr (std::is_same_v<Writer, io::BackgroundTrajectoryWriter>) {
    settings.observer_kinematics = false;  // the writer's thread computes them
    observer = [&](double t, const State& state, const VectorX&, const VectorX&, Data&) {
      writer.write_row(t, state);
    };
  } else {
    observer = [&](double t, const State& state, const VectorX&, const VectorX&, Data& data) {
      writer.write_row(t, state, data, total_energy_of_kinematics(model, state, data));
    };
  }
  const SimulationStats stats = simulate(model, file.initial, settings, observer);
  writer.finish();
  return stats;
}

/// The output states of the default run: representative states for (b).
std::vector<State> trajectory_states(const io::ModelFile& file) {
  std::vector<State> states;
  simulate(file.model, file.initial, SimulationSettings{},
           [&](double, const State& state, const VectorX&, const VectorX&, Data&) {
             states.push_back(state);
           });
  return states;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? 0.0 : n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// Writer: io::BackgroundTrajectoryWriter (what the command does) or io::TrajectoryWriter
/// (the rows written on the integrating thread, as the command did before).
template <class Writer>
void simulate_share(benchmark::State& st) {
  const io::ModelFile& file = eight_body();
  const Model& model = file.model;
  const std::vector<State> states = trajectory_states(file);
  Data data(model, DataOptions::recursive_only());  // what simulate() allocates for this route
  const std::string path = csv_path();
  std::vector<double> a_times, b_times, a_cpu, b_cpu;
  SimulationStats stats;
  for (auto _ : st) {
    const double c0 = thread_cpu_seconds();
    const Clock::time_point t0 = Clock::now();
    stats = simulate_like_the_command<Writer>(file, path);
    const Clock::time_point t1 = Clock::now();
    const double c1 = thread_cpu_seconds();
    for (long i = 0; i < stats.evaluations; ++i) {
      forward_dynamics(model, states[static_cast<size_t>(i) % states.size()], data);
      benchmark::DoNotOptimize(data.ydot.data());
    }
    benchmark::ClobberMemory();
    const Clock::time_point t2 = Clock::now();
    const double c2 = thread_cpu_seconds();
    a_times.push_back(seconds(t1 - t0));
    b_times.push_back(seconds(t2 - t1));
    a_cpu.push_back(c1 - c0);
    b_cpu.push_back(c2 - c1);
  }
  std::filesystem::remove(path);
  if (!stats.ok()) st.SkipWithError(stats.message.c_str());
  const double a_min = *std::min_element(a_times.begin(), a_times.end());
  const double b_min = *std::min_element(b_times.begin(), b_times.end());
  const double a_med = median(a_times), b_med = median(b_times);
  st.counters["steps"] = static_cast<double>(stats.steps_accepted);
  st.counters["evals"] = static_cast<double>(stats.evaluations);
  st.counters["rows"] = static_cast<double>(stats.outputs);
  st.counters["a_ms_min"] = 1e3 * a_min;
  st.counters["a_ms_med"] = 1e3 * a_med;
  st.counters["b_ms_min"] = 1e3 * b_min;
  st.counters["b_ms_med"] = 1e3 * b_med;
  st.counters["ns_per_eval_min"] = 1e9 * b_min / static_cast<double>(stats.evaluations);
  st.counters["steps_per_s_min"] = static_cast<double>(stats.steps_accepted) / a_min;
  st.counters["share_outside_min"] = 1.0 - b_min / a_min;
  st.counters["share_outside_med"] = 1.0 - b_med / a_med;
  st.counters["share_outside_cpu_med"] = 1.0 - median(b_cpu) / median(a_cpu);
}
BENCHMARK(simulate_share<io::BackgroundTrajectoryWriter>)
    ->Name("simulate_share")
    ->Unit(benchmark::kMillisecond)
    ->MinTime(3.0);
BENCHMARK(simulate_share<io::TrajectoryWriter>)
    ->Name("simulate_share_inline_writer")
    ->Unit(benchmark::kMillisecond)
    ->MinTime(3.0);

/// The integrator and simulate()'s loop with no observer: (b) plus the per-step overhead.
void simulate_no_output(benchmark::State& st) {
  const io::ModelFile& file = eight_body();
  SimulationStats stats;
  for (auto _ : st) stats = simulate(file.model, file.initial, SimulationSettings{});
  st.counters["evals"] = static_cast<double>(stats.evaluations);
}
BENCHMARK(simulate_no_output)->Unit(benchmark::kMillisecond);

/// A controller's cost (docs/performance.md, "Controllers"): the URDF arm simulated for 1 s by
/// rk4 (step 1 ms, no observer) with every input 0, and with a PD law on every joint input
/// called at every evaluation (the same number of evaluations). The ratio of the two is the
/// controller's overhead: the copy of the state handed to it, the call and the inputs set.
void simulate_arm(benchmark::State& st, bool controlled) {
  static const io::ModelFile file =
      io::load_model_file(std::string(KANEDYN_SOURCE_DIR) + "/examples/urdf/arm.urdf");
  const Model& m = file.model;
  std::vector<Eigen::Index> coordinate, speed;
  for (const Input& in : m.inputs()) {
    coordinate.push_back(m.coordinate_offset(in.body));
    speed.push_back(m.speed_offset(in.body) + in.speed);
  }
  SimulationSettings s;
  s.t_end = 1.0;
  s.dt_out = 1.0;
  s.integrator = Integrator::rk4;
  s.step = 1e-3;
  if (controlled)
    s.controller = [&](double, const VectorX& q, const VectorX& z, Eigen::Ref<VectorX> u) {
      for (size_t i = 0; i < speed.size(); ++i)
        u[static_cast<Eigen::Index>(i)] = -4.0 * (q[coordinate[i]] - 0.3) - 0.1 * z[speed[i]];
    };
  SimulationStats stats;
  for (auto _ : st) stats = simulate(m, file.q, file.z, s);
  if (!stats.ok()) st.SkipWithError(stats.message.c_str());
  st.counters["evals"] = static_cast<double>(stats.evaluations);
}
BENCHMARK_CAPTURE(simulate_arm, inputs_zero, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(simulate_arm, pd_every_evaluation, true)->Unit(benchmark::kMillisecond);

/// One output row as the command writes it: energy from the kinematics and the CSV row
/// (written to the file when 64 KiB have gathered).
void csv_row(benchmark::State& st) {
  const io::ModelFile& file = eight_body();
  const Model& model = file.model;
  const std::vector<State> states = trajectory_states(file);
  Data data(model, DataOptions::recursive_only());
  const std::string path = csv_path();
  {
    io::TrajectoryWriter writer(model, path);
    size_t i = 0;
    for (auto _ : st) {
      const State& state = states[i++ % states.size()];
      st.PauseTiming();
      compute_kinematics(model, state, data);  // done by simulate() before the observer
      st.ResumeTiming();
      writer.write_row(0.01 * static_cast<double>(i), state, data,
                       total_energy_of_kinematics(model, state, data));
    }
  }
  std::filesystem::remove(path + ".partial");
}
BENCHMARK(csv_row)->Unit(benchmark::kMicrosecond);

/// Numbers like those of the trajectory: |x| from 1e-6 to 1e3, both signs.
std::vector<double> sample_numbers() {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-20, 10);
  std::vector<double> v(4096);
  for (double& x : v) {
    const double m = mantissa(rng);  // before the exponent: argument order is unspecified
    x = std::ldexp(m, exponent(rng));
  }
  return v;
}

void number_to_chars(benchmark::State& st) {
  const std::vector<double> v = sample_numbers();
  char buf[64];
  size_t i = 0;
  for (auto _ : st) {
    benchmark::DoNotOptimize(std::to_chars(buf, buf + sizeof buf, v[i++ % v.size()]).ptr);
    benchmark::ClobberMemory();
  }
}
BENCHMARK(number_to_chars);

}  // namespace
}  // namespace kanedyn

BENCHMARK_MAIN();
