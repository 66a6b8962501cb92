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
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.linalg.lapack import dpotrf as _dpotrf
from scipy.linalg.lapack import dsyev as _dsyev
from scipy.linalg.lapack import dsyevd as _dsyevd

from .options import SQPOptions
from .problem import Evaluation, FloatArray, NonlinearProgram
from .qp import QPBackend, QPSolution, QPStatus, default_qp_solver, make_backend
from .result import MESSAGES, SQPResult, SQPStatus
from .sparse import (
    FixedPattern,
    GramMap,
    RowSubset,
    StackedPattern,
    csc,
    diagonal_positions,
    entry_cols,
    gram_structure,
    is_sparse,
    matvec,
    positive_definite,
    rmatvec,
    transpose_permutation,
)
from .working_set import WorkingSetStep

BoolArray = NDArray[np.bool_]
#: (lam, g, J, c_I, at_lower, at_upper) of one KKT evaluation.
_KKTArgs = tuple[FloatArray, FloatArray, FloatArray, FloatArray, BoolArray | None, BoolArray | None]

# --- Algorithm constants --------------------------------------------------------------
ETA_ACCEPT = 1e-4  # eta: step acceptance threshold on ared/pred, N&W Alg. 18.4 (eta in (0,1))
ETA_GOOD = 0.75  # very successful step -> enlarge radius, N&W Alg. 4.1
ETA_BAD = 0.25  # poor step -> shrink radius, N&W Alg. 4.1
SOC_BELOW = ETA_GOOD  # a second-order correction is tried when the ratio is below this
SOC_REG = 1e-10  # relative regularisation of J_A J_A' in the least-norm correction
SOC_DENSE_MAX = 1 << 16  # sparse J: a dense J_A (rows x columns) up to this size
BACKTRACK_STEPS = 2  # rejected steps: shorter steps along d tried before shrinking
BACKTRACK_FACTOR = 0.5
SCREEN_KEEP = 2.0  # screened QPs keep rows screened in before, up to this many times those needed
GAMMA_SHRINK = 0.25  # radius factor on poor/rejected steps, N&W Alg. 4.1
GAMMA_GROW = 2.0  # radius factor on very successful boundary steps, N&W Alg. 4.1
BOUNDARY_FRACTION = 0.8  # a step "hits the boundary" if ||d|| >= 0.8 radius
RHO_PENALTY = 0.1  # rho in N&W eq. (18.36) for the penalty lower bound
PENALTY_MARGIN = 1.1  # nu >= 1.1 ||y||_inf (exactness of the l1 penalty, N&W Thm. 17.3)
NU_INIT = 1.0  # initial penalty parameter
NU_DECREASE_RATIO = 1.0  # nu is lowered to this multiple of 1.1 ||y||_inf when above it
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
ACTIVE_MULTIPLIER_TOL = 1e-6  # relative multiplier above which a row counts as active
SCALE_MAX_GRADIENT = 100.0  # IPOPT nlp_scaling_max_gradient (Waechter & Biegler 2006, 3.8)
KKT_S_MAX = 100.0  # IPOPT s_max for multiplier-scaled stationarity (W&B 2006, eq. 5)
ROUNDOFF_GUARD = 10.0 * np.finfo(float).eps  # 10 eps_M max(1,|phi|), CGT (2000) 17.4.2
DELTA_MIN = 1e-12  # trust-region collapse threshold (relative to 1 + ||x/xs||_inf)
# Interior start phase (SQPOptions.barrier_start); constants as in IPOPT (W&B 2006, 3.1)
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
# Inexact subproblems (SQPOptions.qp_accuracy = "adaptive")
QP_ACC_FACTOR = 0.1  # QP tolerance = factor x the SQP optimality measure ...
QP_ACC_MAX = 1e-3  # ... at most this (never looser)


class _Timer:
    __slots__ = ("eval", "build", "qp")

    def __init__(self) -> None:
        self.eval = 0.0
        self.build = 0.0
        self.qp = 0.0


def _as2d(J: Any, m: int, n: int) -> FloatArray:
    if J is None or m == 0:
        return np.zeros((m, n))
    if is_sparse(J):
        return np.asarray(J.toarray(), dtype=float).reshape(m, n)
    return np.asarray(J, dtype=float).reshape(m, n)


def _row_absmax(J: Any) -> FloatArray:
    """``max_j |J_ij|`` per row, dense or sparse ``J``."""
    if is_sparse(J):
        if J.shape[0] == 0:
            return np.zeros(0)
        return np.asarray(abs(J).max(axis=1).toarray(), dtype=float).ravel()
    return np.abs(J).max(axis=1)  # type: ignore[no-any-return]


def _values(M: Any) -> FloatArray:
    """The stored values of a dense or sparse matrix."""
    return M.data if is_sparse(M) else M  # type: ignore[no-any-return]


def _all_finite(a: FloatArray) -> bool:
    """``np.all(np.isfinite(a))``, via one sum when that is finite (the usual case)."""
    return math.isfinite(float(a.sum())) or bool(np.all(np.isfinite(a)))


def _chol_ok(H: FloatArray, shift: float, eye: FloatArray) -> bool:
    """Whether the symmetric ``H - shift I`` is numerically positive definite (Cholesky
    succeeds; ``H`` is not modified)."""
    if shift == 0.0:
        return int(_dpotrf(H.T, lower=1, clean=0, overwrite_a=0)[1]) == 0
    # The transpose of the (symmetric, C-ordered) temporary is Fortran-ordered: no copy.
    return int(_dpotrf((H - shift * eye).T, lower=1, clean=0, overwrite_a=1)[1]) == 0


