"""The planar IK problem for the compiled interior point (the fast path): evaluation,
exact Hessian, the KKT step, and their registration with the barrier method.

The planar problem of :class:`stackik.formulation.Problem` (scaled variables ``u = q / xs``):

    min f(u) = (c0 + w |r(u)|^2) / fscale
    s.t. c_E(u) = 0   (3 end-effector equalities, scaled by ``es``)
         c_I(u) >= 0  (24 n limits, scaled by ``cs``; then the dense obstacle and
                       leg-force rows, :mod:`stackik._compiled.dense_rows`)

is solved by the primal-dual barrier method of :mod:`stackik._compiled.barrier` (in the
spirit of IPOPT: Waechter & Biegler 2006) through the functions this module registers
(:mod:`stackik._compiled.kernel`): the evaluation, the exact Hessian of the Lagrangian,
and a null-space solve of the KKT system whose reduced Hessian is made positive definite
by the smallest shift that does it (inertia correction).

Everything that runs per iteration is compiled with numba (``cache=True``: compiled once
per machine, then loaded from ``__pycache__``). The caller re-checks every returned pose
(:func:`stackik.check.check_pose`); this module makes no claim of its own.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from stackik._compiled import kernel
from stackik._compiled.core import (
    _jit,
    _jit_inline,
    _jit_internal,
    _limit_rows,
    no_dense_rows,
)
from stackik._compiled.dense_rows import (
    with_dense_rows,
)
from stackik._compiled.linalg import (
    SHIFT_TRIES,
    _cho_solve,
    _cholesky,
    _cholesky_plus,
    _inv3,
    add_distance_term,
    block_formed,
    first_shift,
    formed_columns,
    semisep_factor,
    semisep_solve,
    shift_given_up,
    subtract_blocks_scaled,
)


class PlanarData(NamedTuple):
    """The planar problem as the kernels take it (every array read-only: one compiled
    specialisation), built by :func:`stackik.methods.ip.problem_arrays`; variables are
    scaled, ``u = q / xs``."""

    xs: Any  #: variable scales (3 n,)
    cs: Any  #: limit row scales (24 n,)
    es: Any  #: equality scales (3,)
    target: Any  #: the target ``(rho [mm], z [mm], theta [rad])`` (3,)
    fscale: float  #: objective scale
    c0: float  #: objective constant
    w: float  #: FN weight of the angle columns
    tf: Any  #: top nodes in the plane's frame (n, 6, 2) [mm]
    tz: Any  #: top nodes' out-of-plane coordinate (n, 6) [mm]
    bf: Any  #: base nodes in the plane's frame (n, 6, 2) [mm]
    bz: Any  #: base nodes' out-of-plane coordinate (n, 6) [mm]
    ls0: Any  #: squared leg lengths' constant part (n, 6) [mm^2]
    lmin2: Any  #: squared minimum leg length (n,) [mm^2]
    lmax2: Any  #: squared maximum leg length (n,) [mm^2]
    sj: Any  #: sine of the minimum joint angle (n,)
    feasible: bool  #: the feasibility objective (f = 0) instead of FN^2
    obstacles: Any  #: the obstacle rows' kernel arrays (ObstacleRows.kernel_args)
    ob_margin: float  #: the obstacle rows' clearance margin [mm]
    ob_L: float  #: the obstacle rows' length scale [mm]
    ob_phi: float  #: the plane angle [rad] of the obstacle rows (the target's plane)
    forces: Any  #: the force rows' kernel arrays (ForceLimits.kernel_args)
    leg_pairs: Any  #: non-adjacent leg-pair rows' kernel arguments (LegPairRows.kernel_args)
    #: number of dense rows (:mod:`stackik._compiled.dense_rows`); None where the problem
    #: has no rows beyond the limits: the lean type (:func:`stackik._compiled.core.lean_type`)
    n_dense: int | None
    families: int  #: token of the constraint families' rows (0: none; stackik.families)


@_jit_internal
def _with_fscale(P0: Any, fscale: float) -> Any:
    """``P0`` with the objective scale ``fscale``."""
    return PlanarData(P0.xs, P0.cs, P0.es, P0.target, fscale, P0.c0, P0.w, P0.tf, P0.tz, P0.bf,
                      P0.bz, P0.ls0, P0.lmin2, P0.lmax2, P0.sj, P0.feasible, P0.obstacles,
                      P0.ob_margin, P0.ob_L, P0.ob_phi, P0.forces, P0.leg_pairs,
                      P0.n_dense, P0.families)  # fmt: skip


@_jit
def _with_target(P0: Any, target: Any) -> Any:
    """``P0`` with the target ``target`` (3,)."""
    return PlanarData(P0.xs, P0.cs, P0.es, target, P0.fscale, P0.c0, P0.w, P0.tf, P0.tz, P0.bf,
                      P0.bz, P0.ls0, P0.lmin2, P0.lmax2, P0.sj, P0.feasible, P0.obstacles,
                      P0.ob_margin, P0.ob_L, P0.ob_phi, P0.forces, P0.leg_pairs,
                      P0.n_dense, P0.families)  # fmt: skip


FloatArray = np.ndarray


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


@_jit_inline
def _scale_formed(H: FloatArray, coef: float, partial: bool) -> None:
    """``H *= coef`` in place on the blocks
    :func:`~stackik._compiled.linalg.block_formed` forms (the others, below the diagonal
    blocks, are the structured step's generators: :func:`_chain_generators`)."""
    N = H.shape[0]
    for a in range(N):
        c0, c1, c2, c3 = formed_columns(a, 3, N, partial)
        for b in range(c0, c1):
            H[a, b] *= coef
        for b in range(c2, c3):
            H[a, b] *= coef


@_jit
def _gauss_newton(c: FloatArray, s: FloatArray, d: FloatArray, partial: bool) -> FloatArray:
    """``Jr^T Jr`` of the FN residuals ``r_i = d_i`` (i < n-1) in O(n^2), shape (3n, 3n)
    (with ``partial``, only the blocks :func:`~stackik._compiled.linalg.block_formed`
    names, zeros elsewhere).

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
    H = np.zeros((N, N)) if partial else np.empty((N, N))
    for m in range(n):
        um = ((c[m], s[m]), (-s[m], c[m]))
        for l in range(n):
            if not block_formed(m, l, partial):
                continue
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
def _fn2_hessian(c: FloatArray, s: FloatArray, d: FloatArray, partial: bool) -> FloatArray:
    """Exact Hessian of ``sum_i |d_i|^2`` (i < n-1) in raw q, shape (3n, 3n) (with
    ``partial``, only the blocks :func:`~stackik._compiled.linalg.block_formed` names,
    zeros elsewhere)."""
    n = c.shape[0]
    H = _gauss_newton(c, s, d, partial)
    _scale_formed(H, 2.0, partial)
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
            if block_formed(m, l, partial):
                H[3 * m + 2, 3 * l + 2] -= 2.0 * Hb[max(m, l)]
    c0 = 0.0
    c1 = 0.0  # sum_{i<k} r_i
    for k in range(n):
        t0 = -s[k] * c0 + c[k] * c1
        t1 = -c[k] * c0 - s[k] * c1
        for m in range(k if not partial else min(k, 1)):  # m < k: the block (k, m) is
            H[3 * k, 3 * m + 2] += 2.0 * t0  # needed only for m = 0 when partial
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
    xs, cs, es, yt, fscale, c0, w, tf = P.xs, P.cs, P.es, P.target, P.fscale, P.c0, P.w, P.tf
    tz, bf, bz, ls, lmin2, lmax2 = P.tz, P.bf, P.bz, P.ls0, P.lmin2, P.lmax2
    sj, feasible = P.sj, P.feasible
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


@_jit_inline
def _evaluate_ext(u: FloatArray, P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray,
                  wq: float) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_evaluate` with the extensions of a path step: the objective plus
    ``wq |u - ug|^2`` (when ``wq > 0``), and, when ``lo`` is not empty, the box
    ``lo <= u <= hi`` as 6 more limit rows per platform (rows 24-26: ``u - lo``, rows
    27-29: ``hi - u``), so that ``c_I`` has ``30 n`` rows and ``D`` is (n, 30, 3). Without
    extensions it returns :func:`_evaluate`'s values unchanged."""
    f, g, cE, AE, cI, D = _evaluate(u, P)
    f = add_distance_term(f, g, u, ug, wq)
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
def _evaluate_ip(u: FloatArray, P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray,
                 wq: float) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_evaluate_ext` with the dense rows (:mod:`stackik._compiled.dense_rows`, the
    obstacle rows in the target's plane ``P.ob_phi``): ``c_I`` the block rows then the
    dense rows, and the pair ``AI = (D, JD)`` in place of ``D``; for the lean problem data
    (no dense rows: :func:`stackik._compiled.core.lean_type`) :func:`_evaluate_ext`'s
    values themselves."""
    f, g, cE, AE, cI, D = _evaluate_ext(u, P, lo, hi, ug, wq)
    cA, AI = with_dense_rows(u, P, cI, D, True, P.ob_phi)
    return f, g, cE, AE, cA, AI


@_jit_inline
def _hessian_of(parts: FloatArray, yE: FloatArray, z: FloatArray, P: Any, wq: float,
                partial: bool) -> FloatArray:  # fmt: skip
    """Hessian of ``f - yE.c_E - z.c_I`` in scaled variables, shape (N, N), at the scaled
    point ``u`` (the parts :func:`_kernel_evaluate` returns); of :func:`_evaluate_ext`'s
    problem too: ``z`` then has 30 n multipliers with a box (its rows are linear) and the
    distance term adds ``2 wq I``. With ``partial`` only the blocks the structured KKT
    step reads (:func:`~stackik._compiled.linalg.block_formed`), zeros elsewhere. Inlined
    into its two entries, :func:`_lagrangian_hessian` (every block: the barrier loop's
    plain step, the SQP method, the path kernels) and :func:`_partial_hessian` (the
    structured step's)."""
    xs, cs, es, fscale, w, tf, tz, bf = P.xs, P.cs, P.es, P.fscale, P.w, P.tf, P.tz, P.bf
    bz, ls, sj, feasible = P.bz, P.ls0, P.sj, P.feasible
    n = tf.shape[0]
    N = 3 * n
    u = parts
    z = _limit_rows(z, n)
    q = (u * xs).reshape(n, 3)
    c, s, y, J, d = _kinematics(q)
    if feasible:
        H = np.zeros((N, N))
    else:
        H = _fn2_hessian(c, s, d, partial)
        _scale_formed(H, w / fscale, partial)
    # end-effector equalities: sum_r yE_r d2 y_r = [min(a,b) is an angle] * v[max(a,b)]
    yp0 = yE[0] * es[0]
    yp1 = yE[1] * es[1]
    v = yp1 * J[0] - yp0 * J[1]
    for a in range(2, N, 3):  # angle columns a: every (a, b) with b >= a
        H[a, a] -= v[a]
        for b in range(a + 1, N if a == 2 or not partial else 0):  # partial: a's block ends at a
            H[a, b] -= v[b]
            H[b, a] -= v[b]
    Hb = _constraint_hessian(q, z * cs, tf, tz, bf, bz, ls, sj)
    H = subtract_blocks_scaled(H, Hb, xs, partial)
    if wq > 0.0:
        for a in range(N):
            H[a, a] += 2.0 * wq
    return H


@_jit
def _lagrangian_hessian(parts: FloatArray, yE: FloatArray, z: FloatArray, P: Any,
                        wq: float = 0.0) -> FloatArray:  # fmt: skip
    """:func:`_hessian_of`, every block (the barrier loop's plain step, the SQP method, the
    path kernels: one compiled function for them all)."""
    return _hessian_of(parts, yE, z, P, wq, False)


@_jit_internal
def _partial_hessian(parts: FloatArray, yE: FloatArray, z: FloatArray, P: Any,
                     wq: float) -> FloatArray:  # fmt: skip
    """:func:`_hessian_of` with ``partial``: the barrier loop's Hessian where it takes the
    structured step (:func:`_chained`)."""
    return _hessian_of(parts, yE, z, P, wq, True)


#: The Hessian with a path step's extensions (the name the tests use): the same function.
_lagrangian_hessian_ext = _lagrangian_hessian


#: From this many variables on, a KKT step of a problem without dense rows factors the
#: reduced Hessian by its structure (:func:`_structured_factor`) instead of densely, and the
#: barrier loop's Hessian forms only the blocks that step reads (``block_formed``). Below
#: it the dense factor is as fast or faster (paired runs, docs/benchmarks.md).
STRUCTURED_MIN_N = 3 * 12


@_jit_internal
def _chained(P: Any, N: int) -> bool:
    """Whether the barrier loop's steps of the problem ``P`` with ``N`` variables are the
    structured ones (:func:`_partial_hessian`, :func:`_structured_step`): ``N >=
    STRUCTURED_MIN_N`` and no dense rows (whose barrier terms, and the leg-force rows'
    SR1 curvature, reach every block). Decided once a start
    (:func:`stackik._compiled.kernel.chained`): a test in every step cost the plain step
    about 0.4 us at n = 4, a third of it."""
    return N >= STRUCTURED_MIN_N and no_dense_rows(P)


@_jit_inline
def _chain_generators(W: FloatArray, AE: FloatArray, P: Any) -> tuple[FloatArray, FloatArray]:
    """``U``, ``V`` (N, 5) with ``W[a, b] = U[a] . V[b]`` wherever platform a's block is
    above platform b's (``a // 3 > b // 3``), for the Hessian ``W`` of a problem without
    dense rows (:func:`_lagrangian_hessian` plus the block rows' ``J^T Sigma J``), in the
    scaled variables.

    Below its diagonal blocks ``W`` is the FN^2 Hessian's and the equalities' curvature
    alone (the limit rows' curvature and the barrier terms are a platform's own). From
    :func:`_gauss_newton` and :func:`_fn2_hessian`, with ``u_m0 = (c_m, s_m)``, ``u_m1 =
    (-s_m, c_m)``, ``J2 v = (-v_y, v_x)``, ``X_l = (l + 1) d_l - P_(l+1)`` and ``k = 2 w /
    fscale`` (0 for the feasibility objective), for m > l:
    trans_m.trans_l and angle_m.trans_l = ``(u_mt; J2 d_m) . k l u_lt'`` (two columns),
    trans_m.angle_l and angle_m.angle_l = ``(J2^T u_mt; d_m) . k X_l`` (two), plus a part
    of the row alone (the rest of the FN^2 terms and the equalities' ``-v[b]``) times 1
    on the angle columns, which is ``W``'s column 2 (``X_0 = 0`` and ``l = 0``: nothing
    else reaches the first angle column from below). ``c``, ``s``, ``d`` are read from
    ``AE`` (its columns are ``J``'s, scaled)."""
    N = W.shape[0]
    n = N // 3
    xs, es = P.xs, P.es
    k = 0.0 if P.feasible else 2.0 * P.w / P.fscale
    U = np.empty((N, 5))
    V = np.zeros((N, 5))
    p0 = 0.0  # P_(m+1), the lever arms summed
    p1 = 0.0
    x2 = xs[2]
    for m in range(n):
        a = 3 * m
        c = AE[0, a] / (es[0] * xs[a])
        sn = AE[1, a] / (es[1] * xs[a])
        dy = -AE[0, a + 2] / (es[0] * xs[a + 2])
        dx = AE[1, a + 2] / (es[1] * xs[a + 2])
        p0 += dx
        p1 += dy
        x0, x1, xa = xs[a], xs[a + 1], xs[a + 2]
        U[a, 0] = c * x0
        U[a, 1] = sn * x0
        U[a + 1, 0] = -sn * x1
        U[a + 1, 1] = c * x1
        U[a + 2, 0] = -dy * xa
        U[a + 2, 1] = dx * xa
        U[a, 2] = sn * x0
        U[a, 3] = -c * x0
        U[a + 1, 2] = c * x1
        U[a + 1, 3] = sn * x1
        U[a + 2, 2] = dx * xa
        U[a + 2, 3] = dy * xa
        for t in range(3):
            U[a + t, 4] = W[a + t, 2] / x2
        km = k * m
        V[a, 0] = km * c * x0
        V[a, 1] = km * sn * x0
        V[a + 1, 0] = -km * sn * x1
        V[a + 1, 1] = km * c * x1
        V[a + 2, 2] = k * ((m + 1) * dx - p0) * xa
        V[a + 2, 3] = k * ((m + 1) * dy - p1) * xa
        V[a + 2, 4] = xa
    return U, V


@_jit_inline
def _reduced_generators(W: FloatArray, Et: FloatArray, U5: FloatArray,
                        V5: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:  # fmt: skip
    """The generators of the reduced Hessian ``Hz = W22 + E^T W12 + W21 E + E^T W11 E``
    (``Z = [E; I]``): the part of ``W`` below its diagonal blocks
    (:func:`_chain_generators`' ``U5``, ``V5``) and the rank-6 term ``X M X^T``, ``X =
    [E^T, W21]``, ``M = [[W11 + t I, I], [I, 0]]`` (11 columns ``Ug``, ``Vg``), with
    ``Vg``'s columns 5-7, ``(E^T (W11 + t I) + W21)``, left for :func:`_structured_factor`
    to fill for each shift ``t`` from ``EW = E^T W11`` (returned)."""
    K = W.shape[0] - 3
    Ug = np.empty((K, 11))
    Vg = np.empty((K, 11))
    EW = np.empty((K, 3))
    for a in range(K):
        for j in range(5):
            Ug[a, j] = U5[3 + a, j]
            Vg[a, j] = V5[3 + a, j]
        for i in range(3):
            Ug[a, 5 + i] = Et[a, i]
            Ug[a, 8 + i] = W[3 + a, i]
            EW[a, i] = Et[a, 0] * W[0, i] + Et[a, 1] * W[1, i] + Et[a, 2] * W[2, i]
            Vg[a, 8 + i] = Et[a, i]
    return Ug, Vg, EW


@_jit_inline
def _structured_factor(W: FloatArray, Et: FloatArray, Ug: FloatArray, Vg: FloatArray,
                       EW: FloatArray, t: float) -> tuple[FloatArray, bool]:  # fmt: skip
    """:func:`stackik._compiled.linalg.semisep_factor` of ``Z^T (W + t I) Z`` (the
    reduced Hessian, shifted) from :func:`_reduced_generators`' ``Ug``, ``Vg`` (whose
    columns 5-7 it fills for ``t``) and ``EW``."""
    K = W.shape[0] - 3
    nb = K // 3
    for a in range(K):
        for i in range(3):  # (X M)[a] = (E^T (W11 + t I) + W21, E^T)
            Vg[a, 5 + i] = EW[a, i] + t * Et[a, i] + W[3 + a, i]
    Ad = np.empty((nb, 3, 3))
    for b in range(nb):
        for i in range(3):
            a = 3 * b + i
            for j in range(i + 1):
                e = 3 * b + j
                acc = W[3 + a, 3 + e]
                for p in range(3):  # X_a M X_e^T
                    acc += Ug[a, 5 + p] * Vg[e, 5 + p] + Ug[a, 8 + p] * Vg[e, 8 + p]
                if i == j:
                    acc += t
                Ad[b, i, j] = acc
    return semisep_factor(Ad, Ug, Vg)


@_jit_inline
def _null_space(AE: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``Binv, E, Et``: the inverse of ``AE``'s first three columns ``B`` and the dependent
    part ``E = -B^-1 C`` (3, K) of the null-space basis ``Z = [E; I]`` and its transpose."""
    K = AE.shape[1] - 3
    Binv = _inv3(AE[:, :3])
    # explicit loops: the inner dimension is 3, where BLAS calls cost more than the arithmetic
    E = np.empty((3, K))
    for i in range(3):
        for a in range(K):
            E[i, a] = -(Binv[i, 0] * AE[0, 3 + a] + Binv[i, 1] * AE[1, 3 + a]
                        + Binv[i, 2] * AE[2, 3 + a])  # fmt: skip
    return Binv, E, E.T.copy()


@_jit
def _structured_kkt_factor(W: FloatArray, AE: FloatArray, P: Any, last_shift: float,
                           try_plain: bool) -> tuple[Any, float]:  # fmt: skip
    """:func:`_kkt_factor` by the chain's structure (:func:`_chain_generators`,
    :func:`_structured_factor`): ``(Binv, E, Et, L, G)`` with ``L`` empty and the
    structured factor ``G``, and the dense factor's shifts (the same schedule, and the
    same end of it: the largest diagonal entry of the reduced Hessian). Where the schedule
    ends without a factor (a shift above ``1e20`` times that entry) ``G`` is incomplete and
    the step is not finite, so the run ends (``IP_NONFINITE``); the dense factor takes a
    step from a matrix that is not a factor there."""
    Binv, E, Et = _null_space(AE)
    U5, V5 = _chain_generators(W, AE, P)
    Ug, Vg, EW = _reduced_generators(W, Et, U5, V5)
    K = W.shape[0] - 3
    shift = 0.0
    ok = False
    if try_plain or not last_shift > 0.0:
        G, ok = _structured_factor(W, Et, Ug, Vg, EW, 0.0)
    if not ok:
        scale = 0.0  # max |Hz_aa|, Hz = Z^T W Z: W22 + E^T W21^T + W21 E + E^T W11 E
        for a in range(K):
            acc = W[3 + a, 3 + a]
            for i in range(3):
                acc += 2.0 * Et[a, i] * W[3 + a, i]
                for j in range(3):
                    acc += Et[a, i] * W[i, j] * Et[a, j]
            scale = max(scale, abs(acc))
        shift, grow = first_shift(last_shift)
        for _ in range(SHIFT_TRIES):
            G, ok = _structured_factor(W, Et, Ug, Vg, EW, shift)
            if ok or shift_given_up(shift, scale):
                break
            shift *= grow
    return (Binv, E, Et, np.empty((0, 0)), G), shift


@_jit_internal
def _structured_step(P: Any, W: FloatArray, AE: FloatArray, cE: FloatArray, rhs: FloatArray,
                     last_shift: float, try_plain: bool) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_structured_kkt_factor`, then :func:`_kkt_solve`: the barrier loop's KKT step
    where :func:`_chained` (from :func:`_partial_hessian`'s ``W``)."""
    fac, shift = _structured_kkt_factor(W, AE, P, last_shift, try_plain)
    return _kkt_solve(fac, W, cE, rhs, shift), shift, fac


@_jit_inline
def _kkt_factor(W: FloatArray, AE: FloatArray, last_shift: float,
                try_plain: bool) -> tuple[Any, float]:  # fmt: skip
    """The factor of :func:`_kkt_step`'s null-space method: ``(Binv, E, Et, L, G)`` (the
    inverse of ``AE``'s first three columns, the dependent part of ``Z`` and its
    transpose, the reduced Hessian's Cholesky factor; ``G`` empty: the structured factor
    of :func:`_structured_kkt_factor`) and the shift; every step with the same ``W`` and
    ``AE`` is then :func:`_kkt_solve`."""
    Binv, E, Et = _null_space(AE)
    K = W.shape[0] - 3
    # Hz = Z^T W Z = E^T M[:3] + M[3:] with M = W Z (N, K) = W[:, :3] E + W[:, 3:]: its
    # first three rows stored, the others formed where Hz needs them, and only Hz's lower
    # triangle (what the Cholesky factor reads): the same numbers, 10 instead of 16 us at
    # n = 64, where one factorisation costs about 17 times that (docs/benchmarks.md)
    M3 = np.empty((3, K))
    for i in range(3):
        w0 = W[i, 0]
        w1 = W[i, 1]
        w2 = W[i, 2]
        for a in range(K):
            M3[i, a] = w0 * E[0, a] + w1 * E[1, a] + w2 * E[2, a] + W[i, 3 + a]
    Hz = np.zeros((K, K))
    for a in range(K):
        w0 = W[3 + a, 0]
        w1 = W[3 + a, 1]
        w2 = W[3 + a, 2]
        e0 = E[0, a]
        e1 = E[1, a]
        e2 = E[2, a]
        for b in range(a + 1):
            m = w0 * E[0, b] + w1 * E[1, b] + w2 * E[2, b] + W[3 + a, 3 + b]
            Hz[a, b] = e0 * M3[0, b] + e1 * M3[1, b] + e2 * M3[2, b] + m
    # inertia correction as in IPOPT: the smallest shift (tried in factors of 8, from a third
    # of the last one) making the reduced Hessian positive definite; unlike IPOPT, no
    # unshifted attempt right after a shifted step (try_plain; docs/benchmarks.md)
    shift = 0.0
    ok = False
    if try_plain or not last_shift > 0.0:  # else L comes from the loop below
        L, ok = _cholesky(Hz, 0.0)
    if not ok:
        scale = 0.0
        for i in range(Hz.shape[0]):
            scale = max(scale, abs(Hz[i, i]))
        ZtZ = Et @ E  # the shift is delta I in x-space: Z^T (W + delta I) Z
        for i in range(ZtZ.shape[0]):
            ZtZ[i, i] += 1.0
        shift, grow = first_shift(last_shift)
        for _ in range(SHIFT_TRIES):
            L, ok = _cholesky_plus(Hz, ZtZ, shift)
            if ok or shift_given_up(shift, scale):
                break
            shift *= grow
    return (Binv, E, Et, L, np.empty((0, 0))), shift


@_jit_inline
def _kkt_solve(fac: Any, W: FloatArray, cE: FloatArray, rhs: FloatArray,
               shift: float) -> FloatArray:  # fmt: skip
    """``dx`` of ``[W + shift I, -AE^T; AE 0] [dx; dy] = [rhs; -cE]`` from
    :func:`_kkt_factor`'s factor ``fac`` (of ``W`` and ``AE``) and shift."""
    Binv, E, Et, L, G = fac
    N = W.shape[0]
    K = N - 3
    dxp = np.empty(3)  # the particular part: -B^-1 cE
    for i in range(3):
        dxp[i] = -(Binv[i, 0] * cE[0] + Binv[i, 1] * cE[1] + Binv[i, 2] * cE[2])
    # rz = Z^T (rhs - W[:, :3] dxp)
    res = np.empty(N)
    for i in range(N):
        res[i] = rhs[i] - (W[i, 0] * dxp[0] + W[i, 1] * dxp[1] + W[i, 2] * dxp[2])
    rz = np.empty(K)
    for a in range(K):
        rz[a] = E[0, a] * res[0] + E[1, a] * res[1] + E[2, a] * res[2] + res[3 + a]
    if shift > 0.0:  # the particular part sees the shifted Hessian too
        rz -= shift * (Et @ dxp)
    w = semisep_solve(G, rz) if G.shape[0] > 0 else _cho_solve(L, rz)
    dx = np.empty(N)
    for i in range(3):
        acc = dxp[i]
        for a in range(K):
            acc += E[i, a] * w[a]
        dx[i] = acc
    for a in range(K):
        dx[3 + a] = w[a]
    return dx


@_jit_inline
def _kkt_step(W: FloatArray, AE: FloatArray, cE: FloatArray, rhs: FloatArray, last_shift: float,
              try_plain: bool) -> tuple[FloatArray, FloatArray, float, float]:  # fmt: skip
    """Solve ``[W -AE^T; AE 0] [dx; dy] = [rhs; -cE]`` by a null-space method
    (:func:`_kkt_factor`, then :func:`_kkt_solve`).

    The null-space basis ``Z = [-B^-1 C; I]`` uses the first platform's three columns
    ``B`` of ``AE = [B C]`` (always invertible: a rotation and a unit angle row). When the
    reduced Hessian ``Z^T W Z`` is not positive definite, a multiple of the identity is
    added until it is (the shift), so that ``dx`` is a descent direction of the merit
    function; after a shifted step (``try_plain`` False) from ``last_shift / 3`` on, with no
    unshifted attempt. Returns ``dx``, ``dy``, the curvature ``dx^T W dx`` and the shift used.
    """
    N = W.shape[0]
    fac, shift = _kkt_factor(W, AE, last_shift, try_plain)
    dx = _kkt_solve(fac, W, cE, rhs, shift)
    Binv = fac[0]
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


@_jit_inline
def _AET_dot(AE: FloatArray, y: FloatArray) -> FloatArray:
    """``AE^T y`` for the (3, N) equality Jacobian."""
    N = AE.shape[1]
    out = np.empty(N)
    for a in range(N):
        out[a] = AE[0, a] * y[0] + AE[1, a] * y[1] + AE[2, a] * y[2]
    return out


@_jit_inline
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


# =========================================================================================
# The barrier method's kernel interface (stackik._compiled.kernel; the loop: barrier.py)
# =========================================================================================
@_jit_internal
def _kernel_evaluate(u: FloatArray, P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray,
                     wq: float) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_evaluate_ip`'s values and the point itself (what the Hessian needs)."""
    f, g, cE, AE, cI, D = _evaluate_ext(u, P, lo, hi, ug, wq)
    cA, AI = with_dense_rows(u, P, cI, D, True, P.ob_phi)
    return f, g, cE, AE, cA, AI, u


@_jit_internal
def _kernel_kkt_step(W: FloatArray, AE: FloatArray, cE: FloatArray, rhs: FloatArray,
                     last_shift: float, try_plain: bool) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_kkt_factor`, then :func:`_kkt_solve`: the step, the shift and the factor."""
    fac, shift = _kkt_factor(W, AE, last_shift, try_plain)
    return _kkt_solve(fac, W, cE, rhs, shift), shift, fac


@_jit_internal
def _kernel_kkt_solve(fac: Any, W: FloatArray, cE: FloatArray, rhs: FloatArray,
                      shift: float) -> FloatArray:  # fmt: skip
    """:func:`_kkt_solve`."""
    return _kkt_solve(fac, W, cE, rhs, shift)


@_jit_internal
def _kernel_eq_multipliers(AE: FloatArray, g: FloatArray, AItz: FloatArray) -> FloatArray:
    """:func:`_ls_multipliers`."""
    return _ls_multipliers(AE, g, AItz)


@_jit_internal
def _kernel_eq_transpose_dot(AE: FloatArray, y: FloatArray) -> FloatArray:
    """:func:`_AET_dot`."""
    return _AET_dot(AE, y)


kernel.register(
    PlanarData,
    evaluate=_kernel_evaluate,
    hessian=_lagrangian_hessian,
    kkt_step=_kernel_kkt_step,
    kkt_solve=_kernel_kkt_solve,
    eq_multipliers=_kernel_eq_multipliers,
    eq_transpose_dot=_kernel_eq_transpose_dot,
    with_fscale=_with_fscale,
    clock_period=16,  # an iteration costs ~10 us at n = 4: a clock read every 16
    chained=_chained,
    chain_hessian=_partial_hessian,
    chain_kkt_step=_structured_step,
)
