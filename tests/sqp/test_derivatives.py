"""Finite-difference checks of every analytic derivative in the HS set."""

from __future__ import annotations

import numpy as np
import pytest

from stackik.sqp.hs import PROBLEMS


def _fd_jac(fun, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    f0 = np.atleast_1d(fun(x))
    J = np.zeros((f0.size, x.size))
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h
        J[:, j] = (np.atleast_1d(fun(x + e)) - np.atleast_1d(fun(x - e))) / (2 * h)
    return J


def _point(p) -> np.ndarray:
    rng = np.random.default_rng(p.number)
    x = p.x0 + 0.1 * rng.standard_normal(p.x0.size)
    lo, up = p.nlp.lower, p.nlp.upper
    if lo is not None:
        x = np.maximum(x, np.asarray(lo) + 1e-3)
    if up is not None:
        x = np.minimum(x, np.asarray(up) - 1e-3)
    return x


def _close(A: np.ndarray, B: np.ndarray) -> bool:
    return bool(np.max(np.abs(A - B), initial=0.0) <= 1e-5 * (1 + np.max(np.abs(B), initial=0)))


@pytest.mark.parametrize("number", sorted(PROBLEMS))
def test_first_derivatives(number: int) -> None:
    p = PROBLEMS[number]
    nlp = p.nlp
    x = _point(p)
    assert _close(nlp.gradient(x)[None, :], _fd_jac(nlp.objective, x))
    if nlp.eq is not None:
        assert _close(nlp.eq_jacobian(x), _fd_jac(nlp.eq, x))
    if nlp.ineq is not None:
        assert _close(nlp.ineq_jacobian(x), _fd_jac(nlp.ineq, x))


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

    assert _close(np.asarray(nlp.hessian(x, yE, yI)), _fd_jac(grad_lag, x))
