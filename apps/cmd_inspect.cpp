// `kanedyn inspect MODEL [--json] [--body K|NAME]... [--quantity NAME]...`: every quantity
// of the notes at the model's initial state, per body: [R_K], positions, velocities, the
// partial velocity matrices in the notes' block notation (symbolically and numerically), their
// rates, the resultants and each body's share of the generalized forces; for a model with
// constraints, the constraints at that state (their equations, the speed partition, the
// constrained motion and the reactions).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "commands.hpp"
#include "kanedyn/analysis.hpp"
#include "kanedyn/constraints.hpp"
#include "kanedyn/inspect.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/text.hpp"
#include "kanedyn/joints.hpp"
#include "options.hpp"

namespace kanedyn::cli {
namespace {

using Json = nlohmann::ordered_json;

/// The per-body quantities of the JSON object (docs/model-format.md, "Inspection output").
const std::vector<std::string>& quantity_names() {
  static const std::vector<std::string> names = {"R",         "p_O", "p_G",   "v_O",   "v_G",
                                                 "w",         "w_y", "v_O_y", "v_G_y", "v_O_y_dot",
                                                 "v_G_y_dot", "F",   "M",     "F_y",   "F_y_star"};
  return names;
}

Json vec(const VectorX& v) {
  Json a = Json::array();
  // nlohmann writes the shortest decimal that reads back as the same double: full precision.
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(v[i]);
  return a;
}

Json mat(const MatrixX& m) {
  Json a = Json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) a.push_back(vec(m.row(i).transpose()));
  return a;
}

Json body_json(const BodyInspection& b, const std::set<std::string>& wanted) {
  Json o;
  o["K"] = b.K;
  o["name"] = b.name;
  o["L"] = b.L;
  o["u"] = b.u;
  o["chain"] = b.chain;
  const auto put = [&](const char* key, Json value) {
    if (wanted.empty() || wanted.count(key)) o[key] = std::move(value);
  };
  put("R", mat(b.R));
  put("p_O", vec(b.p_O));
  put("p_G", vec(b.p_G));
  put("v_O", vec(b.v_O));
  put("v_G", vec(b.v_G));
  put("w", vec(b.w));
  put("w_y", mat(b.w_y));
  put("v_O_y", mat(b.v_O_y));
  put("v_G_y", mat(b.v_G_y));
  put("v_O_y_dot", mat(b.v_O_y_dot));
  put("v_G_y_dot", mat(b.v_G_y_dot));
  put("F", vec(b.F));
  put("M", vec(b.M));
  put("F_y", vec(b.F_y));
  put("F_y_star", vec(b.F_y_star));
  return o;
}

/// The "joints" object of inspect --json (docs/cli.md): per body its joint, q and z slices
/// and its rows of [C]; the projected equations.
Json joints_json(const JointInspection& j) {
  Json o;
  o["n"] = j.n;
  o["q"] = vec(j.q);
  o["z"] = vec(j.z);
  o["C"] = mat(j.C);
  o["Cdot_z"] = vec(j.Cdot_z);
  o["A_z"] = mat(j.A_z);
  o["f_z"] = vec(j.f_z);
  o["zdot"] = vec(j.zdot);
  o["ydot"] = vec(j.ydot);
  o["bodies"] = Json::array();
  for (const JointBodyInspection& b : j.bodies) {
    Json jb;
    jb["K"] = b.K;
    jb["type"] = to_string(b.type);
    jb["q"] = vec(b.q);
    jb["z"] = vec(b.z);
    jb["C_w"] = mat(b.C_w);
    jb["C_sd"] = mat(b.C_sd);
    o["bodies"].push_back(std::move(jb));
  }
  return o;
}

std::string v3(const Vector3& v);

/// The constraints at the inspected state (docs/cli.md, "Models with constraints"): the
/// equations, the speed partition and [C_I], and the constrained motion with its reactions.
/// The notes' per-body quantities stay the tree's; this is the motion the model really has.
struct ConstraintReport {
  std::vector<std::string> rows, speeds;  // row names; the speeds' names (z order)
  std::vector<char> holonomic;
  MatrixX B, C_I;
  VectorX b, errors, zdot, lambda;
  SpeedPartition partition;
  struct Reaction {
    std::string name, type;
    Vector3 point, force, moment;
  };
  std::vector<Reaction> reactions;
};

ConstraintReport constraint_report(const Model& model, const VectorX& q, const VectorX& z,
                                   const VectorX& u) {
  ConstraintReport r;
  const int n = model.num_speeds();
  ConstrainedDynamics dynamics(model);
  r.zdot.resize(n);
  dynamics.evaluate(q, z, u, r.zdot);
  const ConstraintEquations& eq = dynamics.equations();
  r.B = eq.B();
  r.b = eq.b();
  r.errors = eq.errors();
  r.lambda = dynamics.lambda();
  for (int i = 0; i < eq.rows(); ++i) {
    r.rows.push_back(eq.row_name(i));
    r.holonomic.push_back(eq.holonomic(i) ? 1 : 0);
  }
  const std::vector<std::string> names = tangent_state_names(model);
  r.speeds.assign(names.begin() + n, names.end());
  // The partition at this state (the model's independent_speeds when it names them), and
  // [C_I]: z = [C_I] z_I solves the independent rows of [B] z = 0 for the dependent speeds.
  r.partition = partition_speeds(model, r.B);
  const SpeedPartition& p = r.partition;
  r.C_I = independent_basis(r.B, p);
  for (int c = 0; c < model.num_constraints(); ++c) {
    const Constraint& k = model.constraints()[static_cast<size_t>(c)];
    r.reactions.push_back(
        {k.name, to_string(k.type), eq.point(c), eq.force(c, r.lambda), eq.moment(c, r.lambda)});
  }
  return r;
}

/// The "constraints" object of inspect --json (docs/cli.md).
Json constraints_json(const ConstraintReport& r) {
  const auto names = [](const std::vector<std::string>& all, const std::vector<int>& which) {
    Json a = Json::array();
    for (const int i : which) a.push_back(all[static_cast<size_t>(i)]);
    return a;
  };
  Json o;
  o["rows"] = r.rows;
  Json hol = Json::array();
  for (const char h : r.holonomic) hol.push_back(h != 0);
  o["holonomic"] = std::move(hol);
  o["B"] = mat(r.B);
  o["b"] = vec(r.b);
  o["errors"] = vec(r.errors);
  o["rank"] = r.partition.rank;
  o["redundant_rows"] = names(r.rows, r.partition.redundant_rows);
  o["independent_speeds"] = names(r.speeds, r.partition.independent);
  o["dependent_speeds"] = names(r.speeds, r.partition.dependent);
  o["C_I"] = mat(r.C_I);
  o["zdot"] = vec(r.zdot);
  o["lambda"] = vec(r.lambda);
  o["reactions"] = Json::array();
  for (const ConstraintReport::Reaction& x : r.reactions) {
    Json e;
    e["name"] = x.name;
    e["type"] = x.type;
    e["point"] = vec(x.point);
    e["force"] = vec(x.force);
    if (x.type == "hinge") e["moment"] = vec(x.moment);
    o["reactions"].push_back(std::move(e));
  }
  return o;
}

void print_wrapped(const std::string& line, size_t indent);

/// The constraints' block of the text output: the same numbers as constraints_json.
void print_constraints_text(const ConstraintReport& r) {
  const SpeedPartition& p = r.partition;
  const auto list = [](const std::vector<std::string>& all, const std::vector<int>& which) {
    std::string s;
    for (const int i : which) s += (s.empty() ? "" : ", ") + all[static_cast<size_t>(i)];
    return s.empty() ? std::string("none") : s;
  };
  std::printf(
      "\nconstraints: %d equations, rank %d; [B]{z} = 0, [B]{z dot} + {b} = 0 (the notes' "
      "quantities\nabove are the tree's without them; z dot here is the constrained motion)\n",
      static_cast<int>(r.rows.size()), p.rank);
  print_wrapped("redundant rows: " + list(r.rows, p.redundant_rows), 2);
  print_wrapped("independent speeds: " + list(r.speeds, p.independent), 2);
  print_wrapped("dependent speeds: " + list(r.speeds, p.dependent), 2);
  std::printf("  %-22s %-9s %17s %17s %17s\n", "row", "holonomic", "error", "b", "lambda");
  for (size_t i = 0; i < r.rows.size(); ++i) {
    const auto e = static_cast<Eigen::Index>(i);
    std::printf("  %-22s %-9s % .10e % .10e % .10e\n", io::printable(r.rows[i], 22).c_str(),
                r.holonomic[i] ? "yes" : "no", r.errors[e], r.b[e], r.lambda[e]);
    std::string line = "[B] = ";
    std::string terms;
    for (Eigen::Index j = 0; j < r.B.cols(); ++j) {
      if (r.B(e, j) == 0.0) continue;
      char buf[64];
      std::snprintf(buf, sizeof buf, "% .6g ", r.B(e, j));
      terms += (terms.empty() ? "" : ", ") + std::string(buf) + r.speeds[static_cast<size_t>(j)];
    }
    print_wrapped(line + (terms.empty() ? "0" : terms), 4);
  }
  std::printf("  [C_I]: z = [C_I] z_I, each dependent speed from the independent ones\n");
  for (const int d : p.dependent) {
    std::string terms;
    for (size_t j = 0; j < p.independent.size(); ++j) {
      const double v = r.C_I(d, static_cast<Eigen::Index>(j));
      if (v == 0.0) continue;
      char buf[64];
      std::snprintf(buf, sizeof buf, "% .6g ", v);
      terms += (terms.empty() ? "" : ", ") + std::string(buf) +
               r.speeds[static_cast<size_t>(p.independent[j])];
    }
    print_wrapped(r.speeds[static_cast<size_t>(d)] + " = " + (terms.empty() ? "0" : terms), 4);
  }
  std::printf("  %-22s %17s\n", "speed", "z dot");
  for (size_t i = 0; i < r.speeds.size(); ++i)
    std::printf("  %-22s % .10e\n", io::printable(r.speeds[i], 22).c_str(),
                r.zdot[static_cast<Eigen::Index>(i)]);
  std::printf("  reactions on each constraint's body, inertial components:\n");
  for (const ConstraintReport::Reaction& x : r.reactions) {
    std::printf("    %s (%s) at %s\n", io::printable(x.name).c_str(), x.type.c_str(),
                v3(x.point).c_str());
    std::printf("      force  %s\n", v3(x.force).c_str());
    if (x.type == "hinge") std::printf("      moment %s\n", v3(x.moment).c_str());
  }
}

void print_joints_text(const JointInspection& j, const Inspection& in) {
  std::printf(
      "\njoints: y = [C] z, n = %d independent speeds; [C]^T [A] [C] {z dot} = "
      "[C]^T ({f} - [A][C dot]{z}) + Q\n",
      j.n);
  for (size_t s = 0; s < j.bodies.size(); ++s) {
    const JointBodyInspection& b = j.bodies[s];
    std::printf("  body %d '%s': %s joint, q =", b.K, io::printable(in.bodies[s].name).c_str(),
                to_string(b.type));
    for (const double v : b.q) std::printf(" % .6g", v);
    std::printf(", z =");
    for (const double v : b.z) std::printf(" % .6g", v);
    std::printf("\n");
    // The nonzero columns of K's rows of [C]: the speeds of the joints on its chain.
    for (int c = 0; c < j.n; ++c) {
      const Vector3 w = b.C_w.col(c), sd = b.C_sd.col(c);
      if (w.isZero(0.0) && sd.isZero(0.0)) continue;
      std::printf("    [C] column z%-4d w' %s  s' dot %s\n", c + 1, v3(w).c_str(), v3(sd).c_str());
    }
  }
  std::printf("  %-6s %18s %18s\n", "z", "f_z", "z dot");
  for (int i = 0; i < j.n; ++i) std::printf("  z%-5d % .10e % .10e\n", i + 1, j.f_z[i], j.zdot[i]);
}

void print_json(const Inspection& in, const std::set<std::string>& wanted,
                const ConstraintReport* constraints) {
  Json out;
  out["N"] = in.N;
  out["t"] = in.t;
  out["F_y"] = vec(in.F_y);
  out["F_y_star"] = vec(in.F_y_star);
  out["ydot"] = vec(in.ydot);
  out["bodies"] = Json::array();
  for (const BodyInspection& b : in.bodies) out["bodies"].push_back(body_json(b, wanted));
  if (in.joints) out["joints"] = joints_json(*in.joints);
  if (constraints) out["constraints"] = constraints_json(*constraints);
  std::cout << out.dump() << "\n";
}

constexpr size_t kWidth = 100;  // text lines wrap here, at a block boundary

/// Prints "label = ..." wrapped at kWidth at ", " boundaries, continuation lines indented.
void print_wrapped(const std::string& line, size_t indent) {
  const std::string pad(indent, ' ');
  const size_t hang =
      std::min(line.find("= ") == std::string::npos ? 0 : line.find("= ") + 2, kWidth / 2);
  std::string current = pad;
  size_t pos = 0;
  while (pos < line.size()) {
    size_t next = line.find(", ", pos);
    next = next == std::string::npos ? line.size() : next + 2;
    const std::string piece = line.substr(pos, next - pos);
    if (current.size() + piece.size() > kWidth && current.size() > indent + hang) {
      while (current.back() == ' ') current.pop_back();
      std::printf("%s\n", current.c_str());
      current = pad + std::string(hang, ' ');
    }
    current += piece;
    pos = next;
  }
  std::printf("%s\n", current.c_str());
}

std::string v3(const Vector3& v) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(% .6g, % .6g, % .6g)", v.x(), v.y(), v.z());
  return buf;
}

