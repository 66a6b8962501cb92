"""Inverse kinematics of a stack: reach a target with every limit respected, least FN.

The IK problem (DESIGN §3-6) in planar mode, with ``x = q.ravel()`` (3n variables):

.. math::

    \\min_x\\; f(x) \\quad \\text{s.t.}\\quad y(x) = y^*,\\quad c(x) \\ge 0

where ``y`` is the end effector ``(rho, z, theta)``, ``c`` the 24n leg and joint limits and
``f`` one of the objectives ``"frobenius"`` (``FN^2``), ``"feasible"`` (none: the first
feasible pose near the start) or ``"weighted"`` (``trace(J C_x J^T)``). Spatial mode has 6n
variables, ``y = (P_ee, R_ee)`` and the orientation written as the three components of the
rotation vector of ``R_target^T R_ee``.

Inside solvers everything is scaled to O(1): translations by ``L = max leg_max`` [mm],
leg-length constraints (mm^2) by ``leg_max^2``, joint constraints (mm) by ``leg_max``,
position errors by ``L``; results are reported raw.

Every returned pose is re-checked by :func:`check_pose` with the forward kinematics and
constraint functions of :mod:`stackik.kinematics` and :mod:`stackik.platform`, independently
of what the solver claims; ``success`` is True only when that check passes.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable
from concurrent.futures import Executor
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.check import (
    FEAS_TOL,
    TARGET_ANGLE_TOL,
    TARGET_POS_TOL,
    PoseCheck,
    check_pose,
)
from stackik.geometry import Stack
from stackik.kinematics import (
    _J2,
    _planar_parts,
    lift_planar,
    planar_fn_residuals,
    planar_forward,
    planar_jacobian,
    spatial_chain,
)
from stackik.result import STATUS_MESSAGES as _MESSAGES
from stackik.result import IKResult, IKStatus, OptionError
from stackik.rotations import euler_zyx
from stackik.targets import (
    PlanarTarget,
    SpatialTarget,
    Target,
    target_from_dict,
    target_to_dict,
)

__all__ = [
    "FEAS_TOL",
    "TARGET_ANGLE_TOL",
    "TARGET_POS_TOL",
    "IKResult",
    "IKStatus",
    "OptionError",
    "PlanarTarget",
    "PoseCheck",
    "SpatialTarget",
    "check_pose",
    "paper_initial_guess",
    "solve_ik",
    "solve_many",
    "target_from_dict",
    "target_to_dict",
]

FloatArray = NDArray[np.float64]

OBJECTIVES = ("frobenius", "feasible", "weighted")
# Loose SQP settings used to rank the default structured starts before refining the best.
SCREEN_OPTIONS = {"tol": 1e-4, "constr_tol": 1e-7}
SCREEN_FEAS_MM = 1e-3  # [mm] screened runs farther from feasibility rank last
METHODS = ("auto", "sqp", "ip", "slsqp", "trust-constr", "ipopt")


def _so3_log_fast(R: FloatArray) -> FloatArray:
    """Rotation vector of one rotation matrix, as :func:`_so3_log` (angle in [0, pi]),
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



# =========================================================================================
# Starts
# =========================================================================================
def _nominal_height(stack: Stack, frac: float = 0.35) -> FloatArray:
    """Height of each platform at which its legs are at ``leg_min + frac * range`` [mm]."""

    def make(st: Stack) -> FloatArray:
        L = st.leg_min + frac * (st.leg_max - st.leg_min)
        chord = np.linalg.norm(st.top_nodes - st.base_nodes, axis=-1).max(axis=1)
        h = np.sqrt(np.maximum(L**2 - chord**2, (0.5 * L) ** 2))
        h.setflags(write=False)
        return h  # type: ignore[no-any-return]

    return stack.derived(("nominal_height", frac), make)  # type: ignore[no-any-return]


def paper_initial_guess(stack: Stack, target: Target) -> FloatArray:
    """The paper's initial guess: share the target among the platforms, ignoring limits.

    Planar: each platform turns by ``theta / n`` and moves by ``P_target / n`` in the base
    frame (expressed in its own frame), with its local height ``z_i`` raised to at least the
    height where its legs sit at 35% of their range ("a minimum translation in each
    platform's normal direction"). Spatial: the same with the rotation vector of
    ``R_target`` divided evenly. Returns (n, 3) or (n, 6).
    """
    n = stack.n
    hmin = _nominal_height(stack)
    if isinstance(target, PlanarTarget):
        th = np.full(n, target.theta / n)
        Theta = np.cumsum(th) - th
        P = np.array([target.rho, target.z]) / n
        c, s = np.cos(Theta), np.sin(Theta)
        rho = c * P[0] + s * P[1]  # Rot(-Theta) P
        z = -s * P[0] + c * P[1]
        z = np.maximum(z, hmin)
        return np.column_stack([rho, z, th])
    from scipy.spatial.transform import Rotation

    rv = Rotation.from_matrix(target.rotation).as_rotvec() / n
    Ri = Rotation.from_rotvec(rv).as_matrix()
    eul = Rotation.from_rotvec(rv).as_euler("ZYX")
    q = np.zeros((n, 6))
    A = np.eye(3)
    for i in range(n):
        p = A.T @ (target.position / n)
        p[2] = max(p[2], hmin[i])
        q[i, :3] = p
        q[i, 3:] = eul
        A = A @ Ri
    return q


