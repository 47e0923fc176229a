// Google Benchmark entries of Dynamics::evaluate() on jointed models: chains of revolute links (the
// generated chain's links, gravity and bushings, every joint revolute about the link's x axis)
// by the articulated-body route (joints_recursive) and the block-sparse projected route
// (joints_assembled, O(N d^2): only the shorter chains), and the jointed human figure of
// examples/human_jointed.yaml (a free torso, revolute, universal and spherical joints) by both.
// With constraints: the Whipple bicycle of examples/bicycle.yaml by both routes against its four
// bodies without the contacts (joints_*/bicycle-tree), and the 512-link chain closed to the
// ground at its tip (joints_recursive/chain-512-closed) against the open one.
// The counter `per_body` is the time per evaluation divided by N: flat in N for the recursive
// route. Run e.g.
//   build/bench/kanedyn_bench_joints --benchmark_repetitions=3
// and read `per_body` (the "_min" aggregate is the least disturbed on a shared machine).
//
// The terms (terms.hpp) beside the forward dynamics of the same model and state, to be read as
// ratios of one run: terms/forward, terms/inverse_dynamics, terms/mass_matrix and
// terms/frame_jacobian (frame_jacobian of the model's first frame from kinematics computed
// beforehand; terms/frame_jacobian_with_kinematics computes them each time: joint_state and
// compute_kinematics) on the six-joint arm of examples/urdf/arm.urdf and the 512-link revolute
// chain. Filter them with --benchmark_filter=terms. terms/derivatives gives all three blocks of
// d(z dot) (Derivatives::forward) and terms/linearize A, B and the eigenvalues.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "kanedyn/analysis.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/frames.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/terms.hpp"
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

// The arm's initial q, with speeds drawn from a fixed seed so that the velocity terms count.
JointedChain arm() {
  io::ModelFile f = io::load_model_file(KANEDYN_SOURCE_DIR "/examples/urdf/arm.urdf");
  JointedChain c;
  c.model = std::make_unique<Model>(std::move(f.model));
  c.q = f.q;
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> rate(-1.0, 1.0);
  c.z = VectorX::NullaryExpr(c.model->num_speeds(), [&] { return rate(rng); });
  return c;
}

// The Whipple bicycle of examples/bicycle.yaml at its initial state (rolling at 5 m/s), and the
// same four bodies without the contacts (the unconstrained tree the constraints cost is
// measured against).
JointedChain bicycle(bool contacts) {
  io::ModelFile f = io::load_model_file(KANEDYN_SOURCE_DIR "/examples/bicycle.yaml");
  JointedChain c;
  const Model& m = f.model;
  std::vector<Joint> joints;
  for (int k = 0; k < m.num_bodies(); ++k) joints.push_back(m.joint(k));
  c.model = contacts ? std::make_unique<Model>(std::move(f.model))
                     : std::make_unique<Model>(m.bodies(), m.gravity(), m.forces(), m.name(),
                                               joints, m.frames(), m.inputs());
  c.q = f.q;
  c.z = f.z;
  return c;
}

// The revolute chain with its tip held at its initial place by a ball to the ground (3 rows,
// 2 independent: the chain is planar).
JointedChain closed_chain(int n) {
  JointedChain open = revolute_chain(n);
  const Model& m = *open.model;
  State state(m);
  Data data(m, DataOptions::recursive_only());
  joint_state(m, open.q, open.z, state);
  compute_kinematics(m, state, data);
  Constraint tip;
  tip.name = "tip";
  tip.type = ConstraintType::ball;
  tip.body = n - 1;
  tip.other = kGround;
  tip.other_at = data.kinematics.p_O[static_cast<size_t>(n - 1)];
  std::vector<Joint> joints;
  for (int k = 0; k < n; ++k) joints.push_back(m.joint(k));
  JointedChain c;
  c.model = std::make_unique<Model>(m.bodies(), m.gravity(), m.forces(), m.name(), joints,
                                    m.frames(), m.inputs(), std::vector<Constraint>{tip});
  c.q = open.q;
  c.z = open.z;
  project_onto_constraints(*c.model, c.q, c.z);
  return c;
}

