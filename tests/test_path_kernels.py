"""The compiled kernels of path steps: the box and distance extensions of the interior
point (derivatives by finite differences, tests/fd.py), the boxed solve, the run of warm
steps (the same points as the one-start solve) and the batch check."""

from __future__ import annotations

import fd
import numpy as np
import pytest

from stackik._arrays import readonly
from stackik._compiled import barrier as _barrier
from stackik._compiled import core as _ip_core
from stackik._compiled import path as _ip_paths
from stackik._compiled import planar as _ipm
from stackik._compiled import planar_path as _ipm_path
from stackik._compiled import spatial as _spatial_ipm
from stackik._compiled import spatial_path as _spatial_ipm_path
from stackik._compiled.check import (
    _spatial_check,
    planar_check,
    planar_check_many,
    spatial_check_many,
)
from stackik.check import check_pose
from stackik.formulation import POLISH_MARGIN, POLISH_REACH, Problem
from stackik.geometry import Stack
from stackik.methods.ip import problem_arrays, spatial_problem_arrays
from stackik.paths import interpolate_targets
from stackik.sampling import random_reachable_targets, random_spatial_targets
from stackik.solve import solve_ik
from stackik.starts import paper_initial_guess

#: No carried state: the arguments of a run from a point that is not a solved one.
_NO_STATE3 = (np.zeros(3), np.zeros(0), np.zeros(0, dtype=bool), False, np.zeros(0))
#: ip_multi's path-step extensions, none: no box (lo, hi), no distance term (ug, wq)
_NO_BOX = (np.zeros(0), np.zeros(0), np.zeros(0), 0.0)


def _planar(n: int, seed: int):
    stack = Stack.reference(n, leg_radius=0.0)
    t = random_reachable_targets(stack, 1, rng=seed)[0]
    prob = Problem(stack, t, "frobenius", None)
    rng = np.random.default_rng(seed)
    q = paper_initial_guess(stack, t)
    q[:, :2] += rng.normal(0, 40, (n, 2))
    q[:, 2] += rng.normal(0, 0.2, n)
    return prob, prob.u_of(q), problem_arrays(prob), rng


def _spatial(n: int, seed: int):
    stack = Stack.reference(n, leg_radius=0.0)
    t = random_spatial_targets(stack, 1, seed)[0]
    prob = Problem(stack, t, "frobenius", None)
    rng = np.random.default_rng(seed)
    q = paper_initial_guess(stack, t)
    q = q + rng.normal(size=q.shape) * np.array([30, 30, 30, 0.3, 0.3, 0.3])
    return prob, prob.u_of(q), spatial_problem_arrays(prob), rng


def _straight_run(n: int, seed: int):
    """A straight planar path in 15 mm / 0.03 rad steps, the default solve's pose at its
    first waypoint, that waypoint's problem and kernel arrays."""
    stack = Stack.reference(n, leg_radius=0.0)
    a, b = random_reachable_targets(stack, 2, rng=seed)
    pts = interpolate_targets([a, b], max_step=(15.0, 0.03))
    q0 = solve_ik(stack, pts[0]).q
    prob = Problem(stack, pts[0], "frobenius", None)
    return stack, pts, q0, prob, problem_arrays(prob)


def _dense(D: np.ndarray) -> np.ndarray:
    """Blocks (n, R, k) -> the dense (R n, k n) Jacobian."""
    n, R, k = D.shape
    full = np.zeros((n, R, n, k))
    full[np.arange(n), :, np.arange(n), :] = D
    return full.reshape(R * n, k * n)


