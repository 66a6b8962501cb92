"""Statuses, options, backends and Hessian strategies of the SQP engine."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hs_problems import PROBLEMS

from stackik.sqp import (
    Evaluation,
    NonlinearProgram,
    SQPOptions,
    SQPStatus,
    available_qp_solvers,
    solve,
)
from stackik.sqp.qp import QPSolution, QPStatus, make_backend
from stackik.sqp.qp.daqp_ import DAQPBackend


def _infeasible() -> NonlinearProgram:
    # x'x <= 1 and x1 + x2 >= 3 cannot both hold.
    return NonlinearProgram(
        lambda x: float(x @ x),
        lambda x: 2 * x,
        ineq=lambda x: np.array([1 - x @ x, x[0] + x[1] - 3]),
        ineq_jacobian=lambda x: np.array([-2 * x, [1.0, 1.0]]),
    )


@pytest.mark.parametrize("solver", ["daqp", "osqp"])
def test_infeasible_status(solver: str) -> None:
    res = solve(_infeasible(), [0.3, -0.2], qp_solver=solver)
    assert res.status is SQPStatus.INFEASIBLE
    assert not res.success
    assert res.max_violation > 1.0
    # The least-violation point is close to the arc's point nearest to x1 + x2 = 3.
    assert res.x.sum() > 1.3


def test_osqp_elastic_backend_is_capped(monkeypatch: pytest.MonkeyPatch) -> None:
    # the engine calls for_elastic() on the backend of the elastic subproblems only; OSQP
    # then caps its ADMM iterations unless the user set max_iter
    from stackik.sqp.qp import osqp_

    made: list[osqp_.OSQPBackend] = []
    orig = osqp_.OSQPBackend.setup

    def spy(self: osqp_.OSQPBackend, n: int, m_eq: int, m_ineq: int) -> None:
        made.append(self)
        orig(self, n, m_eq, m_ineq)

    monkeypatch.setattr(osqp_.OSQPBackend, "setup", spy)
    res = solve(_infeasible(), [0.3, -0.2], qp_solver="osqp")
    assert res.status is SQPStatus.INFEASIBLE
    caps = {be.n: be.settings["max_iter"] for be in made}
    assert caps[2] == osqp_.DEFAULT_SETTINGS["max_iter"]  # the plain QP: full budget
    assert any(c == osqp_.ELASTIC_MAX_ITER for n, c in caps.items() if n > 2)
    user = make_backend("osqp", {"max_iter": 50000})
    user.for_elastic()
    assert user.settings["max_iter"] == 50000
    plain = make_backend("daqp")
    plain.for_elastic()  # the default is a no-op


def test_infeasible_equality() -> None:
    nlp = NonlinearProgram(
        lambda x: float(x[0]),
        lambda x: np.array([1.0, 0.0]),
        eq=lambda x: np.array([x @ x + 1]),
        eq_jacobian=lambda x: np.array([2 * x]),
    )
    res = solve(nlp, [0.3, -0.2])
    assert res.status is SQPStatus.INFEASIBLE
    assert np.linalg.norm(res.x) < 1e-3


def test_max_iter() -> None:
    p = PROBLEMS[71]
    res = solve(p.nlp, p.x0, options=SQPOptions(max_iter=1))
    assert res.status is SQPStatus.MAX_ITER
    assert res.nit == 1
    assert not res.success


def test_max_time() -> None:
    p = PROBLEMS[71]
    res = solve(p.nlp, p.x0, options=SQPOptions(max_time=1e-12))
    assert res.status is SQPStatus.MAX_TIME
    assert not res.success


def test_numerical_error() -> None:
    nlp = NonlinearProgram(lambda x: float("nan"), lambda x: np.zeros(2))
    res = solve(nlp, [1.0, 2.0])
    assert res.status is SQPStatus.NUMERICAL_ERROR


def test_small_step_status() -> None:
    # Objective with a wrong gradient: the model never predicts what f does.
    nlp = NonlinearProgram(lambda x: float(x @ x), lambda x: -2 * x - 1.0)
    res = solve(nlp, [1.0, 1.0])
    assert res.status is SQPStatus.SMALL_STEP
    assert not res.success


def test_qp_failure_and_fallback(monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(self, *args, **kwargs) -> QPSolution:  # noqa: ANN001
        return self.failed("monkeypatched failure")

    monkeypatch.setattr(DAQPBackend, "solve", broken)
    monkeypatch.setattr(DAQPBackend, "solve_sqp", broken)
    p = PROBLEMS[71]
    res = solve(p.nlp, p.x0, qp_solver="daqp")
    assert res.status is SQPStatus.QP_FAILURE
    assert "monkeypatched" in res.message
    res = solve(p.nlp, p.x0, qp_solver="daqp", options=SQPOptions(fallback_qp_solver="osqp"))
    assert res.success
    assert abs(res.fun - p.f_star) <= 1e-5 * abs(p.f_star)


def test_unknown_solver() -> None:
    p = PROBLEMS[71]
    with pytest.raises(ValueError, match="available"):
        solve(p.nlp, p.x0, qp_solver="no-such-solver")
    with pytest.raises(ValueError, match="available"):
        make_backend("qpsolvers:no-such-solver")
    assert available_qp_solvers()[0] == "daqp"


def test_qpsolvers_backend() -> None:
    p = PROBLEMS[35]
    name = next(s for s in available_qp_solvers() if s.startswith("qpsolvers:"))
    res = solve(p.nlp, p.x0, qp_solver=name)
    assert res.qp_solver == name
    assert res.status in (SQPStatus.SUCCESS, SQPStatus.SMALL_STEP)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("tol", 0.0),
        ("tol", -1.0),
        ("constr_tol", float("nan")),
        ("max_iter", 0),
        ("max_iter", 2.5),
        ("max_time", 0.0),
        ("initial_tr_radius", -1.0),
        ("max_tr_radius", 0.0),
        ("hessian", "newton"),
        ("verbose", 3),
        ("fallback_qp_solver", 3),
        ("qp_options", []),
        ("scaling", "yes"),
    ],
)
def test_option_validation(field: str, value: object) -> None:
    with pytest.raises(ValueError, match=field):
        SQPOptions(**{field: value})


def test_options_frozen_and_radius_order() -> None:
    opts = SQPOptions()
    with pytest.raises(AttributeError):
        opts.tol = 1.0  # type: ignore[misc]
    with pytest.raises(ValueError, match="initial_tr_radius"):
        SQPOptions(initial_tr_radius=10.0, max_tr_radius=1.0)


def test_problem_validation() -> None:
    with pytest.raises(ValueError, match="objective"):
        NonlinearProgram(None)
    with pytest.raises(ValueError, match="eq_jacobian"):
        NonlinearProgram(lambda x: 0.0, lambda x: x, eq=lambda x: x)
    with pytest.raises(ValueError, match="gauss_newton"):
        solve(PROBLEMS[71].nlp, PROBLEMS[71].x0, options=SQPOptions(hessian="gauss-newton"))


def _rosen_gn(constrained: bool, use_evaluate: bool) -> NonlinearProgram:
    def r_jr(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r = np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]])
        Jr = np.array([[-20 * x[0], 10.0], [-1.0, 0.0]])
        return r, Jr

    def f(x: np.ndarray) -> float:
        r, _ = r_jr(x)
        return float(r @ r)

    def g(x: np.ndarray) -> np.ndarray:
        r, Jr = r_jr(x)
        return 2 * Jr.T @ r

    ineq = (lambda x: np.array([1.5 - x @ x])) if constrained else None
    ineq_j = (lambda x: np.array([-2 * x])) if constrained else None
    if use_evaluate:

        def evaluate(x: np.ndarray) -> Evaluation:
            return Evaluation(
                f(x),
                g(x),
                None,
                None,
                None if ineq is None else ineq(x),
                None if ineq_j is None else ineq_j(x),
            )

        return NonlinearProgram(None, evaluate=evaluate, gauss_newton=r_jr, gn_scale=2.0)
    return NonlinearProgram(f, g, ineq=ineq, ineq_jacobian=ineq_j, gauss_newton=r_jr, gn_scale=2.0)


@pytest.mark.parametrize("use_evaluate", [False, True])
def test_gauss_newton(use_evaluate: bool) -> None:
    res = solve(_rosen_gn(False, use_evaluate), [-1.2, 1.0])
    assert res.success
    assert np.allclose(res.x, [1.0, 1.0], atol=1e-5)


def test_gauss_newton_constrained_matches_bfgs() -> None:
    gn = solve(_rosen_gn(True, False), [-1.2, 1.0], options=SQPOptions(hessian="gauss-newton"))
    bf = solve(_rosen_gn(True, False), [-1.2, 1.0], options=SQPOptions(hessian="bfgs"))
    assert gn.success and bf.success
    assert abs(gn.fun - bf.fun) <= 1e-6 * (1 + abs(bf.fun))


def test_evaluate_tuple_and_scaling() -> None:
    p = PROBLEMS[71]
    nlp0 = p.nlp

    def evaluate(x: np.ndarray) -> tuple:
        return (
            nlp0.objective(x),
            nlp0.gradient(x),
            nlp0.eq(x),
            nlp0.eq_jacobian(x),
            nlp0.ineq(x),
            nlp0.ineq_jacobian(x),
        )

    nlp = NonlinearProgram(
        None,
        evaluate=evaluate,
        lower=nlp0.lower,
        upper=nlp0.upper,
        eq_scale=[0.1],
        ineq_scale=[0.01],
    )
    res = solve(nlp, p.x0, qp_solver="clarabel")
    assert res.success
    assert abs(res.fun - p.f_star) <= 1e-5 * p.f_star


def test_result_fields_and_verbose(capsys: pytest.CaptureFixture[str]) -> None:
    p = PROBLEMS[43]
    res = solve(p.nlp, p.x0, options=SQPOptions(verbose=2))
    out = capsys.readouterr().out
    assert "it" in out and "success" in out
    assert res.y_ineq.shape == (3,) and res.y_eq.shape == (0,)
    for t in (res.time_eval, res.time_qp_build, res.time_qp_solve):
        assert 0.0 <= t <= res.time_total
    assert res.nfev >= res.nit >= 1
    assert math.isfinite(res.kkt_residual) and res.tr_radius > 0
    with pytest.raises(AttributeError):
        res.x = None  # type: ignore[misc]


def test_backend_interface_directly() -> None:
    # min 0.5|d|^2 - d1 s.t. d1 + d2 = 1, d1 <= 0.25 (as G d <= h), |d| <= 10.
    for name in ("daqp", "osqp", "clarabel"):
        be = make_backend(name)
        be.setup(2, 1, 1)
        sol = be.solve(
            np.eye(2),
            np.array([-1.0, 0.0]),
            np.array([[1.0, 1.0]]),
            np.array([1.0]),
            np.array([[1.0, 0.0]]),
            np.array([0.25]),
            np.full(2, -10.0),
            np.full(2, 10.0),
        )
        assert sol.status is QPStatus.SOLVED, name
        assert np.allclose(sol.x, [0.25, 0.75], atol=1e-6), name
        stat = np.eye(2) @ sol.x + np.array([-1.0, 0.0])
        stat += np.array([[1.0, 1.0]]).T @ sol.y_eq + np.array([[1.0, 0.0]]).T @ sol.y_ineq
        stat += sol.y_bounds
        assert np.allclose(stat, 0, atol=1e-6), name
        assert sol.y_ineq[0] > 0


def test_backend_solve_sqp_matches_solve() -> None:
    # The SQP form c + J d (=, >=) 0 is solve() with A_eq = J_E, b_eq = -c_E, G = -J_I,
    # h = c_I: same solution and multipliers, on every native backend, repeatedly (warm).
    rng = np.random.default_rng(3)
    n, me, mi = 4, 1, 5
    for name in ("daqp", "osqp", "clarabel"):
        be, ref = make_backend(name), make_backend(name)
        be.setup(n, me, mi)
        ref.setup(n, me, mi)
        for _ in range(3):
            M = rng.normal(size=(n, n))
            P = M @ M.T + np.eye(n)
            q = rng.normal(size=n)
            J = rng.normal(size=(me + mi, n))
            # Feasible: a small step meets the equality, the inequalities hold with margin.
            c = np.concatenate((0.1 * rng.normal(size=me), np.abs(rng.normal(size=mi)) + 0.5))
            lb, ub = np.full(n, -2.0), np.full(n, 2.0)
            sol = be.solve_sqp(P, q, J, c, lb, ub)
            exp = ref.solve(P, q, J[:me], -c[:me], -J[me:], c[me:], lb, ub)
            assert sol.status is QPStatus.SOLVED and exp.status is QPStatus.SOLVED, name
            assert np.allclose(sol.x, exp.x, atol=1e-6), name
            assert np.allclose(sol.y_eq, exp.y_eq, atol=1e-5), name
            assert np.allclose(sol.y_ineq, exp.y_ineq, atol=1e-5), name
            assert np.all(J[me:] @ sol.x + c[me:] >= -1e-6), name
            assert np.allclose(J[:me] @ sol.x + c[:me], 0.0, atol=1e-6), name


@pytest.mark.parametrize("sparse", [False, True])
def test_least_norm_second_order_correction(sparse: bool) -> None:
    """The least-norm correction lands on the linearised working set at x + d (equalities
    and positive-multiplier inequalities, duplicated rows included) and moves no further."""
    import scipy.sparse as sps

    from stackik.sqp.linalg import make_algebra
    from stackik.sqp.solver import soc_min_norm

    rng = np.random.default_rng(3)
    n = 6
    J = rng.standard_normal((5, n))
    J[3] = J[2]  # an identical pair of inequality rows
    alg = make_algebra(sparse, n, 1, 4)
    JJ = sps.csc_matrix(J) if sparse else J
    lam = np.array([-2.0, 0.0, 1.0, 1.0, 0.0])  # rows 0 (equality), 2 and 3 active
    d = rng.standard_normal(n)
    c_t = rng.standard_normal(5)
    c_t[3] = c_t[2]
    dc = soc_min_norm(alg, JJ, c_t, lam, d, 1)
    assert dc is not None
    rows = [0, 2, 3]
    assert np.allclose(c_t[rows] + J[rows] @ (dc - d), 0.0, atol=1e-8)
    # least norm: the correction lies in the row space of the working set
    corr = dc - d
    basis = np.linalg.qr(J[[0, 2]].T)[0]
    assert np.allclose(basis @ (basis.T @ corr), corr, atol=1e-10)


@pytest.mark.parametrize("sparse_form", [False, True])
def test_osqp_polish_first_solves_the_same_qp(sparse_form: bool) -> None:
    # polish_first (not an OSQP setting): a loose solve kept only when polishing succeeds,
    # else ADMM continues to the tight tolerances; either way the QP's solution
    import scipy.sparse as sp

    rng = np.random.default_rng(3)
    n, me, mi = 6, 2, 5
    M = rng.standard_normal((n, n))
    P = M @ M.T + 0.1 * np.eye(n)
    q = rng.standard_normal(n)
    A, b = rng.standard_normal((me, n)), rng.standard_normal(me)
    G, h = rng.standard_normal((mi, n)), 0.1 * np.ones(mi)
    lb, ub = -np.ones(n), np.ones(n)
    if sparse_form:
        P, A, G = sp.csc_matrix(P), sp.csc_matrix(A), sp.csc_matrix(G)
    sols = []
    for opts in ({}, {"polish_first": 1e-3}):
        be = make_backend("osqp", opts)
        assert "polish_first" not in be.settings
        be.setup(n, me, mi)
        for _ in range(2):  # the second solve goes through the update path
            sols.append(be.solve(P, q, A, b, G, h, lb, ub))
    for s in sols:
        assert s.status is QPStatus.SOLVED
        np.testing.assert_allclose(s.x, sols[0].x, atol=1e-5)
