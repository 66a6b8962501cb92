"""Compiled path kernels for planar targets: the continuation (predictor-corrector) step
and many warm steps along a run of targets in one call (:func:`ip_path`), on the planar
evaluation of :mod:`stackik._compiled.planar` and the barrier method of
:mod:`stackik._compiled.barrier`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from stackik._compiled import kernel
from stackik._compiled.barrier import ip_multi, polish, polished
from stackik._compiled.core import (
    IP_NONFINITE,
    IP_SUCCESS,
    _amin,
    _finite,
    _jit,
    _jit_inline,
    no_dense_rows,
)
from stackik._compiled.linalg import _AIT_dot, _lu_solve, min_norm_solve
from stackik._compiled.path import (
    PC_CHANGES,
    PC_DEPENDENT,
    PC_NEWTON,
    PC_OFFSET,
    _merge_twins,
    _pc_change,
    _pc_errors,
    _pc_start,
    _pc_verdict,
    _release,
)
from stackik._compiled.planar import (
    _AET_dot,
    _evaluate,
    _lagrangian_hessian,
    _with_target,
)

FloatArray = Any


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


@_jit_inline
def _pc_span(D: FloatArray, idx: FloatArray, rA: FloatArray,
             n: int) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_pc_kkt`'s first part, by platforms: the part ``dxp`` (N,) of ``dx`` in the
    span of each platform's active rows (``AA dx = rA`` there), the orthonormal free
    directions ``Z`` (3, nz) and their platforms ``zp``, and each platform's basis ``Qs``
    (n, 3, 3) of the span, of rank ``rk``. Returns ``dxp, Z, zp, nz, Qs, rk``."""
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
    return dxp, Z, zp, nz, Qs, rk


@_jit_inline
def _pc_reduced(W: FloatArray, AE: FloatArray, r1: FloatArray, r2: FloatArray,
                dxp: FloatArray, Z: FloatArray, zp: FloatArray,
                nz: int) -> tuple[FloatArray, FloatArray, bool]:  # fmt: skip
    """:func:`_pc_kkt`'s second part: ``dx = dxp + Z v`` and ``dy`` from the reduced system
    in ``(v, dy)``. Returns ``dx, dy, ok`` (``ok`` False: singular)."""
    N = W.shape[0]
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
    if not ok:
        return dx, dy, False
    for c in range(nz):
        b0 = 3 * zp[c]
        for t in range(3):
            dx[b0 + t] += Z[t, c] * sol[c]
    for r in range(3):
        dy[r] = sol[nz + r]
    return dx, dy, True


