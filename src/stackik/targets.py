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
from numpy.typing import ArrayLike, NDArray

from stackik._arrays import finite_array
from stackik.geometry import finite_number
from stackik.rotations import euler_zyx, plane_axis, rodrigues

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
    """End-effector target of spatial mode (DESIGN §4).

    Parameters
    ----------
    position : array_like, shape (3,)
        ``P_ee`` in the base frame [mm].
    rotation : array_like, shape (3, 3)
        ``R_ee``, a rotation matrix (orthonormal to 1e-6, det +1).

    Other constructors: :meth:`from_euler` (yaw, pitch, roll), :meth:`from_rotvec`
    (rotation vector) and :meth:`from_quat` (unit quaternion, scalar last).

    Examples
    --------
    >>> t = SpatialTarget.from_euler([100.0, 0.0, 1200.0], yaw=0.3, pitch=0.0, roll=0.1)
    >>> t.position.tolist()
    [100.0, 0.0, 1200.0]
    """

    position: FloatArray
    rotation: FloatArray

    def __post_init__(self) -> None:
        P = finite_array(self.position, "position", (3,))
        R = finite_array(self.rotation, "rotation", (3, 3))
        err = float(np.abs(R.T @ R - np.eye(3)).max())
        if err > 1e-6:
            raise ValueError(
                f"rotation: not a rotation matrix (max |R^T R - I| = {err:.3g} > 1e-6)"
            )
        if np.linalg.det(R) < 0:
            raise ValueError("rotation: not a rotation matrix (det R = -1, a reflection)")
        P.setflags(write=False)
        R.setflags(write=False)
        object.__setattr__(self, "position", P)
        object.__setattr__(self, "rotation", R)

    @classmethod
    def from_euler(
        cls, position: ArrayLike, yaw: float, pitch: float, roll: float
    ) -> SpatialTarget:
        """The target at ``position`` [mm] with ``R = Rz(yaw) Ry(pitch) Rx(roll)`` [rad].

        The convention of the platform variables (DESIGN §4), the same as scipy's
        ``Rotation.from_euler("ZYX", [yaw, pitch, roll])``: turn by ``roll`` about x,
        then ``pitch`` about y, then ``yaw`` about z, all axes of the base frame.
        """
        angles = [finite_number(v, k) for k, v in (("yaw", yaw), ("pitch", pitch), ("roll", roll))]
        return cls(finite_array(position, "position", (3,)), euler_zyx(angles))

    @classmethod
    def from_rotvec(cls, position: ArrayLike, rotvec: ArrayLike) -> SpatialTarget:
        """The target at ``position`` [mm] turned by the rotation vector ``rotvec``
        (shape (3,)): the axis ``rotvec / |rotvec|``, the angle ``|rotvec|`` [rad]."""
        w = finite_array(rotvec, "rotvec", (3,))
        angle = float(np.linalg.norm(w))
        R = np.eye(3) if angle == 0.0 else rodrigues(w / angle, angle)
        return cls(finite_array(position, "position", (3,)), R)

    @classmethod
    def from_quat(cls, position: ArrayLike, quat: ArrayLike) -> SpatialTarget:
        """The target at ``position`` [mm] turned by the quaternion ``quat = (x, y, z, w)``
        (shape (4,), scalar *last*, as scipy's ``Rotation.from_quat``); normalised
        here, so any non-zero length is accepted."""
        xyzw = finite_array(quat, "quat", (4,))
        norm = float(np.linalg.norm(xyzw))
        if norm < 1e-12:
            raise ValueError("quat: a zero quaternion is no rotation (expected (x, y, z, w))")
        x, y, z, w = xyzw / norm
        R = np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ])  # fmt: skip
        return cls(finite_array(position, "position", (3,)), R)


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
    """The target of a plain-data mapping, the inverse of :func:`target_to_dict`.

    A mapping with ``position`` (3,) [mm] and ``rotation`` (3, 3) is a
    :class:`SpatialTarget`; one with ``rho``, ``z`` [mm], ``theta`` [rad] and optionally
    ``phi`` [rad] (default 0) a :class:`PlanarTarget`.
    """
    if "position" in data:
        return SpatialTarget(data["position"], data["rotation"])
    return PlanarTarget(data["rho"], data["z"], data["theta"], data.get("phi", 0.0))
