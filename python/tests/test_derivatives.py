"""derivatives() and derivatives_batch(): the O(N) route from Python, checked against the
assembled route (eom), against each other, across threads and for every array layout."""

from __future__ import annotations

import threading

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES


def states(m: kanedyn.Model, count: int, seed: int = 1):
    """`count` random states: unit Euler parameters, translations and speeds of order 0.1-1."""
    rng = np.random.default_rng(seed)
    n = m.N
    X = np.empty((count, 7 * n))
    eps = rng.normal(size=(count, n, 4))
    X[:, : 4 * n] = (eps / np.linalg.norm(eps, axis=2, keepdims=True)).reshape(count, 4 * n)
    X[:, 4 * n :] = m.initial_state().x[4 * n :] + 0.01 * rng.normal(size=(count, 3 * n))
    Y = rng.normal(size=(count, 6 * n))
    return X, Y


def test_derivatives_agree_with_the_assembled_route(eight) -> None:
    X, Y = states(eight, 5)
    for x, y in zip(X, Y):
        xdot, ydot = eight.derivatives(x, y)
        e = eight.eom(kanedyn.State(x, y))
        # Two routes to the same solution of Eq. (36): they differ by round-off only, and
        # [A]'s condition number on this model is about 1e6 (ydot up to ~1e3).
        scale = np.abs(e.ydot).max()
        assert np.abs(ydot - e.ydot).max() <= 1e-9 * scale
        assert np.abs(xdot - e.xdot).max() <= 1e-12 * max(1.0, np.abs(e.xdot).max())
        assert xdot.shape == (56,) and ydot.shape == (48,)
        assert xdot.flags["C_CONTIGUOUS"] and ydot.dtype == np.float64


def test_batch_equals_looped_derivatives_bit_for_bit() -> None:
    m = kanedyn.load(EXAMPLES / "chain64.yaml")
    X, Y = states(m, 301)
    for threads in (0, 1, 2, 3, 500):
        Xd, Yd = m.derivatives_batch(X, Y, threads=threads)
        assert Xd.shape == X.shape and Yd.shape == Y.shape
        for i in (0, 1, 150, 299, 300):
            xdot, ydot = m.derivatives(X[i], Y[i])
            assert Xd[i].tobytes() == xdot.tobytes() and Yd[i].tobytes() == ydot.tobytes()
    Xd1, Yd1 = m.derivatives_batch(X, Y, threads=1)
    Xd2, Yd2 = m.derivatives_batch(X, Y, threads=2)
    assert Xd1.tobytes() == Xd2.tobytes() and Yd1.tobytes() == Yd2.tobytes()


def test_batch_into_given_outputs(eight) -> None:
    X, Y = states(eight, 50)
    want = eight.derivatives_batch(X, Y)
    out = (np.full_like(X, np.nan), np.full_like(Y, np.nan))
    got = eight.derivatives_batch(X, Y, out=out)
    assert got[0] is out[0] and got[1] is out[1]
    assert out[0].tobytes() == want[0].tobytes() and out[1].tobytes() == want[1].tobytes()
    with pytest.raises(ValueError, match=r"out: Xd must have shape \(50, 56\)"):
        eight.derivatives_batch(X, Y, out=(out[0][:10], out[1]))
    with pytest.raises(ValueError, match="C-contiguous and writeable"):
        eight.derivatives_batch(X, Y, out=(np.asfortranarray(out[0]), out[1]))
    frozen = out[1].copy()
    frozen.setflags(write=False)
    with pytest.raises(ValueError, match="C-contiguous and writeable"):
        eight.derivatives_batch(X, Y, out=(out[0], frozen))
    with pytest.raises(TypeError, match="float64"):
        eight.derivatives_batch(X, Y, out=(out[0].astype(np.float32), out[1]))
    with pytest.raises(ValueError, match="share memory with X or Y"):
        eight.derivatives_batch(X, Y, out=(X, out[1]))
    with pytest.raises(TypeError, match="a pair"):
        eight.derivatives_batch(X, Y, out=out[0])


