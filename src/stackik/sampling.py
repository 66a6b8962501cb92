"""Random stacks, feasible poses and reachable targets: the one source of random cases.

Tests, benchmarks and the workspace study (:mod:`stackik.analysis.workspace`, which
re-exports the target samplers) draw their random cases here, so a given seed means the
same stack or targets everywhere. Every function takes ``rng``: a
:class:`numpy.random.Generator`, an int seed or None (fresh entropy), passed through
:func:`numpy.random.default_rng`, so an int seed always gives the same draws.

Units: millimetres and radians. Planar poses have shape ``(n, 3)`` with rows
``[rho_i, z_i, theta_i]``; spatial poses ``(n, 6)`` with rows ``[x, y, z, yaw, pitch,
roll]`` (``docs/conventions.md``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from stackik.geometry import PlatformGeometry, Stack
from stackik.kinematics import planar_forward, spatial_forward
from stackik.rotations import plane_axis
from stackik.targets import PlanarTarget, SpatialTarget

__all__ = [
    "platform_box",
    "random_feasible_poses",
    "random_planar_targets",
    "random_reachable_targets",
    "random_spatial_targets",
    "random_stack",
    "uniform_reachable_targets",
]

FloatArray = NDArray[np.float64]
#: What every ``rng`` argument accepts (see :func:`numpy.random.default_rng`).
RNG = np.random.Generator | int | None


# =========================================================================================
# Stacks
# =========================================================================================
def random_stack(n: int, rng: RNG = None) -> Stack:
    """A stack of ``n`` different asymmetric platforms (tests and the benchmark of other
    geometries).

    Each platform is a hexagonal layout with random radii (base 140-190 mm, top
    110-160 mm), half-angles (8-22 deg), leg ranges (min 230-270 mm, max 420-480 mm) and
    joint limits (15-25 deg), whose base nodes are then moved by up to 5 mm in the plane
    (Gaussian, sigma 2 mm, clipped).

    Parameters
    ----------
    n : int
        Number of platforms.
    rng : Generator, int or None
        Random source; an int seed gives the same stack every time.

    Returns
    -------
    Stack
        ``n`` platforms, bottom first.
    """
    gen = np.random.default_rng(rng)
    out = []
    for _ in range(n):
        g = PlatformGeometry.hexagonal(
            base_radius=float(gen.uniform(140, 190)),
            top_radius=float(gen.uniform(110, 160)),
            base_half_angle=float(np.radians(gen.uniform(8, 22))),
            top_half_angle=float(np.radians(gen.uniform(8, 22))),
            leg_min=float(gen.uniform(230, 270)),
            leg_max=float(gen.uniform(420, 480)),
            joint_min=float(np.radians(gen.uniform(15, 25))),
        )
        base = g.base_nodes + np.clip(gen.normal(0, 2, (6, 3)), -5, 5) * [1, 1, 0]
        out.append(PlatformGeometry(base, g.top_nodes, g.leg_min, g.leg_max, g.joint_min))
    return Stack(tuple(out))


# =========================================================================================
# Planar poses and targets
# =========================================================================================
def random_feasible_poses(
    stack: Stack,
    count: int,
    rng: RNG = None,
    phi: float = 0.0,
    box: Sequence[tuple[float, float]] | None = None,
    batch: int = 4096,
) -> FloatArray:
    """Random feasible planar poses by per-platform rejection sampling.

    Every platform's ``(rho_i, z_i, theta_i)`` is drawn uniformly in ``box`` and kept
    when its 24 limits hold; the limits of one platform depend on its own variables only,
    so platforms are drawn independently.

    Parameters
    ----------
    stack : Stack
    count : int
        Number of poses.
    rng : Generator, int or None
        Random source.
    phi : float
        Plane azimuth [rad] (the 3D limits depend on it).
    box : sequence of 3 (low, high) pairs, optional
        Sampling box of ``(rho_i, z_i, theta_i)`` [mm, mm, rad]; default
        ``(+-0.6 leg_max, (0.3 leg_min, leg_max), +-0.8 rad)`` of the largest platform
        (:func:`platform_box` contains every feasible pose).
    batch : int
        Candidates drawn per round.

    Returns
    -------
    q : ndarray, shape (count, n, 3)
        Feasible poses, rows ``[rho_i, z_i, theta_i]`` [mm, mm, rad].

    Raises
    ------
    RuntimeError
        If after 10,000 rounds fewer than 1 in 10,000 candidates were feasible (a box that
        misses the feasible set); otherwise sampling goes on until ``count`` are drawn.
    """
    gen = np.random.default_rng(rng)
    n = stack.n
    if box is None:
        lmax, lmin = float(np.max(stack.leg_max)), float(np.min(stack.leg_min))
        box = [(-0.6 * lmax, 0.6 * lmax), (0.3 * lmin, lmax), (-0.8, 0.8)]
    lo = np.array([b[0] for b in box], dtype=float)
    hi = np.array([b[1] for b in box], dtype=float)
    pools: list[list[FloatArray]] = [[] for _ in range(n)]
    have = np.zeros(n, dtype=int)
    maybe_feasible = _mean_leg_filter(stack, phi)
    alone = [Stack((stack[i],)) for i in range(n)]  # one platform's limits at a time
    rounds = 0
    while not np.all(have >= count):
        rounds += 1
        if rounds > 10_000 and have.min() < 1e-4 * batch * rounds:
            # under 1 feasible in 10,000 candidates: a box that misses the feasible set
            raise RuntimeError("random_feasible_poses: too few feasible samples in the box")
        cand = lo + (hi - lo) * gen.random((batch, n, 3))
        maybe = maybe_feasible(cand)  # (batch, n): a necessary condition, cheap
        for i in range(n):
            if have[i] < count:
                rows = np.flatnonzero(maybe[:, i])
                c = alone[i].planar_constraints(cand[rows, i : i + 1], phi)[:, 0]
                good = cand[rows[np.all(c >= 0.0, axis=-1)], i]
                pools[i].append(good)
                have[i] += good.shape[0]
    return np.stack([np.concatenate(p)[:count] for p in pools], axis=1)


def _mean_leg_filter(stack: Stack, phi: float) -> Callable[[FloatArray], NDArray[np.bool_]]:
    """A cheap necessary condition for a planar platform pose to be feasible.

    The mean ``m = R t_mean + P - b_mean`` of a platform's six leg vectors obeys
    ``|m| <= leg_max`` (triangle inequality) and, because every leg lies in the convex
    cones ``l.e_z >= |l| sin(joint_min)`` and ``l.(R e_z) >= |l| sin(joint_min)`` with
    ``|l| >= leg_min``, ``m.e_z`` and ``m.(R e_z)`` are both at least
    ``sin(joint_min) max(|m|, leg_min)``. About 10 % of the candidates in
    :func:`platform_box` pass (1.5-2 % are feasible); only those get the 24 exact limits.
    The test has a relative slack of 1e-6, so rounding never rejects a feasible pose,
    and the exact limits decide: the samples are those of the exact test alone.

    Returns a function ``cand (batch, n, 3) -> (batch, n)`` of bools.
    """
    # In the frame (e_phi, s, e_z) of the plane: R t = t_par + cos t_perp + sin (s x t),
    # and R e_z = cos e_z - sin e_phi (s x e_z = -e_phi); the s component of m is fixed.
    s = plane_axis(phi)
    e_phi = np.array([np.cos(phi), np.sin(phi), 0.0])
    t_mean = stack.top_nodes.mean(axis=1)  # (n, 3)
    b_mean = stack.base_nodes.mean(axis=1)
    t_par = (t_mean @ s)[:, None] * s
    t_perp = t_mean - t_par
    t_cross = np.cross(s, t_mean)
    a_u, b_u, d_u = (t_par - b_mean) @ e_phi, t_perp @ e_phi, t_cross @ e_phi  # (n,)
    a_w, b_w, d_w = (t_par - b_mean)[:, 2], t_perp[:, 2], t_cross[:, 2]
    v2 = ((t_mean - b_mean) @ s) ** 2
    tol = 1e-6
    lmax2 = (np.asarray(stack.leg_max, dtype=float) * (1.0 + tol)) ** 2
    lmin = np.asarray(stack.leg_min, dtype=float)
    sj = np.asarray(stack.sin_joint_min, dtype=float) * (1.0 - tol)

    def maybe(cand: FloatArray) -> NDArray[np.bool_]:
        c, sn = np.cos(cand[..., 2]), np.sin(cand[..., 2])
        u = a_u + c * b_u + sn * d_u + cand[..., 0]  # m . e_phi
        w = a_w + c * b_w + sn * d_w + cand[..., 1]  # m . e_z
        norm2 = u * u + w * w + v2
        floor = sj * np.sqrt(np.maximum(norm2, lmin * lmin)) - tol
        return (norm2 <= lmax2) & (w >= floor) & (c * w - sn * u >= floor)  # type: ignore[no-any-return]

    return maybe


def random_reachable_targets(
    stack: Stack,
    count: int,
    rng: RNG = None,
    phi: float = 0.0,
    box: Sequence[tuple[float, float]] | None = None,
) -> list[PlanarTarget]:
    """Reachable planar targets: forward kinematics of :func:`random_feasible_poses`.

    They cluster where the stack reaches most easily (see
    :func:`uniform_reachable_targets` for an even spread).

    Parameters
    ----------
    stack : Stack
    count : int
        Number of targets.
    rng : Generator, int or None
        Random source.
    phi : float
        Plane azimuth [rad] of the poses and of the targets.
    box : sequence of 3 (low, high) pairs, optional
        Sampling box of the poses (:func:`random_feasible_poses`).

    Returns
    -------
    list of PlanarTarget
        ``count`` targets ``(rho [mm], z [mm], theta [rad])`` in the plane ``phi``.
    """
    y = planar_forward(random_feasible_poses(stack, count, rng, phi, box))
    return [PlanarTarget(rho=float(a), z=float(b), theta=float(c), phi=phi) for a, b, c in y]


def platform_box(stack: Stack) -> list[tuple[float, float]]:
    """A ``(rho_i, z_i, theta_i)`` box containing every feasible pose of every platform.

    From the limits alone: a leg is at most ``leg_max`` long and joins nodes at most
    ``r_b`` and ``r_t`` from their plate centres, so ``|P| <= r_b + leg_max + r_t`` and
    ``z >= -r_t``; both joint-angle limits keep every leg within ``90 deg - joint_min``
    of each plate normal, so the plates tilt by at most ``180 deg - 2 joint_min``.

    Returns
    -------
    list of 3 (low, high) pairs
        ``[(rho_lo, rho_hi), (z_lo, z_hi), (theta_lo, theta_hi)]`` [mm, mm, rad].
    """
    r_b = float(np.max(np.linalg.norm(stack.base_nodes, axis=-1)))
    r_t = float(np.max(np.linalg.norm(stack.top_nodes, axis=-1)))
    lmax = float(np.max(stack.leg_max))
    tilt = float(np.pi - 2.0 * np.min(np.arcsin(stack.sin_joint_min)))
    reach = r_b + lmax + r_t
    return [(-reach, reach), (-r_t, lmax + r_t), (-tilt, tilt)]


def uniform_reachable_targets(
    stack: Stack,
    count: int,
    rng: RNG = None,
    phi: float = 0.0,
    cell: float = 100.0,
    pool: int | None = None,
) -> list[PlanarTarget]:
    """Reachable planar targets spread evenly over the reachable ``(rho, z)`` region.

    ``pool`` random feasible poses (:func:`random_feasible_poses` in :func:`platform_box`,
    default ``max(2000, min(50 count, 10 count + 500000))``) give reachable targets by
    forward kinematics; the ``(rho, z)`` plane is cut into ``cell`` x ``cell`` mm squares
    and targets are taken one per occupied square, the squares in a random order, round
    after round, until ``count`` are chosen. The result is close to uniform over the
    reachable region (at the resolution of ``cell``) instead of piling up where random poses
    land most often; theta keeps its distribution within a square.

    Parameters
    ----------
    stack : Stack
    count : int
        Number of targets (>= 1).
    rng : Generator, int or None
        Random source.
    phi : float
        Plane azimuth [rad].
    cell : float
        Side of the squares [mm] (> 0).
    pool : int, optional
        Number of random feasible poses to choose from.

    Returns
    -------
    list of PlanarTarget
        ``count`` targets ``(rho [mm], z [mm], theta [rad])`` in the plane ``phi``.
    """
    if count < 1:
        raise ValueError("count must be >= 1")
    if not cell > 0.0:
        raise ValueError("cell must be > 0")
    gen = np.random.default_rng(rng)
    # 50 candidate poses per target, at most 10 per target beyond 12,500 targets (a
    # 100,000-target study draws 1.5 million poses, not 5 million)
    size = (
        max(2000, min(50 * count, 10 * count + 500_000)) if pool is None else max(int(pool), count)
    )
    y = planar_forward(random_feasible_poses(stack, size, gen, phi, platform_box(stack)))
    perm = gen.permutation(size)
    key = np.floor(y[perm, :2] / cell).astype(np.int64)
    cell_id = np.unique(key, axis=0, return_inverse=True)[1].ravel()
    cell_rank = gen.permutation(int(cell_id.max()) + 1)[cell_id]  # random order of squares
    order = np.argsort(cell_id, kind="stable")
    starts = np.flatnonzero(np.r_[True, np.diff(cell_id[order]) != 0])
    occurrence = np.empty(size, dtype=np.int64)  # round in which a target is taken
    occurrence[order] = np.arange(size) - np.repeat(starts, np.diff(np.r_[starts, size]))
    chosen = perm[np.lexsort((cell_rank, occurrence))[:count]]
    return [
        PlanarTarget(rho=float(a), z=float(b), theta=float(c), phi=phi) for a, b, c in y[chosen]
    ]


def random_planar_targets(
    stack: Stack,
    count: int,
    rng: RNG = None,
    phis: Sequence[float] = (0.0,),
) -> list[PlanarTarget]:
    """Reachable planar targets shared out over several planes (the benchmark's targets).

    The ``count`` targets are shared out as evenly as possible over the planes ``phis``
    (the first planes get one more when it does not divide evenly), each plane's from
    :func:`random_reachable_targets`, in the order of ``phis``.

    Parameters
    ----------
    stack : Stack
    count : int
        Number of targets (>= 0).
    rng : Generator, int or None
        Random source. An int seed ``s`` draws the targets of the i-th plane with seed
        ``s + i`` (as the benchmarks always have); a Generator, or fresh entropy for None,
        is used for the planes in turn.
    phis : sequence of float
        Plane azimuths [rad] (at least one).

    Returns
    -------
    list of PlanarTarget
        ``count`` targets ``(rho [mm], z [mm], theta [rad], phi [rad])``.
    """
    if count < 0:
        raise ValueError("count must be >= 0")
    if len(phis) == 0:
        raise ValueError("phis must not be empty")
    m = len(phis)
    per = [count // m + (i < count % m) for i in range(m)]
    seed = int(rng) if isinstance(rng, int | np.integer) else None
    gen = None if seed is not None else np.random.default_rng(rng)
    out: list[PlanarTarget] = []
    for i, (phi, k) in enumerate(zip(phis, per, strict=True)):
        if k:
            source = seed + i if seed is not None else gen
            out += random_reachable_targets(stack, k, rng=source, phi=float(phi))
    return out


# =========================================================================================
# Spatial targets
# =========================================================================================
def random_spatial_targets(
    stack: Stack, count: int, rng: RNG = None, max_draws: int = 1_000_000
) -> list[SpatialTarget]:
    """Reachable spatial targets: forward kinematics of random feasible spatial poses.

    Poses are drawn one at a time, every platform's ``(x, y)`` uniformly in
    ``[-60, 60]`` mm, ``z`` in ``[260, 420]`` mm and ``(yaw, pitch, roll)`` in
    ``[-0.25, 0.25]`` rad, and kept when all limits hold.

    Parameters
    ----------
    stack : Stack
    count : int
        Number of targets.
    rng : Generator, int or None
        Random source.
    max_draws : int
        Poses to try before giving up.

    Returns
    -------
    list of SpatialTarget
        ``count`` targets: end-effector position, shape (3,) [mm], and rotation matrix,
        shape (3, 3).

    Raises
    ------
    RuntimeError
        If ``max_draws`` poses give fewer than ``count`` feasible ones.
    """
    gen = np.random.default_rng(rng)
    out: list[SpatialTarget] = []
    n = stack.n
    for _ in range(max_draws):
        if len(out) >= count:
            break
        q = np.column_stack(
            [
                gen.uniform(-60, 60, (n, 2)),
                gen.uniform(260, 420, n),
                gen.uniform(-0.25, 0.25, (n, 3)),
            ]
        )
        if stack.spatial_constraints(q).min() >= 0:
            P, R = spatial_forward(q)
            out.append(SpatialTarget(P, R))
    else:
        if len(out) < count:
            raise RuntimeError(
                f"random_spatial_targets: {len(out)} of {count} feasible poses in {max_draws} draws"
            )
    return out
