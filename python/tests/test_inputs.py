"""Inputs from Python: u in every evaluation against the tool's eom --input, input tables and
controllers in simulate against the tool's simulate --inputs, the Simulator's steps against
simulate, and the terms of the equations of motion (inverse dynamics, mass matrix, ...)."""

from __future__ import annotations

import pathlib
from typing import List

import numpy as np
import pytest

import kanedyn
from conftest import run_tool, tool_json

# A cart on a rail carrying a pendulum, with a joint, a force and a torque input, and a frame at
# the pole's mass centre (where the force acts) for the Jacobian checks.
CART = """format: kanedyn-model/1
name: cart_pole
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
    initial: {joint: [0.5], joint_rate: [0.2]}
frames:
  - {name: pole_com, body: pole, at: [0, 0, -0.3]}
inputs:
  - {name: push, type: joint, body: cart}
  - {name: thrust, type: force, body: pole, direction: [1, 0, 0]}
  - {name: twist, type: torque, body: pole, axis: [0, 1, 0], reaction: true}
"""

# Two free bodies on a bushing, driven by a force and a torque: the notes' layout.
FREE = """format: kanedyn-model/1
name: free_pair
gravity: [0, 0, -9.81]
bodies:
  - {name: base, parent: ground, mass: 3, inertia: [0.1, 0.2, 0.3]}
  - name: arm
    parent: base
    mass: 1
    inertia: [0.05, 0.04, 0.03]
    joint: [0.2, 0, 0]
    initial: {angular_velocity: [0.3, -0.2, 0.5]}
forces:
  - {type: bushing, body: arm, stiffness: 400, damping: 2, rotational_stiffness: 30,
     rotational_damping: 0.1}
inputs:
  - {name: lift, type: force, body: base, direction: [0, 0, 1]}
  - {name: spin, type: torque, body: arm, axis: [0, 0, 1], reaction: true}
"""

# dt a power of two: i * dt, and the sum of i steps of dt, are the same doubles, so that the
# control instants, the table's rows, the output times and the Simulator's times agree exactly.
DT = 1.0 / 64.0


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    a = np.ascontiguousarray(a, dtype=np.float64)
    b = np.ascontiguousarray(b, dtype=np.float64)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def write_model(tmp_path: pathlib.Path, text: str, name: str) -> pathlib.Path:
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return path


@pytest.fixture(params=["cart", "free"])
def model_file(request, tmp_path) -> pathlib.Path:
    return write_model(tmp_path, CART if request.param == "cart" else FREE, request.param)


def values_at(m: int, i: int) -> np.ndarray:
    """The inputs of step i: smooth in i, with jumps between steps."""
    return np.array([3.0 * np.sin(0.7 * i + 1.3 * j) + 0.5 * j for j in range(m)])


def write_inputs_csv(path: pathlib.Path, names: List[str], t: np.ndarray, U: np.ndarray) -> None:
    # repr() gives the shortest decimal that reads back as the same double.
    lines = [",".join(["t", *names])]
    lines += [",".join(repr(float(v)) for v in (ti, *row)) for ti, row in zip(t, U)]
    path.write_text("\n".join(lines) + "\n")


def test_model_lists_its_inputs(model_file) -> None:
    m = kanedyn.load(model_file)
    assert m.inputs == (["push", "thrust", "twist"] if m.jointed else ["lift", "spin"])
    assert m.columns[-len(m.inputs) :] == [f"input.{name}" for name in m.inputs]


