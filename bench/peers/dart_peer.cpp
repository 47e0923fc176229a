// DART peer: one FreeJoint per body, parent-to-joint transform at q'_K in the lower body's
// axes, child-to-joint identity (the body frame sits at O_K), so the joint's transform is
// (K relative to J, s'_K). DART's FreeJoint speeds are the child's spatial velocity relative
// to its parent in child axes, not (w_K - w_J, s'_K dot) in J axes, so joint springs would not
// reproduce the bushing law; the bushings are applied instead as the spec states them, as
// external forces and moments on K and J, computed from DART's own kinematics in every
// evaluation (the same work a DART user would write).
//
// Trajectories: DART's World::step is semi-implicit Euler (computeForwardDynamics,
// integrateVelocities, integratePositions); DART also ships dart::integration::RK4Integrator,
// which works on an IntegrableSystem that DART's own classes do not implement: the adapter
// below maps it onto the skeleton, positions advanced by the joints' own integratePositions.
// Both converge at first order here (docs/peers-trajectory.md): RK4Integrator::integrate
// starts its fourth stage's positions from the third stage's instead of the step's start, and
// FreeJoint::integratePositions moves the origin along a straight line (R v dt), not along the
// screw of a constant body velocity. "rk4-se3" is a diagnostic without both: a textbook RK4
// over the same DART dynamics, FreeJoint positions advanced by the SE(3) exponential.
#include <dart/dynamics/BallJoint.hpp>
#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/PlanarJoint.hpp>
#include <dart/dynamics/PrismaticJoint.hpp>
#include <dart/dynamics/RevoluteJoint.hpp>
#include <dart/dynamics/Skeleton.hpp>
#include <dart/dynamics/UniversalJoint.hpp>
#include <dart/dynamics/WeldJoint.hpp>
#include <dart/integration/RK4Integrator.hpp>
#include <dart/math/Geometry.hpp>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "peer.hpp"

namespace peers {
namespace {

using dart::dynamics::BodyNode;
using dart::dynamics::FreeJoint;
using Eigen::Vector3d;

Vector3d e3(const Vec3& a) { return {a[0], a[1], a[2]}; }
Vec3 a3(const Vector3d& v) { return {v[0], v[1], v[2]}; }

// DART's IntegrableSystem on an engine's skeleton: configurations are the joints' positions,
// advanced by the joints' own integratePositions (a FreeJoint's exponential map); velocities
// are a vector space; accelerations are the engine's (its loads applied).
template <class E>
class SkeletonSystem final : public dart::integration::IntegrableSystem {
 public:
  explicit SkeletonSystem(E& engine) : e_(engine) {}
  void setConfigs(const Eigen::VectorXd& q) override { e_.skeleton().setPositions(q); }
  void setGenVels(const Eigen::VectorXd& v) override { e_.skeleton().setVelocities(v); }
  Eigen::VectorXd getConfigs() const override { return e_.skeleton().getPositions(); }
  Eigen::VectorXd getGenVels() const override { return e_.skeleton().getVelocities(); }
  Eigen::VectorXd evalGenAccs() override {
    e_.accelerations();
    return e_.skeleton().getAccelerations();
  }
  void integrateConfigs(const Eigen::VectorXd& v, double dt) override {
    const Eigen::VectorXd saved = e_.skeleton().getVelocities();
    e_.skeleton().setVelocities(v);
    e_.skeleton().integratePositions(dt);
    e_.skeleton().setVelocities(saved);
  }
  void integrateGenVels(const Eigen::VectorXd& a, double dt) override {
    e_.skeleton().setVelocities(e_.skeleton().getVelocities() + dt * a);
  }

