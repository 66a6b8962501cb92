"""Starts of the local solvers: the paper's guess, sideways folds, random perturbations.

FN^2 sums the squared distances from each plate to the end effector, so good poses often
fold the top of the stack sideways; which way each upper platform folds is a discrete
choice that a local solver keeps. The structured starts enumerate those choices; random
starts (``rng``) perturb the first start.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from stackik.formulation.modes import Mode, mode_of
from stackik.geometry import Stack
from stackik.targets import PlanarTarget, Target

__all__ = [
    "ARC_PLATFORMS",
    "ARC_TURN",
    "SPATIAL_STARTS",
    "SPATIAL_HOPS",
    "SPATIAL_HOPS_N4",
    "SPATIAL_ALL_HOPS_NS",
    "SPATIAL_HOPS_N5",
    "SPATIAL_START_ORDER",
    "StartSampler",
    "arc_starts",
    "fold_depth",
    "fold_patterns",
    "initial_starts",
    "nominal_height",
    "paper_initial_guess",
    "reach_fraction",
    "spatial_default_hops",
    "spatial_hop_count",
    "spatial_hop_plan",
    "spatial_hops",
    "spatial_start_count",
    "spatial_starts",
    "tall_random_starts",
]

FloatArray = NDArray[np.float64]

#: Default number of starts in spatial mode (5 structured, the rest random; ``rng``).
SPATIAL_STARTS = 12


def nominal_height(stack: Stack, frac: float = 0.35) -> FloatArray:
    """Height of each platform at which its legs are at ``leg_min + frac * range`` [mm]."""

    def make(st: Stack) -> FloatArray:
        L = st.leg_min + frac * (st.leg_max - st.leg_min)
        chord = np.linalg.norm(st.top_nodes - st.base_nodes, axis=-1).max(axis=1)
        h = np.sqrt(np.maximum(L**2 - chord**2, (0.5 * L) ** 2))
        h.setflags(write=False)
        return h  # type: ignore[no-any-return]

    return stack.derived(("nominal_height", frac), make)  # type: ignore[no-any-return]


def paper_initial_guess(stack: Stack, target: Target) -> FloatArray:
    """The paper's initial guess: share the target among the platforms, ignoring limits.

    Planar: each platform turns by ``theta / n`` and moves by ``P_target / n`` in the base
    frame (expressed in its own frame), with its local height ``z_i`` raised to at least the
    height where its legs sit at 35% of their range ("a minimum translation in each
    platform's normal direction"). Spatial: the same with the rotation vector of
    ``R_target`` divided evenly. Returns (n, 3) or (n, 6).
    """
    n = stack.n
    hmin = nominal_height(stack)
    if isinstance(target, PlanarTarget):
        th = np.full(n, target.theta / n)
        Theta = np.cumsum(th) - th
        P = np.array([target.rho, target.z]) / n
        c, s = np.cos(Theta), np.sin(Theta)
        rho = c * P[0] + s * P[1]  # Rot(-Theta) P
        z = -s * P[0] + c * P[1]
        z = np.maximum(z, hmin)
        return np.column_stack([rho, z, th])
    from scipy.spatial.transform import Rotation

    rv = Rotation.from_matrix(target.rotation).as_rotvec() / n
    Ri = Rotation.from_rotvec(rv).as_matrix()
    eul = Rotation.from_rotvec(rv).as_euler("ZYX")
    q = np.zeros((n, 6))
    A = np.eye(3)
    for i in range(n):
        p = A.T @ (target.position / n)
        p[2] = max(p[2], hmin[i])
        q[i, :3] = p
        q[i, 3:] = eul
        A = A @ Ri
    return q


def initial_starts(
    stack: Stack, target: Target, q0: FloatArray, structured: bool
) -> list[FloatArray]:
    """Deterministic starts: ``q0`` and two folded variants per horizontal axis.

    FN^2 sums the squared distances from each plate to the end effector, so good poses
    often fold the top of the stack: the two upper platforms offset sideways in opposite
    directions bring the lower plates closer to the end effector. Which way they fold is a
    discrete choice that a local solver cannot change, hence one start per direction
    (offset ``0.75 (leg_max - leg_min)`` [mm] in the platforms' own frames): along the
    plane's axis in planar mode (3 starts), along x and along y in spatial mode (5 starts,
    followed there by random ones, :data:`SPATIAL_STARTS` in all).
    """
    out = [q0]
    if structured and stack.n >= 2:
        a = fold_offset(stack)
        # planar: the in-plane axis; spatial: both horizontal axes (4 folded starts)
        for axis in mode_of(target).fold_axes:
            for sign in (1.0, -1.0):
                out.append(_fold_top_two(q0, axis, sign * a))
    return out


def fold_offset(stack: Stack) -> float:
    """The sideways offset of the folded starts: ``0.75`` of the mean leg range [mm]."""
    return 0.75 * float(np.mean(stack.leg_max - stack.leg_min))


def _fold_top_two(q0: FloatArray, axis: int, offset: float) -> FloatArray:
    """``q0`` with its top two platforms offset by ``+-offset`` along column ``axis``."""
    q = q0.copy()
    q[-2, axis] += offset
    q[-1, axis] -= offset
    return q


def fold_depth(n: int) -> int:
    """Platforms whose sideways folds the default interior-point starts enumerate.

    0 for n <= 4 (the two folded starts of :func:`initial_starts` suffice), 3 at n = 5,
    4 for n = 6-15, 5 for n = 16-31 and 3 again from n = 32: ``2**depth`` extra starts.
    Chosen on random geometries against IPOPT from eight starts and many random starts
    (README, ``benchmarks/bench_quality.py``); from n = 32 on, 4, 5 and 6 found nothing
    better than 3 (12 targets at n = 32, 6 at n = 64, three geometries) at 1.6-5x the time.
    """
    if n <= 4:
        return 0
    if n >= 32:  # each start costs more there, and more patterns found nothing better
        return 3
    return 3 + (n >= 6) + (n >= 16)


def tall_random_starts(n: int) -> int:
    """Random perturbation starts the default interior-point run adds to the fold
    patterns: 5 from n = 32 (``rng``; fixed seed by default), none below. On 12 targets
    at n = 64 (three geometries) the fold patterns alone came within 0.1 % of the best
    FN found on 11, with five random starts added on all 12 (about 0.35 s more)."""
    return 5 if n >= 32 else 0


def fold_patterns(stack: Stack, q0: FloatArray, depth: int) -> list[FloatArray]:
    """Every pattern of sideways folds of the top ``depth`` platforms, as starts.

    The best poses of taller stacks reach toward the target with the lower platforms and
    fold the upper ones around it; which way each upper platform folds is a discrete
    choice that a local solver keeps, so the default interior-point run tries all
    ``2**depth`` sign patterns of a sideways offset ``0.75 (leg_max - leg_min)`` [mm] on
    the top ``depth`` platforms (planar mode).
    """
    n = stack.n
    m = min(depth, n)
    if m <= 0:
        return []
    a = fold_offset(stack)
    out = []
    for code in range(2**m):
        signs = np.array([1.0 if (code >> j) & 1 else -1.0 for j in range(m)])
        q = q0.copy()
        q[n - m :, 0] += a * signs
        out.append(q)
    return out


def reach_fraction(stack: Stack, target: Target) -> float:
    """The target's distance from the base over the stack's nominal height: ``|P| /
    sum(h_i)`` with ``h_i`` :func:`nominal_height` (dimensionless, >= 0; either mode).

    Small values mean compact targets: a few platforms reach the target and the rest coil
    around it, and the FN minima then differ in which way the bottom of the stack bends
    and how the coils turn (many basins a few percent apart, docs/benchmarks.md).
    """
    return float(np.linalg.norm(mode_of(target).position(target)) / np.sum(nominal_height(stack)))


#: Platforms at the bottom of the stack that :func:`arc_starts` bend ...
ARC_PLATFORMS = 8
#: ... and the turn of each [rad].
ARC_TURN = 0.5


def arc_starts(stack: Stack, q0: FloatArray) -> list[FloatArray]:
    """Two planar starts with the bottom of the stack bent one way or the other: ``q0``
    with each of the bottom :data:`ARC_PLATFORMS` platforms turned by ``+-ARC_TURN`` [rad]
    and moved sideways by ``-+`` :func:`fold_offset` [mm] in its own frame (a turn and a
    shift that agree, an arc to the left or to the right).

    Which way the bottom of a tall stack bends toward a compact target is a discrete
    choice that a local solver keeps, and the paper's guess (each platform turning by
    ``theta / n``) and its perturbations nearly always take one of them. ``q0``: shape
    (n, 3); returns two arrays of that shape (left first).
    """
    m = min(ARC_PLATFORMS, stack.n)
    a = fold_offset(stack)
    out = []
    for sign in (1.0, -1.0):
        q = q0.copy()
        q[:m, 2] += sign * ARC_TURN
        q[:m, 0] -= sign * a
        out.append(q)
    return out


#: Yaw of the opposite twists of the top two platforms in :func:`spatial_starts` [rad].
SPATIAL_YAW_FOLDS = (1.2, -1.2, 2.5, -2.5)
#: Tilt of the bottom platform in the leaning starts of :func:`spatial_starts` [rad].
SPATIAL_LEAN = 0.75
#: The spatial structured starts in the order :func:`spatial_starts` returns them (see
#: there): ``q0``; ``twist<yaw>``; ``fold<axis><sign>``; ``lean<deg>`` (toward the
#: azimuth ``deg`` in the base frame); ``leanT<deg>`` (``deg`` from the target's azimuth).
SPATIAL_START_ORDER = (
    "q0", "twist-1.2", "leanT22.5", "lean0", "twist1.2", "leanT45", "leanT-22.5", "lean180",
    "twist-2.5", "leanT-67.5", "leanT0", "leanT67.5", "leanT-45",
    "lean202.5", "lean157.5", "lean315", "lean135", "lean90",
    "twist2.5", "fold0-", "fold0+", "fold1+", "fold1-", "lean270",
)  # fmt: skip


def spatial_starts(stack: Stack, q0: FloatArray, azimuth: float = 0.0) -> list[FloatArray]:
    """The structured starts of the spatial interior point, most useful first (n >= 2).

    The spatial FN minima fold the stack in more ways than the planar ones (measured on
    random reachable targets against IPOPT from 32 starts, ``benchmarks/bench_spatial.py``):

    * sideways folds (``fold<axis><sign>``): the top two platforms offset in opposite
      directions along x or y (``0.75 leg range``, as :func:`initial_starts`);
    * twists (``twist<yaw>``): the top two platforms turned about their normals in
      opposite directions (yaw in :data:`SPATIAL_YAW_FOLDS`; the best poses of about half
      the targets turn them by 1-2.5 rad);
    * leans (n >= 3): the bottom platform tilted by :data:`SPATIAL_LEAN` toward a
      horizontal direction, the middle platforms shifted along it (``1.5 leg range``, and
      ``-100 mm`` in height): the whole stack leaning over and folding back. The
      directions are fixed in the base frame (``lean<deg>``: the hexagonal geometry has
      preferred ones) or relative to the target's azimuth ``azimuth`` (``leanT<deg>``).
      At n = 8 the best known poses of most targets lean so.

    Order (:data:`SPATIAL_START_ORDER`): a greedy cover, most useful first, of the
    targets on which a start reaches the best FN found from a pool of 41 (these and leans
    every 22.5 degrees in both frames), on random reachable targets: the first 8 on 400
    at n = 4 (five seeds; 96.8 % of the targets; five-fold cross-validated 94 %, where the
    previous five structured starts had 89 %), the next 5 and then 5 more on 80 at n = 6
    and 60 at n = 8 (13: 96 % / 95 %, 18: all, where the previous 13 had 81 % / 80 %).
    n = 2 has no leans.

    Parameters
    ----------
    stack : Stack
    q0 : ndarray, shape (n, 6)
        The base pose (the paper's guess); x, y, z [mm], then yaw, pitch, roll [rad].
    azimuth : float
        The target's azimuth ``atan2(y, x)`` [rad], for the ``leanT`` starts.
    """
    n = stack.n
    a = fold_offset(stack)
    shift = 1.5 * float(np.mean(stack.leg_max - stack.leg_min))
    out: dict[str, FloatArray] = {"q0": q0}
    for yaw in SPATIAL_YAW_FOLDS:
        q = q0.copy()
        q[n - 2, 3] += yaw
        q[n - 1, 3] -= yaw
        out[f"twist{yaw:g}"] = q
    for axis in (0, 1):
        for sign in (1.0, -1.0):
            out[f"fold{axis}{'+' if sign > 0 else '-'}"] = _fold_top_two(q0, axis, sign * a)
    if n >= 3:
        for name in SPATIAL_START_ORDER:
            if name.startswith("lean"):
                rel = name.startswith("leanT")
                phi = math.radians(float(name[5 if rel else 4 :])) + (azimuth if rel else 0.0)
                out[name] = _lean(q0, phi, shift)
    return [out[name] for name in SPATIAL_START_ORDER if name in out]


def _lean(q0: FloatArray, phi: float, shift: float) -> FloatArray:
    # pitch (about y) by -t cos(phi) and roll (about x) by t sin(phi) tilt the bottom
    # platform toward (cos phi, sin phi); the middle platforms move that way and down
    q = q0.copy()
    c, s = math.cos(phi), math.sin(phi)
    q[0, 4] -= SPATIAL_LEAN * c
    q[0, 5] += SPATIAL_LEAN * s
    q[1:-1, 0] += shift * c
    q[1:-1, 1] += shift * s
    q[1:-1, 2] -= 100.0
    return q


def spatial_start_count(n: int) -> int:
    """Structured starts the spatial default runs (the first of :func:`spatial_starts`):
    8 up to n = 3, 12 from n = 4 (measured as :func:`spatial_starts` says and below).

    From n = 5 the first 12 and the hops of :data:`SPATIAL_HOPS_N5` replaced the first 18
    and all 12 hops: on 100 design targets at n = 6 and at n = 8 and 50 at n = 16 (seeds
    74200, 76300, 77300, 79300, 91500; best known from IPOPT from 32 starts and every
    method of those runs) within 0.1 % on 97 / 94 / 47 (was 99 / 100 / 49) at 59 / 57 /
    66 % of the iterations. At n = 4 the first 12 replaced the first 8 (with the hops of
    :data:`SPATIAL_HOPS_N4`): 177 of 180 targets of eight sets within 0.1 % (was 175; on
    the two sets drawn after the plan above, seeds 83100 and 84200, 19 and 19 of 20, was 18
    and 18) at 1.3x the iterations; no set of hops instead recovered those misses (all 12
    hops: 175; docs/benchmarks.md, 2026-12-06). At n = 7 and 8 all 12 hops again since
    2026-12-07 (:data:`SPATIAL_ALL_HOPS_NS`)."""
    return 8 if n <= 3 else 12


#: Hops from the best pose of the spatial default's starts (n >= 4): the yaw of the top
#: platforms changed, ``(platforms from the top, yaw [rad])``: ``(1, 2)`` turns the top
#: two in opposite directions, ``(2,)`` only the second from the top, ``(1,)`` only the
#: top one, ``(2, 3)`` the second and third in opposite directions.
SPATIAL_HOPS: tuple[tuple[tuple[int, ...], float], ...] = (
    ((1, 2), 1.2), ((1, 2), -1.2), ((1, 2), 2.5), ((1, 2), -2.5),
    ((2,), 1.2), ((2,), -1.2), ((1,), 1.2), ((1,), -1.2),
    ((2, 3), 2.5), ((2, 3), -2.5), ((2,), 0.6), ((2,), -0.6),
)  # fmt: skip


def spatial_hops(stack: Stack, q: FloatArray) -> list[FloatArray]:
    """Starts near a spatial minimum ``q`` (shape (n, 6)) in the neighbouring basins of its
    upper platforms (:data:`SPATIAL_HOPS`; the default runs those of :func:`spatial_hop_plan`).

    The multistart's best pose usually has the lower platforms of the best known one and
    differs in how the top two or three are turned: on random reachable targets with the
    best known FN from IPOPT from 48 starts, these 12 hops from the default's pose raised
    the share within 0.1 % of the best from 75 / 65 % to 90 / 95 % (n = 8, two sets of 20
    targets) and from 73 % to all 30 (n = 6).
    """
    n = stack.n
    return [_turned(q, tops, yaw) for tops, yaw in SPATIAL_HOPS if max(tops) <= n]


def spatial_default_hops(stack: Stack, q: FloatArray) -> list[FloatArray]:
    """The spatial default's hops from its best pose ``q``: the entries of
    :data:`SPATIAL_HOPS` that :func:`spatial_hop_plan` names (n >= 4, where every entry
    applies)."""
    return [_turned(q, *SPATIAL_HOPS[i]) for i in spatial_hop_plan(stack.n)]


def _turned(q: FloatArray, tops: tuple[int, ...], yaw: float) -> FloatArray:
    """``q`` with the yaw of the platform ``tops[0]`` from the top turned by ``yaw`` and
    of the others by ``-yaw`` (one entry of :data:`SPATIAL_HOPS`)."""
    n = q.shape[0]
    h = q.copy()
    for k, top in enumerate(tops):
        h[n - top, 3] += yaw if k == 0 else -yaw
    return h


def spatial_hop_count(n: int) -> int:
    """How many hops the spatial default runs from its best pose (and the obstacle and
    force rules' search without rows, :func:`stackik.solve.stages._rows_first`): none up
    to n = 3, 6 from n = 4, 12 at n = 7 and 8 (:func:`spatial_hop_plan` says which)."""
    return len(spatial_hop_plan(n))


#: The hops (indices into :data:`SPATIAL_HOPS`) of the spatial default at n = 4: the top
#: two turned both ways by 1.2 rad, the second and third by 2.5 rad, the second alone by
#: 0.6 rad. On four sets of 20 targets (seeds 74200, 76300, 77300, 91500) the eight
#: starts alone were within 0.1 % of the best known on 19, 19, 19 and 20; with these six
#: hops on 20 each (the first four hops alone: 20, 19, 19; the last four: 19, 20, 20;
#: all twelve: 20 each, at twice these six's cost). With 12 starts, on eight sets (180
#: targets): 177 with these, 176 with :data:`SPATIAL_HOPS_N5`, 176 with hops 0, 1, 10, 11,
#: 175 with none.
SPATIAL_HOPS_N4 = (0, 1, 8, 9, 10, 11)

#: The hops of the spatial default from n = 5: the top two turned both ways by 1.2 and by
#: 2.5 rad, the top one alone by 1.2 rad, the second alone by -0.6 rad. At n = 8 a hop
#: reached a lower basin than the 18 starts on 15 of 50 design targets (seeds 91500,
#: 77300, 74200), the top two turned by 2.5 rad on 8 of them. With the first 12 starts,
#: 100 design targets each (seeds 74200, 76300, 77300, 79300, 91500): n = 6 97 within
#: 0.1 % (96 with hops 0-3, 97 with all 12), n = 8 94 (89 with hops 0-3, 99 with all 12
#: at 1.3x these six's iterations), n = 16 47 of 50 (47 with all 12; the three misses
#: are the starts').
SPATIAL_HOPS_N5 = (0, 1, 2, 3, 6, 11)

#: The stack sizes where the spatial default runs all 12 hops instead of
#: :data:`SPATIAL_HOPS_N5`. On the design targets above, n = 8 99 of 100 within 0.1 %
#: against 94 (n = 6 97 either way, n = 16 47 of 50 either way; n = 7 not measured, taken
#: with 8). On fresh seed 268234 (40 targets each, best known with IPOPT from 128 starts
#: and both plans): n = 8 35 against 33 of 40, at 1.40x the wall time (12.8x IPOPT-8's
#: against 17.4x); n = 6 37 of 40 either way, at 1.32x (docs/benchmarks.md, 2026-12-07).
SPATIAL_ALL_HOPS_NS = (7, 8)


def spatial_hop_plan(n: int) -> tuple[int, ...]:
    """Which of :data:`SPATIAL_HOPS` the spatial default runs from its best pose (indices
    into :func:`spatial_hops`' list): none up to n = 3, :data:`SPATIAL_HOPS_N4` at n = 4,
    all twelve at the sizes of :data:`SPATIAL_ALL_HOPS_NS`, :data:`SPATIAL_HOPS_N5`
    otherwise."""
    if n <= 3:
        return ()
    if n == 4:
        return SPATIAL_HOPS_N4
    return tuple(range(len(SPATIAL_HOPS))) if n in SPATIAL_ALL_HOPS_NS else SPATIAL_HOPS_N5


class StartSampler:
    """Random starts around a base pose ``q0`` (Gaussian, :meth:`Mode.perturbation`).

    The generator is made on the first draw: ``rng=None`` means a fixed seed (0), so the
    same call always returns the same pose, and calls that need no random start pay
    nothing. Draws come in call order, whichever stage asks. ``q0`` (shape (n, k)) may be
    set after construction (the request validates ``rng`` before it builds the start).
    """

    def __init__(
        self, stack: Stack, mode: Mode, rng: object = None, q0: FloatArray | None = None
    ) -> None:
        self.stack, self.mode = stack, mode
        self.q0 = np.zeros((stack.n, mode.k)) if q0 is None else q0
        self._gen: np.random.Generator | None = None
        if rng is not None:
            try:
                self._gen = np.random.default_rng(rng)  # type: ignore[arg-type]
            except (TypeError, ValueError) as exc:
                raise ValueError(
                    f"rng: expected None, an int seed or a numpy Generator ({exc})"
                ) from None

    def draw(self) -> FloatArray:
        """One random start, shape (n, k)."""
        return self.draw_around(self.q0)

    def draw_around(self, q: FloatArray) -> FloatArray:
        """One random start around the pose ``q`` (shape (n, k)) instead of ``q0``, from
        the same generator (the same draws in call order)."""
        if self._gen is None:
            self._gen = np.random.default_rng(0)
        n, k = self.stack.n, self.mode.k
        pert = self.mode.perturbation(self.stack)
        return q + (self._gen.standard_normal(n * k) * pert).reshape(n, k)  # type: ignore[no-any-return]
