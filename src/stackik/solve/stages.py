"""The stages of a solve: the one-call interior-point batch, then local runs one by one.

Each stage returns a :class:`Verdict` (the pose and status the result reports) or, for the
``"auto"`` policy's interior-point batch, a :class:`Handover` to the SQP engine. Selection
is one rule (:meth:`Tally.offer`): the lowest objective among runs that pass the
independent check, else the run with the least violation (as a length).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from stackik._threads import for_problem, map_in_threads
from stackik.check import FEAS_TOL, FORCE_TOL, pose_ok
from stackik.methods import Method, Run, RunStatus, get_method
from stackik.result import IKStatus
from stackik.solve.nearest import (
    NEAREST_MAX_T,
    NEAREST_MESSAGE,
    SPATIAL_NEAREST_MESSAGE,
    stretch_toward,
)
from stackik.solve.policy import (
    ADAPTIVE_N,
    ADAPTIVE_RTOL,
    ADAPTIVE_STANDS,
    CLEAR_BASIN_MAX_ITER,
    CLEAR_COST_RTOL,
    CLEAR_MU0,
    FORCE_COST_RTOL,
    FORCE_METHOD,
    FORCE_MU0,
    FORCE_STARTS,
    RECENTRE_MU0,
    SCREEN_FEAS_MM,
    SCREEN_OPTIONS,
    SHARED_OPTIONS,
    SPATIAL_GIVE_UP,
    SPATIAL_GIVE_UP_MM,
    UNFOLD_MU0,
    UNFOLD_PLATE_ROWS,
    UNFOLD_ROUNDS,
    UNFOLD_SCREEN_MM,
    UNFOLD_STARTS,
    StartPlan,
    compact_hop_rounds,
    confirmed,
    stands,
)
from stackik.solve.request import Request
from stackik.starts import nominal_height, spatial_default_hops

if TYPE_CHECKING:
    from collections.abc import Callable

    from stackik.formulation import Problem
    from stackik.methods.ip import Basins, IPBatch, IPMethod

__all__ = [
    "PLANAR_BLAS_N",
    "Handover",
    "Tally",
    "Verdict",
    "confirmed",
    "ip_stage",
    "local_stage",
    "stands",
]

#: Planar stacks from this size get the solve's BLAS thread limit in the interior point.
PLANAR_BLAS_N = 32

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Verdict:
    """What a solve reports: the pose's run (None: the first start), status, counts."""

    run: Run | None
    status: IKStatus
    nit: int
    n_starts: int
    method: str
    message: str = ""


@dataclass(frozen=True)
class Handover:
    """The interior-point batch found no pose that passes: the SQP engine decides.

    ``quick``: every start stalled (an unreachable target): the SQP engine runs the
    structured starts one at a time until it certifies infeasibility, without screening
    or fallbacks.
    """

    queue: list[FloatArray]
    least: Run | None
    nit: int
    tried: int
    quick: bool
    options: dict[str, object]
    #: leg force limits: the interior point's best passing run (None: none passed), the
    #: engine that enforces them and how many of ``queue`` it runs (None: the plan's)
    best: Run | None = None
    method: str = "sqp"
    n_planned: int | None = None


def _lower(run: Run, best: Run) -> bool:
    """``run``'s objective is below ``best``'s by more than rounding."""
    return _below(run.obj, best.obj)


def _below(obj: float, other: float) -> bool:
    """Objective value ``obj`` is below ``other`` by more than rounding."""
    return obj < other - 1e-12 * abs(other)


@dataclass
class Tally:
    """The runs of a stage so far: best passing, least violating, counts."""

    best: Run | None = None
    least: Run | None = None
    nit: int = 0
    tried: int = 0
    last: RunStatus | None = None
    timed_out: bool = False
    far_off: bool = True
    screened: list[Run] = field(default_factory=list)

    def offer(self, run: Run) -> None:
        """Count ``run`` and keep it if it is the best passing or least violating one."""
        self.nit += run.nit
        self.last = run.status
        self.far_off = self.far_off and run.check.max_violation_mm > SPATIAL_GIVE_UP_MM
        if run.ok:
            if self.best is None or _lower(run, self.best):
                self.best = run
        else:
            self.offer_least(run)

    def offer_least(self, run: Run) -> None:
        if self.least is None or run.check.violation_mm < self.least.check.violation_mm:
            self.least = run

    def failure_status(self) -> IKStatus:
        """The status when no run passed: the last run's word, else infeasible when the
        least violation is above tolerance, else failed."""
        if self.timed_out:
            return IKStatus.MAX_TIME
        if self.last is RunStatus.MAX_ITER:
            return IKStatus.MAX_ITER
        if self.last is RunStatus.MAX_TIME:
            return IKStatus.MAX_TIME
        if self.last is RunStatus.SUCCESS:  # the solver claimed success; the check disagreed
            return IKStatus.FAILED
        if self.least is not None and self.least.check.violation_mm > FEAS_TOL:
            return IKStatus.INFEASIBLE
        return IKStatus.FAILED


