"""One state for every model: a State built from joint coordinates, taken by every call, and
the tool's numbers bit for bit at that state.

The tool reads its state from a model file, so the URDF arm is imported (`kanedyn import`) and
the user's joint coordinates are written into the file as each body's `initial.joint` and
`initial.joint_rate` (shortest round-trip decimals: the same doubles). The imported file is the
same model as the URDF, bit for bit (checked first)."""

from __future__ import annotations

import pathlib
from typing import List

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES, run_tool, tool_json

ARM = EXAMPLES / "urdf" / "arm.urdf"
Q = [0.3, -0.7, 1.1, 0.4, -0.2, 0.9]
Z = [0.5, -0.25, 0.75, 1.5, -1.0, 2.0]


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    a = np.ascontiguousarray(a, dtype=np.float64)
    b = np.ascontiguousarray(b, dtype=np.float64)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def arm_at(m: kanedyn.Model, q: List[float], z: List[float], tmp_path: pathlib.Path) -> pathlib.Path:
    """The arm imported as a model file whose initial state is (q, z)."""
    out = tmp_path / "arm.yaml"
    done = run_tool(["import", ARM, "-o", out])
    assert done.returncode == 0, done.stderr
    layout = m.joint_layout
    lines: List[str] = []
    body = ""
    for line in out.read_text().splitlines():
        lines.append(line)
        if line.startswith("  - name: "):
            body = line.split('"')[1]
        elif line.startswith("      axis: ") and layout[body][1] == 1:
            iq, _, iz, _ = layout[body]
            lines += ["    initial:", f"      joint: [{q[iq]!r}]", f"      joint_rate: [{z[iz]!r}]"]
    out.write_text("\n".join(lines) + "\n")
    return out


@pytest.fixture(scope="module")
def arm() -> kanedyn.Model:
    return kanedyn.load(ARM)