/// The nonzero 3x3 blocks of a 3 x 6N matrix, each labelled with the speed it multiplies.
void print_blocks(const MatrixX& m, int n) {
  int zero = 0;
  for (int part = 0; part < 2; ++part)
    for (int c = 0; c < n; ++c) {
      const Matrix3 b = m.block<3, 3>(0, 3 * n * part + 3 * c);
      if (b.isZero(0.0)) {
        ++zero;
        continue;
      }
      const std::string label =
          (part == 0 ? "w'_" : "s'_") + std::to_string(c + 1) + (part == 0 ? "" : " dot");
      for (int r = 0; r < 3; ++r)
        std::printf("      %-12s % 12.6g % 12.6g % 12.6g\n", r == 0 ? label.c_str() : "", b(r, 0),
                    b(r, 1), b(r, 2));
    }
  std::printf("      (%d of %d blocks are zero)\n", zero, 2 * n);
}

void print_text(const io::ModelFile& file, const Inspection& in, const std::string& where,
                const std::set<std::string>& wanted) {
  const Model& model = file.model;
  const int n = in.N;
  const auto want = [&](const char* key) { return wanted.empty() || wanted.count(key) > 0; };
  std::printf("%s at %s, N = %d\n", io::printable(file.path).c_str(), where.c_str(), n);
  for (const BodyInspection& b : in.bodies) {
    const int k = b.K - 1;
    const std::string chain = chain_text(model, k);
    std::printf("\nbody %d '%s': L(%d) = %d, u = %d, chain %s\n", b.K,
                io::printable(b.name).c_str(), b.K, b.L, b.u, chain.c_str());
    if (want("R"))
      for (int r = 0; r < 3; ++r)
        std::printf("  %-10s % 12.6g % 12.6g % 12.6g\n", r == 0 ? "[R]" : "", b.R(r, 0), b.R(r, 1),
                    b.R(r, 2));
    const auto row = [&](const char* key, const char* label, const Vector3& v) {
      if (want(key)) std::printf("  %-10s %s\n", label, v3(v).c_str());
    };
    row("p_O", "p_O", b.p_O);
    row("p_G", "p_G", b.p_G);
    row("v_O", "v_O", b.v_O);
    row("v_G", "v_G", b.v_G);
    row("w", "w'", b.w);
    if (want("w_y")) {
      // Eq. (8): the constant selection of w'_K from {y}.
      std::string y1 = "[w'_" + std::to_string(b.K) + ",y1] = [ ";
      if (n <= 12) {
        for (int c = 1; c <= n; ++c) y1 += (c > 1 ? ", " : "") + std::string(c == b.K ? "I" : "0");
        y1 += " ]";
      } else {
        y1 += std::to_string(b.K) + ": I ]  (" + std::to_string(n - 1) + " zero blocks not shown)";
      }
      std::printf("  w_y (Eq. 8)\n");
      print_wrapped(y1, 4);
      std::printf("    [w'_%d,y2] = 0\n", b.K);
    }
    const struct {
      const char* key;
      Point point;
      bool rate;
      const MatrixX* value;
    } partials[] = {{"v_O_y", Point::O, false, &b.v_O_y},
                    {"v_G_y", Point::G, false, &b.v_G_y},
                    {"v_O_y_dot", Point::O, true, &b.v_O_y_dot},
                    {"v_G_y_dot", Point::G, true, &b.v_G_y_dot}};
    for (const auto& p : partials) {
      if (!want(p.key)) continue;
      std::printf(
          "  %s (Eq. %s)\n", p.key,
          p.rate ? (p.point == Point::O ? "30" : "29") : (p.point == Point::O ? "18" : "21"));
      for (int part = 1; part <= 2; ++part)
        print_wrapped(format_symbolic(model, k, p.point, p.rate, part), 4);
      print_blocks(*p.value, n);
    }
    row("F", "F", b.F);
    row("M", "M'", b.M);
  }
}

