// Simbody peer: one MobilizedBody::Free per body, inboard frame F at q'_K on the lower body
// (axes of the lower body), outboard frame M at O_K (the body frame), so the mobilizer's
// translation is s'_K in body-J axes and its rotation is K's orientation relative to J.
// Gravity by Force::Gravity; bushings and constant loads by one Force::Custom.
//
// Debian's Simbody libraries are built without NDEBUG, and Simbody's headers change class
// layouts with it: this file must be compiled without NDEBUG (see CMakeLists.txt), or
// realizeTopology() crashes.
#ifdef NDEBUG
#error "simbody_peer.cpp must be compiled without NDEBUG (Debian's Simbody is built without it)"
#endif

#include <Simbody.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "peer.hpp"

namespace peers {
namespace {

using SimTK::Quaternion;
using SimTK::Real;
using SimTK::Rotation;
using SimTK::SpatialVec;
using SimTK::Transform;

SimTK::Vec3 v3(const Vec3& a) { return {a[0], a[1], a[2]}; }
Vec3 a3(const SimTK::Vec3& v) { return {v[0], v[1], v[2]}; }

// theta of the spec: angle in [0, pi] times the unit axis, from a quaternion (w, x, y, z).
SimTK::Vec3 rotation_vector(Real w, const SimTK::Vec3& xyz) {
  SimTK::Vec3 v = xyz;
  if (w < 0) {
    w = -w;
    v = -v;
  }
  const Real n = v.norm();
  if (n < 1e-8) return (2.0 / w) * (1.0 - n * n / (3.0 * w * w)) * v;
  return (2.0 * std::atan2(n, w) / n) * v;
}

// The integrator of `settings` on `system`, started at `initial` (t = 0). A constraint
// tolerance of 0 leaves Simbody's default (the accuracy).
IntegratorInfo start_integrator(SimTK::MultibodySystem& system, const SimTK::State& initial,
                                const IntegratorSettings& settings,
                                std::unique_ptr<SimTK::Integrator>& integrator,
                                double constraint_tolerance = 0) {
  const std::string& method = settings.method;
  std::string name;
  if (method.empty() || method == "rkmerson") {
    integrator = std::make_unique<SimTK::RungeKuttaMersonIntegrator>(system);
    name = "RungeKuttaMerson";
  } else if (method == "rkf") {
    integrator = std::make_unique<SimTK::RungeKuttaFeldbergIntegrator>(system);
    name = "RungeKuttaFeldberg";
  } else if (method == "rk3") {
    integrator = std::make_unique<SimTK::RungeKutta3Integrator>(system);
    name = "RungeKutta3";
  } else if (method == "cpodes") {
    integrator = std::make_unique<SimTK::CPodesIntegrator>(system, SimTK::CPodes::BDF,
                                                           SimTK::CPodes::Newton);
    name = "CPodes (BDF, Newton)";
  } else {
    throw std::invalid_argument("Simbody: unknown integrator '" + method +
                                "' (rkmerson, rkf, rk3, cpodes)");
  }
  integrator->setAccuracy(settings.accuracy);
  if (constraint_tolerance > 0) integrator->setConstraintTolerance(constraint_tolerance);
  // Step to each output time exactly: no interpolated (lower-order) output states.
  integrator->setAllowInterpolation(false);
  SimTK::State start = initial;
  start.setTime(0);
  integrator->initialize(start);
  char accuracy[32];
  std::snprintf(accuracy, sizeof accuracy, "%.3g", settings.accuracy);
  // Error control per step: the global error follows the accuracy to about the first power.
  return {name + ", accuracy " + accuracy, false, 1.0};
}

void advance_integrator(SimTK::Integrator& integrator, double t) {
  while (integrator.getTime() < t) {
    const auto status = integrator.stepTo(t);
    if (status == SimTK::Integrator::EndOfSimulation || integrator.isSimulationOver())
      throw std::runtime_error(
          "Simbody: integration ended at t = " + std::to_string(integrator.getTime()) + ": " +
          SimTK::Integrator::getTerminationReasonString(integrator.getTerminationReason()));
    if (status == SimTK::Integrator::ReachedReportTime) break;
  }
}

// Poses of the bodies at an integrated state.
std::vector<BodyPose> body_poses(const SimTK::MultibodySystem& system, SimTK::State state,
                                 const std::vector<SimTK::MobilizedBody>& bodies,
                                 const std::vector<Body>& specs) {
  system.realize(state, SimTK::Stage::Velocity);
  std::vector<BodyPose> out(bodies.size());
  for (size_t k = 0; k < bodies.size(); ++k) {
    const SimTK::MobilizedBody& mb = bodies[k];
    const SimTK::Vec3 com = v3(specs[k].com);
    out[k].p_G = a3(mb.findStationLocationInGround(state, com));
    out[k].v_G = a3(mb.findStationVelocityInGround(state, com));
    out[k].w = a3(mb.getBodyAngularVelocity(state));
    const SimTK::Mat33& R = mb.getBodyRotation(state).asMat33();  // body axes -> ground
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) out[k].R[static_cast<size_t>(3 * r + c)] = R(r, c);
  }
  return out;
}

SimTK::Body::Rigid rigid_body(const Body& b) {
  const SimTK::Inertia central(SimTK::Mat33(b.inertia[0], b.inertia[1], b.inertia[2], b.inertia[3],
                                            b.inertia[4], b.inertia[5], b.inertia[6], b.inertia[7],
                                            b.inertia[8]));
  // MassProperties wants the inertia about the body origin O_K.
  return SimTK::Body::Rigid(
      SimTK::MassProperties(b.mass, v3(b.com), central.shiftFromMassCenter(v3(b.com), b.mass)));
}

// The spec's bushing laws and constant loads. A bushing's translational force on s'_K and
// its moment pair about theta are exactly generalized forces on the Free mobilizer's
// translational speeds (v_FM in F = s'_K dot) and rotational speeds (w_FM in F = w_K - w_J
// in J axes), so they go into mobilityForces.
class Loads : public SimTK::Force::Custom::Implementation {
 public:
  Loads(const System& system, const std::vector<SimTK::MobilizedBody>& bodies)
      : system_(system), bodies_(bodies) {}

