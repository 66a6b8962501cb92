"""The independent check: the one place that decides whether a pose is a success.

:func:`check_pose` re-evaluates a pose with the forward kinematics of
:mod:`stackik.kinematics`, the constraint functions of :mod:`stackik.platform`, (under a
load or a force limit) the leg forces of :mod:`stackik.loads` and the exact distances of
:mod:`stackik.clearance`, sharing no code with any solver. :func:`pose_ok` holds the
acceptance rule; the compiled twin (:mod:`stackik._compiled.check`) imports only this module (it
checks the limits and the target, not the forces or clearances: those are needed only
with a load or force limit, with obstacles, a leg radius, a plate thickness or a margin
(:func:`stackik.clearance.needs_clearances`), or where a leg's axis passes through a
plate (:func:`stackik.clearance.cores_cross`)).

A user's constraint families (:mod:`stackik.families`) are the one exception to the
independence: the check judges their own ``check_values`` (the rows the solvers see,
unless the family gives an independent form), as the family's author defined them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.clearance import Clearances, clearances, cores_cross, needs_clearances
from stackik.families import ConstraintFamily, as_families, check_values_of
from stackik.geometry import Stack, finite_number
from stackik.kinematics import planar_forward, spatial_forward
from stackik.loads import Load, Statics, statics
from stackik.obstacles import Obstacle, as_obstacles
from stackik.targets import PlanarTarget, Target

__all__ = [
    "FEAS_TOL",
    "FORCE_TOL",
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
FORCE_TOL = 1e-6  # accepted leg force over its limit, relative: |f| <= (1 + FORCE_TOL) force_max


def pose_ok(
    position_error: float,
    angle_error: float,
    violation_mm: float,
    finite: bool,
    force_ratio: float = 0.0,
) -> bool:
    """The acceptance rule of every pose: target within ``TARGET_POS_TOL`` [mm] and
    ``TARGET_ANGLE_TOL`` [rad], every limit within ``FEAS_TOL`` [mm], all values finite,
    and every leg force within its limit: ``force_ratio = max |f| / force_max <= 1 +
    FORCE_TOL`` (0 when forces are not checked; inf at a singular platform)."""
    return (
        position_error <= TARGET_POS_TOL
        and angle_error <= TARGET_ANGLE_TOL
        and violation_mm <= FEAS_TOL
        and bool(finite)
        and force_ratio <= 1.0 + FORCE_TOL
    )


def poses_ok(
    position_error: ArrayLike,
    angle_error: ArrayLike,
    violation_mm: ArrayLike,
    finite: ArrayLike,
    force_ratio: ArrayLike = 0.0,
) -> NDArray[np.bool_]:
    """:func:`pose_ok` elementwise (arrays of the same shape), as a boolean array."""
    return (  # type: ignore[no-any-return]
        (np.asarray(position_error) <= TARGET_POS_TOL)
        & (np.asarray(angle_error) <= TARGET_ANGLE_TOL)
        & (np.asarray(violation_mm) <= FEAS_TOL)
        & np.asarray(finite, dtype=bool)
        & (np.asarray(force_ratio) <= 1.0 + FORCE_TOL)
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
    peak_force_ratio : float
        ``max |f| / force_max`` over every leg (0 where ``force_max`` is inf; inf at a
        singular platform); 0 when leg forces were not checked.
    statics : Statics or None
        Leg forces, margins and singularity measure (:func:`stackik.statics`) when they
        were checked (a load was given or some ``force_max`` is finite), else None.
    clearances : Clearances or None
        Signed distances of the pose's bodies and obstacles [mm]; None when the check
        did not need them (no obstacle, zero leg radii and plate thickness, margin 0, and
        no leg's axis or plate through a plate: every clearance is then >= 0).
    clearance_violation : float
        ``max(0, clearance - clearances.minimum)`` [mm] (0 when not computed).
    family_violation : float
        ``max(0, -c)`` over the rows of the constraint families checked (in their unit,
        :meth:`stackik.ConstraintFamily.check_values`; 0 without any).
    """

    ok: bool
    position_error: float
    angle_error: float
    max_violation: float
    max_violation_mm: float
    constraints: FloatArray
    peak_force_ratio: float = 0.0
    statics: Statics | None = None
    clearances: Clearances | None = None
    clearance_violation: float = 0.0
    family_violation: float = 0.0

    @property
    def violation_mm(self) -> float:
        """The worst shortfall as a length [mm]: limits, clearances and constraint
        families (what ranks the least-violating pose of a solve that found no passing
        one)."""
        return max(self.max_violation_mm, self.clearance_violation, self.family_violation)


