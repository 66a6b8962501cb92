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


def figure_of(data: dict[str, Any], stack: Stack, title: str | None = None) -> Any:
    """The :mod:`stackik.viz` figure of a solve (``q``) or path (``format: stackik-path``)
    JSON document."""
    from stackik import viz

    if data.get("format") == "stackik-path":
        from stackik.paths.result import PathResult

        return viz.path_figure(stack, PathResult.from_dict(data), title=title)
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
    return viz.pose_figure(stack, q, phi=data.get("phi"), target=_solve_target(data), title=title)


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
    fig = figure_of(data, _stack(data, args), args.title)
    out = args.out if args.out is not None else Path(args.result).with_suffix(".html")
    print(f"wrote {write_html(fig, out)}")
    return EXIT_OK
