"""Compiled path kernels for spatial targets: :mod:`stackik._compiled.planar_path`'s
continuation step and run of warm steps (:func:`ip_path`) on the spatial evaluation and
barrier method of :mod:`stackik._compiled.barrier` on the spatial evaluation of
:mod:`stackik._compiled.spatial` (6 variables a platform).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from stackik._compiled import kernel
from stackik._compiled.barrier import ip_multi, polish
from stackik._compiled.core import IP_NONFINITE, IP_SUCCESS, _amin, _jit, _jit_inline
from stackik._compiled.linalg import _AIT_dot
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
from stackik._compiled.spatial import _evaluate, _hessian, _with_target

FloatArray = Any


@_jit
def _dependent(D: FloatArray, idx: FloatArray) -> FloatArray:
    """Mask of the rows ``idx`` (sorted active limit rows) that depend on the others of
    their platform: per platform, Gram-Schmidt on its rows ``D[i, r % R]`` taking the row
    with the largest remaining part first; rows left with less than PC_DEPENDENT of their
    length are dependent (at most 6 rows a platform are independent)."""
    k = idx.size
    R = D.shape[1]  # rows a platform
    dep = np.ones(k, dtype=np.bool_)
    Q = np.zeros((6, 6))
    v = np.empty(6)
    j0 = 0
    while j0 < k:
        i = idx[j0] // R
        j1 = j0
        while j1 < k and idx[j1] // R == i:
            j1 += 1
        rank = 0
        while rank < 6:
            best = -1
            bn = 0.0
            for j in range(j0, j1):
                if not dep[j]:
                    continue
                a = D[i, idx[j] % R]
                v[:] = a
                for s in range(rank):
                    v -= (a @ Q[s]) * Q[s]
                nv = math.sqrt(v @ v)
                if nv > PC_DEPENDENT * math.sqrt(a @ a) and nv > bn:
                    best = j
                    bn = nv
            if best < 0:
                break
            v[:] = D[i, idx[best] % R]
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
    """The continuation step of :func:`stackik._compiled.planar_path._pc_step` for the spatial
    problem (6 equalities, 6 variables per platform): Newton on the KKT conditions with the
    active limits held at ``PC_OFFSET``, the first iteration the tangent predictor, the
    active set corrected (most negative multiplier released, else violated or nearly met
    limits added), and verified as a KKT point to the barrier solve's tolerances. Active
    rows that depend on others of their platform (:func:`_dependent`: where more limits
    meet than the platform has variables, e.g. a leg's base and top joint limits at
    parallel plates) stay active with multiplier 0, out of the Newton system (which is
    singular with them) and take no freedom; while the independent rows exceed the
    freedom ``N - 6`` the weakest goes, not one the last change added
    (:func:`_weakest`). Returns ``(x, ok, yE, z, active, iterations)``."""
    n = P0.top.shape[0]
    N = 6 * n
    # (the kinematic parts: the Hessian at x reuses those of its evaluation)
    f, g, cE, AE, cI, D, parts = _evaluate(x0, P0)
    R = D.shape[1]  # rows a platform: the 24 limits and the self-leg rows
    m = R * n
    fs, P, g, x, yE, zf, act, new = _pc_start(x0, P0, g, yE0, z0, active, m)
    ok, it, changes = False, 0, 0
    while True:
        parent = _merge_twins(act, cI, D, zf, m)
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
            # the dependent rows' residuals count too
            e_du, e_pr, comp, sd = _pc_errors(rd, yE, zA, cE, cI, allidx, idx, m)
            verdict, err = _pc_verdict(e_du, e_pr, comp, sd, tol, constr_tol, it, max_newton,
                                       inner, err_prev)  # fmt: skip
            conv = verdict == 1
            if verdict != 0:
                break
            err_prev = err
            inner += 1
            it += 1
            W = _hessian(parts, yE, zf, P, 0.0)
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
                i = idx[j] // R
                for k in range(6):
                    K[6 * i + k, N + 6 + j] = -D[i, idx[j] % R, k]
                    K[N + 6 + j, 6 * i + k] = D[i, idx[j] % R, k]
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
            f, g, cE, AE, cI, D, parts = _evaluate(x, P)
        if not conv:
            break
        ok, changed = _pc_change(act, new, zf, parent, idx, zA, cI, m, changes, max_changes)
        if not changed:
            break
        changes += 1
    return x, ok, yE / fs, zf / fs, act, it


@_jit_inline
def _reaches(xn: FloatArray, x: FloatArray, P: Any, jump: FloatArray, pos_tol: float,
             ang_tol: float) -> bool:  # fmt: skip
    """Whether the polished point ``xn`` reaches ``P``'s target (``pos_tol`` [mm]; the
    orientation error's sine from the scaled equalities within ``ang_tol``), violates no
    limit nor dense row (scaled) and moves no variable from ``x`` by more than ``jump``
    (scaled)."""
    es = P.es
    none = np.empty(0)
    f, g, cE, AE, cI, _, _ = kernel.evaluate(xn, P, none, none, none, 0.0)
    pe = math.sqrt((cE[0] / es[0]) ** 2 + (cE[1] / es[1]) ** 2 + (cE[2] / es[2]) ** 2)
    ae = math.sqrt((cE[3] / es[3]) ** 2 + (cE[4] / es[4]) ** 2 + (cE[5] / es[5]) ** 2)
    if not (pe <= pos_tol and ae <= ang_tol and _amin(cI) >= -1e-12):
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
    """:func:`stackik._compiled.planar_path.ip_path` for spatial targets (positions ``pos``
    (m, 3) [mm], rotations ``rot`` (m, 3, 3)): each step from the previous point, the continuation
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
    # the barrier solve of one start (ip_multi; no polish, no ranking: the arguments typed
    # as from Python, int64 and bool, not literals, so that the solver's specialisation
    # serves)
    mu0a = np.array([mu0])
    x = u0.copy()
    have = have0  # the state of u0 (multipliers, active set) when it is a solved point
    yE = yE0.copy()
    z = z0.copy()
    active = act0.copy()
    for k in range(m):
        P = _with_target(P0, pos[k], rot[k])
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
        Xn, stn, _, _, _, s1, z1, yE1 = ip_multi(
            x.copy().reshape(1, -1), P, tol, constr_tol, mu0a, max_iter, 1e300,
            np.int64(0), reach, margin, none, none, none, 0.0,  # type: ignore[arg-type]
            np.bool_(False),  # type: ignore[arg-type]
        )  # fmt: skip
        xn, st = Xn[0], stn[0]
        if st == IP_NONFINITE or not np.all(np.isfinite(xn)):
            return X, k, how, yE, z, active, have
        xn = polish(xn, P, 3, reach, margin)
        if not _reaches(xn, x, P, jump, pos_tol, ang_tol):
            return X, k, how, yE, z, active, have
        X[k] = xn
        # the continuation step has the block rows only (the dense rows are last)
        mb = (24 + P.pairs.shape[0]) * P.top.shape[0]
        x, yE, z = xn, yE1, z1[:mb].copy()
        active = z > s1[:mb]
        have = st == IP_SUCCESS
    return X, m, how, yE, z, active, have
