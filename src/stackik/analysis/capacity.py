"""Payload capacity: the largest payload a stack can hold at a target within every limit and
every leg force limit (docs/loads.md)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from stackik.geometry import Stack
from stackik.loads import Load
from stackik.result import IKResult
from stackik.targets import Target

__all__ = ["Capacity", "payload_capacity"]


@dataclass(frozen=True)
class Capacity:
    """Result of :func:`payload_capacity`.

    Attributes
    ----------
    mass : float
        The largest payload mass [kg] found to be carried (0 when even the load's other
        parts cannot be carried: then ``result`` is not a success).
    upper : float
        The least mass [kg] found **not** carried (``mass <= capacity < upper`` up to the
        bisection's tolerance); ``inf`` when ``mass_max`` was carried.
    result : IKResult
        The force-limited solve at ``mass``: its pose carries that payload
        (``result.success``), with its leg forces (``result.leg_forces``).
    solves : int
        How many force-limited solves the search took.
    """

    mass: float
    upper: float
    result: IKResult
    solves: int


def payload_capacity(
    stack: Stack,
    target: Target,
    load: Load | None = None,
    *,
    mass_max: float = 1000.0,
    tol: float = 0.01,
    **solve_kw: Any,
) -> Capacity:
    """The largest payload mass [kg] for which :func:`stackik.solve_ik` finds a pose within
    every limit and every finite leg force limit reaching ``target``, with that pose.

    The payload is ``load.mass`` varied (its position ``load.com``, the external wrench and
    gravity kept); the search doubles from 1 kg until a mass is not carried (or
    ``mass_max`` is), then bisects to ``tol`` [kg]. It assumes that a stack which carries a
    mass carries every lighter one (true when the payload's weight adds to the legs' load
    rather than balancing it, as with gravity along the stack); each answer is a solve's
    checked pose, so ``result`` always carries ``mass``.

    Parameters
    ----------
    stack : Stack
        Needs a finite ``force_max`` somewhere (otherwise the capacity is unbounded).
    target : PlanarTarget or SpatialTarget
    load : Load, optional
        The rest of the load (default: earth gravity, no wrench, payload at the end-effector
        origin); its ``mass`` is ignored.
    mass_max : float
        Largest mass tried [kg] (> 0).
    tol : float
        Bisection tolerance [kg] (> 0).
    **solve_kw
        Passed to every :func:`stackik.solve_ik` call (``method``, ``max_time``, ...).

    Raises
    ------
    ValueError
        No finite ``force_max`` in ``stack``, or a bad ``mass_max`` / ``tol`` / ``load``.
    """
    from stackik.solve import solve_ik

    if not any(math.isfinite(g.force_max) for g in stack):
        raise ValueError("stack: no finite force_max, so the payload capacity is unbounded")
    for name, v in (("mass_max", mass_max), ("tol", tol)):
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ValueError(f"{name}: must be a finite number > 0, got {v!r}")
    base = Load() if load is None else load
    if not isinstance(base, Load):
        raise ValueError(f"load: expected a stackik.Load or None, got {type(base).__name__}")
    solves = 0

    def carried(mass: float) -> IKResult:
        nonlocal solves
        solves += 1
        return solve_ik(stack, target, load=dataclasses.replace(base, mass=mass), **solve_kw)

    best = carried(0.0)
    if not best.success:
        return Capacity(0.0, 0.0, best, solves)
    lo, hi = 0.0, math.inf
    m = min(1.0, mass_max)
    while math.isinf(hi):
        r = carried(m)
        if r.success:
            lo, best = m, r
            if m >= mass_max:
                return Capacity(lo, math.inf, best, solves)
            m = min(2.0 * m, mass_max)
        else:
            hi = m
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        r = carried(mid)
        if r.success:
            lo, best = mid, r
        else:
            hi = mid
    return Capacity(lo, hi, best, solves)
