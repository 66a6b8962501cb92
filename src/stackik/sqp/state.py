"""State of one SQP run, grouped: the variables' box, the constraint rows and their
scaling, the current iterate, the timers (:mod:`stackik.sqp.solver` holds one of each)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .problem import FloatArray

BoolArray = NDArray[np.bool_]


class Timer:
    """Wall-clock seconds spent evaluating the problem, building and solving QPs."""

    __slots__ = ("eval", "build", "qp")

    def __init__(self) -> None:
        self.eval = 0.0
        self.build = 0.0
        self.qp = 0.0


@dataclass(eq=False)
class Box:
    """Bounds ``lower <= x <= upper`` and the variable scale ``xs`` (trust-region units)."""

    lower: FloatArray
    upper: FloatArray
    any_bounds: bool
    xs: FloatArray
    unit_xs: bool
    bound_tol: FloatArray
    lo_tol: FloatArray  # a variable within bound_tol of a bound counts as at it
    up_tol: FloatArray

    @classmethod
    def build(cls, n: int, lower_in: Any, upper_in: Any, x_scale: Any) -> Box:
        """Validated bounds and scale (None: none / unit), shape ``(n,)``."""
        lower = np.full(n, -np.inf) if lower_in is None else np.asarray(lower_in, float)
        upper = np.full(n, np.inf) if upper_in is None else np.asarray(upper_in, float)
        if lower.shape != (n,) or upper.shape != (n,):
            raise ValueError(f"lower/upper must have shape ({n},)")
        any_bounds = False
        if lower_in is not None or upper_in is not None:
            if (lower > upper).any():
                raise ValueError("lower must not exceed upper")
            any_bounds = bool(np.isfinite(lower).any() or np.isfinite(upper).any())
        unit_xs = x_scale is None
        xs = np.ones(n) if x_scale is None else np.asarray(x_scale, float)
        if not unit_xs:
            if xs.shape != (n,) or not ((xs > 0).all() and np.isfinite(xs).all()):
                raise ValueError(f"x_scale must be positive and finite with shape ({n},)")
            unit_xs = bool((xs == 1.0).all())
        return cls(lower, upper, any_bounds, xs, unit_xs, np.zeros(n), lower, upper)

    def set_tolerance(self, constr_tol: float) -> None:
        """Bounds count as active within ``constr_tol (1 + |lower|)``."""
        if self.any_bounds:
            self.bound_tol = constr_tol * (1.0 + np.minimum(np.abs(self.lower), 1e300))
            self.lo_tol = self.lower + self.bound_tol
            self.up_tol = self.upper - self.bound_tol

    def project(self, x: FloatArray) -> FloatArray:
        """``x`` clipped to the bounds."""
        if self.any_bounds:
            return np.minimum(np.maximum(x, self.lower), self.upper)
        return x

    def norm(self, d: FloatArray) -> float:
        """Scaled infinity norm ``max |d| / xs``."""
        if self.unit_xs:
            return float(np.abs(d).max())
        return float(np.max(np.abs(d) / self.xs))

    def trust_region(self, x: FloatArray, delta: float) -> tuple[FloatArray, FloatArray]:
        """Trust-region box intersected with the bounds, around ``x``:
        ``lb = min(max(lower - x, -D xs), 0)``, ``ub = max(min(upper - x, D xs), 0)``."""
        dvec: Any = delta if self.unit_xs else delta * self.xs
        if self.any_bounds:
            lb = np.maximum(np.minimum(self.lower - x, 0.0), -dvec)
            ub = np.minimum(np.maximum(self.upper - x, 0.0), dvec)
        else:
            ub = np.full(x.size, delta) if self.unit_xs else np.array(dvec, dtype=float)
            lb = -ub
        return lb, ub


@dataclass(eq=False)
class Rows:
    """The constraint rows ``c = [c_E; c_I]`` and their scaling: objective factor ``sf``,
    row factors ``w = [wE; wI]``, the l1 violation's weights (:meth:`violation`)."""

    mE: int = 0
    mI: int = 0
    m: int = 0  # mE + mI
    sf: float = 1.0
    w: FloatArray = field(default_factory=lambda: np.ones(0))
    unit_w: bool = True
    w_min: float = 1.0
    ctol: float = 0.0  # constr_tol in scaled units
    viol_a: FloatArray = field(default_factory=lambda: np.zeros(0))
    viol_b: FloatArray = field(default_factory=lambda: np.zeros(0))

    def set_weights(self, w: FloatArray, constr_tol: float) -> None:
        """Row factors ``w`` (positive) and what follows from them."""
        mE, mI = self.mE, self.mI
        if not (w > 0).all():
            raise ValueError("eq_scale and ineq_scale must be positive")
        self.w = w
        self.unit_w = bool((w == 1.0).all())
        self.w_min = min(1.0, float(w.min())) if mE + mI else 1.0
        self.viol_a = np.concatenate((np.ones(mE), np.full(mI, 0.5)))
        self.viol_b = np.concatenate((np.zeros(mE), np.full(mI, 0.5)))
        self.ctol = constr_tol * self.w_min

    def stack(self, cE: Any, cI: Any) -> FloatArray:
        """Scaled stacked constraint values ``[wE cE; wI cI]``."""
        mE = self.mE
        c = np.empty(mE + self.mI)
        if mE:
            c[:mE] = np.asarray(cE, float).ravel()
        if self.mI:
            c[mE:] = np.asarray(cI, float).ravel()
        if not self.unit_w:
            c *= self.w
        return c

    def violation(self, c: FloatArray) -> float:
        """Scaled l1 violation ``||c_E||_1 + ||min(c_I, 0)||_1`` of stacked ``c``, as
        ``a'|c| - b'c`` (``a = [1; 1/2], b = [0; 1/2]``: ``-min(t, 0) = (|t| - t) / 2``)."""
        if not self.mE + self.mI:
            return 0.0
        return float(np.abs(c) @ self.viol_a - c @ self.viol_b)

    def max_violation_unscaled(self, c: FloatArray) -> float:
        """``max(|c_E|, -c_I, 0)`` in the problem's units."""
        u = c if self.unit_w else c / self.w
        mE = self.mE
        v = 0.0
        if mE:
            v = float(np.abs(u[:mE]).max())
        if self.mI:
            v = max(v, -float(u[mE:].min()))
        return max(v, 0.0)


