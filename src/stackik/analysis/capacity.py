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
from stackik.targets import PlanarTarget, Target

__all__ = ["Capacity", "CapacityMap", "capacity_map", "payload_capacity"]


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
    unloaded : IKResult or None
        The search's first solve, with no payload (the load's other parts only): its
        ``peak_force`` is the least-FN pose's peak leg force before any payload.
    """

    mass: float
    upper: float
    result: IKResult
    solves: int
    unloaded: IKResult | None = None


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

    best = first = carried(0.0)
    if not best.success:
        return Capacity(0.0, 0.0, best, solves, first)
    lo, hi = 0.0, math.inf
    m = min(1.0, mass_max)
    while math.isinf(hi):
        r = carried(m)
        if r.success:
            lo, best = m, r
            if m >= mass_max:
                return Capacity(lo, math.inf, best, solves, first)
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
    return Capacity(lo, hi, best, solves, first)


@dataclass(frozen=True)
class CapacityMap:
    """:func:`payload_capacity` at every target of a planar workspace map.

    Attributes
    ----------
    targets : tuple of PlanarTarget
    capacities : tuple of Capacity
        One per target, in order.
    seconds : tuple of float
        Wall time of each target's search [s].
    free_peaks : tuple of float
        Per target, the peak leg force [N] of the least-FN pose of the stack **without**
        its force limits, with no payload (the load's other parts only; NaN if that solve
        failed): what the unconstrained optimum asks of the legs, against ``force_max``.
    """

    targets: tuple[PlanarTarget, ...]
    capacities: tuple[Capacity, ...]
    seconds: tuple[float, ...]
    free_peaks: tuple[float, ...]

    def rows(self) -> list[dict[str, Any]]:
        """One row per target: ``rho, z, theta`` [mm, mm, rad], ``capacity_kg`` (the
        carried mass), ``upper_kg`` (the least mass not carried; inf: ``mass_max`` was
        carried), ``carried`` (the pose at ``capacity_kg`` passes the check),
        ``peak_force_N`` (its peak leg force, at that payload), ``unloaded_peak_force_N``
        (the force-limited least-FN pose's with no payload), ``free_peak_force_N``
        (:attr:`free_peaks`), ``solves``, ``seconds``."""
        out = []
        parts = zip(self.targets, self.capacities, self.seconds, self.free_peaks, strict=True)
        for t, c, sec, free in parts:
            u = c.unloaded
            peak = c.result.peak_force
            peak0 = None if u is None else u.peak_force
            out.append(
                {
                    "rho": t.rho,
                    "z": t.z,
                    "theta": t.theta,
                    "capacity_kg": c.mass,
                    "upper_kg": c.upper,
                    "carried": bool(c.result.success),
                    "peak_force_N": math.nan if peak is None else peak,
                    "unloaded_peak_force_N": math.nan if peak0 is None else peak0,
                    "free_peak_force_N": free,
                    "solves": c.solves,
                    "seconds": sec,
                }
            )
        return out


def _map_point(target: PlanarTarget, options: dict[str, Any]) -> tuple[Capacity, float, float]:
    """One target of :func:`capacity_map`: its capacity, the search's seconds and the
    free peak force (:attr:`CapacityMap.free_peaks`)."""
    import time

    from stackik.solve import solve_ik

    kw = dict(options)
    t = time.perf_counter()
    cap = payload_capacity(target=target, **kw)
    sec = time.perf_counter() - t
    stack: Stack = kw.pop("stack")
    free_stack = Stack(tuple(dataclasses.replace(g, force_max=math.inf) for g in stack))
    load = kw.pop("load")
    base = Load() if load is None else dataclasses.replace(load, mass=0.0)
    for key in ("mass_max", "tol"):
        kw.pop(key)
    free = solve_ik(free_stack, target, load=base, **kw)
    peak = free.peak_force if free.success else None
    return cap, sec, math.nan if peak is None else peak


def capacity_map(
    stack: Stack,
    targets: Any,
    load: Load | None = None,
    *,
    mass_max: float = 1000.0,
    tol: float = 0.1,
    executor: Any = None,
    **solve_kw: Any,
) -> CapacityMap:
    """:func:`payload_capacity` (``mass_max``, ``tol`` [kg], ``solve_kw``) at each planar
    target, the payload's weight along ``load``'s gravity (the load direction) with its
    external wrench; ``executor`` (a :class:`concurrent.futures.Executor`) spreads the
    targets. Each point costs one bisection, about ``log2(capacity / tol) + 2``
    force-limited solves, and one solve without the force limits
    (:attr:`CapacityMap.free_peaks`)."""
    targets = tuple(targets)
    if not all(isinstance(t, PlanarTarget) for t in targets):
        raise ValueError("targets: expected PlanarTarget objects (a planar workspace map)")
    import functools

    options = {"stack": stack, "load": load, "mass_max": mass_max, "tol": tol, **solve_kw}
    fn = functools.partial(_map_point, options=options)
    if executor is None:
        done = [fn(t) for t in targets]
    else:  # a concurrent.futures Executor or a Dask Client: both submit and result()
        done = [f.result() for f in [executor.submit(fn, t) for t in targets]]
    return CapacityMap(
        targets,
        tuple(d[0] for d in done),
        tuple(d[1] for d in done),
        tuple(d[2] for d in done),
    )
