"""Self-leg clearance rows of one spatial platform (numba), the one definition of the family.

Platform i's legs k run from base joint ``b_k`` (fixed in the platform's local frame) to top
joint ``t_k(q) = p + R(yaw, pitch, roll) u_k`` (``u_k`` the top joint in the top plate's
frame), ``q = [x, y, z, yaw, pitch, roll]`` [mm, rad], ``R = Rz Ry Rx``. For each pair (k, l)
of legs that share no joint the row is

    c_kl(q) = (d_kl(q)^2 - rho^2) / scale >= 0,

``d_kl`` the distance [mm] of the two leg axis segments, ``rho = 2 leg_radius + margin`` [mm].

Smoothness: ``d^2`` at the clamped closest points (s*, t*) has a continuous gradient (envelope
theorem: the gradient is that of ``|P(s*) - Q(t*)|^2`` at fixed (s*, t*)), so only the
endpoints' motion enters. For parallel segments the closest points are not unique but the
distance is, and any minimiser gives the same gradient; we take s* = 0 clamped there.

Derivatives along q follow the solver's variable convention (DESIGN.md): j < 3 moves the top
along ``e_j``; j = 3, 4, 5 turn it about ``w = (e_z, Rz e_y, Rz Ry e_x)[j - 3]``, so
``d t_k / d q_j = w_j x (R u_k)``.

Second derivatives (:func:`self_leg_hessian`): ``d^2 = min over (s, t) in [0, 1]^2 of
phi(s, t, q)`` with ``phi = |g|^2``, ``g = P(s) - Q(t)``, so where the minimiser is unique and
its active bounds are strict, ``d^2 (d^2) / dq^2 = phi_qq - phi_qF phi_FF^-1 phi_Fq`` over the
free parameters ``F`` (those strictly inside (0, 1)); ``phi_qq`` at fixed (s, t) has the
serial-chain second derivatives of the top joints, ``d^2 t_k / dq_a dq_b = w_a x (w_b x R u_k)``
for angles ``a <= b`` (zero when either translates).

The spatial kernels (:mod:`stackik._compiled.spatial`) append these rows to each platform's 24
limit rows; :class:`stackik.formulation.Problem` appends them after the limits
(:func:`self_leg_block`). The check does not use them: it measures capsule distances with
its own code (:mod:`stackik.clearance`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from stackik._compiled.core import _jit
from stackik._compiled.spatial_kinematics import _euler

FloatArray = Any
IntArray = Any

#: Relative size of the squared cross term under which two segments count as parallel.
_PARALLEL = 1e-12


@_jit
def _closest(d1: FloatArray, d2: FloatArray, r: FloatArray) -> Any:
    """Parameters (s, t) in [0, 1]^2 of the closest points ``p0 + s d1`` and ``q0 + t d2``
    of two segments, from ``d1 = p1 - p0``, ``d2 = q1 - q0``, ``r = p0 - q0`` (3,)."""
    a = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]
    e = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2]
    f = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2]
    c = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2]
    b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]
    den = a * e - b * b
    if a <= 0.0 and e <= 0.0:
        return 0.0, 0.0
    if a <= 0.0:
        return 0.0, min(max(f / e, 0.0), 1.0)
    if e <= 0.0:
        return min(max(-c / a, 0.0), 1.0), 0.0
    if den > _PARALLEL * a * e:
        s = min(max((b * f - c * e) / den, 0.0), 1.0)
    else:
        s = 0.0
    t = (b * s + f) / e
    if t < 0.0:
        t = 0.0
        s = min(max(-c / a, 0.0), 1.0)
    elif t > 1.0:
        t = 1.0
        s = min(max((b - c) / a, 0.0), 1.0)
    return s, t


@_jit
def closest_params(p0: FloatArray, p1: FloatArray, q0: FloatArray, q1: FloatArray) -> Any:
    """Parameters (s, t) in [0, 1]^2 of closest points of segments p0-p1 and q0-q1 (3,)."""
    return _closest(p1 - p0, q1 - q0, p0 - q0)


@_jit
def _rotation_axes(yaw: float, pitch: float, roll: float) -> Any:
    """``R = Rz Ry Rx`` and the rows ``W``: the axes of yaw, pitch and roll in the bottom
    plate's frame (``e_z``, ``Rz e_y``, ``Rz Ry e_x``)."""
    R, _ = _euler(yaw, pitch, roll)
    cz, sz = math.cos(yaw), math.sin(yaw)
    cy, sy = math.cos(pitch), math.sin(pitch)
    W = np.array([[0.0, 0.0, 1.0], [-sz, cz, 0.0], [cz * cy, sz * cy, -sy]])
    return R, W


