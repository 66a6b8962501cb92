"""Stack kinematics: forward models, Jacobians, FN^2 and its derivatives (DESIGN §1, §3-5).

Oracles: the independent loop-based implementation in ``reference_impl.py`` (complex-step
Jacobians), the closed forms of DESIGN §3-4, and central finite differences.
"""

from __future__ import annotations

import math

import fd
import numpy as np
import pytest
import reference_impl as ref
from helpers import assert_close
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import stackik
from stackik import PlatformGeometry, Stack
from stackik.kinematics import (
    PlanarFN,
    noise_weights,
    planar_fn_residuals,
    planar_hessian_fn2,
)
from stackik.rotations import euler_zyx, euler_zyx_from_matrix, plane_axis, rodrigues

NS = [1, 2, 4, 7]
PHIS = [0.0, 0.7, -2.1, math.pi / 2, 3.0]
SEEDS = [0, 1, 2]
REF_RTOL = 1e-9  # agreement with the reference implementation, relative to magnitude
# Derivatives are checked by fd.py: tolerances from the step and the scales below.


def to_stack(geoms):
    return Stack(
        tuple(
            PlatformGeometry(g["base"], g["top"], g["leg_min"], g["leg_max"], g["joint_min"])
            for g in geoms
        )
    )


def planar_scale(q):
    """F of the planar output (rho_ee, z_ee [mm], theta_ee [rad])."""
    L = fd.chain_length(q)
    return np.array([L, L, 1.0 + float(np.abs(q[:, 2]).sum())])


def spatial_scale(q):
    """F of the spatial output (P_ee [mm], R_ee.ravel())."""
    return np.array([fd.chain_length(q)] * 3 + [1.0] * 9)


def planar_fn2_scale(q):
    """F of FN^2 = 3n + sum_j |P_ee - O_j|^2 [mm^2]: each term is at most chain_length^2."""
    return 3.0 * len(q) + len(q) * fd.chain_length(q) ** 2


def psd_min_eig(H):
    assert np.allclose(H, H.T, rtol=0, atol=1e-9 * max(1.0, np.abs(H).max()))
    return np.linalg.eigvalsh(0.5 * (H + H.T)).min() / max(1.0, np.abs(H).max())


pose_params = pytest.mark.parametrize(("n", "seed"), [(n, s) for n in NS for s in SEEDS])


# =========================================================================================
# Agreement with the reference implementation
# =========================================================================================
@pytest.mark.derivatives
@pose_params
@pytest.mark.parametrize("phi", PHIS)
def test_planar_forward_and_jacobian_match_reference(n, seed, phi):
    q = ref.random_planar_pose(np.random.default_rng(seed), n)
    assert_close(stackik.planar_forward(q), ref.planar_forward(q, phi), REF_RTOL, "y")
    # the reference's Jacobian: complex step of its forward model (ref.planar_jacobian)
    cs = fd.complex_step(lambda x: ref.planar_forward(x, phi), q, typical=fd.TYPICAL_PLANAR)
    J = stackik.planar_jacobian(q).reshape(cs.shape)
    fd.assert_derivative_close(J, cs, f_scale=planar_scale(q), what="J")
    assert_close(stackik.planar_plate_origins(q), ref.planar_plate_origins(q, phi), REF_RTOL, "O")


@pytest.mark.derivatives
@pose_params
def test_spatial_forward_and_jacobian_match_reference(n, seed):
    q = ref.random_spatial_pose(np.random.default_rng(100 + seed), n)
    P, R = stackik.spatial_forward(q)
    P_ref, R_ref = ref.spatial_forward(q)
    assert_close(P, P_ref, REF_RTOL, "P_ee")
    assert_close(R, R_ref, REF_RTOL, "R_ee")
    J = stackik.spatial_jacobian(q)
    assert J.shape == (12, 6 * n)
    # the reference's Jacobian: complex step of its forward model (ref.spatial_jacobian)
    cs = fd.complex_step(ref.spatial_output, q, typical=fd.TYPICAL_SPATIAL)
    fd.assert_derivative_close(J.reshape(cs.shape), cs, f_scale=spatial_scale(q), what="J")
    O = stackik.spatial_plate_origins(q)
    assert O.shape == (n + 1, 3)
    assert_close(O, ref.spatial_plate_origins(q), REF_RTOL, "O")
    assert_close(O[-1], P_ref, REF_RTOL, "O_n = P_ee")
    assert np.all(O[0] == 0)


