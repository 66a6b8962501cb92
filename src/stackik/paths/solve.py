"""Continuous least-sensitivity pose sequences along an end-effector path (DESIGN §9).

:func:`solve_path` turns waypoints ``y_1..y_m`` into poses ``q_1..q_m``, each reaching its
waypoint within every limit (checked by :func:`stackik.check.check_pose` or its compiled
twin), with no platform variable changing by more than ``max_jump`` between consecutive
waypoints. Two modes:

``"fast"`` (continuation)
    Start at the best pose of the default multi-start solve of the first waypoint (or at
    ``start``), then one continuation step per waypoint
    (:class:`stackik.paths.continuation.Tracker`): a warm-started solve that keeps the fold
    of the previous pose, bisection of the step when the warm start leaves its basin, and,
    when the followed FN minimum ends, the least-FN pose within ``max_jump`` of the
    previous one. At waypoint ``reanchor_every`` it compares the path with the default
    solve and moves to a basin better by 1 % by transit steps; the next comparison comes
    ``reanchor_every`` waypoints later after one that moved, twice the last gap after one
    that did not (the path was on the best basin the default solve knows, or its transit
    there was abandoned before a step: checks back off while it stays there); when the
    followed branch
    ends at a limit wall it splices in a detour walked back from the next waypoint's
    default pose.

``"global"`` (Descartes-style)
    Candidates per waypoint: the default solve's best pose, the continuations of the
    previous waypoint's candidates, default poses continued backwards (warm steps, bounded
    steps where their branch ends) until something reaches them, and transit poses
    towards better basins; deduplicated and pruned by
    cost. Dynamic programming (Viterbi) minimises
    ``sum_k FN_k^2 + motion_weight * sum_k |q_{k+1} - q_k|^2`` over the sequences whose
    every step is within ``max_jump`` (``|dq|^2`` mixes mm^2 and rad^2, as FN^2 does).

When no continuation within ``max_jump`` exists, the path breaks: the result says at which
waypoint (``completed``), why (``status``: the waypoint is outside the workspace, or
reachable only by a pose farther than ``max_jump``) and which limit was tightest.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.check import check_pose
from stackik.geometry import Stack
from stackik.kinematics import planar_fn2, spatial_chain
from stackik.paths.checkpoint import PathCheckpoint
from stackik.paths.continuation import Step, Tracker
from stackik.paths.interpolate import _pair, as_waypoints, lerp_target
from stackik.paths.result import MARGIN_NAMES, PATH_MESSAGES, PathResult, PathStatus
from stackik.paths.timing import time_parameterize
from stackik.platform import spatial_legs
from stackik.solve import solve_ik
from stackik.solve.blas import BlasLimit
from stackik.targets import PlanarTarget, Target, target_from_dict, target_to_dict

__all__ = [
    "DEDUPE",
    "FAST_TRANSIT_GAIN",
    "MODES",
    "REANCHOR_EVERY",
    "REANCHOR_ITER_PER_N",
    "REANCHOR_PER_N",
    "REFINE_DEPTH",
    "SPATIAL_REANCHOR_N",
    "TRANSIT_GAIN",
    "TRANSIT_STEPS",
    "path_arrays",
    "solve_path",
]

FloatArray = NDArray[np.float64]

MODES = ("fast", "global")
#: Candidates closer than this (in units of max_jump, per variable) are one candidate.
DEDUPE = 1e-3
#: Bisection levels of ``refine=True``: up to 16 inserted steps per input step.
REFINE_DEPTH = 4
#: Transit steps per attempt to reach a better basin (each must bring it 1/4 jump closer).
TRANSIT_STEPS = 10
#: Fast mode: at the reanchoring checks (``reanchor_every``, backing off) the default
#: solve is compared with the path, which moves to the default pose's basin when its FN
#: is lower by this fraction.
FAST_TRANSIT_GAIN = 0.01
#: Default ``reanchor_every``: ``max(REANCHOR_EVERY, REANCHOR_PER_N * n)`` waypoints
#: (the default solve's starts grow with n: planar 3 at n = 4, 19 at n = 8, 35 at n = 16;
#: this keeps its share of a fast path's time small); spatial paths up to
#: ``SPATIAL_REANCHOR_N`` platforms only (8 starts, ~10 ms, about 20 warm steps, at
#: n = 4; from n = 5 18 starts and 12 hops, ~170 ms at n = 8, where a check at waypoint
#: 40 of the benchmark's and 4 held-out 60-waypoint paths gave no lower FN (mean ratio
#: 1.0107 -> 1.0113 and 1.0025 -> 1.0027) at 60-70 % of the speed).
REANCHOR_EVERY = 20
REANCHOR_PER_N = 5
SPATIAL_REANCHOR_N = 4
#: Fast mode's planar reanchoring check runs the default solve's interior-point starts
#: with at most this many iterations per platform each (:func:`_screen`; on the
#: benchmark's planar paths the best start of a default solve took at most 30
#: iterations at n = 4, 98 at n = 8, 128 at n = 16, a slow start up to 112 at n = 4).
REANCHOR_ITER_PER_N = 10


# =========================================================================================
# Input checks
# =========================================================================================
@dataclass(frozen=True)
class _Request:
    stack: Stack
    targets: list[Target]
    planar: bool
    k: int
    max_jump: tuple[float, float]
    mode: str
    motion_weight: float
    refine: bool
    max_depth: int
    start: FloatArray | None
    leg_speed: float | None
    leg_accel: float | None
    max_candidates: int
    seed: int | None
    reanchor_every: int
    memo: dict[Any, Any] = field(default_factory=dict, compare=False, repr=False)

    def key(self) -> dict[str, Any]:
        """JSON-ready identity of the problem (for checkpoints)."""
        return {
            "stack": self.stack.to_dict(),
            "targets": [target_to_dict(t) for t in self.targets],
            "max_jump": list(self.max_jump),
            "mode": self.mode,
            "motion_weight": self.motion_weight,
            "refine": self.refine,
            "max_depth": self.max_depth,
            "start": None if self.start is None else self.start.tolist(),
            "max_candidates": self.max_candidates,
            "seed": self.seed,
            "reanchor_every": self.reanchor_every,
        }

    def default_solve(self, target: Target, index: int) -> Any:
        """The default multi-start solve of waypoint ``index`` (memoised: a break's
        diagnosis reuses the rejoin attempt's solve)."""
        key = (index, json.dumps(target_to_dict(target)))
        if key not in self.memo:
            rng = None if self.seed is None else self.seed + index
            self.memo[key] = solve_ik(self.stack, target, rng=rng)
        return self.memo[key]


def _request(
    stack: Any,
    targets: Any,
    max_jump: Any,
    mode: Any,
    motion_weight: Any,
    refine: Any,
    max_depth: Any,
    start: Any,
    leg_speed: Any,
    leg_accel: Any,
    max_candidates: Any,
    rng: Any,
    reanchor_every: Any,
) -> _Request:
    if not isinstance(stack, Stack):
        raise ValueError(f"stack: expected a Stack, got {type(stack).__name__}")
    if bool(np.isfinite(stack.force_max).any()):
        # the path kernels do not know leg forces: refuse rather than call a pose over
        # its force limit valid (solve_ik refuses such a pose by the independent check)
        raise ValueError(
            "stack: solve_path does not enforce leg force limits yet (force_max is finite); "
            "use a stack without force_max, or check waypoints with stackik.statics"
        )
    pts = as_waypoints(targets)
    planar = isinstance(pts[0], PlanarTarget)
    k = 3 if planar else 6
    mj = _pair(max_jump, "max_jump")
    if mode not in MODES:
        raise ValueError(f"mode: unknown {mode!r}; choose one of {MODES}")
    try:
        w = float(motion_weight)
    except (TypeError, ValueError):
        raise ValueError(f"motion_weight: expected a number, got {motion_weight!r}") from None
    if not math.isfinite(w) or w < 0:
        raise ValueError(f"motion_weight: must be finite and >= 0, got {motion_weight!r}")
    if not isinstance(refine, bool):
        raise ValueError(f"refine: expected True or False, got {refine!r}")
    if isinstance(max_depth, bool) or not isinstance(max_depth, int) or not 0 <= max_depth <= 12:
        raise ValueError(f"max_depth: expected an integer in 0..12, got {max_depth!r}")
    if (
        isinstance(max_candidates, bool)
        or not isinstance(max_candidates, int)
        or max_candidates < 1
    ):
        raise ValueError(f"max_candidates: expected an integer >= 1, got {max_candidates!r}")
    if (leg_speed is None) != (leg_accel is None):
        raise ValueError("leg_speed and leg_accel: give both (mm/s, mm/s^2) or neither")
    speeds: list[float | None] = [None, None]
    for j, (name, v) in enumerate((("leg_speed", leg_speed), ("leg_accel", leg_accel))):
        if v is not None:
            try:
                fv = float(v)
            except (TypeError, ValueError):
                raise ValueError(f"{name}: expected a number, got {v!r}") from None
            if not math.isfinite(fv) or fv <= 0:
                raise ValueError(f"{name}: must be finite and > 0, got {v!r}")
            speeds[j] = fv
    q0 = None
    if start is not None:
        try:
            q0 = np.array(start, dtype=float)
        except (TypeError, ValueError):
            raise ValueError("start: expected an array of numbers") from None
        if q0.shape != (stack.n, k) or not np.all(np.isfinite(q0)):
            raise ValueError(
                f"start: expected finite values of shape ({stack.n}, {k}), got {q0.shape}"
            )
        chk = check_pose(stack, pts[0], q0)
        if not chk.ok:
            raise ValueError(
                "start: the pose does not reach targets[0] within every limit "
                f"(position error {chk.position_error:.3g} mm, angle error "
                f"{chk.angle_error:.3g} rad, worst violation {chk.max_violation_mm:.3g} mm)"
            )
    if reanchor_every is None:
        reanchor_every = max(REANCHOR_EVERY, REANCHOR_PER_N * stack.n)
        if not planar and stack.n > SPATIAL_REANCHOR_N:
            reanchor_every = 0
    if (
        isinstance(reanchor_every, bool)
        or not isinstance(reanchor_every, int)
        or reanchor_every < 0
    ):
        raise ValueError(
            f"reanchor_every: expected an integer >= 0 or None, got {reanchor_every!r}"
        )
    seed = None
    if rng is not None:
        try:
            seed = int(np.random.default_rng(rng).integers(2**31))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"rng: expected None, an int seed or a Generator ({exc})") from None
    return _Request(
        stack, pts, planar, k, mj, mode, w, refine, max_depth, q0, speeds[0], speeds[1],
        max_candidates, seed, reanchor_every,
    )  # fmt: skip


