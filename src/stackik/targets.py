"""End-effector targets: the planar and spatial kinds, their plain-data form, the paper's.

A target kind is a frozen value type that checks itself on construction. Planar targets
(DESIGN §3) are ``(rho, z, theta, phi)``; spatial targets (DESIGN §4) a position and a
rotation matrix. The solver's behaviour per kind lives in :mod:`stackik.formulation.modes`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik.geometry import finite_number
from stackik.rotations import plane_axis, rodrigues

__all__ = [
    "PAPER_TARGETS",
    "PlanarTarget",
    "SpatialTarget",
    "Target",
    "paper_targets",
    "target_from_dict",
    "target_to_dict",
]

FloatArray = NDArray[np.float64]

#: The paper's three planar test targets ``(rho [mm], z [mm], theta [rad])`` (phi = 0).
PAPER_TARGETS: tuple[tuple[float, float, float], ...] = (
    (600.0, 1000.0, -1.57),
    (145.0, 1500.0, -0.207),
    (-319.0, 1532.0, 0.332),
)


def _finite(value: Any, name: str) -> float:
    """A finite float, or a ``ValueError`` naming ``name``."""
    return finite_number(value, name, ValueError)


@dataclass(frozen=True)
class PlanarTarget:
    """End-effector target of planar mode (DESIGN §3).

    Parameters
    ----------
    rho, z : float
        End-effector position in cylindrical coordinates [mm]; ``rho`` may be negative.
    theta : float
        End-effector rotation about ``s(phi) = (sin phi, -cos phi, 0)`` [rad].
    phi : float
        Azimuth of the working plane [rad].
    """

    rho: float
    z: float
    theta: float
    phi: float = 0.0

    def __post_init__(self) -> None:
        for name in ("rho", "z", "theta", "phi"):
            object.__setattr__(self, name, _finite(getattr(self, name), name))

    @property
    def y(self) -> FloatArray:
        """``(rho, z, theta)``, the planar output vector."""
        return np.array([self.rho, self.z, self.theta])

    def to_spatial(self) -> SpatialTarget:
        """The same target as a :class:`SpatialTarget`."""
        P = np.array([self.rho * math.cos(self.phi), self.rho * math.sin(self.phi), self.z])
        return SpatialTarget(P, rodrigues(plane_axis(self.phi), self.theta))


@dataclass(frozen=True, eq=False)
class SpatialTarget:
    """End-effector target of spatial mode.

    Parameters
    ----------
    position : array_like, shape (3,)
        ``P_ee`` in the base frame [mm].
    rotation : array_like, shape (3, 3)
        ``R_ee``, a rotation matrix (orthonormal to 1e-6, det +1).
    """

    position: FloatArray
    rotation: FloatArray

    def __post_init__(self) -> None:
        try:
            P = np.array(self.position, dtype=float)
            R = np.array(self.rotation, dtype=float)
        except (TypeError, ValueError):
            raise ValueError("position/rotation: expected arrays of numbers") from None
        if P.shape != (3,) or not np.all(np.isfinite(P)):
            raise ValueError(f"position: expected 3 finite values, got shape {P.shape}")
        if R.shape != (3, 3) or not np.all(np.isfinite(R)):
            raise ValueError(f"rotation: expected a finite (3, 3) matrix, got shape {R.shape}")
        if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0:
            raise ValueError("rotation: not a rotation matrix (R^T R != I or det < 0)")
        P.setflags(write=False)
        R.setflags(write=False)
        object.__setattr__(self, "position", P)
        object.__setattr__(self, "rotation", R)


Target = PlanarTarget | SpatialTarget


def paper_targets(phi: float = 0.0) -> list[PlanarTarget]:
    """The paper's three test targets as :class:`PlanarTarget` in the plane ``phi``."""
    return [PlanarTarget(rho, z, theta, phi) for rho, z, theta in PAPER_TARGETS]


def target_to_dict(target: Target) -> dict[str, Any]:
    """Plain-data form of a target (for checkpoints and JSON)."""
    if isinstance(target, PlanarTarget):
        return {"rho": target.rho, "z": target.z, "theta": target.theta, "phi": target.phi}
    return {"position": target.position.tolist(), "rotation": target.rotation.tolist()}


def target_from_dict(data: dict[str, Any]) -> Target:
    """Inverse of :func:`target_to_dict`."""
    if "position" in data:
        return SpatialTarget(data["position"], data["rotation"])
    return PlanarTarget(data["rho"], data["z"], data["theta"], data.get("phi", 0.0))
