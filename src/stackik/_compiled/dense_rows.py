"""Dense inequality rows of the compiled interior points, spatial and planar: rows
``c_D(q) >= 0`` whose Jacobian touches every platform (a leg moves with every platform
below it), appended after the per-platform block rows (the blocks ``D`` (n, R, k), ``k``
variables a platform: 6 spatial, the 24 limits and the self-leg rows of each platform; 3
planar, its 24 limits; a path step's box rows too).

The interior point's inequality Jacobian is then the pair ``AI = (D, JD)``: the blocks and
the dense rows ``JD`` (rows, k n) in scaled variables, the row values ``c_I`` the block rows
then the dense ones. The products here take the pair; with no dense rows (``JD`` empty)
they do exactly the block arithmetic of :mod:`stackik._compiled.linalg` (and, for
:func:`add_normal`, of the planar and spatial barrier loops before the pair) and nothing
else (the fingerprint is unchanged). For the lean problem data (no dense rows at all:
:func:`stackik._compiled.core.lean_type`) ``A_I`` is the blocks ``D`` alone, and numba
compiles each product (an overload resolved by the type of ``A_I``) as that block
arithmetic only, with none of the dense rows' code.

The rows themselves: the obstacle rows (:func:`stackik._compiled.obstacle_rows.obstacle_rows`),
the rows of the bodies of non-adjacent platforms
(:func:`stackik._compiled.leg_pairs.segment_pair_rows`)
and the leg-force limit rows (:func:`stackik._compiled.force_rows.force_rows`), each its
family's one definition, called from :func:`dense_rows` alone with the mode's variables
(``planar``, the plane angle ``phi``); between the last two, the rows of a user's
constraint families (:mod:`stackik.families`), called back in object mode
(:func:`family_rows`). Their exact curvature is not formed (squared
distances, plane distances and leg forces; the limit and self-leg rows keep their exact
Hessians); the leg-force rows get an SR1 estimate (:func:`force_sr1`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import objmode, types
from numba.extending import overload

from stackik import families as _families
from stackik._compiled.core import _OVERLOAD, _jit, _jit_inline, lean_type, unresolved
from stackik._compiled.force_rows import force_rows
from stackik._compiled.leg_pairs import segment_pair_rows
from stackik._compiled.linalg import _AI_dot, _AIT_dot
from stackik._compiled.obstacle_rows import obstacle_rows

FloatArray = Any


@_jit
def dense_rows(q: FloatArray, P: Any, planar: bool, phi: float) -> tuple[FloatArray, FloatArray]:
    """The dense rows of the problem ``P`` (:class:`stackik._compiled.spatial.SpatialData`,
    or :class:`stackik._compiled.planar.PlanarData` with ``planar`` and its plane angle
    ``phi`` [rad]) at the raw pose ``q`` (n, k) [mm, rad]: values ``c`` (rows,) and Jacobian
    (rows, k n) against ``q``: the obstacle rows (``P.obstacles``: their kernel's arrays,
    :attr:`stackik.formulation.obstacle_rows.ObstacleRows.kernel_args`), then the rows of
    bodies of non-adjacent platforms (``P.leg_pairs``:
    :attr:`stackik.formulation.leg_pairs.LegPairRows.kernel_args`), then the leg-force
    limit rows (``P.forces``: :attr:`stackik.formulation.forces.ForceLimits.kernel_args`;
    the limited platforms are its entry 9; last, where :func:`force_sr1` takes them);
    before the force rows, the constraint families' rows (``P.families``, a token:
    :func:`family_rows`)."""
    cO, JO = obstacle_rows(q, *P.obstacles, P.ob_margin, P.ob_L, planar, phi)  # type: ignore[call-arg]
    if P.leg_pairs[2].shape[0] > 0:
        cP, JP = segment_pair_rows(q, *P.leg_pairs, planar, phi, True)  # type: ignore[call-arg]
        if cO.size == 0:
            cO, JO = cP, JP
        else:
            cO, JO = np.concatenate((cO, cP)), np.vstack((JO, JP))
    if P.families != 0:
        cU, JU = family_rows(P.families, q)
        if cO.size == 0:
            cO, JO = cU, JU
        else:
            cO, JO = np.concatenate((cO, cU)), np.vstack((JO, JU))
    if P.forces[9].size == 0:
        return cO, JO
    cF, JF = force_rows(q, *P.forces, planar, phi)  # type: ignore[call-arg]
    if cO.size == 0:
        return cF, JF
    return np.concatenate((cO, cF)), np.vstack((JO, JF))


@_jit
def family_rows(token: int, q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The rows of the constraint families named ``token`` at the raw pose ``q`` (n, k):
    :func:`stackik.families.kernel_rows`, called in object mode (Python: a family is a
    user's class, with no compiled code of its own and nothing to recompile), values
    (rows,) and Jacobian (rows, k n) against ``q``."""
    qc = np.ascontiguousarray(q)
    with objmode(c="float64[::1]", J="float64[:, ::1]"):
        c, J = _families.kernel_rows(token, qc)
    return c, J


