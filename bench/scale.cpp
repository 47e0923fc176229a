// Scale: chains (or, with --trees, random trees) of N = 64 .. 100,000 bodies built in
// C++ (generate.hpp); forward dynamics by the O(N) route timed at the initial state, and a few
// RK4 steps (a plain loop here, independent of integrate.hpp). Prints N, ns per body (median and
// minimum over batches), the workspace's bytes per body, the process's peak RSS, and the RK4 step
// time per body. Then one chain goes through a model file, YAML and JSON, and back
// (io::load_model_file), each loaded in a child process of its own so that its peak RSS is
// the loading's alone.
//   build/bench/kanedyn_scale [--quick] [--trees] [--file-bodies N] [--simd-lanes 2|4|8]
//   (--trees also times each tree given already numbered depth first, and the map between the
//   two numberings alone: what a large tree's renumbering costs, see depth_first below)
//   build/bench/kanedyn_scale --files-only [--keep-files] [--file-bodies N]
//   (--files-only: the model files only; --keep-files: leave them in /tmp)
//   (default N = 100,000; lanes: the widest this CPU runs)
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/testing/generate.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using namespace kanedyn;

Eigen::Index at(size_t i) { return static_cast<Eigen::Index>(i); }

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

double peak_rss_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

// This process image's peak RSS (VmHWM): unlike ru_maxrss, it starts afresh at exec, so that a
// child's number is its own and not its parent's.
double peak_rss_since_exec_mb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::atof(line.c_str() + 6) / 1024.0;  // kB
  return peak_rss_mb();
}

// Median and minimum ns per evaluation over batches of about 2 ms (at least one evaluation).
std::pair<double, double> time_evaluations(const Model& model, const State& state, Data& data) {
  forward_dynamics(model, state, data, Route::recursive);
  auto t0 = Clock::now();
  forward_dynamics(model, state, data, Route::recursive);
  const double once = seconds_since(t0);
  const int batch = std::max(1, static_cast<int>(2e-3 / once));
  const int batches = std::clamp(static_cast<int>(1.0 / (once * batch)), 15, 200);
  std::vector<double> ns;
  for (int b = 0; b < batches; ++b) {
    t0 = Clock::now();
    for (int i = 0; i < batch; ++i) forward_dynamics(model, state, data, Route::recursive);
    ns.push_back(seconds_since(t0) * 1e9 / batch);
  }
  std::sort(ns.begin(), ns.end());
  return {ns[ns.size() / 2], ns.front()};
}

// Classical RK4 on z = (x, y), Euler parameters left as integrated. Returns seconds per step.
double rk4_steps(const Model& model, const State& initial, Data& data, int steps, double h,
                 State& state) {
  state = initial;
  State stage = initial;
  VectorX kx[4], ky[4];
  for (int i = 0; i < 4; ++i) {
    kx[i] = VectorX::Zero(initial.x.size());
    ky[i] = VectorX::Zero(initial.y.size());
  }
  const double c[4] = {0.0, 0.5, 0.5, 1.0};
  const auto t0 = Clock::now();
  for (int step = 0; step < steps; ++step) {
    for (int i = 0; i < 4; ++i) {
      if (i == 0) {
        stage.x = state.x;
        stage.y = state.y;
      } else {
        stage.x = state.x + (c[i] * h) * kx[i - 1];
        stage.y = state.y + (c[i] * h) * ky[i - 1];
      }
      forward_dynamics(model, stage, data, Route::recursive);
      kx[i] = data.xdot;
      ky[i] = data.ydot;
    }
    state.x += (h / 6.0) * (kx[0] + 2.0 * kx[1] + 2.0 * kx[2] + kx[3]);
    state.y += (h / 6.0) * (ky[0] + 2.0 * ky[1] + 2.0 * ky[2] + ky[3]);
  }
  return seconds_since(t0) / steps;
}

