"""The check's compiled body distances (stackik._compiled.body_distances) equal the plain
numpy geometry of stackik.distance, pair by pair, on random and degenerate cases."""

from __future__ import annotations

import numpy as np
import pytest

from stackik import distance as dist
from stackik._compiled import body_distances as bd
from stackik.rotations import euler_zyx

# distances of order 100 mm computed two ways (same formulas, other operation order)
TOL = 1e-9


def _segments(rng: np.random.Generator, m: int) -> tuple[np.ndarray, ...]:
    a0, a1, b0, b1 = (rng.uniform(-100, 100, (m, 3)) for _ in range(4))
    # degenerate and parallel cases: a point, parallel and collinear segments, crossings
    a1[0] = a0[0]
    b1[1] = b0[1] + (a1[1] - a0[1])
    b0[2], b1[2] = a0[2] + 0.3 * (a1[2] - a0[2]), a0[2] + 1.7 * (a1[2] - a0[2])
    b0[3], b1[3] = 0.5 * (a0[3] + a1[3]) - (5, 0, 0), 0.5 * (a0[3] + a1[3]) + (5, 0, 0)
    return a0, a1, b0, b1


def test_segment_segment_matches_numpy() -> None:
    rng = np.random.default_rng(29)
    a0, a1, b0, b1 = _segments(rng, 400)
    ref = dist.segment_segment(a0, a1, b0, b1)
    got = np.array([bd.segment_segment(*x) for x in zip(a0, a1, b0, b1, strict=True)])
    assert np.allclose(got, ref, rtol=0, atol=TOL)
    assert got[3] <= TOL  # two segments that cross


def _polygon(rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    pts = rng.uniform(-80, 80, (8, 2))
    uv = dist.convex_hull_2d(pts, size=8)
    O = rng.uniform(-50, 50, 3)
    A = euler_zyx(rng.uniform(-np.pi, np.pi, 3))
    return O, A, uv


def _world_vertices(O: np.ndarray, A: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """The polygon's vertices in the world frame, the kernels' ``V`` argument, from the
    public geometry (:meth:`stackik.distance.Polygon.vertices`), not a kernel helper."""
    return np.ascontiguousarray(dist.Polygon(O, A, uv).vertices())


@pytest.mark.parametrize("seed", range(4))
def test_segment_and_polygon_distances_match_numpy(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    for _ in range(60):
        O, A, uv = _polygon(rng)
        V = _world_vertices(O, A, uv)
        a, b = rng.uniform(-120, 120, (2, 3))
        poly = dist.Polygon(O, A, uv)
        ref = float(dist.segment_polygon(a, b, poly))
        assert bd.segment_polygon(a, b, O, A, uv, V) == pytest.approx(ref, abs=TOL)
        O2, A2, uv2 = _polygon(rng)
        V2 = _world_vertices(O2, A2, uv2)
        ref = float(dist.polygon_polygon(poly, dist.Polygon(O2, A2, uv2)))
        got = bd.polygon_polygon(O, A, uv, V, O2, A2, uv2, V2)
        assert got == pytest.approx(ref, abs=TOL)
    # through the polygon's interior: minus the penetration depth, as the reference's
    for _ in range(20):
        O, A, uv = _polygon(rng)
        c = O + A[:, :2] @ uv.mean(axis=0)
        a = c - rng.uniform(5, 60) * A[:, 2] + rng.normal(0, 10, 3)
        b = c + rng.uniform(5, 60) * A[:, 2] + rng.normal(0, 10, 3)
        poly = dist.Polygon(O, A, uv)
        ref = float(dist.segment_polygon(a, b, poly))
        got = bd.segment_polygon(a, b, O, A, uv, _world_vertices(O, A, uv))
        assert got == pytest.approx(ref, abs=TOL)
        O2, A2, uv2 = _polygon(rng)
        O2 = c + rng.normal(0, 10, 3)
        ref = float(dist.polygon_polygon(poly, dist.Polygon(O2, A2, uv2)))
        got = bd.polygon_polygon(
            O, A, uv, _world_vertices(O, A, uv), O2, A2, uv2, _world_vertices(O2, A2, uv2)
        )
        assert got == pytest.approx(ref, abs=TOL)
