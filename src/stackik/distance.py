"""Exact distances between the primitive shapes of the clearance check (plain numpy).

Every function broadcasts over leading axes and returns distances in the units of its
input [mm]. The shapes are the *cores* of the bodies of ``docs/clearance.md``: points,
segments, convex planar polygons, boxes and half-spaces; a body is a core thickened by a
radius (a capsule is a segment plus a radius), so the distance of two bodies is the
distance of their cores minus both radii.

Distances between points and segments are >= 0 (0 when they touch or cross: two segments
that cross only touch, there is no depth to a crossing of lines). A segment through a
polygon, or two polygons through each other, get minus their penetration depth
(:func:`depth`): a leg through a plate collides even when neither has a thickness.
Against a solid core (a box, a half-space) distances are *signed*: the least of the
solid's signed distance function over the other core, negative when it enters the solid
(minus the depth of its deepest point).

No tolerance is involved: each distance is the least of a few closed-form candidates,
each the distance of an actual pair of points (so rounding can only err by ~1e-15
relative, never by a screening threshold). This module knows nothing of stacks.
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "Polygon",
    "convex_hull_2d",
    "depth",
    "point_box",
    "point_polygon",
    "point_segment",
    "polygon_box",
    "polygon_halfspace",
    "polygon_polygon",
    "segment_box",
    "segment_halfspace",
    "segment_polygon",
    "segment_segment",
]

FloatArray = NDArray[np.float64]


def _dot(a: FloatArray, b: FloatArray) -> FloatArray:
    """Dot product over the last axis (length 3), broadcasting (faster than einsum here)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]  # type: ignore[no-any-return]


def _norm(a: FloatArray) -> FloatArray:
    return np.sqrt(_dot(a, a))  # type: ignore[no-any-return]


def _f(x: ArrayLike) -> FloatArray:
    return np.asarray(x, dtype=float)


# -----------------------------------------------------------------------------------------
# points and segments
# -----------------------------------------------------------------------------------------
def _segment_param(p: FloatArray, a: FloatArray, d: FloatArray) -> FloatArray:
    """Parameter in [0, 1] of the point of ``a + t d`` nearest to ``p`` (0 if d = 0)."""
    dd = _dot(d, d)
    num = _dot(p - a, d)
    safe = np.where(dd > 0.0, dd, 1.0)
    return np.clip(np.where(dd > 0.0, num / safe, 0.0), 0.0, 1.0)  # type: ignore[no-any-return]


def point_segment(p: ArrayLike, a: ArrayLike, b: ArrayLike) -> FloatArray:
    """Distance from points ``p`` to segments ``[a, b]``, shape of the broadcast (...).

    Parameters
    ----------
    p, a, b : array_like, shape (..., 3)
        A degenerate segment (``a == b``) is a point.
    """
    p, a, b = _f(p), _f(a), _f(b)
    d = b - a
    t = _segment_param(p, a, d)
    return _norm(a + t[..., None] * d - p)


def segment_segment(a0: ArrayLike, a1: ArrayLike, b0: ArrayLike, b1: ArrayLike) -> FloatArray:
    """Distance between segments ``[a0, a1]`` and ``[b0, b1]``, shape (...).

    The least of five candidates (DESIGN §11): the four endpoint-to-segment distances and,
    when the lines are not parallel, the distance of the lines' closest points clamped into
    both segments (a pair of points of the segments, so never below the true distance).
    The true minimum lies either inside both segments (the line candidate) or on an edge of
    the parameter square (an endpoint candidate), so the least is exact; parallel and
    degenerate (zero-length) segments are covered by the endpoint candidates.

    Parameters
    ----------
    a0, a1, b0, b1 : array_like, shape (..., 3)
    """
    a0, a1, b0, b1 = _f(a0), _f(a1), _f(b0), _f(b1)
    u, v, w = a1 - a0, b1 - b0, a0 - b0
    uu, vv, uv = _dot(u, u), _dot(v, v), _dot(u, v)
    uw, vw = _dot(u, w), _dot(v, w)
    den = uu * vv - uv * uv
    ok = den > 1e-14 * uu * vv
    safe = np.where(ok, den, 1.0)
    s = np.clip((uv * vw - vv * uw) / safe, 0.0, 1.0)
    t = np.clip((uu * vw - uv * uw) / safe, 0.0, 1.0)
    line = _norm(a0 + s[..., None] * u - b0 - t[..., None] * v)
    line = np.where(ok, line, np.inf)
    # the four endpoint-to-segment distances in one batched call (leading axis 4)
    a0, a1, b0, b1 = np.broadcast_arrays(a0, a1, b0, b1)
    ends = point_segment(
        np.stack([a0, a1, b0, b1]), np.stack([b0, b0, a0, a0]), np.stack([b1, b1, a1, a1])
    ).min(axis=0)
    return np.minimum(line, ends)  # type: ignore[no-any-return]