@_jit
def _legs(q: FloatArray, base: FloatArray, top: FloatArray, second: bool) -> Any:
    """One platform's legs at ``q`` (6,): axes ``L = T - b`` (6, 3), the top joints'
    derivatives along the angles ``dT[k, j] = w_j x R u_k`` (6, 3, 3) and, when
    ``second``, ``d2T[k, a, b] = w_min x (w_max x R u_k)`` (6, 3, 3, 3)."""
    R, W = _rotation_axes(q[3], q[4], q[5])
    nl = base.shape[0]
    L = np.empty((nl, 3))
    dT = np.empty((nl, 3, 3))
    d2T = np.zeros((nl, 3, 3, 3)) if second else np.zeros((0, 3, 3, 3))
    for k in range(nl):
        u0, u1, u2 = top[k, 0], top[k, 1], top[k, 2]
        ru0 = R[0, 0] * u0 + R[0, 1] * u1 + R[0, 2] * u2
        ru1 = R[1, 0] * u0 + R[1, 1] * u1 + R[1, 2] * u2
        ru2 = R[2, 0] * u0 + R[2, 1] * u1 + R[2, 2] * u2
        L[k, 0] = q[0] + ru0 - base[k, 0]
        L[k, 1] = q[1] + ru1 - base[k, 1]
        L[k, 2] = q[2] + ru2 - base[k, 2]
        for j in range(3):
            w0, w1, w2 = W[j, 0], W[j, 1], W[j, 2]
            dT[k, j, 0] = w1 * ru2 - w2 * ru1
            dT[k, j, 1] = w2 * ru0 - w0 * ru2
            dT[k, j, 2] = w0 * ru1 - w1 * ru0
        if second:
            for a in range(3):
                w0, w1, w2 = W[a, 0], W[a, 1], W[a, 2]
                for b in range(a, 3):
                    x0, x1, x2 = dT[k, b, 0], dT[k, b, 1], dT[k, b, 2]
                    v0 = w1 * x2 - w2 * x1
                    v1 = w2 * x0 - w0 * x2
                    v2 = w0 * x1 - w1 * x0
                    d2T[k, a, b, 0], d2T[k, a, b, 1], d2T[k, a, b, 2] = v0, v1, v2
                    d2T[k, b, a, 0], d2T[k, b, a, 1], d2T[k, b, a, 2] = v0, v1, v2
    return L, dT, d2T


@_jit
def self_leg_rows(
    q: FloatArray,
    base: FloatArray,
    top: FloatArray,
    pairs: IntArray,
    rho: float,
    scale: float,
    c: FloatArray,
    J: FloatArray,
) -> None:
    """Rows ``c`` (m,) and Jacobian ``J`` (m, 6) of one platform, written in place.

    q (6,) pose [mm, rad]; base (6, 3), top (6, 3) joints in the platform's and the top
    plate's frames [mm]; pairs (m, 2) leg indices; rho [mm]; scale [mm^2].
    """
    L, dT, _ = _legs(q, base, top, False)
    r = np.empty(3)
    g = np.empty(3)
    for p in range(pairs.shape[0]):
        k, m = pairs[p, 0], pairs[p, 1]
        for x in range(3):
            r[x] = base[k, x] - base[m, x]
        s, t = _closest(L[k], L[m], r)
        gg = 0.0
        for x in range(3):
            g[x] = r[x] + s * L[k, x] - t * L[m, x]
            gg += g[x] * g[x]
        c[p] = (gg - rho * rho) / scale
        # d(d^2)/dT_k = 2 s g, d(d^2)/dT_m = -2 t g (envelope: s, t fixed)
        sk = 2.0 * s / scale
        sm = -2.0 * t / scale
        for j in range(3):
            J[p, j] = (sk + sm) * g[j]
            ak = g[0] * dT[k, j, 0] + g[1] * dT[k, j, 1] + g[2] * dT[k, j, 2]
            am = g[0] * dT[m, j, 0] + g[1] * dT[m, j, 1] + g[2] * dT[m, j, 2]
            J[p, 3 + j] = sk * ak + sm * am


