"""Common types of the internal QP backend interface.

Every backend solves the convex quadratic program

.. math::

    \\min_d \\tfrac12 d^T P d + q^T d
    \\quad\\text{s.t.}\\quad A_{eq} d = b_{eq},\\; G d \\le h,\\; lb \\le d \\le ub

and reports multipliers in one sign convention (the one of OSQP, DAQP and qpsolvers):

.. math::

    P d + q + A_{eq}^T y_{eq} + G^T y_{ineq} + y_{bounds} = 0,

with ``y_ineq >= 0`` and ``y_bounds`` positive where an upper bound is active and negative
where a lower bound is active.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def dense(M: Any) -> Any:
    """``M`` as a dense array (scipy sparse matrices are converted)."""
    return M.toarray() if hasattr(M, "toarray") else M


class QPStatus(enum.Enum):
    """Outcome of one QP solve."""

    SOLVED = "solved"
    INFEASIBLE = "infeasible"
    FAILED = "failed"


@dataclass(frozen=True, slots=True)
class QPSolution:
    """Solution of one QP.

    Attributes
    ----------
    x : ndarray, shape (n,)
        Primal solution (meaningless unless ``status`` is SOLVED).
    y_eq : ndarray, shape (m_eq,)
        Multipliers of ``A_eq d = b_eq``.
    y_ineq : ndarray, shape (m_ineq,)
        Multipliers of ``G d <= h`` (non-negative).
    y_bounds : ndarray, shape (n,)
        Multipliers of ``lb <= d <= ub`` (positive at active upper bounds).
    status : QPStatus
        Solve outcome.
    info : str
        Backend-specific status text, for messages.
    """

    x: FloatArray
    y_eq: FloatArray
    y_ineq: FloatArray
    y_bounds: FloatArray
    status: QPStatus
    info: str = ""


class QPBackend:
    """Base class of the QP backends.

    A backend is created once per SQP run, ``setup(n, m_eq, m_ineq)`` is called whenever the
    problem dimensions change (the SQP engine has at most a few distinct shapes: the plain
    QP and the elastic QP), then ``solve`` many times with fresh data of those shapes.
    Matrices are dense arrays or, when the problem is sparse, scipy CSC matrices whose
    pattern arrays stay the same objects while the pattern is unchanged; a backend without
    sparse support densifies them (:func:`dense`).

    Parameters
    ----------
    options : dict, optional
        Backend settings passed straight through to the underlying solver.
    """

    name = "base"

    def __init__(self, options: dict[str, Any] | None = None) -> None:
        self.options: dict[str, Any] = dict(options or {})
        #: ``time.perf_counter()`` value after which an iterative backend should stop
        #: (set by the SQP engine from ``SQPOptions.max_time``; inf: no limit).
        self.deadline = math.inf
        self.n = 0
        self.m_eq = 0
        self.m_ineq = 0
        #: Optional identity (sorted integer ids) of the inequality rows of the next QP,
        #: set by the SQP engine when it passes a subset of its rows (screening): a
        #: backend may use it to carry multipliers over to a QP with another row set.
        self.ineq_ids: Any = None

    def setup(self, n: int, m_eq: int, m_ineq: int) -> None:
        """Prepare for QPs with ``n`` variables, ``m_eq`` equalities, ``m_ineq`` inequalities."""
        self.n, self.m_eq, self.m_ineq = n, m_eq, m_ineq

    def set_accuracy(self, eps: float | None) -> None:
        """Solve the next QPs to about ``eps`` (None: the backend's own tolerances).

        The SQP engine's inexact mode calls it with a tolerance that follows its own
        optimality measure; backends whose cost does not depend on it (active-set, dense)
        ignore it, and user-set tolerances in ``qp_options`` always win."""

    def for_elastic(self) -> None:
        """Adjust settings for the engine's elastic subproblems (called once, before
        ``setup``, on the backend instance that solves them). Those QPs carry l1 slack
        variables with only a tiny quadratic term, close to LPs; the default keeps the
        settings."""

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
        """Solve one QP; see the module docstring for the form and sign conventions.

        Parameters
        ----------
        P : ndarray, shape (n, n)
            Symmetric positive (semi)definite Hessian (full matrix).
        q : ndarray, shape (n,)
        A_eq : ndarray, shape (m_eq, n)
        b_eq : ndarray, shape (m_eq,)
        G : ndarray, shape (m_ineq, n)
        h : ndarray, shape (m_ineq,)
        lb, ub : ndarray, shape (n,)
            Finite bounds on ``d``.
        warm : QPSolution, optional
            Previous solution of a QP of the same shape, for warm starting.

        Returns
        -------
        QPSolution
        """
        raise NotImplementedError

    def solve_sqp(
        self,
        P: FloatArray,
        q: FloatArray,
        J: FloatArray,
        c: FloatArray,
        lb: FloatArray,
        ub: FloatArray,
    ) -> QPSolution:
        """Solve the SQP subproblem form of the QP (the engine's per-iteration fast path).

        .. math::

            \\min_d \\tfrac12 d^T P d + q^T d \\quad\\text{s.t.}\\quad
            c_E + J_E d = 0,\\; c_I + J_I d \\ge 0,\\; lb \\le d \\le ub

        with ``J = [J_E; J_I]`` (shape ``(m_eq + m_ineq, n)``) and ``c = [c_E; c_I]``.  It is
        :meth:`solve` with ``A_eq = J_E, b_eq = -c_E, G = -J_I, h = c_I``, and the returned
        multipliers are those of that form.  Backends may override it to avoid building
        ``A_eq``, ``G`` and ``h`` (the arrays must not be modified or kept).
        """
        if self.sparse_sqp and any(sp.issparse(M) for M in (P, J)):
            return self._solve_sparse(P, q, J, c, lb, ub)
        me = self.m_eq
        return self.solve(P, q, J[:me], -c[:me], -J[me:], c[me:], lb, ub)

    #: True when the backend solves sparse ``P``/``J`` on fixed patterns
    #: (:meth:`_solve_sparse`); dense backends get dense arrays.
    sparse_sqp: bool = False

    def _solve_sparse(
        self, P: Any, q: FloatArray, J: Any, c: FloatArray, lb: FloatArray, ub: FloatArray
    ) -> QPSolution:
        """The SQP-form QP with sparse ``P`` and/or ``J`` (backends with ``sparse_sqp``)."""
        raise NotImplementedError

    def failed(self, info: str, status: QPStatus = QPStatus.FAILED) -> QPSolution:
        """Return a failure solution of the current shape."""
        return QPSolution(
            np.zeros(self.n),
            np.zeros(self.m_eq),
            np.zeros(self.m_ineq),
            np.zeros(self.n),
            status,
            info,
        )
