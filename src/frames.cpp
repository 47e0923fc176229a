#include "kanedyn/frames.hpp"

#include "joint_motion.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/rotation.hpp"

namespace kanedyn {

namespace {
size_t at(int i) { return static_cast<size_t>(i); }
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

void frame_jacobian(const Model& model, int f, const VectorX& q, const Kinematics& kin,
                    Eigen::Ref<MatrixX> Jv, Eigen::Ref<MatrixX> Jw) {
  Jv.setZero();
  Jw.setZero();
  const Frame& frame = model.frame(f);
  if (frame.body == kGround) return;
  const Vector3 p = kin.p_O[at(frame.body)] + kin.R[at(frame.body)].transpose() * frame.at;
  detail::JointMotion motion;
  // Each joint c on the chain moves P by its speeds z_c: its rotation, w = [R_c]^T [G_c] z_c,
  // turns everything above it about O_c, and its slide moves O_c by [R_J]^T [T_c] z_c (J =
  // L(c)). A free body's w'_c is its own speed (absolute, Eq. 1): the joints below it do not
  // turn it, they only move O_c, so below it the point moved is O_c and w gains nothing.
  Vector3 point = p;
  bool turns = true;
  for (const int c : model.chain(frame.body)) {
    const JointType type = model.joint(c).type;
    const int m = speed_count(type);
    if (m > 0) {
      detail::joint_motion(model, c, q, nullptr, motion);
      const Matrix36 T = joint_translation_block(model, c);
      const int j = model.lower_body(c);
      const Matrix3& Rc = kin.R[at(c)];
      const Vector3 r = point - kin.p_O[at(c)];
      const int first = model.speed_offset(c);
      for (int i = 0; i < m; ++i) {
        const Vector3 w = Rc.transpose() * motion.G.col(i);
        const Vector3 slide =
            j == kGround ? Vector3(T.col(i)) : Vector3(kin.R[at(j)].transpose() * T.col(i));
        if (turns) Jw.col(first + i) = w;
        Jv.col(first + i) = slide + w.cross(r);
      }
    }
    if (type == JointType::free) {
      point = kin.p_O[at(c)];
      turns = false;
    }
  }
}

}  // namespace kanedyn
