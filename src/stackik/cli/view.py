"""``stackik view``: an interactive 3D view (one self-contained HTML file) of a result.

Reads the JSON of ``stackik solve --json`` (one pose) or the ``path.json`` of ``stackik
path`` (a pose sequence: slider and play button) and writes one HTML file with plotly.js
inlined (no server, no network) through :mod:`stackik.viz`. Both JSON files carry the
stack geometry; ``--geometry`` / ``--n`` give it for files that do not.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._common import EXIT_OK, CLIError, add_stack_args, load_stack

if TYPE_CHECKING:
    from stackik.geometry import Stack

__all__ = ["HELP", "NAME", "add_parser", "figure_of", "run"]

NAME = "view"
HELP = "interactive 3D view of a solve or path result (one self-contained HTML file)"


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``view`` and its arguments to ``subparsers``."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        NAME,
        help=HELP,
        description="Draw the pose of `stackik solve --json` output, or the poses of a "
        "`stackik path` path.json, as an interactive 3D view: plates, legs coloured by the "
        "margin to their nearest limit, the target frame; a slider and a play button "
        "through a path. Writes one HTML file that opens in any browser, offline. Needs "
        "plotly (the [plot] extra).",
    )
    p.add_argument("result", type=Path, metavar="RESULT.json", help="solve or path JSON")
    p.add_argument("--out", type=Path, default=None, metavar="FILE",
                   help="HTML file to write (default: RESULT.html)")  # fmt: skip
    add_stack_args(p, n_help="number of platforms, for a file without its geometry")
    p.add_argument("--title", default=None, help="figure title")
    p.add_argument("--color", choices=("margin", "force"), default="margin",
                   help="leg colour: margin to the nearest limit (default), or leg force [N] "
                   "(compression positive) under the stack's masses, the payload and "
                   "earth gravity (stackik.statics)")  # fmt: skip
    p.add_argument("--payload-mass", type=float, default=0.0, metavar="KG",
                   help="payload [kg] at the end effector, for --color force (0)")  # fmt: skip
    p.add_argument("--obstacles", type=Path, default=None, metavar="FILE",
                   help="obstacles to draw (TOML/JSON list, stackik.load_obstacles)")  # fmt: skip
    return p


def _stack(data: dict[str, Any], args: argparse.Namespace) -> Stack:
    from stackik.geometry import Stack

    if args.geometry is not None or "geometry" not in data:
        return load_stack(args.n, args.geometry)
    return Stack.from_dict(data["geometry"])


def _solve_target(data: dict[str, Any]) -> Any:
    """The target recorded by ``stackik solve --json`` (None if absent)."""
    from stackik.rotations import euler_zyx
    from stackik.targets import PlanarTarget, SpatialTarget

    t = data.get("target")
    if not isinstance(t, dict):
        return None
    if "position" in t:
        R = euler_zyx(t["euler_zyx"]) if "euler_zyx" in t else t["rotation"]
        return SpatialTarget(t["position"], R)
    return PlanarTarget(t["rho"], t["z"], t["theta"], t.get("phi", data.get("phi") or 0.0))


def figure_of(
    data: dict[str, Any],
    stack: Stack,
    title: str | None = None,
    *,
    load: Any = None,
    obstacles: Any = None,
) -> Any:
    """The :mod:`stackik.viz` figure of a solve (``q``) or path (``format: stackik-path``)
    JSON document; with a ``load`` (:class:`stackik.Load`) the legs are coloured by their
    force [N] (:func:`stackik.leg_forces`, compression positive) instead of their margin."""
    from stackik import viz

    if data.get("format") == "stackik-path":
        from stackik.paths.result import PathResult

        path = PathResult.from_dict(data)
        t0 = path.targets[0]
        reached = path.q[: max(path.completed, 1)]  # the poses path_figure draws
        extra = (
            {} if load is None else _force_colours(stack, reached, load, getattr(t0, "phi", None))
        )
        return viz.path_figure(stack, path, title=title, obstacles=obstacles, **extra)
    if "q" not in data:
        raise CLIError("not a stackik result: expected `stackik solve --json` or path.json")
    import numpy as np

    q = np.asarray(data["q"], dtype=float)
    if q.ndim != 2 or q.shape[0] != stack.n:
        raise CLIError(f"the pose has shape {q.shape}, the stack {stack.n} platforms")
    if title is None:
        fn = data.get("frobenius_norm")
        ok = "solved" if data.get("success") else f"not solved ({data.get('status')})"
        title = f"{stack.n}-platform stack, {data.get('mode', '')} pose, {ok}" + (
            f", FN {fn:.1f}" if isinstance(fn, int | float) else ""
        )
    phi = data.get("phi")
    extra = {} if load is None else _force_colours(stack, q, load, phi)
    return viz.pose_figure(
        stack, q, phi=phi, target=_solve_target(data), title=title, obstacles=obstacles, **extra
    )


def _force_colours(stack: Stack, q: Any, load: Any, phi: float | None) -> dict[str, Any]:
    """``pose_figure`` / ``path_figure`` keywords colouring the legs by force [N]: a
    diverging scale symmetric about 0 (compression positive, tension negative)."""
    import numpy as np

    from stackik.loads import leg_forces

    f = leg_forces(stack, np.asarray(q, dtype=float), load, phi=phi)
    finite = np.abs(f[np.isfinite(f)])
    top = float(finite.max()) if finite.size and finite.max() > 0 else 1.0
    return {
        "leg_values": np.nan_to_num(f, nan=0.0, posinf=top, neginf=-top),
        "leg_values_title": "leg force [N]<br>(+ compression)",
        "value_range": (-top, top),
        "colorscale": "RdBu_r",
    }


def run(args: argparse.Namespace) -> int:
    """Read the JSON, write the HTML file, print its path."""
    from stackik.viz import require_plotly, write_html

    require_plotly()
    try:
        data = json.loads(Path(args.result).read_text())
    except json.JSONDecodeError as exc:
        raise CLIError(f"{args.result}: not JSON ({exc})") from None
    if not isinstance(data, dict):
        raise CLIError(f"{args.result}: expected a JSON object")
    load = None
    if args.color == "force":
        from stackik.loads import Load

        try:
            load = Load(mass=args.payload_mass)
        except ValueError as exc:
            raise CLIError(f"--payload-mass: {exc}") from None
    obstacles = None
    if args.obstacles is not None:
        from stackik.obstacles import load_obstacles

        try:
            obstacles = load_obstacles(args.obstacles)
        except ValueError as exc:
            raise CLIError(str(exc)) from None
    fig = figure_of(data, _stack(data, args), args.title, load=load, obstacles=obstacles)
    out = args.out if args.out is not None else Path(args.result).with_suffix(".html")
    print(f"wrote {write_html(fig, out)}")
    return EXIT_OK
