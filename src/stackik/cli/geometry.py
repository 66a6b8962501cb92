"""``stackik geometry``: ``show``, ``validate FILE`` or ``write FILE`` a stack geometry
(.toml / .json)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._common import EXIT_OK, PROG, CLIError, add_stack_args, load_stack

if TYPE_CHECKING:
    from stackik.geometry import Stack

__all__ = ["HELP", "NAME", "add_parser", "describe_stack", "run"]

NAME = "geometry"
HELP = "show, validate or write a stack geometry file"


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``geometry`` and its actions (``show``, ``validate``, ``write``) to ``subparsers``."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        NAME,
        help=HELP,
        description="Stack geometry files (.toml or .json; lengths mm, angles rad).",
    )
    gsub = p.add_subparsers(dest="action", metavar="ACTION", required=True)
    g = gsub.add_parser("show", help="print a geometry (default: the reference geometry)")
    add_stack_args(g)
    g.add_argument("--format", choices=("text", "toml", "json"), default="text")
    g = gsub.add_parser("validate", help="check a geometry file (exit 0 valid, 2 invalid)")
    g.add_argument("file", type=Path, metavar="FILE")
    g = gsub.add_parser("write", help="write the reference geometry to FILE to start from")
    g.add_argument("file", type=Path, metavar="FILE", help=".toml or .json")
    g.add_argument("--n", type=int, default=None, metavar="N", help="platforms (4)")
    g.add_argument("--force", action="store_true", help="overwrite an existing file")
    return p


def describe_stack(stack: Stack) -> str:
    """Human-readable description of a stack geometry."""
    import numpy as np

    lines = [f"stack of {stack.n} platform(s), bottom first; lengths in mm, angles in deg"]
    for i, g in enumerate(stack):
        if i > 0 and g == stack[i - 1]:
            lines.append(f"platform {i + 1}: same as platform {i}")
            continue
        sizes = "".join(
            f", {label} {value:g} mm"
            for label, value in (
                ("leg radius", g.leg_radius),
                ("plate thickness", g.plate_thickness),
            )
            if value > 0
        )
        lines.append(
            f"platform {i + 1}: legs {g.leg_min:g}-{g.leg_max:g} mm, "
            f"joint_min {math.degrees(g.joint_min):.4g} deg{sizes}"
        )
        if g.plate_mass or g.leg_mass or math.isfinite(g.force_max):
            lines.append(
                f"  plate {g.plate_mass:g} kg, each leg {g.leg_mass:g} kg, "
                f"leg force limit {g.force_max:g} N"
            )
        for key, nodes in (("base nodes", g.base_nodes), ("top nodes", g.top_nodes)):
            r = np.hypot(nodes[:, 0], nodes[:, 1])
            ang = np.degrees(np.arctan2(nodes[:, 1], nodes[:, 0]))
            lines.append(f"  {key} (x, y, z) | radius, azimuth:")
            for k in range(6):
                x, y, z = nodes[k]
                lines.append(
                    f"    {k}: ({x:9.3f}, {y:9.3f}, {z:7.3f}) | {r[k]:8.3f}, {ang[k]:8.2f}"
                )
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Run ``stackik geometry ACTION``."""
    from stackik.geometry import Stack

    if args.action == "show":
        stack = load_stack(args.n, args.geometry)
        if args.format == "toml":
            print(stack.to_toml(), end="")
        elif args.format == "json":
            print(stack.to_json())
        else:
            print(describe_stack(stack))
        return EXIT_OK
    if args.action == "validate":
        stack = Stack.from_file(args.file)
        print(f"valid: {args.file} ({stack.n} platform(s))")
        if all(g.leg_radius == 0.0 for g in stack):
            print(
                f"{PROG}: warning: {args.file} gives no leg_radius: the legs are lines to the "
                "clearance check (set leg_radius [mm] to keep real actuators apart)",
                file=sys.stderr,
            )
        return EXIT_OK
    # write
    path: Path = args.file
    suffix = path.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise CLIError(f"{path}: use a .toml or .json file name")
    if path.exists() and not args.force:
        raise CLIError(f"{path} exists (use --force to overwrite)")
    n = 4 if args.n is None else args.n
    if n < 1:
        raise CLIError(f"--n: the number of platforms must be >= 1, got {n}")
    stack = Stack.reference(n)
    if suffix == ".toml":
        stack.to_toml(path)
    else:
        stack.to_json(path)
    print(f"wrote the reference geometry ({n} platforms) to {path}")
    return EXIT_OK
