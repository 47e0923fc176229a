// Loads: per-body resultants from gravity and force elements, and the generalized forces of
// Eq. (31). Force laws exactly as docs/model-format.md ("Force laws, exactly") states them.
#pragma once

#include <string>

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

/// One force element, acting on bodies, on joint coordinates, or both (docs/theory.md, "Adding
/// a force element"). apply() adds its loads to data.loads.force (at G_K, inertial) and
/// data.loads.moment_b (body components) of the bodies it acts on. It may read the state and the
/// kinematics already in data (R, p_O, p_G; see compute_kinematics). apply_joint() adds
/// generalized forces on the joint coordinates of the Model (in the order of z). Neither may
/// allocate.
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
  /// only, and the jointed route (Dynamics) then computes the rest only when asked for it.
  virtual bool reads_positions() const { return true; }
  /// Potential energy stored in the element (0 for constant loads, which are not conservative
  /// in general and are left out of the energy).
  virtual double potential_energy(const Model& model, const State& state,
                                  const Kinematics& kin) const;
  /// Power removed from the system by the element's damping (>= 0).
  virtual double damping_power(const Model& model, const State& state, const Kinematics& kin) const;

  /// True for an element that acts on joint coordinates through apply_joint() and on no body
  /// through apply() (the Model keeps the two kinds apart, so that a model with only joint
  /// springs needs no body loads).
  virtual bool acts_on_joints() const { return false; }
  /// Adds the element's generalized forces at (q, z) to Q (size of z). Nothing by default.
  virtual void apply_joint(const Model& model, const VectorX& q, const VectorX& z,
                           Eigen::Ref<VectorX> Q) const;
  /// Potential energy stored on joint coordinates at q (0 by default).
  virtual double joint_potential_energy(const Model& model, const VectorX& q) const;
  /// Power removed by damping on joint speeds at z (>= 0; 0 by default).
  virtual double joint_damping_power(const Model& model, const VectorX& z) const;
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

/// A load on one body's joint coordinates (the model format's joint_spring and joint_force):
/// for coordinate i, Q_i = value_i - stiffness_i (q_i - rest_i) - damping_i dq_i/dt, potential
/// energy 1/2 stiffness_i (q_i - rest_i)^2. Revolute, prismatic, cylindrical and universal
/// joints only (there z = dq/dt). Each vector has coordinate_count() entries (a loader expands
/// scalars); a joint_force has zero stiffness and damping, a joint_spring zero value.
class JointLoad final : public ForceElement {
 public:
  /// kind: "joint_spring" or "joint_force", the type() the model file spells.
  JointLoad(int body, VectorX stiffness, VectorX damping, VectorX rest, VectorX value,
            std::string kind = "joint_spring");
  std::string type() const override { return kind_; }
  int body() const override { return body_; }
  /// Refuses a free, weld or spherical joint, and vectors of the wrong size.
  std::string validate(const Model& model) const override;
  void apply(const Model&, const State&, const Kinematics&, Loads&) const override {}
  bool reads_positions() const override { return false; }
  bool acts_on_joints() const override { return true; }
  void apply_joint(const Model& model, const VectorX& q, const VectorX& z,
                   Eigen::Ref<VectorX> Q) const override;
  double joint_potential_energy(const Model& model, const VectorX& q) const override;
  double joint_damping_power(const Model& model, const VectorX& z) const override;

  VectorX stiffness, damping, rest, value;

 private:
  int body_;
  std::string kind_;
};

/// Adds every element's generalized forces on the joint coordinates at (q, z) to Q.
void add_joint_forces(const Model& model, const VectorX& q, const VectorX& z,
                      Eigen::Ref<VectorX> Q);
/// Sum of the elements' potentials on joint coordinates at q (the joint springs').
double joint_potential_energy(const Model& model, const VectorX& q);
/// Power removed by the elements' damping on joint speeds at z (>= 0).
double joint_damping_power(const Model& model, const VectorX& z);

/// Per-body resultants {F_K} (at G_K, inertial) and {M'_K} (body) of gravity, every force
/// element and the inputs at data.inputs, into data.loads. Needs data.kinematics of the state
/// (compute_kinematics).
void compute_resultants(const Model& model, const State& state, Data& data);
/// The same into loads, from kin, without the inputs (all zero).
void compute_resultants(const Model& model, const State& state, const Kinematics& kin,
                        Loads& loads);
/// The same with the inputs at the values u (size model.num_inputs()).
void compute_resultants(const Model& model, const State& state, const Kinematics& kin,
                        const VectorX& u, Loads& loads);

/// Adds the body loads of the inputs at the values u (docs/model-format.md, "Inputs") to loads:
/// force and torque inputs, and joint inputs on free bodies (a moment u e_i on K for w'_K i; for
/// s'_K dot i a force u e_i, body-J components, on K at O_K and reversed on J at the point of J
/// coinciding with O_K, whose generalized force is u on that speed alone, as a bushing's). Reads
/// kin.R only. In input order, after the force elements.
void add_input_loads(const Model& model, const VectorX& u, const State& state,
                     const Kinematics& kin, Loads& loads);
/// Adds u_i to Q (in the order of z) for every joint input on a joint other than free.
void add_input_joint_forces(const Model& model, const VectorX& u, Eigen::Ref<VectorX> Q);

/// Eq. (31): {F_y} = sum_K [v_G_K,y]^T {F_K} + [w'_K,y]^T {M'_K}, into data.kane.F_y, O(N): by
/// subtree sums of the loads, the inward pass of Eq. (38). Needs data.kinematics and
/// data.loads of one state, and a Data with DataOptions::kane_terms (throws
/// std::invalid_argument otherwise).
void compute_generalized_forces(const Model& model, Data& data);

}  // namespace kanedyn
