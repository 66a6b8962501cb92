"""``stackik map --capacity``: stackik.payload_capacity over the workspace map's targets
(stackik.analysis.capacity.capacity_map)."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from pathlib import Path

import pytest
from test_figure_borders import assert_clean_border

from stackik import Load, PlatformGeometry, Stack, payload_capacity, solve_ik
from stackik.analysis.workspace import study_targets
from stackik.cli import main

GEOMETRY = "n = 4\n[platform.hexagonal]\nplate_mass = 5.0\nleg_mass = 1.5\nforce_max = 450.0\n"


def test_capacity_map_cli_equals_payload_capacity(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """On a tiny map (2 targets): the figures exist, and the CSV and JSON rows are
    payload_capacity (and the free least-FN pose's peak force) called directly on the
    map's targets with the same load and tolerance."""
    geo = tmp_path / "g.toml"
    geo.write_text(GEOMETRY)
    out = tmp_path / "cap"
    argv = ["map", "--capacity", "--geometry", str(geo), "--targets", "2", "--quiet"]
    argv += ["--capacity-tol", "0.5", "--gravity", "moon", "--seed", "7"]
    assert main([*argv, "--out", str(out), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    for name in ("capacity_map.png", "peak_force_map.png", "capacity.csv"):
        assert (out / name).stat().st_size > 0
    for name in ("capacity_map.png", "peak_force_map.png"):
        assert_clean_border(out / name)
    with (out / "capacity.csv").open() as fh:
        table = list(csv.DictReader(fh))
    assert data["targets"] == 2 and len(table) == 2 == len(data["rows"])
    g = PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5, force_max=450.0)
    stack = Stack.uniform(g, 4)
    free = Stack.uniform(dataclasses.replace(g, force_max=math.inf), 4)
    load = Load(gravity="moon")
    for target, row, line in zip(study_targets(stack, 2, seed=7), data["rows"], table, strict=True):
        assert (row["rho"], row["z"], row["theta"]) == (target.rho, target.z, target.theta)
        cap = payload_capacity(stack, target, load, tol=0.5)
        assert row["capacity_kg"] == cap.mass and row["upper_kg"] == cap.upper
        assert row["carried"] == cap.result.success and row["solves"] == cap.solves
        assert row["peak_force_N"] == cap.result.peak_force
        assert cap.unloaded is not None
        assert row["unloaded_peak_force_N"] == cap.unloaded.peak_force
        assert row["free_peak_force_N"] == solve_ik(free, target, load=load).peak_force
        assert float(line["capacity_kg"]) == cap.mass
        assert float(line["free_peak_force_N"]) == pytest.approx(row["free_peak_force_N"])
    assert main([*argv]) == 0
    assert "payload capacity: 2 of 2" in capsys.readouterr().out


def test_capacity_map_bad_input(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """--payload-mass with --capacity, load options without it, and a stack without a
    finite force_max are one-line CLI errors."""
    geo = tmp_path / "g.toml"
    geo.write_text(GEOMETRY)
    base = ["map", "--geometry", str(geo), "--targets", "2", "--quiet"]
    assert main([*base, "--capacity", "--payload-mass", "2"]) != 0
    assert "--payload-mass" in capsys.readouterr().err
    assert main([*base, "--gravity", "moon"]) != 0
    assert "--capacity" in capsys.readouterr().err
    assert main(["map", "--capacity", "--targets", "1", "--quiet"]) != 0
    assert "force_max" in capsys.readouterr().err
