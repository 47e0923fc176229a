// kanedyn_peers' jointed sections (jointed_section.hpp).
#include "jointed_section.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "jointed.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/terms.hpp"

namespace peers {
namespace {

using kanedyn::VectorX;

struct Column {
  std::string key, title;
  std::optional<JointedEngineInfo> info;  // empty for kanedyn
};

struct Cell {
  std::optional<Timing> timing;
  double difference = -1;   // largest relative difference of zdot over the states; -1: not run
  double of_tolerance = 0;  // largest difference / the state's tolerance
  std::string note;         // why it was not run
};

// max_i |x_i - ref_i| / max_i |ref_i|: the difference at the scale of the largest joint
// acceleration (angles and lengths alike, in the model's units).
double relative_difference(const std::vector<double>& x, const VectorX& ref) {
  double diff = 0, scale = 0;
  for (Eigen::Index i = 0; i < ref.size(); ++i) {
    diff = std::max(diff, std::fabs(x[static_cast<size_t>(i)] - ref[i]));
    scale = std::max(scale, std::fabs(ref[i]));
  }
  return scale > 0 ? diff / scale : diff;
}

// As format_ratio, with three significant digits below 1 (kanedyn slower than a peer).
std::string ratio_text(double r) {
  if (r >= 1) return format_ratio(r);
  std::ostringstream s;
  s << std::setprecision(3) << r;
  return s.str();
}

// Largest number of speeds for which cond(M) is computed: it takes kanedyn's dense projected
// equations (the 6N x 6N [A]) and an eigensolver, 0.2 GB and about a second at n = 512.
constexpr int kMaxConditionSpeeds = 1024;

// The 2-norm condition number of the joint-space mass matrix at the case's state (0 above
// kMaxConditionSpeeds). Solving M zdot = f backward-stably gives a relative error up to about
// cond(M) eps in each engine, so that bounds what two correct engines may differ by.
double mass_matrix_condition(const JointedCase& c) {
  if (c.model.num_speeds() > kMaxConditionSpeeds) return 0;
  kanedyn::Data data(c.model, kanedyn::DataOptions{});
  const kanedyn::ProjectedEquations e = kanedyn::projected_equations(c.model, c.q, c.z, data);
  const Eigen::SelfAdjointEigenSolver<kanedyn::MatrixX> eigen(e.A_z, Eigen::EigenvaluesOnly);
  return eigen.eigenvalues().maxCoeff() / eigen.eigenvalues().minCoeff();
}

bool wanted(const JointedOptions& opt, const std::string& name) {
  return opt.models.empty() ||
         std::find(opt.models.begin(), opt.models.end(), name) != opt.models.end();
}

std::vector<std::unique_ptr<JointedCase>> make_cases(const JointedOptions& opt) {
  std::vector<std::unique_ptr<JointedCase>> cases;
  if (wanted(opt, "eight-body-jointed")) cases.push_back(jointed_eight_body(opt.eight_body));
  if (wanted(opt, "every-joint-type")) cases.push_back(every_joint_type(opt.seed));
  if (wanted(opt, "planar-joints")) cases.push_back(planar_joints(opt.seed));
  if (wanted(opt, "screw-joints")) cases.push_back(screw_joints(opt.seed));
  std::vector<int> chains;
  if (opt.models.empty()) chains.push_back(opt.chain);
  for (const std::string& name : opt.models)
    if (name.rfind("revolute-chain-", 0) == 0) chains.push_back(std::stoi(name.substr(15)));
  for (int n : chains) cases.push_back(revolute_chain(n, opt.seed));
  return cases;
}

void print_table(const std::vector<std::unique_ptr<JointedCase>>& cases,
                 const std::vector<Column>& columns, const char* title,
                 const std::function<std::string(size_t, size_t)>& entry) {
  std::cout << "\n" << title << "\n\n| model | N | n |";
  for (const Column& c : columns) std::cout << ' ' << c.title << " |";
  std::cout << "\n|---|---:|---:|";
  for (size_t i = 0; i < columns.size(); ++i) std::cout << "---:|";
  std::cout << "\n";
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    std::cout << "| " << cases[ci]->name << " | " << cases[ci]->model.num_bodies() << " | "
              << cases[ci]->model.num_speeds() << " |";
    for (size_t ei = 0; ei < columns.size(); ++ei) std::cout << ' ' << entry(ci, ei) << " |";
    std::cout << "\n";
  }
}

bool compare_section(const JointedOptions& opt) {
  std::vector<Column> columns{{"kanedyn", "kanedyn recursive", std::nullopt}};
  for (const std::string& e : opt.engines) {
    std::optional<JointedEngineInfo> info;
    if (e == "simbody") info = simbody_jointed_engine();
    if (e == "mujoco") info = mujoco_jointed_engine();
#ifdef KANEDYN_PEERS_HAVE_DART
    if (e == "dart") info = dart_jointed_engine();
#endif
    if (info) columns.push_back({e, info->name + " " + info->version, info});
  }
  const std::vector<std::unique_ptr<JointedCase>> cases = make_cases(opt);
  if (cases.empty()) return true;
  std::cout << "\n## Jointed models\n"
            << "# joint accelerations at " << opt.states
            << " random states per model (the first also timed), compared in kanedyn's z order "
               "and convention with Dynamics::evaluate (Route::recursive); tolerance "
               "max("
            << format_sci(opt.tolerance)
            << ", 10 cond(M) eps) of the largest |z dot| (cond(M): the 2-norm condition number "
               "of kanedyn's joint-space mass matrix [C]^T [A] [C] at the state, for n <= "
            << kMaxConditionSpeeds << ")\n"
            << std::flush;

  std::vector<std::vector<Cell>> table(cases.size(), std::vector<Cell>(columns.size()));
  bool all_agree = true;
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    JointedCase& c = *cases[ci];
    kanedyn::Dynamics ws(c.model, kanedyn::Route::recursive);
    VectorX zdot(c.model.num_speeds()), qdot(c.model.num_coordinates());
    std::mt19937 rng(opt.seed);
    std::vector<VectorX> q0z0;  // the timed state
    double spread = 0;          // largest difference between two peers' z dot, relative
    double worst_condition = 0;
    // Accelerations at every state; each engine rebuilt at each state, as it would be given it.
    for (int s = 0; s < opt.states; ++s) {
      random_joint_state(c, rng);
      if (s == 0) q0z0 = {c.q, c.z};
      ws.evaluate(c.q, c.z, zdot, qdot);
      const double condition = mass_matrix_condition(c);
      worst_condition = std::max(worst_condition, condition);
      const double tolerance =
          std::max(opt.tolerance, 10.0 * condition * std::numeric_limits<double>::epsilon());
      const JointedSystem sys = describe_jointed(c);
      std::vector<std::vector<double>> results;
      for (size_t ei = 1; ei < columns.size(); ++ei) {
        Cell& cell = table[ci][ei];
        if (!cell.note.empty()) continue;
        if (const std::string why = columns[ei].info->unsupported(sys); !why.empty()) {
          cell.note = why;
          continue;
        }
        try {
          const std::unique_ptr<JointedEngine> engine = columns[ei].info->make(sys);
          engine->evaluate();
          results.push_back(engine->zdot());
          const double d = relative_difference(results.back(), zdot);
          cell.difference = std::max(cell.difference, d);
          cell.of_tolerance = std::max(cell.of_tolerance, d / tolerance);
        } catch (const std::exception& e) {
          cell.note = e.what();
        }
      }
      // Peers among themselves, at the scale of kanedyn's largest |z dot|.
      for (size_t a = 0; a < results.size(); ++a)
        for (size_t b = a + 1; b < results.size(); ++b) {
          const VectorX other = Eigen::Map<const VectorX>(
              results[b].data(), static_cast<Eigen::Index>(results[b].size()));
          spread = std::max(spread, relative_difference(results[a], other) *
                                        other.cwiseAbs().maxCoeff() / zdot.cwiseAbs().maxCoeff());
        }
    }
    std::cout << "# " << c.name << ": " << c.model.num_bodies() << " bodies, "
              << c.model.num_speeds() << " speeds; largest cond(M) "
              << (worst_condition > 0 ? format_sci(worst_condition) : std::string("not computed"))
              << "; largest difference between two peers' z dot " << format_sci(spread) << "\n";
    c.q = q0z0[0];
    c.z = q0z0[1];
    table[ci][0].difference = 0;

    // Timing at the first state, all columns interleaved.
    const JointedSystem sys = describe_jointed(c);
    std::vector<std::unique_ptr<JointedEngine>> engines(columns.size());
    std::vector<Runner> runners(columns.size());
    std::vector<Runner*> active;
    for (size_t ei = 0; ei < columns.size(); ++ei) {
      if (!table[ci][ei].note.empty()) continue;
      Runner& r = runners[ei];
      if (ei == 0) {
        r.run_batch = [&c, &ws, &zdot](long count) {
          for (long b = 0; b < count; ++b) ws.evaluate(c.q, c.z, zdot);
        };
      } else {
        engines[ei] = columns[ei].info->make(sys);
        JointedEngine& e = *engines[ei];
        r.run_batch = [&e](long count) {
          for (long b = 0; b < count; ++b) e.evaluate();
        };
      }
      const auto t0 = Clock::now();
      r.run_batch(1);
      r.first = seconds_since(t0);
      active.push_back(&r);
    }
    time_interleaved(active, opt.budget);
    for (size_t ei = 0; ei < columns.size(); ++ei) {
      Cell& cell = table[ci][ei];
      std::cout << "# " << c.name << " " << columns[ei].title << ": ";
      if (!cell.note.empty()) {
        std::cout << "not run: " << cell.note << "\n";
        continue;
      }
      cell.timing = statistics(runners[ei]);
      const bool agrees = cell.of_tolerance <= 1.0;
      all_agree = all_agree && agrees;
      std::cout << "median " << format_ns(cell.timing->median_ns) << " ns, min "
                << format_ns(cell.timing->min_ns) << " ns, " << cell.timing->evals << " evals";
      if (ei > 0)
        std::cout << "; rel. diff. of z dot " << format_sci(cell.difference) << " ("
                  << format_sci(cell.of_tolerance) << " of the tolerance)"
                  << (agrees ? "" : "  <-- DISAGREES");
      std::cout << "\n" << std::flush;
    }
  }

