"""Target kinds as modes: what differs between planar and spatial solves, in one place.

Every place that used to branch on ``isinstance(target, PlanarTarget)`` asks the target's
mode instead: variables per platform, the random-start perturbation, the fold axes of the
structured starts, the end-effector position, the plane, the target as a 6-DOF one, the
interpolation and step size of a path, the lift to 3D, the FN, the rows that keep a
folded pose's fold from curling back. Each kind is a subclass of
:class:`Mode` that implements these (:class:`PlanarMode`, :class:`SpatialMode`); a new
target kind is a new subclass plus one entry in :func:`mode_of`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from stackik.families import ConstraintFamily
from stackik.geometry import Stack
from stackik.kinematics import lift_planar, planar_jacobian, spatial_chain
from stackik.rotations import euler_zyx, rotation_angle, slerp
from stackik.targets import PlanarTarget, SpatialTarget, Target

__all__ = ["PLANAR", "SPATIAL", "Mode", "PlanarMode", "SpatialMode", "mode_of", "reach_bound"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Mode:
    """What one target kind fixes for a solve (one subclass per kind; their instances
    :data:`PLANAR` and :data:`SPATIAL`).

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
        raise NotImplementedError

    def phi(self, target: Target) -> float | None:
        """The plane azimuth of a planar target [rad]; None in spatial mode."""
        raise NotImplementedError

    def spatial_target(self, target: Target) -> SpatialTarget:
        """``target`` as a 6-DOF target (a planar one lifted into its plane)."""
        raise NotImplementedError

    def interpolate(self, a: Target, b: Target, s: float) -> Target:
        """The target at fraction ``s`` of the way from ``a`` to ``b`` (both of this mode):
        planar linear in ``(rho, z, theta)`` in the plane of ``a``; spatial linear in
        position and :func:`~stackik.rotations.slerp` in orientation."""
        raise NotImplementedError

    def step(self, a: Target, b: Target) -> tuple[float, float]:
        """Size of the step from ``a`` to ``b`` (both of this mode): position distance [mm]
        (planar: in ``(rho, z)``) and rotation [rad] (planar: ``|theta_b - theta_a|``;
        spatial: the angle of ``R_a^T R_b``)."""
        raise NotImplementedError

    def perturbation(self, stack: Stack) -> FloatArray:
        """Per-variable scale of random starts, shape (n k,): 15 % of the mean leg range
        [mm] for translations, 0.1 rad for angles."""
        span = float(np.mean(stack.leg_max - stack.leg_min))
        per = [0.15 * span] * (self.k - self.n_angles) + [0.1] * self.n_angles
        return np.tile(per, stack.n)

    def frames(self, target: Target, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``(P, R)`` of pose ``q``: plate positions (n, 3) [mm] and rotations (n, 3, 3)."""
        raise NotImplementedError

    def lift(self, stack: Stack, target: Target, q: FloatArray) -> tuple[FloatArray, ...]:
        """``(P, R, leg_lengths)`` of pose ``q`` for hardware: shapes (n, 3), (n, 3, 3),
        (n, 6) [mm]."""
        P, R = self.frames(target, q)
        legs = np.linalg.norm(
            np.einsum("nij,nkj->nki", R, stack.top_nodes) + P[:, None, :] - stack.base_nodes,
            axis=-1,
        )
        return P, R, legs

    def frobenius(self, q: FloatArray) -> float:
        """FN of the end-effector Jacobian at ``q``."""
        raise NotImplementedError

    def fold_rows(
        self, stack: Stack, target: Target, q: FloatArray, margin: float
    ) -> list[ConstraintFamily]:
        """Rows that keep the fold of the folded pose ``q`` from curling back on itself
        (:mod:`stackik.formulation.fold_band`; ``margin`` [mm]: the clearance margin),
        widest first; empty: no fold, or none of this kind's (spatial folds have no such
        rows)."""
        return []

    def band_first(self, stack: Stack) -> bool:
        """Whether a batch whose runs folded into themselves goes to :meth:`fold_rows`
        first, making those runs again with the non-adjacent bodies' rows only when the
        fold rows give no pose."""
        return False

    def upright(self, heights: FloatArray) -> FloatArray:
        """Every platform level, straight above the one below, at ``heights`` (n,) [mm]
        (e.g. :func:`stackik.starts.nominal_height`): shape (n, k)."""
        q = np.zeros((len(heights), self.k))
        q[:, self.k - self.n_angles - 1] = heights  # the last translation
        return q


@dataclass(frozen=True)
class PlanarMode(Mode):
    """Planar targets: ``(rho, z, theta)`` per platform in the vertical plane ``phi``."""

    def position(self, target: Target) -> FloatArray:
        assert isinstance(target, PlanarTarget)
        return np.array([target.rho, target.z])

    def phi(self, target: Target) -> float | None:
        assert isinstance(target, PlanarTarget)
        return target.phi

    def spatial_target(self, target: Target) -> SpatialTarget:
        assert isinstance(target, PlanarTarget)
        return target.to_spatial()

    def interpolate(self, a: Target, b: Target, s: float) -> Target:
        assert isinstance(a, PlanarTarget) and isinstance(b, PlanarTarget)
        y = a.y + s * (b.y - a.y)
        return PlanarTarget(float(y[0]), float(y[1]), float(y[2]), a.phi)

    def step(self, a: Target, b: Target) -> tuple[float, float]:
        assert isinstance(a, PlanarTarget) and isinstance(b, PlanarTarget)
        return float(math.hypot(b.rho - a.rho, b.z - a.z)), float(abs(b.theta - a.theta))

    def frames(self, target: Target, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        assert isinstance(target, PlanarTarget)
        return lift_planar(q, target.phi)  # type: ignore[no-any-return]

    def frobenius(self, q: FloatArray) -> float:
        return float(np.sqrt(np.sum(planar_jacobian(q) ** 2)))

    def fold_rows(
        self, stack: Stack, target: Target, q: FloatArray, margin: float
    ) -> list[ConstraintFamily]:
        from stackik.formulation.fold_band import (
            FOLD_BANDS,
            FOLD_SCREEN_MM,
            FoldBand,
            fold_platforms,
        )

        assert isinstance(target, PlanarTarget)
        fold = fold_platforms(stack, q, margin, target.phi, FOLD_SCREEN_MM)
        if fold is None:
            return []
        return [FoldBand(fold, band, tilt, target.theta) for band, tilt in FOLD_BANDS]

    def band_first(self, stack: Stack) -> bool:
        from stackik.formulation.fold_band import FOLD_BAND_FIRST_N

        return stack.n >= FOLD_BAND_FIRST_N


@dataclass(frozen=True)
class SpatialMode(Mode):
    """Spatial targets: ``(x, y, z, yaw, pitch, roll)`` per platform."""

    def position(self, target: Target) -> FloatArray:
        assert isinstance(target, SpatialTarget)
        return target.position

    def phi(self, target: Target) -> float | None:
        return None

    def spatial_target(self, target: Target) -> SpatialTarget:
        assert isinstance(target, SpatialTarget)
        return target

    def interpolate(self, a: Target, b: Target, s: float) -> Target:
        assert isinstance(a, SpatialTarget) and isinstance(b, SpatialTarget)
        P = a.position + s * (b.position - a.position)
        return SpatialTarget(P, slerp(a.rotation, b.rotation, s))

    def step(self, a: Target, b: Target) -> tuple[float, float]:
        assert isinstance(a, SpatialTarget) and isinstance(b, SpatialTarget)
        return (
            float(np.linalg.norm(b.position - a.position)),
            rotation_angle(a.rotation, b.rotation),
        )

    def frames(self, target: Target, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        return q[:, :3].copy(), euler_zyx(q[:, 3:])

    def frobenius(self, q: FloatArray) -> float:
        return float(np.sqrt(np.sum(spatial_chain(q).J ** 2)))


PLANAR: Mode = PlanarMode("planar", 3, 1, (0,))
SPATIAL: Mode = SpatialMode("spatial", 6, 3, (0, 1))


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
