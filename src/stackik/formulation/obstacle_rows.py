"""Obstacle rows of a spatial problem: every leg kept clear of every sphere, capsule and
half-space (docs/clearance.md), the one definition the solvers' problems use.

Leg k of platform i (0-based) is the segment from its base joint ``B = O_i + A_i b_k`` to
its top joint ``T = O_{i+1} + A_{i+1} t_k`` (base frame [mm], :class:`SpatialChain`'s
plate frames), a capsule of radius ``r_i = leg_radius_i``. With the clearance margin ``m``:

* sphere (centre ``c``, radius ``R``) and capsule (axis ``[a, b]``, radius ``R``): per leg
  ``(d^2 - (R + r_i + m)^2) / L^2 >= 0``, ``d`` the distance of the leg's axis from the
  obstacle's (a sphere's axis is its centre), ``L = max leg_max``; the first derivatives by
  the envelope rule at the closest points (``closest_params`` of
  :mod:`stackik._compiled.self_legs`, here in numpy), as the self-leg rows;
* half-space (point ``p``, unit normal ``u``): per leg, both joints:
  ``(u . (X - p) - r_i - m) / L >= 0`` (a capsule is on the free side exactly when both
  its end balls are: the rows are exact, and smooth).

Boxes, and the plates against any obstacle, have no rows: the solvers do not steer
around them, the check (:mod:`stackik.clearance`) refuses a pose that meets them.
The rows are dense (a leg moves with every platform below it) and not in the compiled
kernels; the ``auto`` policy hands a pose that fails only on them to an engine that has
them (:func:`stackik.solve.stages.ip_stage`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik.geometry import Stack
from stackik.kinematics import lift_planar, spatial_chain
from stackik.obstacles import Capsule, HalfSpace, Obstacle, Sphere
from stackik.rotations import plane_axis

__all__ = ["ObstacleRows", "obstacle_rows"]

FloatArray = NDArray[np.float64]

#: Relative size of the squared cross term under which two segments count as parallel
#: (stackik._compiled.self_legs._PARALLEL).
_PARALLEL = 1e-12


def _closest(d1: FloatArray, d2: FloatArray, r: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Closest-point parameters (s, t) in [0, 1] of segments ``p0 + s d1`` and
    ``q0 + t d2`` (rows (k, 3), ``r = p0 - q0``): ``closest_params`` vectorised."""
    a = np.einsum("ij,ij->i", d1, d1)
    e = np.einsum("ij,ij->i", d2, d2)
    f = np.einsum("ij,ij->i", d2, r)
    c = np.einsum("ij,ij->i", d1, r)
    b = np.einsum("ij,ij->i", d1, d2)
    den = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(den > _PARALLEL * a * e, np.clip((b * f - c * e) / den, 0.0, 1.0), 0.0)
        t = (b * s + f) / e
        lo, hi = t < 0.0, t > 1.0
        s = np.where(lo, np.clip(-c / a, 0.0, 1.0), np.where(hi, np.clip((b - c) / a, 0.0, 1.0), s))
        t = np.clip(t, 0.0, 1.0)
        # degenerate segments (an obstacle's axis of zero length: a sphere)
        s = np.where(e <= 0.0, np.clip(-c / a, 0.0, 1.0), s)
        t = np.where(e <= 0.0, 0.0, t)
        s = np.where(a <= 0.0, 0.0, s)
        t = np.where(a <= 0.0, np.where(e > 0.0, np.clip(f / e, 0.0, 1.0), 0.0), t)
    return s, t


