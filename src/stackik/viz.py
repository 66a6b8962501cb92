"""Interactive 3D views of poses and paths: one self-contained HTML file (plotly).

:func:`pose_figure` draws one pose, :func:`path_figure` a pose sequence with a slider and a
play button; :func:`write_html` writes either as one HTML file with plotly.js inlined
(no server, no CDN: it opens offline). plotly is the optional ``plot`` extra and is
imported inside the functions; without it they raise an ImportError that says how to
install it.

What is drawn (base frame, millimetres):

* plates as filled polygons through the leg nodes they carry (the base plate dark grey,
  intermediate plates light grey, the end-effector plate gold);
* legs as lines from base node to top node, coloured by their margin to the nearest limit
  (:func:`leg_margins`, from the library's own constraint evaluation,
  :meth:`~stackik.geometry.Stack.spatial_constraints` / ``planar_constraints``), or by any
  per-leg value given as ``leg_values`` (e.g. leg forces [N]) with its colour-bar title;
* plate centres joined by a dotted line, the end effector a diamond;
* the target frame: its three axes (x red, y green, z blue);
* obstacles, when given: spheres, capsules, boxes and half-spaces (:func:`obstacle_record`
  says which records are understood).

Planar poses (rows ``[rho, z, theta]`` with the plane azimuth ``phi``) are drawn in 3D
through :func:`stackik.analysis.figures.stack_nodes`, the same lift as every figure.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.analysis._nodes import stack_nodes
from stackik.formulation.modes import mode_of
from stackik.geometry import Stack
from stackik.targets import Target

if TYPE_CHECKING:
    from stackik.paths.result import PathResult

__all__ = [
    "MARGIN_TITLE",
    "LegMargins",
    "ObstacleRecord",
    "leg_margins",
    "obstacle_record",
    "path_figure",
    "pose_figure",
    "require_plotly",
    "write_html",
]

FloatArray = NDArray[np.float64]

#: Colour-bar title of the default leg colouring (:attr:`LegMargins.fraction`).
MARGIN_TITLE = "margin to nearest limit<br>(0 = at a limit, 1 = mid-range)"

_PLATE_COLORS = ("#4a4a4a", "#b8c0cc", "#e0a526")  # base, intermediate, end effector
_AXIS_COLORS = ("#d62728", "#2ca02c", "#1f77b4")  # x, y, z
_OBSTACLE_COLOR = "#9467bd"


def require_plotly() -> Any:
    """The ``plotly.graph_objects`` module, or an ImportError with the install hint."""
    try:
        import plotly.graph_objects as go
    except ImportError as exc:
        raise ImportError(
            "the interactive viewer needs plotly: pip install 'stackik[plot]' (or plotly)",
            name="plotly",
        ) from exc
    return go


# =========================================================================================
# Leg margins
# =========================================================================================
@dataclass(frozen=True, eq=False)
class LegMargins:
    """Margins of every leg of a pose to its limits (:func:`leg_margins`).

    Attributes
    ----------
    length : ndarray, shape (n, 6)
        Leg lengths ``|l|`` [mm].
    length_margin : ndarray, shape (n, 6)
        ``min(|l| - leg_min, leg_max - |l|)`` [mm].
    joint_base, joint_top : ndarray, shape (n, 6)
        Angle between the leg and its base (top) plate minus ``joint_min`` [deg].
    fraction : ndarray, shape (n, 6)
        The smallest of the three margins, each as a fraction of its range: the length
        margin over ``(leg_max - leg_min) / 2`` and the angle margins over
        ``90 deg - joint_min``. 0 at a limit, 1 at mid-stroke / a leg normal to its
        plates, negative where a limit is violated.
    nearest : ndarray of str, shape (n, 6)
        Which limit is nearest: ``"leg_min"``, ``"leg_max"``, ``"joint_base"`` or
        ``"joint_top"``.
    """

    length: FloatArray
    length_margin: FloatArray
    joint_base: FloatArray
    joint_top: FloatArray
    fraction: FloatArray
    nearest: NDArray[np.str_]


def leg_margins(stack: Stack, q: ArrayLike, phi: float | None = None) -> LegMargins:
    """Per-leg margins of a pose, from the raw constraint values of DESIGN §2.

    Parameters
    ----------
    stack : Stack
    q : array_like, shape (n, 3) planar (with ``phi``) or (n, 6) spatial
        Pose [mm, rad].
    phi : float, optional
        Plane azimuth of a planar pose [rad].

    Returns
    -------
    LegMargins
    """
    qa = np.asarray(q, dtype=float)
    if qa.ndim != 2 or qa.shape[1] not in (3, 6):
        raise ValueError(f"q: expected shape (n, 3) or (n, 6), got {qa.shape}")
    if qa.shape[1] == 3:
        if phi is None:
            raise ValueError("phi: required for a planar pose (n, 3)")
        c = stack.planar_constraints(qa, phi)
    else:
        c = stack.spatial_constraints(qa)
    lmin, lmax = stack.leg_min[:, None], stack.leg_max[:, None]
    s = stack.sin_joint_min[:, None]
    length = np.sqrt(np.maximum(c[:, 0:6] + lmin**2, 0.0))  # c = |l|^2 - leg_min^2
    safe = np.where(length > 0, length, 1.0)
    # c = l.n - |l| s = |l| (sin(angle) - s)
    ang_b = np.degrees(np.arcsin(np.clip(c[:, 12:18] / safe + s, -1.0, 1.0)))
    ang_t = np.degrees(np.arcsin(np.clip(c[:, 18:24] / safe + s, -1.0, 1.0)))
    jmin = np.degrees(np.arcsin(s))
    to_min, to_max = length - lmin, lmax - length
    jb, jt = ang_b - jmin, ang_t - jmin
    half = (lmax - lmin) / 2
    span = 90.0 - jmin
    fr = np.stack([to_min / half, to_max / half, jb / span, jt / span])  # (4, n, 6)
    names = np.array(["leg_min", "leg_max", "joint_base", "joint_top"])
    return LegMargins(
        length=length,
        length_margin=np.minimum(to_min, to_max),
        joint_base=jb,
        joint_top=jt,
        fraction=fr.min(axis=0),
        nearest=names[fr.argmin(axis=0)],
    )


# =========================================================================================
# Obstacles
# =========================================================================================
@dataclass(frozen=True, eq=False)
class ObstacleRecord:
    """One obstacle to draw, in the base frame [mm] (:func:`obstacle_record`).

    Attributes
    ----------
    kind : str
        ``"sphere"``, ``"capsule"``, ``"box"`` or ``"halfspace"``.
    center : ndarray, shape (3,)
        Sphere or box centre; a point of a half-space's boundary plane.
    radius : float
        Sphere or capsule radius (0 otherwise).
    a, b : ndarray, shape (3,)
        Capsule axis end points (else equal to ``center``).
    half_extents : ndarray, shape (3,)
        Box half sizes along its own axes (else zeros).
    rotation : ndarray, shape (3, 3)
        Box axes in the base frame (columns); the identity otherwise.
    normal : ndarray, shape (3,)
        Outward unit normal of a half-space's boundary (the obstacle is the side it
        points away from: ``{x : normal . (x - center) <= 0}``).
    name : str
    """

    kind: str
    center: FloatArray
    radius: float = 0.0
    a: FloatArray | None = None
    b: FloatArray | None = None
    half_extents: FloatArray | None = None
    rotation: FloatArray | None = None
    normal: FloatArray | None = None
    name: str = ""


def _field(ob: Any, *names: str) -> Any:
    for name in names:
        if isinstance(ob, Mapping):
            if name in ob:
                return ob[name]
        elif hasattr(ob, name):
            return getattr(ob, name)
    return None


def _vec(value: Any, what: str) -> FloatArray:
    v = np.asarray(value, dtype=float).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"obstacles: {what}: expected 3 finite numbers, got {value!r}")
    return v


def _radius(ob: Any) -> float:
    r = _field(ob, "radius", "r")
    try:
        value = float(r)
    except (TypeError, ValueError):
        raise ValueError(f"obstacles: radius: expected a number, got {r!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"obstacles: radius: expected a positive number, got {r!r}")
    return value


def obstacle_record(ob: Any) -> ObstacleRecord:
    """Read an obstacle given as a mapping or as any object with the same attributes.

    The kind is ``ob["kind"]`` / ``ob.kind`` (or ``type``, or the class name, e.g. a
    ``Sphere`` dataclass). Fields, base frame [mm]:

    * sphere: ``center``, ``radius``;
    * capsule (a truss member): ``a`` and ``b`` (or ``p0``/``p1``, ``start``/``end``),
      ``radius``;
    * box: ``center``, ``half_extents`` (or ``size`` = full edge lengths), optional
      ``rotation`` (3, 3);
    * halfspace: ``normal`` and ``point`` (or ``offset`` d with the plane
      ``normal . x = d``); the obstacle is ``normal . (x - point) <= 0``.

    Raises
    ------
    ValueError
        Naming the field that is missing or malformed.
    """
    if isinstance(ob, ObstacleRecord):
        return ob
    kind = _field(ob, "kind", "type", "shape")
    if kind is None and not isinstance(ob, Mapping):
        kind = type(ob).__name__
    kind = str(kind).lower().replace("-", "").replace("_", "") if kind is not None else ""
    name = str(_field(ob, "name", "label") or kind)
    if kind == "sphere":
        r = _radius(ob)
        return ObstacleRecord(
            "sphere", _vec(_field(ob, "center", "centre"), "center"), r, name=name
        )
    if kind in ("capsule", "cylinder", "segment"):
        a = _vec(_field(ob, "a", "p0", "start"), "capsule a")
        b = _vec(_field(ob, "b", "p1", "end"), "capsule b")
        r = _radius(ob)
        return ObstacleRecord("capsule", (a + b) / 2, r, a=a, b=b, name=name)
    if kind == "box":
        c = _vec(_field(ob, "center", "centre"), "box center")
        he = _field(ob, "half_extents", "half_size", "halfsize")
        if he is None:
            size = _field(ob, "size", "extents")
            if size is None:
                raise ValueError("obstacles: box needs half_extents (or size)")
            he = 0.5 * np.asarray(size, dtype=float)
        R = _field(ob, "rotation", "R")
        Rm = np.eye(3) if R is None else np.asarray(R, dtype=float).reshape(3, 3)
        return ObstacleRecord(
            "box", c, half_extents=_vec(he, "box half_extents"), rotation=Rm, name=name
        )
    if kind in ("halfspace", "plane"):
        nv = _vec(_field(ob, "normal"), "halfspace normal")
        nrm = float(np.linalg.norm(nv))
        if nrm == 0:
            raise ValueError("obstacles: halfspace normal must be nonzero")
        nv = nv / nrm
        p = _field(ob, "point", "center", "origin")
        if p is None:
            d = _field(ob, "offset", "d")
            if d is None:
                raise ValueError("obstacles: halfspace needs point (or offset)")
            p = nv * float(d) / nrm
        return ObstacleRecord("halfspace", _vec(p, "halfspace point"), normal=nv, name=name)
    raise ValueError(
        f"obstacles: unknown kind {kind!r} (sphere, capsule, box or halfspace): {ob!r}"
    )


def _frame_basis(u: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Two unit vectors orthogonal to the unit vector u and to each other."""
    t = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(u, t)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(u, e1)


