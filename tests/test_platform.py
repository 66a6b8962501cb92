"""One platform: legs, the 24 constraints and their Jacobians, forward kinematics (DESIGN §2)."""

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
from stackik.platform import (
    CONSTRAINT_BLOCKS,
    PlatformFKStatus,
    planar_constraint_jacobian,
    planar_constraints,
    platform_forward_kinematics,
    spatial_constraint_jacobian,
    spatial_constraints,
)
from stackik.rotations import euler_zyx, euler_zyx_from_matrix

NS = [1, 2, 4, 7]
PHIS = [0.0, 0.7, -2.1, math.pi / 2, 3.0]
REF_RTOL = 1e-9
# Derivatives are checked by fd.py: tolerances from the step and the constraints' scale.


def to_geometry(g):
    return PlatformGeometry(g["base"], g["top"], g["leg_min"], g["leg_max"], g["joint_min"])


def constraint_scale(geoms, q):
    """F of the 24 constraints of each platform (fd.constraint_scale), shape (n, 24)."""
    top = np.array([g["top"] for g in geoms])
    base = np.array([g["base"] for g in geoms])
    return fd.constraint_scale(top, base, [g["leg_max"] for g in geoms], q)


def mixed(rng, n):
    """A mixed stack: random asymmetric geometries, plus the reference one when n > 2."""
    geoms = [ref.random_geometry(rng) for _ in range(n)]
    if n > 2:
        geoms[1] = ref.hexagonal_geometry()
    return geoms, Stack(tuple(to_geometry(g) for g in geoms))


cases = pytest.mark.parametrize(("n", "seed"), [(n, s) for n in NS for s in (0, 1)])


# =========================================================================================
# Agreement with the reference implementation
# =========================================================================================
@pytest.mark.derivatives
@cases
@pytest.mark.parametrize("phi", PHIS)
def test_planar_constraints_match_reference(n, seed, phi):
    rng = np.random.default_rng(seed)
    geoms, stack = mixed(rng, n)
    q = ref.random_planar_pose(rng, n)
    c = stack.planar_constraints(q, phi)
    assert c.shape == (n, 24)
    assert_close(c, ref.planar_constraints(geoms, q, phi), REF_RTOL, "c")
    c2, Jc = planar_constraint_jacobian(stack, q, phi)
    assert np.array_equal(c2, c)
    assert np.array_equal(planar_constraints(stack, q, phi), c)
    assert Jc.shape == (n, 24, 3)
    # the reference's Jacobian, by complex step (as ref.planar_constraint_jacobian)
    cs = fd.complex_step(
        lambda x: ref.planar_constraints(geoms, x, phi), q, typical=fd.TYPICAL_PLANAR
    )
    F = constraint_scale(geoms, q)
    fd.assert_derivative_close(fd.block_diagonal(Jc), cs, f_scale=F, what="Jc")
    full = cs.value
    # block diagonal: platform i's constraints depend on platform i only
    for i in range(n):
        for j in range(n):
            if i != j:
                assert np.all(full[i, :, j, :] == 0)


@pytest.mark.derivatives
@cases
def test_spatial_constraints_match_reference(n, seed):
    rng = np.random.default_rng(50 + seed)
    geoms, stack = mixed(rng, n)
    q = ref.random_spatial_pose(rng, n)
    c = stack.spatial_constraints(q)
    assert c.shape == (n, 24)
    assert_close(c, ref.spatial_constraints(geoms, q), REF_RTOL, "c")
    c2, Jc = spatial_constraint_jacobian(stack, q)
    assert np.array_equal(c2, c)
    assert np.array_equal(spatial_constraints(stack, q), c)
    assert Jc.shape == (n, 24, 6)
    # the reference's Jacobian, by complex step (as ref.spatial_constraint_jacobian)
    cs = fd.complex_step(lambda x: ref.spatial_constraints(geoms, x), q, typical=fd.TYPICAL_SPATIAL)
    F = constraint_scale(geoms, q)
    fd.assert_derivative_close(fd.block_diagonal(Jc), cs, f_scale=F, what="Jc")


@pytest.mark.parametrize("seed", range(4))
def test_leg_vectors_and_lengths_match_reference(seed):
    rng = np.random.default_rng(100 + seed)
    g = ref.random_geometry(rng)
    geom = to_geometry(g)
    x = ref.random_spatial_pose(rng, 1)[0]
    R = euler_zyx(x[3:])
    l = stackik.leg_vectors(geom, x[:3], R)
    assert l.shape == (6, 3)
    for k in range(6):
        assert_close(l[k], R @ g["top"][k] + x[:3] - g["base"][k], 1e-12)
    assert_close(stackik.leg_lengths(geom, x[:3], R), ref.leg_lengths(g, x[:3], R), 1e-12)


