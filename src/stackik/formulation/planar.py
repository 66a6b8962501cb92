"""Planar evaluation for the solvers: limits and their Jacobian, kinematics, Hessians.

The hot path of the Python engines (SQP, scipy) in planar mode; the compiled interior point
(:mod:`stackik._compiled.planar`) has its own twin of these loops. Values equal the reference
implementations of :mod:`stackik.platform` and :mod:`stackik.kinematics` (tested).
"""

from __future__ import annotations

import math
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik.geometry import Stack
from stackik.kinematics import _planar_parts
from stackik.rotations import plane_axis

__all__ = ["PlanarEvaluator"]

FloatArray = NDArray[np.float64]


class PlanarEvaluator:
    """Planar constraints with their Jacobian, specialised for speed (the hot path).

    Works in the plane's basis ``(e_phi, s, e_z)`` where ``P = (rho, 0, z)``, the rotation
    about ``s`` turns the ``(e_phi, e_z)`` components by the 2D rotation and
    ``R n = (-sin theta, 0, cos theta)``; only dot products enter the constraints, so the
    values equal :func:`stackik.platform.planar_constraint_jacobian` (tested).
    """

    def __init__(self, stack: Stack, phi: float) -> None:
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
        self._csc: tuple[Any, Any, FloatArray] | None = None  # pattern of :meth:`sparse`

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
        H = self.constraint_hessian_blocks(q, y)
        out = np.zeros((n, 3, n, 3))
        out[self.idx, :, self.idx, :] = H
        return out.reshape(3 * n, 3 * n)

    def constraint_hessian_blocks(self, q: FloatArray, y: FloatArray) -> FloatArray:
        """The diagonal blocks of :meth:`constraint_hessian`, shape (n, 3, 3): platform i's
        limits curve in its own ``(rho, z, theta)`` only."""
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
        return H

    def set_scaling(self, row_scale: FloatArray, col_scale: FloatArray) -> None:
        """Scale rows (constraints) and columns (variables) of what :meth:`__call__` returns."""
        self._scaling = (row_scale, col_scale)
        self.jflat = None
        self._csc = None

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
        D = self._values(q)
        n = self.n
        if self.jflat is None:
            self._build_scaling()
        assert self.jflat is not None
        J = np.zeros(72 * n * n)
        J[self.jflat] = D.ravel() * self.jscale
        return self.c.ravel() * self.cscale, J.reshape(24 * n, 3 * n)

    def sparse(self, q: FloatArray) -> tuple[FloatArray, Any]:
        """:meth:`__call__` with the Jacobian as a CSC matrix: block diagonal (platform i's
        24 limits touch only its 3 variables), one fixed pattern of 72 n entries (explicit
        zeros kept), the same ``indptr``/``indices`` arrays at every call."""
        from stackik.sqp.sparse import csc

        D = self._values(q)
        n = self.n
        if self.jflat is None:
            self._build_scaling()
        if self._csc is None:
            cols = np.arange(3 * n)
            self._csc = (
                (24 * np.arange(3 * n + 1)).astype(np.int32),
                (24 * (cols // 3)[:, None] + np.arange(24)[None, :]).ravel().astype(np.int32),
                # CSC order (platform, variable, limit) of D's (platform, limit, variable)
                self.jscale.reshape(n, 24, 3).transpose(0, 2, 1).ravel(),
            )
        indptr, indices, scale = self._csc
        J = csc(D.transpose(0, 3, 1, 2).ravel() * scale, indices, indptr, (24 * n, 3 * n))
        return self.c.ravel() * self.cscale, J

    def _values(self, q: FloatArray) -> FloatArray:
        """Fill ``self.c`` (raw constraints) and return ``D`` (n, 4, 6, 3): their
        derivatives with respect to each platform's (rho, z, theta)."""
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
        return D
