"""stackik: inverse kinematics and sensitivity minimisation of stacked Stewart platforms.

Conventions are those of ``docs/conventions.md``: millimetres and radians; planar poses
``(n, 3)`` with rows ``[rho_i, z_i, theta_i]``; spatial poses ``(n, 6)`` with rows
``[x, y, z, yaw, pitch, roll]`` and ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
"""

from typing import Any

from stackik._version import __version__
from stackik.check import PoseCheck, check_pose
from stackik.clearance import Clearances, clearances
from stackik.convex import ConvexStartError, convex_start
from stackik.families import ConstraintFamily, FamilyError, register_family
from stackik.geometry import GeometryError, PlatformGeometry, Stack
from stackik.kinematics import (
    frobenius_norm,
    lift_planar,
    planar_fn2,
    planar_forward,
    planar_jacobian,
    planar_plate_origins,
    spatial_chain,
    spatial_forward,
    spatial_jacobian,
    spatial_plate_origins,
)
from stackik.loads import (
    GRAVITY,
    Conditioning,
    Load,
    Statics,
    leg_forces,
    statics,
    wrench_conditioning,
)
from stackik.obstacles import Box, Capsule, HalfSpace, Sphere, load_obstacles
from stackik.platform import leg_lengths, leg_vectors, platform_forward_kinematics
from stackik.result import IKResult, IKStatus, OptionError
from stackik.solve import solve_ik, solve_many
from stackik.solve.warmup import warm_up
from stackik.starts import paper_initial_guess
from stackik.targets import PlanarTarget, SpatialTarget, target_from_dict, target_to_dict

__all__ = [
    "__version__",
    "Box",
    "Capacity",
    "Capsule",
    "check_pose",
    "Clearances",
    "clearances",
    "ConfidenceEllipse",
    "Conditioning",
    "ConstraintFamily",
    "convex_start",
    "ConvexStartError",
    "draw_perturbations",
    "f_factor",
    "FamilyError",
    "frobenius_norm",
    "GeometryError",
    "GRAVITY",
    "HalfSpace",
    "IKResult",
    "IKStatus",
    "interpolate_targets",
    "leg_forces",
    "leg_lengths",
    "leg_vectors",
    "lift_planar",
    "linear_covariance",
    "linearity_check",
    "Load",
    "load_obstacles",
    "monte_carlo",
    "MonteCarloResult",
    "nonoptimal_poses",
    "OptionError",
    "paper_initial_guess",
    "payload_capacity",
    "PathResult",
    "PathStatus",
    "planar_fn2",
    "planar_forward",
    "planar_jacobian",
    "planar_plate_origins",
    "PlanarTarget",
    "platform_forward_kinematics",
    "PlatformGeometry",
    "PoseCheck",
    "PoseMonteCarlo",
    "random_feasible_poses",
    "random_reachable_targets",
    "register_family",
    "reproduce",
    "solve_ik",
    "solve_many",
    "solve_path",
    "spatial_chain",
    "spatial_forward",
    "spatial_jacobian",
    "spatial_plate_origins",
    "SpatialTarget",
    "Sphere",
    "Stack",
    "statics",
    "Statics",
    "target_from_dict",
    "target_to_dict",
    "time_parameterize",
    "warm_up",
    "workspace_study",
    "wrench_conditioning",
]

# Analysis names are imported on first use: they pull in scipy.stats and friends.
_LAZY = {
    "monte_carlo": "stackik.analysis",
    "MonteCarloResult": "stackik.analysis",
    "PoseMonteCarlo": "stackik.analysis",
    "ConfidenceEllipse": "stackik.analysis",
    "draw_perturbations": "stackik.analysis",
    "linear_covariance": "stackik.analysis",
    "f_factor": "stackik.analysis",
    "linearity_check": "stackik.analysis",
    "workspace_study": "stackik.analysis.workspace",
    "nonoptimal_poses": "stackik.analysis.workspace",
    "random_reachable_targets": "stackik.analysis.workspace",
    "random_feasible_poses": "stackik.analysis.workspace",
    "reproduce": "stackik.analysis.reproduce",
    "payload_capacity": "stackik.analysis.capacity",
    "Capacity": "stackik.analysis.capacity",
    "solve_path": "stackik.paths",
    "PathResult": "stackik.paths",
    "PathStatus": "stackik.paths",
    "interpolate_targets": "stackik.paths",
    "time_parameterize": "stackik.paths",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'stackik' has no attribute {name!r}")
