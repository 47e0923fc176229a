"""Fixtures of the Python suite: the tool beside the module, the examples, a scratch folder."""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
from typing import Any, List

import pytest

import kanedyn

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
MODELS = ["eight_body.yaml", "chain64.yaml", "satellite.yaml", "tennis_racket.yaml", "double_pendulum.yaml"]


def tool() -> str:
    """The kanedyn tool of the same build: KANEDYN_TOOL (ctest sets it), else the one in a package
    installed by pip (kanedyn/bin/kanedyn), else build/kanedyn."""
    shipped = pathlib.Path(kanedyn.__file__).resolve().parent / "bin" / "kanedyn"
    path = os.environ.get("KANEDYN_TOOL", str(shipped if shipped.is_file() else ROOT / "build" / "kanedyn"))
    if not os.access(path, os.X_OK):
        pytest.fail(f"the kanedyn tool is not at {path}: build it, or set KANEDYN_TOOL")
    return path


def run_tool(args: List[Any], cwd: Any = None) -> subprocess.CompletedProcess:
    return subprocess.run([tool(), *map(str, args)], capture_output=True, text=True, cwd=cwd, check=False)


def tool_json(args: List[Any]) -> Any:
    done = run_tool(args)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.fixture
def eight() -> kanedyn.Model:
    return kanedyn.load(EXAMPLES / "eight_body.yaml")
