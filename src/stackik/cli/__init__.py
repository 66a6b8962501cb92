"""Command line of stackik: ``stackik`` (or ``python -m stackik``).

Subcommands (one module each, listed in :data:`COMMANDS`)
---------------------------------------------------------
``solve``
    Inverse kinematics of one target (planar, or spatial with ``--spatial``): prints the
    pose, leg lengths and the margin to every limit, or JSON with ``--json``.
``mc``
    Monte Carlo sensitivity (paper Algorithm 1) of the least-FN pose against non-optimised
    poses of the same target, with common noise.
``map``
    Workspace study (FN ratio map), from :mod:`stackik.analysis.workspace`.
``reproduce``
    The paper's tables and figures, from :mod:`stackik.analysis.reproduce`.
``bench``
    Benchmarks (:func:`stackik.bench.main`).
``geometry``
    ``show``, ``validate FILE`` or ``write FILE`` a stack geometry (.toml / .json).
``path``
    Continuous least-FN poses along an end-effector path (:mod:`stackik.paths`).
``view``
    An interactive 3D view of a solve or path result: one self-contained HTML file
    (:mod:`stackik.viz`).

Adding a subcommand: write a module ``stackik/cli/<name>.py`` that defines

* ``NAME: str``, the subcommand's name, and ``HELP: str``, its line in ``stackik --help``;
* ``add_parser(subparsers) -> argparse.ArgumentParser``: adds ``NAME`` to ``subparsers``
  (``subparsers.add_parser(NAME, help=HELP, ...)``) with its arguments, and returns it;
* ``run(args: argparse.Namespace) -> int``: does the work and returns the exit code;
* optionally ``PASSTHROUGH = True``: every token after ``NAME`` (even ``--help``) reaches
  ``run`` unparsed, as the list ``args.args``;

and add the module to :data:`COMMANDS`. Shared option groups and output helpers are in
:mod:`stackik.cli._common`. Modules import numpy, scipy and the solvers inside ``run``,
never at module level, so ``stackik --help`` stays fast.

Exit codes: 0 success; 1 no feasible solution; 2 bad input (one line on stderr, starting
with ``stackik: error:``). ``run`` reports bad input by raising ``CLIError``, ``ValueError``
(e.g. ``GeometryError``) or ``OSError``; :func:`main` turns them into exit code 2.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from types import ModuleType

from . import bench, geometry, mc, path, reproduce, solve, view
from . import map as map_  # the module, not the builtin
from ._common import EXIT_USAGE, PROG, CLIError, Parser, one_line

__all__ = ["COMMANDS", "build_parser", "main"]

#: The subcommand modules, in the order ``stackik --help`` lists them.
COMMANDS: tuple[ModuleType, ...] = (solve, mc, map_, reproduce, bench, geometry, path, view)


def _command(name: str) -> ModuleType:
    for module in COMMANDS:
        if module.NAME == name:
            return module
    raise KeyError(name)  # pragma: no cover - argparse accepts registered names only


def build_parser() -> argparse.ArgumentParser:
    """The ``stackik`` argument parser (one subparser per module of :data:`COMMANDS`)."""
    from stackik._version import __version__

    parser = Parser(
        prog=PROG,
        description="Inverse kinematics of stacks of Stewart platforms with the least "
        "end-effector sensitivity (minimum Frobenius norm of the Jacobian). "
        "Millimetres and radians.",
        epilog="Exit codes: 0 success, 1 no feasible solution, 2 bad input.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in COMMANDS:
        module.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (0 ok, 1 infeasible, 2 bad input)."""
    tokens = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    passthrough = {m.NAME: m for m in COMMANDS if getattr(m, "PASSTHROUGH", False)}
    try:
        if tokens[:1] and tokens[0] in passthrough:  # every later token belongs to it
            args = argparse.Namespace(command=tokens[0], args=tokens[1:])
        else:
            args = parser.parse_args(tokens)
    except SystemExit as exc:  # usage error (already reported on stderr), --help, --version
        return exc.code if isinstance(exc.code, int) else EXIT_USAGE
    try:
        rc: int = _command(args.command).run(args)
    except (CLIError, ValueError, OSError) as exc:  # GeometryError is a ValueError
        sys.stdout.flush()
        print(f"{PROG}: error: {one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except ImportError as exc:  # an optional dependency (e.g. casadi for ipopt) is missing
        name = getattr(exc, "name", None) or one_line(exc)
        print(
            f"{PROG}: error: missing optional dependency {name} ({one_line(exc)})", file=sys.stderr
        )
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    return rc