/// A row of Kane's equations: its number 1..6N in the notes' numbering of {y}, or its label
/// (w8.2, sd3.1); 0-based. Throws naming the problem.
int parse_row(const std::string& path, const std::string& text, int n) {
  for (int i = 0; i < 6 * n; ++i)
    if (text == speed_label(n, i) || text == std::to_string(i + 1)) return i;
  throw std::runtime_error(path + ": --row " + io::printable(text, 40) + ": no such row (give 1.." +
                           std::to_string(6 * n) + " or a label wK.c or sdK.c, K = 1.." +
                           std::to_string(n) + ", c = 1..3)");
}

/// Which bodies drive speed i: each body's share of F_y (Eq. 31) and of F_y* at the solved
/// {y dot}, largest first; Kane's equations say the sums cancel. Returns false if they do not
/// to round-off.
bool print_row(const io::ModelFile& file, const Inspection& in, const std::string& where, int i) {
  const int n = in.N;
  struct Share {
    int K;
    double fy, fy_star;
  };
  std::vector<Share> shares;
  double scale = 0.0;
  for (const BodyInspection& b : in.bodies) {
    const Share s{b.K, b.F_y[i], b.F_y_star[i]};
    scale = std::max({scale, std::abs(s.fy), std::abs(s.fy_star)});
    if (s.fy != 0.0 || s.fy_star != 0.0) shares.push_back(s);
  }
  // Largest first, by the size rounded to 9 digits of the largest share, so that shares equal
  // but for round-off (a symmetric pair of legs) keep the body order on every machine.
  const auto size = [&](const Share& s) {
    return scale > 0.0 ? std::round(std::max(std::abs(s.fy), std::abs(s.fy_star)) / scale * 1e9)
                       : 0.0;
  };
  std::stable_sort(shares.begin(), shares.end(),
                   [&](const Share& a, const Share& b) { return size(a) > size(b); });
  const std::string label = speed_label(n, i);
  std::printf("%s at %s\nrow %d of Kane's equations (speed %s: %s), F_y + F_y* = 0\n",
              io::printable(file.path).c_str(), where.c_str(), i + 1, label.c_str(),
              i < 3 * n ? "w'_K component, body-K axes" : "s'_K dot component, body-J axes");
  std::printf("  %-4s %-20s %16s %16s\n", "K", "body", "F_y (Eq. 31)", "F_y*");
  for (const Share& s : shares)
    std::printf("  %-4d %-20s % 16.9g % 16.9g\n", s.K,
                io::printable(file.model.body(s.K - 1).name, 20).c_str(), s.fy, s.fy_star);
  std::printf("  (%d of %d bodies contribute)\n", static_cast<int>(shares.size()), n);
  const double sum = in.F_y[i] + in.F_y_star[i];
  // The residual of Newton-Euler per body (the recursive route solved for {y dot}): ~6N eps
  // times the largest term.
  const double tolerance = 1e-12 * std::max(scale, 1e-300) * std::max(1, n / 100);
  const bool ok = std::abs(sum) <= tolerance;
  std::printf("  sum  %-20s % 16.9g % 16.9g\n  F_y + F_y* = %.3g: %s (round-off bound %.3g)\n", "",
              in.F_y[i], in.F_y_star[i], sum, ok ? "cancels" : "DOES NOT CANCEL", tolerance);
  return ok;
}

