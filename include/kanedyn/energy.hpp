// Energy and momentum of the system, for checks and output. Each function computes the
// kinematics it needs into data first.
#pragma once

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

/// sum_K 1/2 m_K |v_G_K|^2 + 1/2 {w'_K}^T [I'_G_K] {w'_K}.
double kinetic_energy(const Model& model, const State& state, Data& data);
/// Gravity (-m_K {g}.{p_G_K}) plus every force element's potential energy.
double potential_energy(const Model& model, const State& state, Data& data);
/// Kinetic plus potential: conserved when every damping is zero and no constant load acts.
double total_energy(const Model& model, const State& state, Data& data);
/// total_energy when data already holds this state's kinematics (compute_kinematics(model,
/// state, data) ran last, as for the data a simulate() observer receives): the same value, bit
/// for bit, without computing the kinematics again (total_energy computes them twice).
double total_energy_of_kinematics(const Model& model, const State& state, const Data& data);
/// Power removed by all damping (>= 0): with only gravity and bushings,
/// d(total_energy)/dt = -damping_power.
double damping_power(const Model& model, const State& state, Data& data);
/// Linear momentum sum_K m_K {v_G_K}, inertial components.
Vector3 linear_momentum(const Model& model, const State& state, Data& data);
/// Angular momentum about the inertial origin, inertial components.
Vector3 angular_momentum(const Model& model, const State& state, Data& data);

}  // namespace kanedyn
