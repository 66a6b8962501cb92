"""``method="sqp"``: stackik's SQP engine (:mod:`stackik.sqp`) with any QP backend."""

from __future__ import annotations

import math
from dataclasses import fields
from typing import Any, ClassVar

import numpy as np

from stackik.formulation import Problem
from stackik.formulation.lifted import LiftedPlanarNLP
from stackik.formulation.structured import ReducedPlanarNLP
from stackik.methods._sqp_compiled import CompiledNLP, compiled_supported
from stackik.methods.base import FloatArray, Method
from stackik.result import OptionError
from stackik.sqp import NonlinearProgram, SQPOptions, default_qp_solver, solve
from stackik.sqp.qp import SPARSE_BACKENDS

#: ``options["formulation"]`` values: ``"auto"`` (spatial: ``"sparse"``; planar:
#: ``"sparse"`` with OSQP, with Clarabel ``"sparse"`` below :data:`LIFTED_FROM` platforms
#: and ``"lifted"`` from there, else ``"dense"``), ``"dense"`` (dense Jacobians; spatial:
#: the NumPy evaluation with damped BFGS), ``"sparse"`` (the reduced problem with its
#: block-diagonal limit Jacobian and its exact, dense Hessian; spatial: the compiled
#: problem of :mod:`stackik.methods._sqp_compiled`),
#: ``"lifted"`` (chain states as variables, :mod:`stackik.formulation.lifted`: every matrix
#: O(n) sparse; the Hessian's 3x3 chain and limit blocks each made positive semidefinite),
#: ``"lifted-exact"`` (the same with the exact Hessian, convexified by the engine).
FORMULATIONS = ("auto", "dense", "sparse", "lifted", "lifted-exact")
#: From this many platforms ``"auto"`` lifts: the reduced problem's dense (3n)^2 Hessian
#: then costs the QPs more than the lifted problem's extra iterations (docs/benchmarks.md).
LIFTED_FROM = 48
#: OSQP's ADMM iteration cap in this method (the engine's default is 10,000): past it the
#: approximate solution is used as a step and judged by the ratio test.
OSQP_MAX_ITER = 4000
#: OSQP settings of this method (with ``max_iter``): each QP is first solved to 1e-4 and
#: kept when OSQP's polishing succeeds (the polished solution is the exact one on the
#: active set ADMM found), else ADMM continues to the engine's 1e-6
#: (:data:`stackik.sqp.qp.osqp_.POLISH_FIRST`); no duality-gap termination test
#: (measurements: docs/benchmarks.md).
OSQP_OPTIONS: dict[str, Any] = {
    "max_iter": OSQP_MAX_ITER,
    "polish_first": 1e-4,
    "check_dualgap": False,
}
#: Clarabel settings of this method: no iterative refinement of its KKT solves (the IK
#: subproblems are well conditioned; the engine's default keeps it, which
#: Hock-Schittkowski needs; docs/benchmarks.md).
CLARABEL_OPTIONS = {"iterative_refinement_enable": False}
#: With Clarabel, the QPs keep every limit row below this many platforms
#: (``SQPOptions.qp_screening=False``): one solver updated in place beats one rebuilt
#: whenever the screened row set grows; from about 16 platforms the smaller screened QPs
#: win (docs/benchmarks.md).
CLARABEL_SCREEN_FROM = 12

__all__ = ["SQPMethod", "sqp_options"]


def sqp_options(opts: dict[str, Any]) -> SQPOptions:
    """``SQPOptions(**opts)``, with bad options reported as :class:`OptionError`."""
    try:
        return SQPOptions(**opts)
    except TypeError as exc:  # an unknown keyword
        known = sorted(f.name for f in fields(SQPOptions))
        raise OptionError(f"options: {exc}; SQP options are {known}") from None
    except ValueError as exc:
        raise OptionError(f"options: {exc}") from None


