"""``method="ipopt"``: IPOPT through CasADi (optional extra ``stackik[ipopt]``), planar and
spatial targets.

The same scaled problem as :class:`stackik.formulation.Problem` is written symbolically so that
IPOPT gets exact first and second derivatives from CasADi's automatic differentiation.
Solvers are built once per (stack, phi, objective) (planar) or (stack, objective) (spatial)
and cached; the target is a parameter, so timing a solve excludes the symbolic set-up.

Spatial mode: ``R_i = Rz(yaw) Ry(pitch) Rx(roll)``, the chain ``O_{i+1} = O_i + A_i p_i``,
``A_{i+1} = A_i R_i``; FN^2 exactly as :meth:`Problem.objective_value` (``c0`` plus the
weighted squared position derivatives ``w_a x (P_ee - O_{i+1})`` of every angle column);
the 24 limits per platform with :class:`Problem`'s scaling, then (when the problem carries
them, ``prob.self_legs``) the self-leg rows of :mod:`stackik._compiled.self_legs` written
symbolically (:func:`_self_leg_rows`), then (with obstacles, planar and spatial) the obstacle
rows of :mod:`stackik.formulation.obstacle_rows` (:func:`_obstacle_rows`), then (when a solve
gave the problem some, :mod:`stackik.formulation.leg_pairs`) the rows for bodies of
non-adjacent platforms (:func:`_pair_rows`, both modes). The orientation equality is
the skew part ``vee(E - E^T) / 2 = sin(angle) axis`` of ``E = R_target^T R_ee``: smooth
everywhere (the rotation vector's ``acos`` is not differentiable at the solution), equal to
the rotation vector to third order at ``E = I``, so first and second derivatives agree
there and the KKT points with ``E = I`` are the same. Its spurious zeros (half turns,
``trace E = -1``) fail the independent check like any other bad pose.
"""

from __future__ import annotations

import math
import time
from functools import lru_cache
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from stackik.formulation import Problem
from stackik.geometry import Stack
from stackik.methods.base import Method
from stackik.result import OptionError
from stackik.rotations import plane_axis
from stackik.targets import PlanarTarget, SpatialTarget

FloatArray = NDArray[np.float64]

__all__ = ["IpoptMethod", "ipopt_available", "run_ipopt"]


def ipopt_available() -> bool:
    """True when CasADi (with its bundled IPOPT) can be imported."""
    try:
        import casadi  # noqa: F401
    except ImportError:
        return False
    return True


def _casadi() -> Any:
    """The casadi module, or a ValueError saying how to install it."""
    try:
        import casadi
    except ImportError:
        raise ValueError(
            'method "ipopt" needs CasADi: pip install "stackik[ipopt]" (or casadi)'
        ) from None
    return casadi


def _nlpsol(ca: Any, name: str, nlp: dict[str, Any], user: tuple[tuple[str, Any], ...]) -> Any:
    """``casadi.nlpsol`` with IPOPT; options IPOPT rejects become an OptionError."""
    try:
        return ca.nlpsol(name, "ipopt", nlp, _ipopt_options(user))
    except RuntimeError as exc:  # e.g. "No such IPOPT option"
        msg = str(exc).strip().splitlines()[-1]
        raise OptionError(f"options: IPOPT rejected them ({msg})") from None


def _force_equilibrium(
    ca: Any, stack: Stack, load: Any, O: list[Any], A: list[Any], sf: Any
) -> list[Any]:
    """Equilibrium equalities of the lifted leg forces (the loads issue's lifted form,
    written apart from :mod:`stackik.loads` and :mod:`stackik.formulation.forces`, which
    eliminate the forces): for each platform i with a finite ``force_max``, the body above
    its legs is in equilibrium in the **base frame**, moments about the base origin,

        sum_k f_k u_k + F_i = 0,    sum_k T_k x (f_k u_k) + M_i = 0,

    with ``f_k = force_max_i sf_k`` (``sf``: the scaled forces, bounds [-1, 1]),
    compression positive (leg k pushes its top joint ``T_k`` along the unit leg vector
    ``u_k`` from its bottom joint), ``F_i, M_i`` the weight of every mass above the cut
    (plates i..n at their origins, leg halves at their joints, the payload at the end
    effector plus its offset) and the external wrench. Rows divided by ``force_max_i``
    (forces) and ``force_max_i r_i`` (moments, ``r_i`` the largest top-node radius).
    ``O[j]``, ``A[j]``: origin [mm] and orientation of plate j (0 = base), symbolic."""
    n = stack.n
    fmax = np.asarray(stack.force_max, dtype=float)
    g = np.asarray(load.g, dtype=float)
    half = 0.5 * np.asarray(stack.leg_mass, dtype=float)
    T = [[O[i + 1] + A[i + 1] @ stack.top_nodes[i, k] for k in range(6)] for i in range(n)]
    B = [[O[i] + A[i] @ stack.base_nodes[i, k] for k in range(6)] for i in range(n)]
    F_ext = np.asarray(load.force, dtype=float)
    M_ext = np.asarray(load.moment, dtype=float) * 1000.0  # N m -> N mm
    if load.frame == "end_effector":
        F_ext, M_ext = A[n] @ F_ext, A[n] @ M_ext
    ee = O[n]
    rows: list[Any] = []
    col = 0
    for i in np.flatnonzero(np.isfinite(fmax)):
        # the masses above platform i's legs: (kg, position)
        masses: list[tuple[float, Any]] = [(float(half[i]), T[i][k]) for k in range(6)]
        for j in range(i, n):
            masses.append((float(stack.plate_mass[j]), O[j + 1]))
        for j in range(i + 1, n):
            masses += [(float(half[j]), T[j][k]) for k in range(6)]
            masses += [(float(half[j]), B[j][k]) for k in range(6)]
        masses.append((float(load.mass), O[n] + A[n] @ np.asarray(load.com, dtype=float)))
        force: Any = F_ext + sum(m for m, _ in masses) * g
        moment: Any = M_ext + ca.cross(ee, F_ext)
        for m, r in masses:
            if m != 0.0:
                moment = moment + ca.cross(r, m * g)
        for k in range(6):
            leg = T[i][k] - B[i][k]
            fk = fmax[i] * sf[col + k] * leg / ca.sqrt(ca.dot(leg, leg))
            force = force + fk
            moment = moment + ca.cross(T[i][k], fk)
        col += 6
        arm = float(np.linalg.norm(stack.top_nodes[i], axis=1).max())
        rows += [force / fmax[i], moment / (fmax[i] * arm)]
    return rows


