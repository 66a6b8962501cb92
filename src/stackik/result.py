"""Results of a solve: statuses with their messages, :class:`IKResult`, option errors."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from enum import Enum
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from stackik.clearance import Clearances

__all__ = ["STATUS_MESSAGES", "IKResult", "IKStatus", "OptionError"]

FloatArray = NDArray[np.float64]


class OptionError(ValueError):
    """Solver options that the chosen method does not accept (a ``ValueError``)."""


class IKStatus(Enum):
    """Outcome of :func:`solve_ik` (``IKResult.status``); ``STATUS_MESSAGES`` has each one's text.

    ``SUCCESS``: the pose passed the independent check (:func:`stackik.check_pose`);
    ``INFEASIBLE``: no feasible pose was found (an unreachable target: ``q`` is the
    least-violation pose); ``MAX_ITER`` / ``MAX_TIME``: the iteration or time limit ended
    the search first; ``FAILED``: the solvers stopped without a checked pose.
    """

    SUCCESS = "success"
    INFEASIBLE = "infeasible"
    MAX_ITER = "max_iter"
    MAX_TIME = "max_time"
    FAILED = "failed"


#: The message of each status (one table; a result may carry a more specific one).
STATUS_MESSAGES = {
    IKStatus.SUCCESS: "Target reached with every leg and joint limit respected (checked).",
    IKStatus.INFEASIBLE: "Unreachable: no feasible pose found. q is the least-violation "
    "pose found.",
    IKStatus.MAX_ITER: "Iteration limit reached before a checked feasible pose was found.",
    IKStatus.MAX_TIME: "Time limit reached before a checked feasible pose was found.",
    IKStatus.FAILED: "The solver stopped without a pose that passes the independent check.",
}


@dataclass(frozen=True)
class IKResult:
    """Result of :func:`solve_ik`.

    Attributes
    ----------
    q : ndarray
        Pose, (n, 3) rows ``[rho, z, theta]`` (planar) or (n, 6) rows
        ``[x, y, z, yaw, pitch, roll]`` (spatial) [mm, rad].
    success : bool
        True only if the independent check passed (target error <= 1e-6 mm and 1e-8 rad,
        every limit within 1e-6 mm).
    status : IKStatus
    message : str
    frobenius_norm : float
        FN of the end-effector Jacobian at ``q``.
    objective : str
        Objective name.
    objective_value : float
        Value of the objective at ``q`` (FN^2 for "frobenius", 0 for "feasible").
    max_violation : float
        Worst raw constraint violation (mm^2 for leg blocks, mm for joint blocks).
    target_error : float
        End-effector position error [mm].
    angle_error : float
        End-effector orientation error [rad].
    nit : int
        Solver iterations, summed over starts.
    time : float
        Wall time [s].
    method, qp_solver : str
    n_starts : int
        Starts tried.
    P, R : ndarray, shapes (n, 3) and (n, 3, 3)
        Per-platform translation and rotation (top plate in bottom frame) for hardware.
    leg_lengths : ndarray, shape (n, 6)
        Actuator lengths [mm].
    phi : float or None
        Plane azimuth of a planar solve.
    leg_forces : ndarray, shape (n, 6), or None
        Axial leg forces at ``q`` [N], compression positive (:func:`stackik.leg_forces`),
        under the solve's load; computed when a ``load`` was given or some ``force_max``
        is finite, else None. ``inf`` on a singular platform.
    force_margin : ndarray, shape (n, 6), or None
        ``force_max - |f|`` per leg [N] (negative = over the limit, ``inf`` without one).
    sigma_min, condition : ndarray, shape (n,), or None
        Per platform, the smallest singular value and the condition number of its leg
        wrench matrix made dimensionless by the characteristic length
        (:func:`stackik.wrench_conditioning`): the distance to a singularity.
    clearances : Clearances or None
        Signed least distances [mm] per pair kind, with the closest pairs
        (:func:`stackik.clearances`), as the check measured them; None when the check had
        none to enforce (zero leg radii and plate thickness, margin 0, and no obstacle or,
        for the interior point, none that a body of the pose can reach). Not
        kept by :meth:`to_record` / :meth:`from_record` (:meth:`to_dict` has them).
    """

    q: FloatArray
    success: bool
    status: IKStatus
    message: str
    frobenius_norm: float
    objective: str
    objective_value: float
    max_violation: float
    target_error: float
    angle_error: float
    nit: int
    time: float
    method: str
    qp_solver: str
    n_starts: int
    P: FloatArray
    R: FloatArray
    leg_lengths: FloatArray
    phi: float | None = None
    mode: str = "planar"
    info: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)
    leg_forces: FloatArray | None = field(default=None, compare=False)
    force_margin: FloatArray | None = field(default=None, compare=False)
    sigma_min: FloatArray | None = field(default=None, compare=False)
    condition: FloatArray | None = field(default=None, compare=False)
    clearances: Clearances | None = field(default=None, compare=False)

    @property
    def peak_force(self) -> float | None:
        """Largest ``|f|`` over every leg [N], or None when forces were not computed."""
        return None if self.leg_forces is None else float(np.abs(self.leg_forces).max())

    def to_record(self) -> dict[str, Any]:
        """Lossless JSON-ready form (floats round-trip exactly); see :meth:`from_record`."""
        d = self.to_dict()
        d.update(
            {
                "P": self.P.tolist(),
                "R": self.R.tolist(),
                "time": self.time,
                "info": {k: v for k, v in self.info.items() if _jsonable(v)},
            }
        )
        return d

    @classmethod
    def from_record(cls, d: dict[str, Any]) -> IKResult:
        """Rebuild a result from :meth:`to_record` output."""
        return cls(
            q=np.array(d["q"], dtype=float),
            success=bool(d["success"]),
            status=IKStatus(d["status"]),
            message=str(d["message"]),
            frobenius_norm=float(d["frobenius_norm"]),
            objective=str(d["objective"]),
            objective_value=float(d["objective_value"]),
            max_violation=float(d["max_violation"]),
            target_error=float(d["target_error"]),
            angle_error=float(d["angle_error"]),
            nit=int(d["nit"]),
            time=float(d["time"]),
            method=str(d["method"]),
            qp_solver=str(d["qp_solver"]),
            n_starts=int(d["n_starts"]),
            P=np.array(d["P"], dtype=float),
            R=np.array(d["R"], dtype=float),
            leg_lengths=np.array(d["leg_lengths"], dtype=float),
            phi=None if d.get("phi") is None else float(d["phi"]),
            mode=str(d.get("mode", "planar")),
            info=dict(d.get("info", {})),
            **_statics_of(d),
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {
            "success": self.success,
            "status": self.status.value,
            "message": self.message,
            "mode": self.mode,
            "q": self.q.tolist(),
            "phi": self.phi,
            "frobenius_norm": self.frobenius_norm,
            "objective": self.objective,
            "objective_value": self.objective_value,
            "max_violation": self.max_violation,
            "target_error": self.target_error,
            "angle_error": self.angle_error,
            "nit": self.nit,
            "time_s": self.time,
            "method": self.method,
            "qp_solver": self.qp_solver,
            "n_starts": self.n_starts,
            "leg_lengths": self.leg_lengths.tolist(),
            "clearances": None if self.clearances is None else self.clearances.to_dict(),
            **{
                k: None if getattr(self, k) is None else getattr(self, k).tolist()
                for k in STATICS_KEYS
            },
        }


#: The optional statics fields of a result (None when forces were not computed).
STATICS_KEYS = ("leg_forces", "force_margin", "sigma_min", "condition")


def _array_or_none(v: Any) -> FloatArray | None:
    return None if v is None else np.array(v, dtype=float)


def _statics_of(d: dict[str, Any]) -> dict[str, Any]:
    """The statics fields of a record (None where absent)."""
    return {k: _array_or_none(d.get(k)) for k in STATICS_KEYS}


def _jsonable(v: Any) -> bool:
    try:
        json.dumps(v)
    except (TypeError, ValueError):
        return False
    return True
