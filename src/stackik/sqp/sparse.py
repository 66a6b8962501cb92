"""Sparse matrices of the SQP engine: fixed CSC patterns and a sparse definiteness test.

A problem may return its Jacobians and Hessian as :mod:`scipy.sparse` matrices. The engine
keeps each of them in one *fixed* CSC pattern (:class:`FixedPattern`: the union of every
pattern seen, explicit zeros kept, indices sorted, the same ``indptr``/``indices`` array
objects from call to call), so that the QP backends can set their solvers up once and
afterwards only pass new values (``OSQP.update(Px=, Ax=)``, Clarabel's ``update``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

try:  # a dependency of cvxpy (itself a stackik dependency); optional here
    import qdldl as _qdldl
except ImportError:  # pragma: no cover - fallback: dense Cholesky
    _qdldl = None


def is_sparse(M: Any) -> bool:
    """Whether ``M`` is a scipy sparse matrix or array."""
    return bool(sp.issparse(M))


def _csc_checked(
    data: FloatArray, indices: IntArray, indptr: IntArray, shape: tuple[int, int]
) -> Any:
    M = sp.csc_matrix(shape, dtype=float)
    M.data, M.indices, M.indptr = data, indices, indptr
    M.has_sorted_indices = True  # the patterns built here are sorted, without duplicates
    M.has_canonical_format = True
    return M


_BASE = dict(sp.csc_matrix((1, 1)).__dict__)


def _csc_fast(data: FloatArray, indices: IntArray, indptr: IntArray, shape: tuple[int, int]) -> Any:
    # scipy's constructor validates the arrays (O(nnz) and ~25 us of Python per matrix,
    # the engine's main overhead at small n); the arrays built here are valid by
    # construction, so the attributes are set directly (checked once at import below)
    M = sp.csc_matrix.__new__(sp.csc_matrix)
    M.__dict__.update(_BASE)
    M.data, M.indices, M.indptr, M._shape = data, indices, indptr, shape
    return M


def _fast_ok() -> bool:
    try:
        A = _csc_fast(
            np.array([1.0, 2.0]), np.array([0, 1], np.int32), np.array([0, 1, 2], np.int32), (2, 2)
        )
        ok = np.array_equal(A.toarray(), np.diag([1.0, 2.0]))
        ok = ok and np.array_equal(A.T @ np.ones(2), [1.0, 2.0])
        return bool(ok and np.array_equal((A @ A).toarray(), np.diag([1.0, 4.0])))
    except Exception:  # noqa: BLE001 - another scipy: the checked constructor
        return False


#: ``csc(data, indices, indptr, shape)``: a CSC matrix on the given arrays, without copies,
#: checks or zero dropping (the arrays must be valid: sorted, no duplicates, one dtype).
csc = _csc_fast if _fast_ok() else _csc_checked

_COLS: dict[int, tuple[Any, Any]] = {}


def entry_cols(indptr: Any) -> Any:
    """Column of every stored entry of a CSC pattern (cached per ``indptr`` object)."""
    hit = _COLS.get(id(indptr))
    if hit is not None and hit[0] is indptr:
        return hit[1]
    cols = np.repeat(np.arange(indptr.size - 1), np.diff(indptr))
    if len(_COLS) > 64:
        _COLS.clear()
    _COLS[id(indptr)] = (indptr, cols)
    return cols


def matvec(A: Any, x: FloatArray) -> FloatArray:
    """``A @ x`` for a dense array or a CSC matrix (no scipy dispatch)."""
    if not sp.issparse(A):
        return A @ x  # type: ignore[no-any-return]
    return np.asarray(
        np.bincount(A.indices, weights=A.data * x[entry_cols(A.indptr)], minlength=A.shape[0]),
        dtype=np.float64,
    )


def rmatvec(A: Any, y: FloatArray) -> FloatArray:
    """``A.T @ y`` for a dense array or a CSC matrix (no scipy dispatch)."""
    if not sp.issparse(A):
        return A.T @ y  # type: ignore[no-any-return]
    return np.asarray(
        np.bincount(entry_cols(A.indptr), weights=A.data * y[A.indices], minlength=A.shape[1]),
        dtype=np.float64,
    )


def _keys(indptr: IntArray, indices: IntArray, nrows: int) -> IntArray:
    cols = np.repeat(np.arange(indptr.size - 1, dtype=np.int64), np.diff(indptr))
    return cols * nrows + indices.astype(np.int64)


class FixedPattern:
    """Keeps matrices of one shape in one CSC pattern (grown to the union when needed).

    :meth:`fit` returns a CSC matrix whose ``indptr`` and ``indices`` are this object's
    arrays: the same objects as long as the pattern does not grow, so a consumer can
    recognise an unchanged pattern by identity.
    """

    def __init__(self, shape: tuple[int, int]) -> None:
        self.shape = shape
        self.indptr: IntArray | None = None
        self.indices: IntArray | None = None
        self._keys: IntArray = np.zeros(0, dtype=np.int64)
        self._src: tuple[Any, Any] | None = None  # (indptr, indices) of the last source
        self._pos: IntArray | None = None  # positions of the last source's entries

    @property
    def nnz(self) -> int:
        return 0 if self.indices is None else int(self.indices.size)

    @property
    def full(self) -> bool:
        """Whether the pattern holds every entry (nothing can grow it)."""
        return self.indices is not None and self.indices.size == self.shape[0] * self.shape[1]

    def include(self, M: Any) -> None:
        """Grow the pattern to contain the structure of ``M`` (sparse or dense: all)."""
        if self.full:
            return
        m, n = self.shape
        if is_sparse(M):
            A = sp.csc_matrix(M, copy=True)
            A.sum_duplicates()
            k = _keys(A.indptr, A.indices, m)
        else:
            k = np.arange(m * n, dtype=np.int64)
            k = (k % n) * m + k // n  # column-major keys of every entry
        keys = np.union1d(self._keys, k)
        if self.indices is not None and keys.size == self._keys.size:
            return
        self._keys = keys
        cols = keys // max(m, 1)
        self.indices = (keys - cols * m).astype(np.int32)
        self.indptr = np.searchsorted(cols, np.arange(n + 1)).astype(np.int32)
        self._src = None
        self._pos = None

    def fit(self, M: Any) -> Any:
        """``M`` (sparse or dense) as a CSC matrix in this pattern (grown if needed)."""
        m, n = self.shape
        if not is_sparse(M):
            D = np.asarray(M, dtype=float).reshape(m, n)
            if self.indices is None or self.nnz != m * n:
                self.include(D)
            assert self.indices is not None and self.indptr is not None
            return csc(D.T.copy(order="C").ravel(), self.indices, self.indptr, (m, n))
        A = M if isinstance(M, sp.csc_matrix) else sp.csc_matrix(M)
        if not A.has_canonical_format:
            A = A.copy()
            A.sum_duplicates()  # sorted, no duplicates (explicit zeros kept)
        if self.indices is None:
            self.include(A)
        assert self.indices is not None and self.indptr is not None
        src = self._src
        if src is not None and src[0] is A.indptr and src[1] is A.indices:
            pos = self._pos
        elif (
            A.indices.size == self.indices.size
            and np.array_equal(A.indptr, self.indptr)
            and np.array_equal(A.indices, self.indices)
        ):
            pos = None
            self._src, self._pos = (A.indptr, A.indices), None
        else:
            k = _keys(A.indptr, A.indices, m)
            pos = np.searchsorted(self._keys, k)
            if pos.size and (pos.max() >= self._keys.size or (self._keys[pos] != k).any()):
                self.include(A)
                pos = np.searchsorted(self._keys, k)
            self._src, self._pos = (A.indptr, A.indices), pos
        if pos is None:
            data = np.array(A.data, dtype=float)
        else:
            data = np.zeros(self.indices.size)
            data[pos] = A.data
        return csc(data, self.indices, self.indptr, (m, n))


def diagonal_positions(indptr: IntArray, indices: IntArray, n: int) -> IntArray:
    """Positions of the diagonal entries in a square CSC pattern that contains them all."""
    pos = np.empty(n, dtype=np.int64)
    for j in range(n):
        lo, hi = int(indptr[j]), int(indptr[j + 1])
        pos[j] = lo + int(np.searchsorted(indices[lo:hi], j))
    return pos


def transpose_permutation(indptr: IntArray, indices: IntArray, n: int) -> IntArray:
    """For a structurally symmetric square CSC pattern: ``perm`` with ``data[perm]`` the
    data of the transpose (same pattern)."""
    keys = _keys(indptr, indices, n)
    cols = keys // n
    rows = keys - cols * n
    pos = np.searchsorted(keys, rows * n + cols)
    if pos.size and (pos.max() >= keys.size or (keys[pos] != rows * n + cols).any()):
        raise ValueError("the Hessian's sparsity pattern must be symmetric")
    return pos


def positive_definite(M: Any) -> bool:
    """Whether the symmetric sparse ``M`` is numerically positive definite (an LDL'
    factorisation with all pivots positive; dense Cholesky when qdldl is missing)."""
    if _qdldl is not None:
        try:
            d = _qdldl.Solver(M).factors()[1]
        except Exception:  # noqa: BLE001 - a zero pivot: not positive definite
            return False
        return bool(np.all(d > 0.0) and np.all(np.isfinite(d)))
    try:  # pragma: no cover - fallback without qdldl
        np.linalg.cholesky(M.toarray())
    except np.linalg.LinAlgError:
        return False
    return True


class StackedPattern:
    """``[A; B]`` of two CSC matrices with fixed patterns (from :class:`FixedPattern`), in a
    fixed pattern of its own, rebuilt only when an input pattern changes."""

    def __init__(self, m_top: int, m_bottom: int, n: int) -> None:
        self.shape = (m_top + m_bottom, n)
        self.m_top = m_top
        self._src: tuple[Any, ...] | None = None
        self.indptr: Any = np.zeros(n + 1, dtype=np.int32)
        self.indices: Any = np.zeros(0, dtype=np.int32)
        self._pa: IntArray = np.zeros(0, dtype=np.int64)
        self._pb: IntArray = np.zeros(0, dtype=np.int64)

    def _layout(self, A: Any, B: Any) -> None:
        n = self.shape[1]
        ca = np.diff(A.indptr).astype(np.int64)
        cb = np.diff(B.indptr).astype(np.int64)
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(ca + cb, out=indptr[1:])
        cols_a = np.repeat(np.arange(n), ca)
        cols_b = np.repeat(np.arange(n), cb)
        # entry k of A's column j goes to indptr[j] + (k - A.indptr[j])
        self._pa = indptr[cols_a] + (np.arange(ca.sum()) - A.indptr[cols_a])
        self._pb = indptr[cols_b] + ca[cols_b] + (np.arange(cb.sum()) - B.indptr[cols_b])
        indices = np.empty(int(indptr[-1]), dtype=np.int32)
        indices[self._pa] = A.indices
        indices[self._pb] = B.indices + self.m_top
        self.indptr, self.indices = indptr.astype(np.int32), indices
        self._src = (A.indptr, A.indices, B.indptr, B.indices)

    def stack(self, A: Any, B: Any) -> Any:
        src = self._src
        if src is None or not (
            src[0] is A.indptr
            and src[1] is A.indices
            and src[2] is B.indptr
            and src[3] is B.indices
        ):
            self._layout(A, B)
        data = np.empty(self.indices.size)
        data[self._pa] = A.data
        data[self._pb] = B.data
        return csc(data, self.indices, self.indptr, self.shape)


def gram_structure(J: Any) -> Any:
    """Structure (ones) of ``J'J`` for a sparse ``J``."""
    S = sp.csc_matrix((np.ones(J.indices.size), J.indices, J.indptr), shape=J.shape)
    return (S.T @ S).tocsc()


