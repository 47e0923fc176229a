// kanedyn_peers_trajectory: the same model integrated over time from the same initial state by
// kanedyn (kanedyn::simulate, dopri5 at a tight tolerance) and by peer engines with their own
// integrators (Simbody's error-controlled Runge-Kutta, MuJoCo's and DART's RK4); body motions
// compared at every output time. See docs/peers-trajectory.md.
//
// Every integration runs three times, at its setting and twice coarser (fixed-step
// integrators: step x2, x4; error-controlled ones: tolerance x10, x100). The differences
// between those runs give each integrator's own truncation error at its setting (Richardson
// extrapolation with the observed order of convergence), and the sum of kanedyn's and the
// peer's is the difference to expect between them. A peer agrees when its difference from
// kanedyn is within --safety times that (and never required below --floor, relative).
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "describe.hpp"
#include "jointed.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/integrate.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/simulate.hpp"
#include "kanedyn/testing/generate.hpp"
#include "peer.hpp"

namespace {

using kanedyn::Matrix3;
using kanedyn::Vector3;
using Clock = std::chrono::steady_clock;

struct Options {
  std::vector<std::string> models{"eight-body", "tree-8", "tree-64", "eight-body-jointed"};
  std::vector<std::string> engines{"simbody", "mujoco", "dart"};
  std::string eight_body = KANEDYN_SOURCE_DIR "/examples/eight_body.yaml";
  unsigned seed = 1;
  double t_end = 0;  // 0: the model's default
  double dt_out = 0.01;
  double rtol = 1e-12;  // kanedyn dopri5; atol = rtol * 1e-2
  std::string simbody_integrator = "rkmerson";
  double accuracy = 1e-9;  // Simbody
  std::string mujoco_integrator = "rk4";
  std::string dart_integrator = "rk4";
  double step = 0;  // MuJoCo and DART; 0: the model's default
  double safety = 10;
  double floor = 1e-11;
  double perturb = 0;
};

struct Case {
  std::string name;
  kanedyn::Model model;
  kanedyn::State state;
  double t_end = 1;  // defaults: the span and the fixed step of MuJoCo's and DART's RK4
  double step = 1e-4;
  std::shared_ptr<peers::JointedCase> jointed;  // a jointed tree at its state (model: its bodies)
};

/// One integrated motion: body poses at the output times.
struct Trajectory {
  std::vector<double> t;
  std::vector<std::vector<peers::BodyPose>> poses;  // [output time][body]
  long steps = 0;
  double seconds = 0;
};

/// Per-quantity numbers: mass-centre position, orientation angle, angular velocity,
/// mass-centre velocity (largest over output times and bodies).
struct Measures {
  double p = 0, angle = 0, w = 0, v = 0;
  double& operator[](int i) { return i == 0 ? p : i == 1 ? angle : i == 2 ? w : v; }
  double operator[](int i) const { return i == 0 ? p : i == 1 ? angle : i == 2 ? w : v; }
};
constexpr int kMeasures = 4;
const char* const kMeasureNames[kMeasures] = {"p_G", "angle", "w", "v_G"};

Vector3 vec(const peers::Vec3& a) { return {a[0], a[1], a[2]}; }
Matrix3 mat(const peers::Mat3& a) {
  Matrix3 m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = a[static_cast<size_t>(3 * r + c)];
  return m;
}

// The angle of R1^T R2, from |R1 - R2|_F = 2 sqrt(2) sin(angle / 2): accurate for small angles
// (acos of the trace is not).
double angle_between(const peers::Mat3& R1, const peers::Mat3& R2) {
  const double d = (mat(R1) - mat(R2)).norm() / (2.0 * std::sqrt(2.0));
  return 2.0 * std::asin(std::min(1.0, d));
}

Measures difference(const Trajectory& a, const Trajectory& b) {
  Measures m;
  for (size_t i = 0; i < a.poses.size(); ++i)
    for (size_t k = 0; k < a.poses[i].size(); ++k) {
      const peers::BodyPose& x = a.poses[i][k];
      const peers::BodyPose& y = b.poses[i][k];
      m.p = std::max(m.p, (vec(x.p_G) - vec(y.p_G)).norm());
      m.angle = std::max(m.angle, angle_between(x.R, y.R));
      m.w = std::max(m.w, (vec(x.w) - vec(y.w)).norm());
      m.v = std::max(m.v, (vec(x.v_G) - vec(y.v_G)).norm());
    }
  return m;
}

// The motion's scale: largest mass-centre displacement from the initial position, largest
// rotation from the initial orientation, largest angular velocity and mass-centre speed.
Measures motion_scale(const Trajectory& r) {
  Measures m;
  for (size_t i = 0; i < r.poses.size(); ++i)
    for (size_t k = 0; k < r.poses[i].size(); ++k) {
      const peers::BodyPose& x = r.poses[i][k];
      const peers::BodyPose& x0 = r.poses[0][k];
      m.p = std::max(m.p, (vec(x.p_G) - vec(x0.p_G)).norm());
      m.angle = std::max(m.angle, angle_between(x.R, x0.R));
      m.w = std::max(m.w, vec(x.w).norm());
      m.v = std::max(m.v, vec(x.v_G).norm());
    }
  return m;
}

/// An integration at its setting (level 0) and twice coarser, with the truncation error
/// estimated from them.
struct Convergence {
  Trajectory fine, coarse;  // levels 0 and 1
  Measures d01, d12;        // differences level 0 - level 1, level 1 - level 2
  Measures order;           // observed order per measure
  double used_order = 0;    // the smallest observed, clamped to [log_r 2, nominal]
  Measures error;           // estimated truncation error of level 0: d01 / (r^used_order - 1)
  long coarse_steps[2] = {0, 0};
  double seconds = 0;  // all three runs
};

// Richardson: with error e_l = C h_l^p and h_{l+1} = r h_l, d01 = e1 - e0 = (r^p - 1) e0 and
// d12 = r^p d01, so p = log_r(d12 / d01). The integrator has one order: the smallest observed
// over the four measures is used for all (a measure whose coarsest run is not yet in the
// asymptotic range shows a higher apparent order), clamped to at most the nominal order and at
// least log_r 2 (so e0 <= d01). Each of these choices can only make the estimate larger.
Convergence converge(std::vector<Trajectory> levels, double ratio, double nominal) {
  Convergence c;
  c.d01 = difference(levels[0], levels[1]);
  c.d12 = difference(levels[1], levels[2]);
  const double lo = std::log(2.0) / std::log(ratio);
  double p = nominal;
  for (int i = 0; i < kMeasures; ++i) {
    c.order[i] = nominal;
    if (c.d01[i] > 0 && c.d12[i] > 0) {
      c.order[i] = std::log(c.d12[i] / c.d01[i]) / std::log(ratio);
      p = std::min(p, c.order[i]);
    }
  }
  c.used_order = std::clamp(p, lo, std::max(lo, nominal));
  for (int i = 0; i < kMeasures; ++i) c.error[i] = c.d01[i] / (std::pow(ratio, c.used_order) - 1.0);
  c.coarse = levels[1];
  c.coarse_steps[0] = levels[1].steps;
  c.coarse_steps[1] = levels[2].steps;
  for (const Trajectory& l : levels) c.seconds += l.seconds;
  c.fine = std::move(levels[0]);
  return c;
}

// The difference from ref of the Richardson-extrapolated trajectory x0 + (x0 - x1) / (r^p - 1)
// (rotation matrices extrapolated entrywise: off orthogonality by the square of the
// correction, far below the differences of interest).
Measures extrapolated_difference(const Convergence& c, double ratio, const Trajectory& ref) {
  const double f = 1.0 / (std::pow(ratio, c.used_order) - 1.0);
  Measures m;
  for (size_t i = 0; i < ref.poses.size(); ++i)
    for (size_t k = 0; k < ref.poses[i].size(); ++k) {
      const peers::BodyPose& x0 = c.fine.poses[i][k];
      const peers::BodyPose& x1 = c.coarse.poses[i][k];
      const peers::BodyPose& y = ref.poses[i][k];
      auto ext = [f](const peers::Vec3& a, const peers::Vec3& b) {
        return Vector3(vec(a) + f * (vec(a) - vec(b)));
      };
      m.p = std::max(m.p, (ext(x0.p_G, x1.p_G) - vec(y.p_G)).norm());
      m.w = std::max(m.w, (ext(x0.w, x1.w) - vec(y.w)).norm());
      m.v = std::max(m.v, (ext(x0.v_G, x1.v_G) - vec(y.v_G)).norm());
      const Matrix3 R = mat(x0.R) + f * (mat(x0.R) - mat(x1.R));
      const double d = (R - mat(y.R)).norm() / (2.0 * std::sqrt(2.0));
      m.angle = std::max(m.angle, 2.0 * std::asin(std::min(1.0, d)));
    }
  return m;
}

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

Trajectory run_kanedyn_jointed(const peers::JointedCase& c, double t_end, double dt_out,
                               double rtol);

Trajectory run_kanedyn(const Case& c, double t_end, double dt_out, double rtol) {
  if (c.jointed) return run_kanedyn_jointed(*c.jointed, t_end, dt_out, rtol);
  kanedyn::SimulationSettings s;
  s.t_end = t_end;
  s.dt_out = dt_out;
  s.integrator = kanedyn::Integrator::dopri5;
  s.rtol = rtol;
  s.atol = rtol * 1e-2;
  Trajectory out;
  const int n = c.model.num_bodies();
  const auto t0 = Clock::now();
  const kanedyn::SimulationStats stats = kanedyn::simulate(
      c.model, c.state, s,
      [&](double t, const kanedyn::State& state, const kanedyn::VectorX&, const kanedyn::VectorX&,
          kanedyn::Data& data) {
        std::vector<peers::BodyPose> poses(static_cast<size_t>(n));
        for (int k = 0; k < n; ++k) {
          peers::BodyPose& p = poses[static_cast<size_t>(k)];
          const auto i = static_cast<size_t>(k);
          const Matrix3 Rt = data.kinematics.R[i].transpose();  // body-K components -> inertial
          for (int r = 0; r < 3; ++r) {
            p.p_G[static_cast<size_t>(r)] = data.kinematics.p_G[i][r];
            p.v_G[static_cast<size_t>(r)] = data.kinematics.v_G[i][r];
            for (int col = 0; col < 3; ++col) p.R[static_cast<size_t>(3 * r + col)] = Rt(r, col);
          }
          const Vector3 w = Rt * state.angular_velocity(k);
          p.w = {w.x(), w.y(), w.z()};
        }
        out.t.push_back(t);
        out.poses.push_back(std::move(poses));
      });
  out.seconds = seconds_since(t0);
  if (!stats.ok()) throw std::runtime_error("kanedyn: " + stats.message);
  out.steps = stats.steps_accepted;
  return out;
}

// The jointed tree integrated by kanedyn's Dopri5 on Dynamics::derivative (in (q; z)), poses at
// every dt_out from its continuous extension (Dynamics::unpack: joint coordinates normalized,
// then the notes' state), and the state's kinematics.
Trajectory run_kanedyn_jointed(const peers::JointedCase& c, double t_end, double dt_out,
                               double rtol) {
  kanedyn::Dynamics ws(c.model, kanedyn::Route::recursive);
  const int n = c.model.num_bodies();
  kanedyn::Dopri5Options options;
  options.rtol = rtol;
  options.atol = rtol * 1e-2;
  kanedyn::Dopri5 integrator(
      ws.size(),
      [&ws](double, const kanedyn::VectorX& x, kanedyn::VectorX& dx) { ws.derivative(x, dx); },
      options);
  kanedyn::VectorX x(ws.size()), q, z;
  ws.pack(c.q, c.z, x);
  kanedyn::State state(c.model);
  kanedyn::Data data(c.model, kanedyn::DataOptions::recursive_only());
  Trajectory out;
  auto record = [&](double t, const kanedyn::VectorX& at) {
    ws.unpack(at, true, q, z, state);
    kanedyn::compute_kinematics(c.model, state, data);
    std::vector<peers::BodyPose> poses(static_cast<size_t>(n));
    for (int k = 0; k < n; ++k) {
      peers::BodyPose& p = poses[static_cast<size_t>(k)];
      const auto i = static_cast<size_t>(k);
      const Matrix3 Rt = data.kinematics.R[i].transpose();  // body-K components -> inertial
      for (int r = 0; r < 3; ++r) {
        p.p_G[static_cast<size_t>(r)] = data.kinematics.p_G[i][r];
        p.v_G[static_cast<size_t>(r)] = data.kinematics.v_G[i][r];
        for (int col = 0; col < 3; ++col) p.R[static_cast<size_t>(3 * r + col)] = Rt(r, col);
      }
      const Vector3 w = Rt * state.angular_velocity(k);
      p.w = {w.x(), w.y(), w.z()};
    }
    out.t.push_back(t);
    out.poses.push_back(std::move(poses));
  };
  const auto t0 = Clock::now();
  if (integrator.start(0.0, x, t_end) != kanedyn::StepStatus::ok)
    throw std::runtime_error("kanedyn: the jointed initial state is not finite");
  record(0.0, x);
  const long outputs = std::lround(t_end / dt_out);
  kanedyn::VectorX at(ws.size());
  for (long i = 1; i <= outputs; ++i) {
    const double t = i == outputs ? t_end : static_cast<double>(i) * dt_out;
    while (integrator.time() < t)
      if (integrator.step() != kanedyn::StepStatus::ok)
        throw std::runtime_error("kanedyn: the jointed integration failed at t = " +
                                 std::to_string(integrator.time()));
    integrator.dense_output(t, at);
    record(t, at);
  }
  out.seconds = seconds_since(t0);
  out.steps = integrator.steps_accepted();
  return out;
}

// A jointed engine as the free-body interface the comparison drives (trajectories only).
class JointedAsEngine final : public peers::Engine {
 public:
  explicit JointedAsEngine(std::unique_ptr<peers::JointedEngine> e) : e_(std::move(e)) {}
  void evaluate() override { e_->evaluate(); }
  std::vector<peers::BodyMotion> motion() override { return {}; }
  peers::IntegratorInfo start(const peers::IntegratorSettings& s) override { return e_->start(s); }
  void advance_to(double t) override { e_->advance_to(t); }
  std::vector<peers::BodyPose> pose() override { return e_->pose(); }
  long steps() const override { return e_->steps(); }

