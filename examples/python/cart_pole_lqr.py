#!/usr/bin/env python3
"""LQR holds the cart-pole upright: linearize, design, simulate the closed loop.

examples/cart_pole.yaml is a cart on a rail (prismatic joint) with a pole on a hinge (revolute
joint) and one input, a force `push` on the cart. Its zero pose is the pole upright, an
unstable equilibrium. The script

1. linearizes the model there (Model.linearize): d(dx)/dt = A dx + B du with the state
   dx = (cart.j1, pole.j1, cart.jd1, pole.jd1), the deviations from the upright pose at rest;
2. designs the LQR gain K = R^-1 B^T P from the continuous algebraic Riccati equation
   (scipy.linalg.solve_continuous_are), which minimizes the integral of dx^T Q dx + du^T R du;
3. simulates the nonlinear model from the file's initial state (the pole tipped 0.2 rad) with
   the controller u = -K dx, sampled every 10 ms and held in between (Model.simulate's
   controller), and prints the pole's angle and the cart's position.

The pole stays within its initial tilt and settles upright; the cart returns to the origin.

    PYTHONPATH=build/python python3 examples/python/cart_pole_lqr.py
"""

from __future__ import annotations

import pathlib

import numpy as np
import scipy.linalg

import kanedyn

HERE = pathlib.Path(__file__).resolve().parent
# The weights: the pole's angle counts most, then the cart's position; the push is cheap
# enough that the gain acts within a second, slow enough for a 10 ms sampled controller.
Q = np.diag([10.0, 100.0, 1.0, 1.0])
R = np.array([[1.0]])
CONTROL_INTERVAL = 0.01  # s


def lqr_gain(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """K of u = -K x for d(x)/dt = A x + B u and the weights Q and R."""
    P = scipy.linalg.solve_continuous_are(A, B, Q, R)
    return np.linalg.solve(R, B.T @ P)


def main() -> None:
    cart = kanedyn.load(HERE.parent / "cart_pole.yaml")
    upright = cart.state(q=[0.0, 0.0], z=[0.0, 0.0])
    lin = cart.linearize(upright)
    print("state:", ", ".join(lin.state), "| inputs:", ", ".join(lin.inputs))
    print("open loop eigenvalues:", np.round(lin.eigenvalues, 4))
    # The upright pose is an equilibrium: nothing moves there without a push.
    assert np.abs(lin.zdot).max() < 1e-12

    K = lqr_gain(lin.A, lin.B)
    closed = np.linalg.eigvals(lin.A - lin.B @ K)
    print("LQR gain K:", np.round(K, 3))
    print("closed loop eigenvalues:", np.round(np.sort_complex(closed), 4))
    print(f"closed loop: largest real part {closed.real.max():.4f} /s")

    def lqr(t: float, s: kanedyn.State) -> np.ndarray:
        # The state in the linearization's coordinates: the tangent deviation of q from the
        # upright pose (for these joints simply q - 0), then z - 0.
        dx = np.concatenate([cart.tangent_difference(upright, s), s.z - upright.z])
        return lin.u - K @ dx

    r = cart.simulate(t_end=5.0, dt_out=0.01, controller=lqr, control_interval=CONTROL_INTERVAL)
    angle, position = r["pole.j1"], r["cart.j1"]
    for t in (0.0, 0.5, 1.0, 2.0, 3.0, 4.0, 5.0):
        i = int(round(t / 0.01))
        print(f"t = {t:3.1f} s: pole angle {angle[i]:+.3e} rad, cart at {position[i]:+.3e} m, push {r.u[i, 0]:+.3e} N")
    print(f"largest pole angle {np.abs(angle).max():.6f} rad")
    print(f"final pole angle {abs(angle[-1]):.3e} rad, cart {abs(position[-1]):.3e} m")


if __name__ == "__main__":
    main()
