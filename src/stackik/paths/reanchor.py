"""Fast mode's reanchoring: compare the path with the default solve and move it to a
better basin (DESIGN §9).

At the reanchoring checks (``reanchor_every``, backing off) :func:`_reanchor` compares the
path's FN with the default solve's pose of the waypoint (planar: the default solve's
interior-point batch with an iteration budget, :func:`_screen`); a pose better by
:data:`stackik.paths.transit.FAST_TRANSIT_GAIN` and more than ``max_jump`` away becomes
the path's :class:`_Goal`, which :func:`_towards` approaches by transit steps while
following the goal's own branch along the waypoints.

The schedule: the first check at waypoint ``reanchor_every``; the next ``reanchor_every``
waypoints after one that moved the path, twice the last gap after one that did not (20,
60, 140, ... while the path stays on the best basin the default solve finds, or its
transit is abandoned before a step; a spatial transit abandoned after steps backs off
likewise). Spatial paths check only up to ``SPATIAL_REANCHOR_N`` = 4 platforms: from
n = 5 the default solve's starts and hops make a check cost 40-70 warm steps, and on the
benchmark's n = 8 paths it found no better path.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numpy.typing import NDArray

from stackik.paths.continuation import Step, Tracker
from stackik.paths.records import _Goal
from stackik.paths.report import _fn2
from stackik.paths.request import _Request
from stackik.paths.transit import FAST_TRANSIT_GAIN, TRANSIT_STEPS, closer
from stackik.targets import Target

__all__ = ["REANCHOR_ITER_PER_N"]

FloatArray = NDArray[np.float64]

#: Fast mode's planar reanchoring check runs the default solve's interior-point starts
#: with at most this many iterations per platform each (:func:`_screen`; on the
#: benchmark's planar paths the best start of a default solve took at most 30
#: iterations at n = 4, 98 at n = 8, 128 at n = 16, a slow start up to 112 at n = 4).
REANCHOR_ITER_PER_N = 10


def _reanchor(
    req: _Request, tracker: Tracker, k: int, target: Target, q: FloatArray, info: dict
) -> _Goal | None:
    """The default solve's pose at waypoint k as a goal, when its FN is lower than the
    path's by more than FAST_TRANSIT_GAIN and it is more than max_jump away (planar: the
    default solve's interior-point batch with an iteration budget, :func:`_screen`)."""
    info["default"] += 1
    found = _screen(req, target, k) if req.planar else _default_pose(req, target, k)
    if found is None:
        return None
    qd, fn_d = found
    fn = math.sqrt(_fn2(req, q))
    dist = tracker.ratio(q, qd)
    if fn_d >= (1 - FAST_TRANSIT_GAIN) * fn or dist <= 1.0:
        return None
    info["reanchored"] += 1
    return _Goal(qd, dist, 0)


def _default_pose(req: _Request, target: Target, index: int) -> tuple[FloatArray, float] | None:
    """``(pose, FN)`` of the default solve of waypoint ``index``, or None if it fails."""
    r = req.default_solve(target, index)
    return (r.q, float(r.frobenius_norm)) if r.success else None


def _screen(req: _Request, target: Target, index: int) -> tuple[FloatArray, float] | None:
    """The planar default solve of waypoint ``index`` as a reanchoring check needs it:
    its interior-point batch (its starts, options and selection,
    :func:`stackik.methods.ip.ip_starts`) with at most ``REANCHOR_ITER_PER_N * n``
    iterations a start, without the pipeline around it. ``(pose, FN)`` of the best start
    that passes the check, or None (then no goal: the default solve would hand over to
    the SQP engine). The same pose as the default solve's wherever its best start
    converges within the budget, the others cut short: on the benchmark's planar paths
    at every waypoint at n = 4 (360; one check there took 216 iterations, 3 ms, with a
    start of 112: 95 with the budget) and n = 16 (24 sampled), at 89 of 90 sampled at
    n = 8 (the other: a start reaching the same basin, 2e-4 higher in FN)."""
    from stackik.methods.ip import IPMethod, ip_starts
    from stackik.solve.blas import BlasLimit
    from stackik.solve.policy import plan_starts
    from stackik.solve.request import build_request

    rng = None if req.seed is None else req.seed + index
    r = build_request(
        req.stack, target, objective="frobenius", method="auto", qp_solver=None, x0=None,
        starts=None, rng=rng, options=None, sigma_t=None, sigma_theta=None, start="paper",
        max_time=None, t_start=time.perf_counter(), blas=BlasLimit(None), **req.clear_kw,
    )  # fmt: skip
    if not isinstance(r.method, IPMethod):
        return _default_pose(req, target, index)
    starts = plan_starts(r).batch(r.sampler, r.structured, req.stack.n)
    budget = {**r.options, "max_iter": REANCHOR_ITER_PER_N * req.stack.n}
    best = ip_starts(r.problem, starts, budget, r.max_time).best
    return None if best is None else (best.q, math.sqrt(best.obj))


def _towards(
    tracker: Tracker, goal: _Goal, q: FloatArray, target: Target, info: dict
) -> tuple[Step | None, _Goal | None]:
    """One step of a fast path towards its goal basin: the goal's pose at ``target``
    (warm continuation); joined when within max_jump, else a transit step that must bring
    it at least a quarter jump closer (:func:`closer`). ``(None, None)``: the transit is
    abandoned."""
    g = tracker.follow(goal.q, target)
    if g is not None:
        if tracker.ratio(q, g) <= 1.0:
            return Step(g, "joined"), None
        if goal.steps < TRANSIT_STEPS:
            moved = closer(tracker, q, target, g, goal.dist)
            if moved is not None:
                return Step(moved[0], "transit"), _Goal(g, moved[1], goal.steps + 1)
    info["transit_abandoned"] = info.get("transit_abandoned", 0) + 1
    return None, None
