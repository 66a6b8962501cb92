"""Compatibility module: the names that used to live here, re-exported.

``stackik.ik`` was the whole IK layer; it is now split into :mod:`stackik.targets`,
:mod:`stackik.result`, :mod:`stackik.check`, :mod:`stackik.formulation`,
:mod:`stackik.starts`, :mod:`stackik.methods` and :mod:`stackik.solve` (see
``docs/architecture.md``). Nothing inside the package imports this module.
"""

from stackik.check import FEAS_TOL, TARGET_ANGLE_TOL, TARGET_POS_TOL, PoseCheck, check_pose
from stackik.result import IKResult, IKStatus, OptionError
from stackik.solve import solve_ik, solve_many
from stackik.starts import SPATIAL_STARTS, fold_depth, paper_initial_guess, tall_random_starts
from stackik.targets import (
    PlanarTarget,
    SpatialTarget,
    Target,
    target_from_dict,
    target_to_dict,
)

__all__ = [
    "FEAS_TOL",
    "SPATIAL_STARTS",
    "TARGET_ANGLE_TOL",
    "TARGET_POS_TOL",
    "IKResult",
    "IKStatus",
    "OptionError",
    "PlanarTarget",
    "PoseCheck",
    "SpatialTarget",
    "Target",
    "check_pose",
    "fold_depth",
    "paper_initial_guess",
    "solve_ik",
    "solve_many",
    "tall_random_starts",
    "target_from_dict",
    "target_to_dict",
]
