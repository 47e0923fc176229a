"""simulate() as a run: the CSV's .partial rules, Ctrl-C, progress, failures, store=False."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES, run_tool


def whole_rows(path, columns: int) -> int:
    """The number of data rows of a CSV, checking that each is whole."""
    text = path.read_text()
    assert text.endswith("\n")
    lines = text.splitlines()
    assert all(len(line.split(",")) == columns for line in lines)
    return len(lines) - 1


def test_the_csv_appears_under_its_name_only_when_complete(eight, tmp_path) -> None:
    out = tmp_path / "run.csv"
    seen = []

    def progress(t: float, t_end: float) -> None:
        seen.append((t, out.exists(), (tmp_path / "run.csv.partial").exists()))

    r = eight.simulate(t_end=2, output=out, progress=progress, rtol=1e-10)
    assert out.exists() and not (tmp_path / "run.csv.partial").exists()
    assert whole_rows(out, len(eight.columns)) == len(r) == 201
    assert r.path == str(out)
    assert seen and all(not final and partial for _, final, partial in seen[:-1])
    assert seen[-1][0] == r.stats["t_reached"] == 2.0  # the last call sees the end


def test_progress_true_draws_a_bar_on_stderr(eight, capsys) -> None:
    eight.simulate(t_end=0.5, progress=True)
    err = capsys.readouterr().err
    assert "[" in err and "100.0%" in err and "t = 0.5 of 0.5" in err


def test_an_exception_in_the_progress_callback_stops_the_run_and_keeps_the_partial_file(eight, tmp_path) -> None:
    out = tmp_path / "run.csv"

    def progress(t: float, t_end: float) -> None:
        if t > 0:
            raise ZeroDivisionError("stop here")

    with pytest.raises(ZeroDivisionError, match="stop here") as caught:
        eight.simulate(t_end=1e4, dt_out=0.01, output=out, progress=progress)
    assert not out.exists()
    rows = whole_rows(tmp_path / "run.csv.partial", len(eight.columns))
    assert rows >= 1
    assert any("partial trajectory" in note and "run.csv.partial" in note for note in caught.value.__notes__)


def test_ctrl_c_raises_keyboard_interrupt_and_keeps_the_partial_file(tmp_path) -> None:
    out = tmp_path / "run.csv"
    code = (
        "import kanedyn\n"
        f"m = kanedyn.load({str(EXAMPLES / 'chain64.yaml')!r})\n"
        f"m.simulate(t_end=1e5, dt_out=0.01, output={str(out)!r})\n"
        "print('not interrupted')\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    partial = tmp_path / "run.csv.partial"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (partial.exists() and partial.stat().st_size > 20000):
        time.sleep(0.05)
    start = time.monotonic()
    proc.send_signal(signal.SIGINT)
    out_text, err_text = proc.communicate(timeout=60)
    # Python's own signal handler runs at the next check (every 50 ms of the run).
    assert time.monotonic() - start < 5
    # An uncaught KeyboardInterrupt ends Python by SIGINT itself (exit status -2).
    assert proc.returncode == -signal.SIGINT, err_text
    assert "KeyboardInterrupt" in err_text and "partial trajectory" in err_text
    assert "not interrupted" not in out_text
    assert not out.exists()
    m = kanedyn.load(EXAMPLES / "chain64.yaml")
    assert whole_rows(partial, len(m.columns)) >= 1


def test_a_failed_run_raises_simulation_error_with_the_rows_before(eight, tmp_path) -> None:
    out = tmp_path / "run.csv"
    with pytest.raises(kanedyn.SimulationError) as caught:
        # rk4 far above the stiffest bushing's stability limit diverges.
        eight.simulate(t_end=5, integrator="rk4", step=0.01, output=out)
    e = caught.value
    assert "diverged" in str(e) or "not finite" in str(e)
    assert "run.csv.partial" in str(e)
    assert e.stats["status"] == "non-finite state" and e.stats["failed_body"] in eight.body_names
    assert e.result is not None and 0 < len(e.result) < 501
    assert np.isfinite(e.result.x).all()
    assert whole_rows(tmp_path / "run.csv.partial", len(eight.columns)) == len(e.result)
    assert not out.exists()


def test_store_false_streams_only(eight, tmp_path) -> None:
    stats = eight.simulate(t_end=1, output=tmp_path / "a.csv", store=False)
    assert isinstance(stats, dict) and stats["status"] == "completed" and stats["outputs"] == 101
    full = eight.simulate(t_end=1, output=tmp_path / "b.csv")
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    assert full.stats["evaluations"] == stats["evaluations"]


def test_result_columns_and_states(eight) -> None:
    r = eight.simulate(t_end=0.1)
    table = r.table()
    for i, name in enumerate(r.columns):
        assert r[name].tobytes() == np.ascontiguousarray(table[:, i]).tobytes(), name
        assert r[name].flags["C_CONTIGUOUS"]
    k = eight.body_number("head") - 1
    assert np.array_equal(r["head.w2"], r.y[:, 3 * k + 1])
    assert np.array_equal(r["head.sd3"], r.y[:, 3 * 8 + 3 * k + 2])
    assert np.array_equal(r["head.z"], r.p_G[:, k, 2])
    s = r.state(5)
    assert np.array_equal(s.x, r.x[5]) and np.array_equal(s.y, r.y[5])
    # The energy column is the model's total energy of each row.
    assert r.energy[5] == eight.energy(s)[2]
    assert len(r) == 11 and r.t[-1] == 0.1


def test_initial_state_argument(eight) -> None:
    s = eight.initial_state()
    s.y[:] = 0.0
    r = eight.simulate(t_end=0.01, initial=s)
    assert np.array_equal(r.y[0], np.zeros(48))
    assert not np.array_equal(eight.simulate(t_end=0.01).y[0], r.y[0])


PENDULUM = """format: kanedyn-model/1
gravity: [0, 0, -9.81]
bodies:
  - {name: upper, parent: ground, mass: 1.0, inertia: [0.08, 0.08, 0.001], com: [0, 0, -0.5],
     joint: {type: revolute, axis: [0, 1, 0]}, initial: {joint: [ANGLE]}}
  - {name: lower, parent: upper, mass: 1.0, inertia: [0.08, 0.08, 0.001], com: [0, 0, -0.5],
     joint: {type: revolute, at: [0, 0, -1], axis: [0, 1, 0]}}
