"""Simulation results and the progress bar (the Python side of Model.simulate)."""

from __future__ import annotations

import difflib
import operator
import os
import pathlib
import sys
import time
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np

from ._kanedyn import Model

_SUFFIXES = ("x", "y", "z", "e1", "e2", "e3", "e4", "s1", "s2", "s3", "w1", "w2", "w3", "sd1", "sd2", "sd3")


class Result:
    """A trajectory: one row per output time.

    t (T,), x (T, 7N) and y (T, 6N) are the states of Eq. (1) in the notes' order, p_G (T, N, 3)
    the mass centres G_K (inertial), energy (T,) the total energy; stats is a dict (status,
    steps_accepted, steps_rejected, evaluations, wall_seconds, energy_initial, energy_final,
    energy_change (J), energy_scale (J: the largest kinetic energy or potential-energy swing
    of the run, 0 when nothing moved), relative_energy_change (energy_change / energy_scale,
    nan when energy_scale is 0), max_euler_drift, message, ...). r["torso.w2"] is a column of the
    trajectory CSV by name (r.columns lists them); r.to_csv(path) writes the CSV that
    `kanedyn simulate` writes. A jointed model's result also has q (T, nq) and z (T, nz), the
    joint coordinates and independent speeds of each row (model.joint_layout gives each
    body's slices), and its columns NAME.j1.. and NAME.jd1.. (r["thigh.j1"]). A model with
    inputs adds u (T, m), the inputs' values in force at each row, its columns input.NAME. A
    model with constraints adds reactions (T, r), each constraint's force on its body (NAME.f1..f3)
    and a hinge's moment (NAME.m1..m3), inertial components, in the order of r.columns; stats
    then has normal_force_negative_at, the rolling discs whose normal force became negative (the
    wheel would lift) and the first output time it did.
    """

    def __init__(
        self,
        model: Any,
        t: np.ndarray,
        x: np.ndarray,
        y: np.ndarray,
        p_G: np.ndarray,
        energy: np.ndarray,
        stats: Dict[str, Any],
        path: Optional[str] = None,
        q: Optional[np.ndarray] = None,
        z: Optional[np.ndarray] = None,
        u: Optional[np.ndarray] = None,
        reactions: Optional[np.ndarray] = None,
    ) -> None:
        _require_model(model)
        self.model = model
        self.t = t
        self.x = x
        self.y = y
        self.p_G = p_G
        self.energy = energy
        self.stats = stats
        self.path = path  #: the CSV streamed during the run, if any
        self.q = q  #: jointed models: the joint coordinates of each row, else None
        self.z = z  #: jointed models: the independent speeds of each row, else None
        #: models with inputs: the inputs' values in force at each row (T, m), else None
        self.u = u
        #: models with constraints: the reactions at each row (T, r), else None
        self.reactions = reactions

    @property
    def columns(self) -> List[str]:
        """The trajectory CSV's columns, in order."""
        return list(self.model.columns)

    @property
    def reaction_columns(self) -> List[str]:
        """The constraints' reaction columns (NAME.f1.., a hinge's NAME.m1..), the CSV's last."""
        return _reaction_columns(self.model)

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def __repr__(self) -> str:
        status = self.stats.get("status", "read from a file")
        rows = f"{len(self)} row" if len(self) == 1 else f"{len(self)} rows"
        return f"<kanedyn.Result {rows}, N={self.model.N}, {status}>"

    def _locate(self, name: str) -> Tuple[np.ndarray, Tuple[Any, ...]]:
        if name == "t":
            return self.t, (slice(None),)
        if name == "energy":
            return self.energy, (slice(None),)
        inputs = list(self.model.inputs)
        if name.startswith("input.") and name[len("input.") :] in inputs:
            if self.u is None:
                raise KeyError(f"column {name!r}: this result holds no input values")
            return self.u, (slice(None), inputs.index(name[len("input.") :]))
        reactions = self.reaction_columns
        if name in reactions:
            if self.reactions is None:
                raise KeyError(f"column {name!r}: this result holds no constraint reactions")
            return self.reactions, (slice(None), reactions.index(name))
        body, _, suffix = name.rpartition(".")
        n = self.model.N
        layout = self.model.joint_layout
        if body in layout and self.model.joint_types[self.model.body_number(body) - 1] not in ("free", "weld"):
            q_at, nq, z_at, nz = layout[body]
            for prefix, array, at, count in (("jd", self.z, z_at, nz), ("j", self.q, q_at, nq)):
                number = suffix[len(prefix) :]
                if suffix.startswith(prefix) and number.isdigit() and 1 <= int(number) <= count:
                    return array, (slice(None), at + int(number) - 1)
        if body and suffix in _SUFFIXES:
            try:
                k = self.model.body_number(body) - 1
            except KeyError:
                k = -1
            if k >= 0:
                i = _SUFFIXES.index(suffix)
                if i < 3:
                    return self.p_G, (slice(None), k, i)
                if i < 7:
                    return self.x, (slice(None), 4 * k + i - 3)
                if i < 10:
                    return self.x, (slice(None), 4 * n + 3 * k + i - 7)
                if i < 13:
                    return self.y, (slice(None), 3 * k + i - 10)
                return self.y, (slice(None), 3 * n + 3 * k + i - 13)
        near = difflib.get_close_matches(name, self.columns, n=1)
        hint = f" (did you mean {near[0]!r}?)" if near else ""
        raise KeyError(f"no column {name!r}{hint}; r.columns lists them")

    def __getitem__(self, name: str) -> np.ndarray:
        """The column `name` of the trajectory CSV (e.g. "torso.w2", "pelvis.z", "energy"), a
        C-contiguous copy of shape (T,)."""
        if not isinstance(name, str):
            raise TypeError(f"columns are named by str, e.g. r['t'], not {type(name).__name__}")
        array, index = self._locate(name)
        return np.ascontiguousarray(array[index])

    def state(self, row: int) -> Any:
        """The State of one row (a copy); row counts from 0 (from -T: from the end). For a
        model with joints it is the row's joint coordinates q and speeds z, the state that
        model's calls (energy, derivatives, eom, ...) take; else the notes' x and y."""
        from ._kanedyn import State

        if isinstance(row, (bool, np.bool_)):
            raise TypeError("row must be an integer, got a bool")
        try:
            index = operator.index(row)
        except TypeError:
            raise TypeError(f"row must be an integer, got {type(row).__name__}") from None
        if not -len(self) <= index < len(self):
            shown = str(index) if index.bit_length() < 128 else f"of {index.bit_length()} bits"
            raise IndexError(f"row {shown} is not in 0..{len(self) - 1} (or -{len(self)}..-1 from the end)")
        if self.q is not None and self.z is not None:
            # The notes' (x, y) of a jointed model do not give back its joint coordinates in
            # general (a hinge's angle is not read from x): the row's stored q and z are its state.
            return self.model.state(q=self.q[index], z=self.z[index])
        return State(self.x[index], self.y[index])

    def table(self) -> np.ndarray:
        """Every column of the CSV, (T, 2 + 16N) (more with joint columns), in the order of
        r.columns."""
        if self.model.jointed or self.model.inputs or self.reaction_columns:
            return np.column_stack([self[c] for c in self.columns])
        n = self.model.N
        T = len(self)
        out = np.empty((T, 2 + 16 * n))
        out[:, 0] = self.t
        per_body = out[:, 1 : 1 + 16 * n].reshape(T, n, 16)
        per_body[:, :, 0:3] = self.p_G
        per_body[:, :, 3:7] = self.x[:, : 4 * n].reshape(T, n, 4)
        per_body[:, :, 7:10] = self.x[:, 4 * n :].reshape(T, n, 3)
        per_body[:, :, 10:13] = self.y[:, : 3 * n].reshape(T, n, 3)
        per_body[:, :, 13:16] = self.y[:, 3 * n :].reshape(T, n, 3)
        out[:, -1] = self.energy
        return out

    def to_csv(self, path: Union[str, bytes, os.PathLike]) -> None:
        """Writes the trajectory CSV, byte for byte what `kanedyn simulate` writes for the same
        run: to PATH.partial, renamed to PATH when complete. The rows are checked first: a
        number that is not finite, Euler parameters not of unit norm (within 1e-6), times out
        of order or no rows at all raise ValueError naming the array, row and column, and no
        file is created (the tool's reader would refuse such a file)."""
        self.model._write_csv(path, self.t, self.x, self.y, self.energy, self.q, self.z, self.u, self.reactions)

    def view(self, path: Union[str, bytes, os.PathLike, None] = None) -> Union[str, bytes]:
        """Writes the web page of `kanedyn view` for this trajectory (docs/viewer.md): one
        self-contained HTML file that animates the model and plots the columns. The default
        path is the CSV's name (when the run streamed one), else the model file's, with .html,
        in the current folder. The same rows give the page `kanedyn view MODEL TRAJ.csv` writes.
        Returns the path written. The rows are checked first, as to_csv checks them (the tool's
        view reads them through the trajectory reader, which refuses a number that is not
        finite): ValueError naming the array, row and column, and no page is written."""
        self.model._check_rows("view", self.t, self.x, self.y, self.energy, self.q, self.z, self.u, self.reactions)
        if path is None:
            named = self.path or (self.model.path if not self.model.path.startswith("<") else None)
            if named is None:
                raise TypeError("view() needs a path: this model was not loaded from a file")
            path = pathlib.Path(named).with_suffix(".html").name
        source = pathlib.Path(self.path).name if self.path else "simulate() from Python"
        self.model._write_view(path, self.table(), source, self.path or "")
        return os.fspath(path)

    @classmethod
    def read_csv(cls, model: Any, path: Union[str, bytes, os.PathLike]) -> "Result":
        """A trajectory CSV of this model, read back to the same doubles by the tool's own
        reader (the header must be this model's, every row whole, times in order); ValueError
        names the file, the line and the problem."""
        _require_model(model)
        table = model._read_csv(path)
        path = os.fsdecode(path)
        n = model.N
        rows = table.shape[0]
        q = z = u = reactions = None
        index = {c: i for i, c in enumerate(model.columns)}
        reaction_columns = _reaction_columns(model)
        if reaction_columns:
            reactions = np.ascontiguousarray(table[:, [index[c] for c in reaction_columns]])
        energy = np.ascontiguousarray(table[:, index["energy"]])
        if model.inputs:
            u = np.ascontiguousarray(table[:, [index[f"input.{name}"] for name in model.inputs]])
        if model.jointed:
            # Each body's 16 columns, then its joint columns: gather them by name.
            body_cols = [index[f"{b}.{s}"] for b in model.body_names for s in _SUFFIXES]
            q = np.zeros((rows, len(model.initial_joint_coordinates)))
            z = np.zeros((rows, len(model.initial_joint_speeds)))
            for k, (b, kind) in enumerate(zip(model.body_names, model.joint_types)):
                q_at, nq, z_at, nz = model.joint_layout[b]
                first = index[f"{b}.x"]
                if kind == "free":
                    q[:, q_at : q_at + 7] = table[:, first + 3 : first + 10]
                    z[:, z_at : z_at + 6] = table[:, first + 10 : first + 16]
                elif kind != "weld":
                    q[:, q_at : q_at + nq] = table[:, first + 16 : first + 16 + nq]
                    z[:, z_at : z_at + nz] = table[:, first + 16 + nq : first + 16 + nq + nz]
            table = np.column_stack([table[:, 0], table[:, body_cols]])
        per_body = table[:, 1 : 1 + 16 * n].reshape(rows, n, 16)
        x = np.concatenate([per_body[:, :, 3:7].reshape(rows, 4 * n), per_body[:, :, 7:10].reshape(rows, 3 * n)], axis=1)
        y = np.concatenate([per_body[:, :, 10:13].reshape(rows, 3 * n), per_body[:, :, 13:16].reshape(rows, 3 * n)], axis=1)
        return cls(
            model,
            np.ascontiguousarray(table[:, 0]),
            np.ascontiguousarray(x),
            np.ascontiguousarray(y),
            np.ascontiguousarray(per_body[:, :, 0:3]),
            energy,
            {},
            path,
            q,
            z,
            u,
            reactions,
        )