  void calcForce(const SimTK::State& state, SimTK::Vector_<SpatialVec>& body_forces,
                 SimTK::Vector_<SimTK::Vec3>&, SimTK::Vector& mobility_forces) const override {
    const SimTK::Vector& q = state.getQ();
    const SimTK::Vector& u = state.getU();
    for (size_t k = 0; k < bodies_.size(); ++k) {
      const Body& b = system_.bodies[k];
      const SimTK::MobilizedBody& mb = bodies_[k];
      const int iq = mb.getFirstQIndex(state), iu = mb.getFirstUIndex(state);
      // q = (quaternion of R_FM, p_FM), u = (w_FM, v_FM), all in F.
      const SimTK::Vec3 theta =
          rotation_vector(q[iq], SimTK::Vec3(q[iq + 1], q[iq + 2], q[iq + 3]));
      for (int i = 0; i < 3; ++i) {
        mobility_forces[iu + i] -= b.kr * theta[i] + b.cr * u[iu + i];
        mobility_forces[iu + 3 + i] -= b.k[i] * q[iq + 4 + i] + b.c[i] * u[iu + 3 + i];
      }
      if (system_.has_constant_loads) {
        const Transform& X_GB = mb.getBodyTransform(state);
        const SimTK::Vec3 f = v3(b.force);
        const SimTK::Vec3 r_G = X_GB.R() * v3(b.com);  // O_K to G_K, ground axes
        mb.applyBodyForce(state, SpatialVec(X_GB.R() * v3(b.torque_b) + r_G % f, f), body_forces);
      }
    }
  }
  Real calcPotentialEnergy(const SimTK::State&) const override { return 0; }

 private:
  const System& system_;
  std::vector<SimTK::MobilizedBody> bodies_;
};

class SimbodyEngine final : public Engine {
 public:
  explicit SimbodyEngine(const System& system)
      : system_(system), matter_(mb_system_), forces_(mb_system_) {
    SimTK::Force::Gravity(forces_, matter_, v3(system.gravity));
    for (const Body& b : system.bodies) {
      const SimTK::Body::Rigid body = rigid_body(b);
      SimTK::MobilizedBody& parent =
          b.parent < 0 ? matter_.updGround() : bodies_[static_cast<size_t>(b.parent)];
      bodies_.push_back(
          SimTK::MobilizedBody::Free(parent, Transform(v3(b.joint)), body, Transform()));
    }
    SimTK::Force::Custom(forces_, new Loads(system_, bodies_));
    mb_system_.realizeTopology();
    state_ = mb_system_.getDefaultState();
    for (size_t k = 0; k < bodies_.size(); ++k) {
      const BodyState& s = system.state[k];
      const Quaternion quat(s.q_rel[0], s.q_rel[1], s.q_rel[2], s.q_rel[3]);
      bodies_[k].setQToFitTransform(state_, Transform(Rotation(quat), v3(s.s)));
      bodies_[k].setUToFitVelocity(state_, SpatialVec(v3(s.w_rel_j), v3(s.s_dot)));
    }
    q_ = state_.getQ();
    u_ = state_.getU();
  }

