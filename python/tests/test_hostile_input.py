"""Hostile arguments: paths with a NUL byte, more threads than the machine has (and threads that
cannot be started), integers beyond 64 bits, Euler parameters that cannot be normalized, and
results whose arrays were overwritten before to_csv or view; None, a str, an object or a huge
int for any argument of any public callable; files that are not regular files or not what the
reader expects; a controller that returns nothing; Ctrl-C in a long Simulator.step. Each gives
a Python exception that says what is wrong; none cuts a path, crashes or blocks the
interpreter or leaves a file behind."""

from __future__ import annotations

import json
import os
import pathlib
import shutil
import signal
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


def _study_dict(model: str) -> dict:
    return {
        "format": "kanedyn-study/1",
        "model": model,
        "vary": [{"key": "bodies[head].mass", "grid": [4.0, 6.0]}],
        "simulate": {"t_end": 0.01, "dt_out": 0.01},
        "outputs": [{"final": "head.z"}],
        "trajectories": "none",
    }


def test_paths_with_a_nul_byte_are_refused_as_open_refuses_them(eight, tmp_path) -> None:
    # The name before the NUL exists, so that a path cut at the NUL would be read or written.
    shutil.copy(EXAMPLES / "eight_body.yaml", tmp_path / "a")
    r = eight.simulate(t_end=0.02)
    r.to_csv(tmp_path / "a.csv")
    study = kanedyn.Study(_study_dict(str(EXAMPLES / "eight_body.yaml")))
    text = (EXAMPLES / "eight_body.yaml").read_text()
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
        lambda: kanedyn.loads(text, name=cut + "\x00.yaml"),
        lambda: kanedyn.Study(cut + "\x00.yaml"),
        lambda: kanedyn.Study(os.fsencode(cut) + b"\x00.yaml"),
        lambda: kanedyn.Study(_study_dict(cut + "\x00.yaml")),
        lambda: study.run(out=str(tmp_path / "new") + "\x00"),
        lambda: study.run(out=os.fsencode(tmp_path / "new") + b"\x00/x"),
        lambda: kanedyn.read_results(cut + ".csv\x00"),
    ]
    for call in calls:
        with pytest.raises(ValueError) as caught:
            call()
        assert str(caught.value) == str(python_own.value) == "embedded null byte"
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert (tmp_path / "a").read_bytes() == (EXAMPLES / "eight_body.yaml").read_bytes()
    # A study file can write the NUL as an escape: the study reader refuses that name too.
    (tmp_path / "s.yaml").write_text(
        'format: kanedyn-study/1\nmodel: "a\\0.yaml"\n'
        "vary:\n  - key: bodies[head].mass\n    grid: [4.0]\noutputs:\n  - final: head.z\n"
    )
    with pytest.raises(kanedyn.ModelError, match="the model file's name holds a NUL byte"):
        kanedyn.Study(tmp_path / "s.yaml")
    done = run_tool(["sweep", tmp_path / "s.yaml", "-o", tmp_path / "out"])
    assert done.returncode != 0 and "holds a NUL byte" in done.stderr, done.stderr


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


def test_to_csv_of_a_result_without_input_values_writes_zeros(tmp_path) -> None:
    """u=None means every input 0, as everywhere; to_csv once read the missing array's second
    axis (IndexError) after creating the file."""
    cart = kanedyn.load(EXAMPLES / "cart_pole.yaml")
    r = cart.simulate(t_end=0.02)
    bare = kanedyn.Result(cart, r.t, r.x, r.y, r.p_G, r.energy, {}, None, r.q, r.z, None)
    bare.to_csv(tmp_path / "u.csv")
    back = kanedyn.read_csv(cart, tmp_path / "u.csv")
    assert back.u is not None and back.u.shape == (len(r), 1) and not back.u.any()
    assert np.array_equal(back.q, r.q) and np.array_equal(back.z, r.z)


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


# --- every public callable ---------------------------------------------------------------------

# What a refusal may raise: ValueError includes kanedyn.ModelError; RuntimeError only as the
# library's refusal of an output path (a folder where a file is to be written).
_REFUSALS = {"TypeError", "ValueError", "ModelError", "IndexError", "KeyError", "SimulationError"}
# pybind11's own messages for an argument it cannot convert: they name no argument and no range.
_GENERIC = ("incompatible function arguments", "incompatible constructor arguments", "Unable to cast")