// The model file of a generated chain (docs/model-format.md), with its initial state.
void write_model_file(const GeneratedSystem& g, const std::string& path) {
  using Json = nlohmann::ordered_json;
  const Model& m = g.model;
  const auto vec = [](const auto& v) {
    Json a = Json::array();
    for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(v[i]);
    return a;
  };
  Json file;
  file["format"] = "kanedyn-model/1";
  file["name"] = m.name();
  file["gravity"] = vec(m.gravity());
  Json bodies = Json::array();
  for (int k = 0; k < m.num_bodies(); ++k) {
    const BodySpec& b = m.body(k);
    const Matrix3& I = b.inertia;
    bodies.push_back({{"name", b.name},
                      {"parent", b.lower_body == kGround ? "ground" : m.body(b.lower_body).name},
                      {"mass", b.mass},
                      {"inertia", {I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2)}},
                      {"com", vec(b.com)},
                      {"joint", vec(b.joint)},
                      {"initial",
                       {{"euler_parameters", vec(g.initial.euler_parameters(k))},
                        {"translation", vec(g.initial.translation(k))},
                        {"angular_velocity", vec(g.initial.angular_velocity(k))},
                        {"translation_rate", vec(g.initial.translation_rate(k))}}}});
  }
  file["bodies"] = bodies;
  Json forces = Json::array();
  for (const auto& element : m.forces()) {
    const auto* b = dynamic_cast<const Bushing*>(element.get());
    if (!b) throw std::runtime_error("write_model_file: only bushings are written");
    forces.push_back({{"type", "bushing"},
                      {"body", m.body(b->body()).name},
                      {"stiffness", vec(b->stiffness)},
                      {"damping", vec(b->damping)},
                      {"rotational_stiffness", b->rotational_stiffness},
                      {"rotational_damping", b->rotational_damping}});
  }
  file["forces"] = forces;
  std::ofstream(path) << file.dump() << "\n";
}

// The same file in YAML block style (docs/model-format.md), numbers written shortest
// round-trip, so that both files give the same doubles.
void write_yaml_model_file(const GeneratedSystem& g, const std::string& path) {
  const Model& m = g.model;
  std::string out;
  const auto num = [&](double v) {
    char buffer[32];
    const auto [end, error] = std::to_chars(buffer, buffer + sizeof buffer, v);
    if (error != std::errc()) throw std::runtime_error("write_yaml_model_file: to_chars");
    out.append(buffer, end);
  };
  const auto vec = [&](const auto& v) {
    out += '[';
    for (Eigen::Index i = 0; i < v.size(); ++i) {
      if (i > 0) out += ", ";
      num(v[i]);
    }
    out += "]\n";
  };
  out += "format: kanedyn-model/1\nname: " + m.name() + "\ngravity: ";
  vec(m.gravity());
  out += "bodies:\n";
  for (int k = 0; k < m.num_bodies(); ++k) {
    const BodySpec& b = m.body(k);
    const Matrix3& I = b.inertia;
    out += "  - name: " + b.name + "\n    parent: " +
           (b.lower_body == kGround ? std::string("ground") : m.body(b.lower_body).name) +
           "\n    mass: ";
    num(b.mass);
    out += "\n    inertia: ";
    vec(Vector6(I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2)));
    out += "    com: ";
    vec(b.com);
    out += "    joint: ";
    vec(b.joint);
    out += "    initial:\n      euler_parameters: ";
    vec(g.initial.euler_parameters(k));
    out += "      translation: ";
    vec(g.initial.translation(k));
    out += "      angular_velocity: ";
    vec(g.initial.angular_velocity(k));
    out += "      translation_rate: ";
    vec(g.initial.translation_rate(k));
  }
  out += "forces:\n";
  for (const auto& element : m.forces()) {
    const auto* b = dynamic_cast<const Bushing*>(element.get());
    if (!b) throw std::runtime_error("write_yaml_model_file: only bushings are written");
    out += "  - type: bushing\n    body: " + m.body(b->body()).name + "\n    stiffness: ";
    vec(b->stiffness);
    out += "    damping: ";
    vec(b->damping);
    out += "    rotational_stiffness: ";
    num(b->rotational_stiffness);
    out += "\n    rotational_damping: ";
    num(b->rotational_damping);
    out += '\n';
  }
  std::ofstream(path) << out;
}