/// Body numbers (1..N) or names to 0-based indices; throws naming the unknown one.
std::vector<int> select_bodies(const Model& model, const std::string& path,
                               const std::vector<std::string>& wanted) {
  std::vector<int> out;
  for (const std::string& w : wanted) {
    int k = -1;
    if (!w.empty() &&
        std::all_of(w.begin(), w.end(), [](char c) { return c >= '0' && c <= '9'; }) &&
        w.size() < 10) {
      const int number = std::stoi(w);
      if (number >= 1 && number <= model.num_bodies()) k = number - 1;
    }
    for (int b = 0; k < 0 && b < model.num_bodies(); ++b)
      if (model.body(b).name == w) k = b;
    if (k < 0) {
      std::vector<std::string> names;
      for (int b = 0; b < model.num_bodies(); ++b) names.push_back(model.body(b).name);
      const std::string hint = io::closest_word(w, names);
      throw std::runtime_error(path + ": --body " + io::printable(w) + ": no such body (give 1.." +
                               std::to_string(model.num_bodies()) + " or a body's name" +
                               (hint.empty() ? "" : "; did you mean '" + hint + "'?") + ")");
    }
    if (std::find(out.begin(), out.end(), k) == out.end()) out.push_back(k);
  }
  std::sort(out.begin(), out.end());
  return out;
}