  auto ratio = [&](size_t ci, size_t ei, double Timing::*stat) -> std::string {
    const Cell& cell = table[ci][ei];
    const Cell& base = table[ci][0];
    if (!cell.timing || !base.timing) return "-";
    return ratio_text((*cell.timing).*stat / (*base.timing).*stat);
  };
  print_table(cases, columns,
              "Jointed models, median ns per evaluation:", [&](size_t ci, size_t ei) {
                const Cell& cell = table[ci][ei];
                return cell.timing ? format_ns(cell.timing->median_ns) : "(" + cell.note + ")";
              });
  print_table(cases, columns,
              "Jointed models, median time relative to kanedyn recursive (x slower):",
              [&](size_t ci, size_t ei) { return ratio(ci, ei, &Timing::median_ns); });
  print_table(cases, columns,
              "Jointed models, minimum time relative to kanedyn recursive (x slower):",
              [&](size_t ci, size_t ei) { return ratio(ci, ei, &Timing::min_ns); });
  print_table(cases, columns,
              "Jointed models, largest relative difference of the joint accelerations z dot "
              "from kanedyn's (over the random states):",
              [&](size_t ci, size_t ei) -> std::string {
                const Cell& cell = table[ci][ei];
                if (ei == 0) return "reference";
                if (!cell.note.empty()) return "-";
                return format_sci(cell.difference);
              });