def _ip_status(statuses: list[RunStatus]) -> IKStatus:
    if RunStatus.MAX_TIME in statuses:
        return IKStatus.MAX_TIME
    if RunStatus.MAX_ITER in statuses and all(
        s in (RunStatus.MAX_ITER, RunStatus.SKIPPED) for s in statuses
    ):
        return IKStatus.MAX_ITER
    return IKStatus.FAILED


def ip_stage(req: Request, plan: StartPlan) -> Verdict | Handover:
    """Every interior-point start in one compiled call.

    A passing pose ends the solve. Otherwise an explicit ``method="ip"`` reports the
    least-violation pose; ``"auto"`` answers an unreachable target (every start stalled)
    with the bisection's limit-respecting pose (:func:`stretch_toward`), or hands over
    to the SQP engine with the options both engines take. The planar structured default
    from ``n = ADAPTIVE_N`` on runs the batch adaptively (:func:`_adaptive_batch`).
    """
    from stackik.methods.ip import IPMethod, n_dense

    method = req.method
    assert isinstance(method, IPMethod)
    starts = plan.batch(req.sampler, req.structured, req.stack.n)
    if not req.mode.planar or req.stack.n >= PLANAR_BLAS_N or n_dense(req.problem):
        # the spatial kernels call LAPACK/BLAS on (6n)^2 matrices, the planar ones on
        # (3n)^2 from n = 48 on, where OpenBLAS starts threads (CPU 2x wall at n = 48-64),
        # and on the dense rows' normal matrix (:func:`_unfold_batch`)
        req.blas.apply()
    # the runs from the plan's starts and hops, with the plan's iteration limit (the
    # rules' search without their rows is the default's: with it too); hand-overs keep
    # the caller's options
    opts = plan.run_options(req.options)
    run_req = req if opts is req.options else dataclasses.replace(req, options=opts)
    nit0 = tried0 = 0
    found: Run | None = None
    rule = (
        _free_first if _free_first_applies(req, plan)
        else _clear_first if _clear_first_applies(req, plan)
        else None
    )  # fmt: skip
    if rule is not None:
        found, nit0, tried0, settled = rule(run_req, method, starts)
        if settled:
            return Verdict(found, IKStatus.SUCCESS, nit0, tried0, "ip")
        if req.out_of_time():  # no batch past the budget: the best found, or none
            status = IKStatus.SUCCESS if found is not None else IKStatus.MAX_TIME
            return Verdict(found, status, nit0, tried0, "ip")
        # no pose from the basins passes, or the rows cost more FN than the rule's cap
        # (FORCE_COST_RTOL, CLEAR_COST_RTOL): the batch with the rows from the plan's
        # starts too
    first = plan.adaptive_first(req.structured, req.mode.planar, req.stack.n, len(starts))
    if first and not req.problem.rows_outside_ip:
        batch, n_run = _adaptive_batch(req, method, starts, first)
    else:
        left = req.time_left(time.perf_counter())
        batch, n_run = method.run_many(req.problem, starts, opts, left), len(starts)
    batch.nit += nit0  # (the search of _free_first, and its pose)
    n_run += tried0
    if found is not None and (batch.best is None or _lower(found, batch.best)):
        batch.best = found
    if batch.folded:
        _unfold_batch(req, method, batch)
    if batch.bound:
        return _force_handover(req, batch, n_run)
    if batch.best is not None:
        best, nit, tried = batch.best, batch.nit, n_run
        # after the self-leg rule's batch with the rows, no hops: on spatial n = 4 with
        # 12 mm legs (seeds 2900, 3000, 3100) they found a lower pose on 1 of 29 targets
        # (0.07 % FN) and cost a third of such a solve (docs/clearance.md)
        rows_batch = rule is _clear_first and _spatial_self_legs(req)
        if plan.spatial_default and not rows_batch:
            best, nit, tried = _hop(run_req, method, best, nit, tried)
        elif plan.compact:
            best, nit, tried = _compact_hops(req, method, best, nit, tried)
        elif plan.starts == 1 and req.structured and _recentres(req):
            best, nit = _recentre(req, method, best, nit)
        return Verdict(best, IKStatus.SUCCESS, nit, tried, "ip")
    if not req.auto:
        return Verdict(batch.least, _ip_status(batch.statuses), batch.nit, n_run, "ip")
    # with obstacle or force rows in the interior point, stalled runs may mean no clear
    # pose or no pose that carries the load (not an unreachable target): the SQP engine
    # decides, with the rows
    prob = req.problem
    dense = (
        prob.clearance.obstacle_rows is not None
        or prob.forces is not None
        or prob.families is not None
    )
    stalled = not dense and all(s in (RunStatus.STALLED, RunStatus.SKIPPED) for s in batch.statuses)
    queue = plan.queue
    if stalled:
        # the bisection toward the target (spatial: in the vertical plane through its
        # position) gives a pose within every limit stretched toward it; a planar
        # bisection: its kernels load now (off the clock) for a spatial target
        req.load_kernels("planar")
        near, t_near, nit_near, n_near = stretch_toward(
            req.stack, req.target, req.objective, req.weights, req.options,
            req.t_start + req.max_time,
        )  # fmt: skip
        planar = req.mode.planar
        if near is not None and (t_near <= NEAREST_MAX_T or not planar):
            n = n_run + n_near
            nit = batch.nit + nit_near
            message = NEAREST_MESSAGE if planar else SPATIAL_NEAREST_MESSAGE
            return Verdict(near, IKStatus.INFEASIBLE, nit, n, "ip", message)
        if near is not None:  # planar, nearly there: the SQP engine starts from that pose
            queue.insert(0, near.q)
    shared = {key: v for key, v in req.options.items() if key in SHARED_OPTIONS}
    return Handover(queue, batch.least, batch.nit, n_run, stalled, shared)