@pose_params
def test_frobenius_norm_matches_reference(n, seed):
    rng = np.random.default_rng(200 + seed)
    qp = ref.random_planar_pose(rng, n)
    qs = ref.random_spatial_pose(rng, n)
    for J in (stackik.planar_jacobian(qp), stackik.spatial_jacobian(qs)):
        assert stackik.frobenius_norm(J) == pytest.approx(ref.frobenius_norm(J), rel=1e-12)
    fn_ref = ref.frobenius_norm(ref.spatial_jacobian(qs))
    assert stackik.frobenius_norm(stackik.spatial_jacobian(qs)) == pytest.approx(
        fn_ref, rel=REF_RTOL
    )


# =========================================================================================
# FN closed forms (DESIGN §3, §4)
# =========================================================================================
@pose_params
@pytest.mark.parametrize("phi", [0.0, 1.1])
def test_planar_fn2_closed_form(n, seed, phi):
    q = ref.random_planar_pose(np.random.default_rng(300 + seed), n)
    O = stackik.planar_plate_origins(q)
    closed = 3 * n + sum(float(np.sum((O[n] - O[j]) ** 2)) for j in range(1, n))
    J = stackik.planar_jacobian(q)
    assert float(np.sum(J**2)) == pytest.approx(closed, rel=1e-12)
    assert stackik.planar_fn2(q) == pytest.approx(closed, rel=1e-12)
    assert closed == pytest.approx(ref.planar_fn2_closed_form(q, phi), rel=REF_RTOL)
    assert float(np.sum(ref.planar_jacobian(q, phi) ** 2)) == pytest.approx(closed, rel=REF_RTOL)
    assert stackik.frobenius_norm(J) ** 2 == pytest.approx(closed, rel=1e-12)
    fn = PlanarFN.at(q)
    assert fn.value == pytest.approx(closed, rel=1e-12)


def test_planar_fn2_single_platform_is_three():
    q = np.array([[40.0, 300.0, 0.3]])
    assert stackik.planar_fn2(q) == 3.0
    assert float(np.sum(stackik.planar_jacobian(q) ** 2)) == pytest.approx(3.0)


@pose_params
def test_spatial_fn2_closed_form(n, seed):
    q = ref.random_spatial_pose(np.random.default_rng(400 + seed), n)
    J = stackik.spatial_jacobian(q)
    closed = ref.spatial_fn2_closed_form(q)
    assert float(np.sum(J**2)) == pytest.approx(closed, rel=REF_RTOL)
    assert float(np.sum(ref.spatial_jacobian(q) ** 2)) == pytest.approx(closed, rel=REF_RTOL)
    chain = stackik.spatial_chain(q)
    assert chain.weighted_norm2() == pytest.approx(closed, rel=REF_RTOL)
    # translation columns are unit, rotation columns carry |w x d|^2 + 2
    cols = np.sum(J**2, axis=0).reshape(n, 6)
    assert np.allclose(cols[:, :3], 1.0, rtol=1e-12)
    assert np.all(cols[:, 3:] >= 2.0 - 1e-12)


# =========================================================================================
# Finite differences: Jacobians of the forward models
# =========================================================================================
@pytest.mark.derivatives
@pose_params
def test_planar_jacobian_finite_differences(n, seed):
    q = ref.random_planar_pose(np.random.default_rng(500 + seed), n)
    num = fd.central(stackik.planar_forward, q, typical=fd.TYPICAL_PLANAR)  # (3, n, 3)
    J = stackik.planar_jacobian(q).reshape(num.shape)
    fd.assert_derivative_close(J, num, f_scale=planar_scale(q), what="planar J")


@pytest.mark.derivatives
@pose_params
def test_spatial_jacobian_finite_differences(n, seed):
    q = ref.random_spatial_pose(np.random.default_rng(600 + seed), n)

    def y(x):
        P, R = stackik.spatial_forward(x)
        return np.concatenate([P, R.ravel()])

    num = fd.central(y, q, typical=fd.TYPICAL_SPATIAL)  # (12, n, 6)
    J = stackik.spatial_jacobian(q).reshape(num.shape)
    fd.assert_derivative_close(J, num, f_scale=spatial_scale(q), what="spatial J")


