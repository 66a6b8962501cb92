"""Targets: the spatial constructors against scipy's Rotation, and messages that say what
is wrong with bad input (not numbers, the wrong shape, NaN or infinite entries)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import stackik as sk
from stackik.rotations import euler_zyx

P = [120.0, -40.0, 1300.0]  # [mm]


def _rotations() -> Rotation:
    return Rotation.random(20, random_state=np.random.default_rng(7))


def test_from_euler_is_scipy_zyx_and_the_platform_convention():
    rng = np.random.default_rng(3)
    for yaw, pitch, roll in rng.uniform(-np.pi, np.pi, (20, 3)) * [1.0, 0.49, 1.0]:
        t = sk.SpatialTarget.from_euler(P, yaw, pitch, roll)
        R = Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_matrix()
        np.testing.assert_allclose(t.rotation, R, atol=1e-14)
        np.testing.assert_allclose(t.rotation, euler_zyx([yaw, pitch, roll]), atol=1e-15)
        np.testing.assert_array_equal(t.position, P)


def test_from_euler_takes_keywords_and_names_a_non_finite_angle():
    t = sk.SpatialTarget.from_euler(P, yaw=0.3, pitch=-0.1, roll=0.2)
    np.testing.assert_allclose(t.rotation, Rotation.from_euler("ZYX", [0.3, -0.1, 0.2]).as_matrix())
    with pytest.raises(ValueError, match="pitch: must be finite"):
        sk.SpatialTarget.from_euler(P, 0.0, float("nan"), 0.0)


def test_from_rotvec_matches_scipy():
    for rot in _rotations():
        t = sk.SpatialTarget.from_rotvec(P, rot.as_rotvec())
        np.testing.assert_allclose(t.rotation, rot.as_matrix(), atol=1e-13)
    np.testing.assert_array_equal(sk.SpatialTarget.from_rotvec(P, [0, 0, 0]).rotation, np.eye(3))


def test_from_quat_is_scalar_last_as_scipy_and_normalises():
    for rot in _rotations():
        quat = rot.as_quat()  # (x, y, z, w)
        for scale in (1.0, 3.5):
            t = sk.SpatialTarget.from_quat(P, scale * quat)
            np.testing.assert_allclose(t.rotation, rot.as_matrix(), atol=1e-13)
    # (0, 0, 0, 1) is the identity scalar-last (scalar-first it would be a half turn)
    np.testing.assert_allclose(sk.SpatialTarget.from_quat(P, [0, 0, 0, 1]).rotation, np.eye(3))
    with pytest.raises(ValueError, match="quat: a zero quaternion"):
        sk.SpatialTarget.from_quat(P, [0, 0, 0, 0])
    with pytest.raises(ValueError, match=r"quat: expected shape \(4,\), got shape \(3,\)"):
        sk.SpatialTarget.from_quat(P, [0, 0, 1])


@pytest.mark.parametrize(
    ("position", "rotation", "message"),
    [
        ([np.nan, 0.0, 1000.0], np.eye(3), r"position: must be finite; NaN or infinite at index 0"),
        ([0.0, 0.0, np.inf], np.eye(3), r"position: must be finite; NaN or infinite at index 2"),
        ([0.0, 1000.0], np.eye(3), r"position: expected shape \(3,\), got shape \(2,\)"),
        ("abc", np.eye(3), r"position: expected an array of numbers of shape \(3,\), got 'abc'"),
        (P, np.eye(2), r"rotation: expected shape \(3, 3\), got shape \(2, 2\)"),
        (P, [[np.nan, 0, 0], [0, 1, 0], [0, 0, 1]], r"rotation: must be finite; .* \(0, 0\)"),
        (P, np.diag([1.0, 1.0, -1.0]), r"rotation: .*det R = -1, a reflection"),
        (P, 2 * np.eye(3), r"rotation: not a rotation matrix \(max \|R\^T R - I\| = 3"),
    ],
)
def test_a_bad_spatial_target_says_what_is_wrong(position, rotation, message):
    with pytest.raises(ValueError, match=message):
        sk.SpatialTarget(position, rotation)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((np.nan, 1000.0, 0.0), "rho: must be finite, got nan"),
        ((0.0, np.inf, 0.0), "z: must be finite, got inf"),
        ((0.0, 1000.0, "0.1"), "theta: expected a number, got '0.1'"),
        ((0.0, 1000.0, 0.0, [0.1]), r"phi: expected a number"),
    ],
)
def test_a_bad_planar_target_names_the_field(args, message):
    with pytest.raises(ValueError, match=message):
        sk.PlanarTarget(*args)


@pytest.mark.parametrize(
    ("x0", "message"),
    [
        (np.zeros((2, 3)), r"x0: expected shape \(3, 3\), got shape \(2, 3\)"),
        (np.full((3, 3), np.nan), r"x0: must be finite; NaN or infinite at index \(0, 0\), "),
        ([["a"] * 3] * 3, r"x0: expected an array of numbers of shape \(3, 3\)"),
    ],
)
def test_a_bad_x0_says_what_is_wrong(x0, message):
    with pytest.raises(ValueError, match=message):
        sk.solve_ik(sk.Stack.reference(3), sk.PlanarTarget(0.0, 900.0, 0.0), x0=x0)
