// Inputs (docs/model-format.md, "Inputs"): each type against the same load written as a force
// element, its generalized force against the partial velocities of frames, its power against
// the energy's rate; input tables, controllers and the simulate() rules about them.
#include <gtest/gtest.h>

#include <random>
#include <stdexcept>

#include "kanedyn/dynamics.hpp"
#include "kanedyn/energy.hpp"
#include "kanedyn/forces.hpp"
#include "kanedyn/frames.hpp"
#include "kanedyn/inputs.hpp"
#include "kanedyn/io/model_file.hpp"
#include "kanedyn/io/trajectory.hpp"
#include "kanedyn/joints.hpp"
#include "kanedyn/kinematics.hpp"
#include "kanedyn/simulate.hpp"
#include "kanedyn/terms.hpp"
#include "test_support.hpp"

namespace kanedyn {
namespace {

using test::joints_of;
using test::random_input;
using test::random_joint;
using test::random_joint_state;
using test::random_jointed;
using test::random_tree;
using test::rebuilt;
using test::uniform;
using test::uniform_int;

VectorX zdot_of(const Model& m, const VectorX& q, const VectorX& z, const VectorX& u) {
  Dynamics d(m);
  VectorX zdot(m.num_speeds());
  d.forward(q, z, u, zdot);
  return zdot;
}

// A joint input on a revolute, prismatic, cylindrical, universal or planar joint is the
// joint_force of the same value on that coordinate: the same bits.
TEST(Inputs, JointInputIsTheJointForceElement) {
  std::mt19937 rng(11);
  int checked = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const Model m = random_jointed(rng, true);
    Input in;
    in.name = "u";
    if (!random_input(m, rng, InputType::joint, in)) continue;
    const JointType type = m.joint(in.body).type;
    if (!speeds_are_coordinate_rates(type)) continue;
    const double value = uniform(rng, -5, 5);
    const int n = coordinate_count(type);
    VectorX load = VectorX::Zero(n);
    load[in.speed] = value;
    auto forces = m.forces();
    forces.push_back(std::make_shared<JointLoad>(in.body, VectorX::Zero(n), VectorX::Zero(n),
                                                 VectorX::Zero(n), load, "joint_force"));
    const Model with_input = rebuilt(m, m.forces(), {in});
    const Model with_element = rebuilt(m, forces, {});
    VectorX q, z;
    random_joint_state(m, rng, q, z);
    const VectorX u = VectorX::Constant(1, value);
    EXPECT_EQ(zdot_of(with_input, q, z, u), zdot_of(with_element, q, z, VectorX()));
    ++checked;
  }
  EXPECT_GT(checked, 5);
}

// A torque input without reaction is a constant torque u a on the body, a force input at the
// mass centre the constant force of the same vector, and a joint input on a free body's w'_K i
// the torque u e_i: the same bits.
TEST(Inputs, TorqueAndForceInputsAreConstantLoads) {
  std::mt19937 rng(12);
  for (int trial = 0; trial < 20; ++trial) {
    const Model m = random_jointed(rng, true);
    Input in;
    in.name = "u";
    ASSERT_TRUE(random_input(m, rng, InputType::torque, in));
    in.reaction = false;
    const double value = uniform(rng, -5, 5);
    const Model with_input = rebuilt(m, m.forces(), {in});
    auto forces = m.forces();
    // The axis as the Model normalized it (kanedyn/direction.hpp), for the same bits.
    forces.push_back(
        std::make_shared<ConstantTorque>(in.body, value * with_input.inputs()[0].axis));
    VectorX q, z;
    random_joint_state(m, rng, q, z);
    EXPECT_EQ(zdot_of(with_input, q, z, VectorX::Constant(1, value)),
              zdot_of(rebuilt(m, forces, {}), q, z, VectorX()));
  }
  // A force input at the mass centre is, at one state, the constant force R_K^T (u d) at G_K:
  // the same vector added to the same body's resultant, and a zero moment. To round-off (1e-12
  // of the largest acceleration), not to the bit: the force element's R_K^T is the staged
  // kinematics' and is added before the other elements' loads, the input's is the evaluation's
  // own and is added after them.
  for (int trial = 0; trial < 20; ++trial) {
    const Model m = random_jointed(rng, true);
    Input in;
    in.name = "u";
    ASSERT_TRUE(random_input(m, rng, InputType::force, in));
    in.point = m.body(in.body).com;
    const Model with_input = rebuilt(m, m.forces(), {in});
    VectorX q, z;
    random_joint_state(m, rng, q, z);
    State s(m);
    joint_state(m, q, z, s);
    Data data(m);
    compute_kinematics(m, s, data);
    const double value = uniform(rng, -5, 5);
    const Vector3 d = with_input.inputs()[0].direction;
    auto forces = m.forces();
    forces.push_back(std::make_shared<ConstantForce>(
        in.body, data.kinematics.R[static_cast<size_t>(in.body)].transpose() * (value * d)));
    const VectorX a = zdot_of(with_input, q, z, VectorX::Constant(1, value));
    const VectorX b = zdot_of(rebuilt(m, forces, {}), q, z, VectorX());
    EXPECT_LE((a - b).cwiseAbs().maxCoeff(), 1e-12 * std::max(1.0, b.cwiseAbs().maxCoeff()));
  }
  // The free body of the all-free eight-body model. A model with inputs runs the staged O(N)
  // route, one with built-in elements only the fused pass: the two agree to round-off (1e-12
  // of the largest acceleration), not to the bit.
  const Model m = test::eight_body_model();
  const State s = test::moving_state(m, 3);
  VectorX q, z;
  joint_coordinates(m, s, q, z);
  for (int i = 0; i < 3; ++i) {
    Input in{"w", InputType::joint, 4, i};
    auto forces = m.forces();
    forces.push_back(std::make_shared<ConstantTorque>(4, 2.5 * Vector3::Unit(i)));
    const VectorX a = zdot_of(rebuilt(m, m.forces(), {in}), q, z, VectorX::Constant(1, 2.5));
    const VectorX b = zdot_of(rebuilt(m, forces, {}), q, z, VectorX());
    EXPECT_LE((a - b).cwiseAbs().maxCoeff(), 1e-12 * b.cwiseAbs().maxCoeff());
    EXPECT_GT((a - zdot_of(m, q, z, VectorX())).cwiseAbs().maxCoeff(), 1e-3);  // it acts
  }
}

// The generalized force of every input type, by the notes' partial velocities: f_z(u) - f_z(0)
// of the projected equations equals u e_i for a joint input (a free body's s'_K dot too: the
// force at O_K and its reaction on J load that speed alone), Jv_P^T d u for a force at P, and
// Jw_K^T a u (minus Jw_J^T a u with reaction) for a torque, the Jacobians of frames at P and
// on K and J (frames.hpp). Both sides are sums of a few products: 1e-12 relative to the
// largest term.
TEST(Inputs, GeneralizedForcesArePartialVelocitiesTimesTheLoads) {
  std::mt19937 rng(13);
  for (int trial = 0; trial < 60; ++trial) {
    const Model base = random_jointed(rng, true);
    const InputType type = static_cast<InputType>(trial % 3);
    Input in;
    in.name = "u";
    if (!random_input(base, rng, type, in)) continue;
    const int j = base.lower_body(in.body);
    std::vector<Frame> frames{Frame{"P", in.body, in.point, Vector4(0, 0, 0, 1)},
                              Frame{"J", j, Vector3::Zero(), Vector4(0, 0, 0, 1)}};
    const Model m = rebuilt(base, base.forces(), {in}, frames);
    VectorX q, z;
    random_joint_state(m, rng, q, z);
    const double value = uniform(rng, -5, 5);
    Data data(m);
    const VectorX f0 = projected_equations(m, q, z, data).f_z;
    data.inputs = VectorX::Constant(1, value);
    const ProjectedEquations e = projected_equations(m, q, z, data);
    const VectorX df = e.f_z - f0;
    const int n = m.num_speeds();
    MatrixX Jv(3, n), Jw(3, n), Jv_j(3, n), Jw_j(3, n);
    Data kin_data(m);
    compute_kinematics(m, e.state, kin_data);
    frame_jacobian(m, 0, q, kin_data.kinematics, Jv, Jw);
    frame_jacobian(m, 1, q, kin_data.kinematics, Jv_j, Jw_j);
    const Matrix3& R = kin_data.kinematics.R[static_cast<size_t>(in.body)];
    VectorX expected = VectorX::Zero(n);
    switch (type) {
      case InputType::joint:
        expected[m.speed_offset(in.body) + in.speed] = value;
        break;
      case InputType::force:
        expected = Jv.transpose() * (R.transpose() * m.inputs()[0].direction) * value;
        break;
      case InputType::torque: {
        const Vector3 a = R.transpose() * m.inputs()[0].axis * value;
        expected = Jw.transpose() * a;
        if (in.reaction && j != kGround) expected -= Jw_j.transpose() * a;
        break;
      }
    }
    const double scale = std::max({1.0, f0.cwiseAbs().maxCoeff(), std::abs(value)});
    EXPECT_LE((df - expected).cwiseAbs().maxCoeff(), 1e-12 * scale)
        << "trial " << trial << " type " << static_cast<int>(type) << "\n"
        << df.transpose() << "\n"
        << expected.transpose();
  }
}

// With gravity and undamped bushings only, the energy's rate is the inputs' power: u z_i for
// a joint input, u d . v_P for a force at P, u a . (w_K - w_J) for a torque with reaction (w_K
// without). dE/dt by central differences along (q dot, z dot), h = 1e-6: truncation O(h^2)
// ~ 1e-12 of the energy's scale, round-off ~ 1e-16 E / h ~ 1e-10 E; asserted to 1e-6.
TEST(Inputs, EnergyRateIsTheInputsPower) {
  std::mt19937 rng(14);
  for (int trial = 0; trial < 30; ++trial) {
    const Model base = random_jointed(rng, false);
    std::vector<Input> inputs;
    for (int t = 0; t < 3; ++t) {
      Input in;
      in.name = "u" + std::to_string(t);
      if (random_input(base, rng, static_cast<InputType>(t), in)) inputs.push_back(in);
    }
    std::vector<Frame> frames;
    for (size_t i = 0; i < inputs.size(); ++i)
      frames.push_back(
          Frame{"P" + std::to_string(i), inputs[i].body, inputs[i].point, Vector4(0, 0, 0, 1)});
    const Model m = rebuilt(base, base.forces(), inputs, frames);
    VectorX q, z;
    random_joint_state(m, rng, q, z);
    VectorX u(m.num_inputs());
    for (int i = 0; i < u.size(); ++i) u[i] = uniform(rng, -5, 5);
    Dynamics d(m);
    VectorX zdot(m.num_speeds()), qdot(m.num_coordinates());
    d.set_inputs(u);
    d.evaluate(q, z, zdot, qdot);
    Data data(m);
    const double h = 1e-6;
    const double e_plus = total_energy(m, q + h * qdot, z + h * zdot, data);
    const double e_minus = total_energy(m, q - h * qdot, z - h * zdot, data);
    const double rate = (e_plus - e_minus) / (2 * h);
    State s(m);
    joint_state(m, q, z, s);
    compute_kinematics(m, s, data);
    double power = 0.0;
    for (size_t i = 0; i < inputs.size(); ++i) {
      const Input& in = m.inputs()[i];
      const Matrix3& R = data.kinematics.R[static_cast<size_t>(in.body)];
      const Vector3 w_k = R.transpose() * s.angular_velocity(in.body);
      const int j = m.lower_body(in.body);
      const Vector3 w_j = j == kGround
                              ? Vector3::Zero()
                              : Vector3(data.kinematics.R[static_cast<size_t>(j)].transpose() *
                                        s.angular_velocity(j));
      const double ui = u[static_cast<Eigen::Index>(i)];
      switch (in.type) {
        case InputType::joint:
          power += ui * z[m.speed_offset(in.body) + in.speed];
          break;
        case InputType::force:
          power += ui * (R.transpose() * in.direction)
                            .dot(frame_state(m, static_cast<int>(i), s, data.kinematics).velocity);
          break;
        case InputType::torque:
          power += ui * (R.transpose() * in.axis).dot(in.reaction ? Vector3(w_k - w_j) : w_k);
          break;
      }
    }
    const double scale = std::max(1.0, std::abs(total_energy(m, q, z, data)));
    EXPECT_NEAR(rate, power, 1e-6 * scale) << "trial " << trial;
  }
}

TEST(Inputs, ModelRefusesBadInputs) {
  const Model m = test::eight_body_model();
  std::vector<Joint> joints = joints_of(m);
  joints[1].type = JointType::weld;
  joints[2].type = JointType::revolute;
  const auto make = [&](Input in) {
    return Model(m.bodies(), m.gravity(), m.forces(), "", joints, {}, {std::move(in)});
  };
  EXPECT_THROW(make(Input{"a", InputType::joint, 1, 0}), ModelError);  // a weld
  EXPECT_THROW(make(Input{"a", InputType::joint, 2, 1}), ModelError);  // one speed
  EXPECT_THROW(make(Input{"a", InputType::joint, 0, 6}), ModelError);  // free: 6 speeds
  EXPECT_NO_THROW(make(Input{"a", InputType::joint, 0, 5}));
  Input force{"f", InputType::force, 0};
  force.direction = Vector3::Zero();
  EXPECT_THROW(make(force), ModelError);
  Input torque{"t", InputType::torque, 0};
  torque.axis = Vector3::Zero();
  EXPECT_THROW(make(torque), ModelError);
  EXPECT_THROW(make(Input{"bad name", InputType::joint, 0, 0}), ModelError);
  EXPECT_THROW(Model(m.bodies(), m.gravity(), m.forces(), "", joints, {},
                     {Input{"a", InputType::joint, 0, 0}, Input{"a", InputType::joint, 0, 1}}),
               ModelError);
  const Model one = make(Input{"a", InputType::joint, 0, 0});  // Dynamics keeps a reference
  Dynamics d(one);
  EXPECT_THROW(d.set_inputs(VectorX::Zero(2)), std::invalid_argument);
}

const char* kCart = R"(format: kanedyn-model/1
name: cart
gravity: [0, 0, -9.81]
bodies:
  - {name: cart, parent: ground, mass: 2, inertia: [0.02, 0.05, 0.06],
     joint: {type: prismatic, axis: [1, 0, 0]}}
  - name: pole
    parent: cart
    mass: 0.5
    inertia: [0.0168, 0.0168, 0.0002]
    com: [0, 0, -0.3]
    joint: {type: revolute, axis: [0, 1, 0]}
    initial: {joint: [0.5]}
inputs:
  - {name: push, type: joint, body: cart}
  - {name: thrust, type: force, body: pole, direction: [2, 0, 0]}
  - {name: twist, type: torque, body: pole, axis: [0, 1, 0], reaction: true}
)";

