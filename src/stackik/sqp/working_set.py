"""Verified working-set step for the SQP subproblem (:attr:`SQPOptions.qp_working_set`).

Near a solution the QPs of consecutive SQP iterations (and a QP and its second-order
correction) keep the same active set. Given the working set ``W`` of the last solved QP
(equalities, inequality rows with a positive multiplier, step components at a bound of
the box), the equality-constrained QP on it is one linear KKT solve::

    [ B_FF  -J_WF' ] [d_F]   [-(g_F + B_FX d_X)]
    [ J_WF    0    ] [lam] = [-(c_W + J_WX d_X)]      (d_X: the components at their bound)

Its solution is accepted as *the* QP's solution only if it is verified optimal for the
convex QP ``min g'd + d'Bd/2  s.t.  c_E + J_E d = 0, c_I + J_I d >= 0, lb <= d <= ub``:
every row and box bound satisfied, the inequality multipliers non-negative and the bound
multipliers of the right sign, the stationarity and equality residuals at round-off level.
With ``B`` positive definite (the engine convexifies every QP Hessian) a verified KKT point
is the QP's unique minimiser, so the step is the one the backend would return, more
accurately. When the check fails, the violated rows and bounds are added and the
wrong-sign ones dropped, and the check repeated (at most ``MAX_TRIES`` solves); after that
the QP goes to the backend. This is what OSQP's own polishing does after its ADMM phase.

Dense linear algebra on ``|F| + |W|`` unknowns: used while that is at most ``MAX_DIM``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lu_factor, lu_solve

from .qp import QPSolution, QPStatus

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

MAX_TRIES = 2  # KKT solves per QP (working-set repairs included)
MAX_DIM = 800  # largest KKT system solved densely
ACTIVE_TOL = 1e-6  # multiplier (relative to the largest) above which a row is in W
PRIMAL_TOL = 1e-9  # feasibility tolerance (relative to max(1, |c|, box))
DUAL_TOL = 1e-9  # multiplier-sign and stationarity tolerance (relative)
REG = 1e-9  # dual regularisation of the factorised KKT matrix (relative to max B_ii)
REFINE_STEPS = 3  # iterative refinement steps on the unregularised KKT system


def _dense(M: Any) -> FloatArray:
    return np.asarray(M.toarray() if hasattr(M, "toarray") else M, dtype=float)


class WorkingSetStep:
    """Predicted working set of an SQP's QPs and the verified step on it.

    ``n`` variables, ``m_eq`` equality and ``m_ineq`` inequality rows (the engine's plain
    QP). :meth:`record` stores the working set of a solved QP, :meth:`solve` returns the
    verified solution of the next QP or None (then the backend solves it).
    """

    def __init__(self, n: int, m_eq: int, m_ineq: int) -> None:
        self.n, self.m_eq, self.m_ineq = n, m_eq, m_ineq
        self.rows: BoolArray = np.zeros(m_ineq, dtype=bool)
        self.lo: BoolArray = np.zeros(n, dtype=bool)
        self.up: BoolArray = np.zeros(n, dtype=bool)
        self.known = False
        self.hits = 0  # QPs solved here
        self.misses = 0  # QPs tried here and passed on

    def record(self, sol: QPSolution) -> None:
        """The working set of a solved QP (multipliers above ``ACTIVE_TOL`` relative)."""
        yi, yb = sol.y_ineq[: self.m_ineq], sol.y_bounds[: self.n]
        scale = max(1.0, float(np.abs(yi).max(initial=0.0)), float(np.abs(yb).max(initial=0.0)))
        thr = ACTIVE_TOL * scale
        self.rows = yi > thr
        self.up = yb > thr
        self.lo = yb < -thr
        self.known = True

    def solve(
        self, B: Any, g: FloatArray, J: Any, c: FloatArray, lb: FloatArray, ub: FloatArray
    ) -> QPSolution | None:
        """The verified solution of the QP on the predicted working set, or None."""
        if not self.known:
            return None
        n, mE = self.n, self.m_eq
        Bd = _dense(B)
        Jd = _dense(J) if self.m_eq + self.m_ineq else np.zeros((0, n))
        rows, lo, up = self.rows.copy(), self.lo & ~self.up, self.up.copy()
        ptol = PRIMAL_TOL * max(1.0, float(np.abs(c).max(initial=0.0)))
        for _ in range(MAX_TRIES):
            out = self._kkt_step(Bd, g, Jd, c, lb, ub, rows, lo, up)
            if out is None:
                break
            d, lam, y_b, cd = out
            dtol = DUAL_TOL * max(1.0, float(np.abs(lam).max(initial=0.0)), float(np.abs(g).max()))
            fixed = lo | up
            free = ~fixed
            viol = (cd[mE:] < -ptol) & ~rows
            neg = (lam[mE:] < -dtol) & rows
            over = free & (d > ub + ptol)
            under = free & (d < lb - ptol)
            wrong_up = up & (y_b < -dtol)
            wrong_lo = lo & (y_b > dtol)
            if (
                not (viol.any() or neg.any() or over.any() or under.any() or wrong_up.any())
                and not wrong_lo.any()
            ):
                self.hits += 1
                self.rows, self.lo, self.up = rows, lo, up
                return QPSolution(
                    np.minimum(np.maximum(d, lb), ub),
                    -lam[:mE],
                    np.maximum(lam[mE:], 0.0),
                    np.where(fixed, y_b, 0.0),
                    QPStatus.SOLVED,
                    "working set",
                )
            rows = (rows | viol) & ~neg
            up = (up | over) & ~wrong_up
            lo = (lo | under) & ~wrong_lo
        self.misses += 1
        return None

    def _kkt_step(
        self,
        Bd: FloatArray,
        g: FloatArray,
        Jd: FloatArray,
        c: FloatArray,
        lb: FloatArray,
        ub: FloatArray,
        rows: BoolArray,
        lo: BoolArray,
        up: BoolArray,
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray] | None:
        """``(d, lam, y_bounds, c + J d)`` of the KKT system on the working set, or None
        (too large, more constraints than free variables, singular, or inaccurate)."""
        n, mE = self.n, self.m_eq
        fixed = lo | up
        F = np.flatnonzero(~fixed)
        X = np.flatnonzero(fixed)
        W = np.concatenate((np.arange(mE), mE + np.flatnonzero(rows)))
        nF, nW = F.size, W.size
        if nF + nW > MAX_DIM:
            return None
        d = np.empty(n)
        dX = np.where(up[X], ub[X], lb[X])
        d[X] = dX
        JW = Jd[W]
        K = np.zeros((nF + nW, nF + nW))
        K[:nF, :nF] = Bd[np.ix_(F, F)]
        JWF = JW[:, F]
        K[:nF, nF:] = -JWF.T
        K[nF:, :nF] = JWF
        rhs = np.empty(nF + nW)
        rhs[:nF] = -g[F]
        rhs[nF:] = -c[W]
        if X.size:
            rhs[:nF] -= Bd[np.ix_(F, X)] @ dX
            rhs[nF:] -= JW[:, X] @ dX
        # Dependent rows (a limit stated twice, several limits meeting at a vertex) make
        # K singular: factorise the quasi-definite K + eps [0 0; 0 I] and refine on K, as
        # OSQP's polishing does (the step is unique; the multipliers end near the least-
        # norm ones, whose signs are then checked like any others).
        eps = REG * max(1.0, float(np.abs(np.diag(K)[:nF]).max(initial=0.0)))
        K[nF:, nF:] = eps * np.eye(nW)
        try:
            lu = lu_factor(K, check_finite=False)
        except ValueError:
            return None
        K[nF:, nF:] = 0.0
        z = lu_solve(lu, rhs, check_finite=False)
        for _ in range(REFINE_STEPS):
            z += lu_solve(lu, rhs - K @ z, check_finite=False)
        if not np.isfinite(z).all():
            return None
        d[F] = z[:nF]
        lam = np.zeros(c.size)
        lam[W] = z[nF:]
        r = Bd @ d + g - Jd.T @ lam  # = -y_bounds (zero on the free components)
        cd = c + Jd @ d
        scale = max(1.0, float(np.abs(g).max(initial=0.0)), float(np.abs(lam).max(initial=0.0)))
        if np.abs(r[F]).max(initial=0.0) > 1e-8 * scale:
            return None
        if np.abs(cd[W]).max(initial=0.0) > 1e-8 * max(1.0, float(np.abs(c).max(initial=0.0))):
            return None
        return d, lam, -r, cd
