"""One Stewart platform: legs, the 24 limit constraints and their Jacobians, forward kinematics.

All functions here are vectorised: a stack's n platforms (and optionally a batch of
poses) are handled at once, the platform axis being the last axis before the per-platform
coordinates. Conventions follow DESIGN §2:

* leg k: :math:`\\ell_k = R t_k + P - b_k` (paper eq. 1) in the bottom plate's frame;
* constraints ``c >= 0`` in four blocks of six (legs 0..5):
  ``|l|^2 - leg_min^2``, ``leg_max^2 - |l|^2``, ``l.n - |l| s``, ``l.(R n) - |l| s`` with
  ``n = (0, 0, 1)`` and ``s = sin(joint_min)``; units mm^2, mm^2, mm, mm.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.rotations import euler_zyx, euler_zyx_derivatives, plane_axis


class PlatformGeometry(Protocol):
    """What this module reads of a :class:`stackik.geometry.PlatformGeometry` (arrays only:
    the module depends on no class of :mod:`stackik.geometry`)."""

    @property
    def base_nodes(self) -> NDArray[np.float64]: ...  # (6, 3) [mm]
    @property
    def top_nodes(self) -> NDArray[np.float64]: ...  # (6, 3) [mm]
    @property
    def leg_min(self) -> float: ...  # [mm]
    @property
    def leg_max(self) -> float: ...  # [mm]


class Stack(Protocol):
    """What this module reads of a :class:`stackik.geometry.Stack`: per-platform arrays."""

    @property
    def n(self) -> int: ...
    @property
    def base_nodes(self) -> NDArray[np.float64]: ...  # (n, 6, 3) [mm]
    @property
    def top_nodes(self) -> NDArray[np.float64]: ...  # (n, 6, 3) [mm]
    @property
    def leg_min(self) -> NDArray[np.float64]: ...  # (n,) [mm]
    @property
    def leg_max(self) -> NDArray[np.float64]: ...  # (n,) [mm]
    @property
    def sin_joint_min(self) -> NDArray[np.float64]: ...  # (n,)
    def derived(self, key: Any, make: Callable[[Any], Any]) -> Any: ...


__all__ = [
    "CONSTRAINT_BLOCKS",
    "PlatformFKResult",
    "PlatformFKStatus",
    "constraints_from_legs",
    "leg_lengths",
    "leg_vectors",
    "planar_constraint_jacobian",
    "planar_constraints",
    "planar_legs",
    "platform_forward_kinematics",
    "spatial_constraint_jacobian",
    "spatial_constraints",
    "spatial_legs",
]

FloatArray = NDArray[np.float64]

#: Names of the four blocks of six constraints, in order.
CONSTRAINT_BLOCKS = ("leg_min", "leg_max", "joint_base", "joint_top")

_EZ = np.array([0.0, 0.0, 1.0])


def _cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """``np.cross(a, b)`` over the last axis (length 3), without its overhead."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def validate_pose_array(q: ArrayLike, n: int, ncols: int, name: str = "q") -> FloatArray:
    """Validate a pose array of shape (..., n, ncols): finite floats, right shape."""
    try:
        arr = np.asarray(q, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected an array of numbers ({exc})") from None
    if arr.ndim < 2 or arr.shape[-2:] != (n, ncols):
        raise ValueError(f"{name}: expected shape (..., {n}, {ncols}), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    return arr


def constraints_from_legs(
    l: FloatArray,
    Rn: FloatArray,
    leg_min: FloatArray,
    leg_max: FloatArray,
    sin_joint: FloatArray,
    dl: FloatArray | None = None,
    dRn: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray | None]:
    """The 24 constraint values of DESIGN §2 (and their Jacobian) from leg vectors.

    Parameters
    ----------
    l : ndarray, shape (..., 6, 3)
        Leg vectors [mm].
    Rn : ndarray, shape (..., 3)
        Top plate normal ``R n`` in the bottom frame.
    leg_min, leg_max, sin_joint : ndarray, shape broadcastable to (...)
        Limits per platform.
    dl : ndarray, shape (..., k, 6, 3), optional
        Derivatives of ``l`` with respect to k variables.
    dRn : ndarray, shape (..., k, 3), optional
        Derivatives of ``Rn``.

    Returns
    -------
    c : ndarray, shape (..., 24)
    Jc : ndarray, shape (..., 24, k) or None
    """
    sq = np.einsum("...ki,...ki->...k", l, l)
    norm = np.sqrt(sq)
    s = np.asarray(sin_joint)[..., None]
    ln = l[..., 2]
    lRn = np.einsum("...ki,...i->...k", l, Rn)
    c = np.concatenate(
        [
            sq - np.asarray(leg_min)[..., None] ** 2,
            np.asarray(leg_max)[..., None] ** 2 - sq,
            ln - norm * s,
            lRn - norm * s,
        ],
        axis=-1,
    )
    if dl is None:
        return c, None
    assert dRn is not None
    dsq = 2.0 * np.einsum("...ki,...jki->...kj", l, dl)  # (..., 6, k)
    dnorm = dsq / (2.0 * norm[..., None])
    dln = dl[..., 2]  # (..., k, 6)
    dln = np.swapaxes(dln, -1, -2)
    dlRn = np.einsum("...jki,...i->...kj", dl, Rn) + np.einsum("...ki,...ji->...kj", l, dRn)
    sj = s[..., None]
    Jc = np.concatenate([dsq, -dsq, dln - dnorm * sj, dlRn - dnorm * sj], axis=-2)
    return c, Jc


def leg_vectors(geometry: PlatformGeometry, P: ArrayLike, R: ArrayLike) -> FloatArray:
    """Leg vectors ``l_k = R t_k + P - b_k`` of one platform (the paper's equation 1).

    Parameters
    ----------
    P : array_like, shape (..., 3)
        Top plate origin in the bottom frame [mm].
    R : array_like, shape (..., 3, 3)
        Top plate orientation in the bottom frame.

    Returns
    -------
    l : ndarray, shape (..., 6, 3) [mm]
    """
    P = np.asarray(P, dtype=float)
    R = np.asarray(R, dtype=float)
    return (
        np.einsum("...ij,kj->...ki", R, geometry.top_nodes) + P[..., None, :] - geometry.base_nodes
    )


def leg_lengths(geometry: PlatformGeometry, P: ArrayLike, R: ArrayLike) -> FloatArray:
    """Leg lengths ``|l_k|`` [mm], shape (..., 6): the platform's inverse kinematics."""
    return np.linalg.norm(leg_vectors(geometry, P, R), axis=-1)


def _plane_parts(phi: float) -> Any:
    """Builder of the phi-dependent, pose-independent parts of :func:`planar_legs`:
    the plane axis s, e_phi, the top nodes split along / across s, s x e_z (cached per
    stack)."""

    def make(stack: Stack) -> tuple[FloatArray, ...]:
        s = plane_axis(phi)
        e_phi = np.array([np.cos(phi), np.sin(phi), 0.0])
        t = stack.top_nodes  # (n, 6, 3)
        t_par = np.einsum("nki,i->nk", t, s)[..., None] * s
        out = (s, e_phi, t_par, t - t_par, _cross(s, t), _cross(s, _EZ))
        for a in out:
            a.setflags(write=False)
        return out

    return make


def planar_legs(
    stack: Stack, q: FloatArray, phi: float, derivatives: bool = False
) -> tuple[FloatArray, FloatArray, FloatArray | None, FloatArray | None]:
    """Leg vectors and top normals of a planar pose, optionally with derivatives.

    Parameters
    ----------
    q : ndarray, shape (..., n, 3)
        Rows ``[rho_i, z_i, theta_i]`` [mm, mm, rad].

    Returns
    -------
    l : (..., n, 6, 3); Rn : (..., n, 3); dl : (..., n, 3, 6, 3) or None;
    dRn : (..., n, 3, 3) or None
    """
    parts = stack.derived(("planar_legs", phi), _plane_parts(phi))
    s, e_phi, t_par, t_perp, t_cross, s_x_ez = parts
    th = q[..., 2]
    c = np.cos(th)[..., None, None]
    sn = np.sin(th)[..., None, None]
    Rt = t_par + c * t_perp + sn * t_cross  # (..., n, 6, 3)
    P = q[..., 0, None] * e_phi + q[..., 1, None] * _EZ  # (..., n, 3)
    l = Rt + P[..., None, :] - stack.base_nodes
    # R e_z: e_z has no component along s (s is horizontal), so R e_z = c e_z + s (s x e_z).
    Rn = np.cos(th)[..., None] * _EZ + np.sin(th)[..., None] * s_x_ez
    if not derivatives:
        return l, Rn, None, None
    dRt = _cross(s, Rt)  # d(R t)/dtheta = s x (R t)
    dl = np.empty(l.shape[:-2] + (3, 6, 3))
    dl[..., 0, :, :] = e_phi
    dl[..., 1, :, :] = _EZ
    dl[..., 2, :, :] = dRt
    dRn = np.zeros(Rn.shape[:-1] + (3, 3))
    dRn[..., 2, :] = _cross(s, Rn)
    return l, Rn, dl, dRn


def spatial_legs(
    stack: Stack, q: FloatArray, derivatives: bool = False
) -> tuple[FloatArray, FloatArray, FloatArray | None, FloatArray | None]:
    """Leg vectors and top normals of a spatial pose (..., n, 6), optionally with derivatives.

    Returns
    -------
    l : (..., n, 6, 3); Rn : (..., n, 3); dl : (..., n, 6, 6, 3) or None;
    dRn : (..., n, 6, 3) or None
    """
    R = euler_zyx(q[..., 3:])
    Rt = np.einsum("...ij,...kj->...ki", R, stack.top_nodes)
    l = Rt + q[..., None, :3] - stack.base_nodes
    Rn = R[..., :, 2]
    if not derivatives:
        return l, Rn, None, None
    D = euler_zyx_derivatives(q[..., 3:])  # (..., n, 3, 3, 3)
    dl = np.empty(l.shape[:-2] + (6, 6, 3))
    dl[..., :3, :, :] = np.eye(3)[:, None, :]
    dl[..., 3:, :, :] = np.einsum("...aij,...kj->...aki", D, stack.top_nodes)
    dRn = np.zeros(Rn.shape[:-1] + (6, 3))
    dRn[..., 3:, :] = D[..., :, 2]
    return l, Rn, dl, dRn


def _limits(stack: Stack) -> tuple[FloatArray, FloatArray, FloatArray]:
    return stack.leg_min, stack.leg_max, stack.sin_joint_min


def planar_constraints(stack: Stack, q: ArrayLike, phi: float) -> FloatArray:
    """Raw constraints of a planar pose; q (..., n, 3) -> (..., n, 24). See :class:`Stack`."""
    qa = validate_pose_array(q, stack.n, 3)
    phi = _check_phi(phi)
    l, Rn, _, _ = planar_legs(stack, qa, phi)
    return constraints_from_legs(l, Rn, *_limits(stack))[0]


def planar_constraint_jacobian(
    stack: Stack, q: ArrayLike, phi: float
) -> tuple[FloatArray, FloatArray]:
    """Planar constraints and their per-platform Jacobian.

    Returns
    -------
    c : ndarray, shape (..., n, 24)
    Jc : ndarray, shape (..., n, 24, 3)
        ``Jc[..., i, r, j] = d c[i, r] / d q[i, j]``; constraints of platform i depend on
        platform i's variables only (the full Jacobian is block diagonal).
    """
    qa = validate_pose_array(q, stack.n, 3)
    phi = _check_phi(phi)
    l, Rn, dl, dRn = planar_legs(stack, qa, phi, derivatives=True)
    c, Jc = constraints_from_legs(l, Rn, *_limits(stack), dl=dl, dRn=dRn)
    assert Jc is not None
    return c, Jc


def spatial_constraints(stack: Stack, q: ArrayLike) -> FloatArray:
    """Raw constraints of a spatial pose; q (..., n, 6) -> (..., n, 24)."""
    qa = validate_pose_array(q, stack.n, 6)
    l, Rn, _, _ = spatial_legs(stack, qa)
    return constraints_from_legs(l, Rn, *_limits(stack))[0]


def spatial_constraint_jacobian(stack: Stack, q: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Spatial constraints (..., n, 24) and per-platform Jacobian (..., n, 24, 6)."""
    qa = validate_pose_array(q, stack.n, 6)
    l, Rn, dl, dRn = spatial_legs(stack, qa, derivatives=True)
    c, Jc = constraints_from_legs(l, Rn, *_limits(stack), dl=dl, dRn=dRn)
    assert Jc is not None
    return c, Jc


def _check_phi(phi: float) -> float:
    try:
        value = float(phi)
    except (TypeError, ValueError):
        raise ValueError(f"phi: expected a number, got {phi!r}") from None
    if not np.isfinite(value):
        raise ValueError("phi: must be finite")
    return value


# --- forward kinematics of one platform ---------------------------------------------------
class PlatformFKStatus(Enum):
    """Outcome of :func:`platform_forward_kinematics`."""

    CONVERGED = "converged"
    MAX_ITER = "max_iter"
    SINGULAR = "singular"


@dataclass(frozen=True)
class PlatformFKResult:
    """Pose found by :func:`platform_forward_kinematics`.

    Attributes
    ----------
    x : ndarray, shape (6,)
        ``[x, y, z, yaw, pitch, roll]`` [mm, rad].
    P : ndarray, shape (3,)
    R : ndarray, shape (3, 3)
    residual : float
        Max abs leg-length error [mm].
    """

    x: FloatArray
    P: FloatArray
    R: FloatArray
    status: PlatformFKStatus
    nit: int
    residual: float

    @property
    def success(self) -> bool:
        return self.status is PlatformFKStatus.CONVERGED


def platform_forward_kinematics(
    geometry: PlatformGeometry,
    lengths: ArrayLike,
    x0: ArrayLike | None = None,
    tol: float = 1e-10,
    max_iter: int = 50,
) -> PlatformFKResult:
    """Pose of one platform from its six leg lengths, by damped Newton's method.

    The forward kinematics of a Stewart platform have up to 40 solutions; Newton's method
    finds the one near the start ``x0`` (the paper cites this as the hard direction).

    Parameters
    ----------
    lengths : array_like, shape (6,)
        Leg lengths [mm].
    x0 : array_like, shape (6,), optional
        Start ``[x, y, z, yaw, pitch, roll]``; default: straight up at the mid leg length.
    tol : float
        Leg-length tolerance [mm].
    """
    L = np.asarray(lengths, dtype=float)
    if L.shape != (6,) or not np.all(np.isfinite(L)) or np.any(L <= 0):
        raise ValueError(f"lengths: expected 6 positive finite values, got {L!r}")
    if x0 is None:
        h = 0.5 * (geometry.leg_min + geometry.leg_max)
        x = np.array([0.0, 0.0, h, 0.0, 0.0, 0.0])
    else:
        x = np.array(x0, dtype=float)
        if x.shape != (6,) or not np.all(np.isfinite(x)):
            raise ValueError("x0: expected 6 finite values")
    status = PlatformFKStatus.MAX_ITER
    nit = 0
    res = np.inf
    for nit in range(max_iter + 1):  # noqa: B007
        R = euler_zyx(x[3:])
        l = leg_vectors(geometry, x[:3], R)
        norm = np.linalg.norm(l, axis=1)
        r = norm - L
        res = float(np.abs(r).max())
        if res <= tol:
            status = PlatformFKStatus.CONVERGED
            break
        if nit == max_iter:
            break
        D = euler_zyx_derivatives(x[3:])
        dl = np.concatenate(
            [
                np.broadcast_to(np.eye(3)[:, None, :], (3, 6, 3)),
                np.einsum("aij,kj->aki", D, geometry.top_nodes),
            ],
            axis=0,
        )
        J = np.einsum("ki,jki->kj", l / norm[:, None], dl)  # (6 legs, 6 vars)
        if np.linalg.cond(J) > 1e12:
            status = PlatformFKStatus.SINGULAR
            break
        dx = np.linalg.solve(J, -r)
        step = 1.0
        for _ in range(30):  # backtracking on the residual norm
            xn = x + step * dx
            rn = np.linalg.norm(leg_vectors(geometry, xn[:3], euler_zyx(xn[3:])), axis=1) - L
            if np.linalg.norm(rn) < np.linalg.norm(r) or step < 1e-6:
                break
            step *= 0.5
        x = xn
    R = euler_zyx(x[3:])
    return PlatformFKResult(x=x, P=x[:3].copy(), R=R, status=status, nit=nit, residual=res)