class SQPMethod(Method):
    """Trust-region SQP: linearised target equalities and limits, a convex QP per step.

    Exact Lagrangian Hessian in spatial mode (the compiled problem of the spatial interior
    point, every objective) and in planar mode (``"frobenius"``, ``"feasible"``, or
    ``"weighted"`` with one ``sigma_theta``); damped BFGS otherwise (Gauss-Newton ignores
    the curvature of active limits and stalls there); in spatial mode the exact Hessian
    takes about 4x fewer iterations than BFGS (docs/benchmarks.md). With OSQP or
    Clarabel the problem is passed with its sparsity (``options["formulation"]``,
    :data:`FORMULATIONS`);
    ``options`` are otherwise :class:`stackik.sqp.SQPOptions` fields, e.g.
    ``barrier_start=True`` for the interior start phase (better local minima from one
    start, more iterations).
    """

    name: ClassVar[str] = "sqp"

    def check_options(self, options: dict[str, Any]) -> dict[str, Any]:
        opts = dict(options)
        form = opts.pop("formulation", "auto")
        if form not in FORMULATIONS:
            raise OptionError(f"options: formulation must be one of {FORMULATIONS}, got {form!r}")
        sqp_options(opts)
        return dict(options)

    def solve_with(
        self,
        prob: Problem,
        u0: FloatArray,
        options: dict[str, Any],
        time_left: float,
        qp_solver: str | None,
    ) -> tuple[FloatArray, int, str]:
        opts = dict(options)
        form = opts.pop("formulation", "auto")
        if "max_time" not in opts and math.isfinite(time_left):
            opts["max_time"] = max(time_left, 1e-3)
        name = (default_qp_solver() if qp_solver is None else qp_solver).strip().lower()
        if prob.dense_rows or prob.force_residuals is not None:
            # the force rows (stackik.formulation.forces) and the obstacle rows are dense
            # in the pose and come without second derivatives: the dense formulation with
            # damped BFGS
            form = "dense"
        if form == "auto":
            if not prob.planar:  # the compiled spatial problem, exact Hessian
                form = "sparse"
            elif name not in SPARSE_BACKENDS:
                form = "dense"
            else:  # OSQP's ADMM struggles with the lifted chain equalities (n = 64)
                lift = name == "clarabel" and prob.n >= LIFTED_FROM
                form = "lifted" if lift else "sparse"
        if name == "osqp" and "qp_options" not in opts:
            opts["qp_options"] = dict(OSQP_OPTIONS)
        if name == "clarabel" and "qp_options" not in opts:
            opts["qp_options"] = dict(CLARABEL_OPTIONS)
        if name == "clarabel" and prob.n < CLARABEL_SCREEN_FROM:
            opts.setdefault("qp_screening", False)
        evaluate: Any = prob.evaluate
        hessian: Any = prob.lagrangian_hessian
        gauss_newton: Any = prob.gauss_newton if prob.has_objective else None
        lifted: LiftedPlanarNLP | None = None
        x0 = u0
        # exact Hessians: planar (one FN weight) in every formulation, spatial in the
        # compiled one ("dense" keeps the NumPy evaluation with damped BFGS)
        exact = prob.planar and compiled_supported(prob) and not prob.dense_rows
        exact = exact and prob.force_residuals is None
        if form == "sparse" and (prob.fast is not None or not prob.planar):
            # the limit Jacobian as CSC, block diagonal by platform; values and Hessian
            # from the compiled kernels where they apply (spatial; planar with one FN
            # weight)
            structured: CompiledNLP | ReducedPlanarNLP = (
                CompiledNLP(prob) if compiled_supported(prob) else ReducedPlanarNLP(prob)
            )
            evaluate, hessian = structured.evaluate, structured.hessian
            exact = exact or not prob.planar
        elif form.startswith("lifted") and prob.fast is not None and exact:
            lifted = LiftedPlanarNLP(prob, psd_blocks=form == "lifted")
            evaluate, hessian, gauss_newton = lifted.evaluate, lifted.hessian, None
            x0 = lifted.lift(u0)
        n_eq = prob.es.size if lifted is None else 3 * prob.n
        nlp = NonlinearProgram(
            objective=None,
            evaluate=evaluate,
            hessian=hessian if exact else None,
            gauss_newton=gauss_newton,
            gn_scale=2.0,
            eq_scale=np.ones(n_eq),
            ineq_scale=np.ones(prob.n_ineq),
            name="stackik-ik",
        )
        run_opts: dict[str, Any] = {
            "tol": 1e-7,
            "constr_tol": 1e-10,
            "max_iter": max(200, 25 * prob.n),  # large stacks need more (observed ~10 n)
            "initial_tr_radius": 0.5,
        }
        if not exact:
            run_opts["hessian"] = "bfgs"
        run_opts.update(opts)
        kw: dict[str, Any] = {}
        if qp_solver is not None:
            kw["qp_solver"] = qp_solver
        res = solve(nlp, x0, options=sqp_options(run_opts), **kw)
        u = res.x if lifted is None else lifted.reduce(res.x)
        return u, res.nit, res.status.value

    def solve(
        self, prob: Problem, u0: FloatArray, options: dict[str, Any], time_left: float
    ) -> tuple[FloatArray, int, str]:
        return self.solve_with(prob, u0, options, time_left, None)
