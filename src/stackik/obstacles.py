"""Keep-out bodies in the base frame (docs/clearance.md): spheres, capsules (truss
members), oriented boxes and half-spaces, and the files that list them.

Each obstacle is a frozen value validated on construction (a ``ValueError`` naming the
field) and carries its own exact signed distances to the cores of the stack's bodies
(points, segments, plate polygons) through :mod:`stackik.distance`, so the clearance
check has no branch per obstacle kind.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from stackik import distance as dist
from stackik._arrays import finite_array, readonly
from stackik._io import read_data_file
from stackik.geometry import finite_number

__all__ = [
    "Box",
    "Capsule",
    "HalfSpace",
    "Obstacle",
    "Sphere",
    "as_obstacles",
    "load_obstacles",
    "obstacle_from_dict",
    "obstacles_from_data",
]

FloatArray = NDArray[np.float64]


def _vector(value: Any, name: str, shape: tuple[int, ...] = (3,)) -> FloatArray:
    """A finite float array of ``shape`` (read-only), or a ValueError naming ``name``."""
    return readonly(finite_array(value, name, shape))


def _radius(value: Any, name: str = "radius") -> float:
    r = finite_number(value, name)
    if r < 0:
        raise ValueError(f"{name}: must be >= 0 mm, got {r}")
    return r


class Obstacle:
    """Interface of a keep-out body: signed distances [mm] from the cores of the stack's
    bodies (negative = the core reaches into the obstacle), broadcasting over leading axes.

    A body's signed distance to the obstacle is its core's minus its own radius.
    """

    kind: ClassVar[str]

    def point_distance(self, p: FloatArray) -> FloatArray:
        """Signed distance from points ``p`` (..., 3), shape (...)."""
        raise NotImplementedError

    def segment_distance(self, a: FloatArray, b: FloatArray) -> FloatArray:
        """Signed distance from segments ``[a, b]`` (..., 3), shape (...)."""
        raise NotImplementedError

    def polygon_distance(self, poly: dist.Polygon) -> FloatArray:
        """Signed distance from convex plate polygons, shape (...)."""
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form with a ``type`` field, the inverse of :func:`obstacle_from_dict`."""
        raise NotImplementedError

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickle through the constructor (validated, read-only arrays in the receiver)."""
        return (obstacle_from_dict, (self.to_dict(),))


@dataclass(frozen=True, eq=False)
class Sphere(Obstacle):
    """A ball of ``radius`` [mm] >= 0 about ``center`` (3,) [mm] in the base frame."""

    center: FloatArray
    radius: float
    kind: ClassVar[str] = "sphere"

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vector(self.center, "center"))
        object.__setattr__(self, "radius", _radius(self.radius))

    def point_distance(self, p: FloatArray) -> FloatArray:
        return np.linalg.norm(np.asarray(p) - self.center, axis=-1) - self.radius  # type: ignore[no-any-return]

    def segment_distance(self, a: FloatArray, b: FloatArray) -> FloatArray:
        return dist.point_segment(self.center, a, b) - self.radius

    def polygon_distance(self, poly: dist.Polygon) -> FloatArray:
        return dist.point_polygon(self.center, poly) - self.radius

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.kind, "center": self.center.tolist(), "radius": self.radius}

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Sphere):
            return NotImplemented
        return bool(np.array_equal(self.center, other.center)) and self.radius == other.radius

    def __hash__(self) -> int:
        return hash((self.kind, self.center.tobytes(), self.radius))


@dataclass(frozen=True, eq=False)
class Capsule(Obstacle):
    """All points within ``radius`` [mm] >= 0 of the segment ``[a, b]`` (each (3,) [mm],
    base frame): a truss member. ``a == b`` is a sphere."""

    a: FloatArray
    b: FloatArray
    radius: float
    kind: ClassVar[str] = "capsule"

    def __post_init__(self) -> None:
        object.__setattr__(self, "a", _vector(self.a, "a"))
        object.__setattr__(self, "b", _vector(self.b, "b"))
        object.__setattr__(self, "radius", _radius(self.radius))

    def point_distance(self, p: FloatArray) -> FloatArray:
        return dist.point_segment(p, self.a, self.b) - self.radius

    def segment_distance(self, a: FloatArray, b: FloatArray) -> FloatArray:
        return dist.segment_segment(a, b, self.a, self.b) - self.radius

    def polygon_distance(self, poly: dist.Polygon) -> FloatArray:
        return dist.segment_polygon(self.a, self.b, poly) - self.radius

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.kind,
            "a": self.a.tolist(),
            "b": self.b.tolist(),
            "radius": self.radius,
        }

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Capsule):
            return NotImplemented
        return (
            bool(np.array_equal(self.a, other.a) and np.array_equal(self.b, other.b))
            and self.radius == other.radius
        )

    def __hash__(self) -> int:
        return hash((self.kind, self.a.tobytes(), self.b.tobytes(), self.radius))


@dataclass(frozen=True, eq=False)
class Box(Obstacle):
    """An oriented box: ``center`` (3,) [mm], ``half_extents`` (3,) [mm] >= 0 along its
    axes, ``rotation`` (3, 3) whose columns are the box axes in the base frame (None: the
    base frame's axes). A rotation must be orthonormal with determinant +1 (to 1e-9)."""

    center: FloatArray
    half_extents: FloatArray
    rotation: FloatArray | None = None
    kind: ClassVar[str] = "box"

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vector(self.center, "center"))
        h = _vector(self.half_extents, "half_extents")
        if np.any(h < 0):
            raise ValueError(f"half_extents: must be >= 0 mm, got {h.tolist()}")
        object.__setattr__(self, "half_extents", h)
        if self.rotation is None:
            R = np.eye(3)
            R.setflags(write=False)
        else:
            R = _vector(self.rotation, "rotation", (3, 3))
            if not np.allclose(R.T @ R, np.eye(3), atol=1e-9, rtol=0.0):
                raise ValueError("rotation: must be orthonormal (R^T R = I to 1e-9)")
            if np.linalg.det(R) < 0:
                raise ValueError("rotation: must be a rotation (determinant +1), not a reflection")
        object.__setattr__(self, "rotation", R)

    @property
    def _R(self) -> FloatArray:
        assert self.rotation is not None  # set in __post_init__
        return self.rotation

    def point_distance(self, p: FloatArray) -> FloatArray:
        return dist.point_box(p, self.center, self.half_extents, self._R)

    def segment_distance(self, a: FloatArray, b: FloatArray) -> FloatArray:
        return dist.segment_box(a, b, self.center, self.half_extents, self._R)

    def polygon_distance(self, poly: dist.Polygon) -> FloatArray:
        return dist.polygon_box(poly, self.center, self.half_extents, self._R)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "type": self.kind,
            "center": self.center.tolist(),
            "half_extents": self.half_extents.tolist(),
        }
        if not np.array_equal(self._R, np.eye(3)):
            out["rotation"] = self._R.tolist()
        return out

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Box):
            return NotImplemented
        return bool(
            np.array_equal(self.center, other.center)
            and np.array_equal(self.half_extents, other.half_extents)
            and np.array_equal(self._R, other._R)
        )

    def __hash__(self) -> int:
        return hash(
            (self.kind, self.center.tobytes(), self.half_extents.tobytes(), self._R.tobytes())
        )


