"""Rotations: planar Rodrigues rotation and ZYX Euler angles (DESIGN §3-4)."""

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
from scipy.spatial.transform import Rotation

from stackik.rotations import (
    cross_matrix,
    euler_zyx,
    euler_zyx_derivatives,
    euler_zyx_from_matrix,
    plane_axis,
    rodrigues,
    rodrigues_derivative,
    rotation_2d,
)

# Derivatives are checked by fd.py: rotation matrices have entries of scale F = 1, angles
# the scale X = max(|angle|, 1); the tolerances follow from these and the step.
PHIS = [0.0, 0.7, -2.1, math.pi / 2, 3.0]

angle = st.floats(-4.0, 4.0, allow_nan=False)
angles3 = arrays(float, 3, elements=angle)


def assert_rotation(R, tol=1e-12):
    R = np.asarray(R)
    eye = np.broadcast_to(np.eye(3), R.shape)
    assert np.allclose(np.swapaxes(R, -1, -2) @ R, eye, rtol=0, atol=tol)
    assert np.allclose(np.linalg.det(R), 1.0, rtol=0, atol=tol)


# =========================================================================================
# Axis, cross matrix, Rodrigues
# =========================================================================================
@pytest.mark.parametrize("phi", PHIS)
def test_plane_axis(phi):
    s = plane_axis(phi)
    assert_close(s, [math.sin(phi), -math.cos(phi), 0.0], 0.0)
    e_phi = np.array([math.cos(phi), math.sin(phi), 0.0])
    assert_close(s, np.cross(e_phi, [0.0, 0.0, 1.0]), 1e-15)
    assert np.linalg.norm(s) == pytest.approx(1.0)


def test_cross_matrix():
    rng = np.random.default_rng(0)
    v, u = rng.normal(size=(2, 5, 3))
    K = cross_matrix(v)
    assert K.shape == (5, 3, 3)
    assert_close(np.einsum("nij,nj->ni", K, u), np.cross(v, u), 1e-14)
    assert_close(K, -np.swapaxes(K, -1, -2), 0.0)


@pytest.mark.parametrize("phi", PHIS)
def test_rodrigues_matches_scipy_and_reference(phi):
    s = plane_axis(phi)
    th = np.random.default_rng(1).uniform(-4, 4, 7)
    R = rodrigues(s, th)
    assert R.shape == (7, 3, 3)
    assert_rotation(R)
    assert_close(R, Rotation.from_rotvec(th[:, None] * s).as_matrix(), 1e-14)
    for k in range(7):
        assert_close(R[k], ref.rodrigues(s, th[k]), 1e-14)
        assert_close(R[k] @ s, s, 1e-14)  # the axis is fixed
    assert_close(rodrigues(s, 0.0), np.eye(3), 0.0)


@pytest.mark.parametrize("phi", PHIS)
def test_rodrigues_is_the_2d_rotation_in_the_plane(phi):
    """In (rho, z) coordinates (basis e_phi, e_z) the rotation is [[c, -s], [s, c]]."""
    E = np.array([[math.cos(phi), math.sin(phi), 0.0], [0.0, 0.0, 1.0]])  # rows e_phi, e_z
    for th in (-2.0, -0.3, 0.0, 0.4, 1.7, 3.1):
        R = rodrigues(plane_axis(phi), th)
        assert_close(E @ R @ E.T, rotation_2d(th), 1e-14)
        assert_close(
            rotation_2d(th), [[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]], 0
        )
        # a positive theta tips e_phi (radial) towards e_z (up)
    R = rodrigues(plane_axis(phi), 0.1)
    assert (E @ R @ E.T)[1, 0] > 0


@pytest.mark.derivatives
@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("phi", PHIS)
def test_rodrigues_derivative_finite_differences(seed, phi):
    s = plane_axis(phi)
    th = np.random.default_rng(seed).uniform(-4, 4, 5)
    dR = rodrigues_derivative(s, th)
    assert dR.shape == (5, 3, 3)
    num = fd.central(lambda t: rodrigues(s, t), th)  # (5, 3, 3, 5): R_k depends on th_k only
    full = np.einsum("kij,km->kijm", dR, np.eye(5))
    fd.assert_derivative_close(full, num, f_scale=1.0, what="dR/dtheta")
    assert_close(dR, cross_matrix(s) @ rodrigues(s, th), 1e-14, "[s]x R")


@pytest.mark.derivatives
def test_rodrigues_general_axis_and_derivative():
    rng = np.random.default_rng(4)
    s = rng.normal(size=3)
    s /= np.linalg.norm(s)
    th = 0.83
    assert_close(rodrigues(s, th), Rotation.from_rotvec(th * s).as_matrix(), 1e-14)
    num = fd.central(lambda t: rodrigues(s, float(t)), th)  # (3, 3)
    fd.assert_derivative_close(rodrigues_derivative(s, th), num, f_scale=1.0, what="dR/dtheta")


