"""Structured (sparse) planar IK problems for the SQP engine's sparse backends."""

from __future__ import annotations

import fd
import numpy as np
import pytest

from stackik import PlanarTarget, Stack, check_pose, solve_ik
from stackik.formulation import Problem
from stackik.formulation.lifted import LiftedPlanarNLP
from stackik.formulation.structured import ReducedPlanarNLP
from stackik.sampling import random_planar_targets
from stackik.starts import paper_initial_guess


@pytest.mark.parametrize("n", [2, 5])
def test_reduced_sparse_equals_dense(n: int) -> None:
    stack = Stack.reference(n, leg_radius=0.0)
    target = random_planar_targets(stack, 1, rng=3)[0]
    prob = Problem(stack, target, "frobenius", None)
    nlp = ReducedPlanarNLP(prob)
    rng = np.random.default_rng(0)
    u = prob.u_of(paper_initial_guess(stack, target)) + 0.01 * rng.normal(size=3 * n)
    dense = prob.evaluate(u)
    sparse = nlp.evaluate(u)
    assert sparse[0] == pytest.approx(dense[0], rel=1e-14)
    for k in (1, 2, 3, 4):
        np.testing.assert_allclose(sparse[k], dense[k], rtol=1e-13, atol=1e-15)
    J = sparse[5]
    assert J.nnz == 72 * n  # block diagonal: 24 limits x 3 variables per platform
    np.testing.assert_allclose(J.toarray(), dense[5], rtol=1e-13, atol=1e-15)
    J2 = nlp.evaluate(u + 1e-3)[5]
    assert J2.indices is J.indices and J2.indptr is J.indptr  # one fixed pattern


@pytest.mark.parametrize("qp", ["osqp", "clarabel"])
def test_sqp_sparse_backends_solve_paper_target(qp: str) -> None:
    stack = Stack.reference(4, leg_radius=0.0)
    target = PlanarTarget(600.0, 1000.0, -1.57)
    res = solve_ik(stack, target, method="sqp", qp_solver=qp, starts=1)
    assert res.success
    assert check_pose(stack, target, res.q).ok
    dense = solve_ik(
        stack, target, method="sqp", qp_solver=qp, starts=1, options={"formulation": "dense"}
    )
    assert dense.success
    assert res.frobenius_norm == pytest.approx(dense.frobenius_norm, rel=1e-6)


def _lifted_case(n: int) -> tuple[Problem, LiftedPlanarNLP, np.ndarray]:
    stack = Stack.reference(n, leg_radius=0.0)
    target = random_planar_targets(stack, 1, rng=3)[0]
    prob = Problem(stack, target, "frobenius", None)
    rng = np.random.default_rng(0)
    u = prob.u_of(paper_initial_guess(stack, target)) + 0.01 * rng.normal(size=3 * n)
    return prob, LiftedPlanarNLP(prob), u


def test_lifted_values_match_reduced() -> None:
    prob, lifted, u = _lifted_case(5)
    x = lifted.lift(u)
    np.testing.assert_array_equal(lifted.reduce(x), u)
    f, g, ceq, Jeq, cin, Jin = lifted.evaluate(x)
    dense = prob.evaluate(u)
    assert f == pytest.approx(dense[0], rel=1e-13)
    np.testing.assert_array_equal(cin, dense[4])
    b = ceq.reshape(5, 3)
    # the chain holds exactly inside; the end effector's error sits in b_1 and a_n
    np.testing.assert_allclose(b[1:, :2], 0.0, atol=1e-14)
    np.testing.assert_allclose(b[:-1, 2], 0.0, atol=1e-14)
    np.testing.assert_allclose(b[0, :2], -dense[2][:2], rtol=1e-12, atol=1e-14)
    assert b[-1, 2] == pytest.approx(-dense[2][2], rel=1e-12, abs=1e-15)
    # O(n) patterns: banded chain rows, 72 entries per platform for the limits
    assert Jin.nnz == 72 * 5
    assert Jeq.nnz <= 12 * 5
    assert lifted.h_pat.nnz <= 25 * 5


