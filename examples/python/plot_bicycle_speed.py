#!/usr/bin/env python3
"""The bicycle's stability map over its forward speed, from the table of the study
examples/studies/bicycle_speed.yaml (docs/bicycle.md, "A stability map as a study"): the real
parts of the weave, capsize and castering modes and the weave's imaginary part against the
speed, and the weave and capsize speeds where the real parts cross zero (linear interpolation
between the two speeds of the grid around each crossing).

    build/kanedyn sweep examples/studies/bicycle_speed.yaml -o bicycle_speed
    python3 examples/python/plot_bicycle_speed.py bicycle_speed [OUT.png]

Reads FOLDER/results.csv only (no kanedyn module needed); writes OUT.png (default
FOLDER/bicycle_speed.png) with matplotlib.
"""

from __future__ import annotations

import csv
import pathlib
import sys
from typing import Dict, List

SPEED = "parameters.speed"


def read(folder: pathlib.Path) -> Dict[str, List[float]]:
    with open(folder / "results.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["status"] == "ok"]
    rows.sort(key=lambda r: float(r[SPEED]))
    return {name: [float(r[name]) for r in rows] for name in rows[0] if name != "status"}


def crossing(v: List[float], f: List[float], rising: bool) -> float:
    """The first speed at which f crosses zero downwards (rising: upwards), interpolated."""
    for i in range(len(v) - 1):
        a, b = f[i], f[i + 1]
        if (a > 0 >= b) if not rising else (a < 0 <= b):
            return v[i] + (v[i + 1] - v[i]) * a / (a - b)
    raise ValueError("no crossing in the table")


def main(folder: pathlib.Path, out: pathlib.Path) -> None:
    t = read(folder)
    v = t[SPEED]
    v_w = crossing(v, t["linearize:weave.real"], rising=False)
    v_c = crossing(v, t["linearize:capsize.real"], rising=True)
    print(f"weave speed   {v_w:.3f} m/s (Meijaard et al. 2007: 4.292)")
    print(f"capsize speed {v_c:.3f} m/s (Meijaard et al. 2007: 6.024)")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=120)
    ax.plot(v, t["linearize:weave.real"], color="C0", label="weave, real part")
    ax.plot(v, t["linearize:weave.imag"], "--", color="C0", label="weave, imaginary part")
    ax.plot(v, t["linearize:capsize.real"], color="C1", label="capsize")
    ax.plot(v, t["linearize:caster.real"], color="C3", label="castering")
    ax.axvspan(v_w, v_c, color="C2", alpha=0.12, label=f"self-stable ({v_w:.2f} to {v_c:.2f} m/s)")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_ylim(-10, 10)
    ax.set_xlabel("forward speed v [m/s]")
    ax.set_ylabel("eigenvalue [1/s]")
    ax.set_title("Whipple bicycle: kanedyn sweep examples/studies/bicycle_speed.yaml")
    ax.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    fig.savefig(out)
    print(f"figure: {out}")


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    folder = pathlib.Path(sys.argv[1])
    main(folder, pathlib.Path(sys.argv[2]) if len(sys.argv) == 3 else folder / "bicycle_speed.png")