# =========================================================================================
# Planar FN^2: residuals, gradient, Hessians
# =========================================================================================
@pytest.mark.derivatives
@pose_params
def test_planar_fn_residuals(n, seed):
    q = ref.random_planar_pose(np.random.default_rng(700 + seed), n)
    r, Jr = planar_fn_residuals(q)
    assert r.shape == (2 * (n - 1),)
    assert Jr.shape == (2 * (n - 1), 3 * n)
    assert 3 * n + r @ r == pytest.approx(stackik.planar_fn2(q), rel=1e-12)
    if n > 1:
        num = fd.central(lambda x: planar_fn_residuals(x)[0], q, typical=fd.TYPICAL_PLANAR)
        L = fd.chain_length(q)  # residuals are differences of positions [mm]
        fd.assert_derivative_close(Jr.reshape(num.shape), num, f_scale=L, what="Jr")


@pytest.mark.derivatives
@pose_params
def test_planar_fn_gradient_finite_differences(n, seed):
    q = ref.random_planar_pose(np.random.default_rng(800 + seed), n)
    fn = PlanarFN.at(q)
    assert fn.gradient.shape == (3 * n,)
    num = fd.central(stackik.planar_fn2, q, typical=fd.TYPICAL_PLANAR)  # (n, 3)
    g = fn.gradient.reshape(num.shape)
    fd.assert_derivative_close(g, num, f_scale=planar_fn2_scale(q), what="grad FN^2")


@pytest.mark.derivatives
@pose_params
def test_planar_hessian_fn2(n, seed):
    q = ref.random_planar_pose(np.random.default_rng(900 + seed), n)
    H = planar_hessian_fn2(q, exact=True)
    assert H.shape == (3 * n, 3 * n)
    num = fd.central(
        lambda x: PlanarFN.at(x).gradient, q, typical=fd.TYPICAL_PLANAR, richardson=True
    )
    F = fd.derivative_scale(planar_fn2_scale(q), num.x_scale.ravel())  # gradient rows
    fd.assert_derivative_close(H.reshape(num.shape), num, f_scale=F, what="exact Hessian")
    assert np.allclose(H, H.T, rtol=0, atol=1e-9 * max(1.0, np.abs(H).max()))
    GN = planar_hessian_fn2(q, exact=False)
    assert psd_min_eig(GN) >= -1e-12
    assert np.array_equal(GN, PlanarFN.at(q).gauss_newton)
    r, Jr = planar_fn_residuals(q)
    assert_close(GN, 2 * Jr.T @ Jr, 1e-12, "GN = 2 Jr^T Jr")


def test_planar_hessian_rows_of_fixed_variables_vanish():
    # FN^2 does not depend on platform 1's translation, nor on the last platform's theta
    # (it only rotates the end effector about its own origin)
    q = ref.random_planar_pose(np.random.default_rng(3), 4)
    g = PlanarFN.at(q).gradient.reshape(4, 3)
    assert np.allclose(g[0, :2], 0.0, atol=1e-9)
    assert abs(g[-1, 2]) < 1e-9


# =========================================================================================
# Spatial chain: Hessian, third derivatives, weighted objective
# =========================================================================================
@pytest.mark.derivatives
@pytest.mark.parametrize(("n", "seed"), [(1, 0), (2, 1), (3, 2)])
def test_spatial_chain_hessian_and_third(n, seed):
    q = ref.random_spatial_pose(np.random.default_rng(1000 + seed), n)
    chain = stackik.spatial_chain(q)
    N = 6 * n
    X = fd.variable_scale(q, fd.TYPICAL_SPATIAL).ravel()
    H = chain.hessian()
    assert H.shape == (12, N, N)
    num = fd.central(
        lambda x: stackik.spatial_chain(x).J, q, typical=fd.TYPICAL_SPATIAL, richardson=True
    )
    F = fd.derivative_scale(spatial_scale(q), X)  # J = d(P, R)/dq: (12, N)
    fd.assert_derivative_close(H.reshape(num.shape), num, f_scale=F, what="hessian")
    assert np.allclose(H, np.swapaxes(H, 1, 2), atol=1e-9 * np.abs(H).max())
    T = chain.third()
    assert T.shape == (12, N, N, N)
    num = fd.central(
        lambda x: stackik.spatial_chain(x).hessian(), q, typical=fd.TYPICAL_SPATIAL, richardson=True
    )
    F = fd.derivative_scale(spatial_scale(q), X, 2)  # (12, N, N)
    fd.assert_derivative_close(T.reshape(num.shape), num, f_scale=F, what="third")