@pytest.mark.derivatives
@pytest.mark.parametrize(("planar", "n", "seed"), [(True, 2, 1), (True, 5, 2), (False, 2, 3)])
def test_extended_problem_derivatives_by_finite_differences(planar, n, seed):
    """Gradient of the distance term, the box rows' Jacobian and the extended Lagrangian
    Hessian (box multipliers included, which must not enter it) against central
    differences; scales from the terms (fd.term_scale), as the spatial IP's test."""
    prob, u, P, rng = (_planar if planar else _spatial)(n, seed)
    k = 3 if planar else 6
    R = 24 + 2 * k
    mod = _ipm if planar else _spatial_ipm
    ev = mod._evaluate_ext
    lo, hi = readonly(u - 0.05), readonly(u + 0.07)
    ug = readonly(u + rng.normal(0, 0.1, u.size))
    wq = 3.7

    def parts(v):
        out = ev(v, P, lo, hi, ug, wq)
        return out[0], out[1], out[2], out[3], out[4], _dense(out[5])

    f, g, cE, AE, cI, AI = parts(u)
    assert cI.shape == (R * n,) and AI.shape == (R * n, k * n)
    # without extensions: the base evaluation, unchanged
    base = ev(u, P, readonly(np.zeros(0)), readonly(np.zeros(0)), readonly(np.zeros(0)), 0.0)
    np.testing.assert_array_equal(base[4], mod._evaluate(u, P)[4])
    assert base[0] == mod._evaluate(u, P)[0]
    num = fd.central(lambda v: parts(v)[0], u)
    fd.assert_derivative_close(g, num, f_scale=fd.term_scale(f, num), what="grad f + distance")
    num = fd.central(lambda v: parts(v)[4], u)
    fd.assert_derivative_close(AI, num, f_scale=fd.term_scale(cI, num), what="A_I with box")
    yE = rng.normal(size=3 if planar else 6)
    z = rng.uniform(0, 2, size=R * n)

    def lag_grad(v):
        f_, g_, cE_, AE_, cI_, AI_ = parts(v)
        return g_ - AE_.T @ yE - AI_.T @ z

    if planar:
        H = _ipm._lagrangian_hessian_ext(u, yE, z, P, wq)
    else:
        H = _spatial_ipm.lagrangian_hessian_ext(u, yE, z, P, lo, hi, ug, wq)
    num = fd.central(lag_grad, u)
    fd.assert_derivative_close(H, num, f_scale=fd.term_scale(lag_grad(u), num), what="W ext")


def test_ip_box_stays_in_its_box_and_ip_path_repeats_the_one_start_solve():
    stack = Stack.reference(4, leg_radius=0.0)
    a, b = random_reachable_targets(stack, 2, rng=5)
    pts = interpolate_targets([a, b], steps=12)
    q0 = solve_ik(stack, pts[0]).q
    prob = Problem(stack, pts[0], "frobenius", None)
    P = problem_arrays(prob)
    # the run of warm steps: the points of _ip_multi from the previous point, bit for bit
    Y = readonly([[t.rho, t.z, t.theta] for t in pts[1:]])
    X, reached, how = _ipm_path.ip_path(
        readonly(prob.u_of(q0)), Y, P, readonly(np.full(12, np.inf)), 1e-7, 1e-9, 1e-3, 300,
        POLISH_REACH, POLISH_MARGIN, 1e-6, 1e-8, False, *_NO_STATE3,
    )[:3]  # fmt: skip
    assert reached >= 1 and not how.any()
    u = prob.u_of(q0)
    for j in range(reached):
        Pj = problem_arrays(Problem(stack, pts[j + 1], "frobenius", None))
        Xj = _barrier.ip_multi(np.atleast_2d(u), Pj, 1e-7, 1e-9, np.array([1e-3]), 300, 1e300,
                              3, POLISH_REACH, POLISH_MARGIN, *_NO_BOX, True)[0]  # fmt: skip
        np.testing.assert_array_equal(X[j], Xj[0])
        u = Xj[0]
    # a box around q0 for the next target: the converged solve lies inside it (an
    # unconverged one need not: the caller checks the jump), on its wall for a tight box
    prob1 = Problem(stack, pts[1], "frobenius", None)
    u0 = readonly(prob1.u_of(q0))
    none = readonly(np.zeros(0))
    walls = []
    for half in (0.1, 0.02):
        box = half * np.array([1.0, 1.0, 3.0] * 4) / prob1.xs * prob1.xs[0]
        lo, hi = readonly(u0 - box), readonly(u0 + box)
        x, st, _ = _barrier.ip_box(u0, problem_arrays(prob1), lo, hi, none, 0.0, 1e-7, 1e-9,
                                   1e-3, 300, POLISH_REACH, POLISH_MARGIN)  # fmt: skip
        if st == _ip_core.IP_SUCCESS:
            assert np.all(x >= lo - 1e-9) and np.all(x <= hi + 1e-9)
            walls.append(float(np.min(np.minimum(x - lo, hi - x))))
    assert walls and walls[0] > 0.0


