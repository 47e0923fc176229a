"""Linearization and static equilibrium (the Python side of Model.linearize and
Model.equilibrium; docs/analysis.md). The C++ side computes; these classes hold the results,
give the spec's JSON object and a readable summary."""

from __future__ import annotations

import json
import math
import operator
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np

from ._kanedyn import Model, State

__all__ = ["Equilibrium", "Linearization", "Reduced"]


def _count(number: int, noun: str) -> str:
    """'1 input', '3 inputs', '0 inputs'."""
    return f"{number} {noun}" if number == 1 else f"{number} {noun}s"


def _reading(value: complex, tolerance: float) -> str:
    """One eigenvalue as the tool's summary reads it: frequency, damping ratio, time constant."""
    re, im = value.real, value.imag
    size = abs(value)
    parts = [f"{re:+.6g}" if im == 0.0 else f"{re:+.6g} {im:+.6g}i"]
    if im != 0.0:
        parts.append(f"{abs(im) / (2 * math.pi):.4g} Hz")
    if size > 0.0:
        parts.append(f"damping ratio {-re / size:.3g}")
    if re != 0.0:
        parts.append(f"time constant {1.0 / abs(re):.4g} s")
    parts.append("unstable" if re > tolerance else "stable" if re < -tolerance else "neutral")
    return ", ".join(parts)


@dataclass(eq=False)
class Reduced:
    """The linearization with its ignorable coordinates dropped (Model.linearize(reduce=True);
    docs/analysis.md, "Steady motions: the reduced system").

    dropped: one dict per dropped coordinate, {"index": its entry of Linearization.state,
    "name": that entry's name, "kind": "coordinate", "heading" or "spin"}; kept: the entries
    kept, state their names; A, B: the reduced system (in coordinates that move with the
    steady motion: time-invariant there); eigenvalues (sorted as Linearization.eigenvalues) and
    modes (with modes=True, else None); steady: the reduced state's rate is zero at the
    operating point (reduced_rate, its largest entry), so the eigenvalues decide stability;
    rates: the nominal speed along each dropped direction (rad/s for heading and spin); lift:
    (len(state), len(kept)), the full state deviation of a reduced one."""

    dropped: List[Dict[str, Any]]
    kept: List[int]
    state: List[str]
    A: np.ndarray
    B: np.ndarray
    eigenvalues: np.ndarray
    steady: bool
    reduced_rate: float
    rates: List[float]
    lift: np.ndarray
    modes: Optional[np.ndarray] = None

    def as_dict(self, with_inputs: bool) -> Dict[str, Any]:
        """The "reduced" object of `kanedyn linearize --json --reduce`."""
        out: Dict[str, Any] = {
            "dropped": [dict(d) for d in self.dropped],
            "state": list(self.state),
            "steady": bool(self.steady),
            "A": self.A.tolist(),
        }
        if with_inputs:
            out["B"] = self.B.tolist()
        out["eigenvalues"] = [[float(v.real), float(v.imag)] for v in self.eigenvalues]
        return out