# =========================================================================================
# Result assembly
# =========================================================================================
def path_arrays(stack: Stack, targets: Sequence[Target], q: ArrayLike) -> dict[str, FloatArray]:
    """FN, leg lengths and limit margins of poses along a path (vectorised).

    Parameters
    ----------
    stack : Stack
    targets : sequence of targets
        One kind; the plane ``phi`` of planar targets is taken from the first.
    q : array_like, shape (m, n, 3) or (m, n, 6)

    Returns
    -------
    dict
        ``frobenius_norm`` (m,), ``leg_lengths`` (m, n, 6) [mm] and ``margins``
        (m, n, 4) [mm, mm, rad, rad] in the order of :data:`MARGIN_NAMES`.
    """
    Q = np.asarray(q, dtype=float)
    m, n = Q.shape[0], stack.n
    if m == 0:
        return {
            "frobenius_norm": np.zeros(0),
            "leg_lengths": np.zeros((0, n, 6)),
            "margins": np.zeros((0, n, len(MARGIN_NAMES))),
        }
    t0 = targets[0]
    if isinstance(t0, PlanarTarget):  # compiled (~20 us for 60 poses at n = 4, not ~200)
        from stackik._compiled.check import planar_path_arrays

        fn, legs, margins = planar_path_arrays(stack, t0.phi, Q)
        return {"frobenius_norm": fn, "leg_lengths": legs, "margins": margins}
    fn = _frobenius_norms(False, Q)
    l, Rn, _, _ = spatial_legs(stack, Q)
    norms = np.linalg.norm(l, axis=-1)  # (m, n, 6)
    joint_min = np.arcsin(stack.sin_joint_min)[None, :]
    ang_base = np.arcsin(np.clip(l[..., 2] / norms, -1.0, 1.0))
    ang_top = np.arcsin(np.clip(np.einsum("mnkj,mnj->mnk", l, Rn) / norms, -1.0, 1.0))
    margins = np.stack(
        [
            norms.min(axis=-1) - stack.leg_min[None, :],
            stack.leg_max[None, :] - norms.max(axis=-1),
            ang_base.min(axis=-1) - joint_min,
            ang_top.min(axis=-1) - joint_min,
        ],
        axis=-1,
    )
    return {"frobenius_norm": fn, "leg_lengths": norms, "margins": margins}


