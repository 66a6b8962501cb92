"""Trust-region Sl1QP engine (:func:`solve`): the driver of the parts.

Algorithm (Nocedal & Wright, *Numerical Optimization*, 2nd ed., ch. 18; Fletcher's Sl1QP;
Byrd, Nocedal & Waltz 2008 penalty steering), in the scaled problem
``min sf*f  s.t.  wE*c_E = 0, wI*c_I >= 0, lower <= x <= upper``:

1. **Subproblem.**  The QP ``min g'd + 1/2 d'Bd  s.t.  c_E + J_E d = 0, c_I + J_I d >= 0``
   on the box ``max(lower - x, -D xs) <= d <= min(upper - x, D xs)`` (infinity-norm trust
   region of radius ``D`` in scaled variables, intersected with the bounds).  When the
   backend reports it inconsistent, the *elastic* QP is solved: slacks penalised by ``nu``
   are added to every equality and to the inequalities violated at ``x`` (only those are
   needed: ``d = 0`` is then feasible), i.e. the Sl1QP subproblem.
2. **Penalty.**  After a consistent QP, ``nu >= max(1.1 ||y||_inf, (g'd + d'Bd/2) /
   ((1 - rho) ||c||_1))`` (N&W eq. 18.36); it is lowered to that bound when the
   multipliers have come down (a large early multiplier would otherwise charge the
   second-order violation of every later step along curved constraints several times
   over, and the trust region would crawl).  After an elastic QP, ``nu`` is steered (x10)
   until the step achieves a fair share of the best achievable reduction of the linearised
   violation (Byrd, Nocedal & Waltz 2008, conditions (3.3)-(3.4)); that best reduction also
   serves to detect local infeasibility.
3. **Ratio test** on the l1 merit ``phi = f + nu (||c_E||_1 + ||min(c_I, 0)||_1)``, with a
   second-order correction against the Maratos effect (N&W Alg. 18.4 / Sec. 15.5): first
   the least-norm correction onto the QP's working set at ``x + d`` (eq. 15.35: one small
   linear solve), and only if that fails the correction QP; then backtracking along the
   step (evaluations only), radius update as in N&W Alg. 4.1 (with the step norm when
   shrinking).
4. **Hessian.**  Exact (``hessian``) made positive definite by adding ``tau J_A'J_A`` for the
   equalities and previously active inequalities (which leaves the QP solution unchanged
   when the reduced Hessian is positive definite), else by eigenvalue clipping;
   Gauss-Newton (``gauss_newton``); or damped BFGS (Powell, N&W Proc. 18.2).
5. **Termination** on the scaled KKT residual (IPOPT-style multiplier scaling) with QP
   multipliers, and on the unscaled maximum violation, re-checked at the end.

Where the parts live: the QPs and their backends in :mod:`~stackik.sqp.subproblem`, dense
or sparse matrices in :mod:`~stackik.sqp.linalg`, the Hessian strategies in
:mod:`~stackik.sqp.hessian`, the interior start in :mod:`~stackik.sqp.barrier`, the run's
state in :mod:`~stackik.sqp.state`, the constants in :mod:`~stackik.sqp.constants`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from .barrier import BARRIER_ITER_SHARE, BarrierStart
from .constants import (
    BACKTRACK_FACTOR,
    BACKTRACK_STEPS,
    DELTA_MIN,
    EPS1_STEER,
    EPS2_STEER,
    ETA_ACCEPT,
    KKT_S_MAX,
    NU_DECREASE_RATIO,
    NU_FEAS,
    NU_INIT,
    NU_MAX,
    NU_STEER_FACTOR,
    NU_STEER_MAX_TRIES,
    PENALTY_MARGIN,
    QP_ACC_FACTOR,
    QP_ACC_MAX,
    RHO_PENALTY,
    ROUNDOFF_GUARD,
    SCALE_MAX_GRADIENT,
    SOC_BELOW,
    SOC_REG,
    radius_after,
    radius_rejected,
)
from .hessian import make_hessian
from .linalg import (
    DenseAlgebra,
    active_rows,
    all_finite,
    elastic_box,
    elastic_qp,
    make_algebra,
    row_absmax,
    values,
)
from .options import SQPOptions
from .problem import Evaluation, FloatArray, NonlinearProgram
from .qp import QPSolution, QPStatus, default_qp_solver, make_backend
from .result import MESSAGES, SQPResult, SQPStatus
from .sparse import is_sparse, matvec, rmatvec
from .state import BoolArray, Box, Point, Rows, Timer
from .subproblem import QPs
from .working_set import WorkingSetStep

#: (lam, g, J, c_I, at_lower, at_upper) of one KKT evaluation.
_KKTArgs = tuple[FloatArray, FloatArray, FloatArray, FloatArray, BoolArray | None, BoolArray | None]


def soc_min_norm(
    alg: DenseAlgebra, J: Any, c_t: FloatArray, lam: FloatArray, d: FloatArray, mE: int
) -> Any:
    """Least-norm second-order correction (N&W eq. 15.35): ``d - J_A'(J_A J_A')^-1
    c_A(x + d)`` over the equalities and the inequalities the QP left active (positive
    multiplier), i.e. the step back onto the linearised working set at ``x + d``: one
    small linear solve instead of a QP.  ``J_A J_A'`` is regularised (planar limits come
    in identical pairs).  None when there is no working set or the solve fails."""
    rows = np.flatnonzero(active_rows(lam, mE))
    if rows.size == 0:
        return None
    r = c_t[rows]
    try:
        JA, G = alg.working_rows(J, rows)
        G[np.diag_indices_from(G)] += SOC_REG * max(1.0, float(G.diagonal().max()))
        y = np.linalg.solve(G, -r)
    except (np.linalg.LinAlgError, ValueError):
        return None
    dc = d + (JA.T @ y)
    if not all_finite(dc):
        return None
    return np.asarray(dc, dtype=float).ravel()


@dataclass(eq=False)
class _Loop:
    """State of the main iteration between steps."""

    lam: FloatArray
    delta: float
    best_x: FloatArray
    best_v: float
    nit: int = 0
    have_lam: bool = False
    x_changed: bool = True
    # Stationarity/complementarity are only needed for the termination test (which needs
    # the violation within tol first), the log and the result: otherwise the evaluation
    # is deferred (``pending``) and done at the end if still the latest.
    pending: _KKTArgs | None = None
    stat: float = math.inf
    compl: float = math.inf
    last_step: float = math.inf  # length of the last accepted step (inexact subproblems)
    status: SQPStatus | None = None
    detail: str = ""


@dataclass(eq=False)
class _Trial:
    """A step ``d`` and its trial point, with the merit model it is judged by."""

    d: FloatArray
    nu: float
    m0: float  # l1 violation at x
    gd: float  # g'd
    dBd: float  # d'Bd
    Jd: FloatArray
    pred: float  # predicted merit reduction
    phi0: float  # merit at x
    guard: float  # roundoff guard of the ratio
    dnorm: float = 0.0
    x: Any = None
    f: float = 0.0
    c: Any = None
    v: float = 0.0
    ev: Evaluation | None = None
    ok: bool = False  # finite merit at the trial point
    ratio: float = -math.inf
    kind: str = "qp"
    bt_alpha: float = 0.0  # backtracking factor of an accepted shorter step (0: none)

    def take(
        self, point: tuple[FloatArray, float, FloatArray, float, Evaluation | None, float]
    ) -> None:
        """Adopt a better trial point ``(x, f, c, v, ev, ratio)``."""
        self.x, self.f, self.c, self.v, self.ev, self.ratio = point


class _Engine:
    """One SQP run: the problem, the grouped state (:mod:`stackik.sqp.state`), the linear
    algebra (:mod:`stackik.sqp.linalg`), the Hessian strategy (:mod:`stackik.sqp.hessian`)
    and the QP subproblems (:mod:`stackik.sqp.subproblem`).

    Constraints are kept stacked, ``c = [c_E; c_I]`` and ``J = [J_E; J_I]`` (scaled), with
    ``cE``/``cI`` and ``JE``/``JI`` views of their blocks, and the multipliers likewise as
    ``lam = [lam_E; lam_I]`` (``L = f - lam'c``, ``lam_I >= 0``).
    """

    def __init__(
        self,
        nlp: NonlinearProgram,
        x0: FloatArray,
        opts: SQPOptions,
        qp_name: str,
    ) -> None:
        self.nlp = nlp
        self.opts = opts
        self.qp_name = qp_name
        self.t0 = time.perf_counter()
        self.timer = Timer()
        self.nfev = 0
        n = x0.size
        self.n = n
        self.box = Box.build(n, nlp.lower, nlp.upper, nlp.x_scale)
        self.hess = make_hessian(opts.hessian, nlp)
        x0 = np.array(x0, dtype=float)
        self.pt = Point(self.box.project(x0), g=np.zeros(n), J=np.zeros((0, n)))
        self.sc = Rows()
        self.alg: Any = DenseAlgebra(n, 0, 0)  # set in _start() once the rows are known
        self.qps = QPs(opts, qp_name, self.t0, self.timer, n)
        self.B: Any = np.eye(n)
        self.nu = NU_INIT

    # ---------------------------------------------------------------- evaluation -----
    def _eval_full(self, x: FloatArray) -> Evaluation:
        t = time.perf_counter()
        ev = self.nlp.evaluate_all(x)
        self.timer.eval += time.perf_counter() - t
        return ev

    def _eval_values(self, x: FloatArray) -> tuple[float, FloatArray, Evaluation | None]:
        t = time.perf_counter()
        f, cE, cI, ev = self.nlp.evaluate_values(x)
        self.timer.eval += time.perf_counter() - t
        self.nfev += 1
        return float(f) * self.sc.sf, self.sc.stack(cE, cI), ev

    def _derivs(self, x: FloatArray, ev: Evaluation | None) -> None:
        """Set gradient and Jacobians (scaled) at ``x`` (``ev`` reused when available)."""
        nlp = self.nlp
        t = time.perf_counter()
        g: Any
        JE: Any
        JI: Any
        if ev is not None:
            g, JE, JI = ev.g, ev.J_eq, ev.J_ineq
        else:
            assert nlp.gradient is not None
            g = nlp.gradient(x)
            JE = None if nlp.eq_jacobian is None else nlp.eq_jacobian(x)
            JI = None if nlp.ineq_jacobian is None else nlp.ineq_jacobian(x)
        self.timer.eval += time.perf_counter() - t
        pt = self.pt
        pt.g = self.sc.sf * np.asarray(g, dtype=float).ravel()
        pt.J, pt.JE, pt.JI = self.alg.jacobian(JE, JI, self.sc.w, self.sc.unit_w)

    def _move_to(self, x_t: FloatArray, f_t: float, c_t: FloatArray, v_t: float, ev_t: Any) -> bool:
        """Make the trial point current (derivatives evaluated); False if not finite."""
        pt = self.pt
        pt.x = x_t
        pt.f = f_t
        pt.set_c(c_t, self.sc.mE)
        pt.v = v_t
        if ev_t is None and self.nlp.evaluate is not None:
            ev_t = self._eval_full(x_t)
        self._derivs(x_t, ev_t)
        if not (all_finite(pt.g) and all_finite(values(pt.J))):
            return False
        pt.refresh(self.sc, self.box)
        return True

    def _time_up(self) -> bool:
        return time.perf_counter() - self.t0 > self.opts.max_time

    def delta_min(self) -> float:
        """The radius below which the trust region has collapsed at the current point."""
        return DELTA_MIN * (1.0 + self.pt.xnorm)

    # ----------------------------------------------------------------- measures -----
    def _multipliers(self, sol: QPSolution) -> FloatArray:
        """Stacked ``[lam_E; lam_I]`` of the QP (lam_I clipped at 0)."""
        mE, mI = self.sc.mE, self.sc.mI
        lam = np.empty(mE + mI)
        if mE:
            np.negative(sol.y_eq[:mE], out=lam[:mE])
        if mI:
            np.maximum(sol.y_ineq[:mI], 0.0, out=lam[mE:])
        return lam

    def _kkt_args(self, lam: FloatArray) -> _KKTArgs:
        """What :meth:`_kkt` needs at the current x (evaluated now or later: the engine
        replaces these arrays at a new point, never modifies them)."""
        pt = self.pt
        return lam, pt.g, pt.J, pt.cI, pt.at_lo, pt.at_up

    def _kkt(self, args: _KKTArgs) -> tuple[float, float]:
        """Scaled stationarity and complementarity (of :meth:`_kkt_args`)."""
        lam, g, J, cI, at_lo, at_up = args
        m = self.sc.m
        r = g - rmatvec(J, lam) if m else g.copy()
        if at_lo is not None:
            np.minimum(r, 0.0, out=r, where=at_lo)
        if at_up is not None:
            np.maximum(r, 0.0, out=r, where=at_up)
        sd = 1.0
        if m:
            sd = max(KKT_S_MAX, float(np.abs(lam).sum()) / m) / KKT_S_MAX
        stat = float(np.abs(r).max()) / sd if r.size else 0.0
        compl = float(np.abs(lam[self.sc.mE :] * cI).max()) / sd if self.sc.mI else 0.0
        return stat, compl

    def _lin_violation(self, d: FloatArray) -> float:
        return self.sc.violation(self.pt.c + matvec(self.pt.J, d))

    # --------------------------------------------------------------- subproblem -------
    def _qp(self, c: FloatArray, lb: FloatArray, ub: FloatArray) -> QPSolution:
        """The QP ``min g'd + d'Bd/2  s.t.  c + J d (=, >=) 0, lb <= d <= ub``."""
        pt = self.pt
        return self.qps.sqp(self.B, pt.g, pt.J, c, self.sc.mE, lb, ub, self.alg.sparse)

    def _elastic(
        self, nu: float, lb: FloatArray, ub: FloatArray, delta_vec: FloatArray
    ) -> tuple[QPSolution, FloatArray]:
        """The Sl1QP subproblem: slacks on every equality and on the inequalities violated
        at ``x`` (``d = 0`` is then feasible), penalised by ``nu``."""
        pt, n, mE = self.pt, self.n, self.sc.mE
        viol_idx = np.flatnonzero(pt.cI < 0.0)
        sparse = self.alg.sparse
        J = sp.csr_matrix(pt.J) if sparse else pt.J
        lbz, ubz = elastic_box(abs(J), pt.c, mE, viol_idx, delta_vec, lb, ub)
        P, q, A_eq, G = elastic_qp(self.B, pt.g, J, mE, viol_idx, nu, sparse)
        sol = self.qps.general(P, q, A_eq, -pt.cE, G, pt.cI, lbz, ubz)
        return sol, sol.x[:n]

    def _model_decrease(self, d: FloatArray, nu: float, m0: float, md: float) -> float:
        return -float(self.pt.g @ d + 0.5 * d @ matvec(self.B, d)) + nu * (m0 - md)

    def _subproblem(
        self, lb: FloatArray, ub: FloatArray, delta: float
    ) -> tuple[QPSolution | None, FloatArray, bool, bool]:
        """Return (solution, d, elastic?, locally-infeasible?)."""
        sol = self._qp(self.pt.c, lb, ub)
        if sol.status is QPStatus.SOLVED:
            return sol, sol.x, False, False
        if self.sc.m == 0:
            return None, np.zeros(self.n), False, False
        delta_vec = np.minimum(np.maximum(ub, -lb), delta * self.box.xs)
        sol, d = self._elastic(self.nu, lb, ub, delta_vec)
        if sol.status is not QPStatus.SOLVED:
            return None, d, True, False
        sol, d, infeasible = self._steer(sol, d, lb, ub, delta, delta_vec)
        return sol, d, True, infeasible

    def _steer(
        self, sol: QPSolution, d: FloatArray, lb: FloatArray, ub: FloatArray, delta: float,
        delta_vec: FloatArray,
    ) -> tuple[QPSolution, FloatArray, bool]:  # fmt: skip
        """Penalty steering after an elastic QP (Byrd, Nocedal & Waltz 2008, (3.3)-(3.4)):
        ``nu`` x10 until the step achieves a fair share of the best achievable reduction of
        the linearised violation, which also detects local infeasibility."""
        m0 = self.pt.v
        nu = self.nu
        m_nu = self._lin_violation(d)
        infeasible = False
        if m_nu > 0.1 * self.sc.ctol:
            sol_inf, d_inf = self._elastic(max(NU_FEAS * nu, NU_FEAS), lb, ub, delta_vec)
            if sol_inf.status is QPStatus.SOLVED:
                m_inf = min(self._lin_violation(d_inf), m_nu)
                best = m0 - m_inf
                chi = best / min(delta, 1.0)
                if m0 > self.sc.ctol and chi <= self.opts.tol * max(1.0, m0):
                    infeasible = True
                for _ in range(NU_STEER_MAX_TRIES):
                    ok1 = m0 - m_nu >= EPS1_STEER * best
                    ok2 = self._model_decrease(d, nu, m0, m_nu) >= EPS2_STEER * nu * best
                    if (ok1 and ok2) or nu >= NU_MAX:
                        break
                    nu = min(nu * NU_STEER_FACTOR, NU_MAX)
                    sol_new, d_new = self._elastic(nu, lb, ub, delta_vec)
                    if sol_new.status is not QPStatus.SOLVED:
                        break
                    sol, d = sol_new, d_new
                    m_nu = self._lin_violation(d)
        self.nu = nu
        return sol, d, infeasible

    # -------------------------------------------------------------------- start -------
    def _start(self) -> tuple[SQPStatus | None, str]:
        """First evaluation, rows, scaling, derivatives and Hessian at ``x0``; a status
        when ``x0`` is not finite."""
        opts, n, pt = self.opts, self.n, self.pt
        ev = self._eval_full(pt.x)
        self.nfev = 1
        cE_raw = np.zeros(0) if ev.c_eq is None else np.asarray(ev.c_eq, float).ravel()
        cI_raw = np.zeros(0) if ev.c_ineq is None else np.asarray(ev.c_ineq, float).ravel()
        sc = self.sc
        sc.mE, sc.mI = mE, mI = cE_raw.size, cI_raw.size
        sc.m = mE + mI
        sparse = is_sparse(ev.J_eq) or is_sparse(ev.J_ineq)
        self.alg = make_algebra(sparse, n, mE, mI)
        JE_raw, JI_raw = self.alg.raw_jacobians(ev.J_eq, ev.J_ineq)
        self._scale(np.asarray(ev.g, dtype=float).ravel(), JE_raw, JI_raw)
        pt.f = sc.sf * float(ev.f)
        pt.set_c(sc.stack(cE_raw, cI_raw), mE)
        self._derivs(pt.x, ev)
        if opts.qp_working_set:
            self.qps.ws = WorkingSetStep(n, mE, mI)
        self.box.set_tolerance(opts.constr_tol)
        self.nu = NU_INIT
        pt.v = sc.violation(pt.c)
        pt.refresh(sc, self.box)
        if not (math.isfinite(pt.f) and all_finite(pt.g) and math.isfinite(pt.v)):
            return SQPStatus.NUMERICAL_ERROR, " (at x0)"
        if not all_finite(values(pt.J)):
            return SQPStatus.NUMERICAL_ERROR, " (Jacobian at x0)"
        self.B = self.hess.initial(self, np.zeros(sc.m))
        return None, ""

    def _scale(self, g_raw: FloatArray, JE_raw: Any, JI_raw: Any) -> None:
        """Scaling (IPOPT gradient-based rule, W&B 2006 Sec. 3.8) or user-given factors."""
        opts, nlp, n, sc = self.opts, self.nlp, self.n, self.sc
        sc.sf = 1.0
        if opts.scaling:
            gmax = float(np.abs(g_raw).max()) if n else 0.0
            if math.isfinite(gmax) and gmax > SCALE_MAX_GRADIENT:
                sc.sf = SCALE_MAX_GRADIENT / gmax

        def row_scale(user: Any, Jraw: Any, mc: int) -> FloatArray:
            if user is not None:
                return np.broadcast_to(np.asarray(user, float), (mc,)).copy()
            if not (opts.scaling and mc and n):
                return np.ones(mc)
            ws = SCALE_MAX_GRADIENT / np.maximum(row_absmax(Jraw), SCALE_MAX_GRADIENT)
            ws[~np.isfinite(ws)] = 1.0
            return ws

        wE = row_scale(nlp.eq_scale, JE_raw, sc.mE)
        wI = row_scale(nlp.ineq_scale, JI_raw, sc.mI)
        sc.set_weights(np.concatenate((wE, wI)), opts.constr_tol)

    def _barrier_start(self, lp: _Loop) -> None:
        """The interior start phase (:mod:`stackik.sqp.barrier`), when asked for."""
        opts = self.opts
        if lp.status is not None or not opts.barrier_start or not self.hess.barrier_ok:
            return
        budget = max(1, int(BARRIER_ITER_SHARE * opts.max_iter))
        lp.lam, lp.delta, lp.nit, lp.status = BarrierStart(self, lp.delta).run(budget)
        if lp.nit and lp.status is None:
            lp.have_lam = True
            self.B = self.hess.at_point(self, lp.lam)

    # ---------------------------------------------------------------------- run -------
    def run(self) -> SQPResult:
        status, detail = self._start()
        pt = self.pt
        lp = _Loop(np.zeros(self.sc.m), self.opts.initial_tr_radius, pt.x.copy(), 0.0)
        lp.status, lp.detail = status, detail
        self._barrier_start(lp)
        lp.best_x, lp.best_v = pt.x.copy(), pt.viol_u
        if self.opts.verbose and lp.status is None:
            print(
                f"{'it':>4} {'f':>14} {'viol':>9} {'stat':>9} {'compl':>9} "
                f"{'radius':>9} {'nu':>9} {'ratio':>9}  step"
            )
        while lp.status is None:
            self._iteration(lp)
        return self._result(lp)

    def _converged(self, lp: _Loop) -> bool:
        """Termination tests at the current point (before its subproblem)."""
        opts = self.opts
        if self._time_up():
            lp.status = SQPStatus.MAX_TIME
            return True
        if lp.have_lam and lp.x_changed:
            lp.pending = self._kkt_args(lp.lam)
            if self.pt.viol_u <= opts.constr_tol:
                lp.stat, lp.compl = self._kkt(lp.pending)
                lp.pending = None
                if lp.stat <= opts.tol and lp.compl <= opts.tol:
                    lp.status = SQPStatus.SUCCESS
                    return True
        if lp.nit >= opts.max_iter:
            lp.status = SQPStatus.MAX_ITER
            return True
        return False

    def _iteration(self, lp: _Loop) -> None:
        """One SQP iteration: subproblem -> penalty -> trial -> correction -> accept."""
        if self._converged(lp):
            return
        lp.x_changed = False
        sub = self._solve_subproblem(lp)
        if sub is None:
            return
        d, elastic, lb, ub = sub
        tr = self._penalty(lp, d, elastic)
        self._trial(tr)
        if tr.ratio < SOC_BELOW and not elastic and self.sc.m and tr.ok and tr.pred > 0:
            self._correct(tr, lp.lam, lb, ub)
        if tr.ratio < ETA_ACCEPT and BACKTRACK_STEPS and not elastic and tr.ok:
            self._backtrack(tr)
        if self.opts.verbose:
            print(
                f"{lp.nit:4d} {self.pt.f / self.sc.sf:14.7e} {self.pt.viol_u:9.2e} "
                f"{lp.stat:9.2e} {lp.compl:9.2e} {lp.delta:9.2e} {tr.nu:9.2e} "
                f"{tr.ratio:9.2e}  {tr.kind}"
                + (f" [{self.qps.last_info}]" if self.opts.verbose > 1 else "")
            )
        if tr.ratio >= ETA_ACCEPT:
            if not self._accept(lp, tr):
                return
        else:
            lp.delta = radius_rejected(lp.delta, tr.dnorm)
        if lp.delta < self.delta_min():
            lp.stat, lp.compl = self._kkt(self._kkt_args(lp.lam))
            lp.pending = None
            lp.status = SQPStatus.SMALL_STEP

    def _solve_subproblem(
        self, lp: _Loop
    ) -> tuple[FloatArray, bool, FloatArray, FloatArray] | None:
        """The QP step ``(d, elastic?, lb, ub)`` at the current point and its multipliers
        (``lp.lam``); None when the run ends here (QP failure, optimality, infeasibility,
        time)."""
        opts, pt = self.opts, self.pt
        viol_u = pt.viol_u
        t = time.perf_counter()
        lb, ub = self.box.trust_region(pt.x, lp.delta)
        self.timer.build += time.perf_counter() - t
        if opts.qp_accuracy == "adaptive":
            # tolerance from the optimality measure, and from the last step's length:
            # inexact multipliers can keep the measure up, but not the steps
            opt = lp.last_step
            if lp.have_lam:
                st_, co_ = self._kkt(self._kkt_args(lp.lam))
                opt = min(opt, max(st_, co_, viol_u))
            self.qps.eps = min(QP_ACC_MAX, QP_ACC_FACTOR * opt)
        lp.nit += 1
        sol, d, elastic, infeasible = self._subproblem(lb, ub, lp.delta)
        if sol is None:
            lp.status = SQPStatus.QP_FAILURE
            lp.detail = f" ({self.qps.last_info})"
            return None
        lp.lam = self._multipliers(sol)
        lp.have_lam = True
        lp.pending = self._kkt_args(lp.lam)
        ctol = opts.constr_tol
        if viol_u <= ctol or opts.verbose:
            lp.stat, lp.compl = self._kkt(lp.pending)
            lp.pending = None
            if lp.stat <= opts.tol and lp.compl <= opts.tol and viol_u <= ctol:
                lp.status = SQPStatus.SUCCESS
                return None
        if infeasible:
            lp.status = SQPStatus.INFEASIBLE
            return None
        if self._time_up():
            lp.status = SQPStatus.MAX_TIME
            return None
        return d, elastic, lb, ub

    def _penalty(self, lp: _Loop, d: FloatArray, elastic: bool) -> _Trial:
        """Penalty update (N&W eq. 18.36) after a consistent QP and the l1 merit model of
        the step ``d``."""
        pt = self.pt
        m0 = pt.v
        dBd = float(d @ matvec(self.B, d))
        gd = float(pt.g @ d)
        if not elastic:
            lam_inf = float(np.abs(lp.lam).max()) if self.sc.m else 0.0
            nu_req = PENALTY_MARGIN * lam_inf
            if self.nu > NU_DECREASE_RATIO * nu_req and self.nu > NU_INIT:
                # a transient large multiplier left nu far above what the current
                # multipliers need: let it come down (keeps exactness, nu >= 1.1 |y|)
                self.nu = max(NU_DECREASE_RATIO * nu_req, NU_INIT)
            nu = max(self.nu, nu_req)
            if m0 > 0:
                nu = max(nu, (gd + 0.5 * dBd) / ((1.0 - RHO_PENALTY) * m0))
            self.nu = min(nu, NU_MAX)
        nu = self.nu
        # Linearised violation of the computed step (not assumed zero: QP tolerances).
        Jd = matvec(pt.J, d)
        md = self.sc.violation(pt.c + Jd)
        pred = -(gd + 0.5 * dBd) + nu * (m0 - md)
        phi0 = pt.f + nu * m0
        # Roundoff-protected ratio, Conn, Gould & Toint (2000) Sec. 17.4.2.
        guard = ROUNDOFF_GUARD * max(1.0, abs(phi0))
        tr = _Trial(d, nu, m0, gd, dBd, Jd, pred, phi0, guard)
        tr.dnorm = 0.0 if self.n == 0 else self.box.norm(d)
        tr.kind = "elastic" if elastic else "qp"
        return tr

    def _trial(self, tr: _Trial) -> None:
        """Evaluate the trial point ``x + d`` and its merit ratio."""
        x_t = self.box.project(self.pt.x + tr.d)
        f_t, c_t, ev_t = self._eval_values(x_t)
        v_t = self.sc.violation(c_t)
        phi_t = f_t + tr.nu * v_t
        tr.ok = math.isfinite(phi_t)
        ok = tr.ok and tr.pred > -tr.guard
        ratio = (tr.phi0 - phi_t + tr.guard) / (tr.pred + tr.guard) if ok else -math.inf
        tr.take((x_t, f_t, c_t, v_t, ev_t, ratio))

    def _corrected(self, tr: _Trial, d_c: FloatArray) -> Any:
        """The trial point of a corrected step ``x + d_c`` (projected), with its merit ratio
        against the uncorrected step's prediction; None unless it is finite, passes
        ``ETA_ACCEPT`` and beats the uncorrected ratio."""
        x_c = self.box.project(self.pt.x + d_c)
        f_c, c_c, ev_c = self._eval_values(x_c)
        v_c = self.sc.violation(c_c)
        phi_c = f_c + tr.nu * v_c
        ratio_c = (tr.phi0 - phi_c + tr.guard) / (tr.pred + tr.guard)
        if math.isfinite(phi_c) and ratio_c >= ETA_ACCEPT and ratio_c > tr.ratio:
            return x_c, f_c, c_c, v_c, ev_c, ratio_c
        return None

    def _correct(self, tr: _Trial, lam: FloatArray, lb: FloatArray, ub: FloatArray) -> None:
        """Second-order correction against the Maratos effect (N&W Alg. 18.4 / Sec. 15.5):
        the least-norm correction first (no QP), the correction QP if that fails."""
        t = time.perf_counter()
        d_m = soc_min_norm(self.alg, self.pt.J, tr.c, lam, tr.d, self.sc.mE)
        self.timer.build += time.perf_counter() - t
        point = None if d_m is None else self._corrected(tr, d_m)
        if point is not None:
            tr.take(point)
            tr.kind, tr.d = "soc-ln", d_m
            return
        sol_c = self._qp(tr.c - tr.Jd, lb, ub)
        if sol_c.status is QPStatus.SOLVED:
            point = self._corrected(tr, sol_c.x)
            if point is not None:
                tr.take(point)
                tr.kind, tr.d = "soc", sol_c.x

    def _backtrack(self, tr: _Trial) -> None:
        """Shorter steps along ``d`` inside the trust region (Nocedal & Yuan 1998): they
        cost evaluations only, not a new QP."""
        pt, nu = self.pt, tr.nu
        Jd0, d0 = tr.Jd, tr.d
        for k in range(1, BACKTRACK_STEPS + 1):
            alpha = BACKTRACK_FACTOR**k
            da = alpha * d0
            md_a = self.sc.violation(pt.c + alpha * Jd0)
            pred_a = -(alpha * tr.gd + 0.5 * alpha * alpha * tr.dBd) + nu * (tr.m0 - md_a)
            if not pred_a > 0:
                break
            x_a = self.box.project(pt.x + da)
            f_a, c_a, ev_a = self._eval_values(x_a)
            v_a = self.sc.violation(c_a)
            phi_a = f_a + nu * v_a
            ratio_a = (tr.phi0 - phi_a + tr.guard) / (pred_a + tr.guard)
            if math.isfinite(phi_a) and ratio_a >= ETA_ACCEPT:
                tr.take((x_a, f_a, c_a, v_a, ev_a, ratio_a))
                tr.d, tr.kind, tr.bt_alpha = da, f"backtrack {alpha:g}", alpha
                tr.dnorm = self.box.norm(da)
                break

    def _accept(self, lp: _Loop, tr: _Trial) -> bool:
        """Move to the trial point, update the Hessian and the radius; False when the new
        point is not finite (the run ends)."""
        memo = self.hess.before_step(self, lp.lam)
        x_old = self.pt.x
        lp.x_changed = True
        if not self._move_to(tr.x, tr.f, tr.c, tr.v, tr.ev):
            lp.status = SQPStatus.NUMERICAL_ERROR
            return False
        self.B = self.hess.updated(self, lp.lam, memo, self.pt.x - x_old)
        lp.last_step = tr.dnorm
        if self.pt.viol_u < lp.best_v:
            lp.best_x, lp.best_v = self.pt.x.copy(), self.pt.viol_u
        lp.delta = radius_after(
            lp.delta, tr.ratio, tr.dnorm, self.opts.max_tr_radius, bool(tr.bt_alpha)
        )
        return True

    def _result(self, lp: _Loop) -> SQPResult:
        """Final re-check and the result."""
        opts, pt, sc = self.opts, self.pt, self.sc
        status, detail = lp.status, lp.detail
        assert status is not None
        stat, compl = lp.stat, lp.compl
        if lp.pending is not None:
            stat, compl = self._kkt(lp.pending)
        if status is SQPStatus.INFEASIBLE and lp.best_v < pt.viol_u:
            pt.x = lp.best_x
            f_b, c_b, _ = self._eval_values(pt.x)
            pt.f = f_b
            pt.set_c(c_b, sc.mE)
        viol_u = sc.max_violation_unscaled(pt.c)
        if status is SQPStatus.SUCCESS and not viol_u <= opts.constr_tol:
            status = SQPStatus.SMALL_STEP
            detail = " (final violation check failed)"
        y = lp.lam * sc.w / sc.sf
        kkt = max(stat, compl, viol_u * sc.w_min)
        total = time.perf_counter() - self.t0
        if opts.verbose:
            print(f"stackik.sqp: {status.value}: {MESSAGES[status]}{detail}")
        return SQPResult(
            x=np.array(pt.x, dtype=float),
            success=status is SQPStatus.SUCCESS,
            status=status,
            message=MESSAGES[status] + detail,
            fun=float(pt.f / sc.sf),
            nit=lp.nit,
            nfev=self.nfev,
            kkt_residual=float(kkt),
            max_violation=float(viol_u),
            y_eq=y[: sc.mE],
            y_ineq=y[sc.mE :],
            tr_radius=float(lp.delta),
            penalty=float(self.nu),
            qp_solver=self.qp_name,
            time_eval=self.timer.eval,
            time_qp_build=self.timer.build,
            time_qp_solve=self.timer.qp,
            time_total=total,
            qp_backend_solves=self.qps.n_backend,
            qp_working_set_solves=0 if self.qps.ws is None else self.qps.ws.hits,
        )


def solve(
    nlp: NonlinearProgram,
    x0: Any,
    qp_solver: str | None = None,
    options: SQPOptions | None = None,
) -> SQPResult:
    """Solve a :class:`NonlinearProgram` with the trust-region Sl1QP method.

    Parameters
    ----------
    nlp : NonlinearProgram
        The problem.
    x0 : array_like, shape (n,)
        Starting point (projected onto the bounds).
    qp_solver : str, optional
        QP backend: ``"daqp"`` (default when installed: fastest for small dense QPs),
        ``"osqp"``, ``"clarabel"``, ``"qpsolvers:NAME"`` or a plain qpsolvers solver name.
    options : SQPOptions, optional
        Algorithm options (defaults: ``SQPOptions()``).

    Returns
    -------
    SQPResult

    Raises
    ------
    ValueError
        On invalid problem data, options, or an unknown/uninstalled QP solver.
    """
    if options is None:
        options = SQPOptions()
    if not isinstance(options, SQPOptions):
        raise ValueError("options must be an SQPOptions instance")
    if not isinstance(nlp, NonlinearProgram):
        raise ValueError("nlp must be a NonlinearProgram")
    name = default_qp_solver() if qp_solver is None else qp_solver
    make_backend(name, options.qp_options)  # validate the name now (raises ValueError)
    if options.fallback_qp_solver is not None:
        make_backend(options.fallback_qp_solver)
    x0a = np.atleast_1d(np.asarray(x0, dtype=float)).ravel()
    if x0a.size == 0 or not np.all(np.isfinite(x0a)):
        raise ValueError("x0 must be a non-empty finite array")
    return _Engine(nlp, x0a, options, name).run()
