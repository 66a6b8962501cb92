"""Compiled primal-dual interior point for the spatial IK problem, with exact second
derivatives.

The spatial problem of :class:`stackik.formulation.Problem` (scaled variables
``u = q / xs``, pose rows ``[x, y, z, yaw, pitch, roll]``, ``R = Rz Ry Rx``):

    min f(u) = (c0 + sum_a w_a |dP_ee / d angle_a|^2) / fscale
    s.t. c_E(u) = 0   (end-effector position / L, and the orientation, 6 rows)
         c_I(u) >= 0  (24 n limits, scaled by ``cs``)

is solved by the barrier method of :mod:`stackik._compiled.planar` (IPOPT-like: slacks,
Fiacco-McCormick ``mu``, Newton steps on the perturbed KKT conditions with inertia correction,
fraction to the boundary, filter line search), here with a null-space KKT solve through the SVD of
the 6 x 6n equality Jacobian. The orientation rows are the skew part
``vee(E - E^T) / 2 = sin(angle) axis`` of ``E = R_target^T R_ee``: smooth everywhere and
equal to the rotation vector to third order at ``E = I``, so the KKT points with ``E = I``
are those of the rotation-vector form :class:`Problem` uses (the caller polishes with that
form and re-checks every pose).

Exact Hessian of the Lagrangian, all in closed form (serial-chain rules, variable ``a``
moving along ``A_i e_j`` or turning about the world axis ``w_a``, ``Jp`` the position
Jacobian):

* ``d^2 P_ee / dx_a dx_b = w_lo x Jp[:, hi]`` (``lo, hi`` = min, max of ``a, b``; zero when
  ``lo`` translates);
* third derivatives ``d^3 P_ee / dx_i dx_j dx_k = w_i x (w_j x Jp[:, k])`` for sorted
  ``i <= j <= k`` with ``i, j`` angles (zero otherwise), which with the Gauss-Newton part
  gives the FN^2 Hessian;
* ``d^2 E / dx_a dx_b = [v_lo]x [v_hi]x E`` with ``v = R_target^T w`` (both angles);
* each platform's 24 limits from ``d^2 R / d angle_j d angle_k = [w_j]x [w_k]x R`` (6 x 6 blocks).

Everything is tested against finite differences (``tests/test_spatial_quality.py``).
"""

from __future__ import annotations

import math
import time
import warnings
from typing import Any

import numpy as np
from numba import njit, objmode

from stackik._compiled.spatial_kinematics import spatial_parts

FloatArray = Any

_jit = njit(cache=True, error_model="numpy", nogil=True)
warnings.filterwarnings(
    "ignore", message="Code running in object mode won't allow parallel execution"
)

#: Stop after this many starts when all end farther than GIVE_UP_VIOLATION (scaled) from
#: feasibility (an unreachable target).
GIVE_UP_AFTER = 3
GIVE_UP_VIOLATION = 1e-4
OBJ_MAX_GRAD = 100.0

IP_SUCCESS, IP_MAX_ITER, IP_STALLED, IP_NONFINITE, IP_MAX_TIME, IP_SKIPPED = 0, 1, 2, 3, 4, 5
IP_STATUS = {
    IP_SKIPPED: "skipped",
    IP_SUCCESS: "success",
    IP_MAX_ITER: "max_iter",
    IP_STALLED: "stalled",
    IP_NONFINITE: "nonfinite",
    IP_MAX_TIME: "max_time",
}


