"""Exact distances (stackik.distance) against brute-force dense sampling, and their
invariants (hypothesis).

A sampled minimum is never below the exact one (each sample is a point of the shape) and
exceeds it by at most the sampling's covering radius (distances are 1-Lipschitz): the
tolerances below follow from the resolution, not from fitting.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from stackik import distance as dist

ROUND = 1e-9  # [mm] rounding allowance of the exact values at the scales below (~100 mm)


def _seg_samples(a, b, N):
    """N points along [a, b]; covering radius |b - a| / (2 (N - 1))."""
    t = np.linspace(0.0, 1.0, N)[:, None]
    return a + t * (b - a), np.linalg.norm(b - a) / (2 * (N - 1))


def _pairwise_min(P, Q):
    return float(np.min(np.linalg.norm(P[:, None, :] - Q[None, :, :], axis=-1)))


def _rotation(rng):
    return Rotation.random(random_state=int(rng.integers(2**31))).as_matrix()


def _polygon(rng, m=6, radius=100.0):
    """A random convex polygon (hull of m points) in a random frame."""
    pts = rng.uniform(-radius, radius, (m + 3, 2))
    uv = dist.convex_hull_2d(pts, size=m + 3)
    return dist.Polygon(rng.normal(0, 50, 3), _rotation(rng), uv)


def _polygon_samples(poly, N):
    """Points filling the polygon (a fan of triangles, barycentric grid of N per side) and
    their covering radius (at most the longest fan edge over N)."""
    V = poly.vertices()
    pts, longest = [], 0.0
    i, j = np.meshgrid(np.arange(N + 1), np.arange(N + 1))
    keep = i + j <= N
    a, b = (i[keep] / N)[:, None], (j[keep] / N)[:, None]
    for k in range(1, len(V) - 1):
        v0, v1, v2 = V[0], V[k], V[k + 1]
        pts.append(v0 + a * (v1 - v0) + b * (v2 - v0))
        longest = max(longest, *(np.linalg.norm(x - y) for x, y in ((v0, v1), (v1, v2), (v0, v2))))
    return np.concatenate(pts), longest / N


# --- point / segment -----------------------------------------------------------------------
def test_point_segment_against_sampling():
    rng = np.random.default_rng(1)
    for _ in range(100):
        p, a, b = rng.normal(0, 100, (3, 3))
        S, cover = _seg_samples(a, b, 4001)
        brute = float(np.min(np.linalg.norm(S - p, axis=1)))
        d = float(dist.point_segment(p, a, b))
        assert d <= brute + ROUND
        assert brute - d <= cover + ROUND


def test_point_segment_degenerate_is_point_distance():
    p, a = np.array([1.0, 2.0, 3.0]), np.array([4.0, 6.0, 3.0])
    assert dist.point_segment(p, a, a) == pytest.approx(5.0, abs=1e-15)


def _random_segment_pairs(rng, count):
    for c in range(count):
        a0, a1, b0, b1 = rng.normal(0, 100, (4, 3))
        kind = c % 5
        if kind == 1:  # parallel, overlapping or not
            b1 = b0 + (a1 - a0) * rng.uniform(-2, 2)
        elif kind == 2:  # a point
            a1 = a0.copy()
        elif kind == 3:  # crossing exactly
            m = a0 + rng.uniform() * (a1 - a0)
            d = rng.normal(size=3)
            b0, b1 = m - rng.uniform(1, 50) * d, m + rng.uniform(1, 50) * d
        elif kind == 4:  # collinear
            d = a1 - a0
            b0, b1 = a0 + rng.uniform(-2, 2) * d, a0 + rng.uniform(-2, 2) * d
        yield a0, a1, b0, b1


def test_segment_segment_against_sampling():
    rng = np.random.default_rng(2)
    for a0, a1, b0, b1 in _random_segment_pairs(rng, 150):
        P, ca = _seg_samples(a0, a1, 1501)
        Q, cb = _seg_samples(b0, b1, 1501)
        brute = _pairwise_min(P, Q)
        d = float(dist.segment_segment(a0, a1, b0, b1))
        assert d >= 0.0
        assert d <= brute + ROUND
        assert brute - d <= ca + cb + ROUND


def test_segment_segment_crossing_is_zero_and_vectorised():
    a0 = np.array([[0.0, 0, 0], [0, 0, 0]])
    a1 = np.array([[2.0, 0, 0], [2, 0, 0]])
    b0 = np.array([[1.0, -1, 0], [1, -1, 5]])
    b1 = np.array([[1.0, 1, 0], [1, 1, 5]])
    np.testing.assert_allclose(dist.segment_segment(a0, a1, b0, b1), [0.0, 5.0], atol=1e-15)


def test_segment_segment_nearly_parallel_is_accurate():
    # lines 1e-9 rad apart: the line candidate is ill-conditioned, the endpoints are not
    a0, a1 = np.array([0.0, 0, 0]), np.array([1000.0, 0, 0])
    b0 = np.array([500.0, 0, 10])
    b1 = b0 + np.array([1000.0, 1e-6, 0])
    assert float(dist.segment_segment(a0, a1, b0, b1)) == pytest.approx(10.0, abs=1e-9)


# --- half-spaces -----------------------------------------------------------------------------
def test_segment_and_polygon_halfspace_are_least_heights():
    rng = np.random.default_rng(3)
    for _ in range(50):
        a, b, point = rng.normal(0, 100, (3, 3))
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        S, cover = _seg_samples(a, b, 2001)
        brute = float(np.min((S - point) @ n))
        assert abs(float(dist.segment_halfspace(a, b, point, n)) - brute) <= ROUND
        poly = _polygon(rng)
        X, _ = _polygon_samples(poly, 40)
        assert float(dist.polygon_halfspace(poly, point, n)) == pytest.approx(
            float(np.min((X - point) @ n)), abs=ROUND
        )


# --- boxes ---------------------------------------------------------------------------------
def _box_brute(p, c, h, R, N=121):
    """Signed distance of points p (k, 3) to a box by sampling its surface."""
    g = np.linspace(-1.0, 1.0, N)
    u, v = np.meshgrid(g, g)
    u, v = u.ravel(), v.ravel()
    faces = []
    for axis in range(3):
        others = [i for i in range(3) if i != axis]
        for side in (-1.0, 1.0):
            f = np.zeros((u.size, 3))
            f[:, axis] = side
            f[:, others[0]], f[:, others[1]] = u, v
            faces.append(f)
    surf = np.concatenate(faces) * h @ R.T + c  # (m, 3)
    d = np.min(np.linalg.norm(p[:, None, :] - surf[None], axis=-1), axis=1)
    local = (p - c) @ R
    inside = np.all(np.abs(local) <= h, axis=1)
    cover = np.linalg.norm(h) * 2 / (N - 1)  # a cell's diagonal, generously
    return np.where(inside, -d, d), cover


def test_point_box_against_sampling():
    rng = np.random.default_rng(4)
    c, h, R = rng.normal(0, 20, 3), rng.uniform(5, 60, 3), _rotation(rng)
    p = c + rng.normal(0, 60, (300, 3))
    brute, cover = _box_brute(p, c, h, R)
    d = dist.point_box(p, c, h, R)
    assert np.all(np.abs(d - brute) <= cover + ROUND)
    assert np.all(np.sign(d[np.abs(brute) > cover]) == np.sign(brute[np.abs(brute) > cover]))


def test_segment_box_against_sampling():
    # point_box is exact (above); the segment's distance is its least over the segment
    rng = np.random.default_rng(5)
    for k in range(150):
        c, h, R = rng.normal(0, 20, 3), rng.uniform(0, 60, 3), _rotation(rng)
        if k % 7 == 0:
            h[rng.integers(3)] = 0.0  # a flat box
        a, b = c + rng.normal(0, 80, (2, 3))
        S, cover = _seg_samples(a, b, 20001)
        brute = float(np.min(dist.point_box(S, c, h, R)))
        d = float(dist.segment_box(a, b, c, h, R))
        assert d <= brute + ROUND
        assert brute - d <= cover + ROUND


def test_segment_through_a_box_is_negative_by_its_depth():
    c, h, R = np.zeros(3), np.array([10.0, 20.0, 30.0]), np.eye(3)
    # along x through the centre: deepest point the centre, depth min(h) = 10
    assert float(dist.segment_box([-50, 0, 0], [50, 0, 0], c, h, R)) == pytest.approx(-10.0)
    # passing 5 mm above the top face, endpoints far outside
    assert float(dist.segment_box([-50, 0, 35], [50, 0, 35], c, h, R)) == pytest.approx(5.0)


# --- polygons ------------------------------------------------------------------------------
def test_convex_hull_2d_counter_clockwise_and_padded():
    pts = np.array([[0, 0], [2, 0], [2, 2], [0, 2], [1, 1], [1, 0]], dtype=float)
    hull = dist.convex_hull_2d(pts, size=6)
    np.testing.assert_array_equal(hull[:4], [[0, 0], [2, 0], [2, 2], [0, 2]])
    np.testing.assert_array_equal(hull[4:], [[0, 2], [0, 2]])
    with pytest.raises(ValueError, match="points"):
        dist.convex_hull_2d([[0, 0], [1, 1], [2, 2]])
    with pytest.raises(ValueError, match="size"):
        dist.convex_hull_2d(pts, size=3)


def test_point_polygon_against_sampling():
    rng = np.random.default_rng(6)
    for _ in range(20):
        poly = _polygon(rng)
        X, cover = _polygon_samples(poly, 150)
        p = poly.origin + rng.normal(0, 120, (40, 3))
        brute = np.min(np.linalg.norm(p[:, None] - X[None], axis=-1), axis=1)
        d = dist.point_polygon(p, poly)
        assert np.all(d <= brute + ROUND)
        assert np.all(brute - d <= cover + ROUND)


def test_segment_polygon_against_sampling():
    rng = np.random.default_rng(7)
    for k in range(60):
        poly = _polygon(rng)
        a, b = poly.origin + rng.normal(0, 120, (2, 3))
        if k % 4 == 0:  # through the polygon's plane near its centre
            n = poly.axes[:, 2]
            a, b = poly.origin + 30 * n + rng.normal(0, 5, 3), poly.origin - 30 * n
        if k % 4 == 1:  # in the plane
            a, b = poly.vertices()[0] * 1.5 - 0.5 * poly.origin, poly.origin + rng.normal(0, 5, 3)
            b = b - (b - poly.origin) @ poly.axes[:, 2] * poly.axes[:, 2]
            a = a - (a - poly.origin) @ poly.axes[:, 2] * poly.axes[:, 2]
        S, cover = _seg_samples(a, b, 5001)
        brute = float(np.min(dist.point_polygon(S, poly)))  # point_polygon: exact, above
        d = float(dist.segment_polygon(a, b, poly))
        if d < 0.0:  # through the polygon: minus the depth (tested below), distance 0
            assert brute <= cover + ROUND
            continue
        assert d <= brute + ROUND
        assert brute - d <= cover + ROUND


def test_polygon_polygon_against_sampling():
    rng = np.random.default_rng(8)
    for k in range(25):
        p, q = _polygon(rng), _polygon(rng)
        if k % 3 == 0:  # coplanar
            q = dist.Polygon(p.origin + p.axes[:, 0] * rng.uniform(-100, 250), p.axes, q.uv)
        X, cover = _polygon_samples(p, 120)
        brute = float(np.min(dist.point_polygon(X, q)))
        d = float(dist.polygon_polygon(p, q))
        assert max(d, 0.0) <= brute + ROUND  # through each other: minus the depth (below)
        assert brute - max(d, 0.0) <= cover + ROUND


def _fibonacci_sphere(N):
    """N unit vectors spread evenly over the sphere; every unit vector is within
    ``2 sqrt(4 pi / N)`` rad of one of them (a generous bound of the spiral's gaps)."""
    k = np.arange(N) + 0.5
    z = 1.0 - 2.0 * k / N
    ang = np.pi * (1.0 + 5**0.5) * k
    r = np.sqrt(1.0 - z * z)
    return np.column_stack([r * np.cos(ang), r * np.sin(ang), z]), 2.0 * np.sqrt(4 * np.pi / N)


def _brute_depth(P, Q, N=200_000):
    """The least over sampled unit directions u of min(h(u), h(-u)), h the support function
    of P - Q, and its error bound: h is max|P - Q|-Lipschitz in u."""
    U, gap = _fibonacci_sphere(N)
    p, q = P @ U.T, Q @ U.T
    h = np.minimum(p.max(0) - q.min(0), q.max(0) - p.min(0))
    lip = np.max(np.linalg.norm(P[:, None] - Q[None], axis=-1))
    return float(h.min()), lip * gap


def test_penetration_depth_of_crossing_cores_against_sampled_directions():
    """A segment through a polygon and two polygons through each other: the signed distance
    is minus the penetration depth, the least over all directions of the support function
    of P - Q (0 in P - Q): never above the sampled directions' least and within their
    resolution of it; and a translation of that length along the best direction found
    separates them."""
    rng = np.random.default_rng(11)
    seen = {"segment": 0, "polygon": 0}
    for k in range(40):
        poly = _polygon(rng)
        n = poly.axes[:, 2]
        c = poly.vertices().mean(axis=0)
        if k % 2 == 0:
            a = c + rng.uniform(5, 60) * n + rng.normal(0, 20, 3)
            b = c - rng.uniform(5, 60) * n + rng.normal(0, 20, 3)
            d = float(dist.segment_polygon(a, b, poly))
            P = np.array([a, b])
            kind = "segment"
        else:
            R = _rotation(rng)
            other = dist.Polygon(
                c + rng.normal(0, 10, 3),
                R,
                dist.convex_hull_2d(rng.uniform(-80, 80, (7, 2)), size=7),
            )
            d = float(dist.polygon_polygon(poly, other))
            if float(dist.polygon_polygon(other, poly)) != pytest.approx(d, abs=ROUND):
                raise AssertionError("not symmetric")
            P = other.vertices()
            kind = "polygon"
        if d >= 0.0:
            continue  # they missed each other
        seen[kind] += 1
        brute, err = _brute_depth(P, poly.vertices())
        assert -d <= brute + ROUND
        assert brute - (-d) <= err + ROUND
    assert min(seen.values()) >= 5


def test_penetration_depth_closed_forms():
    """A segment along the normal through a regular hexagon's centre: the depth is the
    shorter end's height or the inradius; two squares crossing at right angles: the least
    of the heights of the second square's ends."""
    ang = np.arange(6) * np.pi / 3
    hexagon = dist.Polygon(
        np.zeros(3), np.eye(3), np.column_stack([np.cos(ang), np.sin(ang)]) * 150
    )
    inr = 150 * np.cos(np.pi / 6)
    for lo, hi, want in ((30, 40, 30), (200, 250, inr), (300, 120, 120)):
        d = float(dist.segment_polygon([0, 0, -lo], [0, 0, hi], hexagon))
        assert d == pytest.approx(-want, abs=ROUND)
    sq = np.array([[-50.0, -50], [50, -50], [50, 50], [-50, 50]])
    flat = dist.Polygon(np.zeros(3), np.eye(3), sq)
    Rx = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])  # its plane: y = 0
    for dz, want in ((0.0, 50.0), (20.0, 30.0), (-45.0, 5.0)):
        upright = dist.Polygon(np.array([10.0, 0, dz]), Rx, sq)
        assert float(dist.polygon_polygon(flat, upright)) == pytest.approx(-want, abs=ROUND)
    touching = dist.Polygon(np.array([0.0, 0, 50.0]), Rx, sq)
    assert float(dist.polygon_polygon(flat, touching)) == pytest.approx(0.0, abs=ROUND)


