"""``method="slsqp"`` and ``method="trust-constr"``: scipy baselines on the same scaled
problem and analytic derivatives as stackik's own engines."""

from __future__ import annotations

import math
import time
from typing import Any, ClassVar

import numpy as np

from stackik.formulation import Problem
from stackik.methods.base import FloatArray, Method
from stackik.result import OptionError

__all__ = ["SLSQPMethod", "TrustConstrMethod"]


#: Options of the scipy baselines that stackik passes on, with their kind.
_SCIPY_OPTIONS: dict[str, dict[str, str]] = {
    "slsqp": {"maxiter": "int", "ftol": "pos", "eps": "pos", "disp": "bool"},
    "trust-constr": {
        "maxiter": "int",
        "gtol": "pos",
        "xtol": "pos",
        "barrier_tol": "pos",
        "initial_tr_radius": "pos",
        "initial_constr_penalty": "pos",
        "initial_barrier_parameter": "pos",
        "initial_barrier_tolerance": "pos",
        "verbose": "int0",
        "disp": "bool",
    },
}


def _check_scipy_options(method: str, options: dict[str, Any]) -> None:
    allowed = _SCIPY_OPTIONS[method]
    for key, value in options.items():
        kind = allowed.get(key)
        if kind is None:
            raise OptionError(f"options: {key!r} is not a {method} option; use {sorted(allowed)}")
        if kind == "bool":
            ok = isinstance(value, bool)
        elif kind in ("int", "int0"):
            ok = isinstance(value, int | np.integer) and not isinstance(value, bool)
            ok = ok and value >= (1 if kind == "int" else 0)
        else:
            ok = isinstance(value, int | float) and not isinstance(value, bool)
            ok = ok and math.isfinite(value) and value > 0
        if not ok:
            raise OptionError(f"options: bad value {value!r} for {method} option {key!r}")


def _run_scipy(
    prob: Problem,
    u0: FloatArray,
    method: str,
    options: dict[str, Any],
    time_left: float = math.inf,
) -> tuple[FloatArray, int, str]:
    from scipy.optimize import NonlinearConstraint, minimize

    _check_scipy_options(method, options)
    deadline = time.perf_counter() + time_left

    def stop_at_deadline(*_: Any) -> None:
        if time.perf_counter() > deadline:
            raise StopIteration  # scipy ends the run and returns the current point

    def fun(u: FloatArray) -> float:
        return float(prob.evaluate(u)[0])

    def jac(u: FloatArray) -> FloatArray:
        return prob.evaluate(u)[1]  # type: ignore[no-any-return]

    if method == "slsqp":
        cons = [
            {
                "type": "eq",
                "fun": lambda u: prob.evaluate(u)[2],
                "jac": lambda u: prob.evaluate(u)[3],
            },
            {
                "type": "ineq",
                "fun": lambda u: prob.evaluate(u)[4],
                "jac": lambda u: prob.evaluate(u)[5],
            },
        ]
        opts = {"maxiter": 500, "ftol": 1e-12}
        opts.update(options)
        r = minimize(
            fun,
            u0,
            jac=jac,
            constraints=cons,
            method="SLSQP",
            options=opts,
            callback=stop_at_deadline,
        )
        return r.x, int(r.nit), "success" if r.success else str(r.message)

    def hess(u: FloatArray) -> FloatArray:
        if not prob.has_objective:
            return np.zeros((u.size, u.size))
        _, Jr = prob.gauss_newton(u)
        return 2.0 * Jr.T @ Jr  # type: ignore[no-any-return]

    zero_h = lambda u, v: np.zeros((u.size, u.size))  # noqa: E731
    cons_tc = [
        NonlinearConstraint(
            lambda u: prob.evaluate(u)[2], 0.0, 0.0, jac=lambda u: prob.evaluate(u)[3], hess=zero_h
        ),
        NonlinearConstraint(
            lambda u: prob.evaluate(u)[4],
            0.0,
            np.inf,
            jac=lambda u: prob.evaluate(u)[5],
            hess=zero_h,
        ),
    ]
    opts = {"maxiter": 1000, "gtol": 1e-9, "xtol": 1e-12}
    opts.update(options)
    r = minimize(
        fun,
        u0,
        jac=jac,
        hess=hess,
        constraints=cons_tc,
        method="trust-constr",
        options=opts,
        callback=stop_at_deadline,
    )
    return r.x, int(r.nit), "success" if r.status in (1, 2) else str(r.message)


class _ScipyMethod(Method):
    def check_options(self, options: dict[str, Any]) -> dict[str, Any]:
        _check_scipy_options(self.name, options)
        return dict(options)

    def solve(
        self, prob: Problem, u0: FloatArray, options: dict[str, Any], time_left: float
    ) -> tuple[FloatArray, int, str]:
        return _run_scipy(prob, u0, self.name, options, time_left)


class SLSQPMethod(_ScipyMethod):
    """SciPy's SLSQP (dense least-squares QP subproblems)."""

    name: ClassVar[str] = "slsqp"


class TrustConstrMethod(_ScipyMethod):
    """SciPy's trust-constr (equality-constrained SQP inside a barrier), Gauss-Newton
    Hessian of the objective."""

    name: ClassVar[str] = "trust-constr"
