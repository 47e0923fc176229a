#include "kanedyn/energy.hpp"

#include "kanedyn/forces.hpp"
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
  compute_kinematics(model, state, data);
  return potential_sum(model, state, data);
}

double total_energy(const Model& model, const State& state, Data& data) {
  return kinetic_energy(model, state, data) + potential_energy(model, state, data);
}

double total_energy_of_kinematics(const Model& model, const State& state, const Data& data) {
  return kinetic_sum(model, state, data) + potential_sum(model, state, data);
}

double damping_power(const Model& model, const State& state, Data& data) {
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