def _tightest(stack: Stack, target: Target, q: FloatArray) -> str:
    """The limit with the smallest margin at a pose, as text."""
    mg = path_arrays(stack, [target], q[None])["margins"][0]  # (n, 4)
    scale = np.array([1.0, 1.0, 180.0 / math.pi, 180.0 / math.pi])
    units = ("mm", "mm", "deg", "deg")
    rel = mg / np.array([1.0, 1.0, 0.01, 0.01])  # compare 1 mm with ~0.6 deg
    i, j = np.unravel_index(int(np.argmin(rel)), rel.shape)
    return (
        f"tightest limit there: platform {i + 1} {MARGIN_NAMES[j]} margin "
        f"{mg[i, j] * scale[j]:.3g} {units[j]}"
    )


def _assemble(
    req: _Request,
    targets: list[Target],
    sources: list[float],
    poses: list[FloatArray],
    status: PathStatus,
    message: str,
    t_start: float,
    info: dict[str, Any],
) -> PathResult:
    m, n, k = len(targets), req.stack.n, req.k
    c = len(poses)
    Q = np.full((m, n, k), np.nan)
    if c:
        Q[:c] = np.stack(poses)
    arr = path_arrays(req.stack, targets, Q[:c])
    fn = np.full(m, np.nan)
    fn[:c] = arr["frobenius_norm"]
    legs = np.full((m, n, 6), np.nan)
    legs[:c] = arr["leg_lengths"]
    margins = np.full((m, n, len(MARGIN_NAMES)), np.nan)
    margins[:c] = arr["margins"]
    times = None
    if req.leg_speed is not None and req.leg_accel is not None:
        times = np.full(m, np.nan)
        times[:c] = time_parameterize(legs[:c], leg_speed=req.leg_speed, leg_accel=req.leg_accel)
    for a in (Q, fn, legs, margins) + (() if times is None else (times,)):
        a.setflags(write=False)
    src = np.array(sources, dtype=float)
    src.setflags(write=False)
    return PathResult(
        targets=tuple(targets),
        q=Q,
        success=status is PathStatus.SUCCESS,
        completed=c,
        status=status,
        message=message,
        frobenius_norm=fn,
        leg_lengths=legs,
        margins=margins,
        max_jump=req.max_jump,
        mode=req.mode,
        source=src,
        times=times,
        time=time.perf_counter() - t_start,
        info=info,
    )