@_jit_inline
def _pc_multipliers(W: FloatArray, AE: FloatArray, D: FloatArray, idx: FloatArray,
                    r1: FloatArray, dx: FloatArray, dy: FloatArray, Qs: FloatArray,
                    rk: FloatArray, n: int) -> tuple[FloatArray, bool]:  # fmt: skip
    """:func:`_pc_kkt`'s last part: each platform's least-norm ``dz`` of its active rows'
    part of the first equation. Returns ``dz, ok`` (``ok`` False: a rank-deficient
    platform, which the span ruled out)."""
    N = 3 * n
    na = idx.size
    dz = np.zeros(na)
    rows = np.empty(max(na, 1), dtype=np.int64)
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
                    return dz, False
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
    return dz, True


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
    dxp, Z, zp, nz, Qs, rk = _pc_span(D, idx, rA, n)
    dx, dy, ok = _pc_reduced(W, AE, r1, r2, dxp, Z, zp, nz)
    if not ok:
        return dx, dy, np.zeros(idx.size), False
    dz, ok = _pc_multipliers(W, AE, D, idx, r1, dx, dy, Qs, rk, n)
    return dx, dy, dz, ok


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
    :func:`ip_loop` scales them, objective scaling included) are within ``tol`` and
    the equality and active-limit residuals within ``min(constr_tol, PC_PRIMAL_TOL)``
    (:func:`ip_loop`'s termination test, the residuals tighter so that the polish has
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
    n = P0.tf.shape[0]
    N = 3 * n
    m = 24 * n
    f, g, cE, AE, cI, D = _evaluate(x0, P0)
    # zf: the full multipliers; only the rows of the Newton system are used
    fs, P, g, x, yE, zf, act, new = _pc_start(x0, P0, g, yE0, z0, active, m)
    ok, it, changes = False, 0, 0
    while True:
        parent = _merge_twins(act, cI, D, zf, m)
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
            e_du, e_pr, comp, sd = _pc_errors(rd, yE, zA, cE, cI, idx, idx, m)
            verdict, err = _pc_verdict(e_du, e_pr, comp, sd, tol, constr_tol, it, max_newton,
                                       inner, err_prev)  # fmt: skip
            conv = verdict == 1
            if verdict != 0:
                break
            err_prev = err
            inner += 1
            it += 1
            W = _lagrangian_hessian(x, yE, zf, P, 0.0)
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
        ok, changed = _pc_change(act, new, zf, parent, idx, zA, cI, m, changes, max_changes)
        if not changed:
            break
        changes += 1
    return x, ok, yE / fs, zf / fs, act, it, cE, cI


@_jit_inline
def _reaches(xn: FloatArray, x: FloatArray, P: Any, jump: FloatArray, pos_tol: float,
             ang_tol: float) -> bool:  # fmt: skip
    """Whether the polished point ``xn`` reaches ``P``'s target (``pos_tol`` [mm],
    ``ang_tol`` [rad], from the scaled equalities), violates no limit nor dense row
    (scaled) and moves no variable from ``x`` by more than ``jump`` (scaled, per
    variable)."""
    none = np.empty(0)
    f, g, cE, AE, cI, _, _ = kernel.evaluate(xn, P, none, none, none, 0.0)
    return _reaches_at(xn, x, cE, cI, P.es, jump, pos_tol, ang_tol)


@_jit
def _reaches_at(xn: FloatArray, x: FloatArray, cE: FloatArray, cI: FloatArray,
                es: FloatArray, jump: FloatArray, pos_tol: float,
                ang_tol: float) -> bool:  # fmt: skip
    """:func:`_reaches` with the constraint values at ``xn`` given (``es``: the
    equalities' scales)."""
    if not (math.hypot(cE[0] / es[0], cE[1] / es[1]) <= pos_tol
            and abs(cE[2] / es[2]) <= ang_tol and _amin(cI) >= -1e-12):  # fmt: skip
        return False
    for a in range(x.size):
        if not abs(xn[a] - x[a]) <= jump[a]:
            return False
    return True


#: A point with no multipliers (the first of a run that carries none): limits closer than
#: this (scaled) are its active set, and least-squares multipliers start the continuation
#: step (:func:`_ls_state`) instead of a barrier solve.
PC_ACTIVE_GUESS = 1e-6


@_jit_inline
def _ls_state(x: FloatArray, P: Any) -> tuple[FloatArray, FloatArray, FloatArray]:
    """A continuation step's start state at a point that has none: the limits within
    PC_ACTIVE_GUESS of their bound as the active set and the least-squares multipliers of
    the equalities and those limits (``min |g - AE^T yE - AA^T zA|``; multipliers of
    ``P``'s problem, as :func:`ip_loop` returns them). The target enters only ``c_E``:
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
    lam = min_norm_solve(A, g)
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

    With ``pc`` False every step is :func:`ip_loop` with initial barrier ``mu0`` and
    :func:`polish`, exactly as :func:`stackik._compiled.barrier.ip_multi` with that one
    start. With ``pc`` True a step is first the predictor-corrector step
    (:func:`_pc_step`: the previous solution's multipliers and active set carried, Newton
    correctors, verified as a KKT point), polished and tested as below; when it is not
    verified or fails the test, the
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
    # the barrier solve of one start (ip_multi; no polish, no ranking: the arguments typed
    # as from Python, int64 and bool, not literals, so that the solver's specialisation
    # serves)
    mu0a = np.array([mu0])
    far = np.full(N, np.inf)
    x = u0.copy()
    have = have0  # the state of u0 (multipliers, active set) when it is a solved point
    yE = yE0.copy()
    z = z0.copy()
    active = act0.copy()
    es = P0.es
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
        P = _with_target(P0, yt)
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
                # values at xn when the polish would not move it (they have the block
                # rows only: with dense rows, the polish and test see them too)
                if no_dense_rows(P) and polished(cEn, cIn, reach):
                    good = _reaches_at(xn, x, cEn, cIn, es, jump, pos_tol, ang_tol)
                else:
                    xn = polish(xn, P, 3, reach, margin)
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
        Xn, stn, _, _, _, s1, z1, yE1 = ip_multi(
            x.copy().reshape(1, -1), P, tol, constr_tol, mu0a, max_iter, 1e300,
            np.int64(0), reach, margin, none, none, none, 0.0,  # type: ignore[arg-type]
            np.bool_(False),  # type: ignore[arg-type]
        )  # fmt: skip
        xn, st = Xn[0], stn[0]
        if st == IP_NONFINITE or not _finite(xn):
            hist = _hist(known, cur_ok, xprev, yprev, ycur, known2, x2, y2, pcrun, yEp, zp,
                         actp, yE2, z2, act2)  # fmt: skip
            return X, k, how, yE, z, active, have, hist
        xn = polish(xn, P, 3, reach, margin)
        f, g, cE, AE, cI, _, _ = kernel.evaluate(xn, P, none, none, none, 0.0)
        if not _reaches_at(xn, x, cE, cI, es, jump, pos_tol, ang_tol):
            if _reaches_at(xn, x, cE, cI, es, far, pos_tol, ang_tol):
                how[k] = -1  # a pose of the target farther than jump: it left its basin
            hist = _hist(known, cur_ok, xprev, yprev, ycur, known2, x2, y2, pcrun, yEp, zp,
                         actp, yE2, z2, act2)  # fmt: skip
            return X, k, how, yE, z, active, have, hist
        X[k] = xn
        x2, y2, known2 = xprev, yprev, known
        xprev, yprev, ycur, known, cur_ok = x, ycur, yt.copy(), cur_ok, True
        # the continuation step has the limit rows only (the dense rows are last)
        x, yE, z = xn, yE1, z1[:M].copy()
        active = z > s1[:M]
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
