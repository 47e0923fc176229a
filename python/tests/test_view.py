"""Result.view() writes the page `kanedyn view` writes, from the same rows, by the same code."""

from __future__ import annotations

import json

import pytest

import kanedyn
from conftest import EXAMPLES, run_tool


def test_the_page_of_a_streamed_run_is_the_tools(tmp_path) -> None:
    path = EXAMPLES / "eight_body.yaml"
    m = kanedyn.load(path)
    r = m.simulate(t_end=2, output=tmp_path / "run.csv")
    assert r.view(tmp_path / "py.html") == str(tmp_path / "py.html")
    done = run_tool(["view", path, tmp_path / "run.csv", "-o", tmp_path / "tool.html"])
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "py.html").read_bytes() == (tmp_path / "tool.html").read_bytes()
    assert not list(tmp_path.glob("*.partial"))


def test_a_run_in_memory_and_the_default_name(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    m = kanedyn.load(EXAMPLES / "eight_body.yaml")
    r = m.simulate(t_end=0.5)
    assert r.view() == "eight_body.html"
    text = (tmp_path / "eight_body.html").read_text()
    assert "simulate() from Python" in text and m.name in text
    streamed = m.simulate(t_end=0.5, output=tmp_path / "sub.csv")
    assert streamed.view() == "sub.html" and (tmp_path / "sub.html").exists()


def test_a_model_not_from_a_file_needs_a_path(tmp_path) -> None:
    m = kanedyn.load(json.loads((EXAMPLES / "eight_body.json").read_text()))
    r = m.simulate(t_end=0.1)
    with pytest.raises(TypeError, match="needs a path"):
        r.view()
    r.view(tmp_path / "dict.html")
    assert (tmp_path / "dict.html").stat().st_size > 100_000
    with pytest.raises(RuntimeError, match="folder"):
        r.view(tmp_path / "no" / "such.html")


def test_a_jointed_model_s_page_has_its_joints_as_the_tool_s(tmp_path) -> None:
    path = EXAMPLES / "cart_pendulum.yaml"
    m = kanedyn.load(path)
    r = m.simulate(t_end=0.5, output=tmp_path / "cart.csv")
    r.view(tmp_path / "py.html")
    done = run_tool(["view", path, tmp_path / "cart.csv", "-o", tmp_path / "tool.html"])
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "py.html").read_bytes() == (tmp_path / "tool.html").read_bytes()
    text = (tmp_path / "py.html").read_text()
    assert '"joint_type":"prismatic"' in text and '"joint_type":"revolute"' in text
