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
    previous one. The path follows one local optimum; FN is that of the followed branch.

``"global"`` (Descartes-style)
    Candidates per waypoint: the default solve's best pose, the continuation of every
    candidate of the previous waypoint, and the backward continuation of default poses
    that nothing before reaches; deduplicated, at most ``max_candidates``. Then dynamic
    programming (Viterbi) over the candidates minimises
    ``sum_k FN_k^2 + motion_weight * sum_k |q_{k+1} - q_k|^2`` over the sequences whose
    every step is within ``max_jump`` (``|dq|^2`` mixes mm^2 and rad^2, as FN^2 does).

When no continuation within ``max_jump`` exists, the path breaks: the result says at which
waypoint (``completed``), why (``status``: the waypoint is outside the workspace, or
reachable only by a pose farther than ``max_jump``) and which limit was tightest.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.check import check_pose
from stackik.geometry import Stack
from stackik.kinematics import planar_plate_origins, spatial_chain
from stackik.paths.checkpoint import PathCheckpoint
from stackik.paths.continuation import Step, Tracker
from stackik.paths.interpolate import _pair, as_waypoints, lerp_target
from stackik.paths.result import MARGIN_NAMES, PATH_MESSAGES, PathResult, PathStatus
from stackik.paths.timing import time_parameterize
from stackik.platform import planar_legs, spatial_legs
from stackik.solve import solve_ik
from stackik.targets import PlanarTarget, Target, target_from_dict, target_to_dict

__all__ = ["DEDUPE", "MODES", "REFINE_DEPTH", "path_arrays", "solve_path"]

FloatArray = NDArray[np.float64]

