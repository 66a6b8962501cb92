"""Trust-region Sl1QP engine (:func:`solve`).

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
   ((1 - rho) ||c||_1))`` (N&W eq. 18.36).  After an elastic QP, ``nu`` is steered (x10)
   until the step achieves a fair share of the best achievable reduction of the linearised
   violation (Byrd, Nocedal & Waltz 2008, conditions (3.3)-(3.4)); that best reduction also
   serves to detect local infeasibility.
3. **Ratio test** on the l1 merit ``phi = f + nu (||c_E||_1 + ||min(c_I, 0)||_1)``, with a
   second-order correction against the Maratos effect (N&W Alg. 18.4 / Sec. 15.5), radius
   update as in N&W Alg. 4.1 (with the step norm when shrinking).
4. **Hessian.**  Exact (``hessian``) made positive definite by adding ``tau J_A'J_A`` for the
   equalities and previously active inequalities (which leaves the QP solution unchanged
   when the reduced Hessian is positive definite), else by eigenvalue clipping;
   Gauss-Newton (``gauss_newton``); or damped BFGS (Powell, N&W Proc. 18.2).
5. **Termination** on the scaled KKT residual (IPOPT-style multiplier scaling) with QP
   multipliers, and on the unscaled maximum violation, re-checked at the end.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from .options import SQPOptions
from .problem import Evaluation, FloatArray, NonlinearProgram
from .qp import QPBackend, QPSolution, QPStatus, default_qp_solver, make_backend
from .result import MESSAGES, SQPResult, SQPStatus

# --- Algorithm constants --------------------------------------------------------------
ETA_ACCEPT = 1e-4  # eta: step acceptance threshold on ared/pred, N&W Alg. 18.4 (eta in (0,1))
ETA_GOOD = 0.75  # very successful step -> enlarge radius, N&W Alg. 4.1
ETA_BAD = 0.25  # poor step -> shrink radius, N&W Alg. 4.1
GAMMA_SHRINK = 0.25  # radius factor on poor/rejected steps, N&W Alg. 4.1
GAMMA_GROW = 2.0  # radius factor on very successful boundary steps, N&W Alg. 4.1
BOUNDARY_FRACTION = 0.8  # a step "hits the boundary" if ||d|| >= 0.8 radius
RHO_PENALTY = 0.1  # rho in N&W eq. (18.36) for the penalty lower bound
PENALTY_MARGIN = 1.1  # nu >= 1.1 ||y||_inf (exactness of the l1 penalty, N&W Thm. 17.3)
NU_INIT = 1.0  # initial penalty parameter
NU_MAX = 1e10  # cap on the penalty parameter
NU_STEER_FACTOR = 10.0  # penalty increase during steering, Byrd-Nocedal-Waltz 2008
NU_STEER_MAX_TRIES = 6
EPS1_STEER = 0.1  # eps_1: fraction of achievable linearised-violation reduction, BNW 2008
EPS2_STEER = 0.05  # eps_2 < eps_1: merit-model reduction condition, BNW 2008
NU_FEAS = 1e6  # penalty factor emulating the pure feasibility subproblem (nu -> inf)
SLACK_REG = 1e-8  # tiny curvature on elastic slacks keeps every backend's QP strictly convex
HESS_REG = 1e-8  # relative floor of the QP Hessian eigenvalues (convexity)
HESS_FLOOR = 1e-4  # absolute eigenvalue floor of a modified exact Hessian (no LP-like QPs)
BFGS_DAMP = 0.2  # Powell damping threshold, N&W Proc. 18.2
BFGS_DAMP_THETA = 0.8  # Powell damping factor, N&W Proc. 18.2
AUG_TAUS = (1.0, 1e2, 1e4)  # tried multipliers of J_A'J_A for exact-Hessian convexification
SCALE_MAX_GRADIENT = 100.0  # IPOPT nlp_scaling_max_gradient (Waechter & Biegler 2006, 3.8)
KKT_S_MAX = 100.0  # IPOPT s_max for multiplier-scaled stationarity (W&B 2006, eq. 5)
ROUNDOFF_GUARD = 10.0 * np.finfo(float).eps  # 10 eps_M max(1,|phi|), CGT (2000) 17.4.2
DELTA_MIN = 1e-12  # trust-region collapse threshold (relative to 1 + ||x/xs||_inf)


class _Timer:
    __slots__ = ("eval", "build", "qp")

    def __init__(self) -> None:
        self.eval = 0.0
        self.build = 0.0
        self.qp = 0.0


def _as2d(J: Any, m: int, n: int) -> FloatArray:
    if J is None or m == 0:
        return np.zeros((m, n))
    return np.asarray(J, dtype=float).reshape(m, n)


class _Engine:
    """One SQP run (all state of the iteration)."""

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
        self.timer = _Timer()
        self.nfev = 0
        self.backends: dict[tuple[str, int, int, int], QPBackend] = {}
        n = x0.size
        self.n = n
        lower = np.full(n, -np.inf) if nlp.lower is None else np.asarray(nlp.lower, float)
        upper = np.full(n, np.inf) if nlp.upper is None else np.asarray(nlp.upper, float)
        if lower.shape != (n,) or upper.shape != (n,):
            raise ValueError(f"lower/upper must have shape ({n},)")
        if np.any(lower > upper):
            raise ValueError("lower must not exceed upper")
        self.lower, self.upper = lower, upper
        self.xs = np.ones(n) if nlp.x_scale is None else np.asarray(nlp.x_scale, float)
        if self.xs.shape != (n,) or np.any(~(self.xs > 0)) or np.any(~np.isfinite(self.xs)):
            raise ValueError(f"x_scale must be positive and finite with shape ({n},)")
        strategy = opts.hessian
        if strategy == "auto":
            if nlp.hessian is not None:
                strategy = "exact"
            elif nlp.gauss_newton is not None:
                strategy = "gauss-newton"
            else:
                strategy = "bfgs"
        if strategy == "exact" and nlp.hessian is None:
            raise ValueError("SQPOptions.hessian='exact' needs NonlinearProgram.hessian")
        if strategy == "gauss-newton" and nlp.gauss_newton is None:
            raise ValueError(
                "SQPOptions.hessian='gauss-newton' needs NonlinearProgram.gauss_newton"
            )
        self.strategy = strategy
        self.x: FloatArray = np.clip(np.asarray(x0, dtype=float), lower, upper)
        # Iteration state, set in run() once the dimensions and scaling are known.
        self.mE = 0
        self.mI = 0
        self.sf = 1.0
        self.wE: FloatArray = np.ones(0)
        self.wI: FloatArray = np.ones(0)
        self.f = 0.0
        self.cE: FloatArray = np.zeros(0)
        self.cI: FloatArray = np.zeros(0)
        self.g: FloatArray = np.zeros(n)
        self.JE: FloatArray = np.zeros((0, n))
        self.JI: FloatArray = np.zeros((0, n))
        self.negJI: FloatArray = np.zeros((0, n))
        self.B: FloatArray = np.eye(n)
        self.bfgs_first = True
        self.v = 0.0
        self.nu = NU_INIT
        self.any_bounds = False
        self.bound_tol: FloatArray = np.zeros(n)
        self.ctol_scaled = 0.0
        self.last_qp_info = ""

    # ---------------------------------------------------------------- evaluation -----
    def _eval_full(self, x: FloatArray) -> Evaluation:
        t = time.perf_counter()
        ev = self.nlp.evaluate_all(x)
        self.timer.eval += time.perf_counter() - t
        return ev

    def _eval_values(
        self, x: FloatArray
    ) -> tuple[float, FloatArray, FloatArray, Evaluation | None]:
        t = time.perf_counter()
        f, cE, cI, ev = self.nlp.evaluate_values(x)
        self.timer.eval += time.perf_counter() - t
        self.nfev += 1
        fs = float(f) * self.sf
        cEs = self.wE * (np.zeros(0) if cE is None else np.asarray(cE, float).ravel())
        cIs = self.wI * (np.zeros(0) if cI is None else np.asarray(cI, float).ravel())
        return fs, cEs, cIs, ev

    def _derivs(self, x: FloatArray, ev: Evaluation | None) -> None:
        """Set gradient and Jacobians (scaled) at ``x`` (``ev`` reused when available)."""
        nlp = self.nlp
        n, mE, mI = self.n, self.mE, self.mI
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
        self.g = self.sf * np.asarray(g, dtype=float).ravel()
        self.JE = self.wE[:, None] * _as2d(JE, mE, n)
        self.JI = self.wI[:, None] * _as2d(JI, mI, n)
        self.negJI = -self.JI

    # ----------------------------------------------------------------- helpers -------
    def _backend(self, name: str, n: int, me: int, mi: int) -> QPBackend:
        key = (name, n, me, mi)
        be = self.backends.get(key)
        if be is None:
            opts = self.opts.qp_options if name == self.qp_name else None
            be = make_backend(name, opts)
            be.setup(n, me, mi)
            self.backends[key] = be
        return be

    def _qp(
        self,
        P: FloatArray,
        q: FloatArray,
        A_eq: FloatArray,
        b_eq: FloatArray,
        G: FloatArray,
        h: FloatArray,
        lb: FloatArray,
        ub: FloatArray,
    ) -> QPSolution:
        """Solve with the main backend, then (on FAILED) with the fallback backend."""
        n, me, mi = q.size, b_eq.size, h.size
        t = time.perf_counter()
        sol = self._backend(self.qp_name, n, me, mi).solve(P, q, A_eq, b_eq, G, h, lb, ub)
        if (
            sol.status is QPStatus.SOLVED
            and not np.all(np.isfinite(sol.x))
            or sol.status is QPStatus.SOLVED
            and np.any(sol.x < lb - 1e-6 * (1 + np.abs(lb)))
        ):
            sol = QPSolution(sol.x, sol.y_eq, sol.y_ineq, sol.y_bounds, QPStatus.FAILED, "bad")
        fb = self.opts.fallback_qp_solver
        if sol.status is QPStatus.FAILED and fb is not None and fb != self.qp_name:
            sol = self._backend(fb, n, me, mi).solve(P, q, A_eq, b_eq, G, h, lb, ub)
        self.timer.qp += time.perf_counter() - t
        self.last_qp_info = sol.info
        return sol

    def _violation(self, cE: FloatArray, cI: FloatArray) -> float:
        """Scaled l1 violation ``||c_E||_1 + ||min(c_I, 0)||_1``."""
        return float(np.abs(cE).sum() - np.minimum(cI, 0.0).sum())

    def _lin_violation(self, d: FloatArray) -> float:
        return self._violation(self.cE + self.JE @ d, self.cI + self.JI @ d)

    def _max_violation_unscaled(self, cE: FloatArray, cI: FloatArray) -> float:
        v = 0.0
        if cE.size:
            v = float((np.abs(cE) / self.wE).max())
        if cI.size:
            v = max(v, float((-cI / self.wI).max()))
        return max(v, 0.0)

    def _kkt(self, lamE: FloatArray, lamI: FloatArray) -> tuple[float, float]:
        """Scaled stationarity and complementarity at the current x."""
        r = self.g - self.JE.T @ lamE - self.JI.T @ lamI
        if self.any_bounds:
            x = self.x
            at_lo = x <= self.lower + self.bound_tol
            at_up = x >= self.upper - self.bound_tol
            r = np.where(at_lo, np.minimum(r, 0.0), r)
            r = np.where(at_up, np.maximum(r, 0.0), r)
        m = lamE.size + lamI.size
        sd = 1.0
        if m:
            sd = max(KKT_S_MAX, (np.abs(lamE).sum() + np.abs(lamI).sum()) / m) / KKT_S_MAX
        stat = float(np.abs(r).max()) / sd if r.size else 0.0
        compl = float(np.abs(lamI * self.cI).max()) / sd if lamI.size else 0.0
        return stat, compl

    # ------------------------------------------------------------------ Hessian -------
    def _exact_hessian(self, lamE: FloatArray, lamI: FloatArray) -> FloatArray:
        nlp = self.nlp
        assert nlp.hessian is not None
        yE = lamE * self.wE / self.sf
        yI = lamI * self.wI / self.sf
        t = time.perf_counter()
        H = np.asarray(nlp.hessian(self.x, yE, yI), dtype=float).reshape(self.n, self.n)
        self.timer.eval += time.perf_counter() - t
        t = time.perf_counter()
        H = self.sf * 0.5 * (H + H.T)
        B = self._convexify(H, lamI)
        self.timer.build += time.perf_counter() - t
        return B

    def _convexify(self, H: FloatArray, lamI: FloatArray) -> FloatArray:
        if not np.all(np.isfinite(H)):
            return np.eye(self.n)
        w = np.linalg.eigvalsh(H)
        scale = max(1.0, float(np.max(np.abs(w))))
        floor = max(HESS_REG * scale, HESS_FLOOR)
        if w[0] >= HESS_REG * scale:
            return H
        # Augment with J_A'J_A over equalities and active inequalities: unchanged QP solution
        # when that active set is kept and the reduced Hessian is positive definite.
        active = lamI > 0
        JA = np.vstack((self.JE, self.JI[active])) if self.mE + self.mI else np.zeros((0, 1))
        if JA.shape[0]:
            JtJ = JA.T @ JA
            nj = max(float(np.max(np.abs(JtJ))), 1e-300)
            for tau in AUG_TAUS:
                Ha = H + (tau * max(1.0, -w[0]) / nj) * JtJ
                wa = np.linalg.eigvalsh(Ha)
                if wa[0] >= HESS_REG * max(1.0, float(np.max(np.abs(wa)))):
                    return Ha
        # Eigenvalue clipping.
        w, V = np.linalg.eigh(H)
        w = np.maximum(w, floor)
        Hc: FloatArray = (V * w) @ V.T
        return 0.5 * (Hc + Hc.T)

    def _gn_hessian(self) -> FloatArray:
        nlp = self.nlp
        assert nlp.gauss_newton is not None
        t = time.perf_counter()
        _r, Jr = nlp.gauss_newton(self.x)
        self.timer.eval += time.perf_counter() - t
        t = time.perf_counter()
        Jr = np.asarray(Jr, dtype=float)
        B = (self.sf * nlp.gn_scale) * (Jr.T @ Jr)
        reg = HESS_REG * max(1.0, float(np.max(np.diag(B)))) if self.n else 0.0
        B[np.diag_indices_from(B)] += reg
        self.timer.build += time.perf_counter() - t
        return B

    def _bfgs_update(self, s: FloatArray, yv: FloatArray) -> None:
        B = self.B
        Bs = B @ s
        sBs = float(s @ Bs)
        sy = float(s @ yv)
        if sBs <= 1e-300 or not np.isfinite(sy):
            return
        if self.bfgs_first and sy > 0:
            # Initial scaling, N&W eq. (6.20).
            B *= float(yv @ yv) / sy
            Bs = B @ s
            sBs = float(s @ Bs)
            self.bfgs_first = False
        if sy >= BFGS_DAMP * sBs:
            r = yv
        else:
            theta = BFGS_DAMP_THETA * sBs / (sBs - sy)
            r = theta * yv + (1.0 - theta) * Bs
        sr = float(s @ r)
        if sr <= 1e-300:
            return
        B += np.outer(r, r) / sr - np.outer(Bs, Bs) / sBs
        self.B = 0.5 * (B + B.T)

    # --------------------------------------------------------------- subproblem -------
    def _elastic(
        self, nu: float, lb: FloatArray, ub: FloatArray, delta_vec: FloatArray
    ) -> tuple[QPSolution, FloatArray]:
        n, mE = self.n, self.mE
        viol_idx = np.flatnonzero(self.cI < 0.0)
        k = viol_idx.size
        nz = n + 2 * mE + k
        P = np.zeros((nz, nz))
        P[:n, :n] = self.B
        idx = np.arange(n, nz)
        P[idx, idx] = SLACK_REG
        q = np.full(nz, nu)
        q[:n] = self.g
        A_eq = np.zeros((mE, nz))
        A_eq[:, :n] = self.JE
        A_eq[:, n : n + mE] = -np.eye(mE)
        A_eq[:, n + mE : n + 2 * mE] = np.eye(mE)
        G = np.zeros((self.mI, nz))
        G[:, :n] = self.negJI
        G[viol_idx, n + 2 * mE + np.arange(k)] = -1.0
        lbz = np.zeros(nz)
        ubz = np.empty(nz)
        lbz[:n] = lb
        ubz[:n] = ub
        # Finite slack bounds that can never bind: |c_i| + |J_i| (radius * xs) + 1.
        ubz[n : n + mE] = np.abs(self.cE) + np.abs(self.JE) @ delta_vec + 1.0
        ubz[n + mE : n + 2 * mE] = ubz[n : n + mE]
        ubz[n + 2 * mE :] = -self.cI[viol_idx] + np.abs(self.JI[viol_idx]) @ delta_vec + 1.0
        sol = self._qp(P, q, A_eq, -self.cE, G, self.cI, lbz, ubz)
        return sol, sol.x[:n]

    def _model_decrease(self, d: FloatArray, nu: float, m0: float, md: float) -> float:
        return -float(self.g @ d + 0.5 * d @ (self.B @ d)) + nu * (m0 - md)

    def _subproblem(
        self, lb: FloatArray, ub: FloatArray, delta: float
    ) -> tuple[QPSolution | None, FloatArray, bool, bool]:
        """Return (solution, d, elastic?, locally-infeasible?)."""
        sol = self._qp(self.B, self.g, self.JE, -self.cE, self.negJI, self.cI, lb, ub)
        if sol.status is QPStatus.SOLVED:
            return sol, sol.x, False, False
        if self.mE + self.mI == 0:
            return None, np.zeros(self.n), False, False
        delta_vec = np.minimum(np.maximum(ub, -lb), delta * self.xs)
        m0 = self.v
        nu = self.nu
        sol, d = self._elastic(nu, lb, ub, delta_vec)
        if sol.status is not QPStatus.SOLVED:
            return None, d, True, False
        m_nu = self._lin_violation(d)
        infeasible = False
        if m_nu > 0.1 * self.ctol_scaled:
            sol_inf, d_inf = self._elastic(max(NU_FEAS * nu, NU_FEAS), lb, ub, delta_vec)
            if sol_inf.status is QPStatus.SOLVED:
                m_inf = min(self._lin_violation(d_inf), m_nu)
                best = m0 - m_inf
                chi = best / min(delta, 1.0)
                if m0 > self.ctol_scaled and chi <= self.opts.tol * max(1.0, m0):
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
        return sol, d, True, infeasible

    # ---------------------------------------------------------------------- run -------
    def _time_up(self) -> bool:
        return time.perf_counter() - self.t0 > self.opts.max_time

    def run(self) -> SQPResult:
        opts, nlp, n = self.opts, self.nlp, self.n
        verbose = opts.verbose
        x = self.x
        ev = self._eval_full(x)
        self.nfev = 1
        f_raw = float(ev.f)
        cE_raw = np.zeros(0) if ev.c_eq is None else np.asarray(ev.c_eq, float).ravel()
        cI_raw = np.zeros(0) if ev.c_ineq is None else np.asarray(ev.c_ineq, float).ravel()
        self.mE, self.mI = mE, mI = cE_raw.size, cI_raw.size
        g_raw = np.asarray(ev.g, dtype=float).ravel()
        JE_raw = _as2d(ev.J_eq, mE, n)
        JI_raw = _as2d(ev.J_ineq, mI, n)
        # Scaling (IPOPT gradient-based rule, W&B 2006 Sec. 3.8) or user-given factors.
        self.sf = 1.0
        self.wE = np.ones(mE)
        self.wI = np.ones(mI)
        if opts.scaling:
            gmax = float(np.max(np.abs(g_raw))) if n else 0.0
            if np.isfinite(gmax) and gmax > SCALE_MAX_GRADIENT:
                self.sf = SCALE_MAX_GRADIENT / gmax
            if mE:
                rn = np.max(np.abs(JE_raw), axis=1) if n else np.zeros(mE)
                self.wE = SCALE_MAX_GRADIENT / np.maximum(rn, SCALE_MAX_GRADIENT)
            if mI:
                rn = np.max(np.abs(JI_raw), axis=1) if n else np.zeros(mI)
                self.wI = SCALE_MAX_GRADIENT / np.maximum(rn, SCALE_MAX_GRADIENT)
            self.wE[~np.isfinite(self.wE)] = 1.0
            self.wI[~np.isfinite(self.wI)] = 1.0
        if nlp.eq_scale is not None:
            self.wE = np.broadcast_to(np.asarray(nlp.eq_scale, float), (mE,)).copy()
        if nlp.ineq_scale is not None:
            self.wI = np.broadcast_to(np.asarray(nlp.ineq_scale, float), (mI,)).copy()
        if np.any(~(self.wE > 0)) or np.any(~(self.wI > 0)):
            raise ValueError("eq_scale and ineq_scale must be positive")
        self.f = self.sf * f_raw
        self.cE = self.wE * cE_raw
        self.cI = self.wI * cI_raw
        self._derivs(x, ev)
        self.any_bounds = bool(np.any(np.isfinite(self.lower)) or np.any(np.isfinite(self.upper)))
        self.bound_tol = opts.constr_tol * (1.0 + np.minimum(np.abs(self.lower), 1e300))
        self.ctol_scaled = opts.constr_tol * float(
            min(np.min(self.wE, initial=1.0), np.min(self.wI, initial=1.0))
        )
        self.nu = NU_INIT
        self.v = self._violation(self.cE, self.cI)
        lamE = np.zeros(mE)
        lamI = np.zeros(mI)
        self.bfgs_first = True
        self.last_qp_info = ""

        status: SQPStatus | None = None
        detail = ""
        if not (np.isfinite(self.f) and np.all(np.isfinite(self.g)) and np.isfinite(self.v)):
            status = SQPStatus.NUMERICAL_ERROR
            detail = " (at x0)"
        elif not (np.all(np.isfinite(self.JE)) and np.all(np.isfinite(self.JI))):
            status = SQPStatus.NUMERICAL_ERROR
            detail = " (Jacobian at x0)"
        if status is None:
            t = time.perf_counter()
            if self.strategy == "exact":
                self.B = self._exact_hessian(lamE, lamI)
            elif self.strategy == "gauss-newton":
                self.B = self._gn_hessian()
            else:
                self.B = np.eye(n)
            self.timer.build += 0.0 * (time.perf_counter() - t)

        delta = opts.initial_tr_radius
        nit = 0
        have_lam = False
        x_changed = True
        stat = compl = math.inf
        best_x, best_v = x.copy(), self._max_violation_unscaled(self.cE, self.cI)
        if verbose and status is None:
            print(
                f"{'it':>4} {'f':>14} {'viol':>9} {'stat':>9} {'compl':>9} "
                f"{'radius':>9} {'nu':>9} {'ratio':>9}  step"
            )
        while status is None:
            if self._time_up():
                status = SQPStatus.MAX_TIME
                break
            viol_u = self._max_violation_unscaled(self.cE, self.cI)
            if have_lam and x_changed:
                stat, compl = self._kkt(lamE, lamI)
                if stat <= opts.tol and compl <= opts.tol and viol_u <= opts.constr_tol:
                    status = SQPStatus.SUCCESS
                    break
            if nit >= opts.max_iter:
                status = SQPStatus.MAX_ITER
                break
            x_changed = False
            # ---- QP subproblem
            t = time.perf_counter()
            dvec = delta * self.xs
            lb = np.maximum(self.lower - x, -dvec)
            ub = np.minimum(self.upper - x, dvec)
            np.minimum(lb, 0.0, out=lb)
            np.maximum(ub, 0.0, out=ub)
            self.timer.build += time.perf_counter() - t
            nit += 1
            sol, d, elastic, infeasible = self._subproblem(lb, ub, delta)
            if sol is None:
                status = SQPStatus.QP_FAILURE
                detail = f" ({self.last_qp_info})"
                break
            lamE = -sol.y_eq[:mE] if mE else lamE
            lamI = np.maximum(sol.y_ineq[:mI], 0.0) if mI else lamI
            have_lam = True
            stat, compl = self._kkt(lamE, lamI)
            if stat <= opts.tol and compl <= opts.tol and viol_u <= opts.constr_tol:
                status = SQPStatus.SUCCESS
                break
            if infeasible:
                status = SQPStatus.INFEASIBLE
                break
            if self._time_up():
                status = SQPStatus.MAX_TIME
                break
            # ---- penalty update (N&W eq. 18.36) after a consistent QP
            m0 = self.v
            dBd = float(d @ (self.B @ d))
            gd = float(self.g @ d)
            if not elastic:
                lam_inf = max(
                    float(np.max(np.abs(lamE), initial=0.0)),
                    float(np.max(lamI, initial=0.0)),
                )
                nu = max(self.nu, PENALTY_MARGIN * lam_inf)
                if m0 > 0:
                    nu = max(nu, (gd + 0.5 * dBd) / ((1.0 - RHO_PENALTY) * m0))
                self.nu = min(nu, NU_MAX)
            nu = self.nu
            # Linearised violation of the computed step (not assumed zero: QP tolerances).
            md = self._lin_violation(d)
            pred = -(gd + 0.5 * dBd) + nu * (m0 - md)
            phi0 = self.f + nu * m0
            dnorm = float(np.max(np.abs(d) / self.xs)) if n else 0.0
            # ---- trial point
            x_t = np.clip(x + d, self.lower, self.upper)
            f_t, cE_t, cI_t, ev_t = self._eval_values(x_t)
            v_t = self._violation(cE_t, cI_t)
            phi_t = f_t + nu * v_t
            ok = math.isfinite(phi_t)
            # Roundoff-protected ratio, Conn, Gould & Toint (2000) Sec. 17.4.2.
            guard = ROUNDOFF_GUARD * max(1.0, abs(phi0))
            ratio = (phi0 - phi_t + guard) / (pred + guard) if ok and pred > -guard else -math.inf
            kind = "elastic" if elastic else "qp"
            if ratio < ETA_ACCEPT and not elastic and (mE + mI) and ok and pred > 0:
                # Second-order correction (N&W Sec. 15.5 / Alg. 18.4).
                Jd_E = self.JE @ d
                Jd_I = self.JI @ d
                sol_c = self._qp(
                    self.B, self.g, self.JE, -(cE_t - Jd_E), self.negJI, cI_t - Jd_I, lb, ub
                )
                if sol_c.status is QPStatus.SOLVED:
                    x_c = np.clip(x + sol_c.x, self.lower, self.upper)
                    f_c, cE_c, cI_c, ev_c = self._eval_values(x_c)
                    phi_c = f_c + nu * self._violation(cE_c, cI_c)
                    ratio_c = (phi0 - phi_c + guard) / (pred + guard)
                    if math.isfinite(phi_c) and ratio_c >= ETA_ACCEPT:
                        x_t, f_t, cE_t, cI_t, ev_t = x_c, f_c, cE_c, cI_c, ev_c
                        ratio = ratio_c
                        kind = "soc"
                        d = sol_c.x
            if verbose:
                print(
                    f"{nit:4d} {self.f / self.sf:14.7e} {viol_u:9.2e} {stat:9.2e} "
                    f"{compl:9.2e} {delta:9.2e} {nu:9.2e} {ratio:9.2e}  {kind}"
                    + (f" [{self.last_qp_info}]" if verbose > 1 else "")
                )
            if ratio >= ETA_ACCEPT:
                # ---- accept
                if self.strategy == "bfgs":
                    gL_old = self.g - self.JE.T @ lamE - self.JI.T @ lamI
                x_old = x
                x = self.x = x_t
                x_changed = True
                self.f, self.cE, self.cI = f_t, cE_t, cI_t
                self.v = v_t
                if ev_t is None and self.nlp.evaluate is not None:
                    ev_t = self._eval_full(x)
                self._derivs(x, ev_t)
                if not (
                    np.all(np.isfinite(self.g))
                    and np.all(np.isfinite(self.JE))
                    and np.all(np.isfinite(self.JI))
                ):
                    status = SQPStatus.NUMERICAL_ERROR
                    break
                if self.strategy == "exact":
                    self.B = self._exact_hessian(lamE, lamI)
                elif self.strategy == "gauss-newton":
                    self.B = self._gn_hessian()
                else:
                    t = time.perf_counter()
                    gL_new = self.g - self.JE.T @ lamE - self.JI.T @ lamI
                    self._bfgs_update(x - x_old, gL_new - gL_old)
                    self.timer.build += time.perf_counter() - t
                viol_new = self._max_violation_unscaled(self.cE, self.cI)
                if viol_new < best_v:
                    best_x, best_v = x.copy(), viol_new
                if ratio >= ETA_GOOD and dnorm >= BOUNDARY_FRACTION * delta:
                    delta = min(GAMMA_GROW * delta, opts.max_tr_radius)
                elif ratio < ETA_BAD:
                    delta = GAMMA_SHRINK * delta
            else:
                delta = GAMMA_SHRINK * min(delta, dnorm if dnorm > 0 else delta)
            if delta < DELTA_MIN * (1.0 + float(np.max(np.abs(x) / self.xs, initial=0.0))):
                stat, compl = self._kkt(lamE, lamI)
                status = SQPStatus.SMALL_STEP
                break

        # ---- final re-check and result
        if status is SQPStatus.INFEASIBLE and best_v < self._max_violation_unscaled(
            self.cE, self.cI
        ):
            x = best_x
            f_b, cE_b, cI_b, _ = self._eval_values(x)
            self.f, self.cE, self.cI = f_b, cE_b, cI_b
        viol_u = self._max_violation_unscaled(self.cE, self.cI)
        if status is SQPStatus.SUCCESS and not viol_u <= opts.constr_tol:
            status = SQPStatus.SMALL_STEP
            detail = " (final violation check failed)"
        mult_scale = 1.0 / self.sf
        yE = lamE * self.wE * mult_scale
        yI = lamI * self.wI * mult_scale
        kkt = max(
            stat,
            compl,
            viol_u * float(min(np.min(self.wE, initial=1.0), np.min(self.wI, initial=1.0))),
        )
        total = time.perf_counter() - self.t0
        if verbose:
            print(f"stackik.sqp: {status.value}: {MESSAGES[status]}{detail}")
        return SQPResult(
            x=np.array(x, dtype=float),
            success=status is SQPStatus.SUCCESS,
            status=status,
            message=MESSAGES[status] + detail,
            fun=float(self.f / self.sf),
            nit=nit,
            nfev=self.nfev,
            kkt_residual=float(kkt),
            max_violation=float(viol_u),
            y_eq=yE,
            y_ineq=yI,
            tr_radius=float(delta),
            penalty=float(self.nu),
            qp_solver=self.qp_name,
            time_eval=self.timer.eval,
            time_qp_build=self.timer.build,
            time_qp_solve=self.timer.qp,
            time_total=total,
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
