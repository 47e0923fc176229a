"""The reduced linearization from Python (Model.linearize(reduce=True); docs/analysis.md,
"Steady motions: the reduced system"): the coin of examples/rolling_disc.yaml, the tool's JSON,
the upright disc's stability boundary, and a model with nothing to drop."""

from __future__ import annotations

import math

import numpy as np
import pytest

import kanedyn

from conftest import EXAMPLES, tool_json

DISC = """format: kanedyn-model/1
name: upright disc
gravity: [0, 0, -9.81]
bodies:
  - name: disc
    parent: ground
    mass: 2.0
    inertia: [0.045, 0.09, 0.045]
    initial:
      translation: [0, 0, 0.3]
      angular_velocity: [0, {spin}, 0]
      translation_rate: [{v}, 0, 0]
constraints:
  - name: contact
    type: rolling_disc
    body: disc
    axis: [0, 1, 0]
    radius: 0.3
"""


def test_the_coins_position_heading_and_spin_are_dropped() -> None:
    m = kanedyn.load(EXAMPLES / "rolling_disc.yaml")
    lin = m.linearize(reduce=True)
    red = lin.reduced
    assert lin.periodic  # the disc spins: one instant's eigenvalues do not decide
    assert [(d["name"], d["kind"]) for d in red.dropped] == [
        ("disc.s1", "coordinate"),
        ("disc.s2", "coordinate"),
        ("disc.r3", "heading"),
        ("disc.r2", "spin"),
    ]
    assert all(lin.state[d["index"]] == d["name"] for d in red.dropped)
    assert red.state == ["disc.r1", "disc.w1", "disc.w2", "disc.w3"]
    assert red.steady
    # The precession rate of the file's comment, g tan(theta) = Omega^2 (3 rho / 2 + r sin(theta) / 4),
    # is the rate along the heading.
    theta, rho, r = 0.3, 1.0, 0.3
    omega = math.sqrt(9.81 * math.tan(theta) / (1.5 * rho + r * math.sin(theta) / 4))
    assert red.rates[2] == pytest.approx(omega, rel=1e-12)
    # Conservative: a pair on the imaginary axis (to round-off of |A| ~ 30) and two zeros.
    assert np.abs(red.eigenvalues.real).max() < 1e-12 * 30
    assert red.eigenvalues[0].imag > 1.0
    assert "the reduced system is time-invariant" in str(lin)
    with pytest.raises(TypeError, match="reduce must be True or False"):
        m.linearize(reduce="yes")


def test_the_reduced_object_is_the_tools() -> None:
    m = kanedyn.load(EXAMPLES / "rolling_disc.yaml")
    mine = m.linearize(reduce=True).as_dict()
    tools = tool_json(["linearize", EXAMPLES / "rolling_disc.yaml", "--json", "--reduce"])
    assert list(mine) == list(tools)
    assert mine["reduced"] == tools["reduced"]
    assert "reduced" not in m.linearize().as_dict()


def test_the_upright_disc_is_stable_above_whittakers_speed() -> None:
    # sqrt(g r / 3) = 0.99 m/s: 1 % below it the reduced lean diverges at about 0.7 /s; 1 % above
    # it oscillates (real parts at round-off, 1e-12 of |A| ~ 30).
    critical = math.sqrt(9.81 * 0.3 / 3)
    for factor, unstable in ((0.99, True), (1.01, False)):
        v = factor * critical
        m = kanedyn.loads(DISC.format(v=v, spin=v / 0.3))
        red = m.linearize(reduce=True).reduced
        assert red.steady
        top = red.eigenvalues[0].real
        assert (top > 0.1) if unstable else (abs(top) < 1e-12 * 30), (factor, red.eigenvalues)


def test_a_model_with_nothing_to_drop_is_unchanged() -> None:
    m = kanedyn.load(EXAMPLES / "double_pendulum_jointed.yaml")
    lin = m.linearize(reduce=True)
    assert lin.reduced.dropped == []
    assert lin.reduced.state == lin.state
    assert np.array_equal(lin.reduced.A, lin.A)
    assert np.array_equal(lin.reduced.eigenvalues, lin.eigenvalues)
