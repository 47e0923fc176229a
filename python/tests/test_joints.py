"""Jointed models from Python: the joint coordinates as columns (r["pendulum.j1"]), the CSV bit
for bit as the tool writes it and read back, eom's projected equations as the tool prints them,
joint_derivatives against finite differences of a run, and the refusal of a notes' state where
the joints have coordinates of their own."""

from __future__ import annotations

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES, run_tool, tool_json

JOINTED = ["cart_pendulum.yaml", "human_jointed.yaml"]


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    a = np.ascontiguousarray(a, dtype=np.float64)
    b = np.ascontiguousarray(b, dtype=np.float64)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def test_the_model_describes_its_joints() -> None:
    m = kanedyn.load(EXAMPLES / "human_jointed.yaml")
    assert m.jointed
    assert m.joint_types == ["free", "revolute", "universal", "universal", "spherical", "spherical", "spherical", "revolute"]
    layout = m.joint_layout
    assert layout["torso"] == (0, 7, 0, 6)
    assert layout["pelvis"] == (7, 1, 6, 1)
    assert layout["head"][1] == 4 and layout["head"][3] == 3
    assert len(m.initial_joint_coordinates) == 7 + 1 + 2 + 2 + 4 + 4 + 4 + 1
    assert len(m.initial_joint_speeds) == 6 + 1 + 2 + 2 + 3 + 3 + 3 + 1
    assert m.initial_joint_coordinates[layout["pelvis"][0]] == -0.087
    assert "pelvis.j1" in m.columns and "head.jd3" in m.columns and "torso.j1" not in m.columns
    free = kanedyn.load(EXAMPLES / "eight_body.yaml")
    assert not free.jointed and free.joint_types == ["free"] * 8
    assert list(free.joint_layout.values()) == [(7 * k, 7, 6 * k, 6) for k in range(8)]
    assert len(free.initial_joint_coordinates) == 56 and len(free.initial_joint_speeds) == 48


@pytest.mark.parametrize("name", JOINTED)
def test_simulate_writes_the_tools_csv_and_reads_it_back(name: str, tmp_path) -> None:
    m = kanedyn.load(EXAMPLES / name)
    done = run_tool(["simulate", EXAMPLES / name, "--t-end", "0.5", "--dt-out", "0.05", "-o", tmp_path / "tool.csv"])
    assert done.returncode == 0, done.stderr
    r = m.simulate(t_end=0.5, dt_out=0.05, output=tmp_path / "streamed.csv")
    r.to_csv(tmp_path / "stored.csv")
    tool_bytes = (tmp_path / "tool.csv").read_bytes()
    assert (tmp_path / "streamed.csv").read_bytes() == tool_bytes
    assert (tmp_path / "stored.csv").read_bytes() == tool_bytes
    back = kanedyn.read_csv(m, tmp_path / "tool.csv")
    for key in ("t", "x", "y", "p_G", "energy", "q", "z"):
        assert same_bits(getattr(back, key), getattr(r, key)), key
    assert same_bits(back.table(), r.table())
    assert r.table().shape == (11, len(m.columns))


def test_joint_columns_are_the_joint_coordinates() -> None:
    m = kanedyn.load(EXAMPLES / "cart_pendulum.yaml")
    r = m.simulate(t_end=1.0, dt_out=0.1)
    assert r["pendulum.j1"][0] == 0.5
    assert same_bits(r["pendulum.j1"], r.q[:, 1])
    assert same_bits(r["cart.jd1"], r.z[:, 0])
    # The cart slides along the inertial x axis: its s'_1 is its joint coordinate.
    assert same_bits(r["cart.s1"], r["cart.j1"])
    with pytest.raises(KeyError, match="did you mean"):
        r["pendulum.j2"]


@pytest.mark.parametrize("name", JOINTED)
def test_eom_has_the_tools_projected_equations(name: str) -> None:
    m = kanedyn.load(EXAMPLES / name)
    printed = tool_json(["eom", EXAMPLES / name, "--json"])
    e = m.eom()
    assert printed["n"] == e.n == len(m.initial_joint_speeds)
    for key in ("A", "f", "ydot", "xdot", "C", "A_z", "f_z", "zdot"):
        assert same_bits(np.array(printed[key]), getattr(e, key)), key
    # z dot solves A_z z dot = f_z, and is joint_derivatives' z dot at the initial state.
    assert np.allclose(e.A_z @ e.zdot, e.f_z, rtol=1e-12, atol=1e-12 * np.abs(e.f_z).max())
    qdot, zdot = m.joint_derivatives(route="assembled")
    assert np.allclose(zdot, e.zdot, rtol=1e-10, atol=1e-10 * np.abs(e.zdot).max())
    assert kanedyn.load(EXAMPLES / "eight_body.yaml").eom().n is None


