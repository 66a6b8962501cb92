"""Clearances of a pose: signed distances between the stack's bodies and obstacles
(docs/clearance.md).

Bodies (all in the base frame, from the pose's plate frames):

- leg k of platform i (1..n): the capsule of radius ``leg_radius`` around the segment from
  its base joint to its top joint;
- plate j (0 = the base .. n = the end effector): the set of points within
  ``plate_thickness / 2`` of the convex polygon of its nodes (the top nodes of platform j
  and the base nodes of platform j + 1, projected into the plate's plane ``z = 0``), the
  thickness being the larger of the platforms it joins.

Pairs (each kind's least signed distance and its closest pair are reported):

- ``self_legs``: two legs of one platform (its nodes are distinct, so no two legs share a
  joint: all 15 pairs);
- ``adjacent_legs``: a leg of platform i and a leg of platform i + 1 that share no joint.
  Their axes lie on opposite sides of the shared plate by the joint-angle limits and never
  cross, but with a radius the capsules can meet near the plate (docs/clearance.md gives
  the argument and the numbers), so they are checked;
- ``non_adjacent``: every other pair of bodies that are not joined: a leg and a plate it
  does not join, legs of platforms two or more apart, any two plates (a leg is joined to
  the two plates it connects, and touches them by design);
- ``obstacles``: every leg and every plate but the base against each obstacle.

This module shares no code with any solver; it is the check's geometry.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik import distance as dist
from stackik._compiled.body_distances import any_crossing, body_clearances
from stackik.geometry import Stack
from stackik.obstacles import Obstacle, as_obstacles
from stackik.platform import validate_pose_array as _check_q
from stackik.rotations import euler_zyx, plane_axis, rodrigues

__all__ = [
    "Body",
    "Clearances",
    "Contact",
    "ContactPoints",
    "clearances",
    "contact_points",
    "cores_cross",
    "needs_clearances",
    "plate_frames",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

#: Relative distance under which two nodes are one joint (legs sharing it are not paired).
_SHARED = 1e-9

#: Tolerance [mm] of the base test: an obstacle closer than ``leg_radius`` minus this to a
#: joint of the base collides with every pose.
BASE_TOL = 1e-9


@dataclass(frozen=True)
class Body:
    """A body of the stack.

    Attributes
    ----------
    kind : str
        ``"leg"`` or ``"plate"``.
    index : int
        Leg: its platform, 1..n (bottom first). Plate: its plate, 0 (base) .. n.
    leg : int or None
        Leg: its number k = 0..5 (leg k joins ``b_k`` to ``t_k``); None for a plate.
    """

    kind: str
    index: int
    leg: int | None = None

    def __str__(self) -> str:
        if self.kind == "leg":
            return f"platform {self.index} leg {self.leg}"
        return "base plate" if self.index == 0 else f"plate {self.index}"

    def to_dict(self) -> dict[str, Any]:
        """``{"kind", "index", "leg"}``."""
        return {"kind": self.kind, "index": self.index, "leg": self.leg}


@dataclass(frozen=True)
class Contact:
    """The closest pair of one pair kind.

    Attributes
    ----------
    distance : float
        Signed distance [mm] (negative = penetration, by the cores' depth plus both radii).
    a : Body
    b : Body or None
        The other body; None when ``obstacle`` is set.
    obstacle : int or None
        Index of the obstacle in the sequence given.
    """

    distance: float
    a: Body
    b: Body | None = None
    obstacle: int | None = None

    def __str__(self) -> str:
        other = f"obstacle {self.obstacle}" if self.b is None else str(self.b)
        return f"{self.a} - {other}: {self.distance:.6g} mm"

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form."""
        return {
            "distance": self.distance,
            "a": self.a.to_dict(),
            "b": None if self.b is None else self.b.to_dict(),
            "obstacle": self.obstacle,
        }


@dataclass(frozen=True)
class Clearances:
    """Signed minimum distances [mm] of a pose, per pair kind (see the module docstring).

    A kind with no pair (one platform has no adjacent legs and no non-adjacent bodies; no
    obstacles) has distance ``inf`` and no contact.

    Attributes
    ----------
    self_legs : float
        Least over the pairs of legs of one platform.
    self_legs_by_platform : ndarray, shape (n,)
        The same per platform (bottom first).
    adjacent_legs : float
        Least over the pairs of legs of adjacent platforms.
    non_adjacent : float
        Least over the pairs of non-adjacent bodies.
    obstacles : tuple of float
        Least over the bodies, one per obstacle.
    contacts : tuple of Contact
        The closest pair of each kind that has one: self legs, adjacent legs,
        non-adjacent, then each obstacle in order.
    """

    self_legs: float
    self_legs_by_platform: FloatArray
    adjacent_legs: float
    non_adjacent: float
    obstacles: tuple[float, ...]
    contacts: tuple[Contact, ...] = field(default=())

    @property
    def minimum(self) -> float:
        """Least signed distance over every pair [mm] (``inf`` if there is none)."""
        kinds = (self.self_legs, self.adjacent_legs, self.non_adjacent, *self.obstacles)
        return float(min(kinds))

    @property
    def closest(self) -> Contact | None:
        """The closest pair over every kind (None if there is none)."""
        return min(self.contacts, key=lambda c: c.distance, default=None)

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (``inf`` stays a float: JSON writers spell it ``Infinity``)."""
        closest = self.closest
        return {
            "minimum": self.minimum,
            "self_legs": self.self_legs,
            "self_legs_by_platform": self.self_legs_by_platform.tolist(),
            "adjacent_legs": self.adjacent_legs,
            "non_adjacent": self.non_adjacent,
            "obstacles": list(self.obstacles),
            "closest": None if closest is None else closest.to_dict(),
        }


# -----------------------------------------------------------------------------------------
# pose -> plate frames
# -----------------------------------------------------------------------------------------
def plate_frames(
    stack: Stack, q: ArrayLike, phi: float | None = None
) -> tuple[FloatArray, FloatArray]:
    """Rotations ``A_j`` and origins ``O_j`` of the plates j = 0..n in the base frame.

    Parameters
    ----------
    q : array_like, shape (n, 6) or (n, 3)
        A spatial pose, or a planar one with ``phi``.
    phi : float, optional
        Plane angle [rad] of a planar pose (required for shape (n, 3)).

    Returns
    -------
    A : ndarray, shape (n + 1, 3, 3)
    O : ndarray, shape (n + 1, 3) [mm]
    """
    n = stack.n
    try:
        qa = np.asarray(q, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"q: expected an array of numbers ({exc})") from None
    if qa.ndim == 2 and qa.shape == (n, 3):
        if phi is None:
            raise ValueError("phi: required for a planar pose of shape (n, 3)")
        try:
            phi_f = float(phi)
        except (TypeError, ValueError):
            raise ValueError(f"phi: expected a number, got {phi!r}") from None
        if not np.isfinite(phi_f):
            raise ValueError("phi: must be finite")
        qa = _check_q(qa, n, 3)
        R = rodrigues(plane_axis(phi_f), qa[:, 2])
        P = np.column_stack([qa[:, 0] * np.cos(phi_f), qa[:, 0] * np.sin(phi_f), qa[:, 1]])
    else:
        if phi is not None and qa.shape == (n, 6):
            raise ValueError("phi: only a planar pose (n, 3) takes phi")
        if qa.shape != (n, 6):
            raise ValueError(f"q: expected shape ({n}, 6) or ({n}, 3) with phi, got {qa.shape}")
        qa = _check_q(qa, n, 6)
        R = euler_zyx(qa[:, 3:])
        P = qa[:, :3]
    A = np.empty((n + 1, 3, 3))
    O = np.empty((n + 1, 3))
    A[0] = np.eye(3)
    O[0] = 0.0
    for i in range(n):
        O[i + 1] = O[i] + A[i] @ P[i]
        A[i + 1] = A[i] @ R[i]
    return A, O


# -----------------------------------------------------------------------------------------
# the stack's bodies and pairs (geometry only: cached per stack)
# -----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Layout:
    radius: FloatArray  # (n,) leg radius per platform [mm]
    half_t: FloatArray  # (n+1,) half plate thickness per plate [mm]
    uv: FloatArray  # (n+1, M, 2) plate polygons in their plate frames
    self_k: IntArray  # (15,) and self_m (15,): leg pairs of one platform
    self_m: IntArray
    ll: IntArray  # (L, 4): platform_a, leg_a, platform_b, leg_b (0-based platforms)
    adj: IntArray  # (36 (n - 1), 4): the same for legs of adjacent platforms
    lp: IntArray  # (K, 3): platform, leg, plate
    pp: IntArray  # (Q, 2): plate, plate
    centre: FloatArray  # (n+1, 2) centre of each plate polygon's vertices
    reach: FloatArray  # (n+1,) largest distance of a vertex from the centre [mm]


def _layout(stack: Stack) -> _Layout:
    n = stack.n
    radius = np.array([g.leg_radius for g in stack])
    thick = np.zeros(n + 1)
    for j in range(n + 1):
        joined = [stack[i].plate_thickness for i in (j - 1, j) if 0 <= i < n]
        thick[j] = max(joined)
    nodes = []
    for j in range(n + 1):
        pts = []
        if j >= 1:
            pts.append(stack.top_nodes[j - 1][:, :2])
        if j < n:
            pts.append(stack.base_nodes[j][:, :2])
        nodes.append(np.concatenate(pts))
    try:
        hulls = [dist.convex_hull_2d(p) for p in nodes]
    except ValueError:
        raise ValueError(
            "stack: a plate's nodes project onto a line in its plane (no plate polygon)"
        ) from None
    M = max(len(h) for h in hulls)
    uv = np.stack([dist.convex_hull_2d(p, size=M) for p in nodes])
    centre = np.stack([h.mean(axis=0) for h in hulls])
    km = np.array(list(itertools.combinations(range(6), 2)))
    ll = [
        (i, k, j, m) for i in range(n) for j in range(i + 2, n) for k in range(6) for m in range(6)
    ]
    # legs of adjacent platforms, but not two legs that share a joint (a top node of
    # platform i on a base node of platform i + 1: they touch by design)
    top, base = stack.top_nodes, stack.base_nodes
    adj = [
        (i, k, i + 1, m)
        for i in range(n - 1)
        for k in range(6)
        for m in range(6)
        if np.linalg.norm(top[i, k] - base[i + 1, m]) > _SHARED * (1.0 + np.abs(top[i]).max())
    ]
    # leg of platform i (0-based) joins plates i and i + 1
    lp = [
        (i, k, j) for i in range(n) for k in range(6) for j in range(n + 1) if j not in (i, i + 1)
    ]
    pp = [(j, jj) for j in range(n + 1) for jj in range(j + 1, n + 1)]
    out = _Layout(
        radius=radius,
        half_t=thick / 2.0,
        uv=uv,
        self_k=km[:, 0].copy(),
        self_m=km[:, 1].copy(),
        ll=np.array(ll, dtype=np.intp).reshape(-1, 4),
        adj=np.array(adj, dtype=np.intp).reshape(-1, 4),
        lp=np.array(lp, dtype=np.intp).reshape(-1, 3),
        pp=np.array(pp, dtype=np.intp).reshape(-1, 2),
        centre=centre,
        reach=np.linalg.norm(uv - centre[:, None, :], axis=-1).max(axis=1),
    )
    for a in (
        out.radius,
        out.half_t,
        out.uv,
        out.self_k,
        out.self_m,
        out.ll,
        out.adj,
        out.lp,
        out.pp,
    ):
        a.setflags(write=False)
    return out


#: Pairs of least lower bound evaluated first by :meth:`_Best.screen`, to get a bound.
_HEAD = 8
#: Up to this many candidate pairs are evaluated in one call (no head first).
_ALL = 256


class _Best:
    """The least exact distance of a pair kind so far (screening by lower bounds)."""

    def __init__(self) -> None:
        self.value = float("inf")
        self.bodies: tuple[Body, Body | None] | None = None

    def screen(self, lb: FloatArray, exact: Any) -> int | None:
        """Evaluate ``exact`` on the pairs whose lower bound ``lb`` is below the best so
        far (those of least bound first); return the index of a new best pair, or None.

        Exact, not approximate: a pair left out has a distance >= its bound >= the best.
        """
        order = np.argsort(lb, kind="stable")
        order = order[lb[order] < self.value]
        if order.size == 0:
            return None
        found = None
        parts = (order,) if order.size <= _ALL else (order[:_HEAD], order[_HEAD:])
        for part in parts:
            part = part[lb[part] < self.value]
            if part.size == 0:
                continue
            d = exact(part)
            x = int(np.argmin(d))
            if d[x] < self.value:
                self.value, found = float(d[x]), int(part[x])
        return found


def _check_base(stack: Stack, obstacles: Sequence[Obstacle], radius: float) -> None:
    base = stack.base_nodes[0]
    for i, ob in enumerate(obstacles):
        d = np.asarray(ob.point_distance(base))
        k = int(np.argmin(d))
        if d[k] < radius - BASE_TOL:
            where = "inside it" if d[k] < 0 else f"{d[k]:.6g} mm from it, less than leg_radius"
            raise ValueError(
                f"obstacles[{i}]: collides with the base (base joint {k} of platform 1 is "
                f"{where}), so every pose would collide"
            )


def clearances(
    stack: Stack,
    q: ArrayLike,
    obstacles: Sequence[Obstacle] | Obstacle | None = (),
    *,
    phi: float | None = None,
) -> Clearances:
    """Signed minimum distances [mm] between the bodies of a pose and the obstacles.

    Exact (no sampling, no smoothing, no screening threshold): see :mod:`stackik.distance`.
    Negative values are penetrations. With zero leg radii, zero plate thickness and no
    obstacle a value is negative only where a leg's axis passes through a plate or two
    plates through each other (minus the penetration depth); two legs that cross exactly
    are at distance 0.

    Parameters
    ----------
    stack : Stack
    q : array_like, shape (n, 6) or (n, 3)
        Spatial pose ``[x, y, z, yaw, pitch, roll]``, or planar ``[rho, z, theta]`` with
        ``phi``.
    obstacles : sequence of Obstacle, optional
        Keep-out bodies in the base frame (:class:`stackik.Sphere`, :class:`stackik.Capsule`,
        :class:`stackik.Box`, :class:`stackik.HalfSpace`).
    phi : float, optional
        Plane angle [rad] of a planar pose.

    Returns
    -------
    Clearances

    Raises
    ------
    ValueError
        Malformed ``q``, ``phi`` or ``obstacles``, or an obstacle closer than the legs'
        radius to a joint of the base (every pose would collide with it).
    """
    obs = as_obstacles(obstacles)
    lay: _Layout = stack.derived("clearance_layout", _layout)
    _check_base(stack, obs, float(lay.radius[0]))
    A, O = plate_frames(stack, q, phi)
    B, T = _joints(stack, A, O)
    r = lay.radius
    # the bodies of the stack against each other: one compiled call (exact, screened)
    d_self, adj_min, adj_at, non_adj, kind, at = body_clearances(
        B, T, r, A, O, lay.uv, lay.centre, lay.reach, lay.half_t,
        lay.self_k, lay.self_m, lay.adj, lay.ll, lay.lp, lay.pp,
    )  # fmt: skip
    by_plat = d_self.min(axis=1)
    contacts = _stack_contacts(lay, d_self, adj_min, adj_at, non_adj, kind, at)
    ob_min, ob_contacts = _obstacle_contacts(obs, lay, A, O, B, T)
    by_plat.setflags(write=False)
    return Clearances(
        contacts[0].distance, by_plat, float(adj_min), float(non_adj), tuple(ob_min),
        tuple(contacts + ob_contacts),
    )  # fmt: skip


def _stack_contacts(
    lay: _Layout,
    d_self: FloatArray,
    adj_min: float,
    adj_at: int,
    non_adj: float,
    kind: int,
    at: int,
) -> list[Contact]:
    """The closest pairs of the stack's own bodies from :func:`body_clearances`' answer:
    the legs of one platform (always), adjacent platforms' legs and the rest (if any)."""
    k, m = lay.self_k, lay.self_m
    i, p = np.unravel_index(int(np.argmin(d_self)), d_self.shape)
    self_min = float(d_self[i, p])
    contacts = [
        Contact(self_min, Body("leg", int(i) + 1, int(k[p])), Body("leg", int(i) + 1, int(m[p])))
    ]
    if adj_at >= 0:
        ia, ka, ib, kb = lay.adj[adj_at]
        contacts.append(
            Contact(adj_min, Body("leg", int(ia) + 1, int(ka)), Body("leg", int(ib) + 1, int(kb)))
        )
    if kind == 0:
        ia, ka, ib, kb = lay.ll[at]
        bodies = (Body("leg", int(ia) + 1, int(ka)), Body("leg", int(ib) + 1, int(kb)))
    elif kind == 1:
        il, kl, jl = lay.lp[at]
        bodies = (Body("leg", int(il) + 1, int(kl)), Body("plate", int(jl)))
    elif kind == 2:
        j1, j2 = lay.pp[at]
        bodies = (Body("plate", int(j1)), Body("plate", int(j2)))
    if kind >= 0:
        contacts.append(Contact(non_adj, *bodies))
    return contacts


def _obstacle_contacts(
    obs: Sequence[Obstacle],
    lay: _Layout,
    A: FloatArray,
    O: FloatArray,
    B: FloatArray,
    T: FloatArray,
) -> tuple[list[float], list[Contact]]:
    """Each obstacle's least distance to every leg and every plate but the base, and its
    closest body (signed distances are 1-Lipschitz, so a sphere's centre bounds its body's
    distance from below: pairs are screened by bounding spheres, exactly)."""
    ob_min: list[float] = []
    contacts: list[Contact] = []
    if not obs:
        return ob_min, contacts
    r = lay.radius
    # bounding spheres of the bodies: a pair's distance is at least that of its spheres
    leg_c = 0.5 * (B + T)  # (n, 6, 3)
    leg_R = 0.5 * np.linalg.norm(T - B, axis=-1) + r[:, None]
    plate_c = O + np.einsum("nij,nj->ni", A[:, :, :2], lay.centre)  # (n+1, 3)
    plate_R = lay.reach + lay.half_t
    a, b = B.reshape(-1, 3), T.reshape(-1, 3)
    r_leg = np.repeat(r, 6)
    c_leg, R_leg = leg_c.reshape(-1, 3), leg_R.reshape(-1)
    ht = lay.half_t[1:]
    for o_i, ob in enumerate(obs):
        best = _Best()

        def d_leg(x: IntArray, ob: Obstacle = ob) -> FloatArray:
            return ob.segment_distance(a[x], b[x]) - r_leg[x]  # type: ignore[no-any-return]

        def d_plate(x: IntArray, ob: Obstacle = ob) -> FloatArray:
            j = x + 1
            return ob.polygon_distance(dist.Polygon(O[j], A[j], lay.uv[j])) - ht[x]  # type: ignore[no-any-return]

        x = best.screen(ob.point_distance(c_leg) - R_leg, d_leg)
        if x is not None:
            best.bodies = (Body("leg", x // 6 + 1, x % 6), None)
        x = best.screen(ob.point_distance(plate_c[1:]) - plate_R[1:], d_plate)
        if x is not None:
            best.bodies = (Body("plate", x + 1), None)
        assert best.bodies is not None  # a stack has legs
        ob_min.append(best.value)
        contacts.append(Contact(best.value, best.bodies[0], obstacle=o_i))
    return ob_min, contacts


def _joints(stack: Stack, A: FloatArray, O: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Base and top joints of every leg in the base frame, each (n, 6, 3) [mm]."""
    B = O[:-1, None, :] + np.einsum("nij,nkj->nki", A[:-1], stack.base_nodes)
    T = O[1:, None, :] + np.einsum("nij,nkj->nki", A[1:], stack.top_nodes)
    return B, T


def cores_cross(stack: Stack, q: ArrayLike, phi: float | None = None) -> bool:
    """Whether a leg's axis passes through a plate it does not join, or two plates pass
    through each other: the clearances that are negative even on a stack whose legs and
    plates have no size (:func:`needs_clearances` False). A compiled screen of a few
    microseconds; the check measures the clearances of a pose where it is True.

    Parameters
    ----------
    q : array_like, shape (n, 6) or (n, 3)
        A spatial pose, or a planar one with ``phi``.
    """
    lay: _Layout = stack.derived("clearance_layout", _layout)
    if not (len(lay.lp) or len(lay.pp)):
        return False
    A, O = plate_frames(stack, q, phi)
    B, T = _joints(stack, A, O)
    return bool(any_crossing(B, T, A, O, lay.uv, lay.lp, lay.pp))


def needs_clearances(
    stack: Stack, obstacles: Sequence[Obstacle] = (), clearance: float = 0.0
) -> bool:
    """Whether the check measures every pose's clearances: False only with no obstacle,
    zero leg radii and plate thickness and a zero margin. Every clearance is then a
    distance, >= 0, except where cores cross (a leg's axis through a plate, two plates
    through each other): the check screens for those alone (:func:`cores_cross`) and
    measures the clearances of a pose where they do."""
    if obstacles or clearance > 0.0:
        return True
    return bool(stack.derived("clearance_bodies", _has_bodies))


def clearances_can_fail(
    stack: Stack,
    obstacles: Sequence[Obstacle] = (),
    clearance: float = 0.0,
    q: ArrayLike | None = None,
    phi: float | None = None,
) -> bool:
    """Whether some pose within the leg limits can fail a clearance: :func:`needs_clearances`
    except that obstacles out of reach of every pose do not count (a solver that checks
    limits and target apart need not measure them for its verdict). With a pose ``q``, also
    True where its cores cross (:func:`cores_cross`).

    Out of reach: the obstacle's signed distance from the base origin exceeds
    :func:`body_reach`. With a pose ``q`` (``phi`` for a planar one), only the obstacles
    that can touch that pose count: those within the radius, about the centroid of its
    joints, of the ball that holds every joint (hence every leg and plate: convex hulls of
    joints)."""
    if clearance > 0.0 or bool(stack.derived("clearance_bodies", _has_bodies)):
        return True
    if q is not None and cores_cross(stack, q, phi):
        return True
    if not obstacles:
        return False
    reach = body_reach(stack)
    origin = np.zeros(3)
    near = [ob for ob in obstacles if bool(ob.point_distance(origin) <= reach)]
    if not near or q is None:
        return bool(near)
    B, T = _joints(stack, *plate_frames(stack, q, phi))
    joints = np.concatenate([B.reshape(-1, 3), T.reshape(-1, 3)])
    c = joints.mean(axis=0)
    r = float(np.linalg.norm(joints - c, axis=1).max())
    return any(bool(ob.point_distance(c) <= r) for ob in near)


def body_reach(stack: Stack) -> float:
    """Radius [mm] of a ball about the base origin holding every body of every pose within
    the leg limits: ``sum_i (leg_max_i + |mean_k b_ik| + |mean_k t_ik|) + max node radius``.

    Platform i's top origin is ``p = mean_k (l_k + b_k - R t_k)`` (legs ``l_k``), so
    ``|p| <= leg_max + |mean b| + |mean t|``; every joint is within its plate's node radius
    of its plate's origin, and legs and plates are convex hulls of joints."""
    return float(stack.derived("clearance_reach", _reach))


def _reach(stack: Stack) -> float:
    mb = np.linalg.norm(stack.base_nodes.mean(axis=1), axis=-1)
    mt = np.linalg.norm(stack.top_nodes.mean(axis=1), axis=-1)
    r = max(
        np.linalg.norm(stack.base_nodes, axis=-1).max(),
        np.linalg.norm(stack.top_nodes, axis=-1).max(),
    )
    return float(np.sum(stack.leg_max + mb + mt) + r)


def _has_bodies(stack: Stack) -> bool:
    return any(g.leg_radius > 0.0 or g.plate_thickness > 0.0 for g in stack)


# -----------------------------------------------------------------------------------------
# the closest points of a contact (for drawing it)
# -----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ContactPoints:
    """The two closest points of a :class:`Contact` (:func:`contact_points`).

    Attributes
    ----------
    contact : Contact
    a : ndarray, shape (3,)
        Point of body ``contact.a``'s surface [mm], base frame.
    b : ndarray, shape (3,)
        Point of body ``contact.b``'s surface, or of the obstacle's [mm]. ``|b - a|`` is
        ``|contact.distance|`` (up to rounding); when the bodies overlap ``a`` is inside the
        other body, ``b`` inside (or on) body ``a``: the segment spans the overlap.
    """

    contact: Contact
    a: FloatArray
    b: FloatArray

    @property
    def distance(self) -> float:
        """``contact.distance`` [mm] (signed)."""
        return self.contact.distance

    def label(self) -> str:
        """``"12.3 mm"``: the distance with its unit, for a figure."""
        return f"{self.contact.distance:.1f} mm"


#: Points per bracket of the convex line searches of :func:`contact_points`, and rounds:
#: each round shrinks a bracket by (K - 1) / 2 = 8, so 20 rounds reach 8^-20 ~ 1e-18 of
#: the start (below rounding of any stack's coordinates).
_K, _ROUNDS = 17, 20


def _bracket_min(f: Any, lo: FloatArray, hi: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Minimise convex functions of one parameter on ``[lo, hi]`` (arrays (P,)): ``f`` maps
    parameters (P, K) to values (P, K). Returns the minimisers and values, each (P,).

    A convex function's grid minimum at node k brackets a minimiser in ``[k - 1, k + 1]``,
    so each round keeps a minimiser: no tolerance but the rounds."""
    s = np.linspace(0.0, 1.0, _K)
    lo, hi = lo.astype(float).copy(), hi.astype(float).copy()
    rows = np.arange(len(lo))
    for _ in range(_ROUNDS):
        t = lo[:, None] + s * (hi - lo)[:, None]
        k = np.argmin(f(t), axis=1)
        lo, hi = t[rows, np.maximum(k - 1, 0)], t[rows, np.minimum(k + 1, _K - 1)]
    t = np.stack([lo, 0.5 * (lo + hi), hi], axis=1)
    v = f(t)
    k = np.argmin(v, axis=1)
    return t[rows, k], v[rows, k]


def _span(uv: FloatArray, x: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Least and largest y of the convex polygon ``uv`` (M, 2) on the lines x = ``x`` (P,)."""
    e0, e1 = uv, uv[_next_vertex(len(uv))]
    x0, x1 = e0[:, 0], e1[:, 0]
    lo_x, hi_x = np.minimum(x0, x1), np.maximum(x0, x1)
    dx = x1 - x0
    w = np.where(dx != 0.0, (x[:, None] - x0) / np.where(dx != 0.0, dx, 1.0), 0.0)
    y = e0[:, 1] + np.clip(w, 0.0, 1.0) * (e1[:, 1] - e0[:, 1])  # (P, M)
    # a vertical edge at x spans both its end points' y
    on = (x[:, None] >= lo_x) & (x[:, None] <= hi_x)
    vert = on & (dx == 0.0)
    ylo = np.where(on, np.where(vert, np.minimum(e0[:, 1], e1[:, 1]), y), np.inf).min(axis=1)
    yhi = np.where(on, np.where(vert, np.maximum(e0[:, 1], e1[:, 1]), y), -np.inf).max(axis=1)
    return ylo, yhi


def _next_vertex(m: int) -> IntArray:
    return (np.arange(m) + 1) % m


def _core_min(core: Any, f: Any) -> FloatArray:
    """The point of a core (a segment ``(a, b)`` or a :class:`~stackik.distance.Polygon`)
    where the convex function ``f`` of points (..., 3) is least (P = 1 line search along a
    segment; over a polygon, nested searches in its frame: the least over y is convex in
    x)."""
    if not isinstance(core, dist.Polygon):
        a, b = core
        t, _ = _bracket_min(lambda t: f(a + t[..., None] * (b - a)), np.zeros(1), np.ones(1))
        return a + t[0] * (b - a)  # type: ignore[no-any-return]
    uv = core.uv

    def world(x: FloatArray, y: FloatArray) -> FloatArray:
        return core.origin + x[..., None] * core.axes[:, 0] + y[..., None] * core.axes[:, 1]  # type: ignore[no-any-return]

    def inner(x: FloatArray) -> tuple[FloatArray, FloatArray]:
        ylo, yhi = _span(uv, x.ravel())
        y, v = _bracket_min(lambda y: f(world(x.ravel()[:, None], y)), ylo, yhi)
        return y.reshape(x.shape), v.reshape(x.shape)

    lo, hi = np.array([uv[:, 0].min()]), np.array([uv[:, 0].max()])
    x, _ = _bracket_min(lambda x: inner(x)[1], lo, hi)
    y, _ = inner(x)
    return world(x, y)[0]  # type: ignore[no-any-return]


def _nearest_on(core: Any, p: FloatArray) -> FloatArray:
    """The point of a core nearest to the point ``p`` (3,)."""
    if not isinstance(core, dist.Polygon):
        a, b = core
        return a + dist._segment_param(p, a, b - a) * (b - a)  # type: ignore[no-any-return]
    loc = core.local(p)
    if bool(core.inside(loc[:2])):
        return core.origin + core.axes[:, :2] @ loc[:2]  # type: ignore[no-any-return]
    e0 = core.vertices()
    e1 = e0[_next_vertex(len(e0))]
    t = dist._segment_param(p, e0, e1 - e0)
    cand = e0 + t[:, None] * (e1 - e0)
    return cand[int(np.argmin(np.linalg.norm(cand - p, axis=1)))]  # type: ignore[no-any-return]


def _unit(v: FloatArray) -> FloatArray:
    norm = float(np.linalg.norm(v))
    return v / norm if norm > 0.0 else np.zeros(3)


def _surface(ob: Obstacle, p: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The point of the obstacle's boundary nearest to ``p`` and the unit gradient of its
    signed distance at ``p`` (outward)."""
    from stackik.obstacles import Box, Capsule, HalfSpace, Sphere

    if isinstance(ob, Sphere | Capsule):
        foot = ob.center if isinstance(ob, Sphere) else _nearest_on((ob.a, ob.b), p)
        g = _unit(p - foot)
        if not g.any():
            g = np.array([0.0, 0.0, 1.0])
        return foot + ob.radius * g, g
    if isinstance(ob, HalfSpace):
        return p - float((p - ob.point) @ ob.normal) * ob.normal, ob.normal
    if isinstance(ob, Box):
        R, h = ob._R, ob.half_extents
        x = R.T @ (p - ob.center)
        excess = np.abs(x) - h
        if np.any(excess > 0.0):
            q = np.clip(x, -h, h)
            g = _unit(x - q)
        else:  # inside: the nearest face
            i = int(np.argmax(excess))
            q = x.copy()
            q[i] = np.copysign(h[i], x[i])
            g = np.zeros(3)
            g[i] = np.copysign(1.0, x[i])
        return ob.center + R @ q, R @ g
    raise ValueError(f"obstacles: no closest point for {type(ob).__name__}")


def contact_points(
    stack: Stack,
    q: ArrayLike,
    contact: Contact,
    obstacles: Sequence[Obstacle] | Obstacle | None = (),
    *,
    phi: float | None = None,
) -> ContactPoints:
    """The closest points of a contact of :func:`clearances` (e.g. ``.closest``): to draw
    the pair as a segment labelled with its distance.

    From the same distance code as :func:`clearances`: the core point of body ``a`` is
    where the other body's exact point distance (:mod:`stackik.distance`, or the
    obstacle's signed distance) is least over ``a``'s core, a convex function, minimised
    by bracketing searches to rounding; the other core's nearest point follows, and both
    move out to the bodies' surfaces along the line joining them.

    Parameters
    ----------
    stack, q, obstacles, phi
        As given to :func:`clearances` for ``contact``.
    contact : Contact

    Returns
    -------
    ContactPoints
    """
    obs = as_obstacles(obstacles)
    lay: _Layout = stack.derived("clearance_layout", _layout)
    A, O = plate_frames(stack, q, phi)
    B, T = _joints(stack, A, O)

    def core(body: Body) -> tuple[Any, float]:
        if body.kind == "leg":
            i, k = body.index - 1, int(body.leg or 0)
            return (B[i, k], T[i, k]), float(lay.radius[i])
        j = body.index
        return dist.Polygon(O[j], A[j], lay.uv[j]), float(lay.half_t[j])

    core_a, r_a = core(contact.a)
    if contact.b is None:
        if contact.obstacle is None or not 0 <= contact.obstacle < len(obs):
            raise ValueError(f"contact: obstacle {contact.obstacle} is not in obstacles")
        ob = obs[contact.obstacle]
        p = _core_min(core_a, ob.point_distance)
        on_b, g = _surface(ob, p)
        return ContactPoints(contact, p - r_a * g, on_b)
    core_b, r_b = core(contact.b)
    if isinstance(core_b, dist.Polygon):
        to_b: Any = lambda x: dist.point_polygon(x, core_b)  # noqa: E731
    else:
        to_b = lambda x: dist.point_segment(x, *core_b)  # noqa: E731
    p = _core_min(core_a, to_b)
    pb = _nearest_on(core_b, p)
    u = _unit(pb - p)
    return ContactPoints(contact, p + r_a * u, pb - r_b * u)
