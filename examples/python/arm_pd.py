#!/usr/bin/env python3
"""A PD controller with gravity compensation holds the URDF arm at a pose.

The arm's six joint inputs are its joints' torques, in the order of its speeds z (the URDF
import makes one input per revolute joint). Every 2 ms the controller reads the state and sets

    u = Kp (q* - q) - Kd z + g(q)

held until its next call: a sampled-data controller, as a drive's firmware runs it. g(q) is the
generalized gravity (Model.gravity_forces, Pinocchio's sign), so the arm rests at q* exactly;
the gains put every joint near a critically damped 4 Hz mode (Kp = w^2 M_ii, Kd = 2 w M_ii with
the mass matrix's diagonal at q*). The arm starts at rest, hanging straight, and is at q* within
1e-6 rad after 3 s.

    PYTHONPATH=build/python python3 examples/python/arm_pd.py
"""

from __future__ import annotations

import pathlib

import numpy as np

import kanedyn

HERE = pathlib.Path(__file__).resolve().parent
TARGET = np.array([0.4, -0.9, 1.3, -0.6, 0.5, 0.3])  # rad, joint by joint


def main() -> None:
    arm = kanedyn.load(HERE.parent / "urdf" / "arm.urdf")
    start = arm.initial_state()
    assert len(arm.inputs) == len(start.z) == len(TARGET), "one torque input per joint speed"
    w = 2 * np.pi * 4.0
    M = arm.mass_matrix(arm.state(q=TARGET, z=np.zeros(6))).diagonal()
    kp, kd = w * w * M, 2 * w * M

    def pd(t: float, s: kanedyn.State) -> np.ndarray:
        return kp * (TARGET - s.q) - kd * s.z + arm.gravity_forces(s)

    r = arm.simulate(t_end=3.0, dt_out=0.01, controller=pd, control_interval=0.002)
    error = np.abs(r.q - TARGET).max(axis=1)
    for t in (0.0, 0.5, 1.0, 2.0, 3.0):
        i = int(round(t / 0.01))
        print(f"t = {t:3.1f} s: largest joint error {error[i]:.3e} rad, torques {np.round(r.u[i], 3)}")
    print(f"final error {error[-1]:.3e} rad")


if __name__ == "__main__":
    main()
