#include "kanedyn/inspect.hpp"

#include <algorithm>
#include <stdexcept>

#include "kanedyn/data.hpp"
#include "kanedyn/dynamics.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"

namespace kanedyn {

namespace {

size_t at(long long i) { return static_cast<size_t>(i); }

std::string num(int k) { return std::to_string(k + 1); }  // the notes' body number

std::string rt(int j) { return "[R_" + num(j) + "]^T"; }

}  // namespace

Inspection inspect(const Model& model, const State& state, double t, const std::vector<int>& bodies,
                   const VectorX& inputs) {
  const int n = model.num_bodies();
  for (const int k : bodies)
    if (k < 0 || k >= n)
      throw std::out_of_range("inspect: body index " + std::to_string(k) + " outside 0.." +
                              std::to_string(n - 1));
  // {y dot} by the O(N) route: the assembled route's tree LDL^T costs O(N d^2), cubic for a
  // long chain (a 1000-body chain: seconds), and both solve Eq. (36) to round-off.
  if (inputs.size() != 0 && inputs.size() != model.num_inputs())
    throw std::invalid_argument("inspect: " + std::to_string(inputs.size()) + " input values for " +
                                std::to_string(model.num_inputs()) +
                                (model.num_inputs() == 1 ? " input" : " inputs"));
  Data data(model, DataOptions{.kane_terms = false, .dense_mass_matrix = false});
  if (inputs.size() > 0) data.inputs = inputs;
  compute_kinematics(model, state, data);
  compute_partials_recursive(model, state, data);
  compute_partial_rates(model, state, data);
  compute_resultants(model, state, data);
  forward_dynamics(model, state, data, Route::recursive);
  Inspection out;
  out.N = n;
  out.t = t;
  out.ydot = data.ydot;
  out.F_y = VectorX::Zero(6 * n);
  out.F_y_star = VectorX::Zero(6 * n);
  std::vector<char> selected(at(n), bodies.empty() ? 1 : 0);
  for (const int k : bodies) selected[at(k)] = 1;
  const Partials& p = data.partials;
  const Kinematics& kin = data.kinematics;
  VectorX fy(6 * n), fy_star(6 * n);
  for (int k = 0; k < n; ++k) {
    const BodySpec& b = model.body(k);
    const Model::Chain chain = model.chain(k);
    const size_t o = at(model.chain_offset(k));
    const auto i = at(k);
    // {a_G_K} = [v_G_K,y]{y dot} + [v_G_K,y dot]{y} (Eq. 33), over K's chain blocks only.
    Vector3 a_g = Vector3::Zero();
    for (int r = 0; r < chain.size; ++r) {
      const int c = chain[r];
      const size_t e = o + at(r);
      a_g += p.vG_w[e] * data.ydot.segment<3>(3 * c) +
             p.vG_s[e] * data.ydot.segment<3>(3 * n + 3 * c) +
             p.vG_w_dot[e] * state.angular_velocity(c) + p.vG_s_dot[e] * state.translation_rate(c);
    }
    const Vector3 w = state.angular_velocity(k);
    const Vector3 alpha = data.ydot.segment<3>(3 * k);  // Eq. (10)
    const Vector3 inertia_moment = b.inertia * alpha + w.cross(b.inertia * w);
    fy.setZero();
    fy_star.setZero();
    for (int r = 0; r < chain.size; ++r) {
      const int c = chain[r];
      const size_t e = o + at(r);
      fy.segment<3>(3 * c) += p.vG_w[e].transpose() * data.loads.force[i];
      fy.segment<3>(3 * n + 3 * c) += p.vG_s[e].transpose() * data.loads.force[i];
      fy_star.segment<3>(3 * c) -= b.mass * (p.vG_w[e].transpose() * a_g);
      fy_star.segment<3>(3 * n + 3 * c) -= b.mass * (p.vG_s[e].transpose() * a_g);
    }
    fy.segment<3>(3 * k) += data.loads.moment_b[i];  // [w'_K,y]^T selects w'_K (Eq. 8)
    fy_star.segment<3>(3 * k) -= inertia_moment;
    out.F_y += fy;
    out.F_y_star += fy_star;
    if (!selected[i]) continue;
    BodyInspection bi;
    bi.K = k + 1;
    bi.name = b.name;
    bi.L = model.lower_body(k) + 1;
    bi.u = model.depth(k);
    for (int r = 0; r < chain.size; ++r) bi.chain.push_back(chain[r] + 1);
    bi.chain.push_back(0);
    bi.R = kin.R[i];
    bi.p_O = kin.p_O[i];
    bi.p_G = kin.p_G[i];
    bi.v_O = kin.v_O[i];
    bi.v_G = kin.v_G[i];
    bi.w = w;
    bi.w_y = angular_velocity_partial(model, k);
    bi.v_O_y = partial_velocity(model, data, k, Point::O);
    bi.v_G_y = partial_velocity(model, data, k, Point::G);
    bi.v_O_y_dot = partial_velocity_rate(model, data, k, Point::O);
    bi.v_G_y_dot = partial_velocity_rate(model, data, k, Point::G);
    bi.F = data.loads.force[i];
    bi.M = data.loads.moment_b[i];
    bi.F_y = fy;
    bi.F_y_star = fy_star;
    out.bodies.push_back(std::move(bi));
  }
  return out;
}

SymbolicPartial symbolic_partial(const Model& model, int k, Point point, bool rate) {
  if (k < 0 || k >= model.num_bodies())
    throw std::out_of_range("symbolic_partial: body index " + std::to_string(k));
  SymbolicPartial s;
  const Model::Chain chain = model.chain(k);
  const int u = chain.size - 1;
  // Eqs. (26)-(27) and, differentiated, Eqs. (29)-(30): with C = L^r(K) and J = L^{r+1}(K),
  // the y1 block at J is -[R_J]^T([q~'_C]+[s~'_C]) (its rate -[R_J]^T([w~'_J]([q~'_C]+[s~'_C])
  // + [sd~'_C])), the y2 block at C is [R_J]^T (rate [R_J]^T[w~'_J]), [I] at the root (rate
  // 0); for G_K also -[R_K]^T[r~'_K] at K (rate -[R_K]^T[w~'_K][r~'_K]).
  for (int r = u - 1; r >= 0; --r) {
    const int c = chain[r], j = chain[r + 1];
    const std::string qs = "[q~'_" + num(c) + "]+[s~'_" + num(c) + "]";
    s.y1.push_back({j + 1, rate ? rt(j) + "([w~'_" + num(j) + "](" + qs + ")+[sd~'_" + num(c) + "])"
                                : rt(j) + "(" + qs + ")"});
  }
  if (point == Point::G)
    s.y1.push_back({k + 1, rate ? rt(k) + "[w~'_" + num(k) + "][r~'_" + num(k) + "]"
                                : rt(k) + "[r~'_" + num(k) + "]"});
  if (!rate) s.y2.push_back({chain[u] + 1, "I"});
  for (int r = u - 1; r >= 0; --r) {
    const int j = chain[r + 1];
    s.y2.push_back({chain[r] + 1, rate ? rt(j) + "[w~'_" + num(j) + "]" : rt(j)});
  }
  // Body order (the columns of the matrix): the chain is walked from the root, so the
  // blocks are already ascending wherever L(K) < K; sort for models numbered otherwise.
  const auto by_body = [](const SymbolicBlock& a, const SymbolicBlock& b) {
    return a.body < b.body;
  };
  std::stable_sort(s.y1.begin(), s.y1.end(), by_body);
  std::stable_sort(s.y2.begin(), s.y2.end(), by_body);
  return s;
}

std::string format_symbolic(const Model& model, int k, Point point, bool rate, int part,
                            int max_dense_blocks) {
  if (part != 1 && part != 2) throw std::invalid_argument("format_symbolic: part is 1 or 2");
  const SymbolicPartial s = symbolic_partial(model, k, point, rate);
  const std::vector<SymbolicBlock>& blocks = part == 1 ? s.y1 : s.y2;
  const int n = model.num_bodies();
  std::string out = std::string("[v_") + (point == Point::O ? "O" : "G") + num(k) + ",y" +
                    std::to_string(part) + (rate ? " dot" : "") + "] = ";
  if (blocks.empty()) return out + "0";
  const bool negated = part == 1 && s.y1_negated;
  out += negated ? "-[ " : "[ ";
  if (n <= max_dense_blocks) {
    size_t next = 0;
    for (int c = 1; c <= n; ++c) {
      if (c > 1) out += ", ";
      if (next < blocks.size() && blocks[next].body == c)
        out += blocks[next++].symbol;
      else
        out += "0";
    }
    return out + " ]";
  }
  for (size_t b = 0; b < blocks.size(); ++b) {
    if (b > 0) out += ", ";
    out += std::to_string(blocks[b].body) + ": " + blocks[b].symbol;
  }
  return out + " ]  (" + std::to_string(n - static_cast<int>(blocks.size())) +
         " zero blocks not shown)";
}

std::vector<std::vector<int>> mass_matrix_structure(const Model& model) {
  const int n = model.num_bodies();
  std::vector<std::vector<int>> rows(at(n));
  for (int k = 0; k < n; ++k) {
    const Model::Chain chain = model.chain(k);
    for (int r = 0; r < chain.size; ++r) {
      rows[at(k)].push_back(chain[r] + 1);
      if (r > 0) rows[at(chain[r])].push_back(k + 1);  // the transposed block
    }
  }
  for (std::vector<int>& row : rows) std::sort(row.begin(), row.end());
  return rows;
}

Inspection inspect(const Model& model, const VectorX& q, const VectorX& z, double t,
                   const std::vector<int>& bodies, const VectorX& inputs) {
  if (q.size() != model.num_coordinates() || z.size() != model.num_speeds())
    throw std::invalid_argument("inspect: q and z do not have the model's sizes");
  const int n = model.num_bodies();
  State state(model);
  joint_state(model, q, z, state);
  Inspection out = inspect(model, state, t, bodies, inputs);
  if (model.all_free()) return out;
  Data data(model, DataOptions{.partials = false});
  if (inputs.size() > 0) data.inputs = inputs;
  ProjectedEquations e = projected_equations(model, q, z, data);
  JointInspection j;
  j.n = model.num_speeds();
  j.q = q;
  j.z = z;
  j.ydot = e.C * e.zdot + e.Cdot_z;
  for (const BodyInspection& b : out.bodies) {
    const int k = b.K - 1;
    JointBodyInspection jb;
    jb.K = b.K;
    jb.type = model.joint(k).type;
    jb.q = q.segment(model.coordinate_offset(k), coordinate_count(jb.type));
    jb.z = z.segment(model.speed_offset(k), speed_count(jb.type));
    // A model of welds only has no speeds: [C] has no columns and no storage to offset into.
    if (e.C.cols() == 0) {
      jb.C_w = jb.C_sd = MatrixX(3, 0);
    } else {
      jb.C_w = e.C.middleRows(3 * k, 3);
      jb.C_sd = e.C.middleRows(3 * n + 3 * k, 3);
    }
    j.bodies.push_back(std::move(jb));
  }
  j.C = std::move(e.C);
  j.Cdot_z = std::move(e.Cdot_z);
  j.A_z = std::move(e.A_z);
  j.f_z = std::move(e.f_z);
  j.zdot = std::move(e.zdot);
  out.joints = std::move(j);
  return out;
}

std::string Inspection::first_non_finite() const {
  const auto bad = [](const auto& m) { return !m.allFinite(); };
  if (bad(F_y)) return "F_y";
  if (bad(F_y_star)) return "F_y_star";
  if (bad(ydot)) return "ydot";
  for (const BodyInspection& b : bodies) {
    const std::string body = "body " + std::to_string(b.K) + " ";
    const std::pair<const char*, bool> parts[] = {{"R", bad(b.R)},
                                                  {"p_O", bad(b.p_O)},
                                                  {"p_G", bad(b.p_G)},
                                                  {"v_O", bad(b.v_O)},
                                                  {"v_G", bad(b.v_G)},
                                                  {"w", bad(b.w)},
                                                  {"w_y", bad(b.w_y)},
                                                  {"v_O_y", bad(b.v_O_y)},
                                                  {"v_G_y", bad(b.v_G_y)},
                                                  {"v_O_y_dot", bad(b.v_O_y_dot)},
                                                  {"v_G_y_dot", bad(b.v_G_y_dot)},
                                                  {"F", bad(b.F)},
                                                  {"M", bad(b.M)},
                                                  {"F_y", bad(b.F_y)},
                                                  {"F_y_star", bad(b.F_y_star)}};
    for (const auto& [name, is_bad] : parts)
      if (is_bad) return body + name;
  }
  if (joints) {
    const JointInspection& j = *joints;
    const std::pair<const char*, bool> parts[] = {
        {"q", bad(j.q)},     {"z", bad(j.z)},     {"C", bad(j.C)},       {"Cdot_z", bad(j.Cdot_z)},
        {"A_z", bad(j.A_z)}, {"f_z", bad(j.f_z)}, {"zdot", bad(j.zdot)}, {"ydot", bad(j.ydot)}};
    for (const auto& [name, is_bad] : parts)
      if (is_bad) return std::string("joints ") + name;
    for (const JointBodyInspection& b : j.bodies)
      if (bad(b.C_w) || bad(b.C_sd)) return "joints body " + std::to_string(b.K) + " C";
  }
  return "";
}

}  // namespace kanedyn
