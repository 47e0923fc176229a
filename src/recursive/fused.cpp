// The fused O(N) route: its plan (the per-body tables of the kernels, src/recursive/
// fused_kernel.inc) and the choice of SIMD width (src/recursive/fused.hpp).
#include "fused.hpp"

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
  return lower.capacity() * sizeof(int) + ready.capacity() * sizeof(int) +
         params.capacity() * sizeof(double) + param_rows.capacity() * sizeof(int) +
         param_group.capacity() * sizeof(int);
}

std::shared_ptr<const Plan> compile(const Model& model, int kLanes) {
  const int n = model.num_bodies();
  auto plan = std::make_shared<Plan>();
  plan->lanes = kLanes;
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
    const BodySpec& b = model.body(k);
    const int j = b.lower_body;
    plan->lower[at(k)] = j;
    if (j != kGround)  // J's loads are complete once K's group has done pass 1
      plan->ready[at(j / kLanes)] = std::max(plan->ready[at(j / kLanes)], k / kLanes);
    param(k, kInvMass) = 1.0 / b.mass;
    set_symmetric(k, kInertia, b.inertia);
    set_symmetric(k, kInvInertia, model.inverse_inertia(k));
    set3(k, kCom, b.com);
    set3(k, kJoint, b.joint);
    set3(k, kArm, j == kGround ? b.joint : Vector3(b.joint - model.body(j).com));
    set3(k, kForce, b.mass * model.gravity());
  }
  // Loads grouped per body: the laws are linear in k, c, kr, cr and in the constant loads.
  for (const auto& element : model.forces()) {
    const int k = element->body();
    if (const auto* bushing = dynamic_cast<const Bushing*>(element.get())) {
      for (int i = 0; i < 3; ++i) {
        param(k, kStiffness + i) += bushing->stiffness[i];
        param(k, kDamping + i) += bushing->damping[i];
      }
      param(k, kRotStiffness) += bushing->rotational_stiffness;
      param(k, kRotDamping) += bushing->rotational_damping;
    } else if (const auto* force = dynamic_cast<const ConstantForce*>(element.get())) {
      for (int i = 0; i < 3; ++i) param(k, kForce + i) += force->value[i];
    } else if (const auto* torque = dynamic_cast<const ConstantTorque*>(element.get())) {
      for (int i = 0; i < 3; ++i) param(k, kMoment + i) += torque->value[i];
    } else {
      return nullptr;
    }
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
  return plan;
}

void forward_dynamics(const Model& model, const State& state, Data& data) {
  const Plan& plan = *data.fused_plan;
  const int lanes = plan.lanes;
  const int stride = (plan.keep ? kScratchFields : kAccelFields) * lanes;
  const Args args{model.num_bodies(),
                  state.x.data(),
                  state.y.data(),
                  plan.lower.data(),
                  plan.ready.data(),
                  plan.params.data(),
                  plan.param_rows.data(),
                  plan.param_group.data(),
                  data.fused_scratch.data(),
                  stride,
                  plan.scratch_mask,
                  data.ydot.data(),
                  data.xdot.data()};
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
}

}  // namespace kanedyn::fused