def _source_text(s: float) -> str:
    if float(s).is_integer():
        return f"waypoint {int(s)}"
    lo = math.floor(s)
    return f"an inserted waypoint at {s - lo:.4g} of the way from waypoint {lo} to {lo + 1}"


def _break(
    req: _Request,
    tracker: Tracker,
    index: int,
    target: Target,
    source: float,
    q_prev: FloatArray | None,
    info: dict[str, Any],
) -> tuple[PathStatus, str]:
    """Status and message of a path that cannot reach ``target`` (output index ``index``)."""
    r = req.default_solve(target, index)
    info["default"] = info.get("default", 0) + 1
    where = f"the path breaks at index {index} ({_source_text(source)})"
    if not r.success:
        return PathStatus.UNREACHABLE, (
            f"{where}: no pose reaches it within the limits ({r.status.value}: the target "
            f"is outside the workspace, target error {r.target_error:.3g} mm)"
        )
    assert q_prev is not None
    far = tracker.ratio(q_prev, r.q)
    hint = "" if req.refine else "; finer waypoints or refine=True may get through"
    return PathStatus.JUMP, (
        f"{where}: the waypoint is reachable, but no pose within max_jump "
        f"({req.max_jump[0]:g} mm, {req.max_jump[1]:g} rad) of the pose at index {index - 1} "
        f"reaches it (its least-FN pose is {far:.2f} x max_jump away; "
        f"{_tightest(req.stack, target, q_prev)}){hint}"
    )


# =========================================================================================
# Fast mode
# =========================================================================================
@dataclass(frozen=True)
class _Goal:
    """A better basin a fast path is moving to: its pose at the current waypoint, the
    path's distance to it [max_jump] and the transit steps taken."""

    q: FloatArray
    dist: float
    steps: int

    def record(self) -> list[Any]:
        return [self.q.tolist(), self.dist, self.steps]

    @classmethod
    def load(cls, r: list[Any] | None) -> _Goal | None:
        return None if r is None else cls(np.array(r[0], dtype=float), float(r[1]), int(r[2]))


