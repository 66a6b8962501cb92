"""Obstacle rows of a pose (numba), the one definition of the family
(:mod:`stackik.formulation.obstacle_rows` documents it and wraps this kernel).

Every leg j (platform ``i = j // 6``, leg ``k = j % 6``): the segment from its base joint
``B = O_i + A_i b_k`` to its top joint ``T = O_{i+1} + A_{i+1} t_k`` in the base frame [mm].
Against an obstacle axis ``[a, b]`` of radius ``R`` (a sphere: ``a = b``) the row is
``(d^2 - (R + r_j + margin)^2) / L^2`` with ``d`` the distance of the two segments at their
clamped closest points (:func:`stackik._compiled.self_legs._closest`); its gradient is the
envelope rule's ``2 g . ((1 - s) dB + s dT) / L^2``. A sphere then has one row per plate
``p = 1..n``, ``(d^2 - (R + tau_p + margin)^2) / L^2`` with ``d`` the distance of its centre
from the plate's polygon (:func:`_polygon_closest`) and ``tau_p`` the plate's half
thickness, its gradient ``-2 g . dY / L^2`` at the polygon's nearest point ``Y`` (fixed on
plate ``p``). Against a half-space (point ``p``,
unit normal ``u``) the rows are ``(u . (X - p) - rho_X - margin) / L`` for every base joint,
then every top joint, ``rho_X`` the larger of the leg radius and the reach of the plate the
joint is a node of (``jrad``; the base plate has none). Against an oriented box the row is
``(sd - r_j - margin) / L``, ``sd`` the exact signed distance of the leg's axis from the box
(:func:`_segment_box`: the distance outside, minus the penetration depth inside), its
gradient ``w . ((1 - t) dB + t dT) / L`` at the parameter ``t`` of the closest (deepest)
point, ``w`` that point's outward direction (envelope rule).

Derivatives of a point ``X`` on plate ``m`` along variable ``a`` of platform ``i``: zero
unless ``m >= i + 1``; then the translation's direction in the base frame, or
``w_a x (X - O_{i+1})`` for an angle (``w_a`` its axis in the base frame). Spatial
variables ``[x, y, z, yaw, pitch, roll]`` (``R = Rz Ry Rx``, axes ``A_i (e_z, Rz e_y,
Rz Ry e_x)``); planar ``[rho, z, theta]`` in the plane ``phi`` (translation
``(rho cos phi, rho sin phi, z)``, rotation by ``theta`` about ``s(phi)``, which every
plate's rotation leaves fixed).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from stackik._compiled.core import _jit
from stackik._compiled.self_legs import _closest

FloatArray = Any


#: Relative rounding band within which a segment counts as meeting a box: the value the
#: check's geometry uses (``stackik.distance``), written here because the solvers' kernels
#: import nothing of the check (tests/test_architecture.py); tests/test_box_rows.py holds
#: the two distances equal.
_MEETS = 1e-12


@_jit
def _frames(q: FloatArray, planar: bool, phi: float) -> tuple[Any, ...]:
    """Plate rotations ``A`` (n+1, 3, 3), origins ``O`` (n+1, 3) and, per variable, its
    rotation axis ``w`` (zero for a translation), translation direction ``tdir`` and
    whether it is an angle (``k n`` of each). Scalar loops (3 x 3 products through numpy
    allocate and call BLAS: most of an evaluation's time at n = 4)."""
    n = q.shape[0]
    k = 3 if planar else 6
    A = np.zeros((n + 1, 3, 3))
    O = np.zeros((n + 1, 3))
    for a in range(3):
        A[0, a, a] = 1.0
    w = np.zeros((k * n, 3))
    tdir = np.zeros((k * n, 3))
    angle = np.zeros(k * n, dtype=np.bool_)
    cf, sf = math.cos(phi), math.sin(phi)
    s = np.array([sf, -cf, 0.0])  # the planar rotation axis s(phi); [s]x has the entries
    K = np.array([[0.0, 0.0, -cf], [0.0, 0.0, -sf], [cf, sf, 0.0]])  # of K
    R = np.empty((3, 3))
    p = np.empty(3)
    local = np.empty((3, 3))
    for i in range(n):
        Ai = A[i]
        if planar:
            p[0], p[1], p[2] = q[i, 0] * cf, q[i, 0] * sf, q[i, 1]
            c, sn = math.cos(q[i, 2]), math.sin(q[i, 2])
            for a in range(3):  # R = c I + sin [s]x + (1 - c) s s^T
                for b in range(3):
                    R[a, b] = sn * K[a, b] + (1.0 - c) * s[a] * s[b] + (c if a == b else 0.0)
            for a in range(3):
                tdir[3 * i, a] = Ai[a, 0] * cf + Ai[a, 1] * sf
                tdir[3 * i + 1, a] = Ai[a, 2]
                w[3 * i + 2, a] = s[a]
            angle[3 * i + 2] = True
        else:
            for a in range(3):
                p[a] = q[i, a]
            ca, sa = math.cos(q[i, 3]), math.sin(q[i, 3])
            cb, sb = math.cos(q[i, 4]), math.sin(q[i, 4])
            cc, sc = math.cos(q[i, 5]), math.sin(q[i, 5])
            # R = Rz(yaw) Ry(pitch) Rx(roll)
            R[0, 0], R[0, 1], R[0, 2] = ca * cb, ca * sb * sc - sa * cc, ca * sb * cc + sa * sc
            R[1, 0], R[1, 1], R[1, 2] = sa * cb, sa * sb * sc + ca * cc, sa * sb * cc - ca * sc
            R[2, 0], R[2, 1], R[2, 2] = -sb, cb * sc, cb * cc
            # the angles' axes in plate i's frame: e_z, Rz e_y, Rz Ry e_x
            local[0, 0], local[0, 1], local[0, 2] = 0.0, 0.0, 1.0
            local[1, 0], local[1, 1], local[1, 2] = -sa, ca, 0.0
            local[2, 0], local[2, 1], local[2, 2] = ca * cb, sa * cb, -sb
            for j in range(3):
                for a in range(3):
                    tdir[6 * i + j, a] = Ai[a, j]
                    w[6 * i + 3 + j, a] = (
                        Ai[a, 0] * local[j, 0] + Ai[a, 1] * local[j, 1] + Ai[a, 2] * local[j, 2]
                    )
                angle[6 * i + 3 + j] = True
        for a in range(3):
            O[i + 1, a] = O[i, a] + Ai[a, 0] * p[0] + Ai[a, 1] * p[1] + Ai[a, 2] * p[2]
            for b in range(3):
                A[i + 1, a, b] = Ai[a, 0] * R[0, b] + Ai[a, 1] * R[1, b] + Ai[a, 2] * R[2, b]
    return A, O, w, tdir, angle


@_jit
def _joint(A: FloatArray, O: FloatArray, plate: int, node: FloatArray, out: FloatArray) -> None:
    """``O_plate + A_plate node`` (base frame) into ``out`` (3,)."""
    for a in range(3):
        out[a] = (O[plate, a] + A[plate, a, 0] * node[0] + A[plate, a, 1] * node[1]
                  + A[plate, a, 2] * node[2])  # fmt: skip


@_jit
def _point_jacobian(
    X: FloatArray, plate: int, O: FloatArray, w: FloatArray, tdir: FloatArray,
    angle: FloatArray, k: int, out: FloatArray,
) -> None:  # fmt: skip
    """``dX / dq`` (3, k n) of a point ``X`` on plate ``plate`` into ``out``."""
    out[:] = 0.0
    for a in range(w.shape[0]):
        i = a // k
        if plate < i + 1:
            continue
        if angle[a]:
            l0, l1, l2 = X[0] - O[i + 1, 0], X[1] - O[i + 1, 1], X[2] - O[i + 1, 2]
            out[0, a] = w[a, 1] * l2 - w[a, 2] * l1
            out[1, a] = w[a, 2] * l0 - w[a, 0] * l2
            out[2, a] = w[a, 0] * l1 - w[a, 1] * l0
        else:
            out[0, a], out[1, a], out[2, a] = tdir[a, 0], tdir[a, 1], tdir[a, 2]


@_jit
def obstacle_rows(
    q: FloatArray, base: FloatArray, top: FloatArray, radius: FloatArray, segs: FloatArray,
    halfs: FloatArray, boxes: FloatArray, jrad: FloatArray, hulls: FloatArray,
    hthick: FloatArray, kinds: Any, margin: float, L: float, planar: bool, phi: float,
) -> tuple[FloatArray, FloatArray]:  # fmt: skip
    """Rows ``c`` and Jacobian ``J`` (rows, k n) against the raw pose ``q`` (n, k).

    ``base``, ``top`` (n, 6, 3) joints [mm]; ``radius`` (n,) leg radii [mm]; ``segs``
    (s, 7): ``a, b, R`` of the spheres (``a = b``) and capsules; ``halfs`` (h, 6): point and
    unit normal of the half-spaces; ``boxes`` (x, 15): centre, half extents and the
    rotation (row-major, columns the box axes) of the boxes; ``jrad`` (2, n): the radius
    [mm] a half-space keeps from the base joints (row 0) and the top joints (row 1) of
    each platform's legs (the leg radius, or half the thickness of the plate the joint is
    a node of, if larger); ``hulls`` (n, M, 2): plates 1..n's polygons (counter-clockwise,
    padded by repeating a vertex) in their frames' ``z = 0``; ``hthick`` (n,) their half
    thicknesses [mm]; ``kinds`` (s + h + x,): 0 for the next of ``segs`` (a capsule), 3 for
    the next of ``segs`` that is a sphere (its leg rows, then one row per plate), 1 for the
    next of ``halfs``, 2 for the next of ``boxes``, in the obstacles' order (the rows'
    order)."""
    n = q.shape[0]
    k = 3 if planar else 6
    A, O, w, tdir, angle = _frames(q, planar, phi)
    nl = 6 * n
    B = np.empty((nl, 3))
    T = np.empty((nl, 3))
    JB = np.empty((nl, 3, k * n))
    JT = np.empty((nl, 3, k * n))
    for i in range(n):
        for m in range(6):
            j = 6 * i + m
            _joint(A, O, i, base[i, m], B[j])
            _joint(A, O, i + 1, top[i, m], T[j])
            _point_jacobian(B[j], i, O, w, tdir, angle, k, JB[j])
            _point_jacobian(T[j], i + 1, O, w, tdir, angle, k, JT[j])
    rows = 0
    for kind in kinds:
        rows += 2 * nl if kind == 1 else (nl + n if kind == 3 else nl)
    c = np.empty(rows)
    J = np.zeros((rows, k * n))
    r = 0
    si = 0
    hi = 0
    d1 = np.empty(3)
    d2 = np.empty(3)
    rr = np.empty(3)
    g = np.empty(3)
    p0 = np.empty(3)
    gl = np.empty(3)
    bi = 0
    JY = np.empty((3, k * n))
    for kind in kinds:
        if kind == 0 or kind == 3:
            a, b, R = segs[si, :3], segs[si, 3:6], segs[si, 6]
            si += 1
            for x in range(3):
                d2[x] = b[x] - a[x]
            for j in range(nl):
                for x in range(3):
                    d1[x] = T[j, x] - B[j, x]
                    rr[x] = B[j, x] - a[x]
                s, t = _closest(d1, d2, rr)
                gg = 0.0
                for x in range(3):
                    g[x] = rr[x] + s * d1[x] - t * d2[x]
                    gg += g[x] * g[x]
                rho = R + radius[j // 6] + margin
                c[r] = (gg - rho * rho) / (L * L)
                for v in range(k * n):
                    acc = 0.0
                    for x in range(3):
                        acc += g[x] * ((1.0 - s) * JB[j, x, v] + s * JT[j, x, v])
                    J[r, v] = 2.0 * acc / (L * L)
                r += 1
            if kind == 3:  # the sphere against plates 1..n
                for p in range(1, n + 1):
                    _polygon_closest(A[p], O[p], hulls[p - 1], a, g)  # g: the nearest point
                    _point_jacobian(g, p, O, w, tdir, angle, k, JY)
                    gg = 0.0
                    for x in range(3):
                        g[x] = a[x] - g[x]
                        gg += g[x] * g[x]
                    rho = R + hthick[p - 1] + margin
                    c[r] = (gg - rho * rho) / (L * L)
                    for v in range(k * n):
                        J[r, v] = -2.0 * (g[0] * JY[0, v] + g[1] * JY[1, v]
                                          + g[2] * JY[2, v]) / (L * L)  # fmt: skip
                    r += 1
        elif kind == 2:
            ctr, hb, Rb = boxes[bi, :3], boxes[bi, 3:6], boxes[bi, 6:15]
            bi += 1
            for j in range(nl):
                for x in range(3):  # the leg in the box frame: p0 + t d1, t in [0, 1]
                    a0 = 0.0
                    a1 = 0.0
                    for y in range(3):
                        a0 += Rb[3 * y + x] * (B[j, y] - ctr[y])
                        a1 += Rb[3 * y + x] * (T[j, y] - ctr[y])
                    p0[x] = a0
                    d1[x] = a1 - a0
                sd, t = _segment_box(p0, d1, hb, gl)
                c[r] = (sd - radius[j // 6] - margin) / L
                for x in range(3):  # the gradient direction in the base frame
                    g[x] = Rb[3 * x] * gl[0] + Rb[3 * x + 1] * gl[1] + Rb[3 * x + 2] * gl[2]
                for v in range(k * n):
                    acc = 0.0
                    for x in range(3):
                        acc += g[x] * ((1.0 - t) * JB[j, x, v] + t * JT[j, x, v])
                    J[r, v] = acc / L
                r += 1
        else:
            p, u = halfs[hi, :3], halfs[hi, 3:6]
            hi += 1
            for side in range(2):  # the base joints, then the top joints
                X = B if side == 0 else T
                JX = JB if side == 0 else JT
                for j in range(nl):
                    h = 0.0
                    for x in range(3):
                        h += u[x] * (X[j, x] - p[x])
                    c[r] = (h - jrad[side, j // 6] - margin) / L
                    for v in range(k * n):
                        J[r, v] = (u[0] * JX[j, 0, v] + u[1] * JX[j, 1, v]
                                   + u[2] * JX[j, 2, v]) / L  # fmt: skip
                    r += 1
    return c, J


@_jit
def _polygon_closest(A: FloatArray, O: FloatArray, hull: FloatArray, c: FloatArray,
                     out: FloatArray) -> None:  # fmt: skip
    """Into ``out`` (base frame) the point of the convex polygon ``hull`` (M, 2; in the
    plane ``z = 0`` of the frame ``A``, ``O``) nearest to ``c``: ``c``'s projection when it
    falls inside, else the nearest point of the nearest edge."""
    lx = A[0, 0] * (c[0] - O[0]) + A[1, 0] * (c[1] - O[1]) + A[2, 0] * (c[2] - O[2])
    ly = A[0, 1] * (c[0] - O[0]) + A[1, 1] * (c[1] - O[1]) + A[2, 1] * (c[2] - O[2])
    m = hull.shape[0]
    inside = True
    best = np.inf
    bx, by = lx, ly
    for e in range(m):
        x0, y0 = hull[e, 0], hull[e, 1]
        ex, ey = hull[(e + 1) % m, 0] - x0, hull[(e + 1) % m, 1] - y0
        if ex * (ly - y0) - ey * (lx - x0) < 0.0:
            inside = False
        ee = ex * ex + ey * ey
        t = 0.0 if ee <= 0.0 else min(max(((lx - x0) * ex + (ly - y0) * ey) / ee, 0.0), 1.0)
        px, py = x0 + t * ex, y0 + t * ey
        dd = (lx - px) * (lx - px) + (ly - py) * (ly - py)
        if dd < best:
            best, bx, by = dd, px, py
    if inside:
        bx, by = lx, ly
    for x in range(3):
        out[x] = O[x] + A[x, 0] * bx + A[x, 1] * by


@_jit
def _box_excess(p0: FloatArray, d: FloatArray, h: FloatArray, t: float) -> float:
    """Squared distance of the point ``p0 + t d`` from the box ``|x_i| <= h_i`` (box frame)."""
    acc = 0.0
    for i in range(3):
        x = abs(p0[i] + t * d[i]) - h[i]
        if x > 0.0:
            acc += x * x
    return acc


@_jit
def _outward(p0: FloatArray, d: FloatArray, h: FloatArray, t: float, sd: float,
             g: FloatArray) -> None:  # fmt: skip
    """Into ``g`` the unit direction from the box's nearest point to ``p0 + t d`` at the
    distance ``sd > 0`` (box frame)."""
    for i in range(3):
        x = p0[i] + t * d[i]
        ex = abs(x) - h[i]
        g[i] = (math.copysign(ex, x) / sd) if ex > 0.0 else 0.0


@_jit
def _deepest(p0: FloatArray, d: FloatArray, h: FloatArray, t: float) -> float:
    """``max_i (|p0_i + t d_i| - h_i)``: the box's signed distance at ``p0 + t d`` when
    inside (box frame)."""
    val = -np.inf
    for i in range(3):
        val = max(val, abs(p0[i] + t * d[i]) - h[i])
    return val


@_jit
def _segment_box(p0: FloatArray, d: FloatArray, h: FloatArray, g: FloatArray) -> Any:
    """Signed distance ``sd`` of the segment ``p0 + t d`` (t in [0, 1], box frame) from the
    box ``|x_i| <= h_i``, the parameter ``t`` of its closest (or deepest) point, and into
    ``g`` (3,) the direction ``w`` with ``d sd = w . dX(t)`` (the envelope rule at that point).

    Outside, ``sd^2 = min_t sum_i max(|p0_i + t d_i| - h_i, 0)^2``: a convex piecewise
    quadratic in ``t`` whose pieces change where ``p0_i + t d_i = +-h_i``; its least is at
    a piece's stationary point or a breakpoint, all evaluated (exact to rounding), and
    ``w`` is the unit vector from the box's nearest point. When that is 0 the segment
    meets the box and ``sd = min_t max_a l_a(t)``, ``l_a = s (p0_i + t d_i) - h_i`` over
    the six faces (``s = +-1``): a 1D linear program solved over its vertices (the ends
    and the crossings of two faces' lines), minus the penetration depth; ``w`` is the
    active face's outward normal, or at a crossing of two faces with opposite slopes the
    combination ``lam n_a + (1 - lam) n_b`` that makes the value's derivative exact
    (``lam = -l_b' / (l_a' - l_b')``): it pushes the leg out."""
    ts = np.empty(8)
    m = 2
    ts[0], ts[1] = 0.0, 1.0
    for i in range(3):
        if d[i] != 0.0:
            for sg in (-1.0, 1.0):
                tb = (sg * h[i] - p0[i]) / d[i]
                if 0.0 < tb < 1.0:
                    ts[m] = tb
                    m += 1
    tt = np.sort(ts[:m])
    best, tbest = _box_excess(p0, d, h, 0.0), 0.0
    for k in range(m):
        cand = tt[k]
        if k + 1 < m and tt[k + 1] > tt[k]:  # the piece's stationary point
            mid = 0.5 * (tt[k] + tt[k + 1])
            num = 0.0
            den = 0.0
            for i in range(3):
                x = p0[i] + mid * d[i]
                if x > h[i]:
                    num += (p0[i] - h[i]) * d[i]
                    den += d[i] * d[i]
                elif x < -h[i]:
                    num += (p0[i] + h[i]) * d[i]
                    den += d[i] * d[i]
            if den > 0.0:
                cand = min(max(-num / den, tt[k]), tt[k + 1])
        for tc in (tt[k], cand):
            e = _box_excess(p0, d, h, tc)
            if e < best:
                best, tbest = e, tc
    out, tout = math.sqrt(best), tbest
    scale = 1.0 + max(h[0], h[1], h[2])
    far = 0.0
    for i in range(3):
        far = max(far, abs(p0[i]), abs(p0[i] + d[i]))
    scale += far
    if out > 2.0 * _MEETS * scale:  # then the inner value is above MEETS: clear
        _outward(p0, d, h, tout, out, g)
        return out, tout
    # the segment meets the box (up to rounding, as stackik.distance.segment_box decides
    # it): the least over the LP's vertices of the deepest face
    sd = np.inf
    tbest = 0.0
    fa, fb = -1, -1
    for a in range(6):
        for b in range(a + 1, 6):
            ia, sa = a // 2, 2.0 * (a % 2) - 1.0
            ib, sb = b // 2, 2.0 * (b % 2) - 1.0
            den = sa * d[ia] - sb * d[ib]
            if den == 0.0:
                continue
            tc = ((sb * p0[ib] - h[ib]) - (sa * p0[ia] - h[ia])) / den
            if 0.0 <= tc <= 1.0:
                val = _deepest(p0, d, h, tc)
                if val < sd:
                    sd, tbest, fa, fb = val, tc, a, b
    for tc in (0.0, 1.0):
        val = _deepest(p0, d, h, tc)
        if val < sd:
            sd, tbest, fa, fb = val, tc, -1, -1
    if sd > _MEETS * scale:  # clear by rounding only
        _outward(p0, d, h, tout, out, g)
        return out, tout
    g[:] = 0.0
    if fa >= 0:
        ia, sa = fa // 2, 2.0 * (fa % 2) - 1.0
        ib, sb = fb // 2, 2.0 * (fb % 2) - 1.0
        la, lb = sa * d[ia], sb * d[ib]
        tol = 1e-12 * (1.0 + abs(sd) + abs(p0[ia]) + abs(p0[ib]) + abs(d[ia]) + abs(d[ib]))
        va = sa * (p0[ia] + tbest * d[ia]) - h[ia]
        vb = sb * (p0[ib] + tbest * d[ib]) - h[ib]
        if la * lb < 0.0 and abs(va - sd) <= tol and abs(vb - sd) <= tol:  # both active
            lam = -lb / (la - lb)
            g[ia] += lam * sa
            g[ib] += (1.0 - lam) * sb
            return sd, tbest
    amax, val = 0, -np.inf
    for f in range(6):
        i, s = f // 2, 2.0 * (f % 2) - 1.0
        x = s * (p0[i] + tbest * d[i]) - h[i]
        if x > val:
            amax, val = f, x
    g[amax // 2] = 2.0 * (amax % 2) - 1.0
    return sd, tbest