# =========================================================================================
# Derivatives
# =========================================================================================
@_jit
def _mm3(A: FloatArray, B: FloatArray) -> FloatArray:
    """3 x 3 product by loops (BLAS costs more than the arithmetic at this size)."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]
    return out


@_jit
def limit_hessians(q: FloatArray, y: FloatArray, top: FloatArray, base: FloatArray,
                   sin_joint: FloatArray) -> FloatArray:  # fmt: skip
    """``sum_r y[i, r] d^2 c_r / dq_i^2`` per platform, shape (n, 6, 6): the raw limits of
    platform i (24, DESIGN.md order) against its own six variables, weighted by ``y``
    (n, 24).

    With ``R = Rz Ry Rx`` and the axes ``w = (e_z, Rz e_y, Rz Ry e_x)`` of yaw, pitch and
    roll in the bottom plate's frame, ``dR / d angle_j = [w_j]x R`` and
    ``d^2 R / d angle_j d angle_k = [w_j]x [w_k]x R`` (``j <= k``: the serial-chain rule
    within one platform), so the leg ``l = R t + p - b`` and the top normal ``R e_z`` have
    their first and second derivatives by cross products.
    """
    n = q.shape[0]
    out = np.zeros((n, 6, 6))
    lk = np.empty(3)
    dl = np.zeros((6, 3))
    dRn = np.zeros((6, 3))
    d2l = np.zeros((3, 3, 3))  # angles j <= k: w_j x (w_k x R t)
    d2Rn = np.zeros((3, 3, 3))
    gsq = np.empty(6)
    W = np.empty((3, 3))
    Rt = np.empty(3)
    for i in range(n):
        cy, sy = math.cos(q[i, 3]), math.sin(q[i, 3])
        cp, sp = math.cos(q[i, 4]), math.sin(q[i, 4])
        cr, sr = math.cos(q[i, 5]), math.sin(q[i, 5])
        R = np.array(
            [
                [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                [-sp, cp * sr, cp * cr],
            ]
        )
        W[0, 0], W[0, 1], W[0, 2] = 0.0, 0.0, 1.0
        W[1, 0], W[1, 1], W[1, 2] = -sy, cy, 0.0
        W[2, 0], W[2, 1], W[2, 2] = cy * cp, sy * cp, -sp
        Rn0, Rn1, Rn2 = R[0, 2], R[1, 2], R[2, 2]
        for j in range(3):
            dRn[3 + j, 0] = W[j, 1] * Rn2 - W[j, 2] * Rn1
            dRn[3 + j, 1] = W[j, 2] * Rn0 - W[j, 0] * Rn2
            dRn[3 + j, 2] = W[j, 0] * Rn1 - W[j, 1] * Rn0
        for j in range(3):
            for k in range(j, 3):  # w_j x (w_k x Rn) = w_j x dRn_k
                x0, x1, x2 = dRn[3 + k, 0], dRn[3 + k, 1], dRn[3 + k, 2]
                d2Rn[j, k, 0] = W[j, 1] * x2 - W[j, 2] * x1
                d2Rn[j, k, 1] = W[j, 2] * x0 - W[j, 0] * x2
                d2Rn[j, k, 2] = W[j, 0] * x1 - W[j, 1] * x0
        s = sin_joint[i]
        for k in range(6):
            t0, t1, t2 = top[i, k, 0], top[i, k, 1], top[i, k, 2]
            for r in range(3):
                Rt[r] = R[r, 0] * t0 + R[r, 1] * t1 + R[r, 2] * t2
                lk[r] = Rt[r] + q[i, r] - base[i, k, r]
            for j in range(3):
                for r in range(3):
                    dl[j, r] = 1.0 if r == j else 0.0
                dl[3 + j, 0] = W[j, 1] * Rt[2] - W[j, 2] * Rt[1]
                dl[3 + j, 1] = W[j, 2] * Rt[0] - W[j, 0] * Rt[2]
                dl[3 + j, 2] = W[j, 0] * Rt[1] - W[j, 1] * Rt[0]
            for j in range(3):
                for jj in range(j, 3):
                    x0, x1, x2 = dl[3 + jj, 0], dl[3 + jj, 1], dl[3 + jj, 2]
                    d2l[j, jj, 0] = W[j, 1] * x2 - W[j, 2] * x1
                    d2l[j, jj, 1] = W[j, 2] * x0 - W[j, 0] * x2
                    d2l[j, jj, 2] = W[j, 0] * x1 - W[j, 1] * x0
            sq = lk[0] * lk[0] + lk[1] * lk[1] + lk[2] * lk[2]
            nrm = math.sqrt(sq)
            for j in range(6):
                gsq[j] = 2.0 * (lk[0] * dl[j, 0] + lk[1] * dl[j, 1] + lk[2] * dl[j, 2])
            y0, y1, y2, y3 = y[i, k], y[i, 6 + k], y[i, 12 + k], y[i, 18 + k]
            for a in range(6):
                for b in range(a, 6):
                    dd = dl[a, 0] * dl[b, 0] + dl[a, 1] * dl[b, 1] + dl[a, 2] * dl[b, 2]
                    cross_n = (dl[a, 0] * dRn[b, 0] + dl[a, 1] * dRn[b, 1] + dl[a, 2] * dRn[b, 2]
                               + dl[b, 0] * dRn[a, 0] + dl[b, 1] * dRn[a, 1]
                               + dl[b, 2] * dRn[a, 2])  # fmt: skip
                    ld2l = 0.0
                    d2lz = 0.0
                    d2lRn = 0.0
                    lRn2 = 0.0
                    if a >= 3:  # then b >= 3 too (a <= b)
                        a3, b3 = a - 3, b - 3
                        e0, e1, e2 = d2l[a3, b3, 0], d2l[a3, b3, 1], d2l[a3, b3, 2]
                        ld2l = lk[0] * e0 + lk[1] * e1 + lk[2] * e2
                        d2lz = e2
                        d2lRn = e0 * Rn0 + e1 * Rn1 + e2 * Rn2
                        lRn2 = (lk[0] * d2Rn[a3, b3, 0] + lk[1] * d2Rn[a3, b3, 1]
                                + lk[2] * d2Rn[a3, b3, 2])  # fmt: skip
                    hsq = 2.0 * (dd + ld2l)
                    hn = hsq / (2.0 * nrm) - gsq[a] * gsq[b] / (4.0 * nrm * sq)
                    h2 = d2lz - s * hn
                    h3 = d2lRn + cross_n + lRn2 - s * hn
                    v = (y0 - y1) * hsq + y2 * h2 + y3 * h3
                    out[i, a, b] += v
                    if b != a:
                        out[i, b, a] += v
    return out


@_jit
def _skew_vee(M: FloatArray) -> FloatArray:
    return 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])


@_jit
def fn2_hessian(Jp: FloatArray, w: FloatArray, r: FloatArray, Jr: FloatArray,
                wa: FloatArray) -> FloatArray:  # fmt: skip
    """Exact Hessian of ``sum_a wa[platform(a)] |Jp[:, a]|^2`` over the angle columns a
    (raw variables), shape (6n, 6n), from the outputs of
    :func:`stackik._compiled.spatial_kinematics.spatial_parts`."""
    N = Jp.shape[1]
    n = N // 6
    Wr = np.empty((9 * n, N))
    for m in range(9 * n):
        wt = wa[m // 9]
        for b in range(N):
            Wr[m, b] = Jr[m, b] * wt
    H = Wr.T @ Jr  # Gauss-Newton part Jr^T W Jr
    # curvature part H2[b, c] = sum_a wt_a Jp_a . T[sorted(a, b, c)] (a an angle), with
    # T[i, j, k] = w_i x (w_j x Jp_k) (i, j angles), in O(N^2) for b <= c by where a
    # falls (Jp_a is orthogonal to w_a):
    #   a <= b:      (w_b x Jp_c) . S[b],  S[b] = sum_{a <= b} wt_a Jp_a x w_a
    #   b < a <= c:  -w_b . sum_{b < a <= c} wt_a w_a (Jp_a . Jp_c)
    #   c < a:       w_c^T M[c] w_b - (w_b . w_c) tr M[c],  M[c] = sum_{a > c} wt_a Jp_a Jp_a^T
    S = np.zeros((N, 3))
    acc0 = acc1 = acc2 = 0.0
    for a in range(N):
        if a % 6 >= 3:
            wt = wa[a // 6]
            acc0 += wt * (Jp[1, a] * w[a, 2] - Jp[2, a] * w[a, 1])
            acc1 += wt * (Jp[2, a] * w[a, 0] - Jp[0, a] * w[a, 2])
            acc2 += wt * (Jp[0, a] * w[a, 1] - Jp[1, a] * w[a, 0])
        S[a, 0], S[a, 1], S[a, 2] = acc0, acc1, acc2
    M = np.zeros((N, 3, 3))
    Macc = np.zeros((3, 3))
    for c in range(N - 1, -1, -1):
        M[c] = Macc
        if c % 6 >= 3:
            wt = wa[c // 6]
            for k in range(3):
                for m in range(3):
                    Macc[k, m] += wt * Jp[k, c] * Jp[m, c]
    acc = np.zeros(3)
    for c in range(N):
        acc[:] = 0.0
        for b in range(c, -1, -1):  # acc = sum_{b < a <= c} wt_a w_a (Jp_a . Jp_c)
            if b % 6 >= 3:
                val = (
                    (w[b, 1] * Jp[2, c] - w[b, 2] * Jp[1, c]) * S[b, 0]
                    + (w[b, 2] * Jp[0, c] - w[b, 0] * Jp[2, c]) * S[b, 1]
                    + (w[b, 0] * Jp[1, c] - w[b, 1] * Jp[0, c]) * S[b, 2]
                    - (w[b, 0] * acc[0] + w[b, 1] * acc[1] + w[b, 2] * acc[2])
                )
                if c % 6 >= 3:
                    Mc = M[c]
                    wMw = 0.0
                    for k in range(3):
                        wMw += w[c, k] * (
                            Mc[k, 0] * w[b, 0] + Mc[k, 1] * w[b, 1] + Mc[k, 2] * w[b, 2]
                        )
                    tr = Mc[0, 0] + Mc[1, 1] + Mc[2, 2]
                    wbwc = w[b, 0] * w[c, 0] + w[b, 1] * w[c, 1] + w[b, 2] * w[c, 2]
                    val += wMw - wbwc * tr
                H[b, c] += val
                if c != b:
                    H[c, b] += val
                wt = wa[b // 6]
                dot = Jp[0, b] * Jp[0, c] + Jp[1, b] * Jp[1, c] + Jp[2, b] * Jp[2, c]
                acc[0] += wt * w[b, 0] * dot
                acc[1] += wt * w[b, 1] * dot
                acc[2] += wt * w[b, 2] * dot
    return 2.0 * H


# =========================================================================================
# Evaluation (scaled)
# =========================================================================================
@_jit
def _evaluate(u: FloatArray, P: Any) -> tuple[Any, ...]:
    """Scaled ``f, grad f, c_E (6,), A_E (6, N), c_I (24n,), A_I blocks (n, 24, 6)`` and
    the kinematic parts the Hessian reuses."""
    (xs, cs, es, p_t, R_t, fscale, c0, wa, top, base, lmin, lmax, sj, feasible) = P
    n = top.shape[0]
    N = 6 * n
    q = (u * xs).reshape(n, 6)
    Pee, Ree, Jp, w, c, Jc, r, Jr = spatial_parts(q, top, base, lmin, lmax, sj)
    E = _mm3(R_t.T.copy(), Ree)
    cE = np.empty(6)
    sk = _skew_vee(E)
    for k in range(3):
        cE[k] = (Pee[k] - p_t[k]) * es[k]
        cE[3 + k] = sk[k] * es[3 + k]
    AE = np.zeros((6, N))
    trE = E[0, 0] + E[1, 1] + E[2, 2]
    M = -0.5 * E
    for k in range(3):
        M[k, k] += 0.5 * trE
    for b in range(N):
        for k in range(3):
            AE[k, b] = Jp[k, b] * es[k] * xs[b]
        if b % 6 >= 3:  # d vee(skew E) / dx_b = (tr(E) I - E) v / 2, v = R_target^T w_b
            v0 = R_t[0, 0] * w[b, 0] + R_t[1, 0] * w[b, 1] + R_t[2, 0] * w[b, 2]
            v1 = R_t[0, 1] * w[b, 0] + R_t[1, 1] * w[b, 1] + R_t[2, 1] * w[b, 2]
            v2 = R_t[0, 2] * w[b, 0] + R_t[1, 2] * w[b, 1] + R_t[2, 2] * w[b, 2]
            for k in range(3):
                d = M[k, 0] * v0 + M[k, 1] * v1 + M[k, 2] * v2
                AE[3 + k, b] = d * es[3 + k] * xs[b]
    cI = c.ravel() * cs
    D = np.empty((n, 24, 6))
    for i in range(n):
        for rr in range(24):
            for k in range(6):
                D[i, rr, k] = Jc[i, rr, k] * cs[24 * i + rr] * xs[6 * i + k]
    g = np.zeros(N)
    parts = (q, Ree, Jp, w, r, Jr)
    if feasible:
        return 0.0, g, cE, AE, cI, D, parts
    acc = 0.0
    for m in range(9 * n):
        wt = wa[m // 9]
        acc += wt * r[m] * r[m]
        for b in range(N):
            g[b] += 2.0 * wt * r[m] * Jr[m, b]
    for b in range(N):
        g[b] *= xs[b] / fscale
    return (c0 + acc) / fscale, g, cE, AE, cI, D, parts


@_jit
def evaluate(u: FloatArray, P: Any) -> tuple[Any, ...]:
    """Scaled ``f, grad f, c_E (6,), A_E (6, N), c_I (24n,), A_I blocks (n, 24, 6)``."""
    f, g, cE, AE, cI, D, parts = _evaluate(u, P)
    return f, g, cE, AE, cI, D


@_jit
def _evaluate_ext(u: FloatArray, P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray,
                  wq: float) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_evaluate` with a path step's extensions: ``wq |u - ug|^2`` added to the
    objective (when ``wq > 0``) and, when ``lo`` is not empty, the box ``lo <= u <= hi``
    as 12 more limit rows per platform (rows 24-29: ``u - lo``, 30-35: ``hi - u``):
    ``c_I`` (36 n,), ``D`` (n, 36, 6). Without extensions, :func:`_evaluate`'s values."""
    f, g, cE, AE, cI, D, parts = _evaluate(u, P)
    if wq > 0.0:
        acc = 0.0
        for a in range(u.size):
            d = u[a] - ug[a]
            acc += d * d
            g[a] += 2.0 * wq * d
        f += wq * acc
    if lo.size == 0:
        return f, g, cE, AE, cI, D, parts
    n = D.shape[0]
    cB = np.empty(36 * n)
    DB = np.zeros((n, 36, 6))
    for i in range(n):
        for r in range(24):
            cB[36 * i + r] = cI[24 * i + r]
            for k in range(6):
                DB[i, r, k] = D[i, r, k]
        for k in range(6):
            cB[36 * i + 24 + k] = u[6 * i + k] - lo[6 * i + k]
            cB[36 * i + 30 + k] = hi[6 * i + k] - u[6 * i + k]
            DB[i, 24 + k, k] = 1.0
            DB[i, 30 + k, k] = -1.0
    return f, g, cE, AE, cB, DB, parts


