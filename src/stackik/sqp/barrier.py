"""Interior start of the SQP engine (:attr:`SQPOptions.barrier_start`).

Trust-region steps on the log-barrier problem ``min f - mu sum_B log c_i  s.t.  c_E = 0,
c_V >= 0``, where B are the inequalities strictly satisfied at the start and V the others
(kept as linearised QP rows), with the l1 merit on E and V (a trial point leaving the
interior of B is rejected), ``mu`` decreased as in IPOPT once the barrier problem is
solved to ``kappa_eps mu``, until :data:`BARRIER_MU_END`. The QPs carry no barrier rows:
the barrier terms enter the QP's gradient and Hessian (primal-dual, as IPOPT: duals ``z``
of the barrier rows). Constants as in IPOPT (Waechter & Biegler 2006, Sec. 3.1).
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from .constants import (
    ETA_ACCEPT,
    ETA_GOOD,
    KKT_S_MAX,
    NU_INIT,
    NU_MAX,
    PENALTY_MARGIN,
    QP_ACC_FACTOR,
    QP_ACC_MAX,
    RHO_PENALTY,
    ROUNDOFF_GUARD,
    radius_after,
    radius_rejected,
)
from .linalg import elastic_box, elastic_qp
from .problem import FloatArray
from .qp import QPSolution, QPStatus
from .result import SQPStatus
from .sparse import RowSubset, matvec, rmatvec
from .subproblem import bad

if TYPE_CHECKING:
    from .solver import _Engine

BARRIER_MU0 = 0.1  # initial barrier parameter (IPOPT mu_init)
# Hand over to the SQP once the barrier problem of this mu is solved: the barrier phase only
# has to choose the basin (measurements: docs/benchmarks.md).
BARRIER_MU_END = 0.03
# A barrier problem counts as solved when its error <= kappa_eps mu (IPOPT's 10 leaves the
# basin to chance; measurements: docs/benchmarks.md).
BARRIER_KAPPA_EPS = 1.0
BARRIER_KAPPA_MU = 0.2  # mu <- max(mu_end, min(kappa_mu mu, mu^theta_mu))
BARRIER_THETA_MU = 1.5
BARRIER_ITER_SHARE = 0.8  # share of max_iter the barrier phase may use
BARRIER_TAU = 0.99  # fraction to the boundary (of the barrier rows' linearisation)
BARRIER_KAPPA_SIGMA = 1e10  # IPOPT's safeguard of the duals: z c within [mu/k, k mu]

#: :meth:`BarrierStart._iteration`: hand over to the SQP now
_HAND_OVER = "hand over"


class BarrierStart:
    """One barrier phase on the engine's current point (see the module docstring)."""

    def __init__(self, eng: _Engine, delta: float) -> None:
        self.eng = eng
        sc = eng.sc
        mE, mI = sc.mE, sc.mI
        self.delta = delta
        self.barrier = eng.pt.cI > 0.0
        self.V = np.flatnonzero(~self.barrier)
        self.mu = BARRIER_MU0
        self.lamE = np.zeros(mE)
        self.lamV = np.zeros(self.V.size)
        self.lamI = np.zeros(mI)
        self.lam = np.zeros(sc.m)
        self.nit = 0
        self.rows = np.concatenate((np.arange(mE), mE + self.V))  # E and V: the QP's rows
        self.ev_a = sc.viol_a[self.rows]
        self.ev_b = sc.viol_b[self.rows]
        self.c_ev = np.zeros(0)
        self.row_subset: RowSubset | None = None
        self.adaptive = eng.opts.qp_accuracy == "adaptive"

    def run(self, max_iter: int) -> tuple[FloatArray, float, int, SQPStatus | None]:
        """Returns ``(lam, delta, iterations, status or None)``: the stacked multipliers,
        the radius for the SQP, and a final status when the run must end here."""
        eng = self.eng
        sc = eng.sc
        if not sc.mI or not self.barrier.any():
            return self.lam, self.delta, 0, None
        self.z = self.mu / eng.pt.cI[self.barrier]  # duals of the barrier rows
        self.be = eng.qps.backend(eng.qp_name, eng.n, sc.mE, self.V.size)
        while self.nit < max_iter:
            if eng._time_up():
                return self.lam, self.delta, self.nit, SQPStatus.MAX_TIME
            gphi, err = self._measure()
            if err <= BARRIER_KAPPA_EPS * self.mu:
                if self.mu <= BARRIER_MU_END:
                    break
                mu = self.mu
                self.mu = max(BARRIER_MU_END, min(BARRIER_KAPPA_MU * mu, mu**BARRIER_THETA_MU))
                continue
            outcome = self._iteration(gphi, err)
            if outcome == _HAND_OVER:
                break
            if outcome is not None:
                return self.lam, self.delta, self.nit, outcome  # type: ignore[return-value]
            if self.delta < eng.delta_min():
                self.delta = eng.opts.initial_tr_radius  # the SQP's own model starts afresh
                break
        if self.adaptive:
            self.be.set_accuracy(None)
        lamI = np.zeros(sc.mI)
        lamI[self.barrier] = self.z
        lamI[self.V] = self.lamV
        return np.concatenate((self.lamE, lamI)), self.delta, self.nit, None

    def _measure(self) -> tuple[FloatArray, float]:
        """The barrier problem's gradient ``g - J_B' mu / c_B`` and its optimality error
        (stationarity, complementarity of ``z`` and of the V rows, violation), scaled as
        IPOPT's; sets the multipliers ``lam`` of the current point."""
        eng = self.eng
        pt, sc = eng.pt, eng.sc
        mE, mI, m = sc.mE, sc.mI, sc.m
        barrier, z, mu = self.barrier, self.z, self.mu
        cB = pt.cI[barrier]
        lamB = np.zeros(mI)
        lamB[barrier] = mu / cB
        lamI = np.zeros(mI)
        lamI[barrier] = z
        lamI[self.V] = self.lamV
        self.lamI = lamI
        lam = self.lam = np.concatenate((self.lamE, lamI))
        gphi = pt.g - rmatvec(pt.JI, lamB)
        r = pt.g - rmatvec(pt.J, lam)
        sd = max(KKT_S_MAX, float(np.abs(lam).sum()) / m) / KKT_S_MAX
        err = float(np.abs(r).max()) / sd if eng.n else 0.0
        err = max(err, float(np.abs(z * cB - mu).max()) / sd)
        c_ev = self.c_ev = pt.c[self.rows]
        if self.rows.size:
            err = max(err, float(np.abs(c_ev[:mE]).max(initial=0.0)))
            err = max(err, float(np.maximum(-c_ev[mE:], 0.0).max(initial=0.0)))
            err = max(err, float(np.abs(self.lamV * c_ev[mE:]).max(initial=0.0)) / sd)
        return gphi, err

    def _qp_rows(self) -> Any:
        """The rows E and V of the current ``J``."""
        J = self.eng.pt.J
        if self.eng.alg.sparse:
            rs = self.row_subset
            if rs is None or not rs.matches(J):
                rs = self.row_subset = RowSubset(J, self.rows)
            return rs(J)
        return J[self.rows]

    def _to_boundary(self, d: FloatArray, cB: FloatArray) -> FloatArray:
        """``d`` shortened to keep ``BARRIER_TAU`` of the barrier rows' linearised value."""
        JBd = matvec(self.eng.pt.JI, d)[self.barrier]
        shrinking = JBd < 0.0
        if shrinking.any():
            alpha = float(np.min(BARRIER_TAU * cB[shrinking] / -JBd[shrinking]))
            if alpha < 1.0:
                d = alpha * d
        return d

    def _elastic(
        self, B: Any, g: FloatArray, J: Any, c: FloatArray, lb: FloatArray, ub: FloatArray
    ) -> QPSolution:
        """The barrier QP with l1-penalised slacks on every row (``c_E + J_E d = p - q``,
        ``c_V + J_V d + s >= 0``, slacks >= 0, weight ``nu``): always consistent."""
        eng = self.eng
        mE = eng.sc.mE
        nu = max(eng.nu, NU_INIT)
        dvec = np.minimum(np.maximum(ub, -lb), self.delta * eng.box.xs)
        lbz, ubz = elastic_box(abs(J), c, mE, None, dvec, lb, ub)
        P, q, A_eq, G = elastic_qp(B, g, J, mE, None, nu, eng.alg.sparse)
        return eng.qps.general(P, q, A_eq, -c[:mE], G, c[mE:], lbz, ubz)

    def _iteration(self, gphi: FloatArray, err: float) -> Any:
        """One barrier step: None to go on, ``_HAND_OVER`` or a final status."""
        eng = self.eng
        pt = eng.pt
        barrier, mu = self.barrier, self.mu
        cB = pt.cI[barrier]
        lam_act = np.concatenate((self.lamE, np.where(barrier, 0.0, self.lamI)))
        B = eng.hess.barrier(eng, self.lam, barrier, self.z / cB, lam_act)
        t = time.perf_counter()
        lb, ub = eng.box.trust_region(pt.x, self.delta)
        J_ev = self._qp_rows()
        eng.timer.build += time.perf_counter() - t
        t = time.perf_counter()
        if self.adaptive:
            self.be.set_accuracy(min(QP_ACC_MAX, QP_ACC_FACTOR * err))
        c_ev = self.c_ev
        sol = self.be.solve_sqp(B, gphi, J_ev, c_ev, lb, ub)
        elastic = False
        if sol.status is not QPStatus.SOLVED or bad(sol, lb):
            # inconsistent linearisation in the trust region: the l1-elastic QP
            sol = self._elastic(B, gphi, J_ev, c_ev, lb, ub)
            elastic = True
        eng.qps.finish(sol, t)
        self.nit += 1
        if sol.status is not QPStatus.SOLVED:
            return _HAND_OVER  # the SQP takes over from here
        d = self._to_boundary(sol.x[: eng.n], cB)
        lamE_new = -sol.y_eq[: eng.sc.mE]
        lamV_new = np.maximum(sol.y_ineq[: self.V.size], 0.0)
        model = self._merit_model(d, gphi, B, J_ev, lamE_new, lamV_new, elastic)
        if model is None:
            return _HAND_OVER
        ratio, trial, d, kind = self._trial_step(d, model, cB, B, gphi, J_ev, lb, ub)
        dnorm = eng.box.norm(d)
        if eng.opts.verbose:
            print(
                f"{self.nit:4d} {pt.f / eng.sc.sf:14.7e} {pt.viol_u:9.2e} {err:9.2e} "
                f"{mu:9.2e} {self.delta:9.2e} {model[0]:9.2e} {ratio:9.2e}  {kind}"
            )
        if ratio >= ETA_ACCEPT:
            if not self._accept(d, cB, trial):
                return SQPStatus.NUMERICAL_ERROR
            self.lamE, self.lamV = lamE_new, lamV_new
            self.delta = radius_after(self.delta, ratio, dnorm, eng.opts.max_tr_radius, False)
        else:
            self.delta = radius_rejected(self.delta, dnorm)
        return None

    def _merit_model(
        self, d: FloatArray, gphi: FloatArray, B: Any, J_ev: Any, lamE: FloatArray,
        lamV: FloatArray, elastic: bool,
    ) -> tuple[float, float, float, float] | None:  # fmt: skip
        """Penalty update (N&W eq. 18.36 after a consistent QP) and the merit model:
        ``(nu, pred, phi0, guard)``; None when ``nu`` hit its cap (a barrier row jams the
        steps: hand over to the SQP, whose limit rows may become active, with a fresh
        radius; planar n = 16 with OSQP: the radius used to collapse here)."""
        eng = self.eng
        pt = eng.pt
        m0 = pt.v  # = ||c_E||_1 + ||min(c_V, 0)||_1: the barrier rows are positive
        gd = float(gphi @ d)
        dBd = float(d @ matvec(B, d))
        lam_inf = max(float(np.abs(lamE).max(initial=0.0)), float(lamV.max(initial=0.0)))
        nu = eng.nu
        if not elastic:
            nu = max(nu, PENALTY_MARGIN * lam_inf)
            if m0 > 0:
                nu = max(nu, (gd + 0.5 * dBd) / ((1.0 - RHO_PENALTY) * m0))
        nu = eng.nu = min(nu, NU_MAX)
        if nu >= NU_MAX:
            self.delta = max(self.delta, eng.opts.initial_tr_radius)
            return None
        lin = self.c_ev + matvec(J_ev, d)
        md = float(np.abs(lin) @ self.ev_a - lin @ self.ev_b) if self.rows.size else 0.0
        pred = -(gd + 0.5 * dBd) + nu * (m0 - md)
        phi0 = pt.f - self.mu * float(np.log(pt.cI[self.barrier]).sum()) + nu * m0
        return nu, pred, phi0, ROUNDOFF_GUARD * max(1.0, abs(phi0))

    def _ratio(
        self, step: FloatArray, model: tuple[float, float, float, float]
    ) -> tuple[float, Any]:
        """Merit ratio of ``x + step`` and its ``(x, f, c, ev, violation)``."""
        eng = self.eng
        nu, pred, phi0, guard = model
        xt = eng.box.project(eng.pt.x + step)
        ft, ct, evt = eng._eval_values(xt)
        cBt = ct[eng.sc.mE :][self.barrier]
        if not (bool((cBt > 0.0).all()) and math.isfinite(ft) and pred > 0):
            return -math.inf, (xt, ft, ct, evt, math.inf)
        vt = eng.sc.violation(ct)
        phit = ft - self.mu * float(np.log(cBt).sum()) + nu * vt
        return (phi0 - phit + guard) / (pred + guard), (xt, ft, ct, evt, vt)

    def _trial_step(
        self, d: FloatArray, model: tuple[float, float, float, float], cB: FloatArray,
        B: Any, gphi: FloatArray, J_ev: Any, lb: FloatArray, ub: FloatArray,
    ) -> tuple[float, Any, FloatArray, str]:  # fmt: skip
        """The trial point of ``d`` or, when its ratio is below ``ETA_GOOD``, of its
        second-order correction (N&W Sec. 15.5: the same QP at ``c(x + d) - J d``) if
        that is better: ``(ratio, trial, step, kind)``."""
        eng = self.eng
        ratio, trial = self._ratio(d, model)
        kind = "barrier"
        pred = model[1]
        if ratio < ETA_GOOD and self.rows.size and pred > 0 and math.isfinite(trial[1]):
            c_t = trial[2]
            sol_c = self.be.solve_sqp(B, gphi, J_ev, c_t[self.rows] - matvec(J_ev, d), lb, ub)
            eng.qps.n_backend += 1
            if sol_c.status is QPStatus.SOLVED:
                d_c = self._to_boundary(sol_c.x, cB)
                ratio_c, trial_c = self._ratio(d_c, model)
                if ratio_c >= ETA_ACCEPT and ratio_c > ratio:
                    ratio, trial, d, kind = ratio_c, trial_c, d_c, "barrier-soc"
        return ratio, trial, d, kind

    def _accept(self, d: FloatArray, cB: FloatArray, trial: Any) -> bool:
        """Move to the trial point, with the barrier duals' step from the linearised
        ``z c = mu`` (fraction to the boundary, IPOPT's safeguard ``z c in [mu/k, k mu]``);
        False if the new point is not finite."""
        eng = self.eng
        mu, z, barrier = self.mu, self.z, self.barrier
        dz = (mu - z * (cB + matvec(eng.pt.JI, d)[barrier])) / cB
        neg = dz < 0.0
        alpha_z = 1.0
        if neg.any():
            alpha_z = min(1.0, float(np.min(BARRIER_TAU * z[neg] / -dz[neg])))
        z = z + alpha_z * dz
        x_t, f_t, c_t, ev_t, v_t = trial
        if not eng._move_to(x_t, f_t, c_t, v_t, ev_t):
            self.z = z
            return False
        cB_new = eng.pt.cI[barrier]
        self.z = np.clip(z, mu / (BARRIER_KAPPA_SIGMA * cB_new), BARRIER_KAPPA_SIGMA * mu / cB_new)
        return True