 private:
  E& e_;
};

// dart::integration::RK4Integrator is abstract in DART 6.12 (it does not override the
// base's integratePos and integrateVel, which its integrate() does not use): these two
// complete it; integrate() is DART's own.
class Rk4 final : public dart::integration::RK4Integrator {
 public:
  void integratePos(dart::integration::IntegrableSystem*, double) override {
    throw std::logic_error("DART RK4Integrator::integratePos is not used");
  }
  void integrateVel(dart::integration::IntegrableSystem*, double) override {
    throw std::logic_error("DART RK4Integrator::integrateVel is not used");
  }
};

// Body poses at the skeleton's current positions and velocities.
std::vector<BodyPose> body_poses(const std::vector<BodyNode*>& bodies) {
  std::vector<BodyPose> out(bodies.size());
  for (size_t k = 0; k < bodies.size(); ++k) {
    const BodyNode* b = bodies[k];
    out[k].p_G = a3(b->getCOM());
    out[k].v_G = a3(b->getCOMLinearVelocity());
    out[k].w = a3(b->getAngularVelocity());
    const Eigen::Matrix3d& R = b->getWorldTransform().linear();  // body axes -> world
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) out[k].R[static_cast<size_t>(3 * r + c)] = R(r, c);
  }
  return out;
}

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

  IntegratorInfo start(const IntegratorSettings& settings) override {
    const std::string& method = settings.method;
    IntegratorInfo info;
    if (method.empty() || method == "rk4") {
      method_ = Method::rk4;
      info = {"dart::integration::RK4Integrator", true, 4.0};
    } else if (method == "euler") {
      method_ = Method::euler;
      info = {"semi-implicit Euler (World::step)", true, 1.0};
    } else if (method == "rk4-se3") {
      method_ = Method::rk4_se3;
      info = {"textbook RK4, SE(3) exponential (diagnostic)", true, 4.0};
    } else {
      throw std::invalid_argument("DART: unknown integrator '" + method +
                                  "' (rk4, euler, rk4-se3)");
    }
    if (!(settings.step > 0)) throw std::invalid_argument("DART: the step must be > 0");
    step_ = settings.step;
    char step[32];
    std::snprintf(step, sizeof step, "%.3g", step_);
    info.description += std::string(", step ") + step;
    q_int_ = positions_;
    v_int_ = velocities_;
    time_ = 0;
    steps_ = 0;
    return info;
  }

  void advance_to(double t) override {
    const double span = t - time_;
    const long n = equal_steps(span, step_);
    const double h = span / static_cast<double>(n);
    skeleton_->setPositions(q_int_);
    skeleton_->setVelocities(v_int_);
    SkeletonSystem<DartEngine> adapter(*this);
    for (long i = 0; i < n; ++i) {
      switch (method_) {
        case Method::rk4:
          rk4_integrator_.integrate(&adapter, h);
          break;
        case Method::euler:
          accelerations();
          skeleton_->integrateVelocities(h);
          skeleton_->integratePositions(h);
          break;
        case Method::rk4_se3:
          rk4_se3(h);
          break;
      }
    }
    q_int_ = skeleton_->getPositions();
    v_int_ = skeleton_->getVelocities();
    if (!q_int_.allFinite() || !v_int_.allFinite())
      throw std::runtime_error("DART: non-finite state after t = " + std::to_string(time_));
    time_ = t;
    steps_ += n;
  }

  std::vector<BodyPose> pose() override {
    skeleton_->setPositions(q_int_);
    skeleton_->setVelocities(v_int_);
    return body_poses(bodies_);
  }

  long steps() const override { return steps_; }

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

  // The skeleton's accelerations at its current positions and velocities, loads included.
  void accelerations() {
    skeleton_->clearExternalForces();
    for (size_t k = 0; k < bodies_.size(); ++k) apply_loads(k);
    skeleton_->computeForwardDynamics();
  }

  dart::dynamics::Skeleton& skeleton() { return *skeleton_; }

