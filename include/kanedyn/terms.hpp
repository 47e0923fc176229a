// The terms of the equations of motion M(q) z dot = f_z(q, z) + Q at the model's state (q, z),
// one by one (docs/theory.md, "Inverse dynamics, mass matrix, bias and gravity forces"): the
// generalized forces a motion needs (inverse dynamics), the mass matrix, the bias and gravity
// forces and the centre of mass. M and f_z are the projected equations' [C]^T [A] [C] and
// [C]^T ({f} - [A][C dot]{z}) + Q_joint (joints.hpp, ProjectedEquations::A_z and f_z), here
// without forming [A] or [C]. Every generalized force is in the order of z and dual to it:
// Q . z is a power (for a free body, z_K = (w'_K in body-K components, s'_K dot in body-J
// components), so its entries are the moment in body-K components and the force in body-J
// components).
#pragma once

#include <memory>

#include "kanedyn/model.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn {

/// The workspace of one Model (which must outlive it) for the terms below: allocated once, no
/// heap allocation in any call. Copies are independent; not for concurrent calls on one object.
/// q and z have the sizes num_coordinates() and num_speeds(), Euler parameters in q as given
/// (unit norm assumed); every output vector has num_speeds() entries.
class Terms {
 public:
  explicit Terms(const Model& model);
  Terms(const Terms& other);
  Terms& operator=(const Terms&) = delete;
  ~Terms();

  const Model& model() const;

  /// Inverse dynamics, O(N) (Newton-Euler over the joints): the generalized forces Q that,
  /// added to the model's own loads (gravity, force elements, force elements on joint
  /// coordinates), give the motion z dot at (q, z): M z dot = f_z(q, z) + Q, so that forward
  /// dynamics (Dynamics::evaluate) of the model with Q added returns z dot. u: the values of the
  /// model's inputs, whose loads count among its own (null: all 0; else model.num_inputs()
  /// values, std::invalid_argument otherwise).
  void inverse_dynamics(const VectorX& q, const VectorX& z, const VectorX& zdot,
                        Eigen::Ref<VectorX> Q, const VectorX* u = nullptr);

  /// The mass matrix M(q) = [C]^T [A] [C] (n x n, both triangles), [A] of Eq. (37), by a
  /// composite-body pass: O(n d) for depth d (every block off a chain is zero and written so).
  void mass_matrix(const VectorX& q, Eigen::Ref<MatrixX> M);

  /// Bias forces b(q, z) = inverse_dynamics(q, z, 0) = -f_z(q, z): the velocity terms minus
  /// the model's own loads, so that M z dot + b = Q. u as in inverse_dynamics().
  void bias_forces(const VectorX& q, const VectorX& z, Eigen::Ref<VectorX> b,
                   const VectorX* u = nullptr);

  /// Gravity forces g(q): minus the generalized force of gravity alone (no force element, no
  /// velocity), so that with the other loads absent b(q, 0) = g(q) (Pinocchio's sign).
  void gravity_forces(const VectorX& q, Eigen::Ref<VectorX> g);

  /// The system's centre of mass sum m_K p_G_K / sum m_K, inertial components. O(N).
  Vector3 centre_of_mass(const VectorX& q);
  /// Its velocity, inertial components: centre_of_mass_jacobian(q) z. O(N).
  Vector3 centre_of_mass_velocity(const VectorX& q, const VectorX& z);
  /// Its 3 x n Jacobian J (v_com = J z), inertial components. O(N).
  void centre_of_mass_jacobian(const VectorX& q, Eigen::Ref<MatrixX> J);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kanedyn