 private:
  std::unique_ptr<peers::JointedEngine> e_;
};

Trajectory run_peer(peers::Engine& engine, const peers::IntegratorSettings& settings,
                    const std::vector<double>& times, peers::IntegratorInfo* info) {
  Trajectory out;
  const auto t0 = Clock::now();
  *info = engine.start(settings);
  for (double t : times) {
    if (t > 0) engine.advance_to(t);
    out.t.push_back(t);
    out.poses.push_back(engine.pose());
  }
  out.seconds = seconds_since(t0);
  out.steps = engine.steps();
  return out;
}

std::vector<Case> make_cases(const Options& opt) {
  std::vector<Case> cases;
  for (const std::string& name : opt.models) {
    if (name == "eight-body-jointed") {
      std::shared_ptr<peers::JointedCase> j = peers::jointed_eight_body(opt.eight_body);
      std::mt19937 rng(opt.seed);
      peers::random_joint_state(*j, rng);
      kanedyn::State state(j->model);
      kanedyn::joint_state(j->model, j->q, j->z, state);
      // 0.5 s: several swings of the stiffest joint (the lumbar spring, about 100 rad/s) from
      // a random state; RK4 at 1e-4 s has omega h ~ 0.01 there.
      cases.push_back({name, j->model, std::move(state), 0.5, 1e-4, j});
      continue;
    }
    if (name == "eight-body") {
      if (!std::filesystem::exists(opt.eight_body))
        throw std::runtime_error(opt.eight_body + " not found");
      kanedyn::io::ModelFile f = kanedyn::io::load_model_file(opt.eight_body);
      // 2 s: the motion the initial state starts (the forearm swings through 2.3 rad, the head
      // twists at up to 20 rad/s) has mostly decayed. Fixed step 1e-4 s: the three runs (1e-4,
      // 2e-4, 4e-4 s) converge at the same order in all four measures (asymptotic range).
      cases.push_back({name, std::move(f.model), std::move(f.initial), 2.0, 1e-4, nullptr});
      continue;
    }
    const auto dash = name.find('-');
    const std::string family = name.substr(0, dash);
    int n = 0;
    try {
      n = dash == std::string::npos ? 0 : std::stoi(name.substr(dash + 1));
    } catch (const std::exception&) {
      n = 0;
    }
    if ((family != "tree" && family != "chain") || n < 1)
      throw std::runtime_error("unknown model '" + name + "' (eight-body, tree-N, chain-N)");
    kanedyn::GeneratedSystem g = family == "chain" ? kanedyn::chain_model(n, opt.seed)
                                                   : kanedyn::random_tree_model(n, opt.seed);
    // 1 s: most of a swing of the links under gravity. The thinnest, lightest generated links
    // twist about their long axis at up to ~1400 rad/s on their rotational bushings
    // (sqrt(100 / 5.2e-5)); at 2e-5 s the coarsest run (8e-5 s) still has omega h ~ 0.1 and
    // the three runs converge at the same order in all measures (at 1e-4 s the angular
    // velocity of the 4e-4 s run is not yet asymptotic, which the estimate allows for).
    cases.push_back({name, std::move(g.model), std::move(g.initial), 1.0, 2e-5, nullptr});
  }
  return cases;
}

std::string sci(double x, int digits = 1) {
  std::ostringstream s;
  s << std::scientific << std::setprecision(digits) << x;
  return s.str();
}

std::string fixed(double x, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << x;
  return s.str();
}

std::string machine_model() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown CPU";
}