@dataclass(frozen=True, eq=False)
class HalfSpace(Obstacle):
    """Everything behind the plane through ``point`` (3,) [mm] with normal ``normal`` (3,):
    the bodies must stay on the side ``normal`` points to. ``normal`` is stored as a unit
    vector; a zero normal is a ``ValueError``."""

    point: FloatArray
    normal: FloatArray
    kind: ClassVar[str] = "halfspace"

    def __post_init__(self) -> None:
        object.__setattr__(self, "point", _vector(self.point, "point"))
        nv = _vector(self.normal, "normal")
        norm = float(np.linalg.norm(nv))
        if not norm > 0.0 or not math.isfinite(norm):
            raise ValueError("normal: must be a non-zero vector")
        # a unit normal is kept as given (so that a stored obstacle reads back equal)
        unit = nv if abs(norm - 1.0) <= 4 * np.finfo(float).eps else nv / norm
        unit.setflags(write=False)
        object.__setattr__(self, "normal", unit)

    def point_distance(self, p: FloatArray) -> FloatArray:
        return (np.asarray(p) - self.point) @ self.normal  # type: ignore[no-any-return]

    def segment_distance(self, a: FloatArray, b: FloatArray) -> FloatArray:
        return dist.segment_halfspace(a, b, self.point, self.normal)

    def polygon_distance(self, poly: dist.Polygon) -> FloatArray:
        return dist.polygon_halfspace(poly, self.point, self.normal)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.kind, "point": self.point.tolist(), "normal": self.normal.tolist()}

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, HalfSpace):
            return NotImplemented
        return bool(
            np.array_equal(self.point, other.point) and np.array_equal(self.normal, other.normal)
        )

    def __hash__(self) -> int:
        return hash((self.kind, self.point.tobytes(), self.normal.tobytes()))


