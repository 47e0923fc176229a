"""Studies (docs/studies.md): one model run many times, some of its numbers changed by grids and
random draws, the results gathered into one table.

    import kanedyn
    study = kanedyn.Study("examples/studies/eight_body_stiffness.yaml")
    table = study.run(out="stiffness")               # this machine's cores
    table = study.run(out="stiffness", client=dask_client)   # a dask.distributed cluster
    kanedyn.Study("s.yaml", function=f, outputs=["a"])        # f(model, run) -> {"a": 1.0}

Either way the folder `out` is written by the caller, by the rules `kanedyn sweep` follows, and
results.csv is the same file, byte for byte but for the wall_s column.
"""

from __future__ import annotations

import csv
import inspect
import io
import json
import math
import operator
import os
import sys
import time
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from ._kanedyn import _read_table_text, _Study, _StudyFolder

__all__ = ["Study", "read_results"]

# What a worker is sent: the study's text, its name in messages, the model file's text (so
# that it reads no file: it may be another machine), and the names of the function's outputs.
_Payload = Tuple[str, str, str, Tuple[str, ...]]

# Each worker process parses a study once and keeps it for the chunks that follow.
_worker_studies: Dict[_Payload, _Study] = {}


class _Caller:
    """The study's function as the runs call it: with the run's kanedyn.Model (and the run's
    index, when the function takes two arguments), its dict checked against the outputs'
    names. Gives the values in the names' order, or, when the function raises an Exception
    or gives something else than those names' numbers, the message that is the run's status.
    Pickled to dask's workers with the function."""

    def __init__(self, function: Callable[..., Mapping[str, float]], names: Sequence[str], with_run: bool):
        self.function = function
        self.names = tuple(names)
        self.with_run = with_run

    def __call__(self, model: Any, run: int) -> Union[List[float], str]:
        try:
            result = self.function(model, run) if self.with_run else self.function(model)
        except Exception as e:  # noqa: BLE001 (an exception of the function fails its run)
            return _message(e)
        if not isinstance(result, Mapping):
            return f"gave {type(result).__name__}, not a dict of its outputs ({', '.join(self.names)})"
        if set(result) != set(self.names):
            missing = [n for n in self.names if n not in result]
            extra = sorted(repr(k) for k in result if k not in self.names)
            what = []
            if missing:
                what.append("no " + ", ".join(repr(n) for n in missing))
            if extra:
                what.append("unknown " + ", ".join(extra))
            return f"gave {' and '.join(what)}; its outputs are {', '.join(self.names)}"
        values = []
        for name in self.names:
            v = result[name]
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
                return f"gave {type(v).__name__} for {name!r}, not a number"
            values.append(float(v))
        return values


def _message(e: BaseException) -> str:
    """An exception as a run's status shows it: its type and message on one line."""
    text = " ".join(str(e).split())
    return f"{type(e).__name__}: {text}" if text else type(e).__name__


def _takes_run(function: Callable[..., Any]) -> bool:
    """Whether the function takes the run's index after the model: whether two positional
    arguments bind to it (else it must take one)."""
    try:
        signature = inspect.signature(function)
    except (TypeError, ValueError):  # a builtin without a signature: given both
        return True
    for count in (2, 1):
        try:
            signature.bind(*range(count))
            return count == 2
        except TypeError:
            continue
    raise TypeError("function must take the run's model, or the model and the run's index")


def _run_chunk(
    payload: _Payload, runs: Sequence[int], caller: Optional[_Caller] = None
) -> List[Tuple[int, str, Optional[str], str]]:
    """Runs a chunk of runs on a worker: (run, row, trajectory or None, status) for each."""
    study = _worker_studies.get(payload)
    if study is None:
        text, name, model_text, names = payload
        study = _Study.parse(text, name, "", model_text)
        if names:
            study.set_function_outputs(list(names))
        if len(_worker_studies) > 8:
            _worker_studies.clear()
        _worker_studies[payload] = study
    return study.run_chunk(list(runs), caller)


def _integer(value: Any, name: str, lo: int, hi: int) -> int:
    """An int (or a numpy integer), not a bool, in lo..hi: TypeError or ValueError naming the
    argument and the range otherwise, as the module's own integer arguments are checked."""
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be an integer, got a bool")
    try:
        number = operator.index(value)
    except TypeError:
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}") from None
    if not lo <= number <= hi:
        shown = str(number) if number.bit_length() < 128 else f"of {number.bit_length()} bits"
        raise ValueError(f"{name} {shown} is not in {lo}..{hi}")
    return number


# The most threads run() starts: the tool's `sweep --jobs` range (0: one per core).
_MAX_THREADS = 4096


def _table_rows(path: Any) -> Tuple[str, List[Tuple[int, List[str]]]]:
    """The file's name and its CSV rows with their line numbers, read by the rule of every
    reader of the module: a regular file only (a FIFO or a device is refused, not waited on)."""
    text = _read_table_text(path)
    name = os.fsdecode(os.fspath(path))
    reader = csv.reader(io.StringIO(text, newline=""))
    rows = []
    try:
        for row in reader:
            if row:
                rows.append((reader.line_num, row))
    except csv.Error as e:
        raise ValueError(f"{name}:{reader.line_num}: not CSV: {e}") from None
    return name, rows