def test_eom_with_u_equals_the_tools_input_option(model_file) -> None:
    m = kanedyn.load(model_file)
    u = np.array([1.5, -0.7, 0.3][: len(m.inputs)])
    flags = [f for name, v in zip(m.inputs, u) for f in ("--input", f"{name}={v!r}")]
    printed = tool_json(["eom", model_file, "--json", *flags])
    assert printed["inputs"] == m.inputs and printed["u"] == u.tolist()
    e = m.eom(u=u)
    for key in ("A", "f", "ydot", "xdot") + (("A_z", "f_z", "zdot") if m.jointed else ()):
        assert same_bits(np.array(printed[key]), getattr(e, key)), key
    # The inputs change the equations: with u = 0 the tool's numbers differ.
    assert not same_bits(np.array(printed["f"]), m.eom().f)
    # The O(N) routes agree with the assembled equations to round-off: 1e-12 relative to the
    # largest rate, a few hundred ulp of the sums of a two-body model.
    s = m.initial_state()
    zdot_tool = np.array(printed["zdot"] if m.jointed else printed["ydot"])
    scale = np.abs(zdot_tool).max()
    _, rate = m.derivatives(s, u=u)
    np.testing.assert_allclose(rate, zdot_tool, rtol=0, atol=1e-12 * scale)
    _, zdot = m.joint_derivatives(s, u=u)
    zdot_assembled = m.joint_derivatives(s, route="assembled", u=u)[1]
    np.testing.assert_allclose(zdot, zdot_assembled, rtol=0, atol=1e-12 * scale)
    assert same_bits(m.forward(s, u), zdot)  # the same kernel
    assert same_bits(m.forward(s.q, s.z, u=u), zdot)
    if m.jointed:
        assert same_bits(m.derivatives(s.q, s.z, u=u)[1], zdot)
    inspected = m.inspect(s, u=u)
    ydot_tool = np.array(printed["ydot"])
    np.testing.assert_allclose(inspected.ydot, ydot_tool, rtol=0, atol=1e-12 * np.abs(ydot_tool).max())


def test_pooled_workspaces_forget_the_inputs_of_earlier_calls(model_file) -> None:
    m = kanedyn.load(model_file)
    s = m.initial_state()
    before = m.derivatives(s)[1]
    m.derivatives(s, u=np.full(len(m.inputs), 5.0))
    assert same_bits(m.derivatives(s)[1], before)
    assert same_bits(m.forward(s), before if m.jointed else m.joint_derivatives(s)[1])


def test_derivatives_batch_takes_the_inputs_of_each_state(model_file) -> None:
    # Row i of a batch with U equals one call with u=U[i], bit for bit, on every thread count.
    m = kanedyn.load(model_file)
    s = m.initial_state()
    rng = np.random.default_rng(5)
    rows, mu = 6, len(m.inputs)
    x, y = (s.q, s.z) if m.jointed else (s.x, s.y)
    X = np.tile(x, (rows, 1))
    Y = np.tile(y, (rows, 1)) + rng.uniform(-1, 1, (rows, len(y)))
    U = rng.uniform(-3, 3, (rows, mu))
    for threads in (1, 3):
        Xd, Yd = m.derivatives_batch(X, Y, threads=threads, U=U)
        for i in range(rows):
            xd, yd = m.derivatives(X[i], Y[i], u=U[i])
            assert same_bits(Xd[i], xd) and same_bits(Yd[i], yd), (threads, i)
    assert not same_bits(m.derivatives_batch(X, Y)[1], Yd)  # the inputs act
    with pytest.raises(ValueError, match="U"):
        m.derivatives_batch(X, Y, U=U[:, :-1])


@pytest.mark.parametrize("hold", ["zero-order", "linear"])
def test_simulate_with_an_input_table_equals_the_tools_csv(model_file, tmp_path, hold) -> None:
    m = kanedyn.load(model_file)
    t = np.array([0.0, 0.13, 0.3, 0.41])
    U = np.array([values_at(len(m.inputs), i) for i in range(len(t))])
    write_inputs_csv(tmp_path / "u.csv", m.inputs, t, U)
    flags = ["--t-end", "0.5", "--dt-out", "0.02", "--inputs", tmp_path / "u.csv", "--inputs-hold", hold]
    done = run_tool(["simulate", model_file, "-o", tmp_path / "tool.csv", *flags])
    assert done.returncode == 0, done.stderr
    r = m.simulate(t_end=0.5, dt_out=0.02, inputs=(t, U), inputs_hold=hold, output=tmp_path / "py.csv")
    tool_bytes = (tmp_path / "tool.csv").read_bytes()
    assert (tmp_path / "py.csv").read_bytes() == tool_bytes
    r.to_csv(tmp_path / "written.csv")
    assert (tmp_path / "written.csv").read_bytes() == tool_bytes
    back = kanedyn.read_csv(m, tmp_path / "tool.csv")
    for key in ("t", "x", "y", "energy", "u") + (("q", "z") if m.jointed else ()):
        assert same_bits(getattr(back, key), getattr(r, key)), key
    assert same_bits(back.table(), r.table())
    # The rows before the first jump hold its values; the column reads the same numbers.
    assert same_bits(r["input." + m.inputs[0]], r.u[:, 0])
    assert r.u[0].tolist() == U[0].tolist()


