// kanedyn_peers' constraints section (constraints_section.hpp).
#include "constraints_section.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <filesystem>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "jointed.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/simulate.hpp"
#include "peer.hpp"
#include "timing.hpp"

namespace peers {
namespace {

using kanedyn::JointType;
using kanedyn::VectorX;

VectorX vec(const std::vector<double>& v) {
  return Eigen::Map<const VectorX>(v.data(), static_cast<Eigen::Index>(v.size()));
}

// One integrated motion: the joint coordinates, speeds and reactions at the output times.
struct Run {
  std::vector<double> t;
  std::vector<VectorX> q, z, reactions;
  long steps = 0;
  double seconds = 0;
};

Run run_kanedyn(const JointedCase& c, const ConstraintOptions& opt) {
  kanedyn::SimulationSettings s;
  s.t_end = opt.t_end;
  s.dt_out = opt.dt_out;
  s.integrator = kanedyn::Integrator::dopri5;
  s.rtol = opt.rtol;
  s.atol = opt.rtol * 1e-2;
  s.observer_kinematics = false;
  Run run;
  const auto t0 = std::chrono::steady_clock::now();
  const kanedyn::SimulationStats stats =
      kanedyn::simulate(c.model, c.q, c.z, s,
                        [&](double t, const kanedyn::State&, const VectorX& q, const VectorX& z,
                            kanedyn::Data& data) {
                          run.t.push_back(t);
                          run.q.push_back(q);
                          run.z.push_back(z);
                          run.reactions.push_back(data.reactions);
                        });
  run.seconds = seconds_since(t0);
  if (!stats.ok()) throw std::runtime_error("kanedyn: " + stats.message);
  run.steps = stats.steps_accepted;
  return run;
}

Run run_engine(JointedEngine& engine, double accuracy, const std::vector<double>& times,
               std::string& description) {
  IntegratorSettings settings;
  settings.accuracy = accuracy;
  const auto t0 = std::chrono::steady_clock::now();
  description = engine.start(settings).description;
  if (description.empty()) throw std::runtime_error("the engine cannot integrate");
  Run run;
  std::vector<double> q, z, r;
  for (const double t : times) {
    if (t > 0) engine.advance_to(t);
    engine.integrated_state(q, z, r);
    run.t.push_back(t);
    run.q.push_back(vec(q));
    run.z.push_back(vec(z));
    run.reactions.push_back(vec(r));
  }
  run.seconds = seconds_since(t0);
  run.steps = engine.steps();
  return run;
}

// The largest difference between two joint-coordinate vectors of the model: per scalar
// coordinate its difference (rad or m), per orientation in Euler parameters (a spherical
// joint's, a free joint's) the angle between the two, 4 asin(|e - e'| / 2) with the sign of e'
// that makes it smaller (e and -e are the same orientation).
double coordinate_difference(const kanedyn::Model& m, const VectorX& a, const VectorX& b) {
  double worst = 0;
  for (int k = 0; k < m.num_bodies(); ++k) {
    const int o = m.coordinate_offset(k), n = m.coordinate_offset(k + 1) - o;
    int first_scalar = 0;
    const JointType type = m.joint(k).type;
    if (type == JointType::spherical || type == JointType::free) {
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
  double coordinates = 0, speeds = 0, reactions = 0;  // reactions relative to the largest
};

// Both runs at the same output times.
Differences compare(const kanedyn::Model& m, const Run& a, const Run& b) {
  Differences d;
  double scale = 0;
  for (size_t i = 0; i < a.t.size(); ++i) {
    d.coordinates = std::max(d.coordinates, coordinate_difference(m, a.q[i], b.q[i]));
    d.speeds = std::max(d.speeds, (a.z[i] - b.z[i]).cwiseAbs().maxCoeff());
    d.reactions = std::max(d.reactions, (a.reactions[i] - b.reactions[i]).cwiseAbs().maxCoeff());
    scale = std::max(scale, b.reactions[i].cwiseAbs().maxCoeff());
  }
  if (scale > 0) d.reactions /= scale;
  return d;
}

// The largest holonomic error of a run's states in kanedyn's constraint equations.
double closure_error(const kanedyn::Model& m, const Run& run) {
  kanedyn::ConstraintEquations eq(m);
  double worst = 0;
  for (size_t i = 0; i < run.t.size(); ++i) {
    eq.evaluate(run.q[i], run.z[i]);
    worst = std::max(worst, eq.errors().cwiseAbs().maxCoeff());
  }
  return worst;
}

double relative(const VectorX& x, const VectorX& ref) {
  return (x - ref).cwiseAbs().maxCoeff() / std::max(1.0, ref.cwiseAbs().maxCoeff());
}

struct Row {
  std::string name;
  int speeds = 0, rows = 0, rank = 0;
  double zdot = 0, reactions_at_start = 0;
  Differences run, self;
  double closure_kanedyn = 0, closure_engine = 0;
  bool agrees = false;
};

// One model file: returns its row of the summary table.
Row compare_file(const std::string& file, const ConstraintOptions& opt) {
  const kanedyn::io::ModelFile f = kanedyn::io::load_model_file(file);
  JointedCase c(std::filesystem::path(file).filename().string(), f.model);
  c.q = f.q;
  c.z = f.z;
  const JointedSystem sys = describe_jointed(c);
  const JointedEngineInfo info = simbody_jointed_engine();
  Row row;
  row.name = c.name;
  row.speeds = c.model.num_speeds();
  row.rank = f.partition.rank;

  // At the initial state: one evaluation each, no integration.
  kanedyn::ConstrainedDynamics dynamics(c.model);
  VectorX zdot(c.model.num_speeds()), reactions(kanedyn::reaction_count(c.model));
  dynamics.evaluate(c.q, c.z, VectorX::Zero(c.model.num_inputs()), zdot);
  kanedyn::constraint_reactions(dynamics.equations(), dynamics.lambda(), reactions);
  row.rows = dynamics.equations().rows();
  const std::unique_ptr<JointedEngine> engine = info.make(sys);
  engine->evaluate();
  row.zdot = relative(vec(engine->zdot()), zdot);
  row.reactions_at_start = relative(vec(engine->reactions()), reactions);
  std::cout << "# " << c.name << ": " << row.speeds << " speeds, " << row.rows
            << " constraint equations of rank " << row.rank << "; at t = 0, " << info.name << " "
            << info.version << ": rel. diff. of z dot " << format_sci(row.zdot)
            << ", of the reactions " << format_sci(row.reactions_at_start) << " (largest "
            << format_sci(reactions.cwiseAbs().maxCoeff()) << ")\n"
            << std::flush;

  // Over time, each with its own integrator; the engine also at 10 times its accuracy, whose
  // difference from its own run shows the size of its integration error.
  const Run ours = run_kanedyn(c, opt);
  std::string description, coarse_description;
  const Run theirs = run_engine(*engine, opt.accuracy, ours.t, description);
  const Run coarse = run_engine(*info.make(sys), 10 * opt.accuracy, ours.t, coarse_description);
  row.run = compare(c.model, theirs, ours);
  row.self = compare(c.model, coarse, theirs);
  row.closure_kanedyn = closure_error(c.model, ours);
  row.closure_engine = closure_error(c.model, theirs);
  const auto within = [&opt](double difference, double self) {
    return difference <= opt.safety * self / 9.0 + opt.floor;
  };
  row.agrees =
      row.zdot <= opt.instant_tolerance && row.reactions_at_start <= opt.instant_tolerance &&
      within(row.run.coordinates, row.self.coordinates) &&
      within(row.run.speeds, row.self.speeds) && within(row.run.reactions, row.self.reactions);
  std::cout << "# " << c.name << " over " << opt.t_end << " s, every " << opt.dt_out
            << " s: kanedyn dopri5 rtol " << format_sci(opt.rtol) << " (" << ours.steps
            << " steps), " << info.name << " " << description << " (" << theirs.steps
            << " steps): largest difference of joint coordinates "
            << format_sci(row.run.coordinates) << ", speeds " << format_sci(row.run.speeds)
            << ", reactions (rel.) " << format_sci(row.run.reactions) << "; " << info.name
            << " at 10x its accuracy differs from itself by " << format_sci(row.self.coordinates)
            << ", " << format_sci(row.self.speeds) << ", " << format_sci(row.self.reactions)
            << "; closure error of kanedyn's states " << format_sci(row.closure_kanedyn) << ", of "
            << info.name << "'s (in kanedyn's equations) " << format_sci(row.closure_engine)
            << (row.agrees ? "" : "  <-- DISAGREES") << "\n"
            << std::flush;
  return row;
}

}  // namespace

bool run_constraint_section(const ConstraintOptions& opt) {
  std::vector<Row> rows;
  bool all_agree = true;
  for (const std::string& file : opt.files) {
    try {
      rows.push_back(compare_file(file, opt));
      all_agree = all_agree && rows.back().agrees;
    } catch (const std::exception& e) {
      std::cout << "# " << file << ": FAILED: " << e.what() << "\n";
      all_agree = false;
    }
  }
  std::cout << "\nClosed loops against " << simbody_jointed_engine().name
            << " (largest differences; coordinates in rad or m, speeds in rad/s or m/s, "
               "reactions relative to the largest):\n\n"
            << "| model | n | rows (rank) | z dot at t = 0 | reactions at t = 0 | coordinates | "
               "speeds | reactions | engine's own error (coordinates, speeds, reactions) |\n"
            << "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Row& r : rows)
    std::cout << "| " << r.name << " | " << r.speeds << " | " << r.rows << " (" << r.rank << ") | "
              << format_sci(r.zdot) << " | " << format_sci(r.reactions_at_start) << " | "
              << format_sci(r.run.coordinates) << " | " << format_sci(r.run.speeds) << " | "
              << format_sci(r.run.reactions) << " | " << format_sci(r.self.coordinates / 9) << ", "
              << format_sci(r.self.speeds / 9) << ", " << format_sci(r.self.reactions / 9)
              << (r.agrees ? "" : " DISAGREES") << " |\n";
  std::cout << "\n(the engine's own error: its run at 10x the accuracy differs from its run "
               "by about 9 times it; over the run a difference is accepted up to "
               "--constraint-safety "
            << opt.safety << " times it + " << opt.floor << ")\n";
  if (!all_agree)
    std::cout << "\nSome model disagrees beyond the tolerances (--constraint-instant-tolerance "
              << opt.instant_tolerance << " at t = 0, --constraint-safety " << opt.safety
              << " over the run) or failed.\n";
  return all_agree;
}

}  // namespace peers