@_jit
def _limit_rows(z: FloatArray, n: int) -> FloatArray:
    """The multipliers of the 24 n limit rows among the 36 n rows of a boxed problem
    (``z`` itself without a box): the box is linear and has no Hessian."""
    if z.size == 24 * n:
        return z
    out = np.empty(24 * n)
    for i in range(n):
        for r in range(24):
            out[24 * i + r] = z[36 * i + r]
    return out


@_jit
def _hessian_ext(parts: Any, yE: FloatArray, z: FloatArray, P: Any, wq: float) -> FloatArray:
    """Hessian of the Lagrangian of :func:`_evaluate_ext`'s problem from its kinematic
    parts (``z``: 24 n or, with a box, 36 n multipliers): the box rows are linear, the
    distance term adds ``2 wq I``."""
    H = _hessian(parts, yE, _limit_rows(z, P[8].shape[0]), P)
    if wq > 0.0:
        for a in range(H.shape[0]):
            H[a, a] += 2.0 * wq
    return H


@_jit
def lagrangian_hessian_ext(u: FloatArray, yE: FloatArray, z: FloatArray, P: Any,
                           lo: FloatArray, hi: FloatArray, ug: FloatArray,
                           wq: float) -> FloatArray:  # fmt: skip
    """:func:`_hessian_ext` at ``u`` (for the tests)."""
    return _hessian_ext(_evaluate_ext(u, P, lo, hi, ug, wq)[6], yE, z, P, wq)


@_jit
def lagrangian_hessian(u: FloatArray, yE: FloatArray, z: FloatArray, P: Any) -> FloatArray:
    """Hessian of ``f - yE.c_E - z.c_I`` in scaled variables, shape (6n, 6n)."""
    return _hessian(_evaluate(u, P)[6], yE, z, P)


