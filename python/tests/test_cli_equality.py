"""The module computes what the tool prints and writes, bit for bit: eom --json, inspect --json
and the trajectory CSV of simulate (the same library calls on the same settings)."""

from __future__ import annotations

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES, MODELS, run_tool, tool_json


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal as doubles, bit for bit (so -0.0 differs from 0.0 and nan would be compared)."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    b = np.ascontiguousarray(b, dtype=np.float64)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("name", MODELS)
def test_eom_equals_the_tools_json(name: str) -> None:
    m = kanedyn.load(EXAMPLES / name)
    printed = tool_json(["eom", EXAMPLES / name, "--json"])
    e = m.eom(m.initial_state())
    assert printed["N"] == m.N == e.N
    assert printed["L"] == m.L.tolist()
    assert printed["u"] == m.u.tolist()
    for key in ("A", "f", "ydot", "xdot"):
        assert same_bits(np.array(printed[key]), getattr(e, key)), key
    assert e.A.flags["C_CONTIGUOUS"] and e.A.dtype == np.float64


@pytest.mark.parametrize("name", ["eight_body.yaml", "chain64.yaml", "satellite.yaml"])
def test_inspect_equals_the_tools_json(name: str) -> None:
    m = kanedyn.load(EXAMPLES / name)
    printed = tool_json(["inspect", EXAMPLES / name, "--json"])
    q = m.inspect()
    assert printed["N"] == q.N and printed["t"] == q.t == 0.0
    for key in ("F_y", "F_y_star", "ydot"):
        assert same_bits(np.array(printed[key]), getattr(q, key)), key
    assert len(printed["bodies"]) == len(q.bodies) == m.N
    for want, got in zip(printed["bodies"], q.bodies):
        assert (want["K"], want["name"], want["L"], want["u"], want["chain"]) == (got.K, got.name, got.L, got.u, got.chain)
        for key, value in want.items():
            if key in ("K", "name", "L", "u", "chain"):
                continue
            assert same_bits(np.array(value), getattr(got, key)), (got.name, key)


def test_inspect_selects_bodies_like_the_tools_body_option() -> None:
    path = EXAMPLES / "eight_body.yaml"
    m = kanedyn.load(path)
    printed = tool_json(["inspect", path, "--json", "--body", "8", "--body", "pelvis"])
    q = m.inspect(bodies=[8, "pelvis"])
    assert [b["K"] for b in printed["bodies"]] == [b.K for b in q.bodies] == [2, 8]
    assert same_bits(np.array(printed["bodies"][1]["v_G_y_dot"]), q[8].v_G_y_dot)
    assert q["pelvis"] is not None and q[2].name == "pelvis"


SETTINGS = [
    ([], {}),
    (["--integrator", "rk4", "--step", "0.002", "--t-end", "1"], {"integrator": "rk4", "step": 0.002, "t_end": 1}),
    (["--route", "assembled", "--t-end", "0.5", "--dt-out", "0.05", "--rtol", "1e-6"], {"route": "assembled", "t_end": 0.5, "dt_out": 0.05, "rtol": 1e-6}),
]


@pytest.mark.parametrize("flags,kwargs", SETTINGS)
def test_simulate_equals_the_tools_csv(tmp_path, flags, kwargs) -> None:
    path = EXAMPLES / "eight_body.yaml"
    done = run_tool(["simulate", path, "-o", tmp_path / "tool.csv", *flags])
    assert done.returncode == 0, done.stderr
    tool_bytes = (tmp_path / "tool.csv").read_bytes()
    m = kanedyn.load(path)
    r = m.simulate(output=tmp_path / "streamed.csv", **kwargs)
    assert (tmp_path / "streamed.csv").read_bytes() == tool_bytes
    r.to_csv(tmp_path / "written.csv")
    assert (tmp_path / "written.csv").read_bytes() == tool_bytes
    # The arrays themselves: the CSV's shortest round-trip decimals read back to them.
    back = kanedyn.read_csv(m, tmp_path / "tool.csv")
    for key in ("t", "x", "y", "p_G", "energy"):
        assert same_bits(getattr(back, key), getattr(r, key)), key
    assert same_bits(back.table(), r.table())
    assert r.stats["status"] == "completed" and r.stats["outputs"] == len(r)


def test_simulate_takes_the_model_files_settings(tmp_path) -> None:
    text = (EXAMPLES / "eight_body.yaml").read_text()
    text = text[: text.index("\nsimulation:")] + "\nsimulation:\n  t_end: 0.3\n  dt_out: 0.1\n  integrator: rk4\n"
    (tmp_path / "m.yaml").write_text(text)
    done = run_tool(["simulate", tmp_path / "m.yaml", "-o", tmp_path / "tool.csv"])
    assert done.returncode == 0, done.stderr
    m = kanedyn.load(tmp_path / "m.yaml")
    assert m.simulation == {"t_end": 0.3, "dt_out": 0.1, "integrator": "rk4"}
    r = m.simulate()
    assert r.t.tolist() == [0.0, 0.1, 0.2, 0.3]
    r.to_csv(tmp_path / "py.csv")
    assert (tmp_path / "py.csv").read_bytes() == (tmp_path / "tool.csv").read_bytes()
