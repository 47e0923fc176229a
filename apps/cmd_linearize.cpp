// `kanedyn linearize MODEL [--state FILE | --trajectory F --t T] [--input NAME=VALUE] [--json]
// [--reduce]`: the linearized motion about an operating point (docs/analysis.md;
// docs/model-format.md, "Linearization output"), as the spec's JSON object or as a readable
// summary of each eigenvalue: frequency, damping ratio, time constant, stable or not, and with
// --modes the state entries each mode moves most. --reduce adds the system without its
// ignorable coordinates (include/kanedyn/reduce.hpp), whose eigenvalues decide stability at a
// steady motion.
#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "commands.hpp"
#include "kanedyn/analysis.hpp"
#include "kanedyn/io/files.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/reduce.hpp"
#include "options.hpp"

namespace kanedyn::cli {

namespace {

using Json = nlohmann::ordered_json;

Json vector_json(const VectorX& v) {
  Json out = Json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) out.push_back(v[i]);
  return out;
}

Json matrix_json(const MatrixX& a) {
  Json out = Json::array();
  for (Eigen::Index r = 0; r < a.rows(); ++r) out.push_back(vector_json(a.row(r).transpose()));
  return out;
}

Json complex_json(std::complex<double> c) { return Json::array({c.real(), c.imag()}); }

// Column i: eigenvalue i's vector as [re, im] pairs.
Json modes_json(const Eigen::MatrixXcd& vectors) {
  Json modes = Json::array();
  for (Eigen::Index c = 0; c < vectors.cols(); ++c) {
    Json col = Json::array();
    for (Eigen::Index r = 0; r < vectors.rows(); ++r) col.push_back(complex_json(vectors(r, c)));
    modes.push_back(col);
  }
  return modes;
}

struct Options {
  std::string model, state_file;
  StateChoice state;
  bool json = false, modes = false, reduce = false;
};

// The scale below which a real part counts as zero: a simple eigenvalue is found to about
// eps |A|, but a double one (a free body's unrestrained coordinate and its speed, a Jordan block)
// only to about sqrt(eps |A|); ten times that.
double zero_tolerance(const MatrixX& a) {
  const double norm = a.size() ? std::max(1.0, a.cwiseAbs().rowwise().sum().maxCoeff()) : 1.0;
  return 10.0 * std::sqrt(std::numeric_limits<double>::epsilon() * norm);
}

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& s : names) out += (out.empty() ? "" : " ") + s;
  return out;
}

std::string dropped_names(const std::vector<DroppedCoordinate>& dropped) {
  std::string out;
  for (const DroppedCoordinate& d : dropped)
    out += (out.empty() ? "" : ", ") + d.name + (d.kind == "coordinate" ? "" : " (" + d.kind + ")");
  return out;
}

std::string number(double v, const char* format = "%.4g") {
  char buf[40];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

struct Counts {
  int stable = 0, unstable = 0, marginal = 0;
};

// The table of eigenvalues, each read (and with modes the entries each mode moves most).
Counts print_eigenvalues(const Eigen::VectorXcd& values, const Eigen::MatrixXcd& vectors,
                         const std::vector<std::string>& state, double tol, bool modes) {
  std::printf("\n  %4s  %12s  %12s  %11s  %9s  %14s  %s\n", "#", "real", "imag", "freq [Hz]",
              "damping", "time const [s]", "");
  Counts c;
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    const std::complex<double> l = values[i];
    const ModeReading r = read_eigenvalue(l, tol);
    const char* verdict = r.unstable ? "unstable" : r.stable ? "stable" : "marginal";
    c.stable += r.stable ? 1 : 0;
    c.unstable += r.unstable ? 1 : 0;
    c.marginal += (!r.stable && !r.unstable) ? 1 : 0;
    const bool zero_re = std::abs(l.real()) <= tol;
    std::printf("  %4lld  %12s  %12s  %11s  %9s  %14s  %s\n", static_cast<long long>(i + 1),
                zero_re ? "0" : number(l.real(), "%+.5g").c_str(),
                std::abs(l.imag()) <= tol ? "0" : number(l.imag(), "%+.5g").c_str(),
                std::abs(l.imag()) <= tol ? "-" : number(r.frequency_hz).c_str(),
                std::abs(l) <= tol ? "-"
                : zero_re          ? "0"
                                   : number(r.damping_ratio, "%.3f").c_str(),
                zero_re ? "-" : number(r.time_constant).c_str(), verdict);
    if (modes && vectors.cols() == values.size()) {
      // The entries the mode moves most: |v_i| >= 0.1 of the largest (which is 1).
      const Eigen::VectorXcd v = vectors.col(i);
      std::string text;
      for (Eigen::Index s = 0; s < v.size(); ++s) {
        if (std::abs(v[s]) < 0.1) continue;
        text += "  " + state[static_cast<size_t>(s)] + " " + number(std::abs(v[s]), "%.2f");
        const double phase = std::arg(v[s]) * 180.0 / 3.141592653589793;
        if (std::abs(phase) > 0.5) text += "@" + number(phase, "%.0f") + "deg";
      }
      std::printf("        moves:%s\n", text.c_str());
    }
  }
  return c;
}

