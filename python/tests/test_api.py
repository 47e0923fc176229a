"""The module's surface: what a model and a state show, docstrings, and the installed package."""

from __future__ import annotations

import inspect
import os
import pathlib
import pydoc
import subprocess
import sys

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES, run_tool, tool_json


def test_model_description_matches_the_tool(eight) -> None:
    printed = tool_json(["eom", EXAMPLES / "eight_body.yaml", "--json"])
    assert eight.N == 8
    assert eight.L.tolist() == printed["L"] == [0, 1, 2, 2, 1, 1, 1, 7]
    assert eight.u.tolist() == printed["u"]
    assert eight.body_names[0] == "torso" and len(eight.body_names) == 8
    assert eight.total_mass == pytest.approx(eight.mass.sum(), rel=1e-15)
    assert eight.inertia.shape == (8, 3, 3) and eight.com.shape == (8, 3) and eight.joint.shape == (8, 3)
    assert eight.gravity.tolist() == [0.0, 0.0, -9.81]
    assert eight.columns[0] == "t" and eight.columns[-1] == "energy" and len(eight.columns) == 2 + 16 * 8
    assert eight.body_number("left_forearm") == 8
    assert "eight-body" in repr(eight)


def test_state_views_write_through(eight) -> None:
    s = eight.initial_state()
    assert s.x.shape == (56,) and s.y.shape == (48,) and s.N == 8
    assert s.x.flags["C_CONTIGUOUS"] and s.x.dtype == np.float64
    s.y[0] = 0.25
    assert s.y[0] == 0.25
    view = s.x
    s.x = np.arange(56.0)
    assert view[3] == 3.0  # the same memory
    t = s.copy()
    t.y[1] = 7.0
    assert s.y[1] != 7.0
    assert eight.initial_state().y[0] != 0.25  # the model's initial state is untouched
    s = eight.initial_state()
    s.x[0:4] = [0.0, 0.0, 0.0, 3.0]
    assert s.normalize() == pytest.approx(2.0, rel=1e-15)
    assert s.x[3] == 1.0
    zero = eight.state()
    assert zero.x[3] == 1.0 and not zero.y.any()


def test_a_dict_and_a_text_give_the_same_model_as_the_file() -> None:
    import json

    path = EXAMPLES / "eight_body.json"
    from_file = kanedyn.load(path)
    from_dict = kanedyn.load(json.loads(path.read_text()))
    from_text = kanedyn.loads(path.read_text())
    want = from_file.eom()
    for m in (from_dict, from_text):
        got = m.eom()
        assert got.A.tobytes() == want.A.tobytes() and got.ydot.tobytes() == want.ydot.tobytes()
    assert from_dict.path == "<dict>" and from_text.path == "<string>"


def test_docstrings_describe_the_api() -> None:
    text = pydoc.render_doc(kanedyn.Model, renderer=pydoc.plaintext)
    for name in ("derivatives", "derivatives_batch", "eom", "inspect", "simulate", "initial_state", "total_mass"):
        assert name in text, name
    assert "Eq. 36" in kanedyn.Model.derivatives.__doc__
    assert str(inspect.signature(kanedyn.Model.derivatives)) == "(self, /, x, y=None, t=0.0, u=None)"
    assert "kanedyn simulate" in kanedyn.Model.simulate.__doc__
    assert "e4" in kanedyn.State.__doc__
    assert kanedyn.load.__doc__ and kanedyn.Result.__doc__ and kanedyn.ModelError.__doc__


def test_version_is_the_tools() -> None:
    assert run_tool(["--version"]).stdout.split()[-1] == kanedyn.__version__


