"""Calls every public callable of the module with each of its arguments in turn replaced by a
hostile value (None, a str, an object, an int beyond 64 bits, -1, 1.5, nan), the others left
at working values, and prints one JSON line per call: what it raised, or "ok".

Run by test_hostile_input.py in a subprocess (a crash is its exit status) in a scratch folder
(the paths it writes, "x", land there): python3 hostile_calls.py EXAMPLES_DIR."""

from __future__ import annotations

import inspect
import json
import os
import pathlib
import sys
from typing import Any, Callable, Dict, List, Tuple

import numpy as np

import kanedyn

EXAMPLES = pathlib.Path(sys.argv[1])
HOSTILE: List[Tuple[str, Any]] = [
    ("None", None),
    ("str", "x"),
    ("object", object()),
    ("10**30", 10**30),
    ("-1", -1),
    ("1.5", 1.5),
    ("nan", float("nan")),
]
# Values that are valid and would only make a call long: a run to t = 1e30 s.
LONG = {("Model.simulate", "t_end", "10**30")}

eight = kanedyn.load(EXAMPLES / "eight_body.yaml")
four_bar = kanedyn.load(EXAMPLES / "four_bar.yaml")
s = eight.initial_state()
sc = four_bar.initial_state()
n = len(s.z)
X, Y = np.tile(s.x, (3, 1)), np.tile(s.y, (3, 1))
r = eight.simulate(t_end=0.02)
r.to_csv("run.csv")
pathlib.Path("study.yaml").write_text(
    f"""format: kanedyn-study/1
model: {EXAMPLES / "eight_body.yaml"}
vary:
  - key: bodies[head].mass
    grid: [4.0, 6.0]
simulate: {{t_end: 0.01, dt_out: 0.01}}
outputs:
  - final: head.z
trajectories: none
"""
)
study = kanedyn.Study("study.yaml")
study.run(out="done")
lin = eight.linearize(s, modes=True)

