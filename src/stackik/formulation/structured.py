"""Planar IK problems with their sparsity, for the sparse QP backends of the SQP engine.

:class:`ReducedPlanarNLP` is the scaled NLP of :class:`~stackik.formulation.Problem`
(``3n`` variables) with the limit Jacobian as a CSC matrix: platform i's 24 limits touch
only its 3 variables (block diagonal, ``72 n`` entries), the 3 end-effector equalities are
dense rows. Its exact Lagrangian Hessian is dense (``FN^2`` couples every platform).

The lifted formulation (:mod:`stackik.formulation.lifted`) also makes the Hessian sparse.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik.formulation.problem import Problem
from stackik.targets import PlanarTarget

__all__ = ["ReducedPlanarNLP"]

FloatArray = NDArray[np.float64]


class ReducedPlanarNLP:
    """``(f, g, c_E, J_E, c_I, J_I)`` of a planar :class:`Problem` with ``J_I`` sparse.

    Same values as :meth:`Problem.evaluate` (tested), same variables ``u = x / xs``.
    """

    def __init__(self, prob: Problem) -> None:
        if prob.fast is None or not isinstance(prob.target, PlanarTarget):
            raise ValueError("ReducedPlanarNLP is planar only")
        self.prob = prob
        self.fast = prob.fast
        self.target_y = prob.target.y
        self._u: FloatArray | None = None
        self._out: tuple[Any, ...] = ()

    def evaluate(self, u: FloatArray) -> tuple[Any, ...]:
        if self._u is not None and np.array_equal(u, self._u):
            return self._out
        p = self.prob
        q = p.q_of(u)
        y, Jy, r_fn, Jr_fn = self.fast.kinematics(q)
        ceq = (y - self.target_y) * p.es
        Jeq = Jy * p.es[:, None] * p.xs
        cin, Jin = self.fast.sparse(q)
        if p.objective == "feasible":
            f, g = 0.0, np.zeros(u.size)
        else:
            sc = p.rw / math.sqrt(p.fscale)
            r = r_fn * sc
            Jr = Jr_fn * sc[:, None] * p.xs
            f = float(r @ r) + p.c0 / p.fscale
            g = 2.0 * (Jr.T @ r)
        self._u = u.copy()
        self._out = (f, g, ceq, Jeq, cin, Jin)
        return self._out

    def hessian(self, u: FloatArray, y_eq: FloatArray, y_in: FloatArray) -> FloatArray:
        """Exact Lagrangian Hessian (dense, ``3n x 3n``): :meth:`Problem.lagrangian_hessian`."""
        return self.prob.lagrangian_hessian(u, y_eq, y_in)
