"""Rows for the bodies of non-adjacent platforms (issue 29): the family's Jacobian against
central differences (spatial and planar), its values against the check's exact segment
distances, the plates' covering segments (conservative), the compiled interior points'
dense rows equal Problem's, and the screen (close pairs only; none: no rows)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import stackik as sk
from stackik import distance as dist
from stackik.check import FEAS_TOL
from stackik.clearance import plate_frames
from stackik.formulation import Problem
from stackik.formulation.leg_pairs import LegPairRows, close_pairs, pair_table
from stackik.kinematics import planar_forward, spatial_forward
from stackik.methods.ip import n_dense, problem_arrays, spatial_problem_arrays
from stackik.sampling import random_feasible_poses, random_reachable_targets
from tests import fd

NONE = np.empty(0)
FAT = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=7.0, plate_thickness=4.0), 5)


def _pose(stack: sk.Stack, phi: float | None, rng: np.random.Generator) -> np.ndarray:
    """A planar feasible pose in the plane ``phi``, or a spatial one near the straight stack."""
    if phi is not None:
        return random_feasible_poses(stack, 1, rng=rng, phi=phi)[0]
    base = np.tile([0.0, 0.0, 300.0, 0.0, 0.0, 0.0], (stack.n, 1))
    return base + rng.normal(0, [20, 20, 20, 0.3, 0.3, 0.3], (stack.n, 6))


def _segments(stack: sk.Stack, q: np.ndarray, phi: float | None) -> tuple[Any, Any]:
    """Both ends (S, 3) of every segment of the table, from the check's plate frames."""
    A, O = plate_frames(stack, q, phi=phi)
    t = pair_table(stack)
    ends = [
        np.array([O[p] + A[p] @ x for p, x in zip(t.plates[:, e], t.points[:, e])]) for e in (0, 1)
    ]
    return ends[0], ends[1]


@pytest.mark.derivatives
@pytest.mark.parametrize("phi", [None, 0.4])
def test_pair_rows_derivatives_and_values(phi: float | None) -> None:
    """Every pair's row: its Jacobian against central differences (the step and the bound
    from the rows' scale, tests/fd.py), its value the exact segment distance
    (``stackik.distance.segment_segment`` of the ends from the check's plate frames)
    against ``rho`` (two legs: ``2 r + margin``)."""
    rng = np.random.default_rng(29)
    table = pair_table(FAT)
    n = FAT.n
    legs = table.body[table.pairs[:, 1]] < 0
    assert legs.sum() == 36 * (n - 1) * (n - 2) // 2  # leg pairs of platforms >= 2 apart
    rows = LegPairRows(FAT, np.arange(table.pairs.shape[0]), 1.5, phi)
    np.testing.assert_array_equal(rows.kernel_args[3][legs], 2 * 7.0 + 1.5)
    for _ in range(2):
        q = _pose(FAT, phi, rng)
        c, J = rows(q)
        assert c.shape == (rows.size,) and J.shape == (rows.size, q.size)
        num = fd.central(lambda x, s=q.shape: rows(x.reshape(s))[0], q.ravel())
        fd.assert_derivative_close(J, num, f_scale=fd.term_scale(c, num), what="pair rows")
        X0, X1 = _segments(FAT, q, phi)
        a, b = table.pairs[:, 0], table.pairs[:, 1]
        d = dist.segment_segment(X0[a], X1[a], X0[b], X1[b])
        rho = rows.kernel_args[3]
        np.testing.assert_allclose(c * rows.L**2, d**2 - rho**2, rtol=0, atol=1e-8 * rows.L**2)
        np.testing.assert_allclose(rows.distances(q), d - rho, rtol=0, atol=1e-7)
        # a row does not move with the platforms above its higher plate
        top = table.plates[table.pairs].reshape(-1, 4).max(axis=1) * q.shape[1]
        cols = np.arange(q.size)
        assert all(not J[r, cols >= top[r]].any() for r in range(rows.size))


def test_plate_segments_cover_the_plate() -> None:
    """Every point of a plate's polygon lies within ``kappa`` of one of its covering
    segments, and ``kappa`` is nearly reached (to twice the samples' spacing), so the
    leg-plate rows hold only where the check's leg-plate distance does: sampled points
    (uniform in the polygon's bounding box, kept inside)."""
    stack = sk.Stack.reference(3, leg_radius=0.0)
    table = pair_table(stack)
    rng = np.random.default_rng(0)
    q = np.tile([0.0, 330.0, 0.0], (3, 1))
    A, O = plate_frames(stack, q, phi=0.0)
    X0, X1 = _segments(stack, q, 0.0)
    for p in range(stack.n + 1):
        e = np.flatnonzero(table.body == p)
        nodes = np.concatenate(
            ([stack.top_nodes[p - 1]] if p > 0 else []) + ([stack.base_nodes[p]] if p < 3 else [])
        )
        poly = dist.Polygon(O[p], A[p], dist.convex_hull_2d(nodes[:, :2]))
        uv = rng.uniform(-160, 160, (20000, 2))
        uv = uv[poly.inside(uv)]
        pts = O[p] + uv @ A[p][:, :2].T
        d = dist.point_segment(pts[:, None, :], X0[e][None], X1[e][None]).min(axis=1)
        kappa = table.kappa[p]
        spacing = 320.0 / np.sqrt(20000)  # the samples' typical spacing [mm]
        assert d.max() <= kappa + 1e-9 and d.max() > kappa - 2.0 * spacing


