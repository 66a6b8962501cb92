"""``stackik solve``: inverse kinematics of one target (planar, or spatial with
``--spatial``); prints the pose, leg lengths and the margin to every limit, or JSON."""

from __future__ import annotations

import argparse
import dataclasses
import math
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._common import (
    EXIT_INFEASIBLE,
    EXIT_OK,
    CLIError,
    add_clearance_arguments,
    add_load_arguments,
    add_method_args,
    add_planar_target_args,
    add_stack_args,
    add_starts_arg,
    clearance_of,
    dump_json,
    finite_float,
    load_of,
    load_stack,
    planar_target,
    positive_int,
    resolve_qp,
)

if TYPE_CHECKING:
    from stackik.geometry import Stack
    from stackik.result import IKResult
    from stackik.targets import PlanarTarget, SpatialTarget

__all__ = [
    "HELP",
    "NAME",
    "add_parser",
    "format_result",
    "pose_margins",
    "qp_backend",
    "run",
    "split_message",
]

NAME = "solve"
HELP = "solve the inverse kinematics of one target"


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``solve`` and its arguments to ``subparsers``."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        NAME,
        help=HELP,
        description="Solve the inverse kinematics of one end-effector target and print the "
        "pose, leg lengths and margins to every limit.",
    )
    add_stack_args(p)
    add_planar_target_args(p, required=False)
    p.add_argument(
        "--spatial",
        action="store_true",
        help="spatial mode (6 variables per platform): give --position and --euler",
    )
    p.add_argument("--position", nargs=3, type=finite_float, metavar=("X", "Y", "Z"))
    p.add_argument(
        "--euler",
        nargs=3,
        type=finite_float,
        metavar=("YAW", "PITCH", "ROLL"),
        help="target orientation R = Rz(yaw) Ry(pitch) Rx(roll) [rad] (default 0 0 0)",
    )
    p.add_argument(
        "--objective",
        choices=("frobenius", "feasible", "weighted"),
        default="frobenius",
        help="frobenius: least FN (paper); feasible: first feasible pose; weighted: least "
        "trace(J C_x J^T) (default frobenius)",
    )
    p.add_argument("--sigma-t", type=float, default=None, help="weighted: sigma_t [mm] (1)")
    p.add_argument(
        "--sigma-theta", type=float, default=None, help="weighted: sigma_theta [rad] (0.005)"
    )
    add_method_args(p)
    add_starts_arg(p)
    p.add_argument("--seed", type=int, default=None, metavar="S", help="seed of extra starts")
    p.add_argument(
        "--start",
        choices=("paper", "convex"),
        default="paper",
        help="first start: the paper's initial guess or the convex (SOCP) restriction",
    )
    p.add_argument("--max-time", type=float, default=None, metavar="SEC", help="time budget")
    p.add_argument("--threads", type=positive_int, default=None, metavar="N",
                   help="threads the interior point's starts run on (default: every CPU, at "
                        "most 8; the pose does not depend on it)")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--html", type=Path, default=None, metavar="FILE",
                   help="also write an interactive 3D view of the pose (needs plotly)")  # fmt: skip
    add_load_arguments(p)
    add_clearance_arguments(p)
    return p


def pose_margins(stack: Stack, result: IKResult) -> dict[str, list[float]]:
    """Margins of a solved pose to every limit, per platform.

    Returns
    -------
    dict of lists, each of length n
        ``leg_min_mm``: ``min_k |l_k| - leg_min`` [mm]; ``leg_max_mm``:
        ``min_k leg_max - |l_k|`` [mm]; ``joint_base_deg`` / ``joint_top_deg``:
        ``min_k`` (angle between leg k and the base / top plate) ``- joint_min`` [deg].
        Negative means violated.
    """
    import numpy as np

    P, R = result.P, result.R
    legs = np.einsum("nij,nkj->nki", R, stack.top_nodes) + P[:, None, :] - stack.base_nodes
    length = np.linalg.norm(legs, axis=-1)  # (n, 6)
    normal_top = R[:, :, 2]  # R n, n = (0, 0, 1)
    sin_base = legs[..., 2] / length
    sin_top = np.einsum("nki,ni->nk", legs, normal_top) / length
    jmin = np.degrees(np.arcsin(stack.sin_joint_min))[:, None]
    ang_base = np.degrees(np.arcsin(np.clip(sin_base, -1.0, 1.0)))
    ang_top = np.degrees(np.arcsin(np.clip(sin_top, -1.0, 1.0)))
    return {
        "leg_min_mm": (length - stack.leg_min[:, None]).min(axis=1).tolist(),
        "leg_max_mm": (stack.leg_max[:, None] - length).min(axis=1).tolist(),
        "joint_base_deg": (ang_base - jmin).min(axis=1).tolist(),
        "joint_top_deg": (ang_top - jmin).min(axis=1).tolist(),
    }