TEST(Inputs, ModelFileSection) {
  const io::ModelFile f = io::parse_model_file(kCart, "cart.yaml");
  const Model& m = f.model;
  ASSERT_EQ(m.num_inputs(), 3);
  EXPECT_EQ(m.inputs()[0].type, InputType::joint);
  EXPECT_EQ(m.inputs()[1].point, m.body(1).com);  // the mass centre unless given
  EXPECT_EQ(m.inputs()[1].direction, Vector3::UnitX());
  EXPECT_TRUE(m.inputs()[2].reaction);
  EXPECT_EQ(m.input_index("twist"), 2);
  const auto refuses = [](const std::string& inputs, const std::string& words) {
    std::string text = kCart;
    text = text.substr(0, text.find("inputs:")) + inputs;
    try {
      io::parse_model_file(text, "cart.yaml");
      ADD_FAILURE() << "accepted: " << inputs;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("cart.yaml:"), std::string::npos) << e.what();
    }
  };
  refuses("inputs:\n  - {name: a, type: joint, body: pole, speed: 2}\n", "speed");
  refuses("inputs:\n  - {name: a, type: joint, body: pole, speed: 0}\n", "speed");
  refuses("inputs:\n  - {name: a, type: force, body: pole, direction: [0, 0, 0]}\n", "zero vector");
  refuses("inputs:\n  - {name: a, type: torque, body: pole, axis: [0, 0, 0]}\n", "zero vector");
  refuses("inputs:\n  - {name: a, type: force, body: pole}\n", "direction");
  refuses("inputs:\n  - {name: a, type: joint, body: pole, axis: [1, 0, 0]}\n", "axis");
  refuses("inputs:\n  - {name: a, type: motor, body: pole}\n", "input type");
  refuses(
      "inputs:\n  - {name: a, type: joint, body: pole}\n  - {name: a, type: joint, body: "
      "cart}\n",
      "duplicate input name");
  refuses("inputs:\n  - {name: a, type: joint, body: nobody}\n", "nobody");
  // Tables name their time column t: an input of that name could never be driven.
  refuses("inputs:\n  - {name: t, type: joint, body: pole}\n", "time column");
  EXPECT_THROW(Model(m.bodies(), m.gravity(), m.forces(), "", joints_of(m), {},
                     {Input{"t", InputType::joint, 0, 0}}),
               ModelError);
}

