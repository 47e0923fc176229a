"""kanedyn.Study with a Python function of each run's model: a pendulum's small-oscillation
frequency from its linearization over varied lengths against the closed form, the same table
on one thread, two threads and a dask cluster, an exception of the function as the run's
failure, and a study stopped by Ctrl-C and run again."""

from __future__ import annotations

import math
import os
import pathlib
import signal
import subprocess
import sys
import time
from typing import Dict, Iterator, List

import numpy as np
import pytest

import kanedyn

from conftest import EXAMPLES, run_tool

# A rod of mass m hanging from a hinge about y, its mass centre L below the pivot, inertia J
# about its centre: about the hanging pose I_p q'' = -m g L q with I_p = J + m L^2, so
# q'' = -w^2 q, w = sqrt(m g L / (J + m L^2)) (sqrt(g / L) as J goes to 0).
MODEL = """format: kanedyn-model/1
name: pendulum
gravity: [0, 0, -9.81]
bodies:
  - name: rod
    parent: ground
    mass: 2.0
    inertia: [0.001, 0.001, 0.0001]
    com: [0, 0, -1.0]
    joint: {type: revolute, at: [0, 0, 0], axis: [0, 1, 0]}
    initial: {joint: [0.0], joint_rate: [0.0]}
"""

STUDY = """format: kanedyn-study/1
model: pendulum.yaml
vary:
  - key: bodies[rod].com[2]
    grid: [-0.25, -0.5, -1.0, -1.5, -2.0, -3.0]
  - key: bodies[rod].mass
    values: [1.0, 2.0]
outputs:
  - linearize: {mode: swing, value: imag}
"""

G, J = 9.81, 0.001


def omega(m: float, length: float) -> float:
    return math.sqrt(m * G * length / (J + m * length * length))


def frequency(model: kanedyn.Model, run: int) -> Dict[str, float]:
    """The pendulum's small-oscillation frequency from its linearization about the hanging
    pose (the model's initial state), and the run's index to show it was given."""
    lin = model.linearize()
    return {"omega": float(np.abs(lin.eigenvalues.imag).max()), "twice_run": 2.0 * run}


def frequency_or_fail(model: kanedyn.Model, run: int) -> Dict[str, float]:
    """frequency(), raising for runs 3, 7 and 11 and giving no dict for run 5."""
    result = frequency(model, run)
    if run % 4 == 3:
        raise ValueError(f"run {run}: refused,\nas a test")
    if run == 5:
        return [result["omega"]]  # type: ignore[return-value]
    return result


@pytest.fixture
def study(tmp_path: pathlib.Path) -> pathlib.Path:
    (tmp_path / "pendulum.yaml").write_text(MODEL)
    (tmp_path / "study.yaml").write_text(STUDY)
    return tmp_path / "study.yaml"


def without_wall(results: pathlib.Path) -> List[str]:
    return [line.rsplit(",", 1)[0] for line in results.read_text().splitlines()]


def test_the_functions_outputs_are_the_closed_form(study: pathlib.Path) -> None:
    s = kanedyn.Study(study, function=frequency, outputs=["omega", "twice_run"])
    assert s.columns == [
        "run", "bodies[rod].com[2]", "bodies[rod].mass", "linearize:swing.imag",
        "omega", "twice_run", "status", "wall_s",
    ]  # fmt: skip
    table = s.run(out=study.parent / "out", threads=2)
    assert len(table) == 12
    assert set(table["status"]) == {"ok"}
    for i in range(12):
        length, m = -table["bodies[rod].com[2]"][i], table["bodies[rod].mass"][i]
        # The linearization's derivatives are exact (dual numbers); the eigen-solver's
        # round-off is a few ulps of w (at most 6/s here).
        assert table["omega"][i] == pytest.approx(omega(m, length), rel=1e-13, abs=1e-13)
        assert table["twice_run"][i] == 2.0 * i
        # The study file's own linearize output reads the same eigenvalue of the same A.
        assert table["linearize:swing.imag"][i] == pytest.approx(table["omega"][i], rel=1e-14)


def test_a_function_of_the_model_alone(study: pathlib.Path) -> None:
    s = kanedyn.Study(study, function=lambda model: {"n": float(model.N)}, outputs=["n"])
    table = s.run(out=study.parent / "out", threads=1)
    assert list(table["n"]) == [1.0] * 12


def test_exceptions_are_failure_records_and_the_study_goes_on(study: pathlib.Path) -> None:
    s = kanedyn.Study(study, function=frequency_or_fail, outputs=["omega", "twice_run"])
    table = s.run(out=study.parent / "out", threads=2)
    statuses = list(table["status"])
    for i, status in enumerate(statuses):
        if i % 4 == 3:
            # On one line: the message's line break is a space.
            assert status == f"function: ValueError: run {i}: refused, as a test"
            assert math.isnan(table["omega"][i])
            # A failed run's outputs are all empty, the file's too.
            assert math.isnan(table["linearize:swing.imag"][i])
        elif i == 5:
            assert status == "function: gave list, not a dict of its outputs (omega, twice_run)"
        else:
            assert status == "ok"
            assert table["omega"][i] > 0
    missing = kanedyn.Study(study, function=lambda m, r: {"omega": 1.0, "other": 2}, outputs=["omega", "twice_run"])
    table = missing.run(out=study.parent / "out2", threads=1)
    assert table["status"][0] == "function: gave no 'twice_run' and unknown 'other'; its outputs are omega, twice_run"
    text = kanedyn.Study(study, function=lambda m, r: {"omega": "fast"}, outputs=["omega"])
    table = text.run(out=study.parent / "out3", threads=1)
    assert table["status"][0] == "function: gave str for 'omega', not a number"


