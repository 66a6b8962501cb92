"""SO(3) helpers of the spatial formulation: the orientation equality and its Jacobian.

The independent check keeps scipy's rotation vector (:func:`stackik.check.so3_log`); the
solver's equalities use :func:`so3_log_fast` at every evaluation.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["so3_log_fast", "so3_right_jac_inv"]

FloatArray = NDArray[np.float64]


def so3_log_fast(R: FloatArray) -> FloatArray:
    """Rotation vector of one rotation matrix, as :func:`stackik.check.so3_log` (angle in [0, pi]),
    without scipy's per-call overhead (~80 us): the solver's spatial equalities call it at
    every evaluation; the independent check keeps scipy's. Quaternion by Shepperd's
    method (largest of ``1 + trace`` and the diagonal terms), then ``2 atan2(|v|, w)``."""
    r00, r11, r22 = R[0, 0], R[1, 1], R[2, 2]
    tr = r00 + r11 + r22
    k = int(np.argmax((tr, r00, r11, r22)))
    if k == 0:
        w = 0.5 * math.sqrt(max(1.0 + tr, 0.0))
        f = 0.25 / w
        v = np.array([(R[2, 1] - R[1, 2]) * f, (R[0, 2] - R[2, 0]) * f, (R[1, 0] - R[0, 1]) * f])
    else:
        i = k - 1
        j, m = (i + 1) % 3, (i + 2) % 3
        a = 0.5 * math.sqrt(max(1.0 + R[i, i] - R[j, j] - R[m, m], 0.0))
        f = 0.25 / a
        w = (R[m, j] - R[j, m]) * f
        v = np.empty(3)
        v[i], v[j], v[m] = a, (R[j, i] + R[i, j]) * f, (R[m, i] + R[i, m]) * f
    if w < 0.0:
        w, v = -w, -v
    s = math.sqrt(float(v @ v))
    angle = 2.0 * math.atan2(s, w)
    if angle < 1e-3:  # angle / sin(angle / 2) by its series (w ~ 1)
        scale = 2.0 + angle**2 / 12.0 + 7.0 * angle**4 / 2880.0
    else:
        scale = angle / s
    return v * scale


def so3_right_jac_inv(phi: FloatArray) -> FloatArray:
    """Inverse right Jacobian of SO(3) at rotation vector ``phi``."""
    th = float(np.linalg.norm(phi))
    K = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
    if th < 1e-6:
        return np.eye(3) + 0.5 * K + K @ K / 12.0  # type: ignore[no-any-return]
    a = 1.0 / th**2 - (1 + math.cos(th)) / (2 * th * math.sin(th))
    return np.eye(3) + 0.5 * K + a * (K @ K)  # type: ignore[no-any-return]
