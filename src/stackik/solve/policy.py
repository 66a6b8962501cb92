"""The ``method="auto"`` policy and the start plan of a request.

Which method a request runs, which starts it tries and in which order: the rules behind
the default's quality figures (README, ``benchmarks/``), kept apart from the pipeline that
executes them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.starts import (
    SPATIAL_STARTS,
    arc_starts,
    fold_depth,
    fold_patterns,
    initial_starts,
    reach_fraction,
    spatial_start_count,
    spatial_starts,
    tall_random_starts,
)

__all__ = [
    "ADAPTIVE_FIRST",
    "ADAPTIVE_N",
    "ADAPTIVE_RTOL",
    "ADAPTIVE_STANDS",
    "CLEAR_BASIN_MAX_ITER",
    "CLEAR_COST_RTOL",
    "CLEAR_MU0",
    "COMPACT_HOPS",
    "COMPACT_LEAN_HOPS",
    "COMPACT_LEAN_N",
    "COMPACT_RANDOM",
    "COMPACT_REACH",
    "COMPACT_ROUNDS",
    "FORCE_COST_RTOL",
    "FORCE_METHOD",
    "FORCE_MU0",
    "FORCE_STARTS",
    "RECENTRE_MU0",
    "SCREEN_FEAS_MM",
    "SCREEN_OPTIONS",
    "SHARED_OPTIONS",
    "SPATIAL_GIVE_UP",
    "SPATIAL_GIVE_UP_MM",
    "SPATIAL_MAX_ITER",
    "UNFOLD_MU0",
    "UNFOLD_PLATE_ROWS",
    "UNFOLD_ROUNDS",
    "UNFOLD_SCREEN_MM",
    "UNFOLD_STARTS",
    "StartPlan",
    "auto_method",
    "compact_hop_rounds",
    "confirmed",
    "plan_starts",
    "stands",
]

FloatArray = NDArray[np.float64]

#: Loose SQP settings used to rank the default structured starts before refining the best.
SCREEN_OPTIONS = {"tol": 1e-4, "constr_tol": 1e-7}
SCREEN_FEAS_MM = 1e-3  # [mm] screened runs farther from feasibility rank last
#: Options that both engines take; what ``method="auto"`` passes on to its SQP fallback.
SHARED_OPTIONS = ("tol", "constr_tol", "max_iter", "max_time")
#: Spatial default: stop when this many first starts all end farther than
#: SPATIAL_GIVE_UP_MM from satisfying the target and the limits.
SPATIAL_GIVE_UP = 3
SPATIAL_GIVE_UP_MM = 1.0
#: Leg force limits that bind (:func:`stackik.solve.stages.ip_stage`): the engine that
#: enforces them and how many of the interior point's lower-objective poses over a force
#: limit it starts from.
FORCE_METHOD = "slsqp"
FORCE_STARTS = 2
#: Spatial default with leg-force limits (:func:`stackik.solve.stages._free_first`): the
#: initial barrier of the interior point's runs with the force rows from the minima of the
#: unloaded search (small: a run that starts over a force limit stays in its basin).
FORCE_MU0 = 1e-3
#: ... and when the best pose it finds has an FN more than this (relative) above the
#: unloaded search's least, the limits moved the optimum away from the unloaded basins:
#: the batch with the force rows from the plan's starts runs too, and the better wins.
FORCE_COST_RTOL = 1e-3

#: Default (planar or spatial) with obstacle rows (:func:`stackik.solve.stages._clear_first`): the
#: initial barrier of the interior point's runs with the obstacle rows from the minima of
#: the obstacle-free search (small: a run from a pose through an obstacle stays beside it
#: in its own basin) ...
CLEAR_MU0 = 1e-3
#: ... and when the best pose they find has an FN more than this (relative) above the
#: obstacle-free search's least, the obstacle moved the optimum away from the
#: obstacle-free basins: the batch with the obstacle rows from the plan's starts runs too,
#: and the better wins.
CLEAR_COST_RTOL = 1e-3
#: Spatial default on legs with a radius: the runs with the self-leg rows from the
#: zero-radius basins' minima stop at this many iterations (or at the caller's
#: ``max_iter`` when lower). Spatial n = 4, 12 mm legs, 80 targets (seeds 2900, 3000, 3100,
#: 3200): of 134 such runs the 85 that passed took 8-40 iterations (one 71); the 28 that
#: reached the 150-iteration limit and the 21 that stalled passed none, and the capped
#: ones held about two thirds of these runs' iterations.
CLEAR_BASIN_MAX_ITER = 80

#: A run whose pose fails the check on non-adjacent bodies alone (folded into itself:
#: :func:`stackik.methods.ip.folds_only`) is made again from its start, with rows for the
#: pairs of bodies of non-adjacent platforms (legs, plates) that come within this [mm] of
#: their least distance there or at its pose
#: (:func:`stackik.formulation.leg_pairs.close_pairs`; the other pairs cost nothing) ...
UNFOLD_SCREEN_MM = 20.0
#: ... of those, for a leg and a plate, in the interior point's unfold, the rows of the
#: plate's this many covering segments closest to the leg
#: (:func:`~stackik.formulation.leg_pairs.close_pairs`' ``per_plate``; about 8 pass the
#: screen on the folded n = 16 poses, 90 % of the rows; the local engines keep them all:
#: with 3, the SQP engine's unfold of a fingerprint n = 16 target ended folded). Planar n = 16,
#: 12 mm legs, seeds 5917/6917/7917: summed time 12 / 0 mm 2.6/2.6/2.0x against
#: 2.9/3.0/2.3x with every segment, summed FN cost 5.43/4.91/3.39 % against
#: 5.38/4.81/3.47 % ...
UNFOLD_PLATE_ROWS = 3
#: ... again with the pairs found close at that run's pose added, up to this many runs ...
UNFOLD_ROUNDS = 8
#: ... for at most this many of the interior point's folded poses (lowest FN first, one
#: per basin: :func:`stackik.solve.stages._unfold_batch`) ...
UNFOLD_STARTS = 2
#: ... each interior-point run with this initial barrier (unless the caller set ``mu0``):
#: on planar n = 16 with 12 mm legs (seeds 5917, 6917, 7917, 10 targets each) the runs
#: with the rows from the raw start took fewer iterations than with the default 0.1
#: (summed time 2.3-3.0x the 0 mm solves' against 2.2-5.1x) and ended no higher on
#: the sum over the targets on two of the three seeds (docs/clearance.md).
UNFOLD_MU0 = 1e-2

#: Planar default from ``n = ADAPTIVE_N`` on: the interior point first runs
#: ``ADAPTIVE_FIRST`` of the batch's random starts alone (:func:`tall_random_starts`), and
#: when each passes the check and their FN agree within ``ADAPTIVE_RTOL`` (relative), the
#: solve stops there; otherwise the batch's other starts run ``ADAPTIVE_FIRST`` at a time
#: (its other random starts first) until another run confirms the best pose found (FN
#: within ``ADAPTIVE_RTOL``), or ``ADAPTIVE_STANDS`` runs after the one that found it
#: found nothing lower, or every start ran, and the best pose is kept
#: (:meth:`StartPlan.adaptive_first`, :func:`stackik.solve.stages.ip_stage`).
#: Random perturbations of the paper's guess, not its folds: on the design targets the
#: structured starts often agree on the same worse basin (docs/benchmarks.md, 2026-12-03).
#: The confirmation (rather than the whole batch) after a disagreement: on the 10
#: targets of seeds 74100-88100 at n = 32 and 64 where the first two disagreed, the same
#: FN to 0.014 % after 4-6 starts instead of 16, 3-5x fewer iterations
#: (docs/benchmarks.md, 2026-12-07).
ADAPTIVE_N: float = 32
ADAPTIVE_FIRST = 2
ADAPTIVE_RTOL = 5e-4
#: The best pose found once stands when this many runs after it found nothing lower. On
#: 302 targets at n = 32 and 64 (seeds 52700-96300; every start of the batch run, the plan
#: replayed on the runs), 21 ran past the first two starts; with 4-8 every pose is the
#: same, and one target (seed 96300, n = 64, target 12) stops after 8 starts instead of
#: 16: its second run's pose, 7 % below the other 15 runs' (which agree), was never found
#: again (docs/benchmarks.md, 2026-12-07).
ADAPTIVE_STANDS = 6

#: Planar default from ``n = ADAPTIVE_N`` on, targets with a
#: :func:`stackik.starts.reach_fraction` below ``COMPACT_REACH`` (compact: most of the stack
#: coils around the target): no early stop; the batch also has the two
#: :func:`stackik.starts.arc_starts`, and ``COMPACT_HOPS`` random perturbations of its best
#: pose run after it (:meth:`StartPlan.batch`, :func:`compact_hop_rounds`,
#: :func:`stackik.solve.stages.ip_stage`). On the design targets at n = 64 (seeds 52700
#: and 63300) the two random starts of the adaptive plan agreed on a basin up to 8 % above
#: the best known on such targets, the bent bottom (an arc) reached the best basin, the
#: hops the best coils around it (docs/benchmarks.md, 2026-12-04).
COMPACT_REACH = 0.4
COMPACT_HOPS = 8
#: From ``n = COMPACT_LEAN_N`` on, the compact plan is lean: the two arcs and
#: ``COMPACT_RANDOM`` random starts alone (no fold patterns, no other random starts), then
#: ``COMPACT_ROUNDS`` rounds of ``COMPACT_LEAN_HOPS`` hops, each from the best pose so far:
#: 13 runs instead of 26. At n = 64 it found the best known (IPOPT from 32 starts, both
#: plans) on 12 of 12 fresh compact targets against 11 of 12, at a third of the iterations
#: (seed 99000); at n = 32 on 6 of 12 against 11 of 12 (seed 99500), so below it the plan
#: is the one above (docs/benchmarks.md, 2026-12-07).
COMPACT_LEAN_N = 64
COMPACT_RANDOM = 3
COMPACT_LEAN_HOPS = 4
COMPACT_ROUNDS = 2


def compact_hop_rounds(n: int) -> list[int]:
    """The hops of the compact plan at ``n`` platforms, round by round (each round from
    the best pose so far): one round of :data:`COMPACT_HOPS`, or from
    :data:`COMPACT_LEAN_N` on :data:`COMPACT_ROUNDS` rounds of :data:`COMPACT_LEAN_HOPS`."""
    if n >= COMPACT_LEAN_N:
        return [COMPACT_LEAN_HOPS] * COMPACT_ROUNDS
    return [COMPACT_HOPS]


#: Spatial default (:attr:`StartPlan.max_iter`): the iteration limit of the interior
#: point's runs from its structured starts and hops, unless the caller set ``max_iter``.
#: On 20 + 10 random targets at n = 8 and 16 (seed 91500) no run that converged took more
#: than 100 iterations, while the 3.5-4.5 % of runs that reached the method's 300 crawled
#: near feasibility (objective falling 0.1-1 % over 200 iterations) and took a quarter
#: of the iterations; with 150 every pose was the same, 9-12 % fewer iterations.
SPATIAL_MAX_ITER = 150

#: Spatial ``starts=1`` from the paper's guess: initial barriers of the interior point's
#: runs from its own pose after the first (:func:`stackik.solve.stages.ip_stage`).
RECENTRE_MU0 = (0.1, 1.0)


def auto_method(
    planar: bool,
    objective: str,
    sigma_theta: ArrayLike | None,
    qp_solver: str | None,
    options: dict[str, Any] | None = None,
    force_weight: float = 0.0,
) -> str:
    """``method="auto"``: the compiled interior-point path where it applies, else SQP.

    The interior-point path covers planar targets (:mod:`stackik._compiled.planar`) with the
    ``"frobenius"`` objective or ``"weighted"`` with one ``sigma_theta`` for all platforms,
    and spatial targets (:mod:`stackik._compiled.spatial`) with either objective.
    ``"feasible"`` stays with the SQP engine: its poses are the paper's "first feasible
    pose from the start", which a barrier method (drawn to the centre of the feasible
    set) does not reproduce. A given ``qp_solver``, or ``options`` that are not all
    interior-point options, select the SQP engine. ``objective="force"`` and a positive
    ``force_weight`` take :data:`FORCE_METHOD` (the SQP engine with a ``qp_solver``): no
    compiled kernel has the leg forces' residuals (with a weight, the pipeline first
    solves the request without it, :func:`stackik.solve.pipeline._weighted_run`).
    """
    from stackik.methods.ip import IP_DEFAULTS

    if objective == "force" or force_weight > 0.0:
        # the leg forces' residuals (the force objective, or a force weight added to
        # another): no compiled kernel has them
        return "sqp" if qp_solver is not None else FORCE_METHOD
    if objective == "feasible" or qp_solver is not None:
        return "sqp"
    if options and any(key not in IP_DEFAULTS for key in options):
        return "sqp"
    if not planar:  # the spatial interior point takes any per-platform weights
        return "ip"
    if objective == "weighted" and np.ptp(np.asarray(sigma_theta, dtype=float)) != 0:
        return "sqp"
    return "ip"


@dataclass
class StartPlan:
    """The starts of a request, in order.

    Attributes
    ----------
    queue : list of ndarray
        Deterministic starts (:func:`stackik.starts.initial_starts`), tried first.
    n_planned : int
        Local runs planned before any fallback (random starts fill past ``queue``).
    starts : int or None
        The start count in force (the user's, or the spatial default), None for the
        structured default.
    spatial_default : bool
        The spatial default schedule (early stop on unreachable targets).
    compact : bool
        The planar structured default of a tall stack (``n >= ADAPTIVE_N``) toward a
        compact target (:data:`COMPACT_REACH`): arcs in the batch, no early stop, hops.
    max_iter : int or None
        The iteration limit of the interior point's runs from the plan's starts and hops
        when the caller set none (:data:`SPATIAL_MAX_ITER`); None: the method's.
    """

    queue: list[FloatArray]
    n_planned: int
    starts: int | None
    spatial_default: bool
    compact: bool = False
    max_iter: int | None = None

    def run_options(self, options: dict[str, Any]) -> dict[str, Any]:
        """``options`` with the plan's :attr:`max_iter` unless they set ``max_iter``."""
        if self.max_iter is None or "max_iter" in options:
            return options
        return {**options, "max_iter": self.max_iter}

    def batch(self, sampler: Any, structured: bool, n: int) -> list[FloatArray]:
        """The starts of a one-call batch method (the interior point): the planned ones,
        plus on the structured default every fold pattern of the top platforms
        (:func:`stackik.starts.fold_depth`), toward a compact target (:attr:`compact`) the
        two :func:`stackik.starts.arc_starts` and, for tall stacks, random ones (last);
        toward a compact target from :data:`COMPACT_LEAN_N` on, only the arcs and
        :data:`COMPACT_RANDOM` random starts; random starts fill up to the count asked
        for."""
        qs = self.queue[: self.n_planned]
        if self.starts is None and structured:
            lean = self.compact and n >= COMPACT_LEAN_N  # the arcs and random starts alone
            if lean:
                qs = []
            else:
                qs += fold_patterns(sampler.stack, self.queue[0], fold_depth(n))
            if self.compact:
                qs += arc_starts(sampler.stack, self.queue[0])
            randoms = COMPACT_RANDOM if lean else tall_random_starts(n)
            qs += [sampler.draw() for _ in range(randoms)]
        while len(qs) < self.n_planned:
            qs.append(sampler.draw())
        return qs

    def adaptive_first(self, structured: bool, planar: bool, n: int, count: int) -> list[int]:
        """Which of the ``count`` starts of :meth:`batch` run first on their own, before
        the others only if they disagree: on the planar structured default (no ``starts``,
        no ``x0``) from ``n = ADAPTIVE_N`` on, the first :data:`ADAPTIVE_FIRST` random
        starts (the batch ends with its :func:`tall_random_starts`); none (the whole batch
        in one call) otherwise, and toward a compact target (:attr:`compact`)."""
        tall = tall_random_starts(n)
        if self.compact:
            return []
        if self.starts is None and structured and planar and n >= ADAPTIVE_N and tall:
            first = count - tall
            return list(range(first, first + min(ADAPTIVE_FIRST, tall)))
        return []


def plan_starts(req: Any) -> StartPlan:
    """The :class:`StartPlan` of a validated request."""
    starts = req.starts
    spatial_default = False
    spatial_ip = not req.mode.planar and req.method.name == "ip" and req.stack.n >= 2
    if spatial_ip and req.structured:
        # spatial interior point: twists, leans and folds (stackik.starts.spatial_starts)
        pos = req.target.position
        queue = spatial_starts(req.stack, req.q0, math.atan2(pos[1], pos[0]))
        if starts is None:
            k = min(len(queue), spatial_start_count(req.stack.n))
            return StartPlan(queue, k, k, True, max_iter=SPATIAL_MAX_ITER)
    else:  # (the planar structured starts are not built for the spatial plan above)
        queue = initial_starts(req.stack, req.target, req.q0, structured=req.structured)
    if starts is None and not req.mode.planar and req.stack.n >= 2 and req.structured:
        # spatial: the five structured starts and seven random ones, each solved in full
        # (benchmark: within 0.1 % of the best FN found on 30 of 30 targets, vs 28 from
        # the structured five alone, at twice their time)
        starts = SPATIAL_STARTS
        spatial_default = True
    n_planned = len(queue) if starts is None else int(starts)
    compact = (  # (the spatial defaults are spatial_default or returned above)
        starts is None
        and req.structured
        and not spatial_default
        and req.method.name == "ip"
        and req.stack.n >= ADAPTIVE_N
        and reach_fraction(req.stack, req.target) < COMPACT_REACH
    )
    return StartPlan(queue, n_planned, starts, spatial_default, compact)


def stands(runs: Sequence[Any], rtol: float, count: float) -> bool:
    """The least objective among ``runs`` (checked runs: ``Run``, or None where the run
    failed the check) that passed the check was first reached (the earliest run whose
    square root is within ``rtol`` of the least's, relative) at least ``count`` runs
    before the last: that many runs after it found nothing lower. False when no run
    passed."""
    roots = [None if r is None else float(np.sqrt(max(r.obj, 0.0))) for r in runs]
    passed = [x for x in roots if x is not None]
    if not passed:
        return False
    least = min(passed)
    near = least + max(rtol, 0.0) * abs(least)  # (the least itself at least)
    first = next(i for i, x in enumerate(roots) if x is not None and x <= near)
    return len(runs) - 1 - first >= count


def confirmed(runs: Sequence[Any], rtol: float) -> bool:
    """At least two of ``runs`` passed the check and the least objective among them is
    matched by another: square roots (FN for the default objective) within ``rtol`` of
    it, relative (:data:`stackik.solve.policy.ADAPTIVE_RTOL` in the adaptive plan)."""
    roots = sorted(float(np.sqrt(max(r.obj, 0.0))) for r in runs if r is not None)
    return len(roots) >= 2 and roots[1] - roots[0] <= rtol * abs(roots[0])