@dataclass(eq=False)
class Point:
    """The current iterate: ``x``, scaled ``f``, ``c`` (with views ``cE``, ``cI``), ``g``,
    ``J`` (with blocks ``JE``, ``JI``), l1 violation ``v``, and caches of ``x`` only."""

    x: FloatArray
    f: float = 0.0
    c: FloatArray = field(default_factory=lambda: np.zeros(0))
    cE: FloatArray = field(default_factory=lambda: np.zeros(0))
    cI: FloatArray = field(default_factory=lambda: np.zeros(0))
    g: FloatArray = field(default_factory=lambda: np.zeros(0))
    J: Any = None
    JE: Any = None
    JI: Any = None
    v: float = 0.0
    viol_u: float = 0.0  # unscaled maximum violation
    xnorm: float = 0.0  # max |x| / xs
    at_lo: BoolArray | None = None  # None: no bounds
    at_up: BoolArray | None = None

    def set_c(self, c: FloatArray, mE: int) -> None:
        self.c, self.cE, self.cI = c, c[:mE], c[mE:]

    def refresh(self, rows: Rows, box: Box) -> None:
        """Refresh the caches that depend on x (and c) only."""
        x = self.x
        self.viol_u = rows.max_violation_unscaled(self.c)
        if box.unit_xs:
            self.xnorm = float(np.abs(x).max())
        else:
            self.xnorm = float(np.max(np.abs(x) / box.xs, initial=0.0))
        if box.any_bounds:
            self.at_lo = x <= box.lo_tol
            self.at_up = x >= box.up_tol