@_jit
def _hessian(parts: Any, yE: FloatArray, z: FloatArray, P: Any) -> FloatArray:
    """:func:`lagrangian_hessian` from the kinematic parts of :func:`_evaluate`."""
    (xs, cs, es, p_t, R_t, fscale, c0, wa, top, base, lmin, lmax, sj, feasible) = P
    q, Ree, Jp, w, r, Jr = parts
    n = top.shape[0]
    N = 6 * n
    if feasible:
        H = np.zeros((N, N))
    else:
        H = fn2_hessian(Jp, w, r, Jr, wa) / fscale
    E = _mm3(R_t.T.copy(), Ree)
    yp = yE[:3] * es[:3]
    yo = yE[3:] * es[3:]
    # orientation: d^2 E / dx_a dx_b = [v_a]x [v_b]x E = (v_b v_a^T - (v_a . v_b) I) E
    # (v = R_target^T w, a <= b angles), whose skew part is
    # (E^T v_a) x v_b / 2 - (v_a . v_b) vee(skew E)
    V = np.zeros((N, 3))
    EV = np.zeros((N, 3))
    for b in range(N):
        if b % 6 >= 3:
            for k in range(3):
                V[b, k] = R_t[0, k] * w[b, 0] + R_t[1, k] * w[b, 1] + R_t[2, k] * w[b, 2]
            for k in range(3):
                EV[b, k] = E[0, k] * V[b, 0] + E[1, k] * V[b, 1] + E[2, k] * V[b, 2]
    sE = _skew_vee(E)
    ysE = yo[0] * sE[0] + yo[1] * sE[1] + yo[2] * sE[2]
    for a in range(N):
        if a % 6 < 3:
            continue
        wa0, wa1, wa2 = w[a, 0], w[a, 1], w[a, 2]
        for b in range(a, N):
            # position: yp . (w_a x Jp_b) (a <= b, a an angle)
            j0, j1, j2 = Jp[0, b], Jp[1, b], Jp[2, b]
            val = (yp[0] * (wa1 * j2 - wa2 * j1) + yp[1] * (wa2 * j0 - wa0 * j2)
                   + yp[2] * (wa0 * j1 - wa1 * j0))  # fmt: skip
            if b % 6 >= 3:
                e0, e1, e2 = EV[a, 0], EV[a, 1], EV[a, 2]
                v0, v1, v2 = V[b, 0], V[b, 1], V[b, 2]
                c0_ = 0.5 * (e1 * v2 - e2 * v1)
                c1_ = 0.5 * (e2 * v0 - e0 * v2)
                c2_ = 0.5 * (e0 * v1 - e1 * v0)
                dot = V[a, 0] * v0 + V[a, 1] * v1 + V[a, 2] * v2
                val += yo[0] * c0_ + yo[1] * c1_ + yo[2] * c2_ - dot * ysE
            H[a, b] -= val
            if b != a:
                H[b, a] -= val
    Hb = limit_hessians(q, (z * cs).reshape(n, 24), top, base, sj)
    for i in range(n):
        for a in range(6):
            for b in range(6):
                H[6 * i + a, 6 * i + b] -= Hb[i, a, b]
    for a in range(N):
        for b in range(N):
            H[a, b] *= xs[a] * xs[b]
    return H


# =========================================================================================
# Linear algebra
# =========================================================================================
@_jit
def _AI_dot(D: FloatArray, dx: FloatArray) -> FloatArray:
    """``A_I dx`` (R n,) from the blocks ``D`` (n, R, 6) (R = 24, 36 with a box)."""
    n, R = D.shape[0], D.shape[1]
    out = np.empty(R * n)
    for i in range(n):
        for r in range(R):
            acc = 0.0
            for k in range(6):
                acc += D[i, r, k] * dx[6 * i + k]
            out[R * i + r] = acc
    return out


@_jit
def _AIT_dot(D: FloatArray, v: FloatArray) -> FloatArray:
    n, R = D.shape[0], D.shape[1]
    out = np.zeros(6 * n)
    for i in range(n):
        for r in range(R):
            vr = v[R * i + r]
            for k in range(6):
                out[6 * i + k] += D[i, r, k] * vr
    return out


@_jit
def _cholesky(A: FloatArray) -> tuple[FloatArray, bool]:
    """Lower Cholesky factor of ``A``; ``ok`` False when not positive definite."""
    k = A.shape[0]
    if k >= 24:  # LAPACK pays off beyond small sizes
        try:
            L = np.linalg.cholesky(A)
        except Exception:  # noqa: BLE001 - numba raises LinAlgError when not PD
            return A, False
        for i in range(k):
            if not L[i, i] > 1e-7 * math.sqrt(abs(A[i, i]) + 1e-300):
                return L, False
        return L, True
    L = np.zeros((k, k))
    dmax = 0.0
    for i in range(k):
        dmax = max(dmax, abs(A[i, i]))
    for j in range(k):
        acc = A[j, j]
        for p in range(j):
            acc -= L[j, p] * L[j, p]
        if not acc > 1e-14 * dmax:
            return L, False
        L[j, j] = math.sqrt(acc)
        for i in range(j + 1, k):
            acc = A[i, j]
            for p in range(j):
                acc -= L[i, p] * L[j, p]
            L[i, j] = acc / L[j, j]
    return L, True


@_jit
def _cho_solve(L: FloatArray, b: FloatArray) -> FloatArray:
    k = L.shape[0]
    y = np.empty(k)
    for i in range(k):
        acc = b[i]
        for p in range(i):
            acc -= L[i, p] * y[p]
        y[i] = acc / L[i, i]
    x = np.empty(k)
    for i in range(k - 1, -1, -1):
        acc = y[i]
        for p in range(i + 1, k):
            acc -= L[p, i] * x[p]
        x[i] = acc / L[i, i]
    return x


@_jit
def _solve6(B: FloatArray) -> tuple[FloatArray, bool]:
    """Inverse of a 6 x 6 matrix by Gauss-Jordan with partial pivoting (no LAPACK);
    ``ok`` False when a pivot is below 1e-10 of the largest entry."""
    A = B.copy()
    inv = np.eye(6)
    big = np.abs(A).max()
    for c in range(6):
        p = c
        for r in range(c + 1, 6):
            if abs(A[r, c]) > abs(A[p, c]):
                p = r
        if not abs(A[p, c]) > 1e-10 * big:
            return inv, False
        if p != c:
            for k in range(6):
                A[c, k], A[p, k] = A[p, k], A[c, k]
                inv[c, k], inv[p, k] = inv[p, k], inv[c, k]
        d = 1.0 / A[c, c]
        for k in range(6):
            A[c, k] *= d
            inv[c, k] *= d
        for r in range(6):
            if r != c and A[r, c] != 0.0:
                m = A[r, c]
                for k in range(6):
                    A[r, k] -= m * A[c, k]
                    inv[r, k] -= m * inv[c, k]
    return inv, True


@_jit
def _basis(AE: FloatArray, cE: FloatArray) -> tuple[FloatArray, FloatArray, bool]:
    """A null-space basis ``Z`` (N, K) of the 6 x N equality Jacobian and the particular
    step ``dxp`` with ``AE dxp = -cE``: ``Z = [-B^-1 C; I]`` from the first platform's six
    columns ``B`` (a translation block and three rotation axes: invertible away from
    gimbal lock; ``structured`` True), else an orthonormal basis from the SVD."""
    N = AE.shape[1]
    K = N - 6
    Binv, ok = _solve6(AE[:, :6].copy())
    if ok:
        Z = np.zeros((N, K))
        dxp = np.zeros(N)
        for i in range(6):
            acc = 0.0
            for j in range(6):
                acc -= Binv[i, j] * cE[j]
            dxp[i] = acc
            for a in range(K):
                acc = 0.0
                for j in range(6):
                    acc -= Binv[i, j] * AE[j, 6 + a]
                Z[i, a] = acc
        for a in range(K):
            Z[6 + a, a] = 1.0
        return Z, dxp, True
    U, S, Vt = np.linalg.svd(AE)
    rank = 0
    for k in range(6):
        if S[k] > 1e-10 * S[0]:
            rank += 1
    dxp = np.zeros(N)
    for k in range(rank):
        coef = -(U[:, k] @ cE) / S[k]
        for a in range(N):
            dxp[a] += coef * Vt[k, a]
    return Vt[rank:].T.copy(), dxp, False


