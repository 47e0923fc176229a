// kanedyn_peers: one forward-dynamics evaluation of the same model at the same state in
// kanedyn (recursive and Kane routes), Simbody, MuJoCo and DART; median time per evaluation,
// ratios to kanedyn, and agreement of the body accelerations. The jointed sections
// (jointed_section.hpp) do the same for jointed trees with kanedyn's Dynamics, and time
// it per body on revolute chains. See docs/performance.md.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "constraints_section.hpp"
#include "describe.hpp"
#include "jointed_section.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/rotation.hpp"
#include "kanedyn/testing/generate.hpp"
#include "peer.hpp"
#include "springs_section.hpp"
#include "timing.hpp"
#ifdef KANEDYN_PEERS_HAVE_DART_URDF
#include "urdf_section.hpp"
#endif

namespace {

using kanedyn::Matrix3;
using kanedyn::Vector3;
using kanedyn::Vector4;
using peers::format_ns;
using peers::format_ratio;
using peers::format_sci;
using peers::Runner;
using peers::seconds_since;
using peers::Timing;
using Clock = std::chrono::steady_clock;

struct Options {
  std::vector<std::string> models;
  std::vector<int> sizes{8, 64, 512, 4096};
  std::vector<std::string> engines{"recursive", "kane", "simbody", "mujoco", "dart"};
  std::string eight_body = KANEDYN_SOURCE_DIR "/examples/eight_body.yaml";
  unsigned seed = 1;
  int reps = 1000;
  double max_seconds = 2.0;      // timing budget per engine and model
  double batch_seconds = 1e-3;   // length of one timed batch
  double max_eval_seconds = 60;  // skip when one evaluation is predicted to take longer
  double max_memory_gb = 0;      // 0: half of MemAvailable
  double tolerance = 1e-8;
  double backward_tolerance = 1e-10;
#ifdef KANEDYN_PEERS_HAVE_DART_URDF
  std::vector<std::string> sections{"free",        "jointed", "terms", "scaling",
                                    "constraints", "springs", "urdf"};
#else
  std::vector<std::string> sections{"free",    "jointed",     "terms",
                                    "scaling", "constraints", "springs"};
#endif
  int jointed_chain = 512;
  int jointed_states = 4;
  std::vector<int> scaling_sizes{64, 512, 4096};
  double joint_tolerance = 1e-10;
  std::vector<std::string> urdf_files{KANEDYN_SOURCE_DIR "/examples/urdf/arm.urdf",
                                      KANEDYN_SOURCE_DIR "/tests/data/urdf/flange.urdf",
                                      KANEDYN_SOURCE_DIR "/tests/data/urdf/joints.urdf",
                                      KANEDYN_SOURCE_DIR "/tests/data/urdf/floating.urdf",
                                      KANEDYN_SOURCE_DIR "/bench/peers/urdf/joints_welded.urdf",
                                      KANEDYN_SOURCE_DIR "/bench/peers/urdf/branches.urdf"};
  int urdf_states = 8;
  double urdf_tolerance = 1e-12;
  peers::ConstraintOptions constraints{.files = {KANEDYN_SOURCE_DIR "/examples/four_bar.yaml",
                                                 KANEDYN_SOURCE_DIR "/examples/rssr.yaml"}};
  peers::SpringOptions springs;
};

struct Case {
  std::string name;
  kanedyn::Model model;
  kanedyn::State state;
};

peers::Vec3 arr(const Vector3& v) { return {v.x(), v.y(), v.z()}; }
Vector3 vec(const peers::Vec3& a) { return {a[0], a[1], a[2]}; }

peers::System describe(const Case& c) { return peers::describe(c.name, c.model, c.state); }

// Inertial body motion from kanedyn's {y dot}, by an outward pass written here from the
// notes' kinematics (Eqs. 12-17 differentiated once more), independent of the library's
// internal workspace.
std::vector<peers::BodyMotion> kanedyn_motion(const kanedyn::Model& m, const kanedyn::State& s,
                                              const kanedyn::VectorX& ydot) {
  const int n = m.num_bodies();
  std::vector<Matrix3> R(static_cast<size_t>(n));
  std::vector<Vector3> p_O(R.size()), v_O(R.size()), a_O(R.size());
  std::vector<peers::BodyMotion> out(R.size());
  for (int k = 0; k < n; ++k) {
    const auto i = static_cast<size_t>(k);
    R[i] = kanedyn::rotation_matrix(s.euler_parameters(k));
    const Vector3 qs = m.body(k).joint + s.translation(k);
    const Vector3 sd = s.translation_rate(k);
    const Vector3 sdd = ydot.segment<3>(3 * n + 3 * k);
    const int j = m.lower_body(k);
    if (j == kanedyn::kGround) {
      p_O[i] = qs;
      v_O[i] = sd;
      a_O[i] = sdd;
    } else {
      const auto jj = static_cast<size_t>(j);
      const Vector3 wj = s.angular_velocity(j);
      const Vector3 alj = ydot.segment<3>(3 * j);
      p_O[i] = p_O[jj] + R[jj].transpose() * qs;
      v_O[i] = v_O[jj] + R[jj].transpose() * (sd + wj.cross(qs));
      a_O[i] = a_O[jj] + R[jj].transpose() *
                             (sdd + 2.0 * wj.cross(sd) + alj.cross(qs) + wj.cross(wj.cross(qs)));
    }
    const Vector3 w = s.angular_velocity(k), al = ydot.segment<3>(3 * k), r = m.body(k).com;
    out[i].p_G = arr(p_O[i] + R[i].transpose() * r);
    out[i].v_G = arr(v_O[i] + R[i].transpose() * w.cross(r));
    out[i].w = arr(R[i].transpose() * w);
    out[i].a_G = arr(a_O[i] + R[i].transpose() * (al.cross(r) + w.cross(w.cross(r))));
    out[i].alpha = arr(R[i].transpose() * al);
  }
  return out;
}

// kanedyn's {y dot} as rates of the joint speeds of the other engines' joint coordinates:
// s'_K double-dot, and d/dt of w_rel = w'_K - [R_rel] w'_J (K axes, [R_rel] = [R_K][R_J]^T),
// which is alpha'_K - [R_rel] alpha'_J + w'_K x ([R_rel] w'_J).
std::vector<peers::JointAcceleration> kanedyn_joint_accelerations(const kanedyn::Model& m,
                                                                  const kanedyn::State& s,
                                                                  const kanedyn::VectorX& ydot) {
  const int n = m.num_bodies();
  std::vector<peers::JointAcceleration> out(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    auto& o = out[static_cast<size_t>(k)];
    o.s_ddot = arr(ydot.segment<3>(3 * n + 3 * k));
    Vector3 rate = ydot.segment<3>(3 * k);
    const int j = m.lower_body(k);
    if (j != kanedyn::kGround) {
      const Matrix3 R_rel = kanedyn::rotation_matrix(s.euler_parameters(k)) *
                            kanedyn::rotation_matrix(s.euler_parameters(j)).transpose();
      const Vector3 wj_in_k = R_rel * s.angular_velocity(j);
      rate += -R_rel * ydot.segment<3>(3 * j) + s.angular_velocity(k).cross(wj_in_k);
    }
    o.w_rel_dot_k = arr(rate);
  }
  return out;
}

// max_k |x_k - ref_k| / max_k |ref_k| for one per-body 3-vector quantity.
double relative_difference(const std::vector<peers::BodyMotion>& x,
                           const std::vector<peers::BodyMotion>& ref,
                           peers::Vec3 peers::BodyMotion::*field) {
  double diff = 0, scale = 0;
  for (size_t k = 0; k < ref.size(); ++k) {
    diff = std::max(diff, (vec(x[k].*field) - vec(ref[k].*field)).norm());
    scale = std::max(scale, vec(ref[k].*field).norm());
  }
  return scale > 0 ? diff / scale : diff;
}

struct Agreement {
  double state = 0;         // worst of p_G, v_G, w: did the engine get the same state?
  double acceleration = 0;  // worst of a_G, alpha
};

Agreement compare(const std::vector<peers::BodyMotion>& x,
                  const std::vector<peers::BodyMotion>& ref) {
  using M = peers::BodyMotion;
  return {std::max({relative_difference(x, ref, &M::p_G), relative_difference(x, ref, &M::v_G),
                    relative_difference(x, ref, &M::w)}),
          std::max(relative_difference(x, ref, &M::a_G), relative_difference(x, ref, &M::alpha))};
}

struct Cell {
  std::optional<Timing> timing;
  Agreement agreement;
  std::vector<double> backward;  // engine's and kanedyn's backward errors, if the engine has them
  std::string note;              // why it was skipped
};

double mem_available_bytes() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  double kb = 0;
  std::string unit;
  while (in >> key >> kb >> unit)
    if (key == "MemAvailable:") return kb * 1024.0;
  return 8e9;
}

