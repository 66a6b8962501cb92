"""``stackik mc``: Monte Carlo sensitivity (paper Algorithm 1) of the least-FN pose against
non-optimised poses of the same target, with common noise."""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._common import (
    DEFAULT_SEED,
    EXIT_INFEASIBLE,
    EXIT_OK,
    PROG,
    CLIError,
    add_method_args,
    add_planar_target_args,
    add_scale_args,
    add_stack_args,
    add_starts_arg,
    draw_figures,
    dump_json,
    executor_from_args,
    json_default,
    load_stack,
    planar_target,
    positive_int,
    progress,
    resolve_qp,
    say_where,
)

if TYPE_CHECKING:
    from stackik.geometry import Stack
    from stackik.result import IKResult
    from stackik.targets import PlanarTarget

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "mc"
HELP = "Monte Carlo sensitivity: least-FN pose vs non-optimised poses"


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``mc`` and its arguments to ``subparsers``."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        NAME,
        help=HELP,
        description="Paper Algorithm 1: perturb the least-FN pose and NONOPT non-optimised "
        "poses of the same target with the same Gaussian noise and report the median "
        "end-effector displacement, its 95 % interval and the F factor of the linear "
        "estimate J C_x J^T.",
    )
    add_stack_args(p)
    add_planar_target_args(p)
    p.add_argument("--samples", type=positive_int, default=10000, help="samples (10000)")
    p.add_argument("--sigma-t", type=float, default=1.0, help="translation noise [mm] (1)")
    p.add_argument("--sigma-theta", type=float, default=0.005, help="angle noise [rad] (0.005)")
    p.add_argument("--nonopt", type=int, default=2, help="non-optimised poses (2)")
    add_method_args(p)
    add_starts_arg(p)
    p.add_argument("--seed", type=int, default=None, metavar="S", help=f"seed ({DEFAULT_SEED})")
    p.add_argument(
        "--out", type=Path, default=None, metavar="DIR", help="write mc.json and the figures"
    )
    add_scale_args(p)
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p


def _nonoptimal(
    stack: Stack, target: PlanarTarget, k: int, seed: int, executor: Any = None, **kw: Any
) -> list[IKResult]:
    """``k`` non-optimised feasible poses (:func:`stackik.analysis.workspace.nonoptimal_poses`)."""
    from stackik.analysis.workspace import nonoptimal_poses

    found = nonoptimal_poses(stack, target, k, seed=seed, executor=executor, **kw)
    if len(found) < k:
        raise ValueError(f"found only {len(found)} of {k} non-optimised poses of the target")
    return found


def run(args: argparse.Namespace) -> int:
    """Run ``stackik mc``; exit code 1 if the least-FN pose is not found."""
    stack = load_stack(args.n, args.geometry)
    target = planar_target(args)
    for name in ("sigma_t", "sigma_theta"):
        v = getattr(args, name)
        if not (math.isfinite(v) and v >= 0):
            raise CLIError(f"--{name.replace('_', '-')}: must be finite and >= 0, got {v}")
    qp = resolve_qp(args.method, args.qp_solver)
    from stackik.analysis.linear import f_factor, linear_covariance
    from stackik.analysis.montecarlo import monte_carlo
    from stackik.solve import solve_ik

    if args.nonopt < 0:
        raise CLIError(f"--nonopt: expected an integer >= 0, got {args.nonopt}")
    with executor_from_args(args) as executor:
        say_where(executor, args.quiet)
        bar = progress(None, 3, "mc", args.quiet)
        bar.set_postfix_str("least-FN pose")
        opt = solve_ik(stack, target, method=args.method, qp_solver=qp, starts=args.starts)
        if not opt.success:
            bar.close()
            print(f"{PROG}: no feasible least-FN pose: {opt.message}", file=sys.stderr)
            return EXIT_INFEASIBLE
        bar.update()
        bar.set_postfix_str("non-optimised poses")
        seed = DEFAULT_SEED if args.seed is None else args.seed
        others = _nonoptimal(
            stack, target, args.nonopt, seed + 1, executor, method=args.method, qp_solver=qp
        )
        bar.update()
        bar.set_postfix_str(f"{args.samples} samples")
        results = [opt, *others]
        mc = monte_carlo(
            [r.q for r in results],
            args.samples,
            args.sigma_t,
            args.sigma_theta,
            rng=seed + 10,
            executor=executor,
        )
        bar.update()
        bar.close()
    labels = ["optimal"] + [f"non-opt {i + 1}" for i in range(args.nonopt)]
    rows = []
    for label, res, pm in zip(labels, results, mc.poses):
        C_est = linear_covariance(res.q, args.sigma_t, args.sigma_theta)
        rows.append(
            {
                "pose": label,
                "q": res.q.tolist(),
                "frobenius_norm": res.frobenius_norm,
                "median_mm": pm.median,
                "interval_mm": list(pm.interval),
                "f_factor": f_factor(C_est, pm.covariance),
            }
        )
    data = {
        "target": {"rho": target.rho, "z": target.z, "theta": target.theta},
        "phi": target.phi,
        "n_samples": args.samples,
        "sigma_t": args.sigma_t,
        "sigma_theta": args.sigma_theta,
        "seed": seed,
        "poses": rows,
        "geometry": stack.to_dict(),
    }
    written: list[Path] = []
    if args.out is not None:
        out: Path = args.out
        out.mkdir(parents=True, exist_ok=True)
        (out / "mc.json").write_text(json.dumps(data, indent=2, default=json_default) + "\n")
        written.append(out / "mc.json")

        def draw(figures: Any) -> None:
            figures.plot_pose_diagram(
                stack, [r.q for r in results], target.phi, labels, path=out / "poses.png"
            )
            figures.plot_perturbation_clouds(mc, labels, path=out / "clouds.png")

        if draw_figures(draw):
            written += [out / "poses.png", out / "clouds.png"]
    if args.json:
        dump_json(data)
        return EXIT_OK
    print(
        f"Monte Carlo (Algorithm 1): {args.samples} common-noise samples, "
        f"sigma_t = {args.sigma_t} mm, sigma_theta = {args.sigma_theta} rad, seed {seed}"
    )
    print(f"target rho = {target.rho} mm, z = {target.z} mm, theta = {target.theta} rad")
    print(f"{'pose':<10} {'FN':>9} {'median[mm]':>11} {'95% interval [mm]':>20} {'F':>7}")
    for r in rows:
        lo, hi = r["interval_mm"]
        print(
            f"{r['pose']:<10} {r['frobenius_norm']:>9.2f} {r['median_mm']:>11.3f} "
            f"{'[' + f'{lo:.2f}, {hi:.2f}' + ']':>20} {r['f_factor']:>7.1%}"
        )
    for path in written:
        print(f"wrote {path}")
    return EXIT_OK