# -----------------------------------------------------------------------------------------
# half-spaces
# -----------------------------------------------------------------------------------------
def segment_halfspace(
    a: ArrayLike, b: ArrayLike, point: ArrayLike, normal: ArrayLike
) -> FloatArray:
    """Signed distance from segments to the half-space ``{x : (x - point) . normal <= 0}``
    seen from outside: the least height ``(x - point) . normal`` of the segment, shape (...).

    ``normal`` must be a unit vector (shape (..., 3)). Negative = the segment reaches into
    the half-space behind the plane, by that depth.
    """
    a, b, point, normal = _f(a), _f(b), _f(point), _f(normal)
    return np.minimum(_dot(a - point, normal), _dot(b - point, normal))  # type: ignore[no-any-return]


# -----------------------------------------------------------------------------------------
# boxes (oriented): centre c, half extents h >= 0, rotation Rb (columns = box axes)
# -----------------------------------------------------------------------------------------
def _to_box(x: FloatArray, c: FloatArray, Rb: FloatArray) -> FloatArray:
    """Coordinates of points ``x`` (..., 3) in the box frame."""
    return np.einsum("...ji,...j->...i", Rb, x - c)  # type: ignore[no-any-return]


def _box_sdf_local(x: FloatArray, h: FloatArray) -> FloatArray:
    q = np.abs(x) - h
    outside = _norm(np.maximum(q, 0.0))
    inside = np.minimum(q.max(axis=-1), 0.0)
    return outside + inside  # type: ignore[no-any-return]


def point_box(p: ArrayLike, center: ArrayLike, half: ArrayLike, Rb: ArrayLike) -> FloatArray:
    """Signed distance from points to oriented boxes (negative inside), shape (...).

    Parameters
    ----------
    p, center : array_like, shape (..., 3)
    half : array_like, shape (..., 3)
        Half extents along the box axes, >= 0.
    Rb : array_like, shape (..., 3, 3)
        Rotation whose columns are the box axes in the frame of ``p``.
    """
    p, c, h, R = _f(p), _f(center), _f(half), _f(Rb)
    return _box_sdf_local(_to_box(p, c, R), h)