std::vector<Case> make_cases(const Options& opt) {
  std::vector<Case> cases;
  auto wanted = [&](const std::string& name) {
    return opt.models.empty() ||
           std::find(opt.models.begin(), opt.models.end(), name) != opt.models.end();
  };
  if (wanted("eight-body")) {
    if (std::filesystem::exists(opt.eight_body)) {
      kanedyn::io::ModelFile f = kanedyn::io::load_model_file(opt.eight_body);
      cases.push_back({"eight-body", std::move(f.model), std::move(f.initial)});
    } else {
      std::cerr << "kanedyn_peers: " << opt.eight_body << " not found; eight-body skipped\n";
    }
  }
  for (const char* family : {"chain", "tree"})
    for (int n : opt.sizes) {
      const std::string name = std::string(family) + "-" + std::to_string(n);
      if (!wanted(name)) continue;
      kanedyn::GeneratedSystem g = std::string(family) == "chain"
                                       ? kanedyn::chain_model(n, opt.seed)
                                       : kanedyn::random_tree_model(n, opt.seed);
      cases.push_back({name, std::move(g.model), std::move(g.initial)});
    }
  return cases;
}

struct EngineColumn {
  std::string key, title;
  std::optional<peers::EngineInfo> info;   // empty for kanedyn's own routes
  double last_cost = 0, last_seconds = 0;  // the last measured case, for extrapolation
};