  // The speed targets: on the jointed eight-body and the compared revolute chain, kanedyn's
  // recursive route at least 10x faster than DART and 20x faster than Simbody.
  std::cout << "\nJointed models, speed targets (same-run ratios, median / minimum):\n\n"
            << "| target | median ratio | minimum ratio | |\n|---|---:|---:|---|\n";
  const std::string chain = "revolute-chain-" + std::to_string(opt.chain);
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    const std::string& name = cases[ci]->name;
    if (name != "eight-body-jointed" && name != chain) continue;
    for (const auto& [key, factor] :
         {std::pair<std::string, double>{"dart", 10.0}, {"simbody", 20.0}}) {
      // An init-capture: clang 14 cannot capture a structured binding (a C++20 addition).
      const auto it = std::find_if(columns.begin(), columns.end(),
                                   [&k = key](const Column& col) { return col.key == k; });
      if (it == columns.end()) continue;
      const auto ei = static_cast<size_t>(it - columns.begin());
      const Cell& cell = table[ci][ei];
      const Cell& base = table[ci][0];
      std::cout << "| " << name << " recursive >= " << factor << "x faster than " << it->title
                << " | ";
      if (!cell.timing || !base.timing) {
        std::cout << "- | - | not measured |\n";
        continue;
      }
      const double med = cell.timing->median_ns / base.timing->median_ns;
      const double min = cell.timing->min_ns / base.timing->min_ns;
      std::cout << ratio_text(med) << "x | " << ratio_text(min) << "x | "
                << (med >= factor ? "met" : "NOT MET") << " |\n";
    }
  }
  std::cout << std::flush;
  if (!all_agree)
    std::cout << "\nSome engine's joint accelerations disagree with kanedyn's beyond the tolerance "
                 "(marked DISAGREES above).\n";
  return all_agree;
}

