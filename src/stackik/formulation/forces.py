"""The leg-force limit family: ``|f| <= force_max`` as smooth inequality rows of the IK
problem, with the forces eliminated (``f = -G(q)^-1 w(q)``, DESIGN section 10).

For every platform i whose ``force_max`` is finite, 12 rows (platform-major, legs in order)

    1 - f_ik / force_max_i >= 0   (k = 0..5: compression within the limit)
    1 + f_ik / force_max_i >= 0   (k = 0..5: tension within the limit)

with ``f`` the leg forces of :func:`stackik.leg_forces` (compression positive) under the
request's :class:`~stackik.Load` (``None``: the stack's own weight, earth gravity). The rows
are dimensionless; platforms without a limit have none, so a stack without finite
``force_max`` has no rows at all and every solve is unchanged.

Values come from :mod:`stackik.loads` (the statics model the check uses); the Jacobian with
respect to the pose ``q`` by the **complex step**: ``df/dq_a = Im f(q + i h e_a) / h`` with
``h = 1e-30``, exact to rounding (no subtraction), all ``k n`` directions in one batched
evaluation of the statics (``tests/test_forces_family.py`` checks it against central
differences of :func:`stackik.leg_forces`). Second derivatives are not formed: engines that
need a Hessian of the Lagrangian take a quasi-Newton one when these rows are present.

The forces are eliminated rather than lifted as variables: the rows then live in the pose's
variables only, and every engine that takes inequality rows and their Jacobian (SLSQP,
trust-constr, the SQP engine's dense formulation) sees them unchanged. IPOPT, written apart
(:mod:`stackik.methods.ipopt`), lifts the forces as variables with the equilibrium
equalities instead: the two formulations check each other.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik.geometry import Stack
from stackik.loads import Load, _load, _system
from stackik.rotations import plane_axis

__all__ = ["ForceLimits", "ForceResiduals", "force_limited", "force_scales"]

FloatArray = NDArray[np.float64]
#: real or complex (the complex step passes through the same code)
Array = NDArray[Any]

#: Complex-step size: the imaginary part carries the derivative; any tiny value is exact.
STEP = 1e-30


def force_limited(stack: Stack) -> bool:
    """Whether some platform of ``stack`` has a finite leg force limit."""
    return bool(np.isfinite(stack.force_max).any())


def _rot_zyx(a: Array) -> Array:
    """``Rz(a0) Ry(a1) Rx(a2)`` for (..., 3) angles, real or complex, shape (..., 3, 3)."""
    c, s = np.cos(a), np.sin(a)
    cz, cy, cx = c[..., 0], c[..., 1], c[..., 2]
    sz, sy, sx = s[..., 0], s[..., 1], s[..., 2]
    rows = [
        [cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx],
        [sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx],
        [-sy, cy * sx, cy * cx],
    ]
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


class ForceLimits:
    """The force-limit rows of one request (module doc).

    Parameters
    ----------
    stack : Stack
        Its ``force_max`` [N] says which platforms have rows.
    load : Load or None
        Payload, external wrench and gravity; None = the stack's own weight, earth gravity.
    phi : float or None
        Plane angle [rad] of a planar request (poses (n, 3)); None for spatial (n, 6).

    Attributes
    ----------
    platforms : ndarray of int
        Indices (0 = bottom) of the platforms with a finite ``force_max``.
    size : int
        Number of rows, ``12 * len(platforms)``.
    """

    def __init__(self, stack: Stack, load: Load | None, phi: float | None) -> None:
        self.stack = stack
        self.load = _load(load)
        self.phi = phi
        self.k = 6 if phi is None else 3
        fmax = np.asarray(stack.force_max, dtype=float)
        self.platforms = np.flatnonzero(np.isfinite(fmax))
        self.size = 12 * self.platforms.size
        self._inv = 1.0 / fmax[self.platforms]  # (p,) [1/N]
        #: the last complex-step batch of forces: (pose bytes, forces or None if singular)
        self._batch: tuple[bytes, Array | None] = (b"", None)
        if phi is not None:
            s = plane_axis(phi)
            K = np.array([[0.0, -s[2], s[1]], [s[2], 0.0, -s[0]], [-s[1], s[0], 0.0]])
            self._plane = (np.array([np.cos(phi), np.sin(phi)]), np.eye(3), K, np.outer(s, s))

    def _parts(self, q: Array) -> tuple[Array, ...]:
        """Per-platform translations (..., n, 3) and rotations (..., n, 3, 3) of poses
        (..., n, k), real or complex (the arithmetic of :func:`stackik.loads.leg_forces`'s
        pose parts, written without ``dtype=float`` so that the complex step passes)."""
        if self.phi is None:
            return q[..., :3], _rot_zyx(q[..., 3:])
        e, eye, K, ss = self._plane
        rho, z, th = q[..., 0], q[..., 1], q[..., 2]
        P = np.stack([rho * e[0], rho * e[1], z], axis=-1)
        c, s = np.cos(th)[..., None, None], np.sin(th)[..., None, None]
        return P, c * eye + s * K + (1.0 - c) * ss

    def forces(self, q: Array) -> Array:
        """Leg forces (..., n, 6) [N] of poses (..., n, k), compression positive (the
        limited platforms' only matter); complex in, complex out."""
        P, R = self._parts(q)
        G, w = _system(self.stack, P, R, self.load)
        return -np.linalg.solve(G, w[..., None])[..., 0]

    def _rows(self, f: Array) -> Array:
        r = f[..., self.platforms, :] * self._inv[:, None]  # (..., p, 6)
        return np.concatenate([1.0 - r, 1.0 + r], axis=-1).reshape(f.shape[:-2] + (-1,))

    def values(self, q: FloatArray) -> FloatArray:
        """Row values (size,) at a pose (n, k); non-finite where a platform is singular."""
        q = np.asarray(q, dtype=float).reshape(self.stack.n, self.k)
        try:
            return np.asarray(self._rows(self.forces(q)).real, dtype=float)
        except np.linalg.LinAlgError:
            return np.full(self.size, np.nan)

    def __call__(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Row values (size,) and their Jacobian (size, n k) with respect to ``q`` (unscaled:
        mm and rad); NaN where a platform is singular."""
        return self._complex_step(q, self._rows, self.size)

    def _complex_step(
        self, q: FloatArray, of_forces: Any, size: int
    ) -> tuple[FloatArray, FloatArray]:
        """``of_forces(f)`` (size,) and its Jacobian (size, n k) at pose ``q``, by the complex
        step: every direction in one batch of poses ``q + i h e_a``; NaN if singular."""
        n, k = self.stack.n, self.k
        q = np.asarray(q, dtype=float).reshape(n, k)
        N = n * k
        key = q.tobytes()
        if self._batch[0] != key:  # the rows and the force objective share one batch
            Q = np.empty((N + 1, n, k), dtype=complex)
            Q[:] = q
            Q[1:].reshape(N, N)[np.arange(N), np.arange(N)] += 1j * STEP
            try:
                self._batch = (key, self.forces(Q))
            except np.linalg.LinAlgError:
                self._batch = (key, None)
        F = self._batch[1]
        if F is None:  # a singular platform
            return np.full(size, np.nan), np.full((size, N), np.nan)
        out = of_forces(F).reshape(N + 1, size)
        return out[0].real.copy(), (out[1:].imag / STEP).T


def force_scales(stack: Stack) -> FloatArray:
    """Per platform, the force [N] that the ``"force"`` objective divides its legs' forces
    by: ``force_max`` where finite, else 1 N (unscaled). Shape (n,)."""
    fmax = np.asarray(stack.force_max, dtype=float)
    return np.where(np.isfinite(fmax), fmax, 1.0)


class ForceResiduals(ForceLimits):
    """The residuals of ``objective="force"``: ``r = f_ik / s_i`` for every leg of every
    platform (``s = force_scales(stack)``), so that the objective ``|r|^2`` is the sum of
    squared leg forces scaled by the force limits where they are finite (the load-balancing
    pose); :meth:`residuals` gives ``r`` (6 n,) and its Jacobian (6 n, k n) by the complex
    step, as the rows of :class:`ForceLimits`.

    ``weight`` is ``solve_ik``'s ``force_weight`` ``w`` [mm^2] when these residuals are
    added to another objective (``FN^2 + w |r|^2``, :class:`~stackik.formulation.Problem`);
    it does not change ``r``. ``objective="force"`` keeps the default 1.
    """

    def __init__(
        self, stack: Stack, load: Load | None, phi: float | None, weight: float = 1.0
    ) -> None:
        super().__init__(stack, load, phi)
        self._scale = 1.0 / force_scales(stack)
        #: the weight of ``|r|^2`` in the objective it is added to [mm^2]
        self.weight = float(weight)

    def residuals(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``r`` (6 n,) and ``dr/dq`` (6 n, k n) [unscaled q: mm, rad]; NaN if singular."""
        return self._complex_step(q, lambda f: f * self._scale[:, None], 6 * self.stack.n)
