#include "kanedyn/frames.hpp"

#include "joint_motion.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/rotation.hpp"

namespace kanedyn {

namespace {
size_t at(int i) { return static_cast<size_t>(i); }

// Whether a joint of this type may have a nonzero [T_K] (joint_translation_block).
bool slides(JointType type) { return joint_type_info(type).slides; }
}  // namespace

FrameState frame_state(const Model& model, int f, const State& state, const Kinematics& kin) {
  const Frame& frame = model.frame(f);
  FrameState out;
  const Matrix3 axes = rotation_matrix(frame.rotation);  // body K -> frame components
  if (frame.body == kGround) {
    out.position = frame.at;
    out.R = axes;
    return out;
  }
  const Matrix3& R = kin.R[at(frame.body)];
  const Vector3 r = R.transpose() * frame.at;  // P - O_K, inertial
  out.position = kin.p_O[at(frame.body)] + r;
  out.R = axes * R;
  out.angular_velocity = R.transpose() * state.angular_velocity(frame.body);
  out.velocity = kin.v_O[at(frame.body)] + out.angular_velocity.cross(r);
  return out;
}

namespace {

// The Jacobian of the point of body `body` at `at` from O_K (body-K components).
void point_jacobian(const Model& model, int body, const Vector3& at_b, const VectorX& q,
                    const Kinematics& kin, Eigen::Ref<MatrixX> Jv, Eigen::Ref<MatrixX> Jw) {
  Jv.setZero();
  Jw.setZero();
  if (body == kGround) return;
  const Vector3 p = kin.p_O[at(body)] + kin.R[at(body)].transpose() * at_b;
  // Each joint c on the chain moves P by its speeds z_c: its rotation, w = [R_c]^T [G_c] z_c,
  // turns everything above it about O_c, and its slide moves O_c by [R_J]^T [T_c] z_c (J =
  // L(c)). A free body's w'_c is its own speed (absolute, Eq. 1): the joints below it do not
  // turn it, they only move O_c, so below it the point moved is O_c and w gains nothing. Only
  // [G_c] of the joint's table is needed (no sine or cosine but a universal joint's), and
  // [T_c] only where the joint slides (the joint table's turns and slides).
  Vector3 point = p;
  bool turns = true;
  Matrix36 G;
  for (const int c : model.chain(body)) {
    const JointType type = model.joint(c).type;
    const int m = speed_count(type);
    if (m > 0) {
      const Matrix3& Rc = kin.R[at(c)];
      const Vector3 r = point - kin.p_O[at(c)];
      const int first = model.speed_offset(c);
      if (joint_type_info(type).turns) {
        detail::joint_rotation_columns(model, c, q, G);
        for (int i = 0; i < m; ++i) {
          if (G.col(i).isZero(0.0)) continue;
          const Vector3 w = Rc.transpose() * G.col(i);
          if (turns) Jw.col(first + i) = w;
          Jv.col(first + i) = w.cross(r);
        }
      }
      if (slides(type)) {
        const Matrix36 T = joint_translation_block(model, c);
        const int j = model.lower_body(c);
        for (int i = 0; i < m; ++i) {
          if (T.col(i).isZero(0.0)) continue;
          Jv.col(first + i) +=
              j == kGround ? Vector3(T.col(i)) : Vector3(kin.R[at(j)].transpose() * T.col(i));
        }
      }
    }
    if (type == JointType::free) {
      point = kin.p_O[at(c)];
      turns = false;
    }
  }
}

// The acceleration of the point of body `body` at `at` from O_K: the time derivative of
// v_P = sum over c of Jv_c z_c (point_jacobian) at z dot, joint by joint down the chain. With
// w_rel = [R_c]^T [G_c] z_c (inertial), d/dt ([R]^T u) = w x [R]^T u + [R]^T du/dt and [T_c]
// constant in J, the joint c adds
//   angular  Jw_c z dot_c + w_c x w_rel + [R_c]^T [G_c dot] z_c                 (= alpha_rel)
//   linear   [R_J]^T [T_c] z dot_c + w_J x [R_J]^T [T_c] z_c + alpha_rel x (point - O_c)
//            + w_rel x (v_point - v_O_c)
// with the point and its velocity those of P until a free body c is passed, then O_c's (as in
// point_jacobian), and only the joints above the first free body turning it.
FrameAcceleration point_acceleration(const Model& model, int body, const Vector3& at_b,
                                     const VectorX& q, const VectorX& z, const VectorX& zdot,
                                     const State& state, const Kinematics& kin) {
  FrameAcceleration out;
  if (body == kGround) return out;
  const Matrix3& R = kin.R[at(body)];
  const Vector3 r_p = R.transpose() * at_b;
  Vector3 point = kin.p_O[at(body)] + r_p;
  Vector3 v_point = kin.v_O[at(body)] + (R.transpose() * state.angular_velocity(body)).cross(r_p);
  detail::JointMotion motion;
  bool turns = true;
  for (const int c : model.chain(body)) {
    const JointType type = model.joint(c).type;
    const int m = speed_count(type);
    if (m > 0) {
      const int first = model.speed_offset(c);
      detail::joint_motion(model, c, q, z.data() + first, motion);
      const Matrix36 T = joint_translation_block(model, c);
      Vector3 g_zdot = Vector3::Zero(), t_zdot = Vector3::Zero();
      for (int i = 0; i < m; ++i) {
        g_zdot += zdot[first + i] * motion.G.col(i);
        t_zdot += zdot[first + i] * T.col(i);
      }
      const int j = model.lower_body(c);
      const Matrix3& Rc = kin.R[at(c)];
      const Vector3 w_c = Rc.transpose() * state.angular_velocity(c);
      const Vector3 w_rel = Rc.transpose() * motion.w_rel;
      const Vector3 alpha_rel = Rc.transpose() * (g_zdot + motion.g_dot_z) + w_c.cross(w_rel);
      Vector3 slide = t_zdot;
      if (j != kGround) {
        const Matrix3& Rj = kin.R[at(j)];
        const Vector3 w_j = Rj.transpose() * state.angular_velocity(j);
        slide = Rj.transpose() * t_zdot + w_j.cross(Rj.transpose() * motion.slide_rate);
      }
      if (turns) out.angular += alpha_rel;
      out.linear +=
          slide + alpha_rel.cross(point - kin.p_O[at(c)]) + w_rel.cross(v_point - kin.v_O[at(c)]);
    }
    if (type == JointType::free) {
      point = kin.p_O[at(c)];
      v_point = kin.v_O[at(c)];
      turns = false;
    }
  }
  return out;
}

}  // namespace

void frame_jacobian(const Model& model, int f, const VectorX& q, const Kinematics& kin,
                    Eigen::Ref<MatrixX> Jv, Eigen::Ref<MatrixX> Jw) {
  const Frame& frame = model.frame(f);
  point_jacobian(model, frame.body, frame.at, q, kin, Jv, Jw);
}

FrameAcceleration frame_acceleration(const Model& model, int f, const VectorX& q, const VectorX& z,
                                     const VectorX& zdot, const State& state,
                                     const Kinematics& kin) {
  const Frame& frame = model.frame(f);
  return point_acceleration(model, frame.body, frame.at, q, z, zdot, state, kin);
}

FrameState body_frame_state(const Model&, int k, const State& state, const Kinematics& kin) {
  FrameState out;
  const Matrix3& R = kin.R[at(k)];
  out.position = kin.p_O[at(k)];
  out.R = R;
  out.velocity = kin.v_O[at(k)];
  out.angular_velocity = R.transpose() * state.angular_velocity(k);
  return out;
}

void body_jacobian(const Model& model, int k, const VectorX& q, const Kinematics& kin,
                   Eigen::Ref<MatrixX> Jv, Eigen::Ref<MatrixX> Jw) {
  point_jacobian(model, k, Vector3::Zero(), q, kin, Jv, Jw);
}

FrameAcceleration body_acceleration(const Model& model, int k, const VectorX& q, const VectorX& z,
                                    const VectorX& zdot, const State& state,
                                    const Kinematics& kin) {
  return point_acceleration(model, k, Vector3::Zero(), q, z, zdot, state, kin);
}

}  // namespace kanedyn