def test_cmake_install_puts_an_importable_package_under_the_prefix(tmp_path) -> None:
    build = os.environ.get("KANEDYN_BUILD_DIR")
    if not build:
        pytest.fail("KANEDYN_BUILD_DIR is not set (ctest sets it)")
    prefix = tmp_path / "prefix"
    done = subprocess.run(["cmake", "--install", build, "--prefix", str(prefix)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    found = sorted(prefix.glob("lib/python3*/*-packages/kanedyn/__init__.py"))
    assert len(found) == 1, sorted(str(p) for p in prefix.rglob("kanedyn/*"))
    site = found[0].parents[1]
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "KANEDYN_TOOL")}
    env["PYTHONPATH"] = str(site)
    code = (
        "import kanedyn, sys\n"
        f"m = kanedyn.load({str(EXAMPLES / 'eight_body.yaml')!r})\n"
        "print(kanedyn.__file__)\n"
        "print(m.eom().A.shape)\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0].startswith(str(site)) and lines[1] == "(48, 48)"


def test_energy_and_momentum_of_one_free_body_by_hand() -> None:
    # One body, no forces: G_K = O_K + r'_K with O_K at the translation, identity orientation,
    # so v_G = s' dot + w x r' and H_O = [I_G] w + r_G x m v_G (inertial = body components).
    m = kanedyn.loads(
        "format: kanedyn-model/1\n"
        "gravity: [0, 0, -9.81]\n"
        "bodies:\n"
        "  - name: b\n"
        "    parent: ground\n"
        "    mass: 2.0\n"
        "    inertia: [1.0, 2.0, 3.0]\n"
        "    com: [0, 0, 0.5]\n"
        "    initial:\n"
        "      translation: [1.0, 0, 0]\n"
        "      angular_velocity: [1.5, 0, 0]\n"
        "      translation_rate: [0.3, 0, 0]\n"
    )
    w = np.array([1.5, 0.0, 0.0])
    r_g = np.array([1.0, 0.0, 0.5])
    v_g = np.array([0.3, 0.0, 0.0]) + np.cross(w, [0.0, 0.0, 0.5])
    p = 2.0 * v_g
    h = np.array([1.0, 2.0, 3.0]) * w + np.cross(r_g, p)
    kinetic = 0.5 * 2.0 * v_g @ v_g + 0.5 * w @ (np.array([1.0, 2.0, 3.0]) * w)
    # A few roundings each: 1e-14 relative.
    linear, angular = m.momentum()
    assert np.allclose(linear, p, rtol=1e-14, atol=0)
    assert np.allclose(angular, h, rtol=1e-14, atol=1e-15)
    assert m.energy()[0] == pytest.approx(kinetic, rel=1e-14)
    # The pooled workspace keeps nothing from one call to the next: another state in between
    # leaves the first state's numbers as they were, bit for bit.
    first = (m.energy(), m.momentum())
    s = m.initial_state()
    s.y[:] = 0.0
    assert m.energy(s)[0] == 0.0 and not np.any(m.momentum(s)[0])
    again = (m.energy(), m.momentum())
    assert first[0] == again[0]
    assert all(np.array_equal(a, b) for a, b in zip(first[1], again[1]))


def test_the_namespace_is_the_api() -> None:
    # `import kanedyn` binds its API and nothing of its own imports (typing names, numpy, os,
    # json, helpers); its modules (kanedyn.study) stay reachable as modules.
    import types

    assert sorted(set(kanedyn.__all__)) == sorted(kanedyn.__all__)
    for name in kanedyn.__all__:
        assert hasattr(kanedyn, name), name
    leaked = [
        name
        for name in dir(kanedyn)
        if not name.startswith("_") and name not in kanedyn.__all__ and not isinstance(getattr(kanedyn, name), types.ModuleType)
    ]
    assert leaked == []
    for name in ("Any", "np", "os", "json", "Tuple", "Union", "Optional", "annotations"):
        assert not hasattr(kanedyn, name), name
    namespace: dict = {}
    exec("from kanedyn import *", namespace)
    assert sorted(k for k in namespace if k != "__builtins__") == sorted(kanedyn.__all__)
    # The calls kept in a private module still read their annotations there.
    import typing

    assert typing.get_type_hints(kanedyn.load)["return"] is kanedyn.Model
    assert "t_end" in typing.get_type_hints(kanedyn.Model.simulate)