  void evaluate() override {
    // Setting Q and U invalidates every stage from Position on, so each evaluation does the
    // whole forward-dynamics computation again.
    state_.updQ() = q_;
    state_.updU() = u_;
    mb_system_.realize(state_, SimTK::Stage::Acceleration);
  }

  std::vector<BodyMotion> motion() override {
    std::vector<BodyMotion> out(bodies_.size());
    for (size_t k = 0; k < bodies_.size(); ++k) {
      const SimTK::MobilizedBody& mb = bodies_[k];
      const SimTK::Vec3 com = v3(system_.bodies[k].com);
      out[k].p_G = a3(mb.findStationLocationInGround(state_, com));
      out[k].v_G = a3(mb.findStationVelocityInGround(state_, com));
      out[k].w = a3(mb.getBodyAngularVelocity(state_));
      out[k].a_G = a3(mb.findStationAccelerationInGround(state_, com));
      out[k].alpha = a3(mb.getBodyAngularAcceleration(state_));
    }
    return out;
  }

  IntegratorInfo start(const IntegratorSettings& settings) override {
    SimTK::State initial = state_;
    initial.updQ() = q_;
    initial.updU() = u_;
    return start_integrator(mb_system_, initial, settings, integrator_);
  }

  void advance_to(double t) override { advance_integrator(*integrator_, t); }

  std::vector<BodyPose> pose() override {
    return body_poses(mb_system_, integrator_->getState(), bodies_, system_.bodies);
  }

  long steps() const override { return integrator_ ? integrator_->getNumStepsTaken() : 0; }

 private:
  System system_;
  SimTK::MultibodySystem mb_system_;
  SimTK::SimbodyMatterSubsystem matter_;
  SimTK::GeneralForceSubsystem forces_;
  std::vector<SimTK::MobilizedBody> bodies_;
  SimTK::State state_;
  SimTK::Vector q_, u_;
  std::unique_ptr<SimTK::Integrator> integrator_;
};

// ---------------------------------------------------------------------------------------------
// Jointed trees. Simbody's mobilizers move about fixed axes of their inboard frame F_s: Pin
// and Cylinder about z, Slider along x, Universal about x then the new y. Each joint's F_s is
// kanedyn's F turned by a constant S that takes those axes onto the joint's (S z = n for a
// revolute or cylindrical joint, S x = n for a prismatic one, S (x, y) = (a1, a2) for a
// universal one), and the outboard frame M is the body frame turned by the same S, so that
// R_FK = S R_FsM S^T: the turn by q about n (or a1 then a2), with Simbody's q equal to
// kanedyn's. Ball: F_s = F, M = the body frame, q = the quaternion of K relative to F, u = the
// angular velocity of K relative to J in F components (kanedyn's z in K components turned by
// R_FK). Planar: F_s = F, M = the body frame; Simbody's q = (angle about z, x, y along F's x
// and y) (MobilizedBody_Planar.h) is kanedyn's (x, y, angle) rotated by one place, u = q dot
// likewise (planar_index). Free (roots only): as SimbodyEngine's, u = (w_K, v) in ground
// components.

// Simbody's index of kanedyn's coordinate i of a joint: the same, except for a planar joint,
// whose angle comes first in Simbody's q.
int simbody_index(JointKind type, int i) { return type == JointKind::planar ? (i + 1) % 3 : i; }

class JointLoads : public SimTK::Force::Custom::Implementation {
 public:
  JointLoads(const JointedSystem& system, const std::vector<SimTK::MobilizedBody>& bodies)
      : system_(system), bodies_(bodies) {}

