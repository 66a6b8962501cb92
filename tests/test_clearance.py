"""stackik.clearances and the clearance part of check_pose (docs/clearance.md)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import stackik
from stackik import (
    Box,
    Capsule,
    HalfSpace,
    PlanarTarget,
    PlatformGeometry,
    SpatialTarget,
    Sphere,
    Stack,
    check_pose,
    clearances,
)
from stackik import distance as dist
from stackik.clearance import _layout, needs_clearances, plate_frames
from stackik.kinematics import planar_forward, spatial_forward
from stackik.rotations import euler_zyx_from_matrix, plane_axis, rodrigues
from stackik.sampling import random_feasible_poses

PHI = 0.3
GEOM = PlatformGeometry.hexagonal(leg_radius=12.0, plate_thickness=10.0)


def _legs(stack, q, phi=None):
    A, O = plate_frames(stack, q, phi)
    B = O[:-1, None] + np.einsum("nij,nkj->nki", A[:-1], stack.base_nodes)
    T = O[1:, None] + np.einsum("nij,nkj->nki", A[1:], stack.top_nodes)
    return A, O, B, T


def _spatial_of_planar(q, phi):
    R = rodrigues(plane_axis(phi), q[:, 2])
    P = np.column_stack([q[:, 0] * np.cos(phi), q[:, 0] * np.sin(phi), q[:, 1]])
    return np.column_stack([P, euler_zyx_from_matrix(R)])


def _naive(stack, q, obstacles, phi=None):
    """Every pair, no screening: the least distance of each kind."""
    lay = _layout(stack)
    A, O, B, T = _legs(stack, q, phi)
    r, ht, n = lay.radius, lay.half_t, stack.n

    def plate(j):
        return dist.Polygon(O[j], A[j], lay.uv[j])

    vals, adj = [], []
    for i in range(n - 1):
        for k, m in itertools.product(range(6), range(6)):
            adj.append(dist.segment_segment(B[i, k], T[i, k], B[i + 1, m], T[i + 1, m]) - 2 * r[i])
    for i in range(n):
        for j in range(i + 2, n):
            for k, m in itertools.product(range(6), range(6)):
                vals.append(dist.segment_segment(B[i, k], T[i, k], B[j, m], T[j, m]) - r[i] - r[j])
        for k, j in itertools.product(range(6), range(n + 1)):
            if j not in (i, i + 1):
                vals.append(dist.segment_polygon(B[i, k], T[i, k], plate(j)) - r[i] - ht[j])
    for j in range(n + 1):
        for jj in range(j + 1, n + 1):
            vals.append(dist.polygon_polygon(plate(j), plate(jj)) - ht[j] - ht[jj])
    obs = []
    for ob in obstacles:
        v = [ob.segment_distance(B[i, k], T[i, k]) - r[i] for i in range(n) for k in range(6)]
        v += [ob.polygon_distance(plate(j)) - ht[j] for j in range(1, n + 1)]
        obs.append(float(np.min(v)))
    least = float(np.min(vals)) if vals else np.inf
    return (float(np.min(adj)) if adj else np.inf), least, obs


OBSTACLES = [
    Sphere([300, 0, 600], 50),
    Box([0, 300, 500], [50, 50, 50]),
    HalfSpace([0, 0, -20], [0, 0, 1]),
    Capsule([-500, 0, 300], [-500, 0, 900], 20),
]


@pytest.mark.parametrize("n", [1, 2, 3, 4, 7])
def test_screened_pairs_equal_every_pair(n):
    stack = Stack.uniform(GEOM, n)
    for q in random_feasible_poses(stack, 4, rng=n, phi=PHI):
        c = clearances(stack, q, OBSTACLES, phi=PHI)
        adj, non_adj, obs = _naive(stack, q, OBSTACLES, PHI)
        assert c.non_adjacent == pytest.approx(non_adj, abs=1e-9) or non_adj == c.non_adjacent
        assert c.adjacent_legs == pytest.approx(adj, abs=1e-9) or adj == c.adjacent_legs
        np.testing.assert_allclose(c.obstacles, obs, rtol=0, atol=1e-9)
        assert c.minimum == min(c.self_legs, c.adjacent_legs, c.non_adjacent, *c.obstacles)
        assert c.closest is not None and c.closest.distance == c.minimum


def test_one_platform_pairs_its_legs_and_its_two_plates():
    stack = Stack.uniform(GEOM, 1)
    c = clearances(stack, random_feasible_poses(stack, 1, 0)[0], phi=0.0)
    assert c.adjacent_legs == np.inf and c.obstacles == ()
    assert [(x.a.kind, x.b.kind) for x in c.contacts] == [("leg", "leg"), ("plate", "plate")]
    assert str(c.contacts[1].a) == "base plate" and 0 < c.non_adjacent < GEOM.leg_max


def test_self_legs_against_dense_sampling():
    # independent of stackik.distance: sample every leg's axis densely
    stack = Stack.uniform(GEOM, 3)
    N = 801
    t = np.linspace(0, 1, N)[:, None]
    for q in random_feasible_poses(stack, 3, rng=11, phi=PHI):
        c = clearances(stack, q, phi=PHI)
        _, _, B, T = _legs(stack, q, PHI)
        for i in range(stack.n):
            best, cover = np.inf, 0.0
            for k, m in itertools.combinations(range(6), 2):
                P = B[i, k] + t * (T[i, k] - B[i, k])
                Q = B[i, m] + t * (T[i, m] - B[i, m])
                d = np.min(np.linalg.norm(P[:, None] - Q[None], axis=-1)) - 2 * GEOM.leg_radius
                best = min(best, d)
                cover = max(
                    cover,
                    (np.linalg.norm(T[i, k] - B[i, k]) + np.linalg.norm(T[i, m] - B[i, m]))
                    / (2 * (N - 1)),
                )
            assert c.self_legs_by_platform[i] <= best + 1e-9
            assert best - c.self_legs_by_platform[i] <= cover + 1e-9
        assert c.self_legs == c.self_legs_by_platform.min()


def test_legs_are_the_legs_of_the_limits():
    stack = Stack.uniform(GEOM, 4)
    q = random_feasible_poses(stack, 1, rng=3, phi=PHI)[0]
    _, _, B, T = _legs(stack, q, PHI)
    c = stack.planar_constraints(q, PHI)
    np.testing.assert_allclose(
        np.sum((T - B) ** 2, axis=-1), c[:, :6] + GEOM.leg_min**2, rtol=1e-12
    )
    A, O = plate_frames(stack, q, PHI)
    y = planar_forward(q)
    np.testing.assert_allclose(O[-1], [y[0] * np.cos(PHI), y[0] * np.sin(PHI), y[1]], atol=1e-9)


def test_planar_equals_the_same_pose_in_spatial_form():
    stack = Stack.uniform(GEOM, 4)
    for q in random_feasible_poses(stack, 3, rng=5, phi=PHI):
        a = clearances(stack, q, OBSTACLES, phi=PHI)
        b = clearances(stack, _spatial_of_planar(q, PHI), OBSTACLES)
        assert a.self_legs == pytest.approx(b.self_legs, abs=1e-9)
        assert a.non_adjacent == pytest.approx(b.non_adjacent, abs=1e-9)
        assert a.adjacent_legs == pytest.approx(b.adjacent_legs, abs=1e-9)
        np.testing.assert_allclose(a.obstacles, b.obstacles, atol=1e-9)
        np.testing.assert_allclose(a.self_legs_by_platform, b.self_legs_by_platform, atol=1e-9)


def test_an_obstacle_across_a_leg_is_named():
    stack = Stack.uniform(GEOM, 3)
    q = random_feasible_poses(stack, 1, rng=8, phi=0.0)[0]
    _, _, B, T = _legs(stack, q, 0.0)
    mid = 0.5 * (B[1, 4] + T[1, 4])
    c = clearances(stack, q, [Sphere([0, 0, 5000], 1), Sphere(mid, 5)], phi=0.0)
    hit = c.contacts[-1]
    assert hit.obstacle == 1 and str(hit.a) == "platform 2 leg 4" and hit.b is None
    assert hit.distance == pytest.approx(-5 - GEOM.leg_radius, abs=1e-9)
    assert c.closest is hit and c.minimum == hit.distance
    assert c.obstacles[0] > 3000
    d = c.to_dict()
    assert (
        d["closest"]["a"] == {"kind": "leg", "index": 2, "leg": 4} and d["closest"]["obstacle"] == 1
    )


def test_a_plate_inside_a_box_is_named():
    stack = Stack.uniform(PlatformGeometry.hexagonal(plate_thickness=10.0), 2)  # thin legs
    q = random_feasible_poses(stack, 1, rng=9, phi=0.0)[0]
    A, O, _, _ = _legs(stack, q, 0.0)
    c = clearances(stack, q, [Box(O[1], [400, 400, 20], rotation=A[1])], phi=0.0)
    # the plate's polygon lies in the box's mid-plane: depth 20, plus half the thickness
    # (its legs reach 20 deep, no more)
    assert str(c.closest.a) == "plate 1"
    assert c.closest.distance == pytest.approx(-20 - 5.0, abs=1e-9)


def test_obstacles_that_collide_with_the_base_are_refused():
    stack = Stack.uniform(GEOM, 2)
    q = random_feasible_poses(stack, 1, rng=1, phi=0.0)[0]
    with pytest.raises(ValueError, match=r"obstacles\[1\]: collides with the base"):
        clearances(stack, q, [Sphere([0, 0, 900], 1), Sphere(stack.base_nodes[0, 2], 1)], phi=0.0)
    with pytest.raises(ValueError, match="less than leg_radius"):
        clearances(stack, q, [HalfSpace([0, 0, 0], [0, 0, 1])], phi=0.0)  # a floor at z = 0
    c = clearances(stack, q, [HalfSpace([0, 0, -12], [0, 0, 1])], phi=0.0)  # 12 mm lower: ok
    assert c.obstacles[0] >= 0
    thin = Stack.reference(
        2, leg_radius=0.0
    )  # legs of zero radius may touch a floor through the base joints
    assert clearances(thin, q, [HalfSpace([0, 0, 0], [0, 0, 1])], phi=0.0).obstacles[0] >= 0


def test_bad_pose_arguments():
    stack = Stack.reference(2, leg_radius=0.0)
    with pytest.raises(ValueError, match="phi: required"):
        clearances(stack, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="phi: only a planar"):
        clearances(stack, np.zeros((2, 6)), phi=0.0)
    with pytest.raises(ValueError, match="q: expected shape"):
        clearances(stack, np.zeros((3, 6)))
    with pytest.raises(ValueError, match="q"):
        clearances(stack, np.full((2, 6), np.nan))
    with pytest.raises(ValueError, match="obstacles"):
        clearances(stack, np.zeros((2, 6)), obstacles=[1.0])  # type: ignore[list-item]


def test_zero_radius_legs_are_distances():
    # no leg's axis passes through a plate of these poses (n = 4: too short to fold back)
    stack = Stack.reference(4, leg_radius=0.0)
    assert not needs_clearances(stack)
    assert needs_clearances(stack, clearance=1.0) and needs_clearances(stack, [OBSTACLES[0]])
    assert needs_clearances(Stack.uniform(GEOM, 2))
    for q in random_feasible_poses(stack, 5, rng=2, phi=PHI):
        c = clearances(stack, q, phi=PHI)
        assert c.self_legs >= 0 and c.non_adjacent >= 0 and c.adjacent_legs >= 0


def _through_a_plate():
    """A planar n = 16 target (the fingerprint's, seed 36) and the least-FN pose of legs as
    lines that passes through plates (the paper's model: the check's screen off), found by
    the default as it was before the check knew of it."""
    from helpers import screen_off

    from stackik.sampling import random_reachable_targets

    stack = Stack.reference(16, leg_radius=0.0)
    t = random_reachable_targets(stack, 3, rng=36, phi=PHI)[0]
    with screen_off():
        q = stackik.solve_ik(stack, t).q
    return stack, t, q


def test_a_leg_through_a_plate_fails_with_no_thickness():
    """Legs and plates of no size: a leg's axis through a plate is a collision (minus the
    penetration depth), found by the screen and refused by the check, and the default
    answers the target with a pose where none passes through (docs/clearance.md, "Cores
    through plates")."""
    from stackik.clearance import cores_cross

    stack, t, q = _through_a_plate()
    assert cores_cross(stack, q, PHI)
    c = clearances(stack, q, phi=PHI)
    assert c.non_adjacent < -1.0 and c.minimum == c.non_adjacent
    assert {c.closest.a.kind, c.closest.b.kind} == {"leg", "plate"}
    chk = check_pose(stack, t, q)
    assert not chk.ok and chk.clearances is not None
    assert chk.clearance_violation == pytest.approx(-c.minimum)
    assert chk.position_error < 1e-6 and chk.max_violation_mm <= 1e-6  # only that
    res = stackik.solve_ik(stack, t)
    assert res.success and not cores_cross(stack, res.q, PHI)
    assert clearances(stack, res.q, phi=PHI).minimum >= -1e-6
    assert check_pose(stack, t, res.q).ok


def test_cores_cross_is_the_sign_of_the_clearances():
    """The compiled screen says a pose's cores cross exactly where the exact signed
    distances (zero radii and thickness) are negative: on poses between one that passes
    through plates and the default's, both kinds occur."""
    from stackik.clearance import cores_cross

    stack, t, q = _through_a_plate()
    clear = stackik.solve_ik(stack, t).q
    rng = np.random.default_rng(3)
    seen = set()
    for k in range(40):
        x = q + (k / 39) * (clear - q) + rng.normal(0.0, [1.0, 1.0, 0.01], q.shape)
        neg = clearances(stack, x, phi=PHI).minimum < 0.0
        assert cores_cross(stack, x, PHI) == neg
        seen.add(neg)
    assert seen == {True, False}
    for x in random_feasible_poses(stack, 5, rng=4, phi=PHI):
        assert cores_cross(stack, x, PHI) == (clearances(stack, x, phi=PHI).minimum < 0.0)


# --- the check ----------------------------------------------------------------------------
def _planar_case(geom, n=3, seed=4):
    stack = Stack.uniform(geom, n)
    q = random_feasible_poses(stack, 1, rng=seed, phi=PHI)[0]
    y = planar_forward(q)
    return stack, PlanarTarget(y[0], y[1], y[2], PHI), q


def test_check_without_bodies_is_unchanged():
    stack, target, q = _planar_case(PlatformGeometry.reference(leg_radius=0.0))
    chk = check_pose(stack, target, q)
    assert chk.ok and chk.clearances is None and chk.clearance_violation == 0.0
    far = check_pose(stack, target, q, obstacles=[Sphere([0, 0, 1e5], 1)])
    assert far.ok and far.clearances is not None and far.clearances.obstacles[0] > 9e4


def test_check_fails_on_penetration_and_margin():
    stack, target, q = _planar_case(GEOM)
    chk = check_pose(stack, target, q)
    assert chk.clearances is not None
    assert chk.ok == (chk.clearances.minimum >= 0)
    m = chk.clearances.minimum
    assert check_pose(stack, target, q, clearance=max(m, 0) + 1.0).clearance_violation > 0.99
    _, _, B, T = _legs(stack, q, PHI)
    through = Capsule(B[2, 0] + [0, 0, 50], T[2, 0] + [0, 0, 50], 80.0)
    bad = check_pose(stack, target, q, obstacles=[through])
    assert not bad.ok and bad.clearances.obstacles[0] < 0
    assert bad.clearance_violation == pytest.approx(-bad.clearances.minimum)
    with pytest.raises(ValueError, match="clearance"):
        check_pose(stack, target, q, clearance=-1.0)
    with pytest.raises(ValueError, match="clearance"):
        check_pose(stack, target, q, clearance=float("nan"))


def test_check_spatial_target():
    stack = Stack.uniform(GEOM, 2)
    q = _spatial_of_planar(random_feasible_poses(stack, 1, rng=6, phi=0.0)[0], 0.0)
    P, R = spatial_forward(q)
    chk = check_pose(stack, SpatialTarget(P, R), q, obstacles=[Sphere([0, 0, 5000], 10)])
    assert chk.clearances is not None and len(chk.clearances.obstacles) == 1


def test_public_names():
    for name in (
        "clearances",
        "Clearances",
        "Sphere",
        "Capsule",
        "Box",
        "HalfSpace",
        "load_obstacles",
    ):
        assert name in stackik.__all__ and hasattr(stackik, name)


# --- the solve's verdict goes through the clearances ---------------------------------------
@pytest.mark.parametrize("planar", [True, False])
def test_solve_never_claims_a_colliding_pose(planar):
    from stackik import solve_ik
    from stackik.sampling import random_spatial_targets

    thin = Stack.reference(4, leg_radius=0.0)
    if planar:
        q0 = random_feasible_poses(thin, 1, rng=21, phi=0.0)[0]
        y = planar_forward(q0)
        target = PlanarTarget(y[0], y[1], y[2], 0.0)
        phi = 0.0
    else:
        target = random_spatial_targets(thin, 1, rng=700)[0]
        phi = None
    res = solve_ik(thin, target)
    assert res.success
    gap = clearances(thin, res.q, phi=phi).self_legs
    # legs just thick enough that today's pose collides
    fat = Stack.uniform(PlatformGeometry.hexagonal(leg_radius=gap / 2 + 1.0), 4)
    res2 = solve_ik(fat, target)
    if res2.success:
        assert clearances(fat, res2.q, phi=phi).minimum >= -1e-6
    assert not (res2.success and np.allclose(res2.q, res.q))


def test_adjacent_legs_that_share_a_joint_are_not_paired():
    # platform 2's base nodes on platform 1's top nodes (a = 45 deg, b = 15 deg)
    low = PlatformGeometry.hexagonal(leg_radius=12.0)
    high = PlatformGeometry.hexagonal(base_half_angle=np.radians(45), leg_radius=12.0)
    np.testing.assert_allclose(
        np.sort(high.base_nodes, axis=0), np.sort(low.top_nodes, axis=0), atol=1e-12
    )
    stack = Stack((low, high))
    assert len(_layout(stack).adj) == 30
    assert len(_layout(Stack.uniform(low, 2)).adj) == 36
    for q in random_feasible_poses(stack, 3, rng=4, phi=0.0):
        c = clearances(stack, q, phi=0.0)
        assert c.adjacent_legs > -2 * 12.0 + 1.0  # not the -2r of two legs on one joint
