"""Definition of a nonlinear program for the SQP engine (:class:`NonlinearProgram`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def _matrix(M: Any) -> Any:
    """A Jacobian as returned: scipy sparse matrices pass through, the rest becomes a
    float array."""
    if sp.issparse(M):
        return M
    return np.asarray(M, dtype=float)


class Evaluation(NamedTuple):
    """All problem functions at one point, as returned by a ``evaluate`` callable.

    ``c_eq``/``J_eq`` and ``c_ineq``/``J_ineq`` may be ``None`` (no such constraints).
    ``J_eq``/``J_ineq`` may be scipy sparse matrices (see :class:`NonlinearProgram`).
    """

    f: float
    g: FloatArray
    c_eq: FloatArray | None
    J_eq: Any
    c_ineq: FloatArray | None
    J_ineq: Any


@dataclass(frozen=True)
class NonlinearProgram:
    """A smooth nonlinear program

    .. math::

        \\min_x f(x) \\quad\\text{s.t.}\\quad c_E(x) = 0,\\; c_I(x) \\ge 0,\\;
        lower \\le x \\le upper.

    Parameters
    ----------
    objective : callable ``x -> float`` or None
        ``f(x)``.  May be None only if ``evaluate`` is given.
    gradient : callable ``x -> ndarray (n,)`` or None
        ``grad f(x)``.  May be None only if ``evaluate`` is given.
    eq, eq_jacobian : callables ``x -> (m_E,)`` and ``x -> (m_E, n)``, optional
        Equality constraints ``eq(x) == 0`` and their Jacobian (both or neither).
    ineq, ineq_jacobian : callables ``x -> (m_I,)`` and ``x -> (m_I, n)``, optional
        Inequality constraints ``ineq(x) >= 0`` and their Jacobian (both or neither).
    hessian : callable ``(x, y_eq, y_ineq) -> (n, n)``, optional
        Exact Hessian of the Lagrangian ``L = f - y_eq.c_E - y_ineq.c_I`` (Nocedal & Wright
        sign convention, ``y_ineq >= 0``), i.e.
        ``hess f - sum_i y_eq[i] hess c_E[i] - sum_j y_ineq[j] hess c_I[j]``.

    **Sparse problems.**  Jacobians may be scipy sparse matrices (any format; CSC avoids a
    conversion). When either Jacobian at ``x0`` is sparse the engine works sparse: the
    Jacobians and the QP Hessian are kept as CSC matrices in fixed patterns (the union of
    every pattern returned; a pattern that never changes costs nothing), the Hessian may
    then be sparse too (both triangles, symmetric pattern) and is convexified by sparse
    LDL' factorisations, and the OSQP and Clarabel backends factorise only the nonzeros
    (dense backends densify). Return structural zeros as explicit zeros to keep one
    pattern. Dense Jacobians keep the dense engine.
    lower, upper : array_like (n,), optional
        Variable bounds (``-inf``/``+inf`` allowed).  Iterates always satisfy them.
    gauss_newton : callable ``x -> (r, Jr)``, optional
        Residuals ``r`` (shape (p,)) and their Jacobian ``Jr`` (shape (p, n)) such that the
        Gauss-Newton approximation of the *objective* Hessian is ``gn_scale * Jr.T @ Jr``.
        With the default ``gn_scale = 1.0`` this matches ``f = 0.5 * ||r||^2 + const``; for
        ``f = ||r||^2`` pass ``gn_scale = 2.0``.  Used by the Hessian strategy
        ``"gauss-newton"`` (constraint curvature is neglected; the QP Hessian is positive
        semidefinite by construction and gets only a tiny diagonal regularisation).
    gn_scale : float
        Factor of the Gauss-Newton Hessian, see ``gauss_newton``.
    evaluate : callable ``x -> Evaluation-like``, optional
        Single callable returning ``(f, g, c_eq, J_eq, c_ineq, J_ineq)`` at once (a tuple in
        that order, an :class:`Evaluation`, or any object with those attribute names; absent
        constraints as ``None``), so expensive shared work (e.g. kinematics) is done once per
        point.  When given, it replaces ``objective``, ``gradient``, ``eq``, ``eq_jacobian``,
        ``ineq`` and ``ineq_jacobian``, which may then be None (if given they are ignored).
    eq_scale, ineq_scale : array_like, optional
        Positive constraint scale factors: the engine works with ``eq_scale * c_E`` and
        ``ineq_scale * c_I``.  When None (and ``SQPOptions.scaling``), rows are scaled
        automatically at ``x0`` by the IPOPT gradient rule ``min(1, 100 / ||grad c_i||_inf)``.
    x_scale : array_like (n,), optional
        Positive typical magnitudes of the variables: the trust region is
        ``|d_i| <= radius * x_scale[i]``.  Default ones.
    name : str
        Label used in messages.
    """

    objective: Callable[[FloatArray], float] | None
    gradient: Callable[[FloatArray], ArrayLike] | None = None
    eq: Callable[[FloatArray], ArrayLike] | None = None
    eq_jacobian: Callable[[FloatArray], ArrayLike] | None = None
    ineq: Callable[[FloatArray], ArrayLike] | None = None
    ineq_jacobian: Callable[[FloatArray], ArrayLike] | None = None
    hessian: Callable[[FloatArray, FloatArray, FloatArray], ArrayLike] | None = None
    lower: ArrayLike | None = None
    upper: ArrayLike | None = None
    gauss_newton: Callable[[FloatArray], tuple[ArrayLike, ArrayLike]] | None = None
    gn_scale: float = 1.0
    evaluate: Callable[[FloatArray], Any] | None = None
    eq_scale: ArrayLike | None = None
    ineq_scale: ArrayLike | None = None
    x_scale: ArrayLike | None = None
    name: str = ""

    def __post_init__(self) -> None:
        for fname in (
            "objective",
            "gradient",
            "eq",
            "eq_jacobian",
            "ineq",
            "ineq_jacobian",
            "hessian",
            "gauss_newton",
            "evaluate",
        ):
            val = getattr(self, fname)
            if val is not None and not callable(val):
                raise ValueError(f"NonlinearProgram.{fname} must be callable or None")
        if self.evaluate is None:
            if self.objective is None or self.gradient is None:
                raise ValueError(
                    "NonlinearProgram needs objective and gradient (or a single evaluate)"
                )
            if (self.eq is None) != (self.eq_jacobian is None):
                raise ValueError("NonlinearProgram.eq and eq_jacobian must be given together")
            if (self.ineq is None) != (self.ineq_jacobian is None):
                raise ValueError("NonlinearProgram.ineq and ineq_jacobian must be given together")
        if not (isinstance(self.gn_scale, int | float) and self.gn_scale > 0):
            raise ValueError("NonlinearProgram.gn_scale must be a positive number")

    def evaluate_all(self, x: FloatArray) -> Evaluation:
        """Evaluate ``(f, g, c_eq, J_eq, c_ineq, J_ineq)`` at ``x`` (arrays, not scaled)."""
        if self.evaluate is not None:
            out = self.evaluate(x)
            if isinstance(out, tuple):
                return Evaluation(*out)
            return Evaluation(out.f, out.g, out.c_eq, out.J_eq, out.c_ineq, out.J_ineq)
        assert self.objective is not None and self.gradient is not None
        return Evaluation(
            self.objective(x),
            np.asarray(self.gradient(x), dtype=float),
            None if self.eq is None else np.asarray(self.eq(x), dtype=float),
            None if self.eq_jacobian is None else _matrix(self.eq_jacobian(x)),
            None if self.ineq is None else np.asarray(self.ineq(x), dtype=float),
            None if self.ineq_jacobian is None else _matrix(self.ineq_jacobian(x)),
        )

    def evaluate_values(
        self, x: FloatArray
    ) -> tuple[float, FloatArray | None, FloatArray | None, Evaluation | None]:
        """Evaluate ``(f, c_eq, c_ineq)`` only (plus the full evaluation if it came free)."""
        if self.evaluate is not None:
            ev = self.evaluate_all(x)
            return ev.f, ev.c_eq, ev.c_ineq, ev
        assert self.objective is not None
        return (
            self.objective(x),
            None if self.eq is None else np.asarray(self.eq(x), dtype=float),
            None if self.ineq is None else np.asarray(self.ineq(x), dtype=float),
            None,
        )
