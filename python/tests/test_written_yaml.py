"""Model files kanedyn writes (`import`, `equilibrium -o`) read the same under YAML 1.1 (PyYAML,
which takes `8e-04` for a string and wants `8.0e-04`) as under the model loader: every number
a float, and the models equal bit for bit."""

from __future__ import annotations

import pathlib
from typing import Any, Iterator

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES, run_tool

yaml = pytest.importorskip("yaml")

# Small and large numbers in every place the import writes one: mass, inertia, com, the joint's
# origin (at) and its rpy (frame's angle), an axis, damping.
SMALL = """<robot name="small">
  <link name="base_link"/>
  <joint name="mount" type="fixed">
    <parent link="base_link"/><child link="pod"/>
    <origin xyz="0.0001 -2.5e-07 3e+05" rpy="0 0 1e-05"/>
  </joint>
  <link name="pod">
    <inertial><origin xyz="8e-04 0 -1e-06"/><mass value="8e-04"/>
      <inertia ixx="2e-07" iyy="3e-07" izz="4e-07" ixy="1e-09" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="hinge" type="revolute">
    <parent link="pod"/><child link="vane"/>
    <origin xyz="1e-03 0 0"/><axis xyz="0 1e-04 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
    <dynamics damping="7e-05"/>
  </joint>
  <link name="vane">
    <inertial><mass value="1e-05"/>
      <inertia ixx="1e-10" iyy="1e-10" izz="1e-10" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
</robot>
"""


def leaves(node: Any) -> Iterator[Any]:
    if isinstance(node, dict):
        for value in node.values():
            yield from leaves(value)
    elif isinstance(node, list):
        for value in node:
            yield from leaves(value)
    else:
        yield node


def looks_numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def check_written(path: pathlib.Path) -> None:
    text = path.read_text()
    data = yaml.safe_load(text)
    values = list(leaves(data))
    # No number came back as a string (the names are quoted, and none looks like a number).
    assert [v for v in values if isinstance(v, str) and looks_numeric(v)] == []
    assert sum(isinstance(v, float) for v in values) > 10
    # The loader's model from the file and from PyYAML's dict: the same numbers, so the same
    # equations of motion, bit for bit.
    from_file = kanedyn.load(path)
    from_dict = kanedyn.load(data)
    a, b = from_file.eom(), from_dict.eom()
    for name in ("A", "f", "ydot", "xdot"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


@pytest.mark.parametrize("floating", [False, True])
def test_import_writes_numbers_every_yaml_reader_reads_as_numbers(tmp_path: pathlib.Path, floating: bool) -> None:
    (tmp_path / "small.urdf").write_text(SMALL)
    for urdf in (tmp_path / "small.urdf", EXAMPLES / "urdf" / "arm.urdf"):
        out = tmp_path / (urdf.stem + ".yaml")
        done = run_tool(["import", urdf, "-o", out, *(["--floating"] if floating else [])])
        assert done.returncode == 0, done.stderr
        check_written(out)
    # The numbers themselves: PyYAML's float is the correctly rounded value of the text, as
    # the loader's is; the mass 8e-04 is written as 8.0e-04 and comes back as the same double.
    text = (tmp_path / "small.yaml").read_text()
    assert "mass: 8.0e-04" in text
    assert yaml.safe_load(text)["bodies"][0]["mass"] == 8e-04


def test_equilibrium_writes_numbers_every_yaml_reader_reads_as_numbers(tmp_path: pathlib.Path) -> None:
    out = tmp_path / "rest.yaml"
    done = run_tool(["equilibrium", EXAMPLES / "eight_body.yaml", "-o", out])
    assert done.returncode == 0, done.stderr
    check_written(out)