 private:
  // Positions q advanced by the body velocities v over dt, each FreeJoint (every joint here,
  // six positions each) along the screw of its constant body velocity (SE(3) exponential).
  static Eigen::VectorXd screw(const Eigen::VectorXd& q, const Eigen::VectorXd& v, double dt) {
    Eigen::VectorXd out(q.size());
    for (Eigen::Index j = 0; j < q.size(); j += 6) {
      const Eigen::Isometry3d Q = FreeJoint::convertToTransform(Eigen::Vector6d(q.segment<6>(j)));
      const Eigen::Vector6d step = v.segment<6>(j) * dt;
      out.segment<6>(j) = FreeJoint::convertToPositions(Q * dart::math::expMap(step));
    }
    return out;
  }

  // The diagnostic: classical RK4, every stage from the step's start (q1, v1).
  void rk4_se3(double h) {
    const Eigen::VectorXd q1 = skeleton_->getPositions(), v1 = skeleton_->getVelocities();
    auto acc = [this](const Eigen::VectorXd& q, const Eigen::VectorXd& v) -> Eigen::VectorXd {
      skeleton_->setPositions(q);
      skeleton_->setVelocities(v);
      accelerations();
      return skeleton_->getAccelerations();
    };
    const Eigen::VectorXd dv1 = acc(q1, v1);
    const Eigen::VectorXd v2 = v1 + 0.5 * h * dv1;
    const Eigen::VectorXd dv2 = acc(screw(q1, v1, 0.5 * h), v2);
    const Eigen::VectorXd v3 = v1 + 0.5 * h * dv2;
    const Eigen::VectorXd dv3 = acc(screw(q1, v2, 0.5 * h), v3);
    const Eigen::VectorXd v4 = v1 + h * dv3;
    const Eigen::VectorXd dv4 = acc(screw(q1, v3, h), v4);
    skeleton_->setPositions(screw(q1, (v1 + 2.0 * v2 + 2.0 * v3 + v4) / 6.0, h));
    skeleton_->setVelocities(v1 + h / 6.0 * (dv1 + 2.0 * dv2 + 2.0 * dv3 + dv4));
  }

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
  // Trajectories: the integrated state, apart from evaluate()'s.
  Rk4 rk4_integrator_;
  enum class Method { rk4, euler, rk4_se3 } method_ = Method::rk4;
  Eigen::VectorXd q_int_, v_int_;
  double step_ = 0, time_ = 0;
  long steps_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Jointed trees. Each joint's parent-to-joint transform is the joint frame F at q'_K (the
// weld's: F at q'_K + s'_K), child-to-joint the identity, so the joint's own transform is K
// relative to F: RevoluteJoint and PrismaticJoint about and along n (F components),
// UniversalJoint about a1 then a2 as carried by the first, BallJoint (positions the rotation
// vector of K relative to F, velocities w_rel in K components: kanedyn's z), WeldJoint, and
// FreeJoint for free roots (velocities (w_K, v_OK) in K components, the bushing applied as in
// DartEngine). DART has no cylindrical joint: it is a PrismaticJoint along n to a massless
// body, then a RevoluteJoint about n (the two commute). Joint springs, dampers and constant
// forces are the joints' commanded forces, set in every evaluation from DART's positions and
// velocities: DART's own joint springs and dampers are implicit in its time step, which would
// not be the law.

// A skeleton of a jointed tree: per body, in kanedyn's order, its BodyNode and the joint to its
// lower body (a cylindrical joint's revolute part; its prismatic part in `slides`).
struct JointedSkeleton {
  dart::dynamics::SkeletonPtr skeleton;
  std::vector<BodyNode*> bodies;
  std::vector<dart::dynamics::Joint*> joints;
  std::map<size_t, dart::dynamics::Joint*> slides;
};

// The skeleton of the comment above, built from the system's description. This is the one
// place a skeleton comes from: one read from a URDF file (dart::utils::DartLoader) would be
// turned into a JointedSkeleton instead, bodies matched to the system's by name.
JointedSkeleton build_skeleton(const JointedSystem& system) {
  JointedSkeleton out;
  out.skeleton = dart::dynamics::Skeleton::create(system.name);
  out.skeleton->setGravity(e3(system.gravity));
  for (size_t k = 0; k < system.bodies.size(); ++k) {
    const Body& b = system.bodies[k];
    const JointSpec& j = system.joints[k];
    BodyNode::Properties body;
    body.mName = b.name;
    body.mInertia = dart::dynamics::Inertia(
        b.mass, e3(b.com),
        Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(b.inertia.data()));
    BodyNode* parent = b.parent < 0 ? nullptr : out.bodies[static_cast<size_t>(b.parent)];
    Eigen::Isometry3d X_JF = Eigen::Isometry3d::Identity();
    if (j.type != JointKind::free)
      X_JF.linear() = Eigen::Quaterniond(j.frame[0], j.frame[1], j.frame[2], j.frame[3])
                          .normalized()
                          .toRotationMatrix();
    X_JF.translation() =
        e3(b.joint) + (j.type == JointKind::weld ? e3(j.translation) : Vector3d::Zero());
    const Vector3d n = e3(j.axis);
    dart::dynamics::Joint* joint = nullptr;
    BodyNode* node = nullptr;
    auto pair = [&](auto* tag, BodyNode* from, const BodyNode::Properties& props) {
      using J = std::remove_pointer_t<decltype(tag)>;
      auto created = out.skeleton->createJointAndBodyNodePair<J>(from);
      created.second->setProperties(props);
      return created;
    };
    switch (j.type) {
      case JointKind::free: {
        auto c = pair(static_cast<FreeJoint*>(nullptr), parent, body);
        joint = c.first;
        node = c.second;
        break;
      }
      case JointKind::weld: {
        auto c = pair(static_cast<dart::dynamics::WeldJoint*>(nullptr), parent, body);
        joint = c.first;
        node = c.second;
        break;
      }
      case JointKind::revolute: {
        auto c = pair(static_cast<dart::dynamics::RevoluteJoint*>(nullptr), parent, body);
        c.first->setAxis(n);
        joint = c.first;
        node = c.second;
        break;
      }
      case JointKind::prismatic: {
        auto c = pair(static_cast<dart::dynamics::PrismaticJoint*>(nullptr), parent, body);
        c.first->setAxis(n);
        joint = c.first;
        node = c.second;
        break;
      }
      case JointKind::universal: {
        auto c = pair(static_cast<dart::dynamics::UniversalJoint*>(nullptr), parent, body);
        c.first->setAxis1(n);
        c.first->setAxis2(e3(j.axis2));
        joint = c.first;
        node = c.second;
        break;
      }
      case JointKind::spherical: {
        auto c = pair(static_cast<dart::dynamics::BallJoint*>(nullptr), parent, body);
        joint = c.first;
        node = c.second;
        break;
      }
      case JointKind::screw:  // refused by dart_jointed_engine's check
        throw std::runtime_error("peers: DART: screw joints are not translated");
      case JointKind::planar: {
        // DART's positions are (x, y along the plane's axes, angle about its normal), kanedyn's
        // order; the x-y plane of the joint frame F.
        // Named coordinates: DART would otherwise name all three "default" and say so.
        dart::dynamics::PlanarJoint::Properties props;
        props.mName = b.name + "_joint";
        props.mDofNames = {b.name + "_x", b.name + "_y", b.name + "_angle"};
        auto c = out.skeleton->createJointAndBodyNodePair<dart::dynamics::PlanarJoint>(parent,
                                                                                       props, body);
        c.first->setXYPlane(false);
        joint = c.first;
        node = c.second;
        break;
      }
      case JointKind::cylindrical: {
        // DART warns (on std::cerr) that a zero mass and inertia may be invalid; the
        // articulated-body recursion only inverts the inertia seen through each joint, which
        // the outer body's makes positive, so the warnings are silenced for this one body.
        std::streambuf* const saved = std::cerr.rdbuf(nullptr);
        BodyNode::Properties massless;
        massless.mName = b.name + "_slide";
        massless.mInertia = dart::dynamics::Inertia(0.0, Vector3d::Zero(), Eigen::Matrix3d::Zero());
        auto slide = pair(static_cast<dart::dynamics::PrismaticJoint*>(nullptr), parent, massless);
        std::cerr.rdbuf(saved);
        std::cerr.clear();  // the writes to no buffer set badbit
        slide.first->setAxis(n);
        slide.first->setName(b.name + "_slide_joint");
        slide.first->setTransformFromParentBodyNode(X_JF);
        slide.first->setTransformFromChildBodyNode(Eigen::Isometry3d::Identity());
        auto turn = pair(static_cast<dart::dynamics::RevoluteJoint*>(nullptr), slide.second, body);
        turn.first->setAxis(n);
        joint = turn.first;
        node = turn.second;
        X_JF = Eigen::Isometry3d::Identity();  // the revolute joint sits in the slide's frame
        out.slides[k] = slide.first;
        break;
      }
    }
    joint->setName(b.name + "_joint");
    joint->setTransformFromParentBodyNode(X_JF);
    joint->setTransformFromChildBodyNode(Eigen::Isometry3d::Identity());
    out.bodies.push_back(node);
    out.joints.push_back(joint);
  }
  return out;
}

class DartJointedEngine final : public JointedEngine {
 public:
  explicit DartJointedEngine(const JointedSystem& system)
      : DartJointedEngine(system, build_skeleton(system)) {}

  // The system's state and loads on a skeleton of the same bodies and joints.
  DartJointedEngine(const JointedSystem& system, JointedSkeleton built)
      : system_(system),
        skeleton_(std::move(built.skeleton)),
        bodies_(std::move(built.bodies)),
        joints_(std::move(built.joints)),
        joints_extra_(std::move(built.slides)) {
    // Joint coordinates in DART's terms.
    for (size_t k = 0; k < bodies_.size(); ++k) {
      const JointSpec& j = system.joints[k];
      const double* q = system.q.data() + system.q_offset[k];
      const double* z = system.z.data() + system.z_offset[k];
      dart::dynamics::Joint* joint = joints_[k];
      switch (j.type) {
        case JointKind::free: {
          Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
          X.linear() = Eigen::Quaterniond(q[3], q[0], q[1], q[2]).toRotationMatrix();
          X.translation() = Vector3d(q[4], q[5], q[6]);
          joint->setPositions(FreeJoint::convertToPositions(X));
          Eigen::Vector6d v;
          v << Vector3d(z[0], z[1], z[2]), X.linear().transpose() * Vector3d(z[3], z[4], z[5]);
          joint->setVelocities(v);
          break;
        }
        case JointKind::spherical:
          joint->setPositions(dart::dynamics::BallJoint::convertToPositions(
              Eigen::Quaterniond(q[3], q[0], q[1], q[2]).toRotationMatrix()));
          joint->setVelocities(Vector3d(z[0], z[1], z[2]));
          break;
        case JointKind::cylindrical:
          joint->setPosition(0, q[0]);
          joint->setVelocity(0, z[0]);
          joints_extra_[k]->setPosition(0, q[1]);
          joints_extra_[k]->setVelocity(0, z[1]);
          break;
        case JointKind::weld:
          break;
        default:
          for (size_t i = 0; i < joint->getNumDofs(); ++i) {
            joint->setPosition(i, q[i]);
            joint->setVelocity(i, z[i]);
          }
      }
    }
    positions_ = skeleton_->getPositions();
    velocities_ = skeleton_->getVelocities();
  }

  void evaluate() override {
    skeleton_->setPositions(next_positions());
    skeleton_->setVelocities(velocities_);
    accelerations();
  }

  std::vector<double> zdot() override {
    std::vector<double> out(system_.z.size());
    for (size_t k = 0; k < joints_.size(); ++k) {
      double* z = out.data() + system_.z_offset[k];
      const dart::dynamics::Joint* joint = joints_[k];
      switch (system_.joints[k].type) {
        case JointKind::free: {
          // z = (w'_K, s'_K dot): d/dt of the inertial s' dot = R (d/dt v + w x v).
          const Eigen::Vector6d a = joint->getAccelerations(), v = joint->getVelocities();
          const Vector3d w = v.head<3>();
          const Vector3d s_ddot =
              bodies_[k]->getWorldTransform().linear() * (a.tail<3>() + w.cross(v.tail<3>()));
          for (int i = 0; i < 3; ++i) {
            z[i] = a[i];
            z[3 + i] = s_ddot[i];
          }
          break;
        }
        case JointKind::cylindrical:
          z[0] = joint->getAcceleration(0);
          z[1] = joints_extra_.at(k)->getAcceleration(0);
          break;
        default:
          for (size_t i = 0; i < joint->getNumDofs(); ++i) z[i] = joint->getAcceleration(i);
      }
    }
    return out;
  }

  IntegratorInfo start(const IntegratorSettings& settings) override {
    if (!settings.method.empty() && settings.method != "rk4")
      throw std::invalid_argument("DART (jointed): unknown integrator '" + settings.method +
                                  "' (rk4)");
    if (!(settings.step > 0)) throw std::invalid_argument("DART: the step must be > 0");
    step_ = settings.step;
    char step[32];
    std::snprintf(step, sizeof step, "%.3g", step_);
    q_int_ = positions_;
    v_int_ = velocities_;
    time_ = 0;
    steps_ = 0;
    return {std::string("dart::integration::RK4Integrator, step ") + step, true, 4.0};
  }

  void advance_to(double t) override {
    const double span = t - time_;
    const long n = equal_steps(span, step_);
    const double h = span / static_cast<double>(n);
    skeleton_->setPositions(q_int_);
    skeleton_->setVelocities(v_int_);
    SkeletonSystem<DartJointedEngine> adapter(*this);
    for (long i = 0; i < n; ++i) rk4_integrator_.integrate(&adapter, h);
    q_int_ = skeleton_->getPositions();
    v_int_ = skeleton_->getVelocities();
    if (!q_int_.allFinite() || !v_int_.allFinite())
      throw std::runtime_error("DART: non-finite state after t = " + std::to_string(time_));
    time_ = t;
    steps_ += n;
  }

  std::vector<BodyPose> pose() override {
    skeleton_->setPositions(q_int_);
    skeleton_->setVelocities(v_int_);
    return body_poses(bodies_);
  }

  long steps() const override { return steps_; }

  bool has_terms() const override { return true; }

  // DART's accelerations from kanedyn's z dot: u = T z (speed_map) and, for a free root, the
  // turning of K's axes: v = R^T s' dot gives v dot = R^T s'' - w x v (the inverse of zdot()).
  void set_zdot(const std::vector<double>& zdot) override {
    // From here on every call alternates between the state and one whose first coordinate is
    // one ulp away: DART's setPositions returns early on unchanged positions, keeping the
    // kinematics (and the mass matrix) of the previous call, which kanedyn's calls recompute.
    positions_apart_ = positions_;
    positions_apart_[0] = std::nextafter(positions_[0], 1e300);
    alternate_ = true;
    alternated_ = true;  // the next call takes positions_
    skeleton_->setPositions(positions_);
    skeleton_->setVelocities(velocities_);
    map_ = speed_map();
    accelerations_ = map_ * Eigen::Map<const Eigen::VectorXd>(
                                zdot.data(), static_cast<Eigen::Index>(zdot.size()));
    for (size_t k = 0; k < joints_.size(); ++k) {
      if (system_.joints[k].type != JointKind::free) continue;
      const Eigen::Vector6d v = joints_[k]->getVelocities();
      accelerations_.segment<3>(static_cast<Eigen::Index>(joints_[k]->getIndexInSkeleton(3))) -=
          v.head<3>().cross(v.tail<3>());
    }
  }

  // Skeleton::computeInverseDynamics with the bushings as external forces (as in evaluate());
  // the joint loads are subtracted afterwards (generalized_forces), being the model's own.
  void inverse_dynamics() override {
    skeleton_->setPositions(next_positions());
    skeleton_->setVelocities(velocities_);
    skeleton_->setAccelerations(accelerations_);
    skeleton_->clearExternalForces();
    for (size_t k = 0; k < joints_.size(); ++k)
      if (system_.joints[k].type == JointKind::free) apply_bushing(k);
    skeleton_->computeInverseDynamics(true, false, false);
  }

  std::vector<double> generalized_forces() override {
    const Eigen::VectorXd q = map_.transpose() * skeleton_->getForces();
    std::vector<double> out(q.data(), q.data() + q.size());
    for (size_t k = 0; k < joints_.size(); ++k) {
      const JointSpec& j = system_.joints[k];
      double* z = out.data() + system_.z_offset[k];
      switch (j.type) {
        case JointKind::revolute:
        case JointKind::prismatic:
        case JointKind::universal:
        case JointKind::planar:
          for (size_t i = 0; i < joints_[k]->getNumDofs(); ++i) z[i] -= load(j, i, joints_[k], i);
          break;
        case JointKind::cylindrical:
          z[0] -= load(j, 0, joints_[k], 0);
          z[1] -= load(j, 1, joints_extra_[k], 0);
          break;
        default:
          break;
      }
    }
    return out;
  }

  // Skeleton::getMassMatrix after setPositions (which marks it out of date).
  void mass_matrix() override {
    skeleton_->setPositions(next_positions());
    mass_sink_ = skeleton_->getMassMatrix()(0, 0);
  }

  std::vector<double> mass_matrix_in_z() override {
    skeleton_->setPositions(positions_);
    alternated_ = false;
    const Eigen::MatrixXd m = map_.transpose() * skeleton_->getMassMatrix() * map_;
    return std::vector<double>(m.data(), m.data() + m.size());
  }

  // The skeleton's accelerations at its current positions and velocities, loads included.
  void accelerations() {
    skeleton_->clearExternalForces();
    for (size_t k = 0; k < joints_.size(); ++k) {
      const JointSpec& j = system_.joints[k];
      dart::dynamics::Joint* joint = joints_[k];
      switch (j.type) {
        case JointKind::free:
          apply_bushing(k);
          break;
        case JointKind::revolute:
        case JointKind::prismatic:
        case JointKind::universal:
        case JointKind::planar:
          for (size_t i = 0; i < joint->getNumDofs(); ++i) joint->setForce(i, load(j, i, joint, i));
          break;
        case JointKind::cylindrical:
          joint->setForce(0, load(j, 0, joint, 0));
          joints_extra_[k]->setForce(0, load(j, 1, joints_extra_[k], 0));
          break;
        default:
          break;
      }
    }
    skeleton_->computeForwardDynamics();
  }
  dart::dynamics::Skeleton& skeleton() { return *skeleton_; }

 private:
  static double load(const JointSpec& j, size_t c, const dart::dynamics::Joint* joint, size_t i) {
    return j.value[c] - j.stiffness[c] * (joint->getPosition(i) - j.rest[c]) -
           j.damping[c] * joint->getVelocity(i);
  }

  // A free root's bushing to the ground (DartEngine::apply_loads with J the ground).
  void apply_bushing(size_t k) {
    const Body& b = system_.bodies[k];
    BodyNode* K = bodies_[k];
    const Eigen::Isometry3d& X_K = K->getWorldTransform();
    const Vector3d s = X_K.translation() - e3(b.joint);
    const Vector3d s_dot = K->getLinearVelocity();
    const Vector3d f = -e3(b.k).cwiseProduct(s) - e3(b.c).cwiseProduct(s_dot);
    const Eigen::AngleAxisd rel(X_K.linear());  // angle in [0, pi]
    const Vector3d m = -b.kr * rel.angle() * rel.axis() - b.cr * K->getAngularVelocity();
    K->addExtForce(f, Vector3d::Zero(), false, true);  // at O_K
    K->addExtTorque(m, false);
  }

  // positions_, or after set_zdot() positions_ and positions_apart_ in turn.
  const Eigen::VectorXd& next_positions() {
    if (!alternate_) return positions_;
    alternated_ = !alternated_;
    return alternated_ ? positions_apart_ : positions_;
  }

  // u = T z at the skeleton's state: per body, DART's dofs of kanedyn's speeds (a cylindrical
  // joint's slide on its extra joint) and, for a free root, v = R^T s' dot (K components).
  Eigen::MatrixXd speed_map() const {
    const auto n = static_cast<Eigen::Index>(system_.z.size());
    Eigen::MatrixXd t = Eigen::MatrixXd::Zero(n, n);
    const auto dof = [](const dart::dynamics::Joint* joint, size_t i) {
      return static_cast<Eigen::Index>(joint->getIndexInSkeleton(i));
    };
    for (size_t k = 0; k < joints_.size(); ++k) {
      const Eigen::Index off = system_.z_offset[k];
      const dart::dynamics::Joint* joint = joints_[k];
      switch (system_.joints[k].type) {
        case JointKind::free: {
          const Eigen::Matrix3d R = bodies_[k]->getWorldTransform().linear();
          for (int a = 0; a < 3; ++a) {
            t(dof(joint, static_cast<size_t>(a)), off + a) = 1;
            for (int b = 0; b < 3; ++b)
              t(dof(joint, static_cast<size_t>(3 + a)), off + 3 + b) = R(b, a);
          }
          break;
        }
        case JointKind::cylindrical:
          t(dof(joint, 0), off) = 1;
          t(dof(joints_extra_.at(k), 0), off + 1) = 1;
          break;
        case JointKind::weld:
          break;
        default:
          for (size_t i = 0; i < joint->getNumDofs(); ++i)
            t(dof(joint, i), off + static_cast<Eigen::Index>(i)) = 1;
      }
    }
    return t;
  }

  JointedSystem system_;
  dart::dynamics::SkeletonPtr skeleton_;
  std::vector<BodyNode*> bodies_;
  std::vector<dart::dynamics::Joint*> joints_;
  std::map<size_t, dart::dynamics::Joint*> joints_extra_;  // a cylindrical joint's slide
  Eigen::VectorXd positions_, velocities_;
  Eigen::MatrixXd map_;            // speed_map() at set_zdot()
  Eigen::VectorXd accelerations_;  // set_zdot()'s, DART's
  volatile double mass_sink_ = 0;  // keeps the timed mass matrix
  Eigen::VectorXd positions_apart_;
  bool alternate_ = false, alternated_ = false;
  Rk4 rk4_integrator_;
  Eigen::VectorXd q_int_, v_int_;
  double step_ = 0, time_ = 0;
  long steps_ = 0;
};

}  // namespace

JointedEngineInfo dart_jointed_engine() {
  return {"DART", DART_VERSION,
          [](const JointedSystem& s) {
            for (const JointSpec& j : s.joints)
              if (j.type == JointKind::screw) return std::string("screw joints not translated");
            if (!s.springs.empty()) return std::string("point-to-point springs not translated");
            return s.constraints.empty() ? std::string()
                                         : std::string("constraints not translated");
          },
          [](const JointedSystem& s) -> std::unique_ptr<JointedEngine> {
            return std::make_unique<DartJointedEngine>(s);
          }};
}

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