@pytest.mark.parametrize("phi", [None, 0.4])
def test_kernel_dense_rows_are_the_problems_pair_rows(phi: float | None) -> None:
    """The compiled interior points (planar, spatial) carry the rows as dense rows: the
    same values and Jacobian (scaled variables) as Problem's, after the block rows."""
    rng = np.random.default_rng(5)
    stack = FAT
    q = _pose(stack, phi, rng)
    if phi is None:
        target: Any = sk.SpatialTarget(*spatial_forward(q))
    else:
        target = sk.PlanarTarget(*planar_forward(q), phi=phi)
    every = LegPairRows(stack, np.arange(pair_table(stack).pairs.shape[0]), 0.0, phi)
    pairs = close_pairs(stack, [q], 0.0, phi, float(np.median(every.distances(q))))
    assert 0 < pairs.size < every.size
    prob = Problem(stack, target, "frobenius", None).with_leg_pairs(pairs)
    assert prob.dense_rows
    P = problem_arrays(prob) if phi is not None else spatial_problem_arrays(prob)
    assert P.n_dense == n_dense(prob) == pairs.size
    u = prob.u_of(q) + rng.normal(0, 0.01, q.size)
    if phi is None:
        from stackik._compiled.spatial import _evaluate_ip

        out = _evaluate_ip(u, P, NONE, NONE, NONE, 0.0)
    else:
        from stackik._compiled.planar import _evaluate_ip

        out = _evaluate_ip(u, P, NONE, NONE, NONE, 0.0)
    cI, JD = out[4], out[5][1]
    _, _, _, _, cin, Jin = prob.evaluate(u)
    nd = P.n_dense
    np.testing.assert_allclose(cI[-nd:], cin[-nd:], rtol=0, atol=1e-14)
    np.testing.assert_allclose(JD, Jin[-nd:], rtol=0, atol=1e-13)
    assert prob.n_ineq == cin.size


def test_no_pair_is_no_row_and_bad_index_is_refused() -> None:
    """``with_leg_pairs`` of no pair is the problem without rows (the kernels' data empty);
    an index outside the table is a ValueError naming it."""
    t = sk.PlanarTarget(0.0, 700.0, 0.0)
    st2 = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=12.0), 2)
    prob = Problem(st2, t, "frobenius", None).with_leg_pairs(np.zeros(0))
    assert prob.clearance.leg_pairs is None and problem_arrays(prob).n_dense is None
    size = pair_table(FAT).pairs.shape[0]
    with pytest.raises(ValueError, match="index"):
        LegPairRows(FAT, [size], 0.0)


def test_no_rows_have_the_kernel_types_of_rows_and_the_table_its_pairs() -> None:
    """``no_leg_pair_rows`` (empty arrays, no table built) gives the compiled interior
    points arguments of the same numba types as rows of the table (no new
    specialisation); the table's pairs are the module doc's, in its order (written here
    as a plain loop), with ``rho = 2 r`` for two legs and one ``r + tau_p + kappa_p`` per
    plate ``p`` (that sum read from the table)."""
    from numba import typeof

    from stackik.formulation.leg_pairs import no_leg_pair_rows

    rows = LegPairRows(FAT, [0, 1], 0.0).kernel_args
    empty = no_leg_pair_rows(FAT)
    assert [typeof(a) for a in empty] == [typeof(a) for a in rows]
    assert empty[-1] == rows[-1] and all(a.shape[0] == 0 for a in empty[:-1])
    t = pair_table(FAT)
    kappa_tau = {int(p): t.rho[i] - 7.0 for i, p in enumerate(t.body[t.pairs[:, 1]]) if p >= 0}
    want = []
    for i in range(FAT.n):
        for k in range(6):
            want += [(6 * i + k, 6 * j + m, 14.0) for j in range(i + 2, FAT.n) for m in range(6)]
            want += [
                (6 * i + k, int(e), 7.0 + kappa_tau[p])
                for p in range(FAT.n + 1)
                if p not in (i, i + 1)
                for e in np.flatnonzero(t.body == p)
            ]
    np.testing.assert_array_equal(t.pairs, [w[:2] for w in want])
    np.testing.assert_allclose(t.rho, [w[2] for w in want], rtol=1e-15)


REF16 = sk.Stack.reference(16, leg_radius=0.0)
FAT16 = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=12.0), 16)


def _n16_targets() -> list[sk.PlanarTarget]:
    """The fingerprint's planar n = 16 targets (benchmarks/fingerprint.py)."""
    return random_reachable_targets(REF16, 3, rng=36, phi=0.3)