struct Row {
  std::string model, engine, integrator;
  int n = 0;
  double t_end = 0;
  long steps = 0;
  Measures relative_difference, relative_expected, relative_tolerance;
  double worst = 0;  // largest difference / tolerance
  bool ok = false;
  std::string note;  // why there is no result
};

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{
      "Trajectories of the same models in kanedyn and in Simbody, MuJoCo and DART with their "
      "own integrators; body motions compared at every output time"};
  app.add_option("--models", opt.models, "eight-body, tree-N, chain-N, eight-body-jointed")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--engines", opt.engines, "simbody, mujoco, dart")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--eight-body", opt.eight_body, "Model file of the eight-body example")
      ->capture_default_str();
  app.add_option("--seed", opt.seed, "Seed of the generated models")->capture_default_str();
  app.add_option("--t-end", opt.t_end,
                 "End time, s (0: per model, 2 s for eight-body, 1 s for generated ones, 0.5 s for "
                 "eight-body-jointed)")
      ->capture_default_str();
  app.add_option("--dt-out", opt.dt_out, "Interval between compared output times, s")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--rtol", opt.rtol, "kanedyn: dopri5 relative tolerance (atol = rtol / 100)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--simbody-integrator", opt.simbody_integrator, "rkmerson, rkf, rk3, cpodes")
      ->capture_default_str();
  app.add_option("--accuracy", opt.accuracy, "Simbody: the integrator's accuracy")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--mujoco-integrator", opt.mujoco_integrator, "rk4, euler")->capture_default_str();
  app.add_option("--dart-integrator", opt.dart_integrator,
                 "rk4 (dart::integration::RK4Integrator), euler (World::step's semi-implicit "
                 "Euler), rk4-se3 (diagnostic: textbook RK4, FreeJoints by the SE(3) "
                 "exponential)")
      ->capture_default_str();
  app.add_option("--step", opt.step,
                 "MuJoCo and DART: the fixed step, s (0: per model, 1e-4 s for eight-body, "
                 "2e-5 s for generated ones)")
      ->capture_default_str();
  app.add_option("--safety", opt.safety,
                 "Accept differences up to this many times the integrators' estimated "
                 "truncation error")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--floor", opt.floor, "Never require a relative difference below this (round-off)")
      ->capture_default_str();
  app.add_option("--perturb", opt.perturb,
                 "Change the last body's mass in the peers' model by this fraction (to see "
                 "that the check detects a model difference)")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  {
    const std::time_t now = std::time(nullptr);
    char date[32];
    std::strftime(date, sizeof date, "%Y-%m-%d %H:%M", std::localtime(&now));
    std::cout << "# kanedyn_peers_trajectory, " << date << ", " << machine_model() << "\n"
              << "# every integration also runs twice coarser (step x2, x4; tolerance x10, x100) "
                 "to estimate its truncation error; tolerance "
              << opt.safety << " x (kanedyn's + peer's), at least " << sci(opt.floor)
              << " relative\n";
    if (opt.perturb != 0)
      std::cout << "# --perturb " << opt.perturb
                << ": the peers' last body is heavier by that fraction; they should DISAGREE\n";
    std::cout << std::flush;
  }

  std::vector<peers::EngineInfo> engines;
  std::vector<peers::JointedEngineInfo> jointed_engines;  // the same engines, for jointed trees
  std::vector<std::string> engine_keys;
  for (const std::string& e : opt.engines) {
    if (e == "simbody") {
      engines.push_back(peers::simbody_engine());
      jointed_engines.push_back(peers::simbody_jointed_engine());
    } else if (e == "mujoco") {
      engines.push_back(peers::mujoco_engine());
      jointed_engines.push_back(peers::mujoco_jointed_engine());
    }
#ifdef KANEDYN_PEERS_HAVE_DART
    else if (e == "dart") {
      engines.push_back(peers::dart_engine());
      jointed_engines.push_back(peers::dart_jointed_engine());
    }
#else
    else if (e == "dart") {
      std::cerr << "kanedyn_peers_trajectory: built without DART; dart skipped\n";
      continue;
    }
#endif
    else {
      std::cerr << "kanedyn_peers_trajectory: unknown engine '" << e << "'\n";
      return 1;
    }
    engine_keys.push_back(e);
  }

  std::vector<Row> rows;
  bool all_agree = true;
  try {
    for (const Case& c : make_cases(opt)) {
      const double t_end = opt.t_end > 0 ? opt.t_end : c.t_end;
      const double step = opt.step > 0 ? opt.step : c.step;
      const int n = c.model.num_bodies();

      // kanedyn at rtol, 10 rtol, 100 rtol; the output times of the first are everyone's.
      std::vector<Trajectory> levels;
      for (double f : {1.0, 10.0, 100.0})
        levels.push_back(run_kanedyn(c, t_end, opt.dt_out, opt.rtol * f));
      const Convergence kd = converge(std::move(levels), 10.0, 1.0);
      const std::vector<double>& times = kd.fine.t;
      const Measures scale = motion_scale(kd.fine);
      std::cout << "\n# " << c.name << ": " << n << " bodies, t = 0 to " << t_end << " s, "
                << times.size() << " output times\n"
                << "#   motion's scale: mass-centre displacement " << sci(scale.p, 2)
                << " m, rotation " << sci(scale.angle, 2) << " rad, |w| " << sci(scale.w, 2)
                << " rad/s, |v_G| " << sci(scale.v, 2) << " m/s\n"
                << "#   kanedyn dopri5 rtol " << sci(opt.rtol, 0) << " (atol "
                << sci(opt.rtol * 1e-2, 0) << "): " << kd.fine.steps << " steps ("
                << kd.coarse_steps[0] << ", " << kd.coarse_steps[1] << " at x10, x100), "
                << fixed(kd.seconds, 2) << " s; estimated error (rel.)";
      for (int i = 0; i < kMeasures; ++i)
        std::cout << ' ' << kMeasureNames[i] << ' ' << sci(kd.error[i] / scale[i]);
      std::cout << "\n" << std::flush;

      peers::System sys;
      peers::JointedSystem jointed_sys;
      if (c.jointed) {
        jointed_sys = peers::describe_jointed(*c.jointed);
        if (opt.perturb != 0) jointed_sys.bodies.back().mass *= 1.0 + opt.perturb;
      } else {
        sys = peers::describe(c.name, c.model, c.state);
        if (opt.perturb != 0) sys.bodies.back().mass *= 1.0 + opt.perturb;
      }

      for (size_t ei = 0; ei < engines.size(); ++ei) {
        const peers::EngineInfo& info = engines[ei];
        Row row;
        row.model = c.name;
        row.n = n;
        row.t_end = t_end;
        row.engine = info.name + " " + info.version;
        peers::IntegratorSettings settings;
        const std::string& key = engine_keys[ei];
        settings.method = key == "simbody"  ? opt.simbody_integrator
                          : key == "mujoco" ? opt.mujoco_integrator
                                            : opt.dart_integrator;
        settings.accuracy = opt.accuracy;
        settings.step = step;
        try {
          const std::unique_ptr<peers::Engine> engine =
              c.jointed ? std::make_unique<JointedAsEngine>(jointed_engines[ei].make(jointed_sys))
                        : info.make(sys);
          peers::IntegratorInfo integrator;
          std::vector<Trajectory> peer_levels;
          peer_levels.push_back(run_peer(*engine, settings, times, &integrator));
          if (integrator.description.empty()) {
            row.note = "cannot integrate";
            rows.push_back(row);
            continue;
          }
          row.integrator = integrator.description;
          const double ratio = integrator.fixed_step ? 2.0 : 10.0;
          for (int l = 1; l <= 2; ++l) {
            peers::IntegratorSettings coarse = settings;
            if (integrator.fixed_step)
              coarse.step *= std::pow(ratio, l);
            else
              coarse.accuracy *= std::pow(ratio, l);
            peers::IntegratorInfo unused;
            peer_levels.push_back(run_peer(*engine, coarse, times, &unused));
          }
          const Convergence pc = converge(std::move(peer_levels), ratio, integrator.order);
          const Measures diff = difference(pc.fine, kd.fine);
          row.steps = pc.fine.steps;
          row.ok = true;
          for (int i = 0; i < kMeasures; ++i) {
            const double expected = kd.error[i] + pc.error[i];
            const double tolerance = opt.safety * std::max(expected, opt.floor * scale[i]);
            row.relative_difference[i] = diff[i] / scale[i];
            row.relative_expected[i] = expected / scale[i];
            row.relative_tolerance[i] = tolerance / scale[i];
            row.worst = std::max(row.worst, diff[i] / tolerance);
            row.ok = row.ok && diff[i] <= tolerance;
          }
          all_agree = all_agree && row.ok;
          std::cout << "#   " << row.engine << ", " << row.integrator << ": " << row.steps
                    << " steps (" << pc.coarse_steps[0] << ", " << pc.coarse_steps[1]
                    << (integrator.fixed_step ? " at step x2, x4" : " at accuracy x10, x100")
                    << "), " << fixed(pc.seconds, 2) << " s\n";
          auto line = [&](const char* title, const Measures& m) {
            std::cout << "#     " << std::left << std::setw(22) << title << std::right;
            for (int i = 0; i < kMeasures; ++i)
              std::cout << ' ' << kMeasureNames[i] << ' ' << sci(m[i]);
            std::cout << "\n";
          };
          line("difference (rel.)", row.relative_difference);
          Measures peer_error, order;
          for (int i = 0; i < kMeasures; ++i) {
            peer_error[i] = pc.error[i] / scale[i];
            order[i] = pc.order[i];
          }
          line("peer's error (rel.)", peer_error);
          std::cout << "#     " << std::left << std::setw(22) << "observed order" << std::right;
          for (int i = 0; i < kMeasures; ++i)
            std::cout << ' ' << kMeasureNames[i] << ' ' << fixed(order[i], 2);
          std::cout << "  (nominal " << integrator.order << ", used " << fixed(pc.used_order, 2)
                    << ")\n";
          line("expected (rel.)", row.relative_expected);
          Measures extrapolated = extrapolated_difference(pc, ratio, kd.fine);
          for (int i = 0; i < kMeasures; ++i) extrapolated[i] /= scale[i];
          line("extrapolated diff.", extrapolated);
          line("tolerance (rel.)", row.relative_tolerance);
          std::cout << "#     " << (row.ok ? "agrees" : "DISAGREES") << ": largest difference "
                    << fixed(row.worst, 3) << " of the tolerance\n"
                    << std::flush;
        } catch (const std::invalid_argument&) {
          throw;  // a setting the engine does not accept: a usage error (exit code 1)
        } catch (const std::exception& e) {
          row.note = e.what();
          row.ok = false;
          all_agree = false;
          std::cout << "#   " << row.engine << ": failed: " << e.what() << "\n" << std::flush;
        }
        rows.push_back(row);
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "kanedyn_peers_trajectory: " << e.what() << "\n";
    return 1;
  }

  std::cout << "\nLargest differences from kanedyn over the run, relative to the motion's scale "
               "(expected from the integrators' truncation errors in parentheses):\n\n"
            << "| model | N | T (s) | engine | integrator | steps |";
  for (const char* name : kMeasureNames) std::cout << ' ' << name << " |";
  std::cout << " diff / tolerance |\n|---|---:|---:|---|---|---:|";
  for (int i = 0; i < kMeasures; ++i) std::cout << "---:|";
  std::cout << "---:|\n";
  for (const Row& r : rows) {
    std::cout << "| " << r.model << " | " << r.n << " | " << r.t_end << " | " << r.engine << " | "
              << (r.note.empty() ? r.integrator : r.note) << " | " << r.steps << " |";
    for (int i = 0; i < kMeasures; ++i)
      std::cout << ' '
                << (r.note.empty()
                        ? sci(r.relative_difference[i]) + " (" + sci(r.relative_expected[i]) + ")"
                        : "-")
                << " |";
    std::cout << ' ' << (r.note.empty() ? fixed(r.worst, 3) : "-") << (r.ok ? "" : " DISAGREES")
              << " |\n";
  }
  if (!all_agree) {
    std::cout << "\nSome engine's trajectory disagrees with kanedyn's beyond the tolerance.\n";
    return 2;
  }
  return 0;
}