@_jit
def _pair_hessian(
    s: float, t: float, Lk: FloatArray, Lm: FloatArray, g: FloatArray,
    dTk: FloatArray, dTm: FloatArray, d2Tk: FloatArray, d2Tm: FloatArray,
    Jg: FloatArray, B: FloatArray, Hp: FloatArray,
) -> None:  # fmt: skip
    """``d^2 |g|^2 / dq^2`` (6, 6) of one pair into ``Hp`` (``Jg`` (3, 6), ``B`` (2, 6):
    work arrays), the minimisation over the free closest-point parameters included."""
    for x in range(3):
        for j in range(3):
            Jg[x, j] = (s - t) if x == j else 0.0
            Jg[x, 3 + j] = s * dTk[j, x] - t * dTm[j, x]
    for a in range(6):
        for b in range(a, 6):
            v = 2.0 * (Jg[0, a] * Jg[0, b] + Jg[1, a] * Jg[1, b] + Jg[2, a] * Jg[2, b])
            if a >= 3:
                for x in range(3):
                    v += 2.0 * g[x] * (s * d2Tk[a - 3, b - 3, x] - t * d2Tm[a - 3, b - 3, x])
            Hp[a, b] = v
            Hp[b, a] = v
    fs = 0.0 < s < 1.0
    ft = 0.0 < t < 1.0
    if not (fs or ft):
        return
    for a in range(6):
        gk = g[0] * (1.0 if a == 0 else 0.0) + g[1] * (1.0 if a == 1 else 0.0)
        gk += g[2] * (1.0 if a == 2 else 0.0)
        gm = gk
        if a >= 3:
            gk = g[0] * dTk[a - 3, 0] + g[1] * dTk[a - 3, 1] + g[2] * dTk[a - 3, 2]
            gm = g[0] * dTm[a - 3, 0] + g[1] * dTm[a - 3, 1] + g[2] * dTm[a - 3, 2]
        B[0, a] = 2.0 * (Lk[0] * Jg[0, a] + Lk[1] * Jg[1, a] + Lk[2] * Jg[2, a] + gk)
        B[1, a] = -2.0 * (Lm[0] * Jg[0, a] + Lm[1] * Jg[1, a] + Lm[2] * Jg[2, a] + gm)
    A00 = 2.0 * (Lk[0] * Lk[0] + Lk[1] * Lk[1] + Lk[2] * Lk[2])
    A11 = 2.0 * (Lm[0] * Lm[0] + Lm[1] * Lm[1] + Lm[2] * Lm[2])
    A01 = -2.0 * (Lk[0] * Lm[0] + Lk[1] * Lm[1] + Lk[2] * Lm[2])
    if fs and ft:
        det = A00 * A11 - A01 * A01
        if det > _PARALLEL * A00 * A11:
            i00, i11, i01 = A11 / det, A00 / det, -A01 / det
            for a in range(6):
                for b in range(6):
                    Hp[a, b] -= B[0, a] * (i00 * B[0, b] + i01 * B[1, b]) + B[1, a] * (
                        i01 * B[0, b] + i11 * B[1, b]
                    )
        return
    j = 0 if fs else 1
    Ajj = A00 if fs else A11
    if Ajj > 0.0:
        for a in range(6):
            for b in range(6):
                Hp[a, b] -= B[j, a] * B[j, b] / Ajj


@_jit
def self_leg_hessian(
    q: FloatArray,
    base: FloatArray,
    top: FloatArray,
    pairs: IntArray,
    scale: float,
    y: FloatArray,
) -> FloatArray:
    """``sum_r y[r] d^2 c_r / dq^2`` (6, 6) of one platform's rows (:func:`self_leg_rows`)."""
    L, dT, d2T = _legs(q, base, top, True)
    H = np.zeros((6, 6))
    Hp = np.empty((6, 6))
    Jg = np.empty((3, 6))
    B = np.empty((2, 6))
    r = np.empty(3)
    g = np.empty(3)
    for p in range(pairs.shape[0]):
        if y[p] == 0.0:
            continue
        k, m = pairs[p, 0], pairs[p, 1]
        for x in range(3):
            r[x] = base[k, x] - base[m, x]
        s, t = _closest(L[k], L[m], r)
        for x in range(3):
            g[x] = r[x] + s * L[k, x] - t * L[m, x]
        _pair_hessian(s, t, L[k], L[m], g, dT[k], dT[m], d2T[k], d2T[m], Jg, B, Hp)
        w = y[p] / scale
        for a in range(6):
            for b in range(6):
                H[a, b] += w * Hp[a, b]
    return H