def read_results(path: Union[str, bytes, os.PathLike]) -> Any:
    """A results.csv as a numpy structured array: `run` (int64), the varied keys and the
    outputs (float64; nan where a failed run has none), `status` (str) and `wall_s` (float64).
    A pandas DataFrame of the same columns when pandas is installed. A path that is not a
    regular file, or a file that is not a results table, raises ValueError naming the file
    (and the line)."""
    name, rows = _table_rows(path)
    what = "a results table (run, the varied keys and outputs, status, wall_s)"
    if not rows:
        raise ValueError(f"{name}: the file is empty, not {what}")
    (_, header), body = rows[0], rows[1:]
    if len(header) < 3 or header[0] != "run" or header[-2:] != ["status", "wall_s"]:
        shown = ",".join(header)
        shown = shown if len(shown) <= 80 else shown[:77] + "..."
        raise ValueError(f"{name}:1: the header {shown!r} is not that of {what}")
    numeric = header[1:-2]

    def number(line: int, column: str, text: str) -> float:
        try:
            return float(text) if text != "" or column == "wall_s" else math.nan
        except ValueError:
            raise ValueError(f"{name}:{line}: column {column!r}: {text[:40]!r} is not a number") from None

    values = []
    for line, r in body:
        if len(r) != len(header):
            raise ValueError(f"{name}:{line}: the row has {len(r)} fields, the header {len(header)}")
        try:
            run = int(r[0])
        except ValueError:
            run = -1
        if not 0 <= run < 2**63:
            raise ValueError(f"{name}:{line}: column 'run': {r[0][:40]!r} is not a run number")
        values.append(
            (run, *[number(line, c, v) for c, v in zip(numeric, r[1:-2])], r[-2], number(line, "wall_s", r[-1]))
        )
    status_width = max([len(v[-2]) for v in values] + [2])
    dtype = (
        [("run", np.int64)]
        + [(column, np.float64) for column in numeric]
        + [("status", f"U{status_width}"), ("wall_s", np.float64)]
    )
    table = np.empty(len(values), dtype=dtype)
    for i, v in enumerate(values):
        table[i] = v
    try:
        import pandas  # noqa: PLC0415 (optional)
    except ImportError:
        return table
    return pandas.DataFrame({name: table[name] for name in table.dtype.names})