def with_dense_rows(u: FloatArray, P: Any, cI: FloatArray, D: FloatArray, planar: bool,
                    phi: float) -> tuple[Any, Any]:  # fmt: skip
    """``c_I`` (block rows, then the dense rows) and ``A_I`` at the scaled point ``u``
    (k n,; ``k = D.shape[2]``): for problem data with dense rows the pair ``(D, JD)``, ``JD``
    in scaled variables (empty when there are none); for the lean type
    (:func:`stackik._compiled.core.lean_type`, ``n_dense`` None) ``cI`` and the blocks ``D``
    themselves. ``planar``, ``phi``: the mode's variables (:func:`dense_rows`; spatial:
    False, 0).

    Resolved by numba at compile time from the type of ``P``, as are the products below
    from the type of ``A_I`` (an array: the blocks alone; a pair: blocks and dense rows):
    the kernels of a problem with no obstacle, leg-pair, family or force rows hold none of
    those rows' code."""
    return unresolved()


def _is_blocks(AI: Any) -> bool:
    """Whether the numba type of ``A_I`` is the blocks alone (the lean problem data's)."""
    return isinstance(AI, types.Array)


@overload(with_dense_rows, jit_options=_OVERLOAD)
def _with_dense_rows(u, P, cI, D, planar, phi):  # type: ignore[no-untyped-def]
    if lean_type(P):
        return lambda u, P, cI, D, planar, phi: (cI, D)

    def rows(u, P, cI, D, planar, phi):  # type: ignore[no-untyped-def]
        return _with_rows(u, P, cI, D, planar, phi)

    return rows


@_jit
def _with_rows(u: FloatArray, P: Any, cI: FloatArray, D: FloatArray, planar: bool,
               phi: float) -> tuple[Any, Any]:  # fmt: skip
    """:func:`with_dense_rows` of a problem with dense rows (``P.n_dense`` their number)."""
    N = u.size
    if P.n_dense == 0:
        return cI, (D, np.empty((0, N)))
    k = D.shape[2]
    n = N // k
    xs = P.xs
    cD, J = dense_rows((u * xs).reshape(n, k), P, planar, phi)
    JD = np.empty(J.shape)
    for r in range(J.shape[0]):
        for a in range(N):
            JD[r, a] = J[r, a] * xs[a]
    return np.concatenate((cI, cD)), (D, JD)


def block_size(AI: Any) -> int:
    """Number of block rows of ``A_I`` (the blocks ``D`` (n, R, k), or the pair ``(D, JD)``)."""
    return unresolved()


def block_part(z: FloatArray, AI: Any) -> FloatArray:
    """The block rows' entries of ``z`` (the dense rows' last): ``z`` itself without dense
    rows."""
    return unresolved()


def AI_dot(AI: Any, dx: FloatArray) -> FloatArray:
    """``A_I dx``: :func:`stackik._compiled.linalg._AI_dot` of the blocks, then ``JD dx``."""
    return unresolved()


def AIT_dot(AI: Any, v: FloatArray) -> FloatArray:
    """``A_I^T v`` (v: block rows, then dense rows)."""
    return unresolved()


def add_normal(W: FloatArray, AI: Any, Sig: FloatArray) -> None:
    """``W += A_I^T diag(Sig) A_I`` in place: the blocks on the diagonal, the dense rows
    everywhere."""
    return unresolved()


def ineq_row(AI: Any, r: int, out: FloatArray) -> None:
    """Row ``r`` of ``A_I`` (block rows, then dense rows) into ``out`` (k n,)."""
    return unresolved()


def force_update(B: FloatArray, sv: FloatArray, AI0: Any, AI1: Any, z: FloatArray,
                 n_force: int) -> None:  # fmt: skip
    """:func:`force_sr1` of ``B`` with the dense rows' Jacobians of ``A_I`` before and after
    the step ``sv``; nothing without dense rows."""
    return unresolved()


def _block_size_blocks(AI):  # type: ignore[no-untyped-def]
    return AI.shape[0] * AI.shape[1]


def _block_part_pair(z, AI):  # type: ignore[no-untyped-def]
    if AI[1].shape[0] == 0:
        return z
    return z[: block_size(AI)].copy()


def _AI_dot_pair(AI, dx):  # type: ignore[no-untyped-def]
    D, JD = AI
    out = _AI_dot(D, dx)
    if JD.shape[0] == 0:
        return out
    return np.concatenate((out, JD @ dx))


def _AIT_dot_pair(AI, v):  # type: ignore[no-untyped-def]
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


@_jit_inline
def _add_blocks(W: FloatArray, D: FloatArray, Sig: FloatArray) -> None:
    """``W += D^T diag(Sig) D`` of the blocks, on the diagonal."""
    n, R, k = D.shape[0], D.shape[1], D.shape[2]
    for i in range(n):
        for a in range(k):
            for b in range(k):
                acc = 0.0
                for r in range(R):
                    acc += D[i, r, a] * Sig[R * i + r] * D[i, r, b]
                W[k * i + a, k * i + b] += acc


