#include "kanedyn/data.hpp"

#include "kanedyn/constraints.hpp"

#include "recursive/fused.hpp"
#include "workspace.hpp"

namespace kanedyn {

namespace {

size_t at(long long i) { return static_cast<size_t>(i); }

void allocate(Kinematics& kin, size_t n) {
  kin.R.assign(n, Matrix3::Identity());
  kin.p_O.assign(n, Vector3::Zero());
  kin.p_G = kin.v_O = kin.v_G = kin.qs_b = kin.p_O;
}

void allocate(Loads& loads, size_t n) {
  loads.force.assign(n, Vector3::Zero());
  loads.moment_b = loads.force;
}

template <typename T>
std::size_t bytes(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
}
std::size_t bytes(const VectorX& v) { return static_cast<std::size_t>(v.size()) * sizeof(double); }
std::size_t bytes(const MatrixX& m) { return static_cast<std::size_t>(m.size()) * sizeof(double); }
std::size_t bytes(const Kinematics& k) {
  return bytes(k.R) + bytes(k.p_O) + bytes(k.p_G) + bytes(k.v_O) + bytes(k.v_G) + bytes(k.qs_b);
}
std::size_t bytes(const Loads& l) { return bytes(l.force) + bytes(l.moment_b); }

}  // namespace

DataOptions DataOptions::recursive_only(int max_simd_lanes) {
  DataOptions o;
  o.partials = o.kane_terms = o.dense_mass_matrix = false;
  o.max_simd_lanes = max_simd_lanes;
  return o;
}

DataOptions DataOptions::for_model(const Model& model) {
  if (model.chain_entries() > kFullChainEntries) return recursive_only();
  DataOptions o;
  o.dense_mass_matrix = model.num_bodies() <= kFullDenseBodies;
  return o;
}

Data::Data(const Model& model) : Data(model, DataOptions::for_model(model)) {}

Data::Data(const Model& model, const DataOptions& opts)
    : options_(opts), work_(std::make_unique<detail::Workspace>()) {
  const auto n = static_cast<size_t>(model.num_bodies());
  const auto m = static_cast<Eigen::Index>(model.num_y());
  if ((options_.partials || options_.kane_terms) && !model.has_flat_chains())
    throw ModelError("the model's " + std::to_string(model.num_bodies()) + " bodies have " +
                     std::to_string(model.chain_entries()) +
                     " chain entries (the sum of u_K + 1), more than the " +
                     std::to_string(Model::kMaxFlatChainEntries) +
                     " for which the partial velocity blocks and the assembled route are "
                     "built; the recursive route has no such limit "
                     "(DataOptions::recursive_only())");
  detail::Workspace& w = *work_;
  allocate(kinematics, n);
  allocate(loads, n);
  allocate(w.kinematics, n);
  allocate(w.loads, n);
  w.load_sum.assign(n, Vector3::Zero());
  w.a_O.assign(n, Vector3::Zero());
  w.alpha_b = w.a_O;
  if (options_.partials) {
    const auto c = at(model.chain_entries());
    partials.vO_w.assign(c, Matrix3::Zero());
    partials.vO_s = partials.vG_w = partials.vG_s = partials.vO_w;
    partials.vO_w_dot = partials.vO_s_dot = partials.vG_w_dot = partials.vG_s_dot = partials.vO_w;
  }
  inputs = VectorX::Zero(model.num_inputs());
  reactions = VectorX::Zero(reaction_count(model));
  ydot = VectorX::Zero(m);
  xdot = VectorX::Zero(7 * static_cast<Eigen::Index>(n));
  if (options_.kane_terms) {
    kane.F_y = VectorX::Zero(m);
    kane.f = VectorX::Zero(m);
    if (options_.dense_mass_matrix) kane.A = MatrixX::Zero(m, m);
    detail::AssembledScratch& a = w.assembled;
    a.A_blocks.assign(at(model.chain_entries()), Matrix6::Zero());
    a.factor = detail::TreeLdlt(model);
    a.bias_O.assign(n, Vector3::Zero());
    a.h_b = a.bias_O;
    a.subtree_mass.assign(n, 0.0);
    a.composite.assign(n, Matrix36::Zero());
  }
  w.lanes = fused::chosen_lanes(options_.max_simd_lanes);
  // The fused pass computes only the built-in force elements' loads.
  if (model.num_inputs() == 0) w.plan = fused::compile(model, w.lanes);
  if (w.plan) w.fused_scratch.assign(w.plan->scratch_size, 0.0);
}

Data::Data(const Data& other)
    : kinematics(other.kinematics),
      partials(other.partials),
      loads(other.loads),
      kane(other.kane),
      inputs(other.inputs),
      reactions(other.reactions),
      ydot(other.ydot),
      xdot(other.xdot),
      options_(other.options_),
      work_(std::make_unique<detail::Workspace>(*other.work_)) {}

Data& Data::operator=(const Data& other) {
  if (this != &other) *this = Data(other);
  return *this;
}

Data::Data(Data&&) noexcept = default;
Data& Data::operator=(Data&&) noexcept = default;
Data::~Data() = default;

int Data::simd_lanes() const { return work_->lanes; }
bool Data::single_pass() const { return work_->plan != nullptr; }

std::size_t Data::memory_bytes() const {
  const detail::Workspace& w = *work_;
  std::size_t total = bytes(kinematics) + bytes(loads) + bytes(w.kinematics) + bytes(w.loads);
  for (const auto* v :
       {&partials.vO_w, &partials.vO_s, &partials.vG_w, &partials.vG_s, &partials.vO_w_dot,
        &partials.vO_s_dot, &partials.vG_w_dot, &partials.vG_s_dot})
    total += bytes(*v);
  for (const auto* v : {&kane.F_y, &kane.f, &reactions, &ydot, &xdot}) total += bytes(*v);
  total += bytes(kane.A) + bytes(w.load_sum) + bytes(w.a_O) + bytes(w.alpha_b);
  const detail::AssembledScratch& a = w.assembled;
  total += bytes(a.A_blocks) + a.factor.memory_bytes() + bytes(a.bias_O) + bytes(a.h_b) +
           bytes(a.subtree_mass) + bytes(a.composite);
  total += (w.plan ? w.plan->memory_bytes() : 0) + bytes(w.fused_scratch);
  return total;
}

detail::Workspace& workspace(Data& data) { return *data.work_; }
const detail::Workspace& workspace(const Data& data) { return *data.work_; }

}  // namespace kanedyn