// The verdict on an equilibrium or a steady motion from its eigenvalues; with neutral
// coordinates a marginal verdict says that they are why (or among why).
std::string verdict(const Counts& c, bool neutral) {
  if (c.unstable > 0) return "unstable";
  if (c.marginal == 0) return "asymptotically stable";
  return neutral ? "not asymptotically stable (marginal eigenvalues: the neutral coordinates "
                   "above, or no damping)"
                 : "not asymptotically stable (marginal eigenvalues)";
}

void print_reduced(const ReducedLinearization& red, bool modes) {
  std::printf("\nreduced (--reduce): %zu coordinate%s dropped, the state %s\n", red.dropped.size(),
              red.dropped.size() == 1 ? "" : "s", joined(red.state).c_str());
  if (red.steady)
    std::printf(
        "  a steady motion: the reduced system is time-invariant here, and its eigenvalues decide "
        "stability\n");
  else
    std::printf(
        "  not a steady motion (the reduced state's largest rate is %s): the reduced system "
        "changes along the motion, and its eigenvalues at this instant do not decide stability\n",
        number(red.reduced_rate).c_str());
  const double tol = zero_tolerance(red.A);
  const Counts c = print_eigenvalues(red.eigenvalues, red.modes, red.state, tol, modes);
  std::printf("\n  %d stable, %d unstable, %d marginal (|real part| <= %s counts as 0)\n", c.stable,
              c.unstable, c.marginal, number(tol, "%.1e").c_str());
  if (red.steady) std::printf("  the steady motion is %s\n", verdict(c, false).c_str());
}

void print_summary(const io::ModelFile& file, const Linearization& lin, const OperatingPoint& op,
                   const Derivatives& derivatives, bool modes,
                   const ReducedLinearization* reduced) {
  const double tol = zero_tolerance(lin.A);
  std::printf("linearization of %s at %s\n", io::printable(file.path).c_str(), op.where.c_str());
  const int coordinates = static_cast<int>(lin.state.size()) - lin.n;
  const auto s = [](int count) { return count == 1 ? "" : "s"; };  // "1 input", "2 inputs"
  std::printf("  state: %d coordinate%s and %d speed%s (tangent coordinates); %d input%s\n",
              coordinates, s(coordinates), lin.n, s(lin.n), lin.m, s(lin.m));
  if (file.model.num_constraints() > 0)
    std::printf(
        "  constraints: the independent coordinates (those not fixed by holonomic constraints) "
        "and the independent speeds: %s\n",
        joined(lin.state).c_str());
  std::printf("  derivatives: %s\n", derivatives.method().c_str());
  const double moving = lin.zdot.size() ? lin.zdot.cwiseAbs().maxCoeff() : 0.0;
  if (moving > tol)
    std::printf(
        "  not an equilibrium: the largest z dot there is %s; A describes the motion about the "
        "nominal motion through this point\n",
        number(moving).c_str());
  if (lin.periodic)
    std::printf(
        "  a free body turns here (w0 != 0): the linear system is periodic, and its eigenvalues "
        "at one instant do not decide stability\n");
  const Counts counts = print_eigenvalues(lin.eigenvalues, lin.modes, lin.state, tol, modes);
  std::printf("\n  %d stable, %d unstable, %d marginal (|real part| <= %s counts as 0)\n",
              counts.stable, counts.unstable, counts.marginal, number(tol, "%.1e").c_str());
  const std::vector<DroppedCoordinate> neutral =
      reduced ? reduced->dropped : ignorable_coordinates(file.model, lin);
  if (!neutral.empty())
    std::printf("  neutral (the state's rate does not depend on them): %s\n",
                dropped_names(neutral).c_str());
  if (lin.periodic)
    std::printf(
        "  (periodic system: see above%s)\n",
        reduced ? "; the reduced system below" : "; --reduce drops the turning coordinates");
  else if (moving > tol)
    std::printf("  (not an equilibrium: the verdicts hold for a steady motion only)\n");
  else
    std::printf("  the operating point is %s\n", verdict(counts, !neutral.empty()).c_str());
  if (reduced) print_reduced(*reduced, modes);
}

