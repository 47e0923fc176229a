#!/usr/bin/env python3
"""Computed-torque control: the URDF arm tracks a sine on every joint.

The desired motion is q_d(t) = q0 + A sin(2 pi f t) joint by joint. At every evaluation of the
equations the controller sets the joint torques

    u = M(q) (qdd_d + Kd (qd_d - z) + Kp (q_d - q)) + b(q, z)

with the model's own mass matrix M and bias forces b (Model.mass_matrix, Model.bias_forces:
M z dot + b = u for this arm, whose inputs are its joints' torques in the order of z). The
closed loop is then e'' + Kd e' + Kp e = 0 for the error e = q_d - q: the arm starts at rest
away from the sine and the error decays as exp(-w t), w = 10 rad/s, to the integrator's
tolerance.

    PYTHONPATH=build/python python3 examples/python/arm_computed_torque.py
"""

from __future__ import annotations

import pathlib

import numpy as np

import kanedyn

HERE = pathlib.Path(__file__).resolve().parent
Q0 = np.array([0.0, -0.8, 1.2, -0.4, 0.3, 0.0])
AMPLITUDE = np.array([0.5, 0.3, 0.4, 0.6, 0.5, 0.8])
FREQUENCY = np.array([0.5, 0.4, 0.6, 0.7, 0.8, 1.0])  # Hz
W = 10.0  # rad/s: a critically damped error, Kp = w^2, Kd = 2 w
KP, KD = W * W, 2 * W


def desired(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a = 2 * np.pi * FREQUENCY
    return Q0 + AMPLITUDE * np.sin(a * t), AMPLITUDE * a * np.cos(a * t), -AMPLITUDE * a * a * np.sin(a * t)


def main() -> None:
    arm = kanedyn.load(HERE.parent / "urdf" / "arm.urdf")
    assert len(arm.inputs) == len(arm.initial_state().z), "one torque input per joint speed"

    def computed_torque(t: float, s: kanedyn.State) -> np.ndarray:
        q_d, qd_d, qdd_d = desired(t)
        v = qdd_d + KD * (qd_d - s.z) + KP * (q_d - s.q)
        return arm.mass_matrix(s) @ v + arm.bias_forces(s)

    start = arm.state(q=Q0 + 0.2, z=np.zeros(6))
    r = arm.simulate(initial=start, t_end=4.0, dt_out=0.01, controller=computed_torque,
                     control_interval=0.0, rtol=1e-10, atol=1e-12)
    error = np.array([np.abs(desired(t)[0] - q).max() for t, q in zip(r.t, r.q)])
    for t in (0.0, 0.5, 1.0, 2.0, 3.0, 4.0):
        i = int(round(t / 0.01))
        print(f"t = {t:3.1f} s: largest tracking error {error[i]:.3e} rad")
    print(f"largest error over the last 2 s: {error[r.t >= 2.0].max():.3e} rad")


if __name__ == "__main__":
    main()