// A direction's size does not matter, however large or small (kanedyn/direction.hpp): an
// input's direction or axis of 1e200 or 1e-200 is the unit one, as a joint's axis is. Its norm
// taken first once overflowed to infinity and applied no load, or underflowed to 0 and was
// refused as a zero vector.
TEST(Inputs, DirectionsOfAnySizeAreScaledBeforeTheirNorm) {
  const io::ModelFile unit = io::parse_model_file(kCart, "cart.yaml");
  const VectorX u = (VectorX(3) << 0.5, 2.0, -1.5).finished();
  const VectorX expected = zdot_of(unit.model, unit.q, unit.z, u);
  for (const char* scale : {"1e200", "1e-200", "1.7e308"}) {
    std::string text = kCart;
    const std::string s = scale;
    text.replace(text.find("direction: [2, 0, 0]"), 20, "direction: [" + s + ", 0, 0]");
    text.replace(text.find("axis: [0, 1, 0], reaction"), 25, "axis: [0, " + s + ", 0], reaction");
    const io::ModelFile f = io::parse_model_file(text, "cart.yaml");
    EXPECT_EQ(f.model.inputs()[1].direction, Vector3::UnitX()) << scale;
    EXPECT_EQ(f.model.inputs()[2].axis, Vector3::UnitY()) << scale;
    EXPECT_EQ(zdot_of(f.model, f.q, f.z, u), expected) << scale;
  }
  // The Model itself, built in C++, follows the same rule.
  const Model& m = unit.model;
  std::vector<Joint> joints = joints_of(m);
  Input force = m.inputs()[1];
  force.direction = Vector3(1e300, 0, 0);
  Input torque = m.inputs()[2];
  torque.axis = Vector3(0, 1e-300, 0);
  const Model scaled(m.bodies(), m.gravity(), m.forces(), "", joints, {},
                     {m.inputs()[0], force, torque});
  EXPECT_EQ(scaled.inputs()[1].direction, Vector3::UnitX());
  EXPECT_EQ(scaled.inputs()[2].axis, Vector3::UnitY());
  joints[0].axis = Vector3(1e300, 0, 0);
  joints[1].axis = Vector3(0, 1e-300, 0);
  const Model axes(m.bodies(), m.gravity(), m.forces(), "", joints, {}, m.inputs());
  EXPECT_EQ(axes.joint(0).axis, Vector3::UnitX());
  EXPECT_EQ(axes.joint(1).axis, Vector3::UnitY());
}

