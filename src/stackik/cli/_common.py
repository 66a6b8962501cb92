"""Shared pieces of the command line: exit codes, the parser class, argument helpers
(stack, geometry, target and method options), output writing and lazy entry points.

Nothing heavy is imported at module level: numpy, scipy and the solvers are imported
inside the helpers, when a subcommand runs.
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
    from stackik.targets import PlanarTarget

__all__ = [
    "DEFAULT_SEED",
    "EXIT_INFEASIBLE",
    "EXIT_OK",
    "EXIT_USAGE",
    "PROG",
    "CLIError",
    "NotAvailableError",
    "Parser",
    "add_clearance_arguments",
    "add_method_args",
    "add_phi_args",
    "add_planar_target_args",
    "add_scale_args",
    "add_stack_args",
    "add_starts_arg",
    "call_entry",
    "clearance_of",
    "check_scale_args",
    "draw_figures",
    "dump_json",
    "executor_from_args",
    "finite_float",
    "json_default",
    "load_stack",
    "lookup",
    "not_available",
    "one_line",
    "phi_of",
    "planar_target",
    "positive_int",
    "progress",
    "resolve_qp",
    "say_where",
]

PROG = "stackik"
EXIT_OK = 0
EXIT_INFEASIBLE = 1
EXIT_USAGE = 2
#: Base seed of the analysis commands (same as ``stackik.analysis.reproduce.DEFAULT_SEED``,
#: so ``stackik mc`` on a paper target repeats the numbers of ``stackik reproduce``).
DEFAULT_SEED = 2024


class CLIError(Exception):
    """Bad input detected by the command line itself (reported as exit code 2)."""


class Parser(argparse.ArgumentParser):
    """ArgumentParser that reports a usage error as one line: ``stackik: error: ...``.

    Subparsers inherit the class, so every subcommand reports errors the same way.
    """

    def error(self, message: str) -> NoReturn:
        sub = self.prog.removeprefix(PROG).strip()
        hint = f" (see `{PROG} {sub + ' ' if sub else ''}--help`)"
        self.exit(EXIT_USAGE, f"{PROG}: error: {message}{hint}\n")


def one_line(exc: BaseException) -> str:
    """The message of ``exc`` on one line (its type name if it has none)."""
    text = str(exc).strip() or type(exc).__name__
    return " ".join(text.split())


# =========================================================================================
# Argument types and option groups
# =========================================================================================
def finite_float(text: str) -> float:
    """argparse type: a float (NaN/inf are accepted here and rejected with a clear message
    by the target constructors, which name the offending field)."""
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {value}")
    return value


def add_stack_args(p: argparse.ArgumentParser, n_help: str = "number of platforms") -> None:
    """``--n N`` and ``--geometry FILE`` (read back with :func:`load_stack`)."""
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


def load_stack(n: int | None, geometry: Path | None) -> Stack:
    """The stack of ``--n`` / ``--geometry``: the file's, or the reference geometry."""
    from stackik.geometry import Stack

    if geometry is None:
        if n is not None and n < 1:
            raise CLIError(f"--n: the number of platforms must be >= 1, got {n}")
        return Stack.reference(4 if n is None else n)
    stack = Stack.from_file(geometry)
    if n is not None and n != stack.n:
        raise CLIError(f"--n {n} disagrees with {geometry} ({stack.n} platforms)")
    return stack


