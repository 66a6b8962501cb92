"""Dense inequality rows of the compiled spatial interior point: rows ``c_D(q) >= 0`` whose
Jacobian touches every platform (a leg moves with every platform below it), appended after
the per-platform block rows (24 limits and the self-leg rows of each platform, the blocks
``D`` (n, R, 6)).

The interior point's inequality Jacobian is then the pair ``AI = (D, JD)``: the blocks and
the dense rows ``JD`` (rows, 6n) in scaled variables, the row values ``c_I`` the block rows
then the dense ones. The products here take the pair; with no dense rows (``JD`` empty)
they do exactly the block arithmetic of :mod:`stackik._compiled.linalg` and nothing else
(the fingerprint is unchanged).

The rows themselves: the obstacle rows (:func:`stackik._compiled.obstacle_rows.obstacle_rows`)
and the leg-force limit rows (:func:`stackik._compiled.force_rows.force_rows`), each its
family's one definition, called from :func:`dense_rows` alone. Their curvature is not
formed (squared distances, plane distances and leg forces; the limit and self-leg rows keep
their exact Hessians).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from stackik._compiled.core import _jit
from stackik._compiled.force_rows import force_rows
from stackik._compiled.linalg import _AI_dot, _AIT_dot
from stackik._compiled.obstacle_rows import obstacle_rows

FloatArray = Any


@_jit
def dense_rows(q: FloatArray, P: Any) -> tuple[FloatArray, FloatArray]:
    """The dense rows of the spatial problem ``P`` (:class:`stackik._compiled.spatial.SpatialData`)
    at the raw pose ``q`` (n, 6) [mm, rad]: values ``c`` (rows,) and Jacobian (rows, 6n)
    against ``q``: the obstacle rows (``P.obstacles``: their kernel's arrays,
    :attr:`stackik.formulation.obstacle_rows.ObstacleRows.kernel_args`), then the leg-force
    limit rows (``P.forces``: :attr:`stackik.formulation.forces.ForceLimits.kernel_args`;
    the limited platforms are its entry 7)."""
    cO, JO = obstacle_rows(q, *P.obstacles, P.ob_margin, P.ob_L, False, 0.0)  # type: ignore[call-arg]
    if P.forces[7].size == 0:
        return cO, JO
    cF, JF = force_rows(q, P.top, P.base, *P.forces, False, 0.0)  # type: ignore[call-arg]
    if cO.size == 0:
        return cF, JF
    return np.concatenate((cO, cF)), np.vstack((JO, JF))


@_jit
def with_dense_rows(u: FloatArray, P: Any, cI: FloatArray, D: FloatArray) -> tuple[Any, Any]:
    """``c_I`` (block rows, then the dense rows) and the pair ``(D, JD)`` at the scaled
    point ``u`` (6n,), ``JD`` in scaled variables; ``cI`` itself and an empty ``JD`` when
    ``P`` has no dense rows."""
    N = u.size
    if P.n_dense == 0:
        return cI, (D, np.empty((0, N)))
    n = N // 6
    xs = P.xs
    cD, J = dense_rows((u * xs).reshape(n, 6), P)
    JD = np.empty(J.shape)
    for r in range(J.shape[0]):
        for a in range(N):
            JD[r, a] = J[r, a] * xs[a]
    return np.concatenate((cI, cD)), (D, JD)


@_jit
def block_size(AI: Any) -> int:
    """Number of block rows of ``AI = (D, JD)``."""
    D = AI[0]
    return D.shape[0] * D.shape[1]


@_jit
def block_part(z: FloatArray, AI: Any) -> FloatArray:
    """The block rows' entries of ``z`` (the dense rows' last): ``z`` itself without dense
    rows."""
    if AI[1].shape[0] == 0:
        return z
    return z[: block_size(AI)].copy()


@_jit
def AI_dot(AI: Any, dx: FloatArray) -> FloatArray:
    """``A_I dx``: :func:`stackik._compiled.linalg._AI_dot` of the blocks, then ``JD dx``."""
    D, JD = AI
    out = _AI_dot(D, dx)
    if JD.shape[0] == 0:
        return out
    return np.concatenate((out, JD @ dx))


@_jit
def AIT_dot(AI: Any, v: FloatArray) -> FloatArray:
    """``A_I^T v`` (v: block rows, then dense rows)."""
    D, JD = AI
    out = _AIT_dot(D, v)
    if JD.shape[0] == 0:
        return out
    mb = block_size(AI)
    for r in range(JD.shape[0]):
        vr = v[mb + r]
        if vr != 0.0:
            for a in range(out.size):
                out[a] += JD[r, a] * vr
    return out


@_jit
def add_normal(W: FloatArray, AI: Any, Sig: FloatArray) -> None:
    """``W += A_I^T diag(Sig) A_I`` in place: the blocks on the diagonal, the dense rows
    everywhere."""
    D, JD = AI
    n, R = D.shape[0], D.shape[1]
    for i in range(n):
        for a in range(6):
            for b in range(6):
                acc = 0.0
                for r in range(R):
                    acc += D[i, r, a] * Sig[R * i + r] * D[i, r, b]
                W[6 * i + a, 6 * i + b] += acc
    if JD.shape[0] == 0:
        return
    mb = n * R
    N = W.shape[0]
    for r in range(JD.shape[0]):
        sr = Sig[mb + r]
        for a in range(N):
            ja = JD[r, a] * sr
            if ja != 0.0:
                for b in range(N):
                    W[a, b] += ja * JD[r, b]


@_jit
def ineq_row(AI: Any, r: int, out: FloatArray) -> None:
    """Row ``r`` of ``A_I`` (block rows, then dense rows) into ``out`` (6n,)."""
    D, JD = AI
    R = D.shape[1]
    mb = block_size(AI)
    if r < mb:
        i = r // R
        out[:] = 0.0
        out[6 * i : 6 * i + 6] = D[i, r % R]
    else:
        out[:] = JD[r - mb]
