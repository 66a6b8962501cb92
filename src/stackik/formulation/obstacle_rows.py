"""Obstacle rows of a problem, spatial or planar: every leg kept clear of every sphere, capsule and
half-space (docs/clearance.md), the one definition the solvers' problems use.

Leg k of platform i (0-based) is the segment from its base joint ``B = O_i + A_i b_k`` to
its top joint ``T = O_{i+1} + A_{i+1} t_k`` (base frame [mm], :class:`SpatialChain`'s
plate frames), a capsule of radius ``r_i = leg_radius_i``. With the clearance margin ``m``:

* sphere (centre ``c``, radius ``R``) and capsule (axis ``[a, b]``, radius ``R``): per leg
  ``(d^2 - (R + r_i + m)^2) / L^2 >= 0``, ``d`` the distance of the leg's axis from the
  obstacle's (a sphere's axis is its centre), ``L = max leg_max``; the first derivatives by
  the envelope rule at the closest points, as the self-leg rows (the kernel:
  :mod:`stackik._compiled.obstacle_rows`);
* half-space (point ``p``, unit normal ``u``): per leg, both joints:
  ``(u . (X - p) - r_i - m) / L >= 0`` (a capsule is on the free side exactly when both
  its end balls are: the rows are exact, and smooth).

Boxes, and the plates against any obstacle, have no rows: the solvers do not steer
around them, the check (:mod:`stackik.clearance`) refuses a pose that meets them.
The rows are dense (a leg moves with every platform below it): both compiled interior
points, spatial and planar, carry them after their per-platform blocks
(:mod:`stackik._compiled.dense_rows`), so no pose is handed over for them alone
(:attr:`stackik.formulation.Problem.rows_outside_ip`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik._arrays import readonly
from stackik.geometry import Stack
from stackik.obstacles import Capsule, HalfSpace, Obstacle, Sphere

__all__ = ["ObstacleRows", "no_obstacle_rows", "obstacle_rows"]

FloatArray = NDArray[np.float64]


class ObstacleRows:
    """The obstacle rows of one request, spatial or planar (module doc).

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
        self.margin = float(margin)
        self.L = float(np.max(stack.leg_max))
        self.obstacles = obstacles
        segs: list[Any] = []
        halfs: list[Any] = []
        kinds: list[int] = []
        specs: list[Any] = []
        for ob in obstacles:
            if isinstance(ob, HalfSpace):
                u = np.asarray(ob.normal, float) / np.linalg.norm(ob.normal)
                halfs.append([*ob.point, *u])
                kinds.append(1)
                specs.append(("half", tuple(map(float, ob.point)), tuple(map(float, u))))
            else:
                assert isinstance(ob, (Sphere, Capsule))
                a, b = (ob.center, ob.center) if isinstance(ob, Sphere) else (ob.a, ob.b)
                segs.append([*a, *b, ob.radius])
                kinds.append(0)
                specs.append(("seg", tuple(map(float, a)), tuple(map(float, b)), float(ob.radius)))
        #: the rows as plain data, in their order: ``(margin, (("seg", a, b, R) | ("half",
        #: point, unit normal), ...))`` (IPOPT's symbolic rows and solver cache key)
        self.specs = (self.margin, tuple(specs))
        self._args = (
            readonly(stack.base_nodes),
            readonly(stack.top_nodes),
            readonly([g.leg_radius for g in stack]),
            readonly(np.reshape(segs, (-1, 7))),
            readonly(np.reshape(halfs, (-1, 6))),
            _readonly_int(kinds),
        )
        self.size = sum(12 * self.n if isinstance(o, HalfSpace) else 6 * self.n for o in obstacles)

    @property
    def kernel_args(self) -> tuple[Any, ...]:
        """The kernel's array arguments after the pose (``base, top, radius, segs, halfs,
        kinds``, read-only), as the compiled interior point carries them
        (:attr:`stackik._compiled.spatial.SpatialData.obstacles`,
        :attr:`stackik._compiled.planar.PlanarData.obstacles`)."""
        return self._args

    def __call__(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Rows ``c`` (size,) and Jacobian (size, nk) against the raw pose ``q`` (n, k)."""
        from stackik._compiled.obstacle_rows import obstacle_rows as rows

        planar = self.phi is not None
        c, J = rows(
            np.ascontiguousarray(q, dtype=float), *self._args, self.margin, self.L, planar,
            0.0 if self.phi is None else float(self.phi),
        )  # fmt: skip
        return c, J


def _readonly_int(values: Any) -> Any:
    v = np.ascontiguousarray(values, dtype=np.int64).reshape(-1)
    v.setflags(write=False)
    return v


def _out_of_reach(ob: Obstacle, reach: float, gap: float) -> bool:
    """Whether ``ob`` is farther than ``gap`` [mm] from the ball of radius ``reach`` about
    the base origin, which holds every leg of every pose within the leg limits."""
    origin = np.zeros(3)
    return bool(ob.point_distance(origin) > reach + gap)


def no_obstacle_rows(stack: Stack) -> tuple[Any, ...]:
    """:attr:`ObstacleRows.kernel_args` of no obstacle on ``stack`` (cached per stack): the
    compiled interior point's arrays when a problem has no obstacle rows, of the same
    types as with them (one compiled specialisation)."""
    return stack.derived(("no_obstacle_rows",), lambda st: ObstacleRows(st, (), 0.0).kernel_args)  # type: ignore[no-any-return]


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
