// DART peer: one FreeJoint per body, parent-to-joint transform at q'_K in the lower body's
// axes, child-to-joint identity (the body frame sits at O_K), so the joint's transform is
// (K relative to J, s'_K). DART's FreeJoint speeds are the child's spatial velocity relative
// to its parent in child axes, not (w_K - w_J, s'_K dot) in J axes, so joint springs would not
// reproduce the bushing law; the bushings are applied instead as the spec states them, as
// external forces and moments on K and J, computed from DART's own kinematics in every
// evaluation (the same work a DART user would write).
#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/Skeleton.hpp>

#include <Eigen/Geometry>

#include "peer.hpp"

namespace peers {
namespace {

using dart::dynamics::BodyNode;
using dart::dynamics::FreeJoint;
using Eigen::Vector3d;

Vector3d e3(const Vec3& a) { return {a[0], a[1], a[2]}; }
Vec3 a3(const Vector3d& v) { return {v[0], v[1], v[2]}; }

class DartEngine final : public Engine {
 public:
  explicit DartEngine(const System& system)
      : system_(system), skeleton_(dart::dynamics::Skeleton::create(system.name)) {
    skeleton_->setGravity(e3(system.gravity));
    for (const Body& b : system.bodies) {
      FreeJoint::Properties joint;
      joint.mName = b.name + "_joint";
      joint.mT_ParentBodyToJoint = Eigen::Isometry3d::Identity();
      joint.mT_ParentBodyToJoint.translation() = e3(b.joint);
      joint.mT_ChildBodyToJoint = Eigen::Isometry3d::Identity();
      BodyNode::Properties body;
      body.mName = b.name;
      body.mInertia = dart::dynamics::Inertia(
          b.mass, e3(b.com),
          Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(b.inertia.data()));
      BodyNode* parent = b.parent < 0 ? nullptr : bodies_[static_cast<size_t>(b.parent)];
      bodies_.push_back(
          skeleton_->createJointAndBodyNodePair<FreeJoint>(parent, joint, body).second);
    }
    // Joint coordinates, body by body from the root: positions from the relative transform,
    // speeds = (w_K - w_J, velocity of O_K relative to J's coinciding point), child axes.
    for (size_t k = 0; k < bodies_.size(); ++k) {
      const BodyState& s = system.state[k];
      const Eigen::Quaterniond q(s.q_rel[0], s.q_rel[1], s.q_rel[2], s.q_rel[3]);
      Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
      X.linear() = q.toRotationMatrix();  // K axes -> J axes
      X.translation() = e3(s.s);
      auto* joint = static_cast<FreeJoint*>(bodies_[k]->getParentJoint());
      joint->setPositions(FreeJoint::convertToPositions(X));
      Eigen::Vector6d v;
      v << e3(s.w_rel_k), X.linear().transpose() * e3(s.s_dot);
      joint->setVelocities(v);
    }
    positions_ = skeleton_->getPositions();
    velocities_ = skeleton_->getVelocities();
  }

  void evaluate() override {
    skeleton_->setPositions(positions_);
    skeleton_->setVelocities(velocities_);
    skeleton_->clearExternalForces();
    for (size_t k = 0; k < bodies_.size(); ++k) apply_loads(k);
    skeleton_->computeForwardDynamics();
  }

  std::vector<BodyMotion> motion() override {
    std::vector<BodyMotion> out(bodies_.size());
    for (size_t k = 0; k < bodies_.size(); ++k) {
      const BodyNode* b = bodies_[k];
      out[k].p_G = a3(b->getCOM());
      out[k].v_G = a3(b->getCOMLinearVelocity());
      out[k].w = a3(b->getAngularVelocity());
      out[k].a_G = a3(b->getCOMLinearAcceleration());
      out[k].alpha = a3(b->getAngularAcceleration());
    }
    return out;
  }

 private:
  // The bushing on body K and its constant loads, from the body frames' world motion.
  void apply_loads(size_t k) {
    const Body& b = system_.bodies[k];
    BodyNode* K = bodies_[k];
    BodyNode* J = b.parent < 0 ? nullptr : bodies_[static_cast<size_t>(b.parent)];
    const Eigen::Isometry3d& X_K = K->getWorldTransform();
    const Eigen::Isometry3d X_J = J ? J->getWorldTransform() : Eigen::Isometry3d::Identity();
    const Vector3d w_J = J ? J->getAngularVelocity() : Vector3d::Zero();
    const Vector3d v_OJ = J ? J->getLinearVelocity() : Vector3d::Zero();
    const Eigen::Matrix3d& R_J = X_J.linear();                 // J axes -> world
    const Vector3d d = X_K.translation() - X_J.translation();  // O_J to O_K, world
    const Vector3d s = R_J.transpose() * d - e3(b.joint);
    const Vector3d s_dot = R_J.transpose() * (K->getLinearVelocity() - v_OJ - w_J.cross(d));
    const Vector3d f_J = -e3(b.k).cwiseProduct(s) - e3(b.c).cwiseProduct(s_dot);
    const Eigen::AngleAxisd rel(R_J.transpose() * X_K.linear());  // angle in [0, pi]
    const Vector3d theta_J = rel.angle() * rel.axis();
    const Vector3d f = R_J * f_J;
    const Vector3d m = R_J * (-b.kr * theta_J) - b.cr * (K->getAngularVelocity() - w_J);
    K->addExtForce(f, Vector3d::Zero(), false, true);  // at O_K
    K->addExtTorque(m, false);
    if (J) {
      J->addExtForce(-f, X_K.translation(), false, false);  // at J's point at O_K
      J->addExtTorque(-m, false);
    }
    if (system_.has_constant_loads) {
      K->addExtForce(e3(b.force), e3(b.com), false, true);  // at G_K
      K->addExtTorque(e3(b.torque_b), true);
    }
  }

  System system_;
  dart::dynamics::SkeletonPtr skeleton_;
  std::vector<BodyNode*> bodies_;
  Eigen::VectorXd positions_, velocities_;
};

}  // namespace

EngineInfo dart_engine() {
  return {
      "DART", DART_VERSION,
      // The skeleton caches several dense nv x nv matrices (mass matrix, its inverse, the
      // augmented ones, for the skeleton and per tree): about 8 of them.
      [](const System& s) {
        const double nv = 6.0 * static_cast<double>(s.bodies.size());
        return 8.0 * 8.0 * nv * nv;
      },
      // Per-body Jacobians span the body's ancestors' dofs.
      [](const System& s) { return ancestor_dofs(s, 1); },
      [](const System& s) -> std::unique_ptr<Engine> { return std::make_unique<DartEngine>(s); }};
}

}  // namespace peers