@_jit
def _kkt_step(W: FloatArray, AE: FloatArray, cE: FloatArray, rhs: FloatArray,
              last_shift: float) -> tuple[FloatArray, float]:  # fmt: skip
    """Solve ``[W -AE^T; AE 0] [dx; dy] = [rhs; -cE]`` for ``dx`` by a null-space method
    (:func:`_basis`), adding ``delta I`` to ``W`` until the reduced Hessian is positive
    definite (IPOPT's inertia correction)."""
    Z, dxp, structured = _basis(AE, cE)
    N = W.shape[0]
    res = rhs - W @ dxp
    if structured:  # Z = [E; I]: products in O(N^2 6) instead of O(N^3)
        K = N - 6
        E = Z[:6]
        WZ = W[:, 6:].copy()
        for i in range(N):
            for j in range(6):
                wij = W[i, j]
                if wij != 0.0:
                    for a in range(K):
                        WZ[i, a] += wij * E[j, a]
        Hz = WZ[6:].copy()
        rz = res[6:].copy()
        for j in range(6):
            for a in range(K):
                ea = E[j, a]
                if ea != 0.0:
                    rz[a] += ea * res[j]
                    for b in range(K):
                        Hz[a, b] += ea * WZ[j, b]
    else:
        WZ = W @ Z
        Hz = Z.T @ WZ
        rz = Z.T @ res
    K = Hz.shape[0]
    shift = 0.0
    L, ok = _cholesky(Hz)
    if not ok:
        scale = 0.0
        for i in range(K):
            scale = max(scale, abs(Hz[i, i]))
        ZtZ = Z.T @ Z  # the shift is delta I in x-space: Z^T (W + delta I) Z
        shift = max(last_shift / 3.0, 1e-4) if last_shift > 0.0 else 1e-4
        grow = 8.0 if last_shift > 0.0 else 100.0
        for _ in range(60):
            L, ok = _cholesky(Hz + shift * ZtZ)
            if ok or not shift <= 1e20 * (1.0 + scale):
                break
            shift *= grow
    if shift > 0.0:  # the particular part sees the shifted Hessian too
        rz -= shift * (Z.T @ dxp)
    wz = _cho_solve(L, rz)
    dx = dxp + Z @ wz
    return dx, shift


@_jit
def _ls_multipliers(AE: FloatArray, g: FloatArray, AItz: FloatArray) -> FloatArray:
    """Least-squares equality multipliers ``argmin |g - AI^T z - AE^T y|``."""
    G = AE @ AE.T
    for k in range(G.shape[0]):
        G[k, k] += 1e-14 * (1.0 + G[k, k])
    return np.linalg.solve(G, AE @ (g - AItz))


@_jit
def _now() -> float:
    with objmode(t="float64"):
        t = time.perf_counter()
    return t


# =========================================================================================
# The barrier method (as stackik._compiled.planar._ip_loop, 6 equalities, 6 x 6 limit blocks)
# =========================================================================================
@_jit
def _with_fscale(P0: Any, fscale: float) -> Any:
    return (P0[0], P0[1], P0[2], P0[3], P0[4], fscale, P0[6], P0[7], P0[8], P0[9], P0[10],
            P0[11], P0[12], P0[13])  # fmt: skip


@_jit
def ip_loop(u0: FloatArray, P0: Any, tol: float, constr_tol: float, mu0: float,
            max_iter: int, deadline: float, lo: FloatArray, hi: FloatArray, ug: FloatArray,
            wq: float) -> tuple[Any, ...]:  # fmt: skip
    """The barrier method from ``u0``; ``lo``/``hi`` (empty: none) add a box and ``wq``
    a distance term (:func:`_evaluate_ext`). Returns the point, the status, the
    iteration count and the final slacks ``s`` and multipliers ``z``, ``yE`` (of the
    problem as ``P0`` states it, without the loop's objective scaling; a continuation
    step starts from them, :func:`_pc_step`)."""
    n = P0[8].shape[0]
    R = 24 if lo.size == 0 else 36
    m = R * n
    x = u0.copy()
    f, g, cE, AE, cI, D, parts = _evaluate_ext(x, P0, lo, hi, ug, wq)
    if not (np.all(np.isfinite(cI)) and np.all(np.isfinite(cE)) and math.isfinite(f)):
        return x, IP_NONFINITE, 0, cI, np.ones(m), np.zeros(6)
    gmax = np.abs(g).max()
    fs = OBJ_MAX_GRAD / gmax if gmax > OBJ_MAX_GRAD else 1.0
    P = _with_fscale(P0, P0[5] / fs)
    f, g = f * fs, g * fs
    wq = wq * fs
    mu = mu0
    mu_min = min(tol, constr_tol) / 10.0
    s = np.maximum(cI, 1e-2)
    z = np.ones(m)
    yE = _ls_multipliers(AE, g, _AIT_dot(D, z))
    last_shift = 0.0
    logsum = np.log(s).sum()
    logsum_t = logsum
    theta0 = np.abs(cE).sum() + np.abs(cI - s).sum()
    theta_max = 1e4 * max(1.0, theta0)
    theta_min = 1e-4 * max(1.0, theta0)
    filt = np.empty((max_iter + 1, 2))
    nfilt = 0
    status = IP_MAX_ITER
    fails = 0
    it = 0
    for it in range(max_iter):
        if it % 8 == 7 and _now() > deadline:
            status = IP_MAX_TIME
            break
        AEty = AE.T @ yE
        AItz = _AIT_dot(D, z)
        sd_acc = np.abs(yE).sum() + np.abs(z).sum()
        sd = max(100.0, sd_acc / (m + 6)) / 100.0
        e_du = np.abs(g - AEty - AItz).max() / sd
        e_pr = np.abs(cE).max()
        comp = 0.0
        for r in range(m):
            e_pr = max(e_pr, abs(cI[r] - s[r]))
            comp = max(comp, abs(s[r] * z[r]))
        if max(e_du, comp / sd) <= tol and e_pr <= constr_tol:
            status = IP_SUCCESS
            break
        while mu > mu_min:
            comp_mu = 0.0
            for r in range(m):
                comp_mu = max(comp_mu, abs(s[r] * z[r] - mu))
            e_mu = max(e_du, max(comp_mu / sd, e_pr))
            if e_mu > 10.0 * mu:
                break
            mu = max(mu_min, min(0.2 * mu, mu**1.5))
            nfilt = 0
        W = _hessian_ext(parts, yE, z, P, wq)
        if not (np.all(np.isfinite(W)) and np.all(np.isfinite(g)) and np.all(np.isfinite(AE))):
            status = IP_NONFINITE
            break
        Sig = z / s
        for i in range(n):
            for a in range(6):
                for b in range(6):
                    acc = 0.0
                    for r in range(R):
                        acc += D[i, r, a] * Sig[R * i + r] * D[i, r, b]
                    W[6 * i + a, 6 * i + b] += acc
        v = np.empty(m)
        for r in range(m):
            v[r] = mu / s[r] - Sig[r] * (cI[r] - s[r])
        rhs = -g + AEty + _AIT_dot(D, v)
        dx, shift = _kkt_step(W, AE, cE, rhs, last_shift)
        if not np.all(np.isfinite(dx)):
            status = IP_NONFINITE
            break
        if shift > 0.0:
            last_shift = shift
        AIdx = _AI_dot(D, dx)
        ds = np.empty(m)
        dz = np.empty(m)
        for r in range(m):
            ds[r] = AIdx[r] + cI[r] - s[r]
            dz[r] = -z[r] + mu / s[r] - Sig[r] * ds[r]
        tau = max(0.99, 1.0 - mu)
        a_s = 1.0
        a_z = 1.0
        for r in range(m):
            if ds[r] < 0.0:
                a_s = min(a_s, -tau * s[r] / ds[r])
            if dz[r] < 0.0:
                a_z = min(a_z, -tau * z[r] / dz[r])
        theta = np.abs(cE).sum()
        dsum = 0.0
        for r in range(m):
            theta += abs(cI[r] - s[r])
            dsum += ds[r] / s[r]
        gdx = g @ dx
        phi = f - mu * logsum
        gphi = gdx - mu * dsum
        alpha = a_s
        accepted = False
        ftype = False
        st = s.copy()
        ft, gt, cEt, AEt, cIt, Dt, parts_t = f, g, cE, AE, cI, D, parts
        xt = x
        for _ in range(40):
            xt = x + alpha * dx
            st = s + alpha * ds
            ft, gt, cEt, AEt, cIt, Dt, parts_t = _evaluate_ext(xt, P, lo, hi, ug, wq)
            theta_t = np.abs(cEt).sum()
            logsum_t = 0.0
            for r in range(m):
                theta_t += abs(cIt[r] - st[r])
                logsum_t += math.log(st[r])
            if math.isfinite(ft) and math.isfinite(theta_t):
                phi_t = ft - mu * logsum_t
                ok = theta_t <= theta_max
                for j in range(nfilt):
                    if theta_t >= filt[j, 0] and phi_t >= filt[j, 1]:
                        ok = False
                        break
                if ok:
                    switching = gphi < 0.0 and alpha * (-gphi) ** 2.3 > theta**1.1
                    if switching and theta <= theta_min:
                        if phi_t <= phi + 1e-4 * alpha * gphi + 1e-14 * abs(phi):
                            accepted = True
                            ftype = True
                    elif theta_t <= (1.0 - 1e-5) * theta or phi_t <= phi - 1e-8 * theta:
                        accepted = True
                    elif switching and phi_t <= phi + 1e-4 * alpha * gphi + 1e-14 * abs(phi):
                        accepted = True
                        ftype = True
                if accepted:
                    break
            alpha *= 0.5
            if alpha < 1e-12:
                break
        if accepted and not ftype and nfilt < filt.shape[0]:
            filt[nfilt, 0] = (1.0 - 1e-5) * theta
            filt[nfilt, 1] = phi - 1e-8 * theta
            nfilt += 1
        if not accepted:
            fails += 1
            if fails >= 3:
                status = IP_STALLED
                break
            nfilt = 0
            alpha = min(alpha, 1e-8)
            xt = x + alpha * dx
            st = s + alpha * ds
            ft, gt, cEt, AEt, cIt, Dt, parts_t = _evaluate_ext(xt, P, lo, hi, ug, wq)
            if not (math.isfinite(ft) and np.all(np.isfinite(cIt))):
                status = IP_NONFINITE
                break
        else:
            fails = 0
        x = xt
        s = st
        logsum = logsum_t if accepted else np.log(s).sum()
        for r in range(m):
            if cIt[r] > s[r]:
                logsum += math.log(cIt[r]) - math.log(s[r])
                s[r] = cIt[r]
            zr = z[r] + a_z * dz[r]
            z[r] = min(max(zr, mu / (1e10 * s[r])), 1e10 * mu / s[r])
        f, g, cE, AE, cI, D, parts = ft, gt, cEt, AEt, cIt, Dt, parts_t
        yE = _ls_multipliers(AE, g, _AIT_dot(D, z))
    return x, status, it + 1 if status != IP_SUCCESS else it, s, z / fs, yE / fs