def so3_log(R: FloatArray) -> FloatArray:
    """Rotation vector of R (angle in [0, pi])."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(R).as_rotvec()  # type: ignore[no-any-return]


def check_pose(
    stack: Stack,
    target: Target,
    q: ArrayLike,
    load: Load | None = None,
    *,
    obstacles: Sequence[Obstacle] | Obstacle | None = (),
    clearance: float = 0.0,
    constraints: Sequence[ConstraintFamily] | ConstraintFamily | None = (),
) -> PoseCheck:
    """Check a pose against a target, every limit, every force limit and every clearance,
    independently of any solver.

    Uses only :func:`stackik.planar_forward` / :func:`stackik.spatial_forward`,
    :meth:`Stack.planar_constraints` / :meth:`Stack.spatial_constraints`, for the leg
    forces :func:`stackik.statics` and :func:`stackik.clearances`. Tolerances:
    ``TARGET_POS_TOL`` = 1e-6 mm, ``TARGET_ANGLE_TOL`` = 1e-8 rad, ``FEAS_TOL`` = 1e-6 mm
    (leg-length blocks are compared as lengths: ``|l| >= leg_min - FEAS_TOL``; clearances
    likewise: ``clearances.minimum >= clearance - FEAS_TOL``), ``FORCE_TOL`` = 1e-6
    (``|f| <= (1 + FORCE_TOL) force_max``).

    Leg forces are checked when ``load`` is given or some platform's ``force_max`` is
    finite (``load=None`` then means the stack's own weight under earth gravity): every
    force must be finite (no singular platform) and within its limit. Otherwise (no load,
    no limit) they are not computed and the verdict is that of the limits alone.

    Parameters
    ----------
    stack : Stack
    target : PlanarTarget or SpatialTarget
    q : array_like, shape (n, 3) or (n, 6)
    load : Load, optional
        Payload, external wrench and gravity (:class:`stackik.Load`).
    obstacles : sequence of Obstacle, optional
        Keep-out bodies in the base frame [mm].
    clearance : float, optional
        Margin [mm] >= 0 every signed distance must keep (default 0: touching passes, any
        penetration fails). Legs of zero radius that cross exactly are at distance 0, but
        a leg's axis through a plate, or two plates through each other, are at minus their
        penetration depth even with no thickness: with zero radii, zero thickness, no
        obstacle and margin 0 the clearances are computed only where such cores cross
        (:func:`stackik.clearance.cores_cross`; else ``PoseCheck.clearances`` is None).
    constraints : sequence of ConstraintFamily, optional
        A user's constraint families (:mod:`stackik.families`): each row of
        :meth:`~stackik.ConstraintFamily.check_values` must be ``>= -FEAS_TOL`` (in the
        family's unit; ``PoseCheck.family_violation``). These are the user's own
        definitions: the check has no independent implementation of them.

    Raises
    ------
    ValueError
        A malformed ``obstacles`` or ``clearance``, or an obstacle that collides with the
        base (every pose would).
    """
    obs = as_obstacles(obstacles)
    fams = as_families(constraints)
    margin = finite_number(clearance, "clearance")
    if margin < 0:
        raise ValueError(f"clearance: must be >= 0 mm, got {margin}")
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
    finite = bool(np.all(np.isfinite(c)))
    st = None
    ratio = 0.0
    phi = target.phi if isinstance(target, PlanarTarget) else None
    if load is not None or bool(np.isfinite(stack.force_max).any()):
        st = statics(stack, qa, load, phi=phi)
        ratio = st.peak_force_ratio
        finite = finite and bool(np.all(np.isfinite(st.leg_forces)))
    cl, v_cl = None, 0.0
    if needs_clearances(stack, obs, margin) or (finite and cores_cross(stack, qa, phi)):
        if finite:
            cl = clearances(stack, qa, obs, phi=phi)
            v_cl = max(0.0, margin - cl.minimum)
        else:  # no distances of a non-finite pose (it fails on its limits anyway)
            v_cl = float("inf")
    v_fam = 0.0
    for f in fams:
        vals = check_values_of(f, stack, qa, phi)
        v_fam = max(v_fam, float(np.max(-vals, initial=0.0)))
        finite = finite and bool(np.all(np.isfinite(vals)))
    ok = pose_ok(pos_err, ang_err, max(v_mm, v_cl, v_fam), finite, ratio)
    return PoseCheck(ok, pos_err, ang_err, max_v, v_mm, c, ratio, st, cl, v_cl, v_fam)
