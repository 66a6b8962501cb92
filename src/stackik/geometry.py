"""Platform and stack geometry (DESIGN §2).

A :class:`PlatformGeometry` holds the six ball-joint nodes of each plate (in mm, each in
its own plate frame) and the limits of the legs and joints. A :class:`Stack` is an ordered
sequence of n >= 1 geometries, bottom platform first; platforms may differ.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik._io import read_data_file

__all__ = ["GeometryError", "PlatformGeometry", "Stack", "finite_number"]

FloatArray = NDArray[np.float64]

# Reference geometry (DESIGN §2): chosen, not given by the paper.
REF_RADIUS = 150.0  # [mm] r_b = r_t
REF_HALF_ANGLE = math.radians(15.0)  # [rad] a = b
REF_LEG_MIN = 250.0  # [mm]
REF_LEG_MAX = 450.0  # [mm]
REF_JOINT_MIN = math.radians(20.0)  # [rad]
#: [mm] a realistic actuator radius (chosen, not given): the reference geometry's legs
ACTUATOR_RADIUS = 12.0


class GeometryError(ValueError):
    """A geometry (or geometry file) is malformed; the message names the bad field."""


def _nodes(value: ArrayLike, name: str) -> FloatArray:
    try:
        raw = np.asarray(value)
        if raw.dtype.kind not in "iuf":  # reject strings, booleans, None, ragged lists
            raise TypeError(f"got elements of type {raw.dtype}")
        arr = np.array(raw, dtype=float)
    except (TypeError, ValueError) as exc:
        raise GeometryError(f"{name}: expected a (6, 3) array of numbers ({exc})") from None
    if arr.shape != (6, 3):
        raise GeometryError(f"{name}: expected shape (6, 3), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise GeometryError(f"{name}: contains NaN or infinite values")
    d = np.linalg.norm(arr[:, None, :] - arr[None, :, :], axis=-1)
    scale = max(1.0, float(np.abs(arr).max()))
    if np.any(d[np.triu_indices(6, 1)] <= 1e-9 * scale):
        raise GeometryError(f"{name}: the six nodes must be distinct")
    centred = arr - arr.mean(axis=0)
    sv = np.linalg.svd(centred, compute_uv=False)
    if sv[1] <= 1e-9 * max(sv[0], 1e-300):
        raise GeometryError(f"{name}: the six nodes must not be collinear")
    arr.setflags(write=False)
    return arr


def finite_number(value: Any, name: str, error: type[ValueError] = ValueError) -> float:
    """``float(value)`` if it is a finite number (not a string or bool), else ``error``.

    The message names ``name``; ``error`` is a ``ValueError`` subclass.
    """
    if isinstance(value, str | bytes | bool | np.bool_):
        raise error(f"{name}: expected a number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise error(f"{name}: expected a number, got {value!r}") from None
    if not math.isfinite(x):
        raise error(f"{name}: must be finite, got {x}")
    return x


def _scalar(value: Any, name: str) -> float:
    return finite_number(value, name, GeometryError)


#: The statics fields of :class:`PlatformGeometry` (DESIGN §10) and their defaults.
STATICS_FIELDS = ("plate_mass", "leg_mass", "force_max")
STATICS_DEFAULTS = (0.0, 0.0, math.inf)
#: Every field beyond the paper's model (statics, DESIGN §10; bodies for clearance, §11):
#: keyword arguments and optional geometry-file keys, written only when not at their default.
EXTRA_FIELDS = (*STATICS_FIELDS, "leg_radius", "plate_thickness")
EXTRA_DEFAULTS = (*STATICS_DEFAULTS, 0.0, 0.0)


def _force_max(value: Any) -> float:
    """A force limit [N]: a number > 0, ``inf`` allowed (no limit)."""
    if isinstance(value, str | bytes | bool | np.bool_):
        raise GeometryError(f"force_max: expected a number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise GeometryError(f"force_max: expected a number, got {value!r}") from None
    if not x > 0:  # also NaN
        raise GeometryError(f"force_max: must be > 0 N (inf = no limit), got {x}")
    return x


@dataclass(frozen=True, eq=False)
class PlatformGeometry:
    """Geometry of one Stewart platform.

    Parameters
    ----------
    base_nodes : array_like, shape (6, 3)
        Leg attachment points ``b_k`` on the bottom plate, in its frame [mm].
    top_nodes : array_like, shape (6, 3)
        Leg attachment points ``t_k`` on the top plate, in its frame [mm]. Leg k joins
        ``b_k`` to ``t_k``.
    leg_min, leg_max : float
        Actuator length limits [mm], ``0 < leg_min < leg_max``.
    joint_min : float
        Minimum angle between a leg and either plate [rad], ``0 <= joint_min < pi/2``.
    plate_mass : float
        Mass of the top plate [kg], at its centre (DESIGN §10); finite, ``>= 0``.
    leg_mass : float
        Mass of each leg [kg], split half at each of its two joints; finite, ``>= 0``.
    force_max : float
        Each leg's actuator force limit [N]: ``|f| <= force_max`` in tension and
        compression; ``> 0``, default ``inf`` (no limit). The defaults (massless, no limit)
        are the paper's model: they change nothing of the kinematics or the solvers.
    leg_radius : float, optional
        Radius of each leg's capsule, joint to joint [mm], ``>= 0`` (default 0: legs of
        zero thickness, which still may not pass through each other). See
        ``docs/clearance.md``.
    plate_thickness : float, optional
        Thickness of the plates [mm], ``>= 0`` (default 0). A plate is the set of points
        within ``plate_thickness / 2`` of the convex polygon of its nodes.

    Raises
    ------
    GeometryError
        (a ``ValueError``) naming the bad field.
    """

    base_nodes: FloatArray
    top_nodes: FloatArray
    leg_min: float
    leg_max: float
    joint_min: float
    plate_mass: float = 0.0  # [kg]
    leg_mass: float = 0.0  # [kg] per leg
    force_max: float = math.inf  # [N] per leg
    leg_radius: float = 0.0  # [mm]
    plate_thickness: float = 0.0  # [mm]

    def __post_init__(self) -> None:
        object.__setattr__(self, "base_nodes", _nodes(self.base_nodes, "base_nodes"))
        object.__setattr__(self, "top_nodes", _nodes(self.top_nodes, "top_nodes"))
        leg_min = _scalar(self.leg_min, "leg_min")
        leg_max = _scalar(self.leg_max, "leg_max")
        joint_min = _scalar(self.joint_min, "joint_min")
        if leg_min <= 0:
            raise GeometryError(f"leg_min: must be > 0 mm, got {leg_min}")
        if leg_max <= leg_min:
            raise GeometryError(f"leg_max: must exceed leg_min ({leg_min} mm), got {leg_max}")
        if not 0 <= joint_min < math.pi / 2:
            raise GeometryError(f"joint_min: must lie in [0, pi/2) rad, got {joint_min}")
        object.__setattr__(self, "leg_min", leg_min)
        object.__setattr__(self, "leg_max", leg_max)
        object.__setattr__(self, "joint_min", joint_min)
        for name in ("plate_mass", "leg_mass"):
            mass = _scalar(getattr(self, name), name)
            if mass < 0:
                raise GeometryError(f"{name}: must be >= 0 kg, got {mass}")
            object.__setattr__(self, name, mass)
        force_max = _force_max(self.force_max)
        object.__setattr__(self, "force_max", force_max)

        for name in ("leg_radius", "plate_thickness"):
            value = _scalar(getattr(self, name), name)
            if value < 0:
                raise GeometryError(f"{name}: must be >= 0 mm, got {value}")
            object.__setattr__(self, name, value)

    @property
    def _statics(self) -> tuple[float, float, float]:
        """``(plate_mass, leg_mass, force_max)`` [kg, kg, N]."""
        return (self.plate_mass, self.leg_mass, self.force_max)

    @property
    def _extras(self) -> tuple[float, ...]:
        """The fields beyond the paper's model, in :data:`EXTRA_FIELDS` order."""
        return (*self._statics, self.leg_radius, self.plate_thickness)

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickle through the constructor: the node arrays come back validated and
        read-only (numpy's own pickling would make them writable)."""
        args = (self.base_nodes, self.top_nodes, self.leg_min, self.leg_max, self.joint_min)
        return (PlatformGeometry, args + self._extras)

    @classmethod
    def hexagonal(
        cls,
        base_radius: float = REF_RADIUS,
        top_radius: float = REF_RADIUS,
        base_half_angle: float = REF_HALF_ANGLE,
        top_half_angle: float = REF_HALF_ANGLE,
        leg_min: float = REF_LEG_MIN,
        leg_max: float = REF_LEG_MAX,
        joint_min: float = REF_JOINT_MIN,
        *,
        plate_mass: float = 0.0,
        leg_mass: float = 0.0,
        force_max: float = math.inf,
        leg_radius: float = 0.0,
        plate_thickness: float = 0.0,
    ) -> PlatformGeometry:
        """The symmetric layout of DESIGN §2 (radii in mm, angles in rad).

        ``plate_mass``, ``leg_mass`` [kg] and ``force_max`` [N] as in the constructor.

        Base node angles ``[-a, a, 120-a, 120+a, 240-a, 240+a]`` at radius ``base_radius``;
        top node angles ``[-60+b, 60-b, 60+b, 180-b, 180+b, 300-b]`` at ``top_radius``; all
        at z = 0 in their plate, with ``a = base_half_angle`` and ``b = top_half_angle``.
        """
        r_b = _scalar(base_radius, "base_radius")
        r_t = _scalar(top_radius, "top_radius")
        if r_b <= 0:
            raise GeometryError(f"base_radius: must be > 0 mm, got {r_b}")
        if r_t <= 0:
            raise GeometryError(f"top_radius: must be > 0 mm, got {r_t}")
        a = _scalar(base_half_angle, "base_half_angle")
        b = _scalar(top_half_angle, "top_half_angle")
        d120, d60 = 2 * math.pi / 3, math.pi / 3
        base_ang = np.array([-a, a, d120 - a, d120 + a, 2 * d120 - a, 2 * d120 + a])
        top_ang = np.array([-d60 + b, d60 - b, d60 + b, 3 * d60 - b, 3 * d60 + b, 5 * d60 - b])

        def ring(r: float, ang: FloatArray) -> FloatArray:
            return np.column_stack([r * np.cos(ang), r * np.sin(ang), np.zeros(6)])

        return cls(
            ring(r_b, base_ang),
            ring(r_t, top_ang),
            leg_min,
            leg_max,
            joint_min,
            plate_mass=plate_mass,
            leg_mass=leg_mass,
            force_max=force_max,
            leg_radius=leg_radius,
            plate_thickness=plate_thickness,
        )

    @classmethod
    def reference(cls, *, leg_radius: float = ACTUATOR_RADIUS) -> PlatformGeometry:
        """The reference geometry of DESIGN §2 (chosen, not published by the paper).

        ``r_b = r_t = 150`` mm, ``a = b = 15`` deg, legs 250-450 mm, joints >= 20 deg,
        actuators of radius ``leg_radius`` [mm]: :data:`ACTUATOR_RADIUS` = 12 mm by
        default (a realistic actuator, chosen, not given), ``leg_radius=0`` for the
        paper's model (legs as lines).
        """
        return cls.hexagonal(leg_radius=leg_radius)

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (lists and floats), the inverse of :meth:`from_dict`.

        ``plate_mass``, ``leg_mass``, ``force_max``, ``leg_radius`` and ``plate_thickness``
        appear only when they differ from their defaults (so a geometry of the paper's model
        reads as before; JSON has no inf).
        """
        out: dict[str, Any] = {
            "base_nodes": self.base_nodes.tolist(),
            "top_nodes": self.top_nodes.tolist(),
            "leg_min": self.leg_min,
            "leg_max": self.leg_max,
            "joint_min": self.joint_min,
        }
        out.update(self._extra_fields())
        return out

    def _extra_fields(self) -> dict[str, float]:
        """The fields beyond the paper's model that differ from their defaults, in order."""
        fields = zip(EXTRA_FIELDS, self._extras, EXTRA_DEFAULTS, strict=True)
        return {k: v for k, v, d in fields if v != d}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "platform") -> PlatformGeometry:
        """Build from :meth:`to_dict` output, or from ``{"hexagonal": {...}}``.

        ``where`` prefixes the field names in error messages (e.g. ``platforms[2]``).
        """
        if not isinstance(data, Mapping):
            raise GeometryError(f"{where}: expected a table/object, got {type(data).__name__}")
        if "hexagonal" in data:
            spec = data["hexagonal"]
            if not isinstance(spec, Mapping):
                raise GeometryError(f"{where}.hexagonal: expected a table/object")
            allowed = {
                "base_radius",
                "top_radius",
                "base_half_angle",
                "top_half_angle",
                "leg_min",
                "leg_max",
                "joint_min",
                *EXTRA_FIELDS,
            }
            unknown = set(spec) - allowed
            if unknown:
                raise GeometryError(f"{where}.hexagonal: unknown field(s) {sorted(unknown)}")
            try:
                return cls.hexagonal(**spec)
            except GeometryError as exc:
                raise GeometryError(f"{where}.hexagonal.{exc}") from None
        required = ("base_nodes", "top_nodes", "leg_min", "leg_max", "joint_min")
        for key in required:
            if key not in data:
                raise GeometryError(f"{where}.{key}: missing field")
        unknown = set(data) - set(required) - set(EXTRA_FIELDS)
        if unknown:
            raise GeometryError(f"{where}: unknown field(s) {sorted(unknown)}")
        extra = {k: data[k] for k in EXTRA_FIELDS if k in data}
        try:
            return cls(*(data[k] for k in required), **extra)
        except GeometryError as exc:
            raise GeometryError(f"{where}.{exc}") from None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PlatformGeometry):
            return NotImplemented
        return (
            np.array_equal(self.base_nodes, other.base_nodes)
            and np.array_equal(self.top_nodes, other.top_nodes)
            and (self.leg_min, self.leg_max, self.joint_min)
            == (other.leg_min, other.leg_max, other.joint_min)
            and self._extras == other._extras
        )

    def __hash__(self) -> int:
        return hash(
            (
                self.base_nodes.tobytes(),
                self.top_nodes.tobytes(),
                self.leg_min,
                self.leg_max,
                self.joint_min,
                *self._extras,
            )
        )


