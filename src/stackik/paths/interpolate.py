"""Waypoint sequences: validation, interpolation between key targets, slerp.

A path is a sequence of end-effector targets of one kind (DESIGN §9): all planar (one
plane ``phi``) or all spatial. Between two targets the path is

* planar: linear in ``(rho, z, theta)`` [mm, mm, rad];
* spatial: linear in the position [mm] and spherical-linear (slerp, the shortest arc) in
  the orientation.

:func:`interpolate_targets` fills key targets with waypoints by a step count or by a
largest step; :func:`lerp_target` is the one interpolation rule (the path solver bisects
a step with it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik.targets import PlanarTarget, SpatialTarget, Target

__all__ = [
    "as_waypoints",
    "interpolate_targets",
    "lerp_target",
    "rotation_angle",
    "slerp",
    "target_step",
]

FloatArray = NDArray[np.float64]


def as_waypoints(targets: Any) -> list[Target]:
    """The waypoints of a path as a list, checked.

    Parameters
    ----------
    targets : sequence of PlanarTarget or SpatialTarget
        At least one target, all of the same kind; planar targets share one ``phi``.

    Raises
    ------
    ValueError
        Empty sequence, an element that is not a target, mixed planar and spatial
        targets, or planar targets in different planes.
    """
    if isinstance(targets, PlanarTarget | SpatialTarget):
        raise ValueError("targets: expected a sequence of targets, got a single target")
    try:
        out = list(targets)
    except TypeError:
        raise ValueError(
            f"targets: expected a sequence of targets, got {type(targets).__name__}"
        ) from None
    if not out:
        raise ValueError("targets: the path is empty (give at least one target)")
    for k, t in enumerate(out):
        if not isinstance(t, PlanarTarget | SpatialTarget):
            raise ValueError(
                f"targets[{k}]: expected a PlanarTarget or SpatialTarget, got {type(t).__name__}"
            )
    kinds = {isinstance(t, PlanarTarget) for t in out}
    if len(kinds) > 1:
        raise ValueError("targets: mixed planar and spatial targets; a path has one kind")
    if isinstance(out[0], PlanarTarget):
        phi0 = out[0].phi
        for k, t in enumerate(out):
            assert isinstance(t, PlanarTarget)
            if t.phi != phi0:
                raise ValueError(
                    f"targets[{k}]: phi = {t.phi!r} differs from targets[0].phi = {phi0!r}; "
                    "a planar path stays in one plane"
                )
    return out


def rotation_angle(Ra: FloatArray, Rb: FloatArray) -> float:
    """Angle of the relative rotation ``Ra^T Rb`` [rad], in ``[0, pi]``."""
    c = (float(np.trace(np.asarray(Ra).T @ np.asarray(Rb))) - 1.0) / 2.0
    return math.acos(min(1.0, max(-1.0, c)))


def slerp(Ra: FloatArray, Rb: FloatArray, s: float) -> FloatArray:
    """Spherical linear interpolation of rotations: ``Ra exp(s log(Ra^T Rb))``.

    Parameters
    ----------
    Ra, Rb : array_like, shape (3, 3)
        Rotation matrices.
    s : float
        Fraction in ``[0, 1]``: 0 gives ``Ra``, 1 gives ``Rb``; the rotation angle from
        ``Ra`` grows linearly with ``s`` along the shortest arc.

    Returns
    -------
    ndarray, shape (3, 3)
    """
    from scipy.spatial.transform import Rotation

    Ra = np.asarray(Ra, dtype=float)
    if s == 0.0:
        return Ra.copy()
    if s == 1.0:
        return np.array(Rb, dtype=float)
    rv = Rotation.from_matrix(Ra.T @ np.asarray(Rb, dtype=float)).as_rotvec()
    R = Ra @ Rotation.from_rotvec(s * rv).as_matrix()
    # re-orthonormalise (SVD) so that the target constructor's 1e-6 test always passes
    U, _, Vt = np.linalg.svd(R)
    return U @ Vt  # type: ignore[no-any-return]


def lerp_target(a: Target, b: Target, s: float) -> Target:
    """The target at fraction ``s`` of the way from ``a`` to ``b``.

    Planar: ``(rho, z, theta)`` linear, ``phi`` of ``a``; spatial: position linear,
    orientation :func:`slerp`. ``s = 0`` and ``s = 1`` return ``a`` and ``b`` themselves.
    """
    if s == 0.0:
        return a
    if s == 1.0:
        return b
    if isinstance(a, PlanarTarget) and isinstance(b, PlanarTarget):
        y = a.y + s * (b.y - a.y)
        return PlanarTarget(float(y[0]), float(y[1]), float(y[2]), a.phi)
    if isinstance(a, SpatialTarget) and isinstance(b, SpatialTarget):
        P = a.position + s * (b.position - a.position)
        return SpatialTarget(P, slerp(a.rotation, b.rotation, s))
    raise ValueError("lerp_target: both targets must be of the same kind")


def target_step(a: Target, b: Target) -> tuple[float, float]:
    """Size of the step from ``a`` to ``b``: (position distance [mm], rotation [rad]).

    Planar: ``|(rho, z)_b - (rho, z)_a|`` and ``|theta_b - theta_a|``; spatial:
    ``|P_b - P_a|`` and the angle of ``R_a^T R_b``.
    """
    if isinstance(a, PlanarTarget) and isinstance(b, PlanarTarget):
        return float(math.hypot(b.rho - a.rho, b.z - a.z)), float(abs(b.theta - a.theta))
    if isinstance(a, SpatialTarget) and isinstance(b, SpatialTarget):
        return (
            float(np.linalg.norm(b.position - a.position)),
            rotation_angle(a.rotation, b.rotation),
        )
    raise ValueError("target_step: both targets must be of the same kind")


def _pair(value: Any, name: str) -> tuple[float, float]:
    """A (mm, rad) pair of positive finite numbers, or a ValueError naming ``name``."""
    try:
        a, b = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a pair (mm, rad), got {value!r}") from None
    if not (math.isfinite(a) and math.isfinite(b)) or a <= 0 or b <= 0:
        raise ValueError(f"{name}: both entries must be finite and > 0, got ({a!r}, {b!r})")
    return a, b


def interpolate_targets(
    keys: Sequence[Target],
    *,
    steps: int | Sequence[int] | None = None,
    max_step: tuple[float, float] | None = None,
) -> list[Target]:
    """Waypoints between key targets, keys included.

    Each segment between consecutive keys is cut into equal steps (planar: linear in
    ``(rho, z, theta)``; spatial: linear position and slerp orientation, see
    :func:`lerp_target`).

    Parameters
    ----------
    keys : sequence of PlanarTarget or SpatialTarget
        Key targets, one kind (planar ones in one plane); one key gives itself.
    steps : int or sequence of int, optional
        Steps per segment (one number for all, or one per segment, each >= 1).
    max_step : (float, float), optional
        Largest step ``(mm, rad)``: each segment gets the fewest equal steps whose position
        step is at most ``max_step[0]`` mm and rotation step at most ``max_step[1]`` rad.
        Give exactly one of ``steps`` and ``max_step``.

    Returns
    -------
    list of targets
        ``1 + sum(steps)`` waypoints; the keys are among them, exactly.

    Raises
    ------
    ValueError
        Bad keys (see :func:`as_waypoints`), both or neither of ``steps`` and
        ``max_step``, a step count < 1, or a non-positive ``max_step``.
    """
    pts = as_waypoints(keys)
    if (steps is None) == (max_step is None):
        raise ValueError("interpolate_targets: give exactly one of steps and max_step")
    nseg = len(pts) - 1
    if steps is not None:
        counts = [steps] * nseg if isinstance(steps, int | np.integer) else list(steps)
        if len(counts) != nseg:
            raise ValueError(f"steps: expected {nseg} step counts (one per segment)")
        for c in counts:
            if isinstance(c, bool) or not isinstance(c, int | np.integer) or c < 1:
                raise ValueError(f"steps: expected integers >= 1, got {c!r}")
    else:
        mm, rad = _pair(max_step, "max_step")
        counts = []
        for a, b in zip(pts[:-1], pts[1:]):
            d, ang = target_step(a, b)
            counts.append(max(1, math.ceil(d / mm - 1e-12), math.ceil(ang / rad - 1e-12)))
    out: list[Target] = [pts[0]]
    for (a, b), c in zip(zip(pts[:-1], pts[1:]), counts):
        out.extend(lerp_target(a, b, j / int(c)) for j in range(1, int(c) + 1))
    return out
