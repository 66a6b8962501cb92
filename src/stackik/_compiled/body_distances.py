"""Compiled exact distances between the bodies of one pose, for :mod:`stackik.clearance`.

The same geometry as :mod:`stackik.distance` (plain numpy, the reference these kernels are
tested against), written as scalar loops: a pose's self-leg, adjacent-leg and non-adjacent
pairs (legs, plates) cost one compiled call instead of some forty small numpy calls (about
0.7 ms a pose at n = 4, more than the whole planar solve). Distances between:

* two segments: the least of the four endpoint-to-segment distances and, when the lines are
  not parallel, the distance of their closest points clamped into both segments (exact: the
  minimum over the parameter square lies inside it, where the line candidate is the true
  closest pair, or on its boundary, an endpoint candidate);
* a segment and a convex plate polygon: the least of the segment's distances to the edges
  and an endpoint's height when it projects inside; when the segment passes through the
  polygon, minus the penetration depth (:func:`depth`: a leg through a plate collides even
  when both have no thickness);
* two convex polygons: the least over each one's edges of their distance to the other, or
  minus the penetration depth when they pass through each other.

Screening keeps it exact: a pair is skipped only when a lower bound of its signed distance
(the bounding spheres', or a body wholly on one side of a plate's plane; minus a bound of
the depth when it straddles the plane) is at least the least value found so far. Pairs
are visited in index order and a later pair replaces the best only when strictly closer,
so the pair reported is the first closest one in that order.

These kernels share no code with the solvers' clearance rows
(:mod:`stackik._compiled.self_legs`, :mod:`stackik._compiled.obstacle_rows`): the check
stays independent of what it checks.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from stackik._compiled.core import _jit

FloatArray = Any


@_jit
def _dot(a: FloatArray, b: FloatArray) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]  # type: ignore[no-any-return]


@_jit
def _point_segment(p: FloatArray, a: FloatArray, b: FloatArray) -> float:
    d0, d1, d2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    dd = d0 * d0 + d1 * d1 + d2 * d2
    t = 0.0
    if dd > 0.0:
        t = ((p[0] - a[0]) * d0 + (p[1] - a[1]) * d1 + (p[2] - a[2]) * d2) / dd
        t = min(max(t, 0.0), 1.0)
    x0 = a[0] + t * d0 - p[0]
    x1 = a[1] + t * d1 - p[1]
    x2 = a[2] + t * d2 - p[2]
    return math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)


@_jit
def segment_segment(a0: FloatArray, a1: FloatArray, b0: FloatArray, b1: FloatArray) -> float:
    """Distance between segments ``[a0, a1]`` and ``[b0, b1]`` (each shape (3,)) [mm]."""
    u = a1 - a0
    v = b1 - b0
    w = a0 - b0
    uu, vv, uv = _dot(u, u), _dot(v, v), _dot(u, v)
    uw, vw = _dot(u, w), _dot(v, w)
    den = uu * vv - uv * uv
    best = math.inf
    if den > 1e-14 * uu * vv:
        s = min(max((uv * vw - vv * uw) / den, 0.0), 1.0)
        t = min(max((uu * vw - uv * uw) / den, 0.0), 1.0)
        x0 = a0[0] + s * u[0] - b0[0] - t * v[0]
        x1 = a0[1] + s * u[1] - b0[1] - t * v[1]
        x2 = a0[2] + s * u[2] - b0[2] - t * v[2]
        best = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    best = min(best, _point_segment(a0, b0, b1))
    best = min(best, _point_segment(a1, b0, b1))
    best = min(best, _point_segment(b0, a0, a1))
    return min(best, _point_segment(b1, a0, a1))


@_jit
def _local(O: FloatArray, A: FloatArray, x: FloatArray) -> FloatArray:
    """``A^T (x - O)``: world point ``x`` in the frame ``(O, A)``."""
    out = np.empty(3)
    for c in range(3):
        out[c] = A[0, c] * (x[0] - O[0]) + A[1, c] * (x[1] - O[1]) + A[2, c] * (x[2] - O[2])
    return out


@_jit
def _inside(uv: FloatArray, u: float, v: float) -> bool:
    """Whether ``(u, v)`` lies in the counter-clockwise polygon ``uv`` (M, 2)."""
    M = uv.shape[0]
    for m in range(M):
        e0u, e0v = uv[m, 0], uv[m, 1]
        e1u, e1v = uv[(m + 1) % M, 0], uv[(m + 1) % M, 1]
        if (e1u - e0u) * (v - e0v) - (e1v - e0v) * (u - e0u) < 0.0:
            return False
    return True


@_jit
def _vertices(O: FloatArray, A: FloatArray, uv: FloatArray) -> FloatArray:
    M = uv.shape[0]
    V = np.empty((M, 3))
    for m in range(M):
        for c in range(3):
            V[m, c] = O[c] + A[c, 0] * uv[m, 0] + A[c, 1] * uv[m, 1]
    return V


@_jit
def _polygon_gap(
    a: FloatArray, b: FloatArray, O: FloatArray, A: FloatArray, uv: FloatArray, V: FloatArray
) -> tuple[float, bool]:
    """Distance [mm] from segment ``[a, b]`` to the convex polygon ``uv`` (M, 2) in the plane
    ``z = 0`` of the frame ``(O, A)`` (``V`` (M, 3): its vertices in the world frame), and
    whether the segment crosses the plane inside the polygon (the distance is then 0)."""
    M = uv.shape[0]
    d = math.inf
    for m in range(M):
        d = min(d, segment_segment(a, b, V[m], V[(m + 1) % M]))
    la = _local(O, A, a)
    lb = _local(O, A, b)
    ha, hb = la[2], lb[2]
    if _inside(uv, la[0], la[1]):
        d = min(d, abs(ha))
    if _inside(uv, lb[0], lb[1]):
        d = min(d, abs(hb))
    if _crosses_inside(uv, la, lb):
        return 0.0, True
    return d, False


@_jit
def _crosses_inside(uv: FloatArray, la: FloatArray, lb: FloatArray) -> bool:
    """Whether the segment between the points ``la``, ``lb`` (a plate's frame) crosses
    its plane ``z = 0`` inside the polygon ``uv`` (M, 2)."""
    ha, hb = la[2], lb[2]
    if not ha * hb < 0.0:
        return False
    t = ha / (ha - hb)
    return _inside(uv, la[0] + t * (lb[0] - la[0]), la[1] + t * (lb[1] - la[1]))


@_jit
def _overlap(P: FloatArray, Q: FloatArray, u0: float, u1: float, u2: float) -> float:
    """``min(h(u), h(-u))`` for the support function ``h`` of ``P - Q`` (vertex sets P, Q):
    the shorter of the two translations along ``+-u`` (unit) that separate them."""
    pmax, pmin, qmax, qmin = -math.inf, math.inf, -math.inf, math.inf
    for k in range(P.shape[0]):
        s = P[k, 0] * u0 + P[k, 1] * u1 + P[k, 2] * u2
        pmax, pmin = max(pmax, s), min(pmin, s)
    for k in range(Q.shape[0]):
        s = Q[k, 0] * u0 + Q[k, 1] * u1 + Q[k, 2] * u2
        qmax, qmin = max(qmax, s), min(qmin, s)
    return min(pmax - qmin, qmax - pmin)


@_jit
def depth(P: FloatArray, Q: FloatArray, closed_p: bool, N: FloatArray) -> float:
    """Penetration depth [mm] of two convex cores that meet: the length of the shortest
    translation that separates them (the distance from 0 to the boundary of ``P - Q``).

    ``P`` (k, 3) is a segment (k = 2, ``closed_p`` False) or a polygon's vertices
    (``closed_p`` True), ``Q`` (m, 3) a polygon's vertices (closed), ``N`` (c, 3) the unit
    normals of the polygons. Every facet of ``P - Q`` is normal to one of ``N`` or to the
    cross product of an edge of ``P`` and an edge of ``Q``, and the distance from 0 to the
    boundary of a convex polytope holding it is the least over its facet normals ``u`` of
    the support function: the least of :func:`_overlap` over those directions (0 when they
    only touch)."""
    best = math.inf
    for c in range(N.shape[0]):
        best = min(best, _overlap(P, Q, N[c, 0], N[c, 1], N[c, 2]))
    kp = P.shape[0] if closed_p else P.shape[0] - 1
    m = Q.shape[0]
    for i in range(kp):
        e0 = P[(i + 1) % P.shape[0], 0] - P[i, 0]
        e1 = P[(i + 1) % P.shape[0], 1] - P[i, 1]
        e2 = P[(i + 1) % P.shape[0], 2] - P[i, 2]
        for j in range(m):
            f0, f1, f2 = (
                Q[(j + 1) % m, 0] - Q[j, 0],
                Q[(j + 1) % m, 1] - Q[j, 1],
                Q[(j + 1) % m, 2] - Q[j, 2],
            )
            u0, u1, u2 = e1 * f2 - e2 * f1, e2 * f0 - e0 * f2, e0 * f1 - e1 * f0
            nu = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
            ne = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2) * math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
            if nu > 1e-12 * ne:  # parallel or zero-length edges: no facet
                best = min(best, _overlap(P, Q, u0 / nu, u1 / nu, u2 / nu))
    return max(best, 0.0)


@_jit
def segment_polygon(
    a: FloatArray, b: FloatArray, O: FloatArray, A: FloatArray, uv: FloatArray, V: FloatArray
) -> float:
    """Signed distance [mm] from segment ``[a, b]`` to the convex polygon ``uv`` (M, 2) in the
    plane ``z = 0`` of the frame ``(O, A)``; ``V`` (M, 3) its vertices in the world frame.
    Minus the penetration depth (:func:`depth`) when the segment passes through the polygon."""
    d, crosses = _polygon_gap(a, b, O, A, uv, V)
    if not crosses:
        return d
    P = np.empty((2, 3))
    P[0, :] = a
    P[1, :] = b
    N = np.empty((1, 3))
    N[0, :] = A[:, 2]
    return -depth(P, V, False, N)


@_jit
def polygon_polygon(
    O1: FloatArray, A1: FloatArray, uv1: FloatArray, V1: FloatArray,
    O2: FloatArray, A2: FloatArray, uv2: FloatArray, V2: FloatArray,
) -> float:  # fmt: skip
    """Signed distance [mm] between two convex polygons: minus the penetration depth
    (:func:`depth`) when they meet (0 when they only touch)."""
    d = math.inf
    M1, M2 = uv1.shape[0], uv2.shape[0]
    for m in range(M1):
        d = min(d, _polygon_gap(V1[m], V1[(m + 1) % M1], O2, A2, uv2, V2)[0])
    for m in range(M2):
        d = min(d, _polygon_gap(V2[m], V2[(m + 1) % M2], O1, A1, uv1, V1)[0])
    if d > 0.0:
        return d
    N = np.empty((2, 3))
    N[0, :] = A1[:, 2]
    N[1, :] = A2[:, 2]
    return -depth(V1, V2, True, N)


@_jit
def _gap(a: FloatArray, b: FloatArray) -> float:
    x0, x1, x2 = a[0] - b[0], a[1] - b[1], a[2] - b[2]
    return math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)


@_jit
def _height(x: FloatArray, O: FloatArray, A: FloatArray) -> float:
    """Height of ``x`` above the plane of the frame ``(O, A)`` (along its third axis)."""
    return (x[0] - O[0]) * A[0, 2] + (x[1] - O[1]) * A[1, 2] + (x[2] - O[2]) * A[2, 2]  # type: ignore[no-any-return]


@_jit
def _legs_min(
    pairs: FloatArray, B: FloatArray, T: FloatArray, r: FloatArray, leg_c: FloatArray,
    leg_R: FloatArray,
) -> tuple[float, int]:  # fmt: skip
    """Least clearance over the leg pairs ``pairs`` (L, 4) and its index (-1: no pair)."""
    best, at = math.inf, -1
    for p in range(pairs.shape[0]):
        i, k, j, m = pairs[p, 0], pairs[p, 1], pairs[p, 2], pairs[p, 3]
        if _gap(leg_c[i, k], leg_c[j, m]) - leg_R[i, k] - leg_R[j, m] >= best:
            continue
        d = segment_segment(B[i, k], T[i, k], B[j, m], T[j, m]) - r[i] - r[j]
        if d < best:
            best, at = d, p
    return best, at


@_jit
def body_clearances(
    B: FloatArray, T: FloatArray, r: FloatArray, A: FloatArray, O: FloatArray,
    uv: FloatArray, centre: FloatArray, reach: FloatArray, half_t: FloatArray,
    self_k: FloatArray, self_m: FloatArray, adj: FloatArray, ll: FloatArray,
    lp: FloatArray, pp: FloatArray,
) -> tuple[Any, ...]:  # fmt: skip
    """The clearances [mm] between the bodies of one pose (no obstacles).

    Parameters
    ----------
    B, T : (n, 6, 3)
        Base and top joints of every leg in the base frame [mm].
    r : (n,)
        Leg radius per platform [mm].
    A, O : (n + 1, 3, 3), (n + 1, 3)
        Plate frames (rotations, origins).
    uv : (n + 1, M, 2)
        Plate polygons in their frames; ``centre`` (n + 1, 2) and ``reach`` (n + 1,) their
        vertices' centroid and largest distance from it; ``half_t`` (n + 1,) half thickness.
    self_k, self_m : (15,)
        The leg pairs of one platform.
    adj, ll : (L, 4)
        Leg pairs (platform, leg, platform, leg) of adjacent and of non-adjacent platforms.
    lp : (K, 3)
        (platform, leg, plate) pairs of a leg and a plate it does not join.
    pp : (Q, 2)
        Plate pairs.

    Returns
    -------
    d_self : (n, 15)
        Clearance of each leg pair of each platform.
    adj_min, adj_at : float, int
        Least clearance of adjacent platforms' legs and its pair (-1: none).
    non_min, kind, at : float, int, int
        Least clearance of non-adjacent bodies, the kind of its pair (0 legs, 1 leg and
        plate, 2 plates; -1: none) and its index in ``ll``, ``lp`` or ``pp``.
    """
    n = B.shape[0]
    d_self = np.empty((n, self_k.shape[0]))
    for i in range(n):
        for p in range(self_k.shape[0]):
            k, m = self_k[p], self_m[p]
            d_self[i, p] = segment_segment(B[i, k], T[i, k], B[i, m], T[i, m]) - 2.0 * r[i]
    leg_c = 0.5 * (B + T)
    leg_R = np.empty((n, 6))
    for i in range(n):
        for k in range(6):
            leg_R[i, k] = 0.5 * _gap(T[i, k], B[i, k]) + r[i]
    adj_min, adj_at = _legs_min(adj, B, T, r, leg_c, leg_R)
    best, at = _legs_min(ll, B, T, r, leg_c, leg_R)
    kind = 0 if at >= 0 else -1
    J = O.shape[0]
    plate_c = np.empty((J, 3))
    V = np.empty((J, uv.shape[1], 3))
    for j in range(J):
        for c in range(3):
            plate_c[j, c] = O[j, c] + A[j, c, 0] * centre[j, 0] + A[j, c, 1] * centre[j, 1]
        V[j] = _vertices(O[j], A[j], uv[j])
    for p in range(lp.shape[0]):
        i, k, j = lp[p, 0], lp[p, 1], lp[p, 2]
        lb = _gap(leg_c[i, k], plate_c[j]) - leg_R[i, k] - reach[j] - half_t[j]
        ha, hb = _height(B[i, k], O[j], A[j]), _height(T[i, k], O[j], A[j])
        if ha * hb > 0.0:
            lb = max(lb, min(abs(ha), abs(hb)) - r[i] - half_t[j])
        elif ha * hb < 0.0:  # it may pass through: the depth is at most an end's height
            lb = min(lb, -min(abs(ha), abs(hb)) - r[i] - half_t[j])
        if lb >= best:
            continue
        d = segment_polygon(B[i, k], T[i, k], O[j], A[j], uv[j], V[j]) - r[i] - half_t[j]
        if d < best:
            best, at, kind = d, p, 1
    for p in range(pp.shape[0]):
        j1, j2 = pp[p, 0], pp[p, 1]
        lb = _gap(plate_c[j1], plate_c[j2]) - reach[j1] - reach[j2] - half_t[j1] - half_t[j2]
        for a, b in ((j1, j2), (j2, j1)):
            lo, hi = math.inf, -math.inf
            least = math.inf
            for m in range(V.shape[1]):
                h = _height(V[b, m], O[a], A[a])
                lo, hi = min(lo, h), max(hi, h)
                least = min(least, abs(h))
            if lo > 0.0 or hi < 0.0:
                lb = max(lb, least - half_t[j1] - half_t[j2])
            elif lo < 0.0 < hi:  # they may cross: the depth is at most min(hi, -lo)
                lb = min(lb, -min(hi, -lo) - half_t[j1] - half_t[j2])
        if lb >= best:
            continue
        d = polygon_polygon(O[j1], A[j1], uv[j1], V[j1], O[j2], A[j2], uv[j2], V[j2])
        d -= half_t[j1] + half_t[j2]
        if d < best:
            best, at, kind = d, p, 2
    return d_self, adj_min, adj_at, best, kind, at


@_jit
def _through(a: FloatArray, b: FloatArray, O: FloatArray, A: FloatArray, uv: FloatArray) -> bool:
    """Whether segment ``[a, b]`` crosses the plane ``z = 0`` of the frame ``(O, A)`` inside
    the polygon ``uv`` (M, 2)."""
    if not _height(a, O, A) * _height(b, O, A) < 0.0:  # (no frame change: most pairs)
        return False
    return _crosses_inside(uv, _local(O, A, a), _local(O, A, b))


@_jit
def any_crossing(
    B: FloatArray, T: FloatArray, A: FloatArray, O: FloatArray, uv: FloatArray,
    lp: FloatArray, pp: FloatArray,
) -> bool:  # fmt: skip
    """Whether a leg's axis passes through a plate it does not join (pairs ``lp``) or two
    plates (pairs ``pp``) pass through each other (arguments as :func:`body_clearances`):
    with zero radii and thickness the only clearances that can be negative. Two convex
    polygons in distinct planes meet with depth only where an edge of one crosses the
    other."""
    for p in range(lp.shape[0]):
        i, k, j = lp[p, 0], lp[p, 1], lp[p, 2]
        if _through(B[i, k], T[i, k], O[j], A[j], uv[j]):
            return True
    M = uv.shape[1]
    V = np.empty((O.shape[0], M, 3))  # every plate's vertices, once
    for j in range(O.shape[0]):
        V[j] = _vertices(O[j], A[j], uv[j])
    for p in range(pp.shape[0]):
        j1, j2 = pp[p, 0], pp[p, 1]
        for a, b in ((j1, j2), (j2, j1)):
            for m in range(M):
                if _through(V[a, m], V[a, (m + 1) % M], O[b], A[b], uv[b]):
                    return True
    return False