def _lift_forces(ca: Any, stack: Stack, load: Any) -> tuple[Any, int]:
    """The scaled force variables of the platforms with a finite ``force_max`` (or None)."""
    m = 6 * int(np.isfinite(stack.force_max).sum()) if load is not None else 0
    return (ca.SX.sym("sf", m) if m else None), m


def _clamp01(ca: Any, v: Any) -> Any:
    return ca.fmin(ca.fmax(v, 0.0), 1.0)


def _closest_params(ca: Any, p0: Any, p1: Any, q0: Any, q1: Any) -> tuple[Any, Any]:
    """Symbolic :func:`stackik._compiled.self_legs.closest_params`: the same branches
    (degenerate segments, the parallel case, ``t`` clamped with ``s`` recomputed), as
    ``if_else`` so that CasADi differentiates through the active branch. Every division
    has a guarded denominator, so no branch makes a NaN in value or derivative."""
    from stackik._compiled.self_legs import _PARALLEL

    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a, e = ca.dot(d1, d1), ca.dot(d2, d2)
    f, c, b = ca.dot(d2, r), ca.dot(d1, r), ca.dot(d1, d2)
    den = a * e - b * b
    a_ = ca.if_else(a > 0.0, a, 1.0)
    e_ = ca.if_else(e > 0.0, e, 1.0)
    skew = den > _PARALLEL * a * e
    den_ = ca.if_else(skew, den, 1.0)
    s = ca.if_else(skew, _clamp01(ca, (b * f - c * e) / den_), 0.0)
    t = (b * s + f) / e_
    s = ca.if_else(
        t < 0.0, _clamp01(ca, -c / a_), ca.if_else(t > 1.0, _clamp01(ca, (b - c) / a_), s)
    )
    t = _clamp01(ca, t)
    # degenerate segments (a point): the kernel's first three branches
    s_pt_q = _clamp01(ca, -c / a_)  # q is a point
    t_pt_p = _clamp01(ca, f / e_)  # p is a point
    s = ca.if_else(a <= 0.0, 0.0, ca.if_else(e <= 0.0, s_pt_q, s))
    t = ca.if_else(a <= 0.0, ca.if_else(e <= 0.0, 0.0, t_pt_p), ca.if_else(e <= 0.0, 0.0, t))
    return s, t


def _self_leg_rows(
    ca: Any, base: Any, T: list[Any], pairs: Any, rho: float, scale: float
) -> list[Any]:
    """One platform's self-leg rows ``(|P - Q|^2 - rho^2) / scale`` (lower bound 0), ``P``,
    ``Q`` the closest points of the leg axes ``base[k] -> T[k]`` and ``base[l] -> T[l]``
    (platform frame) for each pair (k, l) of ``pairs``."""
    rows = []
    for k, m in np.asarray(pairs):
        s, t = _closest_params(ca, base[k], T[k], base[m], T[m])
        g = base[k] + s * (T[k] - base[k]) - base[m] - t * (T[m] - base[m])
        rows.append((ca.dot(g, g) - rho * rho) / scale)
    return rows


def _self_leg_key(prob: Problem) -> Any:
    """The self-leg rows of ``prob`` as a solver cache key ``(pairs, rho, scale)``, or None."""
    sl = prob.self_legs
    if sl is None:
        return None
    pairs = tuple((int(a), int(b)) for a, b in sl.pairs)
    return (pairs, tuple(map(float, sl.rho)), tuple(map(float, sl.scale)))


