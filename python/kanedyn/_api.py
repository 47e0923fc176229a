"""The module-level calls of kanedyn (load, loads, read_csv) and Model.simulate, kept out of
the package's namespace so that `import kanedyn` exports its API and nothing else."""

from __future__ import annotations

import json
import os
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from ._kanedyn import Model, ModelError, State, _load_file, _load_text
from ._result import Result

__all__ = ["load", "loads", "read_csv"]


def _jsonable(value: Any) -> Any:
    """numpy scalars and arrays as plain numbers and lists, for json.dumps."""
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"a model dict holds only numbers, strings, lists and dicts, not {type(value).__name__}")


def _from_dict(model: Mapping[str, Any]) -> Model:
    try:
        text = json.dumps(model, default=_jsonable, allow_nan=False)
    except ValueError as e:  # nan or inf
        raise ModelError(f"<dict>: {e}") from None
    return _load_text(text, "<dict>")


def load(source: Union[str, bytes, os.PathLike, Mapping[str, Any]]) -> Model:
    """A Model from a model file (YAML or JSON, docs/model-format.md) or from a dict of the
    same structure. Raises kanedyn.ModelError with the tool's message,
    FILE:LINE:COL: KEY.PATH: problem. A path is what open() takes (str, bytes, os.PathLike);
    one holding a NUL byte raises ValueError, as open() does."""
    if isinstance(source, Mapping):
        return _from_dict(source)
    if isinstance(source, (str, bytes, os.PathLike)):
        return _load_file(source)
    raise TypeError(f"load() takes a path or a dict, not {type(source).__name__}")


def loads(text: Union[str, Mapping[str, Any]], name: str = "<string>") -> Model:
    """A Model from the text of a model file (or a dict); `name` stands for the file name in
    error messages."""
    if isinstance(text, Mapping):
        return _from_dict(text)
    if not isinstance(text, str):
        raise TypeError(f"loads() takes a str or a dict, not {type(text).__name__}")
    return _load_text(text, name)


def read_csv(model: Model, path: Union[str, bytes, os.PathLike]) -> Result:
    """A trajectory CSV written by `kanedyn simulate` (or Result.to_csv) for this model, as a
    Result (stats is empty)."""
    return Result.read_csv(model, path)


def _simulate(
    self: Model,
    t_end: Optional[float] = None,
    dt_out: Optional[float] = None,
    *,
    integrator: Optional[str] = None,
    rtol: Optional[float] = None,
    atol: Optional[float] = None,
    step: Optional[float] = None,
    max_step: Optional[float] = None,
    route: Optional[str] = None,
    method: Optional[str] = None,
    initial: Optional[State] = None,
    output: Union[str, bytes, os.PathLike, None] = None,
    store: bool = True,
    progress: Union[bool, Callable[[float, float], Any], None] = None,
    inputs: Optional[Tuple[Sequence[float], Any]] = None,
    inputs_hold: Optional[str] = None,
    controller: Optional[Callable[[float, State], "np.ndarray"]] = None,
    control_interval: float = 0.0,
) -> Result:
    """Integrates the model from its initial state (or `initial`, a State of this model) to
    t_end, with output rows every dt_out, and returns a Result: r.t (T,), r.x (T, 7N), r.y
    (T, 6N), r.p_G (T, N, 3), r.energy (T,), r.stats; for a model with joints also r.q and r.z.

    Settings left None come from the model file's simulation: section, else the defaults of
    `kanedyn simulate` (t_end 10, dt_out 0.01, dopri5 with rtol 1e-8 and atol 1e-10, rk4 step
    1e-3, route "recursive"): the same settings give the same numbers as the tool, bit for bit.
    integrator is "dopri5" or "rk4"; route is "recursive" or "assembled" (method is its older
    name, as --method is for the tool). max_step caps dopri5's step.

    output: also stream the trajectory CSV there, as the tool does (to OUTPUT.partial, renamed
    when the run completes). store=False keeps no rows in memory (then the stats dict is
    returned). progress=True draws a bar on stderr; a callable is called as progress(t, t_end)
    about ten times a second. Ctrl-C raises KeyboardInterrupt, keeping the partial file; a
    failed run raises SimulationError, whose .result holds the rows before the failure.

    The model's inputs (Model.inputs) are 0 unless driven: inputs=(t, U), a table of times t
    (T,) and values U (T, m), held between rows (inputs_hold "zero-order") or interpolated
    ("linear"), as `kanedyn simulate --inputs`; or controller(t, state) -> u (m values),
    called at every evaluation (control_interval 0) or at t_start + i control_interval, its
    values held in between. A controller that raises stops the run: SimulationError, chained
    from the controller's exception, with the rows before. r.u (T, m) holds the values in
    force at each row (the CSV's input.NAME columns).
    """
    if method is not None:
        if route is not None:
            raise ValueError("give route or its older name method, not both")
        route = method
    settings = {
        "t_end": t_end,
        "dt_out": dt_out,
        "integrator": integrator,
        "rtol": rtol,
        "atol": atol,
        "step": step,
        "max_step": max_step,
        "route": route,
        "inputs": inputs,
        "inputs_hold": inputs_hold,
        "controller": controller,
        "control_interval": control_interval,
    }
    return self._simulate(settings, initial, output, store, progress)


Model.simulate = _simulate  # type: ignore[attr-defined]