def _adaptive_batch(
    req: Request, method: IPMethod, starts: list[FloatArray], first: list[int]
) -> tuple[IPBatch, int]:
    """The adaptive plan (:data:`stackik.solve.policy.ADAPTIVE_N`): the starts ``first``
    (indices into ``starts``) each alone, side by side on the solve's threads
    (:mod:`stackik._threads`); when they all pass and agree (:func:`confirmed`), they
    found the same basin and the solve stops with the better of them. Otherwise the
    other starts run ``len(first)`` at a time (those after ``first`` in ``starts``, the
    batch's other random starts, then those before it) until another run confirms the
    best pose found so far, or :data:`~stackik.solve.policy.ADAPTIVE_STANDS` runs after
    the one that found it found nothing lower (:func:`stands`), or every start ran. The
    decision falls after each group of runs, on the runs in their order, so it does not
    depend on which thread finished first. The best pose over all runs is kept
    (merged by :func:`_merge`, the same rule as one call: the lowest objective that
    passes, ties to the earlier run). Returns the merged batch and how many starts ran."""
    prob = req.problem
    later = [j for j in range(len(starts)) if j not in first]
    order = first + sorted(later, key=lambda j: (j < first[0], j))

    parts: list[IPBatch] = []
    ran = 0
    step = len(first)
    while ran < len(order):
        chunk = order[ran : ran + step]

        def alone(k: int, chunk: list[int] = chunk) -> IPBatch:
            left = req.time_left(time.perf_counter())
            return method.run_many(prob, [starts[chunk[k]]], req.options, left)

        # side by side on the solve's threads: the same runs as one after another
        parts += map_in_threads(alone, len(chunk), for_problem(prob.n * prob.k))
        ran += len(chunk)
        runs = [p.best for p in parts]
        if confirmed(runs, ADAPTIVE_RTOL) or stands(runs, ADAPTIVE_RTOL, ADAPTIVE_STANDS):
            break
        if req.out_of_time():
            break
    return _merge(parts), ran


def _merge(parts: list[IPBatch]) -> IPBatch:
    """The batches of consecutive calls as one: the best passing run (the lowest
    objective; ties to the earlier), the least-violation run, iterations, statuses and
    bound runs in order."""
    from stackik.methods.ip import IPBatch

    out = IPBatch(None, None, 0, [])
    for part in parts:
        if part.best is not None and (out.best is None or _lower(part.best, out.best)):
            out.best = part.best
        pl, ol = part.least, out.least
        if pl is not None and (ol is None or pl.check.violation_mm < ol.check.violation_mm):
            out.least = pl
        out.nit += part.nit
        out.statuses += part.statuses
        out.bound += part.bound
        out.folded += part.folded
    out.folded.sort(key=lambda f: f[0].obj)
    return out


def _force_handover(req: Request, batch: IPBatch, tried: int) -> Handover:
    """Leg force limits bind: the interior point (which does not see them) found poses of
    lower objective than its best passing one (if any) that fail the check only on their
    leg forces. The engine that enforces them (:data:`FORCE_METHOD`, with the force rows of
    :mod:`stackik.formulation.forces`) starts from the :data:`FORCE_STARTS` best of those
    (the constrained optimum lies on the force limit next to one of them, as a rule); the
    interior point's passing run competes."""
    queue = [run.q for run in batch.bound[:FORCE_STARTS]]
    shared = {key: v for key, v in req.options.items() if key in SHARED_OPTIONS}
    return Handover(
        queue, batch.least, batch.nit, tried, False, shared,
        best=batch.best, method=FORCE_METHOD, n_planned=len(queue),
    )  # fmt: skip


def _free_first_applies(req: Request, plan: StartPlan) -> bool:
    """The spatial structured default (:attr:`StartPlan.spatial_default`) of a problem with
    leg-force limit rows (a finite ``force_max``) and the FN or weighted objective:
    :func:`_free_first`. Nothing else (unloaded solves, planar ones, explicit ``starts`` or
    ``x0``, the force objective or a force weight) takes it."""
    prob = req.problem
    return (
        plan.spatial_default
        and prob.forces is not None
        and prob.force_residuals is None
        and prob.objective != "feasible"
    )


