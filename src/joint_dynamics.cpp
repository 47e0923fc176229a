#include "kanedyn/joint_dynamics.hpp"

#include "kanedyn/forces.hpp"
#include "kanedyn/kinematics.hpp"

namespace kanedyn {

struct JointDynamics::Impl {
  Impl(const Model& m, const JointTree& t)
      : model(m),
        tree(t),
        data(m, DataOptions{}),
        state(m),
        q(VectorX::Zero(t.num_coordinates())),
        z(VectorX::Zero(t.num_speeds())),
        qdot(VectorX::Zero(t.num_coordinates())) {}
  const Model& model;
  const JointTree& tree;
  Data data;
  State state;
  VectorX q, z, qdot;
};

JointDynamics::JointDynamics(const Model& model, const JointTree& tree)
    : impl_(std::make_unique<Impl>(model, tree)) {}
JointDynamics::JointDynamics(const JointDynamics& other)
    : impl_(std::make_unique<Impl>(*other.impl_)) {}
JointDynamics::~JointDynamics() = default;

const State& JointDynamics::state() const { return impl_->state; }
Data& JointDynamics::data() { return impl_->data; }
const JointTree& JointDynamics::tree() const { return impl_->tree; }

void JointDynamics::evaluate(const VectorX& q, const VectorX& z, Route /*route*/,
                             Eigen::Ref<VectorX> zdot) {
  Impl& s = *impl_;
  // Reference: the dense projected equations (allocates).
  ProjectedEquations e = projected_equations(s.model, s.tree, q, z, s.data);
  zdot = e.zdot;
  s.state = e.state;
  compute_kinematics(s.model, s.state, s.data);
  compute_resultants(s.model, s.state, s.data);
}

void JointDynamics::derivative(const VectorX& qz, Route route, Eigen::Ref<VectorX> dqz) {
  Impl& s = *impl_;
  const int nq = s.tree.num_coordinates(), nz = s.tree.num_speeds();
  s.q = qz.head(nq);
  s.z = qz.tail(nz);
  normalize_joint_coordinates(s.tree, s.q);
  joint_coordinate_rates(s.tree, s.q, s.z, s.qdot);
  dqz.head(nq) = s.qdot;
  evaluate(s.q, s.z, route, dqz.tail(nz));
}

}  // namespace kanedyn
