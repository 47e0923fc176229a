// Loads: per-body resultants from gravity and force elements, and the generalized forces of
// Eq. (31). Force laws exactly as docs/model-format.md ("Force laws, exactly") states them.
#pragma once

#include <string>

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

/// One force element. apply() adds its loads to data.loads.force (at G_K, inertial) and
/// data.loads.moment_b (body components) of the bodies it acts on. It may read the state and the
/// kinematics already in data (R, p_O, p_G; see compute_kinematics). It must not allocate.
class ForceElement {
 public:
  virtual ~ForceElement() = default;
  virtual std::string type() const = 0;  ///< as in model files: "bushing", "force", "torque"
  virtual int body() const = 0;          ///< the body K it is attached to
  /// Checks parameters against the model; returns "" or a message naming the problem.
  virtual std::string validate(const Model& model) const;
  virtual void apply(const Model& model, const State& state, const Kinematics& kin,
                     Loads& loads) const = 0;
  /// Whether apply() reads the positions or velocities in kin (p_O, p_G, qs_b, v_O, v_G) and
  /// not only the state and the rotations R. True unless an element says otherwise, so that
  /// an element written elsewhere is given all of them; the built-in ones read the state and R
  /// only, and the jointed route (JointDynamics) then computes the rest only when asked for it.
  virtual bool reads_positions() const { return true; }
  /// Potential energy stored in the element (0 for constant loads, which are not conservative
  /// in general and are left out of the energy).
  virtual double potential_energy(const Model& model, const State& state,
                                  const Kinematics& kin) const;
  /// Power removed from the system by the element's damping (>= 0).
  virtual double damping_power(const Model& model, const State& state, const Kinematics& kin) const;
};

/// Spring-damper between body K and J = L(K) (or the inertial frame).
/// Translational: {F'} = -diag(k){s'_K} - diag(c){s'_K dot} (body-J components) on K at O_K
/// and reversed on J at the point of J coinciding with O_K.
/// Rotational: M = -kr theta - cr (w_K - w_J) on K, -M on J; theta the rotation vector of K
/// relative to J.
class Bushing final : public ForceElement {
 public:
  Bushing(int body, Vector3 stiffness, Vector3 damping, double rotational_stiffness,
          double rotational_damping);
  std::string type() const override { return "bushing"; }
  int body() const override { return body_; }
  std::string validate(const Model& model) const override;
  void apply(const Model& model, const State& state, const Kinematics& kin,
             Loads& loads) const override;
  bool reads_positions() const override { return false; }  // R_J only
  double potential_energy(const Model& model, const State& state,
                          const Kinematics& kin) const override;
  double damping_power(const Model& model, const State& state,
                       const Kinematics& kin) const override;

  /// {F'} in body-J components; theta of K relative to J.
  Vector3 translational_force_b(const State& state) const;
  Vector3 rotation_vector(const Model& model, const State& state) const;

  Vector3 stiffness, damping;
  double rotational_stiffness, rotational_damping;

 private:
  int body_;
};

/// A constant force at G_K, inertial components.
class ConstantForce final : public ForceElement {
 public:
  ConstantForce(int body, Vector3 value) : value(std::move(value)), body_(body) {}
  std::string type() const override { return "force"; }
  int body() const override { return body_; }
  void apply(const Model& model, const State& state, const Kinematics& kin,
             Loads& loads) const override;
  bool reads_positions() const override { return false; }
  Vector3 value;

 private:
  int body_;
};

/// A constant moment on body K, body-K components.
class ConstantTorque final : public ForceElement {
 public:
  ConstantTorque(int body, Vector3 value) : value(std::move(value)), body_(body) {}
  std::string type() const override { return "torque"; }
  int body() const override { return body_; }
  void apply(const Model& model, const State& state, const Kinematics& kin,
             Loads& loads) const override;
  bool reads_positions() const override { return false; }
  Vector3 value;

 private:
  int body_;
};

/// Per-body resultants {F_K} (at G_K, inertial) and {M'_K} (body) of gravity and every force
/// element, into data.loads. Needs data.kinematics of the state (compute_kinematics).
void compute_resultants(const Model& model, const State& state, Data& data);
/// The same into loads, from kin.
void compute_resultants(const Model& model, const State& state, const Kinematics& kin,
                        Loads& loads);

/// Eq. (31): {F_y} = sum_K [v_G_K,y]^T {F_K} + [w'_K,y]^T {M'_K}, into data.kane.F_y, O(N): by
/// subtree sums of the loads, the inward pass of Eq. (38). Needs data.kinematics and
/// data.loads of one state, and a Data with DataOptions::kane_terms (throws
/// std::invalid_argument otherwise).
void compute_generalized_forces(const Model& model, Data& data);

}  // namespace kanedyn
