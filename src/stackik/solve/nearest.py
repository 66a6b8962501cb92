"""Unreachable planar targets: a pose within every limit, stretched toward the target."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik.check import check_pose
from stackik.formulation import Problem
from stackik.geometry import Stack
from stackik.kinematics import lift_planar, planar_forward
from stackik.methods import Run, RunStatus
from stackik.methods.ip import ip_starts
from stackik.starts import nominal_height, paper_initial_guess
from stackik.targets import PlanarTarget, SpatialTarget, Target

__all__ = [
    "BEYOND_MESSAGE",
    "NEAREST_MAX_T",
    "NEAREST_MESSAGE",
    "NEAREST_STEPS",
    "SPATIAL_NEAREST_MESSAGE",
    "nearest_reachable",
    "stretch_toward",
]

FloatArray = NDArray[np.float64]


def planar_target(y: FloatArray, phi: float) -> PlanarTarget:
    """The planar target ``y = (rho, z, theta)`` in the plane ``phi``."""
    return PlanarTarget(float(y[0]), float(y[1]), float(y[2]), phi)


#: Bisection steps of :func:`_nearest_reachable` (the segment is halved each time).
NEAREST_STEPS = 24
#: Beyond this fraction of the segment the target may still be reachable: the SQP engine
#: decides (starting from the pose reached).
NEAREST_MAX_T = 0.999
NEAREST_MESSAGE = (
    "Unreachable: every interior-point start stalled. q respects every limit and reaches "
    "the point y0 + t (y_target - y0) for the largest t a bisection from the upright pose "
    "y0 found; target_error is what is left [mm]."
)

SPATIAL_NEAREST_MESSAGE = (
    "Unreachable: the first interior-point starts all stalled far from the target. q "
    "respects every limit and is stretched toward the target position in the vertical "
    "plane through it (a bisection of interior-point solves from the upright pose); "
    "target_error is what is left [mm]."
)


def nearest_reachable(
    stack: Stack,
    target: PlanarTarget,
    objective: str,
    weights: tuple[FloatArray, FloatArray] | None,
    options: dict[str, Any],
    deadline: float,
) -> tuple[Run | None, float, int, int]:
    """A pose within every limit that gets as near ``target`` as the segment allows.

    For a target the interior point cannot reach from any start: bisection on ``t`` in
    ``[0, 1]`` over the planar targets ``y(t) = y0 + t (y_target - y0)`` (same phi), from
    the upright pose at nominal height (``y0``, checked feasible) toward the target. Each
    step runs the interior point from the last reached pose and from the paper's guess of
    ``y(t)``; a step succeeds when its pose passes the independent check for ``y(t)``.
    Returns the last reached pose as a :class:`~stackik.methods.Run` checked against
    ``target`` itself (so its violation is the remaining target error), the ``t`` it
    reaches, the iterations and the solves used; ``None`` when the upright pose is not feasible. The
    reachable set need not be convex along the segment: this is a nearby pose within
    limits, not the nearest one.
    """
    from stackik._compiled.check import planar_check

    n = stack.n
    q_lo = np.column_stack([np.zeros(n), nominal_height(stack), np.zeros(n)])
    y0 = planar_forward(q_lo)
    y1 = target.y
    if not planar_check(stack, planar_target(y0, target.phi), q_lo)[0].ok:
        return None, 0.0, 0, 0
    t_lo, t_hi = 0.0, 1.0
    nit = solves = 0
    for _ in range(NEAREST_STEPS):
        left = deadline - time.perf_counter()
        if left <= 0:
            break
        t = 0.5 * (t_lo + t_hi)
        tgt = planar_target(y0 + t * (y1 - y0), target.phi)
        prob = Problem(stack, tgt, objective, weights)
        starts = [q_lo, paper_initial_guess(stack, tgt)]
        batch = ip_starts(prob, starts, options, left)
        nit += batch.nit
        solves += len(starts)
        if batch.best is not None:
            t_lo, q_lo = t, batch.best.q
        else:
            t_hi = t
    chk, P, R, legs = planar_check(stack, target, q_lo)
    obj = Problem(stack, target, objective, weights).objective_value(q_lo)
    run = Run(q_lo, nit, RunStatus.NEAREST, chk, obj, (P, R, legs), "nearest")
    return run, t_lo, nit, solves


BEYOND_MESSAGE = (
    "Unreachable: the target lies beyond the reach bound of the stack. The reach bound is "
    "the sum over platforms of leg_max and the node radii; q respects every limit and is "
    "stretched toward the target along the segment from the upright pose (a bisection of "
    "interior-point solves; spatial targets: in the vertical plane through the target "
    "position); target_error is what is left [mm]."
)


def stretch_toward(
    stack: Stack,
    target: Target,
    objective: str,
    weights: tuple[FloatArray, FloatArray] | None,
    options: dict[str, Any],
    deadline: float,
) -> tuple[Run | None, float, int, int]:
    """A pose within every limit stretched toward an unreachable target.

    Planar targets: :func:`nearest_reachable`. Spatial targets: the same bisection in the
    vertical plane through the target position (``phi = atan2(y, x)``, ``theta = 0``), the
    planar pose lifted to 6 variables per platform and checked against the spatial target.
    Returns the run (None when the upright pose itself is infeasible), the fraction ``t``
    of the segment it reaches, the iterations and the solves used.
    """
    from stackik.methods.ip import IP_DEFAULTS
    from stackik.rotations import euler_zyx_from_matrix

    ip_opts = {k: v for k, v in options.items() if k in IP_DEFAULTS}
    uniform = weights is None or float(np.ptp(weights[1])) == 0.0
    obj, w = (objective, weights) if uniform else ("frobenius", None)
    if isinstance(target, PlanarTarget):
        return nearest_reachable(stack, target, obj, w, ip_opts, deadline)
    assert isinstance(target, SpatialTarget)
    P = target.position
    phi = float(np.arctan2(P[1], P[0])) if np.hypot(P[0], P[1]) > 0 else 0.0
    plane = PlanarTarget(float(np.hypot(P[0], P[1])), float(P[2]), 0.0, phi)
    run, t, nit, solves = nearest_reachable(stack, plane, obj, w, ip_opts, deadline)
    if run is None:
        return None, t, nit, solves
    Pi, Ri = lift_planar(run.q, phi)
    q = np.column_stack([Pi, euler_zyx_from_matrix(Ri)])
    chk = check_pose(stack, target, q)
    value = Problem(stack, target, objective, weights).objective_value(q)
    return Run(q, nit, RunStatus.NEAREST, chk, value, None, "nearest"), t, nit, solves