def _free_first(
    req: Request, method: IPMethod, starts: list[FloatArray]
) -> tuple[Run | None, int, int, bool]:
    """Spatial default with leg-force limits: :func:`_rows_first` without the force rows,
    with the small initial barrier :data:`FORCE_MU0` and the cost cap
    :data:`FORCE_COST_RTOL` (a pose far over a force limit is not checked,
    :func:`_over_limits`).

    Why (docs/loads.md): with the force rows from the plan's starts, the runs' paths bend
    away from the force limits into other basins, and on 3 of 10 spatial n = 4 targets
    none of the eight ended within 0.1 % of the best known, while a run with the force rows
    from the unloaded optimum ended there on all of them; with the default barrier (0.1)
    such a run, which starts over a force limit, is pushed into a neighbouring basin
    (1 of 10), with 1e-3 it stays in its own."""
    prob = req.problem
    free = prob.without_force_limits()
    return _rows_first(
        req, method, starts, free, FORCE_MU0, FORCE_COST_RTOL, lambda q: _over_limits(prob, q)
    )


def _rows_first(
    req: Request,
    method: IPMethod,
    starts: list[FloatArray],
    free: Problem,
    mu0: float,
    rtol: float,
    unchecked: Callable[[FloatArray], bool] | None = None,
    max_iter: int | None = None,
) -> tuple[Run | None, int, int, bool]:
    """The default's search without some of the request's rows (``free``: the batch and,
    spatial from n = 4, the hops from its best pose, as the default without those rows
    runs them). When its best pose passes the request's check, it is the answer (the rows
    do not bind: the default's pose without them, bit for bit). Otherwise runs with the
    rows start from those basins' minima (:func:`_from_basins`, initial barrier ``mu0``,
    cost cap ``rtol``, at most ``max_iter`` iterations each when given); a pose not
    settled there leaves the caller to run the batch with the rows from the plan's starts
    too. ``unchecked(q)``: a pose the check would refuse anyway (it is not checked: None).

    Returns the best passing run (None: none passed), the iterations, the starts that
    ran (batch and hops; the runs from the basins are not starts) and whether that run
    settles the solve (it passed, within ``rtol``)."""
    from stackik.methods.ip import ip_basins

    left = req.time_left(time.perf_counter())
    basins = ip_basins(free, starts, req.options, left)
    tried = len(starts)
    if not basins.points:
        return None, basins.nit, tried, False
    planar = req.mode.planar

    def pose(found: Basins) -> FloatArray:  # its best point, polished (planar: already)
        return free.q_of(found.points[0]) if planar else found.pose(free, 0)

    def checked(found: Basins, q: FloatArray) -> Run | None:
        return None if unchecked is not None and unchecked(q) else found.run(free, 0, q)

    q = pose(basins)
    first = checked(basins, q)
    hops = [] if planar else spatial_default_hops(req.stack, q)
    if hops and not req.out_of_time():
        # the hops of the default (_hop), from the batch's best pose
        left = req.time_left(time.perf_counter())
        more = ip_basins(free, hops, req.options, left)
        tried += sum(st is not RunStatus.SKIPPED for st in more.statuses)
        if more.points:  # a lower hop replaces the batch's pose, as in _hop
            hop = checked(more, pose(more))
            if first is not None and hop is not None:
                first = hop if _lower(hop, first) else first
            elif _below(more.objs[0], basins.objs[0]):
                first = hop  # the lowest pose now, refused unchecked (None) or not
        basins.merge(more)
    nit = basins.nit
    if first is not None and first.ok:  # the rows do not bind there
        return first, nit, tried, True
    best, nit_rows, settled = _from_basins(req, method, free, basins, mu0, rtol, max_iter)
    return best, nit + nit_rows, tried, settled


def _from_basins(
    req: Request,
    method: IPMethod,
    free: Problem,
    basins: Basins,
    mu0: float,
    rtol: float,
    max_iter: int | None = None,
) -> tuple[Run | None, int, bool]:
    """Runs of the request's problem (with the rows ``free`` lacks) from the minima of
    ``basins`` (of ``free``), lowest objective first, initial barrier ``mu0``, while a
    basin's minimum is below the best passing objective so far and that is within
    ``rtol`` (relative, on the square root) of the least minimum. Returns the best passing
    run (None: none), the iterations and whether it settles the solve (within ``rtol``).
    ``max_iter``: each run's iteration limit, unless the request's is lower."""
    best: Run | None = None
    nit = 0
    opts = {"mu0": mu0, **req.options}
    if max_iter is not None:
        opts["max_iter"] = min(int(opts.get("max_iter", max_iter)), max_iter)
    cap = basins.objs[0] * (1.0 + rtol) ** 2
    for u, obj in zip(basins.points, basins.objs):
        if best is not None and (best.obj > cap or not _below(obj, best.obj)):
            # costly rows (the caller's batch decides), or this basin's minimum without
            # the rows is no lower than the best with them: nor is it with them
            break
        if req.out_of_time():
            break
        left = req.time_left(time.perf_counter())
        batch = method.run_many(req.problem, [free.q_of(u)], opts, left)
        nit += batch.nit
        if batch.best is not None and (best is None or _lower(batch.best, best)):
            best = batch.best
    return best, nit, best is not None and best.obj <= cap