TEST(Inputs, TableHoldsAndInterpolates) {
  MatrixX v(3, 2);
  v << 1, 10, 2, 20, 4, 40;
  const InputTable zoh({0.0, 1.0, 3.0}, v, InputHold::zero_order);
  const InputTable lin({0.0, 1.0, 3.0}, v, InputHold::linear);
  VectorX u(2);
  EXPECT_EQ(zoh.segment(-1.0), -1);
  EXPECT_EQ(zoh.segment(1.0), 1);
  EXPECT_EQ(zoh.segment(5.0), 2);
  zoh.value(-1.0, u);
  EXPECT_EQ(u[0], 1.0);
  EXPECT_EQ(u[1], 10.0);
  zoh.value(0.999, u);
  EXPECT_EQ(u[0], 1.0);
  zoh.value(1.0, u);  // the new row's value at its own time
  EXPECT_EQ(u[0], 2.0);
  lin.value(2.0, u);
  EXPECT_DOUBLE_EQ(u[0], 3.0);
  EXPECT_DOUBLE_EQ(u[1], 30.0);
  lin.value(1.0, 0, u);  // the end of segment 0 as that segment computes it
  EXPECT_DOUBLE_EQ(u[0], 2.0);
  lin.value(9.0, u);
  EXPECT_EQ(u[0], 4.0);
  EXPECT_THROW(InputTable({0.0, 0.0}, MatrixX::Zero(2, 1)), std::invalid_argument);
  EXPECT_THROW(InputTable({0.0}, MatrixX::Zero(2, 1)), std::invalid_argument);
}

