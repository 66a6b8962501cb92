"""A validated IK request: every argument of :func:`stackik.solve_ik` checked once.

Bad input gets a ``ValueError`` that names the argument (or an
:class:`~stackik.result.OptionError` for solver options) before any solver runs.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik._arrays import finite_array
from stackik.formulation import Mode, Problem, mode_of
from stackik.geometry import Stack
from stackik.loads import Load
from stackik.methods import AUTO, Method, get_method
from stackik.solve.blas import BlasLimit
from stackik.solve.policy import auto_method
from stackik.solve.warmup import ensure_kernels
from stackik.starts import StartSampler, paper_initial_guess
from stackik.targets import Target

__all__ = ["OBJECTIVES", "Request", "build_request", "sigma_weights"]

FloatArray = NDArray[np.float64]

OBJECTIVES = ("frobenius", "feasible", "weighted", "force")


@dataclass
class Request:
    """Everything one solve needs, validated.

    ``method`` is the method the request starts with (``"auto"`` resolved); ``auto`` says
    whether the policy chose it (and may hand over to the SQP engine). ``q0`` is the first
    start (the user's ``x0``, the convex start or the paper's guess); ``structured`` is
    True when the default structured starts apply (no ``x0``, ``start="paper"``).
    """

    stack: Stack
    target: Target
    mode: Mode
    objective: str
    method: Method
    auto: bool
    qp_solver: str | None
    q0: FloatArray
    structured: bool
    x0_given: bool
    start: str
    starts: int | None
    sampler: StartSampler
    options: dict[str, Any]
    weights: tuple[FloatArray, FloatArray] | None
    problem: Problem
    max_time: float
    t_start: float
    blas: BlasLimit

    def time_left(self, now: float) -> float:
        """Seconds left of the budget at ``now`` (at least 1 ms)."""
        return max(self.max_time - (now - self.t_start), 1e-3)

    def load_kernels(self, kind: str) -> None:
        """Load (or compile) the kernels of ``kind`` in the middle of the solve, the
        seconds spent taken off its clock (as :func:`stackik.solve_ik` loads the others
        before its clock starts): ``t_start`` moves on by them."""
        self.t_start += ensure_kernels(kind)

    def load_row_kernels(self) -> None:
        """Load the mode's ``_rows`` family (:meth:`load_kernels`, off the clock) before a
        run with rows the solve did not load it for: a planar solve's body rows, which
        come lazily (:func:`stackik.solve.warmup.rows_needed` with ``planar_solve``)."""
        self.load_kernels(f"{self.mode.name}_rows")

    def without_force_weight(self) -> Request:
        """The same request without its force weight (its objective alone, the method
        ``"auto"`` picks for it, the same clock, starts and randomness): the pose
        :func:`stackik.solve_ik` with ``force_weight`` starts from first."""
        p = self.problem
        cl = p.clearance
        prob = Problem(
            self.stack, self.target, self.objective, self.weights, load=p.load,
            obstacles=cl.obstacles, clearance=cl.margin,
            constraints=p.constraints,
        )  # fmt: skip
        sigma_theta = None if self.weights is None else self.weights[1]  # (its spread only)
        planar = self.mode.planar
        name = auto_method(planar, self.objective, sigma_theta, self.qp_solver, self.options)
        return dataclasses.replace(self, problem=prob, method=get_method(name))

    def out_of_time(self) -> bool:
        """Whether the budget is spent (:meth:`time_left` never says so: it keeps 1 ms)."""
        return time.perf_counter() - self.t_start > self.max_time


def sigma_weights(
    n: int, sigma_t: ArrayLike | None, sigma_theta: ArrayLike | None
) -> tuple[FloatArray, FloatArray]:
    """Variances ``(sigma_t^2, sigma_theta^2)`` per platform, shape (n,) each."""
    if sigma_t is None or sigma_theta is None:
        raise ValueError('objective="weighted" needs sigma_t [mm] and sigma_theta [rad]')
    st = np.broadcast_to(np.asarray(sigma_t, dtype=float), (n,)).copy()
    sth = np.broadcast_to(np.asarray(sigma_theta, dtype=float), (n,)).copy()
    if not (np.all(np.isfinite(st)) and np.all(np.isfinite(sth))):
        raise ValueError("sigma_t, sigma_theta: must be finite")
    if np.any(st < 0) or np.any(sth <= 0):
        raise ValueError("sigma_t must be >= 0 and sigma_theta > 0")
    return st**2, sth**2


def _first_start(stack: Stack, target: Target, mode: Mode, x0: Any, start: str) -> FloatArray:
    n, k = stack.n, mode.k
    if x0 is not None:
        return finite_array(x0, "x0", (n, k))  # (n, 3) planar, (n, 6) spatial
    if start == "convex":
        from stackik.convex import ConvexStartError, convex_start

        try:
            return convex_start(stack, target)
        except ConvexStartError:  # no convex start for these rotations: the paper's guess
            pass
    return paper_initial_guess(stack, target)


def _check_scalars(stack: Any, max_time: Any, objective: Any, starts: Any, start: Any) -> float:
    if not isinstance(stack, Stack):
        raise ValueError(f"stack: expected a Stack, got {type(stack).__name__}")
    if max_time is None:
        max_time = 10.0 + 2.0 * stack.n
    if not (isinstance(max_time, int | float) and max_time > 0):
        raise ValueError(f"max_time: expected a positive number of seconds, got {max_time!r}")
    if objective not in OBJECTIVES:
        raise ValueError(f"objective: unknown {objective!r}; choose one of {OBJECTIVES}")
    if starts is not None and (
        isinstance(starts, bool) or not isinstance(starts, int | np.integer) or starts < 1
    ):
        raise ValueError(f"starts: expected an integer >= 1, got {starts!r}")
    if start not in ("paper", "convex"):
        raise ValueError(f"start: unknown {start!r}; choose 'paper' or 'convex'")
    return float(max_time)


def check_force_weight(force_weight: Any, objective: str) -> float:
    """``solve_ik``'s ``force_weight`` [mm^2] as a float ``>= 0``; ValueError naming it for
    a negative, non-finite or non-number value, or a positive one with
    ``objective="force"`` (whose objective is the force term alone)."""
    ok = isinstance(force_weight, int | float | np.integer | np.floating)
    if not ok or isinstance(force_weight, bool):
        raise ValueError(f"force_weight: expected a number >= 0, got {force_weight!r}")
    w = float(force_weight)
    if not (math.isfinite(w) and w >= 0.0):
        raise ValueError(f"force_weight: expected a finite number >= 0, got {force_weight!r}")
    if w > 0.0 and objective == "force":
        raise ValueError(
            'force_weight: objective="force" already minimises the leg forces; '
            'add force_weight to "frobenius", "weighted" or "feasible"'
        )
    return w


def build_request(
    stack: Stack,
    target: Target,
    *,
    objective: str,
    method: str,
    qp_solver: str | None,
    x0: ArrayLike | None,
    starts: int | None,
    rng: Any,
    options: dict[str, Any] | None,
    sigma_t: ArrayLike | None,
    sigma_theta: ArrayLike | None,
    start: str,
    max_time: float | None,
    t_start: float,
    blas: BlasLimit,
    load: Load | None = None,
    obstacles: Any = (),
    clearance: float = 0.0,
    force_weight: float = 0.0,
    constraints: Any = (),
) -> Request:
    """Validate the arguments of :func:`stackik.solve_ik` and formulate the problem."""
    budget = _check_scalars(stack, max_time, objective, starts, start)
    weight = check_force_weight(force_weight, objective)
    mode = mode_of(target)
    if method != AUTO:
        get_method(method)  # unknown names: ValueError listing the choices
    auto = method == AUTO
    chosen = get_method(
        auto_method(mode.planar, objective, sigma_theta, qp_solver, options, weight)
        if auto
        else method
    )
    if chosen.uses_blas:
        blas.apply()
    if chosen.name == "sqp" and qp_solver is not None:
        from stackik.sqp.qp import make_backend

        make_backend(qp_solver)  # raises ValueError listing the available ones
    sampler = StartSampler(stack, mode, rng)  # a bad rng: ValueError before any work
    weights = sigma_weights(stack.n, sigma_t, sigma_theta) if objective == "weighted" else None
    q0 = _first_start(stack, target, mode, x0, start)
    sampler.q0 = q0
    if load is not None and not isinstance(load, Load):
        raise ValueError(f"load: expected a stackik.Load or None, got {type(load).__name__}")
    prob = Problem(
        stack, target, objective, weights, load=load, obstacles=obstacles,
        clearance=clearance, force_weight=weight, constraints=constraints,
    )  # fmt: skip
    reason = chosen.supports(prob)
    if reason is not None:
        raise ValueError(reason)
    opts = dict(options or {})
    if chosen.name in ("sqp", "ip"):
        chosen.check_options(opts)  # bad options are reported before any solve
    return Request(
        stack=stack,
        target=target,
        mode=mode,
        objective=objective,
        method=chosen,
        auto=auto,
        qp_solver=qp_solver,
        q0=q0,
        structured=x0 is None and start == "paper",
        x0_given=x0 is not None,
        start=start,
        starts=None if starts is None else int(starts),
        sampler=sampler,
        options=opts,
        weights=weights,
        problem=prob,
        max_time=budget,
        t_start=t_start,
        blas=blas,
    )
