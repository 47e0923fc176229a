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


# --- threads -----------------------------------------------------------------------------------


def _threads_of_this_process() -> int:
    return len(os.listdir("/proc/self/task"))


@pytest.mark.skipif(not os.path.isdir("/proc/self/task"), reason="counts threads in /proc")
def test_batch_threads_are_capped_at_the_cores() -> None:
    chain = kanedyn.load(EXAMPLES / "chain64.yaml")
    s = chain.initial_state()
    X = np.tile(s.x, (20000, 1))
    Y = np.tile(s.y, (20000, 1))
    want = chain.derivatives_batch(X[:50], Y[:50], threads=1)
    for many in (os.cpu_count() or 1) + 5, 10**20:
        got = chain.derivatives_batch(X[:50], Y[:50], threads=many)
        assert got[0].tobytes() == want[0].tobytes() and got[1].tobytes() == want[1].tobytes()
    # Count the threads while a batch asks for 64: the caller, and at most one more per core
    # besides the one the caller's thread works on.
    baseline = _threads_of_this_process()
    done = threading.Event()

    def batch() -> None:
        chain.derivatives_batch(X, Y, threads=64)
        done.set()

    caller = threading.Thread(target=batch)
    caller.start()
    most = 0
    while not done.is_set():
        most = max(most, _threads_of_this_process())
        time.sleep(0.0005)
    caller.join()
    cores = os.cpu_count() or 1
    assert baseline + 1 <= most <= baseline + 1 + (cores - 1), (baseline, most, cores)