// In a child process (--load-file PATH N): loads the file, then checks its accelerations
// against the generated chain's. Returns the exit status.
int load_file(const std::string& path, int n) {
  const auto t0 = Clock::now();
  const io::ModelFile file = io::load_model_file(path);
  const double load_s = seconds_since(t0);
  const double load_rss = peak_rss_since_exec_mb();
  rusage usage{};  // CPU time too: the wall time depends on what else the machine runs
  getrusage(RUSAGE_SELF, &usage);
  const auto cpu = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + 1e-6 * t.tv_usec;
  };
  const double cpu_s = cpu(usage.ru_utime) + cpu(usage.ru_stime);
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  const double file_mb = static_cast<double>(in.tellg()) / 1e6;
  const GeneratedSystem g = chain_model(n);
  Data data(file.model, DataOptions::recursive_only());
  forward_dynamics(file.model, file.initial, data, Route::recursive);
  Data reference(g.model, DataOptions::recursive_only());
  forward_dynamics(g.model, g.initial, reference, Route::recursive);
  const double difference = (data.ydot - reference.ydot).norm() / reference.ydot.norm();
  std::printf(
      "model file %s (%.1f MB): N = %d loaded in %.2f s (CPU %.2f s), peak RSS %.1f MB; ydot "
      "equals the generated chain's to %.1e relative\n",
      path.c_str(), file_mb, file.model.num_bodies(), load_s, cpu_s, load_rss, difference);
  return difference < 1e-12 ? 0 : 1;
}

// A random tree's time split in two (--trees): the same tree given already numbered depth first
// (each body's subtree right after it), which the O(N) route then runs without renumbering, and
// the map between the two numberings alone: the state's 13 doubles per body gathered through the
// permutation and the derivatives' 13 scattered back, as the route does for a large model
// numbered otherwise (src/recursive/fused.cpp). The map touches each body's data in an order
// unrelated to where it lies, so past the caches it is bound by memory latency.
struct DepthFirst {
  GeneratedSystem system;
  std::vector<int> order;  // depth-first body k is the tree's body order[k]
};

// The state into depth-first order: to[body k] = from[body order[k]] (x: 4N Euler parameters,
// then 3N translations; y: 3N angular velocities, then 3N translation rates).
void gather_state(const std::vector<int>& order, const State& from, State& to) {
  const size_t n = order.size();
  for (size_t k = 0; k < n; ++k) {
    const auto u = static_cast<size_t>(order[k]);
    for (size_t c = 0; c < 4; ++c) to.x[at(4 * k + c)] = from.x[at(4 * u + c)];
    for (size_t c = 0; c < 3; ++c) {
      to.x[at(4 * n + 3 * k + c)] = from.x[at(4 * n + 3 * u + c)];
      to.y[at(3 * k + c)] = from.y[at(3 * u + c)];
      to.y[at(3 * n + 3 * k + c)] = from.y[at(3 * n + 3 * u + c)];
    }
  }
}

// The derivatives back, to[body order[k]] = from[body k], but Eq. (40)'s s' dot (= y2, which the
// caller copies in order): ydot, and the Euler parameter rates of xdot.
void scatter_derivatives(const std::vector<int>& order, const VectorX& from_xdot,
                         const VectorX& from_ydot, VectorX& xdot, VectorX& ydot) {
  const size_t n = order.size();
  for (size_t k = 0; k < n; ++k) {
    const auto u = static_cast<size_t>(order[k]);
    for (size_t c = 0; c < 4; ++c) xdot[at(4 * u + c)] = from_xdot[at(4 * k + c)];
    for (size_t c = 0; c < 3; ++c) {
      ydot[at(3 * u + c)] = from_ydot[at(3 * k + c)];
      ydot[at(3 * n + 3 * u + c)] = from_ydot[at(3 * n + 3 * k + c)];
    }
  }
}

