"""``stackik map``: workspace study (FN ratio map), from :mod:`stackik.analysis.workspace`."""

from __future__ import annotations

import argparse
import json
from concurrent.futures import ThreadPoolExecutor
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from ._common import (
    DEFAULT_SEED,
    EXIT_INFEASIBLE,
    EXIT_OK,
    CLIError,
    NotAvailableError,
    add_method_args,
    add_phi_args,
    add_scale_args,
    add_stack_args,
    draw_figures,
    dump_json,
    executor_from_args,
    load_stack,
    lookup,
    not_available,
    phi_of,
    positive_int,
    resolve_qp,
    say_where,
)

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "map"
HELP = "workspace study: FN ratio of optimal vs non-optimised poses"


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``map`` and its arguments to ``subparsers``."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        NAME,
        help=HELP,
        description="Workspace study (paper figures 'ratio' and 'MedianRatio'): on random "
        "reachable targets, compare the least-FN pose with a non-optimised pose (FN ratio, "
        "Monte Carlo median-displacement ratio and their regression).",
    )
    add_stack_args(p)
    add_phi_args(p)
    p.add_argument("--targets", type=int, default=50, metavar="M", help="random targets (50)")
    p.add_argument("--samples", type=positive_int, default=2000, help="MC samples (2000)")
    p.add_argument("--sigma-t", type=float, default=1.0, help="translation noise [mm] (1)")
    p.add_argument("--sigma-theta", type=float, default=0.005, help="angle noise [rad] (0.005)")
    add_method_args(p)
    p.add_argument("--seed", type=int, default=None, metavar="S", help=f"seed ({DEFAULT_SEED})")
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="DIR",
        help="write workspace.csv, regression.json and the figures into DIR; finished "
        "solves are recorded in DIR/checkpoint, so an interrupted run resumes there",
    )
    add_scale_args(p)
    p.add_argument("--json", action="store_true", help="print JSON instead of a summary")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``stackik map``; exit code 1 if no target was solved."""
    stack = load_stack(args.n, args.geometry)
    phi = phi_of(args)
    if args.targets < 3:
        raise CLIError(f"--targets: expected at least 3, got {args.targets}")
    try:
        study_fn = lookup("stackik.analysis.workspace", ("workspace_study",))
        targets_fn = lookup("stackik.analysis.workspace", ("study_targets",))
    except NotAvailableError as exc:
        return not_available(NAME, exc)
    qp = resolve_qp(args.method, args.qp_solver)
    seed = DEFAULT_SEED if args.seed is None else args.seed
    with ExitStack() as cleanup:
        # the workers start (and load the kernels) while this process draws the targets
        with ThreadPoolExecutor(1) as starter:
            pending = starter.submit(cleanup.enter_context, executor_from_args(args))
            targets = targets_fn(stack, args.targets, seed=seed, phi=phi)
            executor = pending.result()
        say_where(executor, args.quiet)
        study = study_fn(
            stack,
            targets,
            n_samples=args.samples,
            sigma_t=args.sigma_t,
            sigma_theta=args.sigma_theta,
            seed=seed,
            phi=phi,
            progress=not args.quiet,
            executor=executor,
            solve_kwargs={"method": args.method, "qp_solver": qp},
            checkpoint_dir=None if args.out is None else args.out / "checkpoint",
        )
    rows = study.rows()
    reg = study.regression
    written: list[Path] = []
    if args.out is not None:
        from stackik._io import write_csv
        from stackik.targets import PAPER_TARGETS

        out: Path = args.out
        out.mkdir(parents=True, exist_ok=True)
        write_csv(out / "workspace.csv", rows)
        reg_data = None if reg is None else reg.to_dict()
        (out / "regression.json").write_text(json.dumps(reg_data, indent=2) + "\n")
        written += [out / "workspace.csv", out / "regression.json"]

        def draw(figures: Any) -> None:
            highlight = [t[:2] for t in PAPER_TARGETS]
            figures.plot_fn_ratio_map(study, highlight=highlight, path=out / "fn_ratio_map.png")
            if reg is not None:
                figures.plot_regression(study, path=out / "regression.png")

        if draw_figures(draw):
            written.append(out / "fn_ratio_map.png")
            if reg is not None:
                written.append(out / "regression.png")
    import numpy as np

    valid = study.valid
    summary = {
        "targets": len(rows),
        "valid": int(valid.sum()),
        "fn_ratio_median": float(np.median(study.fn_ratio[valid])) if valid.any() else None,
        "median_ratio_median": (
            float(np.median(study.median_ratio[valid])) if valid.any() else None
        ),
        "regression": reg.to_dict() if reg is not None else None,
        "n_samples": study.n_samples,
        "sigma_t": study.sigma_t,
        "sigma_theta": study.sigma_theta,
        "seed": seed,
        "phi": phi,
    }
    if args.json:
        dump_json({**summary, "rows": rows, "geometry": stack.to_dict()})
    else:
        print(f"workspace study: {summary['valid']} of {summary['targets']} targets solved")
        if valid.any():
            print(f"median FN ratio (optimal / non-optimal):     {summary['fn_ratio_median']:.3f}")
            print(
                f"median displacement ratio (opt / non-opt):  {summary['median_ratio_median']:.3f}"
            )
        if reg is not None:
            print(
                f"regression of median ratio on FN ratio: slope {reg.slope:.3f}, "
                f"intercept {reg.intercept:.3f}, r^2 {reg.r2:.3f} (n = {reg.n}; "
                "paper: slope 0.4, r^2 0.97)"
            )
        for path in written:
            print(f"wrote {path}")
    return EXIT_OK if valid.any() else EXIT_INFEASIBLE
