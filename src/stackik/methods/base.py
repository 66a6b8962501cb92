"""The interface every solve method implements, and the typed result of one local run.

A method turns the scaled NLP of a request (:class:`stackik.formulation.Problem`) and a
start into a :class:`Run`: a pose, polished and independently checked, with an enum status.
Add a method by subclassing :class:`Method` in its own module and registering it in
:mod:`stackik.methods` (one line); the CLI choices and ``METHOD_NAMES`` derive from there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from stackik.check import PoseCheck
from stackik.families import FamilyError
from stackik.formulation import Problem, polish
from stackik.result import OptionError

__all__ = ["Method", "Run", "RunStatus", "run_status"]

FloatArray = NDArray[np.float64]


class RunStatus(Enum):
    """How one local run ended (the solver's own word; the check decides success)."""

    SUCCESS = "success"  # the solver claims convergence
    INFEASIBLE = "infeasible"  # the solver certifies local infeasibility
    MAX_ITER = "max_iter"
    MAX_TIME = "max_time"
    STALLED = "stalled"  # interior point: no progress far from feasibility
    SKIPPED = "skipped"  # interior point: not run (the first starts looked unreachable)
    NONFINITE = "nonfinite"
    NEAREST = "nearest"  # the unreachable-target bisection's pose
    ERROR = "error"  # the solver raised on a well-formed problem
    OTHER = "other"  # any other solver message (kept in Run.detail)


def run_status(text: str) -> RunStatus:
    """The :class:`RunStatus` of a solver's status string (unknown strings: OTHER)."""
    try:
        return RunStatus(text)
    except ValueError:
        return RunStatus.OTHER


@dataclass
class Run:
    """One local solve, polished and checked.

    Attributes
    ----------
    q : ndarray, shape (n, k)
        The pose [mm, rad].
    nit : int
        Solver iterations.
    status : RunStatus
    check : PoseCheck
        The independent check against the request's target.
    obj : float
        Unscaled objective value at ``q``.
    lifted : tuple of ndarray, optional
        ``(P, R, leg_lengths)`` when the method's check computed them.
    detail : str
        The solver's own status text.
    """

    q: FloatArray
    nit: int
    status: RunStatus
    check: PoseCheck
    obj: float
    lifted: tuple[FloatArray, FloatArray, FloatArray] | None = None
    detail: str = ""

    @property
    def ok(self) -> bool:
        """Whether the run is an answer: its pose passed the check and its solver did not
        raise (a solver that raised leaves its start, which may pass the check but is no
        solution: such a run fails, its error in :attr:`detail`)."""
        return self.check.ok and self.status is not RunStatus.ERROR


class Method:
    """One way of solving the scaled NLP from a start.

    Subclasses set :attr:`name`, :attr:`modes` (the target kinds they accept) and
    :attr:`engine` (the word :attr:`stackik.IKResult.method` reports) and implement
    :meth:`check_options` and :meth:`solve`. :meth:`run` (polish and check) is shared.
    """

    name: ClassVar[str]
    modes: ClassVar[frozenset[str]] = frozenset({"planar", "spatial"})
    #: True when the method uses BLAS on its matrices (the solve applies the thread limit)
    uses_blas: ClassVar[bool] = True
    #: True when the method carries the rows of non-adjacent leg pairs
    #: (:attr:`stackik.formulation.Problem.with_leg_pairs`; a local run that folds into
    #: itself is then solved again with them, :func:`stackik.solve.stages._local_run`)
    leg_pair_rows: ClassVar[bool] = True

    def supports(self, prob: Problem) -> str | None:
        """None when the method can solve ``prob``, else the reason it cannot."""
        if prob.mode.name not in self.modes:
            only = " and ".join(sorted(self.modes))
            return f'method "{self.name}" is {only} only'
        return None

    def check_options(self, options: dict[str, Any]) -> dict[str, Any]:
        """Validated options; :class:`~stackik.result.OptionError` for bad ones."""
        raise NotImplementedError

    def solve(
        self, prob: Problem, u0: FloatArray, options: dict[str, Any], time_left: float
    ) -> tuple[FloatArray, int, str]:
        """Scaled point, iterations and the solver's status string from scaled ``u0``."""
        raise NotImplementedError

    def run(
        self,
        prob: Problem,
        q0: FloatArray,
        options: dict[str, Any],
        time_left: float = math.inf,
        qp_solver: str | None = None,
    ) -> Run:
        """One local solve from ``q0``, polished and checked.

        A solver that raises on a well-formed problem (e.g. scipy on a huge start) makes a
        failed run, not an exception; bad options (:class:`OptionError`) still raise.
        """
        u0 = prob.u_of(q0)
        try:
            u, nit, text = self.solve_with(prob, u0, options, time_left, qp_solver)
        except (OptionError, FamilyError):
            raise
        except Exception as exc:  # noqa: BLE001 - a crashing start is a failed start
            u, nit, text = u0, 0, f"error: {type(exc).__name__}: {exc}"
        if not np.all(np.isfinite(u)):
            u = u0
        u = polish(prob, u)
        q = prob.q_of(u)
        chk = prob.check(q)
        status = RunStatus.ERROR if text.startswith("error:") else run_status(text)
        return Run(q, nit, status, chk, prob.objective_value(q), detail=text)

    def solve_with(
        self,
        prob: Problem,
        u0: FloatArray,
        options: dict[str, Any],
        time_left: float,
        qp_solver: str | None,
    ) -> tuple[FloatArray, int, str]:
        """:meth:`solve` with a QP backend name (only the SQP engine takes one)."""
        return self.solve(prob, u0, options, time_left)
