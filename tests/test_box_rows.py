"""Box obstacles in the solvers' rows (issue 29): the kernel's segment-box signed distance
against the check's exact one, the rows' Jacobian against central differences (spatial and
planar, clear and penetrating), IPOPT's symbolic rows equal to the kernel's, the
half-space rows holding the plates too, and every method going around a box placed
across the legs of the obstacle-free optimum."""

from __future__ import annotations

import fd
import numpy as np
import pytest

import stackik as sk
from stackik import distance as dist
from stackik.formulation.obstacle_rows import ObstacleRows
from stackik.sampling import random_feasible_poses

FAT = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=6.0), 3)


def _rotation(rng: np.random.Generator) -> np.ndarray:
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    Q = Q * np.sign(np.diag(R))
    return Q if np.linalg.det(Q) > 0 else -Q


def _legs(stack: sk.Stack, q: np.ndarray, phi: float | None = None) -> tuple[np.ndarray, ...]:
    from stackik.clearance import plate_frames

    A, O = plate_frames(stack, q, phi=phi)
    B = np.concatenate([O[i] + stack.base_nodes[i] @ A[i].T for i in range(stack.n)])
    T = np.concatenate([O[i + 1] + stack.top_nodes[i] @ A[i + 1].T for i in range(stack.n)])
    return B, T


def test_segment_box_kernel_is_the_exact_distance() -> None:
    """The kernel's signed segment-box distance equals stackik.distance.segment_box (the
    check's) on random segments and boxes, clear, touching-close and penetrating; its
    closest point is at that distance, and outside its direction is a unit vector."""
    from stackik._compiled.obstacle_rows import _segment_box

    rng = np.random.default_rng(29)
    g = np.empty(3)
    inside = 0
    for trial in range(400):
        h = rng.uniform(0.0, 60.0, 3)
        if trial % 7 == 0:
            h[rng.integers(3)] = 0.0  # a flat box
        p0 = rng.uniform(-120, 120, 3) if trial % 2 else rng.uniform(-40, 40, 3)
        d = rng.uniform(-200, 200, 3) if trial % 11 else np.zeros(3)
        sd, t = _segment_box(p0, d, h, g)
        exact = float(dist.segment_box(p0, p0 + d, np.zeros(3), h, np.eye(3)))
        scale = 1.0 + np.abs(p0).max() + np.abs(d).max() + h.max()
        assert sd == pytest.approx(exact, abs=1e-12 * scale)
        assert 0.0 <= t <= 1.0
        at = float(dist.point_box(p0 + t * d, np.zeros(3), h, np.eye(3)))
        assert at == pytest.approx(sd, abs=1e-12 * scale)
        if sd > 0.0:
            assert np.linalg.norm(g) == pytest.approx(1.0, abs=1e-12)
        else:
            inside += 1
    assert 60 < inside < 340  # both branches exercised


def _pose(stack: sk.Stack, phi: float | None, rng: np.random.Generator) -> np.ndarray:
    """A planar feasible pose in the plane ``phi``, or a spatial one near the straight stack."""
    if phi is not None:
        return random_feasible_poses(stack, 1, rng=rng, phi=phi)[0]
    base = np.tile([0.0, 0.0, 300.0, 0.0, 0.0, 0.0], (stack.n, 1))
    return base + rng.normal(0, [20, 20, 20, 0.2, 0.2, 0.2], (stack.n, 6))


def _boxes(stack: sk.Stack, q: np.ndarray, phi: float | None, rng: np.random.Generator):
    """A box through leg 2 of platform 2 (penetrating) and one beside leg 4, outward (clear)."""
    B, T = _legs(stack, q, phi)
    m1 = 0.5 * (B[8] + T[8])
    m2 = 0.5 * (B[10] + T[10])
    out = np.array([m2[0], m2[1], 0.0]) / np.hypot(m2[0], m2[1])
    through = sk.Box(m1 + rng.normal(0, 2, 3), (15.0, 10.0, 25.0), _rotation(rng))
    beside = sk.Box(m2 + 40.0 * out, (12.0, 12.0, 12.0))
    return through, beside


