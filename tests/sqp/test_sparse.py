"""The SQP engine's sparse mode: fixed CSC patterns, sparse backends, sparse IK problem."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp
from hs_problems import PROBLEMS

from stackik.sqp import NonlinearProgram, SQPOptions, solve
from stackik.sqp.sparse import FixedPattern, StackedPattern, positive_definite

SOLVERS = ("daqp", "osqp", "clarabel")


def _sparsify(nlp: NonlinearProgram, drop_zeros: bool = True) -> NonlinearProgram:
    """The same problem with CSC Jacobians and Hessian (zeros dropped: changing patterns)."""

    def as_csc(M: np.ndarray) -> sp.csc_matrix:
        A = sp.csc_matrix(np.atleast_2d(M))
        if drop_zeros:
            A.eliminate_zeros()
        return A

    kw = {}
    if nlp.eq_jacobian is not None:
        kw["eq_jacobian"] = lambda x, f=nlp.eq_jacobian: as_csc(f(x))
    if nlp.ineq_jacobian is not None:
        kw["ineq_jacobian"] = lambda x, f=nlp.ineq_jacobian: as_csc(f(x))
    if nlp.hessian is not None:
        kw["hessian"] = lambda x, a, b, f=nlp.hessian: as_csc(f(x, a, b))
    return dataclasses.replace(nlp, **kw)


def _ok(fun: float, f_star: float) -> bool:
    if f_star == 0.0:
        return abs(fun) <= 1e-6
    return abs(fun - f_star) <= 1e-5 * abs(f_star)


#: problems with constraints and (mostly) exact Hessians, a quick sample of the suite
SAMPLE = (6, 7, 14, 21, 35, 39, 43, 65, 71, 76, 100)


@pytest.mark.parametrize("solver", SOLVERS)
def test_hs_sample_sparse_matches_dense(solver: str) -> None:
    for number in SAMPLE:
        p = PROBLEMS[number]
        dense = solve(p.nlp, p.x0, qp_solver=solver)
        sparse = solve(_sparsify(p.nlp), p.x0, qp_solver=solver)
        assert (dense.success and _ok(dense.fun, p.f_star)) == (
            sparse.success and _ok(sparse.fun, p.f_star)
        ), number
        if sparse.success:
            assert sparse.max_violation <= SQPOptions().constr_tol


def test_fixed_pattern_grows_to_the_union_and_keeps_arrays() -> None:
    pat = FixedPattern((3, 2))
    A = pat.fit(sp.csc_matrix(np.array([[1.0, 0.0], [0.0, 0.0], [2.0, 3.0]])))
    B = pat.fit(sp.csc_matrix(np.array([[4.0, 0.0], [0.0, 0.0], [5.0, 6.0]])))
    assert B.indices is A.indices and B.indptr is A.indptr  # same pattern: same arrays
    C = pat.fit(sp.csc_matrix(np.array([[0.0, 7.0], [0.0, 0.0], [8.0, 0.0]])))
    np.testing.assert_array_equal(C.toarray(), [[0, 7], [0, 0], [8, 0]])
    assert C.nnz == 4  # union of both patterns, zeros kept
    D = pat.fit(np.arange(6.0).reshape(3, 2))  # dense: every entry
    np.testing.assert_array_equal(D.toarray(), np.arange(6.0).reshape(3, 2))


def test_stacked_pattern() -> None:
    rng = np.random.default_rng(0)
    top = sp.random(2, 5, density=0.5, format="csc", random_state=1)
    bottom = sp.random(4, 5, density=0.3, format="csc", random_state=2)
    st = StackedPattern(2, 4, 5)
    S = st.stack(top, bottom)
    np.testing.assert_array_equal(S.toarray(), np.vstack([top.toarray(), bottom.toarray()]))
    top.data[:] = rng.normal(size=top.nnz)
    S2 = st.stack(top, bottom)
    assert S2.indices is S.indices
    np.testing.assert_array_equal(S2.toarray(), np.vstack([top.toarray(), bottom.toarray()]))


def test_positive_definite() -> None:
    assert positive_definite(sp.csc_matrix(np.array([[2.0, 1.0], [1.0, 2.0]])))
    assert not positive_definite(sp.csc_matrix(np.array([[1.0, 2.0], [2.0, 1.0]])))
    assert not positive_definite(sp.csc_matrix(np.zeros((2, 2))))


def _banded(n: int) -> NonlinearProgram:
    """min sum (x_i - 1)^4 + x_i^2 s.t. x_i + x_{i+1} >= 1 (banded Jacobian), sum x = n/2."""

    def evaluate(x: np.ndarray) -> tuple:
        f = float(np.sum((x - 1.0) ** 4 + x**2))
        g = 4.0 * (x - 1.0) ** 3 + 2.0 * x
        cE = np.array([x.sum() - n / 2])
        JE = sp.csc_matrix(np.ones((1, n)))
        cI = x[:-1] + x[1:] - 1.0
        JI = sp.diags([np.ones(n - 1), np.ones(n - 1)], [0, 1], shape=(n - 1, n), format="csc")
        return f, g, cE, JE, cI, JI

    def hessian(x: np.ndarray, yE: np.ndarray, yI: np.ndarray) -> sp.csc_matrix:
        return sp.diags(12.0 * (x - 1.0) ** 2 + 2.0, format="csc")

    return NonlinearProgram(objective=None, evaluate=evaluate, hessian=hessian)


@pytest.mark.parametrize("solver", SOLVERS)
def test_banded_problem_sparse(solver: str) -> None:
    n = 200
    res = solve(_banded(n), np.zeros(n), qp_solver=solver)
    assert res.success, res.message
    np.testing.assert_allclose(res.x, 0.5, atol=1e-5)


def test_interior_start_option_on_hs() -> None:
    """barrier_start: same answers on inequality-constrained textbook problems."""
    opts = SQPOptions(barrier_start=True)
    for number in (35, 43, 65, 71, 100):
        p = PROBLEMS[number]
        res = solve(p.nlp, p.x0, options=opts)
        assert res.success, (number, res.message)
        assert _ok(res.fun, p.f_star), number
        assert res.max_violation <= opts.constr_tol


def test_adaptive_accuracy_option() -> None:
    with pytest.raises(ValueError, match="qp_accuracy"):
        SQPOptions(qp_accuracy="loose")
    p = PROBLEMS[71]
    res = solve(p.nlp, p.x0, qp_solver="osqp", options=SQPOptions(qp_accuracy="adaptive"))
    assert res.success and _ok(res.fun, p.f_star)