void add_inspect(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "inspect", "Print every quantity of the notes per body at the model's initial state");
  struct Options {
    std::string path;
    bool json = false;
    std::vector<std::string> bodies, quantities;
    std::string row;
    StateChoice state;
  };
  auto opt = std::make_shared<Options>();
  add_input_file(cmd, "MODEL", opt->path, kModelHelp)->required();
  cmd->add_flag("--json", opt->json,
                "print the JSON object of docs/model-format.md, \"Inspection output\"");
  cmd->add_option("--body", opt->bodies, "a body by number (1..N) or name (repeatable)");
  cmd->add_option("--quantity", opt->quantities,
                  "a per-body quantity: R, p_O, p_G, v_O, v_G, w, w_y, v_O_y, v_G_y, v_O_y_dot, "
                  "v_G_y_dot, F, M, F_y, F_y_star (repeatable; default: all)");
  auto* row = cmd->add_option(
      "--row", opt->row,
      "explain one row of Kane's equations: each body's share of F_y and F_y* (1..6N, or a "
      "label such as w8.2 or sd3.1)");
  add_state_options(cmd, opt->state);
  row->excludes(cmd->get_option("--json"));
  row->excludes(cmd->get_option("--body"));
  row->excludes(cmd->get_option("--quantity"));
  cmd->callback([opt] {
    // An unknown quantity is bad input like an unknown body: exit 1, with the closest name.
    for (const std::string& q : opt->quantities)
      if (std::find(quantity_names().begin(), quantity_names().end(), q) ==
          quantity_names().end()) {
        const std::string hint = io::closest_word(q, quantity_names());
        throw std::runtime_error("--quantity " + io::printable(q, 40) + ": no such quantity (" +
                                 (hint.empty() ? "" : "did you mean '" + hint + "'? ") +
                                 "see kanedyn inspect --help)");
      }
    const io::ModelFile file = io::load_model_file(opt->path);
    const std::vector<int> bodies = select_bodies(file.model, opt->path, opt->bodies);
    if (!file.model.has_flat_chains())
      throw std::runtime_error(
          opt->path + ": the model's " + std::to_string(file.model.num_bodies()) + " bodies have " +
          std::to_string(file.model.chain_entries()) + " chain entries, more than the " +
          std::to_string(Model::kMaxFlatChainEntries) +
          " for which the partial velocity blocks are built");
    double t = 0.0;
    std::string where;
    VectorX q, z, u;
    const State state = chosen_state(file, opt->state, t, where, q, z, u);
    const int row_index =
        opt->row.empty() ? -1 : parse_row(opt->path, opt->row, file.model.num_bodies());
    const Inspection in = inspect(file.model, q, z, t, bodies, u);
    // Every number printed is finite, or nothing is printed (JSON has no NaN).
    if (const std::string bad = in.first_non_finite(); !bad.empty())
      throw std::runtime_error(opt->path + ": the quantities at this state are not finite (" + bad +
                               ", the first such)");
    if (row_index >= 0) {
      if (!print_row(file, in, where, row_index))
        throw std::runtime_error(opt->path + ": row " + opt->row +
                                 " of Kane's equations does not cancel to round-off");
      return;
    }
    const std::set<std::string> wanted(opt->quantities.begin(), opt->quantities.end());
    std::optional<ConstraintReport> constraints;
    if (file.model.num_constraints() > 0) {
      constraints = constraint_report(file.model, q, z, u);
      if (!constraints->zdot.allFinite() || !constraints->lambda.allFinite() ||
          !constraints->B.allFinite() || !constraints->C_I.allFinite())
        throw std::runtime_error(opt->path +
                                 ": the constraints' quantities at this state are not finite");
    }
    if (opt->json) {
      print_json(in, wanted, constraints ? &*constraints : nullptr);
    } else {
      print_text(file, in, where, wanted);
      if (in.joints) print_joints_text(*in.joints, in);
      if (constraints) print_constraints_text(*constraints);
    }
  });
}

}  // namespace
KANEDYN_COMMAND(25, add_inspect);
}  // namespace kanedyn::cli