def test_polygon_box_against_sampling():
    rng = np.random.default_rng(9)
    signs = set()
    for k in range(40):
        poly = _polygon(rng)
        c = poly.origin + rng.normal(0, 60, 3)
        h, R = rng.uniform(5, 60, 3), _rotation(rng)
        if k % 4 == 0:  # a small box the polygon slices through
            c, h = poly.origin + 0.1 * (poly.vertices()[0] - poly.origin), np.full(3, 4.0)
        X, cover = _polygon_samples(poly, 120)
        brute = float(np.min(dist.point_box(X, c, h, R)))  # point_box: exact, above
        d = float(dist.polygon_box(poly, c, h, R))
        assert d <= brute + ROUND
        assert brute - d <= cover + ROUND
        signs.add(np.sign(d))
    assert signs == {-1.0, 1.0}  # both sides covered


# --- invariants (hypothesis) ---------------------------------------------------------------
coords = st.floats(-200.0, 200.0, allow_nan=False, allow_infinity=False)
vec = st.tuples(coords, coords, coords).map(np.array)
angles = st.tuples(*(st.floats(-np.pi, np.pi) for _ in range(3)))


def _rigid(angles_, shift):
    return Rotation.from_euler("ZYX", angles_).as_matrix(), np.asarray(shift)


