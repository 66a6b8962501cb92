"""Self-leg clearance rows of one spatial platform (numba), the one definition of the family.

Platform i's legs k run from base joint ``b_k`` (fixed in the platform's local frame) to top
joint ``t_k(q) = p + R(yaw, pitch, roll) u_k`` (``u_k`` the top joint in the top plate's
frame), ``q = [x, y, z, yaw, pitch, roll]`` [mm, rad], ``R = Rz Ry Rx``. For each pair (k, l)
of legs that share no joint the row is

    c_kl(q) = (d_kl(q)^2 - rho^2) / scale >= 0,

``d_kl`` the distance [mm] of the two leg axis segments, ``rho = 2 leg_radius + margin`` [mm].

Smoothness: ``d^2`` at the clamped closest points (s*, t*) has a continuous gradient (envelope
theorem: the gradient is that of ``|P(s*) - Q(t*)|^2`` at fixed (s*, t*)), so only the
endpoints' motion enters. For parallel segments the closest points are not unique but the
distance is, and any minimiser gives the same gradient; we take s* = 0 clamped there.

Derivatives along q follow the solver's variable convention (DESIGN.md): j < 3 moves the top
along ``e_j``; j = 3, 4, 5 turn it about ``w = (e_z, Rz e_y, Rz Ry e_x)[j - 3]``, so
``d t_k / d q_j = w_j x (R u_k)``.

Status: standalone (values + Jacobian); not yet wired into the spatial evaluation.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from stackik._compiled.core import _jit
from stackik._compiled.spatial_kinematics import _euler

FloatArray = Any
IntArray = Any

#: Relative size of the squared cross term under which two segments count as parallel.
_PARALLEL = 1e-12


@_jit
def closest_params(p0: FloatArray, p1: FloatArray, q0: FloatArray, q1: FloatArray) -> Any:
    """Parameters (s, t) in [0, 1]^2 of closest points of segments p0-p1 and q0-q1 (3,)."""
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = d1 @ d1
    e = d2 @ d2
    f = d2 @ r
    c = d1 @ r
    b = d1 @ d2
    den = a * e - b * b
    if a <= 0.0 and e <= 0.0:
        return 0.0, 0.0
    if a <= 0.0:
        return 0.0, min(max(f / e, 0.0), 1.0)
    if e <= 0.0:
        return min(max(-c / a, 0.0), 1.0), 0.0
    if den > _PARALLEL * a * e:
        s = min(max((b * f - c * e) / den, 0.0), 1.0)
    else:
        s = 0.0
    t = (b * s + f) / e
    if t < 0.0:
        t = 0.0
        s = min(max(-c / a, 0.0), 1.0)
    elif t > 1.0:
        t = 1.0
        s = min(max((b - c) / a, 0.0), 1.0)
    return s, t


@_jit
def _rotation_axes(yaw: float, pitch: float, roll: float) -> Any:
    """``R = Rz Ry Rx`` and the rows ``W``: the axes of yaw, pitch and roll in the bottom
    plate's frame (``e_z``, ``Rz e_y``, ``Rz Ry e_x``)."""
    R, _ = _euler(yaw, pitch, roll)
    cz, sz = math.cos(yaw), math.sin(yaw)
    cy, sy = math.cos(pitch), math.sin(pitch)
    W = np.array([[0.0, 0.0, 1.0], [-sz, cz, 0.0], [cz * cy, sz * cy, -sy]])
    return R, W


@_jit
def self_leg_rows(
    q: FloatArray,
    base: FloatArray,
    top: FloatArray,
    pairs: IntArray,
    rho: float,
    scale: float,
    c: FloatArray,
    J: FloatArray,
) -> None:
    """Rows ``c`` (m,) and Jacobian ``J`` (m, 6) of one platform, written in place.

    q (6,) pose [mm, rad]; base (6, 3), top (6, 3) joints in the platform's and the top
    plate's frames [mm]; pairs (m, 2) leg indices; rho [mm]; scale [mm^2].
    """
    R, W = _rotation_axes(q[3], q[4], q[5])
    nl = base.shape[0]
    T = np.empty((nl, 3))
    RU = np.empty((nl, 3))
    for k in range(nl):
        RU[k] = R @ top[k]
        T[k] = q[:3] + RU[k]
    for r in range(pairs.shape[0]):
        k, m = pairs[r, 0], pairs[r, 1]
        s, t = closest_params(base[k], T[k], base[m], T[m])
        P = base[k] + s * (T[k] - base[k])
        Q = base[m] + t * (T[m] - base[m])
        g = P - Q
        c[r] = (g @ g - rho * rho) / scale
        # d(d^2)/dT_k = 2 s g, d(d^2)/dT_m = -2 t g (envelope: s, t fixed)
        gk = 2.0 * s * g / scale
        gm = -2.0 * t * g / scale
        for j in range(3):
            J[r, j] = gk[j] + gm[j]
        for j in range(3):
            w = W[j]
            dk = np.cross(w, RU[k])
            dm = np.cross(w, RU[m])
            J[r, 3 + j] = gk @ dk + gm @ dm
