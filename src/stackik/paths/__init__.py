"""Paths: continuous least-sensitivity pose sequences along an end-effector path.

:func:`solve_path` solves a sequence of waypoints so that no platform variable jumps by
more than ``max_jump`` between consecutive waypoints (DESIGN §9), in a fast continuation
mode or a global (dynamic programming) mode; :func:`interpolate_targets` makes waypoints
between key targets; :func:`time_parameterize` gives waypoint times under leg speed and
acceleration limits; :mod:`stackik.paths.animate` plots and animates a result (the
``plot`` extra).
"""

from stackik.paths.interpolate import (
    interpolate_targets,
    lerp_target,
    rotation_angle,
    slerp,
    target_step,
)
from stackik.paths.result import MARGIN_NAMES, PathResult, PathStatus, read_path_csv
from stackik.paths.solve import path_arrays, solve_path
from stackik.paths.timing import leg_rates, time_parameterize

__all__ = [
    "MARGIN_NAMES",
    "PathResult",
    "PathStatus",
    "interpolate_targets",
    "leg_rates",
    "lerp_target",
    "path_arrays",
    "read_path_csv",
    "rotation_angle",
    "slerp",
    "solve_path",
    "target_step",
    "time_parameterize",
]
