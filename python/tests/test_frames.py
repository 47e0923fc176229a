"""Frames from Python: the URDF arm's tool flange (a massless link on a fixed joint), its pose
and velocity at a state, and its Jacobian against the velocity and against central differences
of its position along each joint angle."""

from __future__ import annotations

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES

Q = [0.3, -0.7, 1.1, 0.4, -0.2, 0.9]
Z = [0.5, -0.25, 0.75, 1.5, -1.0, 2.0]


def test_the_arms_tool_flange_is_a_frame() -> None:
    arm = kanedyn.load(EXAMPLES / "urdf" / "arm.urdf")
    assert arm.frames == ["tool_flange"]
    s = arm.state(q=Q, z=Z)
    f = arm.frame("tool_flange", s)
    Jv, Jw = arm.jacobian("tool_flange", s)
    assert Jv.shape == Jw.shape == (3, 6)
    # v = Jv z and w = Jw z: sums of six products of O(1) numbers, 1e-12.
    assert np.allclose(Jv @ s.z, f["velocity"], rtol=0, atol=1e-12)
    assert np.allclose(Jw @ s.z, f["angular_velocity"], rtol=0, atol=1e-12)
    # The arm's z are the joint angles' rates: central differences along each angle, h = 1e-6
    # (truncation ~1e-12, round-off ~1e-10), agree to 1e-7.
    h = 1e-6
    for i in range(6):
        plus, minus = np.array(Q), np.array(Q)
        plus[i] += h
        minus[i] -= h
        dp = (arm.frame("tool_flange", arm.state(q=plus))["position"]
              - arm.frame("tool_flange", arm.state(q=minus))["position"]) / (2 * h)
        assert np.allclose(dp, Jv[:, i], rtol=0, atol=1e-7), i
    # R is orthonormal and maps inertial to frame components.
    assert np.allclose(f["R"] @ f["R"].T, np.eye(3), atol=1e-14)
    with pytest.raises(KeyError, match="did you mean 'tool_flange'"):
        arm.frame("tool_flang")


def test_a_model_files_frames() -> None:
    m = kanedyn.loads({
        "format": "kanedyn-model/1",
        "bodies": [{"name": "a", "parent": "ground", "mass": 1, "inertia": [1, 1, 1, 0, 0, 0],
                    "initial": {"angular_velocity": [0, 0, 2]}}],
        "frames": [{"name": "tip", "body": "a", "at": [0.5, 0, 0]},
                   {"name": "mark", "body": "ground", "at": [1, 2, 3]}],
    })
    assert m.frames == ["tip", "mark"]
    tip = m.frame("tip")
    # A free body spinning at 2 rad/s about z: the tip, 0.5 along x, moves at 1 along y.
    assert np.allclose(tip["position"], [0.5, 0, 0]) and np.allclose(tip["velocity"], [0, 1, 0])
    assert np.array_equal(m.frame("mark")["position"], [1.0, 2.0, 3.0])
    assert not m.jacobian("mark")[0].any()
    assert kanedyn.load(EXAMPLES / "eight_body.yaml").frames == []


def test_a_body_by_its_name_is_its_own_frame() -> None:
    # A body's name gives its own frame (origin O_K, body-K axes): its Jacobian gives its
    # velocities (sums of a few products: 1e-14), and its velocity's central difference along
    # the motion its acceleration (h = 1e-6: truncation ~1e-12, round-off ~1e-10; 1e-7).
    m = kanedyn.load(EXAMPLES / "urdf" / "arm.urdf")
    q, z = np.array(Q), np.linspace(-1, 1, 6)
    s = m.state(q=q, z=z)
    body = m.frame("forearm", s)
    Jv, Jw = m.jacobian("forearm", s)
    assert np.allclose(Jv @ z, body["velocity"], rtol=0, atol=1e-14)
    assert np.allclose(Jw @ z, body["angular_velocity"], rtol=0, atol=1e-14)
    zdot = m.forward(s)
    a = m.frame_acceleration("forearm", s, zdot)
    h = 1e-6
    ahead = m.frame("forearm", m.state(q=q + h * z, z=z + h * zdot))
    behind = m.frame("forearm", m.state(q=q - h * z, z=z - h * zdot))
    assert np.allclose((ahead["velocity"] - behind["velocity"]) / (2 * h), a["linear"], rtol=0, atol=1e-7)
    assert np.allclose((ahead["angular_velocity"] - behind["angular_velocity"]) / (2 * h), a["angular"],
                       rtol=0, atol=1e-7)
    with pytest.raises(KeyError, match="did you mean 'forearm'"):
        m.frame("forarm", s)