  void calcForce(const SimTK::State& state, SimTK::Vector_<SpatialVec>&,
                 SimTK::Vector_<SimTK::Vec3>&, SimTK::Vector& mobility_forces) const override {
    const SimTK::Vector& q = state.getQ();
    const SimTK::Vector& u = state.getU();
    for (size_t k = 0; k < bodies_.size(); ++k) {
      const JointSpec& j = system_.joints[k];
      const SimTK::MobilizedBody& mb = bodies_[k];
      const int iq = mb.getFirstQIndex(state), iu = mb.getFirstUIndex(state);
      if (j.type == JointKind::free) {
        const Body& b = system_.bodies[k];
        const SimTK::Vec3 theta =
            rotation_vector(q[iq], SimTK::Vec3(q[iq + 1], q[iq + 2], q[iq + 3]));
        for (int i = 0; i < 3; ++i) {
          mobility_forces[iu + i] -= b.kr * theta[i] + b.cr * u[iu + i];
          mobility_forces[iu + 3 + i] -= b.k[i] * q[iq + 4 + i] + b.c[i] * u[iu + 3 + i];
        }
        continue;
      }
      if (j.type == JointKind::weld || j.type == JointKind::spherical) continue;
      const int n = mb.getNumU(state);
      for (int i = 0; i < n; ++i) {  // i: kanedyn's coordinate, s: Simbody's
        const auto c = static_cast<size_t>(i);
        const int s = simbody_index(j.type, i);
        mobility_forces[iu + s] +=
            j.value[c] - j.stiffness[c] * (q[iq + s] - j.rest[c]) - j.damping[c] * u[iu + s];
      }
    }
  }
  Real calcPotentialEnergy(const SimTK::State&) const override { return 0; }

 private:
  const JointedSystem& system_;
  std::vector<SimTK::MobilizedBody> bodies_;
};

SimTK::Rotation rotation(const Quat& q) { return Rotation(Quaternion(q[0], q[1], q[2], q[3])); }

// A rotation whose columns are u, v, w (unit, right-handed).
Rotation columns(const SimTK::Vec3& u, const SimTK::Vec3& v, const SimTK::Vec3& w) {
  return Rotation(SimTK::Mat33(u[0], v[0], w[0], u[1], v[1], w[1], u[2], v[2], w[2]), true);
}

// S of the comment above for a joint: F_s components -> F components.
Rotation axes_rotation(const JointSpec& j) {
  const SimTK::Vec3 n = v3(j.axis);
  // Some unit vector perpendicular to n.
  const SimTK::Vec3 p = (std::fabs(n[0]) < 0.9 ? SimTK::Vec3(1, 0, 0) : SimTK::Vec3(0, 1, 0)) % n;
  const SimTK::Vec3 u = p / p.norm();
  switch (j.type) {
    case JointKind::revolute:
    case JointKind::cylindrical:
    case JointKind::screw:
      return columns(u, n % u, n);
    case JointKind::prismatic:
      return columns(n, u, n % u);
    case JointKind::universal:
      return columns(n, v3(j.axis2), n % v3(j.axis2));
    default:  // the identity (Rotation() trips GCC 12's -Warray-bounds in Simbody's Mat)
      return columns(SimTK::Vec3(1, 0, 0), SimTK::Vec3(0, 1, 0), SimTK::Vec3(0, 0, 1));
  }
}

class SimbodyJointedEngine final : public JointedEngine {
 public:
  explicit SimbodyJointedEngine(const JointedSystem& system)
      : system_(system), matter_(mb_system_), forces_(mb_system_) {
    SimTK::Force::Gravity(forces_, matter_, v3(system.gravity));
    for (size_t k = 0; k < system.bodies.size(); ++k) {
      const Body& b = system.bodies[k];
      const JointSpec& j = system.joints[k];
      SimTK::MobilizedBody& parent =
          b.parent < 0 ? matter_.updGround() : bodies_[static_cast<size_t>(b.parent)];
      const Rotation S = axes_rotation(j);
      const Transform X_PF(rotation(j.frame) * S, v3(b.joint));
      const Transform X_BM(S);
      const SimTK::Body::Rigid body = rigid_body(b);
      switch (j.type) {
        case JointKind::free:
          bodies_.push_back(
              SimTK::MobilizedBody::Free(parent, Transform(v3(b.joint)), body, Transform()));
          break;
        case JointKind::weld:
          bodies_.push_back(SimTK::MobilizedBody::Weld(
              parent, Transform(rotation(j.frame), v3(b.joint) + v3(j.translation)), body,
              Transform()));
          break;
        case JointKind::revolute:
          bodies_.push_back(SimTK::MobilizedBody::Pin(parent, X_PF, body, X_BM));
          break;
        case JointKind::prismatic:
          bodies_.push_back(SimTK::MobilizedBody::Slider(parent, X_PF, body, X_BM));
          break;
        case JointKind::cylindrical:
          bodies_.push_back(SimTK::MobilizedBody::Cylinder(parent, X_PF, body, X_BM));
          break;
        case JointKind::universal:
          bodies_.push_back(SimTK::MobilizedBody::Universal(parent, X_PF, body, X_BM));
          break;
        case JointKind::spherical:
          bodies_.push_back(SimTK::MobilizedBody::Ball(parent, X_PF, body, X_BM));
          break;
        case JointKind::planar:  // S is the identity: Simbody's plane is F's x-y plane
          bodies_.push_back(SimTK::MobilizedBody::Planar(parent, X_PF, body, X_BM));
          break;
        case JointKind::screw:  // the turn about M's z = F's z, and pitch times it along it
          bodies_.push_back(SimTK::MobilizedBody::Screw(parent, X_PF, body, X_BM, j.pitch));
          break;
      }
    }
    SimTK::Force::Custom(forces_, new JointLoads(system_, bodies_));
    add_springs();
    add_constraints();
    mb_system_.realizeTopology();
    state_ = mb_system_.getDefaultState();
    for (size_t k = 0; k < bodies_.size(); ++k) {
      const JointSpec& j = system.joints[k];
      const double* q = system.q.data() + system.q_offset[k];
      const double* z = system.z.data() + system.z_offset[k];
      SimTK::MobilizedBody& mb = bodies_[k];
      switch (j.type) {
        case JointKind::free: {
          // kanedyn's eps_K (e4 scalar) as the Hamilton quaternion of K in the ground.
          const Rotation R(Quaternion(q[3], q[0], q[1], q[2]));
          mb.setQToFitTransform(state_, Transform(R, SimTK::Vec3(q[4], q[5], q[6])));
          mb.setUToFitVelocity(
              state_, SpatialVec(R * SimTK::Vec3(z[0], z[1], z[2]), SimTK::Vec3(z[3], z[4], z[5])));
          break;
        }
        case JointKind::spherical: {
          const Rotation R_FK(Quaternion(q[3], q[0], q[1], q[2]));
          mb.setQToFitRotation(state_, R_FK);
          mb.setUToFitAngularVelocity(state_, R_FK * SimTK::Vec3(z[0], z[1], z[2]));
          break;
        }
        case JointKind::weld:
          break;
        default:
          for (int i = 0; i < mb.getNumQ(state_); ++i) {
            mb.setOneQ(state_, simbody_index(j.type, i), q[i]);
            mb.setOneU(state_, simbody_index(j.type, i), z[i]);
          }
      }
    }
    q_ = state_.getQ();
    u_ = state_.getU();
  }

