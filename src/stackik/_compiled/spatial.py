"""The spatial IK problem for the compiled interior point: evaluation with exact second
derivatives, the KKT step, and their registration with the barrier method.

The spatial problem of :class:`stackik.formulation.Problem` (scaled variables
``u = q / xs``, pose rows ``[x, y, z, yaw, pitch, roll]``, ``R = Rz Ry Rx``):

    min f(u) = (c0 + sum_a w_a |dP_ee / d angle_a|^2) / fscale
    s.t. c_E(u) = 0   (end-effector position / L, and the orientation, 6 rows)
         c_I(u) >= 0  (24 n limits, scaled by ``cs``)

is solved by the barrier method of :mod:`stackik._compiled.barrier` (IPOPT-like: slacks,
Fiacco-McCormick ``mu``, Newton steps on the perturbed KKT conditions with inertia
correction, fraction to the boundary, filter line search) through the functions this module
registers (:mod:`stackik._compiled.kernel`), here with a null-space KKT solve through the
SVD of the 6 x 6n equality Jacobian. The orientation rows are the skew part
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
from typing import Any, NamedTuple

import numpy as np
from numba.extending import overload

from stackik._compiled import kernel
from stackik._compiled.core import (
    _OVERLOAD,
    _jit,
    _jit_inline,
    _jit_internal,
    _limit_rows,
    lean_type,
    unresolved,
)
from stackik._compiled.dense_rows import (
    with_dense_rows,
)
from stackik._compiled.linalg import (
    SHIFT_TRIES,
    _cho_solve,
    _cholesky,
    _cholesky_plus,
    _mm3,
    _solve6,
    add_distance_term,
    first_shift,
    shift_given_up,
    subtract_blocks_scaled,
)
from stackik._compiled.self_legs import self_leg_hessians, self_leg_rows
from stackik._compiled.spatial_kinematics import spatial_kinematics

FloatArray = Any


def _self_leg_rows_of(P: Any, i: int, q: FloatArray, base: FloatArray, top: FloatArray,
                      c: FloatArray, J: FloatArray) -> None:  # fmt: skip
    """Platform ``i``'s self-leg rows ``c`` (m,) and Jacobian ``J`` (m, 6) in place
    (:func:`stackik._compiled.self_legs.self_leg_rows`); nothing for the lean problem data
    (:func:`stackik._compiled.core.lean_type`: no self-leg rows, never called)."""
    return unresolved()


def _self_leg_hessians_of(P: Any, q: FloatArray, base: FloatArray, top: FloatArray,
                          y: FloatArray) -> FloatArray:  # fmt: skip
    """The self-leg rows' curvature (n, 6, 6) with multipliers ``y`` (n, m)
    (:func:`stackik._compiled.self_legs.self_leg_hessians`); zeros for the lean problem
    data (never called)."""
    return unresolved()


@overload(_self_leg_rows_of, jit_options=_OVERLOAD)
def _ol_self_leg_rows_of(P, i, q, base, top, c, J):  # type: ignore[no-untyped-def]
    if lean_type(P):
        return lambda P, i, q, base, top, c, J: None

    def rows(P, i, q, base, top, c, J):  # type: ignore[no-untyped-def]
        self_leg_rows(q[i], base[i], top[i], P.pairs, P.rho[i], P.pair_scale[i], c, J)

    return rows


@overload(_self_leg_hessians_of, jit_options=_OVERLOAD)
def _ol_self_leg_hessians_of(P, q, base, top, y):  # type: ignore[no-untyped-def]
    if lean_type(P):
        return lambda P, q, base, top, y: np.zeros((q.shape[0], 6, 6))

    def curvature(P, q, base, top, y):  # type: ignore[no-untyped-def]
        return self_leg_hessians(q, base, top, P.pairs, P.pair_scale, y)

    return curvature


class SpatialData(NamedTuple):
    """The spatial problem as the kernels take it (every array read-only: one compiled
    specialisation), built by :func:`stackik.methods.ip.spatial_problem_arrays`;
    variables are scaled, ``u = q / xs``."""

    xs: Any  #: variable scales (6 n,)
    cs: Any  #: limit row scales (24 n,)
    es: Any  #: equality scales (6,)
    position: Any  #: target position (3,) [mm]
    rotation: Any  #: target rotation (3, 3)
    fscale: float  #: objective scale
    c0: float  #: objective constant
    w: Any  #: FN weights of the angle columns
    top: Any  #: top nodes (n, 6, 3) [mm]
    base: Any  #: base nodes (n, 6, 3) [mm]
    leg_min: Any  #: minimum leg lengths [mm]
    leg_max: Any  #: maximum leg lengths [mm]
    sin_joint: Any  #: sine of the minimum joint angles
    feasible: bool  #: the feasibility objective (f = 0) instead of FN^2
    pairs: Any  #: self-leg pairs (m, 2) int64 (m = 0: no self-leg rows)
    rho: Any  #: least leg-axis distance per platform (n,) [mm]
    pair_scale: Any  #: self-leg row scale per platform (n,) [mm^2]
    obstacles: Any  #: the obstacle rows' kernel arrays (ObstacleRows.kernel_args)
    ob_margin: float  #: the obstacle rows' clearance margin [mm]
    ob_L: float  #: the obstacle rows' length scale [mm]
    forces: Any  #: the force rows' kernel arrays (ForceLimits.kernel_args)
    leg_pairs: Any  #: non-adjacent leg-pair rows' kernel arguments (LegPairRows.kernel_args)
    #: number of dense rows (:mod:`stackik._compiled.dense_rows`); None where the problem
    #: has no rows beyond the limits: the lean type (:func:`stackik._compiled.core.lean_type`)
    n_dense: int | None
    families: int  #: token of the constraint families' rows (0: none; stackik.families)


# =========================================================================================
# Derivatives
# =========================================================================================


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
def fn2_hessian(Jp: FloatArray, w: FloatArray, wa: FloatArray) -> FloatArray:
    """Exact Hessian of ``sum_a wa[platform(a)] |Jp[:, a]|^2`` over the angle columns a
    (raw variables), shape (6n, 6n), from the outputs of
    :func:`stackik._compiled.spatial_kinematics.spatial_parts`.

    For ``b <= c`` it is ``2 v_b . Jp_c`` with

        v_b = A_b Jp_b + [b an angle] S_b x w_b,
        A_b = sum_{a <= b} wt_a (|w_a|^2 I - w_a w_a^T),   S_b = sum_{a <= b} wt_a Jp_a x w_a

    (sums over the angle columns a, ``wt_a`` its platform's weight): with the serial-chain
    rules ``d Jp_a / dx_b = w_lo x Jp_hi`` (zero when ``lo = min(a, b)`` translates) and
    ``d^2 Jp_a / dx_b dx_c`` (``w_i x (w_j x Jp_k)`` for sorted ``i <= j <= k``, ``i, j``
    angles), the Gauss-Newton part ``sum_a wt_a (d Jp_a / dx_b) . (d Jp_a / dx_c)`` and the
    curvature part ``sum_a wt_a Jp_a . d^2 Jp_a / dx_b dx_c`` cancel for every ``a > b``
    (``Jp_a`` is orthogonal to ``w_a``), which leaves the ``a <= b`` terms above. O(N^2),
    against the O(N^3) product ``Jr^T W Jr`` of the residuals' Jacobian."""
    N = Jp.shape[1]
    H = np.empty((N, N))
    A00 = A01 = A02 = A11 = A12 = A22 = 0.0
    S0 = S1 = S2 = 0.0
    for b in range(N):
        j0, j1, j2 = Jp[0, b], Jp[1, b], Jp[2, b]
        angle = b % 6 >= 3
        if angle:
            wt = wa[b // 6]
            w0, w1, w2 = w[b, 0], w[b, 1], w[b, 2]
            ww = w0 * w0 + w1 * w1 + w2 * w2
            A00 += wt * (ww - w0 * w0)
            A11 += wt * (ww - w1 * w1)
            A22 += wt * (ww - w2 * w2)
            A01 -= wt * w0 * w1
            A02 -= wt * w0 * w2
            A12 -= wt * w1 * w2
            S0 += wt * (j1 * w2 - j2 * w1)
            S1 += wt * (j2 * w0 - j0 * w2)
            S2 += wt * (j0 * w1 - j1 * w0)
        v0 = A00 * j0 + A01 * j1 + A02 * j2
        v1 = A01 * j0 + A11 * j1 + A12 * j2
        v2 = A02 * j0 + A12 * j1 + A22 * j2
        if angle:
            v0 += S1 * w2 - S2 * w1
            v1 += S2 * w0 - S0 * w2
            v2 += S0 * w1 - S1 * w0
        v0, v1, v2 = 2.0 * v0, 2.0 * v1, 2.0 * v2
        for c in range(b, N):
            val = v0 * Jp[0, c] + v1 * Jp[1, c] + v2 * Jp[2, c]
            H[b, c] = val
            H[c, b] = val
    return H


# =========================================================================================
# Evaluation (scaled)
# =========================================================================================
@_jit
def _evaluate(u: FloatArray, P: Any) -> tuple[Any, ...]:
    """Scaled ``f, grad f, c_E (6,), A_E (6, N), c_I (24n,), A_I blocks (n, 24, 6)`` and
    the kinematic parts the Hessian reuses."""
    xs, cs, es, p_t, R_t = P.xs, P.cs, P.es, P.position, P.rotation
    fscale, c0, wa, feasible = P.fscale, P.c0, P.w, P.feasible
    top, base, lmin, lmax, sj = P.top, P.base, P.leg_min, P.leg_max, P.sin_joint
    n = top.shape[0]
    N = 6 * n
    q = (u * xs).reshape(n, 6)
    Pee, Ree, Jp, w, c, Jc = spatial_kinematics(q, top, base, lmin, lmax, sj)
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
    mp = P.pairs.shape[0]
    if mp == 0:
        cI = c.ravel() * cs
        D = np.empty((n, 24, 6))
        for i in range(n):
            for rr in range(24):
                for k in range(6):
                    D[i, rr, k] = Jc[i, rr, k] * cs[24 * i + rr] * xs[6 * i + k]
    else:  # each platform's 24 limits, then its self-leg rows
        R = 24 + mp
        cI = np.empty(R * n)
        D = np.empty((n, R, 6))
        cs_ = np.empty(mp)
        Js = np.empty((mp, 6))
        for i in range(n):
            for rr in range(24):
                cI[R * i + rr] = c[i, rr] * cs[24 * i + rr]
                for k in range(6):
                    D[i, rr, k] = Jc[i, rr, k] * cs[24 * i + rr] * xs[6 * i + k]
            _self_leg_rows_of(P, i, q, base, top, cs_, Js)
            for rr in range(mp):
                cI[R * i + 24 + rr] = cs_[rr]
                for k in range(6):
                    D[i, 24 + rr, k] = Js[rr, k] * xs[6 * i + k]
    g = np.zeros(N)
    parts = (q, Ree, Jp, w)
    if feasible:
        return 0.0, g, cE, AE, cI, D, parts
    # FN^2 = sum over the angle columns a of wt_a |Jp_a|^2, its gradient
    # 2 Jp_b . S_b with S_b = sum_{a <= b} wt_a Jp_a x w_a (d Jp_a / dx_b = w_a x Jp_b for
    # a <= b; for a > b it is w_b x Jp_a, orthogonal to Jp_a: :func:`fn2_hessian`)
    acc = 0.0
    S0 = S1 = S2 = 0.0
    for b in range(N):
        j0, j1, j2 = Jp[0, b], Jp[1, b], Jp[2, b]
        if b % 6 >= 3:
            wt = wa[b // 6]
            acc += wt * j0 * j0
            acc += wt * j1 * j1
            acc += wt * j2 * j2
            S0 += wt * (j1 * w[b, 2] - j2 * w[b, 1])
            S1 += wt * (j2 * w[b, 0] - j0 * w[b, 2])
            S2 += wt * (j0 * w[b, 1] - j1 * w[b, 0])
        g[b] = 2.0 * (j0 * S0 + j1 * S1 + j2 * S2) * xs[b] / fscale
    return (c0 + acc) / fscale, g, cE, AE, cI, D, parts


@_jit
def evaluate(u: FloatArray, P: Any) -> tuple[Any, ...]:
    """Scaled ``f, grad f, c_E (6,), A_E (6, N), c_I (24n,), A_I blocks (n, 24, 6)``."""
    f, g, cE, AE, cI, D, parts = _evaluate(u, P)
    return f, g, cE, AE, cI, D


@_jit_inline
def _evaluate_ext(u: FloatArray, P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray,
                  wq: float) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_evaluate` with a path step's extensions: ``wq |u - ug|^2`` added to the
    objective (when ``wq > 0``) and, when ``lo`` is not empty, the box ``lo <= u <= hi``
    as 12 more limit rows per platform (rows 24-29: ``u - lo``, 30-35: ``hi - u``):
    ``c_I`` (36 n,), ``D`` (n, 36, 6). Without extensions, :func:`_evaluate`'s values."""
    f, g, cE, AE, cI, D, parts = _evaluate(u, P)
    f = add_distance_term(f, g, u, ug, wq)
    if lo.size == 0:
        return f, g, cE, AE, cI, D, parts
    n = D.shape[0]
    R0 = D.shape[1]  # 24 limits (and the self-leg rows)
    R = R0 + 12
    cB = np.empty(R * n)
    DB = np.zeros((n, R, 6))
    for i in range(n):
        for r in range(R0):
            cB[R * i + r] = cI[R0 * i + r]
            for k in range(6):
                DB[i, r, k] = D[i, r, k]
        for k in range(6):
            cB[R * i + R0 + k] = u[6 * i + k] - lo[6 * i + k]
            cB[R * i + R0 + 6 + k] = hi[6 * i + k] - u[6 * i + k]
            DB[i, R0 + k, k] = 1.0
            DB[i, R0 + 6 + k, k] = -1.0
    return f, g, cE, AE, cB, DB, parts


@_jit_internal
def _kernel_evaluate(u: FloatArray, P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray,
                     wq: float) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_evaluate_ext` with the dense rows (:mod:`stackik._compiled.dense_rows`):
    ``c_I`` the block rows then the dense rows, and the pair ``AI = (D, JD)`` in place of
    ``D`` (``D`` itself for the lean problem data: :func:`stackik._compiled.core.lean_type`)."""
    f, g, cE, AE, cI, D, parts = _evaluate_ext(u, P, lo, hi, ug, wq)
    cA, AI = with_dense_rows(u, P, cI, D, False, 0.0)
    return f, g, cE, AE, cA, AI, parts


@_jit
def _evaluate_ip(u: FloatArray, P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray,
                 wq: float) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_kernel_evaluate` called from Python (the tests)."""
    return _kernel_evaluate(u, P, lo, hi, ug, wq)


@_jit
def lagrangian_hessian_ext(u: FloatArray, yE: FloatArray, z: FloatArray, P: Any,
                           lo: FloatArray, hi: FloatArray, ug: FloatArray,
                           wq: float) -> FloatArray:  # fmt: skip
    """:func:`_hessian` at ``u`` with a path step's extensions (for the tests)."""
    return _hessian(_evaluate_ext(u, P, lo, hi, ug, wq)[6], yE, z, P, wq)


@_jit
def lagrangian_hessian(u: FloatArray, yE: FloatArray, z: FloatArray, P: Any) -> FloatArray:
    """Hessian of ``f - yE.c_E - z.c_I`` in scaled variables, shape (6n, 6n); ``z`` has
    :func:`evaluate`'s rows (24 limits, then the self-leg rows, per platform)."""
    return _hessian(_evaluate(u, P)[6], yE, z, P, 0.0)


@_jit
def _hessian(parts: Any, yE: FloatArray, z: FloatArray, P: Any, wq: float) -> FloatArray:
    """:func:`lagrangian_hessian` from the kinematic parts of :func:`_evaluate` (or of
    :func:`_evaluate_ext`: ``z`` then has ``R n`` multipliers, the box's 12 rows a platform
    last; they are linear, and the distance term adds ``2 wq I``). One compiled function
    for the barrier loop (the kernel interface's Hessian), the SQP method and the path
    kernels: a thin layer of its own would compile it again."""
    n = P.top.shape[0]
    z = _limit_rows(z, n, 24 + P.pairs.shape[0])
    xs, cs, es, R_t = P.xs, P.cs, P.es, P.rotation
    fscale, wa, feasible = P.fscale, P.w, P.feasible
    top, base, sj = P.top, P.base, P.sin_joint
    q, Ree, Jp, w = parts
    N = 6 * n
    if feasible:
        H = np.zeros((N, N))
    else:
        H = fn2_hessian(Jp, w, wa) / fscale
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
    mp = P.pairs.shape[0]
    if mp == 0:
        Hb = limit_hessians(q, (z * cs).reshape(n, 24), top, base, sj)
    else:
        zz = z.reshape(n, 24 + mp)
        Hb = limit_hessians(q, zz[:, :24] * cs.reshape(n, 24), top, base, sj)
        Hb += _self_leg_hessians_of(P, q, base, top, zz[:, 24:].copy())
    H = subtract_blocks_scaled(H, Hb, xs)
    if wq > 0.0:
        for a in range(N):
            H[a, a] += 2.0 * wq
    return H


# =========================================================================================
# Linear algebra
# =========================================================================================


@_jit
def _basis(AE: FloatArray) -> tuple[Any, ...]:
    """A null-space basis ``Z`` (N, K) of the 6 x N equality Jacobian: ``Z = [-B^-1 C; I]``
    from the first platform's six columns ``B`` (a translation block and three rotation
    axes: invertible away from gimbal lock; ``structured`` True), else an orthonormal basis
    from the SVD. Returns ``Z, Binv, Ut, S, Vt, rank, structured`` (``B^-1`` or the SVD
    of ``AE``, ``U`` transposed, and its rank: what :func:`_particular` needs; the other
    part empty)."""
    N = AE.shape[1]
    K = N - 6
    Binv, ok = _solve6(AE[:, :6].copy())
    none = np.empty((0, 0))
    if ok:
        Z = np.zeros((N, K))
        for i in range(6):
            for a in range(K):
                acc = 0.0
                for j in range(6):
                    acc -= Binv[i, j] * AE[j, 6 + a]
                Z[i, a] = acc
        for a in range(K):
            Z[6 + a, a] = 1.0
        return Z, Binv, none, np.empty(0), none, 0, True
    U, S, Vt = np.linalg.svd(AE)
    rank = 0
    for k in range(6):
        if S[k] > 1e-10 * S[0]:
            rank += 1
    # C order (one array type for both returns): ``Ut[k]`` is ``U``'s column k, contiguous
    return (
        Vt[rank:].T.copy(),
        Binv,
        np.ascontiguousarray(U.T),
        S,
        np.ascontiguousarray(Vt),
        rank,
        False,
    )


@_jit_inline
def _particular(fac: Any, cE: FloatArray, N: int) -> FloatArray:
    """The particular step ``dxp`` (N,) with ``AE dxp = -cE`` of :func:`_basis`'s data
    (in ``fac``, :func:`_kkt_factor`'s): ``-B^-1 cE`` in the first six coordinates, else
    the least-norm solution from the SVD."""
    _, _, Binv, Ut, S, Vt, rank, structured = fac
    dxp = np.zeros(N)
    if structured:
        for i in range(6):
            acc = 0.0
            for j in range(6):
                acc -= Binv[i, j] * cE[j]
            dxp[i] = acc
        return dxp
    for k in range(rank):
        coef = -(Ut[k] @ cE) / S[k]
        for a in range(N):
            dxp[a] += coef * Vt[k, a]
    return dxp


@_jit_inline
def _kkt_factor(W: FloatArray, AE: FloatArray, last_shift: float,
                try_plain: bool) -> tuple[Any, float]:  # fmt: skip
    """The factor of :func:`_kkt_step`'s null-space method (:func:`_basis`): ``(Z, L,
    Binv, Ut, S, Vt, rank, structured)`` with the reduced Hessian's Cholesky factor ``L``,
    made positive definite by adding ``delta I`` to ``W`` (IPOPT's inertia correction;
    ``try_plain`` False: the previous step needed a shift, the unshifted factorisation is
    skipped, as in the planar kernel's :func:`stackik._compiled.planar._kkt_factor`), and
    the shift; every step with the same ``W`` and ``AE`` is then :func:`_kkt_solve`."""
    Z, Binv, Ut, S, Vt, rank, structured = _basis(AE)
    N = W.shape[0]
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
        for j in range(6):
            for a in range(K):
                ea = E[j, a]
                if ea != 0.0:
                    for b in range(K):
                        Hz[a, b] += ea * WZ[j, b]
    else:
        WZ = W @ Z
        Hz = Z.T @ WZ
    K = Hz.shape[0]
    shift = 0.0
    ok = False
    if try_plain or not last_shift > 0.0:  # else L comes from the loop below
        L, ok = _cholesky(Hz, 0.0)
    if not ok:
        scale = 0.0
        for i in range(K):
            scale = max(scale, abs(Hz[i, i]))
        # the shift is delta I in x-space: Z^T (W + delta I) Z
        if structured:  # Z^T Z = E^T E + I (lower triangle: all the factor reads)
            E = Z[:6]
            ZtZ = np.zeros((K, K))
            for a in range(K):
                ZtZ[a, a] = 1.0
                for b in range(a + 1):
                    acc = 0.0
                    for j in range(6):
                        acc += E[j, a] * E[j, b]
                    ZtZ[a, b] += acc
        else:
            ZtZ = Z.T @ Z
        shift, grow = first_shift(last_shift)
        for _ in range(SHIFT_TRIES):
            L, ok = _cholesky_plus(Hz, ZtZ, shift)
            if ok or shift_given_up(shift, scale):
                break
            shift *= grow
    return (Z, L, Binv, Ut, S, Vt, rank, structured), shift


@_jit_inline
def _kkt_solve(fac: Any, W: FloatArray, cE: FloatArray, rhs: FloatArray,
               shift: float) -> FloatArray:  # fmt: skip
    """``dx`` of ``[W + shift I, -AE^T; AE 0] [dx; dy] = [rhs; -cE]`` from
    :func:`_kkt_factor`'s factor ``fac`` (of ``W`` and ``AE``) and shift."""
    Z, L = fac[0], fac[1]
    N = W.shape[0]
    dxp = _particular(fac, cE, N)
    res = rhs - W @ dxp
    if fac[7]:  # structured, Z = [E; I]
        K = N - 6
        rz = res[6:].copy()
        for j in range(6):
            for a in range(K):
                ea = Z[j, a]
                if ea != 0.0:
                    rz[a] += ea * res[j]
    else:
        rz = Z.T @ res
    if shift > 0.0:  # the particular part sees the shifted Hessian too
        rz -= shift * (Z.T @ dxp)
    wz = _cho_solve(L, rz)
    return dxp + Z @ wz


@_jit_inline
def _kkt_step(W: FloatArray, AE: FloatArray, cE: FloatArray, rhs: FloatArray,
              last_shift: float, try_plain: bool) -> tuple[Any, ...]:  # fmt: skip
    """Solve ``[W -AE^T; AE 0] [dx; dy] = [rhs; -cE]`` for ``dx`` by a null-space method
    (:func:`_kkt_factor`, then :func:`_kkt_solve`); returns ``dx``, the shift and the
    factor (for :func:`_kkt_solve` with other ``cE`` and ``rhs``)."""
    fac, shift = _kkt_factor(W, AE, last_shift, try_plain)
    return _kkt_solve(fac, W, cE, rhs, shift), shift, fac


@_jit_inline
def _ls_multipliers(AE: FloatArray, g: FloatArray, AItz: FloatArray) -> FloatArray:
    """Least-squares equality multipliers ``argmin |g - AI^T z - AE^T y|``."""
    G = AE @ AE.T
    for k in range(G.shape[0]):
        G[k, k] += 1e-14 * (1.0 + G[k, k])
    return np.linalg.solve(G, AE @ (g - AItz))


# =========================================================================================
# The problem data with another objective scale or target
# =========================================================================================
@_jit_internal
def _with_fscale(P0: Any, fscale: float) -> Any:
    """``P0`` with the objective scale ``fscale``."""
    return SpatialData(P0.xs, P0.cs, P0.es, P0.position, P0.rotation, fscale, P0.c0, P0.w,
                       P0.top, P0.base, P0.leg_min, P0.leg_max, P0.sin_joint,
                       P0.feasible, P0.pairs, P0.rho, P0.pair_scale, P0.obstacles,
                       P0.ob_margin, P0.ob_L, P0.forces, P0.leg_pairs,
                       P0.n_dense, P0.families)  # fmt: skip


@_jit
def _with_target(P0: Any, position: Any, rotation: Any) -> Any:
    """``P0`` with the target ``position`` (3,) [mm] and ``rotation`` (3, 3)."""
    return SpatialData(P0.xs, P0.cs, P0.es, position, rotation, P0.fscale, P0.c0, P0.w,
                       P0.top, P0.base, P0.leg_min, P0.leg_max, P0.sin_joint,
                       P0.feasible, P0.pairs, P0.rho, P0.pair_scale, P0.obstacles,
                       P0.ob_margin, P0.ob_L, P0.forces, P0.leg_pairs,
                       P0.n_dense, P0.families)  # fmt: skip


# =========================================================================================
# The barrier method's kernel interface (stackik._compiled.kernel; the loop: barrier.py)
# =========================================================================================
@_jit_internal
def _kernel_kkt_step(W: FloatArray, AE: FloatArray, cE: FloatArray, rhs: FloatArray,
                     last_shift: float, try_plain: bool) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_kkt_step`."""
    return _kkt_step(W, AE, cE, rhs, last_shift, try_plain)


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
    """``AE^T y`` by BLAS (the (6, N) equality Jacobian)."""
    return AE.T @ y


kernel.register(
    SpatialData,
    evaluate=_kernel_evaluate,
    hessian=_hessian,
    kkt_step=_kernel_kkt_step,
    kkt_solve=_kernel_kkt_solve,
    eq_multipliers=_kernel_eq_multipliers,
    eq_transpose_dot=_kernel_eq_transpose_dot,
    with_fscale=_with_fscale,
    clock_period=8,  # an iteration costs ~0.1-0.6 ms at n = 4-16
    chained=0,  # no structured step: the dense one
    chain_hessian=_hessian,
    chain_kkt_step=_kernel_kkt_step,
)
