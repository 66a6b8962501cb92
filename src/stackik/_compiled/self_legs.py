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
def closest_params(p0: FloatArray, p1: FloatArray, q0: FloatArray, q1: FloatArray) -> Any:
    """Parameters (s, t) in [0, 1]^2 of closest points of segments p0-p1 and q0-q1 (3,)."""
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = d1 @ d1
    e = d2 @ d2
    f = d2 @ r
    c = d1 @ r
    b = d1 @ d2
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
def _rotation_axes(yaw: float, pitch: float, roll: float) -> Any:
    """``R = Rz Ry Rx`` and the rows ``W``: the axes of yaw, pitch and roll in the bottom
    plate's frame (``e_z``, ``Rz e_y``, ``Rz Ry e_x``)."""
    R, _ = _euler(yaw, pitch, roll)
    cz, sz = math.cos(yaw), math.sin(yaw)
    cy, sy = math.cos(pitch), math.sin(pitch)
    W = np.array([[0.0, 0.0, 1.0], [-sz, cz, 0.0], [cz * cy, sz * cy, -sy]])
    return R, W


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
    R, W = _rotation_axes(q[3], q[4], q[5])
    nl = base.shape[0]
    T = np.empty((nl, 3))
    RU = np.empty((nl, 3))
    for k in range(nl):
        RU[k] = R @ top[k]
        T[k] = q[:3] + RU[k]
    for r in range(pairs.shape[0]):
        k, m = pairs[r, 0], pairs[r, 1]
        s, t = closest_params(base[k], T[k], base[m], T[m])
        P = base[k] + s * (T[k] - base[k])
        Q = base[m] + t * (T[m] - base[m])
        g = P - Q
        c[r] = (g @ g - rho * rho) / scale
        # d(d^2)/dT_k = 2 s g, d(d^2)/dT_m = -2 t g (envelope: s, t fixed)
        gk = 2.0 * s * g / scale
        gm = -2.0 * t * g / scale
        for j in range(3):
            J[r, j] = gk[j] + gm[j]
        for j in range(3):
            w = W[j]
            dk = np.cross(w, RU[k])
            dm = np.cross(w, RU[m])
            J[r, 3 + j] = gk @ dk + gm @ dm


@_jit
def _top_derivatives(W: FloatArray, RU: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``dT / dq`` (3, 6) and ``d^2 T / d angle_a d angle_b`` (3, 3, 3) of a top joint
    ``T = p + R u`` with ``RU = R u`` (3,)."""
    dT = np.zeros((3, 6))
    for j in range(3):
        dT[j, j] = 1.0
        w = W[j]
        dT[0, 3 + j] = w[1] * RU[2] - w[2] * RU[1]
        dT[1, 3 + j] = w[2] * RU[0] - w[0] * RU[2]
        dT[2, 3 + j] = w[0] * RU[1] - w[1] * RU[0]
    d2 = np.zeros((3, 3, 3))
    for a in range(3):
        for b in range(a, 3):
            x = dT[:, 3 + b]
            w = W[a]
            v0 = w[1] * x[2] - w[2] * x[1]
            v1 = w[2] * x[0] - w[0] * x[2]
            v2 = w[0] * x[1] - w[1] * x[0]
            d2[0, a, b], d2[1, a, b], d2[2, a, b] = v0, v1, v2
            d2[0, b, a], d2[1, b, a], d2[2, b, a] = v0, v1, v2
    return dT, d2


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
    R, W = _rotation_axes(q[3], q[4], q[5])
    H = np.zeros((6, 6))
    for r in range(pairs.shape[0]):
        if y[r] == 0.0:
            continue
        k, m = pairs[r, 0], pairs[r, 1]
        RUk = R @ top[k]
        RUm = R @ top[m]
        Tk = q[:3] + RUk
        Tm = q[:3] + RUm
        s, t = closest_params(base[k], Tk, base[m], Tm)
        d1 = Tk - base[k]
        d2 = Tm - base[m]
        g = base[k] + s * d1 - base[m] - t * d2
        dTk, d2Tk = _top_derivatives(W, RUk)
        dTm, d2Tm = _top_derivatives(W, RUm)
        Jg = s * dTk - t * dTm  # (3, 6)
        Hp = 2.0 * (Jg.T @ Jg)
        for a in range(3):
            for b in range(3):
                acc = 0.0
                for c in range(3):
                    acc += g[c] * (s * d2Tk[c, a, b] - t * d2Tm[c, a, b])
                Hp[3 + a, 3 + b] += 2.0 * acc
        # the minimisation over the free parameters (strictly inside (0, 1))
        fs = 0.0 < s < 1.0
        ft = 0.0 < t < 1.0
        if fs or ft:
            B = np.zeros((2, 6))
            A = np.zeros((2, 2))
            B[0] = 2.0 * (d1 @ Jg + g @ dTk)
            B[1] = 2.0 * (-(d2 @ Jg) - g @ dTm)
            A[0, 0] = 2.0 * (d1 @ d1)
            A[1, 1] = 2.0 * (d2 @ d2)
            A[0, 1] = A[1, 0] = -2.0 * (d1 @ d2)
            if fs and ft:
                det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
                if det > _PARALLEL * A[0, 0] * A[1, 1]:
                    inv00, inv11, inv01 = A[1, 1] / det, A[0, 0] / det, -A[0, 1] / det
                    for a in range(6):
                        for b in range(6):
                            Hp[a, b] -= B[0, a] * (inv00 * B[0, b] + inv01 * B[1, b]) + B[1, a] * (
                                inv01 * B[0, b] + inv11 * B[1, b]
                            )
            else:
                j = 0 if fs else 1
                if A[j, j] > 0.0:
                    for a in range(6):
                        for b in range(6):
                            Hp[a, b] -= B[j, a] * B[j, b] / A[j, j]
        H += (y[r] / scale) * Hp
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
