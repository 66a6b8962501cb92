"""The independent check: the one place that decides whether a pose is a success.

:func:`check_pose` re-evaluates a pose with the forward kinematics of
:mod:`stackik.kinematics` and the constraint functions of :mod:`stackik.platform`, sharing no
code with any solver. :func:`pose_ok` holds the acceptance rule; the compiled twin
(:mod:`stackik._compiled.check`) imports only this module.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.geometry import Stack
from stackik.kinematics import planar_forward, spatial_forward
from stackik.targets import PlanarTarget, Target

__all__ = [
    "FEAS_TOL",
    "TARGET_ANGLE_TOL",
    "TARGET_POS_TOL",
    "PoseCheck",
    "check_pose",
    "pose_ok",
    "poses_ok",
]

FloatArray = NDArray[np.float64]

TARGET_POS_TOL = 1e-6  # [mm] largest accepted end-effector position error
TARGET_ANGLE_TOL = 1e-8  # [rad] largest accepted end-effector orientation error
FEAS_TOL = 1e-6  # [mm] accepted violation of a limit, as a length (see check_pose)


def pose_ok(position_error: float, angle_error: float, violation_mm: float, finite: bool) -> bool:
    """The acceptance rule of every pose: target within ``TARGET_POS_TOL`` [mm] and
    ``TARGET_ANGLE_TOL`` [rad], every limit within ``FEAS_TOL`` [mm], all values finite."""
    return (
        position_error <= TARGET_POS_TOL
        and angle_error <= TARGET_ANGLE_TOL
        and violation_mm <= FEAS_TOL
        and bool(finite)
    )


def poses_ok(
    position_error: ArrayLike, angle_error: ArrayLike, violation_mm: ArrayLike, finite: ArrayLike
) -> NDArray[np.bool_]:
    """:func:`pose_ok` elementwise (arrays of the same shape), as a boolean array."""
    return (  # type: ignore[no-any-return]
        (np.asarray(position_error) <= TARGET_POS_TOL)
        & (np.asarray(angle_error) <= TARGET_ANGLE_TOL)
        & (np.asarray(violation_mm) <= FEAS_TOL)
        & np.asarray(finite, dtype=bool)
    )


@dataclass(frozen=True)
class PoseCheck:
    """Independent check of a pose against a target (see :func:`check_pose`).

    Attributes
    ----------
    ok : bool
        True iff every error is within tolerance.
    position_error : float
        ``|P_ee - P_target|`` [mm].
    angle_error : float
        Orientation error [rad] (planar: ``|theta_ee - theta|``; spatial: rotation angle).
    max_violation : float
        Worst raw violation ``max(0, -c)`` over all 24n constraints (mm^2 or mm).
    max_violation_mm : float
        The same as a length [mm]: leg-length blocks converted by ``|l| - limit``.
    constraints : ndarray, shape (n, 24)
        Raw constraint values.
    """

    ok: bool
    position_error: float
    angle_error: float
    max_violation: float
    max_violation_mm: float
    constraints: FloatArray


def so3_log(R: FloatArray) -> FloatArray:
    """Rotation vector of R (angle in [0, pi])."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(R).as_rotvec()  # type: ignore[no-any-return]


def check_pose(stack: Stack, target: Target, q: ArrayLike) -> PoseCheck:
    """Check a pose against a target and every limit, independently of any solver.

    Uses only :func:`stackik.planar_forward` / :func:`stackik.spatial_forward` and
    :meth:`Stack.planar_constraints` / :meth:`Stack.spatial_constraints`. Tolerances:
    ``TARGET_POS_TOL`` = 1e-6 mm, ``TARGET_ANGLE_TOL`` = 1e-8 rad, ``FEAS_TOL`` = 1e-6 mm
    (leg-length blocks are compared as lengths: ``|l| >= leg_min - FEAS_TOL``).
    """
    qa = np.asarray(q, dtype=float)
    if isinstance(target, PlanarTarget):
        y = planar_forward(qa)
        pos_err = float(np.hypot(y[0] - target.rho, y[1] - target.z))
        ang_err = float(abs(y[2] - target.theta))
        c = stack.planar_constraints(qa, target.phi)
    else:
        P, R = spatial_forward(qa)
        pos_err = float(np.linalg.norm(P - target.position))
        ang_err = float(np.linalg.norm(so3_log(target.rotation.T @ R)))
        c = stack.spatial_constraints(qa)
    viol = np.maximum(-c, 0.0)
    max_v = float(viol.max())
    # as lengths: |l|^2 - lmin^2 = -v  ->  lmin - |l| = lmin - sqrt(lmin^2 - v)
    lmin = stack.leg_min[:, None]
    lmax = stack.leg_max[:, None]
    v_min = lmin - np.sqrt(np.maximum(lmin**2 - viol[:, 0:6], 0.0))
    v_max = np.sqrt(lmax**2 + viol[:, 6:12]) - lmax
    v_mm = float(max(v_min.max(), v_max.max(), viol[:, 12:].max()))
    ok = pose_ok(pos_err, ang_err, v_mm, bool(np.all(np.isfinite(c))))
    return PoseCheck(ok, pos_err, ang_err, max_v, v_mm, c)
