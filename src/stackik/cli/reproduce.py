"""``stackik reproduce``: the paper's tables and figures, from
:mod:`stackik.analysis.reproduce`."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ._common import (
    DEFAULT_SEED,
    EXIT_OK,
    NotAvailableError,
    add_scale_args,
    check_scale_args,
    lookup,
    not_available,
)

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "reproduce"
HELP = "reproduce the paper's tables and figures (stackik.analysis.reproduce)"


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``reproduce`` and its arguments to ``subparsers``."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        NAME,
        help=HELP,
        description="Reproduce the paper's Tables 1-2 and figures into a directory.",
    )
    p.add_argument("--out", type=Path, default=Path("results"), metavar="DIR", help="(results)")
    p.add_argument("--quick", action="store_true", help="fewer samples: a fast smoke run")
    p.add_argument("--seed", type=int, default=None, metavar="S", help=f"seed ({DEFAULT_SEED})")
    p.add_argument("--strict", action="store_true", help="exit 1 when a reproduction check fails")
    add_scale_args(p)
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``stackik reproduce`` (:func:`stackik.analysis.reproduce.main_reproduce`)."""
    check_scale_args(args)
    try:
        fn = lookup("stackik.analysis.reproduce", ("main_reproduce",))
    except NotAvailableError as exc:
        return not_available(NAME, exc)
    rc = fn(
        args.out,
        quick=args.quick,
        progress=not args.quiet,
        seed=DEFAULT_SEED if args.seed is None else args.seed,
        workers=1 if args.workers is None else args.workers,
        strict=args.strict,
        scheduler=args.scheduler,
    )
    return int(rc) if rc is not None else EXIT_OK
