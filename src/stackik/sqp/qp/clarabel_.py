"""Clarabel backend (interior point), using its in-place data update path.

Clarabel solves ``min 1/2 x'Px + q'x  s.t.  A x + s = b,  s in K``.  Rows are ordered
``[A_eq (zero cone); G; I; -I]`` (the last three in one non-negative cone; the identity
blocks carry ``d <= ub`` and ``-d <= -lb``).  The solver object is built once per shape
from CSC arrays assembled directly with numpy over a dense pattern (presolve and
structural-zero dropping disabled), and later QPs only call
``solver.update(P=..., q=..., A=..., b=...)`` with the new nonzero values.  Sparse (CSC)
``P`` and ``J`` keep their own patterns (:mod:`stackik.sqp.qp._layout`), so that Clarabel's
sparse LDL' does work proportional to their nonzeros.
"""

from __future__ import annotations

import math
import time
from typing import Any

import clarabel
import numpy as np
import scipy.sparse as sp

from ._layout import StackLayout, TriuLayout, any_sparse, sqp_form
from .base import FloatArray, QPBackend, QPSolution, QPStatus

#: Tolerance settings that :meth:`ClarabelBackend.set_accuracy` moves together.
_TOL_KEYS = ("tol_gap_abs", "tol_gap_rel", "tol_feas")

#: Settings tuned for SQP subproblems; user ``qp_options`` override them.
DEFAULT_SETTINGS: dict[str, Any] = {
    "verbose": False,
    "presolve_enable": False,
    "input_sparse_dropzeros": False,
    "tol_gap_abs": 1e-10,
    "tol_gap_rel": 1e-10,
    "tol_feas": 1e-10,
    "tol_ktratio": 1e-8,
    "max_iter": 200,
}


def _status_name(status: Any) -> str:
    return str(status).split(".")[-1]