def test_a_controller_at_an_interval_equals_the_table_of_its_values(model_file) -> None:
    m = kanedyn.load(model_file)
    count = len(m.inputs)
    seen: List[float] = []

    def controller(t: float, state: kanedyn.State) -> np.ndarray:
        assert isinstance(state, kanedyn.State)
        seen.append(t)
        return values_at(count, round(t / DT))

    settings = dict(t_end=24 * DT, dt_out=DT)
    driven = m.simulate(controller=controller, control_interval=DT, **settings)
    assert seen == [i * DT for i in range(24)]  # once per instant, never at t_end
    t = np.arange(24) * DT
    U = np.array([values_at(count, i) for i in range(24)])
    tabled = m.simulate(inputs=(t, U), **settings)
    for key in ("t", "x", "y", "energy", "u") + (("q", "z") if m.jointed else ()):
        assert same_bits(getattr(driven, key), getattr(tabled, key)), key
    assert driven.stats["evaluations"] == tabled.stats["evaluations"]


def test_a_controller_at_every_evaluation_sees_the_stage_states(model_file) -> None:
    m = kanedyn.load(model_file)
    calls = []

    def controller(t: float, state: kanedyn.State) -> np.ndarray:
        calls.append(t)
        return -0.5 * np.resize(state.z, len(m.inputs))  # a damping law of the state alone

    r = m.simulate(t_end=0.1, dt_out=0.05, integrator="rk4", step=0.01, controller=controller)
    # rk4: 4 evaluations per step, 10 steps, and one call per output row for its values.
    assert len(calls) == 4 * 10 + len(r)
    assert r.stats["evaluations"] == 40


def test_a_raising_controller_stops_the_run_and_keeps_the_rows(model_file, tmp_path) -> None:
    m = kanedyn.load(model_file)

    class Refused(Exception):
        pass

    def controller(t: float, state: kanedyn.State) -> np.ndarray:
        if t > 0.1:
            raise Refused("no more control")
        return np.zeros(len(m.inputs))

    with pytest.raises(kanedyn.SimulationError) as info:
        m.simulate(t_end=0.5, dt_out=0.02, controller=controller, control_interval=0.02, output=tmp_path / "run.csv")
    error = info.value
    assert isinstance(error.__cause__, Refused)
    assert "no more control" in str(error) and "Refused" in str(error)
    assert error.stats["status"] == "controller error"
    # The rows up to the last instant it answered (t = 0.1, the sixth), which the partial file
    # holds too.
    assert len(error.result) == 6 and error.result.t[-1] == pytest.approx(0.1, abs=1e-12)
    assert not (tmp_path / "run.csv").exists()
    kept = (tmp_path / "run.csv.partial").read_text().splitlines()
    assert len(kept) == 1 + len(error.result)
    assert "run.csv.partial" in str(error)


def test_a_controller_returning_a_wrong_value_is_a_chained_value_error(model_file) -> None:
    m = kanedyn.load(model_file)
    with pytest.raises(kanedyn.SimulationError) as info:
        m.simulate(t_end=0.1, controller=lambda t, s: np.zeros(7), control_interval=0.05)
    assert isinstance(info.value.__cause__, ValueError)
    assert "the controller's value must have shape" in str(info.value)


