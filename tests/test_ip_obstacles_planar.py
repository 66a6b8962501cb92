"""The obstacle rows inside the compiled planar interior point (issue 29, speed): the
kernel's dense rows are Problem's planar obstacle rows (values, and a Jacobian in scaled
variables that central differences confirm), the compiled polish corrects them, and a
planar solve past a sphere, a truss member or a floor is clear with the interior point
alone (no hand-over to SLSQP)."""

from __future__ import annotations

import fd
import numpy as np
import pytest

import stackik as sk
from stackik.clearance import plate_frames
from stackik.formulation import Problem
from stackik.methods.ip import problem_arrays
from stackik.sampling import random_planar_targets

REF = sk.Stack.reference(4, leg_radius=0.0)
NONE = np.empty(0)


def _targets() -> list[sk.PlanarTarget]:
    """Planar targets in several planes."""
    return random_planar_targets(REF, 8, rng=np.random.default_rng(2929), phis=(0.0, 0.7, 2.1, 4.0))


def _leg(q: np.ndarray, phi: float, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Midpoint of leg ``k`` of platform 2 (0-based 1) of the planar pose ``q`` in the
    plane ``phi`` (base frame [mm]), and its unit direction."""
    A, O = plate_frames(REF, q, phi=phi)
    B = O[1] + A[1] @ REF.base_nodes[1][k]
    T = O[2] + A[2] @ REF.top_nodes[1][k]
    return (B + T) / 2, (T - B) / np.linalg.norm(T - B)


def _obstacle(kind: str, q: np.ndarray, phi: float, k: int) -> sk.Obstacle:
    """An obstacle across leg ``k`` of platform 2 of ``q`` (a sphere or a truss member: it
    collides with ``q``), or a floor under the base (``wall``)."""
    m, u = _leg(q, phi, k)
    if kind == "sphere":
        return sk.Sphere(m, 15.0)
    if kind == "truss":
        d = np.cross(u, [0.0, 0.0, 1.0])
        d /= np.linalg.norm(d)
        return sk.Capsule(m - 300 * d, m + 300 * d, 10.0)
    return sk.HalfSpace((0.0, 0.0, -30.0), (0.0, 0.0, 1.0))


def _evaluate_ip(u: np.ndarray, P: object) -> tuple[object, ...]:
    from stackik._compiled.planar import _evaluate_ip as ev

    return ev(u, P, NONE, NONE, NONE, 0.0)  # type: ignore[no-any-return]


@pytest.mark.derivatives
@pytest.mark.parametrize("kind", ["sphere", "truss", "wall"])
def test_kernel_dense_rows_are_the_problems_obstacle_rows(kind: str) -> None:
    """The compiled planar interior point's inequality rows are Problem's: the 24 limits a
    platform, then the obstacle rows in the target's plane (same values, same Jacobian in
    scaled variables), and that Jacobian is the derivative of the kernel's rows (central
    differences in the scaled variables the kernel iterates on)."""
    t = _targets()[2]
    q = sk.solve_ik(REF, t).q
    prob = Problem(REF, t, "frobenius", None, obstacles=[_obstacle(kind, q, t.phi, 2)])
    rows = prob.clearance.obstacle_rows
    assert rows is not None and rows.phi == t.phi
    P = problem_arrays(prob)
    assert P.n_dense == rows.size > 0 and P.ob_phi == t.phi
    rng = np.random.default_rng(3)
    u = prob.u_of(q + rng.normal(0, [5, 5, 0.05], q.shape))
    _, _, _, _, cI, (D, JD) = _evaluate_ip(u, P)
    _, _, _, _, cin, Jin = prob.evaluate(u)
    mb = 24 * REF.n
    assert cI.shape == cin.shape == (mb + P.n_dense,) and JD.shape == (P.n_dense, 3 * REF.n)
    np.testing.assert_allclose(cI[mb:], cin[mb:], rtol=0, atol=1e-14)
    np.testing.assert_allclose(JD, Jin[mb:], rtol=0, atol=1e-13)
    np.testing.assert_allclose(cI[:mb], cin[:mb], rtol=1e-12, atol=1e-12)
    for i in range(REF.n):
        np.testing.assert_allclose(
            D[i], Jin[24 * i : 24 * i + 24, 3 * i : 3 * i + 3], rtol=1e-12, atol=1e-12
        )
    num = fd.central(lambda v: _evaluate_ip(v, P)[4][mb:], u)
    fd.assert_derivative_close(JD, num, f_scale=fd.term_scale(cI[mb:], num), what="planar JD")


def test_no_obstacle_rows_leave_the_kernel_data_empty() -> None:
    """Without obstacles (or with one out of reach) the planar kernels see no dense row:
    the lean problem data, whose A_I is the blocks alone, exactly the evaluation's."""
    from stackik._compiled.planar import _evaluate

    t = _targets()[0]
    far = sk.Sphere((1e5, 0.0, 0.0), 10.0)
    for obs in ((), (far,)):
        prob = Problem(REF, t, "frobenius", None, obstacles=obs)
        P = problem_arrays(prob)
        assert P.n_dense is None and P.obstacles[-1].size == 0 and not prob.rows_outside_ip
        u = prob.u_of(sk.paper_initial_guess(REF, t))
        f, g, cE, AE, cI, D = _evaluate_ip(u, P)
        f0, g0, cE0, AE0, cI0, D0 = _evaluate(u, P)
        assert D.shape == (REF.n, 24, 3) and f == f0
        for a, b in ((g, g0), (cE, cE0), (AE, AE0), (cI, cI0), (D, D0)):
            assert np.array_equal(a, b)