def _box_pieces(h: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Signs and half extents of the six affine pieces ``s x_i - h_i`` of the box's
    inner distance ``max_i(|x_i| - h_i)``: each (..., 6) indexing x by ``_AXES``."""
    sign = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])
    return sign, np.repeat(h, 2, axis=-1)


_AXES = np.array([0, 0, 1, 1, 2, 2])

#: Relative rounding of the box's inner program: at or below it (times the coordinates'
#: scale) the core meets the box, whose inner value is then the signed distance. (A core
#: crossing a flat box, h_i = 0, has inner value 0 up to rounding; the edge formula of a
#: disjoint core would miss the crossing.)
_MEETS = 1e-12


def _segment_box_inner(p0: FloatArray, d: FloatArray, h: FloatArray) -> FloatArray:
    """``min_{t in [0,1]} max_i (|p0_i + t d_i| - h_i)`` (box frame): a 1D linear program,
    exact over the candidates t = 0, 1 and the crossings of two of the six pieces."""
    sign, hh = _box_pieces(h)
    m = sign * d[..., _AXES]  # slopes (..., 6)
    c = sign * p0[..., _AXES] - hh  # intercepts (..., 6)
    i, j = np.triu_indices(6, 1)
    dm = m[..., i] - m[..., j]
    okm = np.abs(dm) > 0.0
    tc = np.where(okm, (c[..., j] - c[..., i]) / np.where(okm, dm, 1.0), 0.0)
    tc = np.clip(tc, 0.0, 1.0)
    ts = np.concatenate([np.zeros(tc.shape[:-1] + (1,)), np.ones(tc.shape[:-1] + (1,)), tc], -1)
    g = (m[..., None, :] * ts[..., :, None] + c[..., None, :]).max(axis=-1)  # (..., T)
    return g.min(axis=-1)  # type: ignore[no-any-return]


_BOX_CORNERS = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))  # (8, 3)
_BOX_EDGES = np.array(
    [
        (i, j)
        for i in range(8)
        for j in range(i + 1, 8)
        if np.sum(_BOX_CORNERS[i] != _BOX_CORNERS[j]) == 1
    ]
)  # (12, 2)


def _box_edges_local(h: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The 12 edges of boxes with half extents ``h`` (..., 3) in their frame: (..., 12, 3) x 2."""
    corners = _BOX_CORNERS * h[..., None, :]
    return corners[..., _BOX_EDGES[:, 0], :], corners[..., _BOX_EDGES[:, 1], :]


def segment_box(
    a: ArrayLike, b: ArrayLike, center: ArrayLike, half: ArrayLike, Rb: ArrayLike
) -> FloatArray:
    """Signed distance from segments ``[a, b]`` to oriented boxes, shape (...).

    Negative (or 0): the segment enters (or meets) the box; the value is the box's signed
    distance at the segment's deepest point (a 1D linear program, solved exactly).
    Otherwise the distance is the least of the endpoint-to-box distances and the
    distances to the 12 box edges (where the closest pair of a segment and a disjoint box
    must lie). Arguments as in :func:`point_box`; ``a``, ``b`` shape (..., 3).
    """
    a, b, c, h, R = _f(a), _f(b), _f(center), _f(half), _f(Rb)
    la, lb = _to_box(a, c, R), _to_box(b, c, R)
    h = np.broadcast_to(h, np.broadcast_shapes(h.shape, la.shape))
    inner = _segment_box_inner(la, lb - la, h)
    e0, e1 = _box_edges_local(h)
    edges = segment_segment(la[..., None, :], lb[..., None, :], e0, e1).min(axis=-1)
    ends = np.minimum(_box_sdf_local(la, h), _box_sdf_local(lb, h))
    outside = np.minimum(edges, np.maximum(ends, 0.0))
    scale = np.maximum(np.abs(la).max(-1), np.abs(lb).max(-1)) + h.max(-1) + 1.0
    return np.where(inner <= _MEETS * scale, inner, outside)  # type: ignore[no-any-return]


# -----------------------------------------------------------------------------------------
# convex planar polygons
# -----------------------------------------------------------------------------------------
class Polygon(NamedTuple):
    """Convex planar polygons in the plane ``z = 0`` of a frame ``(origin, axes)``.

    Attributes
    ----------
    origin : ndarray, shape (..., 3)
        The frame's origin in the world frame [mm].
    axes : ndarray, shape (..., 3, 3)
        Its rotation (columns: the frame's x, y, z axes in the world frame); the polygon's
        normal is the third column.
    uv : ndarray, shape (..., M, 2)
        Vertices in the frame's (x, y) coordinates, counter-clockwise (a vertex may repeat:
        polygons of fewer vertices are padded to a common M, see :func:`convex_hull_2d`).
    """

    origin: FloatArray
    axes: FloatArray
    uv: FloatArray

    def vertices(self) -> FloatArray:
        """World coordinates of the vertices, shape (..., M, 3) [mm]."""
        return self.origin[..., None, :] + np.einsum(
            "...ij,...mj->...mi", self.axes[..., :, :2], self.uv
        )  # type: ignore[no-any-return]

    def local(self, x: FloatArray) -> FloatArray:
        """Coordinates of world points ``x`` (..., 3) in the polygon's frame (..., 3)."""
        return np.einsum("...ji,...j->...i", self.axes, x - self.origin)  # type: ignore[no-any-return]

    def inside(self, uv: FloatArray) -> NDArray[np.bool_]:
        """Whether points with in-plane coordinates ``uv`` (..., 2) lie in the polygon."""
        e0 = self.uv
        e1 = e0[..., _next(e0.shape[-2]), :]
        edge = e1 - e0
        rel = uv[..., None, :] - e0
        cross = edge[..., 0] * rel[..., 1] - edge[..., 1] * rel[..., 0]
        return np.all(cross >= 0.0, axis=-1)  # type: ignore[no-any-return]


def convex_hull_2d(points: ArrayLike, size: int | None = None) -> FloatArray:
    """Counter-clockwise convex hull of 2D points (Andrew's monotone chain), shape (M, 2).

    ``size`` pads the hull to that many vertices by repeating its last one (a repeated
    vertex is a zero-length edge, which changes no distance).
    """
    pts = sorted({(float(x), float(y)) for x, y in np.asarray(points, dtype=float)})
    if len(pts) < 3:
        raise ValueError("points: a polygon needs at least three non-collinear points")

    def cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[tuple[float, float]] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    hull = lower[:-1] + upper[:-1]
    if len(hull) < 3:
        raise ValueError("points: a polygon needs at least three non-collinear points")
    if size is not None:
        if size < len(hull):
            raise ValueError(f"size: the hull has {len(hull)} vertices, more than {size}")
        hull = hull + [hull[-1]] * (size - len(hull))
    return np.array(hull)


def _next(m: int) -> NDArray[np.intp]:
    """Index of the next vertex of an m-gon."""
    return (np.arange(m) + 1) % m


def _edges(poly: Polygon) -> tuple[FloatArray, FloatArray]:
    v = poly.vertices()
    return v, v[..., _next(v.shape[-2]), :]


def point_polygon(p: ArrayLike, poly: Polygon) -> FloatArray:
    """Distance from points ``p`` (..., 3) to polygons (broadcast), shape (...)."""
    p = _f(p)
    loc = poly.local(p)
    e0, e1 = _edges(poly)
    edges = point_segment(p[..., None, :], e0, e1).min(axis=-1)
    return np.where(poly.inside(loc[..., :2]), np.abs(loc[..., 2]), edges)  # type: ignore[no-any-return]


def _overlap(P: FloatArray, Q: FloatArray, u: FloatArray) -> FloatArray:
    """``min(h(u), h(-u))`` for the support function ``h`` of ``P - Q``: vertices P (..., k, 3)
    and Q (..., m, 3), unit directions u (..., c, 3); shape (..., c)."""
    p = np.einsum("...kj,...cj->...ck", P, u)
    q = np.einsum("...kj,...cj->...ck", Q, u)
    return np.minimum(p.max(-1) - q.min(-1), q.max(-1) - p.min(-1))  # type: ignore[no-any-return]


def depth(P: ArrayLike, EP: ArrayLike, Q: ArrayLike, EQ: ArrayLike, N: ArrayLike) -> FloatArray:
    """Penetration depth of convex cores that meet (broadcast), shape (...): the length of
    the shortest translation that separates them, the distance from 0 to the boundary of
    ``P - Q``.

    ``P`` (..., k, 3) and ``Q`` (..., m, 3) are the cores' vertices, ``EP`` (..., e, 3) and
    ``EQ`` (..., f, 3) their edge vectors, ``N`` (..., c, 3) the unit normals of their faces
    (a polygon's normal). Every facet of ``P - Q`` is normal to a face normal or to the cross
    product of an edge of each, and the distance from 0 to the boundary of a convex
    polytope holding it is the least of its support function over its facet normals; so
    the depth is the least of :func:`_overlap` over those directions (0 when they only
    touch; meaningless when they are apart: there it is clipped at 0)."""
    P, EP, Q, EQ, N = (_f(x) for x in (P, EP, Q, EQ, N))
    c = np.cross(EP[..., :, None, :], EQ[..., None, :, :])
    c = c.reshape(c.shape[:-3] + (-1, 3))
    nc = _norm(c)
    scale = (_norm(EP)[..., :, None] * _norm(EQ)[..., None, :]).reshape(nc.shape)
    ok = nc > 1e-12 * scale  # parallel or zero-length edges make no facet
    u = c / np.where(ok, nc, 1.0)[..., None]
    h = np.where(ok, _overlap(P, Q, u), np.inf)
    return np.maximum(np.minimum(h.min(-1), _overlap(P, Q, N).min(-1)), 0.0)  # type: ignore[no-any-return]


def _polygon_gap(a: FloatArray, b: FloatArray, poly: Polygon) -> tuple[FloatArray, FloatArray]:
    """Distance from segments to polygons (0 when a segment crosses), and whether it crosses
    the plane inside the polygon."""
    la, lb = poly.local(a), poly.local(b)
    e0, e1 = _edges(poly)
    d = segment_segment(a[..., None, :], b[..., None, :], e0, e1).min(axis=-1)
    ha, hb = la[..., 2], lb[..., 2]
    crosses = ha * hb < 0.0
    t = np.where(crosses, ha / np.where(crosses, ha - hb, 1.0), 0.0)
    x = la[..., :2] + t[..., None] * (lb[..., :2] - la[..., :2])
    ins = poly.inside(np.stack(np.broadcast_arrays(la[..., :2], lb[..., :2], x)))
    d = np.where(ins[0], np.minimum(d, np.abs(ha)), d)
    d = np.where(ins[1], np.minimum(d, np.abs(hb)), d)
    through = crosses & ins[2]
    return np.where(through, 0.0, d), through


def segment_polygon(a: ArrayLike, b: ArrayLike, poly: Polygon) -> FloatArray:
    """Signed distance from segments ``[a, b]`` (..., 3) to polygons (broadcast), shape (...).

    The least of: the segments' distances to the polygon's edges; an endpoint's height
    above the plane when it projects inside. (Where the closest pair is not on an edge, the
    polygon's point is interior, so the segment's point is an endpoint or the crossing, or
    the segment runs parallel to the plane and an endpoint or an edge does as well.) A
    segment that passes through the polygon gets minus the penetration depth
    (:func:`depth`).
    """
    a, b = _f(a), _f(b)
    d, through = _polygon_gap(a, b, poly)
    if not np.any(through):
        return d
    e0, e1 = _edges(poly)
    P = np.stack(np.broadcast_arrays(a, b), axis=-2)
    pen = depth(P, (b - a)[..., None, :], e0, e1 - e0, poly.axes[..., None, :, 2])
    return np.where(through, -pen, d)  # type: ignore[no-any-return]


def polygon_polygon(p: Polygon, q: Polygon) -> FloatArray:
    """Signed distance between polygons (broadcast), shape (...): minus the penetration
    depth (:func:`depth`) when they pass through each other, 0 when they only touch.

    The least over each polygon's edges of their distance to the other polygon (of two
    disjoint convex polygons, the closest pair can be taken with one point on an edge;
    crossing polygons have an edge of one meeting the other).
    """
    pe0, pe1 = _edges(p)
    qe0, qe1 = _edges(q)
    qx = Polygon(q.origin[..., None, :], q.axes[..., None, :, :], q.uv[..., None, :, :])
    px = Polygon(p.origin[..., None, :], p.axes[..., None, :, :], p.uv[..., None, :, :])
    d = np.minimum(
        _polygon_gap(pe0, pe1, qx)[0].min(axis=-1), _polygon_gap(qe0, qe1, px)[0].min(axis=-1)
    )
    if not np.any(d <= 0.0):
        return d  # type: ignore[no-any-return]
    n = np.stack(np.broadcast_arrays(p.axes[..., :, 2], q.axes[..., :, 2]), axis=-2)
    pen = depth(pe0, pe1 - pe0, qe0, qe1 - qe0, n)
    return np.where(d <= 0.0, -pen, d)  # type: ignore[no-any-return]


def polygon_halfspace(poly: Polygon, point: ArrayLike, normal: ArrayLike) -> FloatArray:
    """Signed distance from polygons to a half-space (as :func:`segment_halfspace`): the
    least height of a vertex, shape (...)."""
    point, normal = _f(point), _f(normal)
    v = poly.vertices()
    return _dot(v - point[..., None, :], normal[..., None, :]).min(axis=-1)  # type: ignore[no-any-return]


_TRIPLES = np.array(list(itertools.combinations(range(6), 3)))  # (20, 3)


def polygon_box(poly: Polygon, center: ArrayLike, half: ArrayLike, Rb: ArrayLike) -> FloatArray:
    """Signed distance from polygons to oriented boxes, shape (...) (arguments as in
    :func:`point_box`).

    Negative: the polygon enters the box, by the box's signed distance at its deepest
    point: a 2D linear program over the polygon, solved exactly over its candidates (the
    edges' 1D programs and the points inside where three of the six pieces meet).
    Otherwise the least of the edges' distances to the box and of the box edges' distances
    to the polygon.
    """
    c, h, R = _f(center), _f(half), _f(Rb)
    e0, e1 = _edges(poly)
    ce = c[..., None, :]
    Re = R[..., None, :, :]
    he = h[..., None, :]
    # depth over the edges (1D programs)
    l0, l1 = _to_box(e0, ce, Re), _to_box(e1, ce, Re)
    hb = np.broadcast_to(he, np.broadcast_shapes(he.shape, l0.shape))
    inner = _segment_box_inner(l0, l1 - l0, hb).min(axis=-1)
    # depth at the interior points where three pieces are equal
    o = _to_box(poly.origin, c, R)  # plate origin in the box frame (..., 3)
    ax = np.einsum("...ji,...jk->...ik", R, poly.axes)  # plate axes in the box frame
    sign, hh = _box_pieces(np.broadcast_to(h, o.shape))
    alpha = sign * ax[..., _AXES, 0]
    beta = sign * ax[..., _AXES, 1]
    gamma = sign * o[..., _AXES] - hh  # (..., 6)
    i, j, k = _TRIPLES.T
    a11, a12, b1 = (
        alpha[..., i] - alpha[..., j],
        beta[..., i] - beta[..., j],
        gamma[..., j] - gamma[..., i],
    )
    a21, a22, b2 = (
        alpha[..., i] - alpha[..., k],
        beta[..., i] - beta[..., k],
        gamma[..., k] - gamma[..., i],
    )
    det = a11 * a22 - a12 * a21
    ok = np.abs(det) > 1e-12
    sd = np.where(ok, det, 1.0)
    u = (b1 * a22 - a12 * b2) / sd
    v = (a11 * b2 - b1 * a21) / sd
    uv = np.stack([u, v], axis=-1)  # (..., 20, 2)
    pin = Polygon(poly.origin[..., None, :], poly.axes[..., None, :, :], poly.uv[..., None, :, :])
    good = ok & pin.inside(uv)
    g = (
        alpha[..., None, :] * u[..., :, None]
        + beta[..., None, :] * v[..., :, None]
        + gamma[..., None, :]
    ).max(axis=-1)
    inner = np.minimum(inner, np.where(good, g, np.inf).min(axis=-1))
    # disjoint: polygon edges to the box, box edges to the polygon
    be0, be1 = _box_edges_local(np.broadcast_to(h, o.shape))
    w0 = c[..., None, :] + np.einsum("...ij,...mj->...mi", R, be0)
    w1 = c[..., None, :] + np.einsum("...ij,...mj->...mi", R, be1)
    box_edges = segment_polygon(w0, w1, pin).min(axis=-1)
    poly_edges = segment_box(e0, e1, ce, he, Re).min(axis=-1)
    outside = np.minimum(box_edges, np.maximum(poly_edges, 0.0))
    scale = np.abs(l0).max(axis=(-1, -2)) + h.max(-1) + 1.0
    return np.where(inner <= _MEETS * scale, inner, outside)  # type: ignore[no-any-return]