class ClarabelBackend(QPBackend):
    """Clarabel with a dense pattern and in-place ``update``."""

    sparse_sqp = True

    name = "clarabel"

    def __init__(self, options: dict[str, Any] | None = None) -> None:
        super().__init__(options)
        self.settings = {**DEFAULT_SETTINGS, **self.options}
        self._solver: Any = None
        self._sp_solver: Any = None

    def set_accuracy(self, eps: float | None) -> None:
        """Solve the next QPs to ``eps`` (gap and feasibility; None: the settings' values;
        user-given tolerances are kept)."""
        base = {**DEFAULT_SETTINGS, **self.options}
        if eps is None or any(k in self.options for k in _TOL_KEYS):
            new = {k: base[k] for k in _TOL_KEYS}
        else:
            new = {k: max(float(eps), float(base[k])) for k in _TOL_KEYS}
        new["tol_ktratio"] = (
            base["tol_ktratio"]
            if eps is None
            else max(float(base["tol_ktratio"]), min(1e-6, 100.0 * eps))
        )
        if all(self.settings[k] == v for k, v in new.items()):
            return
        self.settings.update(new)
        for solver in (self._solver, self._sp_solver):
            if solver is not None:
                solver.update(settings=self._make_settings())

    def setup(self, n: int, m_eq: int, m_ineq: int) -> None:
        super().setup(n, m_eq, m_ineq)
        self._solver = None
        # the dense path's arrays are made on its first QP (sparse QPs never use them; the
        # engine's screening calls setup whenever its row set changes)
        self._dense_ready = False
        self._b = np.empty(m_eq + m_ineq + 2 * n)
        # sparse path: rows [J_E; -J_I; I; -I]
        self._sp_solver = None
        self._triu = TriuLayout()
        self._stack = StackLayout(np.r_[np.ones(m_eq), -np.ones(m_ineq)], (1.0, -1.0))

    def _dense_setup(self) -> None:
        """The dense path's constraint matrix (identity blocks filled) and ``P``'s upper
        triangle in column order."""
        n, me, mi = self.n, self.m_eq, self.m_ineq
        rows, cols = np.triu_indices(n)
        order = np.lexsort((rows, cols))
        self._triu_rows, self._triu_cols = rows[order], cols[order]
        self._A = np.zeros((me + mi + 2 * n, n))
        self._A[me + mi : me + mi + n] = np.eye(n)
        self._A[me + mi + n :] = -np.eye(n)
        self._dense_ready = True

    def _make_settings(self) -> Any:
        st = clarabel.DefaultSettings()
        for key, val in self.settings.items():
            if not hasattr(st, key):
                raise ValueError(f"unknown clarabel setting {key!r}")
            setattr(st, key, val)
        return st

    def solve(
        self,
        P: FloatArray,
        q: FloatArray,
        A_eq: FloatArray,
        b_eq: FloatArray,
        G: FloatArray,
        h: FloatArray,
        lb: FloatArray,
        ub: FloatArray,
        warm: QPSolution | None = None,
    ) -> QPSolution:
        if any_sparse(P, A_eq, G):
            J, c = sqp_form(A_eq, b_eq, G, h)
            return self._solve_sparse(P, q, J, c, lb, ub)
        n, me, mi = self.n, self.m_eq, self.m_ineq
        if not self._dense_ready:
            self._dense_setup()
        A, b = self._A, self._b
        A[:me] = A_eq
        A[me : me + mi] = G
        b[:me] = b_eq
        b[me : me + mi] = h
        b[me + mi : me + mi + n] = ub
        b[me + mi + n :] = -lb
        Px = np.ascontiguousarray(P[self._triu_rows, self._triu_cols])
        Ax = np.ascontiguousarray(A.T.ravel())
        rebuild = self._solver is None or not self._solver.is_data_update_allowed()
        return self._run("_solver", rebuild, self._dense_matrices, Px, q, Ax, b)

    def _dense_matrices(self, Px: FloatArray, Ax: FloatArray) -> tuple[Any, Any]:
        """CSC ``P`` (upper triangle) and ``A`` of the dense path from their values."""
        n, m = self.n, self._A.shape[0]
        P_ptr = np.concatenate(([0], np.cumsum(np.arange(1, n + 1)))).astype(np.int64)
        P_csc = sp.csc_matrix((Px, self._triu_rows, P_ptr), shape=(n, n))
        A_ptr = np.arange(0, m * n + 1, m, dtype=np.int64)
        A_idx = np.tile(np.arange(m, dtype=np.int64), n)
        return P_csc, sp.csc_matrix((Ax, A_idx, A_ptr), shape=(m, n))

    def _run(
        self, slot: str, rebuild: bool, matrices: Any, Px: FloatArray, q: FloatArray,
        Ax: FloatArray, b: FloatArray,
    ) -> QPSolution:  # fmt: skip
        """Solve with the persistent solver in ``slot`` (the dense or the sparse path's):
        a new one from ``matrices(Px, Ax)`` when ``rebuild``, else its data updated in
        place; a backend error drops it and becomes a status."""
        try:
            solver = getattr(self, slot)
            if rebuild:
                P_csc, A_csc = matrices(Px, Ax)
                solver = self._new_solver(P_csc, q, A_csc, b)
                setattr(self, slot, solver)
            else:
                solver.update(P=Px, q=q, A=Ax, b=b)
            sol = solver.solve()
        except ValueError:
            raise
        except Exception as exc:  # noqa: BLE001 - any backend error becomes a status
            setattr(self, slot, None)
            return self.failed(f"clarabel raised {exc!r}")
        return self._result(sol)

    def _new_solver(self, P: Any, q: FloatArray, A: Any, b: FloatArray) -> Any:
        me, mi, n = self.m_eq, self.m_ineq, self.n
        cones = []
        if me:
            cones.append(clarabel.ZeroConeT(me))
        cones.append(clarabel.NonnegativeConeT(mi + 2 * n))
        solver = clarabel.DefaultSolver(P, q, A, b, cones, self._make_settings())
        if math.isfinite(self.deadline):
            # stop an interior-point run that would outlast the SQP time budget
            solver.set_termination_callback(lambda _info: time.perf_counter() > self.deadline)
        return solver

    def _solve_sparse(
        self, P: Any, q: FloatArray, J: Any, c: FloatArray, lb: FloatArray, ub: FloatArray
    ) -> QPSolution:
        """The SQP-form QP with sparse ``P`` and/or ``J``, on their own patterns."""
        n, me, mi = self.n, self.m_eq, self.m_ineq
        b = self._b
        np.negative(c[:me], out=b[:me])
        b[me : me + mi] = c[me:]
        b[me + mi : me + mi + n] = ub
        np.negative(lb, out=b[me + mi + n :])
        Px, new_p = self._triu.values(P)
        Ax, new_a = self._stack.values(J)
        rebuild = self._sp_solver is None or new_p or new_a
        return self._run("_sp_solver", rebuild, self._sparse_matrices, Px, q, Ax, b)

    def _sparse_matrices(self, Px: FloatArray, Ax: FloatArray) -> tuple[Any, Any]:
        """CSC ``P`` and ``A`` of the sparse path on their fixed patterns."""
        n = self.n
        return self._triu.matrix(Px, n), self._stack.matrix(self.m_eq + self.m_ineq + 2 * n, n)

    def _result(self, sol: Any) -> QPSolution:
        n, me, mi = self.n, self.m_eq, self.m_ineq
        name = _status_name(sol.status)
        if name in ("Solved", "AlmostSolved"):
            z = np.asarray(sol.z)
            return QPSolution(
                np.asarray(sol.x),
                z[:me].copy(),
                z[me : me + mi].copy(),
                z[me + mi : me + mi + n] - z[me + mi + n :],
                QPStatus.SOLVED,
                name,
            )
        if name in ("PrimalInfeasible", "AlmostPrimalInfeasible"):
            return self.failed("clarabel: primal infeasible", QPStatus.INFEASIBLE)
        return self.failed(f"clarabel: {name}")