def _grid_mesh(X: FloatArray) -> tuple[FloatArray, NDArray[np.int64]]:
    """Vertices (k*m, 3) and triangles of a (k, m, 3) grid of points (rows and columns)."""
    k, m = X.shape[:2]
    idx = np.arange(k * m).reshape(k, m)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    tri = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])
    return X.reshape(-1, 3), tri


def _obstacle_mesh(ob: ObstacleRecord, extent: float) -> tuple[FloatArray, NDArray[np.int64]]:
    """Triangle mesh of an obstacle (vertices [mm], triangle indices)."""
    if ob.kind in ("sphere", "capsule"):
        a = ob.center if ob.a is None else ob.a
        b = ob.center if ob.b is None else ob.b
        axis = b - a
        length = float(np.linalg.norm(axis))
        u = axis / length if length > 0 else np.array([0.0, 0.0, 1.0])
        e1, e2 = _frame_basis(u)
        lon = np.linspace(0, 2 * np.pi, 25)
        ring = np.cos(lon)[:, None] * e1 + np.sin(lon)[:, None] * e2  # (25, 3)
        rows = []  # lower half sphere about a, then upper half about b (the tube between)
        for end, lats in ((a, np.linspace(-np.pi / 2, 0, 7)), (b, np.linspace(0, np.pi / 2, 7))):
            for t in lats:
                rows.append(end + ob.radius * (np.cos(t) * ring + np.sin(t) * u))
        return _grid_mesh(np.array(rows))
    if ob.kind == "box":
        assert ob.half_extents is not None and ob.rotation is not None
        s = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
        V = ob.center + (s * ob.half_extents) @ ob.rotation.T
        quads = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]
        tri = np.array([t for q in quads for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))])
        return V, tri
    assert ob.normal is not None  # halfspace: a square of its boundary plane
    e1, e2 = _frame_basis(ob.normal)
    V = np.array([ob.center + extent * (i * e1 + j * e2) for i in (-1, 1) for j in (-1, 1)])
    return V, np.array([[0, 1, 3], [0, 3, 2]])