SimulationSettings short_run(Integrator integrator) {
  SimulationSettings s;
  s.t_end = 1.0;
  s.dt_out = 0.1;
  s.integrator = integrator;
  s.step = 0.01;
  return s;
}

struct Rows {
  std::vector<double> t;
  std::vector<VectorX> q, z, u;
};

Observer recorder(Rows& rows) {
  return [&rows](double t, const State&, const VectorX& q, const VectorX& z, Data& data) {
    rows.t.push_back(t);
    rows.q.push_back(q);
    rows.z.push_back(z);
    rows.u.push_back(data.inputs);
  };
}

// A controller called at a fixed interval gives the same run as a table of the values it set,
// held between its calls: the same segments and the same values, so the same bits.
TEST(Inputs, IntervalControllerEqualsItsTable) {
  const io::ModelFile f = io::parse_model_file(kCart, "cart.yaml");
  for (const Integrator integrator : {Integrator::rk4, Integrator::dopri5}) {
    std::vector<double> times;
    std::vector<VectorX> values;
    SimulationSettings s = short_run(integrator);
    s.control_interval = 0.07;
    s.controller = [&](double t, const VectorX& q, const VectorX& z, Eigen::Ref<VectorX> u) {
      u << -20.0 * q[0] - 5.0 * z[0], 0.3 * std::sin(5 * t), -2.0 * q[1] - 0.5 * z[1];
      times.push_back(t);
      values.push_back(u);
    };
    Rows a, b;
    const SimulationStats sa = simulate(f.model, f.q, f.z, s, recorder(a));
    ASSERT_TRUE(sa.ok()) << sa.message;
    ASSERT_EQ(times.size(), 15u);  // t = 0, 0.07, ..., 0.98
    MatrixX table(static_cast<Eigen::Index>(times.size()), 3);
    for (size_t i = 0; i < times.size(); ++i) table.row(static_cast<Eigen::Index>(i)) = values[i];
    SimulationSettings st = short_run(integrator);
    st.inputs = std::make_shared<const InputTable>(times, table);
    const SimulationStats sb = simulate(f.model, f.q, f.z, st, recorder(b));
    ASSERT_TRUE(sb.ok()) << sb.message;
    EXPECT_EQ(a.q, b.q);
    EXPECT_EQ(a.z, b.z);
    EXPECT_EQ(a.u, b.u);
    EXPECT_EQ(sa.evaluations, sb.evaluations);
    EXPECT_NE(a.q.back(), a.q.front());
  }
}