# =========================================================================================
# Finite differences
# =========================================================================================
@pytest.mark.derivatives
@cases
@pytest.mark.parametrize("phi", [0.3, -2.5])
def test_planar_constraint_jacobian_finite_differences(n, seed, phi):
    rng = np.random.default_rng(200 + seed)
    geoms, stack = mixed(rng, n)
    q = ref.random_planar_pose(rng, n)
    _, Jc = planar_constraint_jacobian(stack, q, phi)
    num = fd.central(lambda x: stack.planar_constraints(x, phi), q, typical=fd.TYPICAL_PLANAR)
    F = constraint_scale(geoms, q)
    fd.assert_derivative_close(fd.block_diagonal(Jc), num, f_scale=F, what="planar Jc")


@pytest.mark.derivatives
@cases
def test_spatial_constraint_jacobian_finite_differences(n, seed):
    rng = np.random.default_rng(300 + seed)
    geoms, stack = mixed(rng, n)
    q = ref.random_spatial_pose(rng, n)
    _, Jc = spatial_constraint_jacobian(stack, q)
    num = fd.central(stack.spatial_constraints, q, typical=fd.TYPICAL_SPATIAL)  # (n,24,n,6)
    F = constraint_scale(geoms, q)
    fd.assert_derivative_close(fd.block_diagonal(Jc), num, f_scale=F, what="spatial Jc")


# =========================================================================================
# Meaning and order of the 24 constraints
# =========================================================================================
def test_constraint_blocks_by_hand():
    geom = PlatformGeometry.reference()
    stack = Stack.reference(1)
    x = np.array([12.0, -7.0, 330.0, 0.1, -0.05, 0.2])
    P, R = x[:3], euler_zyx(x[3:])
    l = stackik.leg_vectors(geom, P, R)
    L = np.linalg.norm(l, axis=1)
    s = math.sin(geom.joint_min)
    c = stack.spatial_constraints(x[None])[0]
    assert CONSTRAINT_BLOCKS == ("leg_min", "leg_max", "joint_base", "joint_top")
    assert_close(c[0:6], L**2 - 250.0**2, 1e-12)
    assert_close(c[6:12], 450.0**2 - L**2, 1e-12)
    assert_close(c[12:18], l[:, 2] - L * s, 1e-12)
    assert_close(c[18:24], l @ R[:, 2] - L * s, 1e-12)
    assert np.all(c > 0)  # a comfortable mid-range pose is feasible


def test_constraint_violations_flip_the_right_blocks():
    stack = Stack.reference(1)
    straight = np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0]])
    too_short = straight + [0, 0, 100.0, 0, 0, 0]
    too_long = straight + [0, 0, 600.0, 0, 0, 0]
    c = stack.spatial_constraints(too_short)[0]
    assert np.all(c[0:6] < 0) and np.all(c[6:12] > 0)
    c = stack.spatial_constraints(too_long)[0]
    assert np.all(c[0:6] > 0) and np.all(c[6:12] < 0)
    # sliding sideways lays the legs flat: both joint-angle blocks go negative
    flat = np.array([[400.0, 0.0, 30.0, 0.0, 0.0, 0.0]])
    c = stack.spatial_constraints(flat)[0]
    assert np.all(c[12:18] < 0) and np.all(c[18:24] < 0)
    # tilting the top plate by 90 degrees violates the top joint limit only for some legs
    tilted = np.array([[0.0, 0.0, 350.0, 0.0, math.pi / 2 - 0.05, 0.0]])
    c = stack.spatial_constraints(tilted)[0]
    assert np.all(c[12:18] > 0) and np.any(c[18:24] < 0)


def test_planar_constraints_depend_on_phi():
    stack = Stack.reference(2)
    q = np.array([[60.0, 320.0, 0.3], [-40.0, 300.0, -0.2]])
    c0 = stack.planar_constraints(q, 0.0)
    c1 = stack.planar_constraints(q, 0.5)
    assert not np.allclose(c0, c1)
    # three-fold symmetry of the hexagonal layout: phi and phi + 120 deg give the same
    # constraint values, with legs permuted cyclically by two
    c3 = stack.planar_constraints(q, 2 * math.pi / 3)
    perm = np.concatenate([np.roll(np.arange(6), -2) + 6 * b for b in range(4)])
    assert_close(c3[:, perm], c0, 1e-9)


