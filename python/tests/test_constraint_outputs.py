"""The constraints' reactions from Python: the four-bar's run, its CSV against the tool's, the
columns by name, the CSV written back and read back, and the lift of a rolling disc in stats."""

from __future__ import annotations

import numpy as np

import kanedyn
from conftest import EXAMPLES, run_tool

DISC = """format: kanedyn-model/1
name: disc
gravity: [0, 0, 9.81]
bodies:
  - name: disc
    parent: ground
    mass: 2.0
    inertia: [0.045, 0.09, 0.045]
    initial:
      translation: [0, 0, 0.3]
constraints:
  - name: contact
    type: rolling_disc
    body: disc
    axis: [0, 1, 0]
    radius: 0.3
"""


def test_the_four_bars_reactions_equal_the_tools_csv(tmp_path) -> None:
    m = kanedyn.load(EXAMPLES / "four_bar.yaml")
    names = ["closure.f1", "closure.f2", "closure.f3", "closure.m1", "closure.m2", "closure.m3"]
    assert list(m.columns)[-6:] == names
    done = run_tool(["simulate", EXAMPLES / "four_bar.yaml", "-o", tmp_path / "tool.csv", "--t-end", "0.5", "--dt-out", "0.05"])
    assert done.returncode == 0, done.stderr
    r = m.simulate(t_end=0.5, dt_out=0.05, output=tmp_path / "py.csv")
    tool_bytes = (tmp_path / "tool.csv").read_bytes()
    assert (tmp_path / "py.csv").read_bytes() == tool_bytes
    assert r.reactions.shape == (len(r), 6)
    assert r.reaction_columns == names
    assert np.array_equal(r["closure.f2"], r.reactions[:, 1])
    assert r.table().shape == (len(r), len(m.columns))
    assert r.stats["normal_force_negative_at"] == {}
    r.to_csv(tmp_path / "written.csv")
    assert (tmp_path / "written.csv").read_bytes() == tool_bytes
    back = kanedyn.read_csv(m, tmp_path / "tool.csv")
    assert np.array_equal(back.reactions, r.reactions)
    assert np.array_equal(back.table(), r.table())


def test_a_disc_under_a_plane_that_pulls_it_is_reported(tmp_path) -> None:
    (tmp_path / "disc.yaml").write_text(DISC)
    m = kanedyn.load(tmp_path / "disc.yaml")
    r = m.simulate(t_end=0.2, dt_out=0.1)
    # Gravity along +n: the plane holds the disc down with its weight from the start.
    assert r.stats["normal_force_negative_at"] == {"contact": 0.0}
    assert np.allclose(r["contact.f3"], -2.0 * 9.81, atol=1e-9)
    assert r.table().shape == (3, len(m.columns))