DepthFirst depth_first(const GeneratedSystem& tree) {
  const Model& m = tree.model;
  const int n = m.num_bodies();
  std::vector<int> order, stack, rank(static_cast<size_t>(n));
  for (int k = n; k-- > 0;)
    if (m.body(k).lower_body == kGround) stack.push_back(k);
  while (!stack.empty()) {
    const int k = stack.back();
    stack.pop_back();
    order.push_back(k);
    const std::vector<int>& children = m.children(k);
    stack.insert(stack.end(), children.rbegin(), children.rend());
  }
  for (int k = 0; k < n; ++k) rank[static_cast<size_t>(order[static_cast<size_t>(k)])] = k;
  const auto renumbered = [&](int k) {
    return k == kGround ? kGround : rank[static_cast<size_t>(k)];
  };
  std::vector<BodySpec> bodies;
  for (const int u : order) {
    BodySpec b = m.body(u);
    b.lower_body = renumbered(b.lower_body);
    bodies.push_back(std::move(b));
  }
  std::vector<std::shared_ptr<const ForceElement>> forces;
  for (const auto& element : m.forces()) {
    const auto* b = dynamic_cast<const Bushing*>(element.get());
    if (b == nullptr)
      throw std::runtime_error("depth_first: the generated trees hold bushings only");
    forces.push_back(std::make_shared<Bushing>(renumbered(b->body()), b->stiffness, b->damping,
                                               b->rotational_stiffness, b->rotational_damping));
  }
  Model model(std::move(bodies), m.gravity(), std::move(forces), m.name() + "-depth-first");
  State state = tree.initial;
  gather_state(order, tree.initial, state);
  return {{std::move(model), std::move(state)}, std::move(order)};
}

// Minimum ns per call of the map alone (the state into depth-first order, the derivatives back),
// over batches of about 2 ms.
double time_map(const std::vector<int>& order, const State& state) {
  const size_t n = order.size();
  State to = state;
  VectorX xdot(state.x.size()), ydot(state.y.size());
  const VectorX from_xdot = VectorX::Constant(state.x.size(), 1.0), from_ydot = state.y;
  const auto map = [&] {
    gather_state(order, state, to);
    scatter_derivatives(order, from_xdot, from_ydot, xdot, ydot);
    xdot.tail(at(3 * n)) = state.y.tail(at(3 * n));  // Eq. (40)
  };
  map();
  auto t0 = Clock::now();
  map();
  const int batch = std::max(1, static_cast<int>(2e-3 / seconds_since(t0)));
  double best = 1e300;
  for (int b = 0; b < 50; ++b) {
    t0 = Clock::now();
    for (int i = 0; i < batch; ++i) map();
    best = std::min(best, seconds_since(t0) * 1e9 / batch);
  }
  // Use the results, so that the copies are not optimized away.
  if (!to.x.allFinite() || !to.y.allFinite() || !xdot.allFinite() || !ydot.allFinite())
    throw std::runtime_error("time_map: non-finite copies");
  return best;
}