# =========================================================================================
# Figure pieces
# =========================================================================================
def _target_frame(target: Target | None) -> tuple[FloatArray, FloatArray] | None:
    if target is None:
        return None
    try:
        t = mode_of(target).spatial_target(target)
    except ValueError:
        raise ValueError(
            f"target: expected a PlanarTarget or SpatialTarget, got {target!r}"
        ) from None
    return np.asarray(t.position, float), np.asarray(t.rotation, float)


def _plates(stack: Stack, nd: dict[str, FloatArray]) -> tuple[FloatArray, FloatArray, list[str]]:
    """One triangle fan per plate (0 = base .. n = end effector) from its centre through
    every node it carries, in the order of their angle: vertices, triangles, face colours."""
    verts, tris, colors = [], [], []
    offset = 0
    n = stack.n
    for j in range(n + 1):
        local, world = [], []
        if j > 0:
            local.append(stack.top_nodes[j - 1])
            world.append(nd["top"][j - 1])
        if j < n:
            local.append(stack.base_nodes[j])
            world.append(nd["base"][j])
        L, W = np.concatenate(local), np.concatenate(world)
        ring = W[np.argsort(np.arctan2(L[:, 1], L[:, 0]))]
        m = len(ring)
        verts.append(np.vstack([nd["O"][j], ring]))
        tris += [(offset, offset + 1 + i, offset + 1 + (i + 1) % m) for i in range(m)]
        color = _PLATE_COLORS[0 if j == 0 else (2 if j == n else 1)]
        colors += [color] * m
        offset += m + 1
    return np.concatenate(verts), np.array(tris, dtype=float), colors


