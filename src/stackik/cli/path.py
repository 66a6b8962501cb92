"""``stackik path``: continuous least-FN poses along an end-effector path.

Waypoints from ``--from``/``--to`` (a straight segment cut by ``--steps`` or
``--max-step``) or from a CSV file (``--csv``; header ``rho,z,theta[,phi]`` or
``x,y,z,yaw,pitch,roll``); solved by :func:`stackik.paths.solve_path`. Writes
``path.csv``, ``path.json``, ``path.png`` (leg lengths and FN along the path) and
``path.gif`` (the stack following the path; also ``path.mp4`` when ffmpeg is installed)
into ``--out``; ``path.json`` also carries the stack geometry, so that ``stackik view
path.json`` can draw it, and ``--html FILE`` writes that interactive view directly.
Exit code 0 when the whole path is solved, 1 when it breaks (the message says where and
why), 2 on bad input.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._common import (
    EXIT_INFEASIBLE,
    EXIT_OK,
    PROG,
    CLIError,
    add_clearance_arguments,
    add_load_arguments,
    add_phi_args,
    add_stack_args,
    clearance_of,
    dump_json,
    finite_float,
    load_of,
    load_stack,
    phi_of,
    positive_int,
)

if TYPE_CHECKING:
    from stackik.targets import Target

__all__ = ["HELP", "NAME", "add_parser", "read_waypoints_csv", "run"]

NAME = "path"
HELP = "continuous least-FN poses along an end-effector path (CSV, JSON, plot, animation)"

#: Default leg acceleration when only ``--leg-speed`` is given: full speed in 0.25 s.
ACCEL_PER_SPEED = 4.0  # [1/s]


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``path`` and its arguments to ``subparsers``."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        NAME,
        help=HELP,
        description="Solve a sequence of waypoints so that no platform variable moves more "
        "than --max-jump between consecutive waypoints, with the least FN the mode finds; "
        "write CSV, JSON, a plot and an animation. Millimetres and radians.",
        epilog="Exit codes: 0 complete path, 1 the path breaks (see the message), 2 bad input.",
    )
    add_stack_args(p)
    src = p.add_argument_group("waypoints (give --from and --to, or --csv)")
    src.add_argument(
        "--from",
        dest="from_",
        nargs="+",
        type=finite_float,
        metavar="V",
        help="first target: RHO Z THETA (planar) or X Y Z YAW PITCH ROLL (--spatial)",
    )
    src.add_argument("--to", nargs="+", type=finite_float, metavar="V", help="last target")
    src.add_argument(
        "--steps", type=positive_int, default=None, help="steps from --from to --to (20)"
    )
    src.add_argument(
        "--max-step",
        nargs=2,
        type=finite_float,
        default=None,
        metavar=("MM", "RAD"),
        help="instead of --steps: largest target step [mm, rad]",
    )
    src.add_argument("--csv", type=Path, default=None, metavar="FILE", help="waypoints file")
    src.add_argument(
        "--spatial",
        action="store_true",
        help="spatial targets (--from/--to: X Y Z YAW PITCH ROLL, R = Rz Ry Rx)",
    )
    add_phi_args(p)
    p.add_argument(
        "--max-jump",
        nargs=2,
        type=finite_float,
        default=(50.0, 0.25),
        metavar=("MM", "RAD"),
        help="largest change of a platform variable between waypoints (50 mm, 0.25 rad)",
    )
    p.add_argument("--mode", choices=("fast", "global"), default="fast", help="(fast)")
    p.add_argument(
        "--motion-weight",
        type=finite_float,
        default=0.0,
        metavar="W",
        help="global mode: weight of sum |dq|^2 against sum FN^2 (0)",
    )
    p.add_argument(
        "--refine",
        action="store_true",
        help="insert waypoints where a step cannot be made within --max-jump",
    )
    p.add_argument("--leg-speed", type=finite_float, default=None, metavar="MM_S",
                   help="largest leg speed [mm/s]: compute waypoint times")  # fmt: skip
    p.add_argument(
        "--leg-accel",
        type=finite_float,
        default=None,
        metavar="MM_S2",
        help=f"largest leg acceleration [mm/s^2] ({ACCEL_PER_SPEED:g} x --leg-speed)",
    )
    p.add_argument("--out", type=Path, default=Path("path_out"), metavar="DIR",
                   help="output directory (path_out)")  # fmt: skip
    p.add_argument("--no-animation", action="store_true", help="skip the GIF/MP4")
    p.add_argument("--frames", type=positive_int, default=120, help="most animation frames")
    p.add_argument("--fps", type=positive_int, default=10, help="animation frames per second")
    p.add_argument("--checkpoint", type=Path, default=None, metavar="FILE",
                   help="record finished waypoints; rerun to resume")  # fmt: skip
    p.add_argument("--threads", type=positive_int, default=None, metavar="N",
                   help="threads the default solves' starts run on (default: every CPU, at "
                        "most 8; the path does not depend on it)")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--html", type=Path, default=None, metavar="FILE",
                   help="also write an interactive 3D view of the path (needs plotly)")  # fmt: skip
    add_load_arguments(p)
    add_clearance_arguments(p)
    return p


def read_waypoints_csv(path: Path, phi: float) -> list[Target]:
    """Waypoints of a CSV file with a header: ``rho,z,theta[,phi]`` (planar; ``phi``
    [rad] from the file or from ``--phi``) or ``x,y,z,yaw,pitch,roll`` (spatial)."""
    import numpy as np

    from stackik.rotations import euler_zyx
    from stackik.targets import PlanarTarget, SpatialTarget

    with Path(path).open(newline="") as fh:
        rows = [r for r in csv.DictReader(fh)]
    if not rows:
        raise CLIError(f"--csv {path}: no waypoints (a header line and one row per waypoint)")
    cols = set(rows[0])
    out: list[Target] = []
    for k, r in enumerate(rows, start=2):
        try:
            if {"rho", "z", "theta"} <= cols:
                ph = float(r["phi"]) if r.get("phi") not in (None, "") else phi
                out.append(PlanarTarget(float(r["rho"]), float(r["z"]), float(r["theta"]), ph))
            elif {"x", "y", "z", "yaw", "pitch", "roll"} <= cols:
                v = [float(r[c]) for c in ("x", "y", "z", "yaw", "pitch", "roll")]
                out.append(SpatialTarget(np.array(v[:3]), euler_zyx(v[3:])))
            else:
                raise CLIError(
                    f"--csv {path}: header must name rho,z,theta[,phi] or x,y,z,yaw,pitch,roll"
                )
        except (TypeError, ValueError) as exc:
            raise CLIError(f"--csv {path}: line {k}: {exc}") from None
    return out


def _targets(args: argparse.Namespace) -> list[Target]:
    import numpy as np

    from stackik.paths import interpolate_targets
    from stackik.rotations import euler_zyx
    from stackik.targets import PlanarTarget, SpatialTarget

    if args.csv is not None:
        if args.from_ is not None or args.to is not None:
            raise CLIError("give either --csv or --from/--to, not both")
        pts = read_waypoints_csv(args.csv, phi_of(args))
        if args.steps is None and args.max_step is None:
            return pts
    else:
        if args.from_ is None or args.to is None:
            raise CLIError("give the waypoints: --from and --to, or --csv FILE")
        k = 6 if args.spatial else 3
        for name, v in (("--from", args.from_), ("--to", args.to)):
            if len(v) != k:
                what = "X Y Z YAW PITCH ROLL" if args.spatial else "RHO Z THETA"
                raise CLIError(f"{name}: expected {k} numbers ({what}), got {len(v)}")
        if args.spatial:
            pts = [SpatialTarget(np.array(v[:3]), euler_zyx(v[3:])) for v in (args.from_, args.to)]
        else:
            pts = [PlanarTarget(v[0], v[1], v[2], phi_of(args)) for v in (args.from_, args.to)]
    if args.steps is not None and args.max_step is not None:
        raise CLIError("give --steps or --max-step, not both")
    if args.max_step is not None:
        return interpolate_targets(pts, max_step=tuple(args.max_step))
    return interpolate_targets(pts, steps=20 if args.steps is None else args.steps)


def _summary(result: Any, files: list[Path]) -> dict[str, Any]:
    import numpy as np

    sj = result.step_jumps
    done = sj[: max(result.completed - 1, 0)]
    return {
        "status": result.status.value,
        "success": result.success,
        "completed": result.completed,
        "waypoints": result.m,
        "break_index": result.break_index,
        "message": result.message,
        "mode": result.mode,
        "max_jump": list(result.max_jump),
        "largest_step": [float(done[:, 0].max()), float(done[:, 1].max())]
        if len(done)
        else [0.0, 0.0],
        "mean_frobenius_norm": result.mean_frobenius_norm,
        "duration_s": None
        if result.times is None or result.completed == 0
        else float(np.nanmax(result.times)),
        "solve_time_s": result.time,
        "files": [str(f) for f in files],
    }


def _least_clearance(stack: Any, result: Any, clear: dict[str, Any]) -> float | None:
    """The least signed clearance [mm] over the reached waypoints
    (:func:`stackik.clearances`), or None when no clearance can fail."""
    from stackik.clearance import clearances, clearances_can_fail

    if result.completed == 0 or not clearances_can_fail(
        stack, clear["obstacles"], clear["clearance"]
    ):
        return None
    phi = getattr(result.targets[0], "phi", None)
    return min(
        clearances(stack, q, clear["obstacles"], phi=phi).minimum
        for q in result.q[: result.completed]
    )


def run(args: argparse.Namespace) -> int:
    """Solve the path, write the files, print a summary; exit code."""
    from stackik.paths import solve_path

    stack = load_stack(args.n, args.geometry)
    targets = _targets(args)
    speed, accel = args.leg_speed, args.leg_accel
    if accel is not None and speed is None:
        raise CLIError("--leg-accel needs --leg-speed")
    if speed is not None and accel is None:
        accel = ACCEL_PER_SPEED * speed
    if args.html is not None:  # a missing plotly is reported before the solve
        from stackik.viz import require_plotly

        require_plotly()
    if args.force_weight:
        raise CLIError("--force-weight: paths minimise FN; it applies to stackik solve")
    clear = clearance_of(args)
    clear["load"] = load_of(args)
    result = solve_path(
        stack,
        targets,
        **clear,
        max_jump=tuple(args.max_jump),
        mode=args.mode,
        motion_weight=args.motion_weight,
        refine=args.refine,
        leg_speed=speed,
        leg_accel=accel,
        checkpoint=args.checkpoint,
        threads=args.threads,
    )
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    files = [result.to_csv(out / "path.csv")]
    doc = result.to_dict()
    doc["geometry"] = stack.to_dict()  # what `stackik view path.json` draws the poses with
    (out / "path.json").write_text(json.dumps(doc, indent=1) + "\n")
    files.append(out / "path.json")
    if args.html is not None and result.completed > 0:
        from stackik import viz

        fig = viz.path_figure(
            stack, result, obstacles=clear["obstacles"] or None, clearance=clear["clearance"]
        )
        files.append(viz.write_html(fig, args.html))
    try:
        from stackik.paths.animate import animate_path, plot_path

        if result.completed > 0:
            import matplotlib.pyplot as plt

            fig = plot_path(result, stack, out / "path.png")
            plt.close(fig)
            files.append(out / "path.png")
            if not args.no_animation:
                files += animate_path(
                    result, stack, out / "path.gif", fps=args.fps, max_frames=args.frames,
                    obstacles=clear["obstacles"], clearance=clear["clearance"],
                )  # fmt: skip
    except ImportError as exc:
        print(f"{PROG}: note: figures skipped ({exc}); install stackik[plot]", file=sys.stderr)
    summary = _summary(result, files)
    summary["least_clearance_mm"] = _least_clearance(stack, result, clear)
    import numpy as np

    lf = result.leg_forces
    summary["peak_leg_force_N"] = (
        None if lf is None or result.completed == 0 else float(np.nanmax(np.abs(lf)))
    )
    if args.json:
        dump_json(summary)
    else:
        mj = summary["largest_step"]
        print(
            f"{summary['status']}: {result.completed}/{result.m} waypoints "
            f"({result.mode} mode), mean FN {summary['mean_frobenius_norm']:.2f}, "
            f"largest step {mj[0]:.2f} mm / {mj[1]:.4f} rad "
            f"(max jump {result.max_jump[0]:g} mm / {result.max_jump[1]:g} rad), "
            f"{result.time:.2f} s"
        )
        if summary["duration_s"] is not None and math.isfinite(summary["duration_s"]):
            print(f"timed: {summary['duration_s']:.2f} s at {speed:g} mm/s, {accel:g} mm/s^2")
        if summary["peak_leg_force_N"] is not None:
            print(f"peak leg force over the waypoints: {summary['peak_leg_force_N']:.4g} N")
        if summary["least_clearance_mm"] is not None:
            print(f"least clearance over the waypoints: {summary['least_clearance_mm']:.3g} mm")
        if not result.success:
            print(result.message)
        for f in files:
            print(f"wrote {f}")
    return EXIT_OK if result.success else EXIT_INFEASIBLE
