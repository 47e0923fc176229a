#include "options.hpp"

#include <charconv>
#include <cmath>

#include "kanedyn/analysis.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/io/trajectory.hpp"

namespace kanedyn::cli {

std::string constraint_summary(const io::ModelFile& file) {
  const Model& model = file.model;
  const SpeedPartition& p = file.partition;
  ConstraintEquations equations(model);
  const std::vector<std::string> names = tangent_state_names(model);
  const int n = model.num_speeds();
  std::string text = std::to_string(model.num_constraints()) + " (" +
                     std::to_string(equations.rows()) + " equations, " + std::to_string(p.rank) +
                     " independent";
  if (!p.redundant_rows.empty()) {
    text += "; redundant:";
    // The first few: a mechanism with many copies of a hinge has thousands.
    constexpr size_t kShown = 12;
    for (size_t i = 0; i < p.redundant_rows.size() && i < kShown; ++i)
      text += " " + equations.row_name(p.redundant_rows[i]);
    if (p.redundant_rows.size() > kShown)
      text += " ... (" + std::to_string(p.redundant_rows.size() - kShown) + " more)";
  }
  text += "); independent speeds (" +
          std::string(model.independent_speeds().empty() ? "by pivoting" : "as the file says") +
          "):";
  for (const int i : p.independent) text += " " + names[static_cast<size_t>(n + i)];
  char buffer[160];
  std::snprintf(buffer, sizeof buffer,
                "; initial state projected: coordinates moved by at most %.3g, speeds by %.3g",
                file.projection.coordinate_change, file.projection.speed_change);
  return text + buffer;
}

CLI::Validator decimal_number(bool positive) {
  return CLI::Validator(
      [positive](std::string& text) -> std::string {
        double v = 0.0;
        const std::string problem = io::read_decimal(text, v);
        const std::string got = "'" + io::printable(text, 40) + "' ";
        if (problem.starts_with("overflows") || problem.starts_with("is too small"))
          return got + problem;
        const bool ok = problem.empty() && (!positive || v > 0.0);
        return ok ? ""
                  : std::string("must be a decimal number") + (positive ? " > 0" : "") + ", got '" +
                        io::printable(text, 40) + "'";
      },
      positive ? "NUMBER>0" : "NUMBER");
}

std::string speed_label(int n, int i) {
  const int part = i / (3 * n), k = (i % (3 * n)) / 3, c = i % 3;
  return (part == 0 ? "w" : "sd") + std::to_string(k + 1) + "." + std::to_string(c + 1);
}

std::string chain_text(const Model& model, int k) {
  constexpr int kShown = 6;  // a long chain: its first bodies, then its root
  const Model::Chain chain = model.chain(k);
  std::string text;
  int shown = 0;
  // Only the first kShown entries are walked: a chain of N bodies costs O(1) per body, not
  // O(N) (info of a 100,000-link chain would otherwise print 5e9 numbers).
  for (auto it = chain.begin(); it != chain.end() && shown < kShown; ++it, ++shown)
    text += (shown ? " -> " : "") + std::to_string(*it + 1);
  if (chain.size > kShown + 1)
    text += " -> ..." + std::to_string(chain.size - kShown - 1) + " more... -> " +
            std::to_string(chain.root + 1);
  else if (chain.size == kShown + 1)
    text += " -> " + std::to_string(chain.root + 1);
  return text + " -> 0";
}

namespace {

/// The input-file options of every subcommand: only the one that runs has values.
std::vector<const std::string*>& single_inputs() {
  static std::vector<const std::string*> paths;
  return paths;
}

}  // namespace

namespace {

/// A file name given as '' names no file: refused rather than taken for "none".
CLI::Validator file_name() {
  return CLI::Validator(
      [](const std::string& name) {
        return name.empty() ? std::string("an empty file name") : std::string();
      },
      "FILE");
}

}  // namespace

CLI::Option* add_input_file(CLI::App* cmd, const std::string& name, std::string& path,
                            const std::string& help) {
  single_inputs().push_back(&path);
  return cmd->add_option(name, path, help)->check(file_name());
}

std::vector<std::string> input_files() {
  std::vector<std::string> files;
  for (const std::string* p : single_inputs())
    if (!p->empty()) files.push_back(*p);
  return files;
}

void add_state_options(CLI::App* cmd, StateChoice& choice) {
  auto* trajectory = add_input_file(cmd, "--trajectory", choice.trajectory,
                                    "take the state from a row of this trajectory CSV "
                                    "(written by simulate for this model); needs --t");
  auto* t = cmd->add_option("--t", choice.t, "the time of that row (within half a step)")
                ->check(decimal_number(false));
  trajectory->needs(t);
  t->needs(trajectory);
  cmd->add_option("--input", choice.inputs,
                  "NAME=VALUE: an input's value (repeatable); the others are 0, or the "
                  "trajectory row's");
}

State chosen_state(const io::ModelFile& file, const StateChoice& choice, double& t,
                   std::string& where) {
  VectorX q, z;
  return chosen_state(file, choice, t, where, q, z);
}

State chosen_state(const io::ModelFile& file, const StateChoice& choice, double& t,
                   std::string& where, VectorX& q, VectorX& z, VectorX& u) {
  const Model& model = file.model;
  u = VectorX::Zero(model.num_inputs());
  if (!choice.trajectory.empty()) {
    const io::TrajectoryRow row = io::read_trajectory_row(model, choice.trajectory, choice.t);
    u = row.inputs;
  }
  std::vector<std::string> names;
  for (const Input& in : model.inputs()) names.push_back(in.name);
  std::vector<char> set(names.size(), 0);
  for (const std::string& given : choice.inputs) {
    const size_t eq = given.find('=');
    if (eq == std::string::npos)
      throw std::runtime_error("--input " + io::printable(given, 60) +
                               ": expected NAME=VALUE, e.g. --input " +
                               (names.empty() ? std::string("shoulder") : names[0]) + "=1.5");
    const std::string name = given.substr(0, eq), value = given.substr(eq + 1);
    const int i = model.input_index(name);
    if (i < 0) {
      const std::string near = io::closest_word(name, names);
      throw std::runtime_error("--input " + io::printable(given, 60) + ": " +
                               (names.empty()
                                    ? "the model has no inputs"
                                    : "unknown input '" + io::printable(name, 60) + "'" +
                                          (near.empty() ? "" : " (did you mean '" + near + "'?)")));
    }
    // Given twice, one value would be silently dropped.
    if (set[static_cast<size_t>(i)]++)
      throw std::runtime_error("--input " + io::printable(given, 60) + ": input '" +
                               io::printable(name, 60) + "' is given twice");
    double v = 0.0;
    if (const std::string problem = io::read_decimal(value, v); !problem.empty())
      throw std::runtime_error("--input " + io::printable(given, 60) + ": the value '" +
                               io::printable(value, 40) + "' " + problem);
    u[i] = v;
  }
  return chosen_state(file, choice, t, where, q, z);
}

State chosen_state(const io::ModelFile& file, const StateChoice& choice, double& t,
                   std::string& where, VectorX& q, VectorX& z) {
  if (choice.trajectory.empty()) {
    t = 0.0;
    where = "its initial state";
    q = file.q;
    z = file.z;
    return file.initial;
  }
  const io::TrajectoryRow row = io::read_trajectory_row(file.model, choice.trajectory, choice.t);
  q = row.q;
  z = row.z;
  t = row.t;
  char time[32];
  std::snprintf(time, sizeof time, "%.10g", row.t);
  where = "t = " + std::string(time) + " of " + io::printable(choice.trajectory) + " (line " +
          std::to_string(row.line) + ")";
  return row.state;
}

OperatingPoint operating_point(const io::ModelFile& file, const StateChoice& choice,
                               const std::string& state_file) {
  const Model& model = file.model;
  OperatingPoint op;
  double t = 0.0;
  const State state = chosen_state(file, choice, t, op.where, op.q, op.z, op.u);
  if (op.q.size() != model.num_coordinates()) {  // a free tree's row: (eps_K, s'_K; w'_K, s'_K dot)
    op.q.resize(model.num_coordinates());
    op.z.resize(model.num_speeds());
    for (int k = 0; k < model.num_bodies(); ++k) {
      op.q.segment<4>(model.coordinate_offset(k)) = state.euler_parameters(k);
      op.q.segment<3>(model.coordinate_offset(k) + 4) = state.translation(k);
      op.z.segment<3>(model.speed_offset(k)) = state.angular_velocity(k);
      op.z.segment<3>(model.speed_offset(k) + 3) = state.translation_rate(k);
    }
  }
  if (state_file.empty()) return op;
  if (!choice.trajectory.empty())
    throw std::runtime_error("--state and --trajectory both choose the state: give one");
  const io::ModelFile other = io::load_model_file(state_file);
  const Model& m = other.model;
  bool same = m.num_bodies() == model.num_bodies();
  for (int k = 0; same && k < model.num_bodies(); ++k)
    same = m.body(k).name == model.body(k).name && m.joint(k).type == model.joint(k).type;
  if (!same)
    throw std::runtime_error("--state " + io::printable(state_file) +
                             ": its bodies and joints are not those of " +
                             io::printable(file.path) +
                             " (the state file is a model file of the same system, such as "
                             "equilibrium writes)");
  op.q = other.q;
  op.z = other.z;
  op.where = "the initial state of " + io::printable(state_file);
  return op;
}

CLI::Validator route_names() {
  return CLI::IsMember({"recursive", "assembled", "kane"}).description("{recursive,assembled}");
}

}  // namespace kanedyn::cli
