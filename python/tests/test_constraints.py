"""Constraints from Python: the model's constraints and independent speeds, the equations and
the speed partition at a state, the projection onto the constraints, and the constrained
forward dynamics with the reactions, on the four-bar (a hinge closing a loop, 3 of its 5
equations redundant) and the bicycle (two rolling discs), against the tool's inspect."""

from __future__ import annotations

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES, tool_json


@pytest.fixture
def four_bar() -> kanedyn.Model:
    return kanedyn.load(EXAMPLES / "four_bar.yaml")


@pytest.fixture
def bicycle() -> kanedyn.Model:
    return kanedyn.load(EXAMPLES / "bicycle.yaml")


def test_the_model_lists_its_constraints(four_bar: kanedyn.Model, bicycle: kanedyn.Model) -> None:
    (hinge,) = four_bar.constraints
    assert hinge["name"] == "closure" and hinge["type"] == "hinge" and hinge["equations"] == 5
    assert hinge["body"] == "rocker" and hinge["other"] == "ground"
    assert np.array_equal(hinge["at"], [0.9, 0, 0]) and np.array_equal(hinge["other_at"], [1, 0, 0])
    assert np.array_equal(hinge["axis"], [0, 0, 1]) and np.array_equal(hinge["other_axis"], [0, 0, 1])
    assert four_bar.independent_speeds == ["crank.jd1"]
    rear, front = bicycle.constraints
    assert (rear["name"], rear["type"], rear["body"], rear["radius"]) == ("rear_contact", "rolling_disc", "rear_wheel", 0.3)
    assert (front["body"], front["radius"]) == ("front_wheel", 0.35)
    assert np.array_equal(front["plane_normal"], [0, 0, 1]) and front["plane_offset"] == 0.0
    assert np.array_equal(rear["axis"], [0, 1, 0])
    # Chosen by pivoting at the initial state (the file names none): 9 speeds less 6 equations.
    assert len(bicycle.independent_speeds) == 3
    free = kanedyn.load(EXAMPLES / "double_pendulum.yaml")
    assert free.constraints == []
    assert len(free.independent_speeds) == len(free.initial_joint_speeds)


@pytest.mark.parametrize("name, rank, redundant", [("four_bar.yaml", 2, 3), ("bicycle.yaml", 6, 0), ("rssr.yaml", 3, 0)])
def test_the_partition_spans_the_motions_the_constraints_allow(name: str, rank: int, redundant: int) -> None:
    m = kanedyn.load(EXAMPLES / name)
    e = m.constraint_equations()
    p = m.partition_speeds()
    n = len(m.initial_joint_speeds)
    assert e["B"].shape == (len(e["rows"]), n)
    assert p["rank"] == rank and len(p["redundant_rows"]) == redundant
    assert sorted(p["independent"] + p["dependent"]) == list(range(n))
    assert p["C_I"].shape == (n, n - rank)
    assert np.abs(e["B"] @ p["C_I"]).max() < 1e-12 * max(1.0, np.abs(e["B"]).max())
    # C_I is the identity on the independent speeds: z = C_I z_I keeps them.
    assert np.array_equal(p["C_I"][p["independent"]], np.eye(n - rank))
    # The loader projected the initial state: it satisfies the constraints.
    assert np.abs(e["errors"]).max() < 1e-12
    assert np.abs(e["B"] @ m.initial_joint_speeds).max() < 1e-12
    # The same numbers as `kanedyn inspect --json`.
    c = tool_json(["inspect", EXAMPLES / name, "--json"])["constraints"]
    assert c["rows"] == e["rows"] and c["holonomic"] == e["holonomic"]
    assert np.array_equal(np.array(c["B"]), e["B"]) and np.array_equal(np.array(c["b"]), e["b"])
    assert c["independent_speeds"] == p["independent_speeds"]
    assert c["dependent_speeds"] == p["dependent_speeds"]
    assert c["redundant_rows"] == p["redundant_rows"]
    assert np.array_equal(np.array(c["C_I"]), p["C_I"])


def test_four_bar_rows(four_bar: kanedyn.Model) -> None:
    e = four_bar.constraint_equations()
    assert e["rows"] == [f"closure.{i}" for i in range(1, 6)]
    assert e["holonomic"] == [True] * 5
    assert four_bar.partition_speeds()["dependent_speeds"] == ["coupler.jd1", "rocker.jd1"]
    # The rocker's far end is at D.
    assert np.allclose(e["points"][0], [1, 0, 0], atol=1e-9)