// Runs this program again with --load-file PATH N.
int load_in_child(const char* self, const std::string& path, int n) {
  std::string flag = "--load-file", count = std::to_string(n), file = path;
  char* args[] = {const_cast<char*>(self), flag.data(), file.data(), count.data(), nullptr};
  pid_t pid = 0;
  if (posix_spawn(&pid, "/proc/self/exe", nullptr, nullptr, args, environ) != 0) return 1;
  int status = 0;
  if (waitpid(pid, &status, 0) != pid) return 1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 1;
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false, trees = false, files_only = false, keep_files = false;
  int lanes = 8;
  int file_n = 100000;
  if (argc == 4 && std::strcmp(argv[1], "--load-file") == 0)
    return load_file(argv[2], std::atoi(argv[3]));
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else if (std::strcmp(argv[i], "--trees") == 0) {
      trees = true;
    } else if (std::strcmp(argv[i], "--files-only") == 0) {
      files_only = true;
    } else if (std::strcmp(argv[i], "--keep-files") == 0) {
      keep_files = true;
    } else if (std::strcmp(argv[i], "--file-bodies") == 0 && i + 1 < argc) {
      file_n = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--simd-lanes") == 0 && i + 1 < argc) {
      lanes = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr,
                   "usage: %s [--quick] [--trees] [--files-only] [--keep-files] [--file-bodies N] "
                   "[--simd-lanes 2|4|8]\n",
                   argv[0]);
      return 2;
    }
  }
  std::vector<int> sizes = {64, 256, 1024, 4096, 16384, 65536, 100000};
  if (quick) sizes = {64, 1024, 16384};
  if (files_only) sizes.clear();
  std::printf(
      "%s, O(N) route (forward_dynamics, Route::recursive, DataOptions::recursive_only()), "
      "%d bodies per SIMD pass\n\n",
      trees ? "random trees (seed 1)" : "chains",
      Data(chain_model(8).model, DataOptions::recursive_only(lanes)).simd_lanes());
  std::printf("%8s %10s %12s %12s %14s %13s %14s %s", "N", "build ms", "median ns/b", "min ns/b",
              "Data bytes/b", "peak RSS MB", "RK4 ns/step/b", "RK4 check");
  if (trees) std::printf("   depth-first: min ns/b   map alone: min ns/b");
  std::printf("\n");
  for (const int n : sizes) {
    auto t0 = Clock::now();
    const GeneratedSystem g = trees ? random_tree_model(n, 1) : chain_model(n);
    const double build_ms = seconds_since(t0) * 1e3;
    Data data(g.model, DataOptions::recursive_only(lanes));
    const auto [median, min] = time_evaluations(g.model, g.initial, data);
    State end;
    double step = 1e300;  // the fastest of 3 runs of 5 steps
    for (int run = 0; run < 3; ++run)
      step = std::min(step, rk4_steps(g.model, g.initial, data, 5, 1e-4, end));
    // The bodies hang on stiff bushings: after 5 steps of 0.1 ms nothing may blow up, and the
    // state must have moved.
    const bool finite = end.x.allFinite() && end.y.allFinite();
    const bool moved = (end.y - g.initial.y).norm() > 0.0;
    bool same = true;  // --trees: the depth-first tree's derivatives are the random numbering's
    std::printf("%8d %10.1f %12.1f %12.1f %14.0f %13.1f %14.1f %s", n, build_ms, median / n,
                min / n, static_cast<double>(data.memory_bytes()) / n, peak_rss_mb(),
                step * 1e9 / n, finite && moved ? "finite, moved" : "FAILED");
    if (trees) {
      const DepthFirst d = depth_first(g);
      Data depth_first_data(d.system.model, DataOptions::recursive_only(lanes));
      const double depth_first_min =
          time_evaluations(d.system.model, d.system.initial, depth_first_data).second;
      std::printf(" %24.1f %19.1f", depth_first_min / n, time_map(d.order, g.initial) / n);
      // The timing means something only if it is the same tree: the same ydot and Euler
      // parameter rates, body by body (renumbering changes no bit, tests/test_recursive_plan.cpp).
      forward_dynamics(g.model, g.initial, data, Route::recursive);
      VectorX xdot = data.xdot, ydot = data.ydot;
      scatter_derivatives(d.order, depth_first_data.xdot, depth_first_data.ydot, xdot, ydot);
      same = ydot == data.ydot && xdot == data.xdot;
    }
    std::printf(same ? "\n" : "  FAILED: the depth-first tree's derivatives differ\n");
    if (!same) return 1;
  }

  // Loading: the same chain through a model file, YAML and JSON.
  std::printf("\n");
  const GeneratedSystem g = chain_model(file_n);
  int failed = 0;
  for (const char* ext : {".yaml", ".json"}) {
    const std::string path = "/tmp/kanedyn_scale_chain_" + std::to_string(file_n) + ext;
    if (ext[1] == 'y') {
      write_yaml_model_file(g, path);
    } else {
      write_model_file(g, path);
    }
    std::fflush(stdout);
    failed |= load_in_child(argv[0], path, file_n);
    if (!keep_files) std::remove(path.c_str());
  }
  return failed;
}
