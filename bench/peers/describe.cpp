// kanedyn's Model and State in the engine-neutral description, and ancestor_dofs (the engines'
// cost models).
#include "describe.hpp"

#include <cmath>
#include <stdexcept>

#include "kanedyn/forces.hpp"
#include "kanedyn/rotation.hpp"

namespace peers {

double ancestor_dofs(const System& system, int power) {
  std::vector<double> dofs(system.bodies.size());
  double sum = 0;
  for (size_t k = 0; k < dofs.size(); ++k) {
    const int j = system.bodies[k].parent;
    dofs[k] = 6.0 + (j < 0 ? 0.0 : dofs[static_cast<size_t>(j)]);
    sum += 6.0 * std::pow(dofs[k], power);  // six dofs per body, each with that many ancestors
  }
  return sum;
}

namespace {

using kanedyn::Matrix3;
using kanedyn::Vector3;
using kanedyn::Vector4;

Vec3 arr(const Vector3& v) { return {v.x(), v.y(), v.z()}; }
Vector3 vec(const Vec3& a) { return {a[0], a[1], a[2]}; }

}  // namespace

System describe(const std::string& name, const kanedyn::Model& m, const kanedyn::State& s) {
  System sys;
  sys.name = name;
  sys.gravity = arr(m.gravity());
  for (int k = 0; k < m.num_bodies(); ++k) {
    const kanedyn::BodySpec& b = m.body(k);
    Body body;
    body.name = b.name;
    body.parent = b.lower_body;
    body.mass = b.mass;
    for (int r = 0; r < 3; ++r)
      for (int col = 0; col < 3; ++col)
        body.inertia[static_cast<size_t>(3 * r + col)] = b.inertia(r, col);
    body.com = arr(b.com);
    body.joint = arr(b.joint);
    sys.bodies.push_back(body);
  }
  for (const auto& f : m.forces()) {
    Body& b = sys.bodies[static_cast<size_t>(f->body())];
    if (const auto* bushing = dynamic_cast<const kanedyn::Bushing*>(f.get())) {
      for (int i = 0; i < 3; ++i) {
        b.k[static_cast<size_t>(i)] += bushing->stiffness[i];
        b.c[static_cast<size_t>(i)] += bushing->damping[i];
      }
      b.kr += bushing->rotational_stiffness;
      b.cr += bushing->rotational_damping;
    } else if (const auto* force = dynamic_cast<const kanedyn::ConstantForce*>(f.get())) {
      b.force = arr(vec(b.force) + force->value);
      sys.has_constant_loads = true;
    } else if (const auto* torque = dynamic_cast<const kanedyn::ConstantTorque*>(f.get())) {
      b.torque_b = arr(vec(b.torque_b) + torque->value);
      sys.has_constant_loads = true;
    } else {
      throw std::runtime_error("peers: no peer translation for force type " + f->type());
    }
  }
  for (int k = 0; k < m.num_bodies(); ++k) {
    const int j = m.lower_body(k);
    const Vector4 eps_k = s.euler_parameters(k);
    const Vector4 rel = j == kanedyn::kGround
                            ? eps_k
                            : kanedyn::relative_euler_parameters(s.euler_parameters(j), eps_k);
    const Matrix3 R_rel = kanedyn::rotation_matrix(rel);  // J components -> K components
    Vector3 w_rel_k = s.angular_velocity(k);
    if (j != kanedyn::kGround)
      w_rel_k -=
          kanedyn::rotation_matrix(eps_k) *
          (kanedyn::rotation_matrix(s.euler_parameters(j)).transpose() * s.angular_velocity(j));
    BodyState st;
    // kanedyn's [R] is the transpose of the Hamilton rotation of (e4; e1, e2, e3), so the
    // Hamilton quaternion that maps K components to J components has the same numbers.
    st.q_rel = {rel[3], rel[0], rel[1], rel[2]};
    st.s = arr(s.translation(k));
    st.s_dot = arr(s.translation_rate(k));
    st.w_rel_k = arr(w_rel_k);
    st.w_rel_j = arr(R_rel.transpose() * w_rel_k);
    sys.state.push_back(st);
  }
  return sys;
}

}  // namespace peers
