"""Every way a Python caller can get the arguments wrong gives an exception that names the
argument and what was expected; none crashes the interpreter."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES, run_tool


def test_model_file_errors_carry_the_tools_message(tmp_path) -> None:
    text = (EXAMPLES / "eight_body.yaml").read_text().replace("mass: 30.0", "mass: -1", 1)
    assert "mass: -1" in text
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    tool_line = run_tool(["info", path]).stderr.strip()
    assert tool_line.startswith("kanedyn: error: ")
    with pytest.raises(kanedyn.ModelError) as caught:
        kanedyn.load(path)
    e = caught.value
    assert str(e) == tool_line[len("kanedyn: error: ") :]
    assert e.file == str(path) and e.line > 0 and e.column > 0
    assert e.key_path.endswith(".mass") and "> 0" in e.problem
    assert isinstance(e, ValueError)
    with pytest.raises(kanedyn.ModelError) as from_text:
        kanedyn.loads(text, name="given.yaml")
    assert str(from_text.value) == str(e).replace(str(path), "given.yaml")


def test_missing_file_and_bad_sources() -> None:
    with pytest.raises(kanedyn.ModelError, match="no_such.yaml"):
        kanedyn.load("no_such.yaml")
    with pytest.raises(TypeError, match="path or a dict"):
        kanedyn.load(42)
    with pytest.raises(TypeError, match="str or a dict"):
        kanedyn.loads(b"format: x")
    with pytest.raises(kanedyn.ModelError, match="format"):
        kanedyn.loads("just: text")


def test_a_dict_model_and_its_errors() -> None:
    d = {
        "format": "kanedyn-model/1",
        "bodies": [{"name": "b", "parent": "ground", "mass": np.float64(2.0), "inertia": np.array([1.0, 2.0, 2.5]), "com": [0, 0, 0]}],
    }
    m = kanedyn.load(d)
    assert m.N == 1 and m.path == "<dict>" and m.total_mass == 2.0
    assert np.array_equal(m.inertia[0], np.diag([1.0, 2.0, 2.5]))
    d["bodies"][0]["mass"] = 0
    with pytest.raises(kanedyn.ModelError, match=r"bodies\[0\]\.mass"):
        kanedyn.load(d)
    d["bodies"][0]["mass"] = float("nan")
    with pytest.raises(kanedyn.ModelError, match="<dict>"):
        kanedyn.load(d)
    d["bodies"][0]["mass"] = object()
    with pytest.raises(TypeError, match="numbers, strings"):
        kanedyn.load(d)


def test_wrong_shapes_dtypes_and_values(eight) -> None:
    s = eight.initial_state()
    x, y = s.x.copy(), s.y.copy()
    with pytest.raises(ValueError, match=r"x must have shape \(7N,\) = \(56,\) for N = 8, got \(55,\)"):
        eight.derivatives(x[:55], y)
    with pytest.raises(ValueError, match=r"y must have shape .*\(48,\).*got \(1, 48\)"):
        eight.derivatives(x, y[None, :])
    with pytest.raises(TypeError, match=r"x must be a float64 array, got dtype int64.*astype"):
        eight.derivatives(x.astype(np.int64), y)
    with pytest.raises(TypeError, match="float32"):
        eight.derivatives(x, y.astype(np.float32))
    with pytest.raises(TypeError, match="complex128"):
        eight.derivatives(x.astype(complex), y)
    with pytest.raises(TypeError, match=r"x must be a float64 array .*NoneType"):
        eight.derivatives(None, y)
    with pytest.raises(TypeError, match="str"):
        eight.derivatives("x" * 56, y)
    with pytest.raises(TypeError, match="numpy cannot convert"):
        eight.derivatives([object()] * 56, y)
    with pytest.raises(ValueError, match="0-d|shape"):
        eight.derivatives(np.float64(1.0), y)
    bad = x.copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match=r"x\[3\] is nan \(body 'torso' \(e4\)"):
        eight.derivatives(bad, y)
    bad_y = y.copy()
    bad_y[30] = np.inf
    with pytest.raises(ValueError, match=r"y\[30\] is inf \(body '.*' \(sd"):
        eight.derivatives(x, bad_y)
    zero = x.copy()
    zero[4:8] = 0.0
    with pytest.raises(ValueError, match=r"Euler parameters of body 'pelvis' \(x\[4:8\]\) have norm 0"):
        eight.derivatives(zero, y)
    with pytest.raises(ValueError, match="t must be finite"):
        eight.derivatives(x, y, t=float("nan"))


def test_derivatives_arguments(eight) -> None:
    s = eight.initial_state()
    x, y = s.x, s.y
    want = eight.derivatives(x, y)[1].tobytes()
    assert eight.derivatives(x=x, y=y, t=2.0)[1].tobytes() == want
    assert eight.derivatives(x, y, 1)[1].tobytes() == want  # t does not enter the equations
    with pytest.raises(TypeError, match="needs x and y"):
        eight.derivatives(x)
    with pytest.raises(TypeError, match="unexpected keyword argument 'z'"):
        eight.derivatives(x, y, z=1)
    with pytest.raises(TypeError, match="multiple values for argument 'x'"):
        eight.derivatives(x, y, x=x)
    with pytest.raises(TypeError, match="takes x, y, t and u"):
        eight.derivatives(x, y, 0.0, None, 1)
    with pytest.raises(ValueError, match=r"u must have shape \(m,\) = \(0,\)"):
        eight.derivatives(x, y, 0.0, 1)  # the model has no inputs
    with pytest.raises(TypeError, match="t must be a number"):
        eight.derivatives(x, y, t="now")
    with pytest.raises(TypeError, match="doesn't apply"):
        kanedyn.Model.derivatives(s, x, y)


def test_batch_errors_name_the_row(eight) -> None:
    s = eight.initial_state()
    X = np.tile(s.x, (10, 1))
    Y = np.tile(s.y, (10, 1))
    with pytest.raises(ValueError, match=r"Y must have shape \(M, 6N\) = \(10, 48\)"):
        eight.derivatives_batch(X, Y[:9])
    with pytest.raises(ValueError, match=r"X must have shape \(M, 7N\)"):
        eight.derivatives_batch(X[0], Y)
    X[7, 60 % 56] = np.nan
    X[3, 0] = np.nan
    with pytest.raises(ValueError, match=r"X\[3\]\[0\] is nan"):
        eight.derivatives_batch(X, Y, threads=2)
    with pytest.raises(ValueError, match="threads must be >= 0"):
        eight.derivatives_batch(X, Y, threads=-1)


def test_state_arguments(eight) -> None:
    other = kanedyn.load(EXAMPLES / "double_pendulum.yaml")
    with pytest.raises(ValueError, match="state is of 2 bodies; the model has N = 8"):
        eight.eom(other.initial_state())
    with pytest.raises(TypeError, match="kanedyn.State"):
        eight.eom((1, 2))
    s = eight.initial_state()
    s.x[0:4] = [0, 0, 0, 2]
    with pytest.raises(ValueError, match=r"state.x: the Euler parameters of body 'torso'.*norm 2"):
        eight.inspect(s)
    with pytest.raises(ValueError, match=r"x must have shape \(7N,\) for some N >= 1"):
        kanedyn.State(np.zeros(8), np.zeros(6))
    with pytest.raises(ValueError, match=r"y must have shape \(6N,\) = \(6,\)"):
        kanedyn.State(np.zeros(7), np.zeros(7))
    with pytest.raises(ValueError, match=r"x must have shape \(56,\)"):
        s.x = np.zeros(3)


def test_inspect_body_selection_errors(eight) -> None:
    with pytest.raises(ValueError, match=r"body number 9 is not in 1..8"):
        eight.inspect(bodies=[9])
    with pytest.raises(ValueError, match=r"no body named 'torsoo' \(did you mean 'torso'\?\)"):
        eight.inspect(bodies="torsoo")
    with pytest.raises(TypeError, match="bool"):
        eight.inspect(bodies=[True])
    with pytest.raises(KeyError):
        eight.inspect(bodies=[1])[2]
    with pytest.raises(ValueError, match="point must be 'O' or 'G'"):
        eight.symbolic_partial(8, point="Q")


def test_simulate_settings_errors(eight, tmp_path) -> None:
    with pytest.raises(ValueError, match="t_end must be a finite number > 0"):
        eight.simulate(t_end=-1)
    with pytest.raises(ValueError, match="dt_out must be a finite number > 0"):
        eight.simulate(dt_out=float("inf"))
    with pytest.raises(ValueError, match="integrator"):
        eight.simulate(integrator="euler")
    with pytest.raises(ValueError, match="route"):
        eight.simulate(route="fast")
    with pytest.raises(ValueError, match="not both"):
        eight.simulate(route="assembled", method="kane")
    with pytest.raises(TypeError, match="t_end must be a number, got str"):
        eight.simulate(t_end="ten")
    assert len(eight.simulate(t_end=np.int64(1), dt_out=np.float32(0.5))) == 3
    with pytest.raises(TypeError, match="progress must be"):
        eight.simulate(t_end=0.01, progress="yes")
    with pytest.raises(RuntimeError, match="folder"):
        eight.simulate(t_end=0.01, output=tmp_path / "no" / "such" / "run.csv")
    assert not any(tmp_path.iterdir())
    with pytest.raises(KeyError, match=r"no column 'torso.w4' \(did you mean 'torso.w"):
        eight.simulate(t_end=0.01)["torso.w4"]


def test_read_csv_refuses_what_the_tool_refuses(eight, tmp_path) -> None:
    chain = kanedyn.load(EXAMPLES / "chain64.yaml")
    path = tmp_path / "run.csv"
    eight.simulate(t_end=0.02, output=path)
    with pytest.raises(ValueError, match=r"run.csv:1: column 2 is 'torso.x'"):
        kanedyn.read_csv(chain, path)
    lines = path.read_text().splitlines()
    (tmp_path / "bad.csv").write_text("\n".join(lines[:2] + [lines[2].replace(",", ",x", 1)]) + "\n")
    with pytest.raises(ValueError, match=r"bad.csv:3: "):
        kanedyn.read_csv(eight, tmp_path / "bad.csv")
    (tmp_path / "back.csv").write_text("\n".join([lines[0], lines[2], lines[1]]) + "\n")
    with pytest.raises(ValueError, match=r"back.csv:3: t = 0 is before the previous row's"):
        kanedyn.read_csv(eight, tmp_path / "back.csv")
    assert len(kanedyn.read_csv(eight, path)) == 3


def test_hostile_inputs_do_not_crash_the_interpreter() -> None:
    """Each call in a fresh interpreter: an exception is fine, a crash (signal) is not."""
    calls = [
        "m.derivatives(np.empty((0,)), np.empty((0,)))",
        "m.derivatives(np.zeros((56, 1)), np.zeros(48))",
        "m.derivatives(np.zeros(56)[::-1], np.full(48, 1e308))",
        "m.derivatives_batch(np.zeros((3, 56, 1)), np.zeros((3, 48)))",
        "m.derivatives_batch(np.broadcast_to(m.initial_state().x, (1000, 56)), np.zeros((1000, 48)))",
        "m.derivatives(np.ma.masked_array(np.zeros(56)), np.zeros(48))",
        "kanedyn.State(np.zeros(10**6 * 7), np.zeros(10**6 * 6)).x[-1]",
        "m.inspect(bodies=list(range(-5, 5)))",
        "m.inspect(bodies=[10**30])",
        "m.eom(kanedyn.State(np.array([0.0] * 7), np.zeros(6)))",
        "kanedyn.loads('format: kanedyn-model/1\\nbodies: [' * 5000)",
        "m.simulate(t_end=1e300, dt_out=1e-300)",
        "m._write_csv('/dev/full', np.zeros(1), np.zeros((1, 56)), np.zeros((1, 48)), np.zeros(1))",
    ]
    for call in calls:
        code = f"import numpy as np, kanedyn\nm = kanedyn.load({str(EXAMPLES / 'eight_body.yaml')!r})\ntry:\n    {call}\nexcept Exception as e:\n    print(type(e).__name__)\n"
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, (call, done.returncode, done.stderr[-2000:])


def test_eom_refuses_more_bodies_than_the_tool_prints(tmp_path) -> None:
    path = tmp_path / "chain301.yaml"
    subprocess.run(
        [sys.executable, str(EXAMPLES / "make_chain.py"), "301", "-o", str(path)], check=True
    )
    chain = kanedyn.load(path)
    with pytest.raises(ValueError, match=r"N = 301 is more than 300"):
        chain.eom()
    tool = run_tool(["eom", path])
    assert tool.returncode == 1 and "is more than the 300 bodies" in tool.stderr


def test_a_deeply_nested_urdf_raises_model_error(tmp_path) -> None:
    # The XML parser under liburdfdom recurses once per element level: 100,000 levels
    # overflowed the stack and took the interpreter down. The file is refused before parsing.
    levels = 100_000
    path = tmp_path / "deep.urdf"
    path.write_text("<robot>" + "<a>" * levels + "</a>" * levels + "</robot>")
    with pytest.raises(kanedyn.ModelError) as caught:
        kanedyn.load(path)
    e = caught.value
    if "without URDF support" in e.problem:
        pytest.skip("this kanedyn was built without URDF support")
    assert "nested deeper than 100 levels" in e.problem
    assert e.file == str(path) and e.line == 1 and e.column == len("<robot>") + 3 * 99 + 1
    assert "\n" not in str(e)