  void evaluate() override {
    state_.updQ() = q_;
    state_.updU() = u_;
    mb_system_.realize(state_, SimTK::Stage::Acceleration);
  }

  std::vector<double> zdot() override {
    std::vector<double> out(system_.z.size(), 0.0);
    const SimTK::Vector& udot = state_.getUDot();
    for (size_t k = 0; k < bodies_.size(); ++k) {
      const SimTK::MobilizedBody& mb = bodies_[k];
      const int iu = mb.getFirstUIndex(state_);
      double* z = out.data() + system_.z_offset[k];
      auto rates = [&] { return SimTK::Vec3(udot[iu], udot[iu + 1], udot[iu + 2]); };
      switch (system_.joints[k].type) {
        case JointKind::free: {
          // d/dt of w's ground components is alpha; in K components the same vector (the
          // turning of K's axes adds w x w = 0).
          const SimTK::Vec3 alpha_k = ~mb.getBodyRotation(state_) * rates();
          for (int i = 0; i < 3; ++i) {
            z[i] = alpha_k[i];
            z[3 + i] = udot[iu + 3 + i];
          }
          break;
        }
        case JointKind::spherical: {
          // Likewise from F components to K's.
          const SimTK::Vec3 w_dot_k = ~mb.getMobilizerTransform(state_).R() * rates();
          for (int i = 0; i < 3; ++i) z[i] = w_dot_k[i];
          break;
        }
        case JointKind::weld:
          break;
        default:
          for (int i = 0; i < mb.getNumU(state_); ++i)
            z[i] = udot[iu + simbody_index(system_.joints[k].type, i)];
      }
    }
    return out;
  }

  // With constraints, the integrator keeps them to a hundredth of its accuracy (Simbody's
  // default is the accuracy itself), so that the joint angles' drift off the loop stays below
  // the integration error being compared.
  IntegratorInfo start(const IntegratorSettings& settings) override {
    SimTK::State initial = state_;
    initial.updQ() = q_;
    initial.updU() = u_;
    const double tolerance = system_.constraints.empty() ? 0.0 : 1e-2 * settings.accuracy;
    return start_integrator(mb_system_, initial, settings, integrator_, tolerance);
  }
  void advance_to(double t) override { advance_integrator(*integrator_, t); }
  std::vector<BodyPose> pose() override {
    return body_poses(mb_system_, integrator_->getState(), bodies_, system_.bodies);
  }

