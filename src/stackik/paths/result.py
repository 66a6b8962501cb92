"""Result of a path solve: :class:`PathStatus`, :class:`PathResult`, CSV and JSON files."""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field, replace
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.targets import (
    PlanarTarget,
    SpatialTarget,
    Target,
    target_from_dict,
    target_to_dict,
)

__all__ = [
    "MARGIN_NAMES",
    "PATH_MESSAGES",
    "PathResult",
    "PathStatus",
    "read_path_csv",
]

FloatArray = NDArray[np.float64]

#: The four limit margins per platform in :attr:`PathResult.margins` (units mm, mm, rad,
#: rad): ``min |l| - leg_min``, ``leg_max - max |l|``, and the smallest angle between a
#: leg and the base (top) plate minus ``joint_min``. Negative means violated.
MARGIN_NAMES: tuple[str, ...] = ("leg_min", "leg_max", "joint_base", "joint_top")

PLANAR_VARS = ("rho", "z", "theta")
SPATIAL_VARS = ("x", "y", "z", "yaw", "pitch", "roll")


class PathStatus(Enum):
    """Outcome of :func:`stackik.paths.solve_path`."""

    SUCCESS = "success"
    UNREACHABLE = "unreachable"
    JUMP = "jump"


#: The message of each status (a result carries a more specific one, with the index).
PATH_MESSAGES = {
    PathStatus.SUCCESS: "Every waypoint reached, every limit respected (checked), and no "
    "platform variable moved more than max_jump between consecutive waypoints.",
    PathStatus.UNREACHABLE: "A waypoint has no pose within the limits (it is outside the "
    "workspace); the path stops before it.",
    PathStatus.JUMP: "A waypoint is reachable, but not by a pose within max_jump of the "
    "previous waypoint's pose (a limit wall or a branch that ends); the path stops before it.",
}