#: Entries :meth:`Stack.derived` keeps per stack before it starts over.
_DERIVED_MAX = 256


@dataclass(frozen=True)
class Stack(Sequence[PlatformGeometry]):
    """An ordered stack of n >= 1 Stewart platforms, bottom (platform 1) first.

    Parameters
    ----------
    platforms : sequence of PlatformGeometry
        One geometry per platform; they may differ.
    """

    platforms: tuple[PlatformGeometry, ...]
    _arrays: dict[str, FloatArray] = field(default_factory=dict, repr=False, compare=False)
    _derived: dict[Any, Any] = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        plats = tuple(self.platforms) if isinstance(self.platforms, Iterable) else None
        if plats is None or len(plats) == 0:
            raise GeometryError("platforms: a stack needs at least one platform")
        for i, p in enumerate(plats):
            if not isinstance(p, PlatformGeometry):
                raise GeometryError(
                    f"platforms[{i}]: expected a PlatformGeometry, got {type(p).__name__}"
                )
        object.__setattr__(self, "platforms", plats)

    # --- constructors ---------------------------------------------------------------
    @classmethod
    def uniform(cls, geometry: PlatformGeometry, n: int) -> Stack:
        """``n`` identical platforms."""
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
            raise GeometryError(f"n: the number of platforms must be an integer >= 1, got {n!r}")
        return cls(tuple([geometry] * int(n)))

    @classmethod
    def reference(cls, n: int = 4, *, leg_radius: float = ACTUATOR_RADIUS) -> Stack:
        """``n`` reference platforms (:meth:`PlatformGeometry.reference`), legs of radius
        ``leg_radius`` [mm] (:data:`ACTUATOR_RADIUS` = 12 mm by default; 0 for the paper's
        legs as lines)."""
        return cls.uniform(PlatformGeometry.reference(leg_radius=leg_radius), n)

    # --- sequence protocol ----------------------------------------------------------
    def __len__(self) -> int:
        return len(self.platforms)

    def __getitem__(self, i):  # type: ignore[no-untyped-def, override]
        return self.platforms[i]

    def __iter__(self) -> Iterator[PlatformGeometry]:
        return iter(self.platforms)

    @property
    def n(self) -> int:
        """Number of platforms."""
        return len(self.platforms)

    # --- pickling -------------------------------------------------------------------
    def __reduce__(self) -> tuple[Any, ...]:
        """Pickle the platforms only: the caches (:meth:`derived`, the stacked arrays) are
        rebuilt on first use in the receiving process, read-only as here, so a worker
        solves with exactly the arrays (and compiled kernels) the parent uses."""
        return (Stack, (self.platforms,))

    # --- stacked arrays (cached) ----------------------------------------------------
    def derived(self, key: Any, make: Callable[[Stack], Any]) -> Any:
        """``make(self)``, computed once per key and kept (the geometry is immutable).

        For values derived from the geometry alone (e.g. per plane angle phi) that hot
        paths would otherwise rebuild on every call; they must not be mutated.
        """
        try:
            return self._derived[key]
        except KeyError:
            value = make(self)
            if len(self._derived) >= _DERIVED_MAX:  # e.g. a sweep over many phi: stay bounded
                self._derived.clear()
            self._derived[key] = value
            return value

    def _arr(self, key: str) -> FloatArray:
        if key not in self._arrays:
            p = self.platforms
            values: dict[str, FloatArray] = {
                "base": np.stack([g.base_nodes for g in p]),
                "top": np.stack([g.top_nodes for g in p]),
                "leg_min": np.array([g.leg_min for g in p]),
                "leg_max": np.array([g.leg_max for g in p]),
                "sin_joint": np.sin([g.joint_min for g in p]),
                "plate_mass": np.array([g.plate_mass for g in p]),
                "leg_mass": np.array([g.leg_mass for g in p]),
                "force_max": np.array([g.force_max for g in p]),
            }
            for v in values.values():
                v.setflags(write=False)
            self._arrays.update(values)
        return self._arrays[key]

    @property
    def base_nodes(self) -> FloatArray:
        """Base nodes of every platform, shape (n, 6, 3) [mm]."""
        return self._arr("base")

    @property
    def top_nodes(self) -> FloatArray:
        """Top nodes of every platform, shape (n, 6, 3) [mm]."""
        return self._arr("top")

    @property
    def leg_min(self) -> FloatArray:
        """Minimum leg lengths, shape (n,) [mm]."""
        return self._arr("leg_min")

    @property
    def leg_max(self) -> FloatArray:
        """Maximum leg lengths, shape (n,) [mm]."""
        return self._arr("leg_max")

    @property
    def sin_joint_min(self) -> FloatArray:
        """``sin(joint_min)`` of every platform, shape (n,)."""
        return self._arr("sin_joint")

    @property
    def plate_mass(self) -> FloatArray:
        """Mass of every platform's top plate, shape (n,) [kg]."""
        return self._arr("plate_mass")

    @property
    def leg_mass(self) -> FloatArray:
        """Mass of each leg of every platform, shape (n,) [kg]."""
        return self._arr("leg_mass")

    @property
    def force_max(self) -> FloatArray:
        """Leg force limit of every platform, shape (n,) [N] (``inf`` = no limit)."""
        return self._arr("force_max")

    # --- constraints (delegated to stackik.platform) ---------------------------------
    def planar_constraints(self, q: ArrayLike, phi: float) -> FloatArray:
        """Raw constraint values of a planar pose, shape (n, 24) (mm^2 and mm).

        ``q`` has shape (n, 3), rows ``[rho_i, z_i, theta_i]``; DESIGN §2 order per row:
        ``|l|^2 - leg_min^2`` (6), ``leg_max^2 - |l|^2`` (6), ``l.n - |l| s`` (6),
        ``l.(R n) - |l| s`` (6). Feasible iff all are >= 0.
        """
        from stackik.platform import planar_constraints

        return planar_constraints(self, q, phi)

    def spatial_constraints(self, q: ArrayLike) -> FloatArray:
        """Raw constraint values of a spatial pose (n, 6) ``[x, y, z, yaw, pitch, roll]``.

        Returns shape (n, 24), same order as :meth:`planar_constraints`.
        """
        from stackik.platform import spatial_constraints

        return spatial_constraints(self, q)

    # --- serialisation ----------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """``{"platforms": [PlatformGeometry.to_dict(), ...]}``."""
        return {"platforms": [p.to_dict() for p in self.platforms]}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Stack:
        """Inverse of :meth:`to_dict`.

        Also accepts ``{"platform": {...}, "n": 4}`` for a uniform stack, and
        ``{"hexagonal": {...}}`` entries in place of explicit nodes.
        """
        if not isinstance(data, Mapping):
            raise GeometryError(f"stack: expected a table/object, got {type(data).__name__}")
        if "platforms" in data:
            unknown = set(data) - {"platforms"}
            if unknown:
                raise GeometryError(f"stack: unknown field(s) {sorted(unknown)}")
            plats = data["platforms"]
            if not isinstance(plats, list) or not plats:
                raise GeometryError("platforms: expected a non-empty list of platform tables")
            return cls(
                tuple(
                    PlatformGeometry.from_dict(p, where=f"platforms[{i}]")
                    for i, p in enumerate(plats)
                )
            )
        if "platform" in data:
            unknown = set(data) - {"platform", "n"}
            if unknown:
                raise GeometryError(f"stack: unknown field(s) {sorted(unknown)}")
            n = data.get("n")
            if n is None:
                raise GeometryError("n: missing field (required with 'platform')")
            return cls.uniform(PlatformGeometry.from_dict(data["platform"], where="platform"), n)
        raise GeometryError("platforms: missing field (or 'platform' with 'n')")

    def to_json(self, path: str | Path | None = None) -> str:
        """JSON text of :meth:`to_dict`; also written to ``path`` when given."""
        text = json.dumps(self.to_dict(), indent=2)
        if path is not None:
            Path(path).write_text(text + "\n")
        return text

    def to_toml(self, path: str | Path | None = None) -> str:
        """TOML text (``[[platforms]]`` tables); also written to ``path`` when given."""
        lines = ["# stackik stack geometry: lengths in mm, angles in rad", ""]
        if any(p._extra_fields() for p in self.platforms):
            lines.insert(
                1, "# masses in kg, force limits in N, leg radius and plate thickness in mm"
            )
        for p in self.platforms:
            lines.append("[[platforms]]")
            lines.append(f"leg_min = {p.leg_min!r}")
            lines.append(f"leg_max = {p.leg_max!r}")
            lines.append(f"joint_min = {p.joint_min!r}")
            lines.extend(f"{k} = {v!r}" for k, v in p._extra_fields().items())
            for key, arr in (("base_nodes", p.base_nodes), ("top_nodes", p.top_nodes)):
                rows = ",\n    ".join("[" + ", ".join(repr(float(v)) for v in r) + "]" for r in arr)
                lines.append(f"{key} = [\n    {rows},\n]")
            lines.append("")
        text = "\n".join(lines)
        if path is not None:
            Path(path).write_text(text)
        return text

    @classmethod
    def from_file(cls, path: str | Path) -> Stack:
        """Read a ``.json`` or ``.toml`` geometry file.

        Raises
        ------
        GeometryError
            If the file cannot be parsed or a field is malformed (the message names it).
        """
        path = Path(path)
        data = read_data_file(path, "geometry file", GeometryError)
        try:
            return cls.from_dict(data)
        except GeometryError as exc:
            raise GeometryError(f"{path}: {exc}") from None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Stack):
            return NotImplemented
        return self.platforms == other.platforms

    def __hash__(self) -> int:
        return hash(self.platforms)
