#!/usr/bin/env python3
"""Simulate the notes' eight-body figure for 10 s and plot its energy and a few coordinates.

    PYTHONPATH=build/python python3 examples/python/simulate_eight_body.py [OUT.png]

Writes eight_body.png (or OUT.png): the total energy, which the bushings' damping drains, and
the head's height and the torso's angular velocity w2 (body axes) against time.
"""

from __future__ import annotations

import pathlib
import sys

import matplotlib

matplotlib.use("Agg")  # files only: no display needed
import matplotlib.pyplot as plt

import kanedyn

HERE = pathlib.Path(__file__).resolve().parent


def main() -> None:
    out = sys.argv[1] if len(sys.argv) > 1 else "eight_body.png"
    model = kanedyn.load(HERE.parent / "eight_body.yaml")
    r = model.simulate(t_end=10, dt_out=0.01)
    print(f"{model.N} bodies, {len(r)} rows, {r.stats['evaluations']} evaluations, {r.stats['wall_seconds']:.3f} s")
    print(f"energy {r.stats['energy_initial']:.6g} J -> {r.stats['energy_final']:.6g} J")

    fig, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True)
    axes[0].plot(r.t, r.energy)
    axes[0].set_ylabel("energy (J)")
    axes[1].plot(r.t, r["head.z"])
    axes[1].set_ylabel("head G height (m)")
    axes[2].plot(r.t, r["torso.w1"], label="w1")
    axes[2].plot(r.t, r["torso.w2"], label="w2")
    axes[2].plot(r.t, r["torso.w3"], label="w3")
    axes[2].set_ylabel("torso w' (rad/s)")
    axes[2].set_xlabel("t (s)")
    axes[2].legend(loc="upper right")
    fig.suptitle(model.name)
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
