// Frames (docs/model-format.md, "Frames"): the pose, velocity, acceleration and Jacobian of a
// point with axes fixed in a body or in the ground, at the model's state (docs/theory.md, "Frames
// and Jacobians"). A model's frames are named by their index f (Model::frame_index); a body's
// own frame (origin O_K, body K's axes) by the body index k through the functions named body_*.
#pragma once

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

/// A frame at one state, inertial components.
struct FrameState {
  Vector3 position = Vector3::Zero();          ///< its origin P
  Matrix3 R = Matrix3::Identity();             ///< inertial -> frame components (as [R_K])
  Vector3 velocity = Vector3::Zero();          ///< of P: v_O_K + w_K x (P - O_K)
  Vector3 angular_velocity = Vector3::Zero();  ///< w_K = [R_K]^T w'_K
};

/// A frame's acceleration at one state and z dot, inertial components.
struct FrameAcceleration {
  Vector3 linear = Vector3::Zero();   ///< of its origin P (a point fixed in the body)
  Vector3 angular = Vector3::Zero();  ///< alpha = d/dt of its angular velocity
};

/// Frame f of the model at the notes' state and its kinematics (compute_kinematics: R, p_O,
/// v_O). O(1).
FrameState frame_state(const Model& model, int f, const State& state, const Kinematics& kin);

/// The Jacobian of frame f at the model's joint coordinates q, whose notes' state has the
/// kinematics kin (R, p_O): the 3 x n partial velocities of its origin (Jv) and of its angular
/// velocity (Jw) with respect to z, inertial components, so that v_P = Jv z and w = Jw z. In the
/// notes' terms these are [v_P,y][C] and [R_K]^T [w'_K,y][C]: the partial velocities of P
/// (Eqs. 18-27 for a point of body K) times the joints' [C]. Computed down the frame's chain,
/// one joint at a time (each joint's [G] and [T], docs/theory.md): O(d) columns for a frame at
/// depth d; every other column is zero. Jv and Jw must be 3 x num_speeds(); they are
/// overwritten. No heap allocation.
void frame_jacobian(const Model& model, int f, const VectorX& q, const Kinematics& kin,
                    Eigen::Ref<MatrixX> Jv, Eigen::Ref<MatrixX> Jw);

/// Frame f's acceleration at the model's (q, z) and z dot (sizes of q, z, z): state is the
/// notes' state of (q, z) (joint_state) and kin its kinematics (compute_kinematics). O(d) for a
/// frame at depth d: each joint c on the frame's chain adds its Jacobian columns times z dot_c
/// and their time derivatives times z_c (docs/theory.md). No heap allocation.
FrameAcceleration frame_acceleration(const Model& model, int f, const VectorX& q, const VectorX& z,
                                     const VectorX& zdot, const State& state,
                                     const Kinematics& kin);

/// Body k's own frame (origin O_K, axes K's: R = [R_K]) at the notes' state and kinematics, as
/// frame_state gives a frame's. O(1).
FrameState body_frame_state(const Model& model, int k, const State& state, const Kinematics& kin);
/// The Jacobian of body k's own frame (of O_K and w_K), as frame_jacobian. O(d).
void body_jacobian(const Model& model, int k, const VectorX& q, const Kinematics& kin,
                   Eigen::Ref<MatrixX> Jv, Eigen::Ref<MatrixX> Jw);
/// The acceleration of body k's own frame (of O_K, and alpha_K), as frame_acceleration. O(d).
FrameAcceleration body_acceleration(const Model& model, int k, const VectorX& q, const VectorX& z,
                                    const VectorX& zdot, const State& state, const Kinematics& kin);

}  // namespace kanedyn