def pair_key(prob: Problem) -> Any:
    """The rows of ``prob`` for bodies of non-adjacent platforms as plain data (a solver
    cache key): ``(rows, L)``, each row ``(plates of a, ends of a, plates of b, ends of b,
    rho)`` (:class:`stackik.formulation.leg_pairs.LegPairRows`), or None without them."""
    rows = prob.clearance.leg_pairs
    if rows is None:
        return None
    plates, points, pairs, rho, L = rows.kernel_args

    def seg(e: int) -> tuple[Any, ...]:
        return (tuple(map(int, plates[e])), tuple(tuple(map(float, x)) for x in points[e]))

    key = tuple((*seg(int(a)), *seg(int(b)), float(r)) for (a, b), r in zip(pairs, rho))
    return key, float(L)


def _pair_rows(ca: Any, Os: list[Any], As: list[Any], key: Any) -> list[Any]:
    """:class:`stackik.formulation.leg_pairs.LegPairRows` written symbolically (the kernel
    :func:`stackik._compiled.leg_pairs.segment_pair_rows`): per pair of segments
    (:func:`pair_key`) ``(d^2 - rho^2) / L^2``, ``d`` at the closest points of
    :func:`_closest_params` (the kernel's branches)."""
    pairs, L = key
    rows = []
    for pa, xa, pb, xb, rho in pairs:
        a0, a1 = (Os[p] + As[p] @ np.asarray(x) for p, x in zip(pa, xa))
        b0, b1 = (Os[p] + As[p] @ np.asarray(x) for p, x in zip(pb, xb))
        s, t = _closest_params(ca, a0, a1, b0, b1)
        g = a0 + s * (a1 - a0) - (b0 + t * (b1 - b0))
        rows.append((ca.dot(g, g) - rho**2) / L**2)
    return rows


def pair_function(prob: Problem) -> Any:
    """A CasADi function of the raw spatial pose ``q`` (6 n,) [mm, rad] to the rows of
    ``prob`` for bodies of non-adjacent platforms, as the IPOPT solver carries them (for
    the tests)."""
    ca = _casadi()
    q, Os, As = _spatial_frames_sx(ca, prob.n)
    return ca.Function("pair_rows", [q], [ca.vertcat(*_pair_rows(ca, Os, As, pair_key(prob)))])


def _spatial_frames_sx(ca: Any, n: int) -> tuple[Any, list[Any], list[Any]]:
    """A symbolic raw spatial pose ``q`` (6 n,) and its plate origins ``O_0..O_n`` and
    rotations ``A_0..A_n`` (for the tests' CasADi functions of single row families)."""
    q = ca.SX.sym("q", 6 * n)
    Os: list[Any] = [ca.SX.zeros(3, 1)]
    As: list[Any] = [ca.SX.eye(3)]
    for i in range(n):
        _, R = _euler_sx(ca, q[6 * i + 3 : 6 * i + 6])
        Os.append(Os[-1] + As[-1] @ q[6 * i : 6 * i + 3])
        As.append(As[-1] @ R)
    return q, Os, As


def obstacle_key(prob: Problem) -> Any:
    """The obstacle rows of ``prob`` as plain data (a solver cache key,
    :attr:`stackik.formulation.obstacle_rows.ObstacleRows.specs`), or None without rows."""

    rows = prob.clearance.obstacle_rows
    return None if rows is None else rows.specs


def obstacle_function(stack: Stack, obstacles: Any, margin: float) -> Any:
    """A CasADi function of the raw spatial pose ``q`` (6 n,) [mm, rad] to the obstacle
    rows the IPOPT solver carries (:func:`_obstacle_rows`; ``obstacles`` those with rows),
    in the order of :class:`stackik.formulation.obstacle_rows.ObstacleRows` (for the
    tests)."""
    ca = _casadi()
    q, Os, As = _spatial_frames_sx(ca, stack.n)
    from stackik.formulation.obstacle_rows import ObstacleRows

    specs = ObstacleRows(stack, tuple(obstacles), margin).specs
    rows = _obstacle_rows(ca, stack, Os, As, specs)
    return ca.Function("obstacle_rows", [q], [ca.vertcat(*rows)])


