"""The leg-force limit family: ``|f| <= force_max`` as smooth inequality rows of the IK
problem, with the forces eliminated (``f = -G(q)^-1 w(q)``, DESIGN section 10).

For every platform i whose ``force_max`` is finite, 12 rows (platform-major, legs in order)

    1 - f_ik / force_max_i >= 0   (k = 0..5: compression within the limit)
    1 + f_ik / force_max_i >= 0   (k = 0..5: tension within the limit)

with ``f`` the leg forces of :func:`stackik.leg_forces` (compression positive) under the
request's :class:`~stackik.Load` (``None``: the stack's own weight, earth gravity). The rows
are dimensionless; platforms without a limit have none, so a stack without finite
``force_max`` has no rows at all and every solve is unchanged.

Values and the Jacobian with respect to the pose ``q`` (closed form) come from the compiled
kernel :mod:`stackik._compiled.force_rows`, the family's one definition for every engine
(both compiled interior points carry the same rows as dense rows);
``tests/test_forces_family.py`` holds its forces equal to the independent statics of
:func:`stackik.leg_forces` (the check's) and its Jacobian to central differences of them.
Second derivatives are not formed: engines that need a Hessian of the Lagrangian take a
quasi-Newton one when these rows are present (the interior points take an SR1 estimate of the
rows' part, :func:`stackik._compiled.dense_rows.force_sr1`).

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
from stackik.loads import _MM_PER_M, Load, _load, characteristic_length, lumped_masses

__all__ = [
    "ForceLimits",
    "ForceResiduals",
    "force_kernel_args",
    "force_limited",
    "force_scales",
    "no_force_rows",
]

FloatArray = NDArray[np.float64]


def force_limited(stack: Stack) -> bool:
    """Whether some platform of ``stack`` has a finite leg force limit."""
    return bool(np.isfinite(stack.force_max).any())


def force_kernel_args(stack: Stack, load: Load | None) -> tuple[Any, ...]:
    """The statics of ``stack`` under ``load`` as
    :func:`stackik._compiled.force_rows.leg_force_jacobian` takes them after the pose and
    the nodes: ``(L, m, c, g, F_ext, M_ext, ee_frame)`` with ``L`` (n,) [mm] the
    characteristic lengths, ``m`` (n,) [kg] and ``c`` (n, 3) [kg mm] the masses lumped on
    each top plate and their first moments (:func:`stackik.loads.lumped_masses`), ``g``
    (3,) [m/s^2], the external force [N] and moment [N mm] and whether they are given in
    the end effector's frame."""
    ld = _load(load)
    m, c = lumped_masses(stack, ld)
    L = np.asarray(characteristic_length(stack), dtype=float)
    F = np.asarray(ld.force, dtype=float)
    arrays = [L, m, c, ld.g, F, np.asarray(ld.moment, dtype=float) * _MM_PER_M]
    out = []
    for a in arrays:
        a = np.ascontiguousarray(a, dtype=float).copy()
        a.setflags(write=False)
        out.append(a)
    return (*out, ld.frame == "end_effector")


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
        self.platforms = np.flatnonzero(np.isfinite(fmax)).astype(np.int64)
        self.platforms.setflags(write=False)
        self.size = 12 * self.platforms.size
        inv = 1.0 / fmax[self.platforms]  # (p,) [1/N]
        inv.setflags(write=False)
        self._statics = force_kernel_args(stack, self.load)
        self._args = (stack.top_nodes, stack.base_nodes, *self._statics, self.platforms, inv)

    @property
    def kernel_args(self) -> tuple[Any, ...]:
        """The row kernel's arguments after the pose
        (:func:`stackik._compiled.force_rows.force_rows`: the top and base nodes, the
        statics of :func:`force_kernel_args`, the limited platforms and their
        ``1 / force_max``), as the compiled interior points carry them
        (``SpatialData.forces``, ``PlanarData.forces``)."""
        return self._args

    def _pose(self, q: FloatArray) -> FloatArray:
        return np.ascontiguousarray(np.asarray(q, dtype=float).reshape(self.stack.n, self.k))

    def force_jacobian(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Leg forces (n, 6) [N] at the pose ``q`` (n, k) and their Jacobian (6 n, n k)
        (unscaled q: mm and rad); NaN where a platform is singular."""
        from stackik._compiled.force_rows import leg_force_jacobian

        st = self.stack
        f, J, _ = leg_force_jacobian(  # type: ignore[call-arg]
            self._pose(q), st.top_nodes, st.base_nodes, *self._statics, self.phi is not None,
            0.0 if self.phi is None else float(self.phi),
        )  # fmt: skip
        return f, J

    def forces(self, q: FloatArray) -> FloatArray:
        """Leg forces (n, 6) [N] at the pose ``q`` (n, k), compression positive; NaN where
        a platform is singular."""
        return self.force_jacobian(q)[0]

    def values(self, q: FloatArray) -> FloatArray:
        """Row values (size,) at a pose (n, k); non-finite where a platform is singular."""
        return self(q)[0]

    def __call__(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Row values (size,) and their Jacobian (size, n k) with respect to ``q`` (unscaled:
        mm and rad); NaN where a platform is singular."""
        from stackik._compiled.force_rows import force_rows

        return force_rows(  # type: ignore[no-any-return, call-arg]
            self._pose(q), *self._args, self.phi is not None,
            0.0 if self.phi is None else float(self.phi),
        )  # fmt: skip


def no_force_rows(stack: Stack) -> tuple[Any, ...]:
    """:attr:`ForceLimits.kernel_args` of a problem without force rows (no limited
    platform; cached per stack), of the same types as with them (one compiled
    specialisation of the interior point)."""
    return stack.derived(  # type: ignore[no-any-return]
        ("no_force_rows",),
        lambda st: (
            st.top_nodes,
            st.base_nodes,
            *force_kernel_args(st, None),
            _readonly(np.zeros(0, dtype=np.int64)),
            _readonly(np.zeros(0)),
        ),
    )


def _readonly(a: NDArray[Any]) -> NDArray[Any]:
    a.setflags(write=False)
    return a


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
        f, J = self.force_jacobian(q)
        s = np.repeat(self._scale, 6)
        return (f * self._scale[:, None]).reshape(-1), J * s[:, None]
