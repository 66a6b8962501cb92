"""The planar reduced NLP of the SQP method on the compiled planar kernels.

:class:`CompiledPlanarNLP` has the values of
:class:`stackik.formulation.structured.ReducedPlanarNLP` (``(f, g, c_E, J_E, c_I, J_I)``
with ``J_I`` a CSC matrix of one fixed block-diagonal pattern, and the exact Lagrangian
Hessian), computed by the interior point's compiled evaluation and Hessian
(:func:`stackik._ipm._evaluate`, :func:`stackik._ipm._lagrangian_hessian`) instead of
NumPy expressions: one compiled call each, ~0.1 ms less per evaluation at n = 4 .. 16
(benchmarks/results/sqp_profile.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik.formulation import Problem
from stackik.methods.ip import problem_arrays
from stackik.sqp.sparse import csc

__all__ = ["CompiledPlanarNLP", "compiled_supported"]

FloatArray = NDArray[np.float64]


def compiled_supported(prob: Problem) -> bool:
    """Whether the compiled kernels evaluate ``prob``: planar, with one FN weight (the
    kernels' objective is ``(c0 + w |r|^2) / fscale``)."""
    if prob.fast is None:
        return False
    return prob.objective == "feasible" or bool(np.ptp(prob.w_th) == 0)


class CompiledPlanarNLP:
    """``(f, g, c_E, J_E, c_I, J_I)`` and the Lagrangian Hessian of a planar ``Problem``
    (scaled variables ``u = x / xs``), ``J_I`` as CSC: column ``3 i + k`` holds platform
    ``i``'s 24 limit rows."""

    def __init__(self, prob: Problem) -> None:
        if not compiled_supported(prob):
            raise ValueError("CompiledPlanarNLP: planar problems with one FN weight only")
        from stackik import _ipm  # numba: imported when first needed

        self._ipm = _ipm
        self.P = problem_arrays(prob)
        n = prob.n
        self.n = n
        cols = np.arange(3 * n)
        # int32 like ReducedPlanarNLP's pattern (what scipy picks for this size)
        self.indptr: Any = (24 * np.arange(3 * n + 1)).astype(np.int32)
        self.indices: Any = (24 * (cols // 3)[:, None] + np.arange(24)[None, :]).ravel()
        self.indices = self.indices.astype(np.int32)
        self._u: FloatArray | None = None
        self._out: tuple[Any, ...] = ()

    def evaluate(self, u: FloatArray) -> tuple[Any, ...]:
        if self._u is not None and np.array_equal(u, self._u):
            return self._out
        f, g, cE, AE, cI, D = self._ipm._evaluate(np.ascontiguousarray(u, dtype=float), self.P)
        n = self.n
        J = csc(D.transpose(0, 2, 1).ravel(), self.indices, self.indptr, (24 * n, 3 * n))
        self._u = np.array(u, dtype=float)
        self._out = (float(f), g, cE, AE, cI, J)
        return self._out

    def hessian(self, u: FloatArray, y_eq: FloatArray, y_in: FloatArray) -> FloatArray:
        """Exact Hessian of ``f - y_eq'c_E - y_in'c_I`` (dense, ``3n x 3n``)."""
        H: FloatArray = self._ipm._lagrangian_hessian(
            np.ascontiguousarray(u, dtype=float),
            np.ascontiguousarray(y_eq, dtype=float),
            np.ascontiguousarray(y_in, dtype=float),
            self.P,
        )
        return H