def _clear_first_applies(req: Request, plan: StartPlan) -> bool:
    """The structured default (no ``starts``, no ``x0``; planar below
    :data:`stackik.solve.policy.ADAPTIVE_N`, spatial: :attr:`StartPlan.spatial_default`)
    of a problem with obstacle rows and neither leg-force nor planar self-leg rows (the
    spatial self-leg rows are the compiled kernel's and stay), with the FN or weighted
    objective: :func:`_clear_first`. Obstacle-free solves (and those whose obstacles are
    too far for rows) never take it."""
    prob = req.problem
    default = (
        plan.starts is None and req.structured and req.stack.n < ADAPTIVE_N
        if req.mode.planar
        else plan.spatial_default
    )
    return (
        default
        and (prob.clearance.obstacle_rows is not None or _spatial_self_legs(req))
        and prob.forces is None
        and not prob.rows_outside_ip
        and prob.objective != "feasible"
    )


def _spatial_self_legs(req: Request) -> bool:
    """A problem whose interior point carries self-leg rows (spatial, legs with a radius;
    the planar ones are lazy, :attr:`Problem.rows_outside_ip`): its default searches
    without them first (:func:`_clear_first`)."""
    prob = req.problem
    return prob.self_legs is not None and not prob.rows_outside_ip


def _clear_first(
    req: Request, method: IPMethod, starts: list[FloatArray]
) -> tuple[Run | None, int, int, bool]:
    """Default with obstacle rows (planar or spatial) or spatial self-leg rows:
    :func:`_rows_first` without those rows, with the small initial barrier
    :data:`CLEAR_MU0` and the cost cap :data:`CLEAR_COST_RTOL` (clearance only raises a
    basin's minimum). The same rule as :func:`_free_first` for leg-force limits.

    Why (docs/clearance.md): with the obstacle rows from the plan's starts, the runs'
    paths bend away from a truss member into other basins; on 4 of 12 planar n = 4 truss
    targets (seed 4290) none ended within 0.5 % of the best known. With the self-leg rows
    from the plan's starts, spatial runs on 12 mm legs miss basins whose minimum has two
    legs of a platform touching (legs crossing at zero radius): the default ended 3.2 %
    above such a minimum on a reference n = 4 target, from 8 starts as from 64."""
    free = req.problem.without_obstacle_rows()
    cap = None
    if _spatial_self_legs(req):
        free = free.without_self_legs()
        cap = CLEAR_BASIN_MAX_ITER  # runs from the basins that go on past it pass none
    return _rows_first(req, method, starts, free, CLEAR_MU0, CLEAR_COST_RTOL, max_iter=cap)


def _over_limits(prob: Problem, q: FloatArray) -> bool:
    """A leg force of the raw pose ``q`` is over its limit by more than ``100 FORCE_TOL``
    (relative) by the solvers' rows (:attr:`Problem.forces`), or a platform is singular:
    the check would refuse the pose, and its statics need not be computed."""
    assert prob.forces is not None
    c, _ = prob.forces(q)
    return not bool(np.all(c >= -100.0 * FORCE_TOL))


def _hop(req: Request, method: IPMethod, best: Run, nit: int, tried: int) -> tuple[Run, int, int]:
    """The spatial default's hops from its best pose
    (:func:`stackik.starts.spatial_default_hops`): one more compiled batch (within what is
    left of ``max_time``); a passing run with a lower FN replaces ``best``. ``tried``
    counts the hops that ran."""
    hops = spatial_default_hops(req.stack, best.q)
    if not hops or req.out_of_time():
        return best, nit, tried
    return _best_of(req, method, hops, best, nit, tried)


def _best_of(
    req: Request, method: IPMethod, starts: list[Any], best: Run, nit: int, tried: int
) -> tuple[Run, int, int]:
    """``starts`` in one compiled batch within what is left of ``max_time``: its best run
    replaces ``best`` when it passes with a lower FN; the batch's iterations and runs
    counted into ``nit`` and ``tried``."""
    left = req.time_left(time.perf_counter())
    batch = method.run_many(req.problem, starts, req.options, left)
    if batch.best is not None and _lower(batch.best, best):
        best = batch.best
    ran = sum(st is not RunStatus.SKIPPED for st in batch.statuses)
    return best, nit + batch.nit, tried + ran


