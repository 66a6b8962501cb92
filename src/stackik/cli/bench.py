"""``stackik bench``: the solver benchmarks (:func:`stackik.bench.main`).

Every token after ``bench`` (even ``--help``) is passed to the benchmark unparsed
(:data:`PASSTHROUGH`).
"""

from __future__ import annotations

import argparse
from typing import Any

from ._common import call_entry

__all__ = ["HELP", "NAME", "PASSTHROUGH", "add_parser", "run"]

NAME = "bench"
HELP = "run the benchmarks (stackik.bench)"
#: The command line hands every later token to :func:`run` as ``args.args``.
PASSTHROUGH = True


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``bench`` to ``subparsers`` (listed in ``stackik --help``; its arguments are the
    benchmark's own)."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        NAME,
        help=HELP,
        description="Run the solver benchmarks; arguments are passed to stackik.bench.main.",
        add_help=False,
    )
    p.add_argument("args", nargs=argparse.REMAINDER, help="arguments of the benchmarks")
    return p


def run(args: argparse.Namespace) -> int:
    """Run :func:`stackik.bench.main` with ``args.args``."""
    return call_entry("stackik.bench", ("main",), list(args.args), NAME)
