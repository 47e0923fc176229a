"""Repeated calls hold no memory: the resident set after 10,000 more calls of each entry point
stays within 2 MB (a leak of 200 bytes per call, e.g. one array of 25 doubles, would exceed
it; the workspace of one eom() call is about 100 kB)."""

from __future__ import annotations

import os

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES

CALLS = 10_000
ALLOWED = 2 * 1024 * 1024


def rss() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def grows(call) -> int:
    for _ in range(1000):  # warm-up: pools, caches, the allocator's arenas
        call()
    before = rss()
    for _ in range(CALLS):
        call()
    return rss() - before


@pytest.fixture(scope="module")
def m() -> kanedyn.Model:
    return kanedyn.load(EXAMPLES / "eight_body.yaml")


def test_derivatives(m) -> None:
    s = m.initial_state()
    x, y = s.x.copy(), s.y.copy()
    assert grows(lambda: m.derivatives(x, y)) < ALLOWED


def test_derivatives_batch(m) -> None:
    s = m.initial_state()
    X, Y = np.tile(s.x, (4, 1)), np.tile(s.y, (4, 1))
    assert grows(lambda: m.derivatives_batch(X, Y, threads=2)) < ALLOWED


def test_eom_and_inspect(m) -> None:
    s = m.initial_state()
    assert grows(lambda: m.eom(s).A) < ALLOWED
    assert grows(lambda: m.inspect(s, bodies=[8])[8].v_G_y) < ALLOWED


def test_errors(m) -> None:
    s = m.initial_state()
    bad = s.x.copy()
    bad[0] = np.nan

    def fail() -> None:
        try:
            m.derivatives(bad, s.y)
        except ValueError:
            pass
        try:
            kanedyn.loads("format: kanedyn-model/1\nbodies: 3\n")
        except kanedyn.ModelError:
            pass

    assert grows(fail) < ALLOWED


def test_simulate(m) -> None:
    assert grows(lambda: m.simulate(t_end=0.001, dt_out=0.001).x) < ALLOWED