def test_simulator_steps_equal_simulate(model_file) -> None:
    m = kanedyn.load(model_file)
    count = len(m.inputs)
    n = 24
    t = np.arange(n) * DT
    U = np.array([values_at(count, i) for i in range(n)])
    for integrator in ("rk4", "dopri5"):
        r = m.simulate(t_end=n * DT, dt_out=DT, step=DT, integrator=integrator, rtol=1e-9, atol=1e-11, inputs=(t, U))
        sim = kanedyn.Simulator(m, integrator=integrator, dt=DT, rtol=1e-9, atol=1e-11)
        q0, z0 = (r.q[0], r.z[0]) if m.jointed else (r.state(0).q, r.state(0).z)
        assert same_bits(sim.q, q0) and same_bits(sim.z, z0)
        for i in range(n):
            assert sim.step(U[i]) is None
            assert sim.t == r.t[i + 1]
            if m.jointed:
                assert same_bits(sim.q, r.q[i + 1]) and same_bits(sim.z, r.z[i + 1]), (integrator, i)
            else:
                assert same_bits(sim.state.x, r.x[i + 1]) and same_bits(sim.state.y, r.y[i + 1]), (integrator, i)
        assert same_bits(sim.inputs, U[-1])
        assert sim.evaluations == r.stats["evaluations"]


def test_simulator_takes_arrays_in_place_and_refuses_bad_ones(model_file) -> None:
    m = kanedyn.load(model_file)
    count = len(m.inputs)
    a = kanedyn.Simulator(m, dt=DT)
    b = kanedyn.Simulator(m)
    wide = np.zeros((count, 3))
    wide[:, 1] = values_at(count, 2)
    a.step(np.ascontiguousarray(wide[:, 1]))
    b.step(wide[:, 1], DT)  # a strided view
    assert same_bits(a.q, b.q) and same_bits(a.z, b.z)
    b.step(list(values_at(count, 3)), dt=DT)  # a list is converted
    with pytest.raises(ValueError, match="shape"):
        a.step(np.zeros(count + 1))
    with pytest.raises(TypeError, match="float64"):
        a.step(np.zeros(count, dtype=np.float32))
    with pytest.raises(ValueError, match="not finite"):
        a.step(np.full(count, np.nan))
    with pytest.raises(ValueError, match="dt"):
        a.step(np.zeros(count), 0.0)
    with pytest.raises(TypeError, match="dt"):
        b.step(np.zeros(count))  # no default dt
    t = a.t
    with pytest.raises(kanedyn.SimulationError, match="body '"):
        a.step(np.full(count, 1e300))
    assert a.t == t  # the failed step was not taken
    with pytest.raises(ValueError, match="unknown integrator|integrator"):
        kanedyn.Simulator(m, integrator="euler")
    a.set_state(m.initial_state(), t=0.0)
    assert a.t == 0.0 and same_bits(a.q, kanedyn.Simulator(m).q)


def test_input_errors(model_file) -> None:
    m = kanedyn.load(model_file)
    count = len(m.inputs)
    with pytest.raises(ValueError, match=r"u must have shape \(m,\)"):
        m.derivatives(m.initial_state(), u=np.zeros(count + 1))
    with pytest.raises(ValueError, match="u must have shape"):
        m.forward(m.initial_state(), np.zeros(count - 1))
    with pytest.raises(ValueError, match="inf"):
        m.eom(u=np.full(count, np.inf))
    t, U = np.array([0.0, 0.1]), np.zeros((2, count))
    with pytest.raises(ValueError, match="zero-order"):
        m.simulate(t_end=0.2, inputs=(t, U), inputs_hold="cubic")
    with pytest.raises(ValueError, match="inputs_hold"):
        m.simulate(t_end=0.2, inputs_hold="linear")
    with pytest.raises(ValueError, match="not both"):
        m.simulate(t_end=0.2, inputs=(t, U), controller=lambda t, s: np.zeros(count))
    with pytest.raises(ValueError, match="increase"):
        m.simulate(t_end=0.2, inputs=(t[::-1], U))
    with pytest.raises(ValueError, match=r"inputs U must have shape"):
        m.simulate(t_end=0.2, inputs=(t, np.zeros((2, count + 1))))
    with pytest.raises(TypeError, match="callable"):
        m.simulate(t_end=0.2, controller=3)


