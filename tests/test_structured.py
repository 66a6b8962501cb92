"""Structured (sparse) planar IK problems for the SQP engine's sparse backends."""

from __future__ import annotations

import numpy as np
import pytest

from stackik import PlanarTarget, Stack, check_pose, solve_ik
from stackik.formulation import Problem
from stackik.formulation.structured import ReducedPlanarNLP
from stackik.sampling import random_planar_targets
from stackik.starts import paper_initial_guess


@pytest.mark.parametrize("n", [2, 5])
def test_reduced_sparse_equals_dense(n: int) -> None:
    stack = Stack.reference(n)
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
    stack = Stack.reference(4)
    target = PlanarTarget(600.0, 1000.0, -1.57)
    res = solve_ik(stack, target, method="sqp", qp_solver=qp, starts=1)
    assert res.success
    assert check_pose(stack, target, res.q).ok
    dense = solve_ik(
        stack, target, method="sqp", qp_solver=qp, starts=1, options={"formulation": "dense"}
    )
    assert dense.success
    assert res.frobenius_norm == pytest.approx(dense.frobenius_norm, rel=1e-6)
