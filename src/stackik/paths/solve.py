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

Layout: this module is the entry point; :mod:`stackik.paths.request` checks the input,
:mod:`stackik.paths.fast` and :mod:`stackik.paths.global_` are the two modes' drivers
(sharing :mod:`stackik.paths.transit`), :mod:`stackik.paths.reanchor` is fast mode's
move to a better basin, :mod:`stackik.paths.records` the typed records both keep,
:mod:`stackik.paths.replay` their checkpoint records and replay, and
:mod:`stackik.paths.report` the result's arrays and the break diagnosis.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from stackik.geometry import Stack
from stackik.paths.checkpoint import PathCheckpoint
from stackik.paths.continuation import Tracker
from stackik.paths.fast import REFINE_DEPTH, _fast
from stackik.paths.global_ import DEDUPE, _global
from stackik.paths.reanchor import REANCHOR_ITER_PER_N
from stackik.paths.report import _assemble, path_arrays
from stackik.paths.request import (
    MODES,
    REANCHOR_EVERY,
    REANCHOR_PER_N,
    SPATIAL_REANCHOR_N,
    _Request,
    _request,
)
from stackik.paths.result import PathResult
from stackik.paths.transit import (
    FAST_TRANSIT_GAIN,
    GLOBAL_TRANSIT_GAIN,
    TRANSIT_GAIN,
    TRANSIT_STEPS,
)
from stackik.solve.blas import BlasLimit
from stackik.solve.warmup import rows_needed
from stackik.targets import Target

__all__ = [
    "DEDUPE",
    "FAST_TRANSIT_GAIN",
    "GLOBAL_TRANSIT_GAIN",
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
    obstacles: Any = (),
    clearance: float = 0.0,
    load: Any = None,
    constraints: Any = (),
    threads: int | None = None,
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
        Fast mode: every so many waypoints, compare the path with the default solve and
        move to a basin with an FN lower by ``FAST_TRANSIT_GAIN`` (1 %) by transit steps
        within ``max_jump`` (:mod:`stackik.paths.reanchor`: the schedule backs off while
        the path stays on the best basin). 0 turns it off. Default (None): ``max(20, 5 n)``
        planar; spatial 20 up to ``SPATIAL_REANCHOR_N`` = 4 platforms, 0 beyond.
    obstacles, clearance, load
        As :func:`stackik.solve_ik`'s: every waypoint passes the full check with them, and
        the steps carry their rows (a step goes around an obstacle or along a force limit
        within ``max_jump``, else the path breaks there); ``leg_forces`` under ``load``.
    constraints : ConstraintFamily or sequence of ConstraintFamily, optional
        As :func:`stackik.solve_ik`'s (:mod:`stackik.families`): every waypoint keeps them
        (the full check), and the steps' problems carry their rows.
    threads : int or None
        As :func:`stackik.solve_ik`'s: the threads the waypoints' default solves run their
        starts on (None: every CPU the process may use, at most 8; 1: one after another,
        for paths solved in parallel processes). The path does not depend on it.

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
        ``leg_speed``/``leg_accel``, non-positive limits, a malformed ``load``,
        ``obstacles`` or ``clearance``, ``threads`` not a positive integer.
    """
    t_start = time.perf_counter()
    req = _request(
        stack, targets, max_jump, mode, motion_weight, refine, max_depth, start,
        leg_speed, leg_accel, max_candidates, rng, reanchor_every, obstacles, clearance, load,
        constraints, threads,
    )  # fmt: skip
    return _run(req, checkpoint, t_start)


def _run(req: _Request, checkpoint: str | Path | None, t_start: float) -> PathResult:
    """Load what a path needs before its clock starts, open the checkpoint and solve with
    one BLAS thread (``t_start``: when :func:`solve_path` was called)."""
    rows = rows_needed(req.stack, req.clear.obstacles, req.clear.margin, req.constraints)
    if _load_before_clock(req.planar, rows):  # after the validation: bad input loads nothing
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


def _load_before_clock(planar: bool, rows: bool = False) -> bool:
    """What a path loads once per process, before its clock starts (as :func:`solve_ik`
    does for its kernels, so that :attr:`PathResult.time` is the path's own work): the
    compiled kernels (the path kernels among them: tens of milliseconds to load from
    numba's cache on first use) and the BLAS controller (threadpoolctl scans the loaded
    libraries, ~10 ms); with ``rows`` (:func:`stackik.solve.warmup.rows_needed`) the
    path family's twin for problems with rows beyond the limits. Whether anything was loaded (the
    clock restarts then)."""
    from stackik.solve.blas import _BLAS, _blas_controller
    from stackik.solve.warmup import ensure_kernels

    kinds: tuple[str, ...] = ("planar_path",) if planar else ("planar", "spatial_path")
    if rows:
        kinds += ("planar_path_rows",) if planar else ("planar_rows", "spatial_path_rows")
    loaded = sum(ensure_kernels(kind) for kind in kinds) > 0.0
    if not _BLAS:
        _blas_controller()
        loaded = True
    return loaded


def _solve(req: _Request, ck: PathCheckpoint, t_start: float) -> PathResult:
    """Run the mode's driver (global mode with ``refine=True``: over the waypoints of a
    fast refining pass) and assemble the result."""
    tracker = Tracker(
        req.stack, req.planar, req.max_jump, req.max_depth,
        obstacles=req.clear.obstacles, clearance=req.clear.margin, load=req.load,
        constraints=req.constraints,
    )  # fmt: skip
    if req.mode == "fast" or req.refine:
        out = _fast(req, ck, tracker)
        if req.mode == "fast" or not out.poses:  # (global: nothing to refine over)
            out.info.update(tracker.info())
            return _assemble(req, out, t_start)
        targets_g, sources_g = out.targets, out.sources
    else:
        targets_g = list(req.targets)
        sources_g = [float(i) for i in range(len(targets_g))]
    out = _global(req, ck, tracker, targets_g, sources_g)
    out.info.update(tracker.info())
    return _assemble(req, out, t_start)