def _compact_hops(
    req: Request, method: IPMethod, best: Run, nit: int, tried: int
) -> tuple[Run, int, int]:
    """The planar default's hops toward a compact target (:attr:`StartPlan.compact`): the
    rounds of :func:`stackik.solve.policy.compact_hop_rounds`, each that many random
    perturbations of the best pose so far (:meth:`stackik.starts.StartSampler.draw_around`,
    the random starts' scale) in one compiled call (within what is left of ``max_time``);
    a passing run with a lower FN replaces ``best``. The coils of such poses have many
    minima a few tenths of a percent apart, and the perturbed best pose settles in a
    neighbouring one. ``tried`` counts the hops that ran."""
    for count in compact_hop_rounds(req.stack.n):
        if req.out_of_time():
            break
        hops = [req.sampler.draw_around(best.q) for _ in range(count)]
        best, nit, tried = _best_of(req, method, hops, best, nit, tried)
    return best, nit, tried


def _recentres(req: Request) -> bool:
    """Spatial ``starts=1`` from the paper's guess re-centres (:func:`_recentre`) unless
    the caller set the barrier (``options["mu0"]``) or the stack has one platform."""
    return not req.mode.planar and req.stack.n >= 2 and "mu0" not in req.options


def _recentre(req: Request, method: IPMethod, best: Run, nit: int) -> tuple[Run, int]:
    """Spatial ``starts=1`` from the paper's guess: the interior point again from its own
    pose with the barriers of :data:`RECENTRE_MU0` in turn (each from the best so far,
    within what is left of ``max_time``); a passing run with a lower FN replaces
    ``best``. A larger barrier lifts the pose off its active limits, and it settles in the
    lower of the neighbouring minima more often than not (on 85 random n = 4, 6, 8
    targets: FN below one IPOPT run's from the same start on 35, above on 4; without:
    19 / 18). The runs are not starts: ``n_starts`` stays 1, ``nit`` counts them."""
    for mu0 in RECENTRE_MU0:
        if req.out_of_time():
            break
        left = req.time_left(time.perf_counter())
        batch = method.run_many(req.problem, [best.q], {**req.options, "mu0": mu0}, left)
        nit += batch.nit
        if batch.best is not None and _lower(batch.best, best):
            best = batch.best
    return best, nit


def _unfold_batch(req: Request, method: IPMethod, batch: IPBatch) -> None:
    """The interior point's runs that folded into themselves (``batch.folded``: they failed
    the check on non-adjacent bodies alone, at a lower objective than ``batch.best``),
    made again from their starts by :func:`_unfold` (at most :data:`UNFOLD_STARTS`, lowest
    first, one per basin; where the mode goes to the fold band first,
    :meth:`~stackik.formulation.modes.Mode.band_first`, only when it gives no pose;
    initial barrier :data:`UNFOLD_MU0` unless the caller set ``mu0``; of a leg and a
    plate the rows of :data:`UNFOLD_PLATE_ROWS` covering segments);
    a passing run of lower objective replaces ``batch.best`` (in place; the
    iterations counted). A batch without such runs is left as it is.

    The runs carry dense rows, whose normal matrix is a BLAS product every iteration: the
    solve's BLAS thread limit applies from here on (the planar batch below
    :data:`PLANAR_BLAS_N` runs without it). On a machine whose two cores other processes
    share, OpenBLAS's threads on those (3n) x (3n) products made the runs with a few
    hundred rows 8-60x slower an iteration (planar n = 16 with 12 mm legs: one run of
    160 iterations with 880 rows 0.06 s CPU with one thread, 3.0 s without the limit;
    ``benchmarks/profile_unfold.py``)."""
    from stackik.methods.ip import SAME_BASIN_RTOL

    req.blas.apply()
    options = {"mu0": UNFOLD_MU0, **req.options}

    def solve(prob: Problem, q: FloatArray) -> Run | None:
        left = req.time_left(time.perf_counter())
        got = method.run_many(prob, [q], options, left)
        batch.nit += got.nit
        return got.best if got.best is not None else got.least

    first = req.mode.band_first(req.stack)  # the fold band first; the unfolds if it fails
    if first and batch.best is None:
        _fold_band(req, method, batch, solve)
    tried: list[float] = []
    for run, start in batch.folded:
        if len(tried) == UNFOLD_STARTS or req.out_of_time() or (first and batch.best is not None):
            break
        if batch.best is not None and not _lower(run, batch.best):
            break
        if any(abs(run.obj - o) <= SAME_BASIN_RTOL * abs(o) for o in tried):
            continue  # the same basin's minimum as one tried
        tried.append(run.obj)
        got = _unfold(req, run, start, solve, UNFOLD_PLATE_ROWS)
        if got is not None and got.ok and (batch.best is None or _lower(got, batch.best)):
            batch.best = got
    if batch.best is None and not first and not req.out_of_time():
        _fold_band(req, method, batch, solve)


