"""Compiled primal-dual interior-point solver for the planar IK problem (the fast path).

The planar problem of :class:`stackik.formulation.Problem` (scaled variables ``u = q / xs``):

    min f(u) = (c0 + w |r(u)|^2) / fscale
    s.t. c_E(u) = 0   (3 end-effector equalities, scaled by ``es``)
         c_I(u) >= 0  (24 n limits, scaled by ``cs``)

is solved by a primal-dual barrier method in the spirit of IPOPT (Waechter & Biegler 2006;
Nocedal & Wright 2006, ch. 19): slacks ``s > 0`` with ``c_I(u) - s = 0``, barrier
parameter ``mu`` decreased Fiacco-McCormick style, Newton steps on the perturbed KKT
conditions with the exact Hessian of the Lagrangian, a null-space solve of the KKT system
whose reduced Hessian is made positive definite by eigenvalue modification, the
fraction-to-the-boundary rule, and a backtracking line search on the l1 merit function
``f - mu sum log s + nu (|c_E|_1 + |c_I - s|_1)``. The interior path is what makes the
method find good local minima from few starts: it keeps away from the limits until the
objective has shaped the pose, where an active-set SQP commits early to the limits it
meets first.

Everything that runs per iteration is compiled with numba (``cache=True``: compiled once
per machine, then loaded from ``__pycache__``). The caller re-checks every returned pose
(:func:`stackik.check.check_pose`); this module makes no claim of its own.
"""

from __future__ import annotations

import math
import time
import warnings
from typing import Any

import numpy as np
from numba import njit, objmode

FloatArray = np.ndarray

#: Compiled once per machine and cached; floating-point errors give inf/nan (numpy's
#: model) rather than exceptions, and the loop treats non-finite values as failures.
#: nogil: solves in threads (``solve_many(executor=ThreadPoolExecutor(...))``) run in
#: parallel; only the occasional clock read (:func:`_now`, object mode) takes the GIL,
#: which numba warns about at compile time.
_jit = njit(cache=True, error_model="numpy", nogil=True)
warnings.filterwarnings(
    "ignore", message="Code running in object mode won't allow parallel execution"
)

#: :func:`_ip_multi` stops when its first GIVE_UP_AFTER starts all end farther than
#: GIVE_UP_VIOLATION (scaled) from feasibility: an unreachable target is then reported by
#: the SQP fallback in a fraction of the time the remaining starts would take.
GIVE_UP_AFTER = 3
GIVE_UP_VIOLATION = 1e-4
#: The objective is scaled so that its gradient at the start is at most this (IPOPT's
#: nlp_scaling_max_gradient).
OBJ_MAX_GRAD = 100.0

#: Status codes returned by :func:`ip_solve`.
IP_SUCCESS, IP_MAX_ITER, IP_STALLED, IP_NONFINITE, IP_MAX_TIME, IP_SKIPPED = 0, 1, 2, 3, 4, 5
IP_STATUS = {
    IP_SKIPPED: "skipped",
    IP_SUCCESS: "success",
    IP_MAX_ITER: "max_iter",
    IP_STALLED: "stalled",
    IP_NONFINITE: "nonfinite",
    IP_MAX_TIME: "max_time",
}


@_jit
def _finite(a: FloatArray) -> bool:
    """``np.all(np.isfinite(a))`` without the boolean temporary (a kernel's hot loops
    test a few arrays every iteration)."""
    for v in a.flat:
        if not math.isfinite(v):
            return False
    return True


# =========================================================================================
# Evaluation (raw kinematics, then scaled)
# =========================================================================================
@_jit
def _kinematics(q: FloatArray) -> tuple[Any, ...]:
    """Cumulative cos/sin, end effector y, its Jacobian (3, 3n), lever arms d (n, 2)."""
    n = q.shape[0]
    c = np.empty(n)
    s = np.empty(n)
    O = np.zeros((n + 1, 2))
    th = 0.0
    for i in range(n):
        c[i] = math.cos(th)
        s[i] = math.sin(th)
        O[i + 1, 0] = O[i, 0] + c[i] * q[i, 0] - s[i] * q[i, 1]
        O[i + 1, 1] = O[i, 1] + s[i] * q[i, 0] + c[i] * q[i, 1]
        th += q[i, 2]
    d = np.empty((n, 2))
    for i in range(n):
        d[i, 0] = O[n, 0] - O[i + 1, 0]
        d[i, 1] = O[n, 1] - O[i + 1, 1]
    y = np.array([O[n, 0], O[n, 1], th])
    J = np.zeros((3, 3 * n))
    for i in range(n):
        J[0, 3 * i] = c[i]
        J[1, 3 * i] = s[i]
        J[0, 3 * i + 1] = -s[i]
        J[1, 3 * i + 1] = c[i]
        J[0, 3 * i + 2] = -d[i, 1]
        J[1, 3 * i + 2] = d[i, 0]
        J[2, 3 * i + 2] = 1.0
    return c, s, y, J, d


@_jit
def _gauss_newton(c: FloatArray, s: FloatArray, d: FloatArray) -> FloatArray:
    """``Jr^T Jr`` of the FN residuals ``r_i = d_i`` (i < n-1) in O(n^2), shape (3n, 3n).

    With ``u_m0 = (c_m, s_m)``, ``u_m1 = (-s_m, c_m)`` (the translation columns, present in
    the rows i < m), the angle columns ``J2 d_max(i,m)`` and prefix sums ``P_k`` of the
    lever arms d and ``Q_k`` of their squared norms (``d_(n-1) = 0``):
    trans.trans = min(m, l) u.u'; trans_m.angle_l = u . J2 (min(m, l+1) d_l + P_m - P_(l+1));
    angle.angle = (a+1) d_m.d_l + d_b.(P_(b+1) - P_(a+1)) + Q_n - Q_(b+1), a/b = min/max.
    """
    n = c.shape[0]
    N = 3 * n
    P = np.zeros((n + 1, 2))
    Q = np.zeros(n + 1)
    for i in range(n):
        P[i + 1, 0] = P[i, 0] + d[i, 0]
        P[i + 1, 1] = P[i, 1] + d[i, 1]
        Q[i + 1] = Q[i] + d[i, 0] * d[i, 0] + d[i, 1] * d[i, 1]
    H = np.empty((N, N))
    for m in range(n):
        um = ((c[m], s[m]), (-s[m], c[m]))
        for l in range(n):
            ul = ((c[l], s[l]), (-s[l], c[l]))
            k = min(m, l)
            for t in range(2):
                for t2 in range(2):
                    H[3 * m + t, 3 * l + t2] = k * (um[t][0] * ul[t2][0] + um[t][1] * ul[t2][1])
            # translation of m against the angle of l
            k2 = min(m, l + 1)
            Sx = k2 * d[l, 0]
            Sy = k2 * d[l, 1]
            if m > l + 1:
                Sx += P[m, 0] - P[l + 1, 0]
                Sy += P[m, 1] - P[l + 1, 1]
            for t in range(2):
                val = um[t][0] * (-Sy) + um[t][1] * Sx  # u . J2 S, J2 S = (-S_y, S_x)
                H[3 * m + t, 3 * l + 2] = val
                H[3 * l + 2, 3 * m + t] = val
            a = min(m, l)
            b = max(m, l)
            val = (a + 1) * (d[m, 0] * d[l, 0] + d[m, 1] * d[l, 1])
            val += d[b, 0] * (P[b + 1, 0] - P[a + 1, 0]) + d[b, 1] * (P[b + 1, 1] - P[a + 1, 1])
            val += Q[n] - Q[b + 1]
            H[3 * m + 2, 3 * l + 2] = val
    return H


@_jit
def _fn2_hessian(c: FloatArray, s: FloatArray, d: FloatArray) -> FloatArray:
    """Exact Hessian of ``sum_i |d_i|^2`` (i < n-1) in raw q, shape (3n, 3n)."""
    n = c.shape[0]
    H = 2.0 * _gauss_newton(c, s, d)
    # angle-angle part: -sum_{i<n-1} r_i . d_max(i, m, l) depends on b = max(m, l) only:
    # sum_{i<b} d_i . d_b + sum_{b<=i<n-1} |d_i|^2 (O(n^2) with prefix sums)
    Pb0 = 0.0
    Pb1 = 0.0
    tail = np.zeros(n + 1)
    for i in range(n - 2, -1, -1):
        tail[i] = tail[i + 1] + d[i, 0] * d[i, 0] + d[i, 1] * d[i, 1]
    Hb = np.empty(n)
    for b in range(n):
        Hb[b] = Pb0 * d[b, 0] + Pb1 * d[b, 1] + tail[b]
        Pb0 += d[b, 0]
        Pb1 += d[b, 1]
    for m in range(n):
        for l in range(n):
            H[3 * m + 2, 3 * l + 2] -= 2.0 * Hb[max(m, l)]
    c0 = 0.0
    c1 = 0.0  # sum_{i<k} r_i
    for k in range(n):
        t0 = -s[k] * c0 + c[k] * c1
        t1 = -c[k] * c0 - s[k] * c1
        for m in range(k):
            H[3 * k, 3 * m + 2] += 2.0 * t0
            H[3 * k + 1, 3 * m + 2] += 2.0 * t1
            H[3 * m + 2, 3 * k] += 2.0 * t0
            H[3 * m + 2, 3 * k + 1] += 2.0 * t1
        if k < n - 1:
            c0 += d[k, 0]
            c1 += d[k, 1]
    return H