def _force_lines(result: IKResult) -> list[str]:
    """The leg-force block of the table (when the solve computed forces)."""
    if result.leg_forces is None or result.force_margin is None:
        return []
    assert result.sigma_min is not None and result.condition is not None
    lines = [
        "",
        "Leg forces [N] (compression positive), least force margin [N], singularity measure:",
        f"{'i':>2} " + " ".join(f"{'f' + str(k + 1):>8}" for k in range(6))
        + f"  {'margin':>8} {'sigma_min':>9} {'cond':>8}",
    ]  # fmt: skip
    for i, f in enumerate(result.leg_forces):
        m = float(result.force_margin[i].min())
        lines.append(
            f"{i + 1:>2} " + " ".join(f"{v:>8.1f}" for v in f)
            + f"  {m:>8.3g} {result.sigma_min[i]:>9.3g} {result.condition[i]:>8.3g}"
        )  # fmt: skip
    lines.append(
        "  margin = force_max - |f| (inf: no limit; negative = over it); sigma_min, cond: "
        "of the leg wrench matrix made dimensionless (0 / inf = singular)"
    )
    return lines


def _clearance_lines(result: IKResult) -> list[str]:
    """The clearances block of the table (none when the check measured none)."""
    c = result.clearances
    if c is None:
        return []
    obstacles = "".join(f", obstacle {k}: {d:.2f}" for k, d in enumerate(c.obstacles))
    lines = [
        "Clearances [mm] (signed surface distances, negative = penetration): "
        f"self legs {c.self_legs:.2f}, adjacent legs {c.adjacent_legs:.2f}, "
        f"non-adjacent {c.non_adjacent:.2f}{obstacles}"
    ]
    closest = c.closest
    if closest is not None:
        lines.append(f"  closest: {closest}")
    return ["\n".join(textwrap.wrap(lines[0], 88, subsequent_indent="  ")), *lines[1:]]


def format_result(stack: Stack, result: IKResult) -> str:
    """Human-readable table of an :class:`~stackik.result.IKResult` (pose, legs, margins,
    summary)."""
    margins = pose_margins(stack, result)
    planar = result.mode == "planar"
    lines: list[str] = []
    if planar:
        head = f"{'i':>2} {'rho[mm]':>9} {'z[mm]':>9} {'theta[rad]':>10}"
    else:
        head = (
            f"{'i':>2} {'x[mm]':>8} {'y[mm]':>8} {'z[mm]':>8} {'yaw':>7} {'pitch':>7} {'roll':>7}"
        )
    legs_head = " ".join(f"{'l' + str(k + 1):>6}" for k in range(6))
    margin_head = f"{'>lmin':>7} {'<lmax':>7} {'jb[deg]':>7} {'jt[deg]':>7}"
    lines.append("Pose (platform 1 = bottom), leg lengths [mm], margins to limits:")
    lines.append(f"{head}  {legs_head}  {margin_head}")
    for i in range(stack.n):
        q = result.q[i]
        if planar:
            row = f"{i + 1:>2} {q[0]:>9.2f} {q[1]:>9.2f} {q[2]:>10.4f}"
        else:
            row = (
                f"{i + 1:>2} {q[0]:>8.2f} {q[1]:>8.2f} {q[2]:>8.2f} "
                f"{q[3]:>7.4f} {q[4]:>7.4f} {q[5]:>7.4f}"
            )
        legs = " ".join(f"{v:>6.1f}" for v in result.leg_lengths[i])
        marg = " ".join(
            f"{margins[key][i]:>7.2f}".replace("-0.00", " 0.00")  # at the limit
            for key in ("leg_min_mm", "leg_max_mm", "joint_base_deg", "joint_top_deg")
        )
        lines.append(f"{row}  {legs}  {marg}")
    worst = min(min(v) for v in margins.values())
    lines.append(
        "  margins: >lmin = min |l| - leg_min, <lmax = leg_max - max |l|, jb/jt = leg-plate "
        f"angle - joint_min at base/top (worst {worst:.3g}; negative = violated)"
    )
    lines += _force_lines(result)
    lines += _clearance_lines(result)
    lines.append("")
    width = 16
    headline, details = split_message(result.message)
    summary: list[tuple[str, str]] = [
        ("success", str(result.success)),
        ("status", f"{result.status.value}: {headline}"),
        ("frobenius norm", f"{result.frobenius_norm:.6g}"),
        ("objective", f"{result.objective} = {result.objective_value:.6g}"),
        ("max violation", f"{result.max_violation:.3g} (raw: mm^2 leg blocks, mm joint blocks)"),
        ("target error", f"{result.target_error:.3g} mm, {result.angle_error:.3g} rad"),
        ("time", f"{result.time:.3f} s ({result.nit} iterations, {result.n_starts} start(s))"),
        ("method", f"{result.method} (QP backend: {qp_backend(result) or 'none'})"),
    ]
    if result.phi is not None:
        summary.insert(4, ("phi", f"{result.phi:.6g} rad"))
    indent = " " * width
    for key, value in summary:
        lines.append(f"{key:<{width}}{value}")
        if key == "status" and details:  # the message's details, below its headline
            wrapped = textwrap.fill(details, 88, initial_indent=indent, subsequent_indent=indent)
            lines.append(wrapped)
    return "\n".join(lines)


