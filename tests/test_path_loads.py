"""Loaded paths (issue 26): solve_path(..., load=) keeps every waypoint within the leg
force limits, and the result carries the leg forces (JSON and CSV)."""

from __future__ import annotations

import numpy as np
import pytest

import stackik as sk
from stackik.paths import PathResult, interpolate_targets, read_path_csv
from stackik.rotations import euler_zyx

LOAD = sk.Load(mass=4.0)


def _path() -> list[sk.SpatialTarget]:
    a = sk.SpatialTarget((-150, -100, 1250), euler_zyx([0.2, 0, 0]))
    b = sk.SpatialTarget((150, 100, 1300), euler_zyx([-0.2, 0.1, 0]))
    return interpolate_targets([a, b], steps=12)


def _stack(force_max: float = np.inf) -> sk.Stack:
    g = sk.PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5, force_max=force_max)
    return sk.Stack.uniform(g, 4)


def test_loaded_path_keeps_the_force_limits(tmp_path) -> None:
    ts = _path()
    free = sk.solve_path(_stack(), ts, load=LOAD)
    assert free.success and free.leg_forces is not None
    peak = np.abs(free.leg_forces).max(axis=(1, 2))
    fmax = 200.0
    assert (peak > fmax).sum() >= 3  # the limit binds along the path
    stack = _stack(fmax)
    path = sk.solve_path(stack, ts, load=LOAD)
    assert path.success and path.leg_forces is not None
    assert np.abs(path.leg_forces).max() <= fmax * (1 + 1e-6)
    for t, q in zip(ts, path.q):
        assert sk.check_pose(stack, t, q, LOAD).ok
    np.testing.assert_allclose(path.leg_forces[3], sk.leg_forces(stack, path.q[3], LOAD))
    d = np.abs(np.diff(path.q, axis=0))
    assert d[..., :3].max() <= 50.0 and d[..., 3:].max() <= 0.25
    back = PathResult.from_dict(path.to_dict())
    assert back.leg_forces is not None and np.array_equal(back.leg_forces, path.leg_forces)
    csv = read_path_csv(path.to_csv(tmp_path / "path.csv"))
    assert np.array_equal(csv["leg_forces"], path.leg_forces)


def test_unloaded_path_has_no_forces_and_bad_load() -> None:
    ts = _path()[:3]
    plain = sk.solve_path(sk.Stack.reference(4), ts)
    assert plain.leg_forces is None and "leg_forces" not in "".join(plain.csv_header())
    with pytest.raises(ValueError, match="load"):
        sk.solve_path(sk.Stack.reference(4), ts, load="heavy")


def test_cli_path_payload(tmp_path, capsys) -> None:
    import json

    from stackik.cli import main

    argv = ["path", "--spatial", "--from", "-150", "-100", "1250", "0.2", "0", "0", "--to",
            "150", "100", "1300", "-0.2", "0.1", "0", "--steps", "4", "--payload-mass", "4",
            "--no-animation", "--out", str(tmp_path / "out"), "--json"]  # fmt: skip
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["success"] and summary["peak_leg_force_N"] > 0
    doc = json.loads((tmp_path / "out" / "path.json").read_text())
    assert doc["leg_forces"] is not None
