// Joints by the orthogonal-complement method (docs/theory.md, "Joints"): from the joint
// coordinates q and independent speeds z of a Model (layout in joint.hpp), the notes' state
// (x, y) they give, the constraint matrix y = [C] z, [C dot]{z}, the kinematic equations
// dq/dt, and the projected equations [C]^T [A] [C] {z dot} = [C]^T ({f} - [A][C dot]{z}) built
// on Eq. (36).
#pragma once

#include <string>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/joint.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"
#include "kanedyn/types.hpp"

namespace kanedyn {

/// Rotation by `angle` (rad) about the unit `axis` (Eq. 3 of its Euler parameters): maps the
/// components of a frame to those of the frame turned by `angle` about `axis`.
Matrix3 axis_angle_rotation(const Vector3& axis, double angle);

/// Euler parameters of K from those of J and of K relative to J (the inverse of
/// relative_euler_parameters): [R(result)] = [R(rel)] [R(eps_j)].
Vector4 compose_euler_parameters(const Vector4& eps_j, const Vector4& rel);

/// Euler parameters of K relative to J (frame, then the joint's own rotation) from q; not for
/// free joints.
Vector4 joint_relative_rotation(const Model& model, int k, const VectorX& q);
/// s'_K of a jointed body from q (body-J components); not for free joints.
Vector3 joint_translation(const Model& model, int k, const VectorX& q);
/// [G_K] of body k at q, 3 x speed_count(type) (the first columns of a 3x6): w_rel = [G_K] z_K,
/// body-K components (the table under ConstraintMatrix).
Matrix36 joint_rotation_block(const Model& model, int k, const VectorX& q);
/// [T_K] of body k, 3 x speed_count(type): s'_K dot = [T_K] z_K, body-J components; constant.
Matrix36 joint_translation_block(const Model& model, int k);
/// [G_K dot] z_K at (q, z), body-K components: nonzero only for a universal joint.
Vector3 joint_rotation_rate_times_speeds(const Model& model, int k, const VectorX& q,
                                         const VectorX& z);
/// Angular velocity of K relative to J, body-K components, from q and z ([G_K] z_K below).
Vector3 joint_relative_angular_velocity(const Model& model, int k, const VectorX& q,
                                        const VectorX& z);

/// The notes' state from the joint coordinates: eps_K = eps_J composed with the relative
/// rotation, s'_K from the table, w'_K = w_rel + [R_K][R_J]^T w'_J, s'_K dot from z_K; free
/// bodies copy their slices. Needs state sized for N bodies. Unit spherical q assumed.
void joint_state(const Model& model, const VectorX& q, const VectorX& z, State& state);

/// The model's state (q, z) from the notes' state (x, y), where the joints allow it: a free
/// body's slices are its (eps_K, s'_K) and (w'_K, s'_K dot), a weld has none. Throws
/// std::invalid_argument naming the first body whose joint has coordinates of its own
/// (revolute, prismatic, cylindrical, universal, spherical: their q is not read back from x,
/// where angles lose their turns; give q), or a weld whose pose or speeds in (x, y) differ from
/// those its joint gives (by more than 1e-9 (1 + |value|)), or a state of the wrong size.
/// q and z are resized.
void joint_coordinates(const Model& model, const State& state, VectorX& q, VectorX& z);

/// Rescales every spherical q and every free eps_K to unit norm (the integrator's
/// normalization, as State::normalize_euler_parameters); returns the largest | |e| - 1 |.
double normalize_joint_coordinates(const Model& model, Eigen::Ref<VectorX> q);

/// {q dot} from z: z_K itself, except spherical (1/2 [Ebar'(q)]^T w_rel, the form of Eq. 39)
/// and free (Eq. 39 for eps_K, Eq. 40 for s'_K). qdot must have size num_coordinates().
void joint_coordinate_rates(const Model& model, const VectorX& q, const VectorX& z,
                            Eigen::Ref<VectorX> qdot);

/// y = [C] z, block-sparse. w'_K = sum over c in angular_chain(K) of w_block * z_c, with
/// w_block = [R_K][R_c]^T [G_c] (3 x speed_count(c), the first columns of a 3x6); s'_K dot =
/// s_block[K] z_K. [G_c]: free [I 0]; revolute n; cylindrical [n 0]; universal
/// [R(a2, q2) a1, a2]; spherical [I]; planar [0 0 e_z]; prismatic 0. s_block: free [0 I];
/// prismatic n_J; cylindrical [0 n_J]; planar [x_F y_F 0] (F's x and y axes in J components);
/// else 0.
struct ConstraintMatrix {
  explicit ConstraintMatrix(const Model& model);
  std::vector<int> w_begin;       ///< N + 1: body k's blocks are w_begin[k] .. w_begin[k+1]-1
  std::vector<int> w_body;        ///< the body c of each block (angular_chain order)
  std::vector<Matrix36> w_block;  ///< coefficient of z_c in w'_K (body-K components)
  std::vector<Matrix36> s_block;  ///< per body: coefficient of z_K in s'_K dot (body J)
  std::vector<Matrix3> R;         ///< [R_K] of the state it was computed at (Eqs. 3-4)
};

/// (The constructor throws ModelError unless model.has_angular_chains().)
/// Fills C at the state joint_state() gave for q (its eps_K give the [R_K]).
void compute_constraint_matrix(const Model& model, const VectorX& q, const State& state,
                               ConstraintMatrix& C);
/// y = [C] z (6N), from the blocks.
void constraint_times(const Model& model, const ConstraintMatrix& C, const VectorX& z,
                      Eigen::Ref<VectorX> y);
/// [C]^T v (n) for a 6N column v (e.g. generalized forces), from the blocks.
void constraint_transpose_times(const Model& model, const ConstraintMatrix& C, const VectorX& v,
                                Eigen::Ref<VectorX> out);
/// Dense 6N x n view of [C], rows in the order of {y}, columns in the order of z.
MatrixX dense_constraint_matrix(const Model& model, const ConstraintMatrix& C);

/// [C dot]{z} (6N) at the state of C: w'_K part [G_K dot] z_K - w_rel x ([R_K][R_J]^T w'_J)
/// + [R_K][R_J]^T ([C dot]{z})_J (zero at a free body); the s' dot part is zero.
void constraint_rate_times_speeds(const Model& model, const ConstraintMatrix& C, const VectorX& q,
                                  const VectorX& z, const State& state, Eigen::Ref<VectorX> out);

/// The projected equations at (q, z), dense, for output and as the reference route.
struct ProjectedEquations {
  MatrixX C;       ///< 6N x n
  VectorX Cdot_z;  ///< 6N
  MatrixX A_z;     ///< [C]^T [A] [C], n x n
  VectorX f_z;     ///< [C]^T ({f} - [A][C dot]{z}) + Q of the joint force elements, n
  VectorX zdot;    ///< the solution of A_z {z dot} = f_z
  State state;     ///< the notes' (x, y) at (q, z)
};
/// Forms and solves the projected equations with kane_equations() (its dense [A], {f}):
/// data needs DataOptions::kane_terms and dense_mass_matrix (throws std::invalid_argument
/// otherwise); allocates (a reference route).
ProjectedEquations projected_equations(const Model& model, const VectorX& q, const VectorX& z,
                                       Data& data);

}  // namespace kanedyn
