"""Paths keep their clearances (issue 29): every waypoint of solve_path(..., obstacles=,
clearance=) passes the full check; a truss member across the least-FN path's legs is gone
around within max_jump; a tall stack that folds into itself is unfolded step by step."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import stackik as sk
from stackik.check import FEAS_TOL
from stackik.clearance import plate_frames
from stackik.formulation import Problem
from stackik.kinematics import spatial_chain
from stackik.methods.ip import folds_only
from stackik.paths import interpolate_targets
from stackik.rotations import euler_zyx
from stackik.sampling import random_reachable_targets, random_spatial_targets

REF = sk.Stack.reference(4, leg_radius=0.0)
FAT = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=12.0), 4)


def _path() -> list[sk.SpatialTarget]:
    a = sk.SpatialTarget((-150, -100, 1250), euler_zyx([0.2, 0, 0]))
    b = sk.SpatialTarget((150, 100, 1300), euler_zyx([-0.2, 0.1, 0]))
    return interpolate_targets([a, b], steps=12)


def _jumps_ok(path: sk.paths.PathResult, max_jump=(50.0, 0.25)) -> bool:
    q = path.q[: path.completed]
    d = np.abs(np.diff(q, axis=0))
    return bool(np.all(d[..., :3] <= max_jump[0]) and np.all(d[..., 3:] <= max_jump[1]))


def test_path_on_thick_legs_keeps_them_apart() -> None:
    ts = _path()
    plain = sk.solve_path(REF, ts)
    assert plain.success
    assert min(sk.clearances(FAT, q).self_legs for q in plain.q) < 0  # the legs would collide
    path = sk.solve_path(FAT, ts)
    assert path.success and path.completed == len(ts) and _jumps_ok(path)
    for t, q in zip(ts, path.q):
        assert sk.check_pose(FAT, t, q).ok


def test_path_goes_around_a_truss_member() -> None:
    ts = _path()
    plain = sk.solve_path(REF, ts)
    q = plain.q[len(ts) // 2]
    ch = spatial_chain(q)
    i, k = 2, 3
    B = ch.O[i] + ch.A[i] @ REF.base_nodes[i][k]
    T = ch.O[i + 1] + ch.A[i + 1] @ REF.top_nodes[i][k]
    d = np.cross(T - B, [0.0, 0.0, 1.0])
    d /= np.linalg.norm(d)
    member = sk.Capsule((B + T) / 2 - 300 * d, (B + T) / 2 + 300 * d, 10.0)
    assert min(sk.clearances(REF, q, [member]).obstacles[0] for q in plain.q) < 0
    path = sk.solve_path(REF, ts, obstacles=[member])
    assert path.completed == len(ts) and path.success and _jumps_ok(path)
    for t, q in zip(ts, path.q):
        assert sk.check_pose(REF, t, q, obstacles=[member]).ok
    assert np.all(path.frobenius_norm <= plain.frobenius_norm * 1.02)


def test_path_clearance_bad_input() -> None:
    ts = _path()
    with pytest.raises(ValueError, match="clearance"):
        sk.solve_path(REF, ts, clearance=-1.0)
    with pytest.raises(ValueError):
        sk.solve_path(REF, ts, obstacles=[sk.Sphere((0, 0, 0), -5.0)])
    blocked = sk.Sphere(ts[0].position, 200.0)  # around the first waypoint's plate
    with pytest.raises(ValueError, match="start"):
        sk.solve_path(REF, ts, obstacles=[blocked], start=sk.solve_ik(REF, ts[0]).q)


def test_path_breaks_where_no_clear_pose_exists() -> None:
    """A sphere around the waypoints' end-effector plates: the path breaks at once, and
    says that clearances, not the workspace, stop it."""
    stack = sk.Stack.reference(1, leg_radius=0.0)
    a = sk.SpatialTarget((0.0, 0.0, 330.0), np.eye(3))
    b = sk.SpatialTarget((20.0, 0.0, 330.0), np.eye(3))
    ts = interpolate_targets([a, b], steps=3)
    path = sk.solve_path(stack, ts, obstacles=[sk.Sphere(ts[0].position, 200.0)])
    assert not path.success and path.completed == 0
    assert path.status is sk.paths.PathStatus.UNREACHABLE
    assert "clear of the obstacles" in path.message and "waypoint 0" in path.message


def test_cli_path_with_obstacles(tmp_path, capsys) -> None:
    """stackik path --geometry (12 mm legs) --obstacles FILE: the JSON summary has the
    least clearance over the waypoints, >= 0."""
    import json

    from stackik.cli import main

    geo = tmp_path / "legs12.toml"
    FAT.to_toml(geo)
    obs = tmp_path / "member.toml"
    obs.write_text(
        '[[obstacles]]\ntype = "capsule"\na = [-400.0, 0.0, 300.0]\n'
        "b = [-400.0, 0.0, 1200.0]\nradius = 20.0\n"
    )
    argv = ["path", "--spatial", "--from", "-150", "-100", "1250", "0.2", "0", "0", "--to",
            "150", "100", "1300", "-0.2", "0.1", "0", "--steps", "6", "--geometry", str(geo),
            "--obstacles", str(obs), "--no-animation", "--out", str(tmp_path / "out"),
            "--json"]  # fmt: skip
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["success"] and summary["least_clearance_mm"] >= -1e-6


def test_cli_path_refuses_force_weight(capsys) -> None:
    from stackik.cli import main

    argv = ["path", "--from", "0", "1000", "0", "--to", "100", "1000", "0", "--steps", "2",
            "--force-weight", "1", "--no-animation"]  # fmt: skip
    assert main(argv) == 2
    assert "--force-weight" in capsys.readouterr().err


def _planar_path() -> list[sk.PlanarTarget]:
    a = sk.PlanarTarget(-150.0, 1250.0, 0.1)
    b = sk.PlanarTarget(150.0, 1300.0, -0.1)
    return interpolate_targets([a, b], steps=12)


def test_planar_path_goes_around_a_truss_member() -> None:
    """A truss member across one leg of the least-FN planar path's middle pose,
    perpendicular to the plane: every waypoint of the path with the member passes the
    full check, no step goes over max_jump."""
    ts = _planar_path()
    plain = sk.solve_path(REF, ts)
    assert plain.success
    q = plain.q[len(ts) // 2]
    A, O = plate_frames(REF, q, phi=0.0)
    i, k = 1, 2
    B = O[i] + A[i] @ REF.base_nodes[i][k]
    T = O[i + 1] + A[i + 1] @ REF.top_nodes[i][k]
    normal = np.array([0.0, 1.0, 0.0])  # the plane of phi = 0 is x-z
    member = sk.Capsule((B + T) / 2 - 300 * normal, (B + T) / 2 + 300 * normal, 10.0)
    assert min(sk.clearances(REF, p, [member], phi=0.0).obstacles[0] for p in plain.q) < 0
    path = sk.solve_path(REF, ts, obstacles=[member])
    assert path.completed == len(ts) and path.success
    d = np.abs(np.diff(path.q, axis=0))
    assert np.all(d[..., :2] <= 50.0) and np.all(d[..., 2] <= 0.25)
    for t, p in zip(ts, path.q):
        assert sk.check_pose(REF, t, p, obstacles=[member]).ok


def test_planar_path_beside_a_wall() -> None:
    """A wall (half-space x < 180 mm) through the plain path's legs: every waypoint the
    path completes keeps every body on the wall's free side; where it breaks, a solve of
    that waypoint alone finds no clear pose either, and the message names the waypoint
    and the obstacle."""
    ts = _planar_path()
    plain = sk.solve_path(REF, ts)
    wall = sk.HalfSpace((180.0, 0.0, 0.0), (-1.0, 0.0, 0.0))  # keep x < 180 mm
    assert min(sk.clearances(REF, p, [wall], phi=0.0).obstacles[0] for p in plain.q) < 0
    path = sk.solve_path(REF, ts, obstacles=[wall])
    assert path.completed >= 2
    for t, p in zip(ts[: path.completed], path.q[: path.completed]):
        assert sk.check_pose(REF, t, p, obstacles=[wall]).ok
    if path.completed < len(ts):
        k = path.completed
        assert not path.success and f"waypoint {k}" in path.message
        assert "obstacle" in path.message
        assert not sk.solve_ik(REF, ts[k], obstacles=[wall]).success


REF16 = sk.Stack.reference(16, leg_radius=0.0)
FAT16 = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=12.0), 16)


def _folding_path(i: int, m: int) -> list[sk.PlanarTarget]:
    """A straight planar n = 16 path between random reachable targets (plane phi = 0.3)
    whose least-FN poses on legs of zero radius fold into themselves with 12 mm legs."""
    keys = random_reachable_targets(REF16, 8, rng=36, phi=0.3)
    return interpolate_targets([keys[i], keys[i + 1]], steps=m - 1)


def _clear_and_continuous(stack: sk.Stack, path: sk.paths.PathResult) -> None:
    """Every waypoint passes the check, every exact clearance >= 0 (to FEAS_TOL), no step
    over the default max_jump."""
    assert path.success and path.completed == path.m
    for t, q in zip(path.targets, path.q):
        assert sk.check_pose(stack, t, q).ok
        assert sk.clearances(stack, q, phi=t.phi).minimum >= -FEAS_TOL
    d = np.abs(np.diff(path.q, axis=0))
    assert np.all(d[..., :2] <= 50.0) and np.all(d[..., 2] <= 0.25)


@pytest.mark.parametrize(("i", "m", "mode"), [(4, 12, "fast"), (6, 4, "global")])
def test_a_folding_tall_path_goes_through_clear(
    i: int, m: int, mode: str, lines_pass_through: None
) -> None:
    """Planar n = 16 on 12 mm legs: the zero-radius path's poses fold into themselves (the
    check refuses them on non-adjacent bodies alone), and the path with the legs' radius
    (which broke at waypoint 1 (fast) or 2 (global) when its steps had no rows for such
    bodies) goes through,
    every waypoint clear by the exact distances, its steps having been made again with
    the rows of the close pairs (``info["unfold"]``)."""
    ts = _folding_path(i, m)
    thin = sk.solve_path(REF16, ts)
    assert thin.success
    refused = [sk.check_pose(FAT16, t, q) for t, q in zip(ts, thin.q)]
    assert any(folds_only(c, 0.0) for c in refused)
    path = sk.solve_path(FAT16, ts, mode=mode)
    _clear_and_continuous(FAT16, path)
    assert path.info["unfold"] > 0


@pytest.mark.parametrize("mode", ["fast", "global"])
def test_a_path_on_legs_as_lines_unfolds_a_leg_through_a_plate(mode: str) -> None:
    """Planar n = 16 on legs as lines (the first waypoints of bench_path's first n = 16
    path): a warm step passes a leg's axis through a plate, which the check refuses even
    with no thickness. The step is made again with rows for the pairs close there
    (``info["unfold"]``), and the path goes through, every waypoint checked. (Fast mode
    broke at waypoint 1 when steps on zero-size bodies never carried such rows.)"""
    ts = [
        sk.PlanarTarget(2031.211485117825, 4260.49252751689, -2.0315615264045315),
        sk.PlanarTarget(2017.4921807466478, 4267.40157708351, -1.9804929610169741),
        sk.PlanarTarget(2003.7728763754708, 4274.31062665013, -1.9294243956294166),
    ]
    path = sk.solve_path(REF16, ts, mode=mode, max_jump=(60.0, 0.3))
    assert path.success and path.completed == 3, path.message
    assert path.info["unfold"] > 0
    for t, q in zip(ts, path.q):
        assert sk.check_pose(REF16, t, q).ok
    d = np.abs(np.diff(path.q, axis=0))
    assert np.all(d[..., :2] <= 60.0) and np.all(d[..., 2] <= 0.3)


def test_a_path_that_never_folds_has_no_pair_rows(monkeypatch: pytest.MonkeyPatch) -> None:
    """Planar n = 4 on 12 mm legs: no non-adjacent pair comes close, so no step gets rows for
    one (``with_leg_pairs`` is never called) and the poses are the zero-radius path's, bit
    for bit (fast and global)."""

    def refuse(self: Problem, pairs: Any) -> Problem:
        raise AssertionError("rows for non-adjacent pairs where none is close")

    monkeypatch.setattr(Problem, "with_leg_pairs", refuse)
    fat = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=12.0), 4)
    ts = _planar_path()
    for mode in ("fast", "global"):
        a, b = sk.solve_path(REF, ts, mode=mode), sk.solve_path(fat, ts, mode=mode)
        assert a.success and b.success and b.info["unfold"] == 0
        np.testing.assert_array_equal(a.q, b.q)


def test_a_folding_spatial_path_goes_through_clear() -> None:
    """Spatial n = 12 on 12 mm legs (a straight path of bench_path's set, seed 2024), from
    the pose of the batch with the self-leg rows (explicit starts: not the default's search
    without them, whose pose this path never folds from): a step folds the stack into
    itself, and the path (which broke at waypoint 1 when its steps had no rows for
    non-adjacent bodies) goes through, every waypoint clear."""
    from stackik.solve.policy import spatial_start_count

    ref = sk.Stack.reference(12, leg_radius=0.0)
    fat = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=12.0), 12)
    keys = random_spatial_targets(ref, 15, rng=2024)
    ts = interpolate_targets([keys[0], keys[1]], steps=7)
    start = sk.solve_ik(fat, ts[0], starts=spatial_start_count(12))
    assert start.success
    path = sk.solve_path(fat, ts, start=start.q)
    assert path.success and path.completed == len(ts) and _jumps_ok(path)
    assert path.info["unfold"] > 0
    for t, q in zip(ts, path.q):
        assert sk.check_pose(fat, t, q).ok
        assert sk.clearances(fat, q).minimum >= -FEAS_TOL


def test_a_folding_path_resumed_from_its_checkpoint_is_the_same(tmp_path) -> None:
    """The rows a step carries depend on its previous pose alone: a folding planar n = 16
    path cut at several records of its checkpoint and resumed gives the uninterrupted
    poses, bit for bit."""
    ts = _folding_path(4, 12)
    ck = tmp_path / "ck.jsonl"
    full = sk.solve_path(FAT16, ts, checkpoint=ck)
    assert full.success and full.info["unfold"] > 0
    lines = ck.read_text().splitlines(keepends=True)
    for cut in (3, len(lines) // 2, len(lines) - 2):
        ck.write_text("".join(lines[:cut]))
        resumed = sk.solve_path(FAT16, ts, checkpoint=ck)
        np.testing.assert_array_equal(resumed.q, full.q)