def test_batch_check_matches_the_check_pose_by_pose():
    stack = Stack.reference(3, leg_radius=0.0)
    ts = random_reachable_targets(stack, 4, rng=8, phi=0.4)
    Q = np.stack([solve_ik(stack, t).q for t in ts])
    Q[2, 1, 0] += 1.0  # misses its target
    Q[3] = Q[0]  # another target's pose
    ok = planar_check_many(stack, ts, Q)
    assert ok == [planar_check(stack, t, q)[0].ok for t, q in zip(ts, Q)]
    assert ok[:2] == [True, True] and ok[2:] == [False, False]
    assert planar_check_many(stack, [], np.zeros((0, 3, 3))) == []


@pytest.mark.parametrize(("n", "seed"), [(4, 5), (8, 11)])
def test_ip_path_continuation_steps_are_verified_kkt_points_near_the_barrier_solve(n, seed):
    """The predictor-corrector steps (pc=True): most steps of a straight path are made by
    them; every point reaches its target within the limits (the independent check) with
    the objective of the barrier solve from the previous point (the same KKT point, or a
    neighbouring one that the continuation follows where the barrier solve slides to
    the other), and the run is deterministic."""
    stack, pts, q0, prob, P = _straight_run(n, seed)
    Y = readonly([[t.rho, t.z, t.theta] for t in pts[1:]])
    args = (readonly(prob.u_of(q0)), Y, P, readonly(np.full(3 * n, np.inf)), 1e-7, 1e-9,
            1e-3, 300, POLISH_REACH, POLISH_MARGIN, 1e-6, 1e-8, True, *_NO_STATE3)  # fmt: skip
    X, reached, how, *state = _ipm_path.ip_path(*args)
    X2, reached2, how2, *_ = _ipm_path.ip_path(*args)
    assert reached == reached2 and np.array_equal(X[:reached], X2[:reached])
    assert np.array_equal(how, how2)
    assert reached >= 5 and how[:reached].sum() >= reached // 2
    # two runs, the second from the first's last point with its state: the same points,
    # wherever the split (after the first step too: the history then holds the target
    # and the continuation count only; the secant and quadratic predictors start as in
    # the whole run)
    for h in sorted({1, 2, 3, reached // 2}):
        Xa, ra, _, *end = _ipm_path.ip_path(args[0], readonly(Y[:h]), *args[2:13], *_NO_STATE3)
        assert ra == h and end[3]
        Xb, rb, howb, *_ = _ipm_path.ip_path(readonly(Xa[h - 1]), readonly(Y[h:reached]),
                                        *args[2:13], *end)  # fmt: skip
        assert rb == reached - h and howb[0] == how[h]
        np.testing.assert_array_equal(np.concatenate([Xa[:h], Xb[:rb]]), X[:reached])
    Q = np.array([prob.q_of(X[j]) for j in range(reached)])
    assert all(planar_check_many(stack, pts[1 : reached + 1], Q))
    u = prob.u_of(q0)
    compared = 0
    for j in range(reached):
        prob_j = Problem(stack, pts[j + 1], "frobenius", None)
        Pj = problem_arrays(prob_j)
        if how[j]:
            Xj = _barrier.ip_multi(np.atleast_2d(u), Pj, 1e-7, 1e-9, np.array([1e-3]), 300,
                                  1e300, 3, POLISH_REACH, POLISH_MARGIN, *_NO_BOX,
                                  True)  # fmt: skip
            # where the barrier solve finds a pose (it may not: at n = 4, seed 5, one
            # step's barrier point violates a limit by 9 mm, where the continuation step
            # reaches a vertex of its limits, positive multipliers), the same local
            # minimum or (where it slides to a neighbouring one) a KKT point whose FN^2
            # differs by a fraction of a per mille
            if planar_check(stack, pts[j + 1], prob_j.q_of(Xj[0][0]))[0].ok:
                f_pc = _ipm._evaluate(X[j], Pj)[0]
                assert abs(f_pc - Xj[3][0]) <= 1e-3 * abs(Xj[3][0])
                compared += 1
        u = X[j]
    assert compared >= reached // 2


@pytest.mark.parametrize(("n", "seed"), [(4, 5), (4, 7), (8, 11)])
def test_ip_path_starts_with_a_continuation_step_from_least_squares_multipliers(n, seed):
    """A point without a carried state (the default solve's pose): its active limits and
    least-squares multipliers (_ls_state) are those of its own KKT point, so that the
    continuation step at its own target is verified without moving it, and a run from it
    starts with a continuation step instead of a barrier solve."""
    stack, pts, q0, prob, P = _straight_run(n, seed)
    u0 = prob.u_of(q0)
    yE, z, act = _ipm_path._ls_state(u0, P)
    assert act.any() and np.all(z[~act] == 0.0)
    x, ok, *_ = _ipm_path._pc_step(
        u0, P, yE, z, act, 1e-7, 1e-9, _ip_paths.PC_NEWTON, _ip_paths.PC_CHANGES
    )
    assert ok
    assert np.max(np.abs(x - u0)) <= 1e-6
    Y = readonly([[t.rho, t.z, t.theta] for t in pts[1:]])
    X, reached, how, *_ = _ipm_path.ip_path(
        readonly(u0), Y, P, readonly(np.full(3 * n, np.inf)), 1e-7, 1e-9, 1e-3, 300,
        POLISH_REACH, POLISH_MARGIN, 1e-6, 1e-8, True, *_NO_STATE3,
    )  # fmt: skip
    assert reached >= 1 and how[0] == 1
    Q = np.array([prob.q_of(X[j]) for j in range(reached)])
    assert all(planar_check_many(stack, pts[1 : reached + 1], Q))


def test_continuation_step_keeps_a_platform_in_a_corner_of_dependent_limits():
    """A default pose whose top platform meets 4 limits (leg_min of two legs, the base
    and top joint limits of a third, which coincide at parallel plates: 4 rows for 3
    variables): the continuation step at its own target keeps the dependent rows and
    verifies the point without moving it (it failed there, with a singular KKT matrix,
    moving the point by 2.8)."""
    stack = Stack.reference(4, leg_radius=0.0)
    t = random_reachable_targets(stack, 1, rng=30)[0]
    prob = Problem(stack, t, "frobenius", None)
    P = problem_arrays(prob)
    u = prob.u_of(solve_ik(stack, t).q)
    yE, z, act = _ipm_path._ls_state(u, P)
    _, _, _, _, cI, D = _ipm._evaluate(u, P)
    rows = np.nonzero(act & (_ip_paths._twins(act, cI, D) < 0))[0]
    assert np.bincount(rows // 24, minlength=4).max() > 3
    x, ok, *_ = _ipm_path._pc_step(
        u, P, yE, z, act, 1e-7, 1e-9, _ip_paths.PC_NEWTON, _ip_paths.PC_CHANGES
    )
    assert ok
    assert np.max(np.abs(x - u)) <= 1e-6


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_continuation_kkt_solve_by_platforms(seed):
    """The continuation step's KKT solve (_pc_kkt: each platform's active rows fix their
    part of dx, a reduced system the rest) against the dense KKT matrix: the same
    solution where the rows are independent; with 4 rows on a platform (consistent, as
    where base and top joint limits coincide) the exact solution and, of the
    multipliers' family, the least-norm one."""
    rng = np.random.default_rng(seed)
    n, N = 4, 12
    W = rng.normal(size=(N, N))
    W = W + W.T
    AE = rng.normal(size=(3, N))
    D = rng.normal(size=(n, 24, 3))
    idx = np.array([1, 5, 30, 50, 51, 72, 73, 74])
    r1, r2, rA = rng.normal(size=N), rng.normal(size=3), rng.normal(size=idx.size)

    def dense_rows(idx):
        A = np.zeros((idx.size, N))
        for j, r in enumerate(idx):
            A[j, 3 * (r // 24) : 3 * (r // 24) + 3] = D[r // 24, r % 24]
        return A

    A = dense_rows(idx)
    K = np.block([[W, -AE.T, -A.T], [AE, np.zeros((3, 3 + idx.size))],
                  [A, np.zeros((idx.size, 3 + idx.size))]])  # fmt: skip
    want = np.linalg.solve(K, np.concatenate([r1, r2, rA]))
    dx, dy, dz, ok = _ipm_path._pc_kkt(W, AE, D, idx, r1, r2, rA, n)
    assert ok
    np.testing.assert_allclose(np.concatenate([dx, dy, dz]), want, rtol=0, atol=1e-9)
    # a fourth row on platform 3, in the span of its three others, consistent
    D[3, 3] = 0.7 * D[3, 0] - 0.2 * D[3, 1] + 0.5 * D[3, 2]
    idx4 = np.array([1, 5, 30, 50, 51, 72, 73, 74, 75])
    rA4 = np.append(rA, 0.7 * rA[5] - 0.2 * rA[6] + 0.5 * rA[7])
    dx, dy, dz, ok = _ipm_path._pc_kkt(W, AE, D, idx4, r1, r2, rA4, n)
    assert ok
    A4 = dense_rows(idx4)
    np.testing.assert_allclose(W @ dx - AE.T @ dy - A4.T @ dz, r1, rtol=0, atol=1e-11)
    np.testing.assert_allclose(AE @ dx, r2, rtol=0, atol=1e-11)
    np.testing.assert_allclose(A4 @ dx, rA4, rtol=0, atol=1e-11)
    # least norm on platform 3: orthogonal to the null space of its rows' transpose
    null = np.linalg.svd(D[3, [0, 1, 2, 3]].T)[2][-1]
    assert abs(dz[5:] @ null) <= 1e-9 * np.linalg.norm(dz[5:])


def test_degenerate_active_set_releases_an_old_limit_that_frees_a_variable():
    """Over the freedom, the continuation step releases the least multiplier among the
    limits that free a variable (platforms with at most 3) and that the last change did
    not add (adding a violated limit and releasing it again would cycle)."""
    idx = np.array([1, 2, 3, 30, 50, 51, 52, 53])  # platform 2 has 4 rows
    zf = np.zeros(96)
    zf[[1, 2, 3, 30, 50, 51, 52, 53]] = [0.5, 0.4, 0.3, 0.0, 0.01, 0.02, 0.03, 0.04]
    new = np.zeros(96, dtype=bool)
    new[30] = True
    cnt = _ipm_path._platform_counts(idx, 4)
    assert list(cnt) == [3, 1, 4, 0]
    assert _ipm_path._weakest(idx, zf, new, cnt) == 3  # not 30 (new), not 50 (dependent)
    new[:] = False
    assert _ipm_path._weakest(idx, zf, new, cnt) == 30


def test_ip_path_marks_a_stop_where_the_barrier_solve_left_its_basin():
    """A run stops before a step whose point is farther than the jump: marked -1 (the
    barrier solve found a pose of the target, beyond the jump: the warm rung fails there
    without its retry) where the point reaches its target within the limits; a tracker
    whose run stopped so skips the retry."""
    from stackik.paths.continuation import Tracker

    n = 4
    stack, pts, q0, prob, P = _straight_run(n, 5)
    Y = readonly([[t.rho, t.z, t.theta] for t in pts[1:4]])
    for pc in (False, True):
        X, reached, how, *_ = _ipm_path.ip_path(
            readonly(prob.u_of(q0)), Y, P, readonly(np.full(3 * n, 1e-9)), 1e-7, 1e-9,
            1e-3, 300, POLISH_REACH, POLISH_MARGIN, 1e-6, 1e-8, pc, *_NO_STATE3,
        )  # fmt: skip
        assert reached == 0 and how[0] == -1
    tracker = Tracker(stack, True, (1e-6, 1e-8))
    assert tracker.warm_many(q0, pts[1:3]) == []
    assert tracker.tried_from is q0 and tracker.tried_left
    assert tracker.step(q0, pts[0], pts[1], subdivide=False, bounded=False, warm_tried=True,
                        warm_left=True) is None  # fmt: skip
    assert tracker.counts.warm_retry == 0


def test_spatial_batch_check_matches_the_check_pose():
    """The compiled spatial check: the values of check_pose (to rounding) and its verdicts,
    on solved poses and poses moved off them by 1e-12 .. 1 times a typical step."""
    stack = Stack.reference(3, leg_radius=0.0)
    rng = np.random.default_rng(4)
    ts, Q = [], []
    for t in random_spatial_targets(stack, 3, 6):
        q = solve_ik(stack, t).q
        for e in (0.0, *10.0 ** rng.uniform(-12, 0, 7)):
            ts.append(t)
            Q.append(q + e * rng.normal(size=q.shape) * np.array([30, 30, 30, 0.3, 0.3, 0.3]))
    Q = np.array(Q)
    oks = spatial_check_many(stack, ts, Q)
    assert any(oks) and not all(oks)
    for t, q, ok in zip(ts, Q, oks):
        c = check_pose(stack, t, q)
        assert ok == c.ok
        pe, ae, mv, vmm, fin = _spatial_check(
            readonly(q), readonly(stack.base_nodes), readonly(stack.top_nodes),
            readonly(stack.leg_min), readonly(stack.leg_max), readonly(stack.sin_joint_min),
            readonly(t.position), readonly(t.rotation),
        )  # fmt: skip
        assert fin
        np.testing.assert_allclose([pe, ae], [c.position_error, c.angle_error], rtol=1e-6,
                                   atol=1e-11)  # fmt: skip
        np.testing.assert_allclose([mv, vmm], [c.max_violation, c.max_violation_mm],
                                   rtol=1e-9, atol=1e-9)  # fmt: skip
    assert spatial_check_many(stack, [], np.zeros((0, 3, 6))) == []


@pytest.mark.parametrize(("n", "seed", "k"), [(4, 2027, 2), (8, 2028, 1)])
def test_spatial_continuation_step_keeps_a_platform_in_a_corner_of_dependent_limits(n, seed, k):
    """Default poses (targets of the spatial bench rows) where a platform meets more
    limits than its rank (n = 4: 9 rows of rank 6 on the top platform): the continuation
    step at the pose's own target, from the barrier solve's multipliers and active set,
    keeps the dependent rows and verifies the point without moving it (it released
    limits with negative multipliers of a singular KKT system until its change limit:
    ok=False, and at n = 8 moved the point by 7e-3)."""
    stack = Stack.reference(n, leg_radius=0.0)
    t = random_spatial_targets(stack, 10 if n == 4 else 5, seed)[k]
    prob = Problem(stack, t, "frobenius", None)
    P = spatial_problem_arrays(prob)
    none = np.empty(0)
    u = readonly(prob.u_of(solve_ik(stack, t).q))
    x, st, _, s, z, yE = _barrier.ip_loop(u, P, 1e-7, 1e-9, 1e-3, 300, 1e300, none, none,
                                              none, 0.0)  # fmt: skip
    assert st == _ip_core.IP_SUCCESS
    act = z > s
    _, _, _, _, cI, D = _spatial_ipm.evaluate(x, P)
    rows = np.nonzero(act & (_ip_paths._twins(act, cI, D) < 0))[0]
    dep = _spatial_ipm_path._dependent(D, rows)
    assert dep.sum() >= 2
    for i in range(n):  # the independent rows of a platform span what all its rows span
        mine = rows // 24 == i
        if mine.any():
            rank = np.linalg.matrix_rank(D[i, rows[mine] % 24], tol=1e-6)
            assert rank == np.sum(mine & ~dep) <= 6
    xn, ok, *_ = _spatial_ipm_path._pc_step(x, P, yE, z, act, 1e-7, 1e-9, _ip_paths.PC_NEWTON,
                                       _ip_paths.PC_CHANGES)  # fmt: skip
    assert ok
    assert np.max(np.abs(xn - x)) <= 1e-6


def test_spatial_continuation_step_budget_and_early_exit():
    """As the planar step: 16 Newton iterations, given up as soon as Newton's method stops
    converging. On a straight spatial path (n = 4) from the default pose of its first
    waypoint: the step to the next waypoint needs 12 (it failed with 8), the step to the
    last one (far) gives up after a few iterations instead of spending the budget."""
    stack = Stack.reference(4, leg_radius=0.0)
    a, b = random_spatial_targets(stack, 10, 2027)[:2]
    pts = interpolate_targets([a, b], steps=15)
    none = np.empty(0)
    prob = Problem(stack, pts[0], "frobenius", None)
    P = spatial_problem_arrays(prob)
    u = readonly(prob.u_of(solve_ik(stack, pts[0]).q))
    x, st, _, s, z, yE = _barrier.ip_loop(u, P, 1e-7, 1e-9, 1e-3, 300, 1e300, none, none,
                                              none, 0.0)  # fmt: skip
    assert st == _ip_core.IP_SUCCESS
    out = []
    for j in (1, 15):
        Pj = spatial_problem_arrays(Problem(stack, pts[j], "frobenius", None))
        r = _spatial_ipm_path._pc_step(x, Pj, yE, z, z > s, 1e-7, 1e-9, _ip_paths.PC_NEWTON,
                                  _ip_paths.PC_CHANGES)  # fmt: skip
        out.append((r[1], r[5]))
    assert out[0][0] and 8 < out[0][1] <= _ip_paths.PC_NEWTON
    assert not out[1][0] and out[1][1] <= 4


def test_spatial_degenerate_active_set_releases_an_old_independent_limit():
    """Over the freedom, the spatial continuation step releases the least multiplier
    among the independent rows that the last change did not add."""
    idx = np.array([1, 2, 30, 31, 50])
    dep = np.array([False, True, False, False, False])
    zf = np.zeros(96)
    zf[idx] = [0.5, -1.0, 0.0, 0.3, 0.01]
    new = np.zeros(96, dtype=bool)
    new[30] = True
    assert _spatial_ipm_path._weakest(idx, dep, zf, new) == 50  # not 2 (dependent), not 30 (new)
    new[:] = False
    assert _spatial_ipm_path._weakest(idx, dep, zf, new) == 30
    # a row in the span of its platform's others is dependent; other platforms' are not
    D = np.zeros((4, 24, 6))
    rng = np.random.default_rng(5)
    D[0, :8] = rng.normal(size=(8, 6))
    D[0, 3] = 0.5 * D[0, 0] - 2.0 * D[0, 1]
    D[1, 0] = D[0, 0]
    dep = _spatial_ipm_path._dependent(D, np.array([0, 1, 3, 24]))
    assert dep[:3].sum() == 1 and not dep[3]  # which of the three: the largest parts first
    assert _spatial_ipm_path._dependent(D, np.arange(8)).sum() == 2  # 8 rows, rank 6


def test_spatial_ip_path_steps_are_checked_and_deterministic():
    """The spatial run (continuation steps, barrier solves where they are not verified):
    continuation steps on a finely sampled path, every point passes the check and is
    within its jump, the objective of a continuation step is that of the barrier solve
    from the previous point (a per mille), deterministic."""
    stack = Stack.reference(3, leg_radius=0.0)
    a, b = random_spatial_targets(stack, 2, 8)
    pts = interpolate_targets([a, b], steps=40)
    q0 = solve_ik(stack, pts[0]).q
    prob = Problem(stack, pts[0], "frobenius", None)
    P = spatial_problem_arrays(prob)
    jump = np.tile([60.0, 60, 60, 0.3, 0.3, 0.3], 3)
    pos = readonly([t.position for t in pts[1:]])
    rot = readonly([t.rotation for t in pts[1:]])
    args = (readonly(prob.u_of(q0)), pos, rot, P, readonly(jump / prob.xs), 1e-7, 1e-9, 1e-3,
            300, POLISH_REACH, POLISH_MARGIN, 1e-6, 1e-8, True, np.zeros(6), np.zeros(0),
            np.zeros(0, dtype=bool), False)  # fmt: skip
    X, reached, how, *_ = _spatial_ipm_path.ip_path(*args)
    X2, reached2, how2, *_ = _spatial_ipm_path.ip_path(*args)
    assert reached == reached2 and np.array_equal(X[:reached], X2[:reached])
    assert np.array_equal(how, how2)
    assert reached >= 10 and how[:reached].sum() >= 3
    Q = np.array([prob.q_of(X[j]) for j in range(reached)])
    assert all(spatial_check_many(stack, pts[1 : reached + 1], Q))
    steps = np.abs(np.diff(np.concatenate([q0[None], Q]), axis=0)) / jump.reshape(3, 6)
    assert steps.max() <= 1.0
    u = prob.u_of(q0)
    none = np.empty(0)
    for j in range(reached):
        Pj = spatial_problem_arrays(Problem(stack, pts[j + 1], "frobenius", None))
        if how[j]:
            x = _barrier.ip_loop(readonly(u), Pj, 1e-7, 1e-9, 1e-3, 300, 1e300, none, none,
                                     none, 0.0)[0]  # fmt: skip
            f_ip = _spatial_ipm.evaluate(x, Pj)[0]
            f_pc = _spatial_ipm.evaluate(X[j], Pj)[0]
            assert abs(f_pc - f_ip) <= 1e-3 * abs(f_ip)
        u = X[j]


def test_twins_compares_rows_within_their_platform_whatever_its_row_count():
    """``_twins`` with R = 24 + 4 rows a platform (spatial limits and self-leg rows): a row
    that copies an earlier row of its own platform gets it as parent, rows of another
    platform never do. (It took 24 rows a platform: with self-leg rows it compared rows
    of the wrong platform and read past ``D``, so a path's continuation steps on legs of
    a size differed from run to run.)"""
    rng = np.random.default_rng(5)
    n, R = 3, 28
    D = rng.normal(size=(n, R, 6))
    cI = rng.normal(size=n * R)
    r_a, r_b = R + 1, R + 26  # platform 1: limit row 1 and self-leg row 26
    D[1, 26] = D[1, 1]
    cI[r_b] = cI[r_a]
    D[2, 3] = D[1, 1]  # the same row on platform 2: not a copy
    cI[2 * R + 3] = cI[r_a]
    act = np.zeros(n * R, dtype=bool)
    act[[r_a, r_b, 2 * R + 3, n * R - 1]] = True
    parent = _ip_paths._twins(act, cI, D)
    assert parent[r_b] == r_a
    assert parent[r_a] == -1 and parent[2 * R + 3] == -1 and parent[n * R - 1] == -1


def test_a_spatial_path_on_legs_of_a_size_is_deterministic():
    """A fast spatial path on the 12 mm reference (its steps carry the self-leg rows and
    continuation steps): the same poses, bit for bit, run after run."""
    from stackik.paths import solve_path

    stack = Stack.reference(4)
    keys = random_spatial_targets(stack, 10, rng=2027)
    ts = interpolate_targets([keys[2], keys[3]], steps=15)
    runs = [solve_path(stack, ts, max_jump=(60.0, 0.3)) for _ in range(4)]
    assert runs[0].success and runs[0].info["pc"] > 0
    for r in runs[1:]:
        np.testing.assert_array_equal(r.q, runs[0].q)


def test_ip_path_secant_history_starts_with_a_known_target():
    """The secant predictor needs the targets of the last two points: a run from a point
    without history returns only the last target after one step (the target before u0
    is unknown, not the origin) and, after two, the point before the last and both
    targets."""
    n = 4
    stack, pts, q0, prob, P = _straight_run(n, 5)
    u0 = readonly(prob.u_of(q0))
    Y = readonly([[t.rho, t.z, t.theta] for t in pts[1:3]])
    args = (P, readonly(np.full(3 * n, np.inf)), 1e-7, 1e-9, 1e-3, 300,
            POLISH_REACH, POLISH_MARGIN, 1e-6, 1e-8, True, *_NO_STATE3)  # fmt: skip
    X1, r1, _, *end1 = _ipm_path.ip_path(u0, readonly(Y[:1]), *args)
    # after one step: no point before the last, only its target and the continuation count
    assert r1 == 1 and end1[4].size == 4
    np.testing.assert_array_equal(end1[4][:3], Y[0])
    X2, r2, _, *end2 = _ipm_path.ip_path(u0, Y, *args)
    assert r2 == 2
    hist = end2[4]
    N = 3 * n
    # the point before the last and both targets; then the quadratic predictor's state
    # (the point before that not known yet: u0's target is not)
    assert hist.size == 2 * N + 11 + 2 * (3 + 2 * 24 * n)
    np.testing.assert_array_equal(hist[:N], X2[0])
    np.testing.assert_array_equal(hist[N : N + 3], Y[0])
    np.testing.assert_array_equal(hist[N + 3 : N + 6], Y[1])
    assert hist[N + 6] == 0.0 and hist[2 * N + 10] == 2  # two continuation steps
