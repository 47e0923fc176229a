"""kanedyn: dynamics of multibody systems by Kane's equations.

A tree of N rigid bodies, each with a joint (free: the notes' body), from a model file::

    import kanedyn
    m = kanedyn.load("examples/eight_body.yaml")
    e = m.eom()                      # [A], {f}, {y dot}, {x dot} at the initial state
    r = m.simulate(t_end=10)         # r.t, r.x, r.y, r.energy, r["torso.w2"]
    arm = kanedyn.load("examples/urdf/arm.urdf")
    s = arm.state(q=[0.3, -0.7, 1.1, 0.4, -0.2, 0.9])   # a state from joint coordinates
    qdot, zdot = arm.derivatives(s)

Arrays are float64 numpy arrays in the notes' order: x = (eps_1..eps_N, s'_1..s'_N), 7N, and
y = (w'_1..w'_N, s'_1 dot..s'_N dot), 6N (Eq. 1); e4 is the scalar part of eps_K. The state of
a model with joints is its joint coordinates q and speeds z. See docs/python.md.
"""

# The package's namespace is its API (__all__): module imports and helpers live in the
# private modules, and only the names below are bound here.
from ._kanedyn import (
    BodyInspection,
    EquationsOfMotion,
    Inspection,
    Model,
    ModelError,
    SimulationError,
    Simulator,
    State,
    __version__,
)
from ._analysis import Equilibrium, Linearization
from ._api import load, loads, read_csv
from ._result import ProgressBar, Result
from .study import Study, read_results

__all__ = [
    "BodyInspection",
    "Equilibrium",
    "EquationsOfMotion",
    "Inspection",
    "Linearization",
    "Model",
    "ModelError",
    "ProgressBar",
    "Result",
    "SimulationError",
    "Simulator",
    "State",
    "Study",
    "__version__",
    "load",
    "loads",
    "read_csv",
    "read_results",
]
