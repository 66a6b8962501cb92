"""Rows for the bodies of non-adjacent platforms, spatial or planar (docs/clearance.md): leg
``k`` of platform ``i`` kept clear of leg ``l`` of platform ``j >= i + 2`` and of every plate
it does not connect, the one definition the solvers' problems use (its kernel:
:mod:`stackik._compiled.leg_pairs`).

Every body is a set of segments with their ends fixed on plates (:func:`pair_table`): a
leg is its axis, from plate ``i`` to plate ``i + 1``; plate ``p`` (its polygon: the convex
hull of its nodes projected onto its plane, as the check's) is *covered* by its edges and
parallel chords at most :data:`CHORD_MM` apart, so that every point of the polygon lies
within ``kappa_p`` (half the chords' spacing, :func:`_covering`) of a covering segment.
For a pair of segments ``a``, ``b`` the row is

    c = (d^2 - rho^2) / L^2 >= 0,   L = max leg_max [mm],

``d`` the distance of the two segments (clamped closest points), with

* two legs (platforms ``i``, ``j``): ``rho = r_i + r_j + m``, exact: the rows hold exactly
  when the two capsules are ``m`` apart;
* a leg of platform ``i`` and a covering segment of plate ``p`` (``p`` not ``i`` or
  ``i + 1``): ``rho = r_i + tau_p + kappa_p + m`` (``tau_p`` the plate's half thickness
  plus its nodes' height off its plane, as the sphere-plate rows): conservative by at
  most ``kappa_p`` (on the reference geometry 5.8-6.0 mm: 25 or 26 chords and 6 or 12
  edges a plate), and it also keeps a leg from passing through the plate's inside, where
  no edge is near;

``r`` the platforms' ``leg_radius`` and ``m`` the clearance margin. First derivatives by the
envelope rule at the closest points (as the self-leg and obstacle rows), smooth where those
are unique; no second derivatives. The rows depend on the whole chain below the higher
body (both move with every platform below them): they are *dense rows*, which both
compiled interior points carry (:mod:`stackik._compiled.dense_rows`) and
:class:`~stackik.formulation.Problem` appends for the other engines. Two plates of
non-adjacent platforms have no rows (the check still refuses a pose where they meet).

A problem carries rows only for the pairs it is given (screened: :func:`close_pairs`), and
the solve adds them only when a pose without them fails the check on non-adjacent bodies
(:func:`stackik.solve.stages._unfold`): a solve where no such pair comes close is the solve
without the rows, bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik._arrays import readonly
from stackik.geometry import Stack

__all__ = ["LegPairRows", "PairTable", "close_pairs", "no_leg_pair_rows", "pair_table"]

FloatArray = NDArray[np.float64]


def _readonly_int(values: Any, cols: int) -> Any:
    v = np.ascontiguousarray(values, dtype=np.int64).reshape(-1, cols)
    v.setflags(write=False)
    return v


@dataclass(frozen=True)
class PairTable:
    """Every segment and every pair of the family on one stack (read-only arrays).

    Attributes
    ----------
    plates : ndarray, shape (S, 2), int64
        The plates the two ends of each segment are fixed on (legs first: segment
        ``6 i + k`` is leg ``k`` of platform ``i``).
    points : ndarray, shape (S, 2, 3)
        The ends in those plates' frames [mm].
    body : ndarray, shape (S,), int64
        The plate of a plate's segment, -1 for a leg.
    kappa : ndarray, shape (n + 1,)
        The covering radius [mm] of each plate's segments (module doc).
    pairs : ndarray, shape (m, 2), int64
        Every pair of segments with a row: two legs of platforms two or more apart, a leg
        and a covering segment of a plate it does not connect.
    rho : ndarray, shape (m,)
        Each pair's least distance [mm] without the margin.
    """

    plates: Any
    points: Any
    body: Any
    kappa: Any
    pairs: Any
    rho: Any


#: Largest spacing [mm] of the chords that cover a plate (:func:`_covering`): the
#: leg-plate rows are conservative by at most half of it.
CHORD_MM = 12.0


def _covering(hull: FloatArray) -> tuple[FloatArray, float]:
    """The covering segments of the convex polygon ``hull`` (M, 2, counter-clockwise) in
    ``z = 0``, as their 3D ends (K, 2, 3), and their covering radius ``kappa``: the
    polygon's edges and its chords ``x = x_k`` at the spacing ``w <= CHORD_MM`` (the first
    ``w / 2`` from its leftmost vertex). Every point ``p`` of the polygon lies within
    ``kappa = w / 2`` of one: the nearest chord's line is within ``w / 2``, and the
    horizontal segment from ``p`` to it either ends on the chord or leaves the polygon
    through an edge."""
    M = hull.shape[0]
    nxt = np.roll(hull, -1, axis=0)  # edge k runs from vertex k to vertex k + 1
    lo, hi = float(hull[:, 0].min()), float(hull[:, 0].max())
    count = max(1, math.ceil((hi - lo) / CHORD_MM))
    width = (hi - lo) / count
    x = (lo + (np.arange(count) + 0.5) * width)[:, None]  # (count, 1): the chords' lines
    (x0, y0), (x1, y1) = hull.T, nxt.T
    crosses = ((x0 - x) * (x1 - x) <= 0.0) & (x0 != x1)  # (count, M): edges each line crosses
    with np.errstate(divide="ignore", invalid="ignore"):
        y = y0 + (x - x0) / (x1 - x0) * (y1 - y0)
    ends = np.zeros((M + count, 2, 3))
    ends[:M, 0, :2], ends[:M, 1, :2] = hull, nxt
    ends[M:, :, 0] = x
    ends[M:, 0, 1] = np.where(crosses, y, np.inf).min(axis=1)
    ends[M:, 1, 1] = np.where(crosses, y, -np.inf).max(axis=1)
    return ends, width / 2


def _pair_list(
    n: int, body: Any, radius: FloatArray, tau: FloatArray, kappa: FloatArray
) -> tuple[Any, FloatArray]:
    """Every pair of :class:`PairTable` (m, 2) and its ``rho`` (m,), in the table's order:
    for each leg ``a = 6 i + k`` in turn, the legs of platforms ``j >= i + 2``, then the
    covering segments of every plate ``p`` other than ``i`` and ``i + 1`` (ascending: the
    segments are laid out plate by plate). Built platform by platform with whole arrays:
    a stack of 64 has about 10^6 pairs."""
    seg = np.flatnonzero(body >= 0)  # the plates' covering segments, ascending
    plate = body[seg]
    pairs: list[Any] = []
    rho: list[FloatArray] = []
    for i in range(n):
        legs = np.arange(6 * (i + 2), 6 * n, dtype=np.int64)
        keep = (plate != i) & (plate != i + 1)
        other = np.concatenate((legs, seg[keep]))
        r_other = np.concatenate(
            (radius[i] + radius[legs // 6], radius[i] + tau[plate[keep]] + kappa[plate[keep]])
        )
        own = 6 * i + np.arange(6, dtype=np.int64)
        pairs.append(np.column_stack((np.repeat(own, other.size), np.tile(other, 6))))
        rho.append(np.tile(r_other, 6))
    return np.concatenate(pairs), np.concatenate(rho)  # n >= 1: a Stack has a platform


def pair_table(stack: Stack) -> PairTable:
    """The :class:`PairTable` of ``stack`` (cached per stack)."""

    def build(st: Stack) -> PairTable:
        from stackik.distance import convex_hull_2d

        n = st.n
        radius = np.array([g.leg_radius for g in st], dtype=float)
        plates: list[Any] = [np.repeat([(i, i + 1) for i in range(n)], 6, axis=0)]
        points: list[Any] = [np.stack((st.base_nodes, st.top_nodes), axis=2).reshape(-1, 2, 3)]
        body: list[Any] = [np.full(6 * n, -1)]
        kappa = np.zeros(n + 1)
        tau = np.zeros(n + 1)
        for p in range(n + 1):
            nodes = np.concatenate(
                ([st.top_nodes[p - 1]] if p > 0 else []) + ([st.base_nodes[p]] if p < n else [])
            )
            thick = max(st[i].plate_thickness for i in (p - 1, p) if 0 <= i < n)
            tau[p] = thick / 2 + float(np.abs(nodes[:, 2]).max())
            ends, kappa[p] = _covering(convex_hull_2d(nodes[:, :2]))
            plates.append(np.full((len(ends), 2), p))
            points.append(ends)
            body.append(np.full(len(ends), p))
        body_a = np.concatenate(body)
        pairs, rho = _pair_list(n, body_a, radius, tau, kappa)
        return PairTable(
            plates=_readonly_int(np.concatenate(plates), 2),
            points=readonly(np.concatenate(points)),
            body=_readonly_int(body_a, 1).reshape(-1),
            kappa=readonly(kappa),
            pairs=_readonly_int(pairs, 2),
            rho=readonly(rho),
        )

    return stack.derived(("leg_pair_table",), build)  # type: ignore[no-any-return]


class LegPairRows:
    """The rows of some pairs of :func:`pair_table` of one problem, spatial or planar
    (module doc).

    Parameters
    ----------
    stack : Stack
    index : array_like of int, shape (m,)
        The pairs: rows of :attr:`PairTable.pairs`.
    margin : float
        Clearance margin [mm].
    phi : float or None
        Plane angle [rad] of a planar request (poses (n, 3)); None for spatial (n, 6).

    Attributes
    ----------
    size : int
        Number of rows (one per pair).
    index : ndarray, shape (m,), int64
    """

    def __init__(self, stack: Stack, index: Any, margin: float, phi: float | None = None) -> None:
        table = pair_table(stack)
        idx = np.asarray(index, dtype=np.int64).reshape(-1)
        if idx.size and not (idx.min() >= 0 and idx.max() < table.pairs.shape[0]):
            raise ValueError(f"index: pairs are 0..{table.pairs.shape[0] - 1}")
        self.index = readonly(idx)
        self.phi = phi
        self.margin = float(margin)
        self.L = float(np.max(stack.leg_max))
        self.size = int(idx.size)
        pairs = _readonly_int(table.pairs[idx], 2)
        rho = readonly(table.rho[idx] + self.margin)
        self._args = (table.plates, table.points, pairs, rho, self.L)

    @property
    def kernel_args(self) -> tuple[Any, ...]:
        """The kernel's arguments after the pose (``plates, points, pairs, rho, L``), as the
        compiled interior points carry them (``SpatialData.leg_pairs``,
        ``PlanarData.leg_pairs``)."""
        return self._args

    def _rows(self, q: FloatArray, jacobian: bool) -> tuple[FloatArray, FloatArray]:
        from stackik._compiled.leg_pairs import segment_pair_rows

        planar = self.phi is not None
        phi = 0.0 if self.phi is None else float(self.phi)
        qc = np.ascontiguousarray(q, dtype=float)
        return segment_pair_rows(qc, *self._args, planar, phi, jacobian)  # type: ignore[no-any-return]

    def __call__(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Rows ``c`` (size,) and Jacobian (size, n k) against the raw pose ``q`` (n, k)."""
        return self._rows(q, True)

    def distances(self, q: FloatArray) -> FloatArray:
        """The pairs' segment distances [mm] at the raw pose ``q`` minus their ``rho``
        (negative: closer than the rows allow)."""
        c, _ = self._rows(q, False)
        rho = self._args[3]
        return np.sqrt(np.maximum(c * self.L**2 + rho**2, 0.0)) - rho  # type: ignore[no-any-return]