def add_phi_args(p: argparse.ArgumentParser) -> None:
    """``--phi RAD`` or ``--phi-deg DEG`` (mutually exclusive; read with :func:`phi_of`)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--phi", type=finite_float, default=None, help="plane azimuth [rad] (0)")
    g.add_argument("--phi-deg", type=finite_float, default=None, help="plane azimuth [deg]")


def add_planar_target_args(p: argparse.ArgumentParser, required: bool = True) -> None:
    """``--target RHO Z THETA`` and the plane azimuth (read with :func:`planar_target`)."""
    p.add_argument(
        "--target",
        nargs=3,
        type=finite_float,
        metavar=("RHO", "Z", "THETA"),
        required=required,
        help="end-effector target: rho [mm], z [mm], theta [rad] (rho may be negative)",
    )
    add_phi_args(p)


def phi_of(args: argparse.Namespace) -> float:
    """The plane azimuth [rad] of ``--phi`` / ``--phi-deg`` (default 0)."""
    if args.phi_deg is not None:
        return math.radians(args.phi_deg)
    return 0.0 if args.phi is None else float(args.phi)


def planar_target(args: argparse.Namespace) -> PlanarTarget:
    """The :class:`~stackik.targets.PlanarTarget` of ``--target`` and ``--phi``."""
    from stackik.targets import PlanarTarget

    rho, z, theta = args.target
    return PlanarTarget(rho, z, theta, phi_of(args))


def add_method_args(p: argparse.ArgumentParser) -> None:
    """``--method`` (choices: the method registry, ``stackik.solve.METHOD_NAMES``) and
    ``--qp-solver``. The help states the rule of :func:`stackik.solve.policy.auto_method`
    (tests/test_cli.py holds the two together)."""
    from stackik.solve import METHOD_NAMES

    p.add_argument(
        "--method",
        choices=METHOD_NAMES,
        default="auto",
        help="auto (default): ip, stackik's compiled interior point, for planar and spatial "
        "targets with --objective frobenius or weighted (planar: one sigma-theta for all "
        "platforms); sqp, its SQP engine, for --objective feasible or when --qp-solver is "
        "given (and when no interior-point start passes the check); ip or sqp to choose; "
        "slsqp or trust-constr, the scipy baselines; ipopt, IPOPT through CasADi (planar "
        "and spatial; needs the [ipopt] extra)",
    )
    p.add_argument(
        "--qp-solver",
        default=None,
        metavar="NAME",
        help="QP backend of --method sqp (with auto: selects sqp): daqp (default when "
        "installed), osqp, clarabel or any qpsolvers name",
    )


def add_starts_arg(p: argparse.ArgumentParser) -> None:
    """``--starts K``, default None: the default of :func:`stackik.solve_ik` (one default
    for the library and the command line)."""
    p.add_argument(
        "--starts",
        type=positive_int,
        default=None,
        metavar="K",
        help="number of starts (default: solve_ik's: planar, the paper's guess and two "
        "folded variants, plus fold patterns of the top platforms from n = 5; spatial, "
        "the interior point's structured starts and hops); K takes the first K structured "
        "starts and fills up with random ones (--seed)",
    )


def add_scale_args(p: argparse.ArgumentParser) -> None:
    """``--workers K`` and ``--scheduler ADDRESS`` (read with :func:`executor_from_args`)."""
    p.add_argument(
        "--workers",
        type=positive_int,
        default=None,
        metavar="K",
        help="spread the work over K local processes (default: this process only)",
    )
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="spread the work over a Dask cluster: the address of a running scheduler "
        "(tcp://host:8786), or local:K to start a local cluster of K worker processes "
        "(needs the [dask] extra)",
    )


def check_scale_args(args: argparse.Namespace) -> None:
    """Validate ``--workers`` / ``--scheduler`` (CLIError, also for a missing Dask)."""
    scheduler, workers = args.scheduler, args.workers
    if scheduler is None:
        return
    from stackik.distributed import parse_scheduler

    try:
        parse_scheduler(scheduler)
    except ValueError as exc:
        raise CLIError(f"--scheduler: {exc}") from None
    if workers is not None and scheduler.strip() != "local":
        raise CLIError("--workers goes with local processes or `--scheduler local` only")
    try:
        import distributed  # noqa: F401 - only to report a missing extra early
    except ImportError:
        raise CLIError("--scheduler needs Dask: pip install 'stackik[dask]'") from None


def executor_from_args(args: argparse.Namespace) -> Any:
    """Context manager yielding the executor of ``--workers`` / ``--scheduler`` (None:
    serial), from :func:`stackik.distributed.connect`; bad values raise CLIError."""
    check_scale_args(args)
    from stackik.distributed import connect

    return connect(args.scheduler, args.workers, kinds=("planar",))  # planar commands


def say_where(executor: Any, quiet: bool) -> None:
    """One line on stderr about where the work runs (nothing when serial or quiet)."""
    if executor is None or quiet:
        return
    from stackik.distributed import describe

    print(f"{PROG}: running on {describe(executor)}", file=sys.stderr, flush=True)


def resolve_qp(method: str, qp_solver: str | None) -> str | None:
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


# =========================================================================================
# Output
# =========================================================================================
def progress(iterable: Any, total: int | None, desc: str, quiet: bool) -> Any:
    """tqdm progress bar on stderr (shown only on a terminal and unless ``--quiet``)."""
    from tqdm.auto import tqdm

    return tqdm(iterable, total=total, desc=desc, disable=True if quiet else None, leave=False)


def draw_figures(draw: Callable[[Any], Any]) -> bool:
    """Draw figures with :mod:`stackik.analysis.figures`; False (with a note) without
    matplotlib (the ``[plot]`` extra)."""
    try:
        from stackik.analysis import figures

        draw(figures)
    except ImportError as exc:
        print(f"{PROG}: note: figures skipped ({exc}); install stackik[plot]", file=sys.stderr)
        return False
    return True


def json_default(obj: Any) -> Any:
    """``json.dumps(default=...)`` for numpy values and arrays (:mod:`stackik._io`)."""
    from stackik._io import json_default as default

    return default(obj)


def dump_json(data: Any) -> None:
    """Print ``data`` as indented JSON on stdout."""
    print(json.dumps(data, indent=2, default=json_default, allow_nan=True))


# =========================================================================================
# Entry points provided by other modules (imported lazily)
# =========================================================================================
class NotAvailableError(Exception):
    """The module or entry point a subcommand delegates to does not exist (yet)."""


def lookup(module: str, names: Sequence[str]) -> Callable[..., Any]:
    """First attribute of ``module`` among ``names``; NotAvailableError if none or no module."""
    import importlib

    try:
        mod = importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name is not None and (module == exc.name or module.startswith(exc.name + ".")):
            raise NotAvailableError(f"{module} is not available yet") from None
        raise
    for name in names:
        fn = getattr(mod, name, None)
        if callable(fn):
            return fn  # type: ignore[no-any-return]
    raise NotAvailableError(f"{module} has no {' / '.join(names)} entry point yet")


def not_available(what: str, exc: NotAvailableError) -> int:
    """Report that ``stackik WHAT`` cannot run; returns the usage exit code."""
    print(f"{PROG}: error: `{PROG} {what}` is not available yet ({exc})", file=sys.stderr)
    return EXIT_USAGE


def call_entry(module: str, names: Sequence[str], argv: list[str], what: str) -> int:
    """Call ``module.<first of names>(argv)`` and return its exit code (None means 0)."""
    try:
        fn = lookup(module, names)
    except NotAvailableError as exc:
        return not_available(what, exc)
    rc = fn(argv)
    return int(rc) if rc is not None else EXIT_OK


def add_load_arguments(p: argparse.ArgumentParser) -> None:
    """The load options (``stackik.Load``): payload, external wrench, frame, gravity."""
    g = p.add_argument_group("load (leg forces; enforced where force_max is finite)")
    g.add_argument("--payload-mass", type=finite_float, default=None, metavar="KG",
                   help="payload [kg] at the end-effector origin")  # fmt: skip
    g.add_argument("--payload-force", nargs=3, type=finite_float, default=None,
                   metavar=("FX", "FY", "FZ"),
                   help="external force on the end effector [N]")  # fmt: skip
    g.add_argument("--payload-moment", nargs=3, type=finite_float, default=None,
                   metavar=("MX", "MY", "MZ"),
                   help="external moment about the end-effector origin [N m]")  # fmt: skip
    g.add_argument("--load-frame", choices=("base", "end_effector"), default="base",
                   help="frame of --payload-force/--payload-moment (base)")  # fmt: skip
    g.add_argument("--gravity", nargs="+", default=None, metavar="G",
                   help="earth, moon, mars, none, or GX GY GZ [m/s^2] in the base frame "
                   "(earth)")  # fmt: skip
    g.add_argument("--force-weight", type=finite_float, default=0.0, metavar="W",
                   help="add W * sum (f / s)^2 to the objective: leg forces f [N] scaled by "
                   "force_max where finite, else 1 N; W >= 0 [mm^2] (0)")  # fmt: skip


def load_of(args: argparse.Namespace) -> Any:
    """The :class:`stackik.Load` of the load options, or None when none is given."""
    given = (args.payload_mass, args.payload_force, args.payload_moment, args.gravity)
    if all(v is None for v in given) and args.load_frame == "base":
        return None
    from stackik.loads import Load

    gravity: Any = "earth"
    if args.gravity is not None:
        if len(args.gravity) == 1:
            gravity = args.gravity[0]
        elif len(args.gravity) == 3:
            try:
                gravity = [finite_float(v) for v in args.gravity]
            except argparse.ArgumentTypeError as exc:
                raise CLIError(f"--gravity: {exc}") from None
        else:
            raise CLIError("--gravity: a preset name or three numbers GX GY GZ [m/s^2]")
    zero: Any = (0.0, 0.0, 0.0)
    try:
        return Load(
            force=args.payload_force or zero,
            moment=args.payload_moment or zero,
            frame=args.load_frame,
            mass=0.0 if args.payload_mass is None else args.payload_mass,
            gravity=gravity,
        )
    except ValueError as exc:
        raise CLIError(f"load: {exc}") from None


def add_clearance_arguments(p: argparse.ArgumentParser) -> None:
    """The clearance options: obstacles and the margin every pair of bodies keeps."""
    g = p.add_argument_group("clearance (legs, plates, obstacles)")
    g.add_argument("--obstacles", type=Path, default=None, metavar="FILE",
                   help="keep-out bodies: a TOML/JSON list (stackik.load_obstacles)")  # fmt: skip
    g.add_argument("--clearance", type=finite_float, default=0.0, metavar="MM",
                   help="margin [mm] every checked pair of bodies keeps (0)")  # fmt: skip


def clearance_of(args: argparse.Namespace) -> dict[str, Any]:
    """``obstacles`` and ``clearance`` keywords of the clearance options."""
    obstacles: Any = ()
    if args.obstacles is not None:
        from stackik.obstacles import load_obstacles

        try:
            obstacles = load_obstacles(args.obstacles)
        except (OSError, ValueError) as exc:
            raise CLIError(f"--obstacles: {exc}") from None
    if args.clearance < 0:
        raise CLIError(f"--clearance: must be >= 0 mm, got {args.clearance}")
    return {"obstacles": obstacles, "clearance": args.clearance}
