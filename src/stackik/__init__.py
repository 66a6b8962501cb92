"""stackik: inverse kinematics and sensitivity minimisation of stacked Stewart platforms.

Conventions are those of ``docs/conventions.md``: millimetres and radians; planar poses
``(n, 3)`` with rows ``[rho_i, z_i, theta_i]``; spatial poses ``(n, 6)`` with rows
``[x, y, z, yaw, pitch, roll]`` and ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
"""

from stackik.convex import ConvexStartError, convex_start
from stackik.geometry import GeometryError, PlatformGeometry, Stack
from stackik.ik import (
    IKResult,
    IKStatus,
    PlanarTarget,
    PoseCheck,
    SpatialTarget,
    check_pose,
    paper_initial_guess,
    solve_ik,
    solve_many,
)
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
from stackik.platform import leg_lengths, leg_vectors, platform_forward_kinematics

__version__ = "0.1.0"

__all__ = [
    "ConvexStartError",
    "GeometryError",
    "IKResult",
    "IKStatus",
    "PlanarTarget",
    "PlatformGeometry",
    "PoseCheck",
    "SpatialTarget",
    "Stack",
    "__version__",
    "check_pose",
    "convex_start",
    "frobenius_norm",
    "leg_lengths",
    "leg_vectors",
    "lift_planar",
    "paper_initial_guess",
    "planar_fn2",
    "planar_forward",
    "planar_jacobian",
    "planar_plate_origins",
    "platform_forward_kinematics",
    "solve_ik",
    "solve_many",
    "spatial_chain",
    "spatial_forward",
    "spatial_jacobian",
    "spatial_plate_origins",
]