def _segments(a: FloatArray, b: FloatArray) -> FloatArray:
    """Points (3k, 3) of k segments a -> b separated by NaN gaps (plotly breaks lines)."""
    out = np.full((len(a), 3, 3), np.nan)
    out[:, 0], out[:, 1] = a, b
    return out.reshape(-1, 3)


def _none(x: FloatArray) -> list[Any]:
    return [None if not math.isfinite(v) else float(v) for v in x]


@dataclass(frozen=True)
class _Colouring:
    values: FloatArray  # (m, n, 6)
    title: str
    cmin: float
    cmax: float
    colorscale: Any


def _pose_traces(
    go: Any,
    stack: Stack,
    q: FloatArray,
    phi: float | None,
    target: Target | None,
    values: FloatArray,
    colouring: _Colouring,
    axis_length: float,
    show_legend: bool,
) -> list[Any]:
    """The traces of one pose, always in the same order (frames replace them)."""
    nd = stack_nodes(stack, q, phi)
    margins = leg_margins(stack, q, phi)
    V, T, fc = _plates(stack, nd)
    plates = go.Mesh3d(
        x=V[:, 0], y=V[:, 1], z=V[:, 2], i=T[:, 0], j=T[:, 1], k=T[:, 2],
        facecolor=fc, opacity=0.85, flatshading=True, name="plates", showlegend=show_legend,
        hoverinfo="skip", lighting={"ambient": 0.7, "diffuse": 0.5, "specular": 0.1},
    )  # fmt: skip
    n = stack.n
    pts = _segments(nd["base"].reshape(-1, 3), nd["top"].reshape(-1, 3))
    vals = np.repeat(values.reshape(-1), 3).tolist()  # a list: plotly.js reads it per point
    texts = []
    for i in range(n):
        for k in range(6):
            txt = (
                f"platform {i + 1}, leg {k + 1}<br>length {margins.length[i, k]:.1f} mm "
                f"({stack.leg_min[i]:.0f}-{stack.leg_max[i]:.0f})<br>joint angles "
                f"{margins.joint_base[i, k]:+.1f} / {margins.joint_top[i, k]:+.1f} deg over "
                f"the minimum<br>nearest limit {margins.nearest[i, k]}<br>"
                f"{colouring.title.split('<br>')[0]}: {values[i, k]:.3g}"
            )
            texts += [txt, txt, ""]
    legs = go.Scatter3d(
        x=_none(pts[:, 0]), y=_none(pts[:, 1]), z=_none(pts[:, 2]), mode="lines",
        name="legs", showlegend=show_legend, text=texts, hoverinfo="text",
        line={
            "width": 7, "color": vals, "colorscale": colouring.colorscale,
            "cmin": colouring.cmin, "cmax": colouring.cmax, "showscale": True,
            "colorbar": {"title": {"text": colouring.title, "side": "right"}, "len": 0.75,
                         "thickness": 18, "x": 1.0},
        },
    )  # fmt: skip
    O = nd["O"]
    centres = go.Scatter3d(
        x=O[:, 0], y=O[:, 1], z=O[:, 2], mode="lines+markers", name="plate centres",
        showlegend=show_legend, line={"color": "#555555", "width": 2, "dash": "dot"},
        marker={"size": 3, "color": "#555555"}, hoverinfo="x+y+z",
    )  # fmt: skip
    ee = go.Scatter3d(
        x=O[-1:, 0], y=O[-1:, 1], z=O[-1:, 2], mode="markers", name="end effector",
        showlegend=show_legend, marker={"size": 6, "color": "#e0a526", "symbol": "diamond",
                                        "line": {"color": "black", "width": 1}},
    )  # fmt: skip
    frame = _target_frame(target)
    axes = []
    for a, (col, label) in enumerate(zip(_AXIS_COLORS, "xyz", strict=True)):
        if frame is None:
            xyz: list[list[Any]] = [[None], [None], [None]]
        else:
            p, R = frame
            tip = p + axis_length * R[:, a]
            xyz = [[p[d], tip[d]] for d in range(3)]
        axes.append(
            go.Scatter3d(
                x=xyz[0],
                y=xyz[1],
                z=xyz[2],
                mode="lines",
                line={"color": col, "width": 9},
                name="target frame (x red, y green, z blue)",
                legendgroup="target",
                showlegend=show_legend and a == 0 and frame is not None,
                hovertext=f"target {label} axis",
                hoverinfo="text",
            )  # fmt: skip
        )
    return [plates, legs, centres, ee, *axes]