@pytest.mark.derivatives
@pytest.mark.parametrize("psd", [False, True])
def test_lifted_derivatives(psd: bool) -> None:
    prob, _, u = _lifted_case(4)
    lifted = LiftedPlanarNLP(prob, psd_blocks=psd)
    x = lifted.lift(u)
    _, g, _, Jeq, _, Jin = lifted.evaluate(x)

    def part(k: int):  # noqa: ANN202 - test helper
        return lambda z: np.array(LiftedPlanarNLP(prob).evaluate(z)[k], dtype=float)

    for k, analytic, what in ((2, Jeq.toarray(), "J_eq"), (4, Jin.toarray(), "J_in")):
        num = fd.central(part(k), x)
        fd.assert_derivative_close(analytic, num, f_scale=fd.term_scale(part(k)(x), num), what=what)
    num = fd.central(lambda z: np.array([part(0)(z)]), x)
    fd.assert_derivative_close(
        g[None], num, f_scale=fd.term_scale([part(0)(x)], num), what="gradient"
    )
    rng = np.random.default_rng(1)
    ye, yi = rng.normal(size=3 * 4), rng.random(24 * 4)

    def lag_grad(z: np.ndarray) -> np.ndarray:
        _, gz, _, Je, _, Ji = LiftedPlanarNLP(prob).evaluate(z)
        return gz - Je.T @ ye - Ji.T @ yi

    H = lifted.hessian(x, ye, yi).toarray()
    np.testing.assert_array_equal(H, H.T)
    if psd:
        assert np.linalg.eigvalsh(H).min() >= -1e-9 * np.abs(H).max()
        return
    num = fd.central(lag_grad, x, richardson=True)
    fd.assert_derivative_close(
        H, num, f_scale=fd.term_scale(lag_grad(x), num), what="Lagrangian Hessian"
    )


@pytest.mark.parametrize("form", ["lifted", "lifted-exact"])
def test_sqp_lifted_solves(form: str) -> None:
    stack = Stack.reference(4, leg_radius=0.0)
    target = PlanarTarget(600.0, 1000.0, -1.57)
    res = solve_ik(
        stack, target, method="sqp", qp_solver="clarabel", starts=1, options={"formulation": form}
    )
    assert res.success
    assert check_pose(stack, target, res.q).ok


def test_sqp_barrier_start_solves() -> None:
    stack = Stack.reference(4, leg_radius=0.0)
    target = PlanarTarget(600.0, 1000.0, -1.57)
    for qp in ("daqp", "clarabel"):
        res = solve_ik(
            stack, target, method="sqp", qp_solver=qp, starts=1, options={"barrier_start": True}
        )
        assert res.success
        assert check_pose(stack, target, res.q).ok


def test_sqp_barrier_start_hands_over_when_the_barrier_steps_jam() -> None:
    # planar n = 16, OSQP: a barrier row blocked every step, the penalty reached its cap
    # and the radius collapsed inside the barrier phase (INFEASIBLE after 73 iterations
    # in four runs); now the SQP takes over with a fresh radius and reaches the target
    from stackik.sampling import random_planar_targets

    stack = Stack.reference(16, leg_radius=0.0)
    target = random_planar_targets(stack, 5, rng=777 + 16)[4]
    res = solve_ik(
        stack, target, method="sqp", qp_solver="osqp", starts=1, options={"barrier_start": True}
    )
    assert res.success, res.message
    assert check_pose(stack, target, res.q).ok


def test_sqp_formulation_option_checked() -> None:
    from stackik.result import OptionError

    with pytest.raises(OptionError, match="formulation"):
        solve_ik(
            Stack.reference(2, leg_radius=0.0),
            PlanarTarget(0.0, 700.0, 0.0),
            method="sqp",
            options={"formulation": "nope"},
        )


