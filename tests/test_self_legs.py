"""Finite-difference test of the self-leg clearance rows (stackik._compiled.self_legs)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from fd import assert_derivative_close, central

from stackik._compiled.self_legs import self_leg_rows

PAIRS = np.array(list(itertools.combinations(range(6), 2)), dtype=np.int64)


def _joints(rng):
    ang_b = np.sort(rng.uniform(0, 2 * np.pi, 6))
    ang_t = np.sort(rng.uniform(0, 2 * np.pi, 6))
    base = np.c_[100 * np.cos(ang_b), 100 * np.sin(ang_b), np.zeros(6)]
    top = np.c_[70 * np.cos(ang_t), 70 * np.sin(ang_t), np.zeros(6)]
    return base, top


def _rows(q, base, top):
    c = np.empty(len(PAIRS))
    J = np.empty((len(PAIRS), 6))
    self_leg_rows(np.asarray(q, float), base, top, PAIRS, 24.0, 1e4, c, J)
    return c, J


@pytest.mark.parametrize("seed", range(5))
def test_self_leg_jacobian_fd(seed):
    rng = np.random.default_rng(seed)
    base, top = _joints(rng)
    q = np.r_[rng.normal(0, 10, 2), 150 + rng.normal(0, 10), rng.normal(0, 0.2, 3)]
    _, J = _rows(q, base, top)
    num = central(lambda x: _rows(x, base, top)[0], q, typical=[100, 100, 100, 1, 1, 1])
    assert_derivative_close(J, num, f_scale=4.0)


def _grad_weighted(q, base, top, y):
    _, J = _rows(q, base, top)
    return y @ J


@pytest.mark.derivatives
@pytest.mark.parametrize("seed", range(8))
def test_self_leg_hessian_fd(seed):
    """The exact second derivatives (the minimisation over the closest points included)
    against central differences of the analytic gradient."""
    from stackik._compiled.self_legs import self_leg_hessian

    rng = np.random.default_rng(100 + seed)
    base, top = _joints(rng)
    q = np.r_[rng.normal(0, 30, 2), 120 + rng.normal(0, 20), rng.normal(0, 0.6, 3)]
    y = rng.uniform(0.5, 2.0, len(PAIRS))
    H = self_leg_hessian(q, base, top, PAIRS, 1e4, y)
    assert np.allclose(H, H.T, rtol=1e-12, atol=1e-12 * np.abs(H).max())
    num = central(lambda x: _grad_weighted(x, base, top, y), q, typical=[100, 100, 100, 1, 1, 1])
    assert_derivative_close(H, num, f_scale=4.0 * y.sum(), what="self-leg Hessian")


def test_self_leg_block_matches_rows():
    """The batch over platforms is the per-platform rows, platform by platform."""
    from stackik._compiled.self_legs import self_leg_block

    rng = np.random.default_rng(3)
    n = 3
    joints = [_joints(rng) for _ in range(n)]
    base = np.stack([b for b, _ in joints])
    top = np.stack([t for _, t in joints])
    q = np.c_[rng.normal(0, 10, (n, 2)), 150 + rng.normal(0, 10, n), rng.normal(0, 0.2, (n, 3))]
    rho = np.array([24.0, 10.0, 0.0])
    scale = np.array([1e4, 2e4, 3e4])
    c, J = self_leg_block(q, base, top, PAIRS, rho, scale)
    for i in range(n):
        ci = np.empty(len(PAIRS))
        Ji = np.empty((len(PAIRS), 6))
        self_leg_rows(q[i], base[i], top[i], PAIRS, rho[i], scale[i], ci, Ji)
        assert np.array_equal(c[i], ci) and np.array_equal(J[i], Ji)


def test_problem_carries_self_leg_rows():
    """Problem appends the rows when a leg radius is positive; their values are the squared
    axis distances that stackik.clearance measures with its own code."""
    import stackik as sk
    from stackik.clearance import clearances
    from stackik.formulation import Problem

    geom = sk.PlatformGeometry.hexagonal(leg_radius=12.0)
    stack = sk.Stack.uniform(geom, 3)
    tgt = sk.SpatialTarget(position=(10.0, -20.0, 420.0), rotation=np.eye(3))
    plain = Problem(sk.Stack.reference(3, leg_radius=0.0), tgt, "frobenius", None)
    assert plain.self_legs is None and plain.n_ineq == 72
    p = Problem(stack, tgt, "frobenius", None, clearance=1.5)
    assert p.self_legs is not None and p.n_ineq == 72 + 3 * 15
    rng = np.random.default_rng(5)
    q = np.tile([0.0, 0.0, 140.0, 0.0, 0.0, 0.0], (3, 1)) + rng.normal(
        0, [5, 5, 5, 0.3, 0.1, 0.1], (3, 6)
    )
    u = p.u_of(q)
    _, _, _, _, cin, Jin = p.evaluate(u)
    c = cin[72:].reshape(3, 15)
    d = np.sqrt(c * p.self_legs.scale[:, None] + p.self_legs.rho[:, None] ** 2)
    by = clearances(stack, q).self_legs_by_platform
    assert np.allclose(d.min(axis=1) - 2 * 12.0, by, rtol=0, atol=1e-9)

    def rows(v):
        p._cache = None
        return p.evaluate(v)[4][72:]

    num = central(rows, u, typical=1.0)
    assert_derivative_close(Jin[72:], num, f_scale=4.0, what="Problem self-leg rows")


@pytest.mark.derivatives
@pytest.mark.parametrize("seed", range(4))
def test_planar_self_leg_rows_fd_and_values(seed):
    """Planar poses: the rows' Jacobian against central differences, and their values
    against stackik.clearance's own axis distances."""
    import stackik as sk
    from stackik._compiled.self_legs import planar_self_leg_block
    from stackik.clearance import clearances
    from stackik.sampling import random_feasible_poses

    stack = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=12.0), 3)
    phi = 0.3 + seed
    q = random_feasible_poses(stack, 1, rng=seed, phi=phi)[0]
    base, top = np.asarray(stack.base_nodes), np.asarray(stack.top_nodes)
    rho, scale = np.full(3, 24.0), np.asarray(stack.leg_max) ** 2

    def rows(x):
        return planar_self_leg_block(x.reshape(3, 3), phi, base, top, PAIRS, rho, scale)[0].ravel()

    c, J = planar_self_leg_block(q, phi, base, top, PAIRS, rho, scale)
    num = central(rows, q.ravel(), typical=[100, 100, 1] * 3)
    ana = np.zeros((3, 15, 3, 3))
    for i in range(3):
        ana[i, :, i, :] = J[i]
    assert_derivative_close(ana.reshape(45, 9), num, f_scale=4.0, what="planar self-leg rows")
    d = np.sqrt(c * scale[:, None] + 24.0**2).min(axis=1) - 24.0
    assert np.allclose(d, clearances(stack, q, phi=phi).self_legs_by_platform, atol=1e-9)


