"""Generic backend through :mod:`qpsolvers` (any solver it supports, e.g. quadprog, piqp).

Convenient but slower (wrapper overhead of a few tenths of a millisecond per QP).  The
multiplier convention of qpsolvers (``P x + q + G^T z + A^T y + z_box = 0``) is the one of
:mod:`stackik.sqp.qp.base`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import qpsolvers

from .base import FloatArray, QPBackend, QPSolution, QPStatus, dense


def available() -> list[str]:
    """Names of the solvers qpsolvers can use in this environment."""
    return list(qpsolvers.available_solvers)


class QPSolversBackend(QPBackend):
    """Backend calling ``qpsolvers.solve_problem`` with a named solver.

    Parameters
    ----------
    solver : str
        A name from ``qpsolvers.available_solvers``.
    options : dict, optional
        Keyword arguments passed to the solver through qpsolvers.
    """

    def __init__(self, solver: str, options: dict[str, Any] | None = None) -> None:
        super().__init__(options)
        self.solver = solver
        self.name = f"qpsolvers:{solver}"

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
        P, A_eq, G = dense(P), dense(A_eq), dense(G)
        problem = qpsolvers.Problem(
            P,
            q,
            G if self.m_ineq else None,
            h if self.m_ineq else None,
            A_eq if self.m_eq else None,
            b_eq if self.m_eq else None,
            lb,
            ub,
        )
        try:
            sol = qpsolvers.solve_problem(problem, solver=self.solver, **self.options)
        except Exception as exc:  # noqa: BLE001 - any backend error becomes a status
            return self.failed(f"{self.name} raised {exc!r}")
        if not sol.found or sol.x is None:
            return self.failed(f"{self.name}: no solution found")
        n, me, mi = self.n, self.m_eq, self.m_ineq
        y = sol.y if sol.y is not None and me else np.zeros(me)
        z = sol.z if sol.z is not None and mi else np.zeros(mi)
        zb = sol.z_box if sol.z_box is not None else np.zeros(n)
        return QPSolution(
            np.asarray(sol.x, dtype=float),
            np.asarray(y, dtype=float),
            np.asarray(z, dtype=float),
            np.asarray(zb, dtype=float),
            QPStatus.SOLVED,
            "found",
        )
