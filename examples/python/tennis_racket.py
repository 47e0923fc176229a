#!/usr/bin/env python3
"""The tennis racket (Dzhanibekov) effect from the eigenvalues of the linearized spin.

examples/tennis_racket.yaml is one free rigid body without gravity, principal moments
I1 < I2 < I3 about its body axes x, y, z. The script linearizes the torque-free spin at
w0 = 6 rad/s about each principal axis (Model.linearize at q = identity, z = w0 e_i) and
prints the eigenvalues. About the intermediate axis y one is real and positive: a wobble grows
as exp(lambda t) with Euler's rate

    lambda = w0 sqrt((I2 - I1)(I3 - I2) / (I1 I3)),

from I1 dw1/dt = (I2 - I3) w0 dw3 and I3 dw3/dt = (I1 - I2) w0 dw1, whose product gives
d^2(dw1)/dt^2 = lambda^2 dw1. About x and z the same algebra gives lambda^2 < 0: the wobble
turns at |lambda| and stays small. The eigenvalues are compared with those rates, and the
growth is read off the nonlinear simulation of the file's spin too.

    PYTHONPATH=build/python python3 examples/python/tennis_racket.py
"""

from __future__ import annotations

import pathlib

import numpy as np

import kanedyn

HERE = pathlib.Path(__file__).resolve().parent
W0 = 6.0  # rad/s, the spin of the model file's initial state


def euler_rate_squared(I: np.ndarray, i: int) -> float:
    """lambda^2 of a small wobble about a spin w0 about principal axis i (Euler's equations):
    w0^2 (I_i - I_j)(I_k - I_i) / (I_j I_k) for the other two axes j, k."""
    j, k = (i + 1) % 3, (i + 2) % 3
    return W0 * W0 * (I[i] - I[j]) * (I[k] - I[i]) / (I[j] * I[k])


def main() -> None:
    racket = kanedyn.load(HERE.parent / "tennis_racket.yaml")
    I = np.diag(racket.inertia[0])
    print(f"principal moments I1, I2, I3 = {I[0]}, {I[1]}, {I[2]} kg m^2 (body x, y, z)")
    # q of a free body is its Euler parameters (e4 scalar) then s'; z is w' then s' dot.
    identity = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    for i, axis in enumerate("xyz"):
        z = np.zeros(6)
        z[i] = W0
        lin = racket.linearize(q=identity, z=z)
        # A spinning free body gives a periodic linear system (lin.periodic): its orientation
        # turns with the spin, and the rotation-vector part of the state sees the turning
        # -[w0~]. The eigenvalues of one instant need not decide the stability of such a
        # system, but here they do: torque-free, the rates' equations (Euler's) do not depend
        # on the orientation, so the rates' block of A is a constant linear system of its own
        # and the orientation only follows it (A is block triangular). Its eigenvalues are
        # the wobble's growth rates; the rotation-vector block adds 0 and +-i w0, the spin's
        # own turning, and the mass centre's translation adds zeros.
        assert lin.periodic
        largest = lin.eigenvalues[0]  # sorted by decreasing real part
        l2 = euler_rate_squared(I, i)
        shown = ", ".join(f"{v.real:.4g}{v.imag:+.4g}i" for v in lin.eigenvalues)
        print(f"spin about {axis}: eigenvalues {shown}")
        if l2 > 0:
            rate = np.sqrt(l2)
            print(
                f"  unstable: largest real part {largest.real:.15g} /s, Euler's rate {rate:.15g} /s, "
                f"relative difference {abs(largest.real - rate) / rate:.2e}"
            )
        else:
            frequency = np.sqrt(-l2)
            wobble = lin.eigenvalues[np.argmin(np.abs(np.abs(lin.eigenvalues.imag) - frequency))]
            print(
                f"  stable wobble: largest real part {largest.real:.2e} /s, wobble at {abs(wobble.imag):.15g} rad/s, "
                f"Euler's {frequency:.15g} rad/s"
            )

    # The nonlinear motion of the file: a wobble of 0.001 rad/s about x on the spin about y.
    # Both the growing and the decaying modes start equal, so w1 ~ cosh(lambda t) while small;
    # from 0.5 s to 1 s its logarithm grows nearly at lambda (a fraction of a percent less).
    r = racket.simulate(t_end=1.0, dt_out=0.5)
    w1 = np.abs(r["racket.w1"])
    measured = np.log(w1[2] / w1[1]) / 0.5
    print(f"simulated wobble grows at {measured:.3f} /s from 0.5 s to 1 s (Euler's rate {np.sqrt(euler_rate_squared(I, 1)):.3f} /s)")


if __name__ == "__main__":
    main()
