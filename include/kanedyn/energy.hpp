// Energy and momentum of the system, for checks and output. Each function computes the
// kinematics it needs into data first. The functions of the model's state (q, z) cover every
// model; those of the notes' state (x, y) cover the models without force elements on joint
// coordinates (a joint spring's potential is a function of q, which (x, y) does not give
// whole: a revolute angle of 7 rad and of 7 - 2 pi give the same x), and refuse the others.
#pragma once

#include "kanedyn/data.hpp"
#include "kanedyn/model.hpp"
#include "kanedyn/state.hpp"

namespace kanedyn {

/// sum_K 1/2 m_K |v_G_K|^2 + 1/2 {w'_K}^T [I'_G_K] {w'_K}.
double kinetic_energy(const Model& model, const State& state, Data& data);
/// Gravity (-m_K {g}.{p_G_K}) plus every force element's potential energy. Throws
/// std::invalid_argument for a model with force elements on joint coordinates (use the (q, z)
/// form), as do total_energy, total_energy_of_kinematics and damping_power.
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

/// The same at the model's state (q, z), the notes' state being joint_state(q, z): the
/// potential adds every force element's joint_potential_energy (the joint springs'), and the
/// damping power their joint_damping_power. For every model, total_energy is the energy
/// column of the trajectory CSV.
double kinetic_energy(const Model& model, const VectorX& q, const VectorX& z, Data& data);
double potential_energy(const Model& model, const VectorX& q, const VectorX& z, Data& data);
double total_energy(const Model& model, const VectorX& q, const VectorX& z, Data& data);
double damping_power(const Model& model, const VectorX& q, const VectorX& z, Data& data);
/// total_energy at (q, z) when data holds the kinematics of `state`, the notes' state of
/// (q, z): the same bits without computing them again.
double total_energy_of_kinematics(const Model& model, const State& state, const VectorX& q,
                                  const Data& data);
/// The two parts of total_energy_of_kinematics(model, state, q, data), from the kinematics in
/// data: the kinetic energy, and the potential energy with the joint springs' potentials of q.
double kinetic_energy_of_kinematics(const Model& model, const State& state, const Data& data);
double potential_energy_of_kinematics(const Model& model, const State& state, const VectorX& q,
                                      const Data& data);
/// Linear momentum sum_K m_K {v_G_K}, inertial components.
Vector3 linear_momentum(const Model& model, const State& state, Data& data);
/// Angular momentum about the inertial origin, inertial components.
Vector3 angular_momentum(const Model& model, const State& state, Data& data);
/// The momenta at the model's state (q, z).
Vector3 linear_momentum(const Model& model, const VectorX& q, const VectorX& z, Data& data);
Vector3 angular_momentum(const Model& model, const VectorX& q, const VectorX& z, Data& data);

}  // namespace kanedyn
