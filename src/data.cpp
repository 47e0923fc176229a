#include "kanedyn/data.hpp"

#include "recursive/fused.hpp"

namespace kanedyn {

namespace {

size_t at(long long i) { return static_cast<size_t>(i); }

}  // namespace

Data::Data(const Model& model, DataOptions opts) : options(opts) {
  const auto n = static_cast<size_t>(model.num_bodies());
  const auto m = static_cast<Eigen::Index>(model.num_speeds());
  if ((options.partials || options.mass_matrix) && !model.has_flat_chains())
    throw ModelError("the model's " + std::to_string(model.num_bodies()) + " bodies have " +
                     std::to_string(model.chain_entries()) +
                     " chain entries (the sum of u_K + 1), more than the " +
                     std::to_string(Model::kMaxFlatChainEntries) +
                     " for which the partial velocity blocks and the assembled Kane route are "
                     "built; the O(N) recursive route has no such limit (DataOptions with "
                     "partials and mass_matrix off)");
  R.assign(n, Matrix3::Identity());
  p_O.assign(n, Vector3::Zero());
  p_G = v_O = v_G = qs_b = force = moment_b = a_G = a_O = alpha_b = p_O;
  if (options.partials) {
    const auto c = at(model.chain_entries());
    vO_w.assign(c, Matrix3::Zero());
    vO_s = vG_w = vG_s = vO_w_dot = vO_s_dot = vG_w_dot = vG_s_dot = vO_w;
  }
  if (options.partials || options.mass_matrix) load_sum.assign(n, Vector3::Zero());  // Eq. (31)
  F_y = VectorX::Zero(m);
  f = VectorX::Zero(m);
  ydot = VectorX::Zero(m);
  xdot = VectorX::Zero(7 * static_cast<Eigen::Index>(n));
  if (options.mass_matrix) {
    if (options.dense_mass_matrix) A = MatrixX::Zero(m, m);
    A_blocks.assign(at(model.chain_entries()), Matrix6::Zero());
    A_factor = TreeLdlt(model);
    bias_O.assign(n, Vector3::Zero());
    h_b = bias_O;
    subtree_mass.assign(n, 0.0);
    composite.assign(n, Matrix36::Zero());
  }
  fused_lanes = fused::chosen_lanes(options.max_simd_lanes);
  fused_plan = fused::compile(model, fused_lanes);
  fused_loads = fused_plan != nullptr;
  if (fused_plan) fused_scratch.assign(fused_plan->scratch_size, 0.0);
}

namespace {
template <typename T>
std::size_t bytes(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
}
std::size_t bytes(const VectorX& v) { return static_cast<std::size_t>(v.size()) * sizeof(double); }
std::size_t bytes(const MatrixX& m) { return static_cast<std::size_t>(m.size()) * sizeof(double); }
}  // namespace

std::size_t Data::memory_bytes() const {
  std::size_t total = A_factor.memory_bytes();
  for (const auto* v : {&R, &vO_w, &vO_s, &vG_w, &vG_s, &vO_w_dot, &vO_s_dot, &vG_w_dot, &vG_s_dot})
    total += bytes(*v);
  for (const auto* v : {&p_O, &p_G, &v_O, &v_G, &qs_b, &force, &moment_b, &a_G, &a_O, &alpha_b,
                        &bias_O, &h_b, &load_sum})
    total += bytes(*v);
  for (const auto* v : {&F_y, &f, &ydot, &xdot}) total += bytes(*v);
  total += bytes(A) + bytes(A_blocks) + bytes(composite) + bytes(subtree_mass);
  total += (fused_plan ? fused_plan->memory_bytes() : 0) + bytes(fused_scratch);
  return total;
}

}  // namespace kanedyn