  std::vector<double> reactions() override { return reactions_at(state_); }

  void integrated_state(std::vector<double>& q, std::vector<double>& z,
                        std::vector<double>& reactions) override {
    SimTK::State state = integrator_->getState();
    mb_system_.realize(state, SimTK::Stage::Acceleration);
    q = coordinates(state);
    z = speeds(state);
    reactions = reactions_at(state);
  }
  long steps() const override { return integrator_ ? integrator_->getNumStepsTaken() : 0; }

  // MultibodySystem::calcEnergy: kinetic plus every force element's potential (Force::Gravity's
  // -m g . p_G with its zero height at the origin, the springs' 1/2 k (L - L0)^2); JointLoads
  // reports none, so this is the whole energy only for systems without joint springs.
  double energy() override {
    SimTK::State state = integrator_->getState();
    mb_system_.realize(state, SimTK::Stage::Velocity);
    return mb_system_.calcEnergy(state);
  }

  bool has_terms() const override { return true; }

  // Simbody's u dot from kanedyn's z dot: u = T z (speed_map), with T constant along the
  // motion in the sense of zdot(): u dot = T z dot.
  void set_zdot(const std::vector<double>& zdot) override {
    state_.updQ() = q_;
    state_.updU() = u_;
    mb_system_.realize(state_, SimTK::Stage::Position);
    map_ = speed_map();
    const std::vector<double> udot = times(map_, zdot, false);
    udot_.resize(static_cast<int>(udot.size()));
    for (size_t i = 0; i < udot.size(); ++i) udot_[static_cast<int>(i)] = udot[i];
  }

  // The applied forces of every force element (gravity, bushings, joint loads) at the state,
  // then SimbodyMatterSubsystem::calcResidualForceIgnoringConstraints: M u dot + C - applied,
  // the forces to add to the model's own for u dot.
  void inverse_dynamics() override {
    state_.updQ() = q_;
    state_.updU() = u_;
    mb_system_.realize(state_, SimTK::Stage::Dynamics);
    matter_.calcResidualForceIgnoringConstraints(
        state_, mb_system_.getMobilityForces(state_, SimTK::Stage::Dynamics),
        mb_system_.getRigidBodyForces(state_, SimTK::Stage::Dynamics), udot_, residual_);
  }

  std::vector<double> generalized_forces() override {
    std::vector<double> r(static_cast<size_t>(residual_.size()));
    for (size_t i = 0; i < r.size(); ++i) r[i] = residual_[static_cast<int>(i)];
    return times(map_, r, true);
  }

  // SimbodyMatterSubsystem::calcM after setting Q (which invalidates the Position stage).
  void mass_matrix() override {
    state_.updQ() = q_;
    mb_system_.realize(state_, SimTK::Stage::Position);
    matter_.calcM(state_, mass_);
  }

  std::vector<double> mass_matrix_in_z() override {
    const size_t n = system_.z.size();
    std::vector<double> out(n * n), column(n);
    for (size_t c = 0; c < n; ++c) {  // T^T M T, a column at a time
      std::vector<double> e(n, 0.0);
      e[c] = 1;
      const std::vector<double> tc = times(map_, e, false);
      for (size_t i = 0; i < n; ++i) {
        double sum = 0;
        for (size_t j = 0; j < n; ++j)
          sum += mass_(static_cast<int>(i), static_cast<int>(j)) * tc[j];
        column[i] = sum;
      }
      const std::vector<double> col = times(map_, column, true);
      std::copy(col.begin(), col.end(), out.begin() + static_cast<std::ptrdiff_t>(c * n));
    }
    return out;
  }

 private:
  // u = T z at the realized state, n x n by columns: per body, Simbody's u of kanedyn's
  // speeds (planar_index), a free root's w in ground components (R_K w'_K) and a ball's
  // in F components (R_FK z).
  std::vector<double> speed_map() const {
    const size_t n = system_.z.size();
    std::vector<double> t(n * n, 0.0);
    const auto at = [&t, n](int row, int col) -> double& {
      return t[static_cast<size_t>(col) * n + static_cast<size_t>(row)];
    };
    for (size_t k = 0; k < bodies_.size(); ++k) {
      const SimTK::MobilizedBody& mb = bodies_[k];
      const int iu = mb.getFirstUIndex(state_);
      const int off = system_.z_offset[k];
      const JointKind type = system_.joints[k].type;
      if (type == JointKind::free || type == JointKind::spherical) {
        const Rotation R = type == JointKind::free ? mb.getBodyRotation(state_)
                                                   : mb.getMobilizerTransform(state_).R();
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) at(iu + a, off + b) = R[a][b];
        if (type == JointKind::free)
          for (int a = 3; a < 6; ++a) at(iu + a, off + a) = 1;
        continue;
      }
      for (int i = 0; i < mb.getNumU(state_); ++i) at(iu + simbody_index(type, i), off + i) = 1;
    }
    return t;
  }

