"""The Python examples run as a user runs them, from another folder, and say what they did."""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys

import kanedyn

from conftest import EXAMPLES

SCRIPTS = EXAMPLES / "python"


def run(name: str, cwd, *args: str) -> str:
    # The package this suite imports, wherever the examples run from.
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=str(pathlib.Path(kanedyn.__file__).resolve().parents[1]))
    done = subprocess.run([sys.executable, str(SCRIPTS / name), *args], capture_output=True, text=True, cwd=cwd, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_simulate_and_plot(tmp_path) -> None:
    out = run("simulate_eight_body.py", tmp_path)
    png = tmp_path / "eight_body.png"
    assert "1001 rows" in out and "wrote eight_body.png" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000


def test_stiffness_sweep(tmp_path) -> None:
    out = run("stiffness_sweep.py", tmp_path)
    rows = [line.split() for line in out.splitlines() if line.strip().endswith(tuple("0123456789")) and "x " in line]
    assert [r[0] for r in rows] == ["0.25x", "0.5x", "1x", "2x", "4x"]
    steps = [int(r[1]) for r in rows]
    assert steps == sorted(steps)  # stiffer bushings, faster vibrations, more steps
    sag = [float(r[2]) for r in rows]
    assert sag == sorted(sag, reverse=True)  # stiffer bushings, less sag


def test_partial_velocities(tmp_path) -> None:
    out = run("partial_velocities.py", tmp_path)
    assert "[v_G8,y1] = -[ [R_1]^T([q~'_7]+[s~'_7])" in out
    diffs = [float(line.split()[-1].rstrip(")")) for line in out.splitlines() if "(difference" in line]
    assert diffs and max(diffs) <= 1e-15  # the two forms of {v_G8}: round-off of a 3 x 48 product
    assert "matches {F_y} to" in out
    assert float(out.split("matches {F_y} to ")[1].split()[0]) <= 1e-9


def test_arm_pd_holds_the_pose(tmp_path) -> None:
    # Critically damped at 4 Hz per joint (w = 25 rad/s) from errors of ~1 rad: after 3 s the
    # error is of order 1e-8 (the sampled law adds a little); asserted below 1e-6 rad.
    out = run("arm_pd.py", tmp_path)
    final = float(out.split("final error ")[1].split()[0])
    assert final < 1e-6
    first = float(out.splitlines()[0].split("error ")[1].split()[0])
    assert first > 1.0  # it starts far from the pose


def test_arm_computed_torque_tracks_the_sines(tmp_path) -> None:
    # e(t) = (e0 + (e0' + w e0) t) exp(-w t) with w = 10, e0 = 0.2 rad and e0' up to ~5 rad/s:
    # below 1e-7 from t = 2 s (the analytic bound is 3e-8 there), and at the integrator's
    # tolerance (rtol 1e-10) by t = 4 s: below 1e-9 rad.
    out = run("arm_computed_torque.py", tmp_path)
    late = float(out.split("last 2 s: ")[1].split()[0])
    assert late < 1e-7
    end = [line for line in out.splitlines() if line.startswith("t = 4.0")][0]
    assert float(end.split("error ")[1].split()[0]) < 1e-9


def test_cart_pole_lqr_holds_the_pole_up(tmp_path) -> None:
    # From 0.2 rad at rest. The LQR design makes the linear closed loop stable; its slowest
    # eigenvalues are near -1.1 /s, so after 5 s the angle is of order 0.2 exp(-5) ~ 1e-3:
    # asserted below 5e-3 rad (a pole that fell would lie at pi/2 or beyond), the cart within
    # 5 cm of the origin. The push acts from the first instant, so the pole never tips further
    # than it started (0.21 rad leaves room for the sampled law's first 10 ms).
    out = run("cart_pole_lqr.py", tmp_path)
    assert float(out.split("closed loop: largest real part ")[1].split()[0]) < 0
    largest = float(out.split("largest pole angle ")[1].split()[0])
    assert 0.2 <= largest < 0.21
    final = out.split("final pole angle ")[1].split()
    assert float(final[0]) < 5e-3
    assert float(final[3]) < 0.05  # the cart, m


def test_tennis_racket_intermediate_axis_is_unstable(tmp_path) -> None:
    # The eigenvalues of the linearized spin against Euler's equations, computed here from the
    # model file's moments (not from the script's own formula), at 1e-10 relative (the
    # derivatives are dual numbers, exact to round-off; printed with 15 digits). About the
    # intermediate axis y a real eigenvalue w0 sqrt((I2 - I1)(I3 - I2) / (I1 I3)); about x
    # and z no real part above 1e-10 /s, and a wobble at w0 sqrt((I2 - I1)(I3 - I1) / (I2 I3))
    # and w0 sqrt((I3 - I1)(I3 - I2) / (I1 I2)).
    out = run("tennis_racket.py", tmp_path)
    I1, I2, I3, w0 = 0.0022, 0.0120, 0.0138, 6.0
    rate = w0 * ((I2 - I1) * (I3 - I2) / (I1 * I3)) ** 0.5
    wobble = {"x": w0 * ((I2 - I1) * (I3 - I1) / (I2 * I3)) ** 0.5, "z": w0 * ((I3 - I1) * (I3 - I2) / (I1 * I2)) ** 0.5}
    readings = {r[0]: r for r in out.split("spin about ")[1:]}
    assert sorted(readings) == ["x", "y", "z"]
    measured = float(readings["y"].split("largest real part ")[1].split()[0])
    assert abs(measured - rate) <= 1e-10 * rate, (measured, rate)
    for axis in "xz":
        reading = readings[axis]
        assert "stable wobble" in reading, reading
        assert float(reading.split("largest real part ")[1].split()[0]) <= 1e-10
        frequency = float(reading.split("wobble at ")[1].split()[0])
        assert abs(frequency - wobble[axis]) <= 1e-10 * wobble[axis], (axis, frequency, wobble[axis])
    # The nonlinear simulation's wobble grows at nearly that rate (cosh, not exp: 1% less).
    simulated = float(out.split("simulated wobble grows at ")[1].split()[0])
    assert 0.98 * rate < simulated < rate


def test_bicycle_eigenvalues_runs_from_a_copy_of_the_examples_elsewhere(tmp_path) -> None:
    # The examples folder copied out of the repository (the script and the one model it names),
    # run from a third folder: it must need nothing else of the repository. The speeds are the
    # paper's (Meijaard et al. 2007: 4.29238253634111 and 6.02426201538837 m/s), at the 1e-9 m/s
    # that tests/test_bicycle.cpp's 1e-12 eigenvalues leave to a bisection printed to 1e-12.
    import shutil

    copy = tmp_path / "copy" / "examples"
    (copy / "python").mkdir(parents=True)
    shutil.copy(SCRIPTS / "bicycle_eigenvalues.py", copy / "python")
    shutil.copy(EXAMPLES / "bicycle.yaml", copy)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=str(pathlib.Path(kanedyn.__file__).resolve().parents[1]))
    done = subprocess.run(
        [sys.executable, str(copy / "python" / "bicycle_eigenvalues.py")], capture_output=True, text=True, cwd=elsewhere, env=env, timeout=120
    )
    assert done.returncode == 0, done.stderr
    weave = float(done.stdout.split("weave speed")[1].split()[0])
    capsize = float(done.stdout.split("capsize speed")[1].split()[0])
    assert abs(weave - 4.29238253634111) < 1e-9 and abs(capsize - 6.02426201538837) < 1e-9, done.stdout