def _fold_band(
    req: Request,
    method: IPMethod,
    batch: IPBatch,
    solve: Callable[[Problem, FloatArray], Run | None],
) -> None:
    """No run passed, and the batch's runs folded into themselves: the lowest folded
    pose's fold is kept from curling back on itself (the mode's
    :meth:`~stackik.formulation.modes.Mode.fold_rows`; planar:
    :class:`~stackik.formulation.fold_band.FoldBand`, within a band of the end effector's
    angle, each platform turning at most a tilt, for each pair of
    :data:`~stackik.formulation.fold_band.FOLD_BANDS` until one gives a pose; spatial:
    none), from the paper's guess, the folded pose and the upright one
    (:meth:`~stackik.formulation.modes.Mode.upright`). The first pose that passes
    the check of the request's problem (without those rows) becomes ``batch.best`` and
    starts one more :func:`_unfold` (rows for the pairs close at it and at the folded
    pose), whose pose replaces it when it passes at a lower objective.

    Why: from n = 32 on, the unfolds from the batch's raw starts often end folded again,
    and the SQP engine's hand-over then took up to the whole time budget (12 mm legs,
    seeds 9461 and 10461, n = 32 and 64: 8 of 16 targets clear before, 16 of 16 with
    this, the longest solve 57 s against 138 s; FN mostly 0.2-6 % above the zero-radius
    pose, two answers higher than the hand-over's; docs/clearance.md, "Taller
    stacks")."""
    prob = req.problem
    run, _ = batch.folded[0]
    bands = prob.mode.fold_rows(prob.stack, req.target, run.q, prob.clearance.margin)
    for band in bands:
        if req.out_of_time():
            return
        left = req.time_left(time.perf_counter())
        starts = [req.q0, run.q, prob.mode.upright(nominal_height(prob.stack))]
        got = method.run_many(prob.with_families((band,)), starts, req.options, left)
        batch.nit += got.nit
        if got.best is not None and (check := prob.check(got.best.q)).ok:
            batch.best = dataclasses.replace(got.best, check=check)
            break
    if batch.best is None:
        return
    again = _unfold(req, run, batch.best.q, solve, UNFOLD_PLATE_ROWS)
    if again is not None and again.ok and _lower(again, batch.best):
        batch.best = again


def _unfold(
    req: Request,
    run: Run,
    start: FloatArray,
    solve: Callable[[Problem, FloatArray], Run | None],
    per_plate: int | None = None,
) -> Run | None:
    """``run`` (from the raw pose ``start``) folded into itself
    (:func:`stackik.methods.ip.folds_only`): made again from ``start`` with rows for the
    pairs of bodies of non-adjacent platforms (legs and legs, legs and plates) that come
    within :data:`UNFOLD_SCREEN_MM` of their least distance at ``start`` or at its pose
    (:func:`stackik.formulation.leg_pairs.close_pairs`; of a leg and a plate, the
    ``per_plate`` closest covering segments, None: all), and while the result folds again,
    with the pairs close at its pose added, up to :data:`UNFOLD_ROUNDS` runs. From the
    start, not from the folded pose: there the bodies pass through each other, and a
    squared distance has no gradient that pulls them apart. Returns the last run
    (``solve``'s: the request's problem with those rows, from a raw pose; it counts its
    iterations), or None when no run was made (no close pair: a plate-plate contact,
    which has no rows)."""
    from stackik.formulation.leg_pairs import close_pairs
    from stackik.methods.ip import folds_only

    prob = req.problem
    margin, phi = prob.clearance.margin, prob.mode.phi(prob.target)

    def close(qs: list[FloatArray]) -> set[int]:
        found = close_pairs(prob.stack, qs, margin, phi, UNFOLD_SCREEN_MM, per_plate)
        return {int(p) for p in found}

    pairs = close([start, run.q])
    if pairs:
        req.load_row_kernels()
    out: Run | None = None
    for _ in range(UNFOLD_ROUNDS):
        if not pairs or req.out_of_time():
            break
        got = solve(prob.with_leg_pairs(sorted(pairs)), start)
        if got is None:
            break
        out = got
        if got.ok or not folds_only(got.check, margin):
            break
        more = pairs | close([got.q])
        if more == pairs:
            break
        pairs = more
    return out


def _local_run(
    req: Request, method: Method, qs: FloatArray, options: dict[str, object], left: float
) -> Run:
    """One local run from ``qs``. A planar problem's self-leg rows are lazy
    (:attr:`Problem.lazy_self_legs`): the run is first made without them, and made again
    with them only when its pose fails the check on a platform's own legs alone (at the
    target, within every limit and every other clearance), the iterations of both
    counted. A run whose legs stay clear is thus the run of the problem without the rows,
    and a solve on legs with a radius that never come close is the zero-radius solve.
    A run that then fails on non-adjacent bodies alone (folded into itself) is solved again
    from the same start with rows for the pairs close at its start or its pose
    (:func:`_unfold`); the passing one of the two is the run (else the first), the
    iterations of all counted."""
    run = _lazy_self_legs(req, method, qs, options, left)
    from stackik.methods.ip import folds_only

    if not method.leg_pair_rows or not folds_only(run.check, req.problem.clearance.margin):
        return run
    nit = run.nit

    def solve(prob: Problem, q: FloatArray) -> Run:
        nonlocal nit
        got = method.run(prob, q, options, req.time_left(time.perf_counter()), req.qp_solver)
        nit += got.nit
        return got

    got = _unfold(req, run, qs, solve)
    best = got if got is not None and got.ok else run
    return dataclasses.replace(best, nit=nit)


