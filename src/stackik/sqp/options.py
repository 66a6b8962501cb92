"""Options of the SQP engine (:class:`SQPOptions`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

HESSIAN_STRATEGIES = ("auto", "exact", "gauss-newton", "bfgs")
QP_ACCURACIES = ("fixed", "adaptive")


def _positive(name: str, value: Any) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
        raise ValueError(f"SQPOptions.{name} must be a positive number, got {value!r}")
    if math.isnan(value):
        raise ValueError(f"SQPOptions.{name} must not be NaN")


@dataclass(frozen=True)
class SQPOptions:
    """Validated, immutable options of :func:`stackik.sqp.solve`.

    Parameters
    ----------
    tol : float
        Tolerance on the scaled KKT residual (stationarity and complementarity).
    constr_tol : float
        Tolerance on the maximum *unscaled* constraint violation; success is never
        reported at a point violating a constraint by more than this.
    max_iter : int
        Maximum number of SQP iterations (QP subproblems around distinct trial steps).
    max_time : float
        Wall-time limit in seconds (``math.inf`` for none), checked every iteration.
    initial_tr_radius : float
        Initial radius of the infinity-norm trust region, in scaled variables.
    max_tr_radius : float
        Largest trust-region radius.
    hessian : {"auto", "exact", "gauss-newton", "bfgs"}
        Hessian strategy.  ``"auto"`` picks exact if ``hessian`` is given, else Gauss-Newton
        if ``gauss_newton`` is given, else damped BFGS.
    verbose : {0, 1, 2}
        0 silent, 1 one line per iteration, 2 also QP details.
    fallback_qp_solver : str or None
        QP backend tried when the main one fails on a subproblem.
    qp_options : dict
        Settings passed straight through to the QP backend (override its SQP defaults);
        OSQP also takes ``polish_first`` (:data:`stackik.sqp.qp.osqp_.POLISH_FIRST`).
    scaling : bool
        Automatic objective/constraint scaling from gradient norms at ``x0`` (IPOPT rule:
        a function whose gradient max-norm exceeds 100 is scaled down to 100).
    barrier_start : bool
        Interior start phase: when ``x0`` satisfies every inequality strictly, first follow
        the log-barrier path ``min f - mu sum log c_I  s.t.  c_E = 0`` for decreasing
        ``mu`` (trust-region steps from equality-constrained QPs, multipliers ``mu / c_I``)
        and only then run the SQP on the full QP, from the barrier's point and
        multipliers. It keeps early iterates away from the limits, which leads to the
        local minima an interior-point method finds, and its QPs carry no inequality rows.
    qp_accuracy : {"fixed", "adaptive"}
        ``"adaptive"``: inexact SQP, the backends' tolerances follow the SQP's own
        optimality measure (loose far from a solution, the backend's defaults near it;
        iterative backends only: OSQP, Clarabel).
    qp_working_set : bool
        Verified working-set step (:mod:`stackik.sqp.working_set`): each plain QP (and
        second-order correction) is first solved as the equality-constrained QP on the
        working set of the last solved QP, one linear KKT solve, and that solution is
        used only if it is verified optimal for the convex QP (every row feasible,
        multipliers of the right signs); otherwise the backend solves it. The counts are
        in :attr:`SQPResult.qp_working_set_solves` and ``qp_backend_solves``. Off by
        default: on the planar IK problem its misses (degenerate vertices where several
        limits meet, active sets that change far from the solution) cost more than its
        hits save (docs/benchmarks.md).
    qp_screening : bool
        Sparse mode: QPs without the inequality rows that cannot bind in the trust region
        (the same solution, smaller QPs; the backend's solver is rebuilt when that row set
        grows). Off: every row in every QP, one solver updated in place throughout.
    """

    tol: float = 1e-6
    constr_tol: float = 1e-8
    max_iter: int = 300
    max_time: float = math.inf
    initial_tr_radius: float = 1.0
    max_tr_radius: float = 1e4
    hessian: str = "auto"
    verbose: int = 0
    fallback_qp_solver: str | None = None
    qp_options: dict[str, Any] = field(default_factory=dict)
    scaling: bool = True
    barrier_start: bool = False
    qp_accuracy: str = "fixed"
    qp_working_set: bool = False
    qp_screening: bool = True

    def __post_init__(self) -> None:
        _positive("tol", self.tol)
        _positive("constr_tol", self.constr_tol)
        if isinstance(self.max_iter, bool) or not isinstance(self.max_iter, int):
            raise ValueError(f"SQPOptions.max_iter must be an int, got {self.max_iter!r}")
        if self.max_iter < 1:
            raise ValueError(f"SQPOptions.max_iter must be >= 1, got {self.max_iter!r}")
        _positive("max_time", self.max_time)
        _positive("initial_tr_radius", self.initial_tr_radius)
        _positive("max_tr_radius", self.max_tr_radius)
        if math.isinf(self.initial_tr_radius):
            raise ValueError("SQPOptions.initial_tr_radius must be finite")
        if self.initial_tr_radius > self.max_tr_radius:
            raise ValueError("SQPOptions.initial_tr_radius must not exceed max_tr_radius")
        if self.hessian not in HESSIAN_STRATEGIES:
            raise ValueError(
                f"SQPOptions.hessian must be one of {HESSIAN_STRATEGIES}, got {self.hessian!r}"
            )
        if self.verbose not in (0, 1, 2) or isinstance(self.verbose, bool):
            raise ValueError(f"SQPOptions.verbose must be 0, 1 or 2, got {self.verbose!r}")
        if self.fallback_qp_solver is not None and not isinstance(self.fallback_qp_solver, str):
            raise ValueError(
                "SQPOptions.fallback_qp_solver must be a solver name or None, "
                f"got {self.fallback_qp_solver!r}"
            )
        if not isinstance(self.qp_options, dict):
            raise ValueError(f"SQPOptions.qp_options must be a dict, got {self.qp_options!r}")
        if not isinstance(self.scaling, bool):
            raise ValueError(f"SQPOptions.scaling must be a bool, got {self.scaling!r}")
        if not isinstance(self.barrier_start, bool):
            raise ValueError(f"SQPOptions.barrier_start must be a bool, got {self.barrier_start!r}")
        if not isinstance(self.qp_working_set, bool):
            raise ValueError(
                f"SQPOptions.qp_working_set must be a bool, got {self.qp_working_set!r}"
            )
        if not isinstance(self.qp_screening, bool):
            raise ValueError(f"SQPOptions.qp_screening must be a bool, got {self.qp_screening!r}")
        if self.qp_accuracy not in QP_ACCURACIES:
            raise ValueError(
                f"SQPOptions.qp_accuracy must be one of {QP_ACCURACIES}, got {self.qp_accuracy!r}"
            )