@_jit
def _leg(q: FloatArray, i: int, j: int, c: float, sn: float, tf: FloatArray, tz: FloatArray,
         bf: FloatArray, bz: FloatArray, ls: FloatArray) -> tuple[float, ...]:  # fmt: skip
    """Leg ``j`` of platform ``i`` (``c``, ``sn``: cos and sin of its angle): the top
    joint ``R t`` and the leg ``l`` in the plane, and ``|l|^2`` (scalars: no arrays to
    allocate, ~2 us of a continuation step's ~7 us Newton iteration at n = 4 went to
    allocations)."""
    Rtf = c * tf[i, j] - sn * tz[i, j]
    Rtz = sn * tf[i, j] + c * tz[i, j]
    lf = Rtf + q[i, 0] - bf[i, j]
    lz = Rtz + q[i, 1] - bz[i, j]
    sq = lf**2 + ls[i, j] ** 2 + lz**2
    return Rtf, Rtz, lf, lz, sq


@_jit
def _constraints(q: FloatArray, tf: FloatArray, tz: FloatArray, bf: FloatArray, bz: FloatArray,
                 ls: FloatArray, lmin2: FloatArray, lmax2: FloatArray,
                 sj: FloatArray) -> tuple[FloatArray, FloatArray]:  # fmt: skip
    """Raw limits (n*24,) and their Jacobian blocks (n, 24, 3), DESIGN §2 order."""
    n = q.shape[0]
    g = np.empty(24 * n)
    D = np.empty((n, 24, 3))
    for i in range(n):
        c = math.cos(q[i, 2])
        sn = math.sin(q[i, 2])
        for j in range(6):
            Rtf, Rtz, lf, lz, sq = _leg(q, i, j, c, sn, tf, tz, bf, bz, ls)
            nrm = math.sqrt(sq)
            k = sj[i] / nrm
            g[24 * i + j] = sq - lmin2[i]
            g[24 * i + 6 + j] = lmax2[i] - sq
            g[24 * i + 12 + j] = lz - nrm * sj[i]
            g[24 * i + 18 + j] = c * lz - sn * lf - nrm * sj[i]
            dsq_t = 2.0 * (lz * Rtf - lf * Rtz)
            D[i, j, 0] = 2.0 * lf
            D[i, j, 1] = 2.0 * lz
            D[i, j, 2] = dsq_t
            D[i, 6 + j, 0] = -2.0 * lf
            D[i, 6 + j, 1] = -2.0 * lz
            D[i, 6 + j, 2] = -dsq_t
            D[i, 12 + j, 0] = -k * lf
            D[i, 12 + j, 1] = 1.0 - k * lz
            D[i, 12 + j, 2] = Rtf - 0.5 * k * dsq_t
            D[i, 18 + j, 0] = -sn - k * lf
            D[i, 18 + j, 1] = c - k * lz
            D[i, 18 + j, 2] = (sn * Rtz + c * Rtf) - (c * lf + sn * lz) - 0.5 * k * dsq_t
    return g, D


@_jit
def _constraint_hessian(q: FloatArray, yraw: FloatArray, tf: FloatArray, tz: FloatArray,
                        bf: FloatArray, bz: FloatArray, ls: FloatArray,
                        sj: FloatArray) -> FloatArray:  # fmt: skip
    """``sum_r yraw_r Hessian(c_r)`` per platform, shape (n, 3, 3) (block diagonal).
    Legs whose four multipliers are zero are skipped: they add exact zeros wherever the
    leg's terms are finite (a leg of non-zero length at a finite pose)."""
    n = q.shape[0]
    H = np.zeros((n, 3, 3))
    for i in range(n):
        c = math.cos(q[i, 2])
        sn = math.sin(q[i, 2])
        h00 = h11 = h01 = h02 = h12 = h22 = 0.0
        for j in range(6):
            y0 = yraw[24 * i + j]
            y1 = yraw[24 * i + 6 + j]
            y2 = yraw[24 * i + 12 + j]
            y3 = yraw[24 * i + 18 + j]
            if y0 == 0.0 and y1 == 0.0 and y2 == 0.0 and y3 == 0.0:
                continue  # adds exact zeros (a continuation step: limits off its active set)
            Rtf, Rtz, lf, lz, sq = _leg(q, i, j, c, sn, tf, tz, bf, bz, ls)
            nrm = math.sqrt(sq)
            inv = 1.0 / nrm
            S_rt = -2.0 * Rtz
            S_zt = 2.0 * Rtf
            S_tt = 2.0 * (Rtf**2 + Rtz**2 - lf * Rtf - lz * Rtz)
            d_r = lf * inv
            d_z = lz * inv
            d_t = (lz * Rtf - lf * Rtz) * inv
            N_rr = (1.0 - d_r * d_r) * inv
            N_zz = (1.0 - d_z * d_z) * inv
            N_rz = -d_r * d_z * inv
            N_rt = (0.5 * S_rt - d_r * d_t) * inv
            N_zt = (0.5 * S_zt - d_z * d_t) * inv
            N_tt = (0.5 * S_tt - d_t * d_t) * inv
            ys = y0 - y1
            yn = -sj[i] * (y2 + y3)
            rf = lf - Rtf
            rz = lz - Rtz
            h00 += ys * 2.0 + yn * N_rr
            h11 += ys * 2.0 + yn * N_zz
            h01 += yn * N_rz
            h02 += ys * S_rt + yn * N_rt - y3 * c
            h12 += ys * S_zt + yn * N_zt - y3 * sn
            h22 += ys * S_tt + yn * N_tt - y2 * Rtz + y3 * (rf * sn - rz * c)
        H[i, 0, 0] = h00
        H[i, 1, 1] = h11
        H[i, 2, 2] = h22
        H[i, 0, 1] = H[i, 1, 0] = h01
        H[i, 0, 2] = H[i, 2, 0] = h02
        H[i, 1, 2] = H[i, 2, 1] = h12
    return H


@_jit
def _evaluate(u: FloatArray, P: Any) -> tuple[Any, ...]:
    """Scaled f, grad f, c_E, A_E (3, N), c_I (m,), A_I blocks (n, 24, 3) at ``u``."""
    (xs, cs, es, yt, fscale, c0, w, tf, tz, bf, bz, ls, lmin2, lmax2, sj, feasible) = P
    n = tf.shape[0]
    q = (u * xs).reshape(n, 3)
    c, s, y, J, d = _kinematics(q)
    # elementwise in loops (numba's broadcasting allocates temporaries: ~1 us at n = 4)
    cE = np.empty(3)
    AE = np.empty((3, 3 * n))
    for r in range(3):
        cE[r] = (y[r] - yt[r]) * es[r]
        for a in range(3 * n):
            AE[r, a] = J[r, a] * es[r] * xs[a]
    cI, D = _constraints(q, tf, tz, bf, bz, ls, lmin2, lmax2, sj)
    for r in range(24 * n):
        cI[r] *= cs[r]
    for i in range(n):
        for r in range(24):
            for k in range(3):
                D[i, r, k] *= cs[24 * i + r] * xs[3 * i + k]
    if feasible:
        return 0.0, np.zeros(3 * n), cE, AE, cI, D
    # f = (c0 + w sum_{i<n-1} |d_i|^2) / fscale; its gradient by prefix sums of d (O(n)):
    # d/d(rho_m, z_m) = R(Theta_m) e . sum_{i<m} d_i, d/dtheta_m = (sum_{i<=m} d_i) . J2 d_m
    k = 2.0 * w / fscale
    grad = np.empty(3 * n)
    acc = 0.0
    p0 = 0.0
    p1 = 0.0
    for m_ in range(n):
        grad[3 * m_] = k * (c[m_] * p0 + s[m_] * p1) * xs[3 * m_]
        grad[3 * m_ + 1] = k * (-s[m_] * p0 + c[m_] * p1) * xs[3 * m_ + 1]
        if m_ < n - 1:
            p0 += d[m_, 0]
            p1 += d[m_, 1]
            acc += d[m_, 0] * d[m_, 0] + d[m_, 1] * d[m_, 1]
        grad[3 * m_ + 2] = k * (d[m_, 0] * p1 - d[m_, 1] * p0) * xs[3 * m_ + 2]
    f = (c0 + w * acc) / fscale
    return f, grad, cE, AE, cI, D