def no_leg_pair_rows(stack: Stack) -> tuple[Any, ...]:
    """:attr:`LegPairRows.kernel_args` of no pair on ``stack`` (cached per stack): the
    compiled interior points' arguments when a problem has no such rows (the same types,
    empty arrays: without a pair the kernel reads no segment, and a first solve does not
    pay for :func:`pair_table`, about 10^6 pairs at n = 64)."""

    def make(st: Stack) -> tuple[Any, ...]:
        none = _readonly_int(np.zeros((0, 2)), 2)
        return (none, readonly(np.zeros((0, 2, 3))), none, readonly(np.zeros(0)),
                float(np.max(st.leg_max)))  # fmt: skip

    return stack.derived(("no_leg_pair_rows",), make)  # type: ignore[no-any-return]


def close_pairs(
    stack: Stack,
    poses: list[FloatArray],
    margin: float,
    phi: float | None,
    screen: float,
    per_plate: int | None = None,
) -> Any:
    """The pairs (indices into :attr:`PairTable.pairs`, ascending) whose segments come within
    ``rho + screen`` [mm] of each other at any of the raw ``poses``: the pairs a solve's rows
    cover (the others cost nothing). With ``per_plate``, of a leg's pairs with the covering
    segments of one plate only the ``per_plate`` closest (least distance over ``poses``;
    ties to the lower index) stay: the rows then keep the leg off the plate near where it
    is, not over the whole plate (the covering argument of the module doc holds for the
    segments kept; the check's exact distances decide the rest)."""
    table = pair_table(stack)
    every = LegPairRows(stack, np.arange(table.pairs.shape[0]), margin, phi)
    d = np.full(every.size, np.inf)
    for q in poses:
        d = np.minimum(d, every.distances(q))
    near = np.flatnonzero(d < screen)
    if per_plate is None:
        return near
    if per_plate < 1:
        raise ValueError(f"per_plate: at least 1, not {per_plate}")
    plate = table.body[table.pairs[near, 1]]
    legs, plated = near[plate < 0], near[plate >= 0]
    key = table.pairs[plated, 0] * (stack.n + 1) + plate[plate >= 0]
    order = np.lexsort((plated, d[plated], key))  # by (leg, plate), then distance, index
    key, plated = key[order], plated[order]
    first = np.searchsorted(key, key, side="left")  # each group's first position
    rank = np.arange(key.size) - first
    return np.sort(np.concatenate((legs, plated[rank < per_plate])))