# =========================================================================================
# Problem formulation (scaled)
# =========================================================================================
class _PlanarFast:
    """Planar constraints with their Jacobian, specialised for speed (the hot path).

    Works in the plane's basis ``(e_phi, s, e_z)`` where ``P = (rho, 0, z)``, the rotation
    about ``s`` turns the ``(e_phi, e_z)`` components by the 2D rotation and
    ``R n = (-sin theta, 0, cos theta)``; only dot products enter the constraints, so the
    values equal :func:`stackik.platform.planar_constraint_jacobian` (tested).
    """

    def __init__(self, stack: Stack, phi: float) -> None:
        from stackik.rotations import plane_axis

        def basis(st: Stack) -> tuple[FloatArray, ...]:
            e_phi = np.array([math.cos(phi), math.sin(phi), 0.0])
            s = plane_axis(phi)
            B = np.stack([e_phi, s, [0.0, 0.0, 1.0]])  # rows: basis vectors
            b = st.base_nodes @ B.T  # (n, 6, 3)
            t = st.top_nodes @ B.T
            out = (t[..., 0], t[..., 2], t[..., 1] - b[..., 1], b[..., 0], b[..., 2])
            arrays = tuple(np.ascontiguousarray(a) for a in out)
            for a in arrays:
                a.setflags(write=False)
            return arrays

        # tf, tz: top nodes along e_phi, e_z; ls0: s component of l (constant);
        # bf, bz: base nodes along e_phi, e_z (cached per stack and phi)
        self.tf, self.tz, self.ls0, self.bf, self.bz = stack.derived(("plane_basis", phi), basis)
        self.lmin2 = (stack.leg_min**2)[:, None]
        self.lmax2 = (stack.leg_max**2)[:, None]
        self.sj = stack.sin_joint_min[:, None]
        n = stack.n
        self.n = n
        self.c = np.empty((n, 4, 6))
        self.D = np.empty((n, 4, 6, 3))
        self._legs_cache: tuple[FloatArray, tuple[FloatArray, ...]] | None = None
        # the last few points: the engine alternates between the iterate and trial points
        self._kcache: dict[bytes, tuple[Any, ...]] = {}
        self._kin: tuple[FloatArray, FloatArray, FloatArray]
        self.idx = np.arange(n)
        self._scaling = (np.ones(24 * n), np.ones(3 * n))
        self.jflat: FloatArray | None = None  # index arrays, built on first use

    # index arrays of the Python (SQP) path, built on first use: the compiled
    # interior-point path never needs them
    @cached_property
    def later(self) -> FloatArray:
        idx = np.arange(self.n)
        return (idx[None, :] > idx[: self.n - 1, None]).astype(float)  # k > i

    @cached_property
    def maxim(self) -> Any:
        idx = np.arange(self.n)
        return np.maximum(idx[: self.n - 1, None], idx[None, :])  # max(i, m)

    @cached_property
    def i3(self) -> Any:
        return np.arange(self.n)[: self.n - 1, None, None]

    @cached_property
    def top3(self) -> Any:
        idx = np.arange(self.n)
        M = np.maximum(idx[:, None], idx[None, :])
        return np.maximum(self.i3, M[None])  # max(i, m, l), (n-1, n, n)

    @cached_property
    def before(self) -> FloatArray:
        idx = np.arange(self.n)
        return (idx[None, :] < idx[:, None]).astype(float)  # [k, m]: m < k

    @cached_property
    def Hx(self) -> FloatArray:
        return np.zeros((self.n, 3, self.n, 3))

    def kinematics(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """End effector y (3,), its Jacobian (3, 3n), FN residuals r and dr/dx.

        Same values as :func:`planar_forward`, :func:`planar_jacobian` and
        :func:`planar_fn_residuals`, without input validation (tested to agree).
        """
        n = self.n
        key = q.tobytes()
        hit = self._kcache.get(key)
        if hit is not None:
            self._kin = hit[1]
            return hit[0]  # type: ignore[no-any-return]
        Theta, _, O = _planar_parts(q)
        c, s = np.cos(Theta), np.sin(Theta)
        d = O[-1] - O[1:]  # (n, 2), d_n = 0
        y = np.array([O[-1, 0], O[-1, 1], q[:, 2].sum()])
        J = np.zeros((3, n, 3))
        J[0, :, 0], J[1, :, 0] = c, s
        J[0, :, 1], J[1, :, 1] = -s, c
        J[0, :, 2], J[1, :, 2] = -d[:, 1], d[:, 0]
        J[2, :, 2] = 1.0
        Jr = np.empty((n - 1, 2, n, 3))
        later = self.later
        Jr[:, 0, :, 0] = later * c
        Jr[:, 1, :, 0] = later * s
        Jr[:, 0, :, 1] = later * -s
        Jr[:, 1, :, 1] = later * c
        dm = d[self.maxim]
        Jr[:, 0, :, 2] = -dm[..., 1]
        Jr[:, 1, :, 2] = dm[..., 0]
        self._kin = (c, s, d)
        out = (y, J.reshape(3, 3 * n), d[: n - 1].ravel(), Jr.reshape(2 * (n - 1), 3 * n))
        if len(self._kcache) >= 4:
            self._kcache.pop(next(iter(self._kcache)))
        self._kcache[key] = (out, self._kin)
        return out

    def fn2_hessian(self, q: FloatArray) -> FloatArray:
        """Exact Hessian of ``FN^2`` (same as :func:`stackik.kinematics.planar_hessian_fn2`)."""
        n = self.n
        _, _, r, Jr = self.kinematics(q)
        c, s, d = self._kin
        H = 2.0 * Jr.T @ Jr
        rr = r.reshape(n - 1, 2)
        G = rr @ d.T  # G[i, k] = r_i . d_k
        Htt = -G[self.i3, self.top3].sum(axis=0)
        csum = np.zeros((n, 2))
        np.cumsum(rr, axis=0, out=csum[1:])  # sum_{i<k} r_i
        # J2 Rot(Theta_k) e_rho = (-s, c); J2 Rot(Theta_k) e_z = (-c, -s)
        Ht0 = (-s * csum[:, 0] + c * csum[:, 1])[:, None] * self.before
        Ht1 = (-c * csum[:, 0] - s * csum[:, 1])[:, None] * self.before
        Hx = self.Hx
        Hx[:, 2, :, 2] = Htt
        Hx[:, 0, :, 2] = Ht0
        Hx[:, 1, :, 2] = Ht1
        Hx[:, 2, :, 0] = Ht0.T
        Hx[:, 2, :, 1] = Ht1.T
        return H + 2.0 * Hx.reshape(3 * n, 3 * n)  # type: ignore[no-any-return]

    def constraint_hessian(self, q: FloatArray, y: FloatArray) -> FloatArray:
        """``sum_r y_r * Hessian(c_r)`` of the raw constraints, shape (3n, 3n).

        ``y`` has shape (n*24,) in constraint order; block diagonal by platform.
        """
        n = self.n
        lc = self._legs_cache
        legs = lc[1] if lc is not None and np.array_equal(lc[0], q) else self._legs(q)
        c, sn, Rtf, Rtz, rf, rz, lf, lz, sq, norm = legs
        # second derivatives of |l|^2 (entries rr, zz, rt, zt, tt; rz = 0)
        S_rr = 2.0
        S_rt = -2.0 * Rtz
        S_zt = 2.0 * Rtf
        S_tt = 2.0 * (Rtf * Rtf + Rtz * Rtz - lf * Rtf - lz * Rtz)
        d_r = lf / norm  # d|l|/drho
        d_z = lz / norm
        d_t = (lz * Rtf - lf * Rtz) / norm
        inv = 1.0 / norm

        def nh(S_ab: Any, da: FloatArray, db: FloatArray) -> FloatArray:
            return (0.5 * S_ab - da * db) * inv  # type: ignore[no-any-return]

        N_rr, N_zz, N_rz = nh(S_rr, d_r, d_r), nh(S_rr, d_z, d_z), nh(0.0, d_r, d_z)
        N_rt, N_zt, N_tt = nh(S_rt, d_r, d_t), nh(S_zt, d_z, d_t), nh(S_tt, d_t, d_t)
        Y = y.reshape(n, 4, 6)
        y0, y1, y2, y3 = Y[:, 0], Y[:, 1], Y[:, 2], Y[:, 3]
        ys = y0 - y1  # |l|^2 appears with + in block 0 and - in block 1
        sj = self.sj
        yn = -sj * (y2 + y3)  # |l| appears with -sin(joint_min) in blocks 2 and 3
        H = np.zeros((n, 3, 3))
        H[:, 0, 0] = np.sum(ys * S_rr + yn * N_rr, axis=1)
        H[:, 1, 1] = np.sum(ys * S_rr + yn * N_zz, axis=1)
        H[:, 0, 1] = np.sum(yn * N_rz, axis=1)
        # block 2: l.e_z -> d2/dtheta2 = -Rtz; block 3: l.Rn = t_n - rf sin + rz cos
        H[:, 0, 2] = np.sum(ys * S_rt + yn * N_rt - y3 * c, axis=1)
        H[:, 1, 2] = np.sum(ys * S_zt + yn * N_zt - y3 * sn, axis=1)
        H[:, 2, 2] = np.sum(ys * S_tt + yn * N_tt - y2 * Rtz + y3 * (rf * sn - rz * c), axis=1)
        H[:, 1, 0] = H[:, 0, 1]
        H[:, 2, 0] = H[:, 0, 2]
        H[:, 2, 1] = H[:, 1, 2]
        out = np.zeros((n, 3, n, 3))
        out[self.idx, :, self.idx, :] = H
        return out.reshape(3 * n, 3 * n)

    def set_scaling(self, row_scale: FloatArray, col_scale: FloatArray) -> None:
        """Scale rows (constraints) and columns (variables) of what :meth:`__call__` returns."""
        self._scaling = (row_scale, col_scale)
        self.jflat = None

    def _build_scaling(self) -> None:
        row_scale, col_scale = self._scaling
        n = self.n
        r = np.arange(24)[None, :, None] + 24 * self.idx[:, None, None]  # (n, 24, 1)
        cidx = np.arange(3)[None, None, :] + 3 * self.idx[:, None, None]  # (n, 1, 3)
        rows = np.broadcast_to(r, (n, 24, 3))
        cols = np.broadcast_to(cidx, (n, 24, 3))
        self.jflat = (rows * (3 * n) + cols).ravel()
        self.jscale = (row_scale[rows] * col_scale[cols]).ravel()
        self.cscale = row_scale.copy()

    def _legs(self, q: FloatArray) -> tuple[FloatArray, ...]:
        th = q[:, 2:3]
        c, sn = np.cos(th), np.sin(th)
        Rtf = c * self.tf - sn * self.tz
        Rtz = sn * self.tf + c * self.tz
        rf = q[:, 0:1] - self.bf
        rz = q[:, 1:2] - self.bz
        lf = Rtf + rf
        lz = Rtz + rz
        ls = self.ls0
        sq = lf * lf + ls * ls + lz * lz
        norm = np.sqrt(sq)
        return c, sn, Rtf, Rtz, rf, rz, lf, lz, sq, norm

    def __call__(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Constraints (n*24,) and Jacobian (n*24, 3n) in DESIGN §2 order.

        Raw unless :meth:`set_scaling` was called, then scaled by rows and columns.
        """
        legs = self._legs(q)
        self._legs_cache = (q.copy(), legs)
        c, sn, Rtf, Rtz, rf, rz, lf, lz, sq, norm = legs
        lRn = c * lz - sn * lf
        sj = self.sj
        out = self.c
        out[:, 0] = sq - self.lmin2
        out[:, 1] = self.lmax2 - sq
        out[:, 2] = lz - norm * sj
        out[:, 3] = lRn - norm * sj
        # derivatives wrt (rho, z, theta); dl/dtheta = (-Rtz, 0, Rtf), d(Rn)/dtheta = (-c, 0, -sn)
        dsq_t = 2.0 * (lz * Rtf - lf * Rtz)
        k = sj / norm
        D = self.D
        D[:, 0, :, 0] = 2.0 * lf
        D[:, 0, :, 1] = 2.0 * lz
        D[:, 0, :, 2] = dsq_t
        D[:, 1] = -D[:, 0]
        D[:, 2, :, 0] = -k * lf
        D[:, 2, :, 1] = 1.0 - k * lz
        D[:, 2, :, 2] = Rtf - 0.5 * k * dsq_t
        D[:, 3, :, 0] = -sn - k * lf
        D[:, 3, :, 1] = c - k * lz
        D[:, 3, :, 2] = (sn * Rtz + c * Rtf) - (c * lf + sn * lz) - 0.5 * k * dsq_t
        n = self.n
        if self.jflat is None:
            self._build_scaling()
        assert self.jflat is not None
        J = np.zeros(72 * n * n)
        J[self.jflat] = D.ravel() * self.jscale
        return out.ravel() * self.cscale, J.reshape(24 * n, 3 * n)


def _scalings(stack: Stack, planar: bool, wt: FloatArray, wth: FloatArray) -> tuple[Any, ...]:
    """Scalings of :class:`_Problem` (geometry and weights only; arrays read-only).

    Variables ``u = x / xs`` (xs = L = max leg_max for translations [mm], 1 for angles);
    constraint rows: leg blocks / leg_max^2, joint blocks / leg_max; equalities ``es``;
    objective ``f = (c0 + sum_i w_i |r_i|^2) / fscale`` with per-residual weights ``rw``
    (sqrt, residuals indexed by the platform of the angle column).
    """
    n = stack.n
    L = float(stack.leg_max.max())
    per = [L, L, 1.0] if planar else [L] * 3 + [1.0] * 3
    xs = np.tile(per, n)
    cs = np.empty((n, 24))
    cs[:, :12] = 1.0 / stack.leg_max[:, None] ** 2
    cs[:, 12:] = 1.0 / stack.leg_max[:, None]
    es = np.array([1 / L, 1 / L, 1.0]) if planar else np.array([1 / L] * 3 + [1.0] * 3)
    n_rot = 1 if planar else 3
    n_tr = 2 if planar else 3
    rot_const = 1.0 if planar else 2.0  # |d R_ee / d angle|_F^2 (+ theta row)
    c0 = float(np.sum(wt) * n_tr + np.sum(wth) * n_rot * rot_const)
    fscale = L**2 * float(np.max(wth))
    rw = np.repeat(np.sqrt(wth[: n - 1]), 2) if planar else np.repeat(np.sqrt(wth), 9)
    arrays = (xs, cs.ravel(), es, np.array(wt, float), np.array(wth, float), rw)
    for a in arrays:
        a.setflags(write=False)
    xs, cs_flat, es, wt, wth, rw = arrays
    return L, xs, cs_flat, es, wt, wth, c0, fscale, rw


class _Problem:
    """Scaled IK problem: evaluation of objective, equalities and limits with derivatives.

    Variables ``u = x / xs`` with ``xs`` = L for translations, 1 for angles.
    """

    def __init__(
        self,
        stack: Stack,
        target: Target,
        objective: str,
        weights: tuple[FloatArray, FloatArray] | None,
        x_ref: FloatArray | None = None,
    ) -> None:
        self.stack = stack
        self.target = target
        self.planar = isinstance(target, PlanarTarget)
        n = stack.n
        self.n = n
        self.k = 3 if self.planar else 6
        self.objective = objective
        self.x_ref = x_ref
        if objective == "weighted":
            assert weights is not None
            scal = _scalings(stack, self.planar, *weights)
        else:  # unit weights: the same arrays for every target (read-only, cached)
            scal = stack.derived(
                ("problem_scalings", self.planar),
                lambda st: _scalings(st, self.planar, np.ones(n), np.ones(n)),
            )
        (self.L, self.xs, self.cs, self.es, self.w_t, self.w_th, self.c0, self.fscale,
         self.rw) = scal  # fmt: skip
        self.fast = _PlanarFast(stack, target.phi) if isinstance(target, PlanarTarget) else None
        if self.fast is not None:
            self.fast.set_scaling(self.cs, self.xs)
        self._cache_u: FloatArray | None = None
        self._gn_cache: tuple[FloatArray, FloatArray, FloatArray] | None = None
        self._fn_cache: tuple[FloatArray, FloatArray] = (np.zeros(0), np.zeros((0, 0)))
        self._cache: tuple[Any, ...] | None = None
        self.nfev = 0

    # --- index arrays (built on first use) ------------------------------------------
    @cached_property
    def _angle_cols(self) -> Any:
        a = np.arange(self.n * self.k)
        return a[a % 6 >= 3] if self.k == 6 else a[a % 3 == 2]

    @cached_property
    def _hi(self) -> Any:
        a = np.arange(self.n * self.k)
        return np.maximum(a[:, None], a[None, :])

    @cached_property
    def _theta_lo(self) -> FloatArray:
        a = np.arange(self.n * self.k)
        return (np.minimum(a[:, None], a[None, :]) % 3 == 2).astype(float)

    # --- conversions ---------------------------------------------------------------
    def q_of(self, u: FloatArray) -> FloatArray:
        return (u * self.xs).reshape(self.n, self.k)

    def u_of(self, q: FloatArray) -> FloatArray:
        return np.asarray(q, dtype=float).ravel() / self.xs

    # --- residuals of the objective -------------------------------------------------
    def residuals(self, q: FloatArray, ch: Any = None) -> tuple[FloatArray, FloatArray]:
        """Objective residuals (unscaled x) ``r``, ``dr/dx`` with obj = c0 + |r|^2.

        ``ch``: the :class:`~stackik.kinematics.SpatialChain` of ``q`` if already built.
        """
        if self.planar:
            r, Jr = planar_fn_residuals(q)
        else:  # spatial
            ch = spatial_chain(q) if ch is None else ch
            N = 6 * self.n
            ang = self._angle_cols
            r = ch.J[:3, ang].T.ravel()  # (3n*3,)
            H = ch.position_hessian(ang)  # (3, 3n, N)
            Jr = np.moveaxis(H, 0, 1).reshape(-1, N)
            # rows are platform-major (3 angles x 3 coordinates = 9 per platform): rw matches
        return r * self.rw, Jr * self.rw[:, None]

    def gauss_newton(self, u: FloatArray) -> tuple[FloatArray, FloatArray]:
        if self.objective == "feasible":
            return np.zeros(1), np.zeros((1, u.size))
        gc = self._gn_cache
        if gc is not None and np.array_equal(gc[0], u):
            return gc[1], gc[2]
        r, Jr = self.residuals(self.q_of(u))
        s = 1.0 / math.sqrt(self.fscale)
        return r * s, Jr * self.xs * s

    # --- all functions at once ------------------------------------------------------
    def evaluate(self, u: FloatArray) -> tuple[Any, ...]:
        if self._cache_u is not None and np.array_equal(u, self._cache_u):
            assert self._cache is not None
            return self._cache
        self.nfev += 1
        q = self.q_of(u)
        n, k = self.n, self.k
        st = self.stack
        spatial_ch: Any = None
        if self.fast is not None:
            tgt = self.target
            assert isinstance(tgt, PlanarTarget)
            y, Jy, r_fn, Jr_fn = self.fast.kinematics(q)
            self._fn_cache = (r_fn, Jr_fn)
            ceq = (y - tgt.y) * self.es
            Jeq = Jy * self.es[:, None] * self.xs
            cin, Jin = self.fast(q)  # scaled (set_scaling in __init__)
        else:
            from stackik._spatial import block_jacobian, spatial_parts

            tgs = self.target
            assert isinstance(tgs, SpatialTarget)
            # compiled: the values of spatial_chain, spatial_legs, constraints_from_legs
            # and residuals (tested equal)
            Pee, Ree, Jp, w_ax, c, Jc, r_sp, Jr_sp = spatial_parts(
                q, st.top_nodes, st.base_nodes, st.leg_min, st.leg_max, st.sin_joint_min
            )
            spatial_ch = (r_sp * self.rw, Jr_sp * self.rw[:, None])
            E = tgs.rotation.T @ Ree
            phi_v = _so3_log_fast(E)
            # dphi = Jr^{-1}(phi) v with v = R_ee^T w (body-frame axis)
            v = Ree.T @ w_ax.T  # (3, N)
            Jphi = _so3_right_jac_inv(phi_v) @ v
            ceq = np.concatenate([Pee - tgs.position, phi_v]) * self.es
            Jeq = np.vstack([Jp, Jphi]) * self.es[:, None] * self.xs
            cin = c.ravel() * self.cs
            Jin = block_jacobian(Jc, self.cs, self.xs)
        if self.objective == "feasible":
            f, g = 0.0, np.zeros(n * k)
        else:
            if self.fast is not None:
                sc = 1.0 / math.sqrt(self.fscale)
                r = self._fn_cache[0] * self.rw * sc
                Jr = self._fn_cache[1] * (self.rw * sc)[:, None] * self.xs
                self._gn_cache = (u.copy(), r, Jr)
            else:
                sc = 1.0 / math.sqrt(self.fscale)
                r, Jr = spatial_ch
                r, Jr = r * sc, Jr * self.xs * sc
                self._gn_cache = (u.copy(), r, Jr)
            f = float(r @ r) + self.c0 / self.fscale
            g = 2.0 * Jr.T @ r
        out = (f, g, ceq, Jeq, cin, Jin)
        self._cache_u = u.copy()
        self._cache = out
        return out

    def lagrangian_hessian(self, u: FloatArray, y_eq: FloatArray, y_in: FloatArray) -> FloatArray:
        """Exact Hessian of ``f - y_eq.c_E - y_in.c_I`` in scaled variables (planar only)."""
        assert self.fast is not None
        q = self.q_of(u)
        Hx: Any = 0.0
        if self.objective != "feasible":
            Hx = self.fast.fn2_hessian(q) * (float(self.w_th[0]) / self.fscale)
        # end-effector equalities: sum_r y_r d2 y_r = isTheta[min(a,b)] * v[max(a,b)]
        Jy = self.fast.kinematics(q)[1]  # (fn2_hessian above computed it already: cheap)
        yp = y_eq[:2] * self.es[:2]
        v = (yp @ _J2) @ Jy[:2]  # (3n,)
        H_eq = self._theta_lo * v[self._hi]
        H_in = self.fast.constraint_hessian(q, y_in * self.cs)
        H = Hx - H_eq - H_in
        return H * np.outer(self.xs, self.xs)  # type: ignore[no-any-return]

    def objective_value(self, q: FloatArray) -> float:
        """Unscaled objective value at q."""
        if self.objective == "feasible":
            return 0.0
        r, _ = self.residuals(q)
        return float(self.c0 + r @ r)


def _so3_right_jac_inv(phi: FloatArray) -> FloatArray:
    """Inverse right Jacobian of SO(3) at rotation vector ``phi``."""
    th = float(np.linalg.norm(phi))
    K = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
    if th < 1e-6:
        return np.eye(3) + 0.5 * K + K @ K / 12.0  # type: ignore[no-any-return]
    a = 1.0 / th**2 - (1 + math.cos(th)) / (2 * th * math.sin(th))
    return np.eye(3) + 0.5 * K + a * (K @ K)  # type: ignore[no-any-return]


def _frobenius(q: FloatArray, planar: bool) -> float:
    if planar:
        return float(np.sqrt(np.sum(planar_jacobian(q) ** 2)))
    return float(np.sqrt(np.sum(spatial_chain(q).J ** 2)))


def _reach_bound(stack: Stack) -> float:
    """Upper bound on |P_ee| over all poses respecting leg_max [mm] (cached per stack)."""

    def make(st: Stack) -> float:
        rb = np.linalg.norm(st.base_nodes, axis=-1).max(axis=1)
        rt = np.linalg.norm(st.top_nodes, axis=-1).max(axis=1)
        return float(np.sum(st.leg_max + rb + rt))

    return stack.derived("reach_bound", make)  # type: ignore[no-any-return]


# =========================================================================================
# Solver drivers
# =========================================================================================
@dataclass
class _Run:
    q: FloatArray
    nit: int
    status: str
    check: PoseCheck
    obj: float
    lifted: tuple[FloatArray, FloatArray, FloatArray] | None = None  # P, R, leg lengths


POLISH_MARGIN = 1e-12  # scaled margin the polish puts violated limits at (>= 0 raw)
POLISH_REACH = 1e-6  # only limits violated by less than this (scaled) are polished


def _polish(prob: _Problem, u: FloatArray, iters: int = 3) -> FloatArray:
    """Min-norm Newton corrections of the end-effector equalities and of limits that a
    solver left violated by roundoff (tiny moves; a far-off point is left as it is).

    Each step solves ``[J_E; J_V] du = -[c_E; c_V - margin]`` in the least-norm sense,
    where V are the limits with ``-POLISH_REACH < c < 0``, so that the returned pose meets
    the target to rounding and its limits with ``c >= 0`` raw, not only within the
    solver's tolerance.
    """
    for _ in range(iters):
        _, _, ceq, Jeq, cin, Jin = prob.evaluate(u)
        viol = (cin < 0) & (cin > -POLISH_REACH)
        if np.abs(ceq).max() < 1e-13 and not viol.any():
            break
        A = np.vstack([Jeq, Jin[viol]])
        r = np.concatenate([ceq, cin[viol] - POLISH_MARGIN])
        u = u - np.linalg.lstsq(A, r, rcond=None)[0]
    return u


def _sqp_options(opts: dict[str, Any]) -> Any:
    """``SQPOptions(**opts)``, with bad options reported as :class:`OptionError`."""
    from stackik.sqp import SQPOptions

    try:
        return SQPOptions(**opts)
    except TypeError as exc:  # an unknown keyword
        from dataclasses import fields

        known = sorted(f.name for f in fields(SQPOptions))
        raise OptionError(f"options: {exc}; SQP options are {known}") from None
    except ValueError as exc:
        raise OptionError(f"options: {exc}") from None


def _run_sqp(
    prob: _Problem, u0: FloatArray, qp_solver: str | None, options: dict[str, Any]
) -> tuple[FloatArray, int, str]:
    from stackik.sqp import NonlinearProgram, solve

    exact_ok = prob.fast is not None and (prob.objective != "weighted" or np.ptp(prob.w_th) == 0)
    nlp = NonlinearProgram(
        objective=None,
        evaluate=prob.evaluate,
        hessian=prob.lagrangian_hessian if exact_ok else None,
        gauss_newton=None if prob.objective == "feasible" else prob.gauss_newton,
        gn_scale=2.0,
        eq_scale=np.ones(prob.es.size),
        ineq_scale=np.ones(prob.cs.size),
        name="stackik-ik",
    )
    opts: dict[str, Any] = {
        "tol": 1e-7,
        "constr_tol": 1e-10,
        "max_iter": max(200, 25 * prob.n),  # large stacks need more (observed ~10 n)
        "initial_tr_radius": 0.5,
    }
    if not exact_ok:
        # Gauss-Newton ignores the curvature of active limits and stalls there; damped
        # BFGS on the whole Lagrangian converges superlinearly.
        opts["hessian"] = "bfgs"
    opts.update(options)
    kw: dict[str, Any] = {}
    if qp_solver is not None:
        kw["qp_solver"] = qp_solver
    res = solve(nlp, u0, options=_sqp_options(opts), **kw)
    return res.x, res.nit, res.status.value


#: Options of the scipy baselines that stackik passes on, with their kind.
_SCIPY_OPTIONS: dict[str, dict[str, str]] = {
    "slsqp": {"maxiter": "int", "ftol": "pos", "eps": "pos", "disp": "bool"},
    "trust-constr": {
        "maxiter": "int",
        "gtol": "pos",
        "xtol": "pos",
        "barrier_tol": "pos",
        "initial_tr_radius": "pos",
        "initial_constr_penalty": "pos",
        "initial_barrier_parameter": "pos",
        "initial_barrier_tolerance": "pos",
        "verbose": "int0",
        "disp": "bool",
    },
}


def _check_scipy_options(method: str, options: dict[str, Any]) -> None:
    allowed = _SCIPY_OPTIONS[method]
    for key, value in options.items():
        kind = allowed.get(key)
        if kind is None:
            raise OptionError(f"options: {key!r} is not a {method} option; use {sorted(allowed)}")
        if kind == "bool":
            ok = isinstance(value, bool)
        elif kind in ("int", "int0"):
            ok = isinstance(value, int | np.integer) and not isinstance(value, bool)
            ok = ok and value >= (1 if kind == "int" else 0)
        else:
            ok = isinstance(value, int | float) and not isinstance(value, bool)
            ok = ok and math.isfinite(value) and value > 0
        if not ok:
            raise OptionError(f"options: bad value {value!r} for {method} option {key!r}")


def _run_scipy(
    prob: _Problem,
    u0: FloatArray,
    method: str,
    options: dict[str, Any],
    time_left: float = math.inf,
) -> tuple[FloatArray, int, str]:
    from scipy.optimize import NonlinearConstraint, minimize

    _check_scipy_options(method, options)
    deadline = time.perf_counter() + time_left

    def stop_at_deadline(*_: Any) -> None:
        if time.perf_counter() > deadline:
            raise StopIteration  # scipy ends the run and returns the current point

    def fun(u: FloatArray) -> float:
        return float(prob.evaluate(u)[0])

    def jac(u: FloatArray) -> FloatArray:
        return prob.evaluate(u)[1]  # type: ignore[no-any-return]

    if method == "slsqp":
        cons = [
            {
                "type": "eq",
                "fun": lambda u: prob.evaluate(u)[2],
                "jac": lambda u: prob.evaluate(u)[3],
            },
            {
                "type": "ineq",
                "fun": lambda u: prob.evaluate(u)[4],
                "jac": lambda u: prob.evaluate(u)[5],
            },
        ]
        opts = {"maxiter": 500, "ftol": 1e-12}
        opts.update(options)
        r = minimize(
            fun,
            u0,
            jac=jac,
            constraints=cons,
            method="SLSQP",
            options=opts,
            callback=stop_at_deadline,
        )
        return r.x, int(r.nit), "success" if r.success else str(r.message)

    def hess(u: FloatArray) -> FloatArray:
        if prob.objective == "feasible":
            return np.zeros((u.size, u.size))
        _, Jr = prob.gauss_newton(u)
        return 2.0 * Jr.T @ Jr  # type: ignore[no-any-return]

    zero_h = lambda u, v: np.zeros((u.size, u.size))  # noqa: E731
    cons_tc = [
        NonlinearConstraint(
            lambda u: prob.evaluate(u)[2], 0.0, 0.0, jac=lambda u: prob.evaluate(u)[3], hess=zero_h
        ),
        NonlinearConstraint(
            lambda u: prob.evaluate(u)[4],
            0.0,
            np.inf,
            jac=lambda u: prob.evaluate(u)[5],
            hess=zero_h,
        ),
    ]
    opts = {"maxiter": 1000, "gtol": 1e-9, "xtol": 1e-12}
    opts.update(options)
    r = minimize(
        fun,
        u0,
        jac=jac,
        hess=hess,
        constraints=cons_tc,
        method="trust-constr",
        options=opts,
        callback=stop_at_deadline,
    )
    return r.x, int(r.nit), "success" if r.status in (1, 2) else str(r.message)


def _initial_starts(
    stack: Stack, target: Target, q0: FloatArray, structured: bool
) -> list[FloatArray]:
    """Deterministic starts: ``q0`` and two folded variants per horizontal axis.

    FN^2 sums the squared distances from each plate to the end effector, so good poses
    often fold the top of the stack: the two upper platforms offset sideways in opposite
    directions bring the lower plates closer to the end effector. Which way they fold is a
    discrete choice that a local solver cannot change, hence one start per direction
    (offset ``0.75 (leg_max - leg_min)`` [mm] in the platforms' own frames): along the
    plane's axis in planar mode (3 starts), along x and along y in spatial mode (5 starts,
    followed there by random ones, :data:`SPATIAL_STARTS` in all).
    """
    out = [q0]
    if structured and stack.n >= 2:
        a = 0.75 * float(np.mean(stack.leg_max - stack.leg_min))
        # planar: the in-plane axis; spatial: both horizontal axes (4 folded starts)
        for axis in (0,) if isinstance(target, PlanarTarget) else (0, 1):
            for sign in (1.0, -1.0):
                q = q0.copy()
                q[-2, axis] += sign * a
                q[-1, axis] -= sign * a
                out.append(q)
    return out


def fold_depth(n: int) -> int:
    """Platforms whose sideways folds the default interior-point starts enumerate.

    0 for n <= 4 (the two folded starts of :func:`_initial_starts` suffice), 3 at n = 5,
    4 for n = 6-15, 5 for n = 16-31 and 3 again from n = 32: ``2**depth`` extra starts.
    Chosen on random geometries against IPOPT from eight starts and many random starts
    (README, ``benchmarks/bench_quality.py``); from n = 32 on, 4, 5 and 6 found nothing
    better than 3 (12 targets at n = 32, 6 at n = 64, three geometries) at 1.6-5x the time.
    """
    if n <= 4:
        return 0
    if n >= 32:  # each start costs more there, and more patterns found nothing better
        return 3
    return 3 + (n >= 6) + (n >= 16)


def tall_random_starts(n: int) -> int:
    """Random perturbation starts the default interior-point run adds to the fold
    patterns: 5 from n = 32 (``rng``; fixed seed by default), none below. On 12 targets
    at n = 64 (three geometries) the fold patterns alone came within 0.1 % of the best
    FN found on 11, with five random starts added on all 12 (about 0.35 s more)."""
    return 5 if n >= 32 else 0


def _fold_patterns(stack: Stack, q0: FloatArray, depth: int) -> list[FloatArray]:
    """Every pattern of sideways folds of the top ``depth`` platforms, as starts.

    The best poses of taller stacks reach toward the target with the lower platforms and
    fold the upper ones around it; which way each upper platform folds is a discrete
    choice that a local solver keeps, so the default interior-point run tries all
    ``2**depth`` sign patterns of a sideways offset ``0.75 (leg_max - leg_min)`` [mm] on
    the top ``depth`` platforms (planar mode).
    """
    n = stack.n
    m = min(depth, n)
    if m <= 0:
        return []
    a = 0.75 * float(np.mean(stack.leg_max - stack.leg_min))
    out = []
    for code in range(2**m):
        signs = np.array([1.0 if (code >> j) & 1 else -1.0 for j in range(m)])
        q = q0.copy()
        q[n - m :, 0] += a * signs
        out.append(q)
    return out


def _solve_from(
    prob: _Problem,
    q0: FloatArray,
    method: str,
    qp_solver: str | None,
    options: dict[str, Any],
    time_left: float = math.inf,
) -> _Run:
    """One local solve from ``q0``, polished and checked.

    A solver that raises on a well-formed problem (e.g. scipy on a huge start) makes a
    failed start, not an exception; bad options (:class:`OptionError`) still raise.
    """
    u0 = prob.u_of(q0)
    try:
        if method == "sqp":
            opts = dict(options)
            if "max_time" not in opts and math.isfinite(time_left):
                opts["max_time"] = max(time_left, 1e-3)
            u, nit, status = _run_sqp(prob, u0, qp_solver, opts)
        elif method == "ipopt":
            from stackik.ipopt_ import run_ipopt

            u, nit, status = run_ipopt(prob, u0, options, time_left)
        else:
            u, nit, status = _run_scipy(prob, u0, method, options, time_left)
    except OptionError:
        raise
    except Exception as exc:  # noqa: BLE001 - a crashing start is a failed start
        u, nit, status = u0, 0, f"error: {type(exc).__name__}: {exc}"
    if not np.all(np.isfinite(u)):
        u = u0
    u = _polish(prob, u)
    q = prob.q_of(u)
    chk = check_pose(prob.stack, prob.target, q)
    return _Run(q=q, nit=nit, status=status, check=chk, obj=prob.objective_value(q))


def _auto_method(
    planar: bool,
    objective: str,
    sigma_theta: Any,
    qp_solver: str | None,
    options: dict[str, Any] | None = None,
) -> str:
    """``method="auto"``: the compiled interior-point path where it applies, else SQP.

    The interior-point path (:mod:`stackik._ipm`) covers planar targets with the
    ``"frobenius"`` objective or ``"weighted"`` with one ``sigma_theta`` for all platforms.
    ``"feasible"`` stays with the SQP engine: its poses are the paper's "first feasible
    pose from the start", which a barrier method (drawn to the centre of the feasible
    set) does not reproduce. A given ``qp_solver``, or ``options`` that are not all
    interior-point options, select the SQP engine.
    """
    from stackik._ipm import IP_DEFAULTS

    if not planar or objective == "feasible" or qp_solver is not None:
        return "sqp"
    if options and any(key not in IP_DEFAULTS for key in options):
        return "sqp"
    if objective == "weighted" and np.ptp(np.asarray(sigma_theta, dtype=float)) != 0:
        return "sqp"
    return "ip"


#: Options that both engines take; what ``method="auto"`` passes on to its SQP fallback.
_SHARED_OPTIONS = ("tol", "constr_tol", "max_iter", "max_time")


def _planar_target(y: FloatArray, phi: float) -> PlanarTarget:
    return PlanarTarget(float(y[0]), float(y[1]), float(y[2]), phi)


#: Default number of starts in spatial mode (5 structured, the rest random; ``rng``).
SPATIAL_STARTS = 12
#: Spatial default: stop when this many first starts all end farther than
#: SPATIAL_GIVE_UP_MM from satisfying the target and the limits.
SPATIAL_GIVE_UP = 3
SPATIAL_GIVE_UP_MM = 1.0


#: Bisection steps of :func:`_nearest_reachable` (the segment is halved each time).
NEAREST_STEPS = 24
#: Beyond this fraction of the segment the target may still be reachable: the SQP engine
#: decides (starting from the pose reached).
NEAREST_MAX_T = 0.999
NEAREST_MESSAGE = (
    "No feasible pose found: the target looks unreachable (every interior-point start "
    "stalled); q respects every limit and reaches the point y0 + t (y_target - y0) for "
    "the largest t a bisection from the upright pose y0 found; target_error is what is "
    "left [mm]."
)


def _nearest_reachable(
    stack: Stack,
    target: PlanarTarget,
    objective: str,
    weights: tuple[FloatArray, FloatArray] | None,
    options: dict[str, Any],
    deadline: float,
) -> tuple[_Run | None, float, int, int]:
    """A pose within every limit that gets as near ``target`` as the segment allows.

    For a target the interior point cannot reach from any start: bisection on ``t`` in
    ``[0, 1]`` over the planar targets ``y(t) = y0 + t (y_target - y0)`` (same phi), from
    the upright pose at nominal height (``y0``, checked feasible) toward the target. Each
    step runs the interior point from the last reached pose and from the paper's guess of
    ``y(t)``; a step succeeds when its pose passes the independent check for ``y(t)``.
    Returns the last reached pose as a :class:`_Run` checked against ``target`` itself
    (so its violation is the remaining target error), the ``t`` it reaches, the
    iterations and the solves used; ``None`` when the upright pose is not feasible. The
    reachable set need not be convex along the segment: this is a nearby pose within
    limits, not the nearest one.
    """
    from stackik._check import planar_check

    n = stack.n
    q_lo = np.column_stack([np.zeros(n), _nominal_height(stack), np.zeros(n)])
    y0 = planar_forward(q_lo)
    y1 = target.y
    if not planar_check(stack, _planar_target(y0, target.phi), q_lo)[0].ok:
        return None, 0.0, 0, 0
    t_lo, t_hi = 0.0, 1.0
    nit = solves = 0
    for _ in range(NEAREST_STEPS):
        left = deadline - time.perf_counter()
        if left <= 0:
            break
        t = 0.5 * (t_lo + t_hi)
        tgt = _planar_target(y0 + t * (y1 - y0), target.phi)
        prob = _Problem(stack, tgt, objective, weights)
        starts = [q_lo, paper_initial_guess(stack, tgt)]
        run, _, it, _ = _ip_starts(prob, starts, options, left)
        nit += it
        solves += len(starts)
        if run is not None:
            t_lo, q_lo = t, run.q
        else:
            t_hi = t
    chk, P, R, legs = planar_check(stack, target, q_lo)
    obj = _Problem(stack, target, objective, weights).objective_value(q_lo)
    return _Run(q_lo, nit, "nearest", chk, obj, lifted=(P, R, legs)), t_lo, nit, solves


def _ip_starts(
    prob: _Problem, starts: list[FloatArray], options: dict[str, Any], max_time: float
) -> tuple[_Run | None, _Run | None, int, list[str]]:
    """Interior-point runs from every start in one compiled call; the best that passes
    :func:`check_pose` (tried in order of objective among those the solver reports
    feasible), the least-violation run when none passes, the total iterations and the
    solver's statuses."""
    from stackik._check import planar_check
    from stackik._ipm import ip_multi

    U0 = np.stack([prob.u_of(q) for q in starts])
    opts = {"max_time": max_time, **options}
    try:
        X, statuses, nits, objs, viols = ip_multi(prob, U0, opts)
    except OptionError:
        raise
    except Exception:  # noqa: BLE001 - e.g. a LAPACK failure on absurd input: no run
        return None, None, 0, []
    order = sorted(range(len(starts)), key=lambda j: (not viols[j] <= 1e-10, objs[j]))
    least: _Run | None = None
    for j in order:
        q = prob.q_of(X[j])
        # the independent re-check (compiled; same values as check_pose, tested)
        chk, P, R, legs = planar_check(prob.stack, prob.target, q)
        # the objective at the polished point, unscaled (f = objective / fscale)
        obj = objs[j] * prob.fscale
        run = _Run(q, int(nits[j]), statuses[j], chk, obj, lifted=(P, R, legs))
        if chk.ok:
            return run, least, int(np.sum(nits)), statuses
        if least is None or chk.max_violation_mm < least.check.max_violation_mm:
            least = run
        if viols[j] > 1e-6:  # the rest are farther off: stop checking
            break
    return None, least, int(np.sum(nits)), statuses


def _sigma_weights(
    n: int, sigma_t: ArrayLike | None, sigma_theta: ArrayLike | None
) -> tuple[FloatArray, FloatArray]:
    if sigma_t is None or sigma_theta is None:
        raise ValueError('objective="weighted" needs sigma_t [mm] and sigma_theta [rad]')
    st = np.broadcast_to(np.asarray(sigma_t, dtype=float), (n,)).copy()
    sth = np.broadcast_to(np.asarray(sigma_theta, dtype=float), (n,)).copy()
    if not (np.all(np.isfinite(st)) and np.all(np.isfinite(sth))):
        raise ValueError("sigma_t, sigma_theta: must be finite")
    if np.any(st < 0) or np.any(sth <= 0):
        raise ValueError("sigma_t must be >= 0 and sigma_theta > 0")
    return st**2, sth**2


def solve_ik(
    stack: Stack,
    target: Target,
    *,
    objective: Literal["frobenius", "feasible", "weighted"] = "frobenius",
    method: Literal["auto", "sqp", "ip", "slsqp", "trust-constr", "ipopt"] = "auto",
    qp_solver: str | None = None,
    x0: ArrayLike | None = None,
    starts: int | None = None,
    rng: np.random.Generator | int | None = None,
    options: dict[str, Any] | None = None,
    sigma_t: ArrayLike | None = None,
    sigma_theta: ArrayLike | None = None,
    start: Literal["paper", "convex"] = "paper",
    max_time: float | None = None,
    blas_threads: int | None = 1,
) -> IKResult:
    """Solve the inverse kinematics of a stack for one target.

    Parameters
    ----------
    stack : Stack
    target : PlanarTarget or SpatialTarget
        Planar mode (3 variables per platform) or spatial mode (6).
    objective : {"frobenius", "feasible", "weighted"}
        ``"frobenius"`` minimises ``FN^2`` (the paper); ``"feasible"`` only reaches the
        target within the limits (the paper's non-optimised pose: the first feasible pose
        the solver reaches from its start); ``"weighted"`` minimises ``trace(J C_x J^T)``
        with ``C_x = diag(sigma_t^2, ..., sigma_theta^2)`` (per platform if arrays).
    method : {"auto", "sqp", "ip", "slsqp", "trust-constr", "ipopt"}
        ``"ip"``: stackik's compiled primal-dual interior-point solver (planar; see
        :mod:`stackik._ipm`); ``"sqp"``: stackik's SQP engine (:mod:`stackik.sqp`, any QP
        backend, planar and spatial); ``"auto"`` (default) picks ``"ip"`` for planar
        targets with the ``"frobenius"`` objective (or ``"weighted"`` with one
        ``sigma_theta``) and ``"sqp"`` otherwise (see :func:`_auto_method`). When every
        interior-point start stalls far from feasibility (an unreachable target), the
        result is "infeasible" with a pose within every limit part of the way to the
        target (bisection from the upright pose; ``target_error`` is what is left); when
        no start passes the check otherwise, the SQP engine takes over (it reports
        infeasibility and the least-violation pose); the result's ``method`` says which
        produced the pose. ``"slsqp"``/``"trust-constr"``: scipy baselines given the same
        scaled derivatives; ``"ipopt"``: IPOPT through CasADi (planar only; optional extra
        ``stackik[ipopt]``) with exact derivatives by automatic differentiation.
    qp_solver : str, optional
        QP backend of the SQP engine (default: its fastest installed one).
    x0 : array_like, optional
        Warm start, shape (n, 3) or (n, 6); default the paper's initial guess
        (:func:`paper_initial_guess`) or, with ``start="convex"``, the convex restriction
        (:func:`stackik.convex.convex_start`; the paper's guess when that SOCP is
        infeasible).
    starts : int, optional
        Number of starts. Default: in planar mode without ``x0``, three structured starts
        (the paper's guess and two "folded" variants whose top two platforms are offset
        sideways in opposite directions, see :func:`_initial_starts`) and, for the
        interior-point path with n >= 5, every sideways-fold pattern of the top 3 (n = 5),
        4 (n >= 6) or 5 (n >= 16) platforms (:func:`fold_depth`, :func:`_fold_patterns`):
        3, 11, 19 and 35 starts; otherwise one. These find the best known FN on the
        benchmark targets (README). Extra starts perturb the first with Gaussian noise
        (``rng``). The best pose that passes the check is returned; when none does, up to
        three more starts (the convex start first) are tried.
    rng : Generator, int or None
        Randomness of the extra (random) starts, including the fallback ones; None uses a
        fixed seed, so that the same call always returns the same pose.
    options : dict, optional
        Passed to the solver: ``SQPOptions`` fields for "sqp", ``tol``, ``constr_tol``,
        ``mu0``, ``max_iter``, ``max_time`` for "ip" (:data:`stackik._ipm.IP_DEFAULTS`),
        scipy or IPOPT options otherwise.
    max_time : float, optional
        Wall-time budget over all starts [s]; default ``10 + 2 n``.
    blas_threads : int or None
        BLAS threads during the solve (default 1: the matrices are small and threads
        only contend, 5x slower at n = 32 on a loaded 2-core machine); None leaves the
        process setting alone.

    Returns
    -------
    IKResult
        ``success`` only when :func:`check_pose` passes (for interior-point poses its
        compiled twin :func:`stackik._check.planar_check`, tested to agree, does the
        check).
    """
    args = dict(locals())
    blas = _BlasLimit(blas_threads)
    try:
        return _solve_ik(**{**args, "blas_threads": blas})
    finally:
        blas.restore()


_BLAS: list[Any] = []


class _BlasLimit:
    """The BLAS thread limit of one solve, applied on first need: the compiled
    interior-point path does not call BLAS on its small matrices, so it skips the
    threadpoolctl round trip (about 20 us, 5 % of an n = 4 solve); every other path
    (SQP, scipy, IPOPT, the spatial chain) calls :meth:`apply` before it runs."""

    def __init__(self, threads: int | None) -> None:
        self.threads = threads
        self._limiter: Any = None

    def apply(self) -> None:
        if self.threads is not None and self._limiter is None:
            self._limiter = _blas_controller().limit(limits=self.threads, user_api="blas")

    def restore(self) -> None:
        if self._limiter is not None:
            self._limiter.restore_original_limits()
            self._limiter = None


def _blas_controller() -> Any:
    """A cached :class:`threadpoolctl.ThreadpoolController` (creating one scans the libs)."""
    if not _BLAS:
        from threadpoolctl import ThreadpoolController

        _BLAS.append(ThreadpoolController())
    return _BLAS[0]


def _solve_ik(
    stack: Stack,
    target: Target,
    *,
    objective: str,
    method: str,
    qp_solver: str | None,
    x0: ArrayLike | None,
    starts: int | None,
    rng: np.random.Generator | int | None,
    options: dict[str, Any] | None,
    sigma_t: ArrayLike | None,
    sigma_theta: ArrayLike | None,
    start: str,
    max_time: float | None,
    blas_threads: _BlasLimit,
) -> IKResult:
    t_start = time.perf_counter()
    if not isinstance(stack, Stack):
        raise ValueError(f"stack: expected a Stack, got {type(stack).__name__}")
    if max_time is None:
        max_time = 10.0 + 2.0 * stack.n
    if not (isinstance(max_time, int | float) and max_time > 0):
        raise ValueError(f"max_time: expected a positive number of seconds, got {max_time!r}")
    if not isinstance(stack, Stack):
        raise ValueError(f"stack: expected a Stack, got {type(stack).__name__}")
    if not isinstance(target, PlanarTarget | SpatialTarget):
        raise ValueError(
            f"target: expected a PlanarTarget or SpatialTarget, got {type(target).__name__}"
        )
    if objective not in OBJECTIVES:
        raise ValueError(f"objective: unknown {objective!r}; choose one of {OBJECTIVES}")
    if method not in METHODS:
        raise ValueError(f"method: unknown {method!r}; choose one of {METHODS}")
    if starts is not None and (
        isinstance(starts, bool) or not isinstance(starts, int | np.integer) or starts < 1
    ):
        raise ValueError(f"starts: expected an integer >= 1, got {starts!r}")
    if start not in ("paper", "convex"):
        raise ValueError(f"start: unknown {start!r}; choose 'paper' or 'convex'")
    planar = isinstance(target, PlanarTarget)
    auto = method == "auto"
    if auto:
        method = _auto_method(planar, objective, sigma_theta, qp_solver, options)
    if method == "ip" and not planar:
        raise ValueError('method "ip" is planar only (PlanarTarget); use "sqp" or "auto"')
    if method != "ip":
        blas_threads.apply()
    if method == "sqp" and qp_solver is not None:
        from stackik.sqp.qp import make_backend

        make_backend(qp_solver)  # raises ValueError listing the available ones
    n, k = stack.n, (3 if planar else 6)
    gen: Any = None
    if rng is not None:  # None: a fixed seed, made only when a random start is needed
        try:
            gen = np.random.default_rng(rng)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"rng: expected None, an int seed or a numpy Generator ({exc})"
            ) from None

    def random_start() -> FloatArray:
        nonlocal gen
        if gen is None:
            gen = np.random.default_rng(0)
        span = float(np.mean(stack.leg_max - stack.leg_min))
        # perturbation scale of random starts: 15% of the leg range [mm], 0.1 rad
        pert = np.tile([0.15 * span] * (k - (1 if planar else 3)) + [0.1] * (1 if planar else 3), n)
        return q0 + (gen.standard_normal(n * k) * pert).reshape(n, k)  # type: ignore[no-any-return]

    weights = _sigma_weights(n, sigma_t, sigma_theta) if objective == "weighted" else None
    if x0 is not None:
        q0 = np.array(x0, dtype=float)
        if q0.shape != (n, k) or not np.all(np.isfinite(q0)):
            raise ValueError(f"x0: expected finite values of shape ({n}, {k}), got {q0.shape}")
    elif start == "convex":
        from stackik.convex import ConvexStartError, convex_start

        try:
            q0 = convex_start(stack, target)
        except ConvexStartError:  # no convex start for these rotations: the paper's guess
            q0 = paper_initial_guess(stack, target)
    else:
        q0 = paper_initial_guess(stack, target)
    prob = _Problem(stack, target, objective, weights)
    if method == "ip" and objective == "weighted" and np.ptp(prob.w_th) != 0:
        raise ValueError('method "ip" needs one sigma_theta for all platforms; use "sqp"')
    opts = dict(options or {})
    if method == "sqp":
        _sqp_options(opts)  # bad options are reported before any solve
    elif method == "ip":
        from stackik._ipm import _ip_options

        _ip_options(opts)
    qp_name = qp_solver or ("default" if method == "sqp" else "-")

    def finish(
        run: _Run | None, status: IKStatus, nit: int, n_starts: int, message: str = ""
    ) -> IKResult:
        q = q0 if run is None else run.q
        chk = check_pose(stack, target, q) if run is None else run.check
        if run is not None and run.lifted is not None:
            P, R, legs = run.lifted
        else:
            if planar:
                assert isinstance(target, PlanarTarget)
                P, R = lift_planar(q, target.phi)
            else:
                P, R = q[:, :3].copy(), euler_zyx(q[:, 3:])
            legs = np.linalg.norm(
                np.einsum("nij,nkj->nki", R, stack.top_nodes) + P[:, None, :] - stack.base_nodes,
                axis=-1,
            )
        return IKResult(
            q=q,
            success=status is IKStatus.SUCCESS,
            status=status,
            message=message or _MESSAGES[status],
            frobenius_norm=math.sqrt(run.obj)
            if run is not None and objective == "frobenius"
            else _frobenius(q, planar),
            objective=objective,
            objective_value=prob.objective_value(q) if run is None else run.obj,
            max_violation=chk.max_violation,
            target_error=chk.position_error,
            angle_error=chk.angle_error,
            nit=nit,
            time=time.perf_counter() - t_start,
            method=method,
            qp_solver=qp_name,
            n_starts=n_starts,
            P=P,
            R=R,
            leg_lengths=legs,
            phi=target.phi if isinstance(target, PlanarTarget) else None,
            mode="planar" if planar else "spatial",
        )

    # quick unreachability test (triangle inequality on every platform)
    P_t = np.array([target.rho, target.z]) if isinstance(target, PlanarTarget) else target.position
    if float(np.linalg.norm(P_t)) > _reach_bound(stack):
        return finish(None, IKStatus.INFEASIBLE, 0, 0)

    best: _Run | None = None
    least: _Run | None = None
    tried = 0
    last_status = ""
    status_out = IKStatus.SUCCESS
    nit_total = 0
    queue = _initial_starts(stack, target, q0, structured=x0 is None and start == "paper")
    spatial_default = False
    if starts is None and not planar and n >= 2 and x0 is None and start == "paper":
        # spatial: the five structured starts and seven random ones, each solved in full
        # (benchmark: within 0.1 % of the best FN found on 30 of 30 targets, vs 28 from
        # the structured five alone, at twice their time)
        starts = SPATIAL_STARTS
        spatial_default = True
    n_planned = len(queue) if starts is None else int(starts)
    quick_verdict = False
    if method == "ip":
        qs_all = queue[:n_planned]
        if starts is None and x0 is None and start == "paper":
            qs_all += _fold_patterns(stack, q0, fold_depth(n))
            qs_all += [random_start() for _ in range(tall_random_starts(n))]
        while len(qs_all) < n_planned:
            qs_all.append(random_start())
        left = max(max_time - (time.perf_counter() - t_start), 1e-3)
        ip_run, ip_least, nit_ip, ip_statuses = _ip_starts(prob, qs_all, opts, left)
        if ip_run is not None:
            return finish(ip_run, IKStatus.SUCCESS, nit_ip, len(qs_all))
        if not auto:
            if "max_time" in ip_statuses:
                ip_status = IKStatus.MAX_TIME
            elif "max_iter" in ip_statuses and all(
                s in ("max_iter", "skipped") for s in ip_statuses
            ):
                ip_status = IKStatus.MAX_ITER
            else:
                ip_status = IKStatus.FAILED
            return finish(ip_least, ip_status, nit_ip, len(qs_all))
        stalled = all(s in ("stalled", "skipped") for s in ip_statuses)
        if stalled:
            # Every interior-point start stalled far from feasibility: the target is
            # almost certainly unreachable. Report the pose within every limit nearest
            # the target along the segment from the upright pose (a bisection of
            # interior-point solves, milliseconds); when that cannot run, the structured
            # starts go to the SQP engine below, one at a time until it certifies local
            # infeasibility (its least-violation pose), without screening or fallbacks.
            assert isinstance(target, PlanarTarget)
            near, t_near, nit_near, n_near = _nearest_reachable(
                stack, target, objective, weights, opts, t_start + max_time
            )
            if near is not None and t_near <= NEAREST_MAX_T:
                n_tried = len(qs_all) + n_near
                return finish(
                    near, IKStatus.INFEASIBLE, nit_ip + nit_near, n_tried, NEAREST_MESSAGE
                )
            if near is not None:  # nearly there: the SQP engine starts from that pose
                queue.insert(0, near.q)
        # method="auto": no start passed, the SQP engine decides (it reports the least
        # violation and infeasibility), with the limits the user gave
        method = "sqp"
        blas_threads.apply()
        opts = {key: v for key, v in opts.items() if key in _SHARED_OPTIONS}
        nit_total = nit_ip
        tried_ip = len(qs_all)
        least = ip_least
        quick_verdict = stalled
    else:
        tried_ip = 0
    screened: list[_Run] = []
    if starts is None and len(queue) > 1 and method == "sqp" and not quick_verdict:
        # Screen the structured starts with a loose KKT tolerance and keep the best that
        # passes the check (its FN is within ~1e-8 of the fully converged value); when none
        # passes, the others are solved in full, best first.
        for qs in queue:
            left = max(max_time - (time.perf_counter() - t_start), 1e-3)
            run = _solve_from(prob, qs, method, qp_solver, {**SCREEN_OPTIONS, **opts}, left)
            nit_total += run.nit
            screened.append(run)
            if not run.check.ok and (
                least is None or run.check.max_violation_mm < least.check.max_violation_mm
            ):
                least = run
        screened.sort(key=lambda r: (r.check.max_violation_mm > SCREEN_FEAS_MM, r.obj))
        queue = [r.q for r in screened]
        n_planned = 0 if screened[0].check.ok else 1
    fallback = 3 if x0 is None and not quick_verdict else 0  # more starts if none passes
    far_off = True
    while tried < n_planned:
        if tried > 0 and time.perf_counter() - t_start > max_time:
            status_out = IKStatus.MAX_TIME
            break
        if tried < len(queue):
            qs = queue[tried]
        elif best is None and tried == n_planned - fallback and start == "paper":
            from stackik.convex import ConvexStartError, convex_start

            try:
                qs = convex_start(stack, target)
            except ConvexStartError:
                qs = random_start()
        else:
            qs = random_start()
        left = max(max_time - (time.perf_counter() - t_start), 1e-3)
        run = _solve_from(prob, qs, method, qp_solver, opts, left)
        tried += 1
        nit_total += run.nit
        last_status = run.status
        far_off = far_off and run.check.max_violation_mm > SPATIAL_GIVE_UP_MM
        if run.check.ok:
            if best is None or run.obj < best.obj - 1e-12 * abs(best.obj):
                best = run
        elif least is None or run.check.max_violation_mm < least.check.max_violation_mm:
            least = run
        if quick_verdict and (run.check.ok or run.status == "infeasible"):
            break
        if spatial_default and tried == SPATIAL_GIVE_UP and far_off:
            # the first structured starts all ended far from feasibility: an unreachable
            # target (reachable spatial targets pass from the first start in the
            # benchmark and the soak); the other starts would only repeat that
            break
        if tried == n_planned and best is None and fallback > 0:
            n_planned += fallback
            fallback = 0
    if best is None and screened and screened[0].check.ok:
        best = screened[0]
    tried += len(screened) + tried_ip  # every local solve counts as a start
    if best is not None:
        return finish(best, IKStatus.SUCCESS, nit_total, tried)
    if status_out is not IKStatus.MAX_TIME:
        if last_status == "max_iter":
            status_out = IKStatus.MAX_ITER
        elif last_status == "max_time":
            status_out = IKStatus.MAX_TIME
        elif last_status == "success":  # the solver claimed success; the check disagreed
            status_out = IKStatus.FAILED
        elif least is not None and least.check.max_violation_mm > FEAS_TOL:
            status_out = IKStatus.INFEASIBLE
        else:
            status_out = IKStatus.FAILED
    return finish(least, status_out, nit_total, tried)