_THREAD_LIMIT_SCRIPT = """
import os, resource, sys
import numpy as np
import kanedyn

which, out = sys.argv[1], sys.argv[2]
m = kanedyn.load({model!r})
s = m.initial_state()
X = np.tile(s.x, (64, 1))
Y = np.tile(s.y, (64, 1))
target = (np.empty_like(X), np.empty_like(Y))
# Everything the calls need besides the new thread is made now, on this thread alone (a
# thread that ran and ended would leave its stack cached for the next one).
m.derivatives_batch(X, Y, threads=1, out=target)
m.simulate(t_end=0.05)
size = int(next(l for l in open("/proc/self/status") if l.startswith("VmSize:")).split()[1])
# 2 MiB more address space than is mapped: no thread stack (8 MiB by default) fits.
resource.setrlimit(resource.RLIMIT_AS, (size * 1024 + (2 << 20), resource.RLIM_INFINITY))
try:
    if which == "batch":
        m.derivatives_batch(X, Y, threads=2, out=target)
    else:
        m.simulate(t_end=0.05, output=out)
    outcome = "no error"
except Exception as e:
    outcome = type(e).__name__ + ": " + str(e)
finally:
    resource.setrlimit(resource.RLIMIT_AS, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))
print(outcome)
"""


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="reads VmSize from /proc")
@pytest.mark.parametrize("which", ["batch", "simulate"])
def test_a_thread_that_cannot_start_is_an_exception(which, tmp_path) -> None:
    """RLIMIT_AS just above what the process has mapped, so that a thread's stack cannot be
    mapped (RLIMIT_NPROC would do for a user, but is not enforced for root). The interpreter
    must get a RuntimeError and exit normally, not abort (returncode -6)."""
    if which == "batch" and (os.cpu_count() or 1) < 2:
        pytest.skip("one core: derivatives_batch starts no thread")
    out = tmp_path / "run.csv"
    script = _THREAD_LIMIT_SCRIPT.format(model=str(EXAMPLES / "eight_body.yaml"))
    done = subprocess.run(
        [sys.executable, "-c", script, which, str(out)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, (done.returncode, done.stderr[-2000:])
    if which == "batch":
        assert done.stdout.startswith("RuntimeError: derivatives_batch(): cannot start thread 2 of 2"), done.stdout
        assert "ask for fewer threads" in done.stdout
    else:
        assert done.stdout.startswith("RuntimeError: cannot start the thread that writes"), done.stdout
        assert str(out) + ".partial" in done.stdout
    # The run had not begun: neither the CSV nor a partial file with only its header is left.
    assert not any(tmp_path.iterdir())


# --- integers ----------------------------------------------------------------------------------


def test_integers_out_of_range_name_the_range(eight) -> None:
    for bodies in (10**20, [10**20], [-(10**20)], np.int64(9), [0]):
        with pytest.raises(ValueError, match=r"bodies: body number -?\d+ is not in 1\.\.8"):
            eight.inspect(bodies=bodies)
    with pytest.raises(ValueError, match=r"body number .*digits.* is not in 1\.\.8"):
        eight.inspect(bodies=10**5000)
    assert [b.K for b in eight.inspect(bodies=np.int64(3)).bodies] == [3]
    assert [b.K for b in eight.inspect(bodies=np.array([2, 5])).bodies] == [2, 5]
    with pytest.raises(ValueError, match=r"body number 100000000000000000000 is not in 1\.\.8"):
        eight.symbolic_partial(10**20)
    with pytest.raises(KeyError, match="no body 100000000000000000000"):
        eight.inspect(bodies=[1])[10**20]
    s = eight.initial_state()
    with pytest.raises(ValueError, match="t must be finite"):
        eight.derivatives(s.x, s.y, 10**400)
    with pytest.raises(ValueError, match=r"t_end must be a finite number > 0, got 1000"):
        eight.simulate(t_end=10**400)
    with pytest.raises(TypeError, match="t_end must be a number, got bool"):
        eight.simulate(t_end=True)
    X, Y = np.tile(s.x, (3, 1)), np.tile(s.y, (3, 1))
    with pytest.raises(ValueError, match="threads must be >= 0"):
        eight.derivatives_batch(X, Y, threads=-(10**20))
    with pytest.raises(TypeError, match="threads must be an integer, got float"):
        eight.derivatives_batch(X, Y, threads=2.0)
    with pytest.raises(ValueError, match=r"calls 100000000000000000000 is not in 1\.\."):
        eight._time_derivatives(None, 10**20)
    # A broadcast array can claim 7N numbers for N beyond the library's int.
    big = 2**31
    with pytest.raises(ValueError, match=r"x must have shape \(7N,\) for N in 1\.\.306783378"):
        kanedyn.State(np.broadcast_to(0.0, (7 * big,)), np.broadcast_to(0.0, (6 * big,)))


# --- State.normalize ---------------------------------------------------------------------------


def test_normalize_refuses_a_norm_it_cannot_divide_by() -> None:
    s = kanedyn.State(np.zeros(7), np.zeros(6))
    with pytest.raises(ValueError, match=r"body 1 \(x\[0:4\]\) have norm 0"):
        s.normalize()
    assert np.array_equal(s.x, np.zeros(7))  # unchanged, not nan
    x = np.zeros(14)
    x[0:4] = [0, 0, 0, 2]
    two = kanedyn.State(x, np.zeros(12))
    with pytest.raises(ValueError, match=r"body 2 \(x\[4:8\]\) have norm 0"):
        two.normalize()
    assert two.x[3] == 2.0  # body 1 not rescaled either: nothing changes
    two.x[4:8] = [np.nan, 0, 0, 1]
    with pytest.raises(ValueError, match=r"body 2 .* have norm nan"):
        two.normalize()
    two.x[4:8] = [0, 0, 0, np.inf]
    with pytest.raises(ValueError, match=r"body 2 .* have norm inf"):
        two.normalize()
    two.x[4:8] = [0, 0, 3, 4]
    assert two.normalize() == 4.0  # the largest | |eps_K| - 1 |
    assert np.allclose(two.x[:8], [0, 0, 0, 1, 0, 0, 0.6, 0.8])


# --- Result.to_csv -----------------------------------------------------------------------------


def _spoiled(r: kanedyn.Result, array: str, index: tuple, value: float) -> kanedyn.Result:
    copy = kanedyn.Result(r.model, r.t.copy(), r.x.copy(), r.y.copy(), r.p_G, r.energy.copy(), r.stats,
                          None, None if r.q is None else r.q.copy(), None if r.z is None else r.z.copy())
    getattr(copy, array)[index] = value
    return copy


def test_to_csv_refuses_rows_the_reader_would_refuse(eight, tmp_path) -> None:
    r = eight.simulate(t_end=0.05)
    path = tmp_path / "run.csv"
    cases = [
        ("x", (1, 5), np.nan, r"x\[1, 5\] is nan \(body 'pelvis' \(e2\)\)"),
        ("x", (2, 40), np.inf, r"x\[2, 40\] is inf \(body .*\(s"),
        ("y", (3, 47), -np.inf, r"y\[3, 47\] is -inf \(body 'left_forearm' \(sd3\)\)"),
        ("t", (4,), np.nan, r"t\[4\] is nan"),
        ("energy", (5,), np.nan, r"energy\[5\] is nan"),
        ("x", (2, 3), 1.01, r"x\[2, 0:4\]: the Euler parameters of body 'torso' have norm 1.01"),
        ("t", (3,), -1.0, r"t\[3\] is before t\[2\]"),
        ("x", (1, 32), 1e308, r"row 1: the mass centre of body '\w+' is not finite"),
    ]
    for array, index, value, message in cases:
        bad = _spoiled(r, array, index, value)
        if message.startswith("row 1"):
            bad.x[1, 35] = 1e308  # a second translation, so that a sum overflows
        with pytest.raises(ValueError, match="to_csv: " + message) as caught:
            bad.to_csv(path)
        assert "nothing was written" in str(caught.value)
        assert not path.exists() and not (tmp_path / "run.csv.partial").exists(), message
    empty = kanedyn.Result(eight, r.t[:0], r.x[:0], r.y[:0], r.p_G[:0], r.energy[:0], {})
    with pytest.raises(ValueError, match="no rows"):
        empty.to_csv(path)
    # A refused write leaves an existing file as it was.
    r.to_csv(path)
    kept = path.read_bytes()
    with pytest.raises(ValueError):
        _spoiled(r, "x", (0, 0), np.nan).to_csv(path)
    assert path.read_bytes() == kept and not (tmp_path / "run.csv.partial").exists()


def test_to_csv_refuses_a_jointed_models_bad_rows(tmp_path) -> None:
    m = kanedyn.load(EXAMPLES / "human_jointed.yaml")
    r = m.simulate(t_end=0.05)
    assert r.q is not None and r.z is not None
    with pytest.raises(ValueError, match=r"to_csv: z\[2, 0\] is nan"):
        _spoiled(r, "z", (2, 0), np.nan).to_csv(tmp_path / "j.csv")
    with pytest.raises(ValueError, match=r"to_csv: q\[1, 3\] is inf"):
        _spoiled(r, "q", (1, 3), np.inf).to_csv(tmp_path / "j.csv")
    at = m.joint_layout["head"][0]  # a spherical joint: its q are Euler parameters
    bad = _spoiled(r, "q", (1, at), 0.0)
    bad.q[1, at : at + 4] = [0.0, 0.0, 0.0, 2.0]
    with pytest.raises(ValueError, match=rf"q\[1, {at}:{at + 4}\]: the spherical joint's Euler parameters of body 'head' have norm 2"):
        bad.to_csv(tmp_path / "j.csv")
    assert not any(tmp_path.iterdir())
    r.to_csv(tmp_path / "j.csv")
    back = kanedyn.read_csv(m, tmp_path / "j.csv")
    assert np.array_equal(back.q, r.q) and np.array_equal(back.z, r.z)
    done = run_tool(["eom", EXAMPLES / "human_jointed.yaml", "--trajectory", tmp_path / "j.csv", "--t", 0.05])
    assert done.returncode == 0, done.stderr


def test_a_written_csv_reads_back_and_the_tool_reads_it(eight, tmp_path) -> None:
    r = eight.simulate(t_end=0.05)
    r.x[2, 0:4] *= 1 + 0.9e-6  # within the reader's 1e-6: still written, still read
    path = tmp_path / "run.csv"
    r.to_csv(path)
    back = kanedyn.Result.read_csv(eight, path)
    assert np.array_equal(back.t, r.t) and np.array_equal(back.x, r.x) and np.array_equal(back.y, r.y)
    assert np.array_equal(back.energy, r.energy)
    for t in (0.0, float(r.t[2]), float(r.t[-1])):
        done = run_tool(["eom", EXAMPLES / "eight_body.yaml", "--trajectory", path, "--t", t])
        assert done.returncode == 0, done.stderr