// A controller called at every evaluation is the same as a hand-written rk4 loop that sets the
// inputs from the state before each evaluation.
TEST(Inputs, EveryEvaluationControllerEqualsAHandWrittenLoop) {
  const io::ModelFile f = io::parse_model_file(kCart, "cart.yaml");
  const Model& m = f.model;
  const auto law = [](double t, const VectorX& q, const VectorX& z, Eigen::Ref<VectorX> u) {
    u << -20.0 * q[0] - 5.0 * z[0], std::cos(3 * t), -2.0 * q[1] - 0.5 * z[1];
  };
  SimulationSettings s = short_run(Integrator::rk4);
  s.controller = law;
  Rows rows;
  ASSERT_TRUE(simulate(m, f.q, f.z, s, recorder(rows)).ok());
  Dynamics d(m);
  VectorX u = VectorX::Zero(3);
  Rk4 rk4(d.size(), [&](double t, const VectorX& v, VectorX& dv) {
    law(t, v.head(m.num_coordinates()), v.tail(m.num_speeds()), u);
    d.set_inputs(u);
    d.derivative(v, dv);
  });
  VectorX v(d.size());
  d.pack(f.q, f.z, v);
  // simulate()'s steps: each output interval in rk4_substeps equal steps, ending on it.
  double t = 0.0;
  for (int i = 1; i <= 10; ++i) {
    const double t_next = i == 10 ? 1.0 : 0.1 * i;
    const long substeps = rk4_substeps(t_next - t, s.step);
    const double h = (t_next - t) / static_cast<double>(substeps);
    for (long j = 0; j < substeps; ++j) {
      const double t_new = j + 1 == substeps ? t_next : t + h;
      rk4.step(t, h, v);
      d.project(v, true);
      t = t_new;
    }
  }
  EXPECT_EQ(rows.q.back(), v.head(m.num_coordinates()));
  EXPECT_EQ(rows.z.back(), v.tail(m.num_speeds()));
  // The values written at an output are the law's at that output's state.
  VectorX at_end(3);
  law(1.0, rows.q.back(), rows.z.back(), at_end);
  EXPECT_EQ(rows.u.back(), at_end);
}