def test_a_state_from_joint_coordinates(arm: kanedyn.Model) -> None:
    s = arm.state(q=Q, z=Z)
    assert s.jointed and s.N == arm.N == 8
    assert same_bits(s.q, np.array(Q)) and same_bits(s.z, np.array(Z))
    # x and y are the notes' view of (q, z): computed, read-only; q and z are the stored arrays.
    assert s.x.shape == (56,) and s.y.shape == (48,)
    with pytest.raises(ValueError, match="read-only"):
        s.x[0] = 1.0
    with pytest.raises(AttributeError, match="set q and z"):
        s.x = np.zeros(56)
    s.q[0] = 0.0
    assert s.q[0] == 0.0 and not same_bits(s.x, arm.state(q=Q, z=Z).x)
    # The zero state, the initial state, defaults of one half.
    assert same_bits(arm.state().q, np.zeros(6)) and same_bits(arm.state(q=Q).z, np.zeros(6))
    assert same_bits(arm.initial_state().q, arm.initial_joint_coordinates)
    # The notes' x, y give no angles of revolute joints: refused, naming the body.
    with pytest.raises(ValueError, match="shoulder_link"):
        arm.state(x=s.x, y=s.y)
    with pytest.raises(ValueError, match="not both"):
        arm.state(q=Q, x=s.x)
    with pytest.raises(ValueError, match=r"q\[2\] is nan"):
        arm.state(q=[0.0, 0.0, float("nan"), 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"\(6,\)"):
        arm.state(q=[0.0])
    # A state of another model with other joints is refused.
    cart = kanedyn.load(EXAMPLES / "cart_pendulum.yaml")
    with pytest.raises(ValueError, match="another model"):
        arm.energy(cart.initial_state())


def test_every_call_gives_the_tools_numbers_at_the_users_state(arm: kanedyn.Model, tmp_path) -> None:
    path = arm_at(arm, Q, Z, tmp_path)
    imported = kanedyn.load(path)
    # The imported file is the URDF's model: the same equations at the same state.
    s = arm.state(q=Q, z=Z)
    assert same_bits(imported.initial_state().q, s.q) and same_bits(imported.initial_state().z, s.z)
    assert same_bits(imported.eom().A, arm.eom(s).A)

    printed = tool_json(["eom", path, "--json"])
    e = arm.eom(s)
    for key in ("A", "f", "ydot", "xdot", "C", "A_z", "f_z", "zdot"):
        assert same_bits(np.array(printed[key]), getattr(e, key)), key

    joints = tool_json(["inspect", path, "--json"])["joints"]
    j = arm.inspect(s).joints
    for key in ("q", "z", "C", "Cdot_z", "A_z", "f_z", "zdot", "ydot"):
        assert same_bits(np.array(joints[key]), getattr(j, key)), key

    # simulate(initial=) against the tool's run from the file's initial state, row by row.
    done = run_tool(["simulate", path, "--t-end", "0.2", "--dt-out", "0.05", "-o", tmp_path / "tool.csv"])
    assert done.returncode == 0, done.stderr
    tool = kanedyn.read_csv(arm, tmp_path / "tool.csv")
    r = arm.simulate(initial=s, t_end=0.2, dt_out=0.05)
    for key in ("t", "x", "y", "q", "z", "energy"):
        assert same_bits(getattr(tool, key), getattr(r, key)), key
    # energy at the state is the CSV's energy column at its first row.
    assert arm.energy(s)[2] == tool.energy[0]

    # derivatives() is the function simulate integrates: one rk4 step written with it in numpy
    # (the integrator's operations in its order, src/integrate.cpp) gives the tool's row.
    h = 0.01
    done = run_tool(["simulate", path, "--integrator", "rk4", "--step", h, "--t-end", h, "--dt-out", h,
                     "-o", tmp_path / "rk4.csv"])
    assert done.returncode == 0, done.stderr
    row = kanedyn.read_csv(arm, tmp_path / "rk4.csv")
    n = len(Q)

    def f(v: np.ndarray) -> np.ndarray:
        qdot, zdot = arm.derivatives(v[:n], v[n:])
        return np.concatenate([qdot, zdot])

    v = np.concatenate([s.q, s.z])
    k1 = f(v)
    k2 = f(v + (0.5 * h) * k1)
    k3 = f(v + (0.5 * h) * k2)
    k4 = f(v + h * k3)
    v = v + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    assert same_bits(row.q[1], v[:n]) and same_bits(row.z[1], v[n:])

    # derivatives(state), derivatives(q, z) and derivatives_batch give the same bits; so does
    # joint_derivatives, which any model takes.
    qdot, zdot = arm.derivatives(s)
    assert same_bits(np.concatenate([qdot, zdot]), k1)
    Qd, Zd = arm.derivatives_batch(np.array([Q, Q]), np.array([Z, Z]), threads=2)
    assert same_bits(Qd[1], qdot) and same_bits(Zd[0], zdot)
    assert same_bits(arm.joint_derivatives(s)[1], zdot)
    assert same_bits(arm.joint_derivatives(Q, Z)[1], zdot)
    # The assembled route is the tool's projected equations' z dot to round-off (another
    # factorization of the same A_z: 1e-12 relative).
    _, assembled = arm.joint_derivatives(s, route="assembled")
    assert np.allclose(assembled, e.zdot, rtol=1e-12, atol=1e-12 * np.abs(e.zdot).max())


def test_a_batch_row_with_a_problem_is_named(arm: kanedyn.Model) -> None:
    Qs = np.array([Q, Q, Q])
    Qs[2, 4] = np.inf
    with pytest.raises(ValueError, match=r"X\[2\]\[4\] is inf"):
        arm.derivatives_batch(Qs, np.zeros((3, 6)))
    with pytest.raises(ValueError, match=r"\(M, 6\)"):
        arm.derivatives_batch(np.zeros((3, 7)), np.zeros((3, 6)))


def test_an_all_free_model_takes_its_state_either_way(tmp_path) -> None:
    # eight_body: every body free. Its State stores the notes' x, y; q and z are their
    # body-by-body view, and a state built from them is the same state.
    m = kanedyn.load(EXAMPLES / "eight_body.yaml")
    s = m.initial_state()
    assert not s.jointed
    assert same_bits(s.q[:4], s.x[:4]) and same_bits(s.q[4:7], s.x[32:35])
    assert same_bits(s.z[:3], s.y[:3]) and same_bits(s.z[3:6], s.y[24:27])
    with pytest.raises(ValueError, match="read-only"):
        s.q[0] = 1.0
    t = m.state(q=s.q, z=s.z)
    assert same_bits(t.x, s.x) and same_bits(t.y, s.y)
    assert same_bits(m.state(x=s.x, y=s.y).x, s.x)
    # derivatives keeps the notes' layout; joint_derivatives gives the same numbers body by body.
    xdot, ydot = m.derivatives(s)
    assert same_bits(xdot, m.derivatives(s.x, s.y)[0])
    qdot, zdot = m.joint_derivatives(s)
    assert same_bits(zdot[:3], ydot[:3]) and same_bits(zdot[3:6], ydot[24:27])
    assert same_bits(qdot[:4], xdot[:4]) and same_bits(qdot[4:7], xdot[32:35])
    # simulate(initial=) from a state built from (q, z) is the tool's run from the file.
    done = run_tool(["simulate", EXAMPLES / "eight_body.yaml", "--t-end", "0.1", "--dt-out", "0.05", "-o",
                     tmp_path / "tool.csv"])
    assert done.returncode == 0, done.stderr
    r = m.simulate(initial=t, t_end=0.1, dt_out=0.05)
    tool = kanedyn.read_csv(m, tmp_path / "tool.csv")
    assert same_bits(tool.x, r.x) and same_bits(tool.y, r.y)
    # A state of joint coordinates of another model is refused by the notes' calls.
    arm = kanedyn.load(ARM)
    with pytest.raises(ValueError, match="another model"):
        m.derivatives(arm.initial_state())
