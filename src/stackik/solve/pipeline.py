"""solve_ik: one IK request as a pipeline.

validate the request -> formulate (its :class:`~stackik.formulation.Problem`) -> plan the
starts -> run the stages (the interior-point batch, then local runs) -> each run checked
independently -> select -> :class:`~stackik.result.IKResult`.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from stackik._threads import batch_threads
from stackik._threads import resolve as resolve_threads
from stackik.formulation import mode_of, reach_bound
from stackik.geometry import Stack
from stackik.loads import Load, statics
from stackik.result import STATUS_MESSAGES, IKResult, IKStatus
from stackik.solve.blas import BlasLimit
from stackik.solve.nearest import BEYOND_MESSAGE, stretch_toward
from stackik.solve.policy import StartPlan, plan_starts
from stackik.solve.request import Request, build_request
from stackik.solve.stages import Handover, Verdict, ip_stage, local_stage
from stackik.solve.warmup import ensure_kernels, rows_needed
from stackik.targets import PlanarTarget, SpatialTarget, Target

__all__ = ["MethodName", "solve_ik"]

#: The built-in method names (:data:`stackik.methods.METHOD_NAMES`).
MethodName = Literal["auto", "sqp", "ip", "slsqp", "trust-constr", "ipopt"]


def solve_ik(
    stack: Stack,
    target: Target,
    *,
    objective: Literal["frobenius", "feasible", "weighted", "force"] = "frobenius",
    method: MethodName = "auto",
    qp_solver: str | None = None,
    x0: ArrayLike | None = None,
    starts: int | None = None,
    rng: np.random.Generator | int | None = None,
    options: dict[str, Any] | None = None,
    sigma_t: ArrayLike | None = None,
    sigma_theta: ArrayLike | None = None,
    start: Literal["paper", "convex"] = "paper",
    max_time: float | None = None,
    blas_threads: int | None = 1,
    threads: int | None = None,
    load: Load | None = None,
    obstacles: Any = (),
    clearance: float = 0.0,
    force_weight: float = 0.0,
    constraints: Any = (),
) -> IKResult:
    """Solve the inverse kinematics of a stack for one target.

    Parameters
    ----------
    stack : Stack
    target : PlanarTarget or SpatialTarget
        Planar mode (3 variables per platform) or spatial mode (6).
    objective : {"frobenius", "feasible", "weighted", "force"}
        ``"frobenius"`` minimises ``FN^2`` (the paper); ``"feasible"`` only reaches the
        target within the limits (the paper's non-optimised pose: the first feasible pose
        the solver reaches from its start); ``"weighted"`` minimises ``trace(J C_x J^T)``
        with ``C_x = diag(sigma_t^2, ..., sigma_theta^2)`` (per platform if arrays).
        ``"force"`` minimises the sum of squared leg forces, each divided by its
        platform's ``force_max`` where finite (else in N): the load-balancing pose under
        ``load`` (:class:`stackik.formulation.forces.ForceResiduals`; methods ``"slsqp"``
        (the ``"auto"`` choice), ``"sqp"``, ``"trust-constr"``).
    method : {"auto", "sqp", "ip", "slsqp", "trust-constr", "ipopt"}
        ``"ip"``: stackik's compiled primal-dual interior-point solver (planar:
        :mod:`stackik._compiled.planar`; spatial: :mod:`stackik._compiled.spatial`, exact second
        derivatives); ``"sqp"``: stackik's SQP engine (:mod:`stackik.sqp`, any QP
        backend, planar and spatial); ``"auto"`` (default) picks ``"ip"`` for planar targets
        with the ``"frobenius"`` objective (or ``"weighted"`` with one ``sigma_theta``) and
        for spatial targets with ``"frobenius"`` or ``"weighted"``, and ``"sqp"`` otherwise
        (see :func:`stackik.solve.policy.auto_method`). When every
        interior-point start stalls far from feasibility (an unreachable target), the result
        is "infeasible" with a pose within every limit part of the way to the target
        (bisection from the upright pose; ``target_error`` is what is left); when no start
        passes the check otherwise, the SQP engine takes over (it reports infeasibility and
        the least-violation pose); the result's ``method`` says which produced the pose.
        ``"slsqp"``/``"trust-constr"``: scipy baselines given the same scaled derivatives;
        ``"ipopt"``: IPOPT through CasADi (planar and spatial; optional extra ``stackik[ipopt]``)
        with exact derivatives by automatic differentiation.
    qp_solver : str, optional
        QP backend of the SQP engine (default: its fastest installed one).
    x0 : array_like, optional
        Warm start, shape (n, 3) or (n, 6); default the paper's initial guess
        (:func:`stackik.starts.paper_initial_guess`) or, with ``start="convex"``, the convex
        restriction (:func:`stackik.convex.convex_start`; the paper's guess when that SOCP
        is infeasible).
    starts : int, optional
        Number of starts. Default: in planar mode without ``x0``, three structured starts
        (the paper's guess and two "folded" variants whose top two platforms are offset
        sideways in opposite directions, see :func:`stackik.starts.initial_starts`) and, for
        the interior-point path with n >= 5, every sideways-fold pattern of the top 3 (n =
        5), 4 (n = 6-15), 5 (n = 16-31) or 3 (n >= 32) platforms
        (:func:`stackik.starts.fold_depth`, :func:`stackik.starts.fold_patterns`), plus five
        random ones from n = 32 (:func:`stackik.starts.tall_random_starts`); from n = 32
        (:data:`stackik.solve.policy.ADAPTIVE_N`) the interior point first runs two of
        the random ones alone, and when both pass the check with FN within 5e-4 of each
        other (relative, :data:`~stackik.solve.policy.ADAPTIVE_RTOL`) returns the better
        of them (``n_starts`` 2); otherwise it runs the others two at a time (the other
        random ones first) until another run confirms the best FN found, or six runs
        after the one that found it found nothing lower
        (:data:`~stackik.solve.policy.ADAPTIVE_STANDS`), or all 16 ran, and keeps the
        best pose of all (the adaptive plan,
        :func:`stackik.solve.stages.ip_stage`); toward a compact target
        (:func:`stackik.starts.reach_fraction` below 0.4,
        :data:`~stackik.solve.policy.COMPACT_REACH`) it runs the whole batch with two
        arc starts (:func:`stackik.starts.arc_starts`) and then eight random
        perturbations of its best pose (``n_starts`` 26), from n = 64
        (:data:`~stackik.solve.policy.COMPACT_LEAN_N`) the arcs and three random starts
        alone, then two rounds of four perturbations of the best pose so far
        (``n_starts`` 13); in spatial mode
        the interior point's structured starts (:func:`stackik.starts.spatial_starts`: 8
        up to n = 3, 12 from n = 4; twists, leans and folds; then hops from the best
        pose from n = 4, 12 at n = 7 and 8 and 6 otherwise,
        :func:`stackik.starts.spatial_hop_plan`), the SQP
        engine's five
        structured and seven random ones; otherwise one. ``starts=K`` in spatial mode
        takes the first K of :func:`stackik.starts.spatial_starts`; spatial ``starts=1``
        without ``x0`` (and without ``options["mu0"]``) re-runs the interior point twice
        from its own pose with a larger barrier and keeps the lower FN (``n_starts`` 1).
        These find the best known FN on the benchmark targets (README). Extra starts
        perturb the first with Gaussian noise (``rng``). The best pose that passes the
        check is returned; when none does, up to three more starts (the convex start
        first) are tried.
    rng : Generator, int or None
        Randomness of the extra (random) starts, including the fallback ones; None uses a
        fixed seed, so that the same call always returns the same pose.
    options : dict, optional
        Passed to the solver: ``SQPOptions`` fields for "sqp", ``tol``, ``constr_tol``,
        ``mu0``, ``max_iter``, ``max_time`` for "ip"
        (:data:`stackik.methods.ip.IP_DEFAULTS`), scipy or IPOPT options otherwise.
    max_time : float, optional
        Wall-time budget over all starts [s]; default ``10 + 2 n``.
    load : Load, optional
        Payload, external wrench and gravity (:class:`stackik.Load`) the leg forces carry.
        Where a platform's ``force_max`` [N] is finite, every method keeps every leg's
        ``|f| <= force_max`` under it (None: the stack's own weight, earth gravity) and the
        check enforces it (:mod:`stackik.formulation.forces`); without a finite
        ``force_max`` the load changes nothing but the check's reported forces.
    obstacles : Obstacle or sequence of Obstacle, optional
        Keep-out bodies in the base frame [mm] (:class:`stackik.Sphere`,
        :class:`stackik.Capsule`, :class:`stackik.Box`, :class:`stackik.HalfSpace`): the check
        enforces them, so a pose through one is never a success, and the solvers keep every
        leg clear of the spheres, capsules and half-spaces
        (:mod:`stackik.formulation.obstacle_rows`; boxes and plates: the check only,
        ``docs/clearance.md``).
    clearance : float, optional
        Margin [mm] every checked pair of bodies keeps (default 0). In spatial mode the
        solvers keep the legs of each platform ``2 leg_radius + clearance`` apart (axis to
        axis, :mod:`stackik.formulation.clearance`) whenever a leg radius or this margin is
        positive; the check enforces every pair kind of :func:`stackik.clearances`.
    force_weight : float, optional
        ``w >= 0`` [mm^2] (default 0: no force term): adds ``w sum_ik (f_ik / s_i)^2`` to
        the ``"frobenius"``, ``"weighted"`` or ``"feasible"`` objective, with ``f`` the leg
        forces [N] under ``load`` and ``s_i`` platform i's ``force_max`` where finite, else
        1 N (the residuals of ``objective="force"``, stacked under the objective's own:
        :class:`stackik.formulation.forces.ForceResiduals`). FN^2 is in mm^2 (its
        translation columns are dimensionless, its rotation columns mm per rad), the force
        ratios are dimensionless, so ``w`` is in mm^2 per unit squared force ratio: the FN^2
        one would give up to lower the sum of squared force ratios by 1. Methods:
        ``"slsqp"`` (the ``"auto"`` choice), ``"sqp"``, ``"trust-constr"``; ``"ip"`` and
        ``"ipopt"`` refuse it. ``objective_value`` is the total; ``frobenius_norm`` stays
        the pose's FN.
    constraints : ConstraintFamily or sequence of ConstraintFamily, optional
        A user's row families ``c(q) >= 0`` (:class:`stackik.ConstraintFamily`, one
        definition per mode): ``"ip"`` (the default), ``"sqp"``, ``"slsqp"`` and
        ``"trust-constr"`` keep them and the check enforces them (a pose with a row below
        ``-FEAS_TOL`` in the family's unit is not a success); ``"ipopt"`` refuses them.
        See :mod:`stackik.families`.
    blas_threads : int or None
        BLAS threads during the solve (default 1: the matrices are small and threads only
        contend, 5x slower at n = 32 on a loaded 2-core machine); None leaves the process
        setting alone.
    threads : int or None
        Threads that run the interior point's batches of starts side by side (the
        spatial default's structured starts and hops; planar from 8 platforms on):
        default None, the CPUs this process may use (at most 8), or 1 inside the workers
        of :func:`solve_many` and the other batch runners, which already run solves side
        by side; 1 runs them one after another (pass 1 when your own threads or
        processes run solves side by side). The pose does not depend on it: every
        start's run is the same, and the best is chosen in the starts' order.

    Returns
    -------
    IKResult
        ``success`` only when :func:`check_pose` passes (for interior-point poses its
        compiled twin :func:`stackik._compiled.check.planar_check`, tested to agree, does the
        check).
    """
    rows = rows_needed(
        stack, obstacles, clearance, constraints, force_weight, objective,
        planar_solve=isinstance(target, PlanarTarget),
    )  # fmt: skip
    for kind in _kernels_needed(stack, target, rows):
        ensure_kernels(kind)  # load or compile before the clock starts
    n_threads = resolve_threads(threads)
    t_start = time.perf_counter()
    blas = BlasLimit(blas_threads)
    try:
        req = build_request(
            stack, target, objective=objective, method=method, qp_solver=qp_solver, x0=x0,
            starts=starts, rng=rng, options=options, sigma_t=sigma_t,
            sigma_theta=sigma_theta, start=start, max_time=max_time, t_start=t_start,
            blas=blas, load=load, obstacles=obstacles, clearance=clearance,
            force_weight=force_weight, constraints=constraints,
        )  # fmt: skip
        with batch_threads(n_threads):
            return _result(req, _run(req))
    finally:
        blas.restore()


def _beyond_reach(stack: Stack, target: Target) -> bool:
    """True when ``|P_target|`` exceeds :func:`stackik.formulation.reach_bound`."""
    position = mode_of(target).position(target)
    return float(np.linalg.norm(position)) > reach_bound(stack)


def _kernels_needed(stack: object, target: object, rows: bool = False) -> tuple[str, ...]:
    """The compiled kernels a request calls for sure: the planar set for every planar
    target (every method evaluates the planar problem, the SQP its Hessian, through it:
    a cold first SQP solve used to spend its 18 s budget compiling and return its start
    after 0 iterations); the spatial set (evaluation and interior point) for spatial
    targets, with the planar set only for a target beyond the reach bound (its
    stretched pose is a planar bisection). A spatial target that turns out unreachable
    later loads the planar set then, off the clock (:meth:`Request.load_kernels`): a
    first spatial solve compiles no planar kernel (it used to compile both sets). With
    ``rows`` (:func:`stackik.solve.warmup.rows_needed`), each set's ``_rows`` twin too: the
    kernels for problem data with rows beyond the limits."""
    if not isinstance(stack, Stack) or not isinstance(target, PlanarTarget | SpatialTarget):
        return ()  # the request's validation reports it
    if isinstance(target, PlanarTarget):
        kinds: tuple[str, ...] = ("planar",)
    else:
        kinds = ("spatial", "planar") if _beyond_reach(stack, target) else ("spatial",)
    return kinds + tuple(f"{kind}_rows" for kind in kinds) if rows else kinds


def _run(req: Request) -> Verdict:
    """The stages of a validated request, up to its verdict."""
    if _beyond_reach(req.stack, req.target):
        # beyond the triangle-inequality bound of every platform: unreachable; answer with
        # a pose within every limit stretched toward it (never the raw first start)
        run, _, nit, solves = stretch_toward(
            req.stack, req.target, req.objective, req.weights, req.options,
            req.t_start + req.max_time,
        )  # fmt: skip
        if run is None:
            return Verdict(None, IKStatus.INFEASIBLE, 0, 0, req.method.name)
        return Verdict(run, IKStatus.INFEASIBLE, nit, solves, "ip", BEYOND_MESSAGE)
    plan = plan_starts(req)
    if req.auto and req.problem.force_weight > 0.0:
        return _weighted_run(req, plan)
    handover: Handover | None = None
    if req.method.name == "ip":
        out = ip_stage(req, plan)
        if isinstance(out, Verdict):
            return out
        handover = out
    return local_stage(req, plan, handover)


def _weighted_run(req: Request, plan: StartPlan) -> Verdict:
    """``"auto"`` with a force weight: the request's default solve without the weight
    first (the interior point, for "frobenius" and "weighted"), then the force method
    (:data:`~stackik.solve.policy.FORCE_METHOD`, as for ``objective="force"``) from that
    pose and from the plan's starts. A small weight then moves the pose a little from the
    weightless optimum: from the plan's starts alone SLSQP missed its basin (spatial
    n = 3, ``w = 0.001`` mm^2/N^2: FN 724 against 680 at ``w = 0``)."""
    first = _run(req.without_force_weight())
    if first.run is not None and first.status is IKStatus.SUCCESS:
        plan = dataclasses.replace(
            plan, queue=[first.run.q, *plan.queue], n_planned=plan.n_planned + 1
        )
    out = local_stage(req, plan, None)
    n_starts = out.n_starts + first.n_starts
    return dataclasses.replace(out, nit=out.nit + first.nit, n_starts=n_starts)


def _result(req: Request, verdict: Verdict) -> IKResult:
    """The :class:`IKResult` of a verdict (the first start when it has no run)."""
    run = verdict.run
    q = req.q0 if run is None else run.q
    chk = req.problem.check(q) if run is None else run.check
    lifted = None if run is None else run.lifted
    P, R, legs = lifted if lifted is not None else req.mode.lift(req.stack, req.target, q)
    weighted = req.problem.force_weight > 0.0  # the objective is not FN^2 alone
    frobenius = (
        math.sqrt(run.obj)
        if run is not None and req.objective == "frobenius" and not weighted
        else req.mode.frobenius(q)
    )
    start_method = req.method.name
    status, message = verdict.status, verdict.message or STATUS_MESSAGES[verdict.status]
    return IKResult(
        q=q,
        success=status is IKStatus.SUCCESS,
        status=status,
        message=message,
        frobenius_norm=frobenius,
        objective=req.objective,
        objective_value=req.problem.objective_value(q) if run is None or weighted else run.obj,
        max_violation=chk.max_violation,
        target_error=chk.position_error,
        angle_error=chk.angle_error,
        nit=verdict.nit,
        time=time.perf_counter() - req.t_start,
        method=verdict.method,
        qp_solver=req.qp_solver or ("default" if start_method == "sqp" else "-"),
        n_starts=verdict.n_starts,
        P=P,
        R=R,
        leg_lengths=legs,
        phi=req.mode.phi(req.target),
        mode=req.mode.name,
        clearances=chk.clearances,
        **_statics_fields(req, chk, q),
    )


def _statics_fields(req: Request, chk: Any, q: Any) -> dict[str, Any]:
    """``IKResult``'s force fields: from the check when it computed them (a load given or a
    finite ``force_max``), else none."""
    prob = req.problem
    if prob.load is None and prob.forces is None and prob.force_residuals is None:
        return {}
    st = chk.statics
    if st is None:
        st = statics(req.stack, q, req.problem.load, phi=req.mode.phi(req.target))
    return {
        "leg_forces": st.leg_forces,
        "force_margin": st.force_margin,
        "sigma_min": st.sigma_min,
        "condition": st.condition,
    }
