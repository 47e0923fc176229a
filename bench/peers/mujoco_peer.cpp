// MuJoCo peer: the model as MJCF, built in memory and loaded through a virtual file system.
// Body K is nested in its lower body J at pos = q'_K with J's axes; it carries three slide
// joints along those axes (qpos = s'_K) followed by one ball joint at O_K (qpos = K's
// orientation relative to J, qvel = w_K - w_J in K axes). No geoms, so no contacts.
//
// The bushings are joint springs and dampers, which equal the spec's laws exactly: a slide
// joint's passive force -k s - c sdot is the translational law on s'_K (the force acts on K at
// O_K and, reversed, on J at the same point); a ball joint's stiffness acts on the rotation
// vector of the joint's quaternion relative to its reference (identity), angle in [-pi, pi],
// which is -kr theta, and its damping -cr (w_K - w_J) on the joint's angular velocity.
// Constant loads, if any, are added in the passive-force callback with mj_applyFT.
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "peer.hpp"

namespace peers {
namespace {

std::string vec(const Vec3& a) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.17g %.17g %.17g", a[0], a[1], a[2]);
  return buf;
}

// Names of body k and of its joints (snprintf: GCC 12 warns falsely on "b" + std::string).
std::string name(const char* format, size_t k, int i = 0) {
  char buf[48];
  std::snprintf(buf, sizeof buf, format, k, i);
  return buf;
}

std::string num_short(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

std::string num(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

// MJCF nests a body inside its lower body, but MuJoCo 2.2.2's XML parser (tinyxml2) refuses
// elements nested deeper than about 100 (XML_ELEMENT_DEPTH_EXCEEDED), so a chain of 512 cannot
// be one file. Deep subtrees go into <include> files (each parsed on its own, then merged):
// every kMaxDepth levels a body's children move to a new <mujocoinclude> file.
constexpr int kMaxDepth = 50;

// MuJoCo 2.2.2's default stack is 5 (njmax + nv)^2 + 20 (nq + nv + ...) numbers (njmax = 500
// by default), kept in an int: for a 4096-body tree (nv = 24576) it overflows, and the model
// compiler's mj_setConst stops with "Stack overflow". Keep the default where it fits, else
// ask for 1e6 + 100 nv + 16 nM numbers (nM, the mass matrix's nonzeros, from ancestor_dofs;
// a chain of 512 needs more than 4 nM). Returns 0 for "keep the default".
long stack_size(const System& s) {
  const double nv = 6.0 * static_cast<double>(s.bodies.size());
  const double default_size = 5.0 * (500.0 + nv) * (500.0 + nv) + 20.0 * (3.0 * nv);
  if (default_size < 2.0e9) return 0;
  return static_cast<long>(std::min(2.0e9, 1.0e6 + 100.0 * nv + 16.0 * ancestor_dofs(s, 1)));
}

// One body's element: its opening tag, inertial and joints (the children and the closing tag
// are added by Mjcf).
std::string inertial(const Body& b) {
  const Mat3& I = b.inertia;
  std::ostringstream x;
  x << "<inertial pos=\"" << vec(b.com) << "\" mass=\"" << num(b.mass) << "\" ";
  if (I[1] == 0 && I[2] == 0 && I[5] == 0)
    x << "diaginertia=\"" << vec({I[0], I[4], I[8]}) << "\"/>\n";
  else
    x << "fullinertia=\"" << num(I[0]) << ' ' << num(I[4]) << ' ' << num(I[8]) << ' ' << num(I[1])
      << ' ' << num(I[2]) << ' ' << num(I[5]) << "\"/>\n";
  return x.str();
}

// The free body's joints of the comment at the top: three slides, then a ball, with the
// bushing as their springs and dampers.
std::string free_joints(const Body& b, const std::string& id) {
  std::ostringstream x;
  static const char* axes[3] = {"1 0 0", "0 1 0", "0 0 1"};
  for (int i = 0; i < 3; ++i)
    x << "<joint name=\"" << id << "_s" << i << "\" type=\"slide\" axis=\"" << axes[i]
      << "\" stiffness=\"" << num(b.k[static_cast<size_t>(i)]) << "\" damping=\""
      << num(b.c[static_cast<size_t>(i)]) << "\"/>\n";
  x << "<joint name=\"" << id << "_r\" type=\"ball\" stiffness=\"" << num(b.kr) << "\" damping=\""
    << num(b.cr) << "\"/>\n";
  return x.str();
}

struct Mjcf {
  std::vector<std::vector<int>> children;
  std::function<std::string(int)> element;                 // body k's element, as above
  std::vector<std::pair<std::string, std::string>> files;  // (name, text); files[0] is the model

  void body(std::string& xml, int k, int depth) {
    xml += element(k);
    const std::vector<int>& kids = children[static_cast<size_t>(k)];
    if (depth >= kMaxDepth && !kids.empty()) {
      const size_t slot = files.size();  // taken before the recursion names deeper files
      files.emplace_back(name("part%zu.xml", slot), "");
      xml += "<include file=\"" + files[slot].first + "\"/>\n";
      std::string part = "<mujocoinclude>\n";
      for (int child : kids) body(part, child, 1);
      part += "</mujocoinclude>\n";
      files[slot].second = std::move(part);
    } else {
      for (int child : kids) body(xml, child, depth + 1);
    }
    xml += "</body>\n";
  }

  Mjcf(const std::string& title, const Vec3& gravity, const std::vector<Body>& bodies, long stack,
       std::function<std::string(int)> body_element)
      : children(bodies.size()), element(std::move(body_element)) {
    for (size_t k = 0; k < bodies.size(); ++k)
      if (bodies[k].parent >= 0)
        children[static_cast<size_t>(bodies[k].parent)].push_back(static_cast<int>(k));
    std::string model = title;  // as an XML attribute
    for (char& ch : model)
      if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '-') ch = '_';
    files.emplace_back("kanedyn_peer.xml", "");
    std::string xml = "<mujoco model=\"" + model + "\">\n<compiler angle=\"radian\"/>\n" +
                      "<option gravity=\"" + vec(gravity) +
                      "\">\n<flag contact=\"disable\"/>\n</option>\n";
    if (stack > 0) xml += "<size nstack=\"" + std::to_string(stack) + "\"/>\n";
    xml += "<worldbody>\n";
    for (size_t k = 0; k < bodies.size(); ++k)
      if (bodies[k].parent < 0) body(xml, static_cast<int>(k), 1);
    xml += "</worldbody>\n</mujoco>\n";
    files[0].second = std::move(xml);
  }
};

// The free-body model of the comment at the top.
Mjcf free_mjcf(const System& s) {
  return Mjcf(s.name, s.gravity, s.bodies, stack_size(s), [&s](int k) {
    const Body& b = s.bodies[static_cast<size_t>(k)];
    const std::string id = name("b%zu", static_cast<size_t>(k));
    return "<body name=\"" + id + "\" pos=\"" + vec(b.joint) + "\">\n" + inertial(b) +
           free_joints(b, id);
  });
}

mjModel* load(const Mjcf& mjcf) {
  auto vfs = std::make_unique<mjVFS>();  // large (file tables): keep it off the stack
  mj_defaultVFS(vfs.get());
  for (const auto& [file, text] : mjcf.files) {
    if (mj_makeEmptyFileVFS(vfs.get(), file.c_str(), static_cast<int>(text.size())) != 0) {
      mj_deleteVFS(vfs.get());
      throw std::runtime_error("MuJoCo: cannot add " + file + " to the VFS");
    }
    std::memcpy(vfs->filedata[mj_findFileVFS(vfs.get(), file.c_str())], text.data(), text.size());
  }
  char error[1000] = "";
  mjModel* m = mj_loadXML(mjcf.files[0].first.c_str(), vfs.get(), error, sizeof error);
  mj_deleteVFS(vfs.get());
  if (!m) throw std::runtime_error(std::string("MuJoCo: ") + error);
  return m;
}

class MujocoEngine;
const MujocoEngine* g_current = nullptr;  // for the passive-force callback
void constant_loads(const mjModel* m, mjData* d);

class MujocoEngine final : public Engine {
 public:
  explicit MujocoEngine(const System& system) : system_(system), m_(load(free_mjcf(system))) {
    d_ = mj_makeData(m_);
    const size_t n = system.bodies.size();
    body_id_.resize(n);
    qpos_.assign(static_cast<size_t>(m_->nq), 0.0);
    qvel_.assign(static_cast<size_t>(m_->nv), 0.0);
    for (size_t k = 0; k < n; ++k) {
      body_id_[k] = mj_name2id(m_, mjOBJ_BODY, name("b%zu", k).c_str());
      const BodyState& s = system.state[k];
      for (int i = 0; i < 3; ++i) {
        const int j = mj_name2id(m_, mjOBJ_JOINT, name("b%zu_s%d", k, i).c_str());
        qpos_[static_cast<size_t>(m_->jnt_qposadr[j])] = s.s[static_cast<size_t>(i)];
        qvel_[static_cast<size_t>(m_->jnt_dofadr[j])] = s.s_dot[static_cast<size_t>(i)];
      }
      const int j = mj_name2id(m_, mjOBJ_JOINT, name("b%zu_r", k).c_str());
      for (int i = 0; i < 4; ++i)
        qpos_[static_cast<size_t>(m_->jnt_qposadr[j] + i)] = s.q_rel[static_cast<size_t>(i)];
      for (int i = 0; i < 3; ++i)
        qvel_[static_cast<size_t>(m_->jnt_dofadr[j] + i)] = s.w_rel_k[static_cast<size_t>(i)];
    }
    if (system.has_constant_loads) {
      g_current = this;
      mjcb_passive = constant_loads;
    }
  }
  ~MujocoEngine() override {
    if (g_current == this) {
      mjcb_passive = nullptr;
      g_current = nullptr;
    }
    if (integration_) mj_deleteData(integration_);
    mj_deleteData(d_);
    mj_deleteModel(m_);
  }
  MujocoEngine(const MujocoEngine&) = delete;
  MujocoEngine& operator=(const MujocoEngine&) = delete;

  void evaluate() override {
    mju_copy(d_->qpos, qpos_.data(), m_->nq);
    mju_copy(d_->qvel, qvel_.data(), m_->nv);
    mj_forward(m_, d_);
  }

  std::vector<BodyMotion> motion() override {
    mj_rnePostConstraint(m_, d_);  // fills cacc, which mj_objectAcceleration reads
    std::vector<BodyMotion> out(system_.bodies.size());
    for (size_t k = 0; k < out.size(); ++k) {
      const int b = body_id_[k];
      mjtNum v[6], a[6];
      mj_objectVelocity(m_, d_, mjOBJ_BODY, b, v, 0);      // at xipos = G_K, world axes
      mj_objectAcceleration(m_, d_, mjOBJ_BODY, b, a, 0);  // likewise
      for (size_t i = 0; i < 3; ++i) {
        out[k].p_G[i] = d_->xipos[3 * b + static_cast<int>(i)];
        out[k].w[i] = v[i];
        out[k].v_G[i] = v[3 + i];
        out[k].alpha[i] = a[i];
        // cacc holds the acceleration relative to a frame falling with gravity (the world's
        // acceleration is set to -g), i.e. what an accelerometer reads: add g back.
        out[k].a_G[i] = a[3 + i] + system_.gravity[i];
      }
    }
    return out;
  }

  std::vector<double> backward_errors(const std::vector<JointAcceleration>& reference) override {
    // f = qfrc_passive - qfrc_bias (no actuators, no applied forces, no constraints); the
    // constant loads of the callback are inside qfrc_passive.
    const auto nv = static_cast<size_t>(m_->nv);
    std::vector<mjtNum> other(nv, 0.0);
    for (size_t k = 0; k < reference.size(); ++k) {
      for (int i = 0; i < 3; ++i) {
        const int s = m_->jnt_dofadr[mj_name2id(m_, mjOBJ_JOINT, name("b%zu_s%d", k, i).c_str())];
        other[static_cast<size_t>(s)] = reference[k].s_ddot[static_cast<size_t>(i)];
      }
      const int r = m_->jnt_dofadr[mj_name2id(m_, mjOBJ_JOINT, name("b%zu_r", k).c_str())];
      for (int i = 0; i < 3; ++i)
        other[static_cast<size_t>(r + i)] = reference[k].w_rel_dot_k[static_cast<size_t>(i)];
    }
    const std::vector<mjtNum> own(d_->qacc, d_->qacc + nv);
    return {backward_error(own), backward_error(other)};
  }

  IntegratorInfo start(const IntegratorSettings& settings) override {
    const std::string& method = settings.method;
    IntegratorInfo info;
    if (method.empty() || method == "rk4") {
      m_->opt.integrator = mjINT_RK4;
      info = {"RK4 (mjINT_RK4)", true, 4.0};
    } else if (method == "euler") {
      m_->opt.integrator = mjINT_EULER;
      info = {"semi-implicit Euler (mjINT_EULER)", true, 1.0};
    } else {
      throw std::invalid_argument("MuJoCo: unknown integrator '" + method + "' (rk4, euler)");
    }
    if (!(settings.step > 0)) throw std::invalid_argument("MuJoCo: the step must be > 0");
    step_ = settings.step;
    info.description += ", step " + num_short(step_);
    if (!integration_) integration_ = mj_makeData(m_);
    mj_resetData(m_, integration_);
    mju_copy(integration_->qpos, qpos_.data(), m_->nq);
    mju_copy(integration_->qvel, qvel_.data(), m_->nv);
    time_ = 0;
    steps_ = 0;
    return info;
  }

  void advance_to(double t) override {
    const double span = t - time_;
    const long n = equal_steps(span, step_);
    m_->opt.timestep = span / static_cast<double>(n);
    for (long i = 0; i < n; ++i) mj_step(m_, integration_);
    for (int i = 0; i < mjNWARNING; ++i)
      if (integration_->warning[i].number > 0)
        throw std::runtime_error("MuJoCo: warning " + std::to_string(i) + " during integration");
    time_ = t;
    steps_ += n;
  }

  std::vector<BodyPose> pose() override {
    mjData* d = integration_;
    mj_forward(m_, d);  // the kinematics of the current qpos, qvel (mj_step leaves older ones)
    std::vector<BodyPose> out(system_.bodies.size());
    for (size_t k = 0; k < out.size(); ++k) {
      const int b = body_id_[k];
      mjtNum v[6];
      mj_objectVelocity(m_, d, mjOBJ_BODY, b, v, 0);  // at xipos = G_K, world axes
      for (size_t i = 0; i < 3; ++i) {
        out[k].p_G[i] = d->xipos[3 * b + static_cast<int>(i)];
        out[k].w[i] = v[i];
        out[k].v_G[i] = v[3 + i];
      }
      for (size_t i = 0; i < 9; ++i) out[k].R[i] = d->xmat[9 * b + static_cast<int>(i)];
    }
    return out;
  }

  long steps() const override { return steps_; }

  void add_constant_loads(const mjModel* m, mjData* d) const {
    for (size_t k = 0; k < system_.bodies.size(); ++k) {
      const Body& b = system_.bodies[k];
      const int id = body_id_[k];
      const mjtNum* R = d->xmat + 9 * id;  // body-to-world, row-major
      mjtNum force[3], torque[3];
      for (int i = 0; i < 3; ++i) {
        force[i] = b.force[static_cast<size_t>(i)];
        torque[i] =
            R[3 * i] * b.torque_b[0] + R[3 * i + 1] * b.torque_b[1] + R[3 * i + 2] * b.torque_b[2];
      }
      mj_applyFT(m, d, force, torque, d->xipos + 3 * id, id, d->qfrc_passive);
    }
  }

 private:
  // max_i |M a - f|_i / (|M| |a| + |f|)_i with f = qfrc_passive - qfrc_bias.
  double backward_error(const std::vector<mjtNum>& a) {
    const auto nv = static_cast<size_t>(m_->nv);
    std::vector<mjtNum> Ma(nv), abs_a(nv), absM_abs_a(nv);
    mj_mulM(m_, d_, Ma.data(), a.data());
    for (size_t i = 0; i < nv; ++i) abs_a[i] = std::fabs(a[i]);
    std::vector<mjtNum> saved(d_->qM, d_->qM + m_->nM);  // |M|: the same sparse layout
    for (int i = 0; i < m_->nM; ++i) d_->qM[i] = std::fabs(d_->qM[i]);
    mj_mulM(m_, d_, absM_abs_a.data(), abs_a.data());
    std::copy(saved.begin(), saved.end(), d_->qM);
    double worst = 0;
    for (size_t i = 0; i < nv; ++i) {
      const double r = Ma[i] - (d_->qfrc_passive[i] - d_->qfrc_bias[i]);
      const double scale =
          absM_abs_a[i] + std::fabs(d_->qfrc_passive[i]) + std::fabs(d_->qfrc_bias[i]);
      if (scale > 0) worst = std::max(worst, std::fabs(r) / scale);
    }
    return worst;
  }

  System system_;
  mjModel* m_;
  mjData* d_ = nullptr;
  std::vector<int> body_id_;
  std::vector<mjtNum> qpos_, qvel_;
  mjData* integration_ = nullptr;  // the integrated state, apart from evaluate()'s d_
  double step_ = 0, time_ = 0;
  long steps_ = 0;
};

void constant_loads(const mjModel* m, mjData* d) {
  if (g_current) g_current->add_constant_loads(m, d);
}

// ---------------------------------------------------------------------------------------------
// Jointed trees. Body K is nested in J at pos = q'_K (plus the weld's translation) with
// quat = the joint frame F, so that K's frame is F at zero joint coordinates; the joints then
// act in F's axes in the order MuJoCo composes them (each one in the frame the previous ones
// left): revolute one hinge about n; prismatic one slide along n; cylindrical a hinge then a
// slide along n (they commute); universal a hinge about a1 then one about a2, which MuJoCo
// carries by the first (a body with two hinges: MuJoCo's universal joint); spherical a ball
// (qpos the quaternion of K relative to F, qvel w_rel in K components: kanedyn's q and z);
// weld none. Free joints (roots) are the three slides and the ball of the free-body model.
// Joint springs and dampers are MuJoCo's (stiffness, springref, damping); constant joint
// forces go into qfrc_applied.
class MujocoJointedEngine final : public JointedEngine {
 public:
  explicit MujocoJointedEngine(const JointedSystem& system)
      : system_(system), m_(load(jointed_mjcf(system))) {
    d_ = mj_makeData(m_);
    const size_t n = system.bodies.size();
    qpos_.assign(static_cast<size_t>(m_->nq), 0.0);
    qvel_.assign(static_cast<size_t>(m_->nv), 0.0);
    dofs_.resize(n);
    body_id_.resize(n);
    for (size_t k = 0; k < n; ++k) {
      body_id_[k] = mj_name2id(m_, mjOBJ_BODY, name("b%zu", k).c_str());
      const JointSpec& j = system.joints[k];
      const double* q = system.q.data() + system.q_offset[k];
      const double* z = system.z.data() + system.z_offset[k];
      auto joint_id = [&](int i) {
        const int id = mj_name2id(m_, mjOBJ_JOINT, name("b%zu_j%d", k, i).c_str());
        if (id < 0) throw std::logic_error("MuJoCo: joint " + name("b%zu_j%d", k, i) + " missing");
        return id;
      };
      if (j.type == JointKind::free) {
        // qpos: slides s'_K, then the ball eps_K (scalar first); dofs: slides, then the ball.
        for (int i = 0; i < 3; ++i) {
          const int id = joint_id(i);
          qpos_[static_cast<size_t>(m_->jnt_qposadr[id])] = q[4 + i];
          qvel_[static_cast<size_t>(m_->jnt_dofadr[id])] = z[3 + i];
        }
        const int ball = joint_id(3);
        set_quaternion(m_->jnt_qposadr[ball], q);
        for (int i = 0; i < 3; ++i) qvel_[static_cast<size_t>(m_->jnt_dofadr[ball] + i)] = z[i];
        // kanedyn's z order: the ball's three, then the slides'.
        for (int i = 0; i < 3; ++i) dofs_[k].push_back(m_->jnt_dofadr[ball] + i);
        for (int i = 0; i < 3; ++i) dofs_[k].push_back(m_->jnt_dofadr[joint_id(i)]);
      } else if (j.type == JointKind::spherical) {
        const int ball = joint_id(0);
        set_quaternion(m_->jnt_qposadr[ball], q);
        for (int i = 0; i < 3; ++i) {
          qvel_[static_cast<size_t>(m_->jnt_dofadr[ball] + i)] = z[i];
          dofs_[k].push_back(m_->jnt_dofadr[ball] + i);
        }
      } else {
        const int count = system.z_offset[k + 1] - system.z_offset[k];
        for (int i = 0; i < count; ++i) {
          const int id = joint_id(i);
          qpos_[static_cast<size_t>(m_->jnt_qposadr[id])] = q[i];
          qvel_[static_cast<size_t>(m_->jnt_dofadr[id])] = z[i];
          dofs_[k].push_back(m_->jnt_dofadr[id]);
          d_->qfrc_applied[m_->jnt_dofadr[id]] = j.value[static_cast<size_t>(i)];
        }
      }
    }
  }
  ~MujocoJointedEngine() override {
    if (integration_) mj_deleteData(integration_);
    mj_deleteData(d_);
    mj_deleteModel(m_);
  }
  MujocoJointedEngine(const MujocoJointedEngine&) = delete;
  MujocoJointedEngine& operator=(const MujocoJointedEngine&) = delete;

  void evaluate() override {
    mju_copy(d_->qpos, qpos_.data(), m_->nq);
    mju_copy(d_->qvel, qvel_.data(), m_->nv);
    mj_forward(m_, d_);
  }

  std::vector<double> zdot() override {
    std::vector<double> out(system_.z.size());
    for (size_t k = 0; k < dofs_.size(); ++k)
      for (size_t i = 0; i < dofs_[k].size(); ++i)
        out[static_cast<size_t>(system_.z_offset[k]) + i] = d_->qacc[dofs_[k][i]];
    return out;
  }

  IntegratorInfo start(const IntegratorSettings& settings) override {
    IntegratorInfo info;
    if (settings.method.empty() || settings.method == "rk4") {
      m_->opt.integrator = mjINT_RK4;
      info = {"RK4 (mjINT_RK4)", true, 4.0};
    } else if (settings.method == "euler") {
      m_->opt.integrator = mjINT_EULER;
      info = {"semi-implicit Euler (mjINT_EULER)", true, 1.0};
    } else {
      throw std::invalid_argument("MuJoCo: unknown integrator '" + settings.method +
                                  "' (rk4, euler)");
    }
    if (!(settings.step > 0)) throw std::invalid_argument("MuJoCo: the step must be > 0");
    step_ = settings.step;
    info.description += ", step " + num_short(step_);
    if (!integration_) integration_ = mj_makeData(m_);
    mj_resetData(m_, integration_);
    mju_copy(integration_->qpos, qpos_.data(), m_->nq);
    mju_copy(integration_->qvel, qvel_.data(), m_->nv);
    mju_copy(integration_->qfrc_applied, d_->qfrc_applied, m_->nv);
    time_ = 0;
    steps_ = 0;
    return info;
  }

  void advance_to(double t) override {
    const double span = t - time_;
    const long n = equal_steps(span, step_);
    m_->opt.timestep = span / static_cast<double>(n);
    for (long i = 0; i < n; ++i) mj_step(m_, integration_);
    for (int i = 0; i < mjNWARNING; ++i)
      if (integration_->warning[i].number > 0)
        throw std::runtime_error("MuJoCo: warning " + std::to_string(i) + " during integration");
    time_ = t;
    steps_ += n;
  }

  std::vector<BodyPose> pose() override {
    mjData* d = integration_;
    mj_forward(m_, d);
    std::vector<BodyPose> out(system_.bodies.size());
    for (size_t k = 0; k < out.size(); ++k) {
      const int b = body_id_[k];
      mjtNum v[6];
      mj_objectVelocity(m_, d, mjOBJ_BODY, b, v, 0);  // at xipos = G_K, world axes
      for (size_t i = 0; i < 3; ++i) {
        out[k].p_G[i] = d->xipos[3 * b + static_cast<int>(i)];
        out[k].w[i] = v[i];
        out[k].v_G[i] = v[3 + i];
      }
      for (size_t i = 0; i < 9; ++i) out[k].R[i] = d->xmat[9 * b + static_cast<int>(i)];
    }
    return out;
  }

  long steps() const override { return steps_; }

 private:
  // kanedyn's Euler parameters (e1, e2, e3, e4) as MuJoCo's quaternion (w, x, y, z).
  void set_quaternion(int adr, const double* e) {
    const double wxyz[4] = {e[3], e[0], e[1], e[2]};
    for (int i = 0; i < 4; ++i) qpos_[static_cast<size_t>(adr + i)] = wxyz[i];
  }

  static std::string joint_element(const std::string& id, int i, const char* type, const Vec3& axis,
                                   const JointSpec& j, size_t c) {
    return "<joint name=\"" + id + "_j" + std::to_string(i) + "\" type=\"" + type + "\" axis=\"" +
           vec(axis) + "\" stiffness=\"" + num(j.stiffness[c]) + "\" springref=\"" +
           num(j.rest[c]) + "\" damping=\"" + num(j.damping[c]) + "\"/>\n";
  }

  static Mjcf jointed_mjcf(const JointedSystem& s) {
    return Mjcf(s.name, s.gravity, s.bodies, 0, [&s](int k) {
      const auto i = static_cast<size_t>(k);
      const Body& b = s.bodies[i];
      const JointSpec& j = s.joints[i];
      const std::string id = name("b%zu", i);
      Vec3 pos = b.joint;
      if (j.type == JointKind::weld)
        for (size_t r = 0; r < 3; ++r) pos[r] += j.translation[r];
      std::string x = "<body name=\"" + id + "\" pos=\"" + vec(pos) + "\"";
      if (j.type != JointKind::free)
        x += " quat=\"" + num(j.frame[0]) + " " + vec({j.frame[1], j.frame[2], j.frame[3]}) + "\"";
      x += ">\n" + inertial(b);
      switch (j.type) {
        case JointKind::free: {
          // free_joints() names them _s0.._s2, _r; here _j0.._j3.
          std::string f = free_joints(b, id);
          for (int c = 0; c < 3; ++c) {
            const std::string from = id + "_s" + std::to_string(c) + "\"";
            f.replace(f.find(from), from.size(), id + "_j" + std::to_string(c) + "\"");
          }
          f.replace(f.find(id + "_r\""), id.size() + 3, id + "_j3\"");
          x += f;
          break;
        }
        case JointKind::weld:
          break;
        case JointKind::revolute:
          x += joint_element(id, 0, "hinge", j.axis, j, 0);
          break;
        case JointKind::prismatic:
          x += joint_element(id, 0, "slide", j.axis, j, 0);
          break;
        case JointKind::cylindrical:
          x += joint_element(id, 0, "hinge", j.axis, j, 0) +
               joint_element(id, 1, "slide", j.axis, j, 1);
          break;
        case JointKind::universal:
          x += joint_element(id, 0, "hinge", j.axis, j, 0) +
               joint_element(id, 1, "hinge", j.axis2, j, 1);
          break;
        case JointKind::spherical:
          x += "<joint name=\"" + id + "_j0\" type=\"ball\"/>\n";
          break;
        case JointKind::screw:  // refused by mujoco_jointed_engine's check
          throw std::runtime_error("peers: MuJoCo: no screw joint");
        case JointKind::planar:
          // MuJoCo has no planar joint type; two slides along the body frame's (F's) x and y,
          // then a hinge about its z through the moved origin, are one: each joint of a body
          // moves the frame the ones before it left.
          x += joint_element(id, 0, "slide", {1, 0, 0}, j, 0) +
               joint_element(id, 1, "slide", {0, 1, 0}, j, 1) +
               joint_element(id, 2, "hinge", {0, 0, 1}, j, 2);
          break;
      }
      return x;
    });
  }

  JointedSystem system_;
  mjModel* m_;
  mjData* d_ = nullptr;
  std::vector<int> body_id_;
  std::vector<std::vector<int>> dofs_;  // per body, MuJoCo's dof of each entry of kanedyn's z_K
  std::vector<mjtNum> qpos_, qvel_;
  mjData* integration_ = nullptr;
  double step_ = 0, time_ = 0;
  long steps_ = 0;
};

}  // namespace

JointedEngineInfo mujoco_jointed_engine() {
  const EngineInfo free = mujoco_engine();
  return {free.name, free.version,
          [](const JointedSystem& s) {
            // MuJoCo 2.2 has no joint that couples a turn and a slide.
            for (const JointSpec& j : s.joints)
              if (j.type == JointKind::screw) return std::string("no screw joint in MuJoCo");
            if (!s.springs.empty()) return std::string("point-to-point springs not translated");
            return s.constraints.empty() ? std::string()
                                         : std::string("constraints not translated");
          },
          [](const JointedSystem& s) -> std::unique_ptr<JointedEngine> {
            return std::make_unique<MujocoJointedEngine>(s);
          }};
}

EngineInfo mujoco_engine() {
  const int v = mj_version();
  return {
      "MuJoCo",
      std::to_string(v / 100) + "." + std::to_string(v / 10 % 10) + "." + std::to_string(v % 10),
      // qM and its factor qLD hold one entry per (dof, ancestor dof) pair; a few such arrays.
      [](const System& s) { return 4.0 * 8.0 * ancestor_dofs(s, 1); },
      // Factorizing M in tree order: sum over dofs of (ancestor dofs)^2.
      [](const System& s) { return ancestor_dofs(s, 2); },
      [](const System& s) -> std::unique_ptr<Engine> { return std::make_unique<MujocoEngine>(s); }};
}

}  // namespace peers
