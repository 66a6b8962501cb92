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
    add_clearance_arguments,
    add_load_arguments,
    add_method_args,
    add_phi_args,
    add_scale_args,
    add_stack_args,
    clearance_of,
    draw_figures,
    dump_json,
    executor_from_args,
    finite_float,
    load_of,
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
    c = p.add_argument_group("payload capacity map (--capacity)")
    c.add_argument("--capacity", action="store_true",
                   help="map stackik.payload_capacity over the targets instead (needs a "
                   "finite force_max in the geometry; the payload's weight along --gravity): "
                   "capacity.csv, capacity_map.png, peak_force_map.png")  # fmt: skip
    c.add_argument("--capacity-tol", type=finite_float, default=0.1, metavar="KG",
                   help="bisection tolerance of each capacity [kg] (0.1)")  # fmt: skip
    c.add_argument("--mass-max", type=finite_float, default=1000.0, metavar="KG",
                   help="largest payload tried [kg] (1000)")  # fmt: skip
    add_load_arguments(p)
    add_clearance_arguments(p)
    return p


def _clearance(args: argparse.Namespace) -> tuple[dict[str, Any], dict[str, Any]]:
    """The solves' ``obstacles``/``clearance`` keywords (none when not given, so that a map
    without them solves as before) and their JSON record."""
    clear = clearance_of(args)
    record = {"obstacles": [ob.to_dict() for ob in clear["obstacles"]],
              "clearance": clear["clearance"]}  # fmt: skip
    if not clear["obstacles"] and not clear["clearance"]:
        return {}, record
    return clear, record


def _check_checkpoint(folder: Path, record: dict[str, Any]) -> None:
    """Record the obstacles and margin in the checkpoint folder; refuse to resume a
    checkpoint of other ones (its solves would not be this map's)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "clearance.json"
    if path.exists():
        old = json.loads(path.read_text())
        if old != json.loads(json.dumps(record)):
            raise CLIError(
                f"--obstacles/--clearance: {folder} holds solves of other obstacles or "
                "another margin (remove it or use another --out)"
            )
    elif any(folder.iterdir()) and (record["obstacles"] or record["clearance"]):
        raise CLIError(f"--obstacles/--clearance: {folder} holds solves without them")
    path.write_text(json.dumps(record) + "\n")


def run_capacity(args: argparse.Namespace, stack: Any, phi: float) -> int:
    """``stackik map --capacity``: :func:`stackik.analysis.capacity.capacity_map` on the
    map's targets; exit code 1 if no target carries anything."""
    if args.payload_mass is not None:
        raise CLIError("--payload-mass: --capacity varies the payload mass itself")
    from stackik.analysis.capacity import capacity_map
    from stackik.analysis.workspace import study_targets

    seed = DEFAULT_SEED if args.seed is None else args.seed
    targets = study_targets(stack, args.targets, seed=seed, phi=phi)
    clear, record = _clearance(args)
    kw: dict[str, Any] = {"method": args.method, "qp_solver": resolve_qp(args.method, None)}
    kw.update(clear)
    if args.force_weight:
        kw["force_weight"] = args.force_weight
    with executor_from_args(args) as executor:
        say_where(executor, args.quiet)
        cmap = capacity_map(
            stack, targets, load_of(args), mass_max=args.mass_max, tol=args.capacity_tol,
            executor=executor, **kw,
        )  # fmt: skip
    rows = cmap.rows()
    written: list[Path] = []
    if args.out is not None:
        from stackik._io import write_csv

        out: Path = args.out
        out.mkdir(parents=True, exist_ok=True)
        write_csv(out / "capacity.csv", rows)
        written.append(out / "capacity.csv")

        def draw(figures: Any) -> None:
            obs = clear.get("obstacles")
            figures.plot_capacity_map(cmap, path=out / "capacity_map.png", obstacles=obs, phi=phi)
            figures.plot_peak_force_map(
                cmap, path=out / "peak_force_map.png", obstacles=obs, phi=phi
            )

        if draw_figures(draw):
            written += [out / "capacity_map.png", out / "peak_force_map.png"]
    carried = [r for r in rows if r["carried"]]
    if args.json:
        dump_json({"targets": len(rows), "carried": len(carried), "seed": seed, "phi": phi,
                   **record, "rows": rows, "geometry": stack.to_dict()})  # fmt: skip
    else:
        print(f"payload capacity: {len(carried)} of {len(rows)} targets carry their load")
        if carried:
            masses = sorted(r["capacity_kg"] for r in carried)
            print(f"capacity [kg]: min {masses[0]:.3g}, median {masses[len(masses) // 2]:.3g}, "
                  f"max {masses[-1]:.3g}")  # fmt: skip
        sec = sum(cmap.seconds) / max(len(rows), 1)
        print(f"{sec:.2f} s per target ({sum(c.solves for c in cmap.capacities)} solves)")
        for path in written:
            print(f"wrote {path}")
    return EXIT_OK if carried else EXIT_INFEASIBLE


def _write_study(
    args: argparse.Namespace, study: Any, rows: Any, clear: dict[str, Any], phi: float
) -> list[Path]:
    """Write workspace.csv, regression.json and the figures into ``--out`` (if given)."""
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
            figures.plot_fn_ratio_map(
                study, highlight=highlight, path=out / "fn_ratio_map.png",
                obstacles=clear.get("obstacles"), phi=phi,
            )  # fmt: skip
            if reg is not None:
                figures.plot_regression(study, path=out / "regression.png")

        if draw_figures(draw):
            written.append(out / "fn_ratio_map.png")
            if reg is not None:
                written.append(out / "regression.png")
    return written


def run(args: argparse.Namespace) -> int:
    """Run ``stackik map``; exit code 1 if no target was solved."""
    stack = load_stack(args.n, args.geometry)
    phi = phi_of(args)
    if args.capacity:
        if args.targets < 1:
            raise CLIError(f"--targets: expected at least 1, got {args.targets}")
        return run_capacity(args, stack, phi)
    if load_of(args) is not None or args.force_weight:
        raise CLIError("the load options apply to --capacity only")
    if args.targets < 3:
        raise CLIError(f"--targets: expected at least 3, got {args.targets}")
    try:
        study_fn = lookup("stackik.analysis.workspace", ("workspace_study",))
        targets_fn = lookup("stackik.analysis.workspace", ("study_targets",))
    except NotAvailableError as exc:
        return not_available(NAME, exc)
    qp = resolve_qp(args.method, args.qp_solver)
    seed = DEFAULT_SEED if args.seed is None else args.seed
    clear, record = _clearance(args)
    if args.out is not None:
        _check_checkpoint(args.out / "checkpoint", record)
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
            solve_kwargs={"method": args.method, "qp_solver": qp, **clear},
            checkpoint_dir=None if args.out is None else args.out / "checkpoint",
        )
    rows = study.rows()
    reg = study.regression
    written = _write_study(args, study, rows, clear, phi)
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
        **record,
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