def test_compiled_polish_corrects_slightly_violated_obstacle_rows() -> None:
    """A planar pose a hair inside the obstacle's row is moved out of it by the compiled
    polish, at the target, and the pose passes the check."""
    from stackik._compiled.barrier import polish
    from stackik.formulation import POLISH_MARGIN, POLISH_REACH

    t = _targets()[1]
    q = sk.solve_ik(REF, t).q
    m, u = _leg(q, t.phi, 1)
    er = np.array([np.cos(t.phi), np.sin(t.phi), 0.0])  # off the leg, in the plane (where
    d = er - (er @ u) * u  # planar poses move it)
    d /= np.linalg.norm(d)
    sphere = sk.Sphere(m + (7.0 - 1e-5) * d, 7.0)  # its surface 1e-5 mm into the axis
    prob = Problem(REF, t, "frobenius", None, obstacles=[sphere])
    P = problem_arrays(prob)
    u0 = prob.u_of(q)
    cI0 = _evaluate_ip(u0, P)[4]
    assert -POLISH_REACH < cI0[24 * REF.n :].min() < 0.0
    u1 = polish(u0, P, 3, POLISH_REACH, POLISH_MARGIN)
    _, _, cE1, _, cI1, _ = _evaluate_ip(u1, P)
    assert cI1[24 * REF.n :].min() >= 0.0
    assert cI1.min() > -1e-3 * POLISH_REACH and np.abs(cE1).max() < 1e-13
    assert np.abs(u1 - u0).max() < 1e-6
    assert prob.check(prob.q_of(u1)).ok


@pytest.mark.parametrize(("kind", "k"), [("sphere", 0), ("sphere", 3), ("truss", 5)])
def test_planar_interior_point_goes_around_obstacles_without_slsqp(kind: str, k: int) -> None:
    """A sphere or a truss member across a leg of the planar least-FN pose: the interior
    point itself (``method="ip"``, and the default without a hand-over: its method is
    ``"ip"``) returns a pose that the independent check passes, clear of the obstacle,
    within 2 % of the obstacle-free FN."""
    t = _targets()[k]
    plain = sk.solve_ik(REF, t)
    ob = _obstacle(kind, plain.q, t.phi, k % 6)
    assert sk.clearances(REF, plain.q, [ob], phi=t.phi).obstacles[0] < 0  # the optimum collides
    assert not Problem(REF, t, "frobenius", None, obstacles=[ob]).rows_outside_ip
    for method in ("ip", "auto"):
        r = sk.solve_ik(REF, t, obstacles=[ob], method=method)
        assert r.success and r.method == "ip", (kind, k, method, r.method, r.message)
        assert sk.check_pose(REF, t, r.q, obstacles=[ob]).ok
        assert sk.clearances(REF, r.q, [ob], phi=t.phi).obstacles[0] >= -1e-6
        assert r.frobenius_norm <= plain.frobenius_norm * 1.02


def test_planar_floor_and_sphere_together() -> None:
    """Two obstacles at once (a sphere on a leg and a floor under the base): both rows in
    the kernel, the default's pose clear of both."""
    t = _targets()[4]
    plain = sk.solve_ik(REF, t)
    obs = [_obstacle("sphere", plain.q, t.phi, 4), _obstacle("wall", plain.q, t.phi, 0)]
    P = problem_arrays(Problem(REF, t, "frobenius", None, obstacles=obs))
    assert P.n_dense == 7 * REF.n + 12 * REF.n  # the sphere's legs and plates, the wall's
    r = sk.solve_ik(REF, t, obstacles=obs)
    assert r.success and r.method == "ip", r.message
    assert min(sk.clearances(REF, r.q, obs, phi=t.phi).obstacles) >= -1e-6


def test_planar_rows_outside_the_interior_point() -> None:
    """Planar obstacle and leg-force rows are in the kernel; planar self-leg rows are not (a
    run failing only on them is still handed over)."""
    t = _targets()[0]
    sphere = sk.Sphere((0.0, 0.0, 700.0), 20.0)
    assert not Problem(REF, t, "frobenius", None, obstacles=[sphere]).rows_outside_ip
    fat = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=12.0), 4)
    assert Problem(fat, t, "frobenius", None, obstacles=[sphere]).rows_outside_ip
    limited = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(force_max=100.0), 4)
    assert not Problem(limited, t, "frobenius", None, obstacles=[sphere]).rows_outside_ip


def test_planar_bad_obstacles_are_refused() -> None:
    """Bad input is refused as before, planar too: a negative radius, a zero normal, an
    obstacle on a base joint."""
    t = _targets()[0]
    with pytest.raises(ValueError):
        sk.solve_ik(REF, t, obstacles=[sk.Sphere((0.0, 0.0, 500.0), -1.0)])
    with pytest.raises(ValueError):
        sk.solve_ik(REF, t, obstacles=[sk.HalfSpace((0.0, 0.0, -30.0), (0.0, 0.0, 0.0))])
    with pytest.raises(ValueError):
        sk.solve_ik(REF, t, obstacles=[sk.Sphere(REF.base_nodes[0][0], 5.0)])
