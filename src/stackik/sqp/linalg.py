"""Dense and sparse linear algebra of the SQP engine, behind one interface.

:class:`DenseAlgebra` keeps the stacked Jacobian ``J = [J_E; J_I]`` and the QP Hessian as
NumPy arrays; :class:`SparseAlgebra` (chosen when the problem returns a Jacobian as a scipy
sparse matrix) keeps them as CSC matrices in fixed patterns (:mod:`stackik.sqp.sparse`).
The engine asks either for the same things: the scaled Jacobian blocks, the symmetrised
Hessian, its convexification (N&W Sec. 18.1 / IPOPT's inertia correction), ``J' D J``
added to a Hessian, the rows of ``J`` of a working set, and the matrices of an elastic QP.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.linalg.lapack import dpotrf as _dpotrf
from scipy.linalg.lapack import dsyev as _dsyev
from scipy.linalg.lapack import dsyevd as _dsyevd

from .problem import FloatArray
from .sparse import (
    FixedPattern,
    GramMap,
    StackedPattern,
    csc,
    diagonal_positions,
    entry_cols,
    gram_structure,
    is_sparse,
    positive_definite,
    transpose_permutation,
)

HESS_REG = 1e-8  # relative floor of the QP Hessian eigenvalues (convexity)
HESS_FLOOR = 1e-4  # absolute eigenvalue floor of a modified exact Hessian (no LP-like QPs)
AUG_TAUS = (1.0, 1e2, 1e4)  # tried multipliers of J_A'J_A for exact-Hessian convexification
ACTIVE_MULTIPLIER_TOL = 1e-6  # relative multiplier above which a row counts as active
SLACK_REG = 1e-8  # tiny curvature on elastic slacks keeps every backend's QP strictly convex
SOC_DENSE_MAX = 1 << 16  # sparse J: a dense J_A (rows x columns) up to this size


def as2d(J: Any, m: int, n: int) -> FloatArray:
    """``J`` as a dense ``(m, n)`` array (zeros for None or no rows)."""
    if J is None or m == 0:
        return np.zeros((m, n))
    if is_sparse(J):
        return np.asarray(J.toarray(), dtype=float).reshape(m, n)
    return np.asarray(J, dtype=float).reshape(m, n)


def row_absmax(J: Any) -> FloatArray:
    """``max_j |J_ij|`` per row, dense or sparse ``J``."""
    if is_sparse(J):
        if J.shape[0] == 0:
            return np.zeros(0)
        return np.asarray(abs(J).max(axis=1).toarray(), dtype=float).ravel()
    return np.abs(J).max(axis=1)  # type: ignore[no-any-return]


def values(M: Any) -> FloatArray:
    """The stored values of a dense or sparse matrix."""
    return M.data if is_sparse(M) else M  # type: ignore[no-any-return]


def all_finite(a: FloatArray) -> bool:
    """``np.all(np.isfinite(a))``, via one sum when that is finite (the usual case)."""
    return math.isfinite(float(a.sum())) or bool(np.all(np.isfinite(a)))


def active_rows(lam: FloatArray, mE: int) -> Any:
    """The equalities and the inequalities with a multiplier above
    ``ACTIVE_MULTIPLIER_TOL max(1, max|lam|)`` (interior-point backends return tiny
    positive multipliers on inactive rows), as a boolean mask."""
    lam_max = float(np.abs(lam).max()) if lam.size else 0.0
    act = lam > ACTIVE_MULTIPLIER_TOL * max(1.0, lam_max)
    act[:mE] = True
    return act


def _chol_ok(H: FloatArray, shift: float, eye: FloatArray) -> bool:
    """Whether the symmetric ``H - shift I`` is numerically positive definite (Cholesky
    succeeds; ``H`` is not modified)."""
    if shift == 0.0:
        return int(_dpotrf(H.T, lower=1, clean=0, overwrite_a=0)[1]) == 0
    # The transpose of the (symmetric, C-ordered) temporary is Fortran-ordered: no copy.
    return int(_dpotrf((H - shift * eye).T, lower=1, clean=0, overwrite_a=1)[1]) == 0


def elastic_qp(
    B: Any, g: FloatArray, J: Any, mE: int, slack_rows: Any, nu: float, sparse: bool
) -> tuple[Any, FloatArray, Any, Any]:
    """``(P, q, A_eq, G)`` of the l1-elastic QP in ``z = (d, p, r, s)``: ``c_E + J_E d = p -
    r`` and ``c_I + J_I d + E s >= 0`` (``E`` selects the rows ``slack_rows``, None: every
    row), slacks penalised by ``nu`` (and ``SLACK_REG`` curvature). ``sparse``: CSC."""
    n = g.size
    mI = J.shape[0] - mE
    k = mI if slack_rows is None else slack_rows.size
    nz = n + 2 * mE + k
    q = np.full(nz, nu)
    q[:n] = g
    if sparse:
        Jc = sp.csr_matrix(J)
        Bs = B if is_sparse(B) else sp.csr_matrix(B)
        P = sp.block_diag((Bs, sp.identity(nz - n) * SLACK_REG), format="csc")
        eye = sp.identity(mE, format="csr")
        A_eq = sp.hstack((Jc[:mE], -eye, eye, sp.csr_matrix((mE, k))), format="csc")
        if slack_rows is None:
            E = sp.identity(mI, format="csr")
        else:
            E = sp.csr_matrix((np.ones(k), (slack_rows, np.arange(k))), shape=(mI, k))
        G = sp.hstack((-Jc[mE:], sp.csr_matrix((mI, 2 * mE)), -E), format="csc")
        return P, q, A_eq, G
    P = np.zeros((nz, nz))
    P[:n, :n] = B
    idx = np.arange(n, nz)
    P[idx, idx] = SLACK_REG
    A_eq = np.zeros((mE, nz))
    A_eq[:, :n] = J[:mE]
    A_eq[:, n : n + mE] = -np.eye(mE)
    A_eq[:, n + mE : n + 2 * mE] = np.eye(mE)
    G = np.zeros((mI, nz))
    G[:, :n] = -J[mE:]
    if slack_rows is None:
        G[:, n + 2 * mE :] = -np.eye(mI)
    else:
        G[slack_rows, n + 2 * mE + np.arange(k)] = -1.0
    return P, q, A_eq, G


def elastic_box(
    absJ: Any, c: FloatArray, mE: int, slack_rows: Any, dvec: FloatArray,
    lb: FloatArray, ub: FloatArray,
) -> tuple[FloatArray, FloatArray]:  # fmt: skip
    """Bounds of the elastic QP's variables: the step's box, and finite slack bounds that
    can never bind: ``|c_i| + |J_i| dvec + 1`` (``dvec``: the box's half-widths; rows as
    in :func:`elastic_qp`)."""
    n = lb.size
    nz = n + 2 * mE + (c.size - mE if slack_rows is None else slack_rows.size)
    lbz = np.zeros(nz)
    ubz = np.empty(nz)
    lbz[:n] = lb
    ubz[:n] = ub
    ubz[n : n + mE] = np.abs(c[:mE]) + absJ[:mE] @ dvec + 1.0
    ubz[n + mE : n + 2 * mE] = ubz[n : n + mE]
    if slack_rows is None:
        ubz[n + 2 * mE :] = np.abs(c[mE:]) + absJ[mE:] @ dvec + 1.0
    else:
        ubz[n + 2 * mE :] = np.abs(c[mE:][slack_rows]) + absJ[mE:][slack_rows] @ dvec + 1.0
    return lbz, ubz


class DenseAlgebra:
    """Dense matrices (NumPy arrays) throughout."""

    sparse = False

    def __init__(self, n: int, mE: int, mI: int) -> None:
        self.n, self.mE, self.mI = n, mE, mI
        self.eye: FloatArray = np.eye(n)
        self.hess_modified = False  # the last exact Hessian needed convexification

    @property
    def full_hessian_pattern(self) -> bool:
        """Whether the QP Hessian's sparsity pattern is full (dense: no pattern)."""
        return False

    # ------------------------------------------------------------- Jacobians -----
    def raw_jacobians(self, JE: Any, JI: Any) -> tuple[Any, Any]:
        """The problem's Jacobian blocks at ``x0`` (unscaled), for the row scaling."""
        n = self.n
        return as2d(JE, self.mE, n), as2d(JI, self.mI, n)

    def jacobian(self, JE: Any, JI: Any, w: FloatArray, unit_w: bool) -> tuple[Any, Any, Any]:
        """Scaled ``(J, J_E, J_I)`` (the blocks views of ``J``)."""
        n, mE, mI = self.n, self.mE, self.mI
        J = np.empty((mE + mI, n))
        if mE:
            J[:mE] = as2d(JE, mE, n)
        if mI:
            J[mE:] = as2d(JI, mI, n)
        if not unit_w:
            J *= w[:, None]
        return J, J[:mE], J[mE:]

    def working_rows(self, J: Any, rows: Any) -> tuple[Any, FloatArray]:
        """``(J_A, J_A J_A')`` of the rows ``rows`` (sorted) of ``J``."""
        JA = J[rows]
        return JA, JA @ JA.T

    # -------------------------------------------------------------- Hessians -----
    def symmetric(self, Hraw: Any, sf: float, J: Any, dense: bool = False) -> Any:
        """``sf (H + H')/2`` of the problem's Hessian ``Hraw``."""
        if is_sparse(Hraw):
            Hraw = Hraw.toarray()
        H = np.asarray(Hraw, dtype=float).reshape(self.n, self.n)
        H = H + H.T
        H *= 0.5 * sf
        return H

    def gauss_newton(self, Jr: Any, scale: float, J: Any) -> Any:
        """``scale Jr'Jr`` plus ``HESS_REG max(1, max diag)`` on the diagonal."""
        if is_sparse(Jr):
            Jr = Jr.toarray()
        Jr = np.asarray(Jr, dtype=float)
        B = scale * (Jr.T @ Jr)
        reg = HESS_REG * max(1.0, float(np.max(np.diag(B)))) if self.n else 0.0
        B[np.diag_indices_from(B)] += reg
        return B

    def add_gram(self, H: Any, JI: Any, D: FloatArray, J: Any) -> Any:
        """``H + J_I' diag(D) J_I`` (a new matrix)."""
        return H + (JI * D[:, None]).T @ JI

    def _active_gram(self, J: Any, active: Any) -> tuple[Any, int]:
        JA = J[active]
        n_active = JA.shape[0]
        return (JA.T @ JA if n_active else None), n_active

    def _pd_enough(self, H: FloatArray, fro: float) -> bool:
        """Whether ``lambda_min(H) >= HESS_REG max(1, max|lambda(H)|)`` (the convexity test of
        the QP Hessian), for symmetric finite ``H`` with Frobenius norm ``fro``.

        Decided by Cholesky factorisations when possible: ``H`` not positive definite fails
        the test, ``H - HESS_REG max(1, fro) I`` positive definite passes it (``fro`` bounds
        ``max|lambda|``); only in between are the eigenvalues computed.
        """
        if math.isfinite(fro):
            if not _chol_ok(H, 0.0, self.eye):
                return False
            if _chol_ok(H, HESS_REG * max(1.0, fro), self.eye):
                return True
        w = np.linalg.eigvalsh(H)
        return bool(w[0] >= HESS_REG * max(1.0, float(np.max(np.abs(w)))))

    def convexify(self, H: Any, lam: FloatArray, J: Any) -> Any:
        """``H`` made positive definite: unchanged when it is; else ``H + tau J_A'J_A`` over
        the equalities and active inequalities (the same QP solution when that active set
        is kept and the reduced Hessian is positive definite); else eigenvalue clipping."""
        return self._convexify_dense(H, lam, J)

    def _convexify_dense(self, H: FloatArray, lam: FloatArray, J: Any) -> FloatArray:
        fro2 = float(np.vdot(H, H))
        if not math.isfinite(fro2) and not np.all(np.isfinite(H)):
            return np.eye(self.n)
        # Cheap exit: a shifted Cholesky factorisation certifies a positive definite enough H
        # (||H||_F bounds max|lambda|); otherwise the eigenvalues decide exactly.  Skipped
        # while the Hessians keep needing a modification (it would fail).
        fro = math.sqrt(fro2)
        if (
            not self.hess_modified
            and math.isfinite(fro)
            and _chol_ok(H, HESS_REG * max(1.0, fro), self.eye)
        ):
            return H
        self.hess_modified = True
        w, _v, info = _dsyev(H, compute_v=0, lower=1)
        if info != 0:  # pragma: no cover - LAPACK failure, retry through numpy
            w = np.linalg.eigvalsh(H)
        scale = max(1.0, float(max(abs(w[0]), abs(w[-1]))))
        floor = max(HESS_REG * scale, HESS_FLOOR)
        if w[0] >= HESS_REG * scale:
            self.hess_modified = False
            return H
        JtJ, n_active = self._active_gram(J, active_rows(lam, self.mE))
        if n_active:
            # max|JtJ| is on the diagonal of a Gram matrix.
            nj = max(float(JtJ.diagonal().max()), 1e-300)
            for tau in AUG_TAUS:
                Ha = H + (tau * max(1.0, -w[0]) / nj) * JtJ
                if self._pd_enough(Ha, math.sqrt(float(np.vdot(Ha, Ha)))):
                    return Ha
        # Eigenvalue clipping.
        w, V, info = _dsyevd(H, compute_v=1, lower=1)
        if info != 0:  # pragma: no cover - LAPACK failure, retry through numpy
            w, V = np.linalg.eigh(H)
        w = np.maximum(w, floor)
        Hc: FloatArray = (V * w) @ V.T
        return 0.5 * (Hc + Hc.T)


