// Frames: their pose and velocity against the notes' kinematics, and their Jacobian three ways:
// against the velocity (v = J z), against central differences of the frame's pose along each
// speed, and against the notes' partial velocities times the joints' [C] (the second
// formulation, Eqs. 18-27).
#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <vector>

#include "kanedyn/data.hpp"
#include "kanedyn/frames.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/partials.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

// A random forest with a random joint on every body (every type of kJointTypes) and frames on
// random bodies and on the ground.
Model model_with_frames(std::mt19937& rng, int n, bool chain) {
  const Model base = test::random_loaded_model(rng, n, chain);
  std::vector<Joint> joints;
  for (int k = 0; k < n; ++k)
    joints.push_back(test::random_joint(rng, test::random_joint_type(rng)));
  std::vector<Frame> frames;
  for (int f = 0; f < 4; ++f) {
    Frame frame;
    frame.name = test::numbered_name("frame", f + 1);
    frame.body = f == 0 ? kGround : test::uniform_int(rng, 0, n - 1);
    frame.at = test::random_vector(rng, -0.5, 0.5);
    frame.rotation = test::random_euler_parameters(rng);
    frames.push_back(frame);
  }
  return Model(base.bodies(), base.gravity(), base.forces(), "frames", std::move(joints),
               std::move(frames));
}

std::vector<Model> models(unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<Model> out;
  for (int n : {1, 2, 5, 9, 16}) out.push_back(model_with_frames(rng, n, false));
  for (int n : {6, 12}) out.push_back(model_with_frames(rng, n, true));
  return out;
}

struct At {
  State state;
  Data data;
  At(const Model& model, const VectorX& q, const VectorX& z)
      : state(model), data(model, DataOptions{.partials = true, .kane_terms = false}) {
    joint_state(model, q, z, state);
    compute_kinematics(model, state, data);
  }
};

// q moved by h along the coordinate rates of z (Euler parameters renormalized, which changes
// them by O(h^2), the order of the central difference's truncation).
VectorX moved(const Model& model, const VectorX& q, const VectorX& z, double h) {
  VectorX qdot(q.size());
  joint_coordinate_rates(model, q, z, qdot);
  VectorX out = q + h * qdot;
  normalize_joint_coordinates(model, out);
  return out;
}

TEST(Frames, VelocityIsTheJacobianTimesTheSpeeds) {
  // frame_state's velocity is the notes' v_O_K + w_K x r (Eqs. 14-15); J z walks the joints.
  // Both are a few products of O(1) numbers: 1e-12 relative to the velocity's scale.
  std::mt19937 rng(7);
  for (const Model& model : models(11)) {
    for (int trial = 0; trial < 3; ++trial) {
      VectorX q, z;
      test::random_joint_state(model, rng, q, z);
      const At at(model, q, z);
      MatrixX Jv(3, model.num_speeds()), Jw(3, model.num_speeds());
      for (int f = 0; f < static_cast<int>(model.frames().size()); ++f) {
        frame_jacobian(model, f, q, at.data.kinematics, Jv, Jw);
        const FrameState s = frame_state(model, f, at.state, at.data.kinematics);
        const double scale = 1.0 + z.cwiseAbs().maxCoeff();
        EXPECT_LT((Jv * z - s.velocity).norm(), 1e-12 * scale) << model.frame(f).name;
        EXPECT_LT((Jw * z - s.angular_velocity).norm(), 1e-12 * scale) << model.frame(f).name;
        if (model.frame(f).body == kGround) {
          EXPECT_EQ(Jv.cwiseAbs().maxCoeff(), 0.0);
          EXPECT_EQ(s.position, model.frame(f).at);
        }
      }
    }
  }
}

TEST(Frames, JacobianMatchesCentralDifferencesOfThePose) {
  // Along speed i (z = e_i), P and [R_F] move at Jv_i and Jw_i. Central differences with
  // h = 1e-6: truncation h^2 |P'''| / 6 ~ 1e-12, round-off 1e-16 / h ~ 1e-10; 1e-7 relative.
  std::mt19937 rng(8);
  const double h = 1e-6;
  for (const Model& model : models(12)) {
    VectorX q, z;
    test::random_joint_state(model, rng, q, z);
    const At at(model, q, z);
    const int n = model.num_speeds();
    MatrixX Jv(3, n), Jw(3, n);
    for (int f = 0; f < static_cast<int>(model.frames().size()); ++f) {
      frame_jacobian(model, f, q, at.data.kinematics, Jv, Jw);
      const double scale = 1.0 + std::max(Jv.cwiseAbs().maxCoeff(), Jw.cwiseAbs().maxCoeff());
      for (int i = 0; i < n; ++i) {
        const VectorX e = VectorX::Unit(n, i);
        const At plus(model, moved(model, q, e, h), e), minus(model, moved(model, q, e, -h), e);
        const FrameState a = frame_state(model, f, plus.state, plus.data.kinematics);
        const FrameState b = frame_state(model, f, minus.state, minus.data.kinematics);
        const Vector3 v = (a.position - b.position) / (2 * h);
        // d[R_F]/dt = -[w_F~][R_F] (w_F in frame components): w_F~ = -(dR/dt) [R_F]^T.
        const FrameState mid = frame_state(model, f, at.state, at.data.kinematics);
        const Matrix3 W = -((a.R - b.R) / (2 * h)) * mid.R.transpose();
        const Vector3 w =
            mid.R.transpose() * Vector3(0.5 * (W(2, 1) - W(1, 2)), 0.5 * (W(0, 2) - W(2, 0)),
                                        0.5 * (W(1, 0) - W(0, 1)));
        EXPECT_LT((v - Jv.col(i)).norm(), 1e-7 * scale) << model.frame(f).name << " z" << i;
        EXPECT_LT((w - Jw.col(i)).norm(), 1e-7 * scale) << model.frame(f).name << " z" << i;
      }
    }
  }
}