"""


def test_the_relative_energy_change_is_to_the_energy_that_moved() -> None:
    # Released level with its pivot: E0 is round-off (cos(pi/2) g L), the ratio to it 1e+8.
    m = kanedyn.loads(PENDULUM.replace("ANGLE", "1.5707963267948966"))
    r = m.simulate(t_end=1.0, dt_out=0.01)
    s = r.stats
    assert abs(s["energy_initial"]) < 1e-12
    assert s["energy_change"] == s["energy_final"] - s["energy_initial"]
    # The largest kinetic energy or potential swing: more than a few J within a second, and at
    # most the m g (0.5 + 1.5) = 19.62 J the two links lose hanging straight down.
    assert 5.0 < s["energy_scale"] <= 9.81 * 2.0 + 1e-6
    assert s["relative_energy_change"] == s["energy_change"] / s["energy_scale"]
    assert abs(s["relative_energy_change"]) < 1e-6  # dopri5 at rtol 1e-8
    # Hanging at rest nothing moves: no scale and no ratio, only the absolute change.
    rest = kanedyn.loads(PENDULUM.replace("ANGLE", "0.0")).simulate(t_end=1.0).stats
    assert rest["energy_scale"] == 0.0
    assert np.isnan(rest["relative_energy_change"])
    assert abs(rest["energy_change"]) < 1e-12


@pytest.mark.parametrize("name", ["cart_pendulum.yaml", "four_bar.yaml", "double_pendulum_jointed.yaml"])
def test_a_jointed_rows_state_gives_the_energy_of_the_csv(tmp_path, name) -> None:
    # Result.state(row) of a model with joints is the row's joint coordinates and speeds, which
    # every call of that model takes: its energy is the energy column of the tool's CSV of the
    # same run, computed there from the same (q, z) by the same function (so to round-off: 1e-12
    # relative of the run's largest |energy|, far below any change of state between rows).
    model = kanedyn.load(EXAMPLES / name)
    csv = tmp_path / "run.csv"
    done = run_tool(["simulate", EXAMPLES / name, "--t-end", "0.2", "--dt-out", "0.05", "--out", csv])
    assert done.returncode == 0, done.stderr
    column = kanedyn.read_csv(model, csv)["energy"]
    r = model.simulate(t_end=0.2, dt_out=0.05)
    scale = max(1.0, float(np.abs(column).max()))
    for row in (0, 2, -1):
        state = r.state(row)
        kinetic, potential, total = model.energy(state)
        assert abs(total - column[row]) <= 1e-12 * scale, (row, total, column[row])
        assert abs(kinetic + potential - total) <= 1e-12 * scale
    # A row of a run read back from the CSV gives the same state.
    back = kanedyn.read_csv(model, csv).state(-1)
    assert np.array_equal(back.q, r.state(-1).q) and np.array_equal(back.z, r.state(-1).z)
