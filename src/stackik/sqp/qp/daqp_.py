"""DAQP backend (dense dual active-set solver; the fastest choice for small dense QPs).

DAQP solves ``min 1/2 x'Hx + f'x  s.t.  blower <= A x <= bupper`` where the first ``n``
entries of the bound vectors are simple bounds on ``x`` and ``sense == 5`` marks equality
rows.  Its multipliers satisfy ``H x + f + A^T lam = 0`` (positive at upper bounds, negative
at lower bounds), the convention of :mod:`stackik.sqp.qp.base` for upper-bounded rows.

Each formulation (the generic ``G d <= h`` one of :meth:`DAQPBackend.solve` and the
two-sided SQP one of :meth:`DAQPBackend.solve_sqp`) keeps a persistent ``daqp.Model``: the
workspace is allocated once, every later QP of the shape is passed with ``update`` and
warm-started from the previous active set (the QP Hessian is positive definite, so the
solution does not depend on the start; a warm start that does not end optimal is retried
cold).
"""

from __future__ import annotations

from typing import Any

import daqp
import numpy as np

from .base import FloatArray, QPBackend, QPSolution, QPStatus, dense

#: DAQP exit flags (https://darnstrom.github.io/daqp/parameters).
_EXIT_OPTIMAL = (1, 2)
_EXIT_INFEASIBLE = -1
_SENSE_EQ = 5

#: Settings tuned for SQP subproblems (tight primal feasibility).
DEFAULT_SETTINGS: dict[str, Any] = {"primal_tol": 1e-9, "iter_limit": 2000}


class _Workspace:
    """One persistent ``daqp.Model`` with its constraint matrix and bound buffers."""

    __slots__ = ("A", "bu", "bl", "sense", "model", "warm")

    def __init__(self, n: int, m_eq: int, m: int, lower_inf: bool) -> None:
        self.A = np.zeros((m, n))
        self.bu = np.empty(n + m)
        self.bl = np.empty(n + m)
        # Rows after the equalities are one-sided: G d <= h (lower_inf) or J d >= l.
        if lower_inf:
            self.bl[n + m_eq :] = -np.inf
        else:
            self.bu[n + m_eq :] = np.inf
        self.sense = np.zeros(n + m, dtype=np.intc)
        self.sense[n : n + m_eq] = _SENSE_EQ
        self.model: Any = None
        self.warm = False


class DAQPBackend(QPBackend):
    """Dense DAQP backend, called directly (no wrappers, no sparse matrices)."""

    name = "daqp"

    def __init__(self, options: dict[str, Any] | None = None) -> None:
        super().__init__(options)
        self.settings = {**DEFAULT_SETTINGS, **self.options}
        self._bad_settings = ""

    def setup(self, n: int, m_eq: int, m_ineq: int) -> None:
        super().setup(n, m_eq, m_ineq)
        m = m_eq + m_ineq
        self._gen = _Workspace(n, m_eq, m, lower_inf=True)
        self._sqp = _Workspace(n, m_eq, m, lower_inf=False)

    def _run(self, ws: _Workspace, P: FloatArray, q: FloatArray, A: FloatArray) -> Any:
        """Solve with the workspace's model (warm if possible, else cold); DAQP's outputs."""
        if ws.warm:
            if A.shape[0]:
                flag = ws.model.update(H=P, f=q, A=A, bupper=ws.bu, blower=ws.bl)
            else:
                flag = ws.model.update(H=P, f=q, bupper=ws.bu, blower=ws.bl)
            if flag >= 0:
                out = ws.model.solve()
                if out[2] in _EXIT_OPTIMAL:
                    return out
        ws.warm = False
        model = daqp.Model()
        known = model.settings
        unknown = sorted(set(self.settings) - set(known))
        if unknown:
            raise TypeError(f"unknown DAQP settings {unknown}")
        model.settings = self.settings
        # DAQP marks the active set in ``sense`` (the warm start of the next solve).
        flag, _ = model.setup(P, q, A, ws.bu, ws.bl, ws.sense.copy())
        if flag < 0:
            return None, 0.0, flag, {}
        out = model.solve()
        ws.model = model
        ws.warm = out[2] in _EXIT_OPTIMAL
        return out

    def _result(self, out: Any, ineq_sign: float) -> QPSolution:
        x, _fval, flag, info = out
        if flag in _EXIT_OPTIMAL:
            n, me = self.n, self.m_eq
            lam = info["lam"]
            y_ineq = lam[n + me :]
            return QPSolution(
                x,
                lam[n : n + me],
                y_ineq if ineq_sign > 0 else -y_ineq,
                lam[:n],
                QPStatus.SOLVED,
                "optimal",
            )
        if flag == _EXIT_INFEASIBLE:
            return self.failed("daqp: infeasible", QPStatus.INFEASIBLE)
        return self.failed(f"daqp exit flag {flag}")

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
        P, A_eq, G = dense(P), dense(A_eq), dense(G)
        ws = self._gen
        A, bu, bl = ws.A, ws.bu, ws.bl
        A[:me] = A_eq
        A[me:] = G
        bu[:n] = ub
        bl[:n] = lb
        bu[n : n + me] = b_eq
        bl[n : n + me] = b_eq
        bu[n + me :] = h
        try:
            out = self._run(ws, P, q, A)
        except Exception as exc:  # noqa: BLE001 - any backend error becomes a status
            return self.failed(f"daqp raised {exc!r}")
        return self._result(out, 1.0)

    def solve_sqp(
        self,
        P: FloatArray,
        q: FloatArray,
        J: FloatArray,
        c: FloatArray,
        lb: FloatArray,
        ub: FloatArray,
    ) -> QPSolution:
        # Two-sided rows: J_E d = -c_E and -c_I <= J_I d, with J passed as is (no copies).
        n, me = self.n, self.m_eq
        P, J = dense(P), dense(J)
        ws = self._sqp
        bu, bl = ws.bu, ws.bl
        bu[:n] = ub
        bl[:n] = lb
        np.negative(c, out=bl[n:])
        bu[n : n + me] = bl[n : n + me]
        try:
            out = self._run(ws, P, q, J)
        except Exception as exc:  # noqa: BLE001 - any backend error becomes a status
            return self.failed(f"daqp raised {exc!r}")
        # Rows J_I d >= -c_I are lower-bounded: their multipliers are <= 0 in DAQP's
        # convention, i.e. -y_ineq for the equivalent rows -J_I d <= c_I.
        return self._result(out, -1.0)
