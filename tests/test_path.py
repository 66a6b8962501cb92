"""Paths (stackik.paths): continuity, breaks, modes, interpolation, timing, files, CLI.

Small stacks and few waypoints: the whole file runs in well under a minute.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from stackik.check import check_pose
from stackik.geometry import Stack
from stackik.kinematics import frobenius_norm, planar_jacobian, spatial_forward
from stackik.paths import (
    PathResult,
    PathStatus,
    interpolate_targets,
    leg_rates,
    lerp_target,
    path_arrays,
    read_path_csv,
    rotation_angle,
    slerp,
    solve_path,
    target_step,
    time_parameterize,
)
from stackik.rotations import euler_zyx
from stackik.solve import solve_ik
from stackik.targets import PlanarTarget, SpatialTarget

MAX_JUMP = (60.0, 0.3)
A = PlanarTarget(600.0, 1000.0, -1.57)  # the paper's first and second targets
B = PlanarTarget(145.0, 1500.0, -0.207)
OUT = PlanarTarget(2500.0, 1000.0, 0.0)  # outside the workspace of 4 platforms


@pytest.fixture(scope="module")
def stack4() -> Stack:
    return Stack.reference(4, leg_radius=0.0)


@pytest.fixture(scope="module")
def planar_path() -> list[PlanarTarget]:
    return interpolate_targets([A, B], steps=8)  # type: ignore[return-value]


@pytest.fixture(scope="module")
def fast_result(stack4, planar_path) -> PathResult:
    return solve_path(stack4, planar_path, max_jump=MAX_JUMP, leg_speed=150.0, leg_accel=300.0)


def assert_valid_path(stack: Stack, result: PathResult) -> None:
    """Every reached pose passes the independent check; no step above max_jump."""
    c = result.completed
    for t, q in zip(result.targets[:c], result.q[:c]):
        assert check_pose(stack, t, q).ok
    k = result.q.shape[2]
    nt = 2 if k == 3 else 3
    lim = np.array([result.max_jump[0]] * nt + [result.max_jump[1]] * (k - nt))
    d = np.abs(np.diff(result.q[:c], axis=0))
    assert np.all(d <= lim), f"largest step / max_jump = {np.max(d / lim):.6f}"
    assert np.all(np.isnan(result.q[c:]))
    assert np.all(np.isnan(result.frobenius_norm[c:]))


# =========================================================================================
# Interpolation
# =========================================================================================
def test_interpolate_planar_is_linear_and_keeps_the_keys():
    C = PlanarTarget(-300.0, 1400.0, 0.3)
    pts = interpolate_targets([A, B, C], steps=[4, 2])
    assert len(pts) == 7
    assert pts[0] is A and pts[4] is B and pts[6] is C
    for j in range(5):
        np.testing.assert_allclose(pts[j].y, A.y + j / 4 * (B.y - A.y), atol=1e-12)
    assert all(p.phi == 0.0 for p in pts)


def test_interpolate_by_max_step():
    pts = interpolate_targets([A, B], max_step=(50.0, 0.1))
    d, ang = target_step(A, B)
    assert len(pts) - 1 == max(math.ceil(d / 50.0), math.ceil(ang / 0.1))
    for a, b in zip(pts[:-1], pts[1:]):
        s, r = target_step(a, b)
        assert s <= 50.0 + 1e-9 and r <= 0.1 + 1e-12


def test_slerp_is_uniform_along_the_shortest_arc():
    from scipy.spatial.transform import Rotation, Slerp

    Ra = euler_zyx([0.3, -0.2, 0.1])
    Rb = euler_zyx([-1.0, 0.4, 0.9])
    ref = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([Ra, Rb])))
    total = rotation_angle(Ra, Rb)
    for s in (0.0, 0.1, 0.5, 0.73, 1.0):
        R = slerp(Ra, Rb, s)
        np.testing.assert_allclose(R, ref([s]).as_matrix()[0], atol=1e-12)
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-14)
        assert rotation_angle(Ra, R) == pytest.approx(s * total, abs=1e-9)
        assert rotation_angle(R, Rb) == pytest.approx((1 - s) * total, abs=1e-9)


def test_spatial_interpolation():
    ta = SpatialTarget([0.0, 0.0, 700.0], euler_zyx([0.0, 0.0, 0.0]))
    tb = SpatialTarget([100.0, -50.0, 760.0], euler_zyx([0.6, -0.3, 0.2]))
    pts = interpolate_targets([ta, tb], max_step=(20.0, 0.05))
    n = len(pts) - 1
    d, ang = target_step(ta, tb)
    assert n == max(math.ceil(d / 20.0), math.ceil(ang / 0.05))
    for j, p in enumerate(pts):
        np.testing.assert_allclose(p.position, ta.position + j / n * (tb.position - ta.position))
        assert rotation_angle(ta.rotation, p.rotation) == pytest.approx(j / n * ang, abs=1e-9)
    mid = lerp_target(ta, tb, 0.5)
    assert rotation_angle(mid.rotation, tb.rotation) == pytest.approx(ang / 2, abs=1e-9)


def test_interpolate_bad_input():
    with pytest.raises(ValueError, match="exactly one"):
        interpolate_targets([A, B])
    with pytest.raises(ValueError, match="exactly one"):
        interpolate_targets([A, B], steps=2, max_step=(1.0, 1.0))
    with pytest.raises(ValueError, match="integers >= 1"):
        interpolate_targets([A, B], steps=0)
    with pytest.raises(ValueError, match="> 0"):
        interpolate_targets([A, B], max_step=(0.0, 0.1))
    with pytest.raises(ValueError, match="empty"):
        interpolate_targets([], steps=2)


# =========================================================================================
# Bad input
# =========================================================================================
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"max_jump": (0.0, 0.3)}, "max_jump"),
        ({"max_jump": (60.0, -1.0)}, "max_jump"),
        ({"max_jump": 60.0}, "max_jump"),
        ({"max_jump": (float("nan"), 0.3)}, "max_jump"),
        ({"mode": "greedy"}, "mode"),
        ({"motion_weight": -1.0}, "motion_weight"),
        ({"leg_speed": 100.0}, "leg_speed and leg_accel"),
        ({"leg_speed": 100.0, "leg_accel": 0.0}, "leg_accel"),
        ({"start": np.zeros((3, 3))}, "start"),
        ({"start": np.full((4, 3), np.nan)}, "start"),
        ({"start": np.zeros((4, 3))}, "does not reach"),
        ({"max_candidates": 0}, "max_candidates"),
        ({"refine": "yes"}, "refine"),
        ({"reanchor_every": -1}, "reanchor_every"),
        ({"max_depth": 20}, "max_depth"),
    ],
)
def test_solve_path_bad_options(stack4, kwargs, match):
    with pytest.raises(ValueError, match=match):
        solve_path(stack4, [A, B], **kwargs)


def test_solve_path_bad_targets(stack4):
    with pytest.raises(ValueError, match="empty"):
        solve_path(stack4, [])
    with pytest.raises(ValueError, match="mixed planar and spatial"):
        solve_path(stack4, [A, A.to_spatial()])
    with pytest.raises(ValueError, match="phi"):
        solve_path(stack4, [A, PlanarTarget(145.0, 1500.0, -0.207, phi=0.5)])
    with pytest.raises(ValueError, match="targets\\[1\\]"):
        solve_path(stack4, [A, (1.0, 2.0, 3.0)])
    with pytest.raises(ValueError, match="single target"):
        solve_path(stack4, A)
    with pytest.raises(ValueError, match="Stack"):
        solve_path("stack", [A, B])
    with pytest.raises(ValueError):  # NaN is refused by the target itself
        solve_path(stack4, [A, PlanarTarget(float("nan"), 1.0, 0.0)])


# =========================================================================================
# Solving
# =========================================================================================
def test_fast_planar_path_is_valid_and_continuous(stack4, planar_path, fast_result):
    r = fast_result
    assert r.success and r.status is PathStatus.SUCCESS and r.completed == r.m == 9
    assert r.break_index is None
    assert_valid_path(stack4, r)
    assert r.q.shape == (9, 4, 3) and r.leg_lengths.shape == (9, 4, 6)
    assert r.margins.shape == (9, 4, 4) and np.all(r.margins >= -1e-6)
    np.testing.assert_array_equal(r.source, np.arange(9.0))
    # the first pose is the default solve's best pose
    np.testing.assert_allclose(r.q[0], solve_ik(stack4, A).q, atol=1e-9)
    arr = path_arrays(stack4, r.targets, r.q)
    np.testing.assert_allclose(arr["frobenius_norm"], r.frobenius_norm)
    fn = [frobenius_norm(planar_jacobian(q)) for q in r.q]
    np.testing.assert_allclose(r.frobenius_norm, fn, rtol=1e-12)  # FN of the poses


def test_planar_path_arrays_match_the_leg_vectors(stack4, fast_result):
    """The compiled planar path arrays against the leg vectors of stackik.platform:
    lengths, the four margins (the smallest sine of a leg's angle with the base and top
    plates, through asin) and FN."""
    from stackik.kinematics import planar_fn2
    from stackik.platform import planar_legs

    r = fast_result
    Q = np.array(r.q)
    Q[2, 1, 2] += 0.4  # a pose off the path: other legs are the extreme ones
    arr = path_arrays(stack4, r.targets, Q)
    l, Rn, _, _ = planar_legs(stack4, Q, r.targets[0].phi)
    L = np.linalg.norm(l, axis=-1)
    jm = np.arcsin(stack4.sin_joint_min)
    base = np.arcsin(np.clip(l[..., 2] / L, -1, 1)).min(axis=-1) - jm
    top = np.arcsin(np.clip(np.einsum("mnkj,mnj->mnk", l, Rn) / L, -1, 1)).min(axis=-1) - jm
    want = np.stack([L.min(-1) - stack4.leg_min, stack4.leg_max - L.max(-1), base, top], -1)
    np.testing.assert_allclose(arr["leg_lengths"], L, rtol=0, atol=1e-9)
    np.testing.assert_allclose(arr["margins"], want, rtol=0, atol=1e-9)
    np.testing.assert_allclose(arr["frobenius_norm"] ** 2, planar_fn2(Q), rtol=1e-13)


def test_global_mode_is_no_worse_than_fast(stack4, planar_path, fast_result):
    g = solve_path(stack4, planar_path, max_jump=MAX_JUMP, mode="global")
    assert g.success and g.mode == "global"
    assert_valid_path(stack4, g)
    # the fast path's branch is among the candidates: the DP optimum is at least as good
    assert np.sum(g.frobenius_norm**2) <= np.sum(fast_result.frobenius_norm**2) * (1 + 1e-9)
    assert g.info["default"] >= g.m


def test_motion_weight_trades_fn_for_motion(stack4, planar_path):
    r0 = solve_path(stack4, planar_path, max_jump=MAX_JUMP, mode="global")
    r1 = solve_path(stack4, planar_path, max_jump=MAX_JUMP, mode="global", motion_weight=1e6)
    assert_valid_path(stack4, r1)
    assert np.sum(np.diff(r1.q, axis=0) ** 2) <= np.sum(np.diff(r0.q, axis=0) ** 2) + 1e-9
    assert np.sum(r1.frobenius_norm**2) >= np.sum(r0.frobenius_norm**2) * (1 - 1e-9)


def test_global_mode_moves_to_a_better_branch(stack4):
    # a curved path on which the branch of the first waypoint's optimum ends up 12 % worse
    # in FN than the per-waypoint optima: global mode crosses to their branch (walking
    # it back by bounded steps, 0.04 % above their mean FN; by transit steps before those,
    # 0.39 %), fast mode (re-anchoring every 20 waypoints) part of the way
    a = PlanarTarget(222.83, 1374.04, -0.3687)
    c = PlanarTarget(-804.55, 859.93, 0.6632)
    b = PlanarTarget(531.70, 1137.47, -0.1418)
    pts = []
    for s in np.linspace(0.0, 1.0, 30):
        y = (1 - s) ** 2 * a.y + 2 * s * (1 - s) * c.y + s**2 * b.y
        pts.append(PlanarTarget(*y))
    ref = np.mean([solve_ik(stack4, t).frobenius_norm for t in pts])
    stay = solve_path(stack4, pts, max_jump=MAX_JUMP, reanchor_every=0)
    fast = solve_path(stack4, pts, max_jump=MAX_JUMP)
    glob = solve_path(stack4, pts, max_jump=MAX_JUMP, mode="global")
    for r in (stay, fast, glob):
        assert r.success
        assert_valid_path(stack4, r)
    assert stay.mean_frobenius_norm > 1.1 * ref
    assert fast.mean_frobenius_norm < stay.mean_frobenius_norm
    assert fast.info["reanchored"] >= 1
    assert glob.mean_frobenius_norm < 1.002 * ref
    assert glob.info["transit"] + glob.info["backward_bounded"] >= 1


def test_global_mode_walks_back_onto_a_better_branch_by_bounded_steps():
    # n = 8, the benchmark's straight planar path 0 (seed 2025) with 20 waypoints: the
    # per-waypoint optima of the later waypoints lie on a branch that does not exist at
    # the earlier ones (warm steps backwards end); bounded steps walk it back to where the
    # path can join it. With warm backward steps only, global mode's mean FN was 0.61 %
    # above the per-waypoint optima's (1.0061), with bounded ones 0.08 % (1.0008)
    stack = Stack.reference(8, leg_radius=0.0)
    a = PlanarTarget(1390.8039151039927, 1779.7111301941143, -0.673168814752579)
    b = PlanarTarget(-47.16246724719099, 1943.202911548691, 0.9149009681258974)
    pts = interpolate_targets([a, b], steps=19)
    ref = np.mean([solve_ik(stack, t).frobenius_norm for t in pts])
    g = solve_path(stack, pts, max_jump=MAX_JUMP, mode="global")
    assert g.success
    assert_valid_path(stack, g)
    assert g.info["backward_bounded"] >= 1
    assert g.mean_frobenius_norm < 1.003 * ref


def _bezier(a: PlanarTarget, c: PlanarTarget, b: PlanarTarget, m: int) -> list[PlanarTarget]:
    """m waypoints of the quadratic Bezier a -> b with control c (as benchmarks/bench_path)."""
    pts = []
    for s in np.linspace(0.0, 1.0, m):
        y = (1 - s) ** 2 * a.y + 2 * s * (1 - s) * c.y + s**2 * b.y
        pts.append(PlanarTarget(float(y[0]), float(y[1]), float(y[2])))
    pts[0], pts[-1] = a, b
    return pts


def test_fast_mode_reanchoring_keeps_fn_within_3_percent_on_the_bench_path(stack4):
    # the n = 4 benchmark path on which re-anchoring matters (bench_path.py, seed 2024,
    # curved path 2: without re-anchoring its mean FN is 12.7 % above the per-waypoint
    # optima): the check at waypoint 20 finds the better basin, transit steps get there,
    # and the mean FN stays within 3 %; every pose checked, no step above max_jump
    a = PlanarTarget(222.83399568612748, 1374.0378517401462, -0.3687299319593071)
    c = PlanarTarget(-804.5536107866321, 859.9298633823975, 0.6632075790621189)
    b = PlanarTarget(531.7049362483348, 1137.4652087106026, -0.14183720382728005)
    pts = _bezier(a, c, b, 60)
    ref = np.mean([solve_ik(stack4, t).frobenius_norm for t in pts])
    r = solve_path(stack4, pts, max_jump=MAX_JUMP)
    assert r.success
    assert_valid_path(stack4, r)
    assert r.info["reanchored"] >= 1
    assert r.mean_frobenius_norm <= 1.03 * ref
    stay = solve_path(stack4, pts, max_jump=MAX_JUMP, reanchor_every=0)
    assert stay.mean_frobenius_norm > 1.1 * ref


def test_fast_mode_reanchoring_checks_back_off(stack4):
    # a straight n = 4 path (bench_path.py, seed 2024, straight path 0) that stays in the
    # best basin: the check at waypoint 20 finds nothing better, so the next is due at
    # 20 + 40 = 60, past the end: two default solves (waypoint 0 and the check), not three
    a = PlanarTarget(-83.82796298032628, 1224.5834942014094, 0.04429207241448124)
    b = PlanarTarget(-250.97629224822617, 1250.8289009718815, -0.04249152079099028)
    pts = interpolate_targets([a, b], steps=59)
    r = solve_path(stack4, pts, max_jump=MAX_JUMP)
    assert r.success and r.m == 60
    assert_valid_path(stack4, r)
    assert r.info["default"] == 2 and r.info["reanchored"] == 0
    # every 20 waypoints (the default period, reset by a check that moves) without the
    # back-off would check at 20 and 40: a period of 10 checks at 10, then 30
    r10 = solve_path(stack4, pts, max_jump=MAX_JUMP, reanchor_every=10)
    assert r10.info["default"] == 3 and r10.info["reanchored"] == 0
    # the same poses (to rounding: a run restarts from the pose, not the kernel's point)
    np.testing.assert_allclose(r10.q, r.q, rtol=0, atol=1e-9)


def test_fast_mode_reanchoring_backs_off_after_a_transit_abandoned_before_a_step(stack4):
    # the n = 4 benchmark's curved path 1 (bench_path.py, seed 2024): the check at
    # waypoint 20 finds a better basin 9 jumps away, but the first transit step does not
    # bring the path a quarter jump closer: abandoned, the path did not move, and the
    # next check is due at 20 + 40 = 60 (past the end) as after a check that finds
    # nothing; no third default solve at waypoint 40
    a = PlanarTarget(-1095.1836552615814, 334.108793971703, 2.013334065435856)
    c = PlanarTarget(-274.4456166198349, 1008.2648105324206, 0.0018676164655920813)
    b = PlanarTarget(209.54674534085788, 1289.4278635580708, 1.095354359848603)
    r = solve_path(stack4, _bezier(a, c, b, 60), max_jump=MAX_JUMP)
    assert r.success
    assert_valid_path(stack4, r)
    assert r.info["reanchored"] == 1 and r.info["transit_abandoned"] == 1
    assert r.info["default"] == 2


def test_reanchoring_screen_is_the_default_solve_with_slow_starts_cut_short(stack4):
    # waypoint 20 of the n = 4 benchmark's curved path 1: two of the default solve's
    # three starts take 112 and 89 iterations, the best one 15; the check's screen (the
    # same starts, options and selection with 10 n = 40 iterations a start) returns the
    # default solve's pose; with rng, the seed of the waypoint's default solve
    from stackik.paths.reanchor import _screen
    from stackik.paths.request import _request

    t = PlanarTarget(-577.4463669760025, 746.0050920668673, 1.0064166443992248)
    req = _request(stack4, [t], MAX_JUMP, "fast", 0.0, False, 1, None, None, None, 6, None,
                   None)  # fmt: skip
    found = _screen(req, t, 20)
    assert found is not None
    r = solve_ik(stack4, t)
    np.testing.assert_array_equal(found[0], r.q)
    assert found[1] == pytest.approx(r.frobenius_norm, rel=1e-12)
    req7 = _request(stack4, [t], MAX_JUMP, "fast", 0.0, False, 1, None, None, None, 6, 7,
                    None)  # fmt: skip
    np.testing.assert_array_equal(_screen(req7, t, 20)[0], req7.default_solve(t, 20).q)


def test_transit_step_must_come_a_quarter_jump_closer():
    # closer(), the transit step both modes share: the transit pose and its distance to
    # the goal when it ends more than TRANSIT_PROGRESS jumps closer than dist, else None
    # (also when there is no transit pose); dist = inf (a first step): any transit pose
    from stackik.paths.transit import (
        FAST_TRANSIT_GAIN,
        GLOBAL_TRANSIT_GAIN,
        TRANSIT_GAIN,
        TRANSIT_PROGRESS,
        closer,
    )

    class Stub:
        def __init__(self, qt):
            self.qt = qt

        def transit(self, q, target, goal):
            return self.qt

        def ratio(self, qa, qb):
            return float(np.max(np.abs(qb - qa)))

    goal = np.zeros((2, 3))
    qt = np.full((2, 3), 0.5)
    tr = Stub(qt)
    got = closer(tr, goal + 1.0, A, goal, 0.5 + TRANSIT_PROGRESS + 1e-9)
    assert got is not None and got[0] is qt and got[1] == 0.5
    assert closer(tr, goal + 1.0, A, goal, 0.5 + TRANSIT_PROGRESS) is None  # not closer
    first = closer(tr, goal + 1.0, A, goal, math.inf)
    assert first is not None and first[0] is qt and first[1] == 0.5
    assert closer(Stub(None), goal + 1.0, A, goal, math.inf) is None
    # the two gains keep their values (fast 1 %, global 0.5 %; the old name is global's)
    assert (FAST_TRANSIT_GAIN, GLOBAL_TRANSIT_GAIN, TRANSIT_GAIN) == (0.01, 0.005, 0.005)


def test_fast_mode_leaves_a_branch_that_ends_at_a_limit_wall(tmp_path, monkeypatch):
    # n = 8: the branch the fast path follows ends at a joint limit before waypoint 45,
    # where a bounded step that finds no continuation leaves the path there (the compiled
    # interior point's bounded step gets through: monkeypatched away here, and so are the
    # SQP engine's bounded steps, which since issue 14 (penalty following the multipliers,
    # least-norm second-order correction) get through as well; the SQP engine still takes
    # every transit step); the path reaches that waypoint's default pose by transit steps
    # walked back from it (a spliced detour) instead of breaking; resuming after the
    # splice gives the same
    import stackik.paths.continuation as continuation

    sqp_step = continuation.bounded_step

    def transit_only(*args, **kw):
        return None if kw.get("goal") is None else sqp_step(*args, **kw)

    stack = Stack.reference(8, leg_radius=0.0)
    a = PlanarTarget(1390.7857889700388, 1760.292531041743, -2.023119966011402)
    b = PlanarTarget(178.77968731850942, 2078.076457656921, -0.022992853149510606)
    pts = interpolate_targets([a, b], steps=59)
    ip = solve_path(stack, pts, max_jump=MAX_JUMP)  # the compiled bounded step gets through
    assert ip.success and ip.info["how"].get("rejoin", 0) == 0 and ip.info["bounded"] >= 1
    assert_valid_path(stack, ip)
    monkeypatch.setattr(continuation, "bounded_ip", lambda *a, **k: None)
    monkeypatch.setattr(continuation, "bounded_step", transit_only)
    ck = tmp_path / "ck.jsonl"
    r = solve_path(stack, pts, max_jump=MAX_JUMP, checkpoint=ck)
    assert r.success, r.message
    assert r.info.get("rejoined", 0) >= 1 and r.info["how"].get("rejoin", 0) >= 1
    assert_valid_path(stack, r)
    lines = ck.read_text().splitlines(keepends=True)
    cut = next(i for i, ln in enumerate(lines) if '"many"' in ln) + 2
    ck.write_text("".join(lines[:cut]))
    resumed = solve_path(stack, pts, max_jump=MAX_JUMP, checkpoint=ck)
    np.testing.assert_array_equal(resumed.q, r.q)


def test_start_pose_is_kept(stack4, planar_path, fast_result):
    q0 = solve_ik(stack4, A, method="ip", starts=1).q  # the paper's guess, one start
    r = solve_path(stack4, planar_path, max_jump=MAX_JUMP, start=q0)
    np.testing.assert_array_equal(r.q[0], q0)
    assert_valid_path(stack4, r)


def test_path_leaving_the_workspace_breaks_with_its_index(stack4):
    pts = interpolate_targets([A, OUT], steps=12)
    r = solve_path(stack4, pts, max_jump=MAX_JUMP)
    assert not r.success and r.status is PathStatus.UNREACHABLE
    k = r.completed
    assert 0 < k < r.m and r.break_index == k
    assert f"index {k}" in r.message and "outside the workspace" in r.message
    assert_valid_path(stack4, r)
    assert not solve_ik(stack4, pts[k]).success  # the break is real
    g = solve_path(stack4, pts, max_jump=MAX_JUMP, mode="global")
    assert g.status is PathStatus.UNREACHABLE and g.completed == k
    assert_valid_path(stack4, g)


def test_too_coarse_steps_break_as_jump_and_refine_gets_through(stack4):
    mj = (20.0, 0.1)
    pts = interpolate_targets([A, B], steps=3)
    r = solve_path(stack4, pts, max_jump=mj)
    assert r.status is PathStatus.JUMP and r.completed < r.m
    assert f"index {r.completed}" in r.message and "max_jump" in r.message
    assert_valid_path(stack4, r)
    f = solve_path(stack4, pts, max_jump=mj, refine=True)
    assert f.success, f.message
    assert_valid_path(stack4, f)
    assert f.m > r.m
    assert {0.0, 1.0, 2.0, 3.0} <= set(f.source.tolist())
    assert np.any(f.source % 1 != 0)
    for t, s in zip(f.targets, f.source):  # inserted waypoints lie on the segments
        lo = int(math.floor(s))
        ref = pts[lo] if s == lo else lerp_target(pts[lo], pts[lo + 1], s - lo)
        np.testing.assert_allclose(t.y, ref.y, atol=1e-9)


def test_spatial_path():
    stack = Stack.reference(2, leg_radius=0.0)
    qa = np.array([[0, 0, 380, 0, 0, 0], [0, 0, 380, 0, 0, 0.0]])
    qb = np.array([[30, -20, 360, 0.1, 0.05, -0.05], [40, 10, 370, 0.15, -0.05, 0.1]])
    ta, tb = (SpatialTarget(*spatial_forward(q)) for q in (qa, qb))
    pts = interpolate_targets([ta, tb], steps=4)
    r = solve_path(stack, pts, max_jump=MAX_JUMP)
    assert r.success and r.q.shape == (5, 2, 6)
    assert_valid_path(stack, r)
    assert r.step_jumps.shape == (4, 2)
    tight = solve_path(stack, pts, max_jump=(5.0, 0.02))  # forces bounded steps or a break
    assert_valid_path(stack, tight)
    assert tight.success or tight.status in (PathStatus.JUMP, PathStatus.UNREACHABLE)


def test_tight_jump_limit_uses_bounded_steps_and_never_violates_it(stack4, planar_path):
    r = solve_path(stack4, planar_path, max_jump=(25.0, 0.08))
    assert_valid_path(stack4, r)
    assert r.info["bounded"] > 0


# =========================================================================================
# Time parameterisation
# =========================================================================================
def _rates(L, t):
    """Finite differences written out here (independent of leg_rates)."""
    v = [(L[k + 1] - L[k]) / (t[k + 1] - t[k]) for k in range(len(t) - 1)]
    a = []
    for k in range(len(t)):
        v_in = v[k - 1] if k > 0 else np.zeros_like(L[0])
        v_out = v[k] if k < len(t) - 1 else np.zeros_like(L[0])
        h_in = t[k] - t[k - 1] if k > 0 else 0.0
        h_out = t[k + 1] - t[k] if k < len(t) - 1 else 0.0
        a.append(2 * (v_out - v_in) / (h_in + h_out))
    return np.array(v), np.array(a)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_time_parameterization_respects_speed_and_acceleration(seed):
    rng = np.random.default_rng(seed)
    L = 350 + np.cumsum(rng.normal(0, 8, (30, 2, 6)), axis=0)
    L[10:14] = L[10]  # a pause: no leg moves
    vmax, amax = 80.0, 150.0
    t = time_parameterize(L, leg_speed=vmax, leg_accel=amax)
    assert t.shape == (30,) and t[0] == 0 and np.all(np.diff(t) > 0)
    v, a = _rates(L, t)
    assert np.abs(v).max() <= vmax * (1 + 1e-9)
    assert np.abs(a).max() <= amax * (1 + 1e-9)
    # not needlessly slow: some limit is nearly reached
    assert max(np.abs(v).max() / vmax, np.abs(a).max() / amax) > 0.99
    v2, a2 = leg_rates(L, t)
    np.testing.assert_allclose(v2, v)
    np.testing.assert_allclose(a2, a)


def test_solved_path_times(stack4, fast_result):
    r = fast_result
    assert r.times is not None and r.times[0] == 0
    v, a = _rates(r.leg_lengths, r.times)
    assert np.abs(v).max() <= 150.0 * (1 + 1e-9)
    assert np.abs(a).max() <= 300.0 * (1 + 1e-9)
    np.testing.assert_array_equal(time_parameterize(r, leg_speed=150.0, leg_accel=300.0), r.times)
    with pytest.raises(ValueError, match="leg_speed"):
        time_parameterize(r, leg_speed=-1.0, leg_accel=1.0)


# =========================================================================================
# Files and checkpoints
# =========================================================================================
def test_json_round_trip(stack4, fast_result, tmp_path):
    broken = solve_path(stack4, interpolate_targets([A, OUT], steps=12), max_jump=MAX_JUMP)
    for r in (fast_result, broken):
        back = PathResult.from_json(r.to_json(tmp_path / "p.json"))
        again = PathResult.from_json(tmp_path / "p.json")
        for b in (back, again):
            np.testing.assert_array_equal(b.q, r.q)
            np.testing.assert_array_equal(b.frobenius_norm, r.frobenius_norm)
            np.testing.assert_array_equal(b.leg_lengths, r.leg_lengths)
            np.testing.assert_array_equal(b.margins, r.margins)
            np.testing.assert_array_equal(b.source, r.source)
            assert (b.times is None) == (r.times is None)
            if r.times is not None:
                np.testing.assert_array_equal(b.times, r.times)
            assert (b.status, b.message, b.completed, b.success) == (
                r.status, r.message, r.completed, r.success
            )  # fmt: skip
            assert [t.y.tolist() for t in b.targets] == [t.y.tolist() for t in r.targets]
    json.loads((tmp_path / "p.json").read_text())  # plain JSON (NaN written as null)
    assert "NaN" not in (tmp_path / "p.json").read_text()


def test_csv_round_trip(stack4, fast_result, tmp_path):
    broken = solve_path(stack4, interpolate_targets([A, OUT], steps=12), max_jump=MAX_JUMP)
    for r in (fast_result, broken):
        d = read_path_csv(r.to_csv(tmp_path / "p.csv"))
        np.testing.assert_array_equal(d["q"], r.q)
        np.testing.assert_array_equal(d["frobenius_norm"], r.frobenius_norm)
        np.testing.assert_array_equal(d["leg_lengths"], r.leg_lengths)
        np.testing.assert_array_equal(d["margins"], r.margins)
        if r.times is None:
            assert d["times"] is None
        else:
            np.testing.assert_array_equal(d["times"], r.times)
        assert [t.y.tolist() for t in d["targets"]] == [t.y.tolist() for t in r.targets]
    header = (tmp_path / "p.csv").read_text().splitlines()[0].split(",")
    assert header[:4] == ["index", "source", "time_s", "target_rho"]
    assert "p4_theta" in header and "p4_leg5" in header and "p4_margin_joint_top" in header


def test_spatial_csv_round_trip(tmp_path):
    stack = Stack.reference(2, leg_radius=0.0)
    q = np.array([[0, 0, 380, 0, 0, 0], [10, 0, 380, 0.1, 0, 0.0]])
    t = SpatialTarget(*spatial_forward(q))
    r = solve_path(stack, [t], start=q)
    d = read_path_csv(r.to_csv(tmp_path / "s.csv"))
    np.testing.assert_array_equal(d["q"], r.q)
    np.testing.assert_array_equal(d["targets"][0].rotation, t.rotation)


@pytest.mark.parametrize("mode", ["fast", "global"])
def test_checkpoint_resume_gives_the_uninterrupted_result(stack4, mode, tmp_path):
    pts = interpolate_targets([A, B], steps=8)
    ck = tmp_path / "ck.jsonl"
    full = solve_path(stack4, pts, max_jump=(25.0, 0.08), mode=mode, checkpoint=ck)
    lines = ck.read_text().splitlines(keepends=True)
    assert len(lines) > 4
    # interrupted: keep the header and three records, then a torn line
    ck.write_text("".join(lines[:4]) + lines[4][: len(lines[4]) // 2])
    resumed = solve_path(stack4, pts, max_jump=(25.0, 0.08), mode=mode, checkpoint=ck)
    np.testing.assert_array_equal(resumed.q, full.q)
    assert resumed.status is full.status
    assert len(ck.read_text().splitlines()) == len(lines)
    # everything recorded: the rerun only reads
    again = solve_path(stack4, pts, max_jump=(25.0, 0.08), mode=mode, checkpoint=ck)
    np.testing.assert_array_equal(again.q, full.q)
    assert again.info.get("warm", 0) == 0 and again.info.get("bounded", 0) == 0
    with pytest.raises(ValueError, match="different path"):
        solve_path(stack4, pts[:-1], max_jump=(25.0, 0.08), mode=mode, checkpoint=ck)


def test_refined_path_checkpoint_resume(stack4, tmp_path):
    pts = interpolate_targets([A, B], steps=3)
    ck = tmp_path / "ck.jsonl"
    full = solve_path(stack4, pts, max_jump=(20.0, 0.1), refine=True, checkpoint=ck)
    lines = ck.read_text().splitlines(keepends=True)
    for cut in (3, len(lines) // 2, len(lines) - 1):
        ck.write_text("".join(lines[:cut]))
        resumed = solve_path(stack4, pts, max_jump=(20.0, 0.1), refine=True, checkpoint=ck)
        np.testing.assert_array_equal(resumed.q, full.q)
        np.testing.assert_array_equal(resumed.source, full.source)


# =========================================================================================
# Figures and the command line
# =========================================================================================
def test_animation_and_plot(stack4, fast_result, tmp_path):
    pytest.importorskip("matplotlib")
    from PIL import Image

    from stackik.paths.animate import animate_path, default_caption, plot_path, stack_nodes

    nd = stack_nodes(stack4, fast_result, 3)
    L = np.linalg.norm(nd["top"] - nd["base"], axis=-1)
    np.testing.assert_allclose(L, fast_result.leg_lengths[3], atol=1e-9)
    np.testing.assert_allclose(nd["O"][-1][[0, 2]], fast_result.targets[3].y[:2], atol=1e-6)
    files = animate_path(fast_result, stack4, tmp_path / "a.gif", max_frames=3, dpi=40, mp4=False)
    assert files == [tmp_path / "a.gif"]
    with Image.open(files[0]) as im:
        assert im.n_frames == 3
    fig = plot_path(fast_result, stack4, tmp_path / "p.png")
    assert (tmp_path / "p.png").stat().st_size > 0
    assert "4-platform stack" in default_caption(fast_result)
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_cli_path_smoke(tmp_path):
    pytest.importorskip("matplotlib")
    from stackik.cli import main

    out = tmp_path / "out"
    rc = main(
        ["path", "--n", "4", "--from", "600", "1000", "-1.57", "--to", "145", "1500", "-0.207",
         "--steps", "6", "--max-jump", "60", "0.3", "--leg-speed", "100", "--frames", "3",
         "--out", str(out), "--json"]
    )  # fmt: skip
    assert rc == 0
    for name in ("path.csv", "path.json", "path.png", "path.gif"):
        assert (out / name).stat().st_size > 0
    r = PathResult.from_json(out / "path.json")
    assert r.success and r.m == 7 and r.times is not None


def test_cli_path_csv_break_and_errors(tmp_path, capsys):
    from stackik.cli import main

    wp = tmp_path / "wp.csv"
    rows = ["rho,z,theta"] + [f"{600 + 190 * j},1000,{-1.57 + 0.157 * j}" for j in range(11)]
    wp.write_text("\n".join(rows) + "\n")
    rc = main(["path", "--csv", str(wp), "--out", str(tmp_path / "o"), "--no-animation"])
    assert rc == 1  # leaves the workspace, or a step above the jump limit
    text = capsys.readouterr().out
    assert "the path breaks at index" in text
    assert (tmp_path / "o" / "path.csv").exists()
    assert main(["path", "--from", "600", "1000", "--to", "1", "2", "3"]) == 2
    assert main(["path", "--out", str(tmp_path / "x")]) == 2
    assert main(["path", "--from", "600", "1000", "-1.57", "--to", "145", "1500", "-0.207",
                 "--max-jump", "0", "0.3", "--out", str(tmp_path / "y")]) == 2  # fmt: skip
    err = capsys.readouterr().err
    assert "stackik: error:" in err


def test_tracker_follow_keeps_the_paths_carried_state(stack4):
    # a fast path's goal basin is followed by the continuation step with its own state:
    # the path's carried state (multipliers of its last pose) is left as it was
    from stackik.paths.continuation import Tracker
    from stackik.sampling import random_reachable_targets

    a, b = random_reachable_targets(stack4, 2, rng=21)
    pts = interpolate_targets([a, b], max_step=(15.0, 0.03))
    tr = Tracker(stack4, True, (60.0, 0.3))
    q0 = solve_ik(stack4, pts[0]).q
    run = tr.warm_many(q0, pts[1:3])
    assert len(run) == 2
    carry, tried = tr._carry, tr.tried_from
    g = tr.follow(q0, pts[1])
    assert g is not None and check_pose(stack4, pts[1], g).ok
    assert tr.ratio(q0, g) <= 1.0
    assert tr._carry is carry and tr.tried_from is tried
    assert tr._side_carry is not None and tr._side_carry[0] is g


def test_checkpoint_without_the_reanchoring_schedule_resumes_reanchoring(stack4, tmp_path):
    # a checkpoint written before records carried the reanchoring schedule: a resumed
    # path still checks at the next multiple of reanchor_every (not never)
    from stackik.sampling import random_reachable_targets

    a, c = random_reachable_targets(stack4, 2, rng=31)
    pts = interpolate_targets([a, c], steps=39)
    ck = tmp_path / "full.jsonl"
    full = solve_path(stack4, pts, max_jump=(60.0, 0.3), reanchor_every=5, checkpoint=ck)
    assert full.info["default"] >= 3
    lines = ck.read_text().splitlines()
    kept = [lines[0]]
    for line in lines[1:]:
        rec = json.loads(line)
        if rec.get("index", 0) > 12 or "many" in rec:
            continue
        if isinstance(rec.get("value"), dict):
            rec["value"].pop("reanchor", None)
        kept.append(json.dumps(rec))
    legacy = tmp_path / "legacy.jsonl"
    legacy.write_text("\n".join(kept) + "\n")
    res = solve_path(stack4, pts, max_jump=(60.0, 0.3), reanchor_every=5, checkpoint=legacy)
    assert res.success and res.info["default"] >= 1
    assert res.mean_frobenius_norm == pytest.approx(full.mean_frobenius_norm, rel=1e-3)


def _spatial_bench_curve() -> list[SpatialTarget]:
    """The path bench's curved spatial n = 4 path with 60 waypoints (bench_path.py, seed
    2030, curved path 1): a quadratic Bezier in position, slerp in orientation."""
    keys = [
        SpatialTarget(
            [-353.1201960044432, -276.8081744379765, 1257.94545884039],
            [[0.7233143083014085, -0.26540594155623015, -0.6374763506147548],
             [-0.07621160449627626, 0.8868607702725511, -0.4557079826947084],
             [0.6863003735585155, 0.3782031997990346, 0.6212520719604996]],
        ),
        SpatialTarget(
            [265.0896321489826, -57.65374037992752, 1351.1912831058594],
            [[0.9891673312083602, 0.13808302116280854, -0.04981034166397424],
             [-0.13576631887183088, 0.9896138032313547, 0.04724433419962697],
             [0.055816642053448655, -0.03996998524549488, 0.9976406681512899]],
        ),
        SpatialTarget(
            [99.45783474001013, 167.83827022474378, 1295.3047471834857],
            [[0.9866960335395302, 0.15957211384305828, -0.031107521293352678],
             [-0.148724067127619, 0.9632349722115681, 0.2237398939965762],
             [0.06566650024462882, -0.21613682886597016, 0.9741523402186048]],
        ),
    ]  # fmt: skip
    a, c, b = keys
    pts = []
    for s in np.linspace(0.0, 1.0, 60):
        p = (1 - s) ** 2 * a.position + 2 * s * (1 - s) * c.position + s**2 * b.position
        pts.append(SpatialTarget(p, slerp(a.rotation, b.rotation, float(s))))
    pts[0], pts[-1] = a, b
    return pts


def test_spatial_fast_mode_reanchors_by_default_and_keeps_fn_within_3_percent(stack4):
    # the curved spatial n = 4 benchmark path: without re-anchoring its mean FN is 3.2 %
    # above the per-waypoint optima; the default check at waypoint 20 finds a better
    # basin 15 jumps away, transit steps move the path towards it (after 9 steps the
    # goal's barrier solve does not converge, with any iteration cap: the goal is
    # dropped) and
    # bounded steps, boxed solve first (off the optimum), take it into a better basin;
    # the abandoned transit backs the checks off (next at 20 + 40 = 60, past the end:
    # two default solves, waypoint 0 and the check)
    pts = _spatial_bench_curve()
    ref = np.mean([solve_ik(stack4, t).frobenius_norm for t in pts])
    r = solve_path(stack4, pts, max_jump=MAX_JUMP)
    assert r.success
    assert_valid_path(stack4, r)
    assert r.info["reanchored"] == 1 and r.info["transit"] >= 1
    assert r.info["transit_abandoned"] == 1 and r.info["default"] == 2
    assert r.mean_frobenius_norm <= 1.03 * ref
    stay = solve_path(stack4, pts, max_jump=MAX_JUMP, reanchor_every=0)
    assert stay.success
    assert stay.mean_frobenius_norm > 1.03 * ref
    again = solve_path(stack4, pts, max_jump=MAX_JUMP)
    np.testing.assert_array_equal(again.q, r.q)  # deterministic


def test_spatial_default_reanchoring_up_to_four_platforms():
    # a spatial check costs ~20 warm steps at n = 4; from n = 5 (then 18 starts and 12
    # hops) 40-70, and on the benchmark's n = 8 paths it found no better path: off
    from stackik.paths.request import _request

    for n, every in ((2, 20), (4, 20), (5, 0), (8, 0), (16, 0)):
        stack = Stack.reference(n, leg_radius=0.0)
        t = SpatialTarget(*spatial_forward(np.tile([0.0, 0.0, 380.0, 0.0, 0.0, 0.0], (n, 1))))
        req = _request(stack, [t, t], MAX_JUMP, "fast", 0.0, False, 1, None, None, None, 6,
                       None, None)  # fmt: skip
        assert req.reanchor_every == every


def test_tracker_box_first_step_is_warm_inside_the_box(stack4):
    # off the optimum, a spatial fast path's ladder tries the boxed solve first: a small
    # step from a solved pose ends inside the box (a minimum without it, "warm"); a tight
    # jump limit leaves a variable at the box ("bounded"); both checked, within one jump
    from stackik._compiled.check import spatial_check_many
    from stackik.paths.continuation import BOX_INSIDE, Tracker

    pts = _spatial_bench_curve()
    q0 = solve_ik(stack4, pts[0]).q
    tr = Tracker(stack4, False, MAX_JUMP)
    st = tr.step(q0, pts[0], pts[1], box_first=True)
    assert st is not None and st.how == "warm"
    assert tr.ratio(q0, st.q) <= BOX_INSIDE
    assert spatial_check_many(stack4, [pts[1]], st.q[None])[0]
    assert tr.counts.bounded == 1 and tr.counts.warm == 0
    tight = Tracker(stack4, False, (10.0, 0.03))
    st = tight.step(q0, pts[0], pts[1], box_first=True)
    assert st is not None and st.how == "bounded"
    assert BOX_INSIDE < tight.ratio(q0, st.q) <= 1.0
    assert check_pose(stack4, pts[1], st.q).ok
    assert tight.counts.bounded == 1 and tight.counts.warm == 0


def test_spatial_tracker_follow_drops_a_goal_whose_barrier_solve_does_not_converge(
    stack4, monkeypatch
):
    # spatial: a goal pose without a carried state takes a barrier solve with at most
    # FOLLOW_MAX_ITER iterations; follow gives the goal up (None, no slow warm retry)
    # when that solve reaches the target without converging (its pose is no minimum to
    # follow) and when it reaches nothing
    import stackik.paths.continuation as cont

    pts = _spatial_bench_curve()
    q0 = solve_ik(stack4, pts[0]).q
    tr = cont.Tracker(stack4, False, MAX_JUMP)
    g = tr.follow(q0, pts[1])
    assert g is not None and check_pose(stack4, pts[1], g).ok
    # 4 iterations: the polished point reaches the target, the solve has not converged
    monkeypatch.setattr(cont, "FOLLOW_MAX_ITER", 4)
    probe = cont.Tracker(stack4, False, MAX_JUMP)
    assert len(probe.warm_many(q0, [pts[1]], max_iter=4)) == 1
    assert probe._carry is not None and not probe._carry[1][3]  # have: not converged
    tr = cont.Tracker(stack4, False, MAX_JUMP)
    assert tr.follow(q0, pts[1]) is None
    assert tr._side_carry is None and tr.counts.warm_retry == 0
    # 1 iteration: nothing reached
    monkeypatch.setattr(cont, "FOLLOW_MAX_ITER", 1)
    tr = cont.Tracker(stack4, False, MAX_JUMP)
    assert tr.follow(q0, pts[1]) is None
    assert tr._side_carry is None and tr.counts.warm_retry == 0


@pytest.mark.parametrize(("mode", "refine"), [("fast", False), ("fast", True), ("global", True)])
def test_unreachable_first_waypoint_keeps_every_waypoint(mode, refine):
    """Waypoint 0 outside the workspace: every mode reports all the input waypoints, none
    reached, and says where it breaks (global mode with refine=True once raised on the
    refining pass's empty waypoint list; fast mode reported no waypoints)."""
    stack = Stack.reference(2, leg_radius=0.0)
    pts = interpolate_targets(
        [PlanarTarget(5000.0, 600.0, 0.0), PlanarTarget(300.0, 600.0, 0.0)], steps=4
    )
    r = solve_path(stack, pts, max_jump=MAX_JUMP, mode=mode, refine=refine)
    assert r.status is PathStatus.UNREACHABLE and r.completed == 0
    assert r.m == len(pts) and r.break_index == 0
    np.testing.assert_array_equal(r.source, np.arange(len(pts), dtype=float))
    assert "index 0 (waypoint 0)" in r.message


def test_global_refine_break_names_its_source(stack4):
    """With refine=True, global mode runs over the refining pass's waypoints; its break
    message names the waypoint as the input counts it, as the result's ``source`` does."""
    from stackik.paths.report import _source_text

    pts = interpolate_targets([A, OUT], steps=6)
    g = solve_path(stack4, pts, max_jump=MAX_JUMP, mode="global", refine=True)
    assert g.status is PathStatus.UNREACHABLE
    k = g.break_index
    assert k is not None and f"index {k} ({_source_text(g.source[k])})" in g.message
