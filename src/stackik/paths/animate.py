"""Figures of a path: leg lengths and FN along it, and an animation of the stack.

matplotlib is imported inside the functions (the optional ``plot`` extra). The animation
is a GIF (matplotlib's Pillow writer) or, when ffmpeg is installed, also an MP4.

Planar paths are drawn in their plane (horizontal axis: the in-plane coordinate ``rho``
along ``(cos phi, sin phi, 0)``; vertical: ``z``), spatial paths in 3D. Plates are drawn
through their nodes, legs from base node to top node, coloured by length (blue at
``leg_min``, red at ``leg_max``); the dashed line is the target path, the red cross the
current waypoint's target and the blue line the end effector's trail.
"""

from __future__ import annotations

import shutil
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from stackik.formulation.modes import mode_of
from stackik.geometry import Stack
from stackik.paths.result import PathResult

if TYPE_CHECKING:
    from stackik.obstacles import Obstacle

__all__ = ["animate_path", "default_caption", "plot_path", "stack_nodes"]

FloatArray = NDArray[np.float64]


def stack_nodes(stack: Stack, result: PathResult, k: int) -> dict[str, FloatArray]:
    """World coordinates of the stack at waypoint ``k`` [mm]
    (:func:`stackik.analysis.figures.stack_nodes` of its pose).

    Returns
    -------
    dict
        ``O`` (n+1, 3) plate origins, ``A`` (n+1, 3, 3) plate orientations, ``base`` and
        ``top`` (n, 6, 3): both ends of every leg.
    """
    from stackik.analysis.figures import stack_nodes as nodes_of

    t0 = result.targets[0]
    return nodes_of(stack, result.q[k], mode_of(t0).phi(t0))


def _plate_outlines(stack: Stack, nd: dict[str, FloatArray]) -> list[FloatArray]:
    """Closed outline of every plate (0 = base .. n = end effector) through every node it
    carries (the top nodes of the platform below and the base nodes of the one above), in
    the order of their angle about the plate centre: legs end on the outlines."""
    out = []
    for j in range(stack.n + 1):
        local, world = [], []
        if j > 0:
            local.append(stack.top_nodes[j - 1])
            world.append(nd["top"][j - 1])
        if j < stack.n:
            local.append(stack.base_nodes[j])
            world.append(nd["base"][j])
        L, W = np.concatenate(local), np.concatenate(world)
        W = W[np.argsort(np.arctan2(L[:, 1], L[:, 0]))]
        out.append(np.vstack([W, W[:1]]))
    return out


def _target_points(result: PathResult) -> FloatArray:
    """End-effector target positions (m, 3) [mm]."""
    return np.array([mode_of(t).spatial_target(t).position for t in result.targets])


def default_caption(result: PathResult) -> str:
    """What the animation shows, in words (its caption)."""
    kind = mode_of(result.targets[0]).name
    end = (
        "every waypoint reached"
        if result.success
        else f"path breaks at waypoint {result.completed} ({result.status.value})"
    )
    return (
        f"{result.n}-platform stack following a {kind} path of {result.m} waypoints "
        f"({result.mode} mode, max jump {result.max_jump[0]:g} mm / {result.max_jump[1]:g} rad; "
        f"{end}). Dashed: target path; red x: current target; blue: end-effector trail; "
        "legs coloured by length (blue = leg_min, red = leg_max)."
    )