# =========================================================================================
# Batches and validation
# =========================================================================================
@settings(max_examples=20, deadline=None)
@given(
    n=st.integers(1, 3),
    batch=st.lists(st.integers(1, 3), min_size=1, max_size=2),
    seed=st.integers(0, 2**32 - 1),
    phi=st.floats(-3.2, 3.2),
)
def test_batch_constraints_equal_per_pose(n, batch, seed, phi):
    rng = np.random.default_rng(seed)
    _, stack = mixed(rng, n)
    shape = tuple(batch)
    m = math.prod(shape)
    qp = np.stack([ref.random_planar_pose(rng, n) for _ in range(m)]).reshape(shape + (n, 3))
    qs = np.stack([ref.random_spatial_pose(rng, n) for _ in range(m)]).reshape(shape + (n, 6))
    cp, Jp = planar_constraint_jacobian(stack, qp, phi)
    cs, Js = spatial_constraint_jacobian(stack, qs)
    assert cp.shape == shape + (n, 24) and Jp.shape == shape + (n, 24, 3)
    assert cs.shape == shape + (n, 24) and Js.shape == shape + (n, 24, 6)
    assert np.array_equal(stack.planar_constraints(qp, phi), cp)
    assert np.array_equal(stack.spatial_constraints(qs), cs)
    for idx in np.ndindex(*shape):
        c1, J1 = planar_constraint_jacobian(stack, qp[idx], phi)
        assert_close(cp[idx], c1, 1e-12)
        assert_close(Jp[idx], J1, 1e-12)
        c1, J1 = spatial_constraint_jacobian(stack, qs[idx])
        assert_close(cs[idx], c1, 1e-12)
        assert_close(Js[idx], J1, 1e-12)


@pytest.mark.parametrize(
    "bad",
    [
        np.zeros(3),
        np.zeros((3, 3)),  # wrong n (stack has 2)
        np.zeros((2, 6)),
        np.array([[0.0, 300.0, np.nan], [0.0, 300.0, 0.0]]),
        np.array([[0.0, np.inf, 0.0], [0.0, 300.0, 0.0]]),
        "not a pose",
    ],
)
def test_planar_constraint_pose_validation(bad):
    stack = Stack.reference(2)
    with pytest.raises(ValueError):
        stack.planar_constraints(bad, 0.1)
    with pytest.raises(ValueError):
        planar_constraint_jacobian(stack, bad, 0.1)


@pytest.mark.parametrize("phi", [np.nan, np.inf, "x", None])
def test_planar_constraint_phi_validation(phi):
    stack = Stack.reference(1)
    with pytest.raises(ValueError):
        stack.planar_constraints(np.array([[0.0, 300.0, 0.0]]), phi)


@pytest.mark.parametrize(
    "bad",
    [np.zeros(6), np.zeros((3, 6)), np.zeros((2, 3)), np.full((2, 6), np.nan)],
)
def test_spatial_constraint_pose_validation(bad):
    stack = Stack.reference(2)
    with pytest.raises(ValueError):
        stack.spatial_constraints(bad)
    with pytest.raises(ValueError):
        spatial_constraint_jacobian(stack, bad)


# =========================================================================================
# Invariances of the leg lengths (property tests)
# =========================================================================================
vec = arrays(float, 3, elements=st.floats(-200.0, 200.0))
rot = arrays(float, 3, elements=st.floats(-3.0, 3.0))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), G_ang=rot, g=vec, H_ang=rot, h=vec)
def test_leg_lengths_invariant_under_plate_frame_changes(seed, G_ang, g, H_ang, h):
    """Moving the bottom frame (nodes and pose together) or the top frame leaves |l| alone."""
    rng = np.random.default_rng(seed)
    geo = ref.random_geometry(rng)
    x = ref.random_spatial_pose(rng, 1)[0]
    P, R = x[:3], euler_zyx(x[3:])
    L = stackik.leg_lengths(to_geometry(geo), P, R)
    G, H = euler_zyx(G_ang), euler_zyx(H_ang)
    # bottom frame: b' = G b + g, P' = G P + g, R' = G R
    moved = PlatformGeometry(geo["base"] @ G.T + g, geo["top"], 1.0, 2.0, 0.0)
    assert_close(stackik.leg_lengths(moved, G @ P + g, G @ R), L, 1e-9)
    # top frame: t' = H t + h, R' = R H^T, P' = P - R H^T h
    moved = PlatformGeometry(geo["base"], geo["top"] @ H.T + h, 1.0, 2.0, 0.0)
    assert_close(stackik.leg_lengths(moved, P - R @ H.T @ h, R @ H.T), L, 1e-9)