@dataclass(eq=False)
class Linearization:
    """The motion linearized about the nominal motion through (q, z, u)
    (docs/model-format.md, "Linearization output"): d(state)/dt = A state + B du, with the
    state the tangent deviation of q (a rotation vector for each set of Euler parameters),
    then the deviation of z, named by `state` (2n names; with constraints, the independent
    coordinates, then the n independent speeds).

    n, m: the speeds and the inputs; state, inputs: their names; q, z, u: the operating point;
    zdot: z dot there (0 at an equilibrium); A (2n, 2n), B (2n, m); eigenvalues (2n,) complex,
    sorted by decreasing real part, then decreasing imaginary part; modes (2n, 2n) complex,
    column i the eigenvector of eigenvalues[i] scaled so that its largest entry is 1 (only with
    linearize(modes=True), else None); periodic: a free body turns at the operating point, so
    the linear system is periodic and its eigenvalues at this instant do not decide stability;
    reduced: with linearize(reduce=True), the Reduced system (the ignorable coordinates
    dropped), else None.
    """

    n: int
    m: int
    state: List[str]
    inputs: List[str]
    q: np.ndarray
    z: np.ndarray
    u: np.ndarray
    zdot: np.ndarray
    A: np.ndarray
    B: np.ndarray
    eigenvalues: np.ndarray
    modes: Optional[np.ndarray] = None
    periodic: bool = False
    reduced: Optional[Reduced] = None

    def __post_init__(self) -> None:
        if isinstance(self.reduced, dict):
            self.reduced = Reduced(**self.reduced)

    def as_dict(self) -> Dict[str, Any]:
        """The spec's JSON object (`kanedyn linearize --json`) as plain Python: n, m, state,
        inputs, q, z, u, A, B (only when m > 0) and eigenvalues as [real, imaginary] pairs;
        with modes (linearize(modes=True), `--json --modes`) also "modes", each column a list
        of [real, imaginary] pairs."""
        out: Dict[str, Any] = {
            "n": int(self.n),
            "m": int(self.m),
            "state": list(self.state),
            "inputs": list(self.inputs),
            "q": self.q.tolist(),
            "z": self.z.tolist(),
            "u": self.u.tolist(),
            "A": self.A.tolist(),
        }
        if self.m > 0:
            out["B"] = self.B.tolist()
        out["eigenvalues"] = [[float(v.real), float(v.imag)] for v in self.eigenvalues]
        if self.modes is not None:
            # Not in the spec's object unless asked, as `--json --modes` adds it: column i, the
            # vector of eigenvalue i, as [real, imaginary] pairs.
            out["modes"] = [[[float(v.real), float(v.imag)] for v in column] for column in self.modes.T]
        if self.reduced is not None:
            out["reduced"] = self.reduced.as_dict(self.m > 0)
        return out

    def to_json(self, indent: Optional[int] = None) -> str:
        """as_dict() as JSON text; numbers as Python writes them (repr: they read back exactly)."""
        return json.dumps(self.as_dict(), indent=indent, allow_nan=False)

    def mode(self, i: int) -> Dict[str, complex]:
        """Eigenvector i (of eigenvalues[i]) by state name: what each coordinate and speed does
        in that mode. Needs linearize(modes=True)."""
        if self.modes is None:
            raise ValueError("mode(): this linearization has no modes; call linearize(..., modes=True)")
        count = self.modes.shape[1]
        if isinstance(i, (bool, np.bool_)):
            raise TypeError("i must be an integer, got a bool")
        try:
            index = operator.index(i)
        except TypeError:
            raise TypeError(f"i must be an integer, got {type(i).__name__}") from None
        if not -count <= index < count:
            shown = str(index) if index.bit_length() < 128 else f"of {index.bit_length()} bits"
            raise IndexError(f"mode {shown} is not in 0..{count - 1}")
        return {name: complex(v) for name, v in zip(self.state, self.modes[:, index])}

    def summary(self, tolerance: Optional[float] = None) -> str:
        """A readable summary: each eigenvalue with its frequency, damping ratio and time
        constant, and stable (Re < -tolerance), unstable (Re > tolerance) or neutral. The
        default tolerance is 1e-9 times the largest |eigenvalue| (at least 1e-12)."""
        if tolerance is None:
            largest = float(np.abs(self.eigenvalues).max()) if self.eigenvalues.size else 0.0
            tolerance = max(1e-9 * largest, 1e-12)
        # The state is the tangent coordinates then the speeds: with holonomic constraints
        # the independent coordinates are fewer or more than the n speeds (a rolling wheel's
        # contact keeps coordinates its speeds do not span), so count the state's names.
        states = len(self.state)
        lines = [
            f"linearized: n = {_count(self.n, 'speed')}, m = {_count(self.m, 'input')}, "
            f"{_count(states, 'state')}"
        ]
        if self.periodic:
            lines.append(
                "a free body turns at the operating point: the linear system is periodic, and "
                "these eigenvalues of one instant do not decide stability"
            )
        lines += [f"  {i:3d}  {_reading(complex(v), tolerance)}" for i, v in enumerate(self.eigenvalues)]
        red = self.reduced
        if red is not None:
            names = ", ".join(f"{d['name']} ({d['kind']})" for d in red.dropped) or "none"
            lines.append(f"reduced: dropped {names}; kept {', '.join(red.state)}")
            lines.append(
                "the reduced system is time-invariant at this steady motion: its eigenvalues decide stability"
                if red.steady
                else f"not a steady motion (largest reduced rate {red.reduced_rate:.3g}): the verdicts hold for this instant only"
            )
            lines += [f"  {i:3d}  {_reading(complex(v), tolerance)}" for i, v in enumerate(red.eigenvalues)]
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()

    def __repr__(self) -> str:
        return f"<kanedyn.Linearization n={self.n} m={self.m}{' periodic' if self.periodic else ''}>"