@_jit
def _evaluate_ext(u: FloatArray, P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray,
                  wq: float) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_evaluate` with the extensions of a path step: the objective plus
    ``wq |u - ug|^2`` (when ``wq > 0``), and, when ``lo`` is not empty, the box
    ``lo <= u <= hi`` as 6 more limit rows per platform (rows 24-26: ``u - lo``, rows
    27-29: ``hi - u``), so that ``c_I`` has ``30 n`` rows and ``D`` is (n, 30, 3). Without
    extensions it returns :func:`_evaluate`'s values unchanged."""
    f, g, cE, AE, cI, D = _evaluate(u, P)
    if wq > 0.0:
        acc = 0.0
        for a in range(u.size):
            d = u[a] - ug[a]
            acc += d * d
            g[a] += 2.0 * wq * d
        f += wq * acc
    if lo.size == 0:
        return f, g, cE, AE, cI, D
    n = D.shape[0]
    cB = np.empty(30 * n)
    DB = np.zeros((n, 30, 3))
    for i in range(n):
        for r in range(24):
            cB[30 * i + r] = cI[24 * i + r]
            for k in range(3):
                DB[i, r, k] = D[i, r, k]
        for k in range(3):
            cB[30 * i + 24 + k] = u[3 * i + k] - lo[3 * i + k]
            cB[30 * i + 27 + k] = hi[3 * i + k] - u[3 * i + k]
            DB[i, 24 + k, k] = 1.0
            DB[i, 27 + k, k] = -1.0
    return f, g, cE, AE, cB, DB


@_jit
def _limit_rows(z: FloatArray, n: int) -> FloatArray:
    """The multipliers of the 24 n limit rows among the 30 n rows of a boxed problem
    (``z`` itself without a box): the box is linear, so only these enter the Hessian."""
    if z.size == 24 * n:
        return z
    out = np.empty(24 * n)
    for i in range(n):
        for r in range(24):
            out[24 * i + r] = z[30 * i + r]
    return out


@_jit
def _lagrangian_hessian_ext(u: FloatArray, yE: FloatArray, z: FloatArray, P: Any,
                            wq: float) -> FloatArray:  # fmt: skip
    """Hessian of the Lagrangian of :func:`_evaluate_ext`'s problem (``z``: 24 n or, with
    a box, 30 n multipliers): the box rows are linear, the distance term adds ``2 wq I``."""
    H = _lagrangian_hessian(u, yE, _limit_rows(z, P[7].shape[0]), P)
    if wq > 0.0:
        for a in range(H.shape[0]):
            H[a, a] += 2.0 * wq
    return H


@_jit
def _lagrangian_hessian(u: FloatArray, yE: FloatArray, z: FloatArray, P: Any) -> FloatArray:
    """Hessian of ``f - yE.c_E - z.c_I`` in scaled variables, shape (N, N)."""
    (xs, cs, es, yt, fscale, c0, w, tf, tz, bf, bz, ls, lmin2, lmax2, sj, feasible) = P
    n = tf.shape[0]
    N = 3 * n
    q = (u * xs).reshape(n, 3)
    c, s, y, J, d = _kinematics(q)
    if feasible:
        H = np.zeros((N, N))
    else:
        H = _fn2_hessian(c, s, d) * (w / fscale)
    # end-effector equalities: sum_r yE_r d2 y_r = [min(a,b) is an angle] * v[max(a,b)]
    yp0 = yE[0] * es[0]
    yp1 = yE[1] * es[1]
    v = yp1 * J[0] - yp0 * J[1]
    for a in range(2, N, 3):  # angle columns a: every (a, b) with b >= a
        H[a, a] -= v[a]
        for b in range(a + 1, N):
            H[a, b] -= v[b]
            H[b, a] -= v[b]
    Hb = _constraint_hessian(q, z * cs, tf, tz, bf, bz, ls, sj)
    for i in range(n):
        for a in range(3):
            for b in range(3):
                H[3 * i + a, 3 * i + b] -= Hb[i, a, b]
    for a in range(N):
        for b in range(N):
            H[a, b] *= xs[a] * xs[b]
    return H


@_jit
def _AI_dot(D: FloatArray, dx: FloatArray) -> FloatArray:
    """``A_I dx`` (R n,) from the block-diagonal limit Jacobian's blocks ``D`` (n, R, 3)
    (R = 24 limit rows per platform, 30 with a box)."""
    n, R = D.shape[0], D.shape[1]
    out = np.empty(R * n)
    for i in range(n):
        for r in range(R):
            out[R * i + r] = (
                D[i, r, 0] * dx[3 * i] + D[i, r, 1] * dx[3 * i + 1] + D[i, r, 2] * dx[3 * i + 2]
            )
    return out


@_jit
def _AIT_dot(D: FloatArray, v: FloatArray) -> FloatArray:
    """``A_I^T v`` (3n,) from the blocks ``D`` (n, R, 3) of the limit Jacobian."""
    n, R = D.shape[0], D.shape[1]
    out = np.zeros(3 * n)
    for i in range(n):
        for r in range(R):
            vr = v[R * i + r]
            for k in range(3):
                out[3 * i + k] += D[i, r, k] * vr
    return out


@_jit
def _inv3(A: FloatArray) -> FloatArray:
    """Inverse of a 3x3 matrix by its adjugate (no LAPACK call for so small a matrix)."""
    out = np.empty((3, 3))
    out[0, 0] = A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]
    out[0, 1] = A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]
    out[0, 2] = A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]
    out[1, 0] = A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]
    out[1, 1] = A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]
    out[1, 2] = A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]
    out[2, 0] = A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]
    out[2, 1] = A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]
    out[2, 2] = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    det = A[0, 0] * out[0, 0] + A[0, 1] * out[1, 0] + A[0, 2] * out[2, 0]
    return out / det


@_jit
def _cholesky(A: FloatArray, shift: float) -> tuple[FloatArray, bool]:
    """Lower Cholesky factor of ``A + shift I``; ``ok`` False when not positive definite."""
    k = A.shape[0]
    if k >= 24:  # LAPACK pays off beyond small sizes
        B = A.copy()
        for i in range(k):
            B[i, i] += shift
        try:
            L = np.linalg.cholesky(B)
        except Exception:  # noqa: BLE001 - numba raises LinAlgError when not PD
            return B, False
        for i in range(k):
            if not L[i, i] > 1e-7 * math.sqrt(abs(B[i, i]) + 1e-300):
                return L, False
        return L, True
    L = np.zeros((k, k))
    dmax = 0.0
    for i in range(k):
        dmax = max(dmax, abs(A[i, i]) + shift)
    for j in range(k):
        acc = A[j, j] + shift
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
def _kkt_step(W: FloatArray, AE: FloatArray, cE: FloatArray, rhs: FloatArray,
              last_shift: float) -> tuple[FloatArray, FloatArray, float, float]:  # fmt: skip
    """Solve ``[W -AE^T; AE 0] [dx; dy] = [rhs; -cE]`` by a null-space method.

    The null-space basis ``Z = [-B^-1 C; I]`` uses the first platform's three columns
    ``B`` of ``AE = [B C]`` (always invertible: a rotation and a unit angle row). When the
    reduced Hessian ``Z^T W Z`` is not positive definite, a multiple of the identity is
    added until it is (the shift), so that ``dx`` is a descent direction of the merit
    function. Returns ``dx``, ``dy``, the curvature ``dx^T W dx`` and the shift used.
    """
    N = W.shape[0]
    K = N - 3
    Binv = _inv3(AE[:, :3])
    # E = -B^-1 C (3, K): dependent part of Z; dxp = -B^-1 cE. Explicit loops: the inner
    # dimension is 3, where BLAS calls cost more than the arithmetic.
    E = np.empty((3, K))
    dxp = np.empty(3)
    for i in range(3):
        dxp[i] = -(Binv[i, 0] * cE[0] + Binv[i, 1] * cE[1] + Binv[i, 2] * cE[2])
        for a in range(K):
            E[i, a] = -(Binv[i, 0] * AE[0, 3 + a] + Binv[i, 1] * AE[1, 3 + a]
                        + Binv[i, 2] * AE[2, 3 + a])  # fmt: skip
    # M = W Z (N, K) = W[:, :3] E + W[:, 3:]
    M = np.empty((N, K))
    for i in range(N):
        w0 = W[i, 0]
        w1 = W[i, 1]
        w2 = W[i, 2]
        for a in range(K):
            M[i, a] = w0 * E[0, a] + w1 * E[1, a] + w2 * E[2, a] + W[i, 3 + a]
    # Hz = Z^T W Z = E^T M[:3] + M[3:]
    Hz = np.empty((K, K))
    for a in range(K):
        for b in range(K):
            Hz[a, b] = E[0, a] * M[0, b] + E[1, a] * M[1, b] + E[2, a] * M[2, b] + M[3 + a, b]
    # rz = Z^T (rhs - W[:, :3] dxp)
    res = np.empty(N)
    for i in range(N):
        res[i] = rhs[i] - (W[i, 0] * dxp[0] + W[i, 1] * dxp[1] + W[i, 2] * dxp[2])
    rz = np.empty(K)
    for a in range(K):
        rz[a] = E[0, a] * res[0] + E[1, a] * res[1] + E[2, a] * res[2] + res[3 + a]
    Et = E.T.copy()
    # inertia correction as in IPOPT: the smallest shift (tried in factors of 8, starting
    # from a third of the last one) that makes the reduced Hessian positive definite
    shift = 0.0
    L, ok = _cholesky(Hz, 0.0)
    if not ok:
        scale = 0.0
        for i in range(Hz.shape[0]):
            scale = max(scale, abs(Hz[i, i]))
        ZtZ = Et @ E  # the shift is delta I in x-space: Z^T (W + delta I) Z
        for i in range(ZtZ.shape[0]):
            ZtZ[i, i] += 1.0
        shift = max(last_shift / 3.0, 1e-4) if last_shift > 0.0 else 1e-4
        grow = 8.0 if last_shift > 0.0 else 100.0
        for _ in range(60):  # bounded: NaN entries never factor
            L, ok = _cholesky(Hz + shift * ZtZ, 0.0)
            if ok or not shift <= 1e20 * (1.0 + scale):
                break
            shift *= grow
    if shift > 0.0:  # the particular part sees the shifted Hessian too
        rz -= shift * (Et @ dxp)
    w = _cho_solve(L, rz)
    dx = np.empty(N)
    for i in range(3):
        acc = dxp[i]
        for a in range(K):
            acc += E[i, a] * w[a]
        dx[i] = acc
    dx[3:] = w
    Wdx = np.empty(N)
    curv = 0.0
    for i in range(N):
        acc = shift * dx[i]
        for j in range(N):
            acc += W[i, j] * dx[j]
        Wdx[i] = acc
        curv += dx[i] * acc
    dy = np.empty(3)
    for j in range(3):
        dy[j] = ((Wdx[0] - rhs[0]) * Binv[0, j] + (Wdx[1] - rhs[1]) * Binv[1, j]
                 + (Wdx[2] - rhs[2]) * Binv[2, j])  # fmt: skip
    return dx, dy, curv, shift


@_jit
def _AET_dot(AE: FloatArray, y: FloatArray) -> FloatArray:
    """``AE^T y`` for the (3, N) equality Jacobian."""
    N = AE.shape[1]
    out = np.empty(N)
    for a in range(N):
        out[a] = AE[0, a] * y[0] + AE[1, a] * y[1] + AE[2, a] * y[2]
    return out


@_jit
def _ls_multipliers(AE: FloatArray, g: FloatArray, AItz: FloatArray) -> FloatArray:
    """Least-squares equality multipliers: ``argmin |g - AI^T z - AE^T y|``."""
    N = AE.shape[1]
    G = np.zeros((3, 3))
    b = np.zeros(3)
    for i in range(3):
        for a in range(N):
            b[i] += AE[i, a] * (g[a] - AItz[a])
        for j in range(3):
            acc = 0.0
            for a in range(N):
                acc += AE[i, a] * AE[j, a]
            G[i, j] = acc
    Gi = _inv3(G)
    y = np.empty(3)
    for i in range(3):
        y[i] = Gi[i, 0] * b[0] + Gi[i, 1] * b[1] + Gi[i, 2] * b[2]
    return y


@_jit
def _now() -> float:
    with objmode(t="float64"):
        t = time.perf_counter()
    return t


# =========================================================================================
# The barrier method
# =========================================================================================
@_jit
def _ip_loop(u0: FloatArray, P0: Any, tol: float, constr_tol: float, mu0: float,
             max_iter: int, deadline: float, lo: FloatArray, hi: FloatArray,
             ug: FloatArray, wq: float) -> tuple[Any, ...]:  # fmt: skip
    """The barrier method from ``u0``; ``lo``/``hi`` (empty: none) add the box
    ``lo <= u <= hi`` as limit rows and ``wq |u - ug|^2`` is added to the objective
    (:func:`_evaluate_ext`; a path step's extensions). Returns the point, the status,
    the iteration count and the final slacks ``s`` and multipliers ``z``, ``yE``
    (multipliers of the problem as ``P0`` states it, i.e. without the objective scaling
    the loop applies: a continuation step starts from them, :func:`_pc_step`)."""
    n = P0[7].shape[0]
    R = 24 if lo.size == 0 else 30
    m = R * n
    N = 3 * n
    x = u0.copy()
    f, g, cE, AE, cI, D = _evaluate_ext(x, P0, lo, hi, ug, wq)
    if not (_finite(cI) and _finite(cE) and math.isfinite(f)):
        return x, IP_NONFINITE, 0, cI, np.ones(m), np.zeros(3)
    # objective scaling as IPOPT's gradient-based rule: max |grad f(x0)| <= OBJ_MAX_GRAD
    gmax = np.abs(g).max()
    fs = OBJ_MAX_GRAD / gmax if gmax > OBJ_MAX_GRAD else 1.0
    P = (P0[0], P0[1], P0[2], P0[3], P0[4] / fs, P0[5], P0[6], P0[7], P0[8], P0[9], P0[10],
         P0[11], P0[12], P0[13], P0[14], P0[15])  # fmt: skip
    f, g = f * fs, g * fs
    wq = wq * fs
    mu = mu0
    mu_min = min(tol, constr_tol) / 10.0
    s = np.maximum(cI, 1e-2)
    z = np.ones(m)  # bound multipliers start at 1, as IPOPT's
    # least-squares equality multipliers
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
        if it % 16 == 15 and _now() > deadline:
            status = IP_MAX_TIME
            break
        # --- optimality errors (fused loops: these vectors are short) ----------------
        AEty = _AET_dot(AE, yE)
        AItz = _AIT_dot(D, z)
        sd_acc = abs(yE[0]) + abs(yE[1]) + abs(yE[2])
        for r in range(m):
            sd_acc += abs(z[r])
        sd = max(100.0, sd_acc / (m + 3)) / 100.0
        e_du = 0.0
        for a in range(N):
            e_du = max(e_du, abs(g[a] - AEty[a] - AItz[a]))
        e_du /= sd
        e_pr = max(abs(cE[0]), max(abs(cE[1]), abs(cE[2])))
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
        # --- Newton step -----------------------------------------------------------
        W = _lagrangian_hessian_ext(x, yE, z, P, wq)
        if not (_finite(W) and _finite(g) and _finite(AE)):
            status = IP_NONFINITE
            break
        Sig = z / s
        for i in range(n):
            for a in range(3):
                for b in range(3):
                    acc = 0.0
                    for r in range(R):
                        acc += D[i, r, a] * Sig[R * i + r] * D[i, r, b]
                    W[3 * i + a, 3 * i + b] += acc
        v = np.empty(m)
        for r in range(m):
            v[r] = mu / s[r] - Sig[r] * (cI[r] - s[r])
        AIv = _AIT_dot(D, v)
        rhs = np.empty(N)
        for a in range(N):
            rhs[a] = -g[a] + AEty[a] + AIv[a]
        dx, _, _, shift = _kkt_step(W, AE, cE, rhs, last_shift)
        if not _finite(dx):
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
        # --- fraction to the boundary -------------------------------------------------
        tau = max(0.99, 1.0 - mu)
        a_s = 1.0
        a_z = 1.0
        for r in range(m):
            if ds[r] < 0.0:
                a_s = min(a_s, -tau * s[r] / ds[r])
            if dz[r] < 0.0:
                a_z = min(a_z, -tau * z[r] / dz[r])
        # --- filter line search (Waechter & Biegler 2006, sec. 2.3) -------------------
        theta = abs(cE[0]) + abs(cE[1]) + abs(cE[2])
        dsum = 0.0
        for r in range(m):
            theta += abs(cI[r] - s[r])
            dsum += ds[r] / s[r]
        gdx = 0.0
        for a in range(N):
            gdx += g[a] * dx[a]
        phi = f - mu * logsum
        gphi = gdx - mu * dsum
        alpha = a_s
        accepted = False
        ftype = False
        for _ in range(40):
            xt = x + alpha * dx
            st = np.empty(m)
            for r in range(m):
                st[r] = s[r] + alpha * ds[r]
            ft, gt, cEt, AEt, cIt, Dt = _evaluate_ext(xt, P, lo, hi, ug, wq)
            theta_t = abs(cEt[0]) + abs(cEt[1]) + abs(cEt[2])
            logsum_t = 0.0
            for r in range(m):
                theta_t += abs(cIt[r] - st[r])
                logsum_t += math.log(st[r])
            if math.isfinite(ft) and math.isfinite(theta_t):  # NaN/inf anywhere shows here
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
            # a tiny step keeps the iteration going; the barrier will be re-centred
            nfilt = 0
            alpha = min(alpha, 1e-8)
            xt = x + alpha * dx
            st = s + alpha * ds
            ft, gt, cEt, AEt, cIt, Dt = _evaluate_ext(xt, P, lo, hi, ug, wq)
            if not (math.isfinite(ft) and _finite(cIt)):
                status = IP_NONFINITE
                break
        else:
            fails = 0
        x = xt
        # slack reset: a slack below its constraint value only adds violation
        s = st
        logsum = logsum_t if accepted else np.log(s).sum()
        for r in range(m):
            if cIt[r] > s[r]:
                logsum += math.log(cIt[r]) - math.log(s[r])
                s[r] = cIt[r]
            zr = z[r] + a_z * dz[r]
            z[r] = min(max(zr, mu / (1e10 * s[r])), 1e10 * mu / s[r])
        f, g, cE, AE, cI, D = ft, gt, cEt, AEt, cIt, Dt
        yE = _ls_multipliers(AE, g, _AIT_dot(D, z))
    return x, status, it + 1 if status != IP_SUCCESS else it, s, z / fs, yE / fs


@_jit
def _polished(cE: FloatArray, cI: FloatArray, reach: float) -> bool:
    """Whether :func:`_polish` leaves a point with these constraint values as it is."""
    if not np.abs(cE).max() < 1e-13:
        return False
    for r in range(cI.size):
        if -reach < cI[r] < 0.0:
            return False
    return True


@_jit
def _polish(u: FloatArray, P: Any, iters: int, reach: float, margin: float) -> FloatArray:
    """Min-norm Newton corrections of the equalities and of limits violated by less than
    ``reach`` (scaled), as :func:`stackik.formulation.polish` (tiny moves only)."""
    n = P[7].shape[0]
    N = 3 * n
    for _ in range(iters):
        f, g, cE, AE, cI, D = _evaluate(u, P)
        if _polished(cE, cI, reach):
            break
        nv = 0
        for r in range(cI.size):
            if -reach < cI[r] < 0.0:
                nv += 1
        A = np.zeros((3 + nv, N))
        rr = np.empty(3 + nv)
        A[:3] = AE
        rr[:3] = cE
        k = 3
        for r in range(cI.size):
            if -reach < cI[r] < 0.0:
                i = r // 24
                A[k, 3 * i : 3 * i + 3] = D[i, r % 24]
                rr[k] = cI[r] - margin
                k += 1
        if not (_finite(A) and _finite(rr)):
            break
        du = np.linalg.lstsq(A, rr)[0]
        u = u - du
    return u


@_jit
def _ip_multi(U0: FloatArray, P: Any, tol: float, constr_tol: float, mu0: FloatArray,
              max_iter: int, deadline: float, reach: float,
              margin: float) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_ip_loop` and :func:`_polish` from each row of ``U0``.

    ``mu0[j]`` is the initial barrier parameter of start j. Returns the points (k, N),
    statuses, iteration counts, scaled objective values and
    the worst scaled violation of each (equalities and limits), for ranking; the caller
    re-checks the pose it returns.
    """
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
        x, st, it, _, _, _ = _ip_loop(
            U0[j], P, tol, constr_tol, mu0[j], max_iter, deadline, none, none, none, 0.0
        )
        if st == IP_NONFINITE or not _finite(x):
            x = U0[j].copy()
        x = _polish(x, P, 3, reach, margin)
        X[j] = x
        status[j] = st
        nit[j] = it
        f, g, cE, AE, cI, D = _evaluate(x, P)
        obj[j] = f
        viol[j] = max(np.abs(cE).max(), max(0.0, -cI.min()))
        if j + 1 == GIVE_UP_AFTER and viol[: j + 1].min() > GIVE_UP_VIOLATION:
            break  # likely unreachable: the caller's SQP fallback decides, quickly
    return X, status, nit, obj, viol


# =========================================================================================
# Path steps (stackik.paths): a boxed / goal-seeking solve, and many warm steps in one call
# =========================================================================================
@_jit
def ip_box(u0: FloatArray, P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray, wq: float,
           tol: float, constr_tol: float, mu0: float, max_iter: int, reach: float,
           margin: float) -> tuple[FloatArray, int, int]:  # fmt: skip
    """One barrier solve inside the box ``lo <= u <= hi`` (scaled) with ``wq |u - ug|^2``
    added to the objective (``wq = 0``: none), then :func:`_polish`. Returns the point,
    the status and the iteration count; the caller checks the pose and the box."""
    # copies: the barrier loop sees writable arrays whatever the caller passes, as from
    # _ip_multi (one compiled specialisation of the loop, not one per array flag)
    x, st, it, _, _, _ = _ip_loop(u0.copy(), P, tol, constr_tol, mu0, max_iter, 1e300,
                                  lo.copy(), hi.copy(), ug.copy(), wq)  # fmt: skip
    if st == IP_NONFINITE or not _finite(x):
        return u0.copy(), IP_NONFINITE, it
    return _polish(x, P, 3, reach, margin), st, it


#: Newton iterations of a continuation step (:func:`_pc_step`), all active sets
#: together, and active-set changes (a limit added or released) it may make; a step that
#: has not converged by then goes to the barrier solve.
PC_NEWTON = 16
PC_CHANGES = 3
#: ... and it gives up early when Newton's method does not converge: after PC_FREE
#: iterations in one active set, each must shrink the error by PC_CONTRACT.
PC_FREE = 2
PC_CONTRACT = 0.5
#: The continuation step holds its active limits at this scaled value rather than at 0,
#: on the feasible side as the barrier solve's points are (slacks ~ mu / z there), so
#: that rounding never leaves them violated for the polish to move.
PC_OFFSET = 1e-10
#: ... and converges its equality and active-limit residuals (scaled) to this, below
#: the polish's threshold (1e-13), where the barrier solve's own test asks constr_tol.
PC_PRIMAL_TOL = 1e-13


@_jit
def _twins(act: FloatArray, cI: FloatArray, D: FloatArray) -> FloatArray:
    """For each limit row of the set ``act``: -1 when it enters the Newton system, else
    the earlier row of the set it copies (mirror legs: the same value and gradient to
    rounding, i.e. the same function)."""
    m = cI.size
    parent = np.full(m, -1)
    for r in range(m):
        if not act[r]:
            continue
        i = r // 24
        for r2 in range(24 * i, r):
            same = act[r2] and parent[r2] < 0 and abs(cI[r2] - cI[r]) <= 1e-12
            for k in range(3):
                dk = D[i, r % 24, k]
                same = same and abs(D[i, r2 % 24, k] - dk) <= 1e-9 * (1.0 + abs(dk))
            if same:
                parent[r] = r2
                break
    return parent


@_jit
def _release(act: FloatArray, zf: FloatArray, parent: FloatArray, rj: int) -> None:
    """Release limit ``rj`` from the active set, with the limits that mirror it."""
    act[rj] = False
    zf[rj] = 0.0
    for r in range(act.size):
        if parent[r] == rj:
            act[r] = False


@_jit
def _platform_counts(idx: FloatArray, n: int) -> FloatArray:
    """Limit rows of ``idx`` per platform, shape (n,)."""
    cnt = np.zeros(n, dtype=np.int64)
    for j in range(idx.size):
        cnt[idx[j] // 24] += 1
    return cnt


@_jit
def _weakest(idx: FloatArray, zf: FloatArray, new: FloatArray, cnt: FloatArray) -> int:
    """The row of ``idx`` with the least multiplier whose release frees a variable (in
    a platform with at most 3 of the rows ``idx``), among the rows not ``new`` when there
    are any (a limit just added because the point violates it stays; the set makes room
    with an older one)."""
    rj = -1
    for rank in range(4):  # first the old rows of platforms with <= 3 rows, then ...
        for j in range(idx.size):
            r = idx[j]
            if (rank < 2 and cnt[r // 24] > 3) or (rank % 2 == 0 and new[r]):
                continue
            if rj < 0 or zf[r] < zf[rj]:
                rj = r
        if rj >= 0:
            break
    return rj


@_jit
def _lu_solve(M: FloatArray, b: FloatArray) -> tuple[FloatArray, bool]:
    """``M^{-1} b`` by Gaussian elimination with partial pivoting, in place on copies
    (small systems: no LAPACK call); ``ok`` False at a zero or non-finite pivot."""
    A = M.copy()
    x = b.copy()
    m = x.size
    for c in range(m):
        p = c
        for r in range(c + 1, m):
            if abs(A[r, c]) > abs(A[p, c]):
                p = r
        if not (A[p, c] != 0.0 and math.isfinite(A[p, c])):
            return x, False
        if p != c:
            for k in range(c, m):
                A[c, k], A[p, k] = A[p, k], A[c, k]
            x[c], x[p] = x[p], x[c]
        for r in range(c + 1, m):
            f = A[r, c] / A[c, c]
            if f != 0.0:
                for k in range(c + 1, m):
                    A[r, k] -= f * A[c, k]
                x[r] -= f * x[c]
    for c in range(m - 1, -1, -1):
        acc = x[c]
        for k in range(c + 1, m):
            acc -= A[c, k] * x[k]
        x[c] = acc / A[c, c]
    return x, True


#: Rows of a platform's active limits whose part orthogonal to the rows taken before
#: is below this fraction of their length depend on those (the KKT solve of the
#: continuation step, :func:`_pc_kkt`). Not smaller: near the ridge where a leg's base
#: and top joint limits coincide, rows that depend there are off by ~|theta| during
#: Newton's iterations, and taken as independent they gave multipliers of 4e4 (n = 8).
PC_DEPENDENT = 1e-6


@_jit
def _platform_basis(D: FloatArray, idx: FloatArray, rows: FloatArray, k: int, i: int,
                    Q: FloatArray, sel: FloatArray) -> int:  # fmt: skip
    """Orthonormal basis ``Q[:, :r]`` of the span of platform ``i``'s active limit rows
    ``D[i, idx[rows[:k]] % 24]`` by Gram-Schmidt, the row with the largest remaining
    part first (rows with less than PC_DEPENDENT of their length left depend on the
    others); ``sel[:r]``: the rows taken, in order. Returns the rank r."""
    r = 0
    while r < 3:
        best = -1
        bn = 0.0
        for t in range(k):
            taken = False
            for s in range(r):
                taken = taken or sel[s] == t
            if taken:
                continue
            a = D[i, idx[rows[t]] % 24]
            v0, v1, v2 = a[0], a[1], a[2]
            for s in range(r):
                dot = a[0] * Q[0, s] + a[1] * Q[1, s] + a[2] * Q[2, s]
                v0 -= dot * Q[0, s]
                v1 -= dot * Q[1, s]
                v2 -= dot * Q[2, s]
            nv = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
            if nv > PC_DEPENDENT * math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) and nv > bn:
                best = t
                bn = nv
        if best < 0:
            break
        a = D[i, idx[rows[best]] % 24]
        Q[0, r], Q[1, r], Q[2, r] = _orth_unit(a[0], a[1], a[2], Q, r)
        sel[r] = best
        r += 1
    return r


@_jit
def _orth_unit(v0: float, v1: float, v2: float, Q: FloatArray, r: int) -> tuple[Any, ...]:
    """``(v0, v1, v2)`` orthogonalised against the first ``r`` (orthonormal) columns of
    ``Q`` (3, *) by Gram-Schmidt twice (orthogonal to rounding), then normalised."""
    for _ in range(2):
        for s in range(r):
            dot = v0 * Q[0, s] + v1 * Q[1, s] + v2 * Q[2, s]
            v0 -= dot * Q[0, s]
            v1 -= dot * Q[1, s]
            v2 -= dot * Q[2, s]
    nv = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    return v0 / nv, v1 / nv, v2 / nv


@_jit
def _pc_kkt(W: FloatArray, AE: FloatArray, D: FloatArray, idx: FloatArray, r1: FloatArray,
            r2: FloatArray, rA: FloatArray, n: int) -> tuple[Any, ...]:  # fmt: skip
    """The Newton step of the continuation step: the solution of

        W dx - AE^T dy - AA^T dz = r1,   AE dx = r2,   AA dx = rA

    (``AA``: the rows ``idx`` of the block-diagonal limit Jacobian ``D``), by platforms:
    each platform's active rows fix the part of its ``dx`` in their span (the rows that
    depend on others, beyond 3 or in a lower rank, are taken as consistent with them),
    a system of the free parts and ``dy`` (size ``N - rank + 3``, not ``N + 3 + na``)
    gives the rest, and each platform's ``dz`` is the least-norm solution of its rows'
    part of the first equation (unique where its rows are independent). Returns
    ``(dx, dy, dz, ok)``; ``ok`` False when the system is singular."""
    N = 3 * n
    na = idx.size
    dxp = np.zeros(N)
    Z = np.zeros((3, N))  # null-space columns of their platform (3 entries each)
    zp = np.empty(N, dtype=np.int64)  # ... and that platform
    nz = 0
    Qs = np.zeros((n, 3, 3))
    rk = np.zeros(n, dtype=np.int64)
    rows = np.empty(max(na, 1), dtype=np.int64)
    sel = np.empty(3, dtype=np.int64)
    y = np.zeros(3)
    B = np.zeros((3, 3))
    for i in range(n):
        k = 0
        for j in range(na):
            if idx[j] // 24 == i:
                rows[k] = j
                k += 1
        Q = Qs[i]
        r = _platform_basis(D, idx, rows, k, i, Q, sel)
        rk[i] = r
        # the part in the rows' span: A_S Q y = rA_S, A_S Q lower triangular
        for t in range(r):
            a = D[i, idx[rows[sel[t]]] % 24]
            acc = rA[rows[sel[t]]]
            for u in range(t):
                acc -= (a[0] * Q[0, u] + a[1] * Q[1, u] + a[2] * Q[2, u]) * y[u]
            y[t] = acc / (a[0] * Q[0, t] + a[1] * Q[1, t] + a[2] * Q[2, t])
        for c in range(3):
            acc = 0.0
            for t in range(r):
                acc += Q[c, t] * y[t]
            dxp[3 * i + c] = acc
        # the free directions: the unit vectors' parts orthogonal to the span, largest
        # first, orthonormalised
        for t in range(r):
            for c in range(3):
                B[c, t] = Q[c, t]
        nb = r
        while nb < 3:
            best = 0
            bn = -1.0
            for e in range(3):
                acc = 1.0  # |e - sum_s (e.b_s) b_s|^2 = 1 - sum_s (b_s[e])^2
                for t in range(nb):
                    acc -= B[e, t] * B[e, t]
                if acc > bn:
                    bn = acc
                    best = e
            w0, w1, w2 = _orth_unit(
                1.0 if best == 0 else 0.0,
                1.0 if best == 1 else 0.0,
                1.0 if best == 2 else 0.0,
                B,
                nb,
            )
            B[0, nb] = Z[0, nz] = w0
            B[1, nb] = Z[1, nz] = w1
            B[2, nb] = Z[2, nz] = w2
            zp[nz] = i
            nz += 1
            nb += 1
    # the reduced system in (v, dy): Z^T W Z v - Z^T AE^T dy = Z^T (r1 - W dxp),
    # AE Z v = r2 - AE dxp
    m2 = nz + 3
    WZ = np.zeros((N, nz))
    for c in range(nz):
        b0 = 3 * zp[c]
        for a in range(N):
            WZ[a, c] = W[a, b0] * Z[0, c] + W[a, b0 + 1] * Z[1, c] + W[a, b0 + 2] * Z[2, c]
    Wd = np.zeros(N)
    for a in range(N):
        acc = 0.0
        for b in range(N):
            acc += W[a, b] * dxp[b]
        Wd[a] = acc
    M = np.zeros((m2, m2))
    rhs = np.empty(m2)
    for c in range(nz):
        b0 = 3 * zp[c]
        for c2 in range(nz):
            M[c, c2] = Z[0, c] * WZ[b0, c2] + Z[1, c] * WZ[b0 + 1, c2] + Z[2, c] * WZ[b0 + 2, c2]
        acc = 0.0
        for t in range(3):
            zt = Z[t, c]
            acc += zt * (r1[b0 + t] - Wd[b0 + t])
        rhs[c] = acc
        for r in range(3):
            ez = AE[r, b0] * Z[0, c] + AE[r, b0 + 1] * Z[1, c] + AE[r, b0 + 2] * Z[2, c]
            M[c, nz + r] = -ez
            M[nz + r, c] = ez
    for r in range(3):
        acc = r2[r]
        for a in range(N):
            acc -= AE[r, a] * dxp[a]
        rhs[nz + r] = acc
    sol, ok = _lu_solve(M, rhs)
    dx = dxp.copy()
    dy = np.zeros(3)
    dz = np.zeros(na)
    if not ok:
        return dx, dy, dz, False
    for c in range(nz):
        b0 = 3 * zp[c]
        for t in range(3):
            dx[b0 + t] += Z[t, c] * sol[c]
    for r in range(3):
        dy[r] = sol[nz + r]
    # multipliers: per platform, the least-norm dz with A^T dz = (W dx - AE^T dy - r1)
    # on its variables (A = C Q^T, C = A Q: C^T dz = Q^T b, dz = C (C^T C)^-1 Q^T b)
    bvec = np.empty(N)
    for a in range(N):
        acc = -r1[a] - AE[0, a] * dy[0] - AE[1, a] * dy[1] - AE[2, a] * dy[2]
        for b in range(N):
            acc += W[a, b] * dx[b]
        bvec[a] = acc
    C = np.empty((max(na, 1), 3))
    G = np.empty((3, 3))
    w = np.empty(3)
    for i in range(n):
        r = rk[i]
        if r == 0:
            continue
        Q = Qs[i]
        k = 0
        for j in range(na):
            if idx[j] // 24 == i:
                rows[k] = j
                k += 1
        for t in range(k):
            a = D[i, idx[rows[t]] % 24]
            for s in range(r):
                C[t, s] = a[0] * Q[0, s] + a[1] * Q[1, s] + a[2] * Q[2, s]
        # G = C^T C (positive definite: C has rank r) by Cholesky, G w = Q^T b
        for s in range(r):
            w[s] = Q[0, s] * bvec[3 * i] + Q[1, s] * bvec[3 * i + 1] + Q[2, s] * bvec[3 * i + 2]
            for s2 in range(s + 1):
                acc = 0.0
                for t in range(k):
                    acc += C[t, s] * C[t, s2]
                for u in range(s2):
                    acc -= G[s, u] * G[s2, u]
                if s2 < s:
                    G[s, s2] = acc / G[s2, s2]
                elif acc > 0.0:
                    G[s, s] = math.sqrt(acc)
                else:
                    return dx, dy, dz, False
        for s in range(r):  # L y = Q^T b, then L^T w = y
            for u in range(s):
                w[s] -= G[s, u] * w[u]
            w[s] /= G[s, s]
        for s in range(r - 1, -1, -1):
            for u in range(s + 1, r):
                w[s] -= G[u, s] * w[u]
            w[s] /= G[s, s]
        for t in range(k):
            acc = 0.0
            for s in range(r):
                acc += C[t, s] * w[s]
            dz[rows[t]] = acc
    return dx, dy, dz, True


@_jit
def _pc_step(x0: FloatArray, P0: Any, yE0: FloatArray, z0: FloatArray, active: FloatArray,
             tol: float, constr_tol: float, max_newton: int,
             max_changes: int) -> tuple[Any, ...]:  # fmt: skip
    """Predictor-corrector continuation step from ``x0`` (the solution of the previous
    target, or :func:`ip_path`'s extrapolation of it; multipliers ``yE0``, ``z0``
    of ``P0``'s problem, ``active``: boolean mask of the limit rows active there) to the
    solution for ``P0``'s target.

    Newton's method on the KKT conditions of the problem with the active limits as
    equalities, ``g - AE^T yE - AA^T zA = 0``, ``c_E = 0``, ``c_A = PC_OFFSET`` (on the
    feasible side by a rounding-sized margin), exact Hessian. The target enters only
    ``c_E``, so from the previous solution the first iteration, with its KKT matrix, is
    the tangent predictor (``x0`` plus the sensitivity of the solution to the target
    change, times the change); the next ones correct.

    Converged when the stationarity error and the complementarity ``c_A zA`` (scaled as
    :func:`_ip_loop` scales them, objective scaling included) are within ``tol`` and
    the equality and active-limit residuals within ``min(constr_tol, PC_PRIMAL_TOL)``
    (:func:`_ip_loop`'s termination test, the residuals tighter so that the polish has
    nothing left to move). A converged point releases the limit with the most negative
    multiplier, or else adds the other limits that it violates or nearly meets (closer
    than ``PC_OFFSET / 2``), and Newton goes on: at most ``max_changes`` changes and
    ``max_newton`` iterations in all (fewer when, after PC_FREE iterations in one active
    set, an iteration does not shrink the error by PC_CONTRACT: not converging). A set
    with more limits than the freedom ``N - 3`` (degenerate) loses its weakest (least
    multiplier) first, counting at most 3 limits per platform (more depend on those:
    they stay, and :func:`_pc_kkt` takes them as consistent with the others) and
    keeping the limits the last change added. Active rows
    that copy an
    earlier active row (mirror legs, :func:`_twins`) enter once, with the multipliers of
    the copies summed onto that row.

    Verified (``ok``) when converged with every active multiplier >= 0 and every other
    limit at ``c_I >= PC_OFFSET / 2``: a KKT point of the original problem to the barrier
    solve's tolerances. Returns ``(x, ok, yE, z, active, iterations, c_E, c_I)``
    (multipliers of ``P0``'s problem, ``z`` zero off the active set; the constraint
    values at ``x``); the caller polishes and checks ``x``."""
    n = P0[7].shape[0]
    N = 3 * n
    m = 24 * n
    f, g, cE, AE, cI, D = _evaluate(x0, P0)
    gmax = np.abs(g).max()
    fs = OBJ_MAX_GRAD / gmax if gmax > OBJ_MAX_GRAD else 1.0
    P = (P0[0], P0[1], P0[2], P0[3], P0[4] / fs, P0[5], P0[6], P0[7], P0[8], P0[9], P0[10],
         P0[11], P0[12], P0[13], P0[14], P0[15])  # fmt: skip
    g = g * fs
    x = x0.copy()
    yE = yE0 * fs
    zf = z0 * fs  # full multipliers; only the rows of the Newton system are used
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
        idx = np.nonzero(act & (parent < 0))[0]
        # more limits than freedom (degenerate): the weakest go. A platform has 3
        # variables: its limits beyond 3 depend on the others (where base and top joint
        # limits of its legs meet, at parallel plates) and take no freedom; they stay
        # (the KKT solve, _pc_kkt, handles them), and the others make room
        cnt = _platform_counts(idx, n)
        while 3 + np.minimum(cnt, 3).sum() > N:
            _release(act, zf, parent, _weakest(idx, zf, new, cnt))
            idx = np.nonzero(act & (parent < 0))[0]
            cnt = _platform_counts(idx, n)
        na = idx.size
        zA = np.empty(na)
        for j in range(na):
            zA[j] = zf[idx[j]]
        conv = False
        inner = 0  # Newton iterations in this active set
        err_prev = math.inf
        while True:
            if not (_finite(g) and _finite(cE) and _finite(cI)):
                break
            for j in range(na):
                zf[idx[j]] = zA[j]
            rd = g - _AET_dot(AE, yE) - _AIT_dot(D, zf)
            sd_acc = abs(yE[0]) + abs(yE[1]) + abs(yE[2])
            for j in range(na):
                sd_acc += abs(zA[j])
            sd = max(100.0, sd_acc / (m + 3)) / 100.0
            e_du = np.abs(rd).max() / sd
            e_pr = max(abs(cE[0]), max(abs(cE[1]), abs(cE[2])))
            comp = 0.0
            for j in range(na):
                e_pr = max(e_pr, abs(cI[idx[j]] - PC_OFFSET))
                comp = max(comp, abs(cI[idx[j]] * zA[j]))
            ptol = min(constr_tol, PC_PRIMAL_TOL)
            if e_du <= tol and comp / sd <= tol and e_pr <= ptol:
                conv = True
                break
            if it >= max_newton:
                break
            # Newton's method converges quadratically near a solution: an iteration that
            # does not at least halve the error (in units of the tolerances) after the
            # first two of this active set does not converge, and the barrier solve takes
            # the step at once (instead of after the whole budget)
            err = max(e_du / tol, max(comp / sd / tol, e_pr / ptol))
            if inner >= PC_FREE and not err <= PC_CONTRACT * err_prev:
                break
            err_prev = err
            inner += 1
            it += 1
            W = _lagrangian_hessian(x, yE, zf, P)
            if not _finite(W):
                break
            rA = np.empty(na)
            for j in range(na):
                rA[j] = PC_OFFSET - cI[idx[j]]
            dx, dy, dz, solved = _pc_kkt(W, AE, D, idx, -rd, -cE, rA, n)
            if not (solved and _finite(dx) and _finite(dy) and _finite(dz)):
                break  # a singular KKT matrix: the barrier solve decides
            x = x + dx
            for r in range(3):
                yE[r] += dy[r]
            for j in range(na):
                zA[j] += dz[j]
            f, g, cE, AE, cI, D = _evaluate(x, P)
        if not conv:
            break
        # release the limit with the most negative multiplier (and its copies) ...
        jmin = -1
        for j in range(na):
            if zA[j] < 0.0 and (jmin < 0 or zA[j] < zA[jmin]):
                jmin = j
        # ... or add the other limits that the point violates or nearly meets (closer
        # than half the offset: within rounding of it)
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
    return x, ok, yE / fs, zf / fs, act, it, cE, cI


@_jit
def _reaches(xn: FloatArray, x: FloatArray, P: Any, jump: FloatArray, pos_tol: float,
             ang_tol: float) -> bool:  # fmt: skip
    """Whether the polished point ``xn`` reaches ``P``'s target (``pos_tol`` [mm],
    ``ang_tol`` [rad], from the scaled equalities), violates no limit (scaled) and moves
    no variable from ``x`` by more than ``jump`` (scaled, per variable)."""
    f, g, cE, AE, cI, D = _evaluate(xn, P)
    return _reaches_at(xn, x, cE, cI, P[2], jump, pos_tol, ang_tol)


@_jit
def _reaches_at(xn: FloatArray, x: FloatArray, cE: FloatArray, cI: FloatArray,
                es: FloatArray, jump: FloatArray, pos_tol: float,
                ang_tol: float) -> bool:  # fmt: skip
    """:func:`_reaches` with the constraint values at ``xn`` given (``es``: the
    equalities' scales)."""
    if not (math.hypot(cE[0] / es[0], cE[1] / es[1]) <= pos_tol
            and abs(cE[2] / es[2]) <= ang_tol and cI.min() >= -1e-12):  # fmt: skip
        return False
    for a in range(x.size):
        if not abs(xn[a] - x[a]) <= jump[a]:
            return False
    return True


#: A point with no multipliers (the first of a run that carries none): limits closer than
#: this (scaled) are its active set, and least-squares multipliers start the continuation
#: step (:func:`_ls_state`) instead of a barrier solve.
PC_ACTIVE_GUESS = 1e-6


@_jit
def _ls_state(x: FloatArray, P: Any) -> tuple[FloatArray, FloatArray, FloatArray]:
    """A continuation step's start state at a point that has none: the limits within
    PC_ACTIVE_GUESS of their bound as the active set and the least-squares multipliers of
    the equalities and those limits (``min |g - AE^T yE - AA^T zA|``; multipliers of
    ``P``'s problem, as :func:`_ip_loop` returns them). The target enters only ``c_E``:
    any target's ``P`` gives the same state. :func:`_pc_step` verifies its result."""
    f, g, cE, AE, cI, D = _evaluate(x, P)
    m = cI.size
    N = x.size
    act = cI < PC_ACTIVE_GUESS
    idx = np.nonzero(act)[0]
    A = np.zeros((N, 3 + idx.size))
    for a in range(N):
        for r in range(3):
            A[a, r] = AE[r, a]
    for j in range(idx.size):
        i = idx[j] // 24
        for k in range(3):
            A[3 * i + k, 3 + j] = D[i, idx[j] % 24, k]
    lam = np.linalg.lstsq(A, g)[0]
    yE = lam[:3].copy()
    z = np.zeros(m)
    for j in range(idx.size):
        z[idx[j]] = lam[3 + j]
    return yE, z, act


@_jit
def _target_step(a: FloatArray, b: FloatArray, es: FloatArray) -> float:
    """Length of the target step ``a -> b`` in the scaled equalities' units."""
    acc = 0.0
    for r in range(3):
        d = (b[r] - a[r]) * es[r]
        acc += d * d
    return math.sqrt(acc)


@_jit
def ip_path(u0: FloatArray, targets: FloatArray, P0: Any, jump: FloatArray, tol: float,
            constr_tol: float, mu0: float, max_iter: int, reach: float, margin: float,
            pos_tol: float, ang_tol: float, pc: bool, yE0: FloatArray, z0: FloatArray,
            act0: FloatArray, have0: bool, hist0: FloatArray) -> tuple[Any, ...]:  # fmt: skip
    """Warm-started steps along targets ``(m, 3)`` (raw rho, z, theta), each from the
    previous point (the first from ``u0``).

    With ``pc`` False every step is :func:`_ip_loop` with initial barrier ``mu0`` and
    :func:`_polish`, exactly as :func:`_ip_multi` with that one start. With ``pc`` True a
    step is first the predictor-corrector step (:func:`_pc_step`: the previous
    solution's multipliers and active set carried, Newton correctors, verified as a KKT
    point), polished and tested as below; when it is not verified or fails the test, the
    step is the barrier solve as without ``pc`` (whose final multipliers and active set,
    ``z > s``, the next step carries). A point without multipliers (``u0`` without a
    carried state, or a barrier solve that did not converge) gets them from
    :func:`_ls_state`. When the two points before are known, the step starts from their
    secant extrapolation (``x + r (x - x_prev)``, ``r`` the ratio of the target steps): two
    Newton iterations then usually converge where the tangent predictor from ``x`` takes
    three; when three are (and the target step is at most twice the last), from the
    quadratic through them (Lagrange in the targets' arc length), with the multipliers
    extrapolated the same way where the three were continuation steps in one active set:
    one iteration fewer again on smooth stretches (the first 20 steps of a straight n = 4
    path: 241 instead of 332 us). The first step carries ``yE0``, ``z0``, ``act0`` when
    ``have0`` and ``hist0`` (the state of ``u0`` that the previous run returned, see
    :func:`_hist`: empty when not known; empty arrays and False otherwise), so that a run
    split in two gives the same points.

    Stops before the first step whose point misses its target (``pos_tol`` [mm],
    ``ang_tol`` [rad], from the scaled equalities), violates a limit (scaled) or moves
    some variable by more than ``jump`` (scaled, per variable). Returns the points
    (m, N), the number of steps taken, per step 1 when the continuation step made it
    and 0 when the barrier solve did (at the step it stopped before: -1 when the barrier
    solve's point reaches the target within the limits but is farther than ``jump``, the
    solve left its basin, else 0), and the state of the last point reached
    (``yE, z, active, have, hist``, for the next run from it); the caller re-checks every
    point with the independent check."""
    m = targets.shape[0]
    N = u0.size
    X = np.empty((m, N))
    how = np.zeros(m, dtype=np.int64)
    none = np.empty(0)
    far = np.full(N, np.inf)
    x = u0.copy()
    have = have0  # the state of u0 (multipliers, active set) when it is a solved point
    yE = yE0.copy()
    z = z0.copy()
    active = act0.copy()
    es = P0[2]
    # the point before x and the targets of both (known: a secant predictor); cur_ok:
    # ycur is x's target (after a run's first step, not before it when hist0 is empty)
    known = hist0.size >= N + 6
    cur_ok = known or hist0.size == 4  # (4: x's target and pcrun only, see _hist)
    xprev = hist0[:N].copy() if known else np.zeros(N)
    yprev = hist0[N : N + 3].copy() if known else np.zeros(3)
    ycur = hist0[N + 3 : N + 6].copy() if known else hist0[:3].copy() if cur_ok else np.zeros(3)
    # ... and the point before xprev and its target (known2: a quadratic predictor), and
    # the multipliers of xprev and of it (pcrun: x and the points before it made by
    # continuation steps, in a row), from hist0 when it has them (_hist)
    M = 24 * (N // 3)
    known2 = False
    x2 = np.zeros(N)
    y2 = np.zeros(3)
    pcrun = 0
    yEp, zp, actp = yE.copy(), np.zeros(M), np.zeros(M, dtype=np.bool_)
    yE2, z2, act2 = yE.copy(), np.zeros(M), np.zeros(M, dtype=np.bool_)
    if hist0.size == 2 * N + 11 + 2 * (3 + 2 * M):
        known2 = hist0[N + 6] > 0.5
        x2 = hist0[N + 7 : 2 * N + 7].copy()
        y2 = hist0[2 * N + 7 : 2 * N + 10].copy()
        pcrun = int(hist0[2 * N + 10])
        o = 2 * N + 11
        yEp = hist0[o : o + 3].copy()
        zp = hist0[o + 3 : o + 3 + M].copy()
        actp = hist0[o + 3 + M : o + 3 + 2 * M] > 0.5
        o += 3 + 2 * M
        yE2 = hist0[o : o + 3].copy()
        z2 = hist0[o + 3 : o + 3 + M].copy()
        act2 = hist0[o + 3 + M : o + 3 + 2 * M] > 0.5
    elif hist0.size == 4:
        pcrun = int(hist0[3])
    for k in range(m):
        yt = targets[k]
        P = (P0[0], P0[1], P0[2], yt, P0[4], P0[5], P0[6], P0[7], P0[8], P0[9], P0[10],
             P0[11], P0[12], P0[13], P0[14], P0[15])  # fmt: skip
        if pc:
            if not have:
                yE, z, active = _ls_state(x, P)
            xs = x
            yEs, zs = yE, z
            if known:
                d0 = _target_step(yprev, ycur, es)
                d1 = _target_step(ycur, yt.copy(), es)  # writable, as ycur: one specialisation
                d2 = _target_step(y2, yprev, es) if known2 else 0.0
                if d0 > 0.0 and d2 > 0.0 and d1 <= 2.0 * d0 and d0 <= 2.0 * d2:
                    # quadratic extrapolation through the last three points (Lagrange in
                    # the targets' arc length): one Newton iteration fewer on smooth
                    # stretches; the multipliers too when the three kept one active set
                    la, lb, lc = _lagrange3(d2, d0, d1)
                    xs = la * x2 + lb * xprev + lc * x
                    if (pcrun >= 3 and np.array_equal(act2, actp)
                            and np.array_equal(actp, active)):  # fmt: skip
                        yEs = la * yE2 + lb * yEp + lc * yE
                        zs = la * z2 + lb * zp + lc * z
                elif d0 > 0.0:
                    r = min(d1 / d0, 2.0)
                    xs = x + r * (x - xprev)
            xn, ok, yE1, z1, act1, _, cEn, cIn = _pc_step(
                xs, P, yEs, zs, active, tol, constr_tol, PC_NEWTON, PC_CHANGES
            )
            if ok:
                # the polish and test of a barrier step; the step's own constraint
                # values at xn when the polish would not move it
                if _polished(cEn, cIn, reach):
                    good = _reaches_at(xn, x, cEn, cIn, es, jump, pos_tol, ang_tol)
                else:
                    xn = _polish(xn, P, 3, reach, margin)
                    good = _reaches(xn, x, P, jump, pos_tol, ang_tol)
                if good:
                    X[k] = xn
                    how[k] = 1
                    x2, y2, known2 = xprev, yprev, known
                    yE2, z2, act2, yEp, zp, actp = yEp, zp, actp, yE, z, active
                    xprev, yprev, ycur, known, cur_ok = x, ycur, yt.copy(), cur_ok, True
                    x, yE, z, active, have = xn, yE1, z1, act1, True
                    pcrun += 1
                    continue
        xn, st, _, s1, z1, yE1 = _ip_loop(
            x, P, tol, constr_tol, mu0, max_iter, 1e300, none, none, none, 0.0
        )
        if st == IP_NONFINITE or not _finite(xn):
            hist = _hist(known, cur_ok, xprev, yprev, ycur, known2, x2, y2, pcrun, yEp, zp,
                         actp, yE2, z2, act2)  # fmt: skip
            return X, k, how, yE, z, active, have, hist
        xn = _polish(xn, P, 3, reach, margin)
        f, g, cE, AE, cI, D = _evaluate(xn, P)
        if not _reaches_at(xn, x, cE, cI, es, jump, pos_tol, ang_tol):
            if _reaches_at(xn, x, cE, cI, es, far, pos_tol, ang_tol):
                how[k] = -1  # a pose of the target farther than jump: it left its basin
            hist = _hist(known, cur_ok, xprev, yprev, ycur, known2, x2, y2, pcrun, yEp, zp,
                         actp, yE2, z2, act2)  # fmt: skip
            return X, k, how, yE, z, active, have, hist
        X[k] = xn
        x2, y2, known2 = xprev, yprev, known
        xprev, yprev, ycur, known, cur_ok = x, ycur, yt.copy(), cur_ok, True
        x, yE, z = xn, yE1, z1
        active = z1 > s1
        have = st == IP_SUCCESS
        pcrun = 0
    hist = _hist(
        known, cur_ok, xprev, yprev, ycur, known2, x2, y2, pcrun, yEp, zp, actp, yE2, z2, act2
    )
    return X, m, how, yE, z, active, have, hist


@_jit
def _lagrange3(d2: float, d0: float, d1: float) -> tuple[float, float, float]:
    """Weights of the quadratic through points at arc lengths ``0, d2, d2 + d0``
    (the point before the last, the last, the current one), at ``d2 + d0 + d1``."""
    sb = d2
    sc = d2 + d0
    st = sc + d1
    la = (st - sb) * (st - sc) / (sb * sc)
    lb = -st * (st - sc) / (sb * (sc - sb))
    lc = st * (st - sb) / (sc * (sc - sb))
    return la, lb, lc


@_jit
def _hist(known: bool, cur_ok: bool, xprev: FloatArray, yprev: FloatArray,
          ycur: FloatArray, known2: bool, x2: FloatArray, y2: FloatArray, pcrun: int,
          yEp: FloatArray, zp: FloatArray, actp: FloatArray, yE2: FloatArray,
          z2: FloatArray, act2: FloatArray) -> FloatArray:  # fmt: skip
    """``ip_path``'s ``hist``: the point before the last and the targets of both (the
    secant predictor), then, for the quadratic one, whether the point before that is
    known, it, its target, the continuation steps in a row ending at the last point, and
    the multipliers and active sets (as 0/1) of the point before the last and of the one
    before it: ``N + 6`` then ``N + 5 + 2 (3 + 2 m)`` values. When the point before the
    last is not known (a run's first step from a point without history): the last
    point's target and the continuation steps in a row (4 values: a run split after its
    first step continues as the whole run), or nothing before any step."""
    if not known:
        if not cur_ok:
            return np.empty(0)
        out1 = np.empty(4)
        out1[:3] = ycur
        out1[3] = pcrun
        return out1
    N = xprev.size
    m = zp.size
    out = np.empty(2 * N + 11 + 2 * (3 + 2 * m))
    out[:N] = xprev
    out[N : N + 3] = yprev
    out[N + 3 : N + 6] = ycur
    out[N + 6] = 1.0 if known2 else 0.0
    out[N + 7 : 2 * N + 7] = x2
    out[2 * N + 7 : 2 * N + 10] = y2
    out[2 * N + 10] = pcrun
    _put_state(out, 2 * N + 11, yEp, zp, actp)
    _put_state(out, 2 * N + 14 + 2 * m, yE2, z2, act2)
    return out


@_jit
def _put_state(out: FloatArray, o: int, yE: FloatArray, z: FloatArray,
               act: FloatArray) -> None:  # fmt: skip
    m = z.size
    out[o : o + 3] = yE
    out[o + 3 : o + 3 + m] = z
    for r in range(m):
        out[o + 3 + m + r] = 1.0 if act[r] else 0.0