TEST(Frames, JacobianIsTheNotesPartialVelocitiesTimesC) {
  // [v_P,y] = [v_O_K,y] - [r~] [R_K]^T [w'_K,y] (P fixed in K, r = P - O_K) from the notes'
  // block partials (compute_partials_direct, Eqs. 18-27), times the dense [C]: the same
  // matrix by another formulation, 1e-12 relative.
  std::mt19937 rng(9);
  for (const Model& model : models(13)) {
    VectorX q, z;
    test::random_joint_state(model, rng, q, z);
    At at(model, q, z);
    compute_partials_direct(model, at.state, at.data);
    ConstraintMatrix C(model);
    compute_constraint_matrix(model, q, at.state, C);
    const MatrixX Cd = dense_constraint_matrix(model, C);
    const int N = model.num_bodies(), n = model.num_speeds();
    MatrixX Jv(3, n), Jw(3, n);
    for (int f = 0; f < static_cast<int>(model.frames().size()); ++f) {
      const Frame& frame = model.frame(f);
      if (frame.body == kGround) continue;
      const int k = frame.body;
      const Matrix3& R = at.data.kinematics.R[static_cast<size_t>(k)];
      const Vector3 r = R.transpose() * frame.at;
      Matrix3 r_tilde;
      r_tilde << 0, -r.z(), r.y(), r.z(), 0, -r.x(), -r.y(), r.x(), 0;
      MatrixX vP(3, 6 * N), wK(3, 6 * N);
      vP.setZero();
      wK.setZero();
      wK.middleCols<3>(3 * k) = R.transpose();  // w_K = [R_K]^T w'_K: [w'_K,y] selects w'_K
      const Model::Chain chain = model.chain(k);
      for (int e = 0; e < chain.size; ++e) {
        const int a = chain[e];
        const size_t b = static_cast<size_t>(model.chain_offset(k) + e);
        vP.middleCols<3>(3 * a) += at.data.partials.vO_w[b];
        vP.middleCols<3>(3 * N + 3 * a) += at.data.partials.vO_s[b];
      }
      vP -= r_tilde * wK;
      frame_jacobian(model, f, q, at.data.kinematics, Jv, Jw);
      const double scale = 1.0 + Jv.cwiseAbs().maxCoeff();
      EXPECT_LT((vP * Cd - Jv).cwiseAbs().maxCoeff(), 1e-12 * scale) << frame.name;
      EXPECT_LT((wK * Cd - Jw).cwiseAbs().maxCoeff(), 1e-12 * scale) << frame.name;
    }
  }
}

TEST(Frames, TheModelRefusesBadFrames) {
  const Model base = test::eight_body_model();
  const auto with = [&](Frame f) {
    return Model(base.bodies(), base.gravity(), base.forces(), "", {}, {f});
  };
  Frame ok{"tool", 2, Vector3(0, 0, 0.1), Vector4(0, 0, 0, 1)};
  EXPECT_EQ(with(ok).frame_index("tool"), 0);
  EXPECT_EQ(with(ok).frame_index("nothing"), -2);
  Frame f = ok;
  f.name = "a b";
  EXPECT_THROW(with(f), ModelError);
  f = ok;
  f.name = base.body(0).name;
  try {
    with(f);
    FAIL() << "a frame named as a body was accepted";
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("a body has this name"), std::string::npos) << e.what();
  }
  f = ok;
  f.body = 8;
  EXPECT_THROW(with(f), ModelError);
  f = ok;
  f.rotation = Vector4(0, 0, 0, 2);
  EXPECT_THROW(with(f), ModelError);
  f = ok;
  f.at.x() = std::nan("");
  EXPECT_THROW(with(f), ModelError);
  EXPECT_THROW(Model(base.bodies(), base.gravity(), base.forces(), "", {}, {ok, ok}), ModelError);
}

}  // namespace
}  // namespace kanedyn