// One of the terms, or the forward dynamics they are compared with, at the model's (q, z).
enum class Term {
  forward,
  inverse_dynamics,
  mass_matrix,
  frame_jacobian,
  jacobian_and_kinematics,
  derivatives,
  linearize
};

void run_term(benchmark::State& bench, const JointedChain& c, Term term) {
  const Model& model = *c.model;
  const int n = model.num_speeds();
  Dynamics dyn(model);
  Terms terms(model);
  Derivatives derivatives(model);
  const VectorX u = VectorX::Zero(model.num_inputs());
  MatrixX dq(n, n), dz(n, n), du(n, model.num_inputs());
  VectorX zdot(n), Q(n);
  dyn.evaluate(c.q, c.z, zdot);
  MatrixX M(n, n), Jv(3, n), Jw(3, n);
  State state(model);
  Data data(model, DataOptions::recursive_only());
  joint_state(model, c.q, c.z, state);
  compute_kinematics(model, state, data);
  for (auto _ : bench) {
    switch (term) {
      case Term::forward:
        dyn.evaluate(c.q, c.z, zdot);
        benchmark::DoNotOptimize(zdot.data());
        break;
      case Term::inverse_dynamics:
        terms.inverse_dynamics(c.q, c.z, zdot, Q);
        benchmark::DoNotOptimize(Q.data());
        break;
      case Term::mass_matrix:
        terms.mass_matrix(c.q, M);
        benchmark::DoNotOptimize(M.data());
        break;
      case Term::jacobian_and_kinematics:
        joint_state(model, c.q, c.z, state);
        compute_kinematics(model, state, data);
        [[fallthrough]];
      case Term::frame_jacobian:
        frame_jacobian(model, 0, c.q, data.kinematics, Jv, Jw);
        benchmark::DoNotOptimize(Jv.data());
        break;
      case Term::derivatives:  // all three blocks, d(z dot)/dq, dz, du
        derivatives.forward(c.q, c.z, u, dq, dz, du);
        benchmark::DoNotOptimize(dq.data());
        break;
      case Term::linearize: {  // A, B and the eigenvalues
        const Linearization lin = linearize(model, c.q, c.z, u);
        benchmark::DoNotOptimize(lin.eigenvalues.data());
        break;
      }
    }
    benchmark::ClobberMemory();
  }
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
  // Constraints: the bicycle against its four bodies without the contacts, and the 512-link
  // chain closed at its tip against the open one (joints_recursive/chain-512).
  for (const Route route : {Route::recursive, Route::assembled}) {
    add(route, "bicycle", [] { return bicycle(true); });
    add(route, "bicycle-tree", [] { return bicycle(false); });
  }
  add(Route::recursive, "chain-512-closed", [] { return closed_chain(512); });

  const auto term = [](const char* name, Term t, const std::string& model, auto make) {
    benchmark::RegisterBenchmark((std::string("terms/") + name + "/" + model).c_str(),
                                 [t, make](benchmark::State& b) { run_term(b, make(), t); })
        ->Unit(benchmark::kMicrosecond)
        ->ComputeStatistics("min", [](const std::vector<double>& v) {
          return *std::min_element(v.begin(), v.end());
        });
  };
  term("forward", Term::forward, "arm", arm);
  term("inverse_dynamics", Term::inverse_dynamics, "arm", arm);
  term("mass_matrix", Term::mass_matrix, "arm", arm);
  term("frame_jacobian", Term::frame_jacobian, "arm", arm);
  term("frame_jacobian_with_kinematics", Term::jacobian_and_kinematics, "arm", arm);
  term("derivatives", Term::derivatives, "arm", arm);
  term("linearize", Term::linearize, "arm", arm);
  const auto chain64 = [] { return revolute_chain(64); };
  term("forward", Term::forward, "chain-64", chain64);
  term("derivatives", Term::derivatives, "chain-64", chain64);
  const auto chain512 = [] { return revolute_chain(512); };
  term("forward", Term::forward, "chain-512", chain512);
  term("inverse_dynamics", Term::inverse_dynamics, "chain-512", chain512);
  term("mass_matrix", Term::mass_matrix, "chain-512", chain512);
  term("derivatives", Term::derivatives, "chain-512", chain512);
  term("linearize", Term::linearize, "chain-512", chain512);
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
