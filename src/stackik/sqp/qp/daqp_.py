"""DAQP backend (dense dual active-set solver; the fastest choice for small dense QPs).

Uses ``daqp.solve(H, f, A, bupper, blower, sense)`` where the first ``n`` entries of the
bound vectors are simple bounds on ``d`` and ``sense == 5`` marks equality rows.  DAQP's
multiplier convention (``H x + f + A^T lam = 0``, positive at upper bounds) is the one of
:mod:`stackik.sqp.qp.base`, so no sign flips are needed.
"""

from __future__ import annotations

from typing import Any

import daqp
import numpy as np

from .base import FloatArray, QPBackend, QPSolution, QPStatus

#: DAQP exit flags (https://darnstrom.github.io/daqp/parameters).
_EXIT_OPTIMAL = (1, 2)
_EXIT_INFEASIBLE = -1
_SENSE_EQ = 5

#: Settings tuned for SQP subproblems (tight primal feasibility).
DEFAULT_SETTINGS: dict[str, Any] = {"primal_tol": 1e-9, "iter_limit": 2000}


class DAQPBackend(QPBackend):
    """Dense DAQP backend, called directly (no wrappers, no sparse matrices)."""

    name = "daqp"

    def __init__(self, options: dict[str, Any] | None = None) -> None:
        super().__init__(options)
        self.settings = {**DEFAULT_SETTINGS, **self.options}

    def setup(self, n: int, m_eq: int, m_ineq: int) -> None:
        super().setup(n, m_eq, m_ineq)
        m = m_eq + m_ineq
        self._A = np.zeros((m, n))
        self._bu = np.empty(n + m)
        self._bl = np.empty(n + m)
        self._bl[n + m_eq :] = -np.inf
        self._sense = np.zeros(n + m, dtype=np.int32)
        self._sense[n : n + m_eq] = _SENSE_EQ

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
        n, me = self.n, self.m_eq
        A, bu, bl = self._A, self._bu, self._bl
        A[:me] = A_eq
        A[me:] = G
        bu[:n] = ub
        bl[:n] = lb
        bu[n : n + me] = b_eq
        bl[n : n + me] = b_eq
        bu[n + me :] = h
        try:
            x, _fval, flag, info = daqp.solve(P, q, A, bu, bl, self._sense, **self.settings)
        except Exception as exc:  # noqa: BLE001 - any backend error becomes a status
            return self.failed(f"daqp raised {exc!r}")
        if flag in _EXIT_OPTIMAL:
            lam = info["lam"]
            return QPSolution(
                np.asarray(x),
                lam[n : n + me],
                lam[n + me :],
                lam[:n],
                QPStatus.SOLVED,
                "optimal",
            )
        if flag == _EXIT_INFEASIBLE:
            return self.failed("daqp: infeasible", QPStatus.INFEASIBLE)
        return self.failed(f"daqp exit flag {flag}")
