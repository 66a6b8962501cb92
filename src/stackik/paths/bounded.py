"""The bounded step: least FN among the poses within ``max_jump`` of the previous pose.

When the local FN minimum that a path follows ends (it merges with a saddle and
disappears, or runs into a limit wall), a warm-started solve falls into another basin far
away. Continuity then means leaving the optimum: the step solves

.. math::

    \\min_q\\; FN^2(q) \\quad\\text{s.t.}\\quad y(q) = y^*,\\quad c(q) \\ge 0,\\quad
    |q - q_{prev}| \\le \\Delta \\;\\text{(per variable)}

with ``Delta`` the jump limit (mm for translations, rad for angles): the scaled IK problem
of the solvers (:class:`stackik.formulation.Problem`) with variable bounds, on stackik's
generic SQP engine (:mod:`stackik.sqp`, whose iterates always satisfy variable bounds),
with the exact Lagrangian Hessian in planar mode and damped BFGS in spatial mode, as
``method="sqp"``. The caller accepts the pose only through
:func:`stackik.check.check_pose` and its own jump test.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik._arrays import readonly
from stackik.formulation import Problem
from stackik.geometry import Stack
from stackik.sqp import NonlinearProgram, SQPOptions
from stackik.sqp import solve as sqp_solve
from stackik.targets import Target

__all__ = [
    "BOUNDED_OPTIONS",
    "BOX_SHRINK",
    "IP_BOX_SHRINK",
    "IP_BOX_MU0",
    "TRANSIT_WEIGHT",
    "bounded_ip",
    "bounded_step",
]

FloatArray = NDArray[np.float64]

#: SQP settings of the bounded step (tolerances on the scaled problem, as method="sqp").
BOUNDED_OPTIONS = {"tol": 1e-7, "constr_tol": 1e-10, "max_iter": 200, "initial_tr_radius": 0.5}
#: The box is ``max_jump * (1 - BOX_SHRINK)``, so that rounding never reports a jump.
BOX_SHRINK = 1e-9
#: Weight of the distance to the goal against FN in a transit step (both relative).
TRANSIT_WEIGHT = 1.0
#: The compiled interior point's box is ``max_jump * (1 - IP_BOX_SHRINK)``: its polish
#: (Newton corrections of the target equalities, ~1e-9 scaled) may move the pose a little.
IP_BOX_SHRINK = 1e-6
#: Initial barrier parameter of the boxed interior point (the start, the previous pose,
#: sits on its active limits at the centre of the box).
IP_BOX_MU0 = 1e-3


def _box(prob: Problem, q_prev: FloatArray, max_jump: FloatArray, shrink: float) -> tuple[
    FloatArray, FloatArray
]:  # fmt: skip
    box = np.tile(max_jump * (1.0 - shrink), q_prev.shape[0])
    x_prev = q_prev.ravel()
    return (x_prev - box) / prob.xs, (x_prev + box) / prob.xs


def _transit_terms(prob: Problem, q_prev: FloatArray, goal: FloatArray,
                   P: Any = None) -> tuple[float, float, FloatArray]:  # fmt: skip
    """``f0`` and ``d0`` of the transit objective ``f / f0 + |u - u_goal|^2 / d0`` (both
    relative to the previous pose) and ``u_goal``. ``P``: the kernels' problem arrays
    (:func:`stackik.methods.ip.problem_arrays`, ``spatial_problem_arrays``), whose
    compiled evaluation gives ``f`` in microseconds (the Problem's own: ~0.2 ms at
    n = 4, planar and spatial; the same value to rounding)."""
    ug, u_prev = prob.u_of(goal), prob.u_of(q_prev)
    if P is None:
        f = float(prob.evaluate(u_prev)[0])
    elif prob.planar:
        from stackik._compiled import planar as _ipm

        f = float(_ipm._evaluate(u_prev, P)[0])
    else:
        from stackik._compiled import spatial as _spatial_ipm

        f = float(_spatial_ipm._evaluate(u_prev, P)[0])
    f0 = max(f, 1e-12)
    d0 = max(float(np.sum((u_prev - ug) ** 2)), 1e-12) / TRANSIT_WEIGHT
    return f0, d0, ug


def _step_problem(
    stack: Stack, target: Target, obstacles: Any, clearance: float, load: Any, constraints: Any,
    pairs: Any = (),
) -> Problem:  # fmt: skip
    """The FN problem of a bounded step, with the path's clearances, load and constraint
    families (their rows: the step goes around what they keep out), and rows for the
    ``pairs`` of bodies of non-adjacent platforms
    (:meth:`stackik.formulation.Problem.with_leg_pairs`; none when empty)."""
    prob = Problem(
        stack, target, "frobenius", None, obstacles=obstacles, clearance=clearance, load=load,
        constraints=constraints,
    )  # fmt: skip
    return prob.with_leg_pairs(pairs) if len(pairs) else prob


def bounded_ip(
    stack: Stack,
    target: Target,
    q_prev: FloatArray,
    max_jump: FloatArray,
    *,
    goal: FloatArray | None = None,
    obstacles: Any = (),
    clearance: float = 0.0,
    load: Any = None,
    constraints: Any = (),
    pairs: Any = (),
) -> FloatArray | None:
    """:func:`bounded_step`'s problem (the same objective, box and transit objective) on
    the compiled interior point (:func:`stackik._compiled.barrier.ip_box`, exact Hessians,
    then the compiled polish) instead of the SQP engine: a few
    hundred microseconds instead of tens of milliseconds. Starts at ``q_prev``, the
    centre of the box. Returns the pose (polished) or None when the solver failed; the
    caller checks it."""
    from stackik.formulation import POLISH_MARGIN, POLISH_REACH
    from stackik.methods.ip import IP_DEFAULTS, problem_arrays, spatial_problem_arrays

    prob = _step_problem(stack, target, obstacles, clearance, load, constraints, pairs)
    P = problem_arrays(prob) if prob.planar else spatial_problem_arrays(prob)
    lo, hi = _box(prob, q_prev, max_jump, IP_BOX_SHRINK)
    ug, wq, f0 = np.zeros(0), 0.0, 1.0
    if goal is not None:
        f0, d0, ug = _transit_terms(prob, q_prev, goal, P)
        wq = 1.0 / d0
    lo, hi, ug = readonly(lo), readonly(hi), readonly(ug)
    u0 = readonly(prob.u_of(q_prev))
    tol, ctol = float(IP_DEFAULTS["tol"]), float(IP_DEFAULTS["constr_tol"])
    max_iter = int(IP_DEFAULTS["max_iter"])
    try:
        from stackik._compiled import barrier

        P = P._replace(fscale=P.fscale * f0)
        u, st, _ = barrier.ip_box(u0, P, lo, hi, ug, wq, tol, ctol, IP_BOX_MU0, max_iter,
                                  POLISH_REACH, POLISH_MARGIN)  # fmt: skip
    except (ValueError, np.linalg.LinAlgError):
        return None
    if st == _IP_NONFINITE or not np.all(np.isfinite(u)):
        return None
    return prob.q_of(u)


_IP_NONFINITE = 3  # the kernels' IP_NONFINITE (both use 3); read here without importing them


def bounded_step(
    stack: Stack,
    target: Target,
    q_prev: FloatArray,
    max_jump: FloatArray,
    *,
    x0: FloatArray | None = None,
    goal: FloatArray | None = None,
    max_time: float = math.inf,
    obstacles: Any = (),
    clearance: float = 0.0,
    load: Any = None,
    constraints: Any = (),
    pairs: Any = (),
) -> FloatArray | None:
    """Least-FN pose of ``target`` within ``max_jump`` of ``q_prev``, or None.

    With ``goal``, the pose within the box nearest ``goal`` instead (a transit step: the
    objective is ``|u - u_goal|^2`` in the scaled variables, translations / ``L`` and
    angles in rad), to move a path towards a better basin ``max_jump`` at a time.

    Parameters
    ----------
    stack : Stack
    target : PlanarTarget or SpatialTarget
    q_prev : ndarray, shape (n, 3) or (n, 6)
        The previous waypoint's pose (within every limit) [mm, rad].
    max_jump : ndarray, shape (3,) or (6,)
        Largest change of each variable of a platform [mm, rad].
    x0 : ndarray, shape (n, 3) or (n, 6), optional
        Start (projected onto the box); default ``q_prev``.
    goal : ndarray, shape (n, 3) or (n, 6), optional
        Pose to approach (see above).
    max_time : float
        Wall-time budget [s].
    obstacles, clearance, load, constraints
        As :func:`stackik.solve_ik`'s: the step has the same self-leg, obstacle, family and
        leg-force rows (:mod:`stackik.formulation.clearance`,
        :mod:`stackik.formulation.forces`), so it goes around an obstacle or off a force
        limit within the box (:func:`bounded_ip`'s compiled problem has the obstacle rows
        and, spatial, the self-leg rows, not the force rows).
    pairs : sequence of int
        Pairs of bodies of non-adjacent platforms the step keeps apart (indices into
        :func:`stackik.formulation.leg_pairs.pair_table`'s pairs; both this engine and
        :func:`bounded_ip` carry their rows); none by default.

    Returns
    -------
    ndarray or None
        The pose the SQP engine ends at (the caller checks it), or None when the engine
        stopped on bad numbers.
    """
    prob = _step_problem(stack, target, obstacles, clearance, load, constraints, pairs)
    exact = prob.fast is not None and not prob.dense_rows
    evaluate, hessian = prob.evaluate, prob.lagrangian_hessian
    if goal is not None:
        # FN^2 and the squared distance to the goal, each relative to its value at q_prev
        f0, d0, ug = _transit_terms(prob, q_prev, goal)

        def evaluate(u: FloatArray) -> tuple[Any, ...]:
            f, g, ceq, Jeq, cin, Jin = prob.evaluate(u)
            d = u - ug
            return f / f0 + float(d @ d) / d0, g / f0 + 2.0 * d / d0, ceq, Jeq, cin, Jin

        def hessian(u: FloatArray, y_eq: FloatArray, y_in: FloatArray) -> FloatArray:
            H_f = prob.lagrangian_hessian(u, 0.0 * y_eq, 0.0 * y_in)  # objective part
            H = prob.lagrangian_hessian(u, y_eq, y_in) - H_f  # constraint part
            return H + H_f / f0 + (2.0 / d0) * np.eye(H.shape[0])  # type: ignore[no-any-return]

    lower, upper = _box(prob, q_prev, max_jump, BOX_SHRINK)
    nlp = NonlinearProgram(
        objective=None,
        evaluate=evaluate,
        hessian=hessian if exact else None,
        gauss_newton=prob.gauss_newton if goal is None else None,
        gn_scale=2.0,
        eq_scale=np.ones(prob.es.size),
        ineq_scale=np.ones(prob.n_ineq),
        lower=lower,
        upper=upper,
        name="bounded path step",
    )
    opts: dict[str, Any] = dict(BOUNDED_OPTIONS, max_time=max_time)
    if not exact:
        opts["hessian"] = "bfgs"
    u0 = np.clip(prob.u_of(q_prev if x0 is None else x0), lower, upper)
    try:
        res = sqp_solve(nlp, u0, options=SQPOptions(**opts))
    except (ValueError, np.linalg.LinAlgError):
        return None
    if not np.all(np.isfinite(res.x)):
        return None
    return prob.q_of(res.x)