def test_bicycle_rows_are_holonomic_along_the_normal_only(bicycle: kanedyn.Model) -> None:
    e = bicycle.constraint_equations()
    assert e["holonomic"] == [True, False, False, True, False, False]
    assert np.abs(e["points"][:, 2]).max() < 1e-12  # the contacts are on the ground


def test_projection_closes_the_loop_moving_the_dependent_coordinates_only(four_bar: kanedyn.Model) -> None:
    q = four_bar.initial_joint_coordinates.copy()
    z = four_bar.initial_joint_speeds.copy() + np.array([0.0, 0.3, -0.2])  # off the constraints
    q[1] += 0.02  # the coupler: the loop opens by about 2 cm
    before = four_bar.constraint_equations(q, z)
    assert np.abs(before["errors"]).max() > 1e-3
    p = four_bar.project(q, z)
    assert p["iterations"] > 0 and p["error_before"] == pytest.approx(np.abs(before["errors"]).max())
    assert p["coordinate_change"] > 1e-3 and p["speed_change"] > 1e-3
    after = four_bar.constraint_equations(p["q"], p["z"])
    assert np.abs(after["errors"]).max() < 1e-12
    assert np.abs(after["B"] @ p["z"]).max() < 1e-12
    assert p["q"][0] == q[0]  # the crank's angle is the independent coordinate
    # A State works as well, and projecting twice changes nothing more.
    again = four_bar.project(four_bar.state(q=p["q"], z=p["z"]))
    assert again["iterations"] == 0 and again["speed_change"] < 1e-12


def test_equations_undefined_at_a_state_name_the_constraint(bicycle: kanedyn.Model) -> None:
    q = bicycle.initial_joint_coordinates.copy()
    q[0:4] = [np.sqrt(0.5), 0, 0, np.sqrt(0.5)]  # the bicycle on its side: the axles vertical
    z = bicycle.initial_joint_speeds
    for call in (bicycle.constraint_equations, bicycle.constrained_forward, bicycle.project,
                 bicycle.partition_speeds):
        with pytest.raises(ValueError, match="rear_contact"):
            call(q, z)


@pytest.mark.parametrize("name", ["four_bar.yaml", "bicycle.yaml", "rssr.yaml"])
def test_forward_dynamics_keeps_the_constraints(name: str) -> None:
    m = kanedyn.load(EXAMPLES / name)
    s = m.initial_state()
    e = m.constraint_equations(s)
    f = m.constrained_forward(s)
    zdot = f["zdot"]
    scale = max(1.0, np.abs(zdot).max())
    assert np.abs(e["B"] @ zdot + e["b"]).max() < 1e-9 * scale
    # Every forward call of the module gives the constrained z dot.
    assert np.allclose(m.forward(s), zdot, rtol=0, atol=1e-10 * scale)
    assert np.allclose(m.derivatives(s)[1], zdot, rtol=0, atol=1e-10 * scale)
    assert np.allclose(m.joint_derivatives()[1], zdot, rtol=0, atol=1e-10 * scale)
    assert np.allclose(m.joint_derivatives(route="assembled")[1], zdot, rtol=0, atol=1e-9 * scale)
    projected = m.constrained_forward(s, method="projected")
    assert np.allclose(projected["zdot"], zdot, rtol=0, atol=1e-9 * scale)
    # The multipliers are the reactions: M zdot + b = B^T lambda.
    M, b = m.mass_matrix(s), m.bias_forces(s)
    residual = M @ zdot + b - e["B"].T @ f["lambda"]
    assert np.abs(residual).max() < 1e-9 * max(1.0, np.abs(b).max())
    # ... and the tool's inspect reports the same.
    c = tool_json(["inspect", EXAMPLES / name, "--json"])["constraints"]
    assert np.allclose(np.array(c["zdot"]), zdot, rtol=0, atol=1e-12 * scale)
    assert np.allclose(np.array(c["lambda"]), f["lambda"], rtol=1e-12, atol=1e-9)


