"""Result assembly of a path solve: per-waypoint FN, legs and margins, and the break
diagnosis (status and message of a path that cannot go on)."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.check import FEAS_TOL
from stackik.formulation.modes import mode_of
from stackik.geometry import Stack
from stackik.kinematics import planar_fn2, spatial_chain
from stackik.paths.continuation import Tracker
from stackik.paths.records import _Outcome
from stackik.paths.request import _Request
from stackik.paths.result import MARGIN_NAMES, PathResult, PathStatus
from stackik.paths.timing import time_parameterize
from stackik.platform import spatial_legs
from stackik.targets import PlanarTarget, Target

__all__ = ["path_arrays"]

FloatArray = NDArray[np.float64]


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


def _assemble(req: _Request, out: _Outcome, t_start: float) -> PathResult:
    """The result of a mode's outcome (``t_start``: when the path's clock started)."""
    targets, sources, poses, status = out.targets, out.sources, out.poses, out.status
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
    forces = _leg_forces(req, targets, Q, c)
    for a in (Q, fn, legs, margins) + tuple(x for x in (times, forces) if x is not None):
        a.setflags(write=False)
    src = np.array(sources, dtype=float)
    src.setflags(write=False)
    return PathResult(
        targets=tuple(targets),
        q=Q,
        success=status is PathStatus.SUCCESS,
        completed=c,
        status=status,
        message=out.message,
        frobenius_norm=fn,
        leg_lengths=legs,
        margins=margins,
        max_jump=req.max_jump,
        mode=req.mode,
        source=src,
        times=times,
        time=time.perf_counter() - t_start,
        info=out.info,
        leg_forces=forces,
    )


def _leg_forces(req: _Request, targets: Sequence[Target], Q: FloatArray, c: int) -> Any:
    """Leg forces (m, n, 6) [N] of the ``c`` reached poses under the path's load (NaN
    after), when a load was given or some ``force_max`` is finite; else None."""
    from stackik.formulation.forces import force_limited
    from stackik.loads import leg_forces

    if req.load is None and not force_limited(req.stack):
        return None
    out = np.full(Q.shape[:2] + (6,), np.nan)
    phi = mode_of(targets[0]).phi(targets[0])
    for j in range(c):
        out[j] = leg_forces(req.stack, Q[j], req.load, phi=phi)
    return out


def _source_text(s: float) -> str:
    if float(s).is_integer():
        return f"waypoint {int(s)}"
    lo = math.floor(s)
    return f"an inserted waypoint at {s - lo:.4g} of the way from waypoint {lo} to {lo + 1}"


def unreachable_message(req: _Request, r: Any, where: str) -> str:
    """Why a waypoint's default solve ``r`` (no success) found no pose: its clearances when
    they fail (obstacles, bodies, the margin), else the workspace."""
    cl = r.clearances
    if cl is not None and cl.minimum < req.clear.margin - FEAS_TOL:
        return (
            f"{where}: no pose found reaches it within the limits and clear of the "
            f"obstacles and the other bodies ({r.status.value}: the least-violating "
            f"pose misses the target by {r.target_error:.3g} mm, its closest pair is "
            f"{cl.closest}, margin {req.clear.margin:g} mm)"
        )
    return (
        f"{where}: no pose reaches it within the limits ({r.status.value}: the target "
        f"is outside the workspace, target error {r.target_error:.3g} mm)"
    )


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
        return PathStatus.UNREACHABLE, unreachable_message(req, r, where)
    assert q_prev is not None
    far = tracker.ratio(q_prev, r.q)
    hint = "" if req.refine else "; finer waypoints or refine=True may get through"
    return PathStatus.JUMP, (
        f"{where}: the waypoint is reachable, but no pose within max_jump "
        f"({req.max_jump[0]:g} mm, {req.max_jump[1]:g} rad) of the pose at index {index - 1} "
        f"reaches it (its least-FN pose is {far:.2f} x max_jump away; "
        f"{_tightest(req.stack, target, q_prev)}){hint}"
    )


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