@dataclass(eq=False)
class Equilibrium:
    """The result of Model.equilibrium: Newton on the generalized forces at z = 0 over the free
    coordinates.

    converged: the largest generalized force on the free coordinates fell to tolerance * scale;
    iterations; q: the rest pose (the last iterate when not converged); u: the inputs held;
    free: the names of the coordinates Newton moved; residual: the generalized forces on them
    at q, residual_norm their largest magnitude, scale the force scale the tolerance is relative
    to; message: why it stopped; unrestrained: the free coordinates that nothing restrains at
    q (what to hold fixed, or leave out of `free`); linearization: the model linearized at
    (q, 0, u) when converged (else None), and eigenvalues its eigenvalues.
    """

    converged: bool
    iterations: int
    q: np.ndarray
    u: np.ndarray
    free: List[str]
    residual: np.ndarray
    residual_norm: float
    scale: float
    tolerance: float
    message: str
    unrestrained: List[str] = field(default_factory=list)
    linearization: Optional[Linearization] = None

    @property
    def eigenvalues(self) -> Optional[np.ndarray]:
        """The eigenvalues at the rest pose (None when Newton did not converge)."""
        return None if self.linearization is None else self.linearization.eigenvalues

    def __bool__(self) -> bool:
        return self.converged

    def __repr__(self) -> str:
        return f"<kanedyn.Equilibrium converged={self.converged} iterations={self.iterations} residual_norm={self.residual_norm:.3g}>"

    def __str__(self) -> str:
        lines = [self.message]
        if self.unrestrained:
            lines.append("unrestrained at the end (hold them fixed): " + ", ".join(self.unrestrained))
        if self.linearization is not None:
            lines.append(self.linearization.summary())
        return "\n".join(lines)


def _linearize(
    self: Model,
    state: Optional[State] = None,
    u: Optional[Sequence[float]] = None,
    modes: bool = False,
    *,
    q: Optional[Sequence[float]] = None,
    z: Optional[Sequence[float]] = None,
    reduce: bool = False,
) -> Linearization:
    """The model linearized about the nominal motion through a state (default: the initial
    state; or q= and z=) with the inputs at u (None: all 0): a Linearization with A, B, the
    eigenvalues, and with modes=True the eigenvectors. The operating point need not be an
    equilibrium (steady rotation, rolling). reduce=True adds lin.reduced: the system with the
    ignorable coordinates dropped (a free root's position and heading, a wheel's spin), whose
    eigenvalues decide stability at a steady motion (`kanedyn linearize --reduce`).
    lin.as_dict() is `kanedyn linearize --json`'s object; print(lin) reads each eigenvalue."""
    if not isinstance(modes, (bool, np.bool_)):
        raise TypeError(f"modes must be True or False, not {type(modes).__name__}")
    if not isinstance(reduce, (bool, np.bool_)):
        raise TypeError(f"reduce must be True or False, not {type(reduce).__name__}")
    return Linearization(**self._linearize(state, u, bool(modes), q, z, bool(reduce)))


def _equilibrium(
    self: Model,
    free: Union[None, str, Sequence[Union[str, int]]] = None,
    u: Optional[Sequence[float]] = None,
    state: Optional[State] = None,
    tolerance: float = 1e-10,
    max_iterations: int = 50,
    *,
    q: Optional[Sequence[float]] = None,
) -> Equilibrium:
    """Static equilibrium: the joint coordinates at which the model rests (z = 0) with the
    inputs held at u (None: all 0), by Newton's method with the analytic Jacobian from a state's
    q (default: the initial state; or q=; the state's speeds are not used).

    free: None (every coordinate) or a list of body names (all of the body's coordinates),
    coordinate names of Model.tangent_state_names (e.g. "arm.j1", "torso.r2") and indices
    0..n-1; the others keep their values, held by reactions the result does not report.
    tolerance: on the largest generalized force, relative to the force scale (the largest at
    the start, at least 1); a finite number > 0. max_iterations: 1..10000, as the tool's
    --max-iterations.

    Newton that does not converge does not raise: the result has converged False, the last
    iterate, the residual, a message, and the coordinates nothing restrains (what to fix or
    leave out of free). Check result.converged (or bool(result))."""
    d = self._equilibrium(free, u, state, tolerance, max_iterations, q)
    lin = d.pop("linearization")
    return Equilibrium(**d, linearization=None if lin is None else Linearization(**lin))


Model.linearize = _linearize  # type: ignore[attr-defined]
Model.equilibrium = _equilibrium  # type: ignore[attr-defined]