def test_every_public_callable_refuses_hostile_arguments_by_name(tmp_path) -> None:
    """Each argument of each public callable replaced by None, a str, an object, 10**30, -1,
    1.5 and nan in turn (python/tests/hostile_calls.py): no crash (pybind11 once passed None
    through as a null Model: Simulator(None) was a segmentation fault), no pybind11 message,
    only the module's refusals, and None refused by a TypeError naming the argument."""
    # The package this suite imports, found from the scratch folder too.
    package = str(pathlib.Path(kanedyn.__file__).resolve().parents[1])
    done = subprocess.run(
        [sys.executable, str(pathlib.Path(__file__).parent / "hostile_calls.py"), str(EXAMPLES)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": package},
        timeout=600,
    )
    assert done.returncode == 0, (done.returncode, done.stderr[-3000:])
    lines = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    assert lines[0] == {"missing": []}, "public callables hostile_calls.py does not call"
    assert lines[-1] == {"done": True}
    outcomes = lines[1:-1]
    assert len(outcomes) > 500
    for o in outcomes:
        where = f"{o['call']}({o['arg']}={o['value']}): {o['type']}: {o['message']}"
        assert not any(g in o["message"] for g in _GENERIC), where
        if o["type"] == "RuntimeError":
            assert o["message"].startswith("output 'x' is a directory"), where
        else:
            assert o["type"] == "ok" or o["type"] in _REFUSALS, where
        if o["value"] == "None" and o["type"] == "TypeError":
            function = o["call"].split(".")[-1] + "()"
            assert o["arg"] in o["message"] or function in o["message"], where
    refused = {(o["call"], o["arg"]): o for o in outcomes if o["value"] == "None"}
    for call, arg in [("Simulator", "model"), ("read_csv", "model"), ("Result", "model"), ("Result.read_csv", "model")]:
        o = refused[(call, arg)]
        assert o["type"] == "TypeError" and o["message"] == "model must be a kanedyn.Model (kanedyn.load(...)), got NoneType", o


def test_none_for_a_model_or_a_study_is_a_type_error(eight, tmp_path) -> None:
    with pytest.raises(TypeError, match=r"^model must be a kanedyn\.Model \(kanedyn\.load\(\.\.\.\)\), got NoneType$"):
        kanedyn.Simulator(None)
    with pytest.raises(TypeError, match="model must be a kanedyn.Model"):
        kanedyn.Simulator(model=eight.initial_state())
    with pytest.raises(TypeError, match="study must be a kanedyn._Study, got NoneType"):
        kanedyn._kanedyn._StudyFolder(None, str(tmp_path / "out"))
    assert not (tmp_path / "out").exists()
    with pytest.raises(TypeError, match="model must be a kanedyn.Model"):
        kanedyn.read_csv(None, tmp_path / "run.csv")


# --- files that are not regular files, or not the file expected ---------------------------------

_FIFO_SCRIPT = """
import sys, kanedyn
fifo = sys.argv[1]
m = kanedyn.load(sys.argv[2])
for name, call in [
    ("read_results", lambda: kanedyn.read_results(fifo)),
    ("read_csv", lambda: kanedyn.read_csv(m, fifo)),
    ("load", lambda: kanedyn.load(fifo)),
    ("Study", lambda: kanedyn.Study(fifo)),
]:
    try:
        call()
        print(name, "read it")
    except ValueError as e:
        print(name, str(e))
"""


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs a FIFO")
def test_readers_refuse_a_fifo_without_waiting_on_it(tmp_path) -> None:
    """Nothing writes to the FIFO: a reader that opened it for reading would wait for ever (so
    the calls run in a process of their own, stopped by the timeout)."""
    fifo = tmp_path / "results.csv"
    os.mkfifo(fifo)
    done = subprocess.run(
        [sys.executable, "-c", _FIFO_SCRIPT, str(fifo), str(EXAMPLES / "eight_body.yaml")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.splitlines()
    assert [line.split()[0] for line in lines] == ["read_results", "read_csv", "load", "Study"]
    for line in lines:
        assert f"{fifo}: cannot read: it is a FIFO (named pipe), not a regular file" in line, line


def test_read_results_of_another_file_names_the_file_and_the_problem(eight, tmp_path) -> None:
    table = kanedyn.Study(_study_dict(str(EXAMPLES / "eight_body.yaml"))).run(out=tmp_path / "out")
    results = tmp_path / "out" / "results.csv"
    back = kanedyn.read_results(results)
    assert list(back["run"]) == list(table["run"]) == [0, 1]
    trajectory = tmp_path / "run.csv"
    eight.simulate(t_end=0.02).to_csv(trajectory)
    lines = results.read_text().splitlines()
    cases = [
        ("", rf"{tmp_path}/bad.csv: the file is empty, not a results table"),
        (trajectory.read_text(), rf"{tmp_path}/bad.csv:1: the header 't,.*\.\.\.' is not that of a results table"),
        ("a,b\n1,2\n", rf"{tmp_path}/bad.csv:1: the header 'a,b' is not that of a results table"),
        (lines[0] + "\n0,1\n", rf"{tmp_path}/bad.csv:2: the row has 2 fields, the header 5"),
        (lines[0] + "\n" + lines[1].replace("0,", "zero,", 1) + "\n", r"bad.csv:2: column 'run': 'zero' is not a run number"),
        (lines[0] + "\n" + lines[1] + "\n" + "1,x" + lines[2][lines[2].index(",", 2) :] + "\n", r"bad.csv:3: column '[^']+': 'x' is not a number"),
    ]
    for text, message in cases:
        (tmp_path / "bad.csv").write_text(text)
        with pytest.raises(ValueError, match=message):
            kanedyn.read_results(tmp_path / "bad.csv")
    with pytest.raises(ValueError, match=rf"{tmp_path}/out: cannot read: it is a directory, not a regular file"):
        kanedyn.read_results(tmp_path / "out")
    with pytest.raises(ValueError, match="nowhere.csv: cannot open: No such file or directory"):
        kanedyn.read_results(tmp_path / "nowhere.csv")


# --- a controller that returns nothing ---------------------------------------------------------


def test_a_controller_that_returns_none_or_no_numbers_stops_the_run(tmp_path) -> None:
    cart = kanedyn.load(EXAMPLES / "cart_pole.yaml")
    for value, cause, message in [
        (None, TypeError, r"the controller returned None; it must return u, 1 finite numbers"),
        ("push", TypeError, r"the controller's value must be a float64 array of shape \(m,\) = \(1,\)"),
        ([float("nan")], ValueError, r"the controller's value\[0\] is nan \(input 'push'\)"),
    ]:
        with pytest.raises(kanedyn.SimulationError, match=message) as caught:
            cart.simulate(t_end=0.1, controller=lambda t, s, v=value: v, control_interval=0.01, output=tmp_path / "c.csv")
        assert isinstance(caught.value.__cause__, cause), caught.value.__cause__
        assert caught.value.result is not None and len(caught.value.result) == 0
        assert not (tmp_path / "c.csv").exists()


# --- ranges ------------------------------------------------------------------------------------


def test_counts_and_tolerances_out_of_range_name_the_range(eight, tmp_path) -> None:
    study = kanedyn.Study(_study_dict(str(EXAMPLES / "eight_body.yaml")))
    for threads, error, message in [
        (-1, ValueError, r"^threads -1 is not in 0\.\.4096$"),
        (10**30, ValueError, r"^threads 1000000000000000000000000000000 is not in 0\.\.4096$"),
        (1.5, TypeError, r"^threads must be an integer, got float$"),
        (True, TypeError, r"^threads must be an integer, got a bool$"),
    ]:
        with pytest.raises(error, match=message):
            study.run(out=tmp_path / "out", threads=threads)
    with pytest.raises(ValueError, match=r"^chunk_size 0 is not in 1\.\."):
        study.run(out=tmp_path / "out", chunk_size=0)
    assert not (tmp_path / "out").exists()  # refused before the folder is made
    with pytest.raises(IndexError, match=r"^run 1000000000000000000000000000000 is not in 0\.\.1$"):
        study.parameters(10**30)
    with pytest.raises(IndexError, match=r"^run -1 is not in 0\.\.1$"):
        study.parameters(-1)
    with pytest.raises(TypeError, match=r"^run must be an integer, got float$"):
        study.parameters(1.0)
    assert study.parameters(np.int64(1)) == [6.0]
    s = eight.initial_state()
    X, Y = np.tile(s.x, (2, 1)), np.tile(s.y, (2, 1))
    with pytest.raises(ValueError, match=r"threads must be >= 0 \(0: one per core.*\), got -1$"):
        eight.derivatives_batch(X, Y, threads=-1)
    for setting in ("rtol", "atol", "max_step", "dt"):
        for bad in (0, 0.0, -1e-9, float("inf"), 10**400):
            with pytest.raises(ValueError, match=rf"^{setting} must be a finite number > 0, got "):
                kanedyn.Simulator(eight, integrator="dopri5", **{setting: bad})
        with pytest.raises(TypeError, match=rf"^{setting} must be a number, got str$"):
            kanedyn.Simulator(eight, integrator="dopri5", **{setting: "1e-8"})
    with pytest.raises(ValueError, match=r"^rtol must be a finite number > 0, got 0$"):
        eight.simulate(t_end=0.01, rtol=0)
    for bad in (0, -1, 10001, 10**30):
        with pytest.raises(ValueError, match=rf"^max_iterations {bad} is not in 1\.\.10000$"):
            eight.equilibrium(max_iterations=bad)
    with pytest.raises(ValueError, match=r"^tolerance must be a finite number > 0, got 0$"):
        eight.equilibrium(tolerance=0)
    with pytest.raises(ValueError, match=r"^tolerance must be a finite number > 0, got 1000"):
        eight.equilibrium(tolerance=10**400)  # float() of it would be an OverflowError
    with pytest.raises(ValueError, match=r"^t must be finite, got 1000"):
        eight.inspect(t=10**400)
    with pytest.raises(TypeError, match=r"^rate must be True or False, got str$"):
        eight.symbolic_partial(8, rate="yes")
    with pytest.raises(TypeError, match=r"^store must be True or False, got int$"):
        eight.simulate(t_end=0.01, store=1)


# --- Result.view -------------------------------------------------------------------------------


def test_view_refuses_rows_the_tool_would_refuse(eight, tmp_path) -> None:
    """`kanedyn view` reads its rows through the trajectory reader, which refuses a number that
    is not finite; the page was once drawn from nan here."""
    r = eight.simulate(t_end=0.05)
    path = tmp_path / "v.html"
    for array, index, value, message in [
        ("x", (1, 5), np.nan, r"^view: x\[1, 5\] is nan \(body 'pelvis' \(e2\)\); nothing was written$"),
        ("energy", (2,), np.inf, r"^view: energy\[2\] is inf; nothing was written$"),
        ("t", (3,), -1.0, r"^view: t\[3\] is before t\[2\]"),
    ]:
        with pytest.raises(ValueError, match=message):
            _spoiled(r, array, index, value).view(path)
        assert not any(tmp_path.iterdir())
    bad = np.full((2, len(eight.columns)), np.nan)
    with pytest.raises(ValueError, match=r"^view: row 0, column 't' is nan; nothing was written$"):
        eight._write_view(str(path), bad, "test", "")
    assert not any(tmp_path.iterdir())


# --- Ctrl-C in Simulator.step ------------------------------------------------------------------

_LONG_STEP_SCRIPT = """
import sys, threading, time
import numpy as np
import kanedyn

m = kanedyn.load(sys.argv[1])
sim = kanedyn.Simulator(m, integrator="dopri5")
ticks = []
stop = threading.Event()

def tick():  # runs only while step() does not hold the GIL
    while not stop.is_set():
        ticks.append(time.monotonic())
        time.sleep(0.01)

threading.Thread(target=tick, daemon=True).start()
print("stepping", flush=True)
start = time.monotonic()
try:
    sim.step(np.zeros(len(m.inputs)), 1e6)
    print("finished", flush=True)
except KeyboardInterrupt:
    end = time.monotonic()
    stop.set()
    during = [t for t in ticks if start < t < end]
    gap = max(b - a for a, b in zip(during, during[1:]))
    print(f"KeyboardInterrupt after {end - start:.3f} s; t = {sim.t}, steps {sim.steps}; "
          f"ticks {len(during)}, largest gap {gap:.3f} s", flush=True)
"""


@pytest.mark.skipif(sys.platform == "win32", reason="sends SIGINT")
def test_ctrl_c_stops_a_long_simulator_step(tmp_path) -> None:
    """dt = 1e6 s with dopri5 is minutes of steps: Ctrl-C (SIGINT) 0.5 s in must stop it within
    about a second (it once came 12.8 s late, or never), leave the simulator where it was, and
    other Python threads must run meanwhile (the step holds no GIL)."""
    proc = subprocess.Popen(
        [sys.executable, "-c", _LONG_STEP_SCRIPT, str(EXAMPLES / "eight_body.yaml")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "stepping"
        time.sleep(0.5)
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=10)
        waited = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err[-2000:]
    assert out.startswith("KeyboardInterrupt after"), out
    assert waited < 2.0, (waited, out)
    assert "t = 0.0, " in out, out  # the state before the step is kept
    # A step that held the GIL would leave the other thread no tick from start to end (>= 0.5 s);
    # the margin is for a loaded machine.
    gap = float(out.rsplit("largest gap ", 1)[1].split()[0])
    assert gap < 0.4, out
