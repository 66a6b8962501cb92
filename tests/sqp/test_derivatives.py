"""Finite-difference checks of every analytic derivative in the HS set.

Tolerances from the step and the function's scale (tests/fd.py): the HS functions have no
physical scale, so F is the size of their terms under a first-order model
(:func:`fd.term_scale`), and the truncation error is measured by Richardson's difference
(polynomials such as Rosenbrock's curve far more than F / X^3 suggests). The Hessians are
checked against Richardson-extrapolated differences of the gradient (bounds ~100x tighter).
"""

from __future__ import annotations

import fd
import numpy as np
import pytest
from hs_problems import PROBLEMS

pytestmark = pytest.mark.derivatives


def _point(p) -> np.ndarray:
    rng = np.random.default_rng(p.number)
    x = p.x0 + 0.1 * rng.standard_normal(p.x0.size)
    lo, up = p.nlp.lower, p.nlp.upper
    if lo is not None:
        x = np.maximum(x, np.asarray(lo) + 1e-3)
    if up is not None:
        x = np.minimum(x, np.asarray(up) - 1e-3)
    return x


def _vector(fun):
    return lambda z: np.atleast_1d(np.asarray(fun(z), dtype=float))


def _check(analytic, fun, x: np.ndarray, what: str) -> np.ndarray:
    """Assert analytic ~ d fun / dx; return the scale F of fun (one per component)."""
    num = fd.central(_vector(fun), x)
    F = fd.term_scale(_vector(fun)(x), num)
    fd.assert_derivative_close(np.reshape(analytic, num.shape), num, f_scale=F, what=what)
    return F


@pytest.mark.parametrize("number", sorted(PROBLEMS))
def test_first_derivatives(number: int) -> None:
    p = PROBLEMS[number]
    nlp = p.nlp
    x = _point(p)
    _check(nlp.gradient(x)[None, :], nlp.objective, x, "gradient")
    if nlp.eq is not None:
        _check(nlp.eq_jacobian(x), nlp.eq, x, "eq Jacobian")
    if nlp.ineq is not None:
        _check(nlp.ineq_jacobian(x), nlp.ineq, x, "ineq Jacobian")


def _scale(fun, x: np.ndarray) -> np.ndarray:
    return fd.term_scale(_vector(fun)(x), fd.central(_vector(fun), x))


@pytest.mark.parametrize("number", sorted(n for n, p in PROBLEMS.items() if p.has_hessian))
def test_hessian(number: int) -> None:
    p = PROBLEMS[number]
    nlp = p.nlp
    x = _point(p)
    rng = np.random.default_rng(1000 + number)
    mE = 0 if nlp.eq is None else nlp.eq(x).size
    mI = 0 if nlp.ineq is None else nlp.ineq(x).size
    yE, yI = rng.standard_normal(mE), rng.random(mI)

    def grad_lag(z: np.ndarray) -> np.ndarray:
        g = nlp.gradient(z).astype(float)
        if mE:
            g = g - nlp.eq_jacobian(z).T @ yE
        if mI:
            g = g - nlp.ineq_jacobian(z).T @ yI
        return g

    # the Lagrangian's scale: its terms f, yE.cE and yI.cI may cancel one another
    F_lag = float(_scale(nlp.objective, x).sum())
    if mE:
        F_lag += float(np.abs(yE) @ _scale(nlp.eq, x))
    if mI:
        F_lag += float(np.abs(yI) @ _scale(nlp.ineq, x))
    num = fd.central(grad_lag, x, richardson=True)
    F_rows = fd.derivative_scale(F_lag, num.x_scale)  # gradient rows: F / X_a
    H = np.asarray(nlp.hessian(x, yE, yI), dtype=float)
    fd.assert_derivative_close(H, num, f_scale=F_rows, what="Lagrangian Hessian")
