"""The QP subproblems of one SQP run: backends by size, the fallback backend, the verified
working-set step, the inexact mode's tolerance and, in sparse mode, row screening."""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any

import numpy as np

from .options import SQPOptions
from .problem import FloatArray
from .qp import QPBackend, QPSolution, QPStatus, make_backend
from .sparse import RowSubset, entry_cols
from .state import Timer
from .working_set import WorkingSetStep

SCREEN_KEEP = 2.0  # screened QPs keep rows screened in before, up to this many times those needed


def bad(sol: QPSolution, lb: FloatArray) -> bool:
    """A SOLVED status with a non-finite or bound-violating ``x`` (a backend glitch)."""
    if sol.status is not QPStatus.SOLVED:
        return False
    x = sol.x
    if not math.isfinite(float(x.sum())) and not np.isfinite(x).all():
        return True
    return not bool((x >= lb - 1e-6 * (1.0 + np.abs(lb))).all())


class QPs:
    """Solves the engine's QPs with the main backend (set up once per size) and, when its
    solution is missing or bad, with ``SQPOptions.fallback_qp_solver``."""

    def __init__(self, opts: SQPOptions, qp_name: str, t0: float, timer: Timer, n: int) -> None:
        self.opts = opts
        self.qp_name = qp_name
        self.t0 = t0
        self.timer = timer
        self.n = n
        self.backends: dict[tuple[str, int, int, int], QPBackend] = {}
        self.main: QPBackend | None = None  # of the plain QP
        self.screen: QPBackend | None = None  # QPs without the rows that cannot bind
        self._screen_subset: RowSubset | None = None  # rows of the screened QPs' pattern
        self._screen_rows: Any = None
        self.ws: WorkingSetStep | None = None  # SQPOptions.qp_working_set
        self.n_backend = 0  # QPs passed to a backend
        self.eps: float | None = None  # QP tolerance of the inexact mode (None: fixed)
        self.last_info = ""

    def backend(self, name: str, n: int, me: int, mi: int) -> QPBackend:
        """The backend ``name`` set up for ``n`` variables, ``me`` + ``mi`` rows."""
        key = (name, n, me, mi)
        be = self.backends.get(key)
        if be is None:
            opts = self.opts.qp_options if name == self.qp_name else None
            be = make_backend(name, opts)
            if n != self.n:  # the elastic subproblems (extra slack variables)
                be.for_elastic()
            be.setup(n, me, mi)
            be.deadline = self.t0 + self.opts.max_time
            self.backends[key] = be
        return be

    def finish(self, sol: QPSolution, t: float, backend: bool = True) -> QPSolution:
        """Book the QP's time (since ``t``) and count."""
        self.timer.qp += time.perf_counter() - t
        self.n_backend += backend
        self.last_info = sol.info
        return sol

    def _checked(
        self, sol: QPSolution, lb: FloatArray, size: tuple[int, int, int], retry: Any
    ) -> QPSolution:
        """``sol``, or ``retry(fallback backend)`` when it FAILED or is :func:`bad`."""
        if bad(sol, lb):
            sol = QPSolution(sol.x, sol.y_eq, sol.y_ineq, sol.y_bounds, QPStatus.FAILED, "bad")
        fb = self.opts.fallback_qp_solver
        if sol.status is QPStatus.FAILED and fb is not None and fb != self.qp_name:
            sol = retry(self.backend(fb, *size))
        return sol  # type: ignore[no-any-return]

    def general(
        self, P: Any, q: FloatArray, A_eq: Any, b_eq: FloatArray, G: Any, h: FloatArray,
        lb: FloatArray, ub: FloatArray,
    ) -> QPSolution:  # fmt: skip
        """``min q'z + z'Pz/2  s.t.  A_eq z = b_eq, G z <= h, lb <= z <= ub``."""
        size = (q.size, b_eq.size, h.size)
        t = time.perf_counter()
        sol = self.backend(self.qp_name, *size).solve(P, q, A_eq, b_eq, G, h, lb, ub)
        sol = self._checked(sol, lb, size, lambda be: be.solve(P, q, A_eq, b_eq, G, h, lb, ub))
        return self.finish(sol, t)

    def sqp(
        self, B: Any, g: FloatArray, J: Any, c: FloatArray, mE: int, lb: FloatArray,
        ub: FloatArray, sparse: bool,
    ) -> QPSolution:  # fmt: skip
        """The QP ``min g'd + d'Bd/2  s.t.  c + J d (=, >=) 0, lb <= d <= ub``."""
        n, m = g.size, c.size
        size = (n, mE, m - mE)
        t = time.perf_counter()
        ws = self.ws
        if ws is not None:
            sol = ws.solve(B, g, J, c, lb, ub)
            if sol is not None:
                return self.finish(sol, t, backend=False)
        rows = self._binding_rows(J, c, mE, lb, ub) if sparse else None
        if rows is not None:
            sol = self._screened(rows, B, g, J, c, mE, lb, ub)
        else:
            be = self.main
            if be is None:
                be = self.main = self.backend(self.qp_name, *size)
            if self.eps is not None:
                be.set_accuracy(self.eps)
            sol = be.solve_sqp(B, g, J, c, lb, ub)
        if self.opts.qp_accuracy == "adaptive" and sol.status is QPStatus.SOLVED:
            # an inexact solve may leave the step outside the box by its tolerance
            sol = dataclasses.replace(sol, x=np.minimum(np.maximum(sol.x, lb), ub))
        sol = self._checked(sol, lb, size, lambda be: be.solve_sqp(B, g, J, c, lb, ub))
        if ws is not None and sol.status is QPStatus.SOLVED:
            ws.record(sol)
        return self.finish(sol, t)

    def _binding_rows(self, J: Any, c: FloatArray, mE: int, lb: FloatArray, ub: FloatArray) -> Any:
        """Sparse mode: the rows that can bind in the box ``lb <= d <= ub`` (equalities and
        the inequalities with ``c_i - sum_j |J_ij| max(-lb_j, ub_j) <= 0``; the others hold
        for every step in the box, so the QP without them has the same solution), or None
        when that is all of them (or screening is off)."""
        if not (self.opts.qp_screening and c.size > mE):
            return None
        r = np.maximum(-lb, ub)
        reach = np.bincount(
            J.indices, weights=np.abs(J.data) * r[entry_cols(J.indptr)], minlength=c.size
        )
        keep = c - reach <= 0.0
        keep[:mE] = True
        if keep.all():
            return None
        return np.flatnonzero(keep)

    def _screened(
        self, rows: Any, B: Any, g: FloatArray, J: Any, c: FloatArray, mE: int,
        lb: FloatArray, ub: FloatArray,
    ) -> QPSolution:  # fmt: skip
        """:meth:`sqp` on the rows ``rows`` only; multipliers of the others are 0."""
        n, m = g.size, c.size
        mI = m - mE
        # The QP keeps the union of the rows screened in so far (a row screened out now
        # cannot bind either, so the solution is the same): the backend's solver, and
        # its factorisation's symbolic analysis, are rebuilt only when that union grows.
        # Started afresh when it exceeds SCREEN_KEEP times the rows needed now.
        sub = self._screen_subset
        if sub is not None and sub.matches(J):
            held = self._screen_rows
            inside = np.zeros(m, dtype=bool)
            inside[held] = True
            if inside[rows].all() and held.size <= SCREEN_KEEP * rows.size:
                rows = held
            else:
                if held.size + rows.size <= SCREEN_KEEP * rows.size:
                    inside[rows] = True
                    rows = np.flatnonzero(inside)
                sub = None
        else:
            sub = None
        if sub is None:
            sub = self._screen_subset = RowSubset(J, rows)
            self._screen_rows = rows
        k = rows.size - mE
        be = self.screen
        if be is None:
            be = self.screen = make_backend(self.qp_name, self.opts.qp_options)
            be.deadline = self.t0 + self.opts.max_time
        if (be.n, be.m_eq, be.m_ineq) != (n, mE, k):
            be.setup(n, mE, k)
        if self.eps is not None:  # the inexact mode's tolerance, as the main backend's
            be.set_accuracy(self.eps)
        Js = sub(J)
        be.ineq_ids = rows[mE:]
        sol = be.solve_sqp(B, g, Js, c[rows], lb, ub)
        if sol.status is not QPStatus.SOLVED:
            return sol
        y_ineq = np.zeros(mI)
        y_ineq[rows[mE:] - mE] = sol.y_ineq[:k]
        return dataclasses.replace(sol, y_ineq=y_ineq)
