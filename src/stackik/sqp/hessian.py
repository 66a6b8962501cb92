"""Hessian strategies of the SQP engine (:attr:`SQPOptions.hessian`), behind one interface.

- :class:`ExactHessian`: the problem's Lagrangian Hessian, convexified by the engine's
  linear algebra (:meth:`stackik.sqp.linalg.DenseAlgebra.convexify`).
- :class:`GaussNewtonHessian`: ``gn_scale Jr'Jr`` of the residuals (positive
  semidefinite by construction, regularised).
- :class:`BFGSHessian`: damped BFGS (Powell, N&W Proc. 18.2), started from the identity.

Each answers :meth:`~HessianStrategy.initial` (at ``x0``), :meth:`~HessianStrategy.updated`
(after an accepted step) and, for the barrier start, :meth:`~HessianStrategy.barrier`.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np

from .problem import FloatArray, NonlinearProgram
from .sparse import rmatvec

if TYPE_CHECKING:
    from .solver import _Engine

BFGS_DAMP = 0.2  # Powell damping threshold, N&W Proc. 18.2
BFGS_DAMP_THETA = 0.8  # Powell damping factor, N&W Proc. 18.2


class HessianStrategy:
    """The QP Hessian ``B`` of the engine's iterates."""

    name = ""
    #: whether the barrier start (:mod:`stackik.sqp.barrier`) can use it
    barrier_ok = True

    def initial(self, eng: _Engine, lam: FloatArray) -> Any:
        """``B`` at the start point, multipliers ``lam``."""
        return self.at_point(eng, lam)

    def at_point(self, eng: _Engine, lam: FloatArray) -> Any:
        """``B`` at the current point from the problem's derivatives."""
        raise NotImplementedError

    def before_step(self, eng: _Engine, lam: FloatArray) -> Any:
        """What :meth:`updated` needs from the point being left (None: nothing)."""
        return None

    def updated(self, eng: _Engine, lam: FloatArray, memo: Any, s: FloatArray) -> Any:
        """``B`` at the new point after the step ``s`` (``memo`` from :meth:`before_step`)."""
        return self.at_point(eng, lam)

    def barrier(
        self, eng: _Engine, lam: FloatArray, barrier: Any, sigma: FloatArray,
        lam_active: FloatArray,
    ) -> Any:  # fmt: skip
        """Hessian of the barrier Lagrangian: ``B`` at ``lam`` (the barrier rows' duals
        ``z``) plus ``J_B' diag(sigma) J_B``, ``sigma = z / c_B`` (primal-dual; ``mu / c_B^2``
        on the central path), convexified over the rows of ``lam_active``."""
        H = self.unmodified(eng, lam)
        t = time.perf_counter()
        H = eng.alg.add_gram(H, eng.pt.JI, _diag(eng, barrier, sigma), eng.pt.J)
        H = self.convexified(eng, H, lam_active)
        eng.timer.build += time.perf_counter() - t
        return H

    def unmodified(self, eng: _Engine, lam: FloatArray) -> Any:
        """``B`` at the current point before any convexification."""
        return self.at_point(eng, lam)

    def convexified(self, eng: _Engine, H: Any, lam_active: FloatArray) -> Any:
        """``H`` made positive definite if the strategy needs it (default: as it is)."""
        return H


class ExactHessian(HessianStrategy):
    """The convexified exact Hessian of the (scaled) Lagrangian."""

    name = "exact"

    def lagrangian(self, eng: _Engine, lam: FloatArray, dense: bool = False) -> Any:
        """Symmetrised scaled Hessian of ``f - lam'c`` (dense, or CSC in the fixed pattern;
        with ``dense`` a dense Hessian returned by the problem stays dense)."""
        nlp = eng.nlp
        assert nlp.hessian is not None
        sc = eng.sc
        y = lam * sc.w
        if sc.sf != 1.0:
            y /= sc.sf
        mE = sc.mE
        t = time.perf_counter()
        Hraw: Any = nlp.hessian(eng.pt.x, y[:mE], y[mE:])
        eng.timer.eval += time.perf_counter() - t
        t = time.perf_counter()
        H = eng.alg.symmetric(Hraw, sc.sf, eng.pt.J, dense)
        eng.timer.build += time.perf_counter() - t
        return H

    def at_point(self, eng: _Engine, lam: FloatArray) -> Any:
        # A full pattern (a dense Hessian, e.g. the reduced IK problem's) is convexified
        # densely anyway: the Hessian stays dense, without the round trip dense -> CSC ->
        # dense (the same values in the same order; docs/benchmarks.md)
        alg = eng.alg
        H = self.lagrangian(eng, lam, dense=alg.full_hessian_pattern)
        t = time.perf_counter()
        B = alg.convexify(H, lam, eng.pt.J)
        eng.timer.build += time.perf_counter() - t
        return B

    def unmodified(self, eng: _Engine, lam: FloatArray) -> Any:
        return self.lagrangian(eng, lam)

    def convexified(self, eng: _Engine, H: Any, lam_active: FloatArray) -> Any:
        return eng.alg.convexify(H, lam_active, eng.pt.J)