def _require_model(model: Any) -> None:
    if not isinstance(model, Model):
        raise TypeError(f"model must be a kanedyn.Model (kanedyn.load(...)), got {type(model).__name__}")


def _reaction_columns(model: Any) -> List[str]:
    """The columns after energy and the inputs: the constraints' reactions."""
    columns = list(model.columns)
    return columns[columns.index("energy") + 1 + len(model.inputs) :]


class ProgressBar:
    """progress=True of Model.simulate: a bar on stderr, redrawn in place, cleared at the end."""

    def __init__(self, stream: Any = None, width: int = 30) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.start = time.monotonic()
        self.drawn = False

    def __call__(self, t: float, t_end: float) -> None:
        fraction = min(max(t / t_end if t_end > 0 else 1.0, 0.0), 1.0)
        elapsed = time.monotonic() - self.start
        filled = int(fraction * self.width)
        bar = "#" * filled + "." * (self.width - filled)
        left = elapsed * (1 - fraction) / fraction if fraction > 0 else 0.0
        end = "\n" if fraction >= 1.0 else ""
        self.stream.write(f"\r[{bar}] {100 * fraction:5.1f}%  t = {t:.4g} of {t_end:.4g}  elapsed {elapsed:.1f} s  left ~{left:.0f} s {end}")
        self.stream.flush()
        self.drawn = True
