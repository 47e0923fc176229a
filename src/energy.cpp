#include "kanedyn/energy.hpp"

#include <stdexcept>

#include "kanedyn/forces.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"

namespace kanedyn {

namespace {
size_t at(int i) { return static_cast<size_t>(i); }

// The sums, from kinematics already in data.
double kinetic_sum(const Model& model, const State& state, const Data& data) {
  double t = 0.0;
  for (int k = 0; k < model.num_bodies(); ++k) {
    const Vector3 w = state.angular_velocity(k);
    t += 0.5 * model.body(k).mass * data.kinematics.v_G[at(k)].squaredNorm() +
         0.5 * w.dot(model.body(k).inertia * w);
  }
  return t;
}

// The notes' state has no joint coordinates, which a joint spring's potential needs.
void require_no_joint_elements(const Model& model, const char* function) {
  if (model.has_joint_force_elements())
    throw std::invalid_argument(
        std::string(function) +
        ": the model has force elements on joint coordinates (joint springs), whose energy "
        "needs q: call it with the state (q, z)");
}

// The notes' state of (q, z), in a State sized for the model.
State notes_state(const Model& model, const VectorX& q, const VectorX& z) {
  if (q.size() != model.num_coordinates() || z.size() != model.num_speeds())
    throw std::invalid_argument("energy: q and z do not have the model's sizes");
  State s(model);
  joint_state(model, q, z, s);
  return s;
}

double potential_sum(const Model& model, const State& state, const Data& data) {
  double v = 0.0;
  for (int k = 0; k < model.num_bodies(); ++k)
    v -= model.body(k).mass * model.gravity().dot(data.kinematics.p_G[at(k)]);
  for (const auto& e : model.forces()) v += e->potential_energy(model, state, data.kinematics);
  return v;
}
}  // namespace

double kinetic_energy(const Model& model, const State& state, Data& data) {
  compute_kinematics(model, state, data);
  return kinetic_sum(model, state, data);
}

double potential_energy(const Model& model, const State& state, Data& data) {
  require_no_joint_elements(model, "potential_energy");
  compute_kinematics(model, state, data);
  return potential_sum(model, state, data);
}

double total_energy(const Model& model, const State& state, Data& data) {
  require_no_joint_elements(model, "total_energy");
  return kinetic_energy(model, state, data) + potential_energy(model, state, data);
}

double total_energy_of_kinematics(const Model& model, const State& state, const Data& data) {
  require_no_joint_elements(model, "total_energy_of_kinematics");
  return kinetic_sum(model, state, data) + potential_sum(model, state, data);
}

double total_energy_of_kinematics(const Model& model, const State& state, const VectorX& q,
                                  const Data& data) {
  const double e = kinetic_sum(model, state, data) + potential_sum(model, state, data);
  return model.has_joint_force_elements() ? e + joint_potential_energy(model, q) : e;
}

double kinetic_energy_of_kinematics(const Model& model, const State& state, const Data& data) {
  return kinetic_sum(model, state, data);
}

double potential_energy_of_kinematics(const Model& model, const State& state, const VectorX& q,
                                      const Data& data) {
  const double v = potential_sum(model, state, data);
  return model.has_joint_force_elements() ? v + joint_potential_energy(model, q) : v;
}

double kinetic_energy(const Model& model, const VectorX& q, const VectorX& z, Data& data) {
  return kinetic_energy(model, notes_state(model, q, z), data);
}

double potential_energy(const Model& model, const VectorX& q, const VectorX& z, Data& data) {
  const State s = notes_state(model, q, z);
  compute_kinematics(model, s, data);
  return potential_sum(model, s, data) + joint_potential_energy(model, q);
}

double total_energy(const Model& model, const VectorX& q, const VectorX& z, Data& data) {
  const State s = notes_state(model, q, z);
  compute_kinematics(model, s, data);
  return total_energy_of_kinematics(model, s, q, data);
}

double damping_power(const Model& model, const VectorX& q, const VectorX& z, Data& data) {
  const State s = notes_state(model, q, z);
  compute_kinematics(model, s, data);
  double p = joint_damping_power(model, z);
  for (const auto& e : model.forces()) p += e->damping_power(model, s, data.kinematics);
  return p;
}

Vector3 linear_momentum(const Model& model, const VectorX& q, const VectorX& z, Data& data) {
  return linear_momentum(model, notes_state(model, q, z), data);
}

Vector3 angular_momentum(const Model& model, const VectorX& q, const VectorX& z, Data& data) {
  return angular_momentum(model, notes_state(model, q, z), data);
}

double damping_power(const Model& model, const State& state, Data& data) {
  require_no_joint_elements(model, "damping_power");
  compute_kinematics(model, state, data);
  double p = 0.0;
  for (const auto& e : model.forces()) p += e->damping_power(model, state, data.kinematics);
  return p;
}

Vector3 linear_momentum(const Model& model, const State& state, Data& data) {
  compute_kinematics(model, state, data);
  Vector3 p = Vector3::Zero();
  for (int k = 0; k < model.num_bodies(); ++k) p += model.body(k).mass * data.kinematics.v_G[at(k)];
  return p;
}

Vector3 angular_momentum(const Model& model, const State& state, Data& data) {
  compute_kinematics(model, state, data);
  Vector3 h = Vector3::Zero();
  for (int k = 0; k < model.num_bodies(); ++k) {
    const auto i = at(k);
    const BodySpec& b = model.body(k);
    h += b.mass * data.kinematics.p_G[i].cross(data.kinematics.v_G[i]) +
         data.kinematics.R[i].transpose() * (b.inertia * state.angular_velocity(k));
  }
  return h;
}

}  // namespace kanedyn