@pytest.mark.derivatives
@pytest.mark.parametrize(("n", "seed"), [(1, 0), (2, 1), (3, 2), (4, 3)])
def test_spatial_weighted_objective_derivatives(n, seed):
    rng = np.random.default_rng(1100 + seed)
    q = ref.random_spatial_pose(rng, n)
    N = 6 * n
    for w in (None, noise_weights(n, 1.0, 0.005, spatial=True), rng.uniform(0.1, 2.0, N)):
        chain = stackik.spatial_chain(q)
        w_arr = np.ones(N) if w is None else w
        val = chain.weighted_norm2(w)
        assert val == pytest.approx(
            ref.weighted_objective(ref.spatial_jacobian(q), w_arr), rel=1e-9
        )
        # F of sum_b w_b |J[:, b]|^2: a translation column has |J[:, b]|^2 = 1, a rotation
        # column |w_b x d|^2 + |[w_b]x R_ee|_F^2 <= L^2 + 2 (L = chain length)
        X = fd.variable_scale(q, fd.TYPICAL_SPATIAL).ravel()
        rot = np.tile([False] * 3 + [True] * 3, n)
        F = float(np.sum(w_arr * np.where(rot, fd.chain_length(q) ** 2 + 2.0, 1.0)))
        g = chain.weighted_gradient(w)
        num = fd.central(
            lambda x, w=w: stackik.spatial_chain(x).weighted_norm2(w), q, typical=fd.TYPICAL_SPATIAL
        )
        fd.assert_derivative_close(g.reshape(num.shape), num, f_scale=F, what="weighted gradient")
        Hw = chain.weighted_hessian(w)
        num = fd.central(
            lambda x, w=w: stackik.spatial_chain(x).weighted_gradient(w),
            q,
            typical=fd.TYPICAL_SPATIAL,
            richardson=True,
        )
        F_rows = fd.derivative_scale(F, X)
        fd.assert_derivative_close(
            Hw.reshape(num.shape), num, f_scale=F_rows, what="weighted hessian"
        )
        GN = chain.weighted_gauss_newton(w)
        assert psd_min_eig(GN) >= -1e-12


def test_spatial_chain_attributes():
    q = ref.random_spatial_pose(np.random.default_rng(5), 3)
    chain = stackik.spatial_chain(q)
    assert chain.n == 3
    assert chain.A.shape == (4, 3, 3)
    assert chain.O.shape == (4, 3)
    assert chain.w.shape == (18, 3)
    assert np.array_equal(chain.A[0], np.eye(3))
    P, R = stackik.spatial_forward(q)
    assert_close(chain.A[-1], R, 1e-12)
    assert_close(chain.O[-1], P, 1e-12)
    norms = np.linalg.norm(chain.w, axis=1).reshape(3, 6)
    assert np.all(norms[:, :3] == 0)
    assert np.allclose(norms[:, 3:], 1.0)
    axes = ref.spatial_world_axes(q)
    assert_close(chain.w.reshape(3, 6, 3)[:, 3:], np.array(axes), 1e-12)


def test_weighted_norm_is_trace_of_output_covariance():
    # trace(J C_x J^T) is the mean square linearised end-effector displacement
    n = 3
    q = ref.random_spatial_pose(np.random.default_rng(6), n)
    w = noise_weights(n, 2.0, 0.01, spatial=True)
    chain = stackik.spatial_chain(q)
    J = chain.J
    assert chain.weighted_norm2(w) == pytest.approx(float(np.trace(J @ np.diag(w) @ J.T)))


def test_noise_weights():
    w = noise_weights(2, 3.0, 0.5)
    assert np.array_equal(w, [9.0, 9.0, 0.25, 9.0, 9.0, 0.25])
    ws = noise_weights(2, 3.0, 0.5, spatial=True)
    assert np.array_equal(ws, [9.0] * 3 + [0.25] * 3 + [9.0] * 3 + [0.25] * 3)
    assert noise_weights(1, 0.0, 0.0).tolist() == [0.0, 0.0, 0.0]
    for bad in [(-1.0, 0.1), (1.0, -0.1), (np.nan, 0.1), (1.0, np.inf)]:
        with pytest.raises(ValueError):
            noise_weights(2, *bad)


