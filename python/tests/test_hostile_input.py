"""Hostile arguments: paths with a NUL byte, more threads than the machine has (and threads that
cannot be started), integers beyond 64 bits, Euler parameters that cannot be normalized, and
results whose arrays were overwritten before to_csv. Each gives a Python exception that says
what is wrong; none cuts a path, aborts the interpreter or leaves a file behind."""

from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import sys
import textwrap
import threading
import time
from typing import Callable, List

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES, run_tool

# --- paths -------------------------------------------------------------------------------------


def test_paths_with_a_nul_byte_are_refused_as_open_refuses_them(eight, tmp_path) -> None:
    # The name before the NUL exists, so that a path cut at the NUL would be read or written.
    shutil.copy(EXAMPLES / "eight_body.yaml", tmp_path / "a")
    r = eight.simulate(t_end=0.02)
    r.to_csv(tmp_path / "a.csv")
    before = sorted(p.name for p in tmp_path.iterdir())
    cut = str(tmp_path / "a")
    with pytest.raises(ValueError, match="embedded null byte") as python_own:
        open(cut + "\x00.yaml")
    calls: List[Callable[[], object]] = [
        lambda: kanedyn.load(cut + "\x00.yaml"),
        lambda: kanedyn.load(os.fsencode(cut) + b"\x00.yaml"),
        lambda: kanedyn.load(pathlib.PurePosixPath(cut + "\x00.yaml")),
        lambda: kanedyn.read_csv(eight, cut + ".csv\x00.old"),
        lambda: kanedyn.Result.read_csv(eight, os.fsencode(cut + ".csv\x00")),
        lambda: eight.simulate(t_end=0.02, output=cut + "\x00.csv"),
        lambda: eight.simulate(t_end=0.02, output=str(tmp_path / "new") + "\x00.csv"),
        lambda: r.to_csv(cut + "\x00.csv"),
        lambda: r.to_csv(str(tmp_path / "new") + "\x00.csv"),
        lambda: r.view(str(tmp_path / "new") + "\x00.html"),
    ]
    for call in calls:
        with pytest.raises(ValueError) as caught:
            call()
        assert str(caught.value) == str(python_own.value) == "embedded null byte"
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert (tmp_path / "a").read_bytes() == (EXAMPLES / "eight_body.yaml").read_bytes()


def test_paths_are_what_open_takes(eight, tmp_path) -> None:
    """str, bytes and os.PathLike, as open(); bytes were once written as the text "b'...'"."""
    m = kanedyn.load(os.fsencode(EXAMPLES / "eight_body.yaml"))
    assert m.path == str(EXAMPLES / "eight_body.yaml")
    r = m.simulate(t_end=0.02, output=os.fsencode(tmp_path / "run.csv"))
    assert r.path == str(tmp_path / "run.csv") and (tmp_path / "run.csv").exists()
    r.to_csv(os.fsencode(tmp_path / "copy.csv"))
    back = kanedyn.read_csv(m, os.fsencode(tmp_path / "copy.csv"))
    assert back.path == str(tmp_path / "copy.csv")
    assert np.array_equal(back.x, r.x) and np.array_equal(back.y, r.y)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["copy.csv", "run.csv"]
    with pytest.raises(TypeError, match=r"path must be a path \(str, bytes or os.PathLike\), not int"):
        r.to_csv(3)
    with pytest.raises(TypeError, match="output must be a path"):
        m.simulate(t_end=0.02, output=3.5)
    with pytest.raises(TypeError, match="path or a dict"):
        kanedyn.load(bytearray(b"x.yaml"))