@pytest.mark.derivatives
@pytest.mark.parametrize("phi", [None, 0.4])
def test_box_rows_derivatives_and_values(phi: float | None) -> None:
    """The box rows' Jacobian against central differences (a box through a leg and a box
    beside one, spatial and planar), and their values against the check's exact
    leg-box distances."""
    rng = np.random.default_rng(7)
    q = _pose(FAT, phi, rng)
    boxes = _boxes(FAT, q, phi, rng)
    rows = ObstacleRows(FAT, boxes, 1.5, phi)
    c, J = rows(q)
    assert c.shape == (rows.size,) == (2 * 6 * FAT.n,)
    assert c[:18].min() < 0.0 < c[18:].min()  # through one leg, clear of the other box
    num = fd.central(lambda x: rows(x.reshape(q.shape))[0], q.ravel())
    fd.assert_derivative_close(J, num, f_scale=fd.term_scale(c, num), what="box rows")
    B, T = _legs(FAT, q, phi)
    for b, ob in enumerate(boxes):
        assert ob.rotation is not None
        exact = dist.segment_box(B, T, ob.center, ob.half_extents, ob.rotation) - 6.0 - 1.5
        np.testing.assert_allclose(c[18 * b : 18 * b + 18] * rows.L, exact, rtol=0, atol=1e-9)


def test_ipopt_box_rows_are_the_kernels() -> None:
    """IPOPT's symbolic box rows equal the kernel's in value and Jacobian (boxes through,
    beside and rotated about the legs; half-spaces with thick plates)."""
    ca = pytest.importorskip("casadi")
    from stackik.methods.ipopt import obstacle_function

    stack = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=5.0, plate_thickness=20.0), 3)
    rng = np.random.default_rng(3)
    qs = ca.SX.sym("q", 6 * stack.n)
    for _ in range(4):
        q = _pose(stack, None, rng)
        obstacles = (*_boxes(stack, q, None, rng), sk.HalfSpace((0, 0, -20.0), (0.1, 0, 1)),
                     *_plate_spheres(stack, q, None))  # fmt: skip
        rows = ObstacleRows(stack, obstacles, 2.0)
        f = obstacle_function(stack, obstacles, 2.0)
        Jf = ca.Function("J", [qs], [ca.jacobian(f(qs), qs)])
        c, J = rows(q)
        np.testing.assert_allclose(np.asarray(f(q.ravel())).ravel(), c, rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.asarray(Jf(q.ravel())), J, rtol=0, atol=1e-10)


def _plate_spheres(stack: sk.Stack, q: np.ndarray, phi: float | None) -> tuple[sk.Sphere, ...]:
    """A sphere 25 mm above plate 2's centre, one through plate 1's rim and one beside
    plate 3's rim (outside its polygon, in its plane)."""
    from stackik.clearance import plate_frames

    A, O = plate_frames(stack, q, phi=phi)
    rim = stack.top_nodes[0][0]
    side = stack.top_nodes[2][3] * 1.2
    return (
        sk.Sphere(O[2] + 25.0 * A[2][:, 2], 10.0),
        sk.Sphere(O[1] + A[1] @ rim + 3.0 * A[1][:, 2], 8.0),
        sk.Sphere(O[3] + A[3] @ side, 5.0),
    )