def _add_normal_pair(W, AI, Sig):  # type: ignore[no-untyped-def]
    D, JD = AI
    _add_blocks(W, D, Sig)
    if JD.shape[0] == 0:
        return
    mb = block_size(AI)
    N = W.shape[0]
    nd = JD.shape[0]
    SJ = np.empty((N, nd))  # (diag(Sig) JD)^T: one matrix product (BLAS) for the dense rows
    for r in range(nd):
        sr = Sig[mb + r]
        for a in range(N):
            SJ[a, r] = JD[r, a] * sr
    W += SJ @ JD


@_jit_inline
def _block_row(D: FloatArray, r: int, out: FloatArray) -> None:
    """Block row ``r`` of the blocks ``D`` (n, R, k) into ``out`` (k n,)."""
    R, k = D.shape[1], D.shape[2]
    i = r // R
    out[:] = 0.0
    for j in range(k):  # a loop: a slice assignment compiles numba's shape-mismatch message
        out[k * i + j] = D[i, r % R, j]


def _ineq_row_pair(AI, r, out):  # type: ignore[no-untyped-def]
    D, JD = AI
    mb = block_size(AI)
    if r < mb:
        _block_row(D, r, out)
    else:
        out[:] = JD[r - mb]


def _force_update_pair(B, sv, AI0, AI1, z, n_force):  # type: ignore[no-untyped-def]
    force_sr1(B, sv, AI0[1], AI1[1], z, n_force)


# the implementations numba compiles in place of each stub, by the type of A_I (numba
# compares the parameter names of the typing functions and the implementations)
@overload(block_size, jit_options=_OVERLOAD)
def _ol_block_size(AI):  # type: ignore[no-untyped-def]
    return _block_size_blocks if _is_blocks(AI) else (lambda AI: block_size(AI[0]))


@overload(block_part, jit_options=_OVERLOAD)
def _ol_block_part(z, AI):  # type: ignore[no-untyped-def]
    return (lambda z, AI: z) if _is_blocks(AI) else _block_part_pair


@overload(AI_dot, jit_options=_OVERLOAD)
def _ol_AI_dot(AI, dx):  # type: ignore[no-untyped-def]
    return (lambda AI, dx: _AI_dot(AI, dx)) if _is_blocks(AI) else _AI_dot_pair


@overload(AIT_dot, jit_options=_OVERLOAD)
def _ol_AIT_dot(AI, v):  # type: ignore[no-untyped-def]
    return (lambda AI, v: _AIT_dot(AI, v)) if _is_blocks(AI) else _AIT_dot_pair


@overload(add_normal, jit_options=_OVERLOAD)
def _ol_add_normal(W, AI, Sig):  # type: ignore[no-untyped-def]
    return (lambda W, AI, Sig: _add_blocks(W, AI, Sig)) if _is_blocks(AI) else _add_normal_pair


@overload(ineq_row, jit_options=_OVERLOAD)
def _ol_ineq_row(AI, r, out):  # type: ignore[no-untyped-def]
    return (lambda AI, r, out: _block_row(AI, r, out)) if _is_blocks(AI) else _ineq_row_pair


@overload(force_update, jit_options=_OVERLOAD)
def _ol_force_update(B, sv, AI0, AI1, z, n_force):  # type: ignore[no-untyped-def]
    if _is_blocks(AI0):
        return lambda B, sv, AI0, AI1, z, n_force: None
    return _force_update_pair


@_jit
def force_sr1(B: FloatArray, sv: FloatArray, JD0: FloatArray, JD1: FloatArray, z: FloatArray,
              n_force: int) -> None:  # fmt: skip
    """SR1 update in place of ``B``, the barrier loops' estimate of the leg-force rows' part
    of the Lagrangian's Hessian ``-sum_r z_r d^2 c_r`` (the rows' exact curvature is not
    formed; without it a binding force limit zig-zags for hundreds of iterations): after
    the step ``sv`` (scaled), with ``JD0``/``JD1`` the dense rows' Jacobians before and
    after it (the force rows last) and the new multipliers ``z`` (the force rows last),
    ``y = -(JD1 - JD0)^T z_F`` and ``B += r r^T / (r . sv)`` with ``r = y - B sv``,
    skipped when ``|r . sv|`` is below ``1e-8 |r| |sv|`` (Nocedal & Wright 2006, eq. 6.26)."""
    N = sv.size
    nd = JD1.shape[0]
    m = z.size
    r = np.zeros(N)
    for t in range(n_force):
        zt = z[m - n_force + t]
        row = nd - n_force + t
        for a in range(N):
            r[a] -= (JD1[row, a] - JD0[row, a]) * zt
    for a in range(N):
        acc = 0.0
        for b in range(N):
            acc += B[a, b] * sv[b]
        r[a] -= acc
    den = r @ sv
    if not abs(den) > 1e-8 * math.sqrt(r @ r) * math.sqrt(sv @ sv):
        return
    for a in range(N):
        ra = r[a] / den
        for b in range(N):
            B[a, b] += ra * r[b]