@_jit
def ip_multi(U0: FloatArray, P: Any, tol: float, constr_tol: float, mu0: FloatArray,
             max_iter: int, deadline: float) -> tuple[Any, ...]:  # fmt: skip
    """:func:`ip_loop` from each row of ``U0``: points, statuses, iterations, scaled
    objective values and worst scaled violations (for ranking; the caller polishes and
    re-checks)."""
    k, N = U0.shape
    X = np.empty((k, N))
    status = np.full(k, IP_SKIPPED)
    nit = np.zeros(k, dtype=np.int64)
    obj = np.full(k, np.inf)
    viol = np.full(k, np.inf)
    none = np.empty(0)
    for j in range(k):
        X[j] = U0[j]
        if j > 0 and _now() > deadline:
            break
        x, st, it, _, _, _ = ip_loop(
            U0[j], P, tol, constr_tol, mu0[j], max_iter, deadline, none, none, none, 0.0
        )
        if st == IP_NONFINITE or not np.all(np.isfinite(x)):
            x = U0[j].copy()
        X[j] = x
        status[j] = st
        nit[j] = it
        f, g, cE, AE, cI, D = evaluate(x, P)
        obj[j] = f
        viol[j] = max(np.abs(cE).max(), max(0.0, -cI.min()))
        if j + 1 == GIVE_UP_AFTER and viol[: j + 1].min() > GIVE_UP_VIOLATION:
            break
    return X, status, nit, obj, viol


@_jit
def ip_box(u0: FloatArray, P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray, wq: float,
           tol: float, constr_tol: float, mu0: float,
           max_iter: int) -> tuple[FloatArray, int, int]:  # fmt: skip
    """One barrier solve of a path step inside the box ``lo <= u <= hi`` (scaled) with
    ``wq |u - ug|^2`` added to the objective (``wq = 0``: none). Returns the point, the
    status and the iteration count; the caller polishes and checks the pose."""
    # copies: the barrier loop sees writable arrays whatever the caller passes, as from
    # ip_multi (one compiled specialisation of the loop, not one per array flag)
    x, st, it, _, _, _ = ip_loop(u0.copy(), P, tol, constr_tol, mu0, max_iter, 1e300,
                                 lo.copy(), hi.copy(), ug.copy(), wq)  # fmt: skip
    if st == IP_NONFINITE or not np.all(np.isfinite(x)):
        return u0.copy(), IP_NONFINITE, it
    return x, st, it


# =========================================================================================
# Path runs: continuation steps and warm steps in one call (as stackik._compiled.planar.ip_path)
# =========================================================================================
#: As :mod:`stackik._compiled.planar`: Newton iterations and active-set changes of a continuation
#: step, the offset its active limits are held at, and its residual tolerance.
PC_NEWTON = 16
PC_CHANGES = 3
#: ... and it gives up early when Newton's method does not converge: after PC_FREE
#: iterations in one active set, each must shrink the error by PC_CONTRACT.
PC_FREE = 2
PC_CONTRACT = 0.5
PC_OFFSET = 1e-10
PC_PRIMAL_TOL = 1e-13
#: A platform's active limit rows with less than this part of their length outside the
#: span of its other active rows (Gram-Schmidt, the largest remaining part first) depend
#: on those (as :data:`stackik._compiled.planar.PC_DEPENDENT`): where several limits of a platform
#: meet (a leg's base and top joint limits at parallel plates; more limits than the
#: platform's 6 variables) they stay active, out of the Newton system (multiplier 0,
#: their residuals still converged), and take no freedom.
PC_DEPENDENT = 1e-6


