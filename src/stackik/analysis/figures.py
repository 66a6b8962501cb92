"""Figures of the sensitivity analysis (matplotlib, imported lazily, headless-safe).

Every function builds a :class:`matplotlib.figure.Figure` directly (no ``pyplot``, no GUI
backend, no global state), optionally saves it to ``path`` (PNG through the Agg
renderer) and returns it. matplotlib is only imported when a figure is drawn; install it
with the ``plot`` extra.

Planar drawings are in the ``(rho, z)`` plane of azimuth ``phi``: the 3D nodes of the
real (hexagonal or explicit) layout are projected onto it, ``rho = x cos phi + y sin phi``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.analysis._nodes import stack_nodes
from stackik.geometry import Stack
from stackik.kinematics import lift_planar, planar_fn2
from stackik.rotations import euler_zyx_from_matrix

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from stackik.analysis.capacity import CapacityMap
    from stackik.analysis.montecarlo import MonteCarloResult
    from stackik.analysis.workspace import WorkspaceStudy

__all__ = [
    "planar_to_spatial",
    "plot_capacity_map",
    "plot_fn_ratio_map",
    "plot_peak_force_map",
    "plot_perturbation_clouds",
    "plot_pose_diagram",
    "plot_regression",
    "plot_spatial_pose",
    "stack_nodes",
]

FloatArray = NDArray[np.float64]

_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink")


def _figure(width: float, height: float) -> Figure:
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), dpi=110, layout="constrained")


#: Background margin of every saved figure [in]: the saved area is the drawn one (titles,
#: labels, legends) plus this, so that nothing is cut at an edge (tests/test_figure_borders.py).
SAVE_PAD = 0.12


def _save(fig: Figure, path: str | Path | None) -> Figure:
    if path is not None:
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(p, dpi=fig.dpi, bbox_inches="tight", pad_inches=SAVE_PAD)
    return fig


# =========================================================================================
# Geometry helpers
# =========================================================================================
def planar_to_spatial(q: ArrayLike, phi: float) -> FloatArray:
    """Spatial pose (n, 6) ``[x, y, z, yaw, pitch, roll]`` equal to planar pose q (n, 3)."""
    P, R = lift_planar(q, phi)
    return np.concatenate([P, euler_zyx_from_matrix(R)], axis=-1)


def _project(X: FloatArray, phi: float) -> FloatArray:
    """(…, 3) world points -> (…, 2) ``(rho, z)`` in the plane of azimuth phi."""
    return np.stack([X[..., 0] * np.cos(phi) + X[..., 1] * np.sin(phi), X[..., 2]], axis=-1)


def _plate_radii(stack: Stack) -> FloatArray:
    """Radius of plates 0..n (largest node radius of the nodes they carry) [mm]."""
    rb = np.linalg.norm(stack.base_nodes[..., :2], axis=-1).max(axis=-1)  # (n,)
    rt = np.linalg.norm(stack.top_nodes[..., :2], axis=-1).max(axis=-1)
    r = np.zeros(stack.n + 1)
    r[0] = rb[0]
    r[-1] = rt[-1]
    r[1:-1] = np.maximum(rt[:-1], rb[1:])
    return r


def _draw_planar_pose(
    ax: Axes, stack: Stack, q: FloatArray, phi: float, color: str, label: str | None
) -> None:
    nodes = stack_nodes(stack, q, phi)
    O, A = nodes["O"], nodes["A"]
    e_rho = np.array([np.cos(phi), np.sin(phi), 0.0])
    radii = _plate_radii(stack)
    base, top = _project(nodes["base"], phi), _project(nodes["top"], phi)
    for i in range(stack.n):
        for k in range(6):
            ax.plot(
                [base[i, k, 0], top[i, k, 0]],
                [base[i, k, 1], top[i, k, 1]],
                color=color,
                lw=0.8,
                alpha=0.55,
            )
    for j in range(stack.n + 1):
        u = A[j] @ e_rho
        ends = _project(np.stack([O[j] - radii[j] * u, O[j] + radii[j] * u]), phi)
        ax.plot(
            ends[:, 0], ends[:, 1], color="k" if j == 0 else color, lw=3.0, solid_capstyle="round"
        )
    c = _project(O, phi)
    ax.plot(c[:, 0], c[:, 1], ls=":", color=color, lw=1.0, marker="o", ms=3, label=label)
    normal = _project(A[-1] @ np.array([0.0, 0.0, 1.0]), phi)
    ax.annotate(
        "",
        xy=tuple(c[-1] + 120.0 * normal),
        xytext=tuple(c[-1]),
        arrowprops={"arrowstyle": "-|>", "color": "crimson", "lw": 1.5},
    )
    ax.plot(*c[-1], marker="*", ms=14, color="crimson", mec="k", zorder=5)


# =========================================================================================
# Figures
# =========================================================================================
def plot_pose_diagram(
    stack: Stack,
    poses: Sequence[ArrayLike],
    phi: float = 0.0,
    labels: Sequence[str] | None = None,
    title: str | None = None,
    path: str | Path | None = None,
    obstacles: Sequence[Any] | None = None,
    clearance: float = 0.0,
    closest: bool | None = None,
) -> Figure:
    """2D diagram of stack poses in the ``(rho, z)`` plane, one panel per pose.

    Plates are thick segments (the base plate black), legs thin lines (the six legs
    projected on the plane), plate centres joined by a dotted line, the end effector a red
    star with an arrow along its plate normal. All panels share the axes.

    Parameters
    ----------
    stack : Stack
    poses : sequence of array_like (n, 3)
        Planar poses [mm, mm, rad].
    phi : float
        Plane azimuth [rad].
    labels : sequence of str, optional
        Panel titles (``FN`` is appended).
    path : str or Path, optional
        Save the figure there (PNG).
    obstacles : sequence of Obstacle, optional
        Drawn projected onto the plane (:mod:`stackik.analysis.clearance_art`).
    clearance : float
        Margin [mm]: a closest pair below it is drawn red.
    closest : bool, optional
        Mark each pose's closest pair of bodies (segment and distance [mm],
        :func:`stackik.clearance.contact_points`); default: when a clearance can fail
        (obstacles, leg radius, plate thickness or a margin:
        :func:`~stackik.clearance.needs_clearances`).
    """
    k = len(poses)
    labels = list(labels) if labels is not None else [f"pose {i + 1}" for i in range(k)]
    fig = _figure(3.6 * k + 0.4, 5.0)
    axes = fig.subplots(1, k, sharex=True, sharey=True, squeeze=False)[0]
    pts = []
    for i, (ax, q) in enumerate(zip(axes, poses, strict=True)):
        qa = np.asarray(q, dtype=float)
        _draw_planar_pose(ax, stack, qa, phi, _COLORS[i % len(_COLORS)], None)
        nodes = stack_nodes(stack, qa, phi)
        pts.append(_project(np.concatenate([nodes["base"], nodes["top"]]).reshape(-1, 3), phi))
        ax.set_title(f"{labels[i]}\nFN = {np.sqrt(planar_fn2(qa)):.0f}", fontsize=10)
        ax.set_aspect("equal", adjustable="box")
        ax.grid(alpha=0.3)
        ax.set_xlabel(r"$\rho$ [mm]")
    allp = np.concatenate(pts)
    lo, hi = allp.min(axis=0) - 150.0, allp.max(axis=0) + 150.0
    axes[0].set_xlim(lo[0], hi[0])
    axes[0].set_ylim(min(lo[1], -50.0), hi[1])
    axes[0].set_ylabel("z [mm]")
    obs = list(obstacles or ())
    mark = _marks_closest(stack, obs, clearance, closest)
    if obs or mark:
        from stackik.analysis import clearance_art as art

        for ax, q in zip(axes, poses, strict=True):
            art.draw_obstacles_plane(ax, obs, phi)
            if mark:
                cp = art.closest_contact(stack, q, obs, phi)
                if cp is not None:
                    art.draw_contact_plane(ax, cp, phi, clearance)
    if title:
        fig.suptitle(title)
    return _save(fig, path)


def _marks_closest(
    stack: Stack, obstacles: Sequence[Any], clearance: float, closest: bool | None
) -> bool:
    """Whether to mark the closest pair (``closest``, by default when a clearance can fail)."""
    if closest is not None:
        return bool(closest)
    from stackik.clearance import needs_clearances

    return needs_clearances(stack, tuple(obstacles), clearance)


def plot_perturbation_clouds(
    mc: MonteCarloResult,
    labels: Sequence[str] | None = None,
    title: str | None = None,
    path: str | Path | None = None,
    max_points: int = 5000,
) -> Figure:
    """End-effector displacement clouds with their 95 % confidence ellipse (red).

    One panel per pose of a planar Monte Carlo run, common axes; the panel title gives the
    median displacement and its 95 % interval. At most ``max_points`` samples are drawn
    (the first ones; the ellipse uses all).
    """
    if mc.mode != "planar":
        raise ValueError("perturbation clouds are drawn for planar Monte Carlo results")
    k = len(mc)
    labels = list(labels) if labels is not None else [f"pose {i + 1}" for i in range(k)]
    fig = _figure(3.8 * k + 0.4, 4.2)
    axes = fig.subplots(1, k, sharex=True, sharey=True, squeeze=False)[0]
    lim = 0.0
    for i, (ax, p) in enumerate(zip(axes, mc.poses, strict=True)):
        if p.displacement is None:
            raise ValueError("the Monte Carlo result was computed with keep_samples=False")
        D = p.displacement[:max_points]
        ax.scatter(D[:, 0], D[:, 1], s=2, alpha=0.35, color=_COLORS[i % len(_COLORS)], lw=0)
        b = p.ellipse.boundary(240)
        ax.plot(b[:, 0], b[:, 1], color="red", lw=1.8, label="95% ellipse")
        ax.plot(*p.ellipse.center, marker="+", color="red", ms=10)
        lim = max(lim, float(np.abs(b).max()) * 1.15, float(np.quantile(np.abs(D), 0.999)))
        lo, hi = p.interval
        ax.set_title(f"{labels[i]}\nmedian {p.median:.2f} mm [{lo:.2f}, {hi:.2f}]", fontsize=10)
        ax.set_xlabel(r"$\Delta\rho$ [mm]")
        ax.grid(alpha=0.3)
        ax.set_aspect("equal")
    axes[0].set_ylabel(r"$\Delta z$ [mm]")
    axes[0].set_xlim(-lim, lim)
    axes[0].set_ylim(-lim, lim)
    axes[0].legend(loc="upper left", fontsize=8)
    if title:
        fig.suptitle(title)
    return _save(fig, path)


def plot_fn_ratio_map(
    study: WorkspaceStudy,
    highlight: Sequence[tuple[float, float]] | None = None,
    title: str | None = None,
    path: str | Path | None = None,
    obstacles: Sequence[Any] | None = None,
    phi: float = 0.0,
) -> Figure:
    """Targets in the ``(rho, z)`` plane coloured by ``FN_opt / FN_non`` (lower = better).

    Targets where a solve failed are grey crosses; ``highlight`` points (e.g. the paper's
    targets) are black stars; ``obstacles`` are drawn projected onto the plane of azimuth
    ``phi`` [rad] (:mod:`stackik.analysis.clearance_art`).
    """
    fig = _figure(6.4, 5.2)
    ax = fig.subplots()
    X = study.positions
    v = study.valid
    sc = ax.scatter(
        X[v, 0], X[v, 1], c=study.fn_ratio[v], cmap="viridis", s=22, edgecolors="k", lw=0.3
    )
    if np.any(~v):
        ax.scatter(X[~v, 0], X[~v, 1], marker="x", color="0.6", s=18, label="solve failed")
    if highlight:
        h = np.asarray(highlight, dtype=float)
        ax.scatter(h[:, 0], h[:, 1], marker="*", s=160, color="k", label="paper targets")
    fig.colorbar(sc, ax=ax, label=r"FN ratio  $FN_{opt} / FN_{non}$")
    ax.set_xlabel(r"$\rho$ [mm]")
    ax.set_ylabel("z [mm]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    _map_obstacles(ax, obstacles, phi)
    if np.any(~v) or highlight or obstacles:
        ax.legend(loc="lower left", fontsize=8)
    ax.set_title(title or f"{int(v.sum())} targets, FN ratio optimal / non-optimal")
    return _save(fig, path)


def _map_obstacles(ax: Axes, obstacles: Sequence[Any] | None, phi: float) -> None:
    """Obstacles behind a map's targets, the view widened to hold the bounded ones."""
    if not obstacles:
        return
    from stackik.analysis import clearance_art

    ax.autoscale_view()
    clearance_art.draw_obstacles_plane(ax, obstacles, phi, keep_view=False)


