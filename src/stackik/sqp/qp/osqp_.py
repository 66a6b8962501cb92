"""OSQP backend through its persistent update path (OSQP >= 1.0 Python API).

The solver is set up once per shape and pattern, so that every later QP of that shape is
passed with ``update(Px=..., Ax=..., q=..., l=..., u=...)`` and solved warm-started, without
rebuilding the factorisation structure.  Dense ``P`` and ``J`` get dense patterns (full
upper triangle of ``P``, full ``A``); sparse (CSC) ones keep their own patterns
(:mod:`stackik.sqp.qp._layout`), so that OSQP's sparse LDL' does work proportional to
their nonzeros.  Tolerances are tightened (OSQP defaults give only ~1e-3
accuracy, not enough for SQP steps and multipliers) and solution polishing is on.

Rows are ordered ``[A_eq; G; I]`` (the identity rows carry the bounds on ``d``).
"""

from __future__ import annotations

import ctypes
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import osqp
import scipy.sparse as sp

from ._layout import StackLayout, TriuLayout, any_sparse, sqp_form
from .base import FloatArray, QPBackend, QPSolution, QPStatus

#: Settings tuned for SQP subproblems; user ``qp_options`` override them.
DEFAULT_SETTINGS: dict[str, Any] = {
    "verbose": False,
    "eps_abs": 1e-6,
    "eps_rel": 1e-6,
    "eps_prim_inf": 1e-7,
    "eps_dual_inf": 1e-7,
    "polishing": True,
    "polish_refine_iter": 10,
    "warm_starting": True,
    "max_iter": 10000,
    "adaptive_rho": True,
}


#: ADMM iteration cap of the elastic subproblems (:meth:`OSQPBackend.for_elastic`).
ELASTIC_MAX_ITER = 2000

_SOLVED = (
    osqp.SolverStatus.OSQP_SOLVED.value,
    # Accepted: the SQP ratio test guards against a poor step.
    osqp.SolverStatus.OSQP_SOLVED_INACCURATE.value,
)


try:
    _LIBC: Any = ctypes.CDLL(None)
except OSError:  # pragma: no cover - non-POSIX
    _LIBC = None


@contextmanager
def _quiet_c_stdout(active: bool) -> Iterator[None]:
    """Silence C-level stdout (OSQP prints polishing notes even with ``verbose=False``)."""
    if not active or _LIBC is None:
        yield
        return
    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (OSError, ValueError):
        yield
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        _LIBC.fflush(None)
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


_MAX_ITER = osqp.SolverStatus.OSQP_MAX_ITER_REACHED.value
#: OSQP's default linear-algebra module, looked up once: ``osqp.OSQP()`` otherwise tries
#: to import the CUDA and MKL modules on every construction (~0.3 ms each when missing;
#: the screened QPs construct a solver whenever their row set grows).
_ALGEBRA: str = osqp.default_algebra()
#: ``qp_options`` key of this backend, not an OSQP setting: ``{"polish_first": eps}`` solves
#: every QP first to ``eps_abs = eps_rel = eps`` and keeps that solution when OSQP's
#: polishing succeeds (an equality-constrained solve on the guessed active set, accepted
#: by OSQP only when it improves the residuals: accurate wherever ADMM has found the active
#: set); otherwise ADMM continues, warm-started, to the tight tolerances.
POLISH_FIRST = "polish_first"
_POLISH_OK = 1


