#!/usr/bin/env python3
"""The eight-body stiffness grid (eight_body_stiffness.yaml): the pelvis's lowest point and its
swing (rms of pelvis.w2) over the lumbar bushing's translational stiffness, one line per
rotational stiffness. Writes FOLDER/eight_body_stiffness.png.

    build/kanedyn sweep examples/studies/eight_body_stiffness.yaml -o stiffness
    python3 examples/studies/plot_eight_body_stiffness.py stiffness
"""

from __future__ import annotations

import csv
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

K = "forces[1].stiffness"
KR = "forces[1].rotational_stiffness"


def main(folder: pathlib.Path) -> None:
    with open(folder / "results.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["status"] == "ok"]
    k = np.array([float(r[K]) for r in rows])
    kr = np.array([float(r[KR]) for r in rows])
    fig, (sag, swing) = plt.subplots(1, 2, figsize=(10, 4))
    for value in sorted(set(kr)):
        on = kr == value
        order = np.argsort(k[on])
        sag.semilogx(k[on][order], [float(rows[i]["min:pelvis.z"]) for i in np.flatnonzero(on)[order]],
                     "o-", label=f"kr = {value:g} N m/rad")
        swing.semilogx(k[on][order], [float(rows[i]["rms:pelvis.w2"]) for i in np.flatnonzero(on)[order]],
                       "o-", label=f"kr = {value:g} N m/rad")
    sag.set_xlabel("lumbar bushing stiffness (N/m)")
    sag.set_ylabel("lowest pelvis z (m)")
    swing.set_xlabel("lumbar bushing stiffness (N/m)")
    swing.set_ylabel("rms of pelvis w2 (rad/s)")
    swing.legend(fontsize=8)
    fig.suptitle("Eight-body figure: a grid over the lumbar bushing")
    fig.tight_layout()
    fig.savefig(folder / "eight_body_stiffness.png", dpi=120)
    print(f"wrote {folder / 'eight_body_stiffness.png'}")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "stiffness"))