Json reduced_json(const ReducedLinearization& red, bool inputs, bool modes) {
  Json out;
  Json dropped = Json::array();
  for (const DroppedCoordinate& d : red.dropped)
    dropped.push_back({{"index", d.index}, {"name", d.name}, {"kind", d.kind}});
  out["dropped"] = dropped;
  out["state"] = red.state;
  out["steady"] = red.steady;
  out["A"] = matrix_json(red.A);
  if (inputs) out["B"] = matrix_json(red.B);
  Json values = Json::array();
  for (Eigen::Index i = 0; i < red.eigenvalues.size(); ++i)
    values.push_back(complex_json(red.eigenvalues[i]));
  out["eigenvalues"] = values;
  if (modes) out["modes"] = modes_json(red.modes);
  return out;
}

void run(const Options& o) {
  const io::ModelFile file = io::load_model_file(o.model);
  const Model& model = file.model;
  const OperatingPoint op = operating_point(file, o.state, o.state_file);
  const Linearization lin = linearize(model, op.q, op.z, op.u, o.modes);
  if (!lin.A.allFinite() || !lin.B.allFinite())
    throw std::runtime_error("linearize: the derivatives at " + op.where + " are not finite");
  std::unique_ptr<ReducedLinearization> reduced;
  if (o.reduce) reduced = std::make_unique<ReducedLinearization>(reduce(model, lin, o.modes));
  if (!o.json) {
    Derivatives derivatives(model);
    print_summary(file, lin, op, derivatives, o.modes, reduced.get());
    return;
  }
  Json j;
  j["n"] = lin.n;
  j["m"] = lin.m;
  j["state"] = lin.state;
  j["inputs"] = lin.inputs;
  j["q"] = vector_json(lin.q);
  j["z"] = vector_json(lin.z);
  j["u"] = vector_json(lin.u);
  j["A"] = matrix_json(lin.A);
  if (lin.m > 0) j["B"] = matrix_json(lin.B);
  Json values = Json::array();
  for (Eigen::Index i = 0; i < lin.eigenvalues.size(); ++i)
    values.push_back(complex_json(lin.eigenvalues[i]));
  j["eigenvalues"] = values;
  // Not in the spec's object unless asked: column i is eigenvalue i's vector, [re, im] pairs.
  if (o.modes) j["modes"] = modes_json(lin.modes);
  if (reduced) j["reduced"] = reduced_json(*reduced, lin.m > 0, o.modes);
  io::write_to_stdout(j.dump() + "\n");
}

void add_linearize(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "linearize",
      "Linearize the motion about an operating point: A, B and the eigenvalues, each with its "
      "frequency, damping and time constant");
  auto o = std::make_shared<Options>();
  cmd->footer(
      "The operating point is the model's initial state with zero inputs unless --state, "
      "--trajectory or --input says otherwise; it need not be an equilibrium. Positions are "
      "perturbed in tangent coordinates (a rotation vector for each set of Euler parameters); "
      "the state is every body's coordinates, then its speeds (docs/model-format.md, "
      "\"Linearization output\"). The derivatives are analytic (dual numbers through the "
      "inverse dynamics; docs/analysis.md).");
  add_input_file(cmd, "MODEL", o->model, kModelHelp)->required();
  cmd->add_flag("--json", o->json, "print the JSON object of docs/model-format.md");
  cmd->add_flag("--modes", o->modes,
                "also each eigenvector: the state entries it moves most (with --json: a "
                "\"modes\" array of columns of [re, im] pairs)");
  cmd->add_flag("--reduce", o->reduce,
                "also the system without its ignorable coordinates (a free root's position and "
                "heading, a wheel's spin): at a steady motion it is time-invariant and its "
                "eigenvalues decide stability (with --json: a \"reduced\" object)");
  add_input_file(cmd, "--state", o->state_file,
                 "take the operating point from this model file's initial state (the same "
                 "bodies and joints; e.g. what equilibrium writes)");
  add_state_options(cmd, o->state);
  cmd->callback([o] { run(*o); });
}

}  // namespace
KANEDYN_COMMAND(33, add_linearize);
}  // namespace kanedyn::cli