def test_bad_arguments_are_refused(study: pathlib.Path) -> None:
    with pytest.raises(ValueError, match="'status' is already a column"):
        kanedyn.Study(study, function=frequency, outputs=["status"])
    with pytest.raises(ValueError, match="'linearize:swing.imag' is already a column"):
        kanedyn.Study(study, function=frequency, outputs=["linearize:swing.imag"])
    with pytest.raises(ValueError, match="named twice"):
        kanedyn.Study(study, function=frequency, outputs=["a", "a"])
    with pytest.raises(TypeError, match="outputs must be a list"):
        kanedyn.Study(study, function=frequency, outputs="omega")
    with pytest.raises(TypeError, match="function must be"):
        kanedyn.Study(study, function=42, outputs=["omega"])  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="function must take"):
        kanedyn.Study(study, function=lambda a, b, c: {}, outputs=["omega"])
    with pytest.raises(ValueError, match="at least one"):
        kanedyn.Study(study, function=frequency, outputs=[])


def test_a_folder_of_another_function_is_refused(study: pathlib.Path) -> None:
    kanedyn.Study(study).run(out=study.parent / "out", threads=1)
    again = kanedyn.Study(study, function=frequency, outputs=["omega", "twice_run"])
    with pytest.raises(RuntimeError, match="holds the runs of another study"):
        again.run(out=study.parent / "out", threads=1)


calls: List[int] = []


def interrupting(model: kanedyn.Model, run: int) -> Dict[str, float]:
    """frequency(), and a Ctrl-C sent to this process at run 4 of the first start."""
    calls.append(run)
    if run == 4 and not os.environ.get("KANEDYN_TEST_RESUMED"):
        os.kill(os.getpid(), signal.SIGINT)
        # The driver looks for a stop ten times a second: this run is still running then.
        time.sleep(0.3)
    return frequency(model, run)


def test_stopped_and_run_again_resumes(study: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    s = kanedyn.Study(study, function=interrupting, outputs=["omega", "twice_run"])
    calls.clear()
    with pytest.raises(KeyboardInterrupt, match="run\\(\\) again with the same folder"):
        s.run(out=study.parent / "out", threads=1)
    assert not (study.parent / "out" / "results.csv").exists()
    first = list(calls)
    assert 4 in first and len(first) < 12
    monkeypatch.setenv("KANEDYN_TEST_RESUMED", "1")
    calls.clear()
    s.run(out=study.parent / "out", threads=1)
    # Only the missing runs ran again: every run once, but the run in flight at the stop,
    # which ran to its end (a function is not interrupted) and may have been kept.
    assert sorted(set(first) | set(calls)) == list(range(12))
    assert len(set(first) & set(calls)) <= 1
    whole = kanedyn.Study(study, function=frequency, outputs=["omega", "twice_run"])
    whole.run(out=study.parent / "whole", threads=2)
    assert without_wall(study.parent / "out" / "results.csv") == without_wall(study.parent / "whole" / "results.csv")


@pytest.fixture
def client() -> Iterator[object]:
    distributed = pytest.importorskip("distributed")  # Debian: python3-distributed
    with distributed.LocalCluster(
        host="127.0.0.1", processes=True, n_workers=2, threads_per_worker=1, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as c:
        yield c


def test_threads_and_dask_give_the_same_table(study: pathlib.Path, client: object) -> None:
    s = kanedyn.Study(study, function=frequency_or_fail, outputs=["omega", "twice_run"])
    s.run(out=study.parent / "one", threads=1)
    s.run(out=study.parent / "two", threads=2)
    s.run(out=study.parent / "dask", client=client, chunk_size=3)
    one = without_wall(study.parent / "one" / "results.csv")
    assert one == without_wall(study.parent / "two" / "results.csv")
    assert one == without_wall(study.parent / "dask" / "results.csv")
    assert len(one) == 13 and sum('"function: ' in line for line in one) == 4


def test_the_bicycle_speed_study_plots(tmp_path: pathlib.Path) -> None:
    # The example's table and its figure (docs/bicycle.md, "A stability map as a study"); the
    # crossings themselves are checked in tests/test_study_linearize.cpp.
    pytest.importorskip("matplotlib")
    done = run_tool(["sweep", EXAMPLES / "studies" / "bicycle_speed.yaml", "-o", tmp_path / "out"])
    assert done.returncode == 0, done.stderr
    assert "failed: 0" in done.stdout
    script = EXAMPLES / "python" / "plot_bicycle_speed.py"
    drawn = subprocess.run([sys.executable, script, tmp_path / "out", tmp_path / "map.png"],
                           capture_output=True, text=True, check=False)  # fmt: skip
    assert drawn.returncode == 0, drawn.stderr
    assert "weave speed   4.29" in drawn.stdout and "capsize speed 6.02" in drawn.stdout
    assert (tmp_path / "map.png").stat().st_size > 10000