def split_message(message: str) -> tuple[str, str]:
    """``(headline, details)`` of a result message: its first sentence, and the rest
    (empty for the one-sentence messages of a success)."""
    head, sep, rest = message.partition(". ")
    return (head + ".", rest.strip()) if sep else (message, "")


def qp_backend(result: IKResult) -> str | None:
    """The QP backend of the method that produced the pose: the SQP engine's (its
    default, :func:`stackik.sqp.qp.default_qp_solver`, when none was asked for, as after
    the ``auto`` policy's hand-over); None for the methods without one (ip, scipy, ipopt)."""
    if result.method != "sqp":
        return None
    if result.qp_solver not in ("-", "default"):
        return result.qp_solver
    from stackik.sqp.qp import default_qp_solver

    return default_qp_solver()


def _target(args: argparse.Namespace) -> PlanarTarget | SpatialTarget:
    if args.spatial:
        if args.target is not None:
            raise CLIError("--target is planar; with --spatial give --position X Y Z")
        if args.position is None:
            raise CLIError("--spatial needs --position X Y Z [--euler YAW PITCH ROLL]")
        if args.phi is not None or args.phi_deg is not None:
            raise CLIError("--phi applies to planar targets only")
        from stackik.rotations import euler_zyx
        from stackik.targets import SpatialTarget

        euler = args.euler if args.euler is not None else (0.0, 0.0, 0.0)
        for name, v in zip(("yaw", "pitch", "roll"), euler):
            if not math.isfinite(v):
                raise CLIError(f"--euler {name}: must be finite, got {v}")
        return SpatialTarget(args.position, euler_zyx(euler))
    if args.position is not None or args.euler is not None:
        raise CLIError("--position/--euler need --spatial")
    if args.target is None:
        raise CLIError("the following arguments are required: --target RHO Z THETA")
    return planar_target(args)


def run(args: argparse.Namespace) -> int:
    """Run ``stackik solve``; exit code 0 if solved, 1 if no feasible solution."""
    stack = load_stack(args.n, args.geometry)
    target = _target(args)
    if args.objective != "weighted" and (args.sigma_t is not None or args.sigma_theta is not None):
        raise CLIError("--sigma-t/--sigma-theta apply to --objective weighted only")
    qp = resolve_qp(args.method, args.qp_solver)
    if args.html is not None:  # a missing plotly is reported before the solve
        from stackik.viz import require_plotly

        require_plotly()
    from stackik.solve import solve_ik

    clear = clearance_of(args)
    kwargs: dict[str, Any] = {}
    if args.objective == "weighted":
        kwargs["sigma_t"] = 1.0 if args.sigma_t is None else args.sigma_t
        kwargs["sigma_theta"] = 0.005 if args.sigma_theta is None else args.sigma_theta
    if args.max_time is not None:
        kwargs["max_time"] = args.max_time
    result = solve_ik(
        stack,
        target,
        objective=args.objective,
        method=args.method,
        qp_solver=qp,
        starts=args.starts,
        rng=args.seed,
        start=args.start,
        load=load_of(args),
        force_weight=args.force_weight,
        threads=args.threads,
        **clear,
        **kwargs,
    )
    if clear["obstacles"] and result.clearances is None:
        # the solve's check leaves out obstacles no body of the pose can reach; the table
        # and the JSON show every obstacle's distance all the same
        import numpy as np

        from stackik.clearance import clearances

        if np.all(np.isfinite(result.q)):
            measured = clearances(stack, result.q, clear["obstacles"], phi=result.phi)
            result = dataclasses.replace(result, clearances=measured)
    if args.json:
        data = result.to_dict()
        data["qp_solver"] = qp_backend(result) or "-"
        data["n"] = stack.n
        data["force_weight"] = args.force_weight
        if result.mode == "planar":
            data["target"] = {"rho": args.target[0], "z": args.target[1], "theta": args.target[2]}
        else:
            data["target"] = {
                "position": list(args.position),
                "euler_zyx": list(args.euler or (0.0, 0.0, 0.0)),
            }
        data["P"] = result.P.tolist()
        data["R"] = result.R.tolist()
        data["margins"] = pose_margins(stack, result)
        data["geometry"] = stack.to_dict()
        data["geometry_source"] = str(args.geometry) if args.geometry else "reference"
        dump_json(data)
    else:
        src = str(args.geometry) if args.geometry else "reference geometry"
        print(f"stack: {stack.n} platforms ({src})")
        print(format_result(stack, result))
        if args.force_weight > 0:
            print(f"{'force weight':<16}{args.force_weight:.6g} mm^2: objective = FN^2 + w "
                  "sum (f/s)^2")  # fmt: skip
    if args.html is not None:
        from stackik import viz

        fig = viz.pose_figure(
            stack,
            result.q,
            phi=result.phi,
            target=target,
            obstacles=clear["obstacles"] or None,
            clearance=clear["clearance"],
        )
        path = viz.write_html(fig, args.html)
        if not args.json:
            print(f"wrote {path}")
    return EXIT_OK if result.success else EXIT_INFEASIBLE