def _scene(points: FloatArray, pad: float) -> dict[str, Any]:
    """Scene with fixed ranges (the same for every frame) and true proportions."""
    lo = np.nanmin(points, axis=0) - pad
    hi = np.nanmax(points, axis=0) + pad
    lo[2] = min(lo[2], 0.0)
    span = hi - lo
    ratio = span / span.max()
    return {
        "xaxis": {"title": {"text": "x [mm]"}, "range": [lo[0], hi[0]]},
        "yaxis": {"title": {"text": "y [mm]"}, "range": [lo[1], hi[1]]},
        "zaxis": {"title": {"text": "z [mm]"}, "range": [lo[2], hi[2]]},
        "aspectmode": "manual",  # = "data" with these fixed ranges, steady across frames
        "aspectratio": {"x": ratio[0], "y": ratio[1], "z": ratio[2]},
        "camera": {"eye": {"x": 1.15, "y": -1.3, "z": 0.5}, "center": {"x": 0, "y": 0, "z": 0}},
    }


def _poses_array(stack: Stack, poses: ArrayLike) -> FloatArray:
    qa = np.asarray(poses, dtype=float)
    if qa.ndim == 2:
        qa = qa[None]
    if qa.ndim != 3 or qa.shape[1] != stack.n or qa.shape[2] not in (3, 6):
        raise ValueError(
            f"poses: expected shape (m, {stack.n}, 3) or (m, {stack.n}, 6), got {qa.shape}"
        )
    if len(qa) == 0:
        raise ValueError("poses: no pose to draw")
    if not np.all(np.isfinite(qa)):
        raise ValueError("poses: contains NaN or infinite values (draw reached poses only)")
    return qa


def _colouring(
    stack: Stack,
    qa: FloatArray,
    phi: float | None,
    leg_values: ArrayLike | None,
    title: str | None,
    value_range: tuple[float, float] | None,
    colorscale: Any,
) -> _Colouring:
    m = len(qa)
    if leg_values is None:
        vals = np.stack([leg_margins(stack, q, phi).fraction for q in qa])
        lo, hi = (0.0, 1.0) if value_range is None else value_range
        return _Colouring(vals, title or MARGIN_TITLE, lo, hi, colorscale or "RdYlGn")
    vals = np.asarray(leg_values, dtype=float)
    if vals.shape == (stack.n, 6):
        vals = np.broadcast_to(vals, (m, stack.n, 6))
    if vals.shape != (m, stack.n, 6):
        raise ValueError(
            f"leg_values: expected shape ({stack.n}, 6) or ({m}, {stack.n}, 6), got {vals.shape}"
        )
    if value_range is None:
        finite = vals[np.isfinite(vals)]
        lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
        if hi <= lo:
            lo, hi = lo - 0.5, hi + 0.5
    else:
        lo, hi = value_range
    return _Colouring(vals, title or "leg value", lo, hi, colorscale or "Viridis")


def _obstacle_traces(go: Any, obstacles: Sequence[Any] | None, extent: float) -> list[Any]:
    out = []
    for idx, ob in enumerate(obstacles or ()):
        rec = obstacle_record(ob)
        V, T = _obstacle_mesh(rec, extent)
        out.append(
            go.Mesh3d(
                x=V[:, 0],
                y=V[:, 1],
                z=V[:, 2],
                i=T[:, 0],
                j=T[:, 1],
                k=T[:, 2],
                color=_OBSTACLE_COLOR,
                opacity=0.35 if rec.kind == "halfspace" else 0.5,
                name="obstacles",
                legendgroup="obstacles",
                showlegend=idx == 0,
                hovertext=f"{rec.name} ({rec.kind})",
                hoverinfo="text",
                flatshading=True,
            )  # fmt: skip
        )
    return out


