"""Global mode of :func:`stackik.paths.solve_path` (Descartes-style, DESIGN §9).

Candidates per waypoint: the default solve's best pose, the continuations of the previous
waypoint's candidates, default poses continued backwards (warm steps, bounded steps where
their branch ends) until something reaches them, and transit poses towards better basins;
deduplicated and pruned by cost. Dynamic programming (Viterbi) minimises
``sum_k FN_k^2 + motion_weight * sum_k |q_{k+1} - q_k|^2`` over the sequences whose every
step is within ``max_jump``. Its checkpoint records and replay are in
:mod:`stackik.paths.replay`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik.paths.checkpoint import PathCheckpoint
from stackik.paths.continuation import Tracker
from stackik.paths.records import _Cand, _Outcome
from stackik.paths.replay import default_candidate, replay_sweep, sweep_record
from stackik.paths.report import _break, _fn2
from stackik.paths.request import _Request
from stackik.paths.result import PATH_MESSAGES, PathStatus
from stackik.paths.transit import (
    GLOBAL_TRANSIT_GAIN,
    TRANSIT_COOLDOWN,
    TRANSIT_STEPS,
    closer,
)
from stackik.targets import Target

__all__ = ["BOUNDED_CANDIDATES", "DEDUPE"]

FloatArray = NDArray[np.float64]

#: Candidates closer than this (in units of max_jump, per variable) are one candidate.
DEDUPE = 1e-3
#: Global mode: candidates (the cheapest so far) whose continuation may take the bounded
#: rung when their minimum ends; the others' lineages end there.
BOUNDED_CANDIDATES = 2


class _Sweep:
    """Candidates per waypoint and their Viterbi costs, built waypoint by waypoint.

    ``cost[k][j]``: least ``sum FN^2 + w sum |dq|^2`` over the continuous sequences from
    waypoint 0 to candidate j of waypoint k (inf: none within max_jump); ``back[k][j]``:
    its predecessor in ``C[k-1]``.
    """

    def __init__(self, req: _Request, tracker: Tracker, targets: list[Target]) -> None:
        self.req, self.tracker, self.targets = req, tracker, targets
        self.C: list[list[_Cand]] = []
        self.cost: list[FloatArray] = []
        self.back: list[NDArray[np.int64]] = []
        self.cooldown = 0  # no transit starts before this waypoint

    # --- Viterbi costs ---------------------------------------------------------------
    def relax(self, k: int) -> None:
        cur = self.C[k]
        fn2 = np.array([c.fn2 for c in cur])
        back = np.full(len(cur), -1, dtype=np.int64)
        if k == 0:
            start = self.req.start is not None
            cost = np.array([c.fn2 if (c.origin == "start" or not start) else np.inf
                             for c in cur])  # fmt: skip
        else:
            cost = np.full(len(cur), np.inf)
            prev, pc = self.C[k - 1], self.cost[k - 1]
            if cur and prev:
                # every edge at once: (len(cur), len(prev)) jumps and step lengths
                Qc = np.stack([c.q for c in cur])[:, None]
                Qp = np.stack([p.q for p in prev])[None]
                d = Qc - Qp
                far = np.max(np.abs(d) / self.tracker.scale, axis=(2, 3)) > 1.0
                v = pc[None, :] + fn2[:, None]
                if self.req.motion_weight:
                    v = v + self.req.motion_weight * np.sum(d**2, axis=(2, 3))
                v = np.where(far | ~np.isfinite(pc)[None, :], np.inf, v)
                i = np.argmin(v, axis=1)  # the first of equal costs, as a loop would
                cost = v[np.arange(len(cur)), i]
                back = np.where(np.isfinite(cost), i, -1).astype(np.int64)
        if k < len(self.cost):
            self.cost[k], self.back[k] = cost, back
        else:
            self.cost.append(cost)
            self.back.append(back)

    def relax_from(self, j: int) -> None:
        for k in range(j, len(self.C)):
            self.relax(k)

    def connected(self, k: int, c: _Cand) -> bool:
        return bool(np.isfinite(self.cost[k][self.C[k].index(c)]))

    # --- candidate lists ----------------------------------------------------------------
    def add(self, k: int, c: _Cand) -> _Cand:
        """Append ``c`` to ``C[k]`` unless a twin within DEDUPE is there (the better FN
        is kept in the twin); returns the candidate in the list."""
        for o in self.C[k]:
            if self.tracker.ratio(o.q, c.q) <= DEDUPE:
                if c.fn2 < o.fn2 * (1 - 1e-12):
                    o.q, o.fn2 = c.q, c.fn2
                return o
        self.C[k].append(c)
        return c

    def cand(self, q: FloatArray, origin: str, how: str = "", **kw: Any) -> _Cand:
        return _Cand(q, _fn2(self.req, q), origin, how, **kw)

    # --- one waypoint -------------------------------------------------------------------
    def first(self, d0: _Cand | None) -> None:
        self.C.append([])
        if self.req.start is not None:
            self.C[0].append(self.cand(self.req.start, "start"))
        elif d0 is not None:
            self.C[0].append(d0)
        self.relax(0)

    def step(self, k: int, dk: _Cand | None) -> set[int]:
        """Build ``C[k]``; returns the waypoints whose candidate lists changed."""
        tr, t = self.tracker, self.targets
        self.C.append([])
        if dk is not None:
            self.C[k].append(dk)
        # continuations, cheapest first; the bounded rung (the followed minimum ended)
        # only for the BOUNDED_CANDIDATES cheapest reachable candidates
        prev = self.C[k - 1]
        order = np.argsort(self.cost[k - 1], kind="stable")
        for rank, i in enumerate(order):
            c = prev[i]
            bounded = c.origin != "transit" and rank < BOUNDED_CANDIDATES
            bounded = bounded and bool(np.isfinite(self.cost[k - 1][i]))
            off = c.how == "bounded" or c.origin == "transit"
            st = tr.step(c.q, t[k - 1], t[k], subdivide=not off, bounded=bounded)
            if st is not None:
                self.add(k, self.cand(st.q, "forward", st.how))
        moving = False
        if dk is not None:  # a transit under way continues towards the default pose
            for c, cc in zip(prev, self.cost[k - 1]):
                if c.origin != "transit" or not np.isfinite(cc) or c.steps >= TRANSIT_STEPS:
                    continue
                if tr.ratio(c.q, dk.q) <= 1.0:  # arrived: the edge c -> dk exists
                    continue
                moved = closer(tr, c.q, t[k], dk.q, c.goal_dist)
                if moved is not None:
                    qt, g = moved
                    self.add(k, self.cand(qt, "transit", steps=c.steps + 1, goal_dist=g))
                    moving = True
                else:  # gave up: no new transit for a while
                    self.cooldown = k + TRANSIT_COOLDOWN
        self.relax(k)
        changed = {k} | self._rejoin(k)
        if dk is not None:
            dk = self.add(k, dk)
            if not self.connected(k, dk):
                changed |= self._backward(k, dk)
            if not moving and k >= self.cooldown:
                self._start_transit(k, dk)
        self._prune(k)
        return changed

    def _backward(self, k: int, x: _Cand) -> set[int]:
        """Continue ``x`` (waypoint k, not reachable) backwards until a reachable candidate
        is within max_jump or no step is found: along its own branch (warm rung) and,
        where that branch ends going backwards (the minimum appears between two
        waypoints), by the bounded rung, the least-FN pose within one jump. The bounded
        rung matters: the better branch of a later waypoint often does not exist a few
        waypoints earlier, and its bounded continuation back there is the way onto it
        (on the benchmark's paths the mean FN over the per-waypoint optima went from
        1.0225 to 1.0077 on the worst spatial n = 4 path, 1.0125 to 1.0017 spatial n = 8,
        about 1.005 to 1.0005 planar n = 8). No bisection rung: a warm step that fails
        backwards means the branch ends, and halving the step rarely helps."""
        tr, t = self.tracker, self.targets
        changed: set[int] = set()
        j = k
        while j > 0 and not x.back_done:
            x.back_done = True
            st = tr.step(x.q, t[j], t[j - 1], subdivide=False)
            if st is None:
                break
            b = self.add(j - 1, self.cand(st.q, "backward", st.how))
            changed.add(j - 1)
            self.relax_from(j - 1)
            if self.connected(j - 1, b):
                break
            x, j = b, j - 1
        return changed

    def _rejoin(self, k: int) -> set[int]:
        """When the cheapest sequence to waypoint k-1 has no continuation at k (its branch
        ends at a limit wall or the minimum it follows vanishes), walk back from the
        cheapest candidate of waypoint k by transit steps towards that sequence's poses
        until they meet: the DP can then leave the ending branch in time. (Fast mode's
        walk back, :func:`stackik.paths.fast._rejoin_fast`, orders its tests otherwise:
        see there.)"""
        prev, pc = self.C[k - 1], self.cost[k - 1]
        if not np.any(np.isfinite(self.cost[k])) or not np.any(np.isfinite(pc)):
            return set()
        i = int(np.argmin(pc))
        if any(self.tracker.ratio(prev[i].q, c.q) <= 1.0 for c in self.C[k]):
            return set()  # it continues
        chain = []  # the ending sequence, waypoint k-1 down to 0
        for j in range(k - 1, -1, -1):
            chain.append(self.C[j][i].q)
            i = int(self.back[j][i])
        cur = self.C[k][int(np.argmin(self.cost[k]))].q
        dist = self.tracker.ratio(cur, chain[0])
        changed: set[int] = set()
        for step, goal in enumerate(chain[: 2 * TRANSIT_STEPS]):
            j = k - 1 - step
            if dist <= 1.0 or j < 0:
                break
            moved = closer(self.tracker, cur, self.targets[j], goal, dist)
            if moved is None:
                break
            qt = moved[0]
            self.add(j, self.cand(qt, "transit", steps=step + 1))
            changed.add(j)
            cur = qt
            dist = self.tracker.ratio(cur, chain[step + 1]) if step + 1 < len(chain) else 0.0
        if changed:
            self.relax_from(min(changed))
        return changed

    def _start_transit(self, k: int, dk: _Cand) -> None:
        """A transit from the cheapest candidate of waypoint k-1 towards the default pose
        ``dk`` when ``dk`` has a lower FN than the cheapest candidate of waypoint k by more
        than GLOBAL_TRANSIT_GAIN and is not within max_jump of the former."""
        best = self.C[k][int(np.argmin(self.cost[k]))]
        if best is dk or dk.fn2 >= (1 - GLOBAL_TRANSIT_GAIN) ** 2 * best.fn2:
            return
        c = self.C[k - 1][int(np.argmin(self.cost[k - 1]))]
        dist = self.tracker.ratio(c.q, dk.q)
        if dist <= 1.0:
            return  # a direct edge: the DP weighs it
        if dist > TRANSIT_STEPS:  # too far to get there
            self.cooldown = k + TRANSIT_COOLDOWN
            return
        # the first step: no distance to beat yet (any transit pose is progress)
        moved = closer(self.tracker, c.q, self.targets[k], dk.q, math.inf)
        if moved is None:
            self.cooldown = k + TRANSIT_COOLDOWN
        else:
            qt, g = moved
            self.add(k, self.cand(qt, "transit", steps=1, goal_dist=g))
            self.relax(k)

    def _prune(self, k: int) -> None:
        """Keep the ``max_candidates`` cheapest reachable candidates and at most two
        unreachable ones (the default pose first: a later backward step may reach it)."""
        cur, cost = self.C[k], self.cost[k]
        fin = sorted((j for j in range(len(cur)) if np.isfinite(cost[j])), key=lambda j: cost[j])
        inf = sorted((j for j in range(len(cur)) if not np.isfinite(cost[j])),
                     key=lambda j: (cur[j].origin != "default", cur[j].fn2))  # fmt: skip
        keep = sorted(fin[: self.req.max_candidates] + inf[:2])
        if len(keep) < len(cur):
            self.C[k] = [cur[j] for j in keep]
            self.relax(k)

    def best_path(self) -> list[FloatArray]:
        """Poses of the cheapest sequence to the last waypoint reached."""
        reached = 0
        for k in range(len(self.C)):
            if not np.any(np.isfinite(self.cost[k])):
                break
            reached = k + 1
        if reached == 0:
            return []
        j = int(np.argmin(self.cost[reached - 1]))
        poses = []
        for k in range(reached - 1, -1, -1):
            poses.append(self.C[k][j].q)
            j = int(self.back[k][j])
        return poses[::-1]


def _global(
    req: _Request,
    ck: PathCheckpoint,
    tracker: Tracker,
    targets: list[Target],
    sources: list[float],
) -> _Outcome:
    """The global (dynamic programming) path of ``req`` over the waypoints ``targets``
    (the input ones, or a fast refining pass's), resumed from the checkpoint's records."""
    info: dict[str, Any] = {"default": 0}
    sw = _Sweep(req, tracker, targets)
    for k in range(len(targets)):
        rec = ck.get("sweep", k)
        if rec is not None:  # replay: the candidate lists this step left
            replay_sweep(sw, k, rec)
        else:
            if k == 0:
                d0 = (
                    None
                    if req.start is not None
                    else default_candidate(req, ck, targets[0], 0, info)
                )
                sw.first(d0)
                changed = {0}
            else:
                changed = sw.step(k, default_candidate(req, ck, targets[k], k, info))
            ck.put("sweep", k, sweep_record(sw, changed))
        if not np.any(np.isfinite(sw.cost[k])):
            break
    info["candidates_mean"] = float(np.mean([len(c) for c in sw.C]))
    info["candidates_max"] = max(len(c) for c in sw.C)
    info["transit_candidates"] = sum(c.origin == "transit" for cs in sw.C for c in cs)
    info["backward_bounded"] = sum(
        c.origin == "backward" and c.how == "bounded" for cs in sw.C for c in cs
    )
    poses = sw.best_path()
    if len(poses) == len(targets):
        status, message = PathStatus.SUCCESS, PATH_MESSAGES[PathStatus.SUCCESS]
        return _Outcome(targets, sources, poses, status, message, info)
    k = len(poses)
    status, message = _break(req, tracker, k, targets[k], sources[k], poses[-1] if poses else None,
                             info)  # fmt: skip
    return _Outcome(targets, sources, poses, status, message, info)
