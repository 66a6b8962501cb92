"""Stack kinematics: forward kinematics, end-effector Jacobians and the Frobenius-norm objective.

Conventions (DESIGN §1, §3-5):

* Planar pose ``q`` has shape (n, 3), rows ``[rho_i, z_i, theta_i]`` [mm, mm, rad]; the
  flat variable vector is ``q.ravel()`` (platform-major). Output
  ``y = (rho_ee, z_ee, theta_ee)``.
* Spatial pose ``q`` has shape (n, 6), rows ``[x, y, z, yaw, pitch, roll]`` [mm, rad] with
  ``R_i = Rz(yaw) Ry(pitch) Rx(roll)``. Output ``y = (P_ee, R_ee.ravel())`` (12 entries,
  row-major).
* The stack is a serial chain: platform i contributes three prismatic joints (along the
  axes of plate i-1) followed by its rotations about the origin ``O_i`` of plate i. Every
  Jacobian column of a revolute joint ``a`` is ``(w_a x (P_ee - O_i), [w_a]x R_ee)``; the
  derivative of column ``a`` with respect to joint ``b`` is ``Omega_min(a,b) J_max(a,b)``
  (rotation of the distal column by the proximal joint), which gives every Hessian here.

FN^2 is the squared Frobenius norm of ``dy/dx``; in planar mode
:math:`FN^2 = 3n + \\sum_{j=1}^{n-1} |P_{ee} - O_j|^2`, in spatial mode
:math:`FN^2 = 9n + \\sum_{i,k} |w_{ik} \\times (P_{ee} - O_i)|^2`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.platform import _check_phi, _cross, validate_pose_array
from stackik.rotations import euler_zyx, plane_axis, rodrigues

__all__ = [
    "PlanarFN",
    "SpatialChain",
    "frobenius_norm",
    "lift_planar",
    "noise_weights",
    "planar_fn2",
    "planar_fn_residuals",
    "planar_forward",
    "planar_hessian_fn2",
    "planar_jacobian",
    "planar_plate_origins",
    "spatial_chain",
    "spatial_forward",
    "spatial_jacobian",
    "spatial_plate_origins",
]

FloatArray = NDArray[np.float64]

_J2 = np.array([[0.0, -1.0], [1.0, 0.0]])  # d/dtheta of the 2D rotation: R' = J2 R


def _pose(q: ArrayLike, ncols: int) -> FloatArray:
    arr = np.asarray(q, dtype=float)
    if arr.ndim < 2:
        raise ValueError(f"q: expected shape (..., n, {ncols}), got {arr.shape}")
    return validate_pose_array(arr, arr.shape[-2], ncols)


# =========================================================================================
# Planar mode
# =========================================================================================
def _planar_parts(q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Cumulative angles Theta_i (before platform i), world translations, plate origins."""
    theta = q[..., 2]
    Theta = np.cumsum(theta, axis=-1) - theta  # exclusive cumsum: Theta_1 = 0
    c, s = np.cos(Theta), np.sin(Theta)
    rho, z = q[..., 0], q[..., 1]
    v = np.stack([c * rho - s * z, s * rho + c * z], axis=-1)  # Rot(Theta_i) p_i, (..., n, 2)
    O = np.concatenate([np.zeros(v.shape[:-2] + (1, 2)), np.cumsum(v, axis=-2)], axis=-2)
    return Theta, v, O


def planar_plate_origins(q: ArrayLike) -> FloatArray:
    """Origins ``O_0`` to ``O_n`` of the plates in the (rho, z) plane, shape (..., n+1, 2) [mm]."""
    return _planar_parts(_pose(q, 3))[2]


def planar_forward(q: ArrayLike) -> FloatArray:
    """End effector ``(rho_ee, z_ee, theta_ee)`` of a planar pose (the paper's equation "forward").

    Parameters
    ----------
    q : array_like, shape (..., n, 3)
        Rows ``[rho_i, z_i, theta_i]`` [mm, mm, rad]; leading batch axes allowed.

    Returns
    -------
    y : ndarray, shape (..., 3)
    """
    qa = _pose(q, 3)
    _, _, O = _planar_parts(qa)
    return np.concatenate([O[..., -1, :], qa[..., 2].sum(axis=-1, keepdims=True)], axis=-1)


