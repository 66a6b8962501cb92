"""``method="sqp"``: stackik's SQP engine (:mod:`stackik.sqp`) with any QP backend."""

from __future__ import annotations

import math
from dataclasses import fields
from typing import Any, ClassVar

import numpy as np

from stackik.formulation import Problem
from stackik.formulation.structured import ReducedPlanarNLP
from stackik.methods.base import FloatArray, Method
from stackik.result import OptionError
from stackik.sqp import NonlinearProgram, SQPOptions, default_qp_solver, solve
from stackik.sqp.qp import SPARSE_BACKENDS

#: ``options["formulation"]`` values: ``"auto"`` (sparse when the QP backend is),
#: ``"dense"`` (dense Jacobians), ``"sparse"`` (block-diagonal limit Jacobian).
FORMULATIONS = ("auto", "dense", "sparse")

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

    Exact Lagrangian Hessian in planar mode (``"frobenius"``, ``"feasible"``, or
    ``"weighted"`` with one ``sigma_theta``); damped BFGS otherwise (Gauss-Newton ignores
    the curvature of active limits and stalls there).
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
        exact = prob.fast is not None and (prob.objective != "weighted" or np.ptp(prob.w_th) == 0)
        name = default_qp_solver() if qp_solver is None else qp_solver
        if form == "auto":
            form = "sparse" if name.strip().lower() in SPARSE_BACKENDS else "dense"
        evaluate: Any = prob.evaluate
        hessian: Any = prob.lagrangian_hessian
        if form == "sparse" and prob.fast is not None:
            # planar: the limit Jacobian as CSC, block diagonal by platform
            structured = ReducedPlanarNLP(prob)
            evaluate, hessian = structured.evaluate, structured.hessian
        nlp = NonlinearProgram(
            objective=None,
            evaluate=evaluate,
            hessian=hessian if exact else None,
            gauss_newton=None if prob.objective == "feasible" else prob.gauss_newton,
            gn_scale=2.0,
            eq_scale=np.ones(prob.es.size),
            ineq_scale=np.ones(prob.cs.size),
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
        res = solve(nlp, u0, options=sqp_options(run_opts), **kw)
        return res.x, res.nit, res.status.value

    def solve(
        self, prob: Problem, u0: FloatArray, options: dict[str, Any], time_left: float
    ) -> tuple[FloatArray, int, str]:
        return self.solve_with(prob, u0, options, time_left, None)