std::string per_body(double ns) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(ns < 100 ? 1 : 0) << ns;
  return s.str();
}

void scaling_section(const JointedOptions& opt) {
  std::cout << "\n## kanedyn Dynamics::evaluate (Route::recursive) on revolute chains\n"
            << "# median ns per evaluation and per body; a size is skipped when predicted (from "
               "the two sizes before it) above "
            << opt.max_eval_seconds << " s/eval\n\n"
            << "| links | n | median ns | ns per body | min ns | evals |\n"
            << "|---:|---:|---:|---:|---:|---:|\n"
            << std::flush;
  std::vector<std::pair<double, double>> measured;  // (links, seconds per evaluation)
  for (int n : opt.scaling_sizes) {
    double predicted = 0;
    if (!measured.empty()) {
      double p = 1;  // the exponent of the last two sizes, O(N) before there are two
      if (measured.size() >= 2) {
        const auto& [n1, t1] = measured[measured.size() - 2];
        const auto& [n2, t2] = measured.back();
        p = std::max(1.0, std::log(t2 / t1) / std::log(n2 / n1));
      }
      predicted = measured.back().second * std::pow(n / measured.back().first, p);
    }
    if (predicted > opt.max_eval_seconds) {
      std::cout << "| " << n << " | " << n << " | (predicted " << format_sci(predicted)
                << " s/eval) | - | - | - |\n"
                << std::flush;
      continue;
    }
    const std::unique_ptr<JointedCase> c = revolute_chain(n, opt.seed);
    std::mt19937 rng(opt.seed);
    random_joint_state(*c, rng);
    kanedyn::Dynamics ws(c->model, kanedyn::Route::recursive);
    VectorX zdot(c->model.num_speeds());
    Runner r;
    r.run_batch = [&](long count) {
      for (long b = 0; b < count; ++b) ws.evaluate(c->q, c->z, zdot);
    };
    const auto t0 = Clock::now();
    r.run_batch(1);
    r.first = seconds_since(t0);
    std::vector<Runner*> one{&r};
    time_interleaved(one, opt.budget);
    const Timing t = statistics(r);
    measured.emplace_back(n, t.median_ns * 1e-9);
    std::cout << "| " << n << " | " << c->model.num_speeds() << " | " << format_ns(t.median_ns)
              << " | " << per_body(t.median_ns / n) << " | " << format_ns(t.min_ns) << " | "
              << t.evals << " |\n"
              << std::flush;
  }
}