// dopri5 never steps across a row's time: every row time inside the run is an accepted step's
// end. The rows' values are in force from their times on.
TEST(Inputs, Dopri5RestartsAtEveryRow) {
  const io::ModelFile f = io::parse_model_file(kCart, "cart.yaml");
  MatrixX v(4, 3);
  v << 1, 0, 0, -2, 1, 0, 0, 0, 3, 5, 5, 5;
  SimulationSettings s = short_run(Integrator::dopri5);
  s.inputs = std::make_shared<const InputTable>(std::vector<double>{0.0, 0.123, 0.5, 0.7777}, v);
  std::vector<double> steps;
  s.on_step = [&](double t) {
    steps.push_back(t);
    return true;
  };
  Rows rows;
  ASSERT_TRUE(simulate(f.model, f.q, f.z, s, recorder(rows)).ok());
  for (const double row : {0.123, 0.5, 0.7777})
    EXPECT_NE(std::find(steps.begin(), steps.end(), row), steps.end()) << row;
  ASSERT_EQ(rows.t.size(), 11u);
  EXPECT_EQ(rows.u[5], v.row(2).transpose());  // t = 0.5: that row's values
  EXPECT_EQ(rows.u[4], v.row(1).transpose());
  EXPECT_EQ(rows.u[10], v.row(3).transpose());
}

// A controller that throws ends the run as a failure, keeping the outputs before it.
TEST(Inputs, ControllerFailureStopsTheRun) {
  const io::ModelFile f = io::parse_model_file(kCart, "cart.yaml");
  for (const double interval : {0.0, 0.05}) {
    SimulationSettings s = short_run(Integrator::dopri5);
    s.control_interval = interval;
    s.controller = [](double t, const VectorX&, const VectorX&, Eigen::Ref<VectorX> u) {
      if (t > 0.42) throw std::runtime_error("sensor lost");
      u.setZero();
    };
    Rows rows;
    const SimulationStats st = simulate(f.model, f.q, f.z, s, recorder(rows));
    EXPECT_EQ(st.status, SimulationStatus::controller_error);
    EXPECT_NE(st.message.find("sensor lost"), std::string::npos) << st.message;
    EXPECT_LE(st.t_reached, 0.45);
    EXPECT_GE(rows.t.size(), 4u);
    EXPECT_LE(rows.t.back(), 0.42);
    EXPECT_TRUE(std::isfinite(st.energy_final));
  }
  SimulationSettings both = short_run(Integrator::rk4);
  both.controller = [](double, const VectorX&, const VectorX&, Eigen::Ref<VectorX>) {};
  both.inputs = std::make_shared<const InputTable>(std::vector<double>{0.0}, MatrixX::Zero(1, 3));
  EXPECT_THROW(simulate(f.model, f.q, f.z, both), std::invalid_argument);
}

