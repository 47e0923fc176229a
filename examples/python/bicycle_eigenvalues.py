#!/usr/bin/env python3
"""The Whipple bicycle's eigenvalues against its forward speed (docs/bicycle.md).

examples/bicycle.yaml is the benchmark bicycle of Meijaard, Papadopoulos, Ruina and Schwab
(Proc. R. Soc. A 463, 2007). For each speed v from 0 to 10 m/s the script linearizes it about
upright straight running (Model.linearize, in the independent coordinates and speeds: the two
contacts fix the rear frame's height and pitch, and leave three speeds), keeps the four
eigenvalues of roll and steer (the other six are the zeros of the position, heading, wheel
angles and forward speed), and plots their real parts (solid) and imaginary parts (dashed),
with the paper's Table 2 values as circles (tests/data/meijaard2007.json). It prints the weave
and capsize speeds found by bisection.

    PYTHONPATH=build/python python3 examples/python/bicycle_eigenvalues.py [OUT.png]

Without OUT.png the figure is not drawn (no matplotlib needed).
"""

from __future__ import annotations

import json
import pathlib
import sys

import numpy as np

import kanedyn

ROOT = pathlib.Path(__file__).resolve().parents[2]
RR, RF = 0.3, 0.35  # the wheels' radii (Table 1)


def roll_and_steer(model: kanedyn.Model, v: float) -> np.ndarray:
    """The four eigenvalues of roll and steer at forward speed v, sorted by decreasing real part."""
    q = model.initial_joint_coordinates
    z = np.zeros(len(model.initial_joint_speeds))
    z[3] = v  # the rear frame's forward speed (its s'_K dot along x)
    z[6] = v / RR  # the rear wheel's spin
    z[8] = v / RF  # the front wheel's spin (the steer rate z[7] stays 0)
    lin = model.linearize(q=q, z=z)
    # The roll and steer block: roll, steer and their rates act on nothing else. Its eigenvalues
    # are the full A's; near the capsize crossing the full A's solver sees the capsize root
    # beside the forward speed's zero (whose column of A is round-off, 1e-17, rather than
    # exactly zero), and the two split by sqrt(1e-16): the block has no such neighbour.
    names = list(lin.state)
    block = [names.index(n) for n in ("rear_frame.r1", "front_frame.j1", "rear_frame.w1",
                                       "front_frame.jd1")]
    a = np.asarray(lin.A)[np.ix_(block, block)]
    block_values = np.linalg.eigvals(a)
    return block_values[np.lexsort((-block_values.imag, -block_values.real))]


def crossing(model: kanedyn.Model, lo: float, hi: float, weave: bool) -> float:
    """The speed in [lo, hi] where the weave pair's (or the capsize root's) real part is 0."""
    def growth(v: float) -> float:
        e = roll_and_steer(model, v)
        chosen = e[np.abs(e.imag) > 0] if weave else e[e.imag == 0]
        return float(np.max(chosen.real))

    sign = growth(lo) > 0
    while hi - lo > 1e-12:
        mid = 0.5 * (lo + hi)
        if (growth(mid) > 0) == sign:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def main() -> None:
    model = kanedyn.load(str(ROOT / "examples" / "bicycle.yaml"))
    paper = json.loads((ROOT / "tests" / "data" / "meijaard2007.json").read_text())
    v_w = crossing(model, 4.0, 5.0, True)
    v_c = crossing(model, 6.0, 6.5, False)
    published = paper["characteristic_speeds_published"]
    print(f"weave speed   {v_w:.12f} m/s (paper {published['v_w']})")
    print(f"capsize speed {v_c:.12f} m/s (paper {published['v_c']})")
    if len(sys.argv) < 2:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    speeds = np.linspace(0.0, 10.0, 401)
    values = np.array([roll_and_steer(model, v) for v in speeds])
    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=120)
    # Dots, not lines: which of the four is which changes where roots merge and split.
    ax.plot(np.repeat(speeds, 4), values.real.ravel(), ".", color="C0", ms=2, label="real part")
    oscillating = np.abs(values.imag) > 0
    ax.plot(np.repeat(speeds, 4)[oscillating.ravel()], np.abs(values.imag).ravel()[oscillating.ravel()],
            ".", color="C1", ms=2, label="|imaginary part|")
    for entry in paper["eigenvalues_published"]:
        for re, im in entry["eigenvalues"]:
            ax.plot(entry["v"], re, "o", color="C0", ms=4, mfc="none")
            if im != 0:
                ax.plot(entry["v"], abs(im), "s", color="C1", ms=4, mfc="none")
    ax.axvspan(v_w, v_c, color="C2", alpha=0.12, label=f"self-stable ({v_w:.3f} to {v_c:.3f} m/s)")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_ylim(-10, 10)
    ax.set_xlabel("forward speed v [m/s]")
    ax.set_ylabel("eigenvalue [1/s]")
    ax.set_title("Whipple bicycle: kanedyn (dots) and Meijaard et al. 2007, Table 2 (circles)")
    ax.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    fig.savefig(sys.argv[1])
    print(f"figure: {sys.argv[1]}")


if __name__ == "__main__":
    main()
