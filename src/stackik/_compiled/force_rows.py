"""Leg forces and the leg-force limit rows of a pose (numba): the solvers' one definition
of the family (:class:`stackik.formulation.forces.ForceLimits` wraps it; the compiled
spatial interior point carries the rows as dense rows, :mod:`stackik._compiled.dense_rows`).
The independent check keeps its own statics (:func:`stackik.leg_forces`, numpy, an SVD per
platform); a test holds the two equal.

For every platform i with a finite ``force_max`` (``platforms``), 12 rows, platform-major:
``1 - f_ik / force_max_i`` (k = 0..5), then ``1 + f_ik / force_max_i``, with ``f`` the leg
forces (compression positive) of the statics of DESIGN section 10: platform i's six legs
balance the weight of everything above the cut through them (the payload, plates i..n, the
legs above and the top halves of its own) and the external wrench, ``f_i = -G_i^-1 w_i``
with ``G_i`` the dimensionless leg wrench matrix (columns: the unit leg directions and
their moments about the top plate's centre over ``L_i``) and ``w_i`` the cut wrench, both
in platform i's bottom plate frame.

The Jacobian with respect to the raw pose (mm, rad) is in closed form. A variable of
platform j moves every plate above j rigidly, to first order ``X -> t + om x (X - O_{j+1})``
(a translation ``t``, or a rotation about the axis ``om`` through the origin ``O_{j+1}`` of
plate j + 1, :func:`_motion`); the cut wrenches follow from it, and ``G_i`` depends on
platform i's own pose alone, so ``df_i = -G_i^-1 (dw_i + [i = j] dG_j f_j)`` with the LU
factors of each ``G_i`` reused. A singular platform (a zero pivot) gives NaN, which the
interior point reports as a non-finite evaluation.

Spatial variables ``[x, y, z, yaw, pitch, roll]`` (``R = Rz Ry Rx``); planar
``[rho, z, theta]`` in the plane ``phi`` (translation ``(rho cos phi, rho sin phi, z)``,
rotation by ``theta`` about ``s(phi) = (sin phi, -cos phi, 0)``, which every plate's
rotation leaves fixed).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from stackik._compiled.core import _jit

FloatArray = Any
Vec = tuple[float, float, float]
ZERO = (0.0, 0.0, 0.0)


@_jit
def _cr(a: Vec, b: Vec) -> Vec:
    """``a x b`` of two 3-tuples (no allocation)."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@_jit
def _add(a: Vec, b: Vec) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@_jit
def _sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@_jit
def _mul(s: float, a: Vec) -> Vec:
    return (s * a[0], s * a[1], s * a[2])