def _workspace_scatter(
    xy: FloatArray,
    values: FloatArray,
    ok: Any,
    label: str,
    title: str,
    path: Any,
    failed: str = "solve failed",
    obstacles: Sequence[Any] | None = None,
    phi: float = 0.0,
) -> Figure:
    """Targets in the ``(rho, z)`` plane coloured by ``values`` (grey crosses, labelled
    ``failed``, where not ``ok``)."""
    fig = _figure(6.4, 5.2)
    ax = fig.subplots()
    ok = np.asarray(ok, dtype=bool)
    if ok.any():
        sc = ax.scatter(
            xy[ok, 0], xy[ok, 1], c=values[ok], cmap="viridis", s=28, edgecolors="k", lw=0.3
        )
        fig.colorbar(sc, ax=ax, label=label)
    if np.any(~ok):
        ax.scatter(xy[~ok, 0], xy[~ok, 1], marker="x", color="0.6", s=18, label=failed)
    ax.set_xlabel(r"$\rho$ [mm]")
    ax.set_ylabel("z [mm]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    _map_obstacles(ax, obstacles, phi)
    if np.any(~ok) or obstacles:
        ax.legend(loc="lower left", fontsize=8)
    ax.set_title(title)
    return _save(fig, path)


def plot_capacity_map(
    cmap: CapacityMap,
    path: str | Path | None = None,
    obstacles: Sequence[Any] | None = None,
    phi: float = 0.0,
) -> Figure:
    """Targets in the ``(rho, z)`` plane coloured by their payload capacity [kg]
    (:func:`stackik.analysis.capacity.capacity_map`); crosses: not even the rest of the
    load is carried; ``obstacles`` projected onto the plane of azimuth ``phi`` [rad]."""
    rows = cmap.rows()
    xy = np.array([[r["rho"], r["z"]] for r in rows], dtype=float).reshape(-1, 2)
    mass = np.array([r["capacity_kg"] for r in rows], dtype=float)
    ok = np.array([r["carried"] for r in rows], dtype=bool)
    title = f"{len(rows)} targets, payload capacity"
    return _workspace_scatter(
        xy, mass, ok, "payload capacity [kg]", title, path, "not even without payload",
        obstacles, phi,
    )  # fmt: skip


def plot_peak_force_map(
    cmap: CapacityMap,
    path: str | Path | None = None,
    obstacles: Sequence[Any] | None = None,
    phi: float = 0.0,
) -> Figure:
    """Targets in the ``(rho, z)`` plane coloured by the peak leg force [N] of their
    least-FN pose without force limits and without payload
    (:attr:`~stackik.analysis.capacity.CapacityMap.free_peaks`): where it exceeds
    ``force_max`` the limit shapes the pose before any payload. ``obstacles``, ``phi``: as
    in :func:`plot_capacity_map`."""
    rows = cmap.rows()
    xy = np.array([[r["rho"], r["z"]] for r in rows], dtype=float).reshape(-1, 2)
    peak = np.array([r["free_peak_force_N"] for r in rows], dtype=float)
    title = f"{len(rows)} targets, least-FN peak leg force (no payload, no force limit)"
    return _workspace_scatter(
        xy, peak, np.isfinite(peak), "peak leg force [N]", title, path, "solve failed",
        obstacles, phi,
    )  # fmt: skip


def plot_regression(
    study: WorkspaceStudy, title: str | None = None, path: str | Path | None = None
) -> Figure:
    """Median-displacement ratio versus FN ratio with the least-squares line."""
    fig = _figure(6.0, 4.8)
    ax = fig.subplots()
    v = study.valid
    x, y = study.fn_ratio[v], study.median_ratio[v]
    ax.scatter(x, y, s=16, alpha=0.75, color="tab:blue", edgecolors="k", lw=0.3, label="targets")
    reg = study.regression
    if reg is not None:
        xs = np.linspace(x.min(), x.max(), 2)
        ax.plot(
            xs,
            reg.predict(xs),
            color="red",
            label=(
                f"y = {reg.slope:.3f} x + {reg.intercept:.3f}\n$r^2$ = {reg.r2:.3f} (n = {reg.n})"
            ),
        )
    ax.set_xlabel(r"FN ratio  $FN_{opt} / FN_{non}$")
    ax.set_ylabel(r"median displacement ratio  $m_{opt} / m_{non}$")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=9)
    ax.set_title(
        title
        or (
            f"Monte Carlo: {study.n_samples} samples, "
            rf"$\sigma_t$ = {study.sigma_t:g} mm, $\sigma_\theta$ = {study.sigma_theta:g} rad"
        ),
        fontsize=10,
    )
    return _save(fig, path)