// kanedyn's inverse dynamics and mass matrix (Terms) beside the peers' own calls on the same
// models at the same state (the first random state of compare_section), with the forward
// dynamics of each as the reference of its ratios: first the results compared in kanedyn's z
// order and convention (at random joint accelerations in [-1, 1]), then every call timed in
// interleaved rounds.
bool terms_section(const JointedOptions& opt) {
  struct Engine {
    std::string title;
    std::optional<JointedEngineInfo> info;  // empty for kanedyn
  };
  std::vector<Engine> engines{{"kanedyn", std::nullopt}};
  for (const std::string& e : opt.engines) {
    std::optional<JointedEngineInfo> info;
    if (e == "simbody") info = simbody_jointed_engine();
#ifdef KANEDYN_PEERS_HAVE_DART
    if (e == "dart") info = dart_jointed_engine();
#endif
    if (info) engines.push_back({info->name + " " + info->version, info});
  }
  const std::vector<std::unique_ptr<JointedCase>> cases = make_cases(opt);
  if (cases.empty()) return true;
  std::cout << "\n## Inverse dynamics and mass matrix\n"
            << "# kanedyn Terms::inverse_dynamics and Terms::mass_matrix beside Simbody's "
               "calcResidualForceIgnoringConstraints (after realizing Dynamics for the applied "
               "forces) and calcM, and DART's Skeleton::computeInverseDynamics (bushings as "
               "external forces) and getMassMatrix; each engine's forward dynamics (as in the "
               "jointed section) in the same rounds. Results compared in kanedyn's z order "
               "and convention, relative to the largest |Q| and |M_ij|\n"
            << std::flush;
  constexpr int kCalls = 3;  // forward, inverse dynamics, mass matrix
  const char* call_names[kCalls] = {"forward", "inverse dynamics", "mass matrix"};
  // timing[case][engine][call]; difference[case][engine][0: Q, 1: M]
  std::vector<std::vector<std::array<std::optional<Timing>, kCalls>>> timing(
      cases.size(), std::vector<std::array<std::optional<Timing>, kCalls>>(engines.size()));
  std::vector<std::vector<std::array<double, 2>>> difference(
      cases.size(), std::vector<std::array<double, 2>>(engines.size(), {-1.0, -1.0}));
  bool all_agree = true;
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    JointedCase& c = *cases[ci];
    std::mt19937 rng(opt.seed);
    random_joint_state(c, rng);
    const int n = c.model.num_speeds();
    std::uniform_real_distribution<double> rate(-1.0, 1.0);
    const VectorX zdot = VectorX::NullaryExpr(n, [&] { return rate(rng); });
    kanedyn::Dynamics dyn(c.model, kanedyn::Route::recursive);
    kanedyn::Terms terms(c.model);
    VectorX Q(n), forward_zdot(n);
    kanedyn::MatrixX M(n, n);
    terms.inverse_dynamics(c.q, c.z, zdot, Q);
    terms.mass_matrix(c.q, M);
    const JointedSystem sys = describe_jointed(c);
    std::vector<std::unique_ptr<JointedEngine>> made(engines.size());
    std::vector<std::array<Runner, kCalls>> runners(engines.size());
    std::vector<Runner*> active;
    const std::vector<double> zdot_list(zdot.data(), zdot.data() + n);
    for (size_t ei = 0; ei < engines.size(); ++ei) {
      std::array<Runner, kCalls>& r = runners[ei];
      if (ei == 0) {
        r[0].run_batch = [&](long count) {
          for (long b = 0; b < count; ++b) dyn.evaluate(c.q, c.z, forward_zdot);
        };
        r[1].run_batch = [&](long count) {
          for (long b = 0; b < count; ++b) terms.inverse_dynamics(c.q, c.z, zdot, Q);
        };
        r[2].run_batch = [&](long count) {
          for (long b = 0; b < count; ++b) terms.mass_matrix(c.q, M);
        };
      } else {
        try {
          if (const std::string why = engines[ei].info->unsupported(sys); !why.empty())
            throw std::runtime_error(why);
          made[ei] = engines[ei].info->make(sys);
          JointedEngine& e = *made[ei];
          if (!e.has_terms()) throw std::runtime_error("no inverse dynamics here");
          e.set_zdot(zdot_list);
          e.inverse_dynamics();
          const std::vector<double> q = e.generalized_forces();
          difference[ci][ei][0] = relative_difference(q, Q);
          e.mass_matrix();
          const std::vector<double> m = e.mass_matrix_in_z();
          const Eigen::Map<const kanedyn::MatrixX> mm(m.data(), n, n);
          difference[ci][ei][1] = (mm - M).cwiseAbs().maxCoeff() / M.cwiseAbs().maxCoeff();
          all_agree = all_agree && difference[ci][ei][0] <= opt.tolerance &&
                      difference[ci][ei][1] <= opt.tolerance;
          r[0].run_batch = [&e](long count) {
            for (long b = 0; b < count; ++b) e.evaluate();
          };
          r[1].run_batch = [&e](long count) {
            for (long b = 0; b < count; ++b) e.inverse_dynamics();
          };
          r[2].run_batch = [&e](long count) {
            for (long b = 0; b < count; ++b) e.mass_matrix();
          };
        } catch (const std::exception& ex) {
          std::cout << "# " << c.name << " " << engines[ei].title << ": not run: " << ex.what()
                    << "\n";
          made[ei].reset();
          continue;
        }
      }
      for (Runner& one : r) {
        const auto t0 = Clock::now();
        one.run_batch(1);
        one.first = seconds_since(t0);
        active.push_back(&one);
      }
    }
    time_interleaved(active, opt.budget);
    for (size_t ei = 0; ei < engines.size(); ++ei) {
      if (ei > 0 && !made[ei]) continue;
      std::cout << "# " << c.name << " " << engines[ei].title << ":";
      for (int k = 0; k < kCalls; ++k) {
        timing[ci][ei][static_cast<size_t>(k)] = statistics(runners[ei][static_cast<size_t>(k)]);
        std::cout << " " << call_names[k] << " median "
                  << format_ns(timing[ci][ei][static_cast<size_t>(k)]->median_ns) << " ns, min "
                  << format_ns(timing[ci][ei][static_cast<size_t>(k)]->min_ns) << " ns;";
      }
      if (ei > 0)
        std::cout << " rel. diff. of Q " << format_sci(difference[ci][ei][0]) << ", of M "
                  << format_sci(difference[ci][ei][1]);
      std::cout << "\n" << std::flush;
    }
  }

  // One row per model: per engine, median ns of inverse dynamics and mass matrix and their
  // ratios to the engine's own forward dynamics.
  std::cout << "\nInverse dynamics (ID) and mass matrix (M), median ns per call, and per engine "
               "the ratio to its own forward dynamics (FD):\n\n| model | n |";
  for (const Engine& e : engines) std::cout << ' ' << e.title << " ID | M | ID/FD | M/FD |";
  std::cout << "\n|---|---:|";
  for (size_t i = 0; i < engines.size(); ++i) std::cout << "---:|---:|---:|---:|";
  std::cout << "\n";
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    std::cout << "| " << cases[ci]->name << " | " << cases[ci]->model.num_speeds() << " |";
    for (size_t ei = 0; ei < engines.size(); ++ei) {
      const auto& t = timing[ci][ei];
      if (!t[0]) {
        std::cout << " - | - | - | - |";
        continue;
      }
      std::cout << ' ' << format_ns(t[1]->median_ns) << " | " << format_ns(t[2]->median_ns) << " | "
                << ratio_text(t[1]->median_ns / t[0]->median_ns) << " | "
                << ratio_text(t[2]->median_ns / t[0]->median_ns) << " |";
    }
    std::cout << "\n";
  }
  std::cout << "\nInverse dynamics and mass matrix, median time relative to kanedyn's (x "
               "slower), and the largest relative difference of Q and of M from kanedyn's:\n\n"
               "| model | n |";
  for (size_t ei = 1; ei < engines.size(); ++ei)
    std::cout << ' ' << engines[ei].title << " ID | M | diff. Q | diff. M |";
  std::cout << "\n|---|---:|";
  for (size_t ei = 1; ei < engines.size(); ++ei) std::cout << "---:|---:|---:|---:|";
  std::cout << "\n";
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    std::cout << "| " << cases[ci]->name << " | " << cases[ci]->model.num_speeds() << " |";
    const auto& base = timing[ci][0];
    for (size_t ei = 1; ei < engines.size(); ++ei) {
      const auto& t = timing[ci][ei];
      if (!t[0]) {
        std::cout << " - | - | - | - |";
        continue;
      }
      std::cout << ' ' << ratio_text(t[1]->median_ns / base[1]->median_ns) << " | "
                << ratio_text(t[2]->median_ns / base[2]->median_ns) << " | "
                << format_sci(difference[ci][ei][0]) << " | " << format_sci(difference[ci][ei][1])
                << " |";
    }
    std::cout << "\n";
  }
  std::cout << std::flush;
  if (!all_agree)
    std::cout << "\nSome engine's Q or M differs from kanedyn's by more than "
              << format_sci(opt.tolerance) << ".\n";
  return all_agree;
}

}  // namespace

bool run_jointed_sections(const JointedOptions& opt) {
  bool ok = true;
  if (opt.compare) ok = compare_section(opt);
  if (opt.terms) ok = terms_section(opt) && ok;
  if (opt.scaling) scaling_section(opt);
  return ok;
}

}  // namespace peers