def test_planar_weighted_objective_with_noise_weights():
    n = 4
    q = ref.random_planar_pose(np.random.default_rng(7), n)
    J = stackik.planar_jacobian(q)
    w = noise_weights(n, 1.0, 0.005)
    expected = ref.weighted_objective(ref.planar_jacobian(q, 0.4), w)
    assert float(np.einsum("ra,ra,a->", J, J, w)) == pytest.approx(expected, rel=1e-9)


# =========================================================================================
# Planar vs lifted (3D) consistency
# =========================================================================================
@pose_params
@pytest.mark.parametrize("phi", PHIS)
def test_lift_planar_matches_spatial(n, seed, phi):
    rng = np.random.default_rng(1200 + seed)
    q = ref.random_planar_pose(rng, n)
    stack = to_stack([ref.random_geometry(rng) for _ in range(n)])
    P, R = stackik.lift_planar(q, phi)
    assert P.shape == (n, 3)
    assert R.shape == (n, 3, 3)
    q_s = np.concatenate([P, euler_zyx_from_matrix(R)], axis=1)
    assert_close(euler_zyx(q_s[:, 3:]), R, 1e-12, "Euler round trip")
    y = stackik.planar_forward(q)
    rho, z, theta = y
    P_ee, R_ee = stackik.spatial_forward(q_s)
    assert_close(P_ee, [rho * math.cos(phi), rho * math.sin(phi), z], REF_RTOL, "P_ee")
    assert_close(R_ee, rodrigues(plane_axis(phi), theta), REF_RTOL, "R_ee")
    assert_close(stack.spatial_constraints(q_s), stack.planar_constraints(q, phi), REF_RTOL, "c")
    # plate origins: the lifted ones lie in the plane and project onto the planar ones
    O3 = stackik.spatial_plate_origins(q_s)
    e_phi = np.array([math.cos(phi), math.sin(phi), 0.0])
    assert_close(O3 @ plane_axis(phi), np.zeros(n + 1), REF_RTOL, "in plane")
    O2 = np.column_stack([O3 @ e_phi, O3[:, 2]])
    assert_close(stackik.planar_plate_origins(q), O2, REF_RTOL, "origins")
    # the planar Jacobian is the spatial one restricted to the planar directions:
    # dP/d(rho_i, z_i, theta_i) projected on (e_phi, e_z), and theta_ee = sum theta
    Js = stackik.spatial_jacobian(q_s)
    Jp = stackik.planar_jacobian(q)
    assert_close(Jp[2], np.tile([0.0, 0.0, 1.0], n), 1e-15)
    # FN^2 of the planar model is that of (rho, z, theta), not of the 12 spatial outputs
    assert float(np.sum(Js**2)) >= float(np.sum(Jp**2)) - 1e-9 * float(np.sum(Js**2))


# =========================================================================================
# Property tests
# =========================================================================================
angles = st.floats(-3.0, 3.0, allow_nan=False)
small_angles = st.floats(-1.2, 1.2, allow_nan=False)
lengths = st.floats(-300.0, 300.0, allow_nan=False)


@st.composite
def spatial_poses(draw, max_n=4):
    n = draw(st.integers(1, max_n))
    xyz = draw(arrays(float, (n, 3), elements=lengths))
    ang = draw(arrays(float, (n, 3), elements=small_angles))
    return np.concatenate([xyz, ang], axis=1)


@st.composite
def planar_poses(draw, max_n=5):
    n = draw(st.integers(1, max_n))
    rz = draw(arrays(float, (n, 2), elements=lengths))
    th = draw(arrays(float, (n, 1), elements=angles))
    return np.concatenate([rz, th], axis=1)