@settings(max_examples=60, deadline=None)
@given(vec, vec, vec, vec, angles, vec)
def test_segment_segment_symmetric_and_rigid(a0, a1, b0, b1, ang, shift):
    d = float(dist.segment_segment(a0, a1, b0, b1))
    assert float(dist.segment_segment(b0, b1, a0, a1)) == pytest.approx(d, abs=1e-9)
    assert float(dist.segment_segment(a1, a0, b1, b0)) == pytest.approx(d, abs=1e-9)
    R, t = _rigid(ang, shift)
    moved = float(dist.segment_segment(R @ a0 + t, R @ a1 + t, R @ b0 + t, R @ b1 + t))
    assert moved == pytest.approx(d, abs=1e-8)


@settings(max_examples=60, deadline=None)
@given(vec, vec, vec, st.tuples(*(st.floats(0.0, 80.0) for _ in range(3))), angles, angles, vec)
def test_segment_box_rigid(a, b, c, h, box_ang, ang, shift):
    Rb = Rotation.from_euler("ZYX", box_ang).as_matrix()
    h = np.array(h)
    d = float(dist.segment_box(a, b, c, h, Rb))
    assert float(dist.segment_box(b, a, c, h, Rb)) == pytest.approx(d, abs=1e-9)
    R, t = _rigid(ang, shift)
    moved = float(dist.segment_box(R @ a + t, R @ b + t, R @ c + t, h, R @ Rb))
    assert moved == pytest.approx(d, abs=1e-8)


