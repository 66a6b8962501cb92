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

from stackik.formulation.modes import Mode, mode_of
from stackik.rotations import rotation_angle, slerp  # re-exported: the path's rotation rules
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
    if isinstance(targets, PlanarTarget | SpatialTarget):  # one target where a path is due
        raise ValueError("targets: expected a sequence of targets, got a single target")
    try:
        out = list(targets)
    except TypeError:
        raise ValueError(
            f"targets: expected a sequence of targets, got {type(targets).__name__}"
        ) from None
    if not out:
        raise ValueError("targets: the path is empty (give at least one target)")
    modes = []
    for k, t in enumerate(out):
        try:
            modes.append(mode_of(t))
        except ValueError:
            raise ValueError(
                f"targets[{k}]: expected a PlanarTarget or SpatialTarget, got {type(t).__name__}"
            ) from None
    if len(set(modes)) > 1:
        raise ValueError("targets: mixed planar and spatial targets; a path has one kind")
    mode = modes[0]
    phi0 = mode.phi(out[0])  # None for every spatial target
    for k, t in enumerate(out):
        if mode.phi(t) != phi0:
            raise ValueError(
                f"targets[{k}]: phi = {mode.phi(t)!r} differs from targets[0].phi = {phi0!r}; "
                "a planar path stays in one plane"
            )
    return out


def lerp_target(a: Target, b: Target, s: float) -> Target:
    """The target at fraction ``s`` of the way from ``a`` to ``b``.

    Planar: ``(rho, z, theta)`` linear, ``phi`` of ``a``; spatial: position linear,
    orientation :func:`slerp`. ``s = 0`` and ``s = 1`` return ``a`` and ``b`` themselves.
    """
    if s == 0.0:
        return a
    if s == 1.0:
        return b
    return _mode_of_both(a, b, "lerp_target").interpolate(a, b, s)


def target_step(a: Target, b: Target) -> tuple[float, float]:
    """Size of the step from ``a`` to ``b``: (position distance [mm], rotation [rad]).

    Planar: ``|(rho, z)_b - (rho, z)_a|`` and ``|theta_b - theta_a|``; spatial:
    ``|P_b - P_a|`` and the angle of ``R_a^T R_b``.
    """
    return _mode_of_both(a, b, "target_step").step(a, b)


def _mode_of_both(a: Any, b: Any, what: str) -> Mode:
    """The mode of two targets of one kind; a ValueError naming ``what`` otherwise."""
    try:
        mode = mode_of(a)
        if mode_of(b) is mode:
            return mode
    except ValueError:
        pass
    raise ValueError(f"{what}: both targets must be of the same kind")


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
