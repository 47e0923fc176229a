// `kanedyn eom MODEL [--json] [--trajectory FILE.csv --t T]`: the equations of motion at the
// model's initial state or at a row of a trajectory: for a jointed model its joint-space
// equations (A_z, f_z, z dot) first, then the notes' [A] (Eq. 37), {f} (Eq. 38), {y dot}
// (Eq. 36) and {x dot} (Eqs. 39-40).
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "commands.hpp"
#include "kanedyn/data.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kane.hpp"
#include "kanedyn/kinematic_equations.hpp"
#include "kanedyn/simulate.hpp"
#include "options.hpp"

namespace kanedyn::cli {
namespace {

/// Label of coordinate i of {x}: eps_K components then s'_K components.
std::string coordinate_label(int n, int i) {
  if (i < 4 * n) return "e" + std::to_string(i / 4 + 1) + "." + std::to_string(i % 4 + 1);
  const int j = i - 4 * n;
  return "s" + std::to_string(j / 3 + 1) + "." + std::to_string(j % 3 + 1);
}

/// Up to this many bodies the text prints [A] as a table; beyond, its block structure.
constexpr int kTableBodies = 8;

void print_column(const char* title, const VectorX& v, std::string (*label)(int, int), int n) {
  std::printf("\n%s\n", title);
  for (Eigen::Index i = 0; i < v.size(); ++i)
    std::printf("  %-7s % .10e\n", label(n, static_cast<int>(i)).c_str(), v[i]);
}

/// [A]'s block structure: which 6x6 blocks (rows and columns of bodies K and I, in the speed
/// order (w'_K, s'_K dot) of each) are nonzero. A block (K, I) is nonzero exactly when one
/// body is on the other's chain (docs/theory.md).
void print_block_structure(const Model& model, const Data& data) {
  const int n = model.num_bodies();
  const auto nonzero = [&](int k, int i) {
    for (int p = 0; p < 2; ++p)
      for (int q = 0; q < 2; ++q)
        if (!data.kane.A.block<3, 3>(3 * n * p + 3 * k, 3 * n * q + 3 * i).isZero(0.0)) return true;
    return false;
  };
  std::printf("\n[A] (Eq. 37), %d x %d: its 6x6 blocks by body pairs (the table: --full)\n", 6 * n,
              6 * n);
  long count = 0;
  if (n <= 90) {
    std::printf("%5s ", "");
    for (int i = 0; i < n; ++i)
      std::printf("%c", (i + 1) % 10 == 0 ? '0' + ((i + 1) / 10) % 10 : ' ');
    std::printf("\n%5s ", "");
    for (int i = 0; i < n; ++i) std::printf("%d", (i + 1) % 10);
    std::printf("\n");
    for (int k = 0; k < n; ++k) {
      std::printf("%5d ", k + 1);
      for (int i = 0; i < n; ++i) {
        const bool nz = nonzero(k, i);
        count += nz;
        std::printf("%c", nz ? '#' : '.');
      }
      std::printf("\n");
    }
  } else {
    for (int k = 0; k < n; ++k) {
      std::string line;
      int in_row = 0;
      for (int i = 0; i < n; ++i)
        if (nonzero(k, i)) {
          ++in_row;
          if (line.size() < 80) line += (line.empty() ? "" : " ") + std::to_string(i + 1);
        }
      count += in_row;
      std::printf("  %5d: %d blocks: %s%s\n", k + 1, in_row, line.c_str(),
                  line.size() >= 80 ? " ..." : "");
    }
  }
  std::printf("(%ld of %ld blocks nonzero: # where one body is on the other's chain)\n", count,
              static_cast<long>(n) * n);
}

void print_header(const io::ModelFile& file, const Data& data, const std::string& where) {
  std::printf("equations of motion of %s at %s\n", io::printable(file.path).c_str(), where.c_str());
  if (file.model.num_inputs() > 0) {
    std::printf("inputs u:");
    for (int i = 0; i < file.model.num_inputs(); ++i)
      std::printf(" %s = %.10g", file.model.inputs()[static_cast<size_t>(i)].name.c_str(),
                  data.inputs[i]);
    std::printf("\n");
  }
}

/// The notes' system of 6N equations in the free bodies' speeds y.
void print_tables(const io::ModelFile& file, const Data& data, bool full) {
  const int n = file.model.num_bodies();
  std::printf("\nthe notes' equations: [A]{ydot} = {f} (Eq. 36)\n");
  std::printf("N = %d, y = (w'_1..w'_N, s'_1 dot..s'_N dot), x = (eps_1..eps_N, s'_1..s'_N)\n", n);
  if (!full && n > kTableBodies) {
    print_block_structure(file.model, data);
    print_column("{f} (Eq. 38)", data.kane.f, speed_label, n);
    print_column("{y dot} (Eq. 36)", data.ydot, speed_label, n);
    print_column("{x dot} (Eqs. 39-40)", data.xdot, coordinate_label, n);
    return;
  }
  std::printf("\n[A] (Eq. 37), %d x %d\n%-7s", 6 * n, 6 * n, "");
  for (int j = 0; j < 6 * n; ++j) std::printf(" %10s", speed_label(n, j).c_str());
  std::printf("\n");
  for (int i = 0; i < 6 * n; ++i) {
    std::printf("%-7s", speed_label(n, i).c_str());
    for (int j = 0; j < 6 * n; ++j) std::printf(" % 10.4g", data.kane.A(i, j));
    std::printf("\n");
  }
  print_column("{f} (Eq. 38)", data.kane.f, speed_label, n);
  print_column("{y dot} (Eq. 36)", data.ydot, speed_label, n);
  print_column("{x dot} (Eqs. 39-40)", data.xdot, coordinate_label, n);
}

/// Label of independent speed i as the trajectory CSV names its column: NAME.jdN of a jointed
/// body, NAME.wC / NAME.sdC of a free one.
std::string independent_speed_label(const Model& model, int i) {
  int k = -1;
  const std::string column = joint_state_column(model, model.num_coordinates() + i, &k);
  return k < 0 ? "?" : model.body(k).name + "." + column;
}

void print_projected(const io::ModelFile& file, const ProjectedEquations& e, bool full) {
  const Model& model = file.model;
  const int n = model.num_speeds();
  std::printf(
      "\nthe joints' equations, projected from the notes' below (docs/theory.md, \"Joints\"):\n"
      "[C]^T [A] [C] {z dot} = [C]^T ({f} - [A][C dot]{z}) + Q, y = [C] z\n"
      "n = %d independent speeds; [C] is %d x %d\n",
      n, model.num_y(), n);
  // The labels' column as wide as the longest (a robot's link names are long).
  int width = 12;
  for (int i = 0; i < n; ++i)
    width = std::max(width, static_cast<int>(independent_speed_label(model, i).size()));
  if (full || n <= 6 * kTableBodies) {
    std::printf("\nA_z = [C]^T [A] [C], %d x %d\n", n, n);
    for (int i = 0; i < n; ++i) {
      std::printf("%-*s", width, independent_speed_label(model, i).c_str());
      for (int j = 0; j < n; ++j) std::printf(" % 10.4g", e.A_z(i, j));
      std::printf("\n");
    }
  }
  std::printf("\n%-*s %18s %18s\n", width, "z", "f_z", "z dot");
  for (int i = 0; i < n; ++i)
    std::printf("%-*s % .10e % .10e\n", width, independent_speed_label(model, i).c_str(), e.f_z[i],
                e.zdot[i]);
}

void print_json(const io::ModelFile& file, const Data& data, const ProjectedEquations* e) {
  const Model& model = file.model;
  const int n = model.num_bodies();
  using Json = nlohmann::ordered_json;
  Json out;
  auto vec = [](const VectorX& v) {
    Json a = Json::array();
    // nlohmann writes the shortest decimal that reads back as the same double: full precision.
    for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(v[i]);
    return a;
  };
  out["N"] = n;
  out["L"] = Json::array();
  Json depth = Json::array();
  for (int k = 0; k < n; ++k) {
    out["L"].push_back(model.lower_body(k) + 1);
    depth.push_back(model.depth(k));
  }
  // "u" is the notes' u_K, except in a model with inputs, where it is the inputs' values
  // (docs/model-format.md) and u_K moves to "u_K".
  if (model.num_inputs() > 0) {
    out["u"] = vec(data.inputs);
    out["inputs"] = Json::array();
    for (const Input& in : model.inputs()) out["inputs"].push_back(in.name);
    out["u_K"] = std::move(depth);
  } else {
    out["u"] = std::move(depth);
  }
  Json a = Json::array();
  for (Eigen::Index i = 0; i < data.kane.A.rows(); ++i)
    a.push_back(vec(data.kane.A.row(i).transpose()));
  out["A"] = std::move(a);
  out["f"] = vec(data.kane.f);
  out["ydot"] = vec(data.ydot);
  out["xdot"] = vec(data.xdot);
  if (e) {
    const auto mat = [&](const MatrixX& m) {
      Json rows = Json::array();
      for (Eigen::Index i = 0; i < m.rows(); ++i) rows.push_back(vec(m.row(i).transpose()));
      return rows;
    };
    out["n"] = e->zdot.size();
    out["C"] = mat(e->C);
    out["A_z"] = mat(e->A_z);
    out["f_z"] = vec(e->f_z);
    out["zdot"] = vec(e->zdot);
  }
  std::cout << out.dump() << "\n";
}

void add_eom(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "eom",
      "Print A, f, ydot and xdot of Kane's equations at the model's initial state or a "
      "trajectory row");
  struct Options {
    std::string path;
    bool json = false, full = false;
    StateChoice state;
  };
  auto opt = std::make_shared<Options>();
  add_input_file(cmd, "MODEL", opt->path, kModelHelp)->required();
  cmd->add_flag("--json", opt->json, "print the JSON object of docs/model-format.md");
  cmd->add_flag("--full", opt->full,
                "print [A] as a 6N x 6N table at any N (default: up to 8 bodies; beyond, its "
                "block structure)");
  add_state_options(cmd, opt->state);
  cmd->callback([opt] {
    const io::ModelFile file = io::load_model_file(opt->path);
    // [A] is printed dense (kMaxEomBodies).
    if (file.model.num_bodies() > kMaxEomBodies)
      throw std::runtime_error(opt->path + ": eom prints the dense 6N x 6N [A], and N = " +
                               std::to_string(file.model.num_bodies()) + " is more than the " +
                               std::to_string(kMaxEomBodies) +
                               " bodies it prints; `kanedyn bench` and `kanedyn simulate` run "
                               "models of any size");
    Data data(file.model, DataOptions{.partials = false});  // [A] dense, as printed
    double t = 0.0;
    std::string where;
    VectorX q, z;
    const State state = chosen_state(file, opt->state, t, where, q, z, data.inputs);
    std::optional<ProjectedEquations> projected;
    if (file.jointed()) projected = projected_equations(file.model, q, z, data);
    kane_equations(file.model, state, data);
    // Every number printed is finite, or nothing is printed (JSON has no NaN).
    const bool finite = data.kane.A.allFinite() && data.kane.f.allFinite() &&
                        data.ydot.allFinite() && data.xdot.allFinite() &&
                        (!projected || (projected->C.allFinite() && projected->A_z.allFinite() &&
                                        projected->f_z.allFinite() && projected->zdot.allFinite()));
    if (!finite) throw std::runtime_error(opt->path + ": the equations of motion are not finite");
    if (opt->json) {
      print_json(file, data, projected ? &*projected : nullptr);
    } else {
      // A jointed model's own equations first: the n joint speeds are what a user of a robot
      // asks about; the notes' 6N system they come from follows.
      print_header(file, data, where);
      if (projected) print_projected(file, *projected, opt->full);
      print_tables(file, data, opt->full);
    }
  });
}

}  // namespace
KANEDYN_COMMAND(20, add_eom);
}  // namespace kanedyn::cli
