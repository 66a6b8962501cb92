"""Obstacles and the closest pair in the figures, the HTML view and `stackik map`'s record."""

from __future__ import annotations

import argparse
import json

import pytest

from stackik import HalfSpace, PlatformGeometry, Sphere, Stack
from stackik.sampling import random_feasible_poses

pytest.importorskip("matplotlib")

GEOM = PlatformGeometry.hexagonal(leg_radius=12.0, plate_thickness=10.0)
OBS = [Sphere([250, 0, 600], 60), HalfSpace([0, 0, -20], [0, 0, 1])]


def _pose():
    stack = Stack.uniform(GEOM, 3)
    return stack, random_feasible_poses(stack, 1, rng=3, phi=0.0)[0]


def test_pose_figures_draw_the_closest_pair_with_its_distance(tmp_path):
    from stackik.analysis import figures
    from stackik.clearance import clearances

    stack, q = _pose()
    d = clearances(stack, q, OBS, phi=0.0).minimum
    fig = figures.plot_pose_diagram(stack, [q], 0.0, obstacles=OBS, path=tmp_path / "p.png")
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert f"{d:.1f} mm" in texts and (tmp_path / "p.png").stat().st_size > 0
    assert any(line.get_label() == "closest pair" for line in fig.axes[0].lines)
    fig3 = figures.plot_spatial_pose(stack, q, phi=0.0, obstacles=OBS, path=tmp_path / "s.png")
    assert any(f"{d:.1f} mm" in t.get_text() for t in fig3.axes[0].texts)
    # no bodies, no obstacle, no margin: the figure is the one it was (no pair marked)
    plain = figures.plot_pose_diagram(Stack.reference(3, leg_radius=0.0), [q], 0.0)
    assert not [t for t in plain.axes[0].texts if t.get_text().endswith(" mm")]


def test_html_view_has_the_closest_pair_trace():
    pytest.importorskip("plotly")
    from stackik import viz

    stack, q = _pose()
    fig = viz.pose_figure(stack, q, phi=0.0, obstacles=OBS, clearance=100.0)
    (pair,) = [t for t in fig.data if t.name == "closest pair"]
    assert pair.text[0].endswith(" mm") and pair.line.color == "#d62728"  # below the margin
    assert "closest pair" not in [
        t.name for t in viz.pose_figure(Stack.reference(3, leg_radius=0.0), q, phi=0.0).data
    ]


def test_map_records_obstacles_and_guards_its_checkpoint(tmp_path):
    from stackik.cli import map as cmap
    from stackik.cli._common import CLIError

    f = tmp_path / "obs.json"
    f.write_text(json.dumps([{"type": "sphere", "center": [400, 0, 500], "radius": 60}]))
    args = argparse.Namespace(obstacles=f, clearance=2.0)
    clear, record = cmap._clearance(args)
    assert record == {"obstacles": [{"type": "sphere", "center": [400.0, 0.0, 500.0],
                                     "radius": 60.0}], "clearance": 2.0}  # fmt: skip
    assert clear["clearance"] == 2.0 and len(clear["obstacles"]) == 1
    assert cmap._clearance(argparse.Namespace(obstacles=None, clearance=0.0))[0] == {}
    ck = tmp_path / "checkpoint"
    cmap._check_checkpoint(ck, record)
    cmap._check_checkpoint(ck, record)  # the same: resumes
    with pytest.raises(CLIError, match="other obstacles"):
        cmap._check_checkpoint(ck, {"obstacles": [], "clearance": 0.0})


def test_path_animation_marks_the_closest_pair_per_frame(tmp_path):
    from stackik import PlanarTarget
    from stackik.paths import solve_path
    from stackik.paths.animate import animate_path

    stack = Stack.reference(2, leg_radius=0.0)
    targets = [PlanarTarget(100.0 + 20 * k, 600.0, 0.0, 0.0) for k in range(3)]
    res = solve_path(stack, targets, max_jump=(60.0, 0.3))
    assert res.completed > 0
    files = animate_path(res, stack, tmp_path / "a.gif", obstacles=OBS, clearance=5.0, mp4=False)
    assert files[0].stat().st_size > 0
