"""Obstacle rows of a problem, spatial or planar: every leg kept clear of every sphere, capsule,
box and half-space, and every plate but the base clear of every half-space and sphere
(docs/clearance.md), the one definition the solvers' problems use.

Leg k of platform i (0-based) is the segment from its base joint ``B = O_i + A_i b_k`` to
its top joint ``T = O_{i+1} + A_{i+1} t_k`` (base frame [mm], :class:`SpatialChain`'s
plate frames), a capsule of radius ``r_i = leg_radius_i``. With the clearance margin ``m``:

* sphere (centre ``c``, radius ``R``) and capsule (axis ``[a, b]``, radius ``R``): per leg
  ``(d^2 - (R + r_i + m)^2) / L^2 >= 0``, ``d`` the distance of the leg's axis from the
  obstacle's (a sphere's axis is its centre), ``L = max leg_max``; the first derivatives by
  the envelope rule at the closest points, as the self-leg rows (the kernel:
  :mod:`stackik._compiled.obstacle_rows`);
* box (centre ``c``, half extents ``h``, rotation ``R_b``): per leg
  ``(sd - r_i - m) / L >= 0``, ``sd`` the exact signed distance of the leg's axis from the
  box (its distance when clear; when the axis meets the box, minus the depth of its deepest
  point, ``min_t max_faces``: the same values as :func:`stackik.distance.segment_box`),
  computed in the box frame as the least of a convex piecewise quadratic in the axis
  parameter ``t`` (its pieces change where the axis crosses a face's plane; every piece's
  stationary point and every breakpoint evaluated) or, inside, of a 1D linear program over
  its vertices. First derivatives by the envelope rule at that point, ``w . dX(t) / L``
  with ``w`` the unit direction from the box's nearest point (continuous while the leg is
  clear: the feasible side of a row with ``r_i + m > 0`` lies wholly outside the box), and
  inside the deepest face's outward normal (at a crossing of two faces, the combination
  that is the value's exact derivative), which pushes the leg out. Like the capsule rows,
  smooth where the closest point is unique; no second derivatives;
* half-space (point ``p``, unit normal ``u``): per leg, both joints:
  ``(u . (X - p) - rho_X - m) / L >= 0``, ``rho_X`` the larger of ``r_i`` and the reach
  of the plate the joint is a node of (:func:`joint_radii`: ``plate_thickness / 2`` plus
  the node's height off its plate's plane, 0 for the paper's nodes; the base plate is not
  a body against obstacles). A capsule is on the free side exactly when both its end balls
  are, and a plate (the rounded slab of a convex polygon, docs/clearance.md) exactly when
  its vertices' balls are, and every vertex is a joint: the rows are exact, and smooth,
  for legs and plates, at no extra row.

* sphere against plates: after its leg rows, per plate ``p = 1..n`` (the base excepted)
  ``(d^2 - (R + tau_p + m)^2) / L^2 >= 0``, ``d`` the distance of the centre from the
  plate's polygon (:func:`plate_polygons`: the check's polygon; its projection when inside,
  else the nearest edge point), ``tau_p`` half the plate's thickness (plus its nodes'
  height off its plane, 0 for the paper's nodes): the check's rounded-slab distance,
  exact; first derivatives by the envelope rule at the polygon's nearest point (fixed on
  the plate), continuous where that point is unique.

The plates have no rows against capsules and boxes: the solvers do not steer them around
those, the check (:mod:`stackik.clearance`) refuses a pose where one meets them.
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
from stackik.obstacles import Box, Capsule, HalfSpace, Obstacle, Sphere

__all__ = ["ObstacleRows", "joint_radii", "no_obstacle_rows", "obstacle_rows"]

FloatArray = NDArray[np.float64]


class ObstacleRows:
    """The obstacle rows of one request, spatial or planar (module doc).

    Parameters
    ----------
    stack : Stack
    obstacles : sequence of Obstacle
        Those with rows (spheres, capsules, boxes, half-spaces).
    margin : float
        Clearance margin [mm].
    phi : float or None
        Plane angle [rad] of a planar request (poses (n, 3): ``rho, z, theta``, every
        rotation about ``s(phi)``); None for spatial (n, 6).

    Attributes
    ----------
    size : int
        Number of rows: ``6 n`` per capsule or box, ``7 n`` per sphere (legs, then plates),
        ``12 n`` per half-space.
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
        boxes: list[Any] = []
        kinds: list[int] = []
        specs: list[Any] = []
        for ob in obstacles:
            if isinstance(ob, HalfSpace):
                u = np.asarray(ob.normal, float) / np.linalg.norm(ob.normal)
                halfs.append([*ob.point, *u])
                kinds.append(1)
                specs.append(("half", tuple(map(float, ob.point)), tuple(map(float, u))))
            elif isinstance(ob, Box):
                Rb = ob.rotation if ob.rotation is not None else np.eye(3)
                boxes.append([*ob.center, *ob.half_extents, *np.ravel(Rb)])
                kinds.append(2)
                specs.append(("box", tuple(map(float, ob.center)),
                              tuple(map(float, ob.half_extents)),
                              tuple(map(float, np.ravel(Rb)))))  # fmt: skip
            else:
                assert isinstance(ob, (Sphere, Capsule))
                a, b = (ob.center, ob.center) if isinstance(ob, Sphere) else (ob.a, ob.b)
                segs.append([*a, *b, ob.radius])
                kinds.append(3 if isinstance(ob, Sphere) else 0)
                name = "sphere" if isinstance(ob, Sphere) else "seg"
                specs.append((name, tuple(map(float, a)), tuple(map(float, b)), float(ob.radius)))
        #: the rows as plain data, in their order: ``(margin, (("seg", a, b, R) | ("half",
        #: point, unit normal) | ("box", centre, half extents, rotation row-major), ...))``
        #: (IPOPT's symbolic rows and solver cache key)
        self.specs = (self.margin, tuple(specs))
        self._args = (
            readonly(stack.base_nodes),
            readonly(stack.top_nodes),
            readonly([g.leg_radius for g in stack]),
            readonly(np.reshape(segs, (-1, 7))),
            readonly(np.reshape(halfs, (-1, 6))),
            readonly(np.reshape(boxes, (-1, 15))),
            readonly(joint_radii(stack)),
            *plate_polygons(stack),
            _readonly_int(kinds),
        )
        self.size = sum(_rows_of(o, self.n) for o in obstacles)

    @property
    def kernel_args(self) -> tuple[Any, ...]:
        """The kernel's array arguments after the pose (``base, top, radius, segs, halfs,
        boxes, jrad, hulls, hthick, kinds``, read-only), as the compiled interior point carries them
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


def joint_radii(stack: Stack) -> FloatArray:
    """The radius [mm] a half-space's rows keep from each joint (2, n): row 0 the base
    joints of each platform's legs, row 1 the top joints. A joint is a leg's end ball
    (``leg_radius``) and a node of a plate (the base plate excepted), whose rounded slab
    lies within ``plate_thickness / 2 + |z|`` of the node (``z`` the node's height in its
    plate's frame; the plate's polygon is the nodes projected onto ``z = 0``, a shared
    plate takes the larger thickness of its two platforms): the larger of the two, so
    the half-space rows hold every plate but the base on the free side too (exact for a
    convex plate with its nodes in its plane, :mod:`stackik.formulation.obstacle_rows`)."""
    n = stack.n
    thick = [max(stack[i].plate_thickness for i in (j - 1, j) if 0 <= i < n) for j in range(n + 1)]
    out = np.empty((2, n))
    for i in range(n):
        r = stack[i].leg_radius
        zb = float(np.max(np.abs(stack.base_nodes[i][:, 2])))
        zt = float(np.max(np.abs(stack.top_nodes[i][:, 2])))
        out[0, i] = r if i == 0 else max(r, thick[i] / 2 + zb)
        out[1, i] = max(r, thick[i + 1] / 2 + zt)
    return out


def _rows_of(ob: Obstacle, n: int) -> int:
    """Rows of one obstacle: 6 n (legs), 12 n for a half-space (both joints), 7 n for a
    sphere (legs, then plates 1..n)."""
    return 12 * n if isinstance(ob, HalfSpace) else (7 * n if isinstance(ob, Sphere) else 6 * n)


def plate_polygons(stack: Stack) -> tuple[FloatArray, FloatArray]:
    """Plates 1..n (the base excepted) as the sphere rows see them (cached per stack):
    their convex polygons (n, 12, 2) in their frames' ``z = 0`` (counter-clockwise,
    padded by repeating a vertex: :func:`stackik.distance.convex_hull_2d` of the nodes'
    ``x, y``, as the check's) and their half thicknesses (n,) [mm], the larger of the two
    platforms' ``plate_thickness`` for a shared plate, plus the nodes' largest height off
    the plate's plane (0 for the paper's nodes: the rows are then the check's distance)."""

    def build(st: Stack) -> tuple[FloatArray, FloatArray]:
        from stackik.distance import convex_hull_2d

        n = st.n
        hulls = np.empty((n, 12, 2))
        half = np.empty(n)
        for p in range(1, n + 1):
            pts = [st.top_nodes[p - 1]] + ([st.base_nodes[p]] if p < n else [])
            nodes = np.concatenate(pts)
            hulls[p - 1] = convex_hull_2d(nodes[:, :2], size=12)
            thick = max(st[i].plate_thickness for i in (p - 1, p) if i < n)
            half[p - 1] = thick / 2 + float(np.abs(nodes[:, 2]).max())
        return readonly(hulls), readonly(half)

    return stack.derived(("plate_polygons",), build)  # type: ignore[no-any-return]


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
    """The :class:`ObstacleRows` of the obstacles that a leg or a plate can reach (every
    kind has rows), or None when none can: an obstacle beyond
    :func:`stackik.clearance.body_reach` (plus the largest leg radius or half plate
    thickness, and the margin) from the base origin costs nothing."""
    from stackik.clearance import body_reach

    gap = max(max(g.leg_radius, g.plate_thickness / 2) for g in stack) + margin
    reach = body_reach(stack)
    with_rows = tuple(o for o in obstacles if not _out_of_reach(o, reach, gap))
    return ObstacleRows(stack, with_rows, margin, phi) if with_rows else None