  // T x or T^T x for T of speed_map().
  static std::vector<double> times(const std::vector<double>& t, const std::vector<double>& x,
                                   bool transposed) {
    const size_t n = x.size();
    std::vector<double> out(n, 0.0);
    for (size_t c = 0; c < n; ++c)
      for (size_t r = 0; r < n; ++r) {
        const double v = t[c * n + r];
        if (v == 0) continue;
        if (transposed)
          out[c] += v * x[r];
        else
          out[r] += v * x[c];
      }
    return out;
  }

  // kanedyn's point-to-point springs as Simbody's Force::TwoPointLinearSpring (force
  // k (L - L0) along the line, drawing the points together when stretched) and, with damping,
  // Force::TwoPointLinearDamper (force c dL/dt along the line): the same law as kanedyn::Spring.
  void add_springs() {
    for (const SpringSpec& s : system_.springs) {
      SimTK::MobilizedBody& body = bodies_[static_cast<size_t>(s.body)];
      SimTK::MobilizedBody& other =
          s.other < 0 ? matter_.updGround() : bodies_[static_cast<size_t>(s.other)];
      SimTK::Force::TwoPointLinearSpring(forces_, body, v3(s.at), other, v3(s.other_at),
                                         s.stiffness, s.rest_length);
      if (s.damping != 0)
        SimTK::Force::TwoPointLinearDamper(forces_, body, v3(s.at), other, v3(s.other_at),
                                           s.damping);
    }
  }

  // kanedyn's constraints as Simbody's: a ball as Constraint::Ball (body 1 kanedyn's `body`);
  // a hinge as that ball and two Constraint::ConstantAngle at 90 degrees between the body's
  // axis a and the other's p1, p2 (kanedyn's own alignment equations); a distance as
  // Constraint::Rod. Redundant equations (a planar loop closed by a hinge) are Simbody's to
  // handle: it solves for least-squares multipliers, as kanedyn does.
  void add_constraints() {
    for (const ConstraintSpec& c : system_.constraints) {
      SimTK::MobilizedBody& body = bodies_[static_cast<size_t>(c.body)];
      SimTK::MobilizedBody& other =
          c.other < 0 ? matter_.updGround() : bodies_[static_cast<size_t>(c.other)];
      std::vector<SimTK::Constraint> parts;
      switch (c.type) {
        case ConstraintSpec::Kind::ball:
        case ConstraintSpec::Kind::hinge:
          parts.push_back(SimTK::Constraint::Ball(body, v3(c.at), other, v3(c.other_at)));
          break;
        case ConstraintSpec::Kind::distance:
          parts.push_back(SimTK::Constraint::Rod(body, v3(c.at), other, v3(c.other_at), c.length));
          break;
      }
      if (c.type == ConstraintSpec::Kind::hinge)
        for (const Vec3& p : c.p)
          parts.push_back(SimTK::Constraint::ConstantAngle(other, SimTK::UnitVec3(v3(p)), body,
                                                           SimTK::UnitVec3(v3(c.axis))));
      constraints_.push_back(parts);
    }
  }

  // The reactions in kanedyn's convention (JointedEngine::reactions) at a state realized
  // through Acceleration. Simbody's constraint forces on a constrained body are spatial
  // (moment about the body's origin, force), in ground, with the sign opposite to that of
  // applied forces (Constraint::getConstrainedBodyForcesAsVector): kanedyn's force is their
  // negative, its moment about `at` their negative moment less (at - O) x f.
  std::vector<double> reactions_at(const SimTK::State& state) const {
    std::vector<double> out;
    for (size_t i = 0; i < constraints_.size(); ++i) {
      const ConstraintSpec& c = system_.constraints[i];
      const SimTK::MobilizedBody& body = bodies_[static_cast<size_t>(c.body)];
      SimTK::Vec3 force(0), moment_O(0);
      for (const SimTK::Constraint& part : constraints_[i]) {
        const SimTK::Vector_<SpatialVec> f = part.getConstrainedBodyForcesAsVector(state);
        for (int b = 0; b < part.getNumConstrainedBodies(); ++b)
          if (part.getMobilizedBodyFromConstrainedBody(SimTK::ConstrainedBodyIndex(b))
                  .getMobilizedBodyIndex() == body.getMobilizedBodyIndex()) {
            moment_O -= f[b][0];
            force -= f[b][1];
          }
      }
      const SimTK::Vec3 arm = body.getBodyRotation(state) * v3(c.at);
      const SimTK::Vec3 moment = moment_O - arm % force;
      for (int a = 0; a < 3; ++a) out.push_back(force[a]);
      if (c.type == ConstraintSpec::Kind::hinge)
        for (int a = 0; a < 3; ++a) out.push_back(moment[a]);
    }
    return out;
  }