def _arr(value: Any, shape: tuple[int, ...] | None = None) -> FloatArray:
    a = np.array(value, dtype=float)
    if shape is not None and a.shape != shape:
        raise ValueError(f"expected shape {shape}, got {a.shape}")
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class PathResult:
    """A pose sequence along a path (:func:`stackik.paths.solve_path`).

    Attributes
    ----------
    targets : tuple of targets, length m
        The waypoints solved (the input waypoints, plus the inserted ones with
        ``refine=True``, see ``source``).
    q : ndarray, shape (m, n, 3) or (m, n, 6)
        Pose at each waypoint (rows ``[rho, z, theta]`` or ``[x, y, z, yaw, pitch, roll]``
        [mm, rad]); NaN from waypoint ``completed`` on.
    success : bool
        True iff every waypoint was reached (``completed == m``).
    completed : int
        Number of waypoints reached, from the first; the path broke at waypoint
        ``completed`` when it is less than m.
    status : PathStatus
    message : str
        What happened, with the waypoint index where the path broke.
    frobenius_norm : ndarray, shape (m,)
        FN of the end-effector Jacobian at each pose (NaN where not reached).
    leg_lengths : ndarray, shape (m, n, 6)
        Actuator lengths [mm].
    margins : ndarray, shape (m, n, 4)
        Limit margins per platform, in the order of :data:`MARGIN_NAMES` [mm, mm, rad, rad].
    max_jump : (float, float)
        The continuity limit used: largest change of a translation [mm] and of an angle
        [rad] of any platform between consecutive waypoints.
    mode : str
        ``"fast"`` or ``"global"``.
    source : ndarray, shape (m,)
        Position of each waypoint in the input sequence: ``k`` for input waypoint k, a
        fraction between two indices for a waypoint inserted by ``refine=True``.
    times : ndarray, shape (m,) or None
        Waypoint times [s] from :func:`stackik.paths.time_parameterize` when leg speed and
        acceleration limits were given (NaN where not reached).
    time : float
        Wall time of the solve [s] (as ``IKResult.time``, without the one-time
        loading of the compiled kernels, which :func:`solve_path` does before its clock
        starts).
    info : dict
        Counters of the solve (``warm``, ``subdivided``, ``bounded``, ``default`` solves...).
    leg_forces : ndarray, shape (m, n, 6), or None
        Axial leg forces [N], compression positive (:func:`stackik.leg_forces`), under the
        path's ``load``, when a load was given or some ``force_max`` is finite (NaN where
        not reached); else None.
    """

    targets: tuple[Target, ...]
    q: FloatArray
    success: bool
    completed: int
    status: PathStatus
    message: str
    frobenius_norm: FloatArray
    leg_lengths: FloatArray
    margins: FloatArray
    max_jump: tuple[float, float]
    mode: str
    source: FloatArray
    times: FloatArray | None = None
    time: float = 0.0
    info: dict[str, Any] = field(default_factory=dict, compare=False)
    leg_forces: FloatArray | None = None

    # --- derived ------------------------------------------------------------------
    @property
    def m(self) -> int:
        """Number of waypoints."""
        return len(self.targets)

    @property
    def n(self) -> int:
        """Number of platforms."""
        return int(self.q.shape[1])

    @property
    def planar(self) -> bool:
        """True for a planar path."""
        return isinstance(self.targets[0], PlanarTarget)

    @property
    def break_index(self) -> int | None:
        """Index of the first waypoint not reached (None for a complete path)."""
        return None if self.success else self.completed

    @property
    def step_jumps(self) -> FloatArray:
        """Largest change between consecutive waypoints, shape (m-1, 2): of a translation
        [mm] and of an angle [rad], over all platforms (NaN where not reached)."""
        d = np.abs(np.diff(self.q, axis=0))  # (m-1, n, k)
        k = self.q.shape[2]
        nt = 2 if k == 3 else 3
        if d.shape[0] == 0:
            return np.zeros((0, 2))
        out = np.stack([d[..., :nt].max(axis=(1, 2)), d[..., nt:].max(axis=(1, 2))], axis=1)
        return out  # type: ignore[no-any-return]

    @property
    def mean_frobenius_norm(self) -> float:
        """Mean FN over the waypoints reached (NaN if none)."""
        if self.completed == 0:
            return math.nan
        return float(np.mean(self.frobenius_norm[: self.completed]))

    def with_times(self, times: ArrayLike | None) -> PathResult:
        """A copy with ``times`` [s] set (shape (m,)) or removed (None)."""
        return replace(self, times=None if times is None else _arr(times, (self.m,)))

    # --- JSON -----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """Lossless JSON-ready form (floats round-trip exactly; NaN as null)."""

        def clean(a: FloatArray) -> Any:
            out = a.astype(object)
            out[np.isnan(a)] = None
            return out.tolist()

        return {
            "format": "stackik-path",
            "version": 1,
            "mode": self.mode,
            "success": self.success,
            "status": self.status.value,
            "message": self.message,
            "completed": self.completed,
            "break_index": self.break_index,
            "max_jump": list(self.max_jump),
            "targets": [target_to_dict(t) for t in self.targets],
            "source": self.source.tolist(),
            "q": clean(self.q),
            "frobenius_norm": clean(self.frobenius_norm),
            "leg_lengths": clean(self.leg_lengths),
            "margins": clean(self.margins),
            "margin_names": list(MARGIN_NAMES),
            "times": None if self.times is None else clean(self.times),
            "leg_forces": None if self.leg_forces is None else clean(self.leg_forces),
            "time_s": self.time,
            "info": self.info,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PathResult:
        """Inverse of :meth:`to_dict`."""
        if d.get("format") != "stackik-path":
            raise ValueError("not a stackik path result (missing format 'stackik-path')")

        def arr(v: Any) -> FloatArray:
            return _arr(np.array(v, dtype=object).astype(float))

        times = d.get("times")
        forces = d.get("leg_forces")
        return cls(
            targets=tuple(target_from_dict(t) for t in d["targets"]),
            q=arr(d["q"]),
            success=bool(d["success"]),
            completed=int(d["completed"]),
            status=PathStatus(d["status"]),
            message=str(d["message"]),
            frobenius_norm=arr(d["frobenius_norm"]),
            leg_lengths=arr(d["leg_lengths"]),
            margins=arr(d["margins"]),
            max_jump=(float(d["max_jump"][0]), float(d["max_jump"][1])),
            mode=str(d["mode"]),
            source=arr(d["source"]),
            times=None if times is None else arr(times),
            time=float(d.get("time_s", 0.0)),
            info=dict(d.get("info", {})),
            leg_forces=None if forces is None else arr(forces),
        )

    def to_json(self, path: str | Path | None = None) -> str:
        """The JSON text of :meth:`to_dict`; also written to ``path`` when given."""
        text = json.dumps(self.to_dict(), indent=1)
        if path is not None:
            Path(path).write_text(text + "\n")
        return text

    @classmethod
    def from_json(cls, source: str | Path) -> PathResult:
        """Read a result written by :meth:`to_json` (a file path or the JSON text)."""
        text = str(source)
        if not text.lstrip().startswith("{"):
            text = Path(source).read_text()
        return cls.from_dict(json.loads(text))

    # --- CSV ------------------------------------------------------------------------
    def csv_header(self) -> list[str]:
        """Column names of :meth:`to_csv` (platforms numbered from 1, legs from 0)."""
        names = PLANAR_VARS if self.planar else SPATIAL_VARS
        tcols = (
            ["target_rho", "target_z", "target_theta", "target_phi"]
            if self.planar
            else ["target_x", "target_y", "target_z"] + [f"target_R{i}{j}" for i in range(3)
                                                          for j in range(3)]
        )  # fmt: skip
        cols = ["index", "source", "time_s", *tcols, "frobenius_norm"]
        for i in range(1, self.n + 1):
            cols += [f"p{i}_{v}" for v in names]
        for i in range(1, self.n + 1):
            cols += [f"p{i}_leg{k}" for k in range(6)]
        for i in range(1, self.n + 1):
            cols += [f"p{i}_margin_{name}" for name in MARGIN_NAMES]
        if self.leg_forces is not None:
            for i in range(1, self.n + 1):
                cols += [f"p{i}_force{k}" for k in range(6)]
        return cols

    def to_csv(self, path: str | Path) -> Path:
        """One row per waypoint: index, source, time [s], target, FN, pose, leg lengths
        [mm] and margins (see :meth:`csv_header`); floats written exactly (``repr``), empty
        cells where a waypoint was not reached or no times were computed."""

        def cell(x: float) -> str:
            return "" if math.isnan(x) else repr(float(x))

        rows = []
        for k, t in enumerate(self.targets):
            if isinstance(t, PlanarTarget):
                tv = [t.rho, t.z, t.theta, t.phi]
            else:
                tv = [*t.position.tolist(), *t.rotation.ravel().tolist()]
            tk = math.nan if self.times is None else float(self.times[k])
            row = [str(k), cell(self.source[k]), cell(tk), *(cell(v) for v in tv)]
            row.append(cell(self.frobenius_norm[k]))
            row += [cell(v) for v in self.q[k].ravel()]
            row += [cell(v) for v in self.leg_lengths[k].ravel()]
            row += [cell(v) for v in self.margins[k].ravel()]
            if self.leg_forces is not None:
                row += [cell(v) for v in self.leg_forces[k].ravel()]
            rows.append(row)
        out = Path(path)
        with out.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(self.csv_header())
            w.writerows(rows)
        return out


def read_path_csv(path: str | Path) -> dict[str, Any]:
    """Read a file written by :meth:`PathResult.to_csv`.

    Returns
    -------
    dict
        ``targets`` (list of targets), ``source`` (m,), ``times`` (m,) or None,
        ``frobenius_norm`` (m,), ``q`` (m, n, 3|6), ``leg_lengths`` (m, n, 6) and
        ``margins`` (m, n, 4), ``leg_forces`` (m, n, 6) [N] or None; empty cells read as
        NaN.
    """
    with Path(path).open(newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows or rows[0][:3] != ["index", "source", "time_s"]:
        raise ValueError(f"{path}: not a stackik path CSV (header must start index,source,time_s)")
    head, body = rows[0], rows[1:]
    data = np.array([[math.nan if c == "" else float(c) for c in r] for r in body], dtype=float)
    data = data.reshape(len(body), len(head))
    col = {name: j for j, name in enumerate(head)}
    planar = "target_rho" in col
    names = PLANAR_VARS if planar else SPATIAL_VARS
    n = sum(1 for h in head if h.endswith(f"_{names[0]}") and h.startswith("p"))
    m = data.shape[0]
    j0 = col["p1_" + names[0]]
    k = len(names)
    q = data[:, j0 : j0 + n * k].reshape(m, n, k)
    j1 = col["p1_leg0"]
    legs = data[:, j1 : j1 + 6 * n].reshape(m, n, 6)
    j2 = col["p1_margin_" + MARGIN_NAMES[0]]
    margins = data[:, j2 : j2 + 4 * n].reshape(m, n, 4)
    forces = None
    if "p1_force0" in col:
        j3 = col["p1_force0"]
        forces = data[:, j3 : j3 + 6 * n].reshape(m, n, 6)
    targets: list[Target] = []
    for r in data:
        if planar:
            cols = ("target_rho", "target_z", "target_theta", "target_phi")
            targets.append(PlanarTarget(*(r[col[c]] for c in cols)))
        else:
            P = np.array([r[col[f"target_{c}"]] for c in "xyz"])
            R = np.array([[r[col[f"target_R{i}{j}"]] for j in range(3)] for i in range(3)])
            targets.append(SpatialTarget(P, R))
    times = data[:, col["time_s"]]
    return {
        "targets": targets,
        "source": data[:, col["source"]],
        "times": None if np.all(np.isnan(times)) else times,
        "frobenius_norm": data[:, col["frobenius_norm"]],
        "q": q,
        "leg_lengths": legs,
        "margins": margins,
        "leg_forces": forces,
    }
