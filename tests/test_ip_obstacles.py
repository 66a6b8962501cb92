"""The obstacle rows inside the compiled spatial interior point (issue 29, speed): the
kernel's dense rows are Problem's obstacle rows, the compiled polish corrects them, and a
solve through a sphere, a truss member or a half-space is clear with the interior point
alone (no hand-over to SLSQP)."""

from __future__ import annotations

import numpy as np
import pytest

import stackik as sk
from stackik.formulation import Problem
from stackik.kinematics import spatial_chain
from stackik.methods.ip import spatial_problem_arrays
from stackik.sampling import random_spatial_targets

REF = sk.Stack.reference(4, leg_radius=0.0)
NONE = np.empty(0)


def _targets() -> list[sk.SpatialTarget]:
    return random_spatial_targets(REF, 12, rng=np.random.default_rng(4242))


def _leg_midpoint(q: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Midpoint of leg ``k`` of platform 2 (0-based 1) of pose ``q`` [mm], and its unit
    direction."""
    ch = spatial_chain(q)
    B = ch.O[1] + ch.A[1] @ REF.base_nodes[1][k]
    T = ch.O[2] + ch.A[2] @ REF.top_nodes[1][k]
    return (B + T) / 2, (T - B) / np.linalg.norm(T - B)


def _obstacle(kind: str, q: np.ndarray, k: int) -> sk.Obstacle:
    """An obstacle across leg ``k`` of platform 2 of ``q`` (it collides with ``q``)."""
    m, u = _leg_midpoint(q, k)
    if kind == "sphere":
        return sk.Sphere(m, 15.0)
    d = np.cross(u, [0.0, 0.0, 1.0])
    d /= np.linalg.norm(d)
    if kind == "truss":
        return sk.Capsule(m - 300 * d, m + 300 * d, 10.0)
    # a wall 5 mm into the leg from outside the stack: the legs stay on the axis' side
    out = m.copy()
    out[2] = 0.0
    out /= np.linalg.norm(out)
    return sk.HalfSpace(m - 5.0 * out, -out)


@pytest.mark.parametrize("kind", ["sphere", "truss", "wall"])
def test_kernel_dense_rows_are_the_problems_obstacle_rows(kind: str) -> None:
    """The compiled interior point's inequality rows are Problem's: the 24 limits a
    platform, then the obstacle rows (same values, same Jacobian in scaled variables)."""
    from stackik._compiled.spatial import _evaluate_ip

    t = _targets()[0]
    q = sk.solve_ik(REF, t).q
    prob = Problem(REF, t, "frobenius", None, obstacles=[_obstacle(kind, q, 2)])
    assert prob.clearance.obstacle_rows is not None
    P = spatial_problem_arrays(prob)
    assert P.n_dense == prob.clearance.obstacle_rows.size > 0
    rng = np.random.default_rng(3)
    u = prob.u_of(q + rng.normal(0, [5, 5, 5, 0.05, 0.05, 0.05], q.shape))
    _, _, _, _, cI, (D, JD), _ = _evaluate_ip(u, P, NONE, NONE, NONE, 0.0)
    _, _, _, _, cin, Jin = prob.evaluate(u)
    mb = 24 * REF.n
    assert cI.shape == cin.shape == (mb + P.n_dense,)
    np.testing.assert_allclose(cI, cin, rtol=0, atol=1e-14)
    np.testing.assert_allclose(JD, Jin[mb:], rtol=0, atol=1e-13)
    for i in range(REF.n):
        np.testing.assert_allclose(D[i], Jin[24 * i : 24 * i + 24, 6 * i : 6 * i + 6], atol=1e-13)


def test_no_obstacle_rows_leave_the_kernel_data_empty() -> None:
    """Without obstacles (or with one out of reach) the kernels see no dense row."""
    t = _targets()[0]
    far = sk.Sphere((1e5, 0.0, 0.0), 10.0)
    for obs in ((), (far,)):
        P = spatial_problem_arrays(Problem(REF, t, "frobenius", None, obstacles=obs))
        assert P.n_dense is None and P.obstacles[-1].size == 0  # the lean type


def test_compiled_polish_corrects_slightly_violated_obstacle_rows() -> None:
    """A pose a hair inside the obstacle's row is moved out of it by the compiled polish,
    at the target; the limits it was on stay within the polish's reach of them (the
    polish corrects only the rows violated at each of its steps, so a limit active at the
    start may end a rounding below, as without obstacles) and the pose passes the check."""
    from stackik._compiled.barrier import polish
    from stackik._compiled.spatial import _evaluate_ip
    from stackik.formulation import POLISH_MARGIN, POLISH_REACH

    t = _targets()[1]
    q = sk.solve_ik(REF, t).q
    m, u = _leg_midpoint(q, 1)
    d = np.cross(u, [0.0, 0.0, 1.0])
    d /= np.linalg.norm(d)
    # a sphere whose surface reaches 1e-5 mm into the leg's axis
    sphere = sk.Sphere(m + (7.0 - 1e-5) * d, 7.0)
    prob = Problem(REF, t, "frobenius", None, obstacles=[sphere])
    P = spatial_problem_arrays(prob)
    u0 = prob.u_of(q)
    cI0 = _evaluate_ip(u0, P, NONE, NONE, NONE, 0.0)[4]
    assert -POLISH_REACH < cI0[24 * REF.n :].min() < 0.0
    u1 = polish(u0, P, 3, POLISH_REACH, POLISH_MARGIN)
    _, _, cE1, _, cI1, _, _ = _evaluate_ip(u1, P, NONE, NONE, NONE, 0.0)
    assert cI1[24 * REF.n :].min() >= 0.0
    assert cI1.min() > -1e-3 * POLISH_REACH and np.abs(cE1).max() < 1e-13
    assert np.abs(u1 - u0).max() < 1e-6
    assert prob.check(prob.q_of(u1)).ok


@pytest.mark.parametrize(("kind", "k"), [("sphere", 0), ("sphere", 3), ("truss", 1)])
def test_interior_point_goes_around_obstacles_without_slsqp(kind: str, k: int) -> None:
    """A sphere, a truss member or a wall across a leg of the least-FN pose: the interior
    point itself (``method="ip"``, and the default without a hand-over: its method is
    ``"ip"``) returns a clear pose at the target, within 1 % of the obstacle-free FN."""
    t = _targets()[k]
    plain = sk.solve_ik(REF, t)
    ob = _obstacle(kind, plain.q, k % 6)
    assert sk.clearances(REF, plain.q, [ob]).obstacles[0] < 0  # the optimum collides
    for method in ("ip", "auto"):
        r = sk.solve_ik(REF, t, obstacles=[ob], method=method)
        assert r.success and r.method == "ip", (kind, k, method, r.method, r.message)
        assert sk.clearances(REF, r.q, [ob]).obstacles[0] >= -1e-6
        assert r.frobenius_norm <= plain.frobenius_norm * 1.01


def test_only_planar_self_legs_hand_over() -> None:
    """Obstacle and leg-force rows are in both interior points (dense rows): a problem with
    them hands nothing over (``rows_outside_ip`` False, spatial and planar); the planar
    self-leg rows are the one family outside the kernels."""
    t = _targets()[0]
    sphere = sk.Sphere((0.0, 0.0, 700.0), 20.0)
    assert not Problem(REF, t, "frobenius", None, obstacles=[sphere]).rows_outside_ip
    limited = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(force_max=100.0), 4)
    assert not Problem(limited, t, "frobenius", None, obstacles=[sphere]).rows_outside_ip
    planar = sk.PlanarTarget(150.0, 1200.0, 0.3)
    assert not Problem(REF, planar, "frobenius", None, obstacles=[sphere]).rows_outside_ip
    assert not Problem(limited, planar, "frobenius", None).rows_outside_ip
    fat = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=8.0), 4)
    assert Problem(fat, planar, "frobenius", None).rows_outside_ip