def planar_jacobian(q: ArrayLike) -> FloatArray:
    """End-effector Jacobian ``dy/dx`` of a planar pose, shape (3, 3n) (or (..., 3, 3n)).

    Column ``3i + j`` is the derivative with respect to ``q[i, j]``.
    """
    qa = _pose(q, 3)
    n = qa.shape[-2]
    Theta, _, O = _planar_parts(qa)
    c, s = np.cos(Theta), np.sin(Theta)
    d = O[..., -1:, :] - O[..., 1:, :]  # P_ee - O_i, i = 1..n, (..., n, 2)
    J = np.zeros(qa.shape[:-2] + (3, n, 3))
    J[..., 0, :, 0], J[..., 1, :, 0] = c, s
    J[..., 0, :, 1], J[..., 1, :, 1] = -s, c
    J[..., 0, :, 2], J[..., 1, :, 2] = -d[..., 1], d[..., 0]
    J[..., 2, :, 2] = 1.0
    return J.reshape(qa.shape[:-2] + (3, 3 * n))


def planar_fn_residuals(q: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Residuals ``r`` with ``FN^2 = 3n + |r|^2`` and their Jacobian (planar mode).

    ``r`` stacks ``d_j = P_ee - O_j`` for ``j = 1..n-1``.

    Returns
    -------
    r : ndarray, shape (2(n-1),)
    Jr : ndarray, shape (2(n-1), 3n)
    """
    qa = _pose(q, 3)
    if qa.ndim != 2:
        raise ValueError("q: expected a single pose of shape (n, 3)")
    n = qa.shape[0]
    Theta, _, O = _planar_parts(qa)
    d = O[-1] - O[1:]  # (n, 2), d_n = 0
    c, s = np.cos(Theta), np.sin(Theta)
    idx = np.arange(n)
    Jr = np.zeros((n - 1, 2, n, 3))
    later = (idx[None, :] > idx[: n - 1, None]).astype(float)  # k > i
    Jr[:, 0, :, 0] = later * c
    Jr[:, 1, :, 0] = later * s
    Jr[:, 0, :, 1] = later * -s
    Jr[:, 1, :, 1] = later * c
    dm = d[np.maximum(idx[: n - 1, None], idx[None, :])]  # d_{max(i, m)}, (n-1, n, 2)
    Jr[:, 0, :, 2] = -dm[..., 1]
    Jr[:, 1, :, 2] = dm[..., 0]
    return d[: n - 1].ravel(), Jr.reshape(2 * (n - 1), 3 * n)


def planar_fn2(q: ArrayLike) -> float:
    """``FN^2 = 3n + sum_{j<n} |P_ee - O_j|^2`` of a planar pose [mixed mm^2 and 1]."""
    qa = _pose(q, 3)
    O = _planar_parts(qa)[2]
    d = O[..., -1:, :] - O[..., 1:-1, :]
    return 3 * qa.shape[-2] + np.sum(d * d, axis=(-2, -1))  # type: ignore[no-any-return]


def planar_hessian_fn2(q: ArrayLike, exact: bool = True) -> FloatArray:
    """Hessian of planar ``FN^2``, shape (3n, 3n).

    With ``exact=False`` the Gauss-Newton matrix ``2 Jr^T Jr`` (positive semidefinite).
    """
    qa = _pose(q, 3)
    r, Jr = planar_fn_residuals(qa)
    H = 2.0 * Jr.T @ Jr
    if not exact:
        return H
    n = qa.shape[0]
    Theta, _, O = _planar_parts(qa)
    d = np.vstack([O[-1] - O[1:]])  # (n, 2), d_n = 0
    rr = r.reshape(n - 1, 2)
    idx = np.arange(n)
    # theta-theta: sum_i r_i . (-d_{max(i, m, l)})
    G = rr @ d.T  # G[i, k] = r_i . d_k, (n-1, n)
    M = np.maximum(idx[:, None], idx[None, :])
    top = np.maximum(idx[: n - 1, None, None], M[None])  # (n-1, n, n)
    Htt = -G[idx[: n - 1, None, None], top].sum(axis=0)
    # translation(k, j) - theta(m): sum_{i<k} r_i . J2 Rot(Theta_k) e_j, when m < k
    c, s = np.cos(Theta), np.sin(Theta)
    cols = np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], axis=1)  # (n, 2, 2)
    rot_cols = cols @ _J2.T  # J2 Rot e_j as rows, (n, 2 [j], 2)
    csum = np.concatenate([np.zeros((1, 2)), np.cumsum(rr, axis=0)])  # sum_{i<k} r_i, (n, 2)
    Ht = np.einsum("kji,ki->kj", rot_cols, csum[:n])  # (n [k], 2 [j])
    mask = (idx[None, :] < idx[:, None]).astype(float)  # m < k
    Hx = np.zeros((n, 3, n, 3))
    Hx[:, 2, :, 2] = Htt
    for j in range(2):
        Hx[:, j, :, 2] = Ht[:, j, None] * mask
        Hx[:, 2, :, j] = (Ht[:, j, None] * mask).T
    return H + 2.0 * Hx.reshape(3 * n, 3 * n)


@dataclass(frozen=True)
class PlanarFN:
    """Planar ``FN^2`` with gradient and Hessians at one pose (see :func:`planar_fn2`)."""

    value: float
    gradient: FloatArray
    gauss_newton: FloatArray

    @classmethod
    def at(cls, q: ArrayLike) -> PlanarFN:
        qa = _pose(q, 3)
        r, Jr = planar_fn_residuals(qa)
        return cls(3 * qa.shape[0] + float(r @ r), 2.0 * Jr.T @ r, 2.0 * Jr.T @ Jr)


def lift_planar(q: ArrayLike, phi: float) -> tuple[FloatArray, FloatArray]:
    """Per-platform 3D translations and rotations of a planar pose.

    Returns
    -------
    P : ndarray, shape (n, 3)
        ``(rho_i cos phi, rho_i sin phi, z_i)`` [mm].
    R : ndarray, shape (n, 3, 3)
        Rodrigues rotations about ``s(phi)`` by ``theta_i``.
    """
    qa = _pose(q, 3)
    phi = _check_phi(phi)
    P = np.stack([qa[..., 0] * np.cos(phi), qa[..., 0] * np.sin(phi), qa[..., 1]], -1)
    return P, rodrigues(plane_axis(phi), qa[..., 2])


# =========================================================================================
# Spatial mode
# =========================================================================================
@dataclass(frozen=True)
class SpatialChain:
    """The stack as a serial chain of 6n joints at one spatial pose.

    Attributes
    ----------
    A : ndarray, shape (n+1, 3, 3)
        Plate orientations in the base frame (``A_0 = I``, ``A_n = R_ee``).
    O : ndarray, shape (n+1, 3)
        Plate origins in the base frame [mm] (``O_0 = 0``, ``O_n = P_ee``).
    w : ndarray, shape (6n, 3)
        World joint axes: zero for translations, unit rotation axes for angles.
    J : ndarray, shape (12, 6n)
        End-effector Jacobian, rows ``(P_ee, R_ee.ravel())``.
    """

    A: FloatArray
    O: FloatArray
    w: FloatArray
    J: FloatArray

    @property
    def n(self) -> int:
        return self.A.shape[0] - 1

    def _omega(self, X: FloatArray, w: FloatArray) -> FloatArray:
        """Apply ``Omega_w`` (rotation generator) to Jacobian columns X (12, ...)."""
        Xp = np.moveaxis(X[:3], 0, -1)
        XR = np.moveaxis(X[3:].reshape((3, 3) + X.shape[1:]), (0, 1), (-2, -1))
        hp = _cross(w, Xp)
        # [w]x M for M (..., 3, 3): cross of w with each column of M
        hR = _cross(w[..., None, :], np.swapaxes(XR, -1, -2))
        hR = np.swapaxes(hR, -1, -2)
        out = np.concatenate(
            [
                np.moveaxis(hp, -1, 0),
                np.moveaxis(hR, (-2, -1), (0, 1)).reshape((9,) + hp.shape[:-1]),
            ]
        )
        return out

    def hessian(self) -> FloatArray:
        """Second derivatives of ``y``: ``H[r, a, b] = d^2 y_r / dx_a dx_b``, (12, 6n, 6n)."""
        N = self.J.shape[1]
        a = np.arange(N)
        lo = np.minimum(a[:, None], a[None, :])
        hi = np.maximum(a[:, None], a[None, :])
        return self._omega(self.J[:, hi], self.w[lo])

    def position_hessian(self, cols: FloatArray) -> FloatArray:
        """Rows ``P_ee`` of :meth:`hessian` for the columns ``cols`` only, (3, len(cols), 6n).

        Cheaper than the full tensor when only position curvature is needed (FN^2 residuals).
        """
        N = self.J.shape[1]
        b = np.arange(N)
        lo = np.minimum(cols[:, None], b[None, :])
        hi = np.maximum(cols[:, None], b[None, :])
        Jp = self.J[:3].T  # (N, 3)
        return np.moveaxis(_cross(self.w[lo], Jp[hi]), -1, 0)  # type: ignore[no-any-return]

    def third(self) -> FloatArray:
        """Third derivatives ``T[r, a, b, c]``, shape (12, 6n, 6n, 6n): memory O((6n)^3)."""
        N = self.J.shape[1]
        H = self.hessian()
        idx = np.arange(N)
        lo = np.minimum(idx[:, None], idx[None, :])
        hi = np.maximum(idx[:, None], idx[None, :])
        # d/dx_c [Omega_{w_lo} J_hi] = [c < lo] Omega_{w_c x w_lo} J_hi + Omega_{w_lo} H[:, hi, c]
        term2 = self._omega(H[:, hi, :], self.w[lo][:, :, None, :])
        wlo = self.w[lo]  # (N, N, 3)
        dw = _cross(self.w[None, None, :, :], wlo[:, :, None, :])  # (N, N, N [c], 3)
        dw *= (idx[None, None, :] < lo[:, :, None])[..., None]
        Jhi = np.broadcast_to(self.J[:, hi][..., None], (12, N, N, N))
        term1 = self._omega(Jhi, dw)
        return term1 + term2  # type: ignore[no-any-return]

    def weighted_norm2(self, weights: FloatArray | None = None) -> float:
        """``sum_a weights_a |J[:, a]|^2`` (= ``trace(J C_x J^T)``; FN^2 with unit weights)."""
        Wt = np.ones(self.J.shape[1]) if weights is None else weights
        return float(np.einsum("ra,ra,a->", self.J, self.J, Wt))

    def weighted_gradient(self, weights: FloatArray | None = None) -> FloatArray:
        """Gradient of :meth:`weighted_norm2`, shape (6n,)."""
        Wt = np.ones(self.J.shape[1]) if weights is None else weights
        return 2.0 * np.einsum("ra,rab,a->b", self.J, self.hessian(), Wt)  # type: ignore[no-any-return]

    def weighted_gauss_newton(self, weights: FloatArray | None = None) -> FloatArray:
        """Gauss-Newton Hessian ``2 sum_a w_a (dJ_a/dx)^T (dJ_a/dx)`` (PSD), (6n, 6n)."""
        Wt = np.ones(self.J.shape[1]) if weights is None else weights
        H = self.hessian()
        return 2.0 * np.einsum("rab,rac,a->bc", H, H, Wt)  # type: ignore[no-any-return]

    def weighted_hessian(self, weights: FloatArray | None = None) -> FloatArray:
        """Exact Hessian of :meth:`weighted_norm2`, (6n, 6n); costs O((6n)^3) memory."""
        Wt = np.ones(self.J.shape[1]) if weights is None else weights
        T = self.third()
        return self.weighted_gauss_newton(Wt) + 2.0 * np.einsum("ra,rabc,a->bc", self.J, T, Wt)  # type: ignore[no-any-return]


def spatial_chain(q: ArrayLike) -> SpatialChain:
    """Build the :class:`SpatialChain` of a spatial pose ``q`` (n, 6)."""
    qa = _pose(q, 6)
    if qa.ndim != 2:
        raise ValueError("q: expected a single pose of shape (n, 6)")
    n = qa.shape[0]
    R = euler_zyx(qa[:, 3:])  # (n, 3, 3)
    A = np.empty((n + 1, 3, 3))
    A[0] = np.eye(3)
    O = np.zeros((n + 1, 3))
    for i in range(n):
        O[i + 1] = O[i] + A[i] @ qa[i, :3]
        A[i + 1] = A[i] @ R[i]
    yaw = qa[:, 3]
    pitch = qa[:, 4]
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    # local rotation axes: yaw e_z, pitch Rz e_y, roll Rz Ry e_x; (n, 3, 3)
    local = np.zeros((n, 3, 3))
    local[:, 0, 2] = 1.0
    local[:, 1, 0], local[:, 1, 1] = -sy, cy
    local[:, 2, 0], local[:, 2, 1], local[:, 2, 2] = cy * cp, sy * cp, -sp
    w_rot = np.einsum("nij,nkj->nki", A[:-1], local)  # (n, 3, 3)
    u = np.swapaxes(A[:-1], -1, -2)  # u[i, j] = A_{i-1} e_j, (n, 3, 3)
    w = np.concatenate([np.zeros((n, 3, 3)), w_rot], axis=1).reshape(6 * n, 3)
    Pee, Ree = O[-1], A[-1]
    d = Pee - O[1:]  # (n, 3)
    Jp = np.concatenate([u, _cross(w_rot, d[:, None, :])], axis=1).reshape(6 * n, 3)
    JR = np.einsum("aij,jk->aik", _skew(w), Ree).reshape(6 * n, 9)
    J = np.concatenate([Jp.T, JR.T], axis=0)
    return SpatialChain(A=A, O=O, w=w, J=J)


def _skew(v: FloatArray) -> FloatArray:
    K = np.zeros(v.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2] = -v[..., 2], v[..., 1]
    K[..., 1, 0], K[..., 1, 2] = v[..., 2], -v[..., 0]
    K[..., 2, 0], K[..., 2, 1] = -v[..., 1], v[..., 0]
    return K


def spatial_forward(q: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """End-effector pose of a spatial stack (the paper's equation "forward").

    Parameters
    ----------
    q : array_like, shape (..., n, 6)
        Rows ``[x, y, z, yaw, pitch, roll]`` [mm, rad]; leading batch axes allowed.

    Returns
    -------
    P : ndarray, shape (..., 3) [mm]
    R : ndarray, shape (..., 3, 3)
    """
    qa = _pose(q, 6)
    R = euler_zyx(qa[..., 3:])
    n = qa.shape[-2]
    A = np.broadcast_to(np.eye(3), qa.shape[:-2] + (3, 3))
    P = np.zeros(qa.shape[:-2] + (3,))
    for i in range(n):
        P = P + np.einsum("...ij,...j->...i", A, qa[..., i, :3])
        A = A @ R[..., i, :, :]
    return P, A


def spatial_plate_origins(q: ArrayLike) -> FloatArray:
    """Origins ``O_0`` to ``O_n`` of the plates in the base frame, shape (n+1, 3) [mm]."""
    return spatial_chain(q).O


def spatial_jacobian(q: ArrayLike) -> FloatArray:
    """End-effector Jacobian of a spatial pose, shape (12, 6n), rows ``(P_ee, R_ee.ravel())``."""
    return spatial_chain(q).J


def frobenius_norm(J: ArrayLike) -> float:
    """Frobenius norm ``sqrt(trace(J^T J))`` of a Jacobian."""
    Ja = np.asarray(J, dtype=float)
    if Ja.ndim != 2 or not np.all(np.isfinite(Ja)):
        raise ValueError(f"J: expected a finite 2D array, got shape {Ja.shape}")
    return float(np.sqrt(np.sum(Ja * Ja)))


def noise_weights(n: int, sigma_t: float, sigma_theta: float, spatial: bool = False) -> FloatArray:
    """Diagonal of ``C_x`` (variances) for the weighted objective, shape (3n,) or (6n,).

    ``sigma_t`` [mm] for translations, ``sigma_theta`` [rad] for angles.
    """
    if not (np.isfinite(sigma_t) and np.isfinite(sigma_theta)) or sigma_t < 0 or sigma_theta < 0:
        raise ValueError("sigma_t and sigma_theta must be finite and >= 0")
    per = (
        [sigma_t**2] * 3 + [sigma_theta**2] * 3 if spatial else [sigma_t**2] * 2 + [sigma_theta**2]
    )
    return np.tile(per, n)
