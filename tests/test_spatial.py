"""The compiled spatial evaluation (stackik._compiled.spatial_kinematics) against the numpy
implementations and finite differences."""

from __future__ import annotations

import fd
import numpy as np
import pytest

import stackik as sk
from stackik._compiled.spatial_kinematics import spatial_parts
from stackik.formulation import Problem
from stackik.kinematics import spatial_chain
from stackik.platform import constraints_from_legs, spatial_legs
from stackik.sampling import random_stack


def case(n: int, seed: int):
    st = random_stack(n, seed) if seed % 2 else sk.Stack.reference(n)
    rng = np.random.default_rng(seed)
    q = np.column_stack(
        [rng.uniform(-60, 60, (n, 2)), rng.uniform(260, 420, n), rng.uniform(-0.5, 0.5, (n, 3))]
    )
    return st, q


def parts(st: sk.Stack, q: np.ndarray):
    return spatial_parts(q, st.top_nodes, st.base_nodes, st.leg_min, st.leg_max, st.sin_joint_min)


@pytest.mark.parametrize("n", [1, 2, 4, 7])
@pytest.mark.parametrize("seed", [0, 1])
def test_spatial_parts_match_numpy(n, seed):
    st, q = case(n, seed)
    Pee, Ree, Jp, w, c, Jc, r, Jr = parts(st, q)
    ch = spatial_chain(q)
    np.testing.assert_allclose(Pee, ch.O[-1], rtol=1e-13, atol=1e-10)
    np.testing.assert_allclose(Ree, ch.A[-1], rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(Jp, ch.J[:3], rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(w, ch.w, atol=1e-14)
    l, Rn, dl, dRn = spatial_legs(st, q, derivatives=True)
    c0, Jc0 = constraints_from_legs(l, Rn, st.leg_min, st.leg_max, st.sin_joint_min, dl=dl, dRn=dRn)
    np.testing.assert_allclose(c, c0, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(Jc, Jc0, rtol=1e-12, atol=1e-9)
    prob = Problem(st, sk.SpatialTarget(ch.O[-1], ch.A[-1]), "frobenius", None)
    r0, Jr0 = prob.residuals(q, ch)
    np.testing.assert_allclose(r * prob.rw, r0, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(Jr * prob.rw[:, None], Jr0, rtol=1e-12, atol=1e-10)


@pytest.mark.derivatives
@pytest.mark.parametrize("n", [1, 3])
def test_spatial_parts_derivatives_by_finite_differences(n):
    """Tolerances from the step and the scales (tests/fd.py): positions and the residuals
    (w x d [mm], [w]x R) of scale chain_length, constraints of fd.constraint_scale."""
    st, q = case(n, 1)
    _, _, Jp, _, c, Jc, r, Jr = parts(st, q)
    L = fd.chain_length(q)
    num = fd.central(lambda x: parts(st, x)[0], q, typical=fd.TYPICAL_SPATIAL)  # (3, n, 6)
    fd.assert_derivative_close(Jp.reshape(num.shape), num, f_scale=L, what="Jp")
    num = fd.central(lambda x: parts(st, x)[4], q, typical=fd.TYPICAL_SPATIAL)  # (n, 24, n, 6)
    F = fd.constraint_scale(st.top_nodes, st.base_nodes, st.leg_max, q)  # mm^2 and mm
    fd.assert_derivative_close(fd.block_diagonal(Jc), num, f_scale=F, what="Jc")
    num = fd.central(lambda x: parts(st, x)[6], q, typical=fd.TYPICAL_SPATIAL)  # (9n, n, 6)
    fd.assert_derivative_close(Jr.reshape(num.shape), num, f_scale=L, what="Jr")


def test_spatial_solve_uses_the_compiled_parts_and_checks():
    st = sk.Stack.reference(3)
    _, q = case(3, 0)
    P, R = sk.spatial_forward(q)
    r = sk.solve_ik(st, sk.SpatialTarget(P, R))
    assert r.success and sk.check_pose(st, sk.SpatialTarget(P, R), r.q).ok


def test_block_jacobian_matches_dense_assembly():
    from stackik._compiled.spatial_kinematics import block_jacobian

    rng = np.random.default_rng(5)
    n = 3
    Jc = rng.normal(size=(n, 24, 6))
    cs, xs = rng.random(24 * n) + 0.5, rng.random(6 * n) + 0.5
    dense = np.zeros((n, 24, n, 6))
    dense[np.arange(n), :, np.arange(n), :] = Jc
    expected = dense.reshape(24 * n, 6 * n) * cs[:, None] * xs
    np.testing.assert_allclose(block_jacobian(Jc, cs, xs), expected, rtol=1e-15)