@settings(max_examples=40, deadline=None)
@given(vec, vec, angles, angles, vec, st.integers(0, 2**31 - 1))
def test_segment_polygon_and_polygon_polygon_rigid(a, b, plate_ang, ang, shift, seed):
    rng = np.random.default_rng(seed)
    p = dist.Polygon(rng.normal(0, 50, 3), Rotation.from_euler("ZYX", plate_ang).as_matrix(),
                  dist.convex_hull_2d(rng.uniform(-100, 100, (8, 2)), size=8))  # fmt: skip
    q = _polygon(rng)
    R, t = _rigid(ang, shift)

    def move(poly):
        return dist.Polygon(R @ poly.origin + t, R @ poly.axes, poly.uv)

    d = float(dist.segment_polygon(a, b, p))
    assert float(dist.segment_polygon(R @ a + t, R @ b + t, move(p))) == pytest.approx(d, abs=1e-8)
    pq = float(dist.polygon_polygon(p, q))
    assert float(dist.polygon_polygon(q, p)) == pytest.approx(pq, abs=1e-9)
    assert float(dist.polygon_polygon(move(p), move(q))) == pytest.approx(pq, abs=1e-8)
    pb = float(dist.polygon_box(p, q.origin, np.array([20.0, 30.0, 40.0]), q.axes))
    moved = float(
        dist.polygon_box(move(p), R @ q.origin + t, np.array([20.0, 30.0, 40.0]), R @ q.axes)
    )
    assert moved == pytest.approx(pb, abs=1e-8)