class OSQPBackend(QPBackend):
    """OSQP with dense patterns and in-place data updates."""

    sparse_sqp = True

    name = "osqp"

    def __init__(self, options: dict[str, Any] | None = None) -> None:
        super().__init__(options)
        opts = dict(self.options)
        loose = opts.pop(POLISH_FIRST, None)
        self.options = opts
        self.loose_eps: float | None = None if loose is None else float(loose)
        self.settings = {**DEFAULT_SETTINGS, **self.options}
        self._solver: Any = None
        self._sp_solver: Any = None
        self._last: tuple[int, int, FloatArray, FloatArray, Any] | None = None

    def set_accuracy(self, eps: float | None) -> None:
        """Solve the next QPs to ``eps_abs = eps_rel = eps`` (None: the settings' values,
        which are also the tightest used; user-set ``eps_abs``/``eps_rel`` always win)."""
        base = {**DEFAULT_SETTINGS, **self.options}
        if eps is None or "eps_abs" in self.options or "eps_rel" in self.options:
            new = {"eps_abs": base["eps_abs"], "eps_rel": base["eps_rel"]}
        else:
            e = max(float(eps), float(base["eps_abs"]))
            new = {"eps_abs": e, "eps_rel": max(float(eps), float(base["eps_rel"]))}
        if all(self.settings[k] == v for k, v in new.items()):
            return
        self.settings.update(new)
        for solver in (self._solver, self._sp_solver):
            if solver is not None:
                solver.update_settings(**new)

    def for_elastic(self) -> None:
        """ADMM converges slowly on the nearly linear elastic QPs (10000 iterations, ~30 ms
        each on an n = 4 IK problem): cap them at ELASTIC_MAX_ITER and let polishing
        decide, unless the user set ``max_iter``. Regular subproblems keep the full
        budget (some, e.g. HS19's, need it)."""
        if "max_iter" not in self.options:
            self.settings["max_iter"] = min(int(self.settings["max_iter"]), ELASTIC_MAX_ITER)

    def setup(self, n: int, m_eq: int, m_ineq: int) -> None:
        super().setup(n, m_eq, m_ineq)
        m = m_eq + m_ineq + n
        self._solver = None
        # Dense patterns, column-major (CSC) order of the nonzeros.
        self._triu_rows, self._triu_cols = np.triu_indices(n)
        order = np.lexsort((self._triu_rows, self._triu_cols))
        self._triu_rows = self._triu_rows[order]
        self._triu_cols = self._triu_cols[order]
        self._Afull = np.zeros((m, n))
        self._Afull[m_eq + m_ineq :] = np.eye(n)
        self._l = np.empty(m)
        self._u = np.empty(m)
        self._l[m_eq : m_eq + m_ineq] = -np.inf
        # sparse path: rows [J_E; -J_I; I] (the dense path's [A_eq; G; I])
        self._sp_solver = None
        self._triu = TriuLayout()
        self._stack = StackLayout(np.r_[np.ones(m_eq), -np.ones(m_ineq)], (1.0,))

    def _dense_csc(self, M: FloatArray) -> sp.csc_matrix:
        rows, cols = M.shape
        indptr = np.arange(0, rows * cols + 1, rows, dtype=np.int64)
        indices = np.tile(np.arange(rows, dtype=np.int64), cols)
        return sp.csc_matrix((M.T.ravel(), indices, indptr), shape=(rows, cols))

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
        A, l, u = self._Afull, self._l, self._u
        A[:me] = A_eq
        A[me : me + mi] = G
        l[:me] = b_eq
        u[:me] = b_eq
        u[me : me + mi] = h
        l[me + mi :] = lb
        u[me + mi :] = ub
        Px = np.ascontiguousarray(P[self._triu_rows, self._triu_cols])
        Ax = np.ascontiguousarray(A.T.ravel())
        try:
            if self._solver is None:
                indptr = np.concatenate(([0], np.cumsum(np.arange(1, n + 1)))).astype(np.int64)
                P_csc = sp.csc_matrix((Px, self._triu_rows.astype(np.int64), indptr), shape=(n, n))
                self._solver = osqp.OSQP(algebra=_ALGEBRA)
                self._solver.setup(P_csc, q, self._dense_csc(A), l, u, **self.settings)
            else:
                # OSQP warm-starts from its previous solution (warm_starting=True).
                self._solver.update(Px=Px, Ax=Ax, q=q, l=l, u=u)
            res = self._run(self._solver)
        except Exception as exc:  # noqa: BLE001 - any backend error becomes a status
            self._solver = None
            return self.failed(f"osqp raised {exc!r}")
        return self._result(res, lb, ub)

    def _solve_sparse(
        self, P: Any, q: FloatArray, J: Any, c: FloatArray, lb: FloatArray, ub: FloatArray
    ) -> QPSolution:
        """The SQP-form QP with sparse ``P`` and/or ``J``, on their own patterns."""
        n, me, mi = self.n, self.m_eq, self.m_ineq
        l, u = self._l, self._u
        np.negative(c[:me], out=l[:me])
        u[:me] = l[:me]
        u[me : me + mi] = c[me:]
        l[me + mi :] = lb
        u[me + mi :] = ub
        Px, new_p = self._triu.values(P)
        Ax, new_a = self._stack.values(J)
        try:
            if self._sp_solver is None or new_p or new_a:
                self._sp_solver = osqp.OSQP(algebra=_ALGEBRA)
                self._sp_solver.setup(
                    self._triu.matrix(Px, n),
                    q,
                    self._stack.matrix(me + mi + n, n),
                    l,
                    u,
                    **self.settings,
                )
                self._warm_rebuilt(me, mi, n)
            else:
                self._sp_solver.update(Px=Px, Ax=Ax, q=q, l=l, u=u)
            res = self._run(self._sp_solver)
            if res.info.status_val in _SOLVED:
                self._last = (me, n, np.array(res.x), np.array(res.y), self.ineq_ids)
        except Exception as exc:  # noqa: BLE001 - any backend error becomes a status
            self._sp_solver = None
            return self.failed(f"osqp raised {exc!r}")
        return self._result(res, lb, ub)

    def _warm_rebuilt(self, me: int, mi: int, n: int) -> None:
        """A rebuilt solver (new pattern, e.g. another screened row set) starts from the
        last solution: ``x``, and ``y`` of the equality and box rows, which keep their
        positions, and of the inequality rows by their ids where the engine gave them
        (:attr:`QPBackend.ineq_ids`), else from 0)."""
        last = self._last
        if last is None or last[0] != me or last[1] != n:
            return
        _, _, x, y, ids = last
        y0 = np.zeros(me + mi + n)
        y0[:me] = y[:me]
        y0[me + mi :] = y[y.size - n :]
        now = self.ineq_ids
        if ids is not None and now is not None and len(now) == mi and ids.size:
            at = np.minimum(np.searchsorted(ids, now), ids.size - 1)
            hit = ids[at] == now
            y0[me : me + mi][hit] = y[me + at[hit]]
        self._sp_solver.warm_start(x=x, y=y0)

    def _run(self, solver: Any) -> Any:
        """``solver.solve()``, first to the loose tolerance when ``polish_first`` is set
        (:data:`POLISH_FIRST`)."""
        quiet = not self.settings.get("verbose", False)
        loose = self.loose_eps
        tight = {"eps_abs": self.settings["eps_abs"], "eps_rel": self.settings["eps_rel"]}
        if loose is None or loose <= max(tight.values()):
            with _quiet_c_stdout(quiet):
                return solver.solve(raise_error=False)
        solver.update_settings(eps_abs=max(loose, tight["eps_abs"]), eps_rel=loose)
        try:
            with _quiet_c_stdout(quiet):
                res = solver.solve(raise_error=False)
            if res.info.status_polish == _POLISH_OK or res.info.status_val not in _SOLVED:
                return res
        finally:
            solver.update_settings(**tight)
        with _quiet_c_stdout(quiet):  # warm-started from the loose solution
            return solver.solve(raise_error=False)

    def _result(self, res: Any, lb: FloatArray, ub: FloatArray) -> QPSolution:
        me, mi = self.m_eq, self.m_ineq
        status = res.info.status_val
        # At the iteration limit the ADMM iterate is still an approximate solution: the
        # SQP's ratio test judges the step it gives (rejecting it shrinks the trust
        # region, which makes the next QP easier), better than ending the run.
        if status in _SOLVED or status == _MAX_ITER:
            y = res.y
            # ADMM meets the box rows to its tolerance only: project (the box is exact)
            return QPSolution(
                np.minimum(np.maximum(np.array(res.x), lb), ub),
                y[:me].copy(),
                y[me : me + mi].copy(),
                y[me + mi :].copy(),
                QPStatus.SOLVED,
                str(res.info.status),
            )
        if status in (
            osqp.SolverStatus.OSQP_PRIMAL_INFEASIBLE.value,
            osqp.SolverStatus.OSQP_PRIMAL_INFEASIBLE_INACCURATE.value,
        ):
            return self.failed("osqp: primal infeasible", QPStatus.INFEASIBLE)
        return self.failed(f"osqp: {res.info.status}")
