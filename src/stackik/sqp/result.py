"""Result of the SQP engine: :class:`SQPStatus`, :class:`SQPResult`."""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


class SQPStatus(enum.Enum):
    """Termination status of :func:`stackik.sqp.solve`."""

    SUCCESS = "success"
    INFEASIBLE = "infeasible"
    MAX_ITER = "max_iter"
    MAX_TIME = "max_time"
    QP_FAILURE = "qp_failure"
    SMALL_STEP = "small_step"
    NUMERICAL_ERROR = "numerical_error"


#: The human message of each :class:`SQPStatus` (``SQPResult.message`` is one of them).
MESSAGES: dict[SQPStatus, str] = {
    SQPStatus.SUCCESS: "Optimal solution found (scaled KKT residual and violation within tol).",
    SQPStatus.INFEASIBLE: (
        "Converged to a point that locally minimises the constraint violation "
        "(problem locally infeasible); x is the least-violation point found."
    ),
    SQPStatus.MAX_ITER: "Maximum number of iterations reached.",
    SQPStatus.MAX_TIME: "Wall-time limit reached.",
    SQPStatus.QP_FAILURE: "The QP subproblem could not be solved (also by the fallback solver).",
    SQPStatus.SMALL_STEP: (
        "Trust region collapsed: no further progress possible before the KKT tolerance."
    ),
    SQPStatus.NUMERICAL_ERROR: "Non-finite function values or derivatives encountered.",
}


@dataclass(frozen=True)
class SQPResult:
    """Outcome of :func:`stackik.sqp.solve`.

    Attributes
    ----------
    x : ndarray, shape (n,)
        Final iterate (for INFEASIBLE: the least-violation point found).
    success : bool
        True only for ``SQPStatus.SUCCESS``.
    status : SQPStatus
    message : str
        Human-readable text of ``status`` (plus details).
    fun : float
        Objective at ``x`` (unscaled).
    nit : int
        Number of SQP iterations.
    nfev : int
        Number of evaluation points of the problem functions.
    kkt_residual : float
        Scaled KKT residual at ``x`` (max of stationarity, complementarity, violation).
    max_violation : float
        Maximum unscaled violation of constraints and bounds at ``x``.
    y_eq : ndarray, shape (m_eq,)
        Multipliers of ``eq(x) = 0`` for the Lagrangian ``f - y_eq.c_eq - y_ineq.c_ineq``.
    y_ineq : ndarray, shape (m_ineq,)
        Non-negative multipliers of ``ineq(x) >= 0``.
    tr_radius : float
        Final trust-region radius.
    penalty : float
        Final l1 penalty parameter (scaled problem).
    qp_solver : str
        Name of the QP backend used.
    time_eval, time_qp_build, time_qp_solve, time_total : float
        Wall time in seconds spent in user callbacks, QP assembly (including Hessian
        modification), QP backends, and in total.
    qp_backend_solves : int
        QPs passed to the backend (elastic ones included).
    qp_working_set_solves : int
        QPs solved by the verified working-set step (:attr:`SQPOptions.qp_working_set`).
    """

    x: FloatArray
    success: bool
    status: SQPStatus
    message: str
    fun: float
    nit: int
    nfev: int
    kkt_residual: float
    max_violation: float
    y_eq: FloatArray
    y_ineq: FloatArray
    tr_radius: float
    penalty: float
    qp_solver: str
    time_eval: float
    time_qp_build: float
    time_qp_solve: float
    time_total: float
    qp_backend_solves: int = 0
    qp_working_set_solves: int = 0