@pytest.mark.parametrize(("k", "method"), [(1, "ip"), (0, "sqp")])
def test_a_folded_tall_stack_is_solved_clear(k: int, method: str, lines_pass_through: None) -> None:
    """A planar n = 16 target whose least-FN pose on legs of zero radius folds into itself
    with 12 mm legs (the check refuses it on non-adjacent bodies alone) is solved with the
    rows, and the independent check (``stackik.clearances``, exact distances) confirms
    every clearance >= 0 (to ``FEAS_TOL``) and the target reached."""
    t = _n16_targets()[k]
    thin = sk.solve_ik(REF16, t, method=method)
    assert thin.success
    folded = sk.check_pose(FAT16, t, thin.q)
    assert not folded.ok and folded.clearances is not None
    assert folded.clearances.non_adjacent < 0.0 and folded.clearances.self_legs > 0.0
    fat = sk.solve_ik(FAT16, t, method=method)
    assert fat.success, fat.message
    c = sk.clearances(FAT16, fat.q, phi=t.phi)
    # >= 0 to the check's tolerance (a binding row ends at rounding from its bound)
    assert c.minimum >= -FEAS_TOL and c.non_adjacent >= -FEAS_TOL
    assert sk.check_pose(FAT16, t, fat.q).ok


def test_nothing_close_is_the_solve_without_rows(monkeypatch: pytest.MonkeyPatch) -> None:
    """Planar n = 4 with 12 mm legs: no non-adjacent pair comes close, so no problem gets
    rows (``with_leg_pairs`` is never called) and every pose is the zero-radius solve's,
    bit for bit (default, ``ip`` and ``sqp``)."""

    def refuse(self: Problem, pairs: Any) -> Problem:
        raise AssertionError("rows for non-adjacent pairs where none is close")

    monkeypatch.setattr(Problem, "with_leg_pairs", refuse)
    ref = sk.Stack.reference(4, leg_radius=0.0)
    fat = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=12.0), 4)
    targets = random_reachable_targets(ref, 4, rng=np.random.default_rng(2929), phi=0.3)
    for t in targets:
        for kw in ({}, {"method": "ip"}, {"method": "sqp"}):
            a, b = sk.solve_ik(ref, t, **kw), sk.solve_ik(fat, t, **kw)
            assert a.success and b.success
            np.testing.assert_array_equal(a.q, b.q)


def test_ipopt_bounds_and_does_not_cache_the_pair_rows(monkeypatch: pytest.MonkeyPatch) -> None:
    """An IPOPT run carries at most ``IPOPT_MAX_PAIR_ROW_PLATFORMS`` rows for non-adjacent
    bodies times platforms (beyond, it is not made: memory grows by MBs a row at n >= 16),
    and the solver of a run with
    such rows is not kept in the solver cache (each unfold round has rows of its own)."""
    pytest.importorskip("casadi")
    from stackik.methods import ipopt

    rng = np.random.default_rng(12)
    q = _pose(FAT, None, rng)
    every = LegPairRows(FAT, np.arange(pair_table(FAT).pairs.shape[0]), 0.0, None)
    pairs = close_pairs(FAT, [q], 1.0, None, float(np.quantile(every.distances(q), 0.2)))
    prob = Problem(FAT, sk.SpatialTarget(*spatial_forward(q)), "frobenius", None)
    prob = prob.with_leg_pairs(pairs)
    size = prob.clearance.leg_pairs.size
    assert size > 1
    u0 = prob.u_of(q)
    before = ipopt._spatial_solver.cache_info().currsize
    u, nit, status = ipopt.run_ipopt(prob, u0, {"max_iter": 5})
    assert nit > 0 and status != "too many rows"
    assert ipopt._spatial_solver.cache_info().currsize == before
    monkeypatch.setattr(ipopt, "IPOPT_MAX_PAIR_ROW_PLATFORMS", size * FAT.n - 1)
    u, nit, status = ipopt.run_ipopt(prob, u0, {"max_iter": 5})
    assert (nit, status) == (0, "too many rows") and np.array_equal(u, u0)


def test_ipopt_pair_rows_are_the_kernels() -> None:
    """IPOPT's symbolic rows for bodies of non-adjacent platforms equal the kernel's in
    value and Jacobian (spatial poses, legs and plates' covering segments)."""
    ca = pytest.importorskip("casadi")
    from stackik.methods.ipopt import pair_function

    rng = np.random.default_rng(11)
    qs = ca.SX.sym("q", 6 * FAT.n)
    for _ in range(3):
        q = _pose(FAT, None, rng)
        every = LegPairRows(FAT, np.arange(pair_table(FAT).pairs.shape[0]), 0.0, None)
        pairs = close_pairs(FAT, [q], 1.0, None, float(np.quantile(every.distances(q), 0.2)))
        prob = Problem(FAT, sk.SpatialTarget(*spatial_forward(q)), "frobenius", None, clearance=1.0)
        prob = prob.with_leg_pairs(pairs)
        rows = prob.clearance.leg_pairs
        f = pair_function(prob)
        Jf = ca.Function("J", [qs], [ca.jacobian(f(qs), qs)])
        c, J = rows(q)
        np.testing.assert_allclose(np.asarray(f(q.ravel())).ravel(), c, rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.asarray(Jf(q.ravel())), J, rtol=0, atol=1e-10)