@_jit
def polish(u: FloatArray, P: Any, iters: int, reach: float, margin: float) -> FloatArray:
    """:func:`stackik.formulation.polish` compiled: min-norm Newton corrections of the
    end-effector equalities and of the limits violated by less than ``reach`` (scaled),
    put at ``margin``."""
    n = P[8].shape[0]
    N = 6 * n
    for _ in range(iters):
        f, g, cE, AE, cI, D = evaluate(u, P)
        nv = 0
        for r in range(cI.size):
            if -reach < cI[r] < 0.0:
                nv += 1
        if np.abs(cE).max() < 1e-13 and nv == 0:
            break
        A = np.zeros((6 + nv, N))
        rr = np.empty(6 + nv)
        A[:6] = AE
        rr[:6] = cE
        k = 6
        for r in range(cI.size):
            if -reach < cI[r] < 0.0:
                i = r // 24
                A[k, 6 * i : 6 * i + 6] = D[i, r % 24]
                rr[k] = cI[r] - margin
                k += 1
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(rr))):
            break
        u = u - np.linalg.lstsq(A, rr)[0]
    return u


@_jit
def _twins(act: FloatArray, cI: FloatArray, D: FloatArray) -> FloatArray:
    """As :func:`stackik._compiled.planar._twins` (6 variables per platform)."""
    m = cI.size
    parent = np.full(m, -1)
    for r in range(m):
        if not act[r]:
            continue
        i = r // 24
        for r2 in range(24 * i, r):
            same = act[r2] and parent[r2] < 0 and abs(cI[r2] - cI[r]) <= 1e-12
            for k in range(6):
                dk = D[i, r % 24, k]
                same = same and abs(D[i, r2 % 24, k] - dk) <= 1e-9 * (1.0 + abs(dk))
            if same:
                parent[r] = r2
                break
    return parent


@_jit
def _release(act: FloatArray, zf: FloatArray, parent: FloatArray, rj: int) -> None:
    act[rj] = False
    zf[rj] = 0.0
    for r in range(act.size):
        if parent[r] == rj:
            act[r] = False


@_jit
def _dependent(D: FloatArray, idx: FloatArray) -> FloatArray:
    """Mask of the rows ``idx`` (sorted active limit rows) that depend on the others of
    their platform: per platform, Gram-Schmidt on its rows ``D[i, r % 24]`` taking the row
    with the largest remaining part first; rows left with less than PC_DEPENDENT of their
    length are dependent (at most 6 rows a platform are independent)."""
    k = idx.size
    dep = np.ones(k, dtype=np.bool_)
    Q = np.zeros((6, 6))
    v = np.empty(6)
    j0 = 0
    while j0 < k:
        i = idx[j0] // 24
        j1 = j0
        while j1 < k and idx[j1] // 24 == i:
            j1 += 1
        rank = 0
        while rank < 6:
            best = -1
            bn = 0.0
            for j in range(j0, j1):
                if not dep[j]:
                    continue
                a = D[i, idx[j] % 24]
                v[:] = a
                for s in range(rank):
                    v -= (a @ Q[s]) * Q[s]
                nv = math.sqrt(v @ v)
                if nv > PC_DEPENDENT * math.sqrt(a @ a) and nv > bn:
                    best = j
                    bn = nv
            if best < 0:
                break
            v[:] = D[i, idx[best] % 24]
            for _ in range(2):  # Gram-Schmidt twice: orthogonal to rounding
                for s in range(rank):
                    v -= (v @ Q[s]) * Q[s]
            Q[rank] = v / math.sqrt(v @ v)
            dep[best] = False
            rank += 1
        j0 = j1
    return dep


@_jit
def _weakest(idx: FloatArray, dep: FloatArray, zf: FloatArray, new: FloatArray) -> int:
    """The independent row of ``idx`` (not ``dep``) with the least multiplier, among
    those not ``new`` when there are any (a limit just added because the point violates
    it stays; the set makes room with an older one)."""
    rj = -1
    for rank in range(2):
        for j in range(idx.size):
            r = idx[j]
            if dep[j] or (rank == 0 and new[r]):
                continue
            if rj < 0 or zf[r] < zf[rj]:
                rj = r
        if rj >= 0:
            break
    return rj


