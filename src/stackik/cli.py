"""Command line of stackik: ``stackik`` (or ``python -m stackik``).

Subcommands
-----------
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

Exit codes: 0 success; 1 no feasible solution; 2 bad input (one line on stderr, starting
with ``stackik: error:``). Heavy modules (numpy, scipy, the solvers) are imported only when
a subcommand runs.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

if TYPE_CHECKING:
    from stackik.geometry import Stack
    from stackik.ik import IKResult, PlanarTarget, SpatialTarget

__all__ = ["main"]

PROG = "stackik"
EXIT_OK = 0
EXIT_INFEASIBLE = 1
EXIT_USAGE = 2
#: Base seed of the analysis commands (same as ``stackik.analysis.reproduce.DEFAULT_SEED``,
#: so ``stackik mc`` on a paper target repeats the numbers of ``stackik reproduce``).
DEFAULT_SEED = 2024
#: The paper's three planar test targets (rho [mm], z [mm], theta [rad]), phi = 0.
PAPER_TARGETS: tuple[tuple[float, float, float], ...] = (
    (600.0, 1000.0, -1.57),
    (145.0, 1500.0, -0.207),
    (-319.0, 1532.0, 0.332),
)


class CLIError(Exception):
    """Bad input detected by the command line itself (reported as exit code 2)."""


class _Parser(argparse.ArgumentParser):
    """ArgumentParser that reports a usage error as one line: ``stackik: error: ...``."""

    def error(self, message: str) -> NoReturn:
        sub = self.prog.removeprefix(PROG).strip()
        hint = f" (see `{PROG} {sub + ' ' if sub else ''}--help`)"
        self.exit(EXIT_USAGE, f"{PROG}: error: {message}{hint}\n")


# =========================================================================================
# Shared helpers
# =========================================================================================
def _finite_float(text: str) -> float:
    """argparse type: a float (NaN/inf are accepted here and rejected with a clear message
    by the target constructors, which name the offending field)."""
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {value}")
    return value


def _add_stack_args(p: argparse.ArgumentParser, n_help: str = "number of platforms") -> None:
    p.add_argument(
        "--n",
        type=int,
        default=None,
        metavar="N",
        help=f"{n_help} (default 4, or the number in --geometry)",
    )
    p.add_argument(
        "--geometry",
        type=Path,
        default=None,
        metavar="FILE",
        help="stack geometry file (.toml or .json; default: the reference geometry, "
        "r = 150 mm, legs 250-450 mm, joints >= 20 deg)",
    )


def _load_stack(n: int | None, geometry: Path | None) -> Stack:
    from stackik.geometry import Stack

    if geometry is None:
        if n is not None and n < 1:
            raise CLIError(f"--n: the number of platforms must be >= 1, got {n}")
        return Stack.reference(4 if n is None else n)
    stack = Stack.from_file(geometry)
    if n is not None and n != stack.n:
        raise CLIError(f"--n {n} disagrees with {geometry} ({stack.n} platforms)")
    return stack


def _add_planar_target_args(p: argparse.ArgumentParser, required: bool = True) -> None:
    p.add_argument(
        "--target",
        nargs=3,
        type=_finite_float,
        metavar=("RHO", "Z", "THETA"),
        required=required,
        help="end-effector target: rho [mm], z [mm], theta [rad] (rho may be negative)",
    )
    g = p.add_mutually_exclusive_group()
    g.add_argument("--phi", type=_finite_float, default=None, help="plane azimuth [rad] (0)")
    g.add_argument("--phi-deg", type=_finite_float, default=None, help="plane azimuth [deg]")


def _phi(args: argparse.Namespace) -> float:
    if args.phi_deg is not None:
        return math.radians(args.phi_deg)
    return 0.0 if args.phi is None else float(args.phi)


def _planar_target(args: argparse.Namespace) -> PlanarTarget:
    from stackik.ik import PlanarTarget

    rho, z, theta = args.target
    return PlanarTarget(rho, z, theta, _phi(args))


def _resolve_qp(method: str, qp_solver: str | None) -> str | None:
    """The QP backend to request (validated), or None (scipy, ip, or auto's own choice)."""
    if method not in ("sqp", "auto"):
        if qp_solver is not None:
            raise CLIError(f"--qp-solver applies to --method sqp only (got --method {method})")
        return None
    from stackik.sqp.qp import default_qp_solver, make_backend

    if qp_solver is None:
        return None if method == "auto" else default_qp_solver()
    make_backend(qp_solver)  # ValueError listing the available ones
    return qp_solver


def _progress(iterable: Any, total: int | None, desc: str, quiet: bool) -> Any:
    """tqdm progress bar on stderr (shown only on a terminal and unless ``--quiet``)."""
    from tqdm.auto import tqdm

    return tqdm(iterable, total=total, desc=desc, disable=True if quiet else None, leave=False)


def _figures(draw: Callable[[Any], Any]) -> bool:
    """Draw figures with :mod:`stackik.analysis.figures`; False (with a note) without
    matplotlib (the ``[plot]`` extra)."""
    try:
        from stackik.analysis import figures

        draw(figures)
    except ImportError as exc:
        print(f"{PROG}: note: figures skipped ({exc}); install stackik[plot]", file=sys.stderr)
        return False
    return True


def _json_default(obj: Any) -> Any:
    from stackik._io import json_default

    return json_default(obj)


def _dump_json(data: Any) -> None:
    print(json.dumps(data, indent=2, default=_json_default, allow_nan=True))


# =========================================================================================
# solve
# =========================================================================================
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


def format_result(stack: Stack, result: IKResult) -> str:
    """Human-readable table of an :class:`~stackik.IKResult` (pose, legs, margins, summary)."""
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
    lines.append("")
    width = 16
    summary: list[tuple[str, str]] = [
        ("success", str(result.success)),
        ("status", f"{result.status.value}: {result.message}"),
        ("frobenius norm", f"{result.frobenius_norm:.6g}"),
        ("objective", f"{result.objective} = {result.objective_value:.6g}"),
        ("max violation", f"{result.max_violation:.3g} (raw: mm^2 leg blocks, mm joint blocks)"),
        ("target error", f"{result.target_error:.3g} mm, {result.angle_error:.3g} rad"),
        ("time", f"{result.time:.3f} s ({result.nit} iterations, {result.n_starts} start(s))"),
        (
            "method",
            result.method
            if result.qp_solver == "-"
            else f"{result.method} (QP: {result.qp_solver})",
        ),
    ]
    if result.phi is not None:
        summary.insert(4, ("phi", f"{result.phi:.6g} rad"))
    for key, value in summary:
        lines.append(f"{key:<{width}}{value}")
    return "\n".join(lines)


def _solve_target(args: argparse.Namespace) -> PlanarTarget | SpatialTarget:
    if args.spatial:
        if args.target is not None:
            raise CLIError("--target is planar; with --spatial give --position X Y Z")
        if args.position is None:
            raise CLIError("--spatial needs --position X Y Z [--euler YAW PITCH ROLL]")
        if args.phi is not None or args.phi_deg is not None:
            raise CLIError("--phi applies to planar targets only")
        from stackik.ik import SpatialTarget
        from stackik.rotations import euler_zyx

        euler = args.euler if args.euler is not None else (0.0, 0.0, 0.0)
        for name, v in zip(("yaw", "pitch", "roll"), euler):
            if not math.isfinite(v):
                raise CLIError(f"--euler {name}: must be finite, got {v}")
        return SpatialTarget(args.position, euler_zyx(euler))
    if args.position is not None or args.euler is not None:
        raise CLIError("--position/--euler need --spatial")
    if args.target is None:
        raise CLIError("the following arguments are required: --target RHO Z THETA")
    return _planar_target(args)


def _cmd_solve(args: argparse.Namespace) -> int:
    stack = _load_stack(args.n, args.geometry)
    target = _solve_target(args)
    if args.objective != "weighted" and (args.sigma_t is not None or args.sigma_theta is not None):
        raise CLIError("--sigma-t/--sigma-theta apply to --objective weighted only")
    qp = _resolve_qp(args.method, args.qp_solver)
    from stackik.ik import solve_ik

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
        **kwargs,
    )
    if args.json:
        data = result.to_dict()
        data["qp_solver"] = qp if qp is not None else "-"
        data["n"] = stack.n
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
        _dump_json(data)
    else:
        src = str(args.geometry) if args.geometry else "reference geometry"
        print(f"stack: {stack.n} platforms ({src})")
        print(format_result(stack, result))
    return EXIT_OK if result.success else EXIT_INFEASIBLE


