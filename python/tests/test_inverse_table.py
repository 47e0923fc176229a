"""Inverse dynamics from arrays (docs/python.md, "Inputs, forward and inverse dynamics,
stepping"): row by row through Model.state(q=, z=) and Model.inverse_dynamics, without a Result;
and the table of `kanedyn inverse` (docs/cli.md, "inverse") written from the same arrays."""

from __future__ import annotations

import pathlib
import re

import numpy as np

import kanedyn
from conftest import run_tool

# A pendulum on a hinge about y: tau = J q'' + m g l sin q about the hinge, J = I_yy + m l^2.
PENDULUM = (
    "format: kanedyn-model/1\n"
    "gravity: [0, 0, -9.81]\n"
    "bodies:\n"
    "  - name: link\n"
    "    parent: ground\n"
    "    mass: 2.0\n"
    "    inertia: [0.1, 0.1, 0.02]\n"
    "    com: [0, 0, -0.5]\n"
    "    joint: {type: revolute, axis: [0, 1, 0]}\n"
)
M, L, IYY, G, A, W = 2.0, 0.5, 0.1, 9.81, 0.8, 3.0
J = IYY + M * L * L


def driven(t: np.ndarray):
    """q, z, z dot (T, 1) of q = A sin(w t), and the torque that drives it, in closed form."""
    q = A * np.sin(W * t)
    z = A * W * np.cos(W * t)
    zdot = -A * W * W * np.sin(W * t)
    return q[:, None], z[:, None], zdot[:, None], J * zdot + M * G * L * np.sin(q)


def test_inverse_dynamics_of_arrays_row_by_row() -> None:
    m = kanedyn.loads(PENDULUM)
    t = np.linspace(0.0, 2.0, 201)
    q, z, zdot, tau = driven(t)
    Q = np.array([m.inverse_dynamics(m.state(q=q[i], z=z[i]), zdot[i]) for i in range(len(t))])
    assert Q.shape == (len(t), 1)
    # The same numbers by two routes: round-off of the torque's terms (about 10 N m).
    np.testing.assert_allclose(Q[:, 0], tau, rtol=0.0, atol=1e-12)


def test_the_tool_reads_the_same_arrays_as_a_table(tmp_path: pathlib.Path) -> None:
    (tmp_path / "pendulum.yaml").write_text(PENDULUM)
    m = kanedyn.loads(PENDULUM)
    h = 0.01
    t = np.arange(0.0, 2.0 + h / 2, h)
    q, z, _, tau = driven(t)
    # The columns as docs/python.md names them: the coordinates' of Model.columns, and the rates'.
    names = [c for c in m.columns if re.fullmatch(r".+\.j\d+", c)]
    rates = [c for c in m.columns if re.fullmatch(r".+\.jd\d+", c)]
    assert (names, rates) == (["link.j1"], ["link.jd1"])
    np.savetxt(tmp_path / "q.csv", np.column_stack([t, q]), delimiter=",", header="t," + ",".join(names), comments="")
    np.savetxt(
        tmp_path / "qz.csv",
        np.column_stack([t, q, z]),
        delimiter=",",
        header="t," + ",".join(names + rates),
        comments="",
    )
    for name, bound in (
        # The tool's accelerations from the rates: the end cubic's slope error, about
        # f'''' h^3 / 4 = A w^5 h^3 / 4, times J; twice that is asked.
        ("qz", 2 * J * A * W**5 * h**3 / 4),
        # From the coordinates alone, second order: about 1.7 A w^4 h^2 (docs/cli.md), times J.
        ("q", 2 * J * 1.7 * A * W**4 * h**2),
    ):
        done = run_tool(["inverse", "pendulum.yaml", f"{name}.csv", "-o", f"{name}.Q.csv"], cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        out = np.loadtxt(tmp_path / f"{name}.Q.csv", delimiter=",", skiprows=1)
        np.testing.assert_array_equal(out[:, 0], t)
        assert np.max(np.abs(out[:, 1] - tau)) <= bound, name
