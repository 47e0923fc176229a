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

#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

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
      const SimTK::Inertia central(SimTK::Mat33(b.inertia[0], b.inertia[1], b.inertia[2],
                                                b.inertia[3], b.inertia[4], b.inertia[5],
                                                b.inertia[6], b.inertia[7], b.inertia[8]));
      // MassProperties wants the inertia about the body origin O_K.
      const SimTK::Body::Rigid body(
          SimTK::MassProperties(b.mass, v3(b.com), central.shiftFromMassCenter(v3(b.com), b.mass)));
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
    const std::string& method = settings.method;
    std::string name;
    if (method.empty() || method == "rkmerson") {
      integrator_ = std::make_unique<SimTK::RungeKuttaMersonIntegrator>(mb_system_);
      name = "RungeKuttaMerson";
    } else if (method == "rkf") {
      integrator_ = std::make_unique<SimTK::RungeKuttaFeldbergIntegrator>(mb_system_);
      name = "RungeKuttaFeldberg";
    } else if (method == "rk3") {
      integrator_ = std::make_unique<SimTK::RungeKutta3Integrator>(mb_system_);
      name = "RungeKutta3";
    } else if (method == "cpodes") {
      integrator_ = std::make_unique<SimTK::CPodesIntegrator>(mb_system_, SimTK::CPodes::BDF,
                                                              SimTK::CPodes::Newton);
      name = "CPodes (BDF, Newton)";
    } else {
      throw std::invalid_argument("Simbody: unknown integrator '" + method +
                                  "' (rkmerson, rkf, rk3, cpodes)");
    }
    integrator_->setAccuracy(settings.accuracy);
    // Step to each output time exactly: no interpolated (lower-order) output states.
    integrator_->setAllowInterpolation(false);
    SimTK::State initial = state_;
    initial.setTime(0);
    initial.updQ() = q_;
    initial.updU() = u_;
    integrator_->initialize(initial);
    char accuracy[32];
    std::snprintf(accuracy, sizeof accuracy, "%.3g", settings.accuracy);
    // Error control per step: the global error follows the accuracy to about the first power.
    return {name + ", accuracy " + accuracy, false, 1.0};
  }

  void advance_to(double t) override {
    while (integrator_->getTime() < t) {
      const auto status = integrator_->stepTo(t);
      if (status == SimTK::Integrator::EndOfSimulation || integrator_->isSimulationOver())
        throw std::runtime_error(
            "Simbody: integration ended at t = " + std::to_string(integrator_->getTime()) + ": " +
            SimTK::Integrator::getTerminationReasonString(integrator_->getTerminationReason()));
      if (status == SimTK::Integrator::ReachedReportTime) break;
    }
  }

  std::vector<BodyPose> pose() override {
    SimTK::State state = integrator_->getState();
    mb_system_.realize(state, SimTK::Stage::Velocity);
    std::vector<BodyPose> out(bodies_.size());
    for (size_t k = 0; k < bodies_.size(); ++k) {
      const SimTK::MobilizedBody& mb = bodies_[k];
      const SimTK::Vec3 com = v3(system_.bodies[k].com);
      out[k].p_G = a3(mb.findStationLocationInGround(state, com));
      out[k].v_G = a3(mb.findStationVelocityInGround(state, com));
      out[k].w = a3(mb.getBodyAngularVelocity(state));
      const SimTK::Mat33& R = mb.getBodyRotation(state).asMat33();  // body axes -> ground
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) out[k].R[static_cast<size_t>(3 * r + c)] = R(r, c);
    }
    return out;
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

}  // namespace

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
