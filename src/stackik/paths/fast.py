"""Fast mode of :func:`stackik.paths.solve_path`: one continuation step per waypoint.

The path starts at the default solve's best pose of waypoint 0 (or at ``start``) and
takes, per waypoint, runs of warm steps in one compiled call where it follows its
minimum, and the continuation ladder of :class:`stackik.paths.continuation.Tracker`
elsewhere. At the reanchoring checks it moves to a better basin by transit steps
(:mod:`stackik.paths.reanchor`); where its branch ends at a limit wall it splices in a
detour walked back from the next waypoint's default pose (:func:`_rejoin_fast`); with
``refine=True`` a step it cannot make is bisected. Its checkpoint records and replay are
in :mod:`stackik.paths.replay`.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik.paths.checkpoint import PathCheckpoint
from stackik.paths.continuation import Step, Tracker
from stackik.paths.interpolate import lerp_target
from stackik.paths.reanchor import _reanchor, _towards
from stackik.paths.records import _Goal, _Outcome, _Pending, _Waypoint
from stackik.paths.replay import fast_record, put_first, put_rejoin, replay_fast
from stackik.paths.report import _break, unreachable_message
from stackik.paths.request import _Request
from stackik.paths.result import PATH_MESSAGES, PathStatus
from stackik.paths.transit import TRANSIT_PROGRESS, TRANSIT_STEPS
from stackik.targets import Target

__all__ = ["REFINE_DEPTH", "WARM_RUN"]

FloatArray = NDArray[np.float64]

#: Bisection levels of ``refine=True``: up to 16 inserted steps per input step.
REFINE_DEPTH = 4
#: Fast mode: after these steps the path is off its optimum and a warm step often fails;
#: the next step goes through the ladder directly, not through a run of warm steps.
_OFF_OPTIMUM = ("bounded", "transit", "rejoin")
#: Fast mode: most warm steps solved in one compiled call.
WARM_RUN = 256


def _fast(req: _Request, ck: PathCheckpoint, tracker: Tracker) -> _Outcome:
    """The fast path of ``req`` (resumed from the checkpoint's records)."""
    info: dict[str, Any] = {"default": 0, "reanchored": 0}
    if ck.get("fast", 0) is None:
        msg = _first(req, ck, info)
        if msg is not None:  # no waypoint reached: every input one is left
            targets = list(req.targets)
            sources = [float(i) for i in range(len(targets))]
            return _Outcome(targets, sources, [], PathStatus.UNREACHABLE, msg, info)
    return _FastRun(req, ck, tracker, info).run()


def _first(req: _Request, ck: PathCheckpoint, info: dict[str, Any]) -> str | None:
    """Record the pose of waypoint 0 (``start`` or the default solve's); the break
    message when the default solve finds none."""
    if req.start is not None:
        q0, how = req.start, "start"
    else:
        t0 = time.perf_counter()
        r0 = req.default_solve(req.targets[0], 0)
        info["default"] += 1
        info["first_solve_s"] = time.perf_counter() - t0  # the rest: the path's steps
        if not r0.success:
            return unreachable_message(req, r0, "the path breaks at index 0 (waypoint 0)")
        q0, how = r0.q, "default"
    put_first(ck, q0, how)
    return None


def _warm_run_length(k: int, due: int, pending: int) -> int:
    """Waypoints of the next run of warm steps: to the next reanchoring index ``due``
    (inclusive; 0: none), at most WARM_RUN and what is pending."""
    run = WARM_RUN
    if due >= k:
        run = due - k + 1
    return min(run, WARM_RUN, pending)


class _FastRun:
    """A fast path under way: the waypoints reached (``path``), the pending ones (a
    stack, the top next), the goal basin it moves to and the reanchoring schedule (the
    next check's index ``due`` and the gap after it: doubled after a check that finds no
    better basin, reset to ``reanchor_every`` after one that does)."""

    def __init__(
        self, req: _Request, ck: PathCheckpoint, tracker: Tracker, info: dict[str, Any]
    ) -> None:
        self.req, self.ck, self.tracker, self.info = req, ck, tracker, info
        start = replay_fast(req, ck)
        self.path: list[_Waypoint] = start.path
        self.pending: list[_Pending] = start.pending
        self.goal: _Goal | None = start.goal
        self.due, self.gap = start.due, start.gap
        self.ladder_at = -1  # the waypoint a run of warm steps stopped before (the ladder)

    def run(self) -> _Outcome:
        status, message = PathStatus.SUCCESS, PATH_MESSAGES[PathStatus.SUCCESS]
        while self.pending:
            last = self.path[-1]
            if (
                self.goal is None
                and last.how not in _OFF_OPTIMUM
                and len(self.path) != self.ladder_at
            ):
                self._warm_run()
                continue
            tb, sb, depth = self.pending[-1]
            step = self._step(tb, depth)
            if step is not None:
                self._accept(step.q, step.how)
                continue
            splice = _rejoin_fast(self.req, self.tracker, self.path, tb, self.info)
            if splice is not None:  # the followed branch ended: leave it earlier
                self._splice(*splice)
                continue  # the next step from the new pose before tb
            if self.req.refine and depth < REFINE_DEPTH:
                self.pending[-1] = _Pending(tb, sb, depth + 1)
                mid = _Pending(
                    lerp_target(last.target, tb, 0.5), 0.5 * (last.source + sb), depth + 1
                )
                self.pending.append(mid)
                continue
            status, message = _break(
                self.req, self.tracker, len(self.path), tb, sb, last.q, self.info
            )
            break
        # the waypoints not reached: the input ones after the last reached
        pts, m, s_last = self.req.targets, len(self.req.targets), self.path[-1].source
        rest = [pts[i] for i in range(m) if i > s_last]
        rest_src = [float(i) for i in range(m) if i > s_last]
        hows = [p.how for p in self.path]
        self.info["how"] = {h: hows.count(h) for h in sorted(set(hows))}
        targets = [p.target for p in self.path] + rest
        sources = [p.source for p in self.path] + rest_src
        poses = [p.q for p in self.path]
        return _Outcome(targets, sources, poses, status, message, self.info)

    def _warm_run(self) -> None:
        """Warm steps along the next waypoints in one compiled call, up to the next
        reanchoring; the first it does not reach goes through the ladder."""
        req = self.req
        run = _warm_run_length(
            len(self.path), self.due if req.reanchor_every else 0, len(self.pending)
        )
        poses = self.tracker.warm_many(
            self.path[-1].q, [p.target for p in self.pending[::-1][:run]]
        )
        for q in poses:
            self._accept(q, "warm")
        if len(poses) < run:
            self.ladder_at = len(self.path)

    def _step(self, tb: Target, depth: int) -> Step | None:
        """The step to the pending top ``tb``: towards the goal basin if there is one
        (the schedule updated by how that went), else (or when the transit is abandoned)
        the continuation ladder."""
        req, tracker, last = self.req, self.tracker, self.path[-1]
        moving = self.goal
        if moving is not None:
            step, self.goal = _towards(tracker, moving, last.q, tb, self.info)
        else:
            step, self.goal = None, None
        if moving is not None and step is not None:  # it moves to the goal's basin
            if req.planar or step.how == "joined":  # spatial: reset on arrival only
                self.gap = req.reanchor_every
        elif moving is not None and (moving.steps == 0 or not req.planar):
            # abandoned before a step: the check moved nothing, and backs off as one that
            # finds no better basin (the next check 2 x the last gap after it, not
            # reanchor_every: the path stays on its basin); spatial, abandoned at any
            # step: it did not reach the better basin either (its gap is reset on
            # arrival only)
            self.due += self.gap - req.reanchor_every
        if step is not None:
            return step
        off = last.how in ("bounded", "transit")  # off the optimum: no bisection
        # where a run of warm steps stopped in its kernel, it made the warm rung's first
        # solve from this pose to this waypoint
        tried = len(self.path) == self.ladder_at and depth == 0 and tracker.tried_from is last.q
        # spatial, off the optimum: the boxed solve first (~2 ms at n = 4; a warm barrier
        # solve from there slides far, 10-25 ms, and mostly jumps); planar too where the
        # step carries rows for close bodies of non-adjacent platforms (its warm solves
        # slid 3-5 jumps)
        box = off and (not req.planar or tracker.folded_at(last.q, tb))
        return tracker.step(last.q, last.target, tb, subdivide=not off, warm_tried=tried,
                            warm_left=tried and tracker.tried_left, box_first=box)  # fmt: skip

    def _accept(self, q: FloatArray, how: str) -> None:
        """Append the pose of the pending top; reanchor when due; checkpoint."""
        req = self.req
        tb, sb, _ = self.pending.pop()
        wp = _Waypoint(tb, sb, q, how)
        self.path.append(wp)
        k = len(self.path) - 1
        if req.reanchor_every and k == self.due:
            if self.goal is None and self.pending:
                self.goal = _reanchor(req, self.tracker, k, tb, q, self.info)
                self.gap = 2 * self.gap  # the next gap unless the path moves to the goal
            self.due = k + (req.reanchor_every if self.goal is not None else self.gap)
        if self.ck.path is None:  # nothing to write: no record (~5 us a waypoint at n = 4)
            return
        self.ck.put("fast", k, fast_record(req, wp, self.pending, self.goal, self.due, self.gap))

    def _splice(self, j0: int, poses: list[FloatArray]) -> None:
        """Replace the poses from waypoint ``j0`` on by a detour (:func:`_rejoin_fast`)."""
        for j, q in enumerate(poses, start=j0):
            self.path[j] = self.path[j]._replace(q=q, how="rejoin")
        put_rejoin(self.ck, j0, poses)
        self.goal = None
        self.ladder_at = -1  # a new pose: its warm solve is not made yet


def _rejoin_fast(
    req: _Request,
    tracker: Tracker,
    path: list[_Waypoint],
    target: Target,
    info: dict,
) -> tuple[int, list[FloatArray]] | None:
    """New poses for the last waypoints of a fast path whose branch ends before
    ``target``: from the default pose of ``target``, transit steps backwards towards the
    path's poses until one is within max_jump of the path; ``(first index replaced,
    poses)`` (the last one within max_jump of the default pose, so the next step reaches
    it), or None when the waypoint is unreachable or no such detour is found.

    The walk back of global mode (:meth:`stackik.paths.global_._Sweep._rejoin`) differs:
    there a transit pose must come a quarter jump closer to its goal before its meeting
    the sequence counts, the walk may go down to waypoint 0, and the poses of a walk
    that meets nothing stay as candidates; here a pose within max_jump of the path's
    previous pose ends the walk at once, waypoint 0 is never replaced, and a walk that
    meets nothing is dropped."""
    k = len(path)
    r = req.default_solve(target, k)
    info["default"] += 1
    if not r.success or k < 2:
        return None
    cur = r.q
    dist = tracker.ratio(cur, path[-1].q)
    new: list[FloatArray] = []
    for j in range(k - 1, max(k - 1 - 2 * TRANSIT_STEPS, 0), -1):
        qt = tracker.transit(cur, path[j].target, path[j].q)
        if qt is None:
            return None
        new.append(qt)
        if tracker.ratio(qt, path[j - 1].q) <= 1.0:
            info["rejoined"] = info.get("rejoined", 0) + 1
            return j, new[::-1]
        d = tracker.ratio(qt, path[j].q)
        if d >= dist - TRANSIT_PROGRESS:
            return None
        cur, dist = qt, tracker.ratio(qt, path[j - 1].q)
    return None
