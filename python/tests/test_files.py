"""The file rules of the tool hold for the Python front end too (docs/cli.md, "Files"): an output
is a regular file or nothing and never an input (the model file, the trajectory), and a reader
refuses what is not a regular file at once. Device nodes are made in a temporary folder (as
root; otherwise those cases are skipped), never under /dev."""

from __future__ import annotations

import os
import pathlib
import shutil
import stat

import pytest

import kanedyn
from conftest import EXAMPLES


def make_null(path: pathlib.Path) -> bool:
    """A character device like /dev/null at path; False when this process may not make one."""
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    except PermissionError:
        return False
    return True


@pytest.fixture
def model_copy(tmp_path: pathlib.Path) -> kanedyn.Model:
    shutil.copy(EXAMPLES / "eight_body.yaml", tmp_path / "m.yaml")
    return kanedyn.load(tmp_path / "m.yaml")


def test_outputs_onto_a_fifo_or_a_device_are_refused_and_left_as_they_were(
    model_copy: kanedyn.Model, tmp_path: pathlib.Path
) -> None:
    targets = [tmp_path / "fifo"]
    os.mkfifo(targets[0])
    if make_null(tmp_path / "null"):
        targets.append(tmp_path / "null")
    result = model_copy.simulate(t_end=0.05)
    for target in targets:
        kind = stat.S_IFMT(os.lstat(target).st_mode)
        writes = {
            "simulate(output=)": lambda: model_copy.simulate(t_end=0.05, output=target),
            "to_csv": lambda: result.to_csv(target),
            "view": lambda: result.view(target),
        }
        for name, write in writes.items():
            with pytest.raises(RuntimeError, match=f"output '{target}' is a"):
                write()
            assert stat.S_IFMT(os.lstat(target).st_mode) == kind, f"{name} replaced {target}"
            assert not os.path.exists(f"{target}.partial"), name


def test_no_output_is_the_model_file_or_the_trajectory(
    model_copy: kanedyn.Model, tmp_path: pathlib.Path
) -> None:
    model_path = tmp_path / "m.yaml"
    text = model_path.read_text()
    result = model_copy.simulate(t_end=0.05, output=tmp_path / "run.csv")
    csv = (tmp_path / "run.csv").read_text()
    for name, write in {
        "to_csv onto the model": lambda: result.to_csv(model_path),
        "view onto the model": lambda: result.view(model_path),
        "view onto the model, by another name": lambda: result.view(tmp_path / "." / "m.yaml"),
        "view onto the trajectory": lambda: result.view(tmp_path / "run.csv"),
        "simulate onto the model": lambda: model_copy.simulate(t_end=0.05, output=model_path),
    }.items():
        with pytest.raises(RuntimeError, match="is the input file"):
            write()
        assert model_path.read_text() == text, name
        assert (tmp_path / "run.csv").read_text() == csv, name


def test_a_reader_refuses_a_fifo_at_once(model_copy: kanedyn.Model, tmp_path: pathlib.Path) -> None:
    fifo = tmp_path / "run.csv"
    os.mkfifo(fifo)
    # A blocking open would wait here for a writer that never comes.
    with pytest.raises(ValueError, match="is a FIFO"):
        kanedyn.Result.read_csv(model_copy, fifo)
    with pytest.raises(kanedyn.ModelError, match="is a FIFO"):
        kanedyn.load(fifo)