class _Engine:
    """One SQP run (all state of the iteration).

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
        self.timer = _Timer()
        self.nfev = 0
        self.backends: dict[tuple[str, int, int, int], QPBackend] = {}
        self.main_backend: QPBackend | None = None  # of the plain QP
        n = x0.size
        self.n = n
        lower = np.full(n, -np.inf) if nlp.lower is None else np.asarray(nlp.lower, float)
        upper = np.full(n, np.inf) if nlp.upper is None else np.asarray(nlp.upper, float)
        if lower.shape != (n,) or upper.shape != (n,):
            raise ValueError(f"lower/upper must have shape ({n},)")
        self.any_bounds = False
        if nlp.lower is not None or nlp.upper is not None:
            if (lower > upper).any():
                raise ValueError("lower must not exceed upper")
            self.any_bounds = bool(np.isfinite(lower).any() or np.isfinite(upper).any())
        self.lower, self.upper = lower, upper
        self.unit_xs = nlp.x_scale is None
        self.xs = np.ones(n) if nlp.x_scale is None else np.asarray(nlp.x_scale, float)
        if not self.unit_xs:
            xs = self.xs
            if xs.shape != (n,) or not ((xs > 0).all() and np.isfinite(xs).all()):
                raise ValueError(f"x_scale must be positive and finite with shape ({n},)")
            self.unit_xs = bool((xs == 1.0).all())
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
        x0 = np.array(x0, dtype=float)
        self.x: FloatArray = np.minimum(np.maximum(x0, lower), upper) if self.any_bounds else x0
        self.eye: FloatArray = np.eye(n)
        # Iteration state, set in run() once the dimensions and scaling are known.
        self.mE = 0
        self.mI = 0
        self.m = 0
        self.sf = 1.0
        self.w: FloatArray = np.ones(0)  # constraint scale factors [wE; wI]
        self.wE: FloatArray = self.w
        self.wI: FloatArray = self.w
        self.unit_w = True
        self.viol_a: FloatArray = np.zeros(0)
        self.viol_b: FloatArray = np.zeros(0)
        self.f = 0.0
        self.c: FloatArray = np.zeros(0)
        self.cE: FloatArray = self.c
        self.cI: FloatArray = self.c
        self.g: FloatArray = np.zeros(n)
        self.J: Any = np.zeros((0, n))
        self.JE: Any = self.J
        self.JI: Any = self.J
        self.B: Any = np.eye(n)
        # Sparse mode (a Jacobian given as a scipy sparse matrix): J and the QP Hessian
        # are CSC matrices in fixed patterns (see stackik.sqp.sparse).
        self.sparse = False
        self.je_pat = FixedPattern((0, n))
        self.ji_pat = FixedPattern((0, n))
        self.j_stack = StackedPattern(0, 0, n)
        self.h_pat = FixedPattern((n, n))
        self.h_src: tuple[Any, Any] | None = None  # pattern arrays perm/diag belong to
        self.h_perm: Any = None  # data[perm]: data of the transpose
        self.h_diag: Any = None  # positions of the diagonal
        self.h_shift = 0.0  # last diagonal shift of the sparse convexification
        self._gram_maps: dict[int, GramMap] = {}
        self._row_subset: RowSubset | None = None
        self.screen_backend: QPBackend | None = None  # QPs without the rows that cannot bind
        self._screen_subset: RowSubset | None = None  # rows of the screened QPs' pattern
        self._screen_rows: Any = None
        self.ws: WorkingSetStep | None = None  # SQPOptions.qp_working_set
        self.n_backend = 0  # QPs passed to a backend
        self.qp_eps: float | None = None  # QP tolerance of the inexact mode (None: fixed)
        self.bfgs_first = True
        self.hess_modified = False  # the last exact Hessian needed convexification
        self.v = 0.0
        self.nu = NU_INIT
        self.bound_tol: FloatArray = np.zeros(n)
        self.ctol_scaled = 0.0
        self.last_qp_info = ""
        # Caches of quantities that depend on x only (refreshed by _new_point).
        self.viol_u = 0.0
        self.xnorm = 0.0
        self.lo_tol: FloatArray = lower
        self.up_tol: FloatArray = upper
        self.at_lo: BoolArray | None = None  # None: no bounds
        self.at_up: BoolArray | None = None

    # ---------------------------------------------------------------- evaluation -----
    def _eval_full(self, x: FloatArray) -> Evaluation:
        t = time.perf_counter()
        ev = self.nlp.evaluate_all(x)
        self.timer.eval += time.perf_counter() - t
        return ev

    def _stack_c(self, cE: Any, cI: Any) -> FloatArray:
        """Scaled stacked constraint values ``[wE cE; wI cI]``."""
        mE = self.mE
        c = np.empty(self.m)
        if mE:
            c[:mE] = np.asarray(cE, float).ravel()
        if self.mI:
            c[mE:] = np.asarray(cI, float).ravel()
        if not self.unit_w:
            c *= self.w
        return c

    def _eval_values(self, x: FloatArray) -> tuple[float, FloatArray, Evaluation | None]:
        t = time.perf_counter()
        f, cE, cI, ev = self.nlp.evaluate_values(x)
        self.timer.eval += time.perf_counter() - t
        self.nfev += 1
        return float(f) * self.sf, self._stack_c(cE, cI), ev

    def _set_c(self, c: FloatArray) -> None:
        self.c, self.cE, self.cI = c, c[: self.mE], c[self.mE :]

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
        if self.sparse:
            A = self.je_pat.fit(np.zeros((0, n)) if JE is None else JE)
            B = self.ji_pat.fit(np.zeros((0, n)) if JI is None else JI)
            Js = self.j_stack.stack(A, B)
            if not self.unit_w:
                Js.data *= self.w[Js.indices]
                A.data *= self.wE[A.indices]
                B.data *= self.wI[B.indices]
            # scaled row blocks in their own fixed patterns
            self.J, self.JE, self.JI = Js, A, B
            return
        J = np.empty((self.m, n))
        if mE:
            J[:mE] = _as2d(JE, mE, n)
        if mI:
            J[mE:] = _as2d(JI, mI, n)
        if not self.unit_w:
            J *= self.w[:, None]
        self.J, self.JE, self.JI = J, J[:mE], J[mE:]

    def _new_point(self) -> None:
        """Refresh the caches that depend on x (and c) only."""
        x = self.x
        self.viol_u = self._max_violation_unscaled(self.c)
        if self.unit_xs:
            self.xnorm = float(np.abs(x).max())
        else:
            self.xnorm = float(np.max(np.abs(x) / self.xs, initial=0.0))
        if self.any_bounds:
            self.at_lo = x <= self.lo_tol
            self.at_up = x >= self.up_tol

    # ----------------------------------------------------------------- helpers -------
    def _backend(self, name: str, n: int, me: int, mi: int) -> QPBackend:
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

    @staticmethod
    def _bad(sol: QPSolution, lb: FloatArray) -> bool:
        """A SOLVED status with a non-finite or bound-violating ``x`` (a backend glitch)."""
        if sol.status is not QPStatus.SOLVED:
            return False
        x = sol.x
        if not math.isfinite(float(x.sum())) and not np.isfinite(x).all():
            return True
        return not bool((x >= lb - 1e-6 * (1.0 + np.abs(lb))).all())

    def _finish_qp(self, sol: QPSolution, t: float, backend: bool = True) -> QPSolution:
        self.timer.qp += time.perf_counter() - t
        self.n_backend += backend
        self.last_qp_info = sol.info
        return sol

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
        if self._bad(sol, lb):
            sol = QPSolution(sol.x, sol.y_eq, sol.y_ineq, sol.y_bounds, QPStatus.FAILED, "bad")
        fb = self.opts.fallback_qp_solver
        if sol.status is QPStatus.FAILED and fb is not None and fb != self.qp_name:
            sol = self._backend(fb, n, me, mi).solve(P, q, A_eq, b_eq, G, h, lb, ub)
        return self._finish_qp(sol, t)

    def _qp_sqp(self, c: FloatArray, lb: FloatArray, ub: FloatArray) -> QPSolution:
        """The QP ``min g'd + d'Bd/2  s.t.  c + J d (=, >=) 0, lb <= d <= ub`` (:meth:`_qp`)."""
        n, mE, mI = self.n, self.mE, self.mI
        B, g, J = self.B, self.g, self.J
        t = time.perf_counter()
        ws = self.ws
        if ws is not None:
            sol = ws.solve(B, g, J, c, lb, ub)
            if sol is not None:
                return self._finish_qp(sol, t, backend=False)
        rows = self._binding_rows(c, lb, ub)
        if rows is not None:
            sol = self._qp_screened(rows, c, lb, ub)
        else:
            be = self.main_backend
            if be is None:
                be = self.main_backend = self._backend(self.qp_name, n, mE, mI)
            if self.qp_eps is not None:
                be.set_accuracy(self.qp_eps)
            sol = be.solve_sqp(B, g, J, c, lb, ub)
        if self.opts.qp_accuracy == "adaptive" and sol.status is QPStatus.SOLVED:
            # an inexact solve may leave the step outside the box by its tolerance
            sol = dataclasses.replace(sol, x=np.minimum(np.maximum(sol.x, lb), ub))
        if self._bad(sol, lb):
            sol = QPSolution(sol.x, sol.y_eq, sol.y_ineq, sol.y_bounds, QPStatus.FAILED, "bad")
        fb = self.opts.fallback_qp_solver
        if sol.status is QPStatus.FAILED and fb is not None and fb != self.qp_name:
            sol = self._backend(fb, n, mE, mI).solve_sqp(B, g, J, c, lb, ub)
        if ws is not None and sol.status is QPStatus.SOLVED:
            ws.record(sol)
        return self._finish_qp(sol, t)

    def _binding_rows(self, c: FloatArray, lb: FloatArray, ub: FloatArray) -> Any:
        """Sparse mode: the rows that can bind in the box ``lb <= d <= ub`` (equalities and
        the inequalities with ``c_i - sum_j |J_ij| max(-lb_j, ub_j) <= 0``; the others hold
        for every step in the box, so the QP without them has the same solution), or None
        when that is all of them."""
        if not (self.sparse and self.opts.qp_screening and self.mI):
            return None
        J, mE = self.J, self.mE
        r = np.maximum(-lb, ub)
        reach = np.bincount(
            J.indices, weights=np.abs(J.data) * r[entry_cols(J.indptr)], minlength=self.m
        )
        keep = c - reach <= 0.0
        keep[:mE] = True
        if keep.all():
            return None
        return np.flatnonzero(keep)

    def _qp_screened(self, rows: Any, c: FloatArray, lb: FloatArray, ub: FloatArray) -> QPSolution:
        """:meth:`_qp_sqp` on the rows ``rows`` only; multipliers of the others are 0."""
        n, mE, mI = self.n, self.mE, self.mI
        # The QP keeps the union of the rows screened in so far (a row screened out now
        # cannot bind either, so the solution is the same): the backend's solver, and
        # its factorisation's symbolic analysis, are rebuilt only when that union grows.
        # Started afresh when it exceeds SCREEN_KEEP times the rows needed now.
        sub = self._screen_subset
        if sub is not None and sub.matches(self.J):
            held = self._screen_rows
            inside = np.zeros(self.m, dtype=bool)
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
            sub = self._screen_subset = RowSubset(self.J, rows)
            self._screen_rows = rows
        k = rows.size - mE
        be = self.screen_backend
        if be is None:
            be = self.screen_backend = make_backend(self.qp_name, self.opts.qp_options)
            be.deadline = self.t0 + self.opts.max_time
        if (be.n, be.m_eq, be.m_ineq) != (n, mE, k):
            be.setup(n, mE, k)
        if self.qp_eps is not None:  # the inexact mode's tolerance, as the main backend's
            be.set_accuracy(self.qp_eps)
        Js = sub(self.J)
        be.ineq_ids = rows[mE:]
        sol = be.solve_sqp(self.B, self.g, Js, c[rows], lb, ub)
        if sol.status is not QPStatus.SOLVED:
            return sol
        y_ineq = np.zeros(mI)
        y_ineq[rows[mE:] - mE] = sol.y_ineq[:k]
        return dataclasses.replace(sol, y_ineq=y_ineq)

    def _corrected(
        self, x: FloatArray, d_c: FloatArray, nu: float, phi0: float, pred: float,
        guard: float, ratio: float,
    ) -> tuple[FloatArray, float, FloatArray, float, Evaluation | None, float] | None:  # fmt: skip
        """The trial point of a corrected step ``x + d_c`` (projected), with its merit ratio
        against the uncorrected step's prediction ``pred``; None unless it is finite, passes
        ``ETA_ACCEPT`` and beats ``ratio``."""
        x_c = self._project(x + d_c)
        f_c, c_c, ev_c = self._eval_values(x_c)
        v_c = self._violation(c_c)
        phi_c = f_c + nu * v_c
        ratio_c = (phi0 - phi_c + guard) / (pred + guard)
        if math.isfinite(phi_c) and ratio_c >= ETA_ACCEPT and ratio_c > ratio:
            return x_c, f_c, c_c, v_c, ev_c, ratio_c
        return None

    def _soc_min_norm(self, c_t: FloatArray, lam: FloatArray, d: FloatArray) -> Any:
        """Least-norm second-order correction (N&W eq. 15.35): ``d - J_A'(J_A J_A')^-1
        c_A(x + d)`` over the equalities and the inequalities the QP left active (positive
        multiplier), i.e. the step back onto the linearised working set at ``x + d``: one
        small linear solve instead of a QP.  ``J_A J_A'`` is regularised (planar limits come
        in identical pairs).  None when there is no working set or the solve fails."""
        lam_max = float(np.abs(lam).max()) if lam.size else 0.0
        act = lam > ACTIVE_MULTIPLIER_TOL * max(1.0, lam_max)
        act[: self.mE] = True
        rows = np.flatnonzero(act)
        if rows.size == 0:
            return None
        r = c_t[rows]
        try:
            if self.sparse and rows.size * self.n <= SOC_DENSE_MAX:
                JA = self._dense_rows(rows)
                G = JA @ JA.T
            elif self.sparse:
                JA = self.J.tocsr()[rows]
                G = (JA @ JA.T).toarray()
            else:
                JA = self.J[rows]
                G = JA @ JA.T
            G[np.diag_indices_from(G)] += SOC_REG * max(1.0, float(G.diagonal().max()))
            y = np.linalg.solve(G, -r)
        except (np.linalg.LinAlgError, ValueError):
            return None
        dc = d + (JA.T @ y)
        if not _all_finite(dc):
            return None
        return np.asarray(dc, dtype=float).ravel()

    def _dense_rows(self, rows: Any) -> FloatArray:
        """Rows ``rows`` (sorted) of the sparse ``J`` as a dense array, gathered from its
        entries (no CSR conversion or sparse row slicing; docs/benchmarks.md)."""
        J = self.J
        pos = np.full(self.m, -1, dtype=np.int64)
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

    def _violation(self, c: FloatArray) -> float:
        """Scaled l1 violation ``||c_E||_1 + ||min(c_I, 0)||_1`` of stacked ``c``, as
        ``a'|c| - b'c`` (``a = [1; 1/2], b = [0; 1/2]``: ``-min(t, 0) = (|t| - t) / 2``)."""
        if not self.m:
            return 0.0
        return float(np.abs(c) @ self.viol_a - c @ self.viol_b)

    def _lin_violation(self, d: FloatArray) -> float:
        return self._violation(self.c + matvec(self.J, d))

    def _max_violation_unscaled(self, c: FloatArray) -> float:
        u = c if self.unit_w else c / self.w
        mE = self.mE
        v = 0.0
        if mE:
            v = float(np.abs(u[:mE]).max())
        if self.mI:
            v = max(v, -float(u[mE:].min()))
        return max(v, 0.0)

    def _multipliers(self, sol: QPSolution) -> FloatArray:
        """Stacked ``[lam_E; lam_I]`` of the QP (lam_I clipped at 0)."""
        mE = self.mE
        lam = np.empty(self.m)
        if mE:
            np.negative(sol.y_eq[:mE], out=lam[:mE])
        if self.mI:
            np.maximum(sol.y_ineq[: self.mI], 0.0, out=lam[mE:])
        return lam

    def _kkt_args(self, lam: FloatArray) -> _KKTArgs:
        """What :meth:`_kkt` needs at the current x (evaluated now or later: the engine
        replaces these arrays at a new point, never modifies them)."""
        return lam, self.g, self.J, self.cI, self.at_lo, self.at_up

    def _kkt(self, args: _KKTArgs) -> tuple[float, float]:
        """Scaled stationarity and complementarity (of :meth:`_kkt_args`)."""
        lam, g, J, cI, at_lo, at_up = args
        m = self.m
        r = g - rmatvec(J, lam) if m else g.copy()
        if at_lo is not None:
            np.minimum(r, 0.0, out=r, where=at_lo)
        if at_up is not None:
            np.maximum(r, 0.0, out=r, where=at_up)
        sd = 1.0
        if m:
            sd = max(KKT_S_MAX, float(np.abs(lam).sum()) / m) / KKT_S_MAX
        stat = float(np.abs(r).max()) / sd if r.size else 0.0
        compl = float(np.abs(lam[self.mE :] * cI).max()) / sd if self.mI else 0.0
        return stat, compl

    # ------------------------------------------------------------------ Hessian -------
    def _exact_hessian(self, lam: FloatArray) -> Any:
        """The convexified exact Hessian of the (scaled) Lagrangian at ``lam``."""
        # A full pattern (a dense Hessian, e.g. the reduced IK problem's) is convexified
        # densely anyway: the Hessian stays dense, without the round trip dense -> CSC ->
        # dense (the same values in the same order; docs/benchmarks.md)
        H = self._lagrangian_hessian(lam, dense=self.sparse and self.h_pat.full)
        t = time.perf_counter()
        B = self._convexify_sparse(H, lam) if self.sparse else self._convexify(H, lam)
        self.timer.build += time.perf_counter() - t
        return B

    def _lagrangian_hessian(self, lam: FloatArray, dense: bool = False) -> Any:
        """Symmetrised scaled Hessian of ``f - lam'c`` (dense, or CSC in the fixed pattern;
        with ``dense`` a dense Hessian returned by the problem stays dense)."""
        nlp = self.nlp
        assert nlp.hessian is not None
        y = lam * self.w
        if self.sf != 1.0:
            y /= self.sf
        mE = self.mE
        t = time.perf_counter()
        Hraw: Any = nlp.hessian(self.x, y[:mE], y[mE:])
        self.timer.eval += time.perf_counter() - t
        t = time.perf_counter()
        if self.sparse and (not dense or is_sparse(Hraw)):
            Hs = self._fit_hessian(Hraw)
            Hs.data *= self.sf
            self.timer.build += time.perf_counter() - t
            return Hs
        if is_sparse(Hraw):
            Hraw = Hraw.toarray()
        H = np.asarray(Hraw, dtype=float).reshape(self.n, self.n)
        H = H + H.T
        H *= 0.5 * self.sf
        self.timer.build += time.perf_counter() - t
        return H

    # ------------------------------------------------------- sparse Hessians -------
    def _fit_hessian(self, Hraw: Any) -> Any:
        """``(H + H')/2`` as a CSC matrix in the fixed QP Hessian pattern (structurally
        symmetric: the user's pattern, its transpose, the diagonal and that of ``J'J``, so
        that the convexification below never changes it)."""
        n = self.n
        pat = self.h_pat
        if pat.indices is None:
            if not is_sparse(Hraw):  # a dense Hessian: the full pattern, nothing to add
                pat.include(Hraw)
            pat.include(sp.identity(n, format="csc"))
            if self.m and not pat.full:
                pat.include(gram_structure(self.J))
        H = pat.fit(Hraw)
        if self._sync_pattern():
            H = pat.fit(Hraw)
        H.data = 0.5 * (H.data + H.data[self.h_perm])
        return H

    def _ensure_gram_pattern(self) -> None:
        """The Hessian pattern contains that of ``J'J`` for the current ``J`` pattern."""
        key = (self.J.indptr, self.J.indices)
        seen = getattr(self, "_gram_src", None)
        if seen is not None and seen[0] is key[0] and seen[1] is key[1]:
            return
        if not self.h_pat.full:
            self.h_pat.include(gram_structure(self.J))
        self._sync_pattern()
        self._gram_src = key

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
        gm = self._gram_maps.get(id(J.indptr))
        if gm is None or not gm.matches(J, pat.indptr, pat.indices):
            gm = GramMap(J, pat.indptr, pat.indices)
            self._gram_maps[id(J.indptr)] = gm
        return gm.values(J.data, w)

    def _shifted(self, H: Any, shift: float) -> Any:
        """``H + shift I`` in the same pattern (a new matrix)."""
        data = H.data.copy()
        data[self.h_diag] += shift
        return csc(data, H.indices, H.indptr, H.shape)

    def _convexify_sparse(self, H: Any, lam: FloatArray) -> Any:
        """Sparse twin of :meth:`_convexify`: the test is an LDL' factorisation (all pivots
        positive), the modifications keep the pattern: ``H + tau J_A'J_A`` as in the dense
        case, else ``H + delta I`` with ``delta`` raised from the last one (IPOPT's inertia
        correction) instead of eigenvalue clipping. ``H`` may be dense when the pattern is
        full (:meth:`_lagrangian_hessian` with ``dense``)."""
        n = self.n
        if not is_sparse(H) or H.data.size == n * n:
            # a full pattern (e.g. a dense Hessian with a sparse Jacobian): the dense
            # convexification (eigenvalues) costs no fill; values back in column order
            Hd = self._convexify(H if not is_sparse(H) else H.toarray(), lam)
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
        lam_max = float(np.abs(lam).max()) if lam.size else 0.0
        active = lam > ACTIVE_MULTIPLIER_TOL * max(1.0, lam_max)
        active[: self.mE] = True
        if active.any():
            self._ensure_gram_pattern()
            if H.indices is not self.h_pat.indices:
                H = self.h_pat.fit(H)
                data = H.data
            JtJ = self._gram(self.J, active.astype(float))
            nj = max(float(JtJ[self.h_diag].max()), 1e-300)
            for tau in AUG_TAUS:
                coef = tau * 1e-2 * max(1.0, fro) / nj
                Ha = csc(data + coef * JtJ, H.indices, H.indptr, H.shape)
                if positive_definite(self._shifted(Ha, -reg)):
                    return Ha
        delta = max(HESS_FLOOR, 1e-4 * max(1.0, fro), self.h_shift / 4.0)
        while delta < 1e12 * max(1.0, fro):
            Hd = self._shifted(H, delta)
            if positive_definite(self._shifted(Hd, -reg)):
                self.h_shift = delta
                return Hd
            delta *= 8.0
        return self._shifted(csc(np.zeros_like(data), H.indices, H.indptr, H.shape), 1.0)

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

    def _convexify(self, H: FloatArray, lam: FloatArray) -> FloatArray:
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
        # Augment with J_A'J_A over equalities and active inequalities: unchanged QP solution
        # when that active set is kept and the reduced Hessian is positive definite.
        # Interior-point backends (Clarabel, OSQP) return tiny positive multipliers on
        # inactive rows: count a row active only above a relative threshold.
        lam_max = float(np.abs(lam).max()) if lam.size else 0.0
        active = lam > ACTIVE_MULTIPLIER_TOL * max(1.0, lam_max)
        active[: self.mE] = True
        if self.sparse:  # J'J of the active rows, gathered into the (full) pattern
            self._ensure_gram_pattern()
            n = self.n
            JtJ = self._gram(self.J, active.astype(float)).reshape(n, n).T
            n_active = int(active.sum())
        else:
            JA = self.J[active]
            n_active = JA.shape[0]
            if n_active:
                JtJ = JA.T @ JA
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

    def _gn_hessian(self) -> Any:
        nlp = self.nlp
        assert nlp.gauss_newton is not None
        t = time.perf_counter()
        Jr: Any = nlp.gauss_newton(self.x)[1]
        self.timer.eval += time.perf_counter() - t
        t = time.perf_counter()
        if self.sparse:
            G = Jr.T @ Jr
            Hs = self._fit_hessian(G.tocsc() if is_sparse(G) else G)
            Hs.data *= self.sf * nlp.gn_scale
            diag = Hs.data[self.h_diag]
            Hs.data[self.h_diag] += HESS_REG * max(1.0, float(diag.max()) if diag.size else 1.0)
            self.timer.build += time.perf_counter() - t
            return Hs
        if is_sparse(Jr):
            Jr = Jr.toarray()
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

    def _grad_lagrangian(self, lam: FloatArray) -> FloatArray:
        return self.g - rmatvec(self.J, lam) if self.m else self.g.copy()

    # --------------------------------------------------------------- subproblem -------
    def _elastic(
        self, nu: float, lb: FloatArray, ub: FloatArray, delta_vec: FloatArray
    ) -> tuple[QPSolution, FloatArray]:
        n, mE = self.n, self.mE
        viol_idx = np.flatnonzero(self.cI < 0.0)
        k = viol_idx.size
        nz = n + 2 * mE + k
        if self.sparse:
            return self._elastic_sparse(nu, lb, ub, delta_vec, viol_idx)
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
        G[:, :n] = -self.JI
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

    def _elastic_sparse(
        self, nu: float, lb: FloatArray, ub: FloatArray, delta_vec: FloatArray, viol_idx: Any
    ) -> tuple[QPSolution, FloatArray]:
        """:meth:`_elastic` with sparse matrices (same QP)."""
        n, mE, mI = self.n, self.mE, self.mI
        k = viol_idx.size
        nz = n + 2 * mE + k
        J = sp.csr_matrix(self.J)
        JE, JI = J[:mE], J[mE:]
        B = self.B if is_sparse(self.B) else sp.csr_matrix(self.B)
        P = sp.block_diag((B, sp.identity(nz - n) * SLACK_REG), format="csc")
        q = np.full(nz, nu)
        q[:n] = self.g
        eye = sp.identity(mE, format="csr")
        A_eq = sp.hstack((JE, -eye, eye, sp.csr_matrix((mE, k))), format="csc")
        E = sp.csr_matrix((np.ones(k), (viol_idx, np.arange(k))), shape=(mI, k))
        G = sp.hstack((-JI, sp.csr_matrix((mI, 2 * mE)), -E), format="csc")
        lbz = np.zeros(nz)
        ubz = np.empty(nz)
        lbz[:n] = lb
        ubz[:n] = ub
        absJ = abs(J)
        ubz[n : n + mE] = np.abs(self.cE) + absJ[:mE] @ delta_vec + 1.0
        ubz[n + mE : n + 2 * mE] = ubz[n : n + mE]
        ubz[n + 2 * mE :] = -self.cI[viol_idx] + absJ[mE:][viol_idx] @ delta_vec + 1.0
        sol = self._qp(P, q, A_eq, -self.cE, G, self.cI, lbz, ubz)
        return sol, sol.x[:n]

    def _model_decrease(self, d: FloatArray, nu: float, m0: float, md: float) -> float:
        return -float(self.g @ d + 0.5 * d @ matvec(self.B, d)) + nu * (m0 - md)

    def _subproblem(
        self, lb: FloatArray, ub: FloatArray, delta: float
    ) -> tuple[QPSolution | None, FloatArray, bool, bool]:
        """Return (solution, d, elastic?, locally-infeasible?)."""
        sol = self._qp_sqp(self.c, lb, ub)
        if sol.status is QPStatus.SOLVED:
            return sol, sol.x, False, False
        if self.m == 0:
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

    # ------------------------------------------------------------ interior start -----
    def _tr_box(self, delta: float) -> tuple[FloatArray, FloatArray]:
        """Trust-region box intersected with the bounds, around the current x:
        ``lb = min(max(lower - x, -D xs), 0)``, ``ub = max(min(upper - x, D xs), 0)``."""
        n, x = self.n, self.x
        dvec: Any = delta if self.unit_xs else delta * self.xs
        if self.any_bounds:
            lb = np.maximum(np.minimum(self.lower - x, 0.0), -dvec)
            ub = np.minimum(np.maximum(self.upper - x, 0.0), dvec)
        else:
            ub = np.full(n, delta) if self.unit_xs else np.array(dvec, dtype=float)
            lb = -ub
        return lb, ub

    def _move_to(self, x_t: FloatArray, f_t: float, c_t: FloatArray, v_t: float, ev_t: Any) -> bool:
        """Make the trial point current (derivatives evaluated); False if not finite."""
        self.x = x_t
        self.f = f_t
        self._set_c(c_t)
        self.v = v_t
        if ev_t is None and self.nlp.evaluate is not None:
            ev_t = self._eval_full(x_t)
        self._derivs(x_t, ev_t)
        if not (_all_finite(self.g) and _all_finite(_values(self.J))):
            return False
        self._new_point()
        return True

    def _barrier_hessian(
        self, lam: FloatArray, barrier: BoolArray, sigma: FloatArray, lam_active: FloatArray
    ) -> Any:
        """Convexified Hessian of the barrier Lagrangian: the Lagrangian's at ``lam`` (the
        barrier rows' duals ``z``) plus ``J_B' diag(sigma) J_B``, ``sigma = z / c_B``
        (primal-dual; ``mu / c_B^2`` on the central path)."""
        JI = self.JI
        D = np.zeros(self.mI)
        D[barrier] = sigma
        H = self._lagrangian_hessian(lam) if self.strategy == "exact" else self._gn_hessian()
        t = time.perf_counter()
        if is_sparse(JI):
            self._ensure_gram_pattern()
            if H.indices is not self.h_pat.indices:
                H = self.h_pat.fit(H)
            H = csc(H.data + self._gram(JI, D), H.indices, H.indptr, H.shape)
        else:
            H = H + (JI * D[:, None]).T @ JI
        if self.strategy == "exact":
            H = (
                self._convexify_sparse(H, lam_active)
                if self.sparse
                else self._convexify(H, lam_active)
            )
        self.timer.build += time.perf_counter() - t
        return H

    def _barrier_elastic(
        self,
        B: Any,
        g: FloatArray,
        J: Any,
        c: FloatArray,
        lb: FloatArray,
        ub: FloatArray,
        delta: float,
    ) -> QPSolution:
        """The barrier QP with l1-penalised slacks on every row (``c_E + J_E d = p - q``,
        ``c_V + J_V d + s >= 0``, slacks >= 0, weight ``nu``): always consistent."""
        n, mE = self.n, self.mE
        mV = c.size - mE
        k = 2 * mE + mV
        nz = n + k
        nu = max(self.nu, NU_INIT)
        q = np.full(nz, nu)
        q[:n] = g
        lbz = np.zeros(nz)
        ubz = np.empty(nz)
        lbz[:n] = lb
        ubz[:n] = ub
        dvec = np.minimum(np.maximum(ub, -lb), delta * self.xs)
        absJ = abs(J)
        ubz[n : n + mE] = np.abs(c[:mE]) + absJ[:mE] @ dvec + 1.0
        ubz[n + mE : n + 2 * mE] = ubz[n : n + mE]
        ubz[n + 2 * mE :] = np.abs(c[mE:]) + absJ[mE:] @ dvec + 1.0
        if self.sparse or is_sparse(J) or is_sparse(B):
            Bs = B if is_sparse(B) else sp.csr_matrix(B)
            P = sp.block_diag((Bs, sp.identity(k) * SLACK_REG), format="csc")
            Jc = sp.csr_matrix(J)
            eye = sp.identity(mE, format="csr")
            A_eq = sp.hstack((Jc[:mE], -eye, eye, sp.csr_matrix((mE, mV))), format="csc")
            G = sp.hstack(
                (-Jc[mE:], sp.csr_matrix((mV, 2 * mE)), -sp.identity(mV, format="csr")),
                format="csc",
            )
        else:
            P = np.zeros((nz, nz))
            P[:n, :n] = B
            idx = np.arange(n, nz)
            P[idx, idx] = SLACK_REG
            A_eq = np.zeros((mE, nz))
            A_eq[:, :n] = J[:mE]
            A_eq[:, n : n + mE] = -np.eye(mE)
            A_eq[:, n + mE : n + 2 * mE] = np.eye(mE)
            G = np.zeros((mV, nz))
            G[:, :n] = -J[mE:]
            G[:, n + 2 * mE :] = -np.eye(mV)
        return self._qp(P, q, A_eq, -c[:mE], G, c[mE:], lbz, ubz)

    def _barrier_phase(
        self, delta: float, max_iter: int
    ) -> tuple[FloatArray, float, int, SQPStatus | None]:
        """Interior start (:attr:`SQPOptions.barrier_start`): trust-region steps on the
        log-barrier problem ``min f - mu sum_B log c_i  s.t.  c_E = 0, c_V >= 0``, where B
        are the inequalities strictly satisfied at the start and V the others (kept as
        linearised QP rows), with the l1 merit on E and V (a trial point leaving the
        interior of B is rejected), ``mu`` decreased as in IPOPT once the barrier problem
        is solved to ``kappa_eps mu``, until ``BARRIER_MU_END``.  Returns
        ``(lam, delta, iterations, status or None)``. The QPs carry no barrier rows."""
        n, mE, mI, m = self.n, self.mE, self.mI, self.m
        lam = np.zeros(m)
        barrier = self.cI > 0.0
        V = np.flatnonzero(~barrier)
        if not mI or not barrier.any():
            return lam, delta, 0, None
        mu = BARRIER_MU0
        lamE = np.zeros(mE)
        lamV = np.zeros(V.size)
        z = mu / self.cI[barrier]  # duals of the barrier rows (primal-dual, as IPOPT)
        nit = 0
        adaptive = self.opts.qp_accuracy == "adaptive"
        be = self._backend(self.qp_name, n, mE, V.size)
        rows = np.concatenate((np.arange(mE), mE + V))
        ev_a = self.viol_a[rows]
        ev_b = self.viol_b[rows]
        while nit < max_iter:
            if self._time_up():
                return lam, delta, nit, SQPStatus.MAX_TIME
            cI = self.cI
            cB = cI[barrier]
            lamB = np.zeros(mI)
            lamB[barrier] = mu / cB
            lamI = np.zeros(mI)
            lamI[barrier] = z
            lamI[V] = lamV
            lam = np.concatenate((lamE, lamI))
            gphi = self.g - rmatvec(self.JI, lamB)
            r = self.g - rmatvec(self.J, lam)
            sd = max(KKT_S_MAX, float(np.abs(lam).sum()) / m) / KKT_S_MAX
            err = float(np.abs(r).max()) / sd if n else 0.0
            err = max(err, float(np.abs(z * cB - mu).max()) / sd)
            c_ev = self.c[rows]
            if rows.size:
                err = max(err, float(np.abs(c_ev[:mE]).max(initial=0.0)))
                err = max(err, float(np.maximum(-c_ev[mE:], 0.0).max(initial=0.0)))
                err = max(err, float(np.abs(lamV * c_ev[mE:]).max(initial=0.0)) / sd)
            if err <= BARRIER_KAPPA_EPS * mu:
                if mu <= BARRIER_MU_END:
                    break
                mu = max(BARRIER_MU_END, min(BARRIER_KAPPA_MU * mu, mu**BARRIER_THETA_MU))
                continue
            lam_act = np.concatenate((lamE, np.where(barrier, 0.0, lamI)))
            B = self._barrier_hessian(lam, barrier, z / cB, lam_act)
            t = time.perf_counter()
            lb, ub = self._tr_box(delta)
            if self.sparse:
                rs = self._row_subset
                if rs is None or not rs.matches(self.J):
                    rs = self._row_subset = RowSubset(self.J, rows)
                J_ev = rs(self.J)
            else:
                J_ev = self.J[rows]
            self.timer.build += time.perf_counter() - t
            t = time.perf_counter()
            if adaptive:
                be.set_accuracy(min(QP_ACC_MAX, QP_ACC_FACTOR * err))
            sol = be.solve_sqp(B, gphi, J_ev, c_ev, lb, ub)
            elastic = False
            if sol.status is not QPStatus.SOLVED or self._bad(sol, lb):
                # inconsistent linearisation in the trust region: the l1-elastic QP
                sol = self._barrier_elastic(B, gphi, J_ev, c_ev, lb, ub, delta)
                elastic = True
            self._finish_qp(sol, t)
            nit += 1
            if sol.status is not QPStatus.SOLVED:
                break  # the SQP takes over from here
            d = sol.x[:n]
            lamE_new = -sol.y_eq[:mE]
            lamV_new = np.maximum(sol.y_ineq[: V.size], 0.0)
            # fraction to the boundary of the barrier rows, on their linearisation
            JBd = matvec(self.JI, d)[barrier]
            cB = cI[barrier]
            shrinking = JBd < 0.0
            if shrinking.any():
                alpha = float(np.min(BARRIER_TAU * cB[shrinking] / -JBd[shrinking]))
                if alpha < 1.0:
                    d = alpha * d
            m0 = self.v  # = ||c_E||_1 + ||min(c_V, 0)||_1: the barrier rows are positive
            gd = float(gphi @ d)
            dBd = float(d @ matvec(B, d))
            lam_inf = max(
                float(np.abs(lamE_new).max(initial=0.0)), float(lamV_new.max(initial=0.0))
            )
            nu = self.nu
            if not elastic:
                nu = max(nu, PENALTY_MARGIN * lam_inf)
                if m0 > 0:
                    nu = max(nu, (gd + 0.5 * dBd) / ((1.0 - RHO_PENALTY) * m0))
            nu = self.nu = min(nu, NU_MAX)
            if nu >= NU_MAX:
                # the barrier steps cannot reduce the violation (a barrier row jams them):
                # hand over to the SQP, whose limit rows may become active, with a fresh
                # radius (planar n = 16 with OSQP: the radius used to collapse here)
                delta = max(delta, self.opts.initial_tr_radius)
                break
            lin = c_ev + matvec(J_ev, d)
            md = float(np.abs(lin) @ ev_a - lin @ ev_b) if rows.size else 0.0
            pred = -(gd + 0.5 * dBd) + nu * (m0 - md)
            phi0 = self.f - mu * float(np.log(cI[barrier]).sum()) + nu * m0
            guard = ROUNDOFF_GUARD * max(1.0, abs(phi0))

            def trial(
                step: FloatArray,
                mu: float = mu,
                nu: float = nu,
                phi0: float = phi0,
                guard: float = guard,
                pred: float = pred,
            ) -> tuple[float, Any, float, float]:
                """Merit ratio of ``x + step`` (and its f, c, ev, violation)."""
                xt = self._project(self.x + step)
                ft, ct, evt = self._eval_values(xt)
                cBt = ct[mE:][barrier]
                if not (bool((cBt > 0.0).all()) and math.isfinite(ft) and pred > 0):
                    return -math.inf, (xt, ft, ct, evt), math.inf, 0.0
                vt = self._violation(ct)
                phit = ft - mu * float(np.log(cBt).sum()) + nu * vt
                return (phi0 - phit + guard) / (pred + guard), (xt, ft, ct, evt), vt, 0.0

            ratio, (x_t, f_t, c_t, ev_t), v_t, _ = trial(d)
            kind = "barrier"
            if ratio < ETA_GOOD and rows.size and pred > 0 and math.isfinite(f_t):
                # second-order correction (N&W Sec. 15.5): the same QP at c(x + d) - J d
                sol_c = be.solve_sqp(B, gphi, J_ev, c_t[rows] - matvec(J_ev, d), lb, ub)
                self.n_backend += 1
                if sol_c.status is QPStatus.SOLVED:
                    d_c = sol_c.x
                    JBd = matvec(self.JI, d_c)[barrier]
                    shrinking = JBd < 0.0
                    if shrinking.any():
                        alpha = float(np.min(BARRIER_TAU * cB[shrinking] / -JBd[shrinking]))
                        if alpha < 1.0:
                            d_c = alpha * d_c
                    ratio_c, pt_c, v_c, _ = trial(d_c)
                    if ratio_c >= ETA_ACCEPT and ratio_c > ratio:
                        ratio, (x_t, f_t, c_t, ev_t), v_t = ratio_c, pt_c, v_c
                        d = d_c
                        kind = "barrier-soc"
            dnorm = float(np.abs(d).max()) if self.unit_xs else float(np.max(np.abs(d) / self.xs))
            if self.opts.verbose:
                print(
                    f"{nit:4d} {self.f / self.sf:14.7e} {self.viol_u:9.2e} {err:9.2e} "
                    f"{mu:9.2e} {delta:9.2e} {nu:9.2e} {ratio:9.2e}  {kind}"
                )
            if ratio >= ETA_ACCEPT:
                # dual step of the barrier rows from the linearised z c = mu, with the
                # fraction to the boundary and IPOPT's safeguard z c in [mu/k, k mu]
                dz = (mu - z * (cB + matvec(self.JI, d)[barrier])) / cB
                neg = dz < 0.0
                alpha_z = 1.0
                if neg.any():
                    alpha_z = min(1.0, float(np.min(BARRIER_TAU * z[neg] / -dz[neg])))
                z = z + alpha_z * dz
                if not self._move_to(x_t, f_t, c_t, v_t, ev_t):
                    return lam, delta, nit, SQPStatus.NUMERICAL_ERROR
                cB_new = self.cI[barrier]
                z = np.clip(
                    z, mu / (BARRIER_KAPPA_SIGMA * cB_new), BARRIER_KAPPA_SIGMA * mu / cB_new
                )
                lamE, lamV = lamE_new, lamV_new
                if ratio >= ETA_GOOD and dnorm >= BOUNDARY_FRACTION * delta:
                    delta = min(GAMMA_GROW * delta, self.opts.max_tr_radius)
                elif ratio < ETA_BAD:
                    delta = GAMMA_SHRINK * delta
            else:
                delta = GAMMA_SHRINK * min(delta, dnorm if dnorm > 0 else delta)
            if delta < DELTA_MIN * (1.0 + self.xnorm):
                delta = self.opts.initial_tr_radius  # the SQP's own model starts afresh
                break
        if adaptive:
            be.set_accuracy(None)
        lamI = np.zeros(mI)
        lamI[barrier] = z
        lamI[V] = lamV
        return np.concatenate((lamE, lamI)), delta, nit, None

    # ---------------------------------------------------------------------- run -------
    def _time_up(self) -> bool:
        return time.perf_counter() - self.t0 > self.opts.max_time

    def _project(self, x: FloatArray) -> FloatArray:
        if self.any_bounds:
            return np.minimum(np.maximum(x, self.lower), self.upper)
        return x

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
        self.m = m = mE + mI
        g_raw = np.asarray(ev.g, dtype=float).ravel()
        self.sparse = is_sparse(ev.J_eq) or is_sparse(ev.J_ineq)
        if self.sparse:
            self.je_pat = FixedPattern((mE, n))
            self.ji_pat = FixedPattern((mI, n))
            self.j_stack = StackedPattern(mE, mI, n)
            JE_raw = self.je_pat.fit(np.zeros((0, n)) if ev.J_eq is None else ev.J_eq)
            JI_raw = self.ji_pat.fit(np.zeros((0, n)) if ev.J_ineq is None else ev.J_ineq)
        else:
            JE_raw = _as2d(ev.J_eq, mE, n)
            JI_raw = _as2d(ev.J_ineq, mI, n)
        # Scaling (IPOPT gradient-based rule, W&B 2006 Sec. 3.8) or user-given factors.
        self.sf = 1.0
        if opts.scaling:
            gmax = float(np.abs(g_raw).max()) if n else 0.0
            if math.isfinite(gmax) and gmax > SCALE_MAX_GRADIENT:
                self.sf = SCALE_MAX_GRADIENT / gmax

        def row_scale(user: Any, Jraw: Any, mc: int) -> FloatArray:
            if user is not None:
                return np.broadcast_to(np.asarray(user, float), (mc,)).copy()
            if not (opts.scaling and mc and n):
                return np.ones(mc)
            ws = SCALE_MAX_GRADIENT / np.maximum(_row_absmax(Jraw), SCALE_MAX_GRADIENT)
            ws[~np.isfinite(ws)] = 1.0
            return ws

        wE = row_scale(nlp.eq_scale, JE_raw, mE)
        wI = row_scale(nlp.ineq_scale, JI_raw, mI)
        self.w = np.concatenate((wE, wI))
        if not (self.w > 0).all():
            raise ValueError("eq_scale and ineq_scale must be positive")
        self.wE, self.wI = self.w[:mE], self.w[mE:]
        self.unit_w = bool((self.w == 1.0).all())
        w_min = min(1.0, float(self.w.min())) if m else 1.0
        self.viol_a = np.concatenate((np.ones(mE), np.full(mI, 0.5)))
        self.viol_b = np.concatenate((np.zeros(mE), np.full(mI, 0.5)))
        self.f = self.sf * f_raw
        self._set_c(self._stack_c(cE_raw, cI_raw))
        self._derivs(x, ev)
        if opts.qp_working_set:
            self.ws = WorkingSetStep(n, mE, mI)
        if self.any_bounds:
            self.bound_tol = opts.constr_tol * (1.0 + np.minimum(np.abs(self.lower), 1e300))
            self.lo_tol = self.lower + self.bound_tol
            self.up_tol = self.upper - self.bound_tol
        self.ctol_scaled = opts.constr_tol * w_min
        self.nu = NU_INIT
        self.v = self._violation(self.c)
        self._new_point()
        lam = np.zeros(m)
        self.bfgs_first = True
        self.last_qp_info = ""

        status: SQPStatus | None = None
        detail = ""
        if not (math.isfinite(self.f) and _all_finite(self.g) and math.isfinite(self.v)):
            status = SQPStatus.NUMERICAL_ERROR
            detail = " (at x0)"
        elif not _all_finite(_values(self.J)):
            status = SQPStatus.NUMERICAL_ERROR
            detail = " (Jacobian at x0)"
        if status is None:
            if self.strategy == "exact":
                self.B = self._exact_hessian(lam)
            elif self.strategy == "gauss-newton":
                self.B = self._gn_hessian()
            else:
                self.B = np.eye(n)

        delta = opts.initial_tr_radius
        nit = 0
        have_lam = False
        x_changed = True
        if status is None and opts.barrier_start and self.strategy != "bfgs":
            budget = max(1, int(BARRIER_ITER_SHARE * opts.max_iter))
            lam, delta, nit, status = self._barrier_phase(delta, budget)
            x = self.x
            if nit and status is None:
                have_lam = True
                if self.strategy == "exact":
                    self.B = self._exact_hessian(lam)
                elif self.strategy == "gauss-newton":
                    self.B = self._gn_hessian()
        stat = compl = math.inf
        # Stationarity/complementarity are only needed for the termination test (which
        # needs the violation within tol first), the log and the result: otherwise the
        # evaluation is deferred (``pending``) and done at the end if still the latest.
        pending: _KKTArgs | None = None
        ctol = opts.constr_tol
        adaptive = opts.qp_accuracy == "adaptive"
        last_step = math.inf  # length of the last accepted step (inexact subproblems)
        best_x, best_v = x.copy(), self.viol_u
        if verbose and status is None:
            print(
                f"{'it':>4} {'f':>14} {'viol':>9} {'stat':>9} {'compl':>9} "
                f"{'radius':>9} {'nu':>9} {'ratio':>9}  step"
            )
        while status is None:
            if self._time_up():
                status = SQPStatus.MAX_TIME
                break
            viol_u = self.viol_u
            if have_lam and x_changed:
                pending = self._kkt_args(lam)
                if viol_u <= ctol:
                    stat, compl = self._kkt(pending)
                    pending = None
                    if stat <= opts.tol and compl <= opts.tol:
                        status = SQPStatus.SUCCESS
                        break
            if nit >= opts.max_iter:
                status = SQPStatus.MAX_ITER
                break
            x_changed = False
            # ---- QP subproblem
            t = time.perf_counter()
            lb, ub = self._tr_box(delta)  # around x (= self.x)
            self.timer.build += time.perf_counter() - t
            if adaptive:
                # tolerance from the optimality measure, and from the last step's length:
                # inexact multipliers can keep the measure up, but not the steps
                opt = last_step
                if have_lam:
                    st_, co_ = self._kkt(self._kkt_args(lam))
                    opt = min(opt, max(st_, co_, viol_u))
                self.qp_eps = min(QP_ACC_MAX, QP_ACC_FACTOR * opt)
            nit += 1
            sol, d, elastic, infeasible = self._subproblem(lb, ub, delta)
            if sol is None:
                status = SQPStatus.QP_FAILURE
                detail = f" ({self.last_qp_info})"
                break
            lam = self._multipliers(sol)
            have_lam = True
            pending = self._kkt_args(lam)
            if viol_u <= ctol or verbose:
                stat, compl = self._kkt(pending)
                pending = None
                if stat <= opts.tol and compl <= opts.tol and viol_u <= ctol:
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
            dBd = float(d @ matvec(self.B, d))
            gd = float(self.g @ d)
            if not elastic:
                lam_inf = float(np.abs(lam).max()) if m else 0.0
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
            Jd = matvec(self.J, d)
            md = self._violation(self.c + Jd)
            pred = -(gd + 0.5 * dBd) + nu * (m0 - md)
            phi0 = self.f + nu * m0
            if n == 0:
                dnorm = 0.0
            elif self.unit_xs:
                dnorm = float(np.abs(d).max())
            else:
                dnorm = float(np.max(np.abs(d) / self.xs))
            # ---- trial point
            x_t = self._project(x + d)
            f_t, c_t, ev_t = self._eval_values(x_t)
            v_t = self._violation(c_t)
            phi_t = f_t + nu * v_t
            ok = math.isfinite(phi_t)
            # Roundoff-protected ratio, Conn, Gould & Toint (2000) Sec. 17.4.2.
            guard = ROUNDOFF_GUARD * max(1.0, abs(phi0))
            ratio = (phi0 - phi_t + guard) / (pred + guard) if ok and pred > -guard else -math.inf
            kind = "elastic" if elastic else "qp"
            soc_done = False
            if ratio < SOC_BELOW and not elastic and m and ok and pred > 0:
                # Least-norm second-order correction first (no QP).
                t = time.perf_counter()
                d_m = self._soc_min_norm(c_t, lam, d)
                self.timer.build += time.perf_counter() - t
                trial = (
                    None if d_m is None else self._corrected(x, d_m, nu, phi0, pred, guard, ratio)
                )
                if trial is not None:
                    x_t, f_t, c_t, v_t, ev_t, ratio = trial
                    kind = "soc-ln"
                    d = d_m
                    soc_done = True
            if ratio < SOC_BELOW and not elastic and m and ok and pred > 0 and not soc_done:
                # Second-order correction (N&W Sec. 15.5 / Alg. 18.4).
                sol_c = self._qp_sqp(c_t - Jd, lb, ub)
                if sol_c.status is QPStatus.SOLVED:
                    trial = self._corrected(x, sol_c.x, nu, phi0, pred, guard, ratio)
                    if trial is not None:
                        x_t, f_t, c_t, v_t, ev_t, ratio = trial
                        kind = "soc"
                        d = sol_c.x
            bt_alpha = 0.0
            if ratio < ETA_ACCEPT and BACKTRACK_STEPS and not elastic and ok:
                # backtracking inside the trust region (Nocedal & Yuan 1998): shorter
                # steps along d cost evaluations only, not a new QP
                Jd0, d0 = Jd, d
                for k in range(1, BACKTRACK_STEPS + 1):
                    alpha = BACKTRACK_FACTOR**k
                    da = alpha * d0
                    md_a = self._violation(self.c + alpha * Jd0)
                    pred_a = -(alpha * gd + 0.5 * alpha * alpha * dBd) + nu * (m0 - md_a)
                    if not pred_a > 0:
                        break
                    x_a = self._project(x + da)
                    f_a, c_a, ev_a = self._eval_values(x_a)
                    v_a = self._violation(c_a)
                    phi_a = f_a + nu * v_a
                    ratio_a = (phi0 - phi_a + guard) / (pred_a + guard)
                    if math.isfinite(phi_a) and ratio_a >= ETA_ACCEPT:
                        x_t, f_t, c_t, v_t, ev_t = x_a, f_a, c_a, v_a, ev_a
                        ratio, d, kind = ratio_a, da, f"backtrack {alpha:g}"
                        bt_alpha = alpha
                        if self.unit_xs:
                            dnorm = float(np.abs(d).max())
                        else:
                            dnorm = float(np.max(np.abs(d) / self.xs))
                        break
            if verbose:
                print(
                    f"{nit:4d} {self.f / self.sf:14.7e} {viol_u:9.2e} {stat:9.2e} "
                    f"{compl:9.2e} {delta:9.2e} {nu:9.2e} {ratio:9.2e}  {kind}"
                    + (f" [{self.last_qp_info}]" if verbose > 1 else "")
                )
            if ratio >= ETA_ACCEPT:
                # ---- accept
                if self.strategy == "bfgs":
                    gL_old = self._grad_lagrangian(lam)
                x_old = x
                x = x_t
                x_changed = True
                if not self._move_to(x_t, f_t, c_t, v_t, ev_t):
                    status = SQPStatus.NUMERICAL_ERROR
                    break
                if self.strategy == "exact":
                    self.B = self._exact_hessian(lam)
                elif self.strategy == "gauss-newton":
                    self.B = self._gn_hessian()
                else:
                    t = time.perf_counter()
                    gL_new = self._grad_lagrangian(lam)
                    self._bfgs_update(x - x_old, gL_new - gL_old)
                    self.timer.build += time.perf_counter() - t
                last_step = dnorm
                if self.viol_u < best_v:
                    best_x, best_v = x.copy(), self.viol_u
                if bt_alpha:  # a backtracked step: the radius never grows
                    if ratio < ETA_BAD:
                        delta = GAMMA_SHRINK * delta
                elif ratio >= ETA_GOOD and dnorm >= BOUNDARY_FRACTION * delta:
                    delta = min(GAMMA_GROW * delta, opts.max_tr_radius)
                elif ratio < ETA_BAD:
                    delta = GAMMA_SHRINK * delta
            else:
                delta = GAMMA_SHRINK * min(delta, dnorm if dnorm > 0 else delta)
            if delta < DELTA_MIN * (1.0 + self.xnorm):
                stat, compl = self._kkt(self._kkt_args(lam))
                pending = None
                status = SQPStatus.SMALL_STEP
                break

        # ---- final re-check and result
        if pending is not None:
            stat, compl = self._kkt(pending)
        if status is SQPStatus.INFEASIBLE and best_v < self.viol_u:
            x = self.x = best_x
            f_b, c_b, _ = self._eval_values(x)
            self.f = f_b
            self._set_c(c_b)
        viol_u = self._max_violation_unscaled(self.c)
        if status is SQPStatus.SUCCESS and not viol_u <= opts.constr_tol:
            status = SQPStatus.SMALL_STEP
            detail = " (final violation check failed)"
        y = lam * self.w / self.sf
        kkt = max(stat, compl, viol_u * w_min)
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
            y_eq=y[:mE],
            y_ineq=y[mE:],
            tr_radius=float(delta),
            penalty=float(self.nu),
            qp_solver=self.qp_name,
            time_eval=self.timer.eval,
            time_qp_build=self.timer.build,
            time_qp_solve=self.timer.qp,
            time_total=total,
            qp_backend_solves=self.n_backend,
            qp_working_set_solves=0 if self.ws is None else self.ws.hits,
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