def test_empty_batch(eight) -> None:
    Xd, Yd = eight.derivatives_batch(np.empty((0, 56)), np.empty((0, 48)))
    assert Xd.shape == (0, 56) and Yd.shape == (0, 48)


def test_non_contiguous_and_other_layouts_are_read_correctly(eight) -> None:
    X, Y = states(eight, 4)
    want = [eight.derivatives(x, y) for x, y in zip(X, Y)]
    # Every other element of a wider array, a reversed view, Fortran order, a list.
    wide_x = np.zeros((4, 112))
    wide_x[:, ::2] = X
    assert eight.derivatives(wide_x[0, ::2], Y[0])[1].tobytes() == want[0][1].tobytes()
    rev = Y[1][::-1].copy()[::-1]
    assert not rev.flags["C_CONTIGUOUS"] or rev.strides[0] < 0
    assert eight.derivatives(X[1], rev)[1].tobytes() == want[1][1].tobytes()
    assert eight.derivatives(X[2].tolist(), list(Y[2]))[0].tobytes() == want[2][0].tobytes()
    Xf, Yf = np.asfortranarray(X), np.asfortranarray(Y)
    Xd, Yd = eight.derivatives_batch(Xf, Yf)
    Xw, Yw = eight.derivatives_batch(wide_x[:, ::2], Y)
    for i in range(4):
        assert Yd[i].tobytes() == want[i][1].tobytes() == Yw[i].tobytes()
        assert Xd[i].tobytes() == want[i][0].tobytes() == Xw[i].tobytes()
    # Unaligned doubles inside packed records are copied before they are read.
    rec = np.zeros(56, dtype=[("pad", "u1"), ("v", "<f8")])
    rec["v"] = X[3]
    assert rec["v"].strides[0] == 9
    assert eight.derivatives(rec["v"], Y[3])[0].tobytes() == want[3][0].tobytes()


def test_threads_calling_into_one_model_at_once_agree() -> None:
    m = kanedyn.load(EXAMPLES / "chain64.yaml")  # 64 bodies: the GIL is released
    X, Y = states(m, 40)
    want = [m.derivatives(x, y)[1].tobytes() for x, y in zip(X, Y)]
    want_batch = m.derivatives_batch(X, Y)[1].tobytes()
    failures = []

    def work(seed: int) -> None:
        order = np.random.default_rng(seed).permutation(40)
        for _ in range(5):
            for i in order:
                if m.derivatives(X[i], Y[i])[1].tobytes() != want[i]:
                    failures.append((seed, int(i)))
            if m.derivatives_batch(X, Y, threads=2)[1].tobytes() != want_batch:
                failures.append((seed, "batch"))
            if m.eom(kanedyn.State(X[seed], Y[seed])).ydot.shape != (384,):
                failures.append((seed, "eom"))

    threads = [threading.Thread(target=work, args=(s,)) for s in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert failures == []


def test_a_simulation_follows_its_own_derivatives(eight) -> None:
    """The rows of simulate() are states the derivatives integrate between: a central
    difference over two output rows matches the derivative at the middle row to the
    truncation error of the difference, dt^2/6 times the third derivative. The stiff bushings
    make y's large: the difference is off by 4e-3 at dt = 1e-5 (0.05 at 1e-4); the
    integrator's error (rtol 1e-11) over 2 dt is 1e-5. A wrong {y dot} is off by far more
    than the bound, 1e-3 of its scale."""
    dt = 1e-5
    r = eight.simulate(t_end=200 * dt, dt_out=dt, rtol=1e-11, atol=1e-13)
    i = 100
    xdot, ydot = eight.derivatives(r.x[i], r.y[i])
    central_x = (r.x[i + 1] - r.x[i - 1]) / (2 * dt)
    assert np.abs(central_x - xdot).max() <= 1e-3 * max(1.0, np.abs(xdot).max())
    central_y = (r.y[i + 1] - r.y[i - 1]) / (2 * dt)
    assert np.abs(central_y - ydot).max() <= 1e-3 * max(1.0, np.abs(ydot).max())