@settings(max_examples=40, deadline=None)
@given(q=spatial_poses(), psi=angles)
def test_spatial_base_yaw_rotates_end_effector(q, psi):
    P, R = stackik.spatial_forward(q)
    q2 = q.copy()
    G = euler_zyx([psi, 0.0, 0.0])
    q2[0, :3] = G @ q[0, :3]
    q2[0, 3] += psi  # Rz(psi) Rz(yaw) Ry Rx = Rz(yaw + psi) Ry Rx
    P2, R2 = stackik.spatial_forward(q2)
    assert_close(P2, G @ P, 1e-9)
    assert_close(R2, G @ R, 1e-9)
    # FN^2 does not depend on the orientation of the base
    fn = float(np.sum(stackik.spatial_jacobian(q) ** 2))
    assert float(np.sum(stackik.spatial_jacobian(q2) ** 2)) == pytest.approx(fn, rel=1e-9)


@settings(max_examples=40, deadline=None)
@given(q=spatial_poses(), g=arrays(float, 3, elements=small_angles))
def test_spatial_general_base_rotation(q, g):
    G = euler_zyx(g)
    P, R = stackik.spatial_forward(q)
    q2 = q.copy()
    q2[0, :3] = G @ q[0, :3]
    q2[0, 3:] = euler_zyx_from_matrix(G @ euler_zyx(q[0, 3:]))
    P2, R2 = stackik.spatial_forward(q2)
    assert_close(P2, G @ P, 1e-9)
    assert_close(R2, G @ R, 1e-9)


@settings(max_examples=40, deadline=None)
@given(q=planar_poses(), alpha=angles)
def test_planar_base_rotation_composes(q, alpha):
    y = stackik.planar_forward(q)
    q2 = q.copy()
    c, s = math.cos(alpha), math.sin(alpha)
    q2[0, :2] = [c * q[0, 0] - s * q[0, 1], s * q[0, 0] + c * q[0, 1]]
    q2[0, 2] += alpha
    y2 = stackik.planar_forward(q2)
    assert_close(y2[:2], [c * y[0] - s * y[1], s * y[0] + c * y[1]], 1e-9)
    assert y2[2] == pytest.approx(y[2] + alpha, abs=1e-12)
    assert stackik.planar_fn2(q2) == pytest.approx(stackik.planar_fn2(q), rel=1e-9)
    assert y[2] == pytest.approx(float(q[:, 2].sum()), abs=1e-12)


@settings(max_examples=40, deadline=None)
@given(q=spatial_poses(max_n=5), data=st.data())
def test_spatial_chain_splits(q, data):
    # the stack is the composition of its lower and upper parts
    n = q.shape[0]
    k = data.draw(st.integers(0, n))
    P, R = stackik.spatial_forward(q)
    Pa, Ra = stackik.spatial_forward(q[:k]) if k else (np.zeros(3), np.eye(3))
    Pb, Rb = stackik.spatial_forward(q[k:]) if k < n else (np.zeros(3), np.eye(3))
    assert_close(P, Pa + Ra @ Pb, 1e-9)
    assert_close(R, Ra @ Rb, 1e-9)


@settings(max_examples=30, deadline=None)
@given(q=planar_poses(), phi=angles)
def test_planar_closed_form_property(q, phi):
    n = q.shape[0]
    closed = ref.planar_fn2_closed_form(q, phi)
    J = stackik.planar_jacobian(q)
    assert float(np.sum(J**2)) == pytest.approx(closed, rel=1e-9)
    assert stackik.planar_fn2(q) == pytest.approx(closed, rel=1e-9)
    assert closed >= 3 * n


@settings(max_examples=25, deadline=None)
@given(
    n=st.integers(1, 4),
    batch=st.lists(st.integers(1, 3), min_size=1, max_size=2),
    seed=st.integers(0, 2**32 - 1),
)
def test_batch_evaluation_equals_per_pose(n, batch, seed):
    rng = np.random.default_rng(seed)
    shape = tuple(batch)
    qp = np.stack([ref.random_planar_pose(rng, n) for _ in range(math.prod(shape))])
    qp = qp.reshape(shape + (n, 3))
    qs = np.stack([ref.random_spatial_pose(rng, n) for _ in range(math.prod(shape))])
    qs = qs.reshape(shape + (n, 6))
    y = stackik.planar_forward(qp)
    J = stackik.planar_jacobian(qp)
    O = stackik.planar_plate_origins(qp)
    fn2 = stackik.planar_fn2(qp)
    P, R = stackik.spatial_forward(qs)
    assert y.shape == shape + (3,)
    assert J.shape == shape + (3, 3 * n)
    assert O.shape == shape + (n + 1, 2)
    assert np.shape(fn2) == shape
    assert P.shape == shape + (3,)
    assert R.shape == shape + (3, 3)
    for idx in np.ndindex(*shape):
        assert_close(y[idx], stackik.planar_forward(qp[idx]), 1e-12)
        assert_close(J[idx], stackik.planar_jacobian(qp[idx]), 1e-12)
        assert_close(O[idx], stackik.planar_plate_origins(qp[idx]), 1e-12)
        assert fn2[idx] == pytest.approx(stackik.planar_fn2(qp[idx]), rel=1e-12)
        P1, R1 = stackik.spatial_forward(qs[idx])
        assert_close(P[idx], P1, 1e-12)
        assert_close(R[idx], R1, 1e-12)