# =========================================================================================
# mc
# =========================================================================================
def _nonoptimal(stack: Stack, target: PlanarTarget, k: int, seed: int, **kw: Any) -> list[IKResult]:
    """``k`` non-optimised feasible poses (:func:`stackik.analysis.workspace.nonoptimal_poses`)."""
    from stackik.analysis.workspace import nonoptimal_poses

    found = nonoptimal_poses(stack, target, k, seed=seed, **kw)
    if len(found) < k:
        raise ValueError(f"found only {len(found)} of {k} non-optimised poses of the target")
    return found


def _cmd_mc(args: argparse.Namespace) -> int:
    stack = _load_stack(args.n, args.geometry)
    target = _planar_target(args)
    for name in ("sigma_t", "sigma_theta"):
        v = getattr(args, name)
        if not (math.isfinite(v) and v >= 0):
            raise CLIError(f"--{name.replace('_', '-')}: must be finite and >= 0, got {v}")
    qp = _resolve_qp(args.method, args.qp_solver)
    from stackik.analysis import f_factor, linear_covariance, monte_carlo
    from stackik.ik import solve_ik

    if args.nonopt < 0:
        raise CLIError(f"--nonopt: expected an integer >= 0, got {args.nonopt}")
    bar = _progress(None, 3, "mc", args.quiet)
    bar.set_postfix_str("least-FN pose")
    opt = solve_ik(stack, target, method=args.method, qp_solver=qp, starts=args.starts)
    if not opt.success:
        bar.close()
        print(f"{PROG}: no feasible least-FN pose: {opt.message}", file=sys.stderr)
        return EXIT_INFEASIBLE
    bar.update()
    bar.set_postfix_str("non-optimised poses")
    seed = DEFAULT_SEED if args.seed is None else args.seed
    others = _nonoptimal(stack, target, args.nonopt, seed + 1, method=args.method, qp_solver=qp)
    bar.update()
    bar.set_postfix_str(f"{args.samples} samples")
    results = [opt, *others]
    mc = monte_carlo(
        [r.q for r in results], args.samples, args.sigma_t, args.sigma_theta, rng=seed + 10
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
        (out / "mc.json").write_text(json.dumps(data, indent=2, default=_json_default) + "\n")
        written.append(out / "mc.json")

        def draw(figures: Any) -> None:
            figures.plot_pose_diagram(
                stack, [r.q for r in results], target.phi, labels, path=out / "poses.png"
            )
            figures.plot_perturbation_clouds(mc, labels, path=out / "clouds.png")

        if _figures(draw):
            written += [out / "poses.png", out / "clouds.png"]
    if args.json:
        _dump_json(data)
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


# =========================================================================================
# Subcommands provided by other modules (imported lazily)
# =========================================================================================
class _NotAvailableError(Exception):
    pass


def _lookup(module: str, names: Sequence[str]) -> Callable[..., Any]:
    """First attribute of ``module`` among ``names``; _NotAvailableError if none or no module."""
    import importlib

    try:
        mod = importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name is not None and (module == exc.name or module.startswith(exc.name + ".")):
            raise _NotAvailableError(f"{module} is not available yet") from None
        raise
    for name in names:
        fn = getattr(mod, name, None)
        if callable(fn):
            return fn  # type: ignore[no-any-return]
    raise _NotAvailableError(f"{module} has no {' / '.join(names)} entry point yet")


def _call_entry(module: str, names: Sequence[str], argv: list[str], what: str) -> int:
    try:
        fn = _lookup(module, names)
    except _NotAvailableError as exc:
        print(f"{PROG}: error: `{PROG} {what}` is not available yet ({exc})", file=sys.stderr)
        return EXIT_USAGE
    rc = fn(argv)
    return int(rc) if rc is not None else EXIT_OK


def _cmd_reproduce(args: argparse.Namespace) -> int:
    if args.workers < 1:
        raise CLIError(f"--workers: expected an integer >= 1, got {args.workers}")
    try:
        fn = _lookup("stackik.analysis.reproduce", ("main_reproduce",))
    except _NotAvailableError as exc:
        print(f"{PROG}: error: `{PROG} reproduce` is not available yet ({exc})", file=sys.stderr)
        return EXIT_USAGE
    rc = fn(
        args.out,
        quick=args.quick,
        progress=not args.quiet,
        seed=DEFAULT_SEED if args.seed is None else args.seed,
        workers=args.workers,
        strict=args.strict,
    )
    return int(rc) if rc is not None else EXIT_OK


def _cmd_map(args: argparse.Namespace) -> int:
    stack = _load_stack(args.n, args.geometry)
    phi = _phi(args)
    if args.targets < 3:
        raise CLIError(f"--targets: expected at least 3, got {args.targets}")
    try:
        study_fn = _lookup("stackik.analysis.workspace", ("workspace_study",))
    except _NotAvailableError as exc:
        print(f"{PROG}: error: `{PROG} map` is not available yet ({exc})", file=sys.stderr)
        return EXIT_USAGE
    qp = _resolve_qp(args.method, args.qp_solver)
    seed = DEFAULT_SEED if args.seed is None else args.seed
    study = study_fn(
        stack,
        args.targets,
        n_samples=args.samples,
        sigma_t=args.sigma_t,
        sigma_theta=args.sigma_theta,
        seed=seed,
        phi=phi,
        progress=not args.quiet,
        solve_kwargs={"method": args.method, "qp_solver": qp},
        checkpoint_dir=None if args.out is None else args.out / "checkpoint",
    )
    rows = study.rows()
    reg = study.regression
    written: list[Path] = []
    if args.out is not None:
        from stackik._io import write_csv

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

        if _figures(draw):
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
        _dump_json({**summary, "rows": rows, "geometry": stack.to_dict()})
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


def _cmd_bench(args: argparse.Namespace) -> int:
    return _call_entry("stackik.bench", ("main",), list(args.args), "bench")


# =========================================================================================
# geometry
# =========================================================================================
def describe_stack(stack: Stack) -> str:
    """Human-readable description of a stack geometry."""
    import numpy as np

    lines = [f"stack of {stack.n} platform(s), bottom first; lengths in mm, angles in deg"]
    for i, g in enumerate(stack):
        if i > 0 and g == stack[i - 1]:
            lines.append(f"platform {i + 1}: same as platform {i}")
            continue
        lines.append(
            f"platform {i + 1}: legs {g.leg_min:g}-{g.leg_max:g} mm, "
            f"joint_min {math.degrees(g.joint_min):.4g} deg"
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


def _cmd_geometry(args: argparse.Namespace) -> int:
    from stackik.geometry import Stack

    if args.action == "show":
        stack = _load_stack(args.n, args.geometry)
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


# =========================================================================================
# Parser and entry point
# =========================================================================================
def build_parser() -> argparse.ArgumentParser:
    """The ``stackik`` argument parser."""
    from stackik import __version__

    parser = _Parser(
        prog=PROG,
        description="Inverse kinematics of stacks of Stewart platforms with the least "
        "end-effector sensitivity (minimum Frobenius norm of the Jacobian). "
        "Millimetres and radians.",
        epilog="Exit codes: 0 success, 1 no feasible solution, 2 bad input.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    # --- solve ---
    p = sub.add_parser(
        "solve",
        help="solve the inverse kinematics of one target",
        description="Solve the inverse kinematics of one end-effector target and print the "
        "pose, leg lengths and margins to every limit.",
    )
    _add_stack_args(p)
    _add_planar_target_args(p, required=False)
    p.add_argument(
        "--spatial",
        action="store_true",
        help="spatial mode (6 variables per platform): give --position and --euler",
    )
    p.add_argument("--position", nargs=3, type=_finite_float, metavar=("X", "Y", "Z"))
    p.add_argument(
        "--euler",
        nargs=3,
        type=_finite_float,
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
    _add_method_args(p)
    p.add_argument("--starts", type=_positive_int, default=1, metavar="K", help="starts (1)")
    p.add_argument("--seed", type=int, default=None, metavar="S", help="seed of extra starts")
    p.add_argument(
        "--start",
        choices=("paper", "convex"),
        default="paper",
        help="first start: the paper's initial guess or the convex (SOCP) restriction",
    )
    p.add_argument("--max-time", type=float, default=None, metavar="SEC", help="time budget")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=_cmd_solve)

    # --- mc ---
    p = sub.add_parser(
        "mc",
        help="Monte Carlo sensitivity: least-FN pose vs non-optimised poses",
        description="Paper Algorithm 1: perturb the least-FN pose and NONOPT non-optimised "
        "poses of the same target with the same Gaussian noise and report the median "
        "end-effector displacement, its 95%% interval and the F factor of the linear "
        "estimate J C_x J^T.",
    )
    _add_stack_args(p)
    _add_planar_target_args(p)
    p.add_argument("--samples", type=_positive_int, default=10000, help="samples (10000)")
    p.add_argument("--sigma-t", type=float, default=1.0, help="translation noise [mm] (1)")
    p.add_argument("--sigma-theta", type=float, default=0.005, help="angle noise [rad] (0.005)")
    p.add_argument("--nonopt", type=int, default=2, help="non-optimised poses (2)")
    _add_method_args(p)
    p.add_argument("--starts", type=_positive_int, default=1, metavar="K", help="starts (1)")
    p.add_argument("--seed", type=int, default=None, metavar="S", help=f"seed ({DEFAULT_SEED})")
    p.add_argument(
        "--out", type=Path, default=None, metavar="DIR", help="write mc.json and the figures"
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_mc)

    # --- map ---
    p = sub.add_parser(
        "map",
        help="workspace study: FN ratio of optimal vs non-optimised poses",
        description="Workspace study (paper figures 'ratio' and 'MedianRatio'): on random "
        "reachable targets, compare the least-FN pose with a non-optimised pose (FN ratio, "
        "Monte Carlo median-displacement ratio and their regression).",
    )
    _add_stack_args(p)
    mx = p.add_mutually_exclusive_group()
    mx.add_argument("--phi", type=_finite_float, default=None, help="plane azimuth [rad] (0)")
    mx.add_argument("--phi-deg", type=_finite_float, default=None, help="plane azimuth [deg]")
    p.add_argument("--targets", type=int, default=50, metavar="M", help="random targets (50)")
    p.add_argument("--samples", type=_positive_int, default=2000, help="MC samples (2000)")
    p.add_argument("--sigma-t", type=float, default=1.0, help="translation noise [mm] (1)")
    p.add_argument("--sigma-theta", type=float, default=0.005, help="angle noise [rad] (0.005)")
    _add_method_args(p)
    p.add_argument("--seed", type=int, default=None, metavar="S", help=f"seed ({DEFAULT_SEED})")
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="DIR",
        help="write workspace.csv, regression.json and the figures into DIR; finished "
        "solves are recorded in DIR/checkpoint, so an interrupted run resumes there",
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a summary")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=_cmd_map)

    # --- reproduce ---
    p = sub.add_parser(
        "reproduce",
        help="reproduce the paper's tables and figures (stackik.analysis.reproduce)",
        description="Reproduce the paper's Tables 1-2 and figures into a directory.",
    )
    p.add_argument("--out", type=Path, default=Path("results"), metavar="DIR", help="(results)")
    p.add_argument("--quick", action="store_true", help="fewer samples: a fast smoke run")
    p.add_argument("--seed", type=int, default=None, metavar="S", help=f"seed ({DEFAULT_SEED})")
    p.add_argument("--workers", type=int, default=1, metavar="W", help="processes (1)")
    p.add_argument("--strict", action="store_true", help="exit 1 when a reproduction check fails")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=_cmd_reproduce)

    # --- bench ---
    p = sub.add_parser(
        "bench",
        help="run the benchmarks (stackik.bench)",
        description="Run the solver benchmarks; arguments are passed to stackik.bench.main.",
        add_help=False,
    )
    p.add_argument("args", nargs=argparse.REMAINDER, help="arguments of the benchmarks")
    p.set_defaults(func=_cmd_bench)

    # --- geometry ---
    p = sub.add_parser(
        "geometry",
        help="show, validate or write a stack geometry file",
        description="Stack geometry files (.toml or .json; lengths mm, angles rad).",
    )
    gsub = p.add_subparsers(dest="action", metavar="ACTION", required=True)
    g = gsub.add_parser("show", help="print a geometry (default: the reference geometry)")
    _add_stack_args(g)
    g.add_argument("--format", choices=("text", "toml", "json"), default="text")
    g = gsub.add_parser("validate", help="check a geometry file (exit 0 valid, 2 invalid)")
    g.add_argument("file", type=Path, metavar="FILE")
    g = gsub.add_parser("write", help="write the reference geometry to FILE to start from")
    g.add_argument("file", type=Path, metavar="FILE", help=".toml or .json")
    g.add_argument("--n", type=int, default=None, metavar="N", help="platforms (4)")
    g.add_argument("--force", action="store_true", help="overwrite an existing file")
    p.set_defaults(func=_cmd_geometry)
    return parser


def _add_method_args(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--method",
        choices=("auto", "ip", "sqp", "slsqp", "trust-constr", "ipopt"),
        default="auto",
        help="auto (default): stackik's compiled interior-point solver for planar targets, "
        "its SQP engine otherwise; ip or sqp to choose; a scipy baseline; or IPOPT through "
        "CasADi (planar; needs the [ipopt] extra)",
    )
    p.add_argument(
        "--qp-solver",
        default=None,
        metavar="NAME",
        help="QP backend of --method sqp (with auto: selects sqp): daqp (default when "
        "installed), osqp, clarabel or any qpsolvers name",
    )


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip() or type(exc).__name__
    return " ".join(text.split())


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (0 ok, 1 infeasible, 2 bad input)."""
    tokens = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    try:
        if tokens[:1] == ["bench"]:  # every later token (even --help) belongs to the benchmark
            args = argparse.Namespace(command="bench", args=tokens[1:], func=_cmd_bench)
        else:
            args = parser.parse_args(tokens)
    except SystemExit as exc:  # usage error (already reported on stderr), --help, --version
        return exc.code if isinstance(exc.code, int) else EXIT_USAGE
    try:
        rc: int = args.func(args)
    except (CLIError, ValueError, OSError) as exc:  # GeometryError is a ValueError
        sys.stdout.flush()
        print(f"{PROG}: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except ImportError as exc:  # an optional dependency (e.g. casadi for ipopt) is missing
        name = getattr(exc, "name", None) or _one_line(exc)
        print(
            f"{PROG}: error: missing optional dependency {name} ({_one_line(exc)})", file=sys.stderr
        )
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    return rc