def _fast(
    req: _Request, ck: PathCheckpoint, tracker: Tracker, t_start: float
) -> tuple[list[Target], list[float], list[FloatArray], list[str], PathStatus, str, dict]:
    info: dict[str, Any] = {"default": 0, "reanchored": 0}
    tl: list[Target] = []
    sl: list[float] = []
    ql: list[FloatArray] = []
    hows: list[str] = []
    pts = req.targets
    m = len(pts)
    rec = ck.get("fast", 0)
    if rec is None:
        if req.start is not None:
            q0, how = req.start, "start"
        else:
            t0 = time.perf_counter()
            r0 = req.default_solve(pts[0], 0)
            info["default"] += 1
            info["first_solve_s"] = time.perf_counter() - t0  # the rest: the path's steps
            if not r0.success:
                msg = (
                    f"the path breaks at index 0 (waypoint 0): no pose reaches it within the "
                    f"limits ({r0.status.value}, target error {r0.target_error:.3g} mm)"
                )
                return [], [], [], [], PathStatus.UNREACHABLE, msg, info
            q0, how = r0.q, "default"
        ck.put("fast", 0, {"q": q0.tolist(), "how": how, "pending": [], "goal": None})
        rec = ck.get("fast", 0)
    j = 0
    refined: list[tuple[Target, float, int]] = []
    goal: _Goal | None = None
    # reanchoring schedule: the next check's index and the gap after it (doubled after a
    # check that finds no better basin, reset to reanchor_every after one that does)
    due, gap = req.reanchor_every, req.reanchor_every
    scheduled = False  # a record carried the schedule (checkpoints before it did not)
    while rec is not None:  # replay the checkpoint (or just waypoint 0)
        if j == 0:
            tl.append(pts[0])
            sl.append(0.0)
        else:
            tl.append(target_from_dict(rec["target"]))
            sl.append(float(rec["source"]))
        ql.append(np.array(rec["q"], dtype=float))
        hows.append(str(rec["how"]))
        refined = [(target_from_dict(t), float(s), int(d)) for t, s, d in rec["pending"]]
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
    pending: list[tuple[Target, float, int]] = [
        (pts[i], float(i), 0) for i in range(m - 1, int(sl[-1]), -1) if i not in inputs_left
    ]
    pending += refined
    status, message = PathStatus.SUCCESS, PATH_MESSAGES[PathStatus.SUCCESS]

    def accept(q: FloatArray, how: str) -> None:
        """Append the pose of the pending top; reanchor when due; checkpoint."""
        nonlocal goal, due, gap
        tb, sb, _ = pending.pop()
        tl.append(tb)
        sl.append(sb)
        ql.append(q)
        hows.append(how)
        k = len(ql) - 1
        if req.reanchor_every and k == due:
            if goal is None and pending:
                goal = _reanchor(req, tracker, k, tb, q, info)
                gap = 2 * gap  # the next gap unless the path moves to the goal (below)
            due = k + (req.reanchor_every if goal is not None else gap)
        if ck.path is None:  # nothing to write: no record (~5 us a waypoint at n = 4)
            return
        top = [(target_to_dict(t), s, d) for t, s, d in pending if d > 0] if req.refine else []
        ck.put(
            "fast",
            k,
            {
                "target": target_to_dict(tb),
                "source": sb,
                "q": q.tolist(),
                "how": how,
                "pending": top,
                "goal": None if goal is None else goal.record(),
                "reanchor": [due, gap],
            },
        )

    ladder_at = -1  # the waypoint a run of warm steps stopped before (the ladder takes it)
    while pending:
        if (goal is None and hows[-1] not in _OFF_OPTIMUM
                and len(ql) != ladder_at):  # fmt: skip
            # warm steps along the next waypoints in one compiled call, up to the next
            # reanchoring; the first it does not reach goes through the ladder below
            run = _warm_run_length(len(ql), due if req.reanchor_every else 0, len(pending))
            poses = tracker.warm_many(ql[-1], [t for t, _, _ in pending[::-1][:run]])
            for q in poses:
                accept(q, "warm")
            if len(poses) < run:
                ladder_at = len(ql)
            continue
        tb, sb, depth = pending[-1]
        moving = goal
        step, goal = _towards(tracker, goal, ql[-1], tb, info) if goal else (None, None)
        if moving is not None and step is not None:  # it moves to the goal's basin
            if req.planar or step.how == "joined":  # spatial: reset on arrival only
                gap = req.reanchor_every
        elif moving is not None and (moving.steps == 0 or not req.planar):
            # abandoned before a step: the check moved nothing, and backs off as one that
            # finds no better basin (the next check 2 x the last gap after it, not
            # reanchor_every: the path stays on its basin); spatial, abandoned at any
            # step: it did not reach the better basin either (its gap is reset on
            # arrival only)
            due += gap - req.reanchor_every
        if step is None:
            off = hows[-1] in ("bounded", "transit")  # off the optimum: no bisection
            # where a run of warm steps stopped in its kernel, it made the warm rung's
            # first solve from this pose to this waypoint
            tried = len(ql) == ladder_at and depth == 0 and tracker.tried_from is ql[-1]
            # spatial, off the optimum: the boxed solve first (~2 ms at n = 4; a warm
            # barrier solve from there slides far, 10-25 ms, and mostly jumps)
            step = tracker.step(ql[-1], tl[-1], tb, subdivide=not off, warm_tried=tried,
                                warm_left=tried and tracker.tried_left,
                                box_first=off and not req.planar)  # fmt: skip
        if step is not None:
            accept(step.q, step.how)
            continue
        splice = _rejoin_fast(req, tracker, tl, ql, tb, info)
        if splice is not None:  # the followed branch ended: leave it earlier
            j0, poses = splice
            items = []
            for j, q in enumerate(poses, start=j0):
                ql[j], hows[j] = q, "rejoin"
                if ck.path is not None:
                    old = ck.get("fast", j)
                    items.append((j, {**old, "q": q.tolist(), "how": "rejoin", "goal": None}))
            if items:
                ck.put_many("fast", items)
            goal = None
            ladder_at = -1  # a new pose: its warm solve is not made yet
            continue  # the next step from the new pose before tb
        if req.refine and depth < REFINE_DEPTH:
            sa = sl[-1]
            pending[-1] = (tb, sb, depth + 1)
            pending.append((lerp_target(tl[-1], tb, 0.5), 0.5 * (sa + sb), depth + 1))
            continue
        status, message = _break(req, tracker, len(ql), tb, sb, ql[-1], info)
        break
    # the waypoints not reached: the input ones after the last reached
    rest = [pts[i] for i in range(m) if i > sl[-1]]
    rest_src = [float(i) for i in range(m) if i > sl[-1]]
    info["how"] = {h: hows.count(h) for h in sorted(set(hows))}
    return tl + rest, sl + rest_src, ql, hows, status, message, info


#: Fast mode: after these steps the path is off its optimum and a warm step often fails;
#: the next step goes through the ladder directly, not through a run of warm steps.
_OFF_OPTIMUM = ("bounded", "transit", "rejoin")
#: Fast mode: most warm steps solved in one compiled call.
WARM_RUN = 256