class GramMap:
    """``J' diag(w) J`` of a CSC ``J`` (fixed pattern) as values in a fixed symmetric CSC
    pattern that contains its structure (:class:`FixedPattern` of the Hessian): O(sum of
    squared row counts) work, no scipy objects."""

    def __init__(self, J: Any, h_indptr: Any, h_indices: Any) -> None:
        m, n = J.shape
        self.key = (J.indptr, J.indices, h_indptr, h_indices)
        cols = entry_cols(J.indptr)
        rows = np.asarray(J.indices, dtype=np.int64)
        order = np.argsort(rows, kind="stable")
        counts = np.bincount(rows, minlength=m)
        starts = np.zeros(m, dtype=np.int64)
        np.cumsum(counts[:-1], out=starts[1:])
        sq = counts * counts
        total = int(sq.sum())
        self.rows = np.repeat(np.arange(m), sq)
        off = np.zeros(m, dtype=np.int64)
        np.cumsum(sq[:-1], out=off[1:])
        t = np.arange(total) - off[self.rows]
        k = counts[self.rows]
        self.p = order[starts[self.rows] + t // k]
        self.q = order[starts[self.rows] + t % k]
        keys_h = _keys(h_indptr, h_indices, n)
        want = cols[self.q] * n + cols[self.p]  # (row cols[p], column cols[q])
        pos = np.searchsorted(keys_h, want)
        if pos.size and (pos.max() >= keys_h.size or (keys_h[pos] != want).any()):
            raise ValueError("the Hessian pattern does not contain that of J'J")
        self.pos = pos
        self.nnz = int(keys_h.size)

    def matches(self, J: Any, h_indptr: Any, h_indices: Any) -> bool:
        k = self.key
        return k[0] is J.indptr and k[1] is J.indices and k[2] is h_indptr and k[3] is h_indices

    def values(self, Jdata: FloatArray, w: FloatArray) -> FloatArray:
        """Data of ``J' diag(w) J`` in the Hessian pattern."""
        return np.asarray(
            np.bincount(
                self.pos, weights=w[self.rows] * Jdata[self.p] * Jdata[self.q], minlength=self.nnz
            ),
            dtype=np.float64,
        )


class RowSubset:
    """Rows ``rows`` (sorted) of a CSC matrix with a fixed pattern, as CSC (fixed pattern)."""

    def __init__(self, J: Any, rows: Any) -> None:
        m, n = J.shape
        self.key = (J.indptr, J.indices)
        remap = np.full(m, -1, dtype=np.int64)
        remap[rows] = np.arange(rows.size)
        new_rows = remap[J.indices]
        self.take = np.flatnonzero(new_rows >= 0)
        cols = entry_cols(J.indptr)[self.take]
        self.indices = new_rows[self.take].astype(J.indices.dtype)
        self.indptr = np.searchsorted(cols, np.arange(n + 1)).astype(J.indptr.dtype)
        self.shape = (int(rows.size), n)

    def matches(self, J: Any) -> bool:
        return self.key[0] is J.indptr and self.key[1] is J.indices

    def __call__(self, J: Any) -> Any:
        return csc(J.data[self.take], self.indices, self.indptr, self.shape)
