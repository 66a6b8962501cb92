"""Generic trust-region SQP engine (Sl1QP) for smooth nonlinear programs.

Knows nothing about platforms; see :func:`solve` and :class:`NonlinearProgram`.
"""

from .options import SQPOptions
from .problem import Evaluation, NonlinearProgram
from .qp import available_qp_solvers, default_qp_solver
from .result import MESSAGES, SQPResult, SQPStatus
from .solver import solve

__all__ = [
    "MESSAGES",
    "Evaluation",
    "NonlinearProgram",
    "SQPOptions",
    "SQPResult",
    "SQPStatus",
    "available_qp_solvers",
    "default_qp_solver",
    "solve",
]
