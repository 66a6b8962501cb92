"""Compiled (numba) evaluation of the spatial IK problem's parts, for the SQP engine.

:func:`spatial_parts` computes, in one call, what :meth:`stackik.formulation.Problem.evaluate`
needs in spatial mode and otherwise builds from :func:`stackik.kinematics.spatial_chain`,
:func:`stackik.platform.spatial_legs`, :func:`stackik.platform.constraints_from_legs` and
the FN^2 residuals (:meth:`stackik.formulation.Problem.residuals`): the same formulas as explicit
loops (numpy's per-call overhead dominated those small arrays: ~180 us per evaluation at
n = 4, ~15 us here). Tested equal to the numpy implementations (``tests/test_spatial.py``).

Conventions (DESIGN.md): pose rows ``[x, y, z, yaw, pitch, roll]``, ``R = Rz Ry Rx``;
``A_0 = I``, ``O_0 = 0``, ``O_{i+1} = O_i + A_i p_i``, ``A_{i+1} = A_i R_i``; variable
``6 i + j`` moves platform i along ``A_i e_j`` (j < 3) or turns it about the axis
``w = A_i (e_z, Rz e_y, Rz Ry e_x)[j - 3]``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

FloatArray = Any

_jit = njit(cache=True, error_model="numpy", nogil=True)


@_jit
def _euler(a: float, b: float, c: float) -> tuple[Any, Any]:
    """``R = Rz(a) Ry(b) Rx(c)`` and its derivatives ``D[k] = dR / d(a, b, c)[k]``.

    Written out element by element (the products ``(Rz Ry) Rx``, ``(dRz Ry) Rx``,
    ``(Rz dRy) Rx`` and ``(Rz Ry) dRx`` with their zero terms left out, each product in
    the order a 3 x 3 matrix product takes it): BLAS for so small a matrix costs more than
    the arithmetic, fused multiply-adds made its rounding depend on the CPU, and the
    compiled code of a matrix product is far larger than these lines."""
    ca, sa = math.cos(a), math.sin(a)
    cb, sb = math.cos(b), math.sin(b)
    cc, sc = math.cos(c), math.sin(c)
    # Rz Ry, and its derivatives by a (dRz Ry) and by b (Rz dRy)
    casb, sasb, cacb, sacb = ca * sb, sa * sb, ca * cb, sa * cb
    R = np.empty((3, 3))
    R[0, 0], R[0, 1], R[0, 2] = cacb, -sa * cc + casb * sc, sa * sc + casb * cc
    R[1, 0], R[1, 1], R[1, 2] = sacb, ca * cc + sasb * sc, -ca * sc + sasb * cc
    R[2, 0], R[2, 1], R[2, 2] = -sb, cb * sc, cb * cc
    D = np.zeros((3, 3, 3))
    D[0, 0, 0], D[0, 0, 1], D[0, 0, 2] = -sacb, -ca * cc + -sasb * sc, ca * sc + -sasb * cc
    D[0, 1, 0], D[0, 1, 1], D[0, 1, 2] = cacb, -sa * cc + casb * sc, sa * sc + casb * cc
    D[1, 0, 0], D[1, 0, 1], D[1, 0, 2] = -casb, cacb * sc, cacb * cc
    D[1, 1, 0], D[1, 1, 1], D[1, 1, 2] = -sasb, sacb * sc, sacb * cc
    D[1, 2, 0], D[1, 2, 1], D[1, 2, 2] = -cb, -sb * sc, -sb * cc
    for r in range(3):  # (Rz Ry) dRx: the columns of R turned by a quarter about x
        D[2, r, 1] = R[r, 2]
        D[2, r, 2] = -R[r, 1]
    return R, D


@_jit
def _cross(a: Any, b: Any) -> Any:
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


@_jit
def spatial_parts(
    q: FloatArray,
    top: FloatArray,
    base: FloatArray,
    leg_min: FloatArray,
    leg_max: FloatArray,
    sin_joint: FloatArray,
) -> tuple[Any, ...]:
    """Kinematics, limits and FN^2 residuals of a spatial pose ``q`` (n, 6).

    Returns
    -------
    Pee : (3,) end-effector position [mm]
    Ree : (3, 3) end-effector rotation
    Jp : (3, 6n) position Jacobian
    w : (6n, 3) rotation axis of each variable in the base frame (zero for translations)
    c : (n, 24) raw constraints; Jc : (n, 24, 6) their derivatives w.r.t. the platform's
    own variables
    r : (9n,) FN^2 residuals ``Jp[:, angle columns]`` (platform-major, 3 per angle) and
    Jr : (9n, 6n) their Jacobian (unweighted, unscaled)
    """
    Pee, Ree, Jp, w, c, Jc = spatial_kinematics(q, top, base, leg_min, leg_max, sin_joint)
    r, Jr = fn2_residuals(Jp, w)
    return Pee, Ree, Jp, w, c, Jc, r, Jr


@_jit
def spatial_kinematics(
    q: FloatArray,
    top: FloatArray,
    base: FloatArray,
    leg_min: FloatArray,
    leg_max: FloatArray,
    sin_joint: FloatArray,
) -> tuple[Any, ...]:
    """:func:`spatial_parts` without the FN^2 residuals: ``Pee, Ree, Jp, w, c, Jc`` (the
    interior point's evaluation, whose FN^2 terms need ``Jp`` and ``w`` alone)."""
    n = q.shape[0]
    N = 6 * n
    A = np.zeros((n + 1, 3, 3))
    O = np.zeros((n + 1, 3))
    A[0, 0, 0] = A[0, 1, 1] = A[0, 2, 2] = 1.0
    w = np.zeros((N, 3))
    c = np.empty((n, 24))
    Jc = np.zeros((n, 24, 6))
    for i in range(n):
        R, D = _euler(q[i, 3], q[i, 4], q[i, 5])
        Ai = A[i]
        for r_ in range(3):
            O[i + 1, r_] = O[i, r_] + (
                Ai[r_, 0] * q[i, 0] + Ai[r_, 1] * q[i, 1] + Ai[r_, 2] * q[i, 2]
            )
        for r_ in range(3):
            for c_ in range(3):
                A[i + 1, r_, c_] = (
                    Ai[r_, 0] * R[0, c_] + Ai[r_, 1] * R[1, c_] + Ai[r_, 2] * R[2, c_]
                )
        cy, sy = math.cos(q[i, 3]), math.sin(q[i, 3])
        cp, sp = math.cos(q[i, 4]), math.sin(q[i, 4])
        local = np.array([[0.0, 0.0, 1.0], [-sy, cy, 0.0], [cy * cp, sy * cp, -sp]])
        for j in range(3):
            for r_ in range(3):
                w[6 * i + 3 + j, r_] = (
                    Ai[r_, 0] * local[j, 0] + Ai[r_, 1] * local[j, 1] + Ai[r_, 2] * local[j, 2]
                )
        # --- limits of platform i (own frame): legs l_k = R t_k + p - b_k ---------------
        Rn = R[:, 2]
        dRn = D[:, :, 2]  # (3 angles, 3)
        s = sin_joint[i]
        for k in range(6):
            lk = np.empty(3)
            for r_ in range(3):
                lk[r_] = (
                    R[r_, 0] * top[i, k, 0] + R[r_, 1] * top[i, k, 1] + R[r_, 2] * top[i, k, 2]
                    + q[i, r_] - base[i, k, r_]
                )  # fmt: skip
            sq = lk[0] * lk[0] + lk[1] * lk[1] + lk[2] * lk[2]
            norm = math.sqrt(sq)
            lRn = lk[0] * Rn[0] + lk[1] * Rn[1] + lk[2] * Rn[2]
            c[i, k] = sq - leg_min[i] ** 2
            c[i, 6 + k] = leg_max[i] ** 2 - sq
            c[i, 12 + k] = lk[2] - norm * s
            c[i, 18 + k] = lRn - norm * s
            for j in range(6):
                # dl_k / dx_j: e_j for translations, D[a] t_k for the angles
                if j < 3:
                    dl0 = 1.0 if j == 0 else 0.0
                    dl1 = 1.0 if j == 1 else 0.0
                    dl2 = 1.0 if j == 2 else 0.0
                    dRn0 = dRn1 = dRn2 = 0.0
                else:
                    Da = D[j - 3]
                    t0, t1, t2 = top[i, k, 0], top[i, k, 1], top[i, k, 2]
                    dl0 = Da[0, 0] * t0 + Da[0, 1] * t1 + Da[0, 2] * t2
                    dl1 = Da[1, 0] * t0 + Da[1, 1] * t1 + Da[1, 2] * t2
                    dl2 = Da[2, 0] * t0 + Da[2, 1] * t1 + Da[2, 2] * t2
                    dRn0, dRn1, dRn2 = dRn[j - 3, 0], dRn[j - 3, 1], dRn[j - 3, 2]
                dsq = 2.0 * (lk[0] * dl0 + lk[1] * dl1 + lk[2] * dl2)
                dnorm = dsq / (2.0 * norm)
                dlRn = dl0 * Rn[0] + dl1 * Rn[1] + dl2 * Rn[2]
                dlRn += lk[0] * dRn0 + lk[1] * dRn1 + lk[2] * dRn2
                Jc[i, k, j] = dsq
                Jc[i, 6 + k, j] = -dsq
                Jc[i, 12 + k, j] = dl2 - dnorm * s
                Jc[i, 18 + k, j] = dlRn - dnorm * s
    Pee = O[n].copy()
    Ree = A[n].copy()
    # --- position Jacobian ---------------------------------------------------------------
    Jp = np.empty((3, N))
    for i in range(n):
        d = Pee - O[i + 1]
        for j in range(3):
            for r_ in range(3):
                Jp[r_, 6 * i + j] = A[i, r_, j]
            x = _cross(w[6 * i + 3 + j], d)
            for r_ in range(3):
                Jp[r_, 6 * i + 3 + j] = x[r_]
    return Pee, Ree, Jp, w, c, Jc


@_jit
def fn2_residuals(Jp: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The FN^2 residuals ``r`` (9n,) and their Jacobian ``Jr`` (9n, 6n) of
    :func:`spatial_parts` from its ``Jp`` and ``w``."""
    N = Jp.shape[1]
    n = N // 6
    # the angle columns of Jp and their derivatives:
    # d Jp[:, a] / dx_b = w[min(a, b)] x Jp[:, max(a, b)] (zero when min(a, b) translates)
    r = np.empty(9 * n)
    Jr = np.zeros((9 * n, N))
    for i in range(n):
        for j in range(3):
            a = 6 * i + 3 + j
            m = 3 * i + j
            for r_ in range(3):
                r[3 * m + r_] = Jp[r_, a]
            for b in range(N):
                lo = min(a, b)
                hi = max(a, b)
                if lo % 6 < 3:
                    continue
                w0, w1, w2 = w[lo, 0], w[lo, 1], w[lo, 2]
                j0, j1, j2 = Jp[0, hi], Jp[1, hi], Jp[2, hi]
                Jr[3 * m, b] = w1 * j2 - w2 * j1
                Jr[3 * m + 1, b] = w2 * j0 - w0 * j2
                Jr[3 * m + 2, b] = w0 * j1 - w1 * j0
    return r, Jr


@_jit
def block_jacobian(Jc: FloatArray, cs: FloatArray, xs: FloatArray) -> FloatArray:
    """The dense limit Jacobian (24n, 6n) from its diagonal blocks ``Jc`` (n, 24, 6), rows
    scaled by ``cs`` (24n,) and columns by ``xs`` (6n,)."""
    n = Jc.shape[0]
    out = np.zeros((24 * n, 6 * n))
    for i in range(n):
        for r_ in range(24):
            row = 24 * i + r_
            for j in range(6):
                col = 6 * i + j
                out[row, col] = Jc[i, r_, j] * cs[row] * xs[col]
    return out