class ObstacleRows:
    """The obstacle rows of one spatial request (module doc).

    Parameters
    ----------
    stack : Stack
    obstacles : sequence of Obstacle
        Those with rows (spheres, capsules, half-spaces).
    margin : float
        Clearance margin [mm].
    phi : float or None
        Plane angle [rad] of a planar request (poses (n, 3): ``rho, z, theta``, every
        rotation about ``s(phi)``); None for spatial (n, 6).

    Attributes
    ----------
    size : int
        Number of rows: ``6 n`` per sphere or capsule, ``12 n`` per half-space.
    """

    def __init__(
        self,
        stack: Stack,
        obstacles: tuple[Obstacle, ...],
        margin: float,
        phi: float | None = None,
    ) -> None:
        self.n = stack.n
        self.phi = phi
        self.k = 6 if phi is None else 3
        self.radius = np.repeat([g.leg_radius for g in stack], 6)  # (6n,) per leg
        self.margin = float(margin)
        self.L = float(np.max(stack.leg_max))
        self.obstacles = obstacles
        self._nodes = (np.asarray(stack.base_nodes), np.asarray(stack.top_nodes))
        self.size = sum(12 * self.n if isinstance(o, HalfSpace) else 6 * self.n for o in obstacles)

    def _chain(self, q: FloatArray) -> tuple[FloatArray, ...]:
        """Plate rotations ``A`` (n+1, 3, 3) and origins ``O`` (n+1, 3) of ``q``, and per
        variable its world rotation axis ``w`` (zero for translations) and translation
        direction ``Jt`` (nk, 3)."""
        if self.phi is None:
            ch = spatial_chain(q)
            return ch.A, ch.O, ch.w, ch.J[:3].T
        n = self.n
        P, R = lift_planar(q, self.phi)
        A = np.empty((n + 1, 3, 3))
        O = np.zeros((n + 1, 3))
        A[0] = np.eye(3)
        for i in range(n):
            O[i + 1] = O[i] + A[i] @ P[i]
            A[i + 1] = A[i] @ R[i]
        s = plane_axis(self.phi)  # every rotation is about s, which they leave fixed
        radial = np.array([np.cos(self.phi), np.sin(self.phi), 0.0])
        Jt = np.zeros((3 * n, 3))
        Jt[0::3] = A[:-1] @ radial
        Jt[1::3] = A[:-1, :, 2]
        w = np.zeros((3 * n, 3))
        w[2::3] = s
        return A, O, w, Jt

    def _joints(self, q: FloatArray) -> tuple[FloatArray, ...]:
        """World joints ``B``, ``T`` (6n, 3) and their Jacobians (6n, 3, nk)."""
        A, O, w, Jt = self._chain(q)
        n, k = self.n, self.k
        base, top = self._nodes
        B = (O[:-1, None, :] + np.einsum("iab,ikb->ika", A[:-1], base)).reshape(-1, 3)
        T = (O[1:, None, :] + np.einsum("iab,ikb->ika", A[1:], top)).reshape(-1, 3)
        plate_of_col = np.repeat(np.arange(n), k) + 1  # variable a moves plates >= this
        is_angle = np.tile(np.arange(k) >= 3 if k == 6 else np.arange(k) == 2, n)
        O_col = O[plate_of_col]  # (nk, 3): the origin a variable turns about

        def jac(X: FloatArray, plate: Any) -> FloatArray:
            lever = X[:, None, :] - O_col[None, :, :]  # (P, nk, 3)
            cr = np.empty_like(lever)
            cr[..., 0] = w[:, 1] * lever[..., 2] - w[:, 2] * lever[..., 1]
            cr[..., 1] = w[:, 2] * lever[..., 0] - w[:, 0] * lever[..., 2]
            cr[..., 2] = w[:, 0] * lever[..., 1] - w[:, 1] * lever[..., 0]
            J = np.where(is_angle[None, :, None], cr, Jt[None, :, :])
            J = J * (plate[:, None] >= plate_of_col[None, :])[:, :, None]
            return np.swapaxes(J, 1, 2)  # type: ignore[no-any-return]

        leg_platform = np.repeat(np.arange(n), 6)
        return B, T, jac(B, leg_platform), jac(T, leg_platform + 1)

    def __call__(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Rows ``c`` (size,) and Jacobian (size, nk) against the raw pose ``q`` (n, k)."""
        B, T, JB, JT = self._joints(q)
        cs: list[FloatArray] = []
        Js: list[FloatArray] = []
        L = self.L
        for ob in self.obstacles:
            if isinstance(ob, HalfSpace):
                u = ob.normal / np.linalg.norm(ob.normal)
                for X, JX in ((B, JB), (T, JT)):
                    cs.append(((X - ob.point) @ u - self.radius - self.margin) / L)
                    Js.append(np.einsum("k,ikv->iv", u, JX) / L)
                continue
            assert isinstance(ob, (Sphere, Capsule))
            a, b = (ob.center, ob.center) if isinstance(ob, Sphere) else (ob.a, ob.b)
            rho = ob.radius + self.radius + self.margin
            d2 = np.broadcast_to(np.asarray(b) - np.asarray(a), B.shape)
            s, t = _closest(T - B, d2, B - a)
            g = B + s[:, None] * (T - B) - (a + t[:, None] * d2)
            cs.append((np.einsum("ij,ij->i", g, g) - rho * rho) / L**2)
            dP = (1.0 - s)[:, None, None] * JB + s[:, None, None] * JT
            Js.append(2.0 * np.einsum("ik,ikv->iv", g, dP) / L**2)
        if not cs:
            return np.zeros(0), np.zeros((0, self.k * self.n))
        return np.concatenate(cs), np.vstack(Js)


def _out_of_reach(ob: Obstacle, reach: float, gap: float) -> bool:
    """Whether ``ob`` is farther than ``gap`` [mm] from the ball of radius ``reach`` about
    the base origin, which holds every leg of every pose within the leg limits."""
    origin = np.zeros(3)
    return bool(ob.point_distance(origin) > reach + gap)


def obstacle_rows(
    stack: Stack, obstacles: tuple[Obstacle, ...], margin: float, phi: float | None = None
) -> Any:
    """The :class:`ObstacleRows` of the obstacles that have rows and that a leg can reach,
    or None when none has: an obstacle beyond :func:`stackik.clearance.body_reach` (plus
    the leg radius and the margin) from the base origin costs nothing."""
    from stackik.clearance import body_reach

    gap = max(g.leg_radius for g in stack) + margin
    reach = body_reach(stack)
    with_rows = tuple(
        o
        for o in obstacles
        if isinstance(o, (Sphere, Capsule, HalfSpace)) and not _out_of_reach(o, reach, gap)
    )
    return ObstacleRows(stack, with_rows, margin, phi) if with_rows else None
