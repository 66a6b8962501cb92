"""Fixed CSC layouts of the QP data for the sparse solvers (OSQP, Clarabel).

The engine passes ``P`` and ``J`` either dense or as CSC matrices whose pattern arrays
stay the same objects while the pattern is unchanged (:mod:`stackik.sqp.sparse`).  A
layout turns them into the solver's CSC arrays once per pattern and afterwards only
gathers values, in the solver's nonzero order, for an in-place ``update``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def _new_sparse_pattern(key: tuple[Any, ...] | None, M: Any) -> bool:
    """True unless ``key`` records the CSC pattern arrays of ``M`` (the same objects or
    equal arrays)."""
    return (
        key is None
        or key[0] != "sparse"
        or not (_same(key[1], M.indptr) and _same(key[2], M.indices))
    )


def _same(a: Any, b: Any) -> bool:
    return a is b or (
        a is not None and b is not None and a.shape == b.shape and bool(np.array_equal(a, b))
    )


class TriuLayout:
    """The upper triangle of a symmetric ``P`` (dense, or CSC with both triangles)."""

    def __init__(self) -> None:
        self.key: tuple[Any, ...] | None = None
        self.indptr: Any = None
        self.indices: Any = None
        self.take: Any = None  # gather indices into the source values
        self.dense = True

    def values(self, P: Any) -> tuple[FloatArray, bool]:
        """``(data, changed)``: the triangle's values; changed: a new pattern."""
        changed = False
        if sp.issparse(P):
            if _new_sparse_pattern(self.key, P):
                n = P.shape[0]
                cols = np.repeat(np.arange(n), np.diff(P.indptr))
                keep = P.indices <= cols
                self.take = np.flatnonzero(keep)
                self.indices = P.indices[keep].astype(np.int64)
                self.indptr = np.zeros(n + 1, dtype=np.int64)
                np.cumsum(np.bincount(cols[keep], minlength=n), out=self.indptr[1:])
                self.key = ("sparse", P.indptr, P.indices)
                self.dense = False
                changed = True
            return np.ascontiguousarray(P.data[self.take]), changed
        n = P.shape[0]
        if self.key is None or self.key[0] != "dense" or self.key[1] != n:
            rows, cols = np.triu_indices(n)
            order = np.lexsort((rows, cols))
            rows, cols = rows[order], cols[order]
            self.take = rows * n + cols
            self.indices = rows.astype(np.int64)
            self.indptr = np.concatenate(([0], np.cumsum(np.arange(1, n + 1)))).astype(np.int64)
            self.key = ("dense", n)
            self.dense = True
            changed = True
        return np.ascontiguousarray(np.asarray(P).ravel()[self.take]), changed

    def matrix(self, data: FloatArray, n: int) -> Any:
        return sp.csc_matrix((data, self.indices, self.indptr), shape=(n, n))


class StackLayout:
    """``A = [diag(row_sign) J; s_1 I; s_2 I; ...]`` for a dense or CSC ``J``.

    ``identity_signs`` gives the sign of each identity block below ``J`` (the bounds on
    the step); their values are set once.
    """

    def __init__(self, row_sign: FloatArray, identity_signs: tuple[float, ...]) -> None:
        self.row_sign = row_sign
        self.identity_signs = identity_signs
        self.key: tuple[Any, ...] | None = None
        self.indptr: Any = None
        self.indices: Any = None
        self.pos: Any = None  # positions of J's values in A's data
        self.sign: Any = None  # row sign of each of J's values
        self.data: Any = None  # A's data buffer (identity values set once)

    def _build(self, indptr: Any, indices: Any, m: int, n: int) -> None:
        nb = len(self.identity_signs)
        cnt = np.diff(indptr).astype(np.int64)
        A_ptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(cnt + nb, out=A_ptr[1:])
        cols = np.repeat(np.arange(n), cnt)
        self.pos = A_ptr[cols] + (np.arange(cnt.sum()) - np.asarray(indptr)[cols])
        A_idx = np.empty(int(A_ptr[-1]), dtype=np.int64)
        A_idx[self.pos] = indices
        self.data = np.empty(A_idx.size)
        for b, s in enumerate(self.identity_signs):
            at = A_ptr[1:] - nb + b
            A_idx[at] = m + b * n + np.arange(n)
            self.data[at] = s
        self.sign = self.row_sign[np.asarray(indices)]
        self.indptr, self.indices = A_ptr, A_idx

    def values(self, J: Any) -> tuple[FloatArray, bool]:
        """``(data, changed)``: A's values (a buffer reused between calls)."""
        m, n = J.shape
        changed = False
        if sp.issparse(J):
            if _new_sparse_pattern(self.key, J):
                self._build(J.indptr, J.indices, m, n)
                self.key = ("sparse", J.indptr, J.indices)
                changed = True
            self.data[self.pos] = J.data * self.sign
            return self.data, changed
        if self.key is None or self.key[0] != "dense" or self.key[1] != (m, n):
            indptr = np.arange(0, m * n + 1, m, dtype=np.int64)
            indices = np.tile(np.arange(m, dtype=np.int64), n)
            self._build(indptr, indices, m, n)
            self.key = ("dense", (m, n))
            changed = True
        self.data[self.pos] = np.asarray(J).T.ravel() * self.sign
        return self.data, changed

    def matrix(self, rows: int, n: int) -> Any:
        return sp.csc_matrix((self.data.copy(), self.indices, self.indptr), shape=(rows, n))


def any_sparse(*mats: Any) -> bool:
    return any(sp.issparse(M) for M in mats)


def sqp_form(A_eq: Any, b_eq: FloatArray, G: Any, h: FloatArray) -> tuple[Any, FloatArray]:
    """``(J, c)`` with ``J = [A_eq; -G]``, ``c = [-b_eq; h]`` (CSC): the SQP form of
    ``A_eq d = b_eq, G d <= h`` (:meth:`QPBackend.solve_sqp`)."""
    J = sp.vstack((sp.csr_matrix(A_eq), -sp.csr_matrix(G)), format="csc")
    J.sort_indices()
    return J, np.concatenate((-np.asarray(b_eq, float), np.asarray(h, float)))
