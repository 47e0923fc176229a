#!/usr/bin/env python3
"""The Whipple bicycle's eigenvalues against its forward speed (docs/bicycle.md).

examples/bicycle.yaml is the benchmark bicycle of Meijaard, Papadopoulos, Ruina and Schwab
(Proc. R. Soc. A 463, 2007). For each speed v from 0 to 10 m/s the script linearizes it about
upright straight running (Model.linearize, in the independent coordinates and speeds: the two
contacts fix the rear frame's height and pitch, and leave three speeds), keeps the four
eigenvalues of roll and steer (the other six are the zeros of the position, heading, wheel
angles and forward speed), and plots their real parts (solid) and imaginary parts (dashed),
with the paper's Table 2 values as circles. It prints the weave and capsize speeds found by
bisection.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/bicycle_eigenvalues.py [OUT.png]

It reads only ../bicycle.yaml beside its own folder, so it runs from any folder, and from a
copy of examples/ outside the repository.

Without OUT.png the figure is not drawn (no matplotlib needed).
"""

from __future__ import annotations

import pathlib
import sys

import numpy as np

import kanedyn

HERE = pathlib.Path(__file__).resolve().parent
RR, RF = 0.3, 0.35  # the wheels' radii (Table 1)
# Meijaard et al. (2007): the weave and capsize speeds, as published.
PUBLISHED_V_W, PUBLISHED_V_C = "4.29238253634111", "6.02426201538837"
# Table 2, to the 6 digits a plot shows: at each speed v [m/s], the roll and steer eigenvalues
# as (real part, |imaginary part|), one entry per complex pair (tests/data/meijaard2007.json
# holds them to 1e-12, for tests/test_bicycle.cpp).
TABLE_2 = [
    (0, [(5.53094, 0), (3.13164, 0), (-3.13164, 0), (-5.53094, 0)]),
    (1, [(3.52696, 0.80774), (-3.13423, 0), (-7.11008, 0)]),
    (2, [(2.68235, 1.68066), (-3.07159, 0), (-8.67388, 0)]),
    (3, [(1.70676, 2.31582), (-2.63366, 0), (-10.351, 0)]),
    (4, [(0.413253, 3.07911), (-1.42944, 0), (-12.1586, 0)]),
    (5, [(-0.775342, 4.46487), (-0.322866, 0), (-14.0784, 0)]),
    (6, [(-1.52644, 5.87673), (-0.0040669, 0), (-16.0854, 0)]),
    (7, [(-2.13876, 7.19526), (0.102682, 0), (-18.1579, 0)]),
    (8, [(-2.69349, 8.46038), (0.143279, 0), (-20.2794, 0)]),
    (9, [(-3.21675, 9.69377), (0.157902, 0), (-22.4379, 0)]),
    (10, [(-3.72017, 10.9068), (0.161053, 0), (-24.6246, 0)]),
]


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
    model = kanedyn.load(HERE.parent / "bicycle.yaml")
    v_w = crossing(model, 4.0, 5.0, True)
    v_c = crossing(model, 6.0, 6.5, False)
    print(f"weave speed   {v_w:.12f} m/s (paper {PUBLISHED_V_W})")
    print(f"capsize speed {v_c:.12f} m/s (paper {PUBLISHED_V_C})")
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
    for v, pairs in TABLE_2:
        for re, im in pairs:
            ax.plot(v, re, "o", color="C0", ms=4, mfc="none")
            if im != 0:
                ax.plot(v, im, "s", color="C1", ms=4, mfc="none")
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