  // kanedyn's q at a state realized through Position: the constructor's mapping backwards.
  std::vector<double> coordinates(const SimTK::State& state) const {
    std::vector<double> out(system_.q.size(), 0.0);
    for (size_t k = 0; k < bodies_.size(); ++k) {
      const SimTK::MobilizedBody& mb = bodies_[k];
      double* q = out.data() + system_.q_offset[k];
      const JointKind type = system_.joints[k].type;
      if (type == JointKind::free || type == JointKind::spherical) {
        // A free joint is a root's: F has the ground's axes (at q'_K).
        const Transform& X = mb.getMobilizerTransform(state);
        const Quaternion e = X.R().convertRotationToQuaternion();  // (w, x, y, z)
        for (int i = 0; i < 3; ++i) q[i] = e[i + 1];
        q[3] = e[0];
        if (type == JointKind::free)
          for (int i = 0; i < 3; ++i) q[4 + i] = X.p()[i];
      } else if (type != JointKind::weld) {
        for (int i = 0; i < mb.getNumQ(state); ++i)
          q[i] = mb.getOneQ(state, simbody_index(type, i));
      }
    }
    return out;
  }

  // kanedyn's z at a state realized through Velocity (speed_map backwards).
  std::vector<double> speeds(const SimTK::State& state) const {
    std::vector<double> out(system_.z.size(), 0.0);
    for (size_t k = 0; k < bodies_.size(); ++k) {
      const SimTK::MobilizedBody& mb = bodies_[k];
      double* z = out.data() + system_.z_offset[k];
      const JointKind type = system_.joints[k].type;
      if (type == JointKind::free || type == JointKind::spherical) {
        const Rotation& R = mb.getMobilizerTransform(state).R();
        const SimTK::Vec3 w =
            ~R * SimTK::Vec3(mb.getOneU(state, 0), mb.getOneU(state, 1), mb.getOneU(state, 2));
        for (int i = 0; i < 3; ++i) z[i] = w[i];
        if (type == JointKind::free)
          for (int i = 0; i < 3; ++i) z[3 + i] = mb.getOneU(state, 3 + i);
      } else if (type != JointKind::weld) {
        for (int i = 0; i < mb.getNumU(state); ++i)
          z[i] = mb.getOneU(state, simbody_index(type, i));
      }
    }
    return out;
  }

  std::vector<std::vector<SimTK::Constraint>> constraints_;  // per ConstraintSpec
  std::vector<double> map_;
  SimTK::Vector udot_, residual_;
  SimTK::Matrix mass_;
  JointedSystem system_;
  SimTK::MultibodySystem mb_system_;
  SimTK::SimbodyMatterSubsystem matter_;
  SimTK::GeneralForceSubsystem forces_;
  std::vector<SimTK::MobilizedBody> bodies_;
  SimTK::State state_;
  SimTK::Vector q_, u_;
  std::unique_ptr<SimTK::Integrator> integrator_;
};

}  // namespace

JointedEngineInfo simbody_jointed_engine() {
  const EngineInfo free = simbody_engine();
  return {free.name, free.version, [](const JointedSystem&) { return std::string(); },
          [](const JointedSystem& s) -> std::unique_ptr<JointedEngine> {
            return std::make_unique<SimbodyJointedEngine>(s);
          }};
}

EngineInfo simbody_engine() {
  int major = 0, minor = 0, build = 0;
  SimTK_version_simbody(&major, &minor, &build);
  return {"Simbody", std::to_string(major) + "." + std::to_string(minor),
          // O(N) storage and work (articulated-body recursions).
          [](const System& s) { return 4000.0 * static_cast<double>(s.bodies.size()); },
          [](const System& s) { return static_cast<double>(s.bodies.size()); },
          [](const System& s) -> std::unique_ptr<Engine> {
            return std::make_unique<SimbodyEngine>(s);
          }};
}

}  // namespace peers