def plot_spatial_pose(
    stack: Stack,
    q: ArrayLike,
    phi: float | None = None,
    title: str | None = None,
    path: str | Path | None = None,
    elev: float = 18.0,
    azim: float = -60.0,
    obstacles: Sequence[Any] | None = None,
    clearance: float = 0.0,
    closest: bool | None = None,
) -> Figure:
    """3D drawing of a pose: plates, the six legs per platform, plate frames.

    Each plate is the (shaded) polygon through the leg nodes it carries: the base plate
    and the end-effector plate through their six nodes, an intermediate plate through the
    six top nodes of the platform below and the six base nodes of the platform above.

    Parameters
    ----------
    q : array_like, shape (n, 6) spatial, or (n, 3) planar with ``phi``
    obstacles, clearance, closest
        As in :func:`plot_pose_diagram` (the obstacles as 3D meshes).
    """
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    nodes = stack_nodes(stack, q, phi)
    O, A, base, top = nodes["O"], nodes["A"], nodes["base"], nodes["top"]
    fig = _figure(6.0, 6.4)
    ax: Any = fig.add_subplot(projection="3d")
    n = stack.n
    # plate j carries the top nodes of platform j (1-based, below it) and the base nodes
    # of platform j + 1 (above it): outline all of them, so every leg ends on its plate
    outlines: list[tuple[FloatArray, FloatArray]] = []  # (world nodes, plate-frame nodes)
    for j in range(n + 1):
        world = ([top[j - 1]] if j > 0 else []) + ([base[j]] if j < n else [])
        frame = ([stack.top_nodes[j - 1]] if j > 0 else []) + (
            [stack.base_nodes[j]] if j < n else []
        )
        outlines.append((np.concatenate(world), np.concatenate(frame)))
    for j, (nodes_w, nodes_p) in enumerate(outlines):
        order = np.argsort(np.arctan2(nodes_p[:, 1], nodes_p[:, 0]))
        ring = nodes_w[np.r_[order, order[:1]]]
        color = "k" if j == 0 else "0.25"
        ax.add_collection3d(Poly3DCollection([ring[:-1]], facecolor=color, alpha=0.12))
        ax.plot(ring[:, 0], ring[:, 1], ring[:, 2], color=color, lw=2)
    for i in range(n):
        c = _COLORS[i % len(_COLORS)]
        for k in range(6):
            seg = np.stack([base[i, k], top[i, k]])
            ax.plot(seg[:, 0], seg[:, 1], seg[:, 2], color=c, lw=1.2)
    L = 0.6 * float(np.max(np.linalg.norm(stack.top_nodes, axis=-1)))
    for j in range(n + 1):
        for ax_i, col in enumerate(("r", "g", "b")):
            tip = O[j] + L * A[j][:, ax_i]
            ax.plot(*np.stack([O[j], tip]).T, color=col, lw=1.0 if j < n else 2.0)
    ax.plot(*O.T, ls=":", color="0.4", marker="o", ms=3)
    ax.scatter(*O[-1], marker="*", s=160, color="crimson", edgecolors="k")
    pts = np.concatenate([base.reshape(-1, 3), top.reshape(-1, 3)])
    mid = 0.5 * (pts.max(0) + pts.min(0))
    half = 0.5 * float((pts.max(0) - pts.min(0)).max())
    obs = list(obstacles or ())
    if obs or _marks_closest(stack, obs, clearance, closest):
        from stackik.analysis import clearance_art as art

        art.draw_obstacles_3d(ax, obs, half)
        if _marks_closest(stack, obs, clearance, closest):
            cp = art.closest_contact(stack, q, obs, phi)
            if cp is not None:
                art.draw_contact_3d(ax, cp, clearance)
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_zlabel("z [mm]")
    ax.view_init(elev=elev, azim=azim)
    if title:
        ax.set_title(title, fontsize=10)
    return _save(fig, path)