class SparseAlgebra(DenseAlgebra):
    """CSC matrices in fixed patterns (see :mod:`stackik.sqp.sparse`): the Jacobian blocks
    and the QP Hessian, whose pattern (structurally symmetric: the problem's, its
    transpose, the diagonal and that of ``J'J``) no convexification changes."""

    sparse = True

    def __init__(self, n: int, mE: int, mI: int) -> None:
        super().__init__(n, mE, mI)
        self.je_pat = FixedPattern((mE, n))
        self.ji_pat = FixedPattern((mI, n))
        self.j_stack = StackedPattern(mE, mI, n)
        self.h_pat = FixedPattern((n, n))
        self.h_src: tuple[Any, Any] | None = None  # pattern arrays perm/diag belong to
        self.h_perm: Any = None  # data[perm]: data of the transpose
        self.h_diag: Any = None  # positions of the diagonal
        self.h_shift = 0.0  # last diagonal shift of the convexification
        self.gram_maps: dict[int, GramMap] = {}
        self.gram_src: tuple[Any, Any] | None = None

    @property
    def full_hessian_pattern(self) -> bool:
        return self.h_pat.full

    # ------------------------------------------------------------- Jacobians -----
    def raw_jacobians(self, JE: Any, JI: Any) -> tuple[Any, Any]:
        n = self.n
        return (
            self.je_pat.fit(np.zeros((0, n)) if JE is None else JE),
            self.ji_pat.fit(np.zeros((0, n)) if JI is None else JI),
        )

    def jacobian(self, JE: Any, JI: Any, w: FloatArray, unit_w: bool) -> tuple[Any, Any, Any]:
        n, mE = self.n, self.mE
        A = self.je_pat.fit(np.zeros((0, n)) if JE is None else JE)
        B = self.ji_pat.fit(np.zeros((0, n)) if JI is None else JI)
        Js = self.j_stack.stack(A, B)
        if not unit_w:
            Js.data *= w[Js.indices]
            A.data *= w[:mE][A.indices]
            B.data *= w[mE:][B.indices]
        # scaled row blocks in their own fixed patterns
        return Js, A, B

    def working_rows(self, J: Any, rows: Any) -> tuple[Any, FloatArray]:
        if rows.size * self.n <= SOC_DENSE_MAX:
            JA = self._dense_rows(J, rows)
            return JA, JA @ JA.T
        JA = J.tocsr()[rows]
        return JA, (JA @ JA.T).toarray()

    def _dense_rows(self, J: Any, rows: Any) -> FloatArray:
        """Rows ``rows`` (sorted) of the sparse ``J`` as a dense array, gathered from its
        entries (no CSR conversion or sparse row slicing; docs/benchmarks.md)."""
        pos = np.full(J.shape[0], -1, dtype=np.int64)
        pos[rows] = np.arange(rows.size)
        at = pos[J.indices]
        sel = at >= 0
        JA = np.zeros((rows.size, self.n))
        idx = (at[sel], entry_cols(J.indptr)[sel])
        if J.has_canonical_format:  # no duplicate entries: plain assignment
            JA[idx] = J.data[sel]
        else:
            np.add.at(JA, idx, J.data[sel])
        return JA

    # -------------------------------------------------------------- Hessians -----
    def symmetric(self, Hraw: Any, sf: float, J: Any, dense: bool = False) -> Any:
        """As :meth:`DenseAlgebra.symmetric`, as CSC in the fixed pattern; with ``dense`` a
        dense ``Hraw`` stays dense (a full pattern is convexified densely anyway)."""
        if dense and not is_sparse(Hraw):
            return super().symmetric(Hraw, sf, J)
        Hs = self._fit(Hraw, J)
        Hs.data *= sf
        return Hs

    def gauss_newton(self, Jr: Any, scale: float, J: Any) -> Any:
        G = Jr.T @ Jr
        Hs = self._fit(G.tocsc() if is_sparse(G) else G, J)
        Hs.data *= scale
        diag = Hs.data[self.h_diag]
        Hs.data[self.h_diag] += HESS_REG * max(1.0, float(diag.max()) if diag.size else 1.0)
        return Hs

    def add_gram(self, H: Any, JI: Any, D: FloatArray, J: Any) -> Any:
        self._ensure_gram_pattern(J)
        if H.indices is not self.h_pat.indices:
            H = self.h_pat.fit(H)
        return csc(H.data + self._gram(JI, D), H.indices, H.indptr, H.shape)

    def _fit(self, Hraw: Any, J: Any) -> Any:
        """``(H + H')/2`` as a CSC matrix in the fixed QP Hessian pattern."""
        n = self.n
        pat = self.h_pat
        if pat.indices is None:
            if not is_sparse(Hraw):  # a dense Hessian: the full pattern, nothing to add
                pat.include(Hraw)
            pat.include(sp.identity(n, format="csc"))
            if J.shape[0] and not pat.full:
                pat.include(gram_structure(J))
        H = pat.fit(Hraw)
        if self._sync_pattern():
            H = pat.fit(Hraw)
        H.data = 0.5 * (H.data + H.data[self.h_perm])
        return H

    def _ensure_gram_pattern(self, J: Any) -> None:
        """The Hessian pattern contains that of ``J'J`` for the current ``J`` pattern."""
        seen = self.gram_src
        if seen is not None and seen[0] is J.indptr and seen[1] is J.indices:
            return
        if not self.h_pat.full:
            self.h_pat.include(gram_structure(J))
        self._sync_pattern()
        self.gram_src = (J.indptr, J.indices)

    def _sync_pattern(self) -> bool:
        """After the Hessian pattern grew: make it symmetric again and recompute the
        transpose permutation and the diagonal positions (True if it had grown)."""
        pat, n = self.h_pat, self.n
        src = self.h_src
        if src is not None and src[0] is pat.indptr and src[1] is pat.indices:
            return False
        assert pat.indices is not None and pat.indptr is not None
        ones = csc(np.ones(pat.indices.size), pat.indices, pat.indptr, (n, n))
        pat.include(ones.T)
        assert pat.indices is not None and pat.indptr is not None
        self.h_perm = transpose_permutation(pat.indptr, pat.indices, n)
        self.h_diag = diagonal_positions(pat.indptr, pat.indices, n)
        self.h_src = (pat.indptr, pat.indices)
        return True

    def _gram(self, J: Any, w: FloatArray) -> FloatArray:
        """Data of ``J' diag(w) J`` in the Hessian pattern (sparse ``J``, fixed pattern
        within that of the full ``J``; the Hessian pattern must be current)."""
        pat = self.h_pat
        gm = self.gram_maps.get(id(J.indptr))
        if gm is None or not gm.matches(J, pat.indptr, pat.indices):
            gm = GramMap(J, pat.indptr, pat.indices)
            self.gram_maps[id(J.indptr)] = gm
        return gm.values(J.data, w)

    def _active_gram(self, J: Any, active: Any) -> tuple[Any, int]:
        # J'J of the active rows, gathered into the (full) pattern
        self._ensure_gram_pattern(J)
        n = self.n
        return self._gram(J, active.astype(float)).reshape(n, n).T, int(active.sum())

    def _shifted(self, H: Any, shift: float) -> Any:
        """``H + shift I`` in the same pattern (a new matrix)."""
        data = H.data.copy()
        data[self.h_diag] += shift
        return csc(data, H.indices, H.indptr, H.shape)

    def convexify(self, H: Any, lam: FloatArray, J: Any) -> Any:
        """The dense rule's sparse twin: the test is an LDL' factorisation (all pivots
        positive), the modifications keep the pattern: ``H + tau J_A'J_A`` as in the dense
        case, else ``H + delta I`` with ``delta`` raised from the last one (IPOPT's inertia
        correction) instead of eigenvalue clipping. ``H`` may be dense when the pattern is
        full (:meth:`symmetric` with ``dense``): then the dense rule (no fill)."""
        n = self.n
        if not is_sparse(H) or H.data.size == n * n:
            # a full pattern (e.g. a dense Hessian with a sparse Jacobian): the dense
            # convexification (eigenvalues) costs no fill; values back in column order
            Hd = self._convexify_dense(H if not is_sparse(H) else H.toarray(), lam, J)
            pat = self.h_pat
            assert pat.indices is not None and pat.indptr is not None
            return csc(np.ascontiguousarray(Hd.T).ravel(), pat.indices, pat.indptr, (n, n))
        data = H.data
        fro = math.sqrt(float(data @ data))
        if not math.isfinite(fro):
            return self._shifted(csc(np.zeros_like(data), H.indices, H.indptr, H.shape), 1.0)
        reg = HESS_REG * max(1.0, fro)
        if positive_definite(self._shifted(H, -reg)):
            self.hess_modified = False
            self.h_shift = 0.0
            return H
        self.hess_modified = True
        active = active_rows(lam, self.mE)
        if active.any():
            self._ensure_gram_pattern(J)
            if H.indices is not self.h_pat.indices:
                H = self.h_pat.fit(H)
                data = H.data
            JtJ = self._gram(J, active.astype(float))
            nj = max(float(JtJ[self.h_diag].max()), 1e-300)
            for tau in AUG_TAUS:
                coef = tau * 1e-2 * max(1.0, fro) / nj
                Ha = csc(data + coef * JtJ, H.indices, H.indptr, H.shape)
                if positive_definite(self._shifted(Ha, -reg)):
                    return Ha
        return self._diagonal_shift(H, fro, reg)

    def _diagonal_shift(self, H: Any, fro: float, reg: float) -> Any:
        """``H + delta I``, ``delta`` from a quarter of the last one up by factors 8."""
        delta = max(HESS_FLOOR, 1e-4 * max(1.0, fro), self.h_shift / 4.0)
        while delta < 1e12 * max(1.0, fro):
            Hd = self._shifted(H, delta)
            if positive_definite(self._shifted(Hd, -reg)):
                self.h_shift = delta
                return Hd
            delta *= 8.0
        return self._shifted(csc(np.zeros_like(H.data), H.indices, H.indptr, H.shape), 1.0)


def make_algebra(sparse: bool, n: int, mE: int, mI: int) -> DenseAlgebra:
    """The dense or sparse algebra for a problem of ``n`` variables, ``mE`` + ``mI`` rows."""
    return SparseAlgebra(n, mE, mI) if sparse else DenseAlgebra(n, mE, mI)