def test_the_bicycle_at_rest_stands_on_its_contacts(bicycle: kanedyn.Model) -> None:
    n = len(bicycle.initial_joint_speeds)
    rest = bicycle.state(q=bicycle.initial_joint_coordinates, z=np.zeros(n))
    f = bicycle.constrained_forward(rest)
    normal = sum(r["force"][2] for r in f["reactions"])  # the plane's normal is +z
    weight = 94 * 9.81
    assert normal == pytest.approx(weight, rel=1e-9)
    assert all(r["force"][2] > 0 for r in f["reactions"])  # neither wheel lifts
    assert abs(sum(r["force"][0] for r in f["reactions"])) < 1e-9 * weight
    assert abs(sum(r["force"][1] for r in f["reactions"])) < 1e-9 * weight
    assert [r["name"] for r in f["reactions"]] == ["rear_contact", "front_contact"]
    assert all(np.array_equal(r["moment"], [0, 0, 0]) for r in f["reactions"])
    # Statics: the contacts share the weight as a beam's supports, by the mass centre's x.
    (com, _) = bicycle.centre_of_mass(rest)
    rear, front = (r["point"][0] for r in f["reactions"])
    assert f["reactions"][1]["force"][2] == pytest.approx(weight * (com[0] - rear) / (front - rear), rel=1e-6)


def test_four_bar_hinge_carries_no_moment(four_bar: kanedyn.Model) -> None:
    f = four_bar.constrained_forward()
    assert f["rank"] == 2
    (hinge,) = f["reactions"]
    assert hinge["type"] == "hinge"
    assert np.abs(hinge["moment"]).max() < 1e-9  # its rows are the redundant ones
    assert abs(hinge["force"][2]) < 1e-9 and np.linalg.norm(hinge["force"]) > 1.0


BALL_PENDULUM = """format: kanedyn-model/1
name: a free body hung from a ball constraint
gravity: [0, 0, -9.81]
bodies:
  - name: bob
    parent: ground
    mass: 2
    inertia: [0.1, 0.2, 0.3]
    initial:
      translation: [0.3, 0, -0.9539392014169457]
      angular_velocity: [0.4, -0.2, 1.0]
constraints:
  - name: pivot
    type: ball
    body: bob
    at: [0, 0, 1]
"""


def test_an_all_free_model_with_constraints_derives_the_constrained_motion() -> None:
    # Every body free: derivatives() works in the notes' layout, and must still keep the
    # constraints the free tree knows nothing of.
    m = kanedyn.loads(BALL_PENDULUM)
    assert not m.jointed
    s = m.initial_state()
    e = m.constraint_equations(s)
    assert np.abs(e["B"] @ s.z).max() < 1e-12
    f = m.constrained_forward(s)
    zdot = f["zdot"]
    assert np.abs(e["B"] @ zdot + e["b"]).max() < 1e-10
    xdot, ydot = m.derivatives(s)
    # The notes' layout: w' dots of every body, then s' dots.
    assert np.allclose(ydot, np.concatenate([zdot[0:3], zdot[3:6]]), rtol=0, atol=1e-12)
    assert np.allclose(m.derivatives(s.x, s.y)[1], ydot, rtol=0, atol=0)
    assert np.allclose(m.forward(s), zdot, rtol=0, atol=1e-12)
    Xd, Yd = m.derivatives_batch(np.array([s.x, s.x]), np.array([s.y, s.y]))
    assert np.array_equal(Yd[0], ydot) and np.array_equal(Xd[1], xdot)
    # The reaction holds the bob up (on average, with the centripetal part).
    (pivot,) = f["reactions"]
    assert pivot["force"][2] > 0


def test_the_four_bar_rests_where_nothing_accelerates(four_bar: kanedyn.Model) -> None:
    # Newton along the independent speed (the crank's) with the reactions balancing the rest:
    # the constrained forward dynamics then gives no acceleration (residual 1e-10 of the
    # weights' moments over inertias ~0.01: far below 1e-7). From the file's pose the nearest
    # stationary point is balanced over the top: a real pair +-lambda.
    rest = four_bar.equilibrium()
    assert rest.converged, rest.message
    assert rest.free == ["crank.j1"]
    n = len(four_bar.initial_joint_speeds)
    f = four_bar.constrained_forward(four_bar.state(q=rest.q, z=np.zeros(n)))
    assert np.abs(f["zdot"]).max() < 1e-7
    assert rest.eigenvalues is not None and len(rest.eigenvalues) == 2
    assert rest.eigenvalues[0].real > 1.0 and abs(rest.eigenvalues[0] + rest.eigenvalues[1]) < 1e-6
    with pytest.raises(ValueError, match="constraints"):
        four_bar.equilibrium(free=["crank"])
