"""Which clearance rows a spatial problem carries: the one place that decides it.

Self-leg rows (:mod:`stackik._compiled.self_legs`, the family's one definition): for each
platform i and each of the 15 pairs (k, l) of its legs,

    c = (d_kl^2 - rho_i^2) / scale_i >= 0,   rho_i = 2 leg_radius_i + clearance [mm],
    scale_i = leg_max_i^2 [mm^2] (as the leg-length rows),

``d_kl`` the distance of the two leg axes. They are present when the target is spatial and a
leg radius or the clearance margin is positive: with zero radii and margin 0 two axes may
touch (the check then has nothing to enforce either), so the problem is the paper's,
unchanged.

Not constrained by these rows (the check enforces them, so a colliding pose is never a
success): legs of adjacent platforms (kept >= 26.6 mm apart on the reference geometry by the
joint-angle limits, ``docs/clearance.md``) and two plates of platforms two or more apart.
Obstacles have their rows (:mod:`stackik.formulation.obstacle_rows`); legs against legs and
plates of platforms two or more apart have rows a solve adds when a pose folds into itself
(:mod:`stackik.formulation.leg_pairs`, :attr:`Clearance.leg_pairs`).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np

from stackik._arrays import readonly
from stackik.geometry import Stack
from stackik.obstacles import Obstacle, as_obstacles

__all__ = ["NO_PAIRS", "SELF_LEG_PAIRS", "Clearance", "SelfLegs", "clearance_of", "self_legs_of"]


def _readonly_int(a: Any) -> Any:
    v = np.ascontiguousarray(a, dtype=np.int64).reshape(-1, 2)
    v.setflags(write=False)
    return v


#: The 15 leg pairs (k, l), k < l, of one platform (no two legs of a platform share a joint).
SELF_LEG_PAIRS = _readonly_int(list(itertools.combinations(range(6), 2)))
#: No pairs: the kernels' data when a problem has no self-leg rows.
NO_PAIRS = _readonly_int(np.zeros((0, 2)))


@dataclass(frozen=True)
class SelfLegs:
    """The self-leg rows of one problem (every array read-only).

    Attributes
    ----------
    pairs : ndarray, shape (m, 2), int64
        Leg pairs of one platform.
    rho : ndarray, shape (n,)
        Least axis distance per platform [mm].
    scale : ndarray, shape (n,)
        Row scale per platform [mm^2].
    """

    pairs: Any
    rho: Any
    scale: Any

    @property
    def m(self) -> int:
        """Rows per platform."""
        return int(self.pairs.shape[0])


def self_legs_of(stack: Stack, clearance: float) -> SelfLegs | None:
    """The self-leg rows of a problem on ``stack``, or None when it has none (zero leg radii
    with ``clearance`` 0 [mm]). Planar problems have them too (as rows outside the planar
    kernels: :class:`stackik.formulation.Problem` appends them, the interior point hands a
    pose that fails only on them over, as for the obstacle rows)."""
    radius = np.array([g.leg_radius for g in stack], dtype=float)
    if not (radius.max() > 0.0 or clearance > 0.0):
        return None
    return SelfLegs(
        pairs=SELF_LEG_PAIRS,
        rho=readonly(2.0 * radius + float(clearance)),
        scale=readonly(np.asarray(stack.leg_max, dtype=float) ** 2),
    )


@dataclass(frozen=True)
class Clearance:
    """What a problem keeps clear: the margin, the obstacles and its self-leg rows.

    Attributes
    ----------
    margin : float
        Least clearance [mm] every checked pair keeps (``check_pose(..., clearance=)``).
    obstacles : tuple of Obstacle
        Keep-out bodies in the base frame, enforced by the check.
    self_legs : SelfLegs or None
        The self-leg rows, or None.
    obstacle_rows : ObstacleRows or None
        The rows that keep the legs clear of the spheres, capsules and half-spaces
        (:mod:`stackik.formulation.obstacle_rows`; planar ones in the target's plane), or
        None.
    leg_pairs : LegPairRows or None
        Rows for some pairs of legs of non-adjacent platforms
        (:mod:`stackik.formulation.leg_pairs`), or None: a problem has none until a solve
        finds such a pair close (:meth:`stackik.formulation.Problem.with_leg_pairs`).
    """

    margin: float = 0.0
    obstacles: tuple[Obstacle, ...] = ()
    self_legs: SelfLegs | None = None
    obstacle_rows: Any = None
    leg_pairs: Any = None


def clearance_of(
    stack: Stack, planar: bool, margin: Any = 0.0, obstacles: Any = (), phi: float | None = None
) -> Clearance:
    """Validate ``margin`` [mm] and ``obstacles`` and decide the rows (a ValueError names a
    bad argument); ``phi`` [rad]: a planar request's plane (its obstacle rows need it)."""
    from stackik.geometry import finite_number

    m = finite_number(margin, "clearance")
    if m < 0.0:
        raise ValueError(f"clearance: must be >= 0 mm, got {m}")
    from stackik.formulation.obstacle_rows import obstacle_rows

    obs = tuple(as_obstacles(obstacles))
    rows = None
    if obs and not (planar and phi is None):
        rows = obstacle_rows(stack, obs, m, phi if planar else None)
    return Clearance(margin=m, obstacles=obs, self_legs=self_legs_of(stack, m), obstacle_rows=rows)
