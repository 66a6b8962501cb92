"""Linear (first-order) covariance estimate and the paper's F factor (DESIGN §7).

For small perturbations ``dy = J dx``, so a Gaussian input ``dx ~ N(0, C_x)`` gives
``C_y = J C_x J^T``; with ``C_x = diag(sigma_t^2, sigma_t^2, sigma_theta^2, ...)`` (planar)
or ``diag(sigma_t^2 x3, sigma_theta^2 x3, ...)`` (spatial). The F factor compares it with
the covariance observed in a Monte Carlo run:

.. math:: F = \\frac{\\sum_{ij} |C^{est}_{ij} - C^{obs}_{ij}|}{\\sum_{ij} |C^{obs}_{ij}|}

over the end-effector position block: ``(rho, z)`` (2x2) in planar mode, ``(x, y, z)``
(3x3) in spatial mode.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.analysis.montecarlo import MonteCarloResult, as_pose_batch
from stackik.kinematics import noise_weights, planar_jacobian, spatial_jacobian

__all__ = ["LinearCheck", "f_factor", "linear_covariance", "linearity_check"]

FloatArray = NDArray[np.float64]


def linear_covariance(
    pose: ArrayLike, sigma_t: float, sigma_theta: float, full: bool = False
) -> FloatArray:
    """First-order end-effector covariance ``C_y = J C_x J^T`` of one pose.

    Parameters
    ----------
    pose : array_like, shape (n, 3) or (n, 6)
        Planar ``[rho, z, theta]`` or spatial ``[x, y, z, yaw, pitch, roll]`` rows.
    sigma_t : float
        Translation noise [mm].
    sigma_theta : float
        Angle noise [rad].
    full : bool, optional
        Return the covariance of the whole output ``y`` ((3, 3) planar with theta_ee,
        (12, 12) spatial with ``vec(R_ee)``) instead of the position block.

    Returns
    -------
    C : ndarray, shape (2, 2) planar / (3, 3) spatial [mm^2] (or the full output block)
    """
    Q, mode = as_pose_batch(pose)
    if Q.shape[0] != 1:
        raise ValueError("pose: expected a single pose")
    q = Q[0]
    n = q.shape[0]
    spatial = mode == "spatial"
    J = spatial_jacobian(q) if spatial else planar_jacobian(q)
    w = noise_weights(n, sigma_t, sigma_theta, spatial=spatial)
    C = (J * w) @ J.T
    if full:
        return C  # type: ignore[no-any-return]
    d = 3 if spatial else 2
    return C[:d, :d]  # type: ignore[no-any-return]


def f_factor(C_est: ArrayLike, C_obs: ArrayLike) -> float:
    """``F = sum|C_est - C_obs| / sum|C_obs|`` (a fraction: 0.25 means 25 %).

    Parameters
    ----------
    C_est, C_obs : array_like, same shape (d, d)
        Estimated and observed covariances.
    """
    a = np.asarray(C_est, dtype=float)
    b = np.asarray(C_obs, dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"shape mismatch: {a.shape} vs {b.shape}")
    den = float(np.sum(np.abs(b)))
    if den == 0.0:
        raise ValueError("C_obs is zero: F undefined")
    return float(np.sum(np.abs(a - b)) / den)


@dataclass(frozen=True)
class LinearCheck:
    """Linear-region check of one pose.

    Attributes
    ----------
    estimated : ndarray, shape (d, d)
        ``J C_x J^T`` position block [mm^2].
    observed : ndarray, shape (d, d)
        Monte Carlo covariance [mm^2].
    F : float
        F factor (fraction).
    """

    estimated: FloatArray
    observed: FloatArray
    F: float

    def to_dict(self) -> dict[str, object]:
        return {
            "estimated": self.estimated.tolist(),
            "observed": self.observed.tolist(),
            "F": self.F,
        }


def linearity_check(
    mc: MonteCarloResult, poses: ArrayLike | Sequence[ArrayLike] | None = None
) -> tuple[LinearCheck, ...]:
    """F factor of every pose of a Monte Carlo run (using its sigmas).

    Parameters
    ----------
    mc : MonteCarloResult
    poses : optional
        Defaults to the poses stored in ``mc``.
    """
    Q = [p.pose for p in mc.poses] if poses is None else list(as_pose_batch(poses)[0])
    if len(Q) != len(mc.poses):
        raise ValueError("poses and Monte Carlo result differ in length")
    out = []
    for q, p in zip(Q, mc.poses, strict=True):
        C_est = linear_covariance(q, mc.sigma_t, mc.sigma_theta)
        out.append(LinearCheck(C_est, p.covariance, f_factor(C_est, p.covariance)))
    return tuple(out)
