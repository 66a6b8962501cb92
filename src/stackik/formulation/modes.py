"""Target kinds as modes: what differs between planar and spatial solves, in one place.

Every place that used to branch on ``isinstance(target, PlanarTarget)`` asks the target's
mode instead: variables per platform, the random-start perturbation, the fold axes of the
structured starts, the end-effector position, the lift to 3D, the FN. A new target kind
is a new :class:`Mode` plus one entry in :func:`mode_of`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from stackik.geometry import Stack
from stackik.kinematics import lift_planar, planar_jacobian, spatial_chain
from stackik.rotations import euler_zyx
from stackik.targets import PlanarTarget, SpatialTarget, Target

__all__ = ["PLANAR", "SPATIAL", "Mode", "mode_of", "reach_bound"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Mode:
    """What one target kind fixes for a solve.

    Attributes
    ----------
    name : str
        ``"planar"`` or ``"spatial"`` (:attr:`stackik.IKResult.mode`).
    k : int
        Variables per platform (3: ``rho, z, theta``; 6: ``x, y, z, yaw, pitch, roll``).
    n_angles : int
        How many of them are angles [rad] (the last ``n_angles``); the rest are [mm].
    fold_axes : tuple of int
        Columns along which the structured starts fold the top platforms sideways.
    """

    name: str
    k: int
    n_angles: int
    fold_axes: tuple[int, ...]

    @property
    def planar(self) -> bool:
        return self.name == "planar"

    def position(self, target: Target) -> FloatArray:
        """End-effector position of ``target`` in its own coordinates [mm]."""
        if isinstance(target, PlanarTarget):
            return np.array([target.rho, target.z])
        return target.position

    def phi(self, target: Target) -> float | None:
        """The plane azimuth of a planar target [rad]; None in spatial mode."""
        return target.phi if isinstance(target, PlanarTarget) else None

    def perturbation(self, stack: Stack) -> FloatArray:
        """Per-variable scale of random starts, shape (n k,): 15 % of the mean leg range
        [mm] for translations, 0.1 rad for angles."""
        span = float(np.mean(stack.leg_max - stack.leg_min))
        per = [0.15 * span] * (self.k - self.n_angles) + [0.1] * self.n_angles
        return np.tile(per, stack.n)

    def lift(self, stack: Stack, target: Target, q: FloatArray) -> tuple[FloatArray, ...]:
        """``(P, R, leg_lengths)`` of pose ``q`` for hardware: shapes (n, 3), (n, 3, 3),
        (n, 6) [mm]."""
        if isinstance(target, PlanarTarget):
            P, R = lift_planar(q, target.phi)
        else:
            P, R = q[:, :3].copy(), euler_zyx(q[:, 3:])
        legs = np.linalg.norm(
            np.einsum("nij,nkj->nki", R, stack.top_nodes) + P[:, None, :] - stack.base_nodes,
            axis=-1,
        )
        return P, R, legs

    def frobenius(self, q: FloatArray) -> float:
        """FN of the end-effector Jacobian at ``q``."""
        if self.planar:
            return float(np.sqrt(np.sum(planar_jacobian(q) ** 2)))
        return float(np.sqrt(np.sum(spatial_chain(q).J ** 2)))


PLANAR = Mode("planar", 3, 1, (0,))
SPATIAL = Mode("spatial", 6, 3, (0, 1))


def mode_of(target: Target) -> Mode:
    """The :class:`Mode` of a target; ``ValueError`` for anything that is not one."""
    if isinstance(target, PlanarTarget):
        return PLANAR
    if isinstance(target, SpatialTarget):
        return SPATIAL
    raise ValueError(
        f"target: expected a PlanarTarget or SpatialTarget, got {type(target).__name__}"
    )


def reach_bound(stack: Stack) -> float:
    """Upper bound on ``|P_ee|`` over all poses respecting leg_max [mm] (cached per stack)."""

    def make(st: Stack) -> float:
        rb = np.linalg.norm(st.base_nodes, axis=-1).max(axis=1)
        rt = np.linalg.norm(st.top_nodes, axis=-1).max(axis=1)
        return float(np.sum(st.leg_max + rb + rt))

    return stack.derived("reach_bound", make)  # type: ignore[no-any-return]