@settings(max_examples=30, deadline=None)
@given(x=arrays(float, 6, elements=st.floats(-0.8, 0.8)), k=st.integers(1, 2))
def test_hexagonal_leg_lengths_threefold_symmetry(x, k):
    """Rotating the pose by 120 k deg about z permutes the legs of the hexagonal layout."""
    geom = PlatformGeometry.reference()
    P = np.array([100 * x[0], 100 * x[1], 300 + 100 * x[2]])
    R = euler_zyx(x[3:])
    G = euler_zyx([2 * math.pi * k / 3, 0.0, 0.0])
    L = stackik.leg_lengths(geom, P, R)
    L2 = stackik.leg_lengths(geom, G @ P, G @ R @ G.T)
    assert_close(L2, np.roll(L, 2 * k), 1e-9)
    stack = Stack.reference(1)
    q = np.concatenate([P, x[3:]])[None]
    q2 = np.concatenate([G @ P, euler_zyx_from_matrix(G @ R @ G.T)])[None]
    perm = np.concatenate([np.roll(np.arange(6), 2 * k) + 6 * b for b in range(4)])
    assert_close(stack.spatial_constraints(q2)[0], stack.spatial_constraints(q)[0][perm], 1e-9)


# =========================================================================================
# Forward kinematics of one platform
# =========================================================================================
@pytest.mark.parametrize("seed", range(6))
def test_platform_forward_kinematics_recovers_pose(seed):
    rng = np.random.default_rng(400 + seed)
    geom = PlatformGeometry.reference() if seed % 2 else to_geometry(ref.random_geometry(rng))
    x_true = np.array([*rng.uniform(-40, 40, 2), rng.uniform(280, 380), *rng.uniform(-0.2, 0.2, 3)])
    L = stackik.leg_lengths(geom, x_true[:3], euler_zyx(x_true[3:]))
    x0 = x_true + np.concatenate([rng.normal(0, 5, 3), rng.normal(0, 0.03, 3)])
    for start in (x0, None):
        res = platform_forward_kinematics(geom, L, x0=start)
        assert res.status is PlatformFKStatus.CONVERGED
        assert res.success
        assert res.residual <= 1e-10
        assert_close(stackik.leg_lengths(geom, res.P, res.R), L, 1e-12)
        assert_close(res.x, x_true, 1e-7)
        assert_close(res.R, euler_zyx(res.x[3:]), 1e-15)
        assert np.array_equal(res.P, res.x[:3])


def test_platform_forward_kinematics_max_iter_zero():
    geom = PlatformGeometry.reference()
    x = np.array([10.0, 5.0, 320.0, 0.05, 0.02, -0.03])
    L = stackik.leg_lengths(geom, x[:3], euler_zyx(x[3:]))
    res = platform_forward_kinematics(geom, L, max_iter=0)
    assert res.status is PlatformFKStatus.MAX_ITER
    assert not res.success
    assert res.nit == 0
    assert res.residual > 1e-3
    # the start is returned untouched
    assert_close(res.x, [0.0, 0.0, 350.0, 0.0, 0.0, 0.0], 0.0)


def test_platform_forward_kinematics_impossible_lengths_does_not_raise():
    geom = PlatformGeometry.reference()
    res = platform_forward_kinematics(geom, np.full(6, 1.0))  # legs of 1 mm cannot close
    assert res.status is not PlatformFKStatus.CONVERGED
    assert not res.success
    assert res.residual > 1.0
    assert res.x.shape == (6,)


@pytest.mark.parametrize(
    "lengths", [np.ones(5), np.full(6, np.nan), [300.0] * 5 + [-1.0], [300.0] * 5 + [0.0]]
)
def test_platform_forward_kinematics_rejects_bad_lengths(lengths):
    with pytest.raises(ValueError):
        platform_forward_kinematics(PlatformGeometry.reference(), lengths)


@pytest.mark.parametrize("x0", [np.zeros(5), np.full(6, np.inf)])
def test_platform_forward_kinematics_rejects_bad_start(x0):
    with pytest.raises(ValueError):
        platform_forward_kinematics(PlatformGeometry.reference(), np.full(6, 300.0), x0=x0)
