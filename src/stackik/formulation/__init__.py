"""Formulation: the scaled NLP of a request, per-mode evaluation and scalings.

Layer above the kinematics and the check, below the methods and the solve pipeline.
"""

from stackik.formulation.modes import PLANAR, SPATIAL, Mode, mode_of, reach_bound
from stackik.formulation.planar import PlanarEvaluator
from stackik.formulation.problem import (
    POLISH_MARGIN,
    POLISH_REACH,
    Problem,
    polish,
    problem_scalings,
)

__all__ = [
    "PLANAR",
    "POLISH_MARGIN",
    "POLISH_REACH",
    "SPATIAL",
    "Mode",
    "PlanarEvaluator",
    "Problem",
    "mode_of",
    "polish",
    "problem_scalings",
    "reach_bound",
]
