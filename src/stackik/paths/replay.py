"""Checkpoint records of both path modes, and the replay that resumes from them.

A path's checkpoint (:class:`stackik.paths.checkpoint.PathCheckpoint`) holds, in fast
mode, one ``"fast"`` record per reached waypoint (its target, source, pose, rung, the
refined waypoints pending, the goal basin and the reanchoring schedule; a spliced detour
rewrites the records it replaces), and in global mode one ``"default"`` record per
waypoint (the default solve's pose and FN^2) and one ``"sweep"`` record per waypoint (the
candidate lists that step changed, and the transit cooldown). Replaying them rebuilds the
state the uninterrupted run had at that point: floats round-trip exactly through JSON,
so a resumed path equals an uninterrupted one, with one exception: the continuation
step's multipliers, which a run of warm steps carries inside its compiled call, are not
recorded, so a spatial fast path resumed inside such a run starts that step from fresh
ones (differences of about 1e-7 [mm, rad]; planar and global mode: none measured).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from stackik.paths.checkpoint import PathCheckpoint
from stackik.paths.records import _Cand, _Goal, _Pending, _Waypoint
from stackik.paths.request import _Request
from stackik.targets import Target, target_from_dict, target_to_dict

if TYPE_CHECKING:
    from stackik.paths.global_ import _Sweep

FloatArray = NDArray[np.float64]


# =========================================================================================
# Fast mode
# =========================================================================================
@dataclass
class _FastStart:
    """A fast path as its checkpoint leaves it: the waypoints reached, the pending ones
    (the top next), the goal basin and the reanchoring schedule (the next check's index
    ``due`` and the gap after it)."""

    path: list[_Waypoint]
    pending: list[_Pending]
    goal: _Goal | None
    due: int
    gap: int


def put_first(ck: PathCheckpoint, q0: FloatArray, how: str) -> None:
    """Record the pose of waypoint 0."""
    ck.put("fast", 0, {"q": q0.tolist(), "how": how, "pending": [], "goal": None})


def replay_fast(req: _Request, ck: PathCheckpoint) -> _FastStart:
    """The fast path the records give (waypoint 0's at least: :func:`put_first`)."""
    pts = req.targets
    m = len(pts)
    path: list[_Waypoint] = []
    refined: list[_Pending] = []
    goal: _Goal | None = None
    # reanchoring schedule: the next check's index and the gap after it (doubled after a
    # check that finds no better basin, reset to reanchor_every after one that does)
    due, gap = req.reanchor_every, req.reanchor_every
    scheduled = False  # a record carried the schedule (checkpoints before it did not)
    j = 0
    rec = ck.get("fast", 0)
    while rec is not None:
        if j == 0:
            target, source = pts[0], 0.0
        else:
            target, source = target_from_dict(rec["target"]), float(rec["source"])
        path.append(_Waypoint(target, source, np.array(rec["q"], dtype=float), str(rec["how"])))
        refined = [_Pending(target_from_dict(t), float(s), int(d)) for t, s, d in rec["pending"]]
        goal = _Goal.load(rec["goal"])
        if "reanchor" in rec:
            due, gap = (int(v) for v in rec["reanchor"])
            scheduled = True
        j += 1
        rec = ck.get("fast", j)
    if not scheduled and j > 1 and req.reanchor_every:
        # a checkpoint written without the schedule: the next multiple of reanchor_every
        # after its last waypoint (the rule it was written under), not a check in the past
        gap = req.reanchor_every
        due = gap * ((j - 1) // gap + 1)
    # pending: a stack of (target, source, depth); the top is the next waypoint to reach
    inputs_left = {s for _, s, _ in refined}
    last = int(path[-1].source)
    pending = [
        _Pending(pts[i], float(i), 0) for i in range(m - 1, last, -1) if i not in inputs_left
    ]
    pending += refined
    return _FastStart(path, pending, goal, due, gap)


def fast_record(
    req: _Request, wp: _Waypoint, pending: list[_Pending], goal: _Goal | None, due: int, gap: int
) -> dict[str, Any]:
    """The record of a reached waypoint ``wp`` (the refined waypoints pending with it)."""
    top = [(target_to_dict(t), s, d) for t, s, d in pending if d > 0] if req.refine else []
    return {
        "target": target_to_dict(wp.target),
        "source": wp.source,
        "q": wp.q.tolist(),
        "how": wp.how,
        "pending": top,
        "goal": None if goal is None else goal.record(),
        "reanchor": [due, gap],
    }


def put_rejoin(ck: PathCheckpoint, j0: int, poses: list[FloatArray]) -> None:
    """Rewrite the records of waypoints ``j0, j0 + 1, ...`` with a spliced detour's poses
    (in one line: an interruption keeps all of them or none)."""
    if ck.path is None:
        return
    items = []
    for j, q in enumerate(poses, start=j0):
        old = ck.get("fast", j)
        items.append((j, {**old, "q": q.tolist(), "how": "rejoin", "goal": None}))
    if items:
        ck.put_many("fast", items)


# =========================================================================================
# Global mode
# =========================================================================================
def default_candidate(
    req: _Request, ck: PathCheckpoint, target: Target, k: int, info: dict[str, Any]
) -> _Cand | None:
    """The default solve's pose of waypoint k as a candidate (recorded; None: it fails)."""
    rec = ck.get("default", k)
    if rec is None:
        r = req.default_solve(target, k)
        info["default"] += 1
        rec = [r.q.tolist(), float(r.frobenius_norm) ** 2] if r.success else []
        ck.put("default", k, rec)
    return _Cand(np.array(rec[0]), float(rec[1]), "default") if rec else None


def sweep_record(sw: _Sweep, changed: set[int]) -> dict[str, Any]:
    """The record of one global step: the candidate lists it changed, the cooldown."""
    sets = [[j, [c.record() for c in sw.C[j]]] for j in sorted(changed)]
    return {"sets": sets, "cooldown": sw.cooldown}


def replay_sweep(sw: _Sweep, k: int, rec: dict[str, Any]) -> None:
    """Redo global step k from its record: the candidate lists it left, then the costs."""
    sw.C.append([])
    low = k
    sw.cooldown = int(rec["cooldown"])
    for j, cands in rec["sets"]:
        sw.C[j] = [_Cand.load(r) for r in cands]
        low = min(low, j)
    if low < k:
        sw.relax_from(low)
    else:
        sw.relax(k)