# =========================================================================================
# Validation
# =========================================================================================
@pytest.mark.parametrize(
    "bad",
    [
        np.zeros(3),  # 1D
        np.zeros((2, 4)),  # wrong columns
        np.array([[1.0, np.nan, 0.0]]),
        np.array([[1.0, 2.0, np.inf]]),
        [["a", "b", "c"]],
    ],
)
def test_planar_pose_validation(bad):
    for f in (
        stackik.planar_forward,
        stackik.planar_jacobian,
        stackik.planar_fn2,
        stackik.planar_plate_origins,
        planar_fn_residuals,
        planar_hessian_fn2,
        PlanarFN.at,
        lambda x: stackik.lift_planar(x, 0.1),
    ):
        with pytest.raises(ValueError):
            f(bad)


@pytest.mark.parametrize(
    "bad",
    [
        np.zeros(6),
        np.zeros((2, 3)),
        np.array([[0.0, 0.0, 300.0, np.nan, 0.0, 0.0]]),
        np.array([[0.0, 0.0, -np.inf, 0.0, 0.0, 0.0]]),
    ],
)
def test_spatial_pose_validation(bad):
    for f in (
        stackik.spatial_forward,
        stackik.spatial_jacobian,
        stackik.spatial_plate_origins,
        stackik.spatial_chain,
    ):
        with pytest.raises(ValueError):
            f(bad)


@pytest.mark.parametrize("phi", [np.nan, np.inf, "x", None])
def test_lift_planar_phi_validation(phi):
    with pytest.raises(ValueError):
        stackik.lift_planar(np.array([[0.0, 300.0, 0.1]]), phi)


def test_lift_planar_batch():
    q = ref.random_planar_pose(np.random.default_rng(8), 6).reshape(2, 3, 3)
    P, R = stackik.lift_planar(q, 0.4)
    assert P.shape == (2, 3, 3) and R.shape == (2, 3, 3, 3)
    P1, R1 = stackik.lift_planar(q[1], 0.4)
    assert_close(P[1], P1, 1e-15)
    assert_close(R[1], R1, 1e-15)


def test_single_pose_only_functions_reject_batches():
    with pytest.raises(ValueError):
        stackik.spatial_chain(np.zeros((2, 1, 6)))
    with pytest.raises(ValueError):
        planar_fn_residuals(np.zeros((2, 1, 3)))


def test_frobenius_norm_validation():
    assert stackik.frobenius_norm(np.array([[3.0, 4.0]])) == 5.0
    for bad in (np.zeros(3), np.zeros((2, 2, 2)), np.array([[np.nan]])):
        with pytest.raises(ValueError):
            stackik.frobenius_norm(bad)


def test_single_platform_forward_is_identity_map():
    q = np.array([[-42.0, 310.0, 0.25]])
    assert_close(stackik.planar_forward(q), q[0], 1e-15)
    qs = np.array([[10.0, -20.0, 300.0, 0.1, -0.2, 0.3]])
    P, R = stackik.spatial_forward(qs)
    assert_close(P, qs[0, :3], 1e-15)
    assert_close(R, euler_zyx(qs[0, 3:]), 1e-15)


def test_position_hessian_matches_full_tensor():
    rng = np.random.default_rng(3)
    q = rng.normal(size=(5, 6)) * [40, 40, 40, 0.3, 0.3, 0.3] + [0, 0, 300, 0, 0, 0]
    ch = stackik.spatial_chain(q)
    cols = np.array([c for c in range(30) if c % 6 >= 3])
    np.testing.assert_allclose(ch.position_hessian(cols), ch.hessian()[:3][:, cols, :], atol=1e-12)
