"""Small dense linear algebra the compiled kernels share, written as loops (LAPACK's call
overhead costs more than the arithmetic at these sizes): Cholesky factor and solve, 3 x 3
and 6 x 6 inverses, Gaussian elimination, and the products with the block-diagonal limit
Jacobian (``n`` blocks of ``R`` rows by ``k`` variables, ``k`` = 3 planar, 6 spatial).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba.core import types
from numba.np.linalg import _LAPACK  # numba's bindings of np.linalg's LAPACK calls

from stackik._compiled.core import _abs_max, _jit, _jit_inline

FloatArray = Any


@_jit
def min_norm_solve(A: FloatArray, b: FloatArray) -> FloatArray:
    """Least-squares, least-norm solution of ``A x = b`` with numpy's default cut-off
    (``rcond = eps max(A.shape)``, :func:`numpy.linalg.lstsq` with ``rcond=None``, as
    :func:`stackik.formulation.polish` uses): numba's default keeps singular values down to
    machine precision, so two equal rows (a symmetric pose's twin limits) gave a rounding-
    sized singular value and a step of rounding divided by it, different on every CPU."""
    rcond = np.finfo(np.float64).eps * max(A.shape[0], A.shape[1])
    return np.linalg.lstsq(A, b, rcond=rcond)[0]  # type: ignore[no-any-return]


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
def _mm3(A: FloatArray, B: FloatArray) -> FloatArray:
    """3 x 3 product by loops (BLAS costs more than the arithmetic at this size)."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]
    return out


#: LAPACK's Cholesky factorisation as numba's ``np.linalg.cholesky`` calls it (its helper
#: library's ``numba_xxpotrf(kind, uplo, n, a, lda)``, SciPy's LAPACK), here on a buffer
#: the caller owns: no copy of numba's own and no zeroing of the other triangle.
_POTRF = _LAPACK().numba_xxpotrf(types.float64)
_DOUBLE = ord("d")
_LOWER = ord("L")


@_jit
def _cholesky(A: FloatArray, shift: float) -> tuple[FloatArray, bool]:
    """Cholesky factor of ``A + shift I`` as ``R`` with ``A + shift I = R^T R`` (``R`` upper
    triangular, C order: the lower factor ``L = R^T`` stored row by row); ``ok`` False when
    not positive definite (then ``R`` is not a factor; :func:`_cho_solve` reads it all
    the same, as before).

    Reads only the lower triangle and the diagonal of ``A`` (the planar KKT step forms no
    other). From 24 rows on, LAPACK's ``potrf`` with ``uplo = 'L'`` on the Fortran-order
    buffer that holds ``A``'s lower triangle as C order's upper (about 30 % faster than
    numba's ``np.linalg.cholesky``, which asks for ``'U'`` on a C-order copy: 174 against
    250 us at 189 rows on one core; the factor agrees to rounding); below it the loops,
    whose arithmetic is the same in either layout."""
    if A.shape[0] >= 24:  # LAPACK pays off beyond small sizes
        return _potrf(A, A, 0.0, shift, False)
    return _cholesky_loops(A, shift)


@_jit
def _cholesky_plus(A: FloatArray, D: FloatArray, t: float) -> tuple[FloatArray, bool]:
    """:func:`_cholesky` of ``A + t D`` (the inertia correction's shifted matrices), built
    into the factor's buffer from the two lower triangles, not as a matrix of its own: the
    same numbers as ``_cholesky(A + t * D, 0.0)``."""
    if A.shape[0] >= 24:
        return _potrf(A, D, t, 0.0, True)
    return _cholesky_loops(A + t * D, 0.0)


@_jit_inline
def _potrf(A: FloatArray, D: FloatArray, t: float, shift: float,
           plus: bool) -> tuple[FloatArray, bool]:  # fmt: skip
    """LAPACK's factor of ``S = A (+ t D when plus) + shift I`` (lower triangles read),
    refused below a pivot of ``1e-7 sqrt|S_ii|``; when LAPACK refuses, ``S`` itself."""
    k = A.shape[0]
    R = _upper_of(A, D, t, shift, plus)
    if _POTRF(_DOUBLE, _LOWER, k, R.ctypes, k) != 0:
        return _upper_of(A, D, t, shift, plus), False  # not a factor: S as R
    for i in range(k):
        sii = A[i, i] + t * D[i, i] if plus else A[i, i]
        if not R[i, i] > 1e-7 * math.sqrt(abs(sii + shift) + 1e-300):
            return R, False
    return R, True


@_jit_inline
def _upper_of(A: FloatArray, D: FloatArray, t: float, shift: float, plus: bool) -> FloatArray:
    """The lower triangle of ``A (+ t D when plus)``, its diagonal plus ``shift``, as the
    upper triangle of a new C-order matrix, zeros below."""
    k = A.shape[0]
    R = np.zeros((k, k))
    for j in range(k):
        if plus:
            R[j, j] = A[j, j] + t * D[j, j] + shift
            for i in range(j + 1, k):
                R[j, i] = A[i, j] + t * D[i, j]
        else:
            R[j, j] = A[j, j] + shift
            for i in range(j + 1, k):
                R[j, i] = A[i, j]
    return R


@_jit_inline
def _cholesky_loops(A: FloatArray, shift: float) -> tuple[FloatArray, bool]:
    """:func:`_cholesky` by loops (below 24 rows, where LAPACK's call costs more)."""
    k = A.shape[0]
    R = np.zeros((k, k))
    dmax = 0.0
    for i in range(k):
        dmax = max(dmax, abs(A[i, i]) + shift)
    for j in range(k):
        acc = A[j, j] + shift
        for p in range(j):
            acc -= R[p, j] * R[p, j]
        if not acc > 1e-14 * dmax:
            return R, False
        R[j, j] = math.sqrt(acc)
        for i in range(j + 1, k):
            acc = A[i, j]
            for p in range(j):
                acc -= R[p, i] * R[p, j]
            R[j, i] = acc / R[j, j]
    return R, True


@_jit
def _cho_solve(R: FloatArray, b: FloatArray) -> FloatArray:
    """``x`` with ``R^T R x = b`` for the factor ``R`` of :func:`_cholesky`."""
    k = R.shape[0]
    y = np.empty(k)
    for i in range(k):
        acc = b[i]
        for p in range(i):
            acc -= R[p, i] * y[p]
        y[i] = acc / R[i, i]
    x = np.empty(k)
    for i in range(k - 1, -1, -1):
        acc = y[i]
        for p in range(i + 1, k):
            acc -= R[i, p] * x[p]
        x[i] = acc / R[i, i]
    return x


#: The inertia correction's tries of a shift, at most (NaN entries never factor).
SHIFT_TRIES = 60


@_jit_inline
def first_shift(last_shift: float) -> tuple[float, float]:
    """The inertia correction's first trial shift and its growth factor (IPOPT's rule, as
    the KKT steps of both modes use it): once a step of the run needed a shift, from a
    third of the last nonzero shift ``last_shift`` (at least 1e-4) in factors of 8, else
    from 1e-4 in factors of 100."""
    if last_shift > 0.0:
        return max(last_shift / 3.0, 1e-4), 8.0
    return 1e-4, 100.0


@_jit_inline
def shift_given_up(shift: float, scale: float) -> bool:
    """Whether the inertia correction stops growing ``shift`` for a matrix whose largest
    diagonal entry is ``scale`` (then the step is taken from the last factor tried)."""
    return not shift <= 1e20 * (1.0 + scale)


@_jit
def semisep_factor(Ad: FloatArray, Ug: FloatArray, Vg: FloatArray) -> tuple[FloatArray, bool]:
    """Block ``L D L^T`` factor of the symmetric matrix ``S`` (``3 nb`` rows) whose diagonal
    blocks are ``Ad`` (nb, 3, 3) and whose blocks below them are ``S[b, c] = U_b V_c^T``
    (``b > c``; ``U_b``, ``V_b`` the rows ``3 b .. 3 b + 2`` of ``Ug``, ``Vg`` (3 nb, r)): a
    block *semiseparable* matrix (the planar KKT step's reduced Hessian,
    :func:`stackik._compiled.planar._structured_kkt_factor`). ``L = I + (U_b W_c^T below the
    diagonal)`` and ``D = blockdiag(D_b)`` by the recursion (Foreman-Mackey et al. 2017's,
    celerite, in 3 x 3 blocks)

        S_0 = 0,  D_b = A_b - U_b S_b U_b^T,  W_b = D_b^-1 (V_b - U_b S_b),
        S_(b+1) = S_b + W_b^T D_b W_b,

    O(nb r^2) instead of the dense factor's O(nb^3). ``D_b``'s pivots are those of the
    dense Cholesky factor of ``S`` (the same elimination order): ``ok`` False when one is
    not above ``1e-14 |S_ii|`` (the dense factor's test, :func:`_potrf`). Returns ``G``
    (3 nb, 2 r + 3): each row's ``U``, ``W`` and its row of ``D_b``'s lower Cholesky
    factor, for :func:`semisep_solve`."""
    K, r = Ug.shape
    nb = K // 3
    G = np.zeros((K, 2 * r + 3))
    S = np.zeros((r, r))
    T = np.empty((3, r))  # U_b S_b, then V_b - U_b S_b
    D = np.empty((3, 3))
    L = np.zeros((3, 3))
    for b in range(nb):
        o = 3 * b
        for i in range(3):
            for k in range(r):
                acc = 0.0
                for m in range(r):
                    acc += Ug[o + i, m] * S[m, k]
                T[i, k] = acc
        for i in range(3):
            for j in range(i + 1):
                acc = Ad[b, i, j]
                for k in range(r):
                    acc -= T[i, k] * Ug[o + j, k]
                D[i, j] = acc
        for j in range(3):
            acc = D[j, j]
            for p in range(j):
                acc -= L[j, p] * L[j, p]
            if not acc > 1e-14 * (abs(Ad[b, j, j]) + 1e-300):
                return G, False
            L[j, j] = math.sqrt(acc)
            for i in range(j + 1, 3):
                acc = D[i, j]
                for p in range(j):
                    acc -= L[i, p] * L[j, p]
                L[i, j] = acc / L[j, j]
        for i in range(3):
            for k in range(r):
                T[i, k] = Vg[o + i, k] - T[i, k]
                G[o + i, k] = Ug[o + i, k]
            for p in range(3):
                G[o + i, 2 * r + p] = L[i, p]
        for k in range(r):  # W_b = D_b^-1 (V_b - U_b S_b), column by column
            y0 = T[0, k] / L[0, 0]
            y1 = (T[1, k] - L[1, 0] * y0) / L[1, 1]
            y2 = (T[2, k] - L[2, 0] * y0 - L[2, 1] * y1) / L[2, 2]
            x2 = y2 / L[2, 2]
            x1 = (y1 - L[2, 1] * x2) / L[1, 1]
            x0 = (y0 - L[1, 0] * x1 - L[2, 0] * x2) / L[0, 0]
            G[o, r + k] = x0
            G[o + 1, r + k] = x1
            G[o + 2, r + k] = x2
        for m in range(r):  # S += W_b^T D_b W_b = W_b^T (V_b - U_b S_b)
            w0 = G[o, r + m]
            w1 = G[o + 1, r + m]
            w2 = G[o + 2, r + m]
            for k in range(r):
                S[m, k] += w0 * T[0, k] + w1 * T[1, k] + w2 * T[2, k]
    return G, True


@_jit
def semisep_solve(G: FloatArray, b: FloatArray) -> FloatArray:
    """``x`` with ``S x = b`` for :func:`semisep_factor`'s factor ``G`` of ``S``."""
    K = b.shape[0]
    r = (G.shape[1] - 3) // 2
    nb = K // 3
    acc = np.zeros(r)
    y = np.empty(K)
    for bl in range(nb):  # L y = b
        o = 3 * bl
        for i in range(3):
            v = b[o + i]
            for k in range(r):
                v -= G[o + i, k] * acc[k]
            y[o + i] = v
        for k in range(r):
            acc[k] += G[o, r + k] * y[o] + G[o + 1, r + k] * y[o + 1] + G[o + 2, r + k] * y[o + 2]
    c = 2 * r
    for bl in range(nb):  # D w = y, in place
        o = 3 * bl
        y0 = y[o] / G[o, c]
        y1 = (y[o + 1] - G[o + 1, c] * y0) / G[o + 1, c + 1]
        y2 = (y[o + 2] - G[o + 2, c] * y0 - G[o + 2, c + 1] * y1) / G[o + 2, c + 2]
        x2 = y2 / G[o + 2, c + 2]
        x1 = (y1 - G[o + 2, c + 1] * x2) / G[o + 1, c + 1]
        x0 = (y0 - G[o + 1, c] * x1 - G[o + 2, c] * x2) / G[o, c]
        y[o] = x0
        y[o + 1] = x1
        y[o + 2] = x2
    acc[:] = 0.0
    x = np.empty(K)
    for bl in range(nb - 1, -1, -1):  # L^T x = w
        o = 3 * bl
        for i in range(3):
            v = y[o + i]
            for k in range(r):
                v -= G[o + i, r + k] * acc[k]
            x[o + i] = v
        for k in range(r):
            acc[k] += G[o, k] * x[o] + G[o + 1, k] * x[o + 1] + G[o + 2, k] * x[o + 2]
    return x


@_jit
def _solve6(B: FloatArray) -> tuple[FloatArray, bool]:
    """Inverse of a 6 x 6 matrix by Gauss-Jordan with partial pivoting (no LAPACK);
    ``ok`` False when a pivot is below 1e-10 of the largest entry."""
    A = B.copy()
    inv = np.eye(6)
    big = _abs_max(A)
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


@_jit
def _AI_dot(D: FloatArray, dx: FloatArray) -> FloatArray:
    """``A_I dx`` (R n,) from the block-diagonal limit Jacobian's blocks ``D`` (n, R, k)
    (``k`` variables a platform: 3 planar, 6 spatial; R = 24 limit rows per platform,
    more with a box)."""
    n, R, k = D.shape[0], D.shape[1], D.shape[2]
    out = np.empty(R * n)
    for i in range(n):
        for r in range(R):
            acc = 0.0
            for j in range(k):
                acc += D[i, r, j] * dx[k * i + j]
            out[R * i + r] = acc
    return out


@_jit
def _AIT_dot(D: FloatArray, v: FloatArray) -> FloatArray:
    """``A_I^T v`` (k n,) from the blocks ``D`` (n, R, k) of the limit Jacobian."""
    n, R, k = D.shape[0], D.shape[1], D.shape[2]
    out = np.zeros(k * n)
    for i in range(n):
        for r in range(R):
            vr = v[R * i + r]
            for j in range(k):
                out[k * i + j] += D[i, r, j] * vr
    return out


@_jit_inline
def block_formed(m: int, l: int, partial: bool) -> bool:
    """Whether a Hessian's block of platforms ``m`` and ``l`` is formed: every block, or
    with ``partial`` only a platform's own block and the first platform's row and column
    of blocks (the planar structured KKT step's entries,
    :func:`stackik._compiled.planar._structured_kkt_factor`; zeros elsewhere)."""
    return not partial or m == l or m == 0 or l == 0


@_jit_inline
def formed_columns(a: int, k: int, N: int, partial: bool) -> tuple[int, int, int, int]:
    """The columns of row ``a`` (``k`` variables a platform, ``N`` in all) in blocks that
    :func:`block_formed` forms, as two ranges ``[c0, c1)`` and ``[c2, c3)``."""
    if not partial or a < k:
        return 0, N, 0, 0
    o = a - a % k
    return 0, k, o, o + k


@_jit_inline
def subtract_blocks_scaled(H: FloatArray, Hb: FloatArray, xs: FloatArray,
                           partial: bool = False) -> FloatArray:  # fmt: skip
    """``H - blockdiag(Hb)`` in the variables scaled by ``xs``: ``H[a, b] * xs[a] *
    xs[b]``, in place (``H`` (N, N), ``Hb`` (n, k, k) a platform's block, ``N = k n``);
    returns ``H``. With ``partial`` only the blocks :func:`block_formed` forms are scaled."""
    n, k = Hb.shape[0], Hb.shape[1]
    for i in range(n):
        for a in range(k):
            for b in range(k):
                H[k * i + a, k * i + b] -= Hb[i, a, b]
    for a in range(H.shape[0]):
        c0, c1, c2, c3 = formed_columns(a, k, H.shape[1], partial)
        for b in range(c0, c1):
            H[a, b] *= xs[a] * xs[b]
        for b in range(c2, c3):
            H[a, b] *= xs[a] * xs[b]
    return H


@_jit_inline
def add_distance_term(f: float, g: FloatArray, u: FloatArray, ug: FloatArray,
                      wq: float) -> float:  # fmt: skip
    """``f + wq |u - ug|^2``, its gradient added to ``g`` in place (a path step's pull
    toward ``ug``; nothing when ``wq <= 0``)."""
    if wq > 0.0:
        acc = 0.0
        for a in range(u.size):
            d = u[a] - ug[a]
            acc += d * d
            g[a] += 2.0 * wq * d
        f += wq * acc
    return f
