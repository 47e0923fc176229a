#!/usr/bin/env python3
"""The Python module's costs, measured in one run (docs/performance.md, "Python"):

1. the call overhead of Model.derivatives on the eight-body model: Python's time per call
   minus the C++ loop's (Model._time_derivatives, the same evaluation without Python);
2. derivatives_batch on 10,000 states, on one thread and on every core;
3. Model.simulate against `kanedyn simulate` on the same model and settings, CSV included;
4. the overhead of Simulator.step on the six-joint arm (examples/urdf/arm.urdf, with a joint
   input per joint): Python's time per step minus the C++ loop's (Simulator._time_steps).

Usage: PYTHONPATH=build/python python3 bench/python/bench_python.py [--tool build/kanedyn]
Each figure is the best of several repetitions (the least disturbed by other work).
"""

from __future__ import annotations

import argparse
import os
import pathlib
import re
import subprocess
import tempfile
import time

import numpy as np

import kanedyn

ROOT = pathlib.Path(__file__).resolve().parents[2]


def best(repeats: int, fn) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def call_overhead(m: kanedyn.Model) -> None:
    s = m.initial_state()
    x, y = s.x.copy(), s.y.copy()
    calls = 200_000
    cpp = min(m._time_derivatives(s, calls) for _ in range(5))
    derivatives = m.derivatives

    def loop() -> None:
        for _ in range(calls):
            derivatives(x, y)

    py = best(5, loop) / calls
    print(f"derivatives, {m.N} bodies: C++ {cpp * 1e6:.3f} us per call, from Python {py * 1e6:.3f} us: overhead {(py - cpp) * 1e6:.3f} us")


def batch(m: kanedyn.Model) -> None:
    """One thread against every core, interleaved (this VM's second core comes and goes), the
    best of 41 each; into preallocated outputs too (first-touching 8 MB of new pages costs
    about as much as 10,000 eight-body evaluations here)."""
    rng = np.random.default_rng(0)
    count = 10_000
    s = m.initial_state()
    X = np.tile(s.x, (count, 1))
    Y = np.tile(s.y, (count, 1)) + 0.1 * rng.normal(size=(count, 6 * m.N))
    out = (np.empty_like(X), np.empty_like(Y))
    cores = os.cpu_count() or 1
    times: dict = {}
    for _ in range(41):
        for key, threads, target in (("1", 1, None), ("all", 0, None), ("1 out", 1, out), ("all out", 0, out)):
            start = time.perf_counter()
            m.derivatives_batch(X, Y, threads=threads, out=target)
            times[key] = min(times.get(key, float("inf")), time.perf_counter() - start)
    print(
        f"derivatives_batch, {count} states of {m.N} bodies: 1 thread {times['1'] * 1e3:.2f} ms, {cores} threads "
        f"{times['all'] * 1e3:.2f} ms: {times['1'] / times['all']:.2f}x; into out=: {times['1 out'] * 1e3:.2f} ms, "
        f"{times['all out'] * 1e3:.2f} ms: {times['1 out'] / times['all out']:.2f}x"
    )


def simulate(path: pathlib.Path, tool: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        out_tool = pathlib.Path(tmp) / "tool.csv"
        out_py = pathlib.Path(tmp) / "py.csv"
        walls = []

        def run_tool() -> None:
            done = subprocess.run([tool, "simulate", str(path), "-o", str(out_tool)], capture_output=True, text=True, check=True)
            walls.append(float(re.search(r"wall time ([0-9.e+-]+) s", done.stdout).group(1)))

        cli = best(5, run_tool)
        results = []

        def run_py() -> None:
            m = kanedyn.load(path)
            results.append(m.simulate(output=out_py))

        py = best(5, run_py)
        same = out_tool.read_bytes() == out_py.read_bytes()
        inner_py = min(r.stats["wall_seconds"] for r in results)
        print(
            f"simulate {path.name}: the tool {cli * 1e3:.1f} ms (process, load, run, CSV; the run {min(walls) * 1e3:.1f} ms), "
            f"Python load + simulate {py * 1e3:.1f} ms (the run {inner_py * 1e3:.1f} ms): {py / cli:.2f}x the tool's time; "
            f"same CSV: {same}"
        )


def arm_with_inputs(tool: str) -> kanedyn.Model:
    """examples/urdf/arm.urdf as a model file, with a joint input (a torque) on each joint."""
    urdf = ROOT / "examples" / "urdf" / "arm.urdf"
    done = subprocess.run([tool, "import", str(urdf), "-o", "-"], capture_output=True, text=True, check=True)
    arm = kanedyn.load(urdf)
    driven = [b for b, kind in zip(arm.body_names, arm.joint_types) if kind not in ("weld", "free")]
    inputs = "".join(f"  - {{name: tau_{b}, type: joint, body: {b}}}\n" for b in driven)
    return kanedyn.loads(done.stdout + "inputs:\n" + inputs, "arm_inputs.yaml")


def step_overhead(m: kanedyn.Model) -> None:
    """Simulator.step(u, dt) from Python against the same steps looped in C++, both rk4 at
    dt = 1 ms with a float64 array u held in place, best of 5 runs of 50,000 steps each."""
    steps = 50_000
    dt = 1e-3
    u = np.linspace(-0.5, 0.5, len(m.inputs))
    sim = kanedyn.Simulator(m, integrator="rk4")
    cpp = min(sim._time_steps(u, dt, steps) for _ in range(5))
    step = sim.step

    def loop() -> None:
        for _ in range(steps):
            step(u, dt)

    py = best(5, loop) / steps
    print(
        f"Simulator.step, {m.N} bodies, {len(m.inputs)} inputs, rk4: C++ {cpp * 1e6:.3f} us per step, "
        f"from Python {py * 1e6:.3f} us: overhead {(py - cpp) * 1e6:.3f} us"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tool", default=str(ROOT / "build" / "kanedyn"))
    args = parser.parse_args()
    eight = kanedyn.load(ROOT / "examples" / "eight_body.yaml")
    call_overhead(eight)
    batch(eight)
    batch(kanedyn.load(ROOT / "examples" / "chain64.yaml"))
    simulate(ROOT / "examples" / "eight_body.yaml", args.tool)
    simulate(ROOT / "examples" / "chain64.yaml", args.tool)
    step_overhead(arm_with_inputs(args.tool))


if __name__ == "__main__":
    main()