@_jit
def _dot(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@_jit
def _row(X: FloatArray) -> Vec:
    return (X[0], X[1], X[2])


@_jit
def _matvec(A: FloatArray, x: Vec) -> Vec:
    """``A x`` for a (3, 3) array."""
    return (A[0, 0] * x[0] + A[0, 1] * x[1] + A[0, 2] * x[2],
            A[1, 0] * x[0] + A[1, 1] * x[1] + A[1, 2] * x[2],
            A[2, 0] * x[0] + A[2, 1] * x[1] + A[2, 2] * x[2])  # fmt: skip


@_jit
def _tmatvec(A: FloatArray, x: Vec) -> Vec:
    """``A^T x`` for a (3, 3) array."""
    return (A[0, 0] * x[0] + A[1, 0] * x[1] + A[2, 0] * x[2],
            A[0, 1] * x[0] + A[1, 1] * x[1] + A[2, 1] * x[2],
            A[0, 2] * x[0] + A[1, 2] * x[1] + A[2, 2] * x[2])  # fmt: skip


@_jit
def _pose_part(qi: FloatArray, planar: bool, phi: float, R: FloatArray) -> Vec:
    """Rotation ``R`` (3, 3, in place) and translation of one platform's pose ``qi`` (k,)."""
    if planar:
        cf, sf = math.cos(phi), math.sin(phi)
        s = (sf, -cf, 0.0)
        K = ((0.0, 0.0, -cf), (0.0, 0.0, -sf), (cf, sf, 0.0))
        c, sn = math.cos(qi[2]), math.sin(qi[2])
        for a in range(3):
            for b in range(3):
                R[a, b] = sn * K[a][b] + (1.0 - c) * s[a] * s[b]
            R[a, a] += c
        return (qi[0] * cf, qi[0] * sf, qi[1])
    cz, sz = math.cos(qi[3]), math.sin(qi[3])
    cy, sy = math.cos(qi[4]), math.sin(qi[4])
    cx, sx = math.cos(qi[5]), math.sin(qi[5])
    R[0, 0] = cz * cy
    R[0, 1] = cz * sy * sx - sz * cx
    R[0, 2] = cz * sy * cx + sz * sx
    R[1, 0] = sz * cy
    R[1, 1] = sz * sy * sx + cz * cx
    R[1, 2] = sz * sy * cx - cz * sx
    R[2, 0] = -sy
    R[2, 1] = cy * sx
    R[2, 2] = cy * cx
    return (qi[0], qi[1], qi[2])


@_jit
def _local_motion(qi: FloatArray, v: int, planar: bool, phi: float) -> tuple[Vec, Vec]:
    """Translation and rotation axis, in platform i's bottom plate frame, of the plates
    above it per unit of its variable ``v`` (the rotation about the origin of plate i + 1)."""
    if planar:
        cf, sf = math.cos(phi), math.sin(phi)
        if v == 0:
            return (cf, sf, 0.0), ZERO
        if v == 1:
            return (0.0, 0.0, 1.0), ZERO
        return ZERO, (sf, -cf, 0.0)
    if v < 3:
        if v == 0:
            return (1.0, 0.0, 0.0), ZERO
        if v == 1:
            return (0.0, 1.0, 0.0), ZERO
        return (0.0, 0.0, 1.0), ZERO
    if v == 3:
        return ZERO, (0.0, 0.0, 1.0)
    cy, sy = math.cos(qi[3]), math.sin(qi[3])
    if v == 4:
        return ZERO, (-sy, cy, 0.0)
    cp, sp = math.cos(qi[4]), math.sin(qi[4])
    return ZERO, (cy * cp, sy * cp, -sp)


@_jit
def _lu6(G: FloatArray, M: FloatArray, piv: Any) -> bool:
    """LU factors ``M`` (in place) of the 6x6 ``G`` with partial pivoting (``piv``, in
    place); False if singular."""
    for r in range(6):
        piv[r] = r
        for b in range(6):
            M[r, b] = G[r, b]
    for col in range(6):
        p = col
        best = abs(M[col, col])
        for r in range(col + 1, 6):
            if abs(M[r, col]) > best:
                best, p = abs(M[r, col]), r
        if not best > 0.0:
            return False
        if p != col:
            for b in range(6):
                M[col, b], M[p, b] = M[p, b], M[col, b]
            piv[col], piv[p] = piv[p], piv[col]
        for r in range(col + 1, 6):
            M[r, col] /= M[col, col]
            for b in range(col + 1, 6):
                M[r, b] -= M[r, col] * M[col, b]
    return True


@_jit
def _lu6_solve(M: FloatArray, piv: Any, b: FloatArray, x: FloatArray) -> None:
    """``x`` with ``G x = b`` from :func:`_lu6`'s factors, in place."""
    for r in range(6):
        x[r] = b[piv[r]]
    for r in range(6):
        for e in range(r):
            x[r] -= M[r, e] * x[e]
    for r in range(5, -1, -1):
        for e in range(r + 1, 6):
            x[r] -= M[r, e] * x[e]
        x[r] /= M[r, r]


@_jit
def leg_force_jacobian(
    q: FloatArray, top: FloatArray, base: FloatArray, L: FloatArray, m: FloatArray,
    c: FloatArray, g: FloatArray, F_ext: FloatArray, M_ext: FloatArray, ee_frame: bool,
    planar: bool, phi: float,
) -> tuple[FloatArray, FloatArray, bool]:  # fmt: skip
    """Leg forces ``f`` (n, 6) [N] (compression positive) of the raw pose ``q`` (n, k) [mm,
    rad] and their Jacobian (6 n, k n) (row ``6 i + leg``); False (and NaN) when a platform
    is singular.

    ``top``, ``base`` (n, 6, 3) nodes [mm]; then
    :func:`stackik.formulation.forces.force_kernel_args`: ``L`` (n,) [mm], ``m`` (n,) [kg]
    and ``c`` (n, 3) [kg mm] the masses lumped on each top plate and their first moments in
    its frame, ``g`` (3,) [m/s^2], the external force [N] and moment [N mm], ``ee_frame``
    (those two given in the end effector's frame). Derivatives: module doc."""
    n, k = q.shape
    f = np.empty((n, 6))
    J = np.zeros((6 * n, n * k))
    # frames: A[i] orientation and O[i] origin of plate i (base frame) [mm]
    A = np.zeros((n + 1, 3, 3))
    O = np.zeros((n + 1, 3))
    R = np.empty((n, 3, 3))
    P = np.empty((n, 3))
    for a in range(3):
        A[0, a, a] = 1.0
    for i in range(n):
        p = _pose_part(q[i], planar, phi, R[i])
        P[i, 0], P[i, 1], P[i, 2] = p
        d = _matvec(A[i], p)
        for a in range(3):
            O[i + 1, a] = O[i, a] + d[a]
        for a in range(3):
            for e in range(3):
                acc = 0.0
                for d_ in range(3):
                    acc += A[i, a, d_] * R[i, d_, e]
                A[i + 1, a, e] = acc
    FE = (F_ext[0], F_ext[1], F_ext[2])
    ME = (M_ext[0], M_ext[1], M_ext[2])
    if ee_frame:
        FE = _matvec(A[n], FE)
        ME = _matvec(A[n], ME)
    GV = (g[0], g[1], g[2])
    On = _row(O[n])
    # suffix sums of the lumped masses (Mc) and their first moments (Sc, base frame)
    Mc = np.zeros(n + 1)
    Sc = np.zeros((n + 1, 3))
    for i in range(n - 1, -1, -1):
        Mc[i] = Mc[i + 1] + m[i]
        s = _add(_mul(m[i], _row(O[i + 1])), _matvec(A[i + 1], _row(c[i])))
        for a in range(3):
            Sc[i, a] = Sc[i + 1, a] + s[a]
    # cut wrenches in the base frame, legs, LU factors, forces
    Fb = np.empty((n, 3))
    Mb = np.empty((n, 3))
    RT = np.empty((n, 6, 3))  # R_i t_k (bottom frame of platform i) [mm]
    U = np.empty((n, 6, 3))  # unit leg directions
    LN = np.empty((n, 6))  # leg lengths [mm]
    LU = np.empty((n, 6, 6))
    PIV = np.empty((n, 6), dtype=np.int64)
    G = np.empty((6, 6))
    b = np.empty(6)
    x = np.empty(6)
    for i in range(n):
        Oi = _row(O[i + 1])
        F = _add(FE, _mul(Mc[i], GV))
        M = _add(_add(ME, _cr(_sub(On, Oi), FE)), _cr(_sub(_row(Sc[i]), _mul(Mc[i], Oi)), GV))
        for a in range(3):
            Fb[i, a], Mb[i, a] = F[a], M[a]
        wf = _tmatvec(A[i], F)
        wm = _tmatvec(A[i], M)
        for leg in range(6):
            rt = _matvec(R[i], _row(top[i, leg]))
            lv = _sub(_add(rt, _row(P[i])), _row(base[i, leg]))
            ln = math.sqrt(_dot(lv, lv))
            u = _mul(1.0 / ln, lv)
            mo = _cr(rt, u)
            LN[i, leg] = ln
            for a in range(3):
                RT[i, leg, a], U[i, leg, a] = rt[a], u[a]
                G[a, leg] = u[a]
                G[3 + a, leg] = mo[a] / L[i]
        if not _lu6(G, LU[i], PIV[i]):
            f[:, :] = np.nan
            J[:, :] = np.nan
            return f, J, False
        for a in range(3):
            b[a] = -wf[a]
            b[3 + a] = -wm[a] / L[i]
        _lu6_solve(LU[i], PIV[i], b, x)
        for leg in range(6):
            f[i, leg] = x[leg]
    dgf = np.empty(6)
    for j in range(n):
        Aj = A[j]
        Oj = _row(O[j + 1])
        for v in range(k):
            tl, wl = _local_motion(q[j], v, planar, phi)
            T = _matvec(Aj, tl)  # the motion of the plates above j in the base frame
            W = _matvec(Aj, wl)
            dFe = _cr(W, FE) if ee_frame else ZERO
            dMe = _cr(W, ME) if ee_frame else ZERO
            dOn = _add(T, _cr(W, _sub(On, Oj)))
            # dG_j f_j: leg k's dl = tl + wl x rt, du = (dl - u (u . dl)) / |l|,
            # d(rt x u) = (wl x rt) x u + rt x du (platform j's bottom frame)
            dgf[:] = 0.0
            for leg in range(6):
                rt = _row(RT[j, leg])
                u = _row(U[j, leg])
                drt = _cr(wl, rt)
                dl = _add(tl, drt)
                du = _mul(1.0 / LN[j, leg], _sub(dl, _mul(_dot(u, dl), u)))
                dmo = _add(_cr(drt, u), _cr(rt, du))
                fl = f[j, leg]
                for a in range(3):
                    dgf[a] += du[a] * fl
                    dgf[3 + a] += dmo[a] * fl / L[j]
            col = k * j + v
            for i in range(n):
                h = max(i, j)  # the masses at or above plate h + 1 move
                dS = _add(_mul(Mc[h], T), _cr(W, _sub(_row(Sc[h]), _mul(Mc[h], Oj))))
                Oi = _row(O[i + 1])
                dOi = _add(T, _cr(W, _sub(Oi, Oj))) if i >= j else ZERO
                dF = dFe
                dM = _add(dMe, _cr(_sub(dOn, dOi), FE))
                dM = _add(dM, _add(_cr(_sub(On, Oi), dFe), _cr(_sub(dS, _mul(Mc[i], dOi)), GV)))
                if i > j:  # platform i's frame turns too: d(A^T x) = A^T (dx - om x x)
                    dF = _sub(dF, _cr(W, _row(Fb[i])))
                    dM = _sub(dM, _cr(W, _row(Mb[i])))
                df = _tmatvec(A[i], dF)
                dm = _tmatvec(A[i], dM)
                for a in range(3):
                    b[a] = -df[a]
                    b[3 + a] = -dm[a] / L[i]
                if i == j:
                    for r in range(6):
                        b[r] -= dgf[r]
                _lu6_solve(LU[i], PIV[i], b, x)
                for r in range(6):
                    J[6 * i + r, col] = x[r]
    return f, J, True


@_jit
def force_rows(
    q: FloatArray, top: FloatArray, base: FloatArray, L: FloatArray, m: FloatArray,
    c: FloatArray, g: FloatArray, F_ext: FloatArray, M_ext: FloatArray, ee_frame: bool,
    platforms: Any, inv: FloatArray, planar: bool, phi: float,
) -> tuple[FloatArray, FloatArray]:  # fmt: skip
    """Rows ``c`` (12 p,) and Jacobian (12 p, k n) against the raw pose ``q`` (n, k) [mm,
    rad]; ``platforms`` (p,) the limited platforms, ``inv`` (p,) their ``1 / force_max``
    [1/N]; the rest as :func:`leg_force_jacobian`. NaN everywhere when a platform is
    singular."""
    n, k = q.shape
    p = platforms.size
    rows = np.empty(12 * p)
    J = np.empty((12 * p, n * k))
    if p == 0:
        return rows, J
    f, Jf, _ = leg_force_jacobian(q, top, base, L, m, c, g, F_ext, M_ext, ee_frame, planar, phi)
    for t in range(p):
        i = platforms[t]
        for leg in range(6):
            r = f[i, leg] * inv[t]
            rows[12 * t + leg] = 1.0 - r
            rows[12 * t + 6 + leg] = 1.0 + r
            for a in range(n * k):
                d = Jf[6 * i + leg, a] * inv[t]
                J[12 * t + leg, a] = -d
                J[12 * t + 6 + leg, a] = d
    return rows, J