class Study:
    """A study file (YAML or JSON, docs/studies.md) or a dict of the same structure, checked
    at once: a refusal raises kanedyn.ModelError with the tool's one-line message. A dict's
    `model` is relative to the current folder, a file's to the file's folder.

    With `function`, each run also calls function(model, run) (or function(model)) with the
    run's kanedyn.Model (the model file with the run's numbers) and its index; it returns a
    dict of the numbers named by `outputs`, which become columns after the file's outputs. An
    exception it raises fails that run (its status "function: TYPE: message") and the study
    goes on. A run simulates only when the file's outputs read a trajectory."""

    def __init__(
        self,
        source: Union[str, bytes, os.PathLike, Mapping[str, Any]],
        function: Optional[Callable[..., Mapping[str, float]]] = None,
        outputs: Optional[Sequence[str]] = None,
    ):
        self._caller: Optional[_Caller] = None
        if function is not None or outputs is not None:
            if function is None or not callable(function):
                raise TypeError("function must be a callable(model, run) returning a dict of its outputs")
            if outputs is None or isinstance(outputs, (str, bytes)) or not all(isinstance(n, str) for n in outputs):
                raise TypeError("outputs must be a list of the function's output names (str)")
            if not outputs:
                raise ValueError("outputs must name at least one output of the function")
            self._caller = _Caller(function, list(outputs), _takes_run(function))
        if isinstance(source, Mapping):
            # The model's path, as every path the module takes: a NUL byte would end it there
            # and read another file.
            model = source.get("model")
            if isinstance(model, str) and "\x00" in model:
                raise ValueError("embedded null byte")
            text = json.dumps(source, allow_nan=False)
            self._core = _Study.parse(text, "<dict>", "", None)
        elif isinstance(source, (str, bytes, os.PathLike)):
            self._core = _Study.load(source)
        else:
            raise TypeError(f"Study() takes a path or a dict, not {type(source).__name__}")
        if self._caller is not None:
            self._core.set_function_outputs(list(self._caller.names))

    @property
    def runs(self) -> int:
        """The number of runs: the grids' product times `runs`."""
        return self._core.runs

    @property
    def columns(self) -> List[str]:
        """The columns of results.csv."""
        return list(self._core.columns)

    def parameters(self, run: int) -> List[float]:
        """Run `run`'s value of each varied key, in the order of `vary`."""
        return list(self._core.parameters(run))

    def run(
        self,
        out: Union[str, bytes, os.PathLike],
        client: Any = None,
        *,
        threads: int = 0,
        chunk_size: Optional[int] = None,
        progress: bool = False,
    ) -> Any:
        """Runs the runs not yet done in the folder `out` (created; its parent must exist) and
        returns the results table (read_results). Without a client, on `threads` threads of
        this process (0: all cores), as `kanedyn sweep`. With a dask.distributed Client, in
        chunks of `chunk_size` runs on its workers (default: about eight chunks per worker
        thread, at most 256 runs each); each worker parses the study and the model once from
        their texts, sent with its first chunk. A lost worker's chunks are run again by dask.
        The caller writes the folder as chunks come back. Ctrl-C stops, keeping every finished
        run (KeyboardInterrupt); run() again with the same folder does only the missing runs.
        threads is 0..4096 and chunk_size at least 1 (ValueError otherwise); everything is
        checked before the folder is created."""
        threads = _integer(threads, "threads", 0, _MAX_THREADS)
        if chunk_size is not None:
            chunk_size = _integer(chunk_size, "chunk_size", 1, 2**31 - 1)
        if client is not None and not (hasattr(client, "submit") and hasattr(client, "nthreads")):
            raise TypeError(f"client must be a dask.distributed Client or None, got {type(client).__name__}")
        if not isinstance(progress, (bool, np.bool_)):
            raise TypeError(f"progress must be True or False, got {type(progress).__name__}")
        folder = _StudyFolder(self._core, out)
        if client is None:
            self._run_here(folder, threads, progress)
        else:
            self._run_dask(folder, client, chunk_size, progress)
        return read_results(folder.results_path)

    def _run_here(self, folder: _StudyFolder, threads: int, progress: bool) -> None:
        bar = _Bar(folder.total) if progress else None
        _ran, stopped, interrupted = folder.sweep(threads, bar.update if bar else None, self._caller)
        if bar:
            bar.close()
        if stopped:
            _stopped(folder, interrupted)

    def _run_dask(self, folder: _StudyFolder, client: Any, chunk_size: Optional[int], progress: bool) -> None:
        from distributed import as_completed  # noqa: PLC0415 (only for this path)

        total = folder.total
        first = folder.next_missing(0)
        if first < total:
            if chunk_size is None:
                threads = sum(client.nthreads().values()) or 1
                left = total - folder.done
                chunk_size = max(1, min(256, math.ceil(left / (8 * threads))))
                in_flight = 4 * threads
            else:
                in_flight = 4 * (sum(client.nthreads().values()) or 1)
            core = self._core
            payload: _Payload = (core.text, core.path, core.model_text, tuple(core.function_outputs))
            cursor = first

            def next_chunk() -> List[int]:
                # The missing runs walked a chunk at a time: nothing is held per run of the
                # study, however many it has.
                nonlocal cursor
                chunk: List[int] = []
                while cursor < total and len(chunk) < chunk_size:
                    chunk.append(cursor)
                    cursor = folder.next_missing(cursor + 1)
                return chunk

            # The texts go with every chunk (a few kB): a worker that joins or restarts needs
            # nothing from the others. At most `in_flight` chunks wait on the cluster at once,
            # so the caller's memory does not grow with the study either.
            running = set()
            for _ in range(in_flight):
                chunk = next_chunk()
                if not chunk:
                    break
                running.add(client.submit(_run_chunk, payload, chunk, self._caller, pure=False))
            waiting = as_completed(list(running))
            bar = _Bar(folder.total) if progress else None
            pending: List[Tuple[int, str, Optional[str], str]] = []
            last = time.monotonic()
            try:
                for future in waiting:
                    pending.extend(future.result())
                    running.discard(future)
                    future.release()
                    chunk = next_chunk()
                    if chunk:
                        submitted = client.submit(_run_chunk, payload, chunk, self._caller, pure=False)
                        running.add(submitted)
                        waiting.add(submitted)
                    if time.monotonic() - last >= 1.0:
                        folder.record(pending)
                        pending = []
                        last = time.monotonic()
                    if bar:
                        bar.update(folder.done + len(pending), 0)
                folder.record(pending)
            except KeyboardInterrupt:
                folder.record(pending)
                client.cancel(list(running))
                _stopped(folder, True)
            finally:
                if bar:
                    bar.close()
        folder.write_results()


def _stopped(folder: _StudyFolder, interrupted: bool) -> None:
    message = (
        f"stopped: {folder.done} of {folder.total} runs are kept; run() again with the same "
        "folder runs only the missing ones"
    )
    if interrupted:
        raise KeyboardInterrupt(message)
    raise RuntimeError(message)


class _Bar:
    """Runs done, the rate and the time left, on stderr."""

    def __init__(self, total: int):
        self.total = total
        self.start = time.monotonic()
        self.first: Optional[int] = None

    def update(self, done: int, _ran: int) -> None:
        if self.first is None:
            self.first = done
        elapsed = time.monotonic() - self.start
        rate = (done - self.first) / elapsed if elapsed > 0 else 0.0
        left = f"{(self.total - done) / rate:.0f} s" if rate > 0 else "?"
        sys.stderr.write(f"\r{done}/{self.total} runs  {rate:.1f} runs/s  left ~{left} \033[K")
        sys.stderr.flush()

    def close(self) -> None:
        sys.stderr.write("\r\033[K")
        sys.stderr.flush()
