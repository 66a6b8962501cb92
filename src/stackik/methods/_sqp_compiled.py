"""The reduced NLP of the SQP method on the interior point's compiled kernels.

:class:`CompiledNLP` gives the SQP engine ``(f, g, c_E, J_E, c_I, J_I)`` with ``J_I`` a CSC
matrix of one fixed block-diagonal pattern (platform ``i``'s 24 limit rows touch only its
own ``k`` variables, ``k = 3`` planar, ``6`` spatial) and the exact Lagrangian Hessian,
each from one compiled call:

* planar (:func:`stackik._compiled.planar._evaluate`,
  :func:`stackik._compiled.planar._lagrangian_hessian`): the values of
  :class:`stackik.formulation.structured.ReducedPlanarNLP`, ~0.1 ms less per evaluation at
  n = 4 .. 16 (benchmarks/results/sqp_profile.md);
* spatial (:func:`stackik._compiled.spatial._evaluate`,
  :func:`stackik._compiled.spatial._hessian`): the spatial interior point's problem,
  whose orientation equality is ``vee(skew(R_target' R_ee)) = 0`` (the rotation-vector
  form of :meth:`stackik.formulation.Problem.evaluate` has no closed-form second
  derivatives there). Exact second derivatives instead of damped BFGS.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik.formulation import Problem
from stackik.methods.ip import problem_arrays, spatial_problem_arrays
from stackik.sqp.sparse import csc

__all__ = ["CompiledNLP", "compiled_supported"]

FloatArray = NDArray[np.float64]


def compiled_supported(prob: Problem) -> bool:
    """Whether the compiled kernels evaluate ``prob``: spatial, or planar with one FN
    weight (the planar kernels' objective is ``(c0 + w |r|^2) / fscale``)."""
    if not prob.planar:
        return True
    if prob.fast is None:
        return False
    return prob.objective == "feasible" or bool(np.ptp(prob.w_th) == 0)


class CompiledNLP:
    """``(f, g, c_E, J_E, c_I, J_I)`` and the Lagrangian Hessian of a ``Problem``
    (scaled variables ``u = x / xs``), ``J_I`` as CSC: column ``k i + j`` holds platform
    ``i``'s 24 limit rows (``k`` variables per platform)."""

    def __init__(self, prob: Problem) -> None:
        if not compiled_supported(prob):
            raise ValueError("CompiledNLP: spatial problems, or planar with one FN weight")
        if prob.planar:
            from stackik._compiled import planar as _ipm  # numba: imported when first needed

            self._evaluate: Any = _ipm._evaluate
            self._hessian: Any = _ipm._lagrangian_hessian
            self.P: Any = problem_arrays(prob)
        else:
            from stackik._compiled import spatial as _spatial_ipm

            # the interior point's own compiled functions (no layer of their own to
            # compile): the evaluation with its kinematic parts, the Hessian from them
            self._evaluate = _spatial_ipm._evaluate
            self._hessian = _spatial_ipm._hessian
            self.P = spatial_problem_arrays(prob)
        n, k = prob.n, prob.k
        self.n, self.k = n, k
        # rows a platform: the 24 limits, then (spatial) its self-leg rows
        R = 24 if prob.self_legs is None or prob.planar else 24 + prob.self_legs.m
        self.R = R
        cols = np.arange(k * n)
        # int32 like ReducedPlanarNLP's pattern (what scipy picks for this size)
        self.indptr: Any = (R * np.arange(k * n + 1)).astype(np.int32)
        self.indices: Any = (R * (cols // k)[:, None] + np.arange(R)[None, :]).ravel()
        self.indices = self.indices.astype(np.int32)
        self._u: FloatArray | None = None
        self._out: tuple[Any, ...] = ()
        # the point of the last compiled evaluation, bytes, and what the Hessian takes there
        self._at: bytes | None = None
        self._parts: Any = None

    def evaluate(self, u: FloatArray) -> tuple[Any, ...]:
        if self._u is not None and np.array_equal(u, self._u):
            return self._out
        uc = np.ascontiguousarray(u, dtype=float)
        out = self._evaluate(uc, self.P)
        f, g, cE, AE, cI, D = out[:6]
        self._at, self._parts = uc.tobytes(), self._parts_of(uc, out)
        n, k = self.n, self.k
        J = csc(D.transpose(0, 2, 1).ravel(), self.indices, self.indptr, (self.R * n, k * n))
        self._u = np.array(u, dtype=float)
        self._out = (float(f), g, cE, AE, cI, J)
        return self._out

    @staticmethod
    def _parts_of(u: FloatArray, out: tuple[Any, ...]) -> Any:
        """What the Hessian takes for the point ``u`` from its evaluation ``out``: the
        spatial kinematic parts (the evaluation's last value), the planar point itself (a
        copy: the caller's array may change)."""
        return out[6] if len(out) > 6 else u.copy()

    def hessian(self, u: FloatArray, y_eq: FloatArray, y_in: FloatArray) -> FloatArray:
        """Exact Hessian of ``f - y_eq'c_E - y_in'c_I`` (dense, ``kn x kn``); spatial: from
        the kinematic parts of the evaluation at ``u`` (the last one's when it was at
        ``u``, bit for bit)."""
        uc = np.ascontiguousarray(u, dtype=float)
        if self._at is not None and uc.tobytes() == self._at:
            parts = self._parts
        else:
            parts = self._parts_of(uc, self._evaluate(uc, self.P))
        H: FloatArray = self._hessian(
            parts,
            np.ascontiguousarray(y_eq, dtype=float),
            np.ascontiguousarray(y_in, dtype=float),
            self.P,
            0.0,
        )
        return H
