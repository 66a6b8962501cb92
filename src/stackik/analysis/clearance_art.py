"""Obstacles and the closest pair of bodies in the matplotlib figures (docs/clearance.md).

Shared by :mod:`stackik.analysis.figures` and :mod:`stackik.paths.animate`. Planar
drawings are in the ``(rho, z)`` plane of azimuth ``phi``: a bounded obstacle is drawn as
its projection onto that plane (the convex hull of its projected surface mesh, the mesh of
the HTML view), a half-space as its section by the plane. The closest pair is the segment
between the two closest points (:func:`stackik.clearance.contact_points`), labelled with
its signed distance [mm]: red when negative or below the margin, dark green otherwise.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.geometry import Stack

__all__ = [
    "CLEAR_COLOR",
    "HIT_COLOR",
    "OBSTACLE_COLOR",
    "closest_contact",
    "contact_color",
    "draw_contact_3d",
    "draw_contact_plane",
    "draw_obstacles_3d",
    "draw_obstacles_plane",
]

FloatArray = NDArray[np.float64]

OBSTACLE_COLOR = "#9467bd"  # as in the HTML view (stackik.viz)
HIT_COLOR = "#d62728"
CLEAR_COLOR = "#1a7f37"


def closest_contact(
    stack: Stack, q: ArrayLike, obstacles: Sequence[Any] = (), phi: float | None = None
) -> Any:
    """The :class:`~stackik.clearance.ContactPoints` of the pose's closest pair over every
    kind (:attr:`~stackik.clearance.Clearances.closest`), or None when it has none."""
    from stackik.clearance import clearances, contact_points

    c = clearances(stack, q, obstacles, phi=phi).closest
    return None if c is None else contact_points(stack, q, c, obstacles, phi=phi)


def contact_color(distance: float, margin: float = 0.0) -> str:
    """Red when ``distance`` [mm] is negative or below ``margin`` [mm], else green."""
    return HIT_COLOR if distance < max(margin, 0.0) else CLEAR_COLOR


def _project(X: FloatArray, phi: float) -> FloatArray:
    return np.stack([X[..., 0] * np.cos(phi) + X[..., 1] * np.sin(phi), X[..., 2]], axis=-1)


def _clip(square: FloatArray, a: FloatArray, c: float) -> FloatArray:
    """The polygon ``square`` (k, 2) cut to ``a . x <= c`` (one Sutherland-Hodgman pass)."""
    out = []
    for p, r in zip(square, np.roll(square, -1, axis=0), strict=True):
        fp, fr = float(a @ p) - c, float(a @ r) - c
        if fp <= 0:
            out.append(p)
        if fp * fr < 0:
            out.append(p + fp / (fp - fr) * (r - p))
    return np.array(out).reshape(-1, 2)


def draw_obstacles_plane(
    ax: Any, obstacles: Sequence[Any] | None, phi: float, keep_view: bool = True
) -> None:
    """Draw obstacles in the ``(rho, z)`` plane of azimuth ``phi`` (call after the axes'
    limits are set: a half-space fills its side of the view). ``keep_view``: restore the
    limits afterwards (else the bounded obstacles may widen them)."""
    from stackik.distance import convex_hull_2d
    from stackik.viz import _obstacle_mesh, obstacle_record

    if not obstacles:
        return
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    view = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)
    e_rho = np.array([np.cos(phi), np.sin(phi), 0.0])
    for k, ob in enumerate(obstacles):
        rec = obstacle_record(ob)
        if rec.kind == "halfspace":
            assert rec.normal is not None
            # n . (rho e_rho + z e_z - p) <= 0 in the plane
            a = np.array([rec.normal @ e_rho, rec.normal[2]])
            c = float(rec.normal @ rec.center)
            poly = _clip(view, a, c) if np.any(a) else (view if c >= 0 else view[:0])
        else:
            V, _ = _obstacle_mesh(rec, 1.0)
            P = _project(V, phi)
            try:
                poly = convex_hull_2d(P)
            except ValueError:  # projects onto a line
                poly = P
        if len(poly) == 0:
            continue
        ax.fill(poly[:, 0], poly[:, 1], color=OBSTACLE_COLOR, alpha=0.3, lw=1.0,
                ec=OBSTACLE_COLOR, zorder=1, label="obstacles" if k == 0 else None)  # fmt: skip
    if keep_view:
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)


def draw_obstacles_3d(ax: Any, obstacles: Sequence[Any] | None, extent: float) -> None:
    """Draw obstacles on 3D axes (a half-space as a square of its plane, ``extent`` [mm]
    from its point)."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from stackik.viz import _obstacle_mesh, obstacle_record

    for ob in obstacles or ():
        rec = obstacle_record(ob)
        V, tri = _obstacle_mesh(rec, extent)
        alpha = 0.15 if rec.kind == "halfspace" else 0.3
        ax.add_collection3d(Poly3DCollection(V[tri], facecolor=OBSTACLE_COLOR, alpha=alpha,
                                             edgecolor="none"))  # fmt: skip


def draw_contact_plane(ax: Any, cp: Any, phi: float, margin: float = 0.0) -> list[Any]:
    """Draw a :class:`~stackik.clearance.ContactPoints` in the ``(rho, z)`` plane: the
    segment between the two points, its end points, and its distance label. Returns the
    artists (line, text)."""
    ab = _project(np.stack([cp.a, cp.b]), phi)
    col = contact_color(cp.distance, margin)
    (line,) = ax.plot(ab[:, 0], ab[:, 1], color=col, lw=2.0, marker="o", ms=4, zorder=6,
                      label="closest pair")  # fmt: skip
    mid = ab.mean(axis=0)
    text = ax.annotate(cp.label(), xy=tuple(mid), xytext=(6, 6), textcoords="offset points",
                       color=col, fontsize=9, fontweight="bold", zorder=7,
                       bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": col,
                             "alpha": 0.85})  # fmt: skip
    return [line, text]


def draw_contact_3d(ax: Any, cp: Any, margin: float = 0.0) -> list[Any]:
    """Draw a :class:`~stackik.clearance.ContactPoints` on 3D axes (segment and label)."""
    ab = np.stack([cp.a, cp.b])
    col = contact_color(cp.distance, margin)
    (line,) = ax.plot(ab[:, 0], ab[:, 1], ab[:, 2], color=col, lw=2.5, marker="o", ms=4,
                      zorder=6)  # fmt: skip
    mid = ab.mean(axis=0)
    box = {"boxstyle": "round,pad=0.2", "fc": "white", "ec": col, "alpha": 0.85}
    text = ax.text(mid[0], mid[1], mid[2], "  " + cp.label(), color=col, fontsize=9,
                   fontweight="bold", zorder=7, bbox=box)  # fmt: skip
    return [line, text]