def _lazy_self_legs(
    req: Request, method: Method, qs: FloatArray, options: dict[str, object], left: float
) -> Run:
    """One local run from ``qs`` with lazy planar self-leg rows (:func:`_local_run`)."""
    prob = req.problem
    if not prob.lazy_self_legs:
        return method.run(prob, qs, options, left, req.qp_solver)
    run = method.run(prob.without_self_legs(), qs, options, left, req.qp_solver)
    chk = run.check
    if chk.ok or chk.clearances is None:
        return run
    from stackik.methods.ip import unconstrained_shortfall

    others = max(chk.max_violation_mm, unconstrained_shortfall(prob, chk))
    if not pose_ok(chk.position_error, chk.angle_error, others, True, chk.peak_force_ratio):
        return run
    if req.out_of_time():  # no second run past the budget
        return run
    req.load_row_kernels()
    again = method.run(prob, qs, options, req.time_left(time.perf_counter()), req.qp_solver)
    return dataclasses.replace(again, nit=run.nit + again.nit)


def _screen(req: Request, method: Method, queue: list[FloatArray], tally: Tally) -> None:
    """Screen the structured starts with a loose KKT tolerance, best passing first (its FN
    is within ~1e-8 of the fully converged value); when none passes, the others are
    solved in full, best first."""
    for qs in queue:
        left = req.time_left(time.perf_counter())
        opts = {**SCREEN_OPTIONS, **req.options}
        run = _local_run(req, method, qs, opts, left)
        tally.nit += run.nit
        tally.screened.append(run)
        if not run.ok:
            tally.offer_least(run)
    tally.screened.sort(key=lambda r: (r.check.violation_mm > SCREEN_FEAS_MM, r.obj))


def _next_start(
    req: Request, queue: list[FloatArray], tally: Tally, fallback_at: int
) -> FloatArray:
    if tally.tried < len(queue):
        return queue[tally.tried]
    if tally.best is None and tally.tried == fallback_at and req.start == "paper":
        from stackik.convex import ConvexStartError, convex_start

        try:
            return convex_start(req.stack, req.target)
        except ConvexStartError:
            pass
    return req.sampler.draw()


def local_stage(req: Request, plan: StartPlan, handover: Handover | None) -> Verdict:
    """Local runs one start at a time (SQP, scipy, IPOPT; the SQP engine after a handover),
    with screening of the structured starts, fallback starts when none passes, the
    spatial early stop on unreachable targets and the time budget."""
    method = req.method if handover is None else get_method(handover.method)
    options = req.options if handover is None else dict(handover.options)
    queue = plan.queue if handover is None else handover.queue
    quick = handover is not None and handover.quick
    tally = Tally()
    n_planned = plan.n_planned
    if handover is not None:
        req.blas.apply()
        tally.nit, tally.least = handover.nit, handover.least
        tally.best = handover.best  # (its iterations are in handover.nit)
        if handover.n_planned is not None:
            n_planned = handover.n_planned
    if plan.starts is None and len(queue) > 1 and method.name == "sqp" and not quick:
        _screen(req, method, queue, tally)
        queue = [r.q for r in tally.screened]
        n_planned = 0 if tally.screened[0].ok else 1
    fallback = 3 if not req.x0_given and not quick else 0  # more starts if none passes
    while tally.tried < n_planned:
        if tally.tried > 0 and req.out_of_time():
            tally.timed_out = True
            break
        qs = _next_start(req, queue, tally, n_planned - fallback)
        left = req.time_left(time.perf_counter())
        if handover is None:
            tally.offer(_local_run(req, method, qs, options, left))
        else:  # the starts of a hand-over failed on the rows: the engine gets them all
            tally.offer(method.run(req.problem, qs, options, left, req.qp_solver))
        tally.tried += 1
        if quick and (tally.last is RunStatus.INFEASIBLE or tally.best is not None):
            break
        if plan.spatial_default and tally.tried == SPATIAL_GIVE_UP and tally.far_off:
            # the first structured starts all ended far from feasibility: an unreachable
            # target; the other starts would only repeat that
            break
        if tally.tried == n_planned and tally.best is None and fallback > 0:
            n_planned += fallback
            fallback = 0
    if tally.best is None and tally.screened and tally.screened[0].ok:
        tally.best = tally.screened[0]
    n_starts = tally.tried + len(tally.screened) + (handover.tried if handover else 0)
    if tally.best is not None:
        return Verdict(tally.best, IKStatus.SUCCESS, tally.nit, n_starts, method.name)
    return Verdict(tally.least, tally.failure_status(), tally.nit, n_starts, method.name)