def _obstacle_rows(ca: Any, stack: Stack, Os: list[Any], As: list[Any], key: Any) -> list[Any]:
    """:class:`stackik.formulation.obstacle_rows.ObstacleRows` written symbolically: every
    leg (base joint ``O_i + A_i b_k`` to top joint ``O_{i+1} + A_{i+1} t_k``, radius
    ``leg_radius``) against each obstacle of ``key`` (:func:`obstacle_key`), in its order:
    the legs' rows per sphere or capsule, then per half-space the base joints' and the top
    joints' rows."""
    from stackik.formulation.obstacle_rows import joint_radii, plate_polygons

    margin, obstacles = key
    n = stack.n
    L = float(stack.leg_max.max())
    B = [Os[i] + As[i] @ stack.base_nodes[i, k] for i in range(n) for k in range(6)]
    T = [Os[i + 1] + As[i + 1] @ stack.top_nodes[i, k] for i in range(n) for k in range(6)]
    r = [float(stack[i].leg_radius) for i in range(n) for _ in range(6)]
    jr = joint_radii(stack)
    rows: list[Any] = []
    for ob in obstacles:
        if ob[0] == "half":
            p, u = np.asarray(ob[1]), np.asarray(ob[2])
            for side, X in enumerate((B, T)):
                rows += [(ca.dot(u, X[j] - p) - jr[side, j // 6] - margin) / L
                         for j in range(6 * n)]  # fmt: skip
            continue
        if ob[0] == "box":
            c, h, Rb = np.asarray(ob[1]), np.asarray(ob[2]), np.reshape(ob[3], (3, 3))
            Rt = ca.DM(Rb.T)
            for j in range(6 * n):
                sd = _segment_box_sx(ca, ca.mtimes(Rt, B[j] - c), ca.mtimes(Rt, T[j] - c), h)
                rows.append((sd - r[j] - margin) / L)
            continue
        a, b, R = np.asarray(ob[1]), np.asarray(ob[2]), ob[3]
        for j in range(6 * n):
            s, t = _closest_params(ca, B[j], T[j], a, b)
            g = B[j] + s * (T[j] - B[j]) - (a + t * (b - a))
            rows.append((ca.dot(g, g) - (R + r[j] + margin) ** 2) / L**2)
        if ob[0] == "sphere":  # then plates 1..n
            hulls, half = plate_polygons(stack)
            for pl in range(1, n + 1):
                d2 = _point_polygon_sq(ca, ca.mtimes(As[pl].T, a - Os[pl]), hulls[pl - 1])
                rows.append((d2 - (R + half[pl - 1] + margin) ** 2) / L**2)
    return rows


def _point_polygon_sq(ca: Any, x: Any, hull: FloatArray) -> Any:
    """Squared distance of the point ``x`` (plate frame, symbolic) from the convex polygon
    ``hull`` (M, 2, counter-clockwise) in ``z = 0``: the height squared when ``x``
    projects inside, else the least over the edges (the kernel's
    :func:`stackik._compiled.obstacle_rows._polygon_closest`)."""
    m = hull.shape[0]
    inside: Any = 1
    outs = []
    for e in range(m):
        v, w = hull[e], hull[(e + 1) % m]
        ed = w - v
        inside = ca.logic_and(inside, ed[0] * (x[1] - v[1]) - ed[1] * (x[0] - v[0]) >= 0.0)
        ee = float(ed @ ed)
        t = 0.0 if ee <= 0.0 else _clamp01(ca, ((x[0] - v[0]) * ed[0] + (x[1] - v[1]) * ed[1]) / ee)
        dx, dy = x[0] - v[0] - t * ed[0], x[1] - v[1] - t * ed[1]
        outs.append(dx * dx + dy * dy)
    return x[2] * x[2] + ca.if_else(inside, 0.0, ca.mmin(ca.vertcat(*outs)))


def _segment_box_sx(ca: Any, p0: Any, p1: Any, h: FloatArray) -> Any:
    """The signed distance of the segment ``[p0, p1]`` (box frame, symbolic) from the box
    ``|x_i| <= h_i``, as :func:`stackik.distance.segment_box` computes it: inside (the
    segment meets the box) the least over the vertices of the 1D linear program
    ``min_t max_faces (s x_i(t) - h_i)`` (the ends and each two faces' crossing, clamped
    to the segment: a clamped candidate is still a point of it); outside the least of the
    ends' distances from the box and the distances from its 12 edges (where the closest
    pair of a segment and a disjoint box lies). ``fmin`` differentiates through the
    active candidate: the envelope rule at the kernel's closest (or deepest) point, and at
    a crossing the exact derivative of the crossing's value
    (:func:`stackik._compiled.obstacle_rows._segment_box`). Square roots are taken of at
    least ``1e-24`` mm^2, so that no branch makes a NaN derivative."""
    d = p1 - p0
    pieces = [(i, sg) for i in range(3) for sg in (-1.0, 1.0)]

    def deepest(t: Any) -> Any:
        return ca.mmax(ca.vertcat(*[sg * (p0[i] + t * d[i]) - h[i] for i, sg in pieces]))

    cands = [deepest(0.0), deepest(1.0)]
    for a in range(6):
        for b in range(a + 1, 6):
            (ia, sa), (ib, sb) = pieces[a], pieces[b]
            den = sa * d[ia] - sb * d[ib]
            den_ = ca.if_else(den == 0.0, 1.0, den)
            t = ((sb * p0[ib] - h[ib]) - (sa * p0[ia] - h[ia])) / den_
            cands.append(deepest(_clamp01(ca, t)))
    inner = ca.mmin(ca.vertcat(*cands))

    def point_dist(x: Any) -> Any:
        e = ca.fmax(ca.fabs(x) - h, 0.0)
        return ca.sqrt(ca.fmax(ca.dot(e, e), 1e-24))

    outs = [point_dist(p0), point_dist(p1)]
    corners = [np.array([sx, sy, sz]) * h for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    edges = [(a, a | 1 << k) for a in range(8) for k in range(3) if not a & 1 << k]  # 12
    for a, b in edges:
        s, t = _closest_params(ca, p0, p1, corners[a], corners[b])
        g = p0 + s * d - (corners[a] + t * (corners[b] - corners[a]))
        outs.append(ca.sqrt(ca.fmax(ca.dot(g, g), 1e-24)))
    return ca.if_else(inner <= 0.0, inner, ca.mmin(ca.vertcat(*outs)))


def _euler_sx(ca: Any, ang: Any) -> tuple[Any, Any]:
    """``Rz`` and ``R = Rz Ry Rx`` (symbolic) of the angles ``ang`` (yaw, pitch, roll)."""

    def mat(rows: list[list[Any]]) -> Any:
        return ca.vertcat(*[ca.horzcat(*r) for r in rows])

    ca_, sa = ca.cos(ang[0]), ca.sin(ang[0])
    cb, sb = ca.cos(ang[1]), ca.sin(ang[1])
    cc, sc = ca.cos(ang[2]), ca.sin(ang[2])
    Rz = mat([[ca_, -sa, 0], [sa, ca_, 0], [0, 0, 1]])
    Ry = mat([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    Rx = mat([[1, 0, 0], [0, cc, -sc], [0, sc, cc]])
    return Rz, Rz @ Ry @ Rx


def self_leg_function(base: Any, top: Any, rho: Any, scale: Any, pairs: Any) -> Any:
    """A CasADi function of the raw spatial pose ``q`` (6 n,) [mm, rad] to every platform's
    self-leg rows (n m,), platform-major: the rows the IPOPT solver carries. ``base``,
    ``top`` (n, 6, 3) joints [mm] (``Stack.base_nodes``, ``Stack.top_nodes``), ``rho``,
    ``scale`` (n,) as :class:`stackik.formulation.clearance.SelfLegs`."""
    ca = _casadi()
    n = len(base)
    q = ca.SX.sym("q", 6 * n)
    out: list[Any] = []
    for i in range(n):
        _, R = _euler_sx(ca, q[6 * i + 3 : 6 * i + 6])
        T = [q[6 * i : 6 * i + 3] + R @ np.asarray(top[i][k], float) for k in range(6)]
        b = np.asarray(base[i], float)
        out += _self_leg_rows(ca, b, T, pairs, float(rho[i]), float(scale[i]))
    return ca.Function("self_legs", [q], [ca.vertcat(*out)])


@lru_cache(maxsize=32)
def _solver(
    stack: Stack,
    phi: float,
    objective: str,
    xs: tuple[float, ...],
    user: tuple[tuple[str, Any], ...] = (),
    load: Any = None,
    obstacles: Any = None,
    self_legs: Any = None,
    pairs: Any = None,
) -> Any:
    ca = _casadi()
    n = stack.n
    L = float(stack.leg_max.max())
    e_phi = np.array([math.cos(phi), math.sin(phi), 0.0])
    B = np.stack([e_phi, plane_axis(phi), [0.0, 0.0, 1.0]])
    b = stack.base_nodes @ B.T
    t = stack.top_nodes @ B.T
    u = ca.SX.sym("u", 3 * n)
    p = ca.SX.sym("p", 3)  # target (rho, z, theta) [mm, mm, rad]
    xsv = np.asarray(xs)
    x = u * xsv
    rho, z, th = x[0::3], x[1::3], x[2::3]
    Theta: Any = 0
    P: list[Any] = [0, 0]
    origins = []
    for i in range(n):
        c, s = ca.cos(Theta), ca.sin(Theta)
        P = [P[0] + c * rho[i] - s * z[i], P[1] + s * rho[i] + c * z[i]]
        origins.append(P)
        Theta = Theta + th[i]
    theta_ee = ca.sum1(th)
    g_eq = ca.vertcat((P[0] - p[0]) / L, (P[1] - p[1]) / L, theta_ee - p[2])
    fn2: Any = 3 * n
    for j in range(n - 1):
        fn2 = fn2 + (P[0] - origins[j][0]) ** 2 + (P[1] - origins[j][1]) ** 2
    f = 0 if objective == "feasible" else fn2 / L**2
    g_in = []
    for i in range(n):
        c, s = ca.cos(th[i]), ca.sin(th[i])
        sj = float(stack.sin_joint_min[i])
        lmin2, lmax2, lm = stack.leg_min[i] ** 2, stack.leg_max[i] ** 2, stack.leg_max[i]
        rows: list[list[Any]] = [[], [], [], []]
        for k in range(6):
            lf = c * t[i, k, 0] - s * t[i, k, 2] + rho[i] - b[i, k, 0]
            ls = t[i, k, 1] - b[i, k, 1]
            lz = s * t[i, k, 0] + c * t[i, k, 2] + z[i] - b[i, k, 2]
            sq = lf**2 + ls**2 + lz**2
            nrm = ca.sqrt(sq)
            rows[0].append((sq - lmin2) / lmax2)
            rows[1].append((lmax2 - sq) / lmax2)
            rows[2].append((lz - nrm * sj) / lm)
            rows[3].append((c * lz - s * lf - nrm * sj) / lm)
        g_in += rows[0] + rows[1] + rows[2] + rows[3]
    sf, m = _lift_forces(ca, stack, load)
    g_f: list[Any] = []
    g_ob: list[Any] = []
    if sf is not None or obstacles is not None or self_legs is not None or pairs is not None:
        # the plates' frames in 3D: O_j = O_{j-1} + A_{j-1} P_j
        axis = plane_axis(phi)
        K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        Os: list[Any] = [ca.SX.zeros(3, 1)]
        As: list[Any] = [ca.SX.eye(3)]
        for i in range(n):
            Pi = rho[i] * e_phi + z[i] * np.array([0.0, 0.0, 1.0])
            Ri = ca.cos(th[i]) * np.eye(3) + ca.sin(th[i]) * K
            Ri = Ri + (1 - ca.cos(th[i])) * np.outer(axis, axis)
            Os.append(Os[-1] + As[-1] @ Pi)
            As.append(As[-1] @ Ri)
        if sf is not None:
            g_f = _force_equilibrium(ca, stack, load, Os, As, sf)
        if self_legs is not None:  # in the base frame (the distances are the same)
            legs, rho_sl, scale_sl = self_legs  # not ``pairs``: the non-adjacent rows' key
            for i in range(n):
                Bw = [Os[i] + As[i] @ stack.base_nodes[i, k] for k in range(6)]
                Tw = [Os[i + 1] + As[i + 1] @ stack.top_nodes[i, k] for k in range(6)]
                g_ob += _self_leg_rows(ca, Bw, Tw, legs, rho_sl[i], scale_sl[i])
        if obstacles is not None:
            g_ob += _obstacle_rows(ca, stack, Os, As, obstacles)
        if pairs is not None:
            g_ob += _pair_rows(ca, Os, As, pairs)
    g = ca.vertcat(g_eq, *g_f, *g_in, *g_ob)
    nlp = {"x": u if sf is None else ca.vertcat(u, sf), "p": p, "f": f, "g": g}
    solver = _nlpsol(ca, "stackik_ipopt", nlp, user)
    lbg = np.concatenate([np.zeros(3 + m), np.zeros(24 * n + len(g_ob))])
    ubg = np.concatenate([np.zeros(3 + m), np.full(24 * n + len(g_ob), np.inf)])
    return solver, lbg, ubg


def _ipopt_options(user: tuple[tuple[str, Any], ...]) -> dict[str, Any]:
    return {
        "print_time": False,
        "ipopt": {
            "print_level": 0,
            "tol": 1e-9,
            "constr_viol_tol": 1e-10,
            "bound_relax_factor": 0.0,
            "max_iter": 3000,
            "sb": "yes",
            **dict(user),
        },
    }


@lru_cache(maxsize=32)
def _spatial_solver(
    stack: Stack,
    objective: str,
    xs: tuple[float, ...],
    user: tuple[tuple[str, Any], ...] = (),
    load: Any = None,
    self_legs: tuple[tuple[tuple[int, int], ...], tuple[float, ...], tuple[float, ...]]
    | None = None,
    obstacles: Any = None,
    pairs: Any = None,
) -> Any:
    """IPOPT for the scaled spatial problem (with ``load``: the lifted leg forces of
    :func:`_force_equilibrium`, appended to the variables; with ``self_legs = (pairs, rho,
    scale)``: the self-leg rows after the limits; with ``obstacles`` (:func:`obstacle_key`)
    the obstacle rows last); parameters ``p = (P_target (3),
    R_target.ravel() (9), per-platform angle weights w_th (n), c0, fscale)``."""
    ca = _casadi()
    n = stack.n
    L = float(stack.leg_max.max())
    u = ca.SX.sym("u", 6 * n)
    p = ca.SX.sym("p", 12 + n + 2)
    x = u * np.asarray(xs)
    p_t = p[0:3]
    R_t = ca.reshape(p[3:12], 3, 3).T  # p holds R_target row-major
    w_th = p[12 : 12 + n]
    c0, fscale = p[12 + n], p[13 + n]

    A: Any = ca.SX.eye(3)
    O: Any = ca.SX.zeros(3, 1)
    axes: list[tuple[Any, int]] = []  # (world axis, platform) of every angle variable
    origins = []
    g_in = []
    g_sl: list[Any] = []
    Os: list[Any] = [O]
    As: list[Any] = [A]
    ez = np.array([0.0, 0.0, 1.0])
    for i in range(n):
        px, ang = x[6 * i : 6 * i + 3], x[6 * i + 3 : 6 * i + 6]
        Rz, R = _euler_sx(ca, ang)
        # world axes of yaw, pitch, roll: A_i (e_z, Rz e_y, Rz Ry e_x = R e_x)
        for loc in (ez, Rz[:, 1], R[:, 0]):
            axes.append((A @ loc, i))
        O = O + A @ px
        origins.append(O)
        A = A @ R
        Os.append(O)
        As.append(A)
        # limits of platform i in its own frame: l_k = R t_k + p - b_k
        sj = float(stack.sin_joint_min[i])
        lmin2, lmax2, lm = stack.leg_min[i] ** 2, stack.leg_max[i] ** 2, stack.leg_max[i]
        rows: list[list[Any]] = [[], [], [], []]
        for k in range(6):
            lk = R @ stack.top_nodes[i, k] + px - stack.base_nodes[i, k]
            sq = ca.dot(lk, lk)
            nrm = ca.sqrt(sq)
            rows[0].append((sq - lmin2) / lmax2)
            rows[1].append((lmax2 - sq) / lmax2)
            rows[2].append((lk[2] - nrm * sj) / lm)
            rows[3].append((ca.dot(lk, R[:, 2]) - nrm * sj) / lm)
        g_in += rows[0] + rows[1] + rows[2] + rows[3]
        if self_legs is not None:
            T = [px + R @ stack.top_nodes[i, k] for k in range(6)]
            legs, rho, scale = self_legs  # not ``pairs``: the non-adjacent rows' key
            g_sl += _self_leg_rows(ca, stack.base_nodes[i], T, legs, rho[i], scale[i])
    P_ee, R_ee = O, A
    E = R_t.T @ R_ee
    skew = 0.5 * ca.vertcat(E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1])
    g_eq = ca.vertcat((P_ee - p_t) / L, skew)
    if objective == "feasible":
        f: Any = 0
    else:
        acc: Any = 0
        for w_a, i in axes:
            r_a = ca.cross(w_a, P_ee - origins[i])
            acc = acc + w_th[i] * ca.dot(r_a, r_a)
        f = (c0 + acc) / fscale
    sf, m = _lift_forces(ca, stack, load)
    g_f = [] if sf is None else _force_equilibrium(ca, stack, load, Os, As, sf)
    x_all = u if sf is None else ca.vertcat(u, sf)
    g_ob = [] if obstacles is None else _obstacle_rows(ca, stack, Os, As, obstacles)
    if pairs is not None:
        g_ob += _pair_rows(ca, Os, As, pairs)
    g_all = ca.vertcat(g_eq, *g_f, *g_in, *g_sl, *g_ob)
    nlp = {"x": x_all, "p": p, "f": f, "g": g_all}
    solver = _nlpsol(ca, "stackik_ipopt_spatial", nlp, user)
    k = 24 * n + len(g_sl) + len(g_ob)
    lbg = np.zeros(6 + m + k)
    ubg = np.concatenate([np.zeros(6 + m), np.full(k, np.inf)])
    return solver, lbg, ubg


#: The most rows for bodies of non-adjacent platforms times platforms an IPOPT run
#: carries; with more the run is not made (status "too many rows"; the fold stays, the
#: check refuses it). CasADi's symbolic rows and the Hessian it derives grow with the
#: rows and with the depth of the plate frames' expressions, about 0.12 MB a row and
#: platform (planar n = 16: 334 rows, 0.86 GB in all; n = 32: three unfold rounds of 482,
#: 694 and 908 rows, 3.7 GB): a ``stackik bench`` at n = 64 on 12 mm legs (thousands of
#: rows) was killed by the OOM killer at 24 GB, its solvers cached. Runs with such rows
#: build their solver uncached.
IPOPT_MAX_PAIR_ROW_PLATFORMS = 20_000

#: Keys of the solvers built in this process (their last ``_BUILT_MAX``) and, per stack
#: and obstacle set, how long its last build took [s].
_BUILT: set[Any] = set()
_BUILD_S: dict[Any, float] = {}
_BUILT_MAX = 256


def _built(build: Any, time_left: float, shape: Any, *args: Any) -> Any:
    """``build(*args)`` (a cached CasADi solver), or None when it is not built yet and the
    last build for the same stack and obstacles took longer than ``time_left``: a new
    ``max_wall_time`` (:func:`run_ipopt` rounds it to a power of two, so a later run of
    a solve may need a solver of its own) or the self-leg rows of a second run must not
    spend past the budget on symbolic set-up (seconds with box obstacles' rows).
    ``shape``: the stack and the obstacle key."""
    full = (build.__name__, args)
    family = (build.__name__, shape)
    if full not in _BUILT and _BUILD_S.get(family, 0.0) > time_left:
        return None
    t0 = time.perf_counter()
    out = build(*args)
    if full not in _BUILT:
        if len(_BUILT) >= _BUILT_MAX:
            _BUILT.clear()
        _BUILT.add(full)
        _BUILD_S[family] = time.perf_counter() - t0
    return out


def run_ipopt(
    prob: Problem, u0: FloatArray, options: dict[str, Any], time_left: float = math.inf
) -> tuple[FloatArray, int, str]:
    """Solve the scaled problem ``prob`` (:class:`~stackik.formulation.Problem`, planar or
    spatial) with IPOPT from ``u0``.

    ``options`` are IPOPT options (``max_iter``, ``tol``, ...). ``time_left`` [s] becomes
    IPOPT's ``max_wall_time``, rounded down to a power of two so that cached solvers are
    reused. When building the CasADi solver (seconds with box obstacles' rows) used up
    ``time_left``, IPOPT does not run: ``u0``, 0 iterations, status ``"max_time"``; nor
    with rows for bodies of non-adjacent platforms beyond
    :data:`IPOPT_MAX_PAIR_ROW_PLATFORMS` (status ``"too many rows"``).
    """
    t_start = time.perf_counter()
    target = prob.target
    planar = isinstance(target, PlanarTarget)
    if planar and prob.objective == "weighted" and np.ptp(prob.w_th) != 0:
        raise OptionError('method "ipopt" supports "weighted" only with uniform sigma_theta')
    user = dict(options)
    if math.isfinite(time_left):
        user["max_wall_time"] = 2.0 ** math.floor(math.log2(max(time_left, 1e-3)))
    try:
        key = tuple(sorted(user.items()))
        hash(key)
    except TypeError:
        raise OptionError("options: IPOPT option values must be numbers or strings") from None
    load = None if prob.forces is None else prob.forces.load
    obstacles = obstacle_key(prob)
    lp = prob.clearance.leg_pairs
    if lp is not None and lp.size * prob.n > IPOPT_MAX_PAIR_ROW_PLATFORMS:
        return u0, 0, "too many rows"
    build: Any
    if isinstance(target, PlanarTarget):
        build = _solver
        args: tuple[Any, ...] = (
            prob.stack, target.phi, prob.objective, tuple(prob.xs), key, load, obstacles,
            _self_leg_key(prob), pair_key(prob),
        )  # fmt: skip
        par = target.y
    else:
        assert isinstance(target, SpatialTarget)
        build = _spatial_solver
        args = (
            prob.stack, prob.objective, tuple(prob.xs), key, load, _self_leg_key(prob),
            obstacles, pair_key(prob),
        )  # fmt: skip
        par = np.concatenate(
            [
                target.position,
                np.asarray(target.rotation, float).ravel(),
                np.asarray(prob.w_th, float),
                [prob.c0, prob.fscale],
            ]
        )
    if lp is not None:  # a solver of its own unfold round: not kept (hundreds of MB)
        build = build.__wrapped__
    built = _built(build, time_left, (prob.stack, obstacles), *args)
    if built is None:
        return u0, 0, "max_time"
    solver, lbg, ubg = built
    x0: FloatArray = u0
    lbx: Any = -np.inf
    ubx: Any = np.inf
    if prob.forces is not None:  # the lifted forces start at the start pose's, clipped
        f0 = prob.forces.forces(prob.q_of(u0)).real[prob.forces.platforms]
        fmax = np.asarray(prob.stack.force_max, dtype=float)[prob.forces.platforms]
        s0 = np.clip(np.nan_to_num(f0 / fmax[:, None]), -1.0, 1.0).ravel()
        x0 = np.concatenate([u0, s0])
        lbx = np.concatenate([np.full(u0.size, -np.inf), -np.ones(s0.size)])
        ubx = np.concatenate([np.full(u0.size, np.inf), np.ones(s0.size)])
    if time.perf_counter() - t_start >= time_left:  # the set-up spent the budget
        return u0, 0, "max_time"
    sol = solver(x0=x0, p=par, lbg=lbg, ubg=ubg, lbx=lbx, ubx=ubx)
    stats = solver.stats()
    u = np.asarray(sol["x"], dtype=float).ravel()[: u0.size]
    status = "success" if stats.get("success") else str(stats.get("return_status"))
    return u, int(stats.get("iter_count", 0)), status


class IpoptMethod(Method):
    """IPOPT with exact derivatives by automatic differentiation (CasADi), planar and
    spatial targets."""

    name: ClassVar[str] = "ipopt"
    modes: ClassVar[frozenset[str]] = frozenset({"planar", "spatial"})

    def supports(self, prob: Problem) -> str | None:
        if prob.objective == "force":
            return 'method "ipopt" does not take objective="force"; use "auto", "slsqp" or "sqp"'
        if prob.force_weight > 0.0:
            return 'method "ipopt" does not take force_weight; use "auto", "slsqp" or "sqp"'
        if prob.families is not None:
            return ('method "ipopt" does not take constraint families (its rows are symbolic); '
                    'use "auto", "ip", "sqp" or "slsqp"')  # fmt: skip
        return None  # run_ipopt reports what it cannot do as an OptionError

    def check_options(self, options: dict[str, Any]) -> dict[str, Any]:
        return dict(options)  # IPOPT itself judges them (OptionError on the first run)

    def solve(
        self, prob: Problem, u0: FloatArray, options: dict[str, Any], time_left: float
    ) -> tuple[FloatArray, int, str]:
        return run_ipopt(prob, u0, options, time_left)