def _marks_closest(
    stack: Stack, obstacles: Sequence[Any] | None, clearance: float, closest: bool | None
) -> bool:
    if closest is not None:
        return bool(closest)
    from stackik.clearance import needs_clearances
    from stackik.obstacles import Obstacle

    obs = tuple(obstacles or ())
    if not all(isinstance(ob, Obstacle) for ob in obs):  # plain drawing records
        return False
    return needs_clearances(stack, obs, clearance)


def _closest_trace(
    go: Any,
    stack: Stack,
    q: FloatArray,
    phi: float | None,
    obstacles: Sequence[Any] | None,
    clearance: float,
) -> Any:
    """The pose's closest pair: a segment between its two closest points with its signed
    distance [mm] as text (red below the margin), named ``closest pair`` (empty if none)."""
    from stackik.clearance import clearances, contact_points

    obs = tuple(obstacles or ())
    c = clearances(stack, q, obs, phi=phi).closest
    cp = None if c is None else contact_points(stack, q, c, obs, phi=phi)
    if cp is None:
        return go.Scatter3d(x=[None], y=[None], z=[None], mode="lines", name="closest pair",
                            showlegend=False)  # fmt: skip
    ab = np.stack([cp.a, cp.b])
    col = "#d62728" if cp.distance < max(clearance, 0.0) else "#1a7f37"  # as clearance_art
    what = str(cp.contact).rsplit(":", 1)[0]
    return go.Scatter3d(
        x=ab[:, 0], y=ab[:, 1], z=ab[:, 2], mode="lines+markers+text", name="closest pair",
        line={"color": col, "width": 8}, marker={"size": 4, "color": col},
        text=[cp.label(), ""], textposition="top center",
        textfont={"color": col, "size": 14},
        hovertext=f"closest pair: {what}, {cp.distance:.2f} mm", hoverinfo="text",
    )  # fmt: skip


def _layout(title: str, scene: dict[str, Any]) -> dict[str, Any]:
    return {
        "title": {"text": title, "x": 0.02, "xanchor": "left", "font": {"size": 15}},
        "scene": scene,
        "legend": {"x": 0.01, "y": 0.93, "xanchor": "left", "yanchor": "top",
                   "bgcolor": "rgba(255,255,255,0.75)", "font": {"size": 12}},
        "margin": {"l": 0, "r": 0, "t": 50, "b": 0},
        "paper_bgcolor": "white",
        "uirevision": "keep",  # the camera stays where the user put it while frames play
    }  # fmt: skip


# =========================================================================================
# Public figures
# =========================================================================================
def pose_figure(
    stack: Stack,
    q: ArrayLike,
    *,
    phi: float | None = None,
    target: Target | None = None,
    leg_values: ArrayLike | None = None,
    leg_values_title: str | None = None,
    value_range: tuple[float, float] | None = None,
    colorscale: Any = None,
    obstacles: Sequence[Any] | None = None,
    title: str | None = None,
    clearance: float = 0.0,
    closest: bool | None = None,
) -> Any:
    """Interactive 3D figure of one pose.

    Parameters
    ----------
    stack : Stack
    q : array_like, shape (n, 3) planar (with ``phi``) or (n, 6) spatial
        The pose [mm, rad].
    phi : float, optional
        Plane azimuth of a planar pose [rad].
    target : PlanarTarget or SpatialTarget, optional
        Drawn as its frame (three axes).
    leg_values : array_like, shape (n, 6), optional
        Colour of every leg (e.g. leg forces [N]) instead of the margin to its nearest
        limit (:attr:`LegMargins.fraction`, red at a limit, green mid-range).
    leg_values_title : str, optional
        Colour-bar title of ``leg_values`` (with its unit).
    value_range : (float, float), optional
        Colour range (default: 0..1 for margins, the values' range otherwise).
    colorscale : str or list, optional
        A plotly colour scale (default ``"RdYlGn"`` for margins, ``"Viridis"`` otherwise).
    obstacles : sequence, optional
        Obstacles to draw (:func:`obstacle_record` lists the accepted records).
    title : str, optional
    clearance : float
        Margin [mm]: a closest pair below it (or negative) is drawn red, else green.
    closest : bool, optional
        Mark the closest pair of bodies: a segment between the two closest points
        (:func:`stackik.clearance.contact_points`) labelled with its distance [mm];
        default: when a clearance can fail (:func:`stackik.clearance.needs_clearances`;
        needs :class:`stackik.Obstacle` obstacles).

    Returns
    -------
    plotly.graph_objects.Figure
    """
    return path_figure(
        stack,
        q,
        phi=phi,
        targets=None if target is None else [target],
        leg_values=leg_values,
        leg_values_title=leg_values_title,
        value_range=value_range,
        colorscale=colorscale,
        obstacles=obstacles,
        title=title,
        clearance=clearance,
        closest=closest,
    )