class GaussNewtonHessian(HessianStrategy):
    """``gn_scale Jr'Jr`` of the problem's residual Jacobian ``Jr`` (scaled)."""

    name = "gauss-newton"

    def at_point(self, eng: _Engine, lam: FloatArray) -> Any:
        nlp = eng.nlp
        assert nlp.gauss_newton is not None
        t = time.perf_counter()
        Jr: Any = nlp.gauss_newton(eng.pt.x)[1]
        eng.timer.eval += time.perf_counter() - t
        t = time.perf_counter()
        B = eng.alg.gauss_newton(Jr, eng.sc.sf * nlp.gn_scale, eng.pt.J)
        eng.timer.build += time.perf_counter() - t
        return B


class BFGSHessian(HessianStrategy):
    """Damped BFGS on the gradient of the Lagrangian (Powell, N&W Proc. 18.2)."""

    name = "bfgs"
    barrier_ok = False

    def __init__(self) -> None:
        self.first = True  # the first update scales B (N&W eq. 6.20)

    def initial(self, eng: _Engine, lam: FloatArray) -> Any:
        return np.eye(eng.n)

    def before_step(self, eng: _Engine, lam: FloatArray) -> Any:
        return _grad_lagrangian(eng, lam)

    def updated(self, eng: _Engine, lam: FloatArray, memo: Any, s: FloatArray) -> Any:
        t = time.perf_counter()
        B = self.update(eng.B, s, _grad_lagrangian(eng, lam) - memo)
        eng.timer.build += time.perf_counter() - t
        return B

    def update(self, B: FloatArray, s: FloatArray, yv: FloatArray) -> FloatArray:
        """Damped BFGS update of ``B`` (in place where possible) for step ``s`` and
        gradient change ``yv``; ``B`` unchanged when the update is not defined."""
        Bs = B @ s
        sBs = float(s @ Bs)
        sy = float(s @ yv)
        if sBs <= 1e-300 or not np.isfinite(sy):
            return B
        if self.first and sy > 0:
            # Initial scaling, N&W eq. (6.20).
            B *= float(yv @ yv) / sy
            Bs = B @ s
            sBs = float(s @ Bs)
            self.first = False
        if sy >= BFGS_DAMP * sBs:
            r = yv
        else:
            theta = BFGS_DAMP_THETA * sBs / (sBs - sy)
            r = theta * yv + (1.0 - theta) * Bs
        sr = float(s @ r)
        if sr <= 1e-300:
            return B
        B += np.outer(r, r) / sr - np.outer(Bs, Bs) / sBs
        return 0.5 * (B + B.T)  # type: ignore[no-any-return]


def _diag(eng: _Engine, barrier: Any, sigma: FloatArray) -> FloatArray:
    D = np.zeros(eng.sc.mI)
    D[barrier] = sigma
    return D


def _grad_lagrangian(eng: _Engine, lam: FloatArray) -> FloatArray:
    pt = eng.pt
    return pt.g - rmatvec(pt.J, lam) if eng.sc.m else pt.g.copy()


def make_hessian(option: str, nlp: NonlinearProgram) -> HessianStrategy:
    """The strategy of ``SQPOptions.hessian`` (``"auto"``: exact when the problem has a
    Hessian, else Gauss-Newton when it has residuals, else BFGS)."""
    strategy = option
    if strategy == "auto":
        if nlp.hessian is not None:
            strategy = "exact"
        elif nlp.gauss_newton is not None:
            strategy = "gauss-newton"
        else:
            strategy = "bfgs"
    if strategy == "exact" and nlp.hessian is None:
        raise ValueError("SQPOptions.hessian='exact' needs NonlinearProgram.hessian")
    if strategy == "gauss-newton" and nlp.gauss_newton is None:
        raise ValueError("SQPOptions.hessian='gauss-newton' needs NonlinearProgram.gauss_newton")
    if strategy == "exact":
        return ExactHessian()
    if strategy == "gauss-newton":
        return GaussNewtonHessian()
    return BFGSHessian()
