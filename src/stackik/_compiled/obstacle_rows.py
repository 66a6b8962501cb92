"""Obstacle rows of a pose (numba), the one definition of the family
(:mod:`stackik.formulation.obstacle_rows` documents it and wraps this kernel).

Every leg j (platform ``i = j // 6``, leg ``k = j % 6``): the segment from its base joint
``B = O_i + A_i b_k`` to its top joint ``T = O_{i+1} + A_{i+1} t_k`` in the base frame [mm].
Against an obstacle axis ``[a, b]`` of radius ``R`` (a sphere: ``a = b``) the row is
``(d^2 - (R + r_j + margin)^2) / L^2`` with ``d`` the distance of the two segments at their
clamped closest points (:func:`stackik._compiled.self_legs._closest`); its gradient is the
envelope rule's ``2 g . ((1 - s) dB + s dT) / L^2``. Against a half-space (point ``p``,
unit normal ``u``) the rows are ``(u . (X - p) - r_j - margin) / L`` for every base joint,
then every top joint.

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
    halfs: FloatArray, kinds: Any, margin: float, L: float, planar: bool, phi: float,
) -> tuple[FloatArray, FloatArray]:  # fmt: skip
    """Rows ``c`` and Jacobian ``J`` (rows, k n) against the raw pose ``q`` (n, k).

    ``base``, ``top`` (n, 6, 3) joints [mm]; ``radius`` (n,) leg radii [mm]; ``segs``
    (s, 7): ``a, b, R`` of the spheres (``a = b``) and capsules; ``halfs`` (h, 6): point and
    unit normal of the half-spaces; ``kinds`` (s + h,): 0 for the next of ``segs``, 1 for
    the next of ``halfs``, in the obstacles' order (the rows' order)."""
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
        rows += nl if kind == 0 else 2 * nl
    c = np.empty(rows)
    J = np.zeros((rows, k * n))
    r = 0
    si = 0
    hi = 0
    d1 = np.empty(3)
    d2 = np.empty(3)
    rr = np.empty(3)
    g = np.empty(3)
    for kind in kinds:
        if kind == 0:
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
                    c[r] = (h - radius[j // 6] - margin) / L
                    for v in range(k * n):
                        J[r, v] = (u[0] * JX[j, 0, v] + u[1] * JX[j, 1, v]
                                   + u[2] * JX[j, 2, v]) / L  # fmt: skip
                    r += 1
    return c, J