def path_figure(
    stack: Stack,
    poses: ArrayLike | PathResult,
    *,
    phi: float | None = None,
    targets: Sequence[Target] | None = None,
    leg_values: ArrayLike | None = None,
    leg_values_title: str | None = None,
    value_range: tuple[float, float] | None = None,
    colorscale: Any = None,
    obstacles: Sequence[Any] | None = None,
    labels: Sequence[str] | None = None,
    title: str | None = None,
    frame_ms: int = 120,
    clearance: float = 0.0,
    closest: bool | None = None,
) -> Any:
    """Interactive 3D figure of a pose sequence: one frame per pose, a slider and a play
    button (a single pose gives a figure without them).

    Parameters
    ----------
    stack : Stack
    poses : array_like, shape (m, n, 3) or (m, n, 6), or PathResult
        The poses [mm, rad]; a :class:`~stackik.paths.PathResult` gives its reached
        poses, its targets, its plane azimuth and per-waypoint labels (FN, time).
    phi : float, optional
        Plane azimuth of planar poses [rad] (taken from a planar PathResult's targets).
    targets : sequence of targets, length m (or 1), optional
        The target of each pose, drawn as its frame; the whole path is drawn dashed.
    leg_values : array_like, shape (m, n, 6) or (n, 6), optional
        Colour of every leg at every pose, with ``leg_values_title`` (see
        :func:`pose_figure`).
    leg_values_title, value_range, colorscale, obstacles, title, clearance, closest
        As in :func:`pose_figure` (the closest pair is marked at every pose).
    labels : sequence of str, length m, optional
        Slider labels (default the pose index).
    frame_ms : int
        Time per frame of the play button [ms].

    Returns
    -------
    plotly.graph_objects.Figure
    """
    go = require_plotly()
    if hasattr(poses, "q") and hasattr(poses, "targets"):  # a PathResult
        poses, phi, targets, labels, title = _path_defaults(poses, phi, targets, labels, title)
    qa = _poses_array(stack, poses)
    m = len(qa)
    if qa.shape[2] == 3 and phi is None:
        raise ValueError("phi: required for planar poses (n, 3)")
    tg = _one_target_per_pose(targets, m)
    if labels is not None and len(labels) != m:
        raise ValueError(f"labels: expected {m} labels, got {len(labels)}")
    colouring = _colouring(stack, qa, phi, leg_values, leg_values_title, value_range, colorscale)
    radius = float(np.linalg.norm(stack.top_nodes[..., :2], axis=-1).max())
    axis_length = 0.9 * radius
    tpos, all_pts = _drawn_points(stack, qa, phi, tg)
    scene = _scene(all_pts, pad=axis_length + 30.0)
    extent = 0.5 * float(np.nanmax(all_pts.max(0) - all_pts.min(0))) + axis_length

    traces = [
        _pose_traces(go, stack, q, phi, t, colouring.values[k], colouring, axis_length, k == 0)
        for k, (q, t) in enumerate(zip(qa, tg, strict=True))
    ]
    if _marks_closest(stack, obstacles, clearance, closest):
        for k, q in enumerate(qa):
            traces[k].append(_closest_trace(go, stack, q, phi, obstacles, clearance))
    static: list[Any] = _obstacle_traces(go, obstacles, extent)
    solid = [t for t in static if t.hovertext and "halfspace" not in t.hovertext]
    if solid:  # keep the bodies in view (a half-space is drawn as large as the scene)
        extra = np.concatenate([np.stack([t.x, t.y, t.z], 1) for t in solid])
        scene = _scene(np.concatenate([all_pts, extra]), pad=axis_length + 30.0)
    if m > 1 and len(tpos) > 1:
        static.append(
            go.Scatter3d(
                x=tpos[:, 0],
                y=tpos[:, 1],
                z=tpos[:, 2],
                mode="lines",
                name="target path",
                line={"color": "black", "width": 3, "dash": "dash"},
                hoverinfo="skip",
            )  # fmt: skip
        )
    fig = go.Figure(data=traces[0] + static)
    base_title = title or (
        f"{stack.n}-platform stack" + (f", {m} poses" if m > 1 else "") + " (mm)"
    )
    fig.update_layout(**_layout(base_title, scene))
    if m > 1:
        names = [str(k) for k in range(m)] if labels is None else [str(s) for s in labels]
        _add_player(go, fig, traces, names, frame_ms)
    return fig


