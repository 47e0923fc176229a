// One joint's motion at (q, z), shared by joint_state, the per-joint functions of joints.hpp and
// JointDynamics: each joint type's table (docs/theory.md, "Joints") is evaluated here only.
#pragma once

#include "kanedyn/joints.hpp"

namespace kanedyn::detail {

/// Body K's joint at (q, z_K).
struct JointMotion {
  Vector4 rel;         ///< Euler parameters of K relative to J (the frame for free joints)
  Matrix36 G;          ///< [G_K], the first speed_count columns; w_rel = [G_K] z_K
  Vector3 w_rel;       ///< [G_K] z_K, body-K components (free: w'_K itself)
  Vector3 slide;       ///< s'_K, body-J components
  Vector3 slide_rate;  ///< s'_K dot = [T_K] z_K, body-J components
  Vector3 g_dot_z;     ///< [G_K dot] z_K, body-K components (nonzero only for universal)
};

/// z_k points at body K's slice of z (speed_count entries), or is null for zero rates.
JointMotion joint_motion(const Model& model, int k, const VectorX& q, const double* z_k);
/// The same into m (every field written).
void joint_motion(const Model& model, int k, const VectorX& q, const double* z_k, JointMotion& m);

/// [G_K] alone (JointMotion::G, every column written), without the rest of the table: no sine
/// or cosine except for a universal joint, whose a1 turns with q2.
void joint_rotation_columns(const Model& model, int k, const VectorX& q, Matrix36& G);

/// joint_state, also storing each body's JointMotion in motion (N entries) when not null.
void joint_state(const Model& model, const VectorX& q, const VectorX& z, State& state,
                 std::vector<JointMotion>* motion);

}  // namespace kanedyn::detail
