#!/usr/bin/env python3
"""The tennis-racket Monte Carlo (tennis_flip.yaml): the time of the first flip of each run,
read from its trajectory (the first row where racket.w2 changes sign, interpolated linearly),
as a histogram and against the initial wobble. Writes FOLDER/tennis_flip.png.

    build/kanedyn sweep examples/studies/tennis_flip.yaml -o tennis_flip
    python3 examples/studies/plot_tennis_flip.py tennis_flip
"""

from __future__ import annotations

import csv
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

WOBBLE = "bodies[racket].initial.angular_velocity[0]"


def flip_time(trajectory: pathlib.Path) -> float:
    """The first time racket.w2 crosses zero; nan if it never does."""
    data = np.genfromtxt(trajectory, delimiter=",", names=True)
    t, w2 = data["t"], data["racketw2"]
    crossing = np.flatnonzero(np.sign(w2[1:]) != np.sign(w2[:-1]))
    if crossing.size == 0:
        return float("nan")
    i = crossing[0]
    return float(t[i] - w2[i] * (t[i + 1] - t[i]) / (w2[i + 1] - w2[i]))


def main(folder: pathlib.Path) -> None:
    with open(folder / "results.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["status"] == "ok"]
    wobble = np.array([float(r[WOBBLE]) for r in rows])
    flips = np.array([flip_time(folder / "runs" / f"run_{int(r['run']):06d}.csv") for r in rows])
    flipped = np.isfinite(flips)
    print(f"{flipped.sum()} of {len(rows)} runs flipped within the run; first flip "
          f"{np.nanmean(flips):.3f} s on average, {np.nanstd(flips):.3f} s spread (std)")
    fig, (hist, scatter) = plt.subplots(1, 2, figsize=(10, 4))
    hist.hist(flips[flipped], bins=30)
    hist.set_xlabel("time of the first flip (s)")
    hist.set_ylabel("runs")
    scatter.semilogx(wobble[flipped], flips[flipped], ".")
    scatter.set_xlabel("initial wobble w1 (rad/s)")
    scatter.set_ylabel("time of the first flip (s)")
    fig.suptitle("Tennis racket: the flip time over uncertain initial rates")
    fig.tight_layout()
    fig.savefig(folder / "tennis_flip.png", dpi=120)
    print(f"wrote {folder / 'tennis_flip.png'}")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "tennis_flip"))