@pytest.mark.derivatives
@pytest.mark.parametrize("phi", [None, 0.4])
def test_sphere_plate_rows_derivatives_and_values(phi: float | None) -> None:
    """A sphere's rows: the legs', then one per plate (1..n); their Jacobian against central
    differences, and the least surface distance they give equal to the check's."""
    rng = np.random.default_rng(17)
    stack = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=6.0, plate_thickness=8.0), 3)
    q = _pose(stack, phi, rng)
    spheres = _plate_spheres(stack, q, phi)
    rows = ObstacleRows(stack, spheres, 1.0, phi)
    c, J = rows(q)
    n = stack.n
    assert c.shape == (rows.size,) == (3 * 7 * n,)
    num = fd.central(lambda x: rows(x.reshape(q.shape))[0], q.ravel())
    fd.assert_derivative_close(J, num, f_scale=fd.term_scale(c, num), what="sphere-plate rows")
    L = rows.L
    cl = sk.clearances(stack, q, spheres, phi=phi)
    for s, sp in enumerate(spheres):
        block = c[7 * n * s : 7 * n * (s + 1)]
        R = sp.radius
        legs = np.sqrt(block[: 6 * n] * L**2 + (R + 6.0 + 1.0) ** 2) - R - 6.0
        plates = np.sqrt(block[6 * n :] * L**2 + (R + 4.0 + 1.0) ** 2) - R - 4.0
        assert min(legs.min(), plates.min()) == pytest.approx(cl.obstacles[s], abs=1e-9)
    assert c[6 * n + 1] > 0.0 and c[7 * n + 6 * n] < 0.0  # above plate 2; through plate 1


def test_halfspace_rows_hold_the_plates() -> None:
    """With plates thicker than the legs, the least half-space row is the check's least
    clearance of every leg and plate (but the base) from the half-space: the rows are
    exact for the plates too."""
    stack = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=4.0, plate_thickness=30.0), 3)
    half = sk.HalfSpace((240.0, 0.0, 0.0), (-1.0, 0.1, 0.05))
    rng = np.random.default_rng(4)
    for q in [_pose(stack, None, rng) for _ in range(4)] + [_pose(stack, 0.3, rng)]:
        phi = 0.3 if q.shape[1] == 3 else None
        rows = ObstacleRows(stack, (half,), 0.0, phi)
        c, _ = rows(q)
        least = float(c.min() * rows.L)
        check = sk.clearances(stack, q, [half], phi=phi).obstacles[0]
        assert least == pytest.approx(check, abs=1e-9)


REF = sk.Stack.reference(4)


def _beam_across_leg(stack: sk.Stack, q: np.ndarray, phi: float | None, k: int) -> sk.Box:
    """A 300 mm beam of 20 mm square section on the midpoint of leg ``k`` of platform 2,
    horizontal and perpendicular to it (it collides with ``q``)."""
    B, T = _legs(stack, q, phi)
    b, t = B[6 + k], T[6 + k]
    u = (t - b) / np.linalg.norm(t - b)
    d = np.cross(u, [0.0, 0.0, 1.0])
    d /= np.linalg.norm(d)
    return sk.Box(0.5 * (b + t), (150.0, 10.0, 10.0), np.column_stack([d, u, np.cross(d, u)]))


@pytest.mark.parametrize("planar", [False, True])
@pytest.mark.parametrize(
    "method, kw",
    [("auto", {}), ("ip", {}), ("sqp", {"qp_solver": "daqp"}), ("slsqp", {}),
     ("ipopt", {"starts": 4, "rng": 0})],
)  # fmt: skip
def test_methods_go_around_a_box(method: str, kw: dict, planar: bool) -> None:
    """A beam across a leg of the obstacle-free optimum: every method returns a success that
    check_pose with the box accepts, at no less FN than without it."""
    from stackik.formulation import Problem
    from stackik.sampling import random_planar_targets, random_spatial_targets

    if method == "ipopt":
        pytest.importorskip("casadi")
    if planar:
        target = random_planar_targets(REF, 1, rng=5, phis=(0.7,))[0]
        phi: float | None = target.phi
    else:
        target = random_spatial_targets(REF, 1, rng=5)[0]
        phi = None
    r0 = sk.solve_ik(REF, target)
    assert r0.success
    box = _beam_across_leg(REF, r0.q, phi, 2)
    assert not sk.check_pose(REF, target, r0.q, obstacles=[box]).ok  # in the way
    rows = Problem(REF, target, "frobenius", None, obstacles=[box]).clearance.obstacle_rows
    assert rows is not None and rows.size == 6 * REF.n  # the box has rows
    r = sk.solve_ik(REF, target, method=method, obstacles=[box], **kw)
    assert r.success, r.message
    assert sk.check_pose(REF, target, r.q, obstacles=[box]).ok
    assert r.frobenius_norm >= r0.frobenius_norm * (1 - 1e-6)