@pytest.mark.parametrize("name", JOINTED)
def test_inspect_has_the_tools_joints(name: str) -> None:
    m = kanedyn.load(EXAMPLES / name)
    printed = tool_json(["inspect", EXAMPLES / name, "--json"])["joints"]
    j = m.inspect().joints
    assert printed["n"] == j.n == len(m.initial_joint_speeds)
    for key in ("q", "z", "C", "Cdot_z", "A_z", "f_z", "zdot", "ydot"):
        assert same_bits(np.array(printed[key]), getattr(j, key)), key
    assert [b["K"] for b in printed["bodies"]] == [b.K for b in j.bodies] == list(range(1, m.N + 1))
    for p, b in zip(printed["bodies"], j.bodies):
        assert p["type"] == b.type == m.joint_types[b.K - 1]
        for key in ("q", "z", "C_w", "C_sd"):
            assert same_bits(np.array(p[key]).reshape(getattr(b, key).shape), getattr(b, key)), key
    one = m.inspect(bodies=[2]).joints
    assert [b.K for b in one.bodies] == [2] and same_bits(one.A_z, j.A_z)
    assert kanedyn.load(EXAMPLES / "eight_body.yaml").inspect().joints is None


def test_inspect_at_a_runs_joint_state_gives_its_rates() -> None:
    m = kanedyn.load(EXAMPLES / "cart_pendulum.yaml")
    h = 1e-4
    r = m.simulate(t_end=2 * h, dt_out=h, integrator="rk4", step=h / 10)
    j = m.inspect(q=r.q[1], z=r.z[1]).joints
    assert same_bits(j.q, r.q[1]) and same_bits(j.z, r.z[1])
    _, zdot = m.joint_derivatives(r.q[1], r.z[1], route="assembled")
    assert np.allclose(j.zdot, zdot, rtol=1e-10, atol=1e-12)
    # The jointed y dot against central differences of the run's y (truncation ~h^2/6 times the
    # third derivative, O(100) here: 2e-7).
    assert np.allclose((r.y[2] - r.y[0]) / (2 * h), j.ydot, atol=1e-6)
    s = m.initial_state()
    assert same_bits(m.inspect(s).joints.zdot, m.inspect().joints.zdot)
    with pytest.raises(ValueError, match="joint coordinates"):
        m.inspect(kanedyn.State(s.x, s.y))
    with pytest.raises(ValueError, match=r"\(56,\)"):
        kanedyn.load(EXAMPLES / "eight_body.yaml").inspect(q=[1.0])
    with pytest.raises(ValueError):
        m.inspect(q=[0.0])


def test_joint_derivatives_match_finite_differences_of_a_run() -> None:
    m = kanedyn.load(EXAMPLES / "cart_pendulum.yaml")
    h = 1e-4
    r = m.simulate(t_end=2 * h, dt_out=h, integrator="rk4", step=h / 10)
    qdot, zdot = m.joint_derivatives(r.q[1], r.z[1])
    # Central differences: truncation h^2/6 times the third derivative (O(100) here) = 2e-7.
    assert np.allclose((r.q[2] - r.q[0]) / (2 * h), qdot, atol=1e-6)
    assert np.allclose((r.z[2] - r.z[0]) / (2 * h), zdot, atol=1e-6)
    # The two routes agree to round-off.
    _, assembled = m.joint_derivatives(r.q[1], r.z[1], route="assembled")
    assert np.allclose(assembled, zdot, rtol=1e-10, atol=1e-12)


def test_a_notes_state_is_refused_where_the_joints_have_coordinates() -> None:
    # x and y give no angle of the pendulum's revolute joint: every call refuses them, naming
    # the body; the model's own State (its joint coordinates) is taken.
    m = kanedyn.load(EXAMPLES / "cart_pendulum.yaml")
    s = m.initial_state()
    notes = kanedyn.State(s.x, s.y)
    for call in (m.derivatives, m.eom, m.inspect, m.energy, m.momentum, m.joint_derivatives,
                 lambda state: m.simulate(initial=state, t_end=0.1)):
        with pytest.raises(ValueError, match="body 'cart' has a prismatic joint"):
            call(notes)
    assert same_bits(m.derivatives(s)[1], m.derivatives(s.q, s.z)[1])
    with pytest.raises(ValueError, match="unit norm"):
        h = kanedyn.load(EXAMPLES / "human_jointed.yaml")
        q = h.initial_joint_coordinates.copy()
        q[h.joint_layout["head"][0]] = 0.5
        h.joint_derivatives(q)


