// The fused O(N) route: its plan (the per-body tables of the kernels, src/recursive/
// fused_kernel.inc) and the choice of SIMD width (src/recursive/fused.hpp).
#include "fused.hpp"

#include "../workspace.hpp"

#include <algorithm>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "kanedyn/forces.hpp"

namespace kanedyn::fused {

namespace {

size_t at(long long i) { return static_cast<size_t>(i); }

/// Keeps one copy of each distinct field of a group (its lanes doubles, equal bit for bit) in
/// plan.params, and one copy of each distinct row of a group's kParamFields offsets into it
/// (plan.param_rows); every group of bodies points at its row (plan.param_group).
/// Along a chain of identical links every group but the first has the same row, so past the
/// caches the kernel streams about a third less memory per body. Bodies that differ (a random
/// tree's masses and widths) still share the fields that agree, as the zero products of
/// inertia, the zero loads, the joint and mass centre of identical link shapes: of the 36 fields
/// of such a tree 8 differ, and a third of the constants' memory is read per body.
void share_equal_params(int groups, int lanes, Plan& plan) {
  const size_t field_size = at(lanes);
  const size_t field_bytes = field_size * sizeof(double);
  std::vector<double> unique;
  // The fields and rows seen so far, as views of their bytes in plan.params and rows (both
  // kept until the end).
  std::unordered_map<std::string_view, int> field_index, row_index;
  std::vector<int> rows(at(groups) * at(kParamFields));
  for (size_t f = 0; f < rows.size(); ++f) {
    const double* p = plan.params.data() + f * field_size;
    const std::string_view bytes(reinterpret_cast<const char*>(p), field_bytes);
    const auto [it, added] = field_index.emplace(bytes, static_cast<int>(unique.size()));
    if (added) unique.insert(unique.end(), p, p + field_size);
    rows[f] = it->second;
  }
  plan.param_group.assign(at(groups), 0);
  for (int g = 0; g < groups; ++g) {
    const int* row = rows.data() + at(g) * at(kParamFields);
    const std::string_view bytes(reinterpret_cast<const char*>(row), kParamFields * sizeof(int));
    const auto [it, added] =
        row_index.emplace(bytes, static_cast<int>(plan.param_rows.size()) / kParamFields);
    if (added) plan.param_rows.insert(plan.param_rows.end(), row, row + kParamFields);
    plan.param_group[at(g)] = it->second;
  }
  unique.shrink_to_fit();
  plan.params = std::move(unique);
  plan.param_rows.shrink_to_fit();
}

/// The bodies in depth-first pre-order: each root, then its children's subtrees one after the
/// other, children in the Model's order. Every body then comes after its lower body, and its
/// lower body's data (and the path up to the root) was touched shortly before, where in a
/// random numbering it is anywhere in memory. Children taken in the Model's order reach each
/// lower body's loads in the same order as in the Model's numbering, so the sums are the same
/// bit for bit.
std::vector<int> depth_first_order(const Model& model) {
  const int n = model.num_bodies();
  // The children of each body (and of the ground, slot n), in increasing number.
  std::vector<int> first(at(n) + 2, 0), children(at(n));
  for (int k = 0; k < n; ++k) {
    const int j = model.body(k).lower_body;
    ++first[at(j == kGround ? n : j) + 1];
  }
  for (int k = 0; k <= n; ++k) first[at(k) + 1] += first[at(k)];
  std::vector<int> fill(first.begin(), first.end() - 1);
  for (int k = 0; k < n; ++k) {
    const int j = model.body(k).lower_body;
    children[at(fill[at(j == kGround ? n : j)]++)] = k;
  }
  std::vector<int> order, stack;
  order.reserve(at(n));
  for (int c = first[at(n) + 1]; c-- > first[at(n)];) stack.push_back(children[at(c)]);
  while (!stack.empty()) {
    const int k = stack.back();
    stack.pop_back();
    order.push_back(k);
    for (int c = first[at(k) + 1]; c-- > first[at(k)];) stack.push_back(children[at(c)]);
  }
  return order;
}

}  // namespace

int widest_supported_lanes() {
#if defined(__x86_64__) || defined(__i386__)
  static const int lanes = __builtin_cpu_supports("avx512f") ? 8
                           : __builtin_cpu_supports("avx")   ? 4
                                                             : 2;
  return lanes;
#else
  return 2;
#endif
}

int chosen_lanes(int max_simd_lanes) {
  return std::min(widest_supported_lanes(), max_simd_lanes >= 8 ? 8 : max_simd_lanes >= 4 ? 4 : 2);
}

size_t Plan::memory_bytes() const {
  return user.capacity() * sizeof(int) + lower.capacity() * sizeof(int) +
         ready.capacity() * sizeof(int) + params.capacity() * sizeof(double) +
         param_rows.capacity() * sizeof(int) + param_group.capacity() * sizeof(int);
}

std::shared_ptr<const Plan> compile(const Model& model, int kLanes) {
  return compile(model, kLanes, kRenumberFrom);
}

std::shared_ptr<const Plan> compile(const Model& model, int kLanes, int renumber_from) {
  const int n = model.num_bodies();
  auto plan = std::make_shared<Plan>();
  plan->lanes = kLanes;
  // Plan body k is the Model's body user[k]; rank is the inverse (empty: the same numbering).
  std::vector<int> rank;
  if (n >= renumber_from) {
    std::vector<int> order = depth_first_order(model);
    bool same = true;
    for (int k = 0; k < n && same; ++k) same = order[at(k)] == k;
    if (!same) {
      rank.assign(at(n), 0);
      for (int k = 0; k < n; ++k) rank[at(order[at(k)])] = k;
      plan->user = std::move(order);
    }
  }
  const auto plan_body = [&](int k) { return rank.empty() || k == kGround ? k : rank[at(k)]; };
  const int groups = (n + kLanes - 1) / kLanes;
  const auto padded = at(groups) * kLanes;
  plan->lower.assign(padded, kGround);
  plan->ready.assign(at(groups), 0);
  for (int g = 0; g < groups; ++g) plan->ready[at(g)] = g;
  plan->params.assign(at(groups) * kParamFields * kLanes, 0.0);
  const auto param = [&](int k, int field) -> double& {
    return plan
        ->params[at(k / kLanes) * kParamFields * kLanes + at(field) * kLanes + at(k % kLanes)];
  };
  const auto set3 = [&](int k, int field, const Vector3& v) {
    for (int i = 0; i < 3; ++i) param(k, field + i) = v[i];
  };
  const auto set_symmetric = [&](int k, int field, const Matrix3& m) {
    const double v[6] = {m(0, 0), m(1, 1), m(2, 2), m(0, 1), m(0, 2), m(1, 2)};
    for (int i = 0; i < 6; ++i) param(k, field + i) = v[i];
  };
  for (int k = 0; k < static_cast<int>(padded); ++k) {
    if (k >= n) {  // padding: a unit body at rest, so that its lanes stay finite
      param(k, kInvMass) = 1.0;
      set_symmetric(k, kInertia, Matrix3::Identity());
      set_symmetric(k, kInvInertia, Matrix3::Identity());
      continue;
    }
    const int u = plan->user.empty() ? k : plan->user[at(k)];
    const BodySpec& b = model.body(u);
    const int j = plan_body(b.lower_body);
    plan->lower[at(k)] = j;
    if (j != kGround)  // J's loads are complete once K's group has done pass 1
      plan->ready[at(j / kLanes)] = std::max(plan->ready[at(j / kLanes)], k / kLanes);
    param(k, kInvMass) = 1.0 / b.mass;
    set_symmetric(k, kInertia, b.inertia);
    set_symmetric(k, kInvInertia, model.inverse_inertia(u));
    set3(k, kCom, b.com);
    set3(k, kJoint, b.joint);
    set3(k, kArm, j == kGround ? b.joint : Vector3(b.joint - model.body(b.lower_body).com));
    set3(k, kForce, b.mass * model.gravity());
  }
  // Loads grouped per body: the laws are linear in k, c, kr, cr and in the constant loads.
  for (const auto& element : model.forces()) {
    if (element->acts_on_joints()) continue;  // no body loads: nothing for the pass
    const std::optional<LinearBodyLoad> load = element->linear_body_load();
    if (!load) return nullptr;
    const int k = plan_body(element->body());
    for (int i = 0; i < 3; ++i) {
      param(k, kStiffness + i) += load->stiffness[i];
      param(k, kDamping + i) += load->damping[i];
      param(k, kForce + i) += load->force[i];
      param(k, kMoment + i) += load->moment[i];
    }
    param(k, kRotStiffness) += load->rotational_stiffness;
    param(k, kRotDamping) += load->rotational_damping;
  }
  share_equal_params(groups, kLanes, *plan);
  // Pass 1 keeps its intermediate results for pass 2 (~9% fewer instructions) when they are
  // still in cache for pass 2: in a small model, or where pass 2 of every group comes soon
  // after its pass 1 (a chain: one group later). Otherwise (a large bushy tree, whose bodies'
  // children are spread over the later groups) pass 2 gathers and recomputes them, which moves
  // less memory (docs/performance-internal.md).
  int lag = 0;  // the most groups between a group's pass 1 and its pass 2
  for (int g = 0; g < groups; ++g) lag = std::max(lag, plan->ready[at(g)] - g);
  const bool near = lag * kLanes <= kKeepLag;
  plan->keep = n <= kKeepLimit || near;
  // The scratch of group g lives in slot g mod 2^k. Group g's slot is written by its pass 1 and
  // by its children's (groups up to g + lag), read by its pass 2 and its children's (by group
  // g + 2 lag at the latest, pass 2 running in group order), so 2 lag + 2 slots suffice: where
  // the lag is short (a chain: 1) the scratch stays a few kilobytes at any N.
  int slots = 1;
  while (slots < (near ? 2 * lag + 2 : groups)) slots *= 2;
  plan->scratch_mask = slots - 1;
  plan->scratch_size =
      at(std::min(slots, groups)) * (plan->keep ? kScratchFields : kAccelFields) * at(kLanes);
  plan->copies_at = plan->scratch_size;
  if (!plan->user.empty()) plan->scratch_size += 26 * at(n);
  return plan;
}

namespace {

// The state (x: 4N Euler parameters, then 3N translations; y: 3N angular velocities, then 3N
// translation rates) copied into the plan's numbering, to[body k] = from[body user[k]]; and
// back, the derivatives but Eq. (40)'s s' dot (= y2, copied in order from the state instead),
// to[body user[k]] = from[body k]. Tight loops of independent copies, so that the cache misses
// of the scattered side overlap.
void gather(const int* user, int n, const double* x, const double* y, double* to_x, double* to_y) {
  const size_t bodies = at(n);
  for (size_t k = 0; k < bodies; ++k) {
    const size_t u = at(user[k]);
    for (size_t c = 0; c < 4; ++c) to_x[4 * k + c] = x[4 * u + c];
    for (size_t c = 0; c < 3; ++c) to_x[4 * bodies + 3 * k + c] = x[4 * bodies + 3 * u + c];
    for (size_t c = 0; c < 3; ++c) to_y[3 * k + c] = y[3 * u + c];
    for (size_t c = 0; c < 3; ++c) to_y[3 * bodies + 3 * k + c] = y[3 * bodies + 3 * u + c];
  }
}
void scatter(const int* user, int n, const double* xdot, const double* ydot, const double* y,
             double* to_xdot, double* to_ydot) {
  const size_t bodies = at(n);
  for (size_t k = 0; k < bodies; ++k) {
    const size_t u = at(user[k]);
    for (size_t c = 0; c < 4; ++c) to_xdot[4 * u + c] = xdot[4 * k + c];
    for (size_t c = 0; c < 3; ++c) to_ydot[3 * u + c] = ydot[3 * k + c];
    for (size_t c = 0; c < 3; ++c) to_ydot[3 * bodies + 3 * u + c] = ydot[3 * bodies + 3 * k + c];
  }
  std::copy(y + 3 * bodies, y + 6 * bodies, to_xdot + 4 * bodies);
}

}  // namespace

void forward_dynamics(const Model& model, const State& state, Data& data) {
  detail::Workspace& w = workspace(data);
  const Plan& plan = *w.plan;
  const int lanes = plan.lanes;
  const int n = model.num_bodies();
  const int stride = (plan.keep ? kScratchFields : kAccelFields) * lanes;
  // A renumbered plan runs on copies in its own numbering, kept after the kernel's scratch:
  // x (7N), y (6N), xdot (7N), ydot (6N).
  const bool renumbered = !plan.user.empty();
  const double* x = state.x.data();
  const double* y = state.y.data();
  double* xdot = data.xdot.data();
  double* ydot = data.ydot.data();
  if (renumbered) {
    double* copies = w.fused_scratch.data() + plan.copies_at;
    gather(plan.user.data(), n, x, y, copies, copies + 7 * at(n));
    x = copies;
    y = copies + 7 * at(n);
    xdot = copies + 13 * at(n);
    ydot = copies + 20 * at(n);
  }
  const Args args{n,
                  x,
                  y,
                  plan.lower.data(),
                  plan.ready.data(),
                  plan.params.data(),
                  plan.param_rows.data(),
                  plan.param_group.data(),
                  w.fused_scratch.data(),
                  stride,
                  plan.scratch_mask,
                  ydot,
                  xdot};
  switch (lanes) {
    case 8:
      lanes8::evaluate(args);
      break;
    case 4:
      lanes4::evaluate(args);
      break;
    default:
      lanes2::evaluate(args);
  }
  if (renumbered)
    scatter(plan.user.data(), n, xdot, ydot, state.y.data(), data.xdot.data(), data.ydot.data());
}

}  // namespace kanedyn::fused