def _drawn_points(
    stack: Stack, qa: FloatArray, phi: float | None, tg: list[Target | None]
) -> tuple[FloatArray, FloatArray]:
    """The targets' positions (k, 3) and every leg end and target position drawn [mm]."""
    nodes = [stack_nodes(stack, q, phi) for q in qa]
    pts = [np.concatenate([nd["base"].reshape(-1, 3), nd["top"].reshape(-1, 3)]) for nd in nodes]
    frames_xyz = [_target_frame(t) for t in tg]
    tpos = np.array([f[0] for f in frames_xyz if f is not None]).reshape(-1, 3)
    return tpos, np.concatenate(pts + [tpos])


def _path_defaults(
    res: Any,
    phi: float | None,
    targets: Sequence[Target] | None,
    labels: Sequence[str] | None,
    title: str | None,
) -> tuple[FloatArray, float | None, Sequence[Target], Sequence[str], str]:
    """``(poses, phi, targets, labels, title)`` of :func:`path_figure` for a PathResult:
    its reached poses, and what is not given taken from it."""
    c = int(res.completed)
    if c == 0:
        raise ValueError("poses: the path has no reached waypoint to draw")
    t0 = res.targets[0]
    if phi is None:  # a planar path's plane (None for a spatial path)
        phi = mode_of(t0).phi(t0)
    if targets is None:
        targets = list(res.targets[:c])
    if labels is None:
        fn = res.frobenius_norm
        labels = [
            f"{k}: FN {fn[k]:.0f}" + (f", t {res.times[k]:.2f} s" if res.times is not None else "")
            for k in range(c)
        ]
    if title is None:
        kind = mode_of(t0).name
        title = (
            f"{res.n}-platform stack, {kind} path: {c}/{res.m} waypoints, "
            f"{res.status.value} (mean FN {res.mean_frobenius_norm:.0f})"
        )
    return np.asarray(res.q[:c]), phi, targets, labels, title


def _one_target_per_pose(targets: Sequence[Target] | None, m: int) -> list[Target | None]:
    """``targets`` as one entry per pose (None: no target; a single one: the same for all)."""
    if targets is None:
        return [None] * m
    tg: list[Target | None] = list(targets)
    if len(tg) == 1:
        tg = tg * m
    if len(tg) != m:
        raise ValueError(f"targets: expected {m} targets (one per pose) or 1, got {len(tg)}")
    return tg


def _add_player(go: Any, fig: Any, traces: list[list[Any]], names: list[str], ms: int) -> None:
    """One frame per pose, a play/pause button and a slider (``ms`` per frame)."""
    m = len(traces)
    idx = list(range(len(traces[0])))
    fig.frames = [go.Frame(data=traces[k], traces=idx, name=names[k]) for k in range(m)]
    play = {"frame": {"duration": ms, "redraw": True}, "fromcurrent": True,
            "transition": {"duration": 0}, "mode": "immediate"}  # fmt: skip
    pause = {"frame": {"duration": 0, "redraw": False}, "mode": "immediate",
             "transition": {"duration": 0}}  # fmt: skip
    fig.update_layout(
        scene_domain={"x": [0.0, 1.0], "y": [0.1, 1.0]},  # room for the slider below
        updatemenus=[{
            "type": "buttons", "direction": "left", "x": 0.01, "y": 0.02, "xanchor": "left",
            "yanchor": "bottom", "pad": {"r": 6, "t": 6}, "showactive": False,
            "buttons": [{"label": "play", "method": "animate", "args": [None, play]},
                        {"label": "pause", "method": "animate", "args": [[None], pause]}],
        }],
        sliders=[{
            "active": 0, "x": 0.14, "y": 0.02, "len": 0.6, "xanchor": "left", "yanchor": "bottom",
            "pad": {"t": 6, "b": 0}, "currentvalue": {"prefix": "waypoint ", "font": {"size": 12}},
            "steps": [{"label": names[k], "method": "animate",
                       "args": [[names[k]], {**play, "mode": "immediate"}]} for k in range(m)],
        }],
    )  # fmt: skip


def write_html(fig: Any, path: str | Path) -> Path:
    """Write ``fig`` as ONE self-contained HTML file (plotly.js inlined, no CDN, no server).

    Parameters
    ----------
    fig : plotly.graph_objects.Figure
    path : str or Path
        The file to write (its folder is created).

    Returns
    -------
    Path
        The file written.
    """
    require_plotly()
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.write_html(
        str(out),
        include_plotlyjs=True,
        full_html=True,
        auto_play=False,
        default_width="100%",
        default_height="100vh",
        config={"displaylogo": False, "responsive": True},
    )
    return out