@_jit
def self_leg_block(
    q: FloatArray,
    base: FloatArray,
    top: FloatArray,
    pairs: IntArray,
    rho: FloatArray,
    scale: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Every platform's rows: ``c`` (n, m) and ``J`` (n, m, 6) against the raw pose
    ``q`` (n, 6) [mm, rad]; ``base``, ``top`` (n, 6, 3) [mm], ``rho``, ``scale`` (n,)."""
    n = q.shape[0]
    m = pairs.shape[0]
    c = np.empty((n, m))
    J = np.empty((n, m, 6))
    for i in range(n):
        self_leg_rows(q[i], base[i], top[i], pairs, rho[i], scale[i], c[i], J[i])
    return c, J


@_jit
def self_leg_hessians(
    q: FloatArray,
    base: FloatArray,
    top: FloatArray,
    pairs: IntArray,
    scale: FloatArray,
    y: FloatArray,
) -> FloatArray:
    """:func:`self_leg_hessian` of every platform, (n, 6, 6); ``y`` (n, m)."""
    n = q.shape[0]
    out = np.zeros((n, 6, 6))
    for i in range(n):
        out[i] = self_leg_hessian(q[i], base[i], top[i], pairs, scale[i], y[i])
    return out


@_jit
def planar_self_leg_block(
    q: FloatArray,
    phi: float,
    base: FloatArray,
    top: FloatArray,
    pairs: IntArray,
    rho: FloatArray,
    scale: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """:func:`self_leg_block` for planar poses ``q`` (n, 3) = ``[rho, z, theta]`` in the
    plane ``phi``: platform i's top is ``p = (rho cos phi, rho sin phi, z)`` rotated by
    ``theta`` about ``s = (sin phi, -cos phi, 0)``, so ``dT / d rho = (cos phi, sin phi,
    0)``, ``dT / dz = e_z`` and ``dT / d theta = s x (R u)``; ``J`` is (n, m, 3)."""
    n = q.shape[0]
    m = pairs.shape[0]
    c = np.empty((n, m))
    J = np.empty((n, m, 3))
    cf, sf = math.cos(phi), math.sin(phi)
    s = np.array([sf, -cf, 0.0])
    K = np.array([[0.0, 0.0, -cf], [0.0, 0.0, -sf], [cf, sf, 0.0]])  # [s]x
    L = np.empty((6, 3))
    dth = np.empty((6, 3))
    r = np.empty(3)
    g = np.empty(3)
    for i in range(n):
        ct, st = math.cos(q[i, 2]), math.sin(q[i, 2])
        R = ct * np.eye(3) + st * K + (1.0 - ct) * np.outer(s, s)
        p = np.array([q[i, 0] * cf, q[i, 0] * sf, q[i, 1]])
        for k in range(6):
            ru = R @ top[i, k]
            for x in range(3):
                L[k, x] = p[x] + ru[x] - base[i, k, x]
            dth[k, 0] = s[1] * ru[2] - s[2] * ru[1]
            dth[k, 1] = s[2] * ru[0] - s[0] * ru[2]
            dth[k, 2] = s[0] * ru[1] - s[1] * ru[0]
        for pr in range(m):
            k, l = pairs[pr, 0], pairs[pr, 1]
            for x in range(3):
                r[x] = base[i, k, x] - base[i, l, x]
            sk, tl = _closest(L[k], L[l], r)
            gg = 0.0
            for x in range(3):
                g[x] = r[x] + sk * L[k, x] - tl * L[l, x]
                gg += g[x] * g[x]
            c[i, pr] = (gg - rho[i] * rho[i]) / scale[i]
            a = 2.0 * (sk - tl) / scale[i]  # d(d^2)/dp: 2 (s - t) g
            J[i, pr, 0] = a * (g[0] * cf + g[1] * sf)
            J[i, pr, 1] = a * g[2]
            J[i, pr, 2] = (
                2.0 * sk * (g[0] * dth[k, 0] + g[1] * dth[k, 1] + g[2] * dth[k, 2])
                - 2.0 * tl * (g[0] * dth[l, 0] + g[1] * dth[l, 1] + g[2] * dth[l, 2])
            ) / scale[i]
    return c, J
