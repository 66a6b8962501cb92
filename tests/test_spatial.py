"""The compiled spatial evaluation (stackik._spatial) against the numpy implementations
and finite differences."""

from __future__ import annotations

import numpy as np
import pytest

import stackik as sk
from stackik._spatial import spatial_parts
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


@pytest.mark.parametrize("n", [1, 3])
def test_spatial_parts_derivatives_by_finite_differences(n):
    st, q = case(n, 1)
    _, _, Jp, _, c, Jc, r, Jr = parts(st, q)
    eps = 1e-6
    N = 6 * n
    fd_c = np.zeros((n, 24, 6))
    fd_r = np.zeros((r.size, N))
    fd_p = np.zeros((3, N))
    for a in range(N):
        dq = np.zeros(N)
        dq[a] = eps
        hi = parts(st, q + dq.reshape(n, 6))
        lo = parts(st, q - dq.reshape(n, 6))
        fd_p[:, a] = (hi[0] - lo[0]) / (2 * eps)
        fd_r[:, a] = (hi[6] - lo[6]) / (2 * eps)
        i, j = divmod(a, 6)
        fd_c[i, :, j] = (hi[4][i] - lo[4][i]) / (2 * eps)
    np.testing.assert_allclose(Jp, fd_p, rtol=1e-6, atol=1e-5)
    np.testing.assert_allclose(Jc, fd_c, rtol=1e-6, atol=1e-3)  # c in mm^2
    np.testing.assert_allclose(Jr, fd_r, rtol=1e-6, atol=1e-5)


def test_spatial_solve_uses_the_compiled_parts_and_checks():
    st = sk.Stack.reference(3)
    _, q = case(3, 0)
    P, R = sk.spatial_forward(q)
    r = sk.solve_ik(st, sk.SpatialTarget(P, R))
    assert r.success and sk.check_pose(st, sk.SpatialTarget(P, R), r.q).ok


def test_block_jacobian_matches_dense_assembly():
    from stackik._spatial import block_jacobian

    rng = np.random.default_rng(5)
    n = 3
    Jc = rng.normal(size=(n, 24, 6))
    cs, xs = rng.random(24 * n) + 0.5, rng.random(6 * n) + 0.5
    dense = np.zeros((n, 24, n, 6))
    dense[np.arange(n), :, np.arange(n), :] = Jc
    expected = dense.reshape(24 * n, 6 * n) * cs[:, None] * xs
    np.testing.assert_allclose(block_jacobian(Jc, cs, xs), expected, rtol=1e-15)