# Each public callable: (its name, the callable, the arguments of a working call by name).
Call = Tuple[str, Callable[..., Any], Dict[str, Any]]
CALLS: List[Call] = [
    ("load", kanedyn.load, {"source": str(EXAMPLES / "eight_body.yaml")}),
    ("loads", kanedyn.loads, {"text": (EXAMPLES / "eight_body.yaml").read_text(), "name": "m.yaml"}),
    ("read_csv", kanedyn.read_csv, {"model": eight, "path": "run.csv"}),
    ("read_results", kanedyn.read_results, {"path": "done/results.csv"}),
    ("Study", kanedyn.Study, {"source": "study.yaml"}),
    ("Study.parameters", study.parameters, {"run": 1}),
    ("Study.run", study.run, {"out": "done", "client": None, "threads": 1, "chunk_size": None, "progress": False}),
    ("State", kanedyn.State, {"x": s.x, "y": s.y}),
    ("State.copy", s.copy, {}),
    ("State.normalize", s.copy().normalize, {}),
    ("Result", kanedyn.Result, {"model": eight, "t": r.t, "x": r.x, "y": r.y, "p_G": r.p_G, "energy": r.energy, "stats": {}}),
    ("Result.read_csv", kanedyn.Result.read_csv, {"model": eight, "path": "run.csv"}),
    ("Result.state", r.state, {"row": 1}),
    ("Result.table", r.table, {}),
    ("Result.to_csv", r.to_csv, {"path": "copy.csv"}),
    ("Result.view", r.view, {"path": "run.html"}),
    ("Linearization.mode", lin.mode, {"i": 0}),
    (
        "Simulator",
        kanedyn.Simulator,
        {
            "model": eight,
            "initial": s,
            "integrator": "rk4",
            "dt": 0.01,
            "rtol": 1e-8,
            "atol": 1e-10,
            "max_step": 0.1,
            "route": "recursive",
            "t": 0.0,
            "project_euler_parameters": True,
        },
    ),
    ("Simulator.step", kanedyn.Simulator(eight).step, {"u": np.zeros(0), "dt": 0.01}),
    ("Simulator.set_state", kanedyn.Simulator(eight).set_state, {"state": s, "t": 0.5}),
]
MODEL_CALLS: Dict[str, Tuple[kanedyn.Model, Dict[str, Any]]] = {
    "bias_forces": (eight, {"state": s, "u": None}),
    "body_number": (eight, {"name": "head"}),
    "centre_of_mass": (eight, {"state": s}),
    "centre_of_mass_jacobian": (eight, {"state": s}),
    "constrained_forward": (four_bar, {"state": sc, "u": None, "method": "multipliers"}),
    "constraint_equations": (four_bar, {"state": sc}),
    "derivatives": (eight, {"x": s.x, "y": s.y, "t": 0.0, "u": None}),
    "derivatives_batch": (eight, {"X": X, "Y": Y, "threads": 1, "out": None, "U": None}),
    "energy": (eight, {"state": s}),
    "eom": (eight, {"state": s, "u": None}),
    "equilibrium": (
        eight,
        {"free": None, "u": None, "state": s, "tolerance": 1e-10, "max_iterations": 2, "q": None},
    ),
    "forward": (eight, {"state": s, "z": None, "u": None}),
    "forward_derivatives": (eight, {"state": s, "u": None}),
    "frame": (eight, {"name": "head", "state": s}),
    "frame_acceleration": (eight, {"name": "head", "state": s, "zdot": np.zeros(n)}),
    "gravity_forces": (eight, {"state": s}),
    "initial_state": (eight, {}),
    "inspect": (eight, {"state": s, "t": 0.0, "bodies": 1}),
    "inverse_derivatives": (eight, {"state": s, "zdot": np.zeros(n), "u": None}),
    "inverse_dynamics": (eight, {"state": s, "zdot": np.zeros(n), "u": None}),
    "jacobian": (eight, {"name": "head", "state": s}),
    "joint_derivatives": (eight, {"q": s, "route": "recursive", "u": None}),
    "linearize": (eight, {"state": s, "u": None, "modes": False}),
    "mass_matrix": (eight, {"state": s}),
    "momentum": (eight, {"state": s}),
    "partition_speeds": (four_bar, {"state": sc}),
    "project": (four_bar, {"state": sc, "tolerance": 1e-12}),
    "retract": (eight, {"q0": s, "dx": np.zeros(n)}),
    "simulate": (
        eight,
        {
            "t_end": 0.01,
            "dt_out": 0.005,
            "integrator": "rk4",
            "rtol": 1e-8,
            "atol": 1e-10,
            "step": 0.005,
            "max_step": 0.1,
            "route": "recursive",
            "initial": s,
            "output": "sim.csv",
            "store": True,
            "progress": None,
            "control_interval": 0.0,
        },
    ),
    "state": (eight, {"q": None, "z": None, "x": None, "y": None}),
    "symbolic_partial": (eight, {"body": 8, "point": "G", "rate": False}),
    "tangent_difference": (eight, {"q0": s, "q": s}),
}
for name, (model, kwargs) in MODEL_CALLS.items():
    CALLS.append((f"Model.{name}", getattr(model, name), kwargs))

# Every public callable is in the table: a new one must be added here.
covered = {label for label, _, _ in CALLS}
public = {f"Model.{a}" for a in dir(kanedyn.Model) if not a.startswith("_") and callable(getattr(kanedyn.Model, a))}
for cls in (kanedyn.Simulator, kanedyn.State, kanedyn.Study, kanedyn.Result):
    public |= {f"{cls.__name__}.{a}" for a in dir(cls) if not a.startswith("_") and callable(getattr(cls, a))}
public |= {a for a in kanedyn.__all__ if inspect.isfunction(getattr(kanedyn, a))}
public |= {"Study", "State", "Simulator", "Result"}
print(json.dumps({"missing": sorted(public - covered)}), flush=True)

for label, f, kwargs in CALLS:
    f(**kwargs)  # the working call works
    for arg in kwargs:
        for shown, value in HOSTILE:
            if (label, arg, shown) in LONG:
                continue
            try:
                f(**{**kwargs, arg: value})
                outcome = {"type": "ok", "message": ""}
            except Exception as e:  # noqa: BLE001 (every exception is reported)
                outcome = {"type": type(e).__name__, "message": str(e)}
            print(json.dumps({"call": label, "arg": arg, "value": shown, **outcome}), flush=True)
print(json.dumps({"done": True}), flush=True)