def _warm_run_length(k: int, due: int, pending: int) -> int:
    """Waypoints of the next run of warm steps: to the next reanchoring index ``due``
    (inclusive; 0: none), at most WARM_RUN and what is pending."""
    run = WARM_RUN
    if due >= k:
        run = due - k + 1
    return min(run, WARM_RUN, pending)


def _rejoin_fast(
    req: _Request,
    tracker: Tracker,
    tl: list[Target],
    ql: list[FloatArray],
    target: Target,
    info: dict,
) -> tuple[int, list[FloatArray]] | None:
    """New poses for the last waypoints of a fast path whose branch ends before
    ``target``: from the default pose of ``target``, transit steps backwards towards the
    path's poses until one is within max_jump of the path; ``(first index replaced,
    poses)`` (the last one within max_jump of the default pose, so the next step reaches
    it), or None when the waypoint is unreachable or no such detour is found."""
    k = len(ql)
    r = req.default_solve(target, k)
    info["default"] += 1
    if not r.success or k < 2:
        return None
    cur = r.q
    dist = tracker.ratio(cur, ql[-1])
    new: list[FloatArray] = []
    for j in range(k - 1, max(k - 1 - 2 * TRANSIT_STEPS, 0), -1):
        qt = tracker.transit(cur, tl[j], ql[j])
        if qt is None:
            return None
        new.append(qt)
        if tracker.ratio(qt, ql[j - 1]) <= 1.0:
            info["rejoined"] = info.get("rejoined", 0) + 1
            return j, new[::-1]
        d = tracker.ratio(qt, ql[j])
        if d >= dist - 0.25:
            return None
        cur, dist = qt, tracker.ratio(qt, ql[j - 1])
    return None


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
        max_time=None, t_start=time.perf_counter(), blas=BlasLimit(None),
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
    it at least a quarter jump closer. ``(None, None)``: the transit is abandoned."""
    g = tracker.follow(goal.q, target)
    if g is not None:
        if tracker.ratio(q, g) <= 1.0:
            return Step(g, "joined"), None
        if goal.steps < TRANSIT_STEPS:
            qt = tracker.transit(q, target, g)
            if qt is not None and tracker.ratio(qt, g) < goal.dist - 0.25:
                return Step(qt, "transit"), _Goal(g, tracker.ratio(qt, g), goal.steps + 1)
    info["transit_abandoned"] = info.get("transit_abandoned", 0) + 1
    return None, None


# =========================================================================================
# Global mode
# =========================================================================================
@dataclass(eq=False)  # identity: candidates hold arrays
class _Cand:
    """A candidate pose of one waypoint in global mode."""

    q: FloatArray
    fn2: float
    origin: str  # "default", "start", "forward", "backward" or "transit"
    how: str = ""  # rung of the continuation that produced it
    steps: int = 0  # transit steps taken (origin "transit")
    goal_dist: float = math.inf  # transit: distance to its goal, in max_jump
    back_done: bool = False  # backward continuation tried

    def record(self) -> list[Any]:
        return [self.q.tolist(), self.fn2, self.origin, self.how, self.steps,
                None if math.isinf(self.goal_dist) else self.goal_dist, self.back_done]  # fmt: skip

    @classmethod
    def load(cls, r: list[Any]) -> _Cand:
        gd = math.inf if r[5] is None else float(r[5])
        return cls(np.array(r[0], dtype=float), float(r[1]), str(r[2]), str(r[3]), int(r[4]),
                   gd, bool(r[6]))  # fmt: skip


def _frobenius_norms(planar: bool, Q: FloatArray) -> FloatArray:
    """FN of each pose of ``Q`` (m, n, 3|6)."""
    if planar:
        return np.sqrt(planar_fn2(Q))  # type: ignore[no-any-return]
    return np.array([math.sqrt(spatial_chain(qk).weighted_norm2()) for qk in Q])


def _fn2(req: _Request, q: FloatArray) -> float:
    """FN^2 of one pose, without the legs and margins :func:`path_arrays` also computes:
    it runs for every candidate (spatial: path_arrays' FN squared, the same rounding;
    planar: :func:`stackik.kinematics.planar_fn2`, where path_arrays' compiled FN agrees
    to rounding, ~1e-16 relative, not bit for bit)."""
    planar = isinstance(req.targets[0], PlanarTarget)
    return float(_frobenius_norms(planar, q[None])[0] ** 2)


#: Global mode: a default pose that no candidate reaches within max_jump is approached by
#: transit steps when its FN is lower than every reachable candidate's by this fraction
#: (one transit at a time; after one gives up, none starts for TRANSIT_COOLDOWN waypoints).
TRANSIT_GAIN = 0.005
TRANSIT_COOLDOWN = 5
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
                qt = tr.transit(c.q, t[k], dk.q)
                if qt is not None and tr.ratio(qt, dk.q) < c.goal_dist - 0.25:
                    g = tr.ratio(qt, dk.q)
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
        until they meet: the DP can then leave the ending branch in time."""
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
            qt = self.tracker.transit(cur, self.targets[j], goal)
            if qt is None or self.tracker.ratio(qt, goal) >= dist - 0.25:
                break
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
        than TRANSIT_GAIN and is not within max_jump of the former."""
        best = self.C[k][int(np.argmin(self.cost[k]))]
        if best is dk or dk.fn2 >= (1 - TRANSIT_GAIN) ** 2 * best.fn2:
            return
        c = self.C[k - 1][int(np.argmin(self.cost[k - 1]))]
        dist = self.tracker.ratio(c.q, dk.q)
        if dist <= 1.0:
            return  # a direct edge: the DP weighs it
        if dist > TRANSIT_STEPS:  # too far to get there
            self.cooldown = k + TRANSIT_COOLDOWN
            return
        qt = self.tracker.transit(c.q, self.targets[k], dk.q)
        if qt is None:
            self.cooldown = k + TRANSIT_COOLDOWN
        else:
            g = self.tracker.ratio(qt, dk.q)
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
) -> tuple[list[FloatArray], PathStatus, str, dict[str, Any]]:
    info: dict[str, Any] = {"default": 0}
    sw = _Sweep(req, tracker, targets)

    def default(k: int) -> _Cand | None:
        rec = ck.get("default", k)
        if rec is None:
            r = req.default_solve(targets[k], k)
            info["default"] += 1
            rec = [r.q.tolist(), float(r.frobenius_norm) ** 2] if r.success else []
            ck.put("default", k, rec)
        return _Cand(np.array(rec[0]), float(rec[1]), "default") if rec else None

    for k in range(len(targets)):
        rec = ck.get("sweep", k)
        if rec is not None:  # replay: the candidate lists this step left
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
        else:
            if k == 0:
                sw.first(None if req.start is not None else default(0))
                changed = {0}
            else:
                changed = sw.step(k, default(k))
            sets = [[j, [c.record() for c in sw.C[j]]] for j in sorted(changed)]
            ck.put("sweep", k, {"sets": sets, "cooldown": sw.cooldown})
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
        return poses, PathStatus.SUCCESS, PATH_MESSAGES[PathStatus.SUCCESS], info
    k = len(poses)
    status, message = _break(req, tracker, k, targets[k], float(k), poses[-1] if poses else None,
                             info)  # fmt: skip
    return poses, status, message, info


# =========================================================================================
# Entry point
# =========================================================================================
def solve_path(
    stack: Stack,
    targets: Sequence[Target],
    *,
    max_jump: tuple[float, float] = (50.0, 0.25),
    mode: Literal["fast", "global"] = "fast",
    motion_weight: float = 0.0,
    refine: bool = False,
    max_depth: int = 1,
    start: ArrayLike | None = None,
    leg_speed: float | None = None,
    leg_accel: float | None = None,
    max_candidates: int = 6,
    checkpoint: str | Path | None = None,
    rng: np.random.Generator | int | None = None,
    reanchor_every: int | None = None,
) -> PathResult:
    """Continuous least-FN poses along a sequence of end-effector waypoints.

    Parameters
    ----------
    stack : Stack
    targets : sequence of PlanarTarget or SpatialTarget
        The waypoints, in order; one kind, planar ones in one plane. Between waypoints
        the path is the straight segment of :func:`stackik.paths.lerp_target` (use
        :func:`stackik.paths.interpolate_targets` to fill key targets).
    max_jump : (float, float)
        Continuity limit: largest change of any platform's translation variable [mm] and
        angle variable [rad] between consecutive waypoints. A hard rule: every step of the
        result is within it, or the path breaks there.
    mode : {"fast", "global"}
        ``"fast"``: continuation from the best default pose of the first waypoint;
        ``"global"``: several candidate poses per waypoint and dynamic programming over
        them (see the module docstring). Global mode runs the default multi-start solve
        at every waypoint, so it costs about as much as independent solves.
    motion_weight : float
        Global mode: weight ``w`` of ``sum |dq|^2`` [1/mm^2 and 1/rad^2 mixed, as FN^2]
        against ``sum FN^2``; 0 (default) minimises FN only, within the jump limit.
    refine : bool
        When a step cannot be made within ``max_jump``, bisect it and insert the
        intermediate waypoints into the result (to ``REFINE_DEPTH`` = 4 levels: up to 16
        steps in place of one) instead of breaking. The result then has more waypoints
        than ``targets``; ``source`` maps them back. Global mode takes the waypoints of a
        fast refining pass.
    max_depth : int
        Bisection depth of a continuation step's subdivided rung (up to ``2**max_depth``
        warm-started sub-steps, not kept in the result).
    start : array_like, shape (n, 3) or (n, 6), optional
        Pose at the first waypoint (e.g. the robot's current pose; must pass
        :func:`stackik.check.check_pose` for ``targets[0]``). Default: the default solve's
        best pose (fast) or every candidate (global).
    leg_speed, leg_accel : float, optional
        Largest leg speed [mm/s] and acceleration [mm/s^2]: the result's ``times`` are
        waypoint times respecting both (:func:`stackik.paths.time_parameterize`).
    max_candidates : int
        Global mode: candidates kept per waypoint.
    checkpoint : path, optional
        JSON-lines file recording every finished waypoint (fast) or stage (global): a later
        call with the same problem and file continues where it stopped, with the same
        result as an uninterrupted run.
    rng : Generator, int or None
        Seeds the random starts of the default solves (waypoint k gets seed ``s + k``);
        None keeps :func:`stackik.solve.solve_ik`'s fixed seed. Deterministic either way.
    reanchor_every : int or None
        Fast mode: at waypoint ``reanchor_every``, compare the path with the default solve
        of the waypoint; when that pose's FN is lower by more than ``FAST_TRANSIT_GAIN``
        (1 %) and it lies more than ``max_jump`` away, the path moves to its basin by
        transit steps (least FN^2 plus distance to the goal's continuation, within
        ``max_jump``), at most ``TRANSIT_STEPS`` of them. The next check is
        ``reanchor_every`` waypoints after one that moved the path, twice the last gap
        after one that did not (20, 60, 140, ... while the path stays on the best basin
        the default solve finds, or its transit is abandoned before a step). 0 turns it
        off. Default (None):
        ``max(20, 5 n)`` for planar paths (20 at n = 4, 40 at n = 8, 80 at n = 16: the
        default solve's cost grows with n); spatial: 20 up to ``SPATIAL_REANCHOR_N`` = 4
        platforms (a check costs about 20 warm steps), 0 beyond (the default solve's
        starts and hops make a check cost 40-70 warm steps, and on the benchmark's n = 8
        paths it found no better path). Spatial paths: a transit abandoned after steps
        backs off as one abandoned before a step.

    Returns
    -------
    PathResult
        Poses, FN, leg lengths and limit margins per waypoint; ``success``, ``completed``,
        ``status`` and ``message`` say whether and where the path broke.

    Raises
    ------
    ValueError
        Bad input: not a Stack, empty or mixed waypoints, planar waypoints in different
        planes, NaN, ``max_jump`` not a pair of positive numbers, unknown mode, a
        ``start`` of the wrong shape or that misses ``targets[0]``, only one of
        ``leg_speed``/``leg_accel``, non-positive limits, a stack with a finite
        ``force_max`` (paths do not enforce force limits yet).
    """
    t_start = time.perf_counter()
    req = _request(
        stack, targets, max_jump, mode, motion_weight, refine, max_depth, start,
        leg_speed, leg_accel, max_candidates, rng, reanchor_every,
    )  # fmt: skip
    if _load_before_clock(req.planar):  # after the validation: bad input loads nothing
        t_start = time.perf_counter()
    ck = PathCheckpoint(checkpoint, req.key() if checkpoint is not None else {})
    # one BLAS thread, as solve_ik's: the path kernels (the spatial interior point and
    # continuation step, the planar continuation step's solve) call BLAS on small
    # matrices, where multi-threaded OpenBLAS on a loaded machine is up to 300x slower
    # (a spatial n = 16 warm step: 0.4 s instead of 20 ms)
    blas = BlasLimit(1)
    blas.apply()
    try:
        return _solve(req, ck, t_start)
    finally:
        blas.restore()


def _load_before_clock(planar: bool) -> bool:
    """What a path loads once per process, before its clock starts (as :func:`solve_ik`
    does for its kernels, so that :attr:`PathResult.time` is the path's own work): the
    compiled kernels (the path kernels among them: tens of milliseconds to load from
    numba's cache on first use) and the BLAS controller (threadpoolctl scans the loaded
    libraries, ~10 ms). Whether anything was loaded (the clock restarts then)."""
    from stackik.solve.blas import _BLAS, _blas_controller
    from stackik.solve.warmup import ensure_kernels

    loaded = ensure_kernels("planar") > 0.0
    if not planar:
        loaded = ensure_kernels("spatial") > 0.0 or loaded
    if not _BLAS:
        _blas_controller()
        loaded = True
    return loaded


def _solve(req: _Request, ck: PathCheckpoint, t_start: float) -> PathResult:
    tracker = Tracker(req.stack, req.planar, req.max_jump, req.max_depth)
    if req.mode == "fast" or req.refine:
        tl, sl, ql, _, status, message, info = _fast(req, ck, tracker, t_start)
        if req.mode == "fast":
            info.update(tracker.info())
            return _assemble(req, tl, sl, ql, status, message, t_start, info)
        targets_g, sources_g = tl, sl
    else:
        targets_g = list(req.targets)
        sources_g = [float(i) for i in range(len(targets_g))]
    poses, status, message, info = _global(req, ck, tracker, targets_g)
    info.update(tracker.info())
    return _assemble(req, targets_g, sources_g, poses, status, message, t_start, info)