def test_rotation_2d_shapes():
    assert rotation_2d(0.3).shape == (2, 2)
    assert rotation_2d(np.zeros((4, 5))).shape == (4, 5, 2, 2)


# =========================================================================================
# ZYX Euler
# =========================================================================================
@pytest.mark.parametrize("seed", range(4))
def test_euler_zyx_matches_scipy_and_elementary_product(seed):
    a = np.random.default_rng(seed).uniform(-3, 3, (6, 3))
    R = euler_zyx(a)
    assert R.shape == (6, 3, 3)
    assert_rotation(R)
    assert_close(R, Rotation.from_euler("ZYX", a).as_matrix(), 1e-14)
    for k in range(6):
        assert_close(R[k], ref.euler_zyx_explicit(*a[k]).real, 1e-14)
        assert_close(R[k], ref.euler_zyx_scipy(*a[k]), 1e-14)


def test_euler_zyx_elementary_rotations():
    t = 0.4
    c, s = math.cos(t), math.sin(t)
    assert_close(euler_zyx([t, 0, 0]), [[c, -s, 0], [s, c, 0], [0, 0, 1]], 1e-15)
    assert_close(euler_zyx([0, t, 0]), [[c, 0, s], [0, 1, 0], [-s, 0, c]], 1e-15)
    assert_close(euler_zyx([0, 0, t]), [[1, 0, 0], [0, c, -s], [0, s, c]], 1e-15)


@pytest.mark.derivatives
@pytest.mark.parametrize("seed", range(4))
def test_euler_zyx_derivatives_finite_differences(seed):
    a = np.random.default_rng(10 + seed).uniform(-3, 3, (4, 3))
    D = euler_zyx_derivatives(a)
    assert D.shape == (4, 3, 3, 3)
    num = fd.central(euler_zyx, a)  # (4, 3, 3, 4, 3): R_k depends on a_k only
    full = np.einsum("klij,km->kijml", D, np.eye(4))
    fd.assert_derivative_close(full, num, f_scale=1.0, what="dR/dangles")
    # and by the complex step of the written-out reference
    for k in range(4):
        cs = fd.complex_step(lambda x: ref.euler_zyx_explicit(*x), a[k])  # (3, 3, 3)
        Dk = np.moveaxis(D[k], 0, -1)
        fd.assert_derivative_close(Dk, cs, f_scale=1.0, what="dR/dangles vs complex step")


@pytest.mark.parametrize("seed", range(4))
def test_euler_zyx_from_matrix_round_trip(seed):
    rng = np.random.default_rng(20 + seed)
    a = np.column_stack(
        [rng.uniform(-3.1, 3.1, 8), rng.uniform(-1.5, 1.5, 8), rng.uniform(-3.1, 3.1, 8)]
    )
    back = euler_zyx_from_matrix(euler_zyx(a))
    assert back.shape == (8, 3)
    assert_close(back, a, 1e-10)
    assert euler_zyx_from_matrix(np.eye(3)).shape == (3,)
    assert euler_zyx_from_matrix(euler_zyx(a).reshape(2, 4, 3, 3)).shape == (2, 4, 3)


# =========================================================================================
# Property tests
# =========================================================================================
@settings(max_examples=60, deadline=None)
@given(a=angles3)
def test_euler_zyx_is_a_rotation(a):
    R = euler_zyx(a)
    assert_rotation(R)
    # and the matrix maps back to angles giving the same matrix (even past gimbal ranges)
    assert_close(euler_zyx(euler_zyx_from_matrix(R)), R, 1e-9)


@settings(max_examples=60, deadline=None)
@given(phi=angle, a=angle, b=angle)
def test_rodrigues_composes(phi, a, b):
    s = plane_axis(phi)
    Ra, Rb = rodrigues(s, a), rodrigues(s, b)
    assert_rotation(Ra)
    assert_close(Ra @ Rb, rodrigues(s, a + b), 1e-12)
    assert_close(Ra @ Rb, Rb @ Ra, 1e-12)
    assert_close(rotation_2d(a) @ rotation_2d(b), rotation_2d(a + b), 1e-12)
    assert_close(rodrigues(s, -a), Ra.T, 1e-12)


@settings(max_examples=40, deadline=None)
@given(a=arrays(float, (3, 2), elements=angle))
def test_rotations_broadcast_over_batches(a):
    s = plane_axis(0.3)
    R = rodrigues(s, a)
    D = rodrigues_derivative(s, a)
    assert R.shape == D.shape == (3, 2, 3, 3)
    for idx in np.ndindex(3, 2):
        assert_close(R[idx], rodrigues(s, a[idx]), 0.0)
        assert_close(D[idx], rodrigues_derivative(s, a[idx]), 0.0)
    E = euler_zyx(a.reshape(2, 3))
    assert E.shape == (2, 3, 3)
    assert_close(E[1], euler_zyx(a.reshape(2, 3)[1]), 0.0)