@pytest.mark.parametrize("objective", ["frobenius", "feasible"])
@pytest.mark.parametrize("n", [2, 5])
def test_compiled_planar_nlp_equals_reduced(objective: str, n: int) -> None:
    # the SQP method's compiled evaluation (stackik._compiled.planar kernels) has ReducedPlanarNLP's
    # values, sparsity pattern and Hessian
    from stackik.methods._sqp_compiled import CompiledNLP, compiled_supported

    stack = Stack.reference(n, leg_radius=0.0)
    target = random_planar_targets(stack, 1, rng=3)[0]
    prob = Problem(stack, target, objective, None)
    assert compiled_supported(prob)
    ref, nlp = ReducedPlanarNLP(prob), CompiledNLP(prob)
    rng = np.random.default_rng(1)
    u = prob.u_of(paper_initial_guess(stack, target)) + 0.01 * rng.normal(size=3 * n)
    a, b = ref.evaluate(u), nlp.evaluate(u)
    assert b[0] == pytest.approx(a[0], rel=1e-13)
    for k in (1, 2, 3, 4):
        np.testing.assert_allclose(b[k], a[k], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(b[5].toarray(), a[5].toarray(), rtol=1e-12, atol=1e-14)
    assert b[5].nnz == 72 * n
    J2 = nlp.evaluate(u + 1e-3)[5]
    assert J2.indices is b[5].indices and J2.indptr is b[5].indptr
    y_eq, y_in = rng.normal(size=3), rng.random(24 * n)
    np.testing.assert_allclose(
        nlp.hessian(u, y_eq, y_in), ref.hessian(u, y_eq, y_in), rtol=1e-12, atol=1e-12
    )


def test_qp_screening_off_gives_the_same_pose() -> None:
    # SQPOptions.qp_screening: screened QPs (rows that cannot bind left out) and full QPs
    # have the same solutions; the IK method turns screening off for Clarabel below
    # CLARABEL_SCREEN_FROM platforms
    from stackik.methods.sqp import CLARABEL_SCREEN_FROM
    from stackik.sqp import SQPOptions

    assert CLARABEL_SCREEN_FROM > 4
    with pytest.raises(ValueError, match="qp_screening"):
        SQPOptions(qp_screening=1)  # type: ignore[arg-type]
    stack = Stack.reference(4, leg_radius=0.0)
    target = PlanarTarget(600.0, 1000.0, -1.57)
    runs = [
        solve_ik(stack, target, method="sqp", qp_solver=qp, starts=1, options=opts)
        for qp in ("clarabel", "osqp")
        for opts in ({"qp_screening": True}, {"qp_screening": False})
    ]
    for r in runs:
        assert r.success
        assert r.frobenius_norm == pytest.approx(runs[0].frobenius_norm, rel=1e-6)


@pytest.mark.parametrize("objective", ["frobenius", "feasible"])
def test_compiled_spatial_nlp_has_the_problems_values(objective: str) -> None:
    # the SQP method's spatial evaluation (stackik._compiled.spatial kernels, whose derivatives
    # are tested against differences in test_spatial_quality.py): Problem's objective and
    # limits, the limit Jacobian in one fixed block-diagonal CSC pattern, the kernel's
    # Lagrangian Hessian
    from stackik._compiled import spatial as _spatial_ipm
    from stackik.methods._sqp_compiled import CompiledNLP, compiled_supported
    from stackik.sampling import random_spatial_targets

    n = 3
    stack = Stack.reference(n, leg_radius=0.0)
    target = random_spatial_targets(stack, 1, rng=5)[0]
    prob = Problem(stack, target, objective, None)
    assert compiled_supported(prob)
    nlp = CompiledNLP(prob)
    rng = np.random.default_rng(2)
    u = prob.u_of(paper_initial_guess(stack, target)) + 0.01 * rng.normal(size=6 * n)
    f, g, cE, AE, cI, JI = nlp.evaluate(u)
    ref = prob.evaluate(u)
    assert f == pytest.approx(ref[0], rel=1e-12, abs=1e-15)
    np.testing.assert_allclose(g, ref[1], rtol=1e-10, atol=1e-12 * max(1.0, np.abs(g).max()))
    np.testing.assert_allclose(cI, ref[4], rtol=1e-13, atol=1e-15)
    Jd = ref[5].toarray() if hasattr(ref[5], "toarray") else ref[5]
    np.testing.assert_allclose(JI.toarray(), Jd, rtol=1e-12, atol=1e-14)
    assert JI.nnz == 24 * 6 * n
    J2 = nlp.evaluate(u + 1e-3)[5]
    assert J2.indices is JI.indices and J2.indptr is JI.indptr
    y_eq, y_in = rng.normal(size=6), rng.random(24 * n)
    np.testing.assert_array_equal(
        nlp.hessian(u, y_eq, y_in), _spatial_ipm.lagrangian_hessian(u, y_eq, y_in, nlp.P)
    )


def test_sqp_spatial_exact_hessian_by_default() -> None:
    # spatial SQP: the compiled problem with its exact Hessian ("auto"), every backend;
    # the NumPy evaluation with damped BFGS stays as formulation="dense" and needs more
    # iterations on the same target (deterministic counts, no timing)
    from stackik.sampling import random_spatial_targets

    stack = Stack.reference(4, leg_radius=0.0)
    target = random_spatial_targets(stack, 1, rng=60621)[0]
    nit = {}
    for qp in ("daqp", "clarabel", "osqp"):
        res = solve_ik(stack, target, method="sqp", qp_solver=qp, starts=1)
        assert res.success, (qp, res.status)
        assert check_pose(stack, target, res.q).ok
        nit[qp] = res.nit
    bfgs = solve_ik(
        stack, target, method="sqp", qp_solver="daqp", starts=1, options={"formulation": "dense"}
    )
    assert bfgs.success
    assert nit["daqp"] < bfgs.nit
