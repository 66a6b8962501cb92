"""``method="ip"``: the compiled primal-dual interior point (:mod:`stackik._compiled.barrier`),
planar (:mod:`stackik._compiled.planar`) and spatial (:mod:`stackik._compiled.spatial`, exact second
derivatives in closed form).

This module turns a :class:`~stackik.formulation.Problem` into the arrays the compiled
kernels take, parses the method's options, runs every start of a batch in one compiled
call (or on the solve's threads, :mod:`stackik._threads`) and checks the poses with the
independent check (planar: its compiled twin; spatial: :func:`stackik.check.check_pose`
after the polish of :func:`stackik.formulation.polish`).
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from stackik._arrays import readonly
from stackik._threads import for_problem, map_in_threads
from stackik.families import FamilyError
from stackik.formulation import POLISH_MARGIN, POLISH_REACH, Problem, polish
from stackik.methods.base import FloatArray, Method, Run, RunStatus, run_status
from stackik.result import OptionError

if TYPE_CHECKING:
    from stackik._compiled.planar import PlanarData
    from stackik._compiled.spatial import SpatialData

__all__ = [
    "IP_DEFAULTS",
    "Basins",
    "IPMethod",
    "ip_basins",
    "ip_multi",
    "folds_only",
    "ip_solve",
    "n_dense",
    "problem_arrays",
    "unconstrained_shortfall",
    "warm_up",
]


def spatial_problem_arrays(prob: Any) -> SpatialData:
    """The arrays :func:`stackik._compiled.barrier.ip_loop` needs, named, from a spatial
    :class:`~stackik.formulation.Problem` (every array read-only)."""
    from stackik._compiled.spatial import SpatialData
    from stackik.formulation.clearance import NO_PAIRS
    from stackik.formulation.forces import no_force_rows
    from stackik.formulation.leg_pairs import no_leg_pair_rows
    from stackik.formulation.obstacle_rows import no_obstacle_rows

    st = prob.stack
    tgt = prob.target
    sl = prob.self_legs
    ob = prob.clearance.obstacle_rows
    fr = prob.forces
    lp = prob.clearance.leg_pairs
    return SpatialData(
        readonly(prob.xs),
        readonly(prob.cs),
        readonly(prob.es),
        readonly(tgt.position),
        readonly(tgt.rotation),
        float(prob.fscale),
        float(prob.c0),
        readonly(prob.w_th),
        readonly(st.top_nodes),
        readonly(st.base_nodes),
        readonly(st.leg_min),
        readonly(st.leg_max),
        readonly(st.sin_joint_min),
        prob.objective == "feasible",
        NO_PAIRS if sl is None else sl.pairs,
        readonly(np.zeros(prob.n)) if sl is None else sl.rho,
        readonly(st.leg_max) if sl is None else sl.scale,
        no_obstacle_rows(st) if ob is None else ob.kernel_args,
        0.0 if ob is None else ob.margin,
        float(np.max(st.leg_max)) if ob is None else ob.L,
        no_force_rows(st) if fr is None else fr.kernel_args,
        no_leg_pair_rows(st) if lp is None else lp.kernel_args,
        None if sl is None and not n_dense(prob) else n_dense(prob),  # None: the lean type
        prob.family_token,
    )


def n_dense(prob: Problem) -> int:
    """Number of the dense rows of ``prob`` the compiled interior points carry (obstacle,
    non-adjacent leg-pair, constraint-family and leg-force rows:
    :mod:`stackik._compiled.dense_rows`)."""
    return sum(0 if f is None else int(f.size) for f in prob.dense_families)


def problem_arrays(prob: Any) -> PlanarData:
    """The arrays :func:`stackik._compiled.barrier.ip_loop` needs, named, from a planar
    :class:`~stackik.formulation.Problem`; every array read-only
    (:func:`stackik._arrays.readonly`: one compiled specialisation, whatever the source)."""
    fast = prob.fast
    assert fast is not None
    n = prob.n
    tgt = prob.target
    feasible = prob.objective == "feasible"
    w = float(prob.w_th[0])
    ob = prob.clearance.obstacle_rows
    fr = prob.forces
    lp = prob.clearance.leg_pairs
    from stackik._compiled.planar import PlanarData
    from stackik.formulation.forces import no_force_rows
    from stackik.formulation.leg_pairs import no_leg_pair_rows
    from stackik.formulation.obstacle_rows import no_obstacle_rows

    return PlanarData(
        readonly(prob.xs),
        readonly(prob.cs),
        readonly(prob.es),
        readonly([tgt.rho, tgt.z, tgt.theta]),
        float(prob.fscale),
        float(prob.c0),
        w,
        readonly(fast.tf),
        readonly(fast.tz),
        readonly(fast.bf),
        readonly(fast.bz),
        readonly(fast.ls0),
        readonly(fast.lmin2.reshape(n)),
        readonly(fast.lmax2.reshape(n)),
        readonly(fast.sj.reshape(n)),
        feasible,
        no_obstacle_rows(prob.stack) if ob is None else ob.kernel_args,
        0.0 if ob is None else ob.margin,
        float(np.max(prob.stack.leg_max)) if ob is None else ob.L,
        float(tgt.phi),
        no_force_rows(prob.stack) if fr is None else fr.kernel_args,
        no_leg_pair_rows(prob.stack) if lp is None else lp.kernel_args,
        n_dense(prob) or None,  # None: the lean type (stackik._compiled.core.lean_type)
        prob.family_token,
    )


#: Worst scaled violation up to which a finished run is ranked by its objective alone
#: (:func:`ip_starts`): the runs that converged (to ``constr_tol``, or nearly, before the
#: polish) compete on FN; farther ones rank after them and are not checked.
RANK_VIOLATION = 1e-6

#: Default options of :func:`ip_solve`.
IP_DEFAULTS: dict[str, float] = {
    "tol": 1e-7,
    "constr_tol": 1e-9,
    "mu0": 0.1,
    "max_iter": 300,
    "max_time": math.inf,
}


def _ip_options(options: dict[str, Any] | None) -> dict[str, Any]:
    """The defaults updated by ``options``; unknown keys or bad values raise OptionError."""
    opts: dict[str, Any] = dict(IP_DEFAULTS)
    for key, value in (options or {}).items():
        if key not in IP_DEFAULTS:
            raise OptionError(
                f"options: {key!r} is not an interior-point option; use {sorted(IP_DEFAULTS)}"
            )
        bad = isinstance(value, bool) or not isinstance(value, int | float | np.integer)
        if key == "max_iter":  # a positive integer, as SQPOptions.max_iter
            bad = bad or not isinstance(value, int | np.integer)
        if bad or not (value > 0):
            raise OptionError(f"options: bad value {value!r} for interior-point option {key!r}")
        opts[key] = value
    return opts


def ip_solve(prob: Any, u0: FloatArray, options: dict[str, Any] | None = None) -> tuple[
    FloatArray, int, str
]:  # fmt: skip
    """Run the barrier method (and the polish, planar) on a
    :class:`stackik.formulation.Problem` from one scaled start ``u0``: :func:`ip_multi`
    with one row.

    Returns the scaled point, the iteration count and a status string
    (``"success"``, ``"max_iter"``, ``"stalled"``, ``"nonfinite"``, ``"max_time"``).
    """
    X, statuses, nits, _, _ = ip_multi(prob, np.atleast_2d(u0), options)
    return X[0], int(nits[0]), statuses[0]


def ip_multi(
    prob: Any,
    U0: FloatArray,
    options: dict[str, Any] | None = None,
    mu0: FloatArray | None = None,
) -> tuple[Any, ...]:
    """Run the barrier method from each row of ``U0`` (scaled starts) in one compiled call.

    ``mu0``: initial barrier parameter per start (default ``options["mu0"]`` for all).

    Returns ``(X, statuses, nits, objective values, violations)`` (see
    :func:`stackik._compiled.barrier.ip_multi`); statuses as strings.
    """
    opts = _ip_options(options)
    deadline = time.perf_counter() + float(opts["max_time"])
    U = np.ascontiguousarray(np.atleast_2d(U0), dtype=float)
    mus = np.full(U.shape[0], float(opts["mu0"])) if mu0 is None else np.asarray(mu0, float)
    from stackik._compiled import barrier  # numba: imported when first needed
    from stackik._compiled.core import IP_STATUS

    # the planar runs are polished in the kernel (3 steps); the spatial ones by the caller
    # (Problem's form of the polish)
    P, polish_iters = (
        (problem_arrays(prob), 3) if prob.planar else (spatial_problem_arrays(prob), 0)
    )
    none = np.empty(0)  # no box, no distance term (a path step's extensions)
    stop = deadline if math.isfinite(deadline) else 1e300

    def run(rows: slice) -> tuple[Any, ...]:
        return barrier.ip_multi(  # type: ignore[no-any-return]
            U[rows],
            P,
            float(opts["tol"]),
            float(opts["constr_tol"]),
            np.ascontiguousarray(mus[rows]),
            int(opts["max_iter"]),
            stop,
            polish_iters,
            POLISH_REACH,
            POLISH_MARGIN,
            none,
            none,
            none,
            0.0,
            True,  # the objective values and violations, for ranking
        )

    threads = min(for_problem(U.shape[1]), U.shape[0])
    if threads > 1:
        X, st, nit, obj, viol = _side_by_side(run, U, deadline, threads)
    else:
        X, st, nit, obj, viol, _, _, _ = run(slice(None))
    return X, [IP_STATUS[int(s)] for s in st], nit, obj, viol


def _side_by_side(
    run: Any, U: FloatArray, deadline: float, threads: int
) -> tuple[FloatArray, Any, Any, FloatArray, FloatArray]:
    """The kernel's batch from each row of ``U`` on ``threads`` threads
    (:func:`stackik._threads.map_in_threads`): each start runs alone
    (``run(slice(j, j + 1))``), and the batch's rules across starts are applied here as
    the kernel applies them, so the results are those of one compiled call over every
    start: a start after the first is skipped once ``deadline`` (``time.perf_counter``)
    has passed (decided in the starts' order), and when the first ``GIVE_UP_AFTER`` runs
    all end farther than ``GIVE_UP_VIOLATION`` from feasible, every later start is
    skipped (one already under way is discarded)."""
    from stackik._compiled.core import GIVE_UP_AFTER, GIVE_UP_VIOLATION, IP_SKIPPED

    ns = U.shape[0]
    X = U.copy()
    st = np.full(ns, IP_SKIPPED, dtype=np.int64)
    nit = np.zeros(ns, dtype=np.int64)
    obj = np.full(ns, np.inf)
    viol = np.full(ns, np.inf)
    ran = np.zeros(ns, dtype=bool)
    late = False  # the deadline passed when a start was taken: every later one skips
    lock = threading.Lock()

    def gave_up() -> bool:
        first = slice(0, GIVE_UP_AFTER)
        far = ran[first].all() and viol[first].min() > GIVE_UP_VIOLATION
        return ns > GIVE_UP_AFTER and bool(far)

    def one(j: int) -> None:
        nonlocal late
        with lock:
            late = late or (j > 0 and time.perf_counter() > deadline)
            if late or (j >= GIVE_UP_AFTER and gave_up()):
                return
        out = run(slice(j, j + 1))
        X[j], st[j], nit[j], obj[j], viol[j] = (part[0] for part in out[:5])
        ran[j] = True

    map_in_threads(one, ns, threads)
    if gave_up():
        X[GIVE_UP_AFTER:] = U[GIVE_UP_AFTER:]
        st[GIVE_UP_AFTER:], nit[GIVE_UP_AFTER:] = IP_SKIPPED, 0
        obj[GIVE_UP_AFTER:] = viol[GIVE_UP_AFTER:] = np.inf
    return X, st, nit, obj, viol


@dataclass
class IPBatch:
    """The runs of one compiled call over many starts.

    ``best``: the best run that passes the check (None when none does); ``least``: the
    least-violation run among those checked otherwise; ``nit``: iterations over all
    starts; ``statuses``: the solver's status per start; ``bound``: with rows the compiled
    interior point does not carry (:attr:`Problem.rows_outside_ip`: leg force limits,
    planar self-leg rows), the poses of the runs that ranked before ``best`` (lower
    objective, near feasible) and failed the check only on rows some solver has: starts
    for an engine that enforces them (:func:`stackik.solve.stages.ip_stage`). The obstacle
    rows are in both kernels (dense rows): without rows outside the interior point, a run
    failing on them is no start.
    """

    best: Run | None
    least: Run | None
    nit: int
    statuses: list[RunStatus]
    bound: list[Run] = field(default_factory=list)
    #: the runs that ranked before ``best`` and failed the check on non-adjacent bodies
    #: alone (:func:`folds_only`), lowest objective first, each with its start (raw): the
    #: starts of runs with the rows of the pairs close there
    #: (:func:`stackik.solve.stages.ip_stage`)
    folded: list[tuple[Run, FloatArray]] = field(default_factory=list)


def _run_batch(
    prob: Problem, starts: list[FloatArray], options: dict[str, Any], max_time: float
) -> tuple[Any, ...] | None:
    """:func:`ip_multi` from the raw poses ``starts`` within ``max_time`` [s]: ``(X, texts,
    nits, objs, viols)``, or None when the kernel failed (e.g. a LAPACK failure on absurd
    input: no run); option errors raise."""
    U0 = np.stack([prob.u_of(q) for q in starts])
    opts = {"max_time": max_time, **options}
    try:
        return ip_multi(prob, U0, opts)
    except (OptionError, FamilyError):
        raise
    except Exception:  # noqa: BLE001
        return None


def ip_starts(
    prob: Problem, starts: list[FloatArray], options: dict[str, Any], max_time: float
) -> IPBatch:
    """Interior-point runs from every start in one compiled call; the best that passes
    the independent check (tried in order of objective among the runs within
    :data:`RANK_VIOLATION` of feasibility), or the least-violation run when none passes."""
    from stackik._compiled.check import planar_check
    from stackik.check import pose_ok
    from stackik.clearance import clearances_can_fail

    ran = _run_batch(prob, starts, options, max_time)
    if ran is None:
        return IPBatch(None, None, 0, [])
    X, texts, nits, objs, viols = ran
    statuses = [run_status(t) for t in texts]
    order = sorted(range(len(starts)), key=lambda j: (not viols[j] <= RANK_VIOLATION, objs[j]))
    least: Run | None = None
    bound: list[Run] = []
    folded: list[tuple[Run, FloatArray]] = []
    total = int(np.sum(nits))
    for j in order:
        q = prob.q_of(X[j])
        if prob.planar:
            # the independent re-check (compiled; same values as check_pose, tested)
            chk, P, R, legs = planar_check(prob.stack, prob.target, q)
            cl = prob.clearance
            if chk.ok and (
                prob.forces is not None
                or prob.families is not None
                or clearances_can_fail(
                    prob.stack, cl.obstacles, cl.margin, q, prob.mode.phi(prob.target)
                )
            ):
                # bodies with a size, obstacles, a margin, a force limit or constraint
                # families: the twin checks none of them
                chk = prob.check(q)
            # the objective at the polished point, unscaled (f = objective / fscale)
            obj = objs[j] * prob.fscale
            run = Run(q, int(nits[j]), statuses[j], chk, obj, (P, R, legs), texts[j])
        else:  # polished here, only the runs checked (Problem's rotation-vector form)
            q = prob.q_of(polish(prob, X[j]))
            chk = prob.check(q, screen=True)
            obj = prob.objective_value(q)
            run = Run(q, int(nits[j]), statuses[j], chk, obj, None, texts[j])
        if chk.ok:
            return IPBatch(run, least, total, statuses, bound, folded)
        if folds_only(chk, prob.clearance.margin):
            folded.append((run, starts[j]))
        # a pose that fails only on rows outside the interior point is a start for the
        # engine that has them; a shortfall no engine constrains is not
        clear = unconstrained_shortfall(prob, chk)
        if prob.rows_outside_ip and pose_ok(
            chk.position_error, chk.angle_error, max(chk.max_violation_mm, clear), True
        ):
            bound.append(run)  # at the target within every limit, failing on dense rows
        if least is None or chk.violation_mm < least.check.violation_mm:
            least = run
        if viols[j] > RANK_VIOLATION:  # the rest are farther off: stop checking
            break
    return IPBatch(None, least, total, statuses, bound, folded)


@dataclass
class Basins:
    """The end points of interior-point runs, unchecked (:func:`ip_basins`), one per
    basin, lowest objective first: ``points`` (scaled, as the kernel left them), their
    objective values ``objs`` (unscaled, as :meth:`Problem.objective_value`) and each
    run's iterations and status text ``runs``; ``nit``: iterations over all starts;
    ``statuses``: the solver's status per start."""

    points: list[FloatArray]
    objs: list[float]
    runs: list[tuple[int, str]]
    nit: int
    statuses: list[RunStatus]

    def add(self, u: FloatArray, obj: float, run: tuple[int, str]) -> None:
        """Keep ``u`` in order of objective unless a kept point's objective is within
        :data:`SAME_BASIN_RTOL` of ``obj`` (the same basin)."""
        if any(abs(obj - o) <= SAME_BASIN_RTOL * abs(o) for o in self.objs):
            return
        at = int(np.searchsorted(self.objs, obj, side="right"))
        self.points.insert(at, u)
        self.objs.insert(at, obj)
        self.runs.insert(at, run)

    def merge(self, other: Basins) -> None:
        """``other``'s basins added (:meth:`add`), its iterations and statuses counted."""
        for u, obj, run in zip(other.points, other.objs, other.runs):
            self.add(u, obj, run)
        self.nit += other.nit
        self.statuses += other.statuses

    def pose(self, prob: Problem, i: int) -> FloatArray:
        """Basin ``i``'s point polished (:func:`polish` with the rows of ``prob``), raw."""
        return prob.q_of(polish(prob, self.points[i]))

    def run(self, prob: Problem, i: int, q: FloatArray) -> Run:
        """Basin ``i``'s run at its polished pose ``q`` (:meth:`pose`), checked
        (:meth:`Problem.check`: for :meth:`Problem.without_force_limits`, the request's
        check with its force limits), as :func:`ip_starts` makes a run."""
        nit, text = self.runs[i]
        return Run(q, nit, run_status(text), prob.check(q), prob.objective_value(q), None, text)


#: Two end points whose objectives agree within this (relative) are one basin's minimum.
SAME_BASIN_RTOL = 1e-7


def ip_basins(
    prob: Problem, starts: list[FloatArray], options: dict[str, Any], max_time: float
) -> Basins:
    """Interior-point runs from every start in one compiled call, as starts for
    other runs rather than answers: the end points of the runs within
    :data:`RANK_VIOLATION` of feasibility, one per basin (:class:`Basins`: the lowest of
    those whose objectives agree within :data:`SAME_BASIN_RTOL`). No point is polished or
    checked (:meth:`Basins.pose` and :meth:`Basins.run` do it for one)."""
    ran = _run_batch(prob, starts, options, max_time)
    if ran is None:
        return Basins([], [], [], 0, [])
    X, texts, nits, objs, viols = ran
    out = Basins([], [], [], int(np.sum(nits)), [run_status(t) for t in texts])
    for j in sorted(range(len(starts)), key=lambda j: objs[j]):
        if viols[j] <= RANK_VIOLATION:
            out.add(X[j], float(objs[j]) * prob.fscale, (int(nits[j]), texts[j]))
    return out


def unconstrained_shortfall(prob: Problem, chk: Any) -> float:
    """The clearance shortfall [mm] of ``chk`` that no solver's rows of ``prob`` can
    remove: all of it without obstacle or planar self-leg rows; with them, the kinds
    without rows (adjacent and non-adjacent bodies, self legs when absent, obstacles
    without rows: out of reach) but not those the rows cover (a platform's own legs; the
    legs against every obstacle: their distances include the plates, which have rows
    against half-spaces and spheres only, so a plate's shortfall counts as covered
    there). Only rows
    outside the interior point (:attr:`Problem.rows_outside_ip`) make such a run a
    hand-over start; the obstacle rows count as covered in both modes (the interior point
    has them, and the engine it hands over to too)."""
    cl = prob.clearance
    rows = cl.obstacle_rows is not None or (prob.planar and prob.self_legs is not None)
    if not rows or chk.clearances is None:
        return float(chk.clearance_violation)
    c, m = chk.clearances, cl.margin
    kinds = [c.adjacent_legs, c.non_adjacent]
    if prob.self_legs is None:
        kinds.append(c.self_legs)
    with_rows = set() if cl.obstacle_rows is None else {id(o) for o in cl.obstacle_rows.obstacles}
    kinds += [d for o, d in zip(cl.obstacles, c.obstacles) if id(o) not in with_rows]
    return max([0.0] + [m - d for d in kinds])


def folds_only(chk: Any, margin: float) -> bool:
    """Whether the check ``chk`` fails only on non-adjacent bodies: the pose is at the
    target within every limit (and force limit), clear of obstacles, its platforms' own
    legs and adjacent legs (to ``margin`` [mm]), but two bodies of platforms two or more
    apart come closer than ``margin``. Such a pose is a start for the rows of the close
    leg pairs (:mod:`stackik.formulation.leg_pairs`)."""
    from stackik.check import FEAS_TOL, pose_ok

    c = chk.clearances
    if chk.ok or c is None or not margin - c.non_adjacent > FEAS_TOL:
        return False
    others = max([chk.max_violation_mm, chk.family_violation]
                 + [margin - d for d in (c.self_legs, c.adjacent_legs)]
                 + [margin - d for d in c.obstacles])  # fmt: skip
    return pose_ok(chk.position_error, chk.angle_error, others, True, chk.peak_force_ratio)


class IPMethod(Method):
    """The compiled primal-dual interior point (planar and spatial; all starts in one
    call)."""

    name: ClassVar[str] = "ip"
    modes: ClassVar[frozenset[str]] = frozenset({"planar", "spatial"})
    #: planar: no BLAS; the spatial kernels do use it, and ip_stage applies the limit
    uses_blas: ClassVar[bool] = False

    def supports(self, prob: Problem) -> str | None:
        if prob.objective == "force":
            return 'method "ip" does not take objective="force"; use "auto", "slsqp" or "sqp"'
        if prob.force_weight > 0.0:
            return 'method "ip" does not take force_weight; use "auto", "slsqp" or "sqp"'
        if prob.planar and prob.objective == "weighted" and np.ptp(prob.w_th) != 0:
            return 'method "ip" needs one sigma_theta for all platforms; use "sqp"'
        return None

    def check_options(self, options: dict[str, Any]) -> dict[str, Any]:
        _ip_options(options)
        return dict(options)

    def solve(
        self, prob: Problem, u0: FloatArray, options: dict[str, Any], time_left: float
    ) -> tuple[FloatArray, int, str]:
        return ip_solve(prob, u0, {"max_time": time_left, **options})

    def run_many(
        self, prob: Problem, starts: list[FloatArray], options: dict[str, Any], max_time: float
    ) -> IPBatch:
        """Every start in one compiled call (:func:`ip_starts`)."""
        return ip_starts(prob, starts, options, max_time)


def warm_up() -> float:
    """Compile (or load from numba's cache) the planar kernels; returns seconds.

    The first call on a machine compiles (about 30-60 s); later processes load the cached
    machine code (about 0.3 s). :func:`stackik.solve_ik` does this before its clock
    starts on its first planar interior-point solve.
    """
    from stackik.geometry import Stack
    from stackik.starts import paper_initial_guess
    from stackik.targets import PlanarTarget

    t0 = time.perf_counter()
    stack = Stack.reference(2)
    target = PlanarTarget(0.0, 700.0, 0.0)
    prob = Problem(stack, target, "frobenius", None)
    ip_starts(prob, [paper_initial_guess(stack, target)], {}, math.inf)
    return time.perf_counter() - t0