@pytest.mark.parametrize("name", JOINTED)
def test_energy_is_the_csv_energy_column_with_the_joint_springs(name: str, tmp_path) -> None:
    # Both models have joint springs (examples: cart_pendulum's on the cart, human_jointed's on
    # the pelvis and a hip): their potentials are in the tool's energy column, and
    # Model.energy at a row's (q, z) gives that column's number, bit for bit (the row's q and z
    # read back to the same doubles, and the energy is the same function of them).
    m = kanedyn.load(EXAMPLES / name)
    done = run_tool(["simulate", EXAMPLES / name, "--t-end", "0.3", "--dt-out", "0.1", "-o", tmp_path / "run.csv"])
    assert done.returncode == 0, done.stderr
    back = kanedyn.read_csv(m, tmp_path / "run.csv")
    springs = 0.0
    for i in range(len(back.t)):
        kinetic, potential, total = m.energy(q=back.q[i], z=back.z[i])
        assert total == back.energy[i], i
        assert total == kinetic + potential
        springs = max(springs, abs(total))
    assert springs > 0.0
    # The notes' state alone does not give the joint coordinates: refused, naming the body.
    s = m.initial_state()
    with pytest.raises(ValueError, match="joint coordinates q"):
        m.energy(kanedyn.State(s.x, s.y))
    with pytest.raises(ValueError, match="not both"):
        m.energy(s, q=back.q[0])
    assert m.energy(m.state(q=back.q[1], z=back.z[1]))[2] == back.energy[1]


def test_energy_of_the_joint_springs_is_their_potential() -> None:
    # cart_pendulum: joint_spring of stiffness 5 on the cart's prismatic coordinate (rest 0).
    # Moving the cart by d changes only the spring's potential: 1/2 5 d^2 (the cart slides
    # along its horizontal axis, so gravity's potential does not change).
    m = kanedyn.load(EXAMPLES / "cart_pendulum.yaml")
    q = m.initial_joint_coordinates.copy()
    z = np.zeros_like(m.initial_joint_speeds)
    q[0] = 0.0
    _, v0, _ = m.energy(q=q, z=z)
    q[0] = 0.3
    _, v1, _ = m.energy(q=q, z=z)
    assert v1 - v0 == pytest.approx(0.5 * 5.0 * 0.3**2, rel=1e-12)


def test_energy_of_an_all_free_model_from_its_state_or_its_coordinates() -> None:
    m = kanedyn.load(EXAMPLES / "eight_body.yaml")
    s = m.initial_state()
    q = np.concatenate([np.concatenate([s.x[4 * k:4 * k + 4], s.x[32 + 3 * k:32 + 3 * k + 3]]) for k in range(8)])
    z = np.concatenate([np.concatenate([s.y[3 * k:3 * k + 3], s.y[24 + 3 * k:24 + 3 * k + 3]]) for k in range(8)])
    assert m.energy(s) == m.energy(q=q, z=z) == m.energy()
    p1, h1 = m.momentum(s)
    p2, h2 = m.momentum(q=q, z=z)
    assert same_bits(p1, p2) and same_bits(h1, h2)


def test_the_jointed_double_pendulum_swings_as_the_one_on_bushings() -> None:
    # examples/double_pendulum_jointed.yaml is examples/double_pendulum.yaml with hinges for its
    # stiff bushings: the same initial pose to round-off, and over the first second the same
    # swing to within the bushings' stretch (at most about 0.3 mm at 1e6 N/m, the file says;
    # 1 mm allows for the chaotic swing's growth of that difference), in far fewer steps (the
    # bushings' 1e6 N/m sets their step).
    bushings = kanedyn.load(EXAMPLES / "double_pendulum.yaml")
    hinges = kanedyn.load(EXAMPLES / "double_pendulum_jointed.yaml")
    assert np.abs(bushings.initial_state().x - hinges.initial_state().x).max() < 1e-15
    a = bushings.simulate(t_end=1.0, dt_out=0.1)
    b = hinges.simulate(t_end=1.0, dt_out=0.1)
    assert np.abs(a.p_G - b.p_G).max() < 1e-3
    assert len(b.z[0]) == 2 and 10 * b.stats["steps_accepted"] < a.stats["steps_accepted"]