std::string machine_model() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown CPU";
}

// The free-body section: every engine on the free-body models (the tables of
// docs/performance.md, "Results"). Returns the exit code: 2 when some engine disagrees.
int free_bodies(const Options& opt, std::vector<EngineColumn>& columns, bool have_recursive) {
  const std::vector<Case> cases = make_cases(opt);
  if (cases.empty()) return 0;  // only jointed models asked for
  std::vector<std::vector<Cell>> table(cases.size(), std::vector<Cell>(columns.size()));
  bool all_agree = true;
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    const Case& c = cases[ci];
    const int n = c.model.num_bodies();
    const peers::System sys = describe(c);
    // The reference: kanedyn's recursive route (the Kane route is checked against it too).
    const kanedyn::DataOptions recursive_options = kanedyn::DataOptions::recursive_only();
    kanedyn::DataOptions kane_options;  // the assembled route, no partials, no dense [A]
    kane_options.partials = false;
    kane_options.dense_mass_matrix = false;
    kanedyn::Data ref_data(c.model, recursive_options);
    kanedyn::forward_dynamics(c.model, c.state, ref_data, kanedyn::Route::recursive);
    const std::vector<peers::BodyMotion> reference =
        kanedyn_motion(c.model, c.state, ref_data.ydot);

    // Every column of this case lives until the case is timed (interleaved rounds).
    struct Slot {
      std::unique_ptr<kanedyn::Data> data;
      std::unique_ptr<peers::Engine> engine;
      Runner runner;
      double cost = 0, setup = 0;
    };
    std::vector<Slot> slots(columns.size());
    std::vector<Runner*> runners;
    for (size_t ei = 0; ei < columns.size(); ++ei) {
      EngineColumn& col = columns[ei];
      Cell& cell = table[ci][ei];
      const double cost =
          col.info ? col.info->cost(sys) : (col.key == "kane" ? peers::ancestor_dofs(sys, 2) : n);
      // kanedyn's Kane route keeps partial velocity blocks and blocks of [A] per chain entry.
      const double bytes = col.info ? col.info->bytes(sys)
                                    : (col.key == "kane" ? 1200.0 * c.model.chain_entries() : 0.0);
      const double predicted = col.last_cost > 0 ? col.last_seconds * cost / col.last_cost : 0;
      if (predicted > opt.max_eval_seconds) {
        cell.note = "predicted " + format_sci(predicted) + " s/eval";
      } else if (bytes > opt.max_memory_gb * 1e9) {
        cell.note = "needs ~" + format_ratio(bytes / 1e9) + " GB";
      }
      if (!cell.note.empty()) {
        std::cout << "# " << c.name << " " << col.title << ": skipped, " << cell.note << "\n"
                  << std::flush;
        continue;
      }
      slots[ei].cost = cost;
      // Set up, evaluate once (the result checked), and prepare the batch function.
      Slot& slot = slots[ei];
      std::vector<peers::BodyMotion> motion;
      double first = 0;
      if (!col.info) {
        const kanedyn::Route method =
            col.key == "kane" ? kanedyn::Route::assembled : kanedyn::Route::recursive;
        slot.data = std::make_unique<kanedyn::Data>(
            c.model, method == kanedyn::Route::assembled ? kane_options : recursive_options);
        kanedyn::Data& data = *slot.data;
        slot.runner.run_batch = [&c, &data, method](long count) {
          for (long b = 0; b < count; ++b)
            kanedyn::forward_dynamics(c.model, c.state, data, method);
        };
        const auto t0 = Clock::now();
        slot.runner.run_batch(1);
        first = seconds_since(t0);
        motion = kanedyn_motion(c.model, c.state, data.ydot);
      } else {
        const auto t_setup = Clock::now();
        slot.engine = col.info->make(sys);
        slot.setup = seconds_since(t_setup);
        peers::Engine& engine = *slot.engine;
        slot.runner.run_batch = [&engine](long count) {
          for (long b = 0; b < count; ++b) engine.evaluate();
        };
        const auto t0 = Clock::now();
        slot.runner.run_batch(1);
        first = seconds_since(t0);
        motion = engine.motion();
        cell.backward =
            engine.backward_errors(kanedyn_joint_accelerations(c.model, c.state, ref_data.ydot));
      }
      slot.runner.first = first;
      cell.agreement = compare(motion, reference);
      runners.push_back(&slot.runner);
    }

    peers::time_interleaved(runners, {opt.reps, opt.max_seconds, opt.batch_seconds});

    for (size_t ei = 0; ei < columns.size(); ++ei) {
      EngineColumn& col = columns[ei];
      Cell& cell = table[ci][ei];
      Slot& slot = slots[ei];
      if (!cell.note.empty()) continue;
      const Timing t = peers::statistics(slot.runner);
      cell.timing = t;
      col.last_cost = slot.cost;
      col.last_seconds = t.median_ns * 1e-9;
      // The same accelerations, or (ill-conditioned joint-space M) kanedyn's accelerations
      // solve the engine's own equations to round-off.
      const bool by_backward_error =
          cell.backward.size() == 2 && cell.backward[1] <= opt.backward_tolerance;
      const bool agrees = cell.agreement.state <= opt.tolerance &&
                          (cell.agreement.acceleration <= opt.tolerance || by_backward_error);
      all_agree = all_agree && agrees;
      std::cout << "# " << c.name << " " << col.title << ": median " << format_ns(t.median_ns)
                << " ns, min " << format_ns(t.min_ns) << " ns, " << t.evals
                << " evals; rel. diff. state " << format_sci(cell.agreement.state)
                << ", accelerations " << format_sci(cell.agreement.acceleration)
                << (agrees ? "" : "  <-- DISAGREES");
      if (cell.backward.size() == 2)
        std::cout << "; backward error of M qacc = f: own " << format_sci(cell.backward[0])
                  << ", kanedyn's " << format_sci(cell.backward[1]);
      if (col.info) std::cout << "; setup " << format_sci(slot.setup) << " s";
      std::cout << "\n" << std::flush;
    }
  }

  // Tables (markdown).
  auto header = [&] {
    std::cout << "\n| model | N |";
    for (const auto& col : columns) std::cout << ' ' << col.title << " |";
    std::cout << "\n|---|---:|";
    for (size_t i = 0; i < columns.size(); ++i) std::cout << "---:|";
    std::cout << "\n";
  };
  std::cout << "\nMedian ns per evaluation:\n";
  header();
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    std::cout << "| " << cases[ci].name << " | " << cases[ci].model.num_bodies() << " |";
    for (const Cell& cell : table[ci])
      std::cout << ' ' << (cell.timing ? format_ns(cell.timing->median_ns) : "(" + cell.note + ")")
                << " |";
    std::cout << "\n";
  }
  if (have_recursive) {
    const auto rec = static_cast<size_t>(
        std::find_if(columns.begin(), columns.end(),
                     [](const EngineColumn& c) { return c.key == "recursive"; }) -
        columns.begin());
    auto ratios = [&](const char* title, double Timing::*stat) {
      std::cout << "\n" << title << "\n";
      header();
      for (size_t ci = 0; ci < cases.size(); ++ci) {
        std::cout << "| " << cases[ci].name << " | " << cases[ci].model.num_bodies() << " |";
        const Cell& base = table[ci][rec];
        for (const Cell& cell : table[ci])
          std::cout << ' '
                    << (cell.timing && base.timing
                            ? format_ratio((*cell.timing).*stat / (*base.timing).*stat)
                            : "-")
                    << " |";
        std::cout << "\n";
      }
    };
    ratios("Median time relative to kanedyn recursive (x slower):", &Timing::median_ns);
    // Minima are less sensitive to slow spells of a shared machine; a cross-check.
    ratios("Minimum time relative to kanedyn recursive (x slower):", &Timing::min_ns);
  }
  std::cout << "\nLargest relative difference of body accelerations (a_G, alpha; inertial) from "
               "kanedyn recursive:\n";
  header();
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    std::cout << "| " << cases[ci].name << " | " << cases[ci].model.num_bodies() << " |";
    for (size_t ei = 0; ei < columns.size(); ++ei) {
      const Cell& cell = table[ci][ei];
      std::cout << ' ';
      if (columns[ei].key == "recursive")
        std::cout << "reference";
      else if (!cell.timing)
        std::cout << "-";
      else
        std::cout << format_sci(cell.agreement.acceleration);
      if (cell.timing && cell.backward.size() == 2 && cell.agreement.acceleration > opt.tolerance)
        std::cout << " (bwd " << format_sci(cell.backward[1]) << ")";
      std::cout << " |";
    }
    std::cout << "\n";
  }
  std::cout << "\n(bwd: componentwise backward error of kanedyn's accelerations in the engine's "
               "own M qacc = f, shown where the forward difference exceeds --tolerance)\n";
  if (!all_agree) {
    std::cout << "\nSome engine disagrees with kanedyn beyond --tolerance " << opt.tolerance
              << " (marked DISAGREES above).\n";
    return 2;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"Forward dynamics of the same models in kanedyn, Simbody, MuJoCo and DART"};
  app.add_option(
         "--models", opt.models,
         "Models to run: eight-body, chain-N, tree-N; eight-body-jointed, every-joint-type, "
         "planar-joints, screw-joints, revolute-chain-N (default: all)")
      ->delimiter(',');
  app.add_option("--sizes", opt.sizes, "N of the chains and random trees")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--engines", opt.engines,
                 "recursive, kane, simbody, mujoco, dart (the jointed sections: kanedyn's "
                 "recursive route and the peers among these)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--eight-body", opt.eight_body, "Model file of the eight-body example")
      ->capture_default_str();
  app.add_option("--seed", opt.seed, "Seed of the generated models")->capture_default_str();
  app.add_option("--reps", opt.reps, "Timed batches per engine and model (at most)")
      ->capture_default_str();
  app.add_option("--max-seconds", opt.max_seconds,
                 "Timing budget per engine and model, s (at least one batch is timed)")
      ->capture_default_str();
  app.add_option("--batch-seconds", opt.batch_seconds,
                 "Length of one timed batch of evaluations, s (engines take turns batch by batch)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--max-eval-seconds", opt.max_eval_seconds,
                 "Skip a case when one evaluation is predicted (from the engine's smaller "
                 "measured cases) to take longer, s")
      ->capture_default_str();
  app.add_option("--max-memory-gb", opt.max_memory_gb,
                 "Skip a case when the engine's estimated memory exceeds this (0: half of "
                 "MemAvailable)")
      ->capture_default_str();
  app.add_option("--tolerance", opt.tolerance,
                 "Largest accepted relative difference of body accelerations")
      ->capture_default_str();
  app.add_option("--backward-tolerance", opt.backward_tolerance,
                 "Accept a larger difference when kanedyn's accelerations satisfy the engine's "
                 "own M qacc = f to this componentwise backward error (ill-conditioned M)")
      ->capture_default_str();
  app.add_option("--sections", opt.sections,
                 "free (the free-body tables), jointed (jointed models: accelerations and "
                 "timing), terms (the jointed models' inverse dynamics and mass matrix against "
                 "Simbody's and DART's), scaling (kanedyn's time per body on revolute chains), "
                 "constraints (closed loops: motions and reactions against Simbody's), springs "
                 "(point-to-point springs against Simbody's TwoPointLinearSpring), urdf "
                 "(kanedyn's URDF import against DART's URDF loader; needs "
                 "libdart-utils-urdf-dev)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--jointed-chain", opt.jointed_chain,
                 "Links of the revolute chain of the jointed comparison")
      ->capture_default_str();
  app.add_option("--jointed-states", opt.jointed_states,
                 "Random states per jointed model at which accelerations are compared")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--scaling-sizes", opt.scaling_sizes, "Links of the revolute chains timed")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--joint-tolerance", opt.joint_tolerance,
                 "Largest accepted relative difference of joint accelerations (raised to 10 "
                 "cond(M) eps where the joint-space mass matrix is ill-conditioned)")
      ->capture_default_str();
  app.add_option("--urdf-files", opt.urdf_files, "URDF files of the urdf section")->delimiter(',');
  app.add_option("--urdf-states", opt.urdf_states,
                 "Random states per URDF file at which mass matrices and accelerations are "
                 "compared")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--urdf-tolerance", opt.urdf_tolerance,
                 "Largest accepted relative difference of the URDF files' mass matrices and "
                 "joint accelerations (accelerations: raised to 10 cond(M) eps where larger)")
      ->capture_default_str();
  peers::ConstraintOptions& c = opt.constraints;
  app.add_option("--constraint-files", c.files,
                 "Model files of the constraints section (ball, hinge, distance constraints)")
      ->delimiter(',');
  app.add_option("--constraint-t-end", c.t_end, "Span of the constraints section's runs, s")
      ->capture_default_str();
  app.add_option("--constraint-dt-out", c.dt_out, "Time between its compared states, s")
      ->capture_default_str();
  app.add_option("--constraint-rtol", c.rtol, "kanedyn's dopri5 rtol there (atol = rtol / 100)")
      ->capture_default_str();
  app.add_option("--constraint-accuracy", c.accuracy, "Simbody's integrator accuracy there")
      ->capture_default_str();
  app.add_option("--constraint-instant-tolerance", c.instant_tolerance,
                 "Largest accepted relative difference of z dot and reactions at the initial "
                 "state")
      ->capture_default_str();
  app.add_option("--constraint-safety", c.safety,
                 "Over the run, accept differences up to this many times Simbody's own "
                 "integration error (estimated from a run at 10x its accuracy)")
      ->capture_default_str();
  app.add_option("--constraint-floor", c.floor, "... plus this (rad, rad/s, relative reaction)")
      ->capture_default_str();
  peers::SpringOptions& sp = opt.springs;
  app.add_option("--spring-states", sp.states,
                 "Random states per model of the springs section at which accelerations are "
                 "compared")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--spring-tolerance", sp.tolerance,
                 "Largest accepted relative difference of z dot there (and of the two engines' "
                 "energies of the same state)")
      ->capture_default_str();
  app.add_option("--spring-t-end", sp.t_end, "Span of the springs section's undamped runs, s")
      ->capture_default_str();
  app.add_option("--spring-accuracy", sp.accuracy, "Simbody's integrator accuracy there")
      ->capture_default_str();
  app.add_option("--spring-safety", sp.safety,
                 "Over the run, accept differences and energy drifts up to this many times the "
                 "integrators' own errors (estimated from runs at 10x their tolerances)")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  for (const std::string& section : opt.sections)
    if (section != "free" && section != "jointed" && section != "scaling" && section != "urdf" &&
        section != "terms" && section != "constraints" && section != "springs") {
      std::cerr << "kanedyn_peers: unknown section '" << section
                << "' (free, jointed, scaling, urdf, terms, constraints, springs)\n";
      return 1;
    }
  if (opt.max_memory_gb <= 0) opt.max_memory_gb = 0.5 * mem_available_bytes() / 1e9;

  std::vector<EngineColumn> columns;
  for (const std::string& e : opt.engines) {
    if (e == "recursive")
      columns.push_back({e, "kanedyn recursive", std::nullopt});
    else if (e == "kane")
      columns.push_back({e, "kanedyn kane", std::nullopt});
    else if (e == "simbody")
      columns.push_back({e, "", peers::simbody_engine()});
    else if (e == "mujoco")
      columns.push_back({e, "", peers::mujoco_engine()});
#ifdef KANEDYN_PEERS_HAVE_DART
    else if (e == "dart")
      columns.push_back({e, "", peers::dart_engine()});
#else
    else if (e == "dart")
      std::cerr << "kanedyn_peers: built without DART; dart skipped\n";
#endif
    else {
      std::cerr << "kanedyn_peers: unknown engine '" << e << "'\n";
      return 1;
    }
    if (columns.back().info)
      columns.back().title = columns.back().info->name + " " + columns.back().info->version;
  }
  const bool have_recursive =
      std::find(opt.engines.begin(), opt.engines.end(), "recursive") != opt.engines.end();

  {
    const std::time_t now = std::time(nullptr);
    char date[32];
    std::strftime(date, sizeof date, "%Y-%m-%d %H:%M", std::localtime(&now));
    std::cout << "# kanedyn_peers, " << date << ", " << machine_model() << "\n"
              << "# median ns per forward-dynamics evaluation at the model's initial state; "
              << "budget " << opt.max_seconds << " s per cell, skip above " << opt.max_eval_seconds
              << " s/eval or " << std::setprecision(3) << opt.max_memory_gb << " GB\n"
              << std::flush;
  }

  const auto selected = [&](const char* section) {
    return std::find(opt.sections.begin(), opt.sections.end(), section) != opt.sections.end();
  };
  int rc = selected("free") ? free_bodies(opt, columns, have_recursive) : 0;
  if (selected("jointed") || selected("scaling") || selected("terms")) {
    peers::JointedOptions j;
    j.models = opt.models;
    j.engines = opt.engines;
    j.eight_body = opt.eight_body;
    j.seed = opt.seed;
    j.chain = opt.jointed_chain;
    j.states = opt.jointed_states;
    j.scaling_sizes = opt.scaling_sizes;
    j.budget = {opt.reps, opt.max_seconds, opt.batch_seconds};
    j.max_eval_seconds = opt.max_eval_seconds;
    j.tolerance = opt.joint_tolerance;
    j.compare = selected("jointed");
    j.scaling = selected("scaling");
    j.terms = selected("terms");
    if (!peers::run_jointed_sections(j) && rc == 0) rc = 2;
  }
  if (selected("constraints") && !peers::run_constraint_section(opt.constraints) && rc == 0) rc = 2;
  if (selected("springs")) {
    opt.springs.seed = opt.seed;
    opt.springs.budget = {opt.reps, opt.max_seconds, opt.batch_seconds};
    if (!peers::run_spring_section(opt.springs) && rc == 0) rc = 2;
  }
  if (selected("urdf")) {
#ifdef KANEDYN_PEERS_HAVE_DART_URDF
    peers::UrdfOptions u;
    u.files = opt.urdf_files;
    u.seed = opt.seed;
    u.states = opt.urdf_states;
    u.tolerance = opt.urdf_tolerance;
    if (!peers::run_urdf_section(u) && rc == 0) rc = 2;
#else
    std::cerr << "kanedyn_peers: built without DART's URDF loader (libdart-utils-urdf-dev) or "
                 "without kanedyn's URDF import; section urdf skipped\n";
#endif
  }
  return rc;
}