MODES = ("fast", "global")
#: Candidates closer than this (in units of max_jump, per variable) are one candidate.
DEDUPE = 1e-3
#: Bisection levels of ``refine=True``: up to 16 inserted steps per input step.
REFINE_DEPTH = 4


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
        }

    def default_solve(self, target: Target, index: int) -> Any:
        rng = None if self.seed is None else self.seed + index
        return solve_ik(self.stack, target, rng=rng)


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
) -> _Request:
    if not isinstance(stack, Stack):
        raise ValueError(f"stack: expected a Stack, got {type(stack).__name__}")
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
    seed = None
    if rng is not None:
        try:
            seed = int(np.random.default_rng(rng).integers(2**31))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"rng: expected None, an int seed or a Generator ({exc})") from None
    return _Request(
        stack, pts, planar, k, mj, mode, w, refine, max_depth, q0, speeds[0], speeds[1],
        max_candidates, seed,
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
    if isinstance(t0, PlanarTarget):
        O = planar_plate_origins(Q)  # (m, n+1, 2)
        d = O[:, -1:, :] - O[:, 1:-1, :]
        fn = np.sqrt(3 * n + np.sum(d**2, axis=(1, 2)))
        l, Rn, _, _ = planar_legs(stack, Q, t0.phi)
    else:
        fn = np.array([math.sqrt(spatial_chain(qk).weighted_norm2()) for qk in Q])
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
def _fast(
    req: _Request, ck: PathCheckpoint, tracker: Tracker, t_start: float
) -> tuple[list[Target], list[float], list[FloatArray], list[str], PathStatus, str, dict]:
    info: dict[str, Any] = {"default": 0}
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
            r0 = req.default_solve(pts[0], 0)
            info["default"] += 1
            if not r0.success:
                msg = (
                    f"the path breaks at index 0 (waypoint 0): no pose reaches it within the "
                    f"limits ({r0.status.value}, target error {r0.target_error:.3g} mm)"
                )
                return [], [], [], [], PathStatus.UNREACHABLE, msg, info
            q0, how = r0.q, "default"
        ck.put("fast", 0, {"q": q0.tolist(), "how": how, "pending": []})
        rec = ck.get("fast", 0)
    j = 0
    refined: list[tuple[Target, float, int]] = []
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
        j += 1
        rec = ck.get("fast", j)
    # pending: a stack of (target, source, depth); the top is the next waypoint to reach
    inputs_left = {s for _, s, _ in refined}
    pending: list[tuple[Target, float, int]] = [
        (pts[i], float(i), 0) for i in range(m - 1, int(sl[-1]), -1) if i not in inputs_left
    ]
    pending += refined
    status, message = PathStatus.SUCCESS, PATH_MESSAGES[PathStatus.SUCCESS]
    while pending:
        tb, sb, depth = pending[-1]
        step: Step | None = tracker.step(ql[-1], tl[-1], tb, subdivide=hows[-1] != "bounded")
        if step is not None:
            pending.pop()
            tl.append(tb)
            sl.append(sb)
            ql.append(step.q)
            hows.append(step.how)
            top = [(target_to_dict(t), s, d) for t, s, d in pending if d > 0]
            ck.put(
                "fast",
                len(ql) - 1,
                {
                    "target": target_to_dict(tb),
                    "source": sb,
                    "q": step.q.tolist(),
                    "how": step.how,
                    "pending": top,
                },
            )
            continue
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


# =========================================================================================
# Global mode
# =========================================================================================
@dataclass(eq=False)  # identity: candidates hold arrays
class _Cand:
    q: FloatArray
    fn2: float
    origin: str  # "default", "start", "forward", "backward"
    how: str  # rung of the continuation that produced it ("" for default/start)


def _fn2(req: _Request, q: FloatArray) -> float:
    return float(path_arrays(req.stack, req.targets[:1], q[None])["frobenius_norm"][0] ** 2)


def _add(cands: list[_Cand], c: _Cand, tracker: Tracker) -> bool:
    """Append ``c`` unless a candidate within DEDUPE exists; True if appended."""
    for o in cands:
        if tracker.ratio(o.q, c.q) <= DEDUPE:
            if c.fn2 < o.fn2 - 1e-12 * o.fn2:  # keep the better twin
                o.q, o.fn2 = c.q, c.fn2
            return False
    cands.append(c)
    return True


def _cap(cands: list[_Cand], k: int) -> list[_Cand]:
    if len(cands) <= k:
        return cands
    keep = [c for c in cands if c.origin in ("default", "start")][:1]
    rest = sorted((c for c in cands if c not in keep), key=lambda c: c.fn2)
    return keep + rest[: k - len(keep)]


def _cand_record(cands: list[_Cand]) -> list[Any]:
    return [[c.q.tolist(), c.fn2, c.origin, c.how] for c in cands]


def _cand_load(rec: list[Any]) -> list[_Cand]:
    return [_Cand(np.array(q, dtype=float), float(f), str(o), str(h)) for q, f, o, h in rec]


def _global(
    req: _Request,
    ck: PathCheckpoint,
    tracker: Tracker,
    targets: list[Target],
) -> tuple[list[FloatArray], PathStatus, str, dict[str, Any]]:
    info: dict[str, Any] = {"default": 0}
    m = len(targets)
    # 1. the default (multi-start) solve of every waypoint
    D: list[_Cand | None] = []
    for k, t in enumerate(targets):
        rec = ck.get("default", k)
        if rec is None:
            r = req.default_solve(t, k)
            info["default"] += 1
            rec = [r.q.tolist(), float(r.frobenius_norm) ** 2] if r.success else None
            ck.put("default", k, rec if rec is not None else [])
        D.append(_Cand(np.array(rec[0]), float(rec[1]), "default", "") if rec else None)
    # 2. forward sweep: continuations of every candidate, plus the default pose
    C: list[list[_Cand]] = []
    for k, t in enumerate(targets):
        rec = ck.get("forward", k)
        if rec is not None:
            C.append(_cand_load(rec))
            continue
        cands: list[_Cand] = []
        if k == 0:
            if req.start is not None:
                cands.append(_Cand(req.start, _fn2(req, req.start), "start", ""))
            elif D[0] is not None:
                cands.append(D[0])
        else:
            dk = D[k]
            if dk is not None:
                cands.append(dk)
            for c in C[k - 1]:
                st = tracker.step(c.q, targets[k - 1], t, subdivide=c.how != "bounded")
                if st is not None:
                    _add(cands, _Cand(st.q, _fn2(req, st.q), "forward", st.how), tracker)
        cands = _cap(cands, req.max_candidates)
        ck.put("forward", k, _cand_record(cands))
        C.append(cands)
    # 3. backward sweep: default poses with no predecessor within max_jump are continued
    #    backwards (warm and subdivided rungs: along their own branch) until they connect
    rec = ck.get("backward", 0)
    if rec is not None:
        C = [_cand_load(r) for r in rec]
    elif req.start is None:
        for k in range(m - 1, 0, -1):
            for c in list(C[k]):
                if c.origin not in ("default", "backward"):
                    continue
                if any(tracker.ratio(p.q, c.q) <= 1.0 for p in C[k - 1]):
                    continue
                st = tracker.step(c.q, targets[k], targets[k - 1], bounded=False)
                if st is not None:
                    _add(C[k - 1], _Cand(st.q, _fn2(req, st.q), "backward", st.how), tracker)
        ck.put("backward", 0, [_cand_record(c) for c in C])
    info["candidates_mean"] = float(np.mean([len(c) for c in C])) if C else 0.0
    info["candidates_max"] = max((len(c) for c in C), default=0)
    # 4. dynamic programming over the candidates
    w = req.motion_weight
    cost = np.array([c.fn2 for c in C[0]]) if C[0] else np.zeros(0)
    back: list[NDArray[np.int64]] = []
    reached = 0 if cost.size == 0 else 1
    for k in range(1, m):
        prev, cur = C[k - 1], C[k]
        new = np.full(len(cur), np.inf)
        arg = np.full(len(cur), -1, dtype=np.int64)
        for j, cj in enumerate(cur):
            for i, pi in enumerate(prev):
                if not np.isfinite(cost[i]) or tracker.ratio(pi.q, cj.q) > 1.0:
                    continue
                v = cost[i] + cj.fn2 + w * float(np.sum((cj.q - pi.q) ** 2))
                if v < new[j]:
                    new[j], arg[j] = v, i
        if not np.any(np.isfinite(new)):
            break
        back.append(arg)
        cost = new
        reached = k + 1
    poses: list[FloatArray] = []
    if reached:
        j = int(np.argmin(cost))
        for k in range(reached - 1, -1, -1):
            poses.append(C[k][j].q)
            if k > 0:
                j = int(back[k - 1][j])
        poses.reverse()
    if reached == m:
        return poses, PathStatus.SUCCESS, PATH_MESSAGES[PathStatus.SUCCESS], info
    t = targets[reached]
    status, message = _break(
        req, tracker, reached, t, float(reached), poses[-1] if poses else None, info
    )
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
        ``leg_speed``/``leg_accel``, non-positive limits.
    """
    t_start = time.perf_counter()
    req = _request(
        stack, targets, max_jump, mode, motion_weight, refine, max_depth, start,
        leg_speed, leg_accel, max_candidates, rng,
    )  # fmt: skip
    ck = PathCheckpoint(checkpoint, req.key())
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
