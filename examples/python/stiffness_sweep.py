#!/usr/bin/env python3
"""A parameter sweep: the eight-body figure with its bushings' stiffness scaled from 0.25x to
4x, each model built from a dict and simulated for 2 s; prints the steps the integrator took
and how far the head sagged, then the accelerations of every variant at one state by
derivatives_batch.

    PYTHONPATH=build/python python3 examples/python/stiffness_sweep.py
"""

from __future__ import annotations

import copy
import json
import pathlib

import numpy as np

import kanedyn

HERE = pathlib.Path(__file__).resolve().parent


def scaled(base: dict, factor: float) -> kanedyn.Model:
    """The model with every bushing's translational and rotational stiffness times factor."""
    spec = copy.deepcopy(base)
    for force in spec["forces"]:
        if force["type"] == "bushing":
            for key in ("stiffness", "rotational_stiffness"):
                if key in force:
                    force[key] = (np.asarray(force[key], dtype=float) * factor).tolist()
    spec["name"] = f"{base['name']} (stiffness x{factor:g})"
    return kanedyn.load(spec)


def main() -> None:
    base = json.loads((HERE.parent / "eight_body.json").read_text())
    factors = [0.25, 0.5, 1.0, 2.0, 4.0]
    print(f"{'stiffness':>10} {'steps':>7} {'head sag (mm)':>14} {'energy change (J)':>18}")
    for factor in factors:
        m = scaled(base, factor)
        r = m.simulate(t_end=2, dt_out=0.01)
        sag = 1000 * (r["head.z"][0] - r["head.z"].min())
        print(f"{factor:>9g}x {r.stats['steps_accepted']:>7} {sag:>14.3f} {r.stats['energy_change']:>18.4g}")

    # The same state through every variant at once: one batch per model, rows = samples of
    # the torso's angular velocity.
    m = scaled(base, 1.0)
    s = m.initial_state()
    w1 = np.linspace(-2, 2, 1001)
    X = np.tile(s.x, (w1.size, 1))
    Y = np.tile(s.y, (w1.size, 1))
    Y[:, 0] = w1  # w'_1, the torso's first component
    Xd, Yd = m.derivatives_batch(X, Y)
    k = m.body_number("head") - 1
    print(f"head's angular acceleration (body axes, component 1) over torso w1 in [-2, 2] rad/s: "
          f"{Yd[:, 3 * k].min():.4g} .. {Yd[:, 3 * k].max():.4g} rad/s^2")


if __name__ == "__main__":
    main()