def plot_path(result: PathResult, stack: Stack, path: str | Path | None = None) -> Any:
    """Leg lengths and FN along a path (and the break, if any).

    Parameters
    ----------
    result : PathResult
    stack : Stack
        The stack solved (for the leg limits).
    path : path, optional
        Save the figure there (format from the suffix, e.g. ``.png``).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib

    if path is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    x = result.times if result.times is not None else np.arange(result.m, dtype=float)
    xlabel = "time [s]" if result.times is not None else "waypoint"
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True, layout="constrained")
    cmap = plt.get_cmap("viridis")
    c = result.completed
    for i in range(result.n):
        color = cmap(i / max(result.n - 1, 1))
        for k in range(6):
            ax1.plot(x[:c], result.leg_lengths[:c, i, k], color=color, lw=0.8,
                     label=f"platform {i + 1}" if k == 0 else None)  # fmt: skip
    ax1.axhline(float(stack.leg_min.min()), color="k", ls="--", lw=0.8, label="leg limits")
    ax1.axhline(float(stack.leg_max.max()), color="k", ls="--", lw=0.8)
    ax1.set_ylabel("leg length [mm]")
    ax1.set_title(
        f"{result.mode} mode, {result.completed}/{result.m} waypoints, {result.status.value}"
    )
    if result.n <= 8:  # beside the axes, off the data and the limit lines
        ax1.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    ax2.plot(x[:c], result.frobenius_norm[:c], "b.-", lw=1)
    ax2.set_ylabel("FN")
    ax2.set_xlabel(xlabel)
    if not result.success and c < result.m:
        for ax in (ax1, ax2):
            ax.axvline(float(x[c]) if result.times is None else float(x[c - 1]), color="r")
        ax2.text(0.01, 0.9, f"break at waypoint {c}", color="r", transform=ax2.transAxes)
    if path is not None:  # the drawn area plus a background margin: nothing cut at an edge
        fig.savefig(path, dpi=120, bbox_inches="tight", pad_inches=0.12)
    return fig


def _frames(result: PathResult, max_frames: int) -> list[int]:
    last = max(result.completed - 1, 0)
    ks = list(range(result.completed))
    if len(ks) > max_frames:
        ks = sorted({int(round(v)) for v in np.linspace(0, last, max_frames)})
    return ks if ks else [0]


@dataclass(frozen=True)
class _PlaneView:
    """A planar path drawn in its vertical plane ``phi``: axes ``rho`` and ``z``."""

    plane: float
    projection: str | None = None

    def proj(self, p: FloatArray) -> FloatArray:
        """World points [mm] as ``(rho, z)`` in the plane."""
        from stackik.analysis.figures import _project

        return _project(p, self.plane)

    def figure_size(self, lo: FloatArray, hi: FloatArray, pad: float) -> tuple[float, float]:
        """A figure shaped like the drawing, so that the stack fills it."""
        aspect = float((hi[0] - lo[0] + 2 * pad) / (hi[1] - min(lo[1], 0.0) + 2 * pad))
        return (float(np.clip(1.5 + 7.0 * aspect, 6.0, 11.0)), 9.0)

    def set_limits(self, ax: Any, lo: FloatArray, hi: FloatArray, pad: float) -> float:
        """Axis limits, equal aspect and labels; returns 0 (no 3D span)."""
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(min(lo[1], 0.0) - pad, hi[1] + pad)
        ax.set_aspect("equal")
        ax.set_xlabel("rho [mm]")
        ax.set_ylabel("z [mm]")
        return 0.0

    def draw_obstacles(self, ax: Any, obs: list[Obstacle], span: float) -> None:
        from stackik.analysis import clearance_art as art

        art.draw_obstacles_plane(ax, obs, float(self.plane))

    def draw_contact(self, ax: Any, contact: Any, clearance: float) -> None:
        from stackik.analysis import clearance_art as art

        art.draw_contact_plane(ax, contact, float(self.plane), clearance)


@dataclass(frozen=True)
class _SpaceView:
    """A spatial path drawn in 3D with equal scales on all axes."""

    plane: None = None
    projection: str | None = "3d"

    def proj(self, p: FloatArray) -> FloatArray:
        """World points [mm], unchanged."""
        return p

    def figure_size(self, lo: FloatArray, hi: FloatArray, pad: float) -> tuple[float, float]:
        return (8.0, 8.5)

    def set_limits(self, ax: Any, lo: FloatArray, hi: FloatArray, pad: float) -> float:
        """Axis limits, box aspect and labels; returns the half-span [mm] of x and y."""
        span = float(np.max(hi[:2] - lo[:2])) / 2 + pad  # equal scales on all axes
        mid = (hi + lo) / 2
        z0, z1 = min(lo[2], 0.0) - pad, hi[2] + pad
        ax.set_xlim(mid[0] - span, mid[0] + span)
        ax.set_ylim(mid[1] - span, mid[1] + span)
        ax.set_zlim(z0, z1)
        ax.set_box_aspect((2 * span, 2 * span, z1 - z0))
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        ax.set_zlabel("z [mm]")
        return span

    def draw_obstacles(self, ax: Any, obs: list[Obstacle], span: float) -> None:
        from stackik.analysis import clearance_art as art

        art.draw_obstacles_3d(ax, obs, span)

    def draw_contact(self, ax: Any, contact: Any, clearance: float) -> None:
        from stackik.analysis import clearance_art as art

        art.draw_contact_3d(ax, contact, clearance)


@dataclass(frozen=True)
class _Scene:
    """What every frame of an animation draws from: the stack at each reached waypoint,
    the targets and the end-effector trail in drawing coordinates, the bounds, the view."""

    nodes: list[dict[str, FloatArray]]
    targets: FloatArray  # (m, 2) or (m, 3), projected
    trail: FloatArray  # (completed, 2) or (completed, 3), projected
    lo: FloatArray
    hi: FloatArray
    pad: float
    view: _PlaneView | _SpaceView


def _scene(result: PathResult, stack: Stack) -> _Scene:
    """The :class:`_Scene` of a path with at least one reached waypoint."""
    t0 = result.targets[0]
    plane = mode_of(t0).phi(t0)
    view: _PlaneView | _SpaceView = _SpaceView() if plane is None else _PlaneView(plane)
    proj = view.proj
    nodes = [stack_nodes(stack, result, k) for k in range(result.completed)]
    tp = proj(_target_points(result))
    dim = tp.shape[1]
    allpts = np.concatenate(
        [proj(nd["base"]).reshape(-1, dim) for nd in nodes]
        + [proj(nd["top"]).reshape(-1, dim) for nd in nodes]
        + [tp]
    )
    lo, hi = allpts.min(axis=0), allpts.max(axis=0)
    pad = 0.05 * float(np.max(hi - lo)) + 50.0
    ee = np.array([proj(nd["O"][-1]) for nd in nodes])
    return _Scene(nodes, tp, ee, lo, hi, pad, view)


def _draw_stack(ax: Any, scene: _Scene, result: PathResult, stack: Stack, k: int) -> None:
    """Frame ``k``: target path, trail, current target, plates, legs by length, title."""
    import matplotlib.pyplot as plt

    cmap = plt.get_cmap("coolwarm")
    lmin, lmax = float(stack.leg_min.min()), float(stack.leg_max.max())
    nd, tpp, ee, proj = scene.nodes[k], scene.targets, scene.trail, scene.view.proj
    ax.plot(*tpp.T, "k--", lw=1, label="target path")
    trail = ee[: k + 1]
    ax.plot(*trail.T, "b-", lw=2, label="end-effector trail")
    ax.plot(*tpp[k], "rx", ms=14, mew=1.5, label="target (waypoint)", zorder=5)
    ax.plot(*ee[k], "o", color="b", ms=4, label="end effector", zorder=6)
    for poly in _plate_outlines(stack, nd):
        ax.plot(*proj(poly).T, color="0.3", lw=1.5)
    lengths = result.leg_lengths[k]
    for i in range(stack.n):
        for j in range(6):
            seg = proj(np.stack([nd["base"][i, j], nd["top"][i, j]]))
            c = cmap((lengths[i, j] - lmin) / (lmax - lmin))
            ax.plot(*seg.T, color=c, lw=1.2)
    ax.set_title(
        f"waypoint {k}/{result.m - 1}   FN = {result.frobenius_norm[k]:.0f}"
        + (f"   t = {result.times[k]:.2f} s" if result.times is not None else "")
        + (
            f"\nbreak at waypoint {result.completed}: {result.status.value}"
            if (not result.success and k == result.completed - 1)
            else ""
        ),
        fontsize=10,
    )


def animate_path(
    result: PathResult,
    stack: Stack,
    path: str | Path,
    *,
    fps: int = 10,
    max_frames: int = 120,
    dpi: int = 90,
    caption: str | None = None,
    mp4: bool = True,
    obstacles: Sequence[Obstacle] | None = None,
    clearance: float = 0.0,
    closest: bool | None = None,
) -> list[Path]:
    """Animate the stack along a solved path.

    Parameters
    ----------
    result : PathResult
    stack : Stack
    path : path
        Output file; its suffix is replaced by ``.gif`` (and ``.mp4``).
    fps : int
        Frames per second.
    max_frames : int
        At most this many frames (waypoints evenly subsampled; the last one included).
    dpi : int
    caption : str, optional
        Text under the drawing (default :func:`default_caption`).
    mp4 : bool
        Also write an MP4 when ffmpeg is installed.
    obstacles : sequence of Obstacle, optional
        Drawn in every frame (planar: projected onto the path's plane).
    clearance : float
        Margin [mm]: a closest pair below it is drawn red.
    closest : bool, optional
        Mark each frame's closest pair of bodies (segment and distance [mm],
        :func:`stackik.clearance.contact_points`); default: when a clearance can fail.

    Returns
    -------
    list of Path
        The files written (the GIF, then the MP4 if any).
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation

    from stackik.analysis import clearance_art as art
    from stackik.analysis.figures import _marks_closest

    if result.completed == 0:
        raise ValueError("animate_path: the path has no reached waypoint to draw")
    frames = _frames(result, max_frames)
    scene = _scene(result, stack)
    view = scene.view
    size = view.figure_size(scene.lo, scene.hi, scene.pad)
    fig = plt.figure(figsize=size)
    ax: Any = fig.add_axes((0.1, 0.2, 0.85, 0.73), projection=view.projection)
    cap = default_caption(result) if caption is None else caption
    fig.text(0.03, 0.015, textwrap.fill(cap, int(14 * size[0])), fontsize=8, va="bottom")
    obs = list(obstacles or ())
    mark = _marks_closest(stack, obs, clearance, closest)
    contacts = {
        k: art.closest_contact(stack, result.q[k], obs, view.plane) if mark else None
        for k in frames
    }

    def draw(k: int) -> None:
        ax.cla()
        span = view.set_limits(ax, scene.lo, scene.hi, scene.pad)
        _draw_stack(ax, scene, result, stack, k)
        view.draw_obstacles(ax, obs, span)
        if contacts[k] is not None:
            view.draw_contact(ax, contacts[k], clearance)
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=4, fontsize=7)

    anim = FuncAnimation(fig, lambda i: draw(frames[i]), frames=len(frames), blit=False)
    written = _save(anim, Path(path), fps, dpi, mp4)
    plt.close(fig)
    return written


def _save(anim: Any, out: Path, fps: int, dpi: int, mp4: bool) -> list[Path]:
    """Write the GIF (and the MP4 when asked and ffmpeg is installed); the files written."""
    from matplotlib.animation import FFMpegWriter, PillowWriter

    written = []
    gif = out.with_suffix(".gif")
    anim.save(str(gif), writer=PillowWriter(fps=int(round(fps))), dpi=dpi)
    written.append(gif)
    if mp4 and shutil.which("ffmpeg") is not None and FFMpegWriter.isAvailable():
        mp4_path = out.with_suffix(".mp4")
        anim.save(str(mp4_path), writer=FFMpegWriter(fps=int(round(fps))), dpi=dpi)
        written.append(mp4_path)
    return written