// Both routes of Dynamics (the articulated-body recursion, with its spherical joints in body
// axes, and the projected equations in tree order) against the dense projected equations, with
// an input of each type on random models of every joint type: 1e-9 relative (the condition of
// random mass matrices; the routes agree to round-off without inputs, at the same tolerance
// in test_joint_dynamics.cpp).
TEST(Inputs, EveryRouteTakesThem) {
  std::mt19937 rng(14);
  for (int trial = 0; trial < 30; ++trial) {
    const Model base = random_jointed(rng, false);
    for (int t = 0; t < 3; ++t) {
      Input in;
      in.name = "u";
      std::mt19937 r2(static_cast<unsigned>(trial * 7 + t));
      if (!random_input(base, r2, static_cast<InputType>(t), in)) continue;
      const Model m = rebuilt(base, base.forces(), {in});
      VectorX q, z;
      random_joint_state(m, r2, q, z);
      const VectorX u = VectorX::Constant(1, 2.0);
      Data data(m);
      data.inputs = u;
      const VectorX ref = projected_equations(m, q, z, data).zdot;
      for (const Route route : {Route::recursive, Route::assembled}) {
        Dynamics d(m, route);
        VectorX zd(m.num_speeds());
        d.forward(q, z, u, zd);
        EXPECT_LE((zd - ref).cwiseAbs().maxCoeff(), 1e-9 * (1 + ref.cwiseAbs().maxCoeff()))
            << trial << " type " << t << " route " << to_string(route);
      }
    }
  }
}

// Inverse dynamics counts the inputs among the model's own loads: at the z dot forward dynamics
// gives with inputs u, the Q still needed is zero (1e-12 of the largest generalized force), and
// without u it is the inputs' generalized forces.
TEST(Inputs, InverseDynamicsCountsThem) {
  std::mt19937 rng(15);
  for (int trial = 0; trial < 30; ++trial) {
    const Model base = random_jointed(rng, true);
    std::vector<Input> inputs;
    for (int t = 0; t < 3; ++t) {
      Input in;
      in.name = "u" + std::to_string(t);
      if (random_input(base, rng, static_cast<InputType>(t), in)) inputs.push_back(in);
    }
    const Model m = rebuilt(base, base.forces(), inputs);
    VectorX q, z;
    random_joint_state(m, rng, q, z);
    VectorX u(m.num_inputs());
    for (int i = 0; i < u.size(); ++i) u[i] = uniform(rng, -5, 5);
    const VectorX zdot = zdot_of(m, q, z, u);
    Terms terms(m);
    VectorX Q(m.num_speeds()), Q0(m.num_speeds());
    terms.inverse_dynamics(q, z, zdot, Q, &u);
    terms.inverse_dynamics(q, z, zdot, Q0);
    Data data(m);
    const VectorX f0 = projected_equations(m, q, z, data).f_z;
    data.inputs = u;
    const VectorX f_u = projected_equations(m, q, z, data).f_z;
    const double scale = std::max(1.0, f0.cwiseAbs().maxCoeff());
    EXPECT_LE(Q.cwiseAbs().maxCoeff(), 1e-12 * scale) << trial;
    EXPECT_LE((Q0 - (f_u - f0)).cwiseAbs().maxCoeff(), 1e-12 * scale) << trial;
  }
}

}  // namespace
}  // namespace kanedyn