def test_planar_problem_carries_self_leg_rows():
    """Thick legs on planar targets: the planar problem carries the self-leg rows (outside
    the planar kernels: dense rows, so SLSQP and the SQP engine see them), in Problem's
    order (limits, then self legs), and a solve never calls a colliding pose a success
    (30 mm legs: adjacent platforms' legs, which no solver constrains, collide here)."""
    import stackik as sk
    from stackik.formulation import Problem

    stack = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=30.0), 4)
    t = sk.PlanarTarget(600.0, 1000.0, -1.57)
    prob = Problem(stack, t, "frobenius", None)
    assert prob.self_legs is not None and prob.dense_rows and prob.n_ineq == 96 + 60
    q = sk.solve_ik(sk.Stack.reference(4, leg_radius=0.0), t).q
    cin = prob.evaluate(prob.u_of(q))[4]
    d = np.sqrt(cin[96:].reshape(4, 15) * prob.self_legs.scale[:, None] + 60.0**2)
    by = sk.clearances(stack, q, phi=t.phi).self_legs_by_platform
    assert np.allclose(d.min(axis=1) - 60.0, by, atol=1e-9)
    r = sk.solve_ik(stack, t, method="slsqp", starts=3)
    assert not r.success or (r.clearances is not None and r.clearances.minimum >= -1e-6)
    # IPOPT has the planar rows too: its pose keeps each platform's legs apart, where
    # the same start on zero-radius legs does not (adjacent legs still collide: no success)
    r0 = sk.solve_ik(sk.Stack.reference(4, leg_radius=0.0), t, method="ipopt", starts=1)
    assert sk.clearances(stack, r0.q, phi=t.phi).self_legs < 0
    r1 = sk.solve_ik(stack, t, method="ipopt", starts=1)
    assert r1.target_error < 1e-6 and r1.max_violation <= 1e-6
    assert sk.clearances(stack, r1.q, phi=t.phi).self_legs >= -1e-6


def test_handover_only_for_what_the_rows_cover():
    """A pose whose only shortfall is one the rows cover (a platform's own legs) is a
    hand-over start; one whose adjacent-platform legs collide (no rows) is not."""
    import stackik as sk
    from stackik.formulation import Problem
    from stackik.methods.ip import unconstrained_shortfall

    stack = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=30.0), 4)
    t = sk.PlanarTarget(600.0, 1000.0, -1.57)
    prob = Problem(stack, t, "frobenius", None)
    q = sk.solve_ik(sk.Stack.reference(4, leg_radius=0.0), t).q
    chk = prob.check(q)
    cl = chk.clearances
    assert cl is not None and cl.self_legs < 0 and cl.adjacent_legs < 0
    assert unconstrained_shortfall(prob, chk) == pytest.approx(-cl.adjacent_legs)
    thin = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=12.0), 4)
    p12 = Problem(thin, t, "frobenius", None, clearance=1.0)
    c12 = p12.check(q)
    assert c12.clearances is not None
    expect = max(0.0, 1.0 - min(c12.clearances.adjacent_legs, c12.clearances.non_adjacent))
    assert unconstrained_shortfall(p12, c12) == pytest.approx(expect)


def test_planar_self_leg_rows_are_lazy() -> None:
    """Planar self-leg rows only where a run needs them (stages._local_run): legs with a
    radius that stay clear give the zero-radius solve exactly; legs that would meet get a
    second run with the rows, and a clear pose."""
    import stackik as sk
    from stackik.sampling import random_planar_targets

    ref = sk.Stack.reference(4, leg_radius=0.0)
    fat = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=12.0), 4)
    t = random_planar_targets(ref, 1, rng=np.random.default_rng(7))[0]
    for method in ("sqp", "slsqp"):
        a, b = sk.solve_ik(ref, t, method=method), sk.solve_ik(fat, t, method=method)
        assert b.success and np.array_equal(a.q, b.q) and a.nit == b.nit
    ref2 = sk.Stack.reference(2, leg_radius=0.0)
    t = random_planar_targets(ref2, 8, rng=np.random.default_rng(3))[6]
    d = sk.clearances(ref2, sk.solve_ik(ref2, t).q, phi=t.phi).self_legs
    thick = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=d / 2 + 2.0), 2)
    for method in ("sqp", "slsqp"):
        r = sk.solve_ik(thick, t, method=method)
        assert r.success and r.clearances is not None and r.clearances.self_legs >= -1e-6
        assert r.nit > sk.solve_ik(ref2, t, method=method).nit  # without the rows, then with
