#!/usr/bin/env python3
"""The notes' partial velocity matrices from Python: for body 8 of the eight-body system, the
block form of [v_G8,y] as the notes print it after Eq. (27), its numbers at the initial state,
and two checks of what it means: {v_G8} = [v_G8,y]{y} (Eq. 17 against Eqs. 18-21), and the
generalized forces {F_y} = sum_K [v_GK,y]^T {F_K} + [w'_K,y]^T {M'_K} (Eq. 31).

    PYTHONPATH=build/python python3 examples/python/partial_velocities.py
"""

from __future__ import annotations

import pathlib

import numpy as np

import kanedyn

HERE = pathlib.Path(__file__).resolve().parent


def main() -> None:
    m = kanedyn.load(HERE.parent / "eight_body.yaml")
    s = m.initial_state()
    q = m.inspect(s)
    b = q[8]
    print(f"body 8 '{b.name}': L(8) = {b.L}, u_8 = {b.u}, chain {b.chain}")
    print(m.symbolic_partial(8, point="G"))
    print(m.symbolic_partial(8, point="G", rate=True))
    np.set_printoptions(precision=4, suppress=True, linewidth=120)
    n = m.N
    for c, body in enumerate(b.chain[:-1]):
        print(f"\nblock of w'_{body} in [v_G8,y1]:\n{b.v_G_y[:, 3 * (body - 1) : 3 * body]}")
        print(f"block of s'_{body} dot in [v_G8,y2]:\n{b.v_G_y[:, 3 * n + 3 * (body - 1) : 3 * n + 3 * body]}")

    v = b.v_G_y @ s.y
    print(f"\n[v_G8,y]{{y}} = {v}\n{{v_G8}}     = {b.v_G}  (difference {np.abs(v - b.v_G).max():.2e})")
    F_y = sum(body.v_G_y.T @ body.F + body.w_y.T @ body.M for body in q.bodies)
    print(f"Eq. (31) summed from the per-body terms matches {{F_y}} to {np.abs(F_y - q.F_y).max():.2e}")


if __name__ == "__main__":
    main()
