"""Monte Carlo (Algorithm 1), confidence ellipses, linear covariance and F factor."""

import numpy as np
import pytest

from stackik import Stack, planar_forward
from stackik.analysis import (
    ConfidenceEllipse,
    draw_perturbations,
    f_factor,
    linear_covariance,
    linearity_check,
    monte_carlo,
)

# a feasible hand-made pose of the reference stack (n = 4, phi = 0)
Q1 = np.array(
    [[0.0, 300.0, -0.3925], [0.0, 300.0, -0.3925], [0.0, 300.0, -0.3925], [0, 300, -0.3925]]
)
Q2 = np.array([[20.0, 310.0, -0.2], [-10.0, 300.0, -0.5], [15.0, 290.0, -0.4], [0, 305, -0.47]])


def test_hand_poses_feasible():
    s = Stack.reference(4)
    assert s.planar_constraints(Q1, 0.0).min() >= 0
    assert s.planar_constraints(Q2, 0.0).min() >= 0


def test_reproducible_and_chunk_independent():
    a = monte_carlo([Q1, Q2], 3000, 1.0, 0.005, rng=7)
    b = monte_carlo([Q1, Q2], 3000, 1.0, 0.005, rng=7, chunk=211)
    c = monte_carlo([Q1, Q2], 3000, 1.0, 0.005, rng=8)
    np.testing.assert_array_equal(a.medians, b.medians)
    np.testing.assert_allclose(a[0].displacement, b[0].displacement, atol=1e-9)
    assert not np.array_equal(a.medians, c.medians)
    assert a.seed == 7 and a.mode == "planar" and a[0].n_samples == 3000


def test_same_draws_for_every_pose_match_direct_forward_kinematics():
    N = 500
    mc = monte_carlo(np.stack([Q1, Q2]), N, 2.0, 0.01, rng=np.random.default_rng(3))
    dx = draw_perturbations(N, 4, 2.0, 0.01, rng=np.random.default_rng(3))
    for q, p in zip([Q1, Q2], mc.poses, strict=True):
        y, y0 = planar_forward(q + dx), planar_forward(q)
        np.testing.assert_allclose(p.displacement, y[:, :2] - y0[:2], atol=1e-9)
        np.testing.assert_allclose(p.angle, y[:, 2] - y0[2], atol=1e-12)
        np.testing.assert_allclose(p.distance, np.linalg.norm(y[:, :2] - y0[:2], axis=1))
        assert p.median == pytest.approx(np.median(p.distance))
        lo, hi = np.percentile(p.distance, [2.5, 97.5])
        assert p.interval == pytest.approx((lo, hi))
        np.testing.assert_allclose(p.covariance, np.cov(p.displacement.T), rtol=1e-9)


def test_keep_samples_false_same_statistics():
    a = monte_carlo(Q1, 2000, 1.0, 0.005, rng=1)
    b = monte_carlo(Q1, 2000, 1.0, 0.005, rng=1, keep_samples=False)
    assert b[0].displacement is None and b[0].angle is None
    assert a[0].median == b[0].median
    np.testing.assert_array_equal(a[0].covariance, b[0].covariance)


def test_ellipse_covers_about_95_percent():
    mc = monte_carlo([Q1, Q2], 20000, 1.0, 0.005, rng=11)
    for p in mc.poses:
        frac = p.ellipse.contains(p.displacement).mean()
        assert 0.94 < frac < 0.96
        assert p.ellipse.quantile == pytest.approx(5.991, abs=1e-3)


def test_ellipse_geometry():
    e = ConfidenceEllipse.from_covariance([1.0, 2.0], [[4.0, 0.0], [0.0, 1.0]])
    np.testing.assert_allclose(e.semi_axes, np.sqrt(5.991464547) * np.array([2.0, 1.0]))
    assert e.angle == pytest.approx(0.0)
    b = e.boundary(50)
    np.testing.assert_allclose(e.mahalanobis2(b), 1.0)
    r = ConfidenceEllipse.from_covariance([0, 0], [[2.0, 1.0], [1.0, 2.0]])
    assert r.angle == pytest.approx(np.pi / 4)


def test_small_sigma_linear_estimate_matches():
    mc = monte_carlo([Q1, Q2], 40000, 0.01, 5e-5, rng=2)
    for c in linearity_check(mc):
        assert c.F < 0.05
    # at the paper's high noise the linear estimate breaks down
    big = monte_carlo(Q1, 20000, 100.0, 0.5, rng=2, keep_samples=False)
    assert linearity_check(big)[0].F > 0.2


def test_linear_covariance_trace_is_weighted_fn():
    # trace of the planar position block = 2n sigma_t^2 + sigma_theta^2 (FN^2 - 3n)
    from stackik import planar_fn2

    C = linear_covariance(Q2, 1.5, 0.01)
    n = 4
    assert np.trace(C) == pytest.approx(2 * n * 1.5**2 + 0.01**2 * (planar_fn2(Q2) - 3 * n))


def test_f_factor_hand_made():
    C_obs = np.array([[4.0, 1.0], [1.0, 2.0]])
    C_est = np.array([[5.0, 0.0], [0.0, 2.0]])
    # |1| + |-1| + |-1| + 0 = 3 over 4 + 1 + 1 + 2 = 8
    assert f_factor(C_est, C_obs) == pytest.approx(3 / 8)
    assert f_factor(C_obs, C_obs) == 0.0
    with pytest.raises(ValueError):
        f_factor(C_est, np.zeros((2, 2)))


def test_spatial_monte_carlo():
    from stackik.analysis.figures import planar_to_spatial

    qs = planar_to_spatial(Q2, 0.3)
    mc = monte_carlo(qs, 4000, 1.0, 0.005, rng=5)
    p = mc[0]
    assert mc.mode == "spatial" and p.displacement.shape == (4000, 3)
    assert p.covariance.shape == (3, 3) and np.all(p.angle >= 0)
    assert 0.93 < p.ellipse.contains(p.displacement).mean() < 0.97
    # small noise: the linear estimate is accurate in 3D too
    small = monte_carlo(qs, 20000, 0.01, 5e-5, rng=5)
    assert f_factor(linear_covariance(qs, 0.01, 5e-5), small[0].covariance) < 0.05
    # spatial angle: rotation angle of R0^T R
    from stackik import spatial_forward
    from stackik.analysis.montecarlo import _rotation_angle

    dx = draw_perturbations(100, 4, 1.0, 0.005, rng=5, spatial=True)
    _, R = spatial_forward(qs + dx)
    _, R0 = spatial_forward(qs)
    M = np.einsum("ji,njk->nik", R0, R)
    ref = np.arccos(np.clip((np.trace(M, axis1=1, axis2=2) - 1) / 2, -1, 1))
    np.testing.assert_allclose(_rotation_angle(R0, R), ref, atol=1e-6)


def test_bad_inputs():
    with pytest.raises(ValueError):
        monte_carlo(np.zeros((4, 4)), 10, 1.0, 0.1)
    with pytest.raises(ValueError):
        monte_carlo(Q1, 1, 1.0, 0.1)
    with pytest.raises(ValueError):
        monte_carlo(Q1, 10, -1.0, 0.1)