_KINDS: dict[str, tuple[type[Obstacle], tuple[str, ...], tuple[str, ...]]] = {
    # type: (class, required fields, optional fields)
    "sphere": (Sphere, ("center", "radius"), ()),
    "capsule": (Capsule, ("a", "b", "radius"), ()),
    "box": (Box, ("center", "half_extents"), ("rotation",)),
    "halfspace": (HalfSpace, ("point", "normal"), ()),
}


def obstacle_from_dict(data: Mapping[str, Any], where: str = "obstacle") -> Obstacle:
    """Build an obstacle from ``{"type": "sphere" | "capsule" | "box" | "halfspace", ...}``
    (the fields of its class). ``where`` prefixes the field names in error messages."""
    if not isinstance(data, Mapping):
        raise ValueError(f"{where}: expected a table/object, got {type(data).__name__}")
    kind = data.get("type")
    if kind not in _KINDS:
        raise ValueError(f"{where}.type: expected one of {sorted(_KINDS)}, got {kind!r}")
    cls, required, optional = _KINDS[kind]
    for key in required:
        if key not in data:
            raise ValueError(f"{where}.{key}: missing field")
    unknown = set(data) - set(required) - set(optional) - {"type"}
    if unknown:
        raise ValueError(f"{where}: unknown field(s) {sorted(unknown)}")
    try:
        return cls(**{k: data[k] for k in (*required, *optional) if k in data})
    except ValueError as exc:
        raise ValueError(f"{where}.{exc}") from None


def obstacles_from_data(data: Any) -> tuple[Obstacle, ...]:
    """Obstacles from a list of tables, or from ``{"obstacles": [...]}``."""
    if isinstance(data, Mapping):
        unknown = set(data) - {"obstacles"}
        if unknown:
            raise ValueError(f"obstacles file: unknown field(s) {sorted(unknown)}")
        data = data.get("obstacles", [])
    if not isinstance(data, list):
        raise ValueError("obstacles: expected a list of obstacle tables")
    return tuple(obstacle_from_dict(d, where=f"obstacles[{i}]") for i, d in enumerate(data))


def load_obstacles(path: str | Path) -> tuple[Obstacle, ...]:
    """Read a ``.toml`` (``[[obstacles]]`` tables) or ``.json`` (a list, or
    ``{"obstacles": [...]}``) obstacle file; lengths in mm, base frame.

    Raises
    ------
    ValueError
        If the file cannot be read or parsed, or a field is malformed (the message names
        the file and the field, e.g. ``obstacles[1].radius``).
    """
    path = Path(path)
    data = read_data_file(path, "obstacle file", ValueError)
    try:
        return obstacles_from_data(data)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def as_obstacles(obstacles: Sequence[Obstacle] | Obstacle | None) -> tuple[Obstacle, ...]:
    """``obstacles`` as a tuple (one obstacle or None allowed); anything else a ``ValueError``."""
    if obstacles is None:
        return ()
    if isinstance(obstacles, Obstacle):
        return (obstacles,)
    try:
        out = tuple(obstacles)
    except TypeError:
        raise ValueError(
            f"obstacles: expected a sequence of obstacles, got {type(obstacles).__name__}"
        ) from None
    for i, o in enumerate(out):
        if not isinstance(o, Obstacle):
            raise ValueError(
                f"obstacles[{i}]: expected a Sphere, Capsule, Box or HalfSpace, "
                f"got {type(o).__name__}"
            )
    return out