@_jit
def _pc_step(x0: FloatArray, P0: Any, yE0: FloatArray, z0: FloatArray, active: FloatArray,
             tol: float, constr_tol: float, max_newton: int,
             max_changes: int) -> tuple[Any, ...]:  # fmt: skip
    """The continuation step of :func:`stackik._compiled.planar._pc_step` for the spatial problem
    (6 equalities, 6 variables per platform): Newton on the KKT conditions with the
    active limits held at ``PC_OFFSET``, the first iteration the tangent predictor, the
    active set corrected (most negative multiplier released, else violated or nearly met
    limits added), and verified as a KKT point to the barrier solve's tolerances. Active
    rows that depend on others of their platform (:func:`_dependent`: where more limits
    meet than the platform has variables, e.g. a leg's base and top joint limits at
    parallel plates) stay active with multiplier 0, out of the Newton system (which is
    singular with them) and take no freedom; while the independent rows exceed the
    freedom ``N - 6`` the weakest goes, not one the last change added
    (:func:`_weakest`). Returns ``(x, ok, yE, z, active, iterations)``."""
    n = P0[8].shape[0]
    N = 6 * n
    m = 24 * n
    f, g, cE, AE, cI, D = evaluate(x0, P0)
    gmax = np.abs(g).max()
    fs = OBJ_MAX_GRAD / gmax if gmax > OBJ_MAX_GRAD else 1.0
    P = _with_fscale(P0, P0[5] / fs)
    g = g * fs
    x = x0.copy()
    yE = yE0 * fs
    zf = z0 * fs
    act = active.copy()
    new = np.zeros(m, dtype=np.bool_)  # the limits the last change added
    ok = False
    it = 0
    changes = 0
    while True:
        parent = _twins(act, cI, D)
        for r in range(m):
            if act[r] and parent[r] >= 0:
                zf[parent[r]] += zf[r]
                zf[r] = 0.0
            elif not act[r]:
                zf[r] = 0.0
        # rows that depend on others of their platform stay active, out of the Newton
        # system; the independent ones beyond the freedom N - 6 (degenerate): the weakest go
        allidx = np.nonzero(act & (parent < 0))[0]
        dep = _dependent(D, allidx)
        while 6 + allidx.size - dep.sum() > N:
            _release(act, zf, parent, _weakest(allidx, dep, zf, new))
            allidx = np.nonzero(act & (parent < 0))[0]
            dep = _dependent(D, allidx)
        for j in range(allidx.size):
            if dep[j]:
                zf[allidx[j]] = 0.0
        idx = allidx[~dep]
        na = idx.size
        zA = np.empty(na)
        for j in range(na):
            zA[j] = zf[idx[j]]
        K = np.zeros((N + 6 + na, N + 6 + na))
        rhs = np.empty(N + 6 + na)
        conv = False
        inner = 0  # Newton iterations in this active set
        err_prev = math.inf
        while True:
            if not (np.all(np.isfinite(g)) and np.all(np.isfinite(cE))
                    and np.all(np.isfinite(cI))):  # fmt: skip
                break
            for j in range(na):
                zf[idx[j]] = zA[j]
            rd = g - AE.T @ yE - _AIT_dot(D, zf)
            sd_acc = np.abs(yE).sum()
            for j in range(na):
                sd_acc += abs(zA[j])
            sd = max(100.0, sd_acc / (m + 6)) / 100.0
            e_du = np.abs(rd).max() / sd
            e_pr = np.abs(cE).max()
            comp = 0.0
            for j in range(allidx.size):  # the dependent rows' residuals too
                e_pr = max(e_pr, abs(cI[allidx[j]] - PC_OFFSET))
            for j in range(na):
                comp = max(comp, abs(cI[idx[j]] * zA[j]))
            ptol = min(constr_tol, PC_PRIMAL_TOL)
            if e_du <= tol and comp / sd <= tol and e_pr <= ptol:
                conv = True
                break
            if it >= max_newton:
                break
            # as the planar step: an iteration that does not at least halve the error (in
            # units of the tolerances) after the first two of this active set does not
            # converge, and the barrier solve takes the step at once
            err = max(e_du / tol, max(comp / sd / tol, e_pr / ptol))
            if inner >= PC_FREE and not err <= PC_CONTRACT * err_prev:
                break
            err_prev = err
            inner += 1
            it += 1
            W = lagrangian_hessian(x, yE, zf, P)
            K[:] = 0.0
            K[:N, :N] = W
            for a in range(N):
                for r in range(6):
                    K[a, N + r] = -AE[r, a]
                    K[N + r, a] = AE[r, a]
                rhs[a] = -rd[a]
            for r in range(6):
                rhs[N + r] = -cE[r]
            for j in range(na):
                i = idx[j] // 24
                for k in range(6):
                    K[6 * i + k, N + 6 + j] = -D[i, idx[j] % 24, k]
                    K[N + 6 + j, 6 * i + k] = D[i, idx[j] % 24, k]
                rhs[N + 6 + j] = PC_OFFSET - cI[idx[j]]
            if not np.all(np.isfinite(K)):
                break
            try:
                sol = np.linalg.solve(K, rhs)
            except Exception:  # noqa: BLE001 - singular KKT matrix: the barrier solve decides
                break
            if not np.all(np.isfinite(sol)):
                break
            x = x + sol[:N]
            for r in range(6):
                yE[r] += sol[N + r]
            for j in range(na):
                zA[j] += sol[N + 6 + j]
            f, g, cE, AE, cI, D = evaluate(x, P)
        if not conv:
            break
        jmin = -1
        for j in range(na):
            if zA[j] < 0.0 and (jmin < 0 or zA[j] < zA[jmin]):
                jmin = j
        nadd = 0
        for r in range(m):
            if not act[r] and not cI[r] >= 0.5 * PC_OFFSET:
                nadd += 1
        if jmin < 0 and nadd == 0:
            ok = True
            break
        if changes >= max_changes:
            break
        changes += 1
        new[:] = False
        if jmin >= 0:
            _release(act, zf, parent, idx[jmin])
        else:
            for r in range(m):
                if not act[r] and not cI[r] >= 0.5 * PC_OFFSET:
                    act[r] = True
                    new[r] = True
    return x, ok, yE / fs, zf / fs, act, it


@_jit
def _reaches(xn: FloatArray, x: FloatArray, P: Any, jump: FloatArray, pos_tol: float,
             ang_tol: float) -> bool:  # fmt: skip
    """Whether the polished point ``xn`` reaches ``P``'s target (``pos_tol`` [mm]; the
    orientation error's sine from the scaled equalities within ``ang_tol``), violates no
    limit (scaled) and moves no variable from ``x`` by more than ``jump`` (scaled)."""
    es = P[2]
    f, g, cE, AE, cI, D = evaluate(xn, P)
    pe = math.sqrt((cE[0] / es[0]) ** 2 + (cE[1] / es[1]) ** 2 + (cE[2] / es[2]) ** 2)
    ae = math.sqrt((cE[3] / es[3]) ** 2 + (cE[4] / es[4]) ** 2 + (cE[5] / es[5]) ** 2)
    if not (pe <= pos_tol and ae <= ang_tol and cI.min() >= -1e-12):
        return False
    for a in range(x.size):
        if not abs(xn[a] - x[a]) <= jump[a]:
            return False
    return True


@_jit
def ip_path(u0: FloatArray, pos: FloatArray, rot: FloatArray, P0: Any, jump: FloatArray,
            tol: float, constr_tol: float, mu0: float, max_iter: int, reach: float,
            margin: float, pos_tol: float, ang_tol: float, pc: bool, yE0: FloatArray,
            z0: FloatArray, act0: FloatArray, have0: bool) -> tuple[Any, ...]:  # fmt: skip
    """:func:`stackik._compiled.planar.ip_path` for spatial targets (positions ``pos`` (m, 3) [mm],
    rotations ``rot`` (m, 3, 3)): each step from the previous point, the continuation
    step first (``pc``) and the barrier solve (initial barrier ``mu0``) when it is not
    verified, then :func:`polish`; stops before the first step whose point misses its
    target, violates a limit or jumps (:func:`_reaches`). The first step carries the
    state ``yE0, z0, act0`` of ``u0`` when ``have0``. Returns the points (m, N), the
    number of steps taken, per step 1 (continuation step) or 0 (barrier solve), and the
    state of the last point reached (``yE, z, active, have``); the caller re-checks
    every point with the independent check."""
    m = pos.shape[0]
    N = u0.size
    X = np.empty((m, N))
    how = np.zeros(m, dtype=np.int64)
    none = np.empty(0)
    x = u0.copy()
    have = have0  # the state of u0 (multipliers, active set) when it is a solved point
    yE = yE0.copy()
    z = z0.copy()
    active = act0.copy()
    for k in range(m):
        P = (P0[0], P0[1], P0[2], pos[k], rot[k], P0[5], P0[6], P0[7], P0[8], P0[9], P0[10],
             P0[11], P0[12], P0[13])  # fmt: skip
        if pc and have:
            xn, ok, yE1, z1, act1, _ = _pc_step(
                x, P, yE, z, active, tol, constr_tol, PC_NEWTON, PC_CHANGES
            )
            if ok:
                xn = polish(xn, P, 3, reach, margin)
                if _reaches(xn, x, P, jump, pos_tol, ang_tol):
                    X[k] = xn
                    how[k] = 1
                    x, yE, z, active = xn, yE1, z1, act1
                    continue
        xn, st, _, s1, z1, yE1 = ip_loop(x, P, tol, constr_tol, mu0, max_iter, 1e300, none,
                                         none, none, 0.0)  # fmt: skip
        if st == IP_NONFINITE or not np.all(np.isfinite(xn)):
            return X, k, how, yE, z, active, have
        xn = polish(xn, P, 3, reach, margin)
        if not _reaches(xn, x, P, jump, pos_tol, ang_tol):
            return X, k, how, yE, z, active, have
        X[k] = xn
        x, yE, z = xn, yE1, z1
        active = z1 > s1
        have = st == IP_SUCCESS
    return X, m, how, yE, z, active, have