def test_inverse_dynamics_of_forward_gives_the_inputs_generalized_forces(tmp_path) -> None:
    m = kanedyn.load(write_model(tmp_path, CART, "cart"))
    s = m.state(q=[0.1, 0.7], z=[0.3, -0.4])
    u = np.array([1.7, -2.3, 0.9])
    zdot = m.forward(s, u)
    Q = m.inverse_dynamics(s, zdot)
    # Independently: a joint input is its speed's generalized force; the force acts at the
    # frame pole_com along the pole's x axis (Q = Jv^T F); the torque about the revolute axis
    # (the reaction on the cart does no work on its slide).
    Jv, _ = m.jacobian("pole_com", s)
    F = m.frame("pole_com", s)["R"].T @ np.array([u[1], 0.0, 0.0])
    expected = Jv.T @ F + np.array([u[0], u[2]])
    # Round-off of an O(N) pass on numbers of order 10: 1e-12 relative.
    scale = np.abs(expected).max()
    np.testing.assert_allclose(Q, expected, rtol=0, atol=1e-12 * scale)
    # With u among the model's own loads, the motion it gives needs no more force.
    np.testing.assert_allclose(m.inverse_dynamics(s, zdot, u=u), 0.0, atol=1e-12 * scale)
    # M zdot + b = Q, and b(q, 0) = g(q) with no other loads (the cart has no force elements).
    M = m.mass_matrix(s)
    np.testing.assert_allclose(M @ zdot + m.bias_forces(s, u=u), 0.0, atol=1e-12 * scale)
    rest = m.state(q=s.q)
    assert np.allclose(m.bias_forces(rest), m.gravity_forces(rest.q), rtol=0, atol=1e-12 * scale)


def test_mass_matrix_equals_eoms_A_z(tmp_path) -> None:
    m = kanedyn.load(write_model(tmp_path, CART, "cart"))
    s = m.state(q=[0.1, 0.7], z=[0.3, -0.4])
    A_z = m.eom(s).A_z
    M = m.mass_matrix(s)
    # Composite bodies against [C]^T [A] [C]: round-off of sums of a few terms, 1e-13 of the
    # largest entry.
    np.testing.assert_allclose(M, A_z, rtol=0, atol=1e-13 * np.abs(A_z).max())
    assert same_bits(M, M.T)
    assert same_bits(m.mass_matrix(s.q), M)


def test_centre_of_mass_and_frame_acceleration(tmp_path) -> None:
    m = kanedyn.load(write_model(tmp_path, CART, "cart"))
    s = m.state(q=[0.1, 0.7], z=[0.3, -0.4])
    p, v = m.centre_of_mass(s)
    inspected = m.inspect(s)
    weighted = sum(mass * b.p_G for mass, b in zip(m.mass, inspected.bodies)) / m.total_mass
    np.testing.assert_allclose(p, weighted, rtol=0, atol=1e-15)
    J = m.centre_of_mass_jacobian(s)
    np.testing.assert_allclose(v, J @ s.z, rtol=0, atol=1e-15)
    # At rest the acceleration of a point is its Jacobian times z dot (the J dot z term is 0).
    rest = m.state(q=s.q)
    zdot = np.array([0.8, -1.1])
    a = m.frame_acceleration("pole_com", rest, zdot)
    Jv, Jw = m.jacobian("pole_com", rest)
    np.testing.assert_allclose(a["linear"], Jv @ zdot, rtol=0, atol=1e-14)
    np.testing.assert_allclose(a["angular"], Jw @ zdot, rtol=0, atol=1e-14)
    with pytest.raises(KeyError, match="pole_com"):
        m.frame_acceleration("pole_cm", rest, zdot)


def test_a_simulator_stepped_from_two_threads_refuses_the_overlap() -> None:
    import threading

    from conftest import EXAMPLES

    # 64 bodies: steps run without the GIL, so the two threads can overlap; a step that would
    # race the other's is refused, and every step taken counts once in the time reached.
    m = kanedyn.load(EXAMPLES / "chain64.yaml")
    sim = kanedyn.Simulator(m, dt=1.0 / 1024.0)
    u = np.zeros(0)
    done = threading.Event()
    taken = [0]

    def other() -> None:
        sim._time_steps(u, 1.0 / 1024.0, 400)
        done.set()

    thread = threading.Thread(target=other)
    thread.start()
    refused = 0
    while not done.is_set():
        try:
            sim.step(u)
            taken[0] += 1
        except RuntimeError as e:
            assert "another thread" in str(e)
            refused += 1
    thread.join()
    assert sim.t == (400 + taken[0]) / 1024.0