def solve_many(
    stack: Stack,
    targets: Iterable[Target],
    *,
    progress: bool = False,
    executor: Executor | None = None,
    checkpoint: str | Path | None = None,
    **kwargs: Any,
) -> list[IKResult]:
    """Solve :func:`solve_ik` for many targets (same keyword arguments).

    Parameters
    ----------
    progress : bool
        Show a tqdm progress bar.
    executor : concurrent.futures.Executor, optional
        Spread the targets (e.g. a ``ProcessPoolExecutor``); results keep the input order.
    checkpoint : path, optional
        JSON-lines file: every finished result is appended (and flushed) as soon as it
        completes; a later call with the same targets and file skips the targets already
        there, so an interrupted batch resumes without losing or repeating work.

    Returns
    -------
    list of IKResult
        In the order of ``targets``.
    """
    from stackik.batch import checkpointed_map

    return checkpointed_map(
        _SolveOne(stack, kwargs),
        targets,
        key=target_to_dict,
        encode=IKResult.to_record,
        decode=IKResult.from_record,
        checkpoint=checkpoint,
        executor=executor,
        progress=progress,
        desc="solve",
    )


@dataclass(frozen=True)
class _SolveOne:
    stack: Stack
    kwargs: dict[str, Any]

    def __call__(self, target: Target) -> IKResult:
        return solve_ik(self.stack, target, **self.kwargs)
