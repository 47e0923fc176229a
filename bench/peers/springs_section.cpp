// kanedyn_peers' springs section (springs_section.hpp).
#include "springs_section.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <iostream>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "jointed.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/simulate.hpp"
#include "kanedyn/testing/generate.hpp"
#include "peer.hpp"

namespace peers {
namespace {

using kanedyn::Joint;
using kanedyn::JointType;
using kanedyn::Matrix3;
using kanedyn::Vector3;
using kanedyn::VectorX;

VectorX vec(const std::vector<double>& v) {
  return Eigen::Map<const VectorX>(v.data(), static_cast<Eigen::Index>(v.size()));
}

// One spring of a model: body, point, other body (kGround) and point, k, c, L0.
struct SpringData {
  int body;
  Vector3 at;
  int other;
  Vector3 other_at;
  double k, c, l0;
};

std::vector<std::shared_ptr<const kanedyn::ForceElement>> springs(
    const std::vector<SpringData>& list, bool damped) {
  std::vector<std::shared_ptr<const kanedyn::ForceElement>> out;
  for (const SpringData& s : list)
    out.push_back(std::make_shared<const kanedyn::Spring>(s.body, s.at, s.other, s.other_at, s.k,
                                                          damped ? s.c : 0.0, s.l0));
  return out;
}

kanedyn::BodySpec body(const std::string& name, double mass, const Matrix3& inertia,
                       const Vector3& com, const Vector3& joint) {
  kanedyn::BodySpec b;
  b.name = name;
  b.mass = mass;
  b.inertia = inertia;
  b.com = com;
  b.joint = joint;
  return b;
}

Matrix3 inertia(double a, double b, double c, double ab, double ac, double bc) {
  Matrix3 m;
  m << a, ab, ac, ab, b, bc, ac, bc, c;
  return m;
}

// Three free bodies (roots) under gravity: a hangs from the ground, b from a, c from b and from
// a second ground point, a and c joined too. Every spring joins off-centre points (not the mass
// centres, so the springs turn the bodies) and has a rest length well below its length at the
// states used, so none comes near L = 0.
std::unique_ptr<JointedCase> three_free_bodies(bool damped) {
  const int g = kanedyn::kGround;
  std::vector<kanedyn::BodySpec> bodies{
      body("a", 1.2, inertia(0.020, 0.030, 0.025, 0.002, -0.001, 0.0015), {0.03, -0.01, 0.02},
           {0.0, 0.0, -0.4}),
      body("b", 0.8, inertia(0.012, 0.009, 0.015, -0.001, 0.0005, 0.001), {-0.02, 0.02, -0.01},
           {0.35, 0.1, -0.8}),
      body("c", 1.5, inertia(0.040, 0.035, 0.020, 0.003, 0.002, -0.002), {0.01, 0.03, -0.02},
           {-0.3, -0.15, -1.1})};
  const std::vector<SpringData> list{
      {0, {0.05, 0.02, 0.08}, g, {0.0, 0.0, 0.0}, 120, 0.8, 0.3},
      {0, {0.04, -0.06, -0.07}, 1, {-0.05, 0.03, 0.06}, 80, 0.5, 0.35},
      {1, {0.06, 0.05, -0.04}, 2, {0.02, -0.07, 0.05}, 60, 0.4, 0.5},
      {2, {-0.05, 0.04, 0.07}, g, {-0.4, 0.2, -0.3}, 40, 0.3, 0.6},
      {0, {-0.06, 0.05, -0.03}, 2, {0.07, 0.01, 0.03}, 30, 0.2, 0.7}};
  const std::string name = damped ? "three-free-bodies" : "three-free-bodies-undamped";
  const kanedyn::Model m(bodies, Vector3(0, 0, -9.81), springs(list, damped), name);
  Joint free;
  free.type = JointType::free;
  auto c =
      std::make_unique<JointedCase>(name, m, std::vector<Joint>(3, free),
                                    std::vector<std::shared_ptr<const kanedyn::ForceElement>>{});
  return c;
}

// Three links of kanedyn::chain_model (0.5 m boxes hanging along -z) on revolute joints, the
// axes alternating between y and x, no joint loads: a spring from a ground point to the first
// link, one between the first and the third link, one from a lower ground point to the third.
std::unique_ptr<JointedCase> pin_chain(bool damped, unsigned seed) {
  const int g = kanedyn::kGround;
  const kanedyn::GeneratedSystem chain = kanedyn::chain_model(3, seed);
  const std::vector<SpringData> list{
      {0, {0.03, 0.02, -0.35}, g, {0.4, 0.1, -0.2}, 150, 1.0, 0.25},
      {0, {-0.02, 0.025, -0.1}, 2, {0.02, -0.02, -0.3}, 90, 0.6, 0.6},
      {2, {0.0, 0.025, -0.45}, g, {-0.3, -0.2, -1.9}, 70, 0.5, 0.3}};
  const std::string name = damped ? "pin-chain-3" : "pin-chain-3-undamped";
  const kanedyn::Model m(chain.model.bodies(), Vector3(0, 0, -9.81), springs(list, damped), name);
  std::vector<Joint> joints(3);
  for (int k = 0; k < 3; ++k) {
    joints[static_cast<size_t>(k)].type = JointType::revolute;
    joints[static_cast<size_t>(k)].axis = k % 2 == 0 ? Vector3::UnitY() : Vector3::UnitX();
  }
  return std::make_unique<JointedCase>(name, m, joints,
                                       std::vector<std::shared_ptr<const kanedyn::ForceElement>>{});
}

std::unique_ptr<JointedCase> make_case(int which, bool damped, unsigned seed) {
  return which == 0 ? three_free_bodies(damped) : pin_chain(damped, seed);
}

// The shortest spring at the case's state, to show that no spring is near L = 0 (where its
// direction is undefined).
double shortest_spring(const JointedCase& c) {
  const JointedSystem sys = describe_jointed(c);
  kanedyn::Data data(c.model);
  kanedyn::State state(c.model);
  kanedyn::joint_state(c.model, c.q, c.z, state);
  kanedyn::compute_kinematics(c.model, state, data);
  const kanedyn::Kinematics& kin = data.kinematics;
  double shortest = INFINITY;
  auto point = [&](int k, const Vec3& at) -> Vector3 {  // inertial, from the origin
    const Vector3 p(at[0], at[1], at[2]);
    if (k < 0) return p;
    return kin.p_O[static_cast<size_t>(k)] + kin.R[static_cast<size_t>(k)].transpose() * p;
  };
  for (const SpringSpec& s : sys.springs)
    shortest = std::min(shortest, (point(s.other, s.other_at) - point(s.body, s.at)).norm());
  return shortest;
}

// One integrated motion: joint coordinates, speeds and the energies at the output times.
struct Run {
  std::vector<double> t;
  std::vector<VectorX> q, z;
  std::vector<double> energy, kinetic;
  long steps = 0;
  double seconds = 0;
  std::string description;
};

Run run_kanedyn(const JointedCase& c, const SpringOptions& opt, double rtol) {
  kanedyn::SimulationSettings s;
  s.t_end = opt.t_end;
  s.dt_out = opt.dt_out;
  s.integrator = kanedyn::Integrator::dopri5;
  s.rtol = rtol;
  s.atol = rtol * 1e-2;
  s.observer_kinematics = false;
  Run run;
  const auto t0 = Clock::now();
  const kanedyn::SimulationStats stats = kanedyn::simulate(
      c.model, c.q, c.z, s,
      [&](double t, const kanedyn::State&, const VectorX& q, const VectorX& z, kanedyn::Data&) {
        run.t.push_back(t);
        run.q.push_back(q);
        run.z.push_back(z);
      });
  run.seconds = seconds_since(t0);
  if (!stats.ok()) throw std::runtime_error("kanedyn: " + stats.message);
  run.steps = stats.steps_accepted;
  kanedyn::Data data(c.model);
  for (size_t i = 0; i < run.t.size(); ++i) {
    run.energy.push_back(kanedyn::total_energy(c.model, run.q[i], run.z[i], data));
    run.kinetic.push_back(kanedyn::kinetic_energy(c.model, run.q[i], run.z[i], data));
  }
  run.description = "dopri5 rtol " + format_sci(rtol);
  return run;
}

Run run_simbody(const JointedSystem& sys, double accuracy, const std::vector<double>& times) {
  const std::unique_ptr<JointedEngine> engine = simbody_jointed_engine().make(sys);
  IntegratorSettings settings;
  settings.accuracy = accuracy;
  Run run;
  const auto t0 = Clock::now();
  run.description = engine->start(settings).description;
  std::vector<double> q, z, r;
  for (const double t : times) {
    if (t > 0) engine->advance_to(t);
    engine->integrated_state(q, z, r);
    run.t.push_back(t);
    run.q.push_back(vec(q));
    run.z.push_back(vec(z));
    run.energy.push_back(engine->energy());
  }
  run.seconds = seconds_since(t0);
  run.steps = engine->steps();
  return run;
}

// The largest difference between two joint-coordinate vectors: per scalar coordinate its
// difference (rad or m), per orientation in Euler parameters (a free joint's) the angle between
// the two, 4 asin(|e - e'| / 2) with the sign of e' that makes it smaller.
double coordinate_difference(const kanedyn::Model& m, const VectorX& a, const VectorX& b) {
  double worst = 0;
  for (int k = 0; k < m.num_bodies(); ++k) {
    const int o = m.coordinate_offset(k), n = m.coordinate_offset(k + 1) - o;
    int first_scalar = 0;
    if (m.joint(k).type == JointType::free) {
      const kanedyn::Vector4 e = a.segment<4>(o), f = b.segment<4>(o);
      const double chord = std::min((e - f).norm(), (e + f).norm());
      worst = std::max(worst, 4.0 * std::asin(std::min(1.0, chord / 2.0)));
      first_scalar = 4;
    }
    for (int i = first_scalar; i < n; ++i) worst = std::max(worst, std::abs(a[o + i] - b[o + i]));
  }
  return worst;
}

struct Differences {
  double coordinates = 0, speeds = 0, energy = 0;  // energy relative to the scale
};

Differences compare(const kanedyn::Model& m, const Run& a, const Run& b, double energy_scale) {
  Differences d;
  for (size_t i = 0; i < a.t.size(); ++i) {
    d.coordinates = std::max(d.coordinates, coordinate_difference(m, a.q[i], b.q[i]));
    d.speeds = std::max(d.speeds, (a.z[i] - b.z[i]).cwiseAbs().maxCoeff());
    d.energy = std::max(d.energy, std::abs(a.energy[i] - b.energy[i]) / energy_scale);
  }
  return d;
}

// max_t |E(t) - E(0)|, relative to the scale.
double drift(const Run& run, double energy_scale) {
  double worst = 0;
  for (const double e : run.energy) worst = std::max(worst, std::abs(e - run.energy.front()));
  return worst / energy_scale;
}

struct Row {
  std::string name;
  int bodies = 0, speeds = 0, springs = 0;
  double zdot = 0, shortest = INFINITY;
  Timing ours, theirs;
  Differences run, self_simbody, self_kanedyn;
  double drift_kanedyn = 0, drift_simbody = 0, energy_definition = 0;
  long steps_kanedyn = 0, steps_simbody = 0;
  bool agrees = false;
};

Row compare_model(int which, const SpringOptions& opt) {
  Row row;
  // Accelerations of the damped model at random states, each engine built at each state.
  const std::unique_ptr<JointedCase> damped = make_case(which, true, opt.seed);
  JointedCase& c = *damped;
  row.name = c.name;
  row.bodies = c.model.num_bodies();
  row.speeds = c.model.num_speeds();
  kanedyn::Dynamics dynamics(c.model, kanedyn::Route::recursive);
  VectorX zdot(c.model.num_speeds());
  std::mt19937 rng(opt.seed);
  VectorX q_first, z_first;
  for (int s = 0; s < opt.states; ++s) {
    random_joint_state(c, rng);
    if (s == 0) {
      q_first = c.q;
      z_first = c.z;
    }
    row.shortest = std::min(row.shortest, shortest_spring(c));
    dynamics.evaluate(c.q, c.z, zdot);
    const JointedSystem sys = describe_jointed(c);
    row.springs = static_cast<int>(sys.springs.size());
    const std::unique_ptr<JointedEngine> engine = simbody_jointed_engine().make(sys);
    engine->evaluate();
    const VectorX theirs = vec(engine->zdot());
    row.zdot = std::max(row.zdot, (theirs - zdot).cwiseAbs().maxCoeff() /
                                      std::max(1.0, zdot.cwiseAbs().maxCoeff()));
  }

  // Timing at the first state, interleaved.
  c.q = q_first;
  c.z = z_first;
  const JointedSystem sys = describe_jointed(c);
  const std::unique_ptr<JointedEngine> engine = simbody_jointed_engine().make(sys);
  Runner ours, theirs;
  ours.run_batch = [&](long count) {
    for (long b = 0; b < count; ++b) dynamics.evaluate(c.q, c.z, zdot);
  };
  theirs.run_batch = [&](long count) {
    for (long b = 0; b < count; ++b) engine->evaluate();
  };
  std::vector<Runner*> runners{&ours, &theirs};
  for (Runner* r : runners) {
    const auto t0 = Clock::now();
    r->run_batch(1);
    r->first = seconds_since(t0);
  }
  time_interleaved(runners, opt.budget);
  row.ours = statistics(ours);
  row.theirs = statistics(theirs);
  std::cout << "# " << c.name << ": " << row.bodies << " bodies, " << row.speeds << " speeds, "
            << row.springs << " springs (damped); z dot at " << opt.states
            << " random states: largest rel. diff. " << format_sci(row.zdot) << " (tolerance "
            << format_sci(opt.tolerance) << "); shortest spring " << row.shortest
            << " m; per evaluation: kanedyn " << format_ns(row.ours.median_ns) << " ns, Simbody "
            << format_ns(row.theirs.median_ns) << " ns (median), Simbody / kanedyn "
            << format_ratio(row.theirs.median_ns / row.ours.median_ns) << "\n"
            << std::flush;

  // The undamped model from the first state, integrated by both; each engine also at 10 times
  // its tolerance, whose difference from its own run shows the size of its integration error.
  const std::unique_ptr<JointedCase> undamped = make_case(which, false, opt.seed);
  undamped->q = q_first;
  undamped->z = z_first;
  const JointedSystem free_sys = describe_jointed(*undamped);
  const Run k = run_kanedyn(*undamped, opt, opt.rtol);
  const Run k_coarse = run_kanedyn(*undamped, opt, 10 * opt.rtol);
  const Run s = run_simbody(free_sys, opt.accuracy, k.t);
  const Run s_coarse = run_simbody(free_sys, 10 * opt.accuracy, k.t);
  const double scale = *std::max_element(k.kinetic.begin(), k.kinetic.end());
  row.run = compare(undamped->model, s, k, scale);
  row.self_simbody = compare(undamped->model, s_coarse, s, scale);
  row.self_kanedyn = compare(undamped->model, k_coarse, k, scale);
  row.drift_kanedyn = drift(k, scale);
  row.drift_simbody = drift(s, scale);
  row.steps_kanedyn = k.steps;
  row.steps_simbody = s.steps;
  // Simbody's own energy against kanedyn's total_energy of Simbody's states: the same
  // definition (gravity's zero at the origin, 1/2 k (L - L0)^2), so equal to round-off.
  kanedyn::Data data(undamped->model);
  for (size_t i = 0; i < s.t.size(); ++i)
    row.energy_definition = std::max(
        row.energy_definition,
        std::abs(kanedyn::total_energy(undamped->model, s.q[i], s.z[i], data) - s.energy[i]) /
            scale);
  const auto within = [&opt](double difference, double self, bool energy = false) {
    return difference <= opt.safety * self / 9.0 + (energy ? opt.energy_floor : opt.floor);
  };
  row.agrees = row.zdot <= opt.tolerance &&
               within(row.run.coordinates, row.self_simbody.coordinates) &&
               within(row.run.speeds, row.self_simbody.speeds) &&
               within(row.drift_kanedyn, row.self_kanedyn.energy, true) &&
               within(row.drift_simbody, row.self_simbody.energy, true) &&
               row.energy_definition <= opt.tolerance;
  std::cout << "# " << undamped->name << " over " << opt.t_end << " s, every " << opt.dt_out
            << " s: kanedyn " << k.description << " (" << k.steps << " steps), Simbody "
            << s.description << " (" << s.steps << " steps): largest difference of joint "
            << "coordinates " << format_sci(row.run.coordinates) << ", speeds "
            << format_sci(row.run.speeds) << "; Simbody at 10x its accuracy differs from itself by "
            << format_sci(row.self_simbody.coordinates) << ", "
            << format_sci(row.self_simbody.speeds)
            << "; energy drift (of the largest kinetic energy, " << format_sci(scale)
            << " J): kanedyn " << format_sci(row.drift_kanedyn) << " (its own energy error about "
            << format_sci(row.self_kanedyn.energy / 9) << "), Simbody "
            << format_sci(row.drift_simbody) << " (about "
            << format_sci(row.self_simbody.energy / 9)
            << "); Simbody's calcEnergy against kanedyn's total_energy of the same states "
            << format_sci(row.energy_definition) << (row.agrees ? "" : "  <-- DISAGREES") << "\n"
            << std::flush;
  return row;
}

}  // namespace

bool run_spring_section(const SpringOptions& opt) {
  std::cout << "\n## Springs against Simbody's TwoPointLinearSpring\n" << std::flush;
  std::vector<Row> rows;
  bool all_agree = true;
  for (int which = 0; which < 2; ++which) {
    try {
      rows.push_back(compare_model(which, opt));
      all_agree = all_agree && rows.back().agrees;
    } catch (const std::exception& e) {
      std::cout << "# springs model " << which << ": FAILED: " << e.what() << "\n";
      all_agree = false;
    }
  }
  std::cout << "\n| model | n | springs | z dot rel. diff. | kanedyn ns | Simbody ns | Simbody / "
               "kanedyn | coordinates | speeds | Simbody's own error | energy drift kanedyn | "
               "energy drift Simbody |\n"
            << "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Row& r : rows)
    std::cout << "| " << r.name << " | " << r.speeds << " | " << r.springs << " | "
              << format_sci(r.zdot) << " | " << format_ns(r.ours.median_ns) << " | "
              << format_ns(r.theirs.median_ns) << " | "
              << format_ratio(r.theirs.median_ns / r.ours.median_ns) << " | "
              << format_sci(r.run.coordinates) << " | " << format_sci(r.run.speeds) << " | "
              << format_sci(r.self_simbody.coordinates / 9) << ", "
              << format_sci(r.self_simbody.speeds / 9) << " | " << format_sci(r.drift_kanedyn)
              << " | " << format_sci(r.drift_simbody) << (r.agrees ? "" : " DISAGREES") << " |\n";
  std::cout << "\n(z dot: the damped models at " << opt.states
            << " random states, of the largest |z dot|; coordinates (rad or m) and speeds (rad/s "
               "or m/s): the undamped models over "
            << opt.t_end << " s, kanedyn dopri5 rtol " << format_sci(opt.rtol)
            << " against Simbody RungeKuttaMerson accuracy " << format_sci(opt.accuracy)
            << "; energy drift max |E(t) - E(0)| of the largest kinetic energy)\n";
  if (!all_agree)
    std::cout << "\nSome model disagrees beyond the tolerances (--spring-tolerance "
              << opt.tolerance << " at the states, --spring-safety " << opt.safety
              << " over the run) or failed.\n";
  return all_agree;
}

}  // namespace peers
