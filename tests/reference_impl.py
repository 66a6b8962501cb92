"""Independent reference implementation of DESIGN.md §1-5, used as a test oracle.

Written from DESIGN.md alone, deliberately naive: explicit loops over platforms and legs,
one 3x3 matrix per platform, Rodrigues' formula written out, plain Python lists. Nothing
here imports stackik. Jacobians are taken by the complex-step method (exact to rounding),
which every function below supports because it uses only analytic operations (no abs,
no conjugation). For ZYX Euler angles the rotation is written out as ``Rz Ry Rx`` (which
supports complex arguments) and also available through scipy
``Rotation.from_euler("ZYX", ...)`` (real only); the tests check that the two agree.

A geometry is a plain dict ``{"base": (6,3), "top": (6,3), "leg_min", "leg_max",
"joint_min"}``; a stack is a list of such dicts (bottom platform first).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

H_CS = 1e-30  # complex-step size

EZ = np.array([0.0, 0.0, 1.0])


# --------------------------------------------------------------------------- geometry
def hexagonal_geometry(r_b=150.0, r_t=150.0, a_deg=15.0, b_deg=15.0, leg_min=250.0,
                       leg_max=450.0, joint_min_deg=20.0):  # fmt: skip
    """DESIGN §2 hexagonal layout, angles in degrees as written there."""
    a, b = a_deg, b_deg
    base_deg = [-a, a, 120 - a, 120 + a, 240 - a, 240 + a]
    top_deg = [-60 + b, 60 - b, 60 + b, 180 - b, 180 + b, 300 - b]
    base = [[r_b * math.cos(math.radians(d)), r_b * math.sin(math.radians(d)), 0.0]
            for d in base_deg]  # fmt: skip
    top = [[r_t * math.cos(math.radians(d)), r_t * math.sin(math.radians(d)), 0.0]
           for d in top_deg]  # fmt: skip
    return {
        "base": np.array(base),
        "top": np.array(top),
        "leg_min": leg_min,
        "leg_max": leg_max,
        "joint_min": math.radians(joint_min_deg),
    }


def random_geometry(rng):
    """An asymmetric geometry: jittered radii, angles and heights, random limits."""
    base = []
    top = []
    for k in range(6):
        ang_b = 2 * math.pi * k / 6 + rng.uniform(-0.4, 0.4)
        ang_t = 2 * math.pi * k / 6 + math.pi / 6 + rng.uniform(-0.4, 0.4)
        rb = rng.uniform(100.0, 200.0)
        rt = rng.uniform(80.0, 180.0)
        base.append([rb * math.cos(ang_b), rb * math.sin(ang_b), rng.uniform(-10.0, 10.0)])
        top.append([rt * math.cos(ang_t), rt * math.sin(ang_t), rng.uniform(-10.0, 10.0)])
    leg_min = rng.uniform(150.0, 300.0)
    return {
        "base": np.array(base),
        "top": np.array(top),
        "leg_min": leg_min,
        "leg_max": leg_min + rng.uniform(50.0, 250.0),
        "joint_min": rng.uniform(0.0, 1.2),
    }


# --------------------------------------------------------------------------- rotations
def rodrigues(axis, theta):
    """R = cos(t) I + sin(t) [s]x + (1 - cos(t)) s s^T, written out entry by entry."""
    sx, sy, sz = axis
    c = np.cos(theta)
    s = np.sin(theta)
    v = 1 - c
    return np.array(
        [
            [c + v * sx * sx, v * sx * sy - s * sz, v * sx * sz + s * sy],
            [v * sy * sx + s * sz, c + v * sy * sy, v * sy * sz - s * sx],
            [v * sz * sx - s * sy, v * sz * sy + s * sx, c + v * sz * sz],
        ]
    )


def plane_axis(phi):
    return np.array([math.sin(phi), -math.cos(phi), 0.0])


def euler_zyx_scipy(yaw, pitch, roll):
    return Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_matrix()


def euler_zyx_explicit(yaw, pitch, roll):
    """Rz(yaw) @ Ry(pitch) @ Rx(roll), elementary matrices written out (complex-safe)."""
    cy, sy = np.cos(yaw), np.sin(yaw)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cr, sr = np.cos(roll), np.sin(roll)
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]], dtype=complex)
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]], dtype=complex)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]], dtype=complex)
    return Rz @ Ry @ Rx


def euler_zyx(yaw, pitch, roll):
    if all(np.isrealobj(v) for v in (yaw, pitch, roll)):
        return euler_zyx_scipy(float(yaw), float(pitch), float(roll))
    return euler_zyx_explicit(yaw, pitch, roll)


# --------------------------------------------------------------------------- per-platform
def planar_platform_pose(row, phi):
    """(P_i, R_i) of one planar platform row (rho, z, theta)."""
    rho, z, theta = row
    P = np.array([rho * math.cos(phi), rho * math.sin(phi), z])
    R = rodrigues(plane_axis(phi), theta)
    return P, R


def spatial_platform_pose(row):
    x, y, z, yaw, pitch, roll = row
    return np.array([x, y, z]), euler_zyx(yaw, pitch, roll)


def platform_constraints(geom, P, R):
    """The 24 constraints of DESIGN §2 for one platform, in block order."""
    s = math.sin(geom["joint_min"])
    Rn = R @ EZ
    blocks = [[], [], [], []]
    for k in range(6):
        l = R @ geom["top"][k] + P - geom["base"][k]
        sq = l[0] * l[0] + l[1] * l[1] + l[2] * l[2]
        norm = np.sqrt(sq)
        blocks[0].append(sq - geom["leg_min"] ** 2)
        blocks[1].append(geom["leg_max"] ** 2 - sq)
        blocks[2].append(l @ EZ - norm * s)
        blocks[3].append(l @ Rn - norm * s)
    return np.array(blocks[0] + blocks[1] + blocks[2] + blocks[3])


def leg_lengths(geom, P, R):
    return np.array([np.linalg.norm(R @ geom["top"][k] + P - geom["base"][k]) for k in range(6)])


# --------------------------------------------------------------------------- chain
def chain(poses):
    """Plate origins O_0..O_n and orientations A_0..A_n from per-platform (P_i, R_i)."""
    O = [np.zeros(3)]
    A = [np.eye(3)]
    for P, R in poses:
        O.append(O[-1] + A[-1] @ P)
        A.append(A[-1] @ R)
    return O, A


def planar_chain(q, phi):
    return chain([planar_platform_pose(row, phi) for row in q])


def spatial_chain(q):
    return chain([spatial_platform_pose(row) for row in q])


def planar_forward(q, phi=0.3):
    """(rho_ee, z_ee, theta_ee); computed in 3D then projected on the plane of azimuth phi."""
    O, _ = planar_chain(q, phi)
    e_phi = np.array([math.cos(phi), math.sin(phi), 0.0])
    Pee = O[-1]
    theta = 0.0
    for row in q:
        theta = theta + row[2]
    return np.array([Pee @ e_phi, Pee[2], theta])


def planar_plate_origins(q, phi=0.3):
    """O_0..O_n as (rho, z), shape (n+1, 2)."""
    O, _ = planar_chain(q, phi)
    e_phi = np.array([math.cos(phi), math.sin(phi), 0.0])
    return np.array([[o @ e_phi, o[2]] for o in O])


def spatial_forward(q):
    O, A = spatial_chain(q)
    return O[-1], A[-1]


def spatial_output(q):
    P, R = spatial_forward(q)
    return np.concatenate([P, np.reshape(R, 9)])


def spatial_plate_origins(q):
    O, _ = spatial_chain(q)
    return np.array(O)


def planar_constraints(stack, q, phi):
    out = []
    for geom, row in zip(stack, q):
        P, R = planar_platform_pose(row, phi)
        out.append(platform_constraints(geom, P, R))
    return np.array(out)


def spatial_constraints(stack, q):
    out = []
    for geom, row in zip(stack, q):
        P, R = spatial_platform_pose(row)
        out.append(platform_constraints(geom, P, R))
    return np.array(out)


# --------------------------------------------------------------------------- clearance
def _point_segment_distance(p, a, b):
    d = b - a
    dd = float(d @ d)
    t = 0.0 if dd == 0.0 else min(1.0, max(0.0, float((p - a) @ d) / dd))
    e = p - (a + t * d)
    return math.sqrt(float(e @ e))


def segment_distance(p0, p1, q0, q1):
    """Exact distance of segments p0-p1 and q0-q1 (real): |P(s) - Q(t)|^2 is convex on the
    unit square, so the minimum is the interior stationary point (non-parallel segments,
    when it lies inside) or on an edge, i.e. an endpoint-to-segment distance."""
    u, v, w = p1 - p0, q1 - q0, p0 - q0
    a, b, c = float(u @ u), float(u @ v), float(v @ v)
    d, e = float(u @ w), float(v @ w)
    best = min(
        _point_segment_distance(p0, q0, q1),
        _point_segment_distance(p1, q0, q1),
        _point_segment_distance(q0, p0, p1),
        _point_segment_distance(q1, p0, p1),
    )
    den = a * c - b * b
    if den > 1e-14 * a * c:
        s = (b * e - c * d) / den
        t = (a * e - b * d) / den
        if 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0:
            g = w + s * u - t * v
            best = min(best, math.sqrt(float(g @ g)))
    return best


def spatial_self_leg_gaps(stack, q):
    """Per platform, the least distance between the axes (bottom joint to top joint) of
    two of its legs, for a spatial pose q (n, 6); in the platform's own frame."""
    return self_leg_gaps(stack, [spatial_platform_pose(row) for row in q])


def self_leg_gaps(stack, poses):
    """Per platform, the least distance between the axes (bottom joint to top joint) of
    two of its legs, from its pose ``(P, R)`` (planar poses lifted, or spatial); in the
    platform's own frame."""
    out = []
    for geom, (P, R) in zip(stack, poses):
        tops = [R @ geom["top"][k] + P for k in range(6)]
        best = math.inf
        for k in range(6):
            for m in range(k + 1, 6):
                d = segment_distance(geom["base"][k], tops[k], geom["base"][m], tops[m])
                best = min(best, d)
        out.append(best)
    return np.array(out)


# --------------------------------------------------------------------------- obstacles
# Obstacles as plain dicts (``stackik.Obstacle.to_dict()``'s format): {"type": "sphere",
# "center", "radius"}, {"type": "capsule", "a", "b", "radius"}, {"type": "box", "center",
# "half_extents", "rotation" (optional)}, {"type": "halfspace", "point", "normal"}.
def _hull(pts):
    """Convex hull (counter-clockwise, monotone chain) of 2D points (m, 2)."""
    P = sorted(map(tuple, pts))

    def half(seq):
        h = []
        for p in seq:
            while (
                len(h) >= 2
                and (
                    (h[-1][0] - h[-2][0]) * (p[1] - h[-2][1])
                    - (h[-1][1] - h[-2][1]) * (p[0] - h[-2][0])
                )
                <= 0
            ):
                h.pop()
            h.append(p)
        return h

    lo, hi = half(P), half(P[::-1])
    return np.array(lo[:-1] + hi[:-1])


def _inside(h, p):
    """Whether 2D point p lies in the counter-clockwise convex polygon h."""
    e = np.roll(h, -1, axis=0) - h
    w = p - h
    return bool(np.all(e[:, 0] * w[:, 1] - e[:, 1] * w[:, 0] >= 0))


def plate_distance(nodes, A, O, a, b):
    """Exact distance [mm] of the segment a-b (a point if a = b) from the convex polygon of
    ``nodes`` (plate frame, z = 0) placed at (A, O): 0 if it crosses the polygon, else the
    least of the endpoints' heights where they project inside and the edge distances."""
    assert np.allclose(nodes[:, 2], 0.0)
    h = _hull(nodes[:, :2])
    la, lb = A.T @ (a - O), A.T @ (b - O)
    best = math.inf
    for p in (la, lb):
        if _inside(h, p[:2]):
            best = min(best, abs(float(p[2])))
    if la[2] * lb[2] < 0:  # the segment crosses the plane: where?
        x = la + (lb - la) * (la[2] / (la[2] - lb[2]))
        if _inside(h, x[:2]):
            return 0.0
    H = np.column_stack([h, np.zeros(len(h))])
    for v, w in zip(H, np.roll(H, -1, axis=0)):
        best = min(best, segment_distance(v, w, la, lb))
    return best


def _plate_nodes(stack, j):
    """Nodes (plate frame) of plate j = 0..n: the base nodes of platform 0 for the base, else
    the top nodes of platform j - 1 and the base nodes of platform j (if any)."""
    n = len(stack)
    if j == 0:
        return np.asarray(stack[0]["base"], float)
    nodes = np.asarray(stack[j - 1]["top"], float)
    if j < n:
        nodes = np.vstack([nodes, np.asarray(stack[j]["base"], float)])
    return nodes


def _through(h, A, O, a, b, tol):
    """Whether segment a-b passes through the polygon h (plate frame) at (A, O) by more than
    ``tol``: both ends farther than tol from the plane on opposite sides, and the crossing
    point farther than tol inside every edge."""
    la, lb = A.T @ (a - O), A.T @ (b - O)
    if not (la[2] * lb[2] < 0 and min(abs(la[2]), abs(lb[2])) > tol):
        return False
    x = (la + (lb - la) * (la[2] / (la[2] - lb[2])))[:2]
    e = np.roll(h, -1, axis=0) - h
    inward = (e[:, 0] * (x[1] - h[:, 1]) - e[:, 1] * (x[0] - h[:, 0])) / np.hypot(e[:, 0], e[:, 1])
    return bool(np.all(inward > tol))


def cores_through_plates(stack, O, A, tol=1e-6):
    """Every leg axis that passes through a plate it does not join, and every plate edge
    through another plate, by more than ``tol`` [mm] (:func:`_through`): a collision of
    legs and plates of no thickness. ``O``, ``A``: plate origins and orientations (n + 1)
    from :func:`chain`. Returns ``(what, j)`` pairs: ``what`` names the leg or plate."""
    n = len(stack)
    hulls = [_hull(_plate_nodes(stack, j)[:, :2]) for j in range(n + 1)]
    found = []
    for j in range(n + 1):
        for i, geom in enumerate(stack):
            if j in (i, i + 1):  # the two plates platform i's legs join
                continue
            for k in range(6):
                a = O[i] + A[i] @ geom["base"][k]
                b = O[i + 1] + A[i + 1] @ geom["top"][k]
                if _through(hulls[j], A[j], O[j], a, b, tol):
                    found.append((f"platform {i + 1} leg {k}", j))
        for jj in range(n + 1):
            if jj == j:
                continue
            H = np.column_stack([hulls[jj], np.zeros(len(hulls[jj]))])
            V = [O[jj] + A[jj] @ v for v in H]
            for v, w in zip(V, V[1:] + V[:1]):
                if _through(hulls[j], A[j], O[j], v, w, tol):
                    found.append((f"plate {jj}", j))
                    break
    return found


def _box_frame(box):
    R = np.asarray(box.get("rotation", np.eye(3)), float)
    return np.asarray(box["center"], float), np.asarray(box["half_extents"], float), R


def _box_sdf(x, box):
    """Signed distance [mm] of the point x from the box (negative inside)."""
    c, h, R = _box_frame(box)
    e = np.abs(R.T @ (x - c)) - h
    return float(np.linalg.norm(np.maximum(e, 0.0)) + min(float(e.max()), 0.0))


def _clip(a, b, box):
    """The parameter interval of the segment a-b inside the box (slab clipping), or None."""
    c, half, R = _box_frame(box)
    la, lb = R.T @ (a - c), R.T @ (b - c)
    t0, t1 = 0.0, 1.0
    for p, d, h in zip(la, lb - la, half):
        if d == 0.0:
            if abs(p) > h:
                return None
            continue
        lo, hi = sorted(((-h - p) / d, (h - p) / d))
        t0, t1 = max(t0, lo), min(t1, hi)
        if t0 > t1:
            return None
    return t0, t1


def box_edges(box):
    """The box's 12 edges, pairs of corners."""
    c, half, R = _box_frame(box)
    s = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    k = c + (s * half) @ R.T
    return [(k[i], k[j]) for i in range(8) for j in range(i + 1, 8) if np.sum(s[i] != s[j]) == 1]


def segment_box_gap(a, b, box):
    """Signed distance [mm] of the segment a-b from the box. Disjoint (slab clipping finds
    no point inside): exact, the least of the ends' distances and the distances from the
    box's 12 edges, where the closest pair of a segment and a disjoint box lies. Meeting:
    at most 0, the least over t of the box's signed distance at a + t (b - a) (convex in
    t: bounded Brent, and the clipped interval's middle) -- only its sign decides a false
    success."""
    from scipy.optimize import minimize_scalar

    def f(t):
        return _box_sdf(a + t * (b - a), box)

    inside = _clip(a, b, box)
    if inside is None:
        edges = min(segment_distance(a, b, e0, e1) for e0, e1 in box_edges(box))
        return min(f(0.0), f(1.0), edges)
    r = minimize_scalar(f, bounds=(0.0, 1.0), method="bounded", options={"xatol": 1e-13})
    return min(float(r.fun), f(0.5 * (inside[0] + inside[1])), 0.0)


def plate_box_gap(nodes, A, O, box):
    """Distance [mm] of a plate polygon from the box, 0 or less when they meet: two convex
    bodies' least distance is attained at an edge (or vertex) of one of them, so the least
    of the polygon's edges against the box (:func:`segment_box_gap`, signed) and of the
    box's 12 edges against the polygon (:func:`plate_distance`, 0 when one pierces it)."""
    h = _hull(nodes[:, :2])
    H = np.column_stack([h, np.zeros(len(h))]) @ A.T + O
    best = min(segment_box_gap(v, w, box) for v, w in zip(H, np.roll(H, -1, axis=0)))
    return min(best, *(plate_distance(nodes, A, O, e0, e1) for e0, e1 in box_edges(box)))


def _halfspace_depth(x, hs):
    """Signed distance [mm] of the point x from the half-space's boundary (positive on the
    side its normal points to, where bodies must stay)."""
    n = np.asarray(hs["normal"], float)
    return float((x - np.asarray(hs["point"], float)) @ n) / math.sqrt(float(n @ n))


def obstacle_body_gaps(stack, O, A, ob):
    """Least signed surface distances [mm] of an obstacle (a dict, above) from every leg
    axis and from every plate but the base (the convex polygon of the top nodes of platform
    j and the base nodes of platform j + 1, zero thickness), as ``{"leg": (n, 6),
    "plate": (n,)}``, measured from the obstacle's surface (a sphere's and a capsule's
    radius subtracted; a leg's own radius not). ``O``, ``A``: plate origins and
    orientations (n + 1) from :func:`chain`."""
    n = len(stack)
    kind = ob["type"]
    leg = np.empty((n, 6))
    plate = np.empty(n)
    for i, geom in enumerate(stack):
        for k in range(6):
            a = O[i] + A[i] @ geom["base"][k]
            b = O[i + 1] + A[i + 1] @ geom["top"][k]
            if kind == "sphere":
                c = np.asarray(ob["center"], float)
                leg[i, k] = _point_segment_distance(c, a, b) - ob["radius"]
            elif kind == "capsule":
                p0, p1 = np.asarray(ob["a"], float), np.asarray(ob["b"], float)
                leg[i, k] = segment_distance(a, b, p0, p1) - ob["radius"]
            elif kind == "box":
                leg[i, k] = segment_box_gap(a, b, ob)
            else:
                leg[i, k] = min(_halfspace_depth(a, ob), _halfspace_depth(b, ob))
    for j in range(1, n + 1):
        nodes = np.asarray(stack[j - 1]["top"], float)
        if j < n:
            nodes = np.vstack([nodes, np.asarray(stack[j]["base"], float)])
        if kind == "sphere":
            c = np.asarray(ob["center"], float)
            plate[j - 1] = plate_distance(nodes, A[j], O[j], c, c) - ob["radius"]
        elif kind == "capsule":
            p0, p1 = np.asarray(ob["a"], float), np.asarray(ob["b"], float)
            plate[j - 1] = plate_distance(nodes, A[j], O[j], p0, p1) - ob["radius"]
        elif kind == "box":
            plate[j - 1] = plate_box_gap(nodes, A[j], O[j], ob)
        else:
            plate[j - 1] = min(_halfspace_depth(O[j] + A[j] @ x, ob) for x in nodes)
    return {"leg": leg, "plate": plate}


# --------------------------------------------------------------------------- derivatives
def complex_step(f, x):
    """Jacobian of f at the real array x (any shape) by the complex step; f(x) any shape.

    Returns an array of shape f(x).shape + x.shape.
    """
    x = np.asarray(x, dtype=float)
    f0 = np.asarray(f(x))
    out = np.zeros(f0.shape + x.shape)
    for idx in np.ndindex(*x.shape):
        xc = x.astype(complex)
        xc[idx] += 1j * H_CS
        out[(Ellipsis,) + idx] = np.imag(np.asarray(f(xc))) / H_CS
    return out


def planar_jacobian(q, phi=0.3):
    """dy/dx with x = q.ravel(), shape (3, 3n), by complex step of the 3D forward model."""
    q = np.asarray(q, dtype=float)
    n = q.shape[0]
    J = complex_step(lambda x: planar_forward(x, phi), q)  # (3, n, 3)
    return J.reshape(3, 3 * n)


def spatial_jacobian(q):
    q = np.asarray(q, dtype=float)
    n = q.shape[0]
    J = complex_step(spatial_output, q)  # (12, n, 6)
    return J.reshape(12, 6 * n)


def planar_constraint_jacobian(stack, q, phi):
    """Per-platform blocks (n, 24, 3) of the constraint Jacobian (complex step)."""
    q = np.asarray(q, dtype=float)
    full = complex_step(lambda x: planar_constraints(stack, x, phi), q)  # (n, 24, n, 3)
    return np.array([full[i, :, i, :] for i in range(q.shape[0])]), full


def spatial_constraint_jacobian(stack, q):
    q = np.asarray(q, dtype=float)
    full = complex_step(lambda x: spatial_constraints(stack, x), q)  # (n, 24, n, 6)
    return np.array([full[i, :, i, :] for i in range(q.shape[0])]), full


def frobenius_norm(J):
    total = 0.0
    for row in J:
        for v in row:
            total += v * v
    return math.sqrt(total)


# --------------------------------------------------------------------------- FN closed forms
def planar_fn2_closed_form(q, phi=0.3):
    """3n + sum_{j=1}^{n-1} |P_ee - O_j|^2 (DESIGN §3)."""
    O, _ = planar_chain(q, phi)
    n = len(q)
    total = 3.0 * n
    for j in range(1, n):
        d = O[n] - O[j]
        total += d @ d
    return total


def spatial_world_axes(q):
    """World rotation axes of platform i's yaw, pitch, roll: A_{i-1} (e_z, Rz e_y, Rz Ry e_x)."""
    _, A = spatial_chain(q)
    axes = []
    for i, row in enumerate(q):
        yaw, pitch = row[3], row[4]
        Rz = euler_zyx(yaw, 0.0, 0.0)
        Ry = euler_zyx(0.0, pitch, 0.0)
        local = [EZ, Rz @ np.array([0.0, 1.0, 0.0]), Rz @ Ry @ np.array([1.0, 0.0, 0.0])]
        axes.append([A[i] @ w for w in local])
    return axes


def spatial_fn2_closed_form(q):
    """9n + sum_{i,k} |w_ik x (P_ee - O_i)|^2 (translation columns: 1 each; rotation
    columns: |w x d|^2 + |[w]x R_ee|_F^2 = |w x d|^2 + 2)."""
    O, _ = spatial_chain(q)
    n = len(q)
    total = 9.0 * n
    for i, ws in enumerate(spatial_world_axes(q)):
        d = O[n] - O[i + 1]
        for w in ws:
            c = np.cross(w, d)
            total += c @ c
    return total


def weighted_objective(J, variances):
    """trace(J C_x J^T) with C_x = diag(variances)."""
    return float(np.trace(J @ np.diag(variances) @ J.T))


def random_planar_pose(rng, n):
    """(n, 3) rows (rho, z, theta): rho may be negative [mm, mm, rad]."""
    return np.column_stack(
        [rng.uniform(-150, 150, n), rng.uniform(200, 450, n), rng.uniform(-0.6, 0.6, n)]
    )


def random_spatial_pose(rng, n):
    """(n, 6) rows (x, y, z, yaw, pitch, roll) [mm, rad]."""
    return np.column_stack(
        [rng.uniform(-120, 120, (n, 2)), rng.uniform(200, 450, n), rng.uniform(-0.7, 0.7, (n, 3))]
    )


# --------------------------------------------------------------------------- statics
def world_leg_forces(base_nodes, top_nodes, plate_mass, leg_mass, poses, mass, com, g, F, M, frame):
    """Leg forces (n, 6) [N], compression positive, of a pose given as per-platform
    ``(P_i, R_i)``: each cut body's equilibrium in the base frame, moments about the base
    origin. The body above platform i's legs carries the payload ``mass`` [kg] at ``com``
    (end-effector frame, mm), the plates i..n, the legs above (half at each joint) and the
    top halves of its own legs; ``g`` [m/s^2] base frame; ``F`` [N] and ``M`` [N m] the
    external wrench on the end effector in ``frame`` ("base" or "end_effector")."""
    O, A = chain(poses)
    n = len(poses)
    T = [[O[i + 1] + A[i + 1] @ top_nodes[i][k] for k in range(6)] for i in range(n)]
    B = [[O[i] + A[i] @ base_nodes[i][k] for k in range(6)] for i in range(n)]
    F_ext, M_ext = np.asarray(F, float), 1000.0 * np.asarray(M, float)  # N mm
    if frame == "end_effector":
        F_ext, M_ext = A[n] @ F_ext, A[n] @ M_ext
    g = np.asarray(g, float)
    out = np.empty((n, 6))
    for i in range(n):
        masses = [(0.5 * leg_mass[i], T[i][k]) for k in range(6)]
        masses += [(plate_mass[j], O[j + 1]) for j in range(i, n)]
        for j in range(i + 1, n):
            masses += [(0.5 * leg_mass[j], p) for p in T[j] + B[j]]
        masses.append((mass, O[n] + A[n] @ np.asarray(com, float)))
        Ftot = F_ext + sum(m for m, _ in masses) * g
        Mtot = M_ext + np.cross(O[n], F_ext) + sum(np.cross(r, m * g) for m, r in masses)
        G = np.empty((6, 6))
        for k in range(6):
            d = T[i][k] - B[i][k]
            u = d / np.linalg.norm(d)
            G[:3, k], G[3:, k] = u, np.cross(T[i][k], u)
        out[i] = -np.linalg.solve(G, np.concatenate([Ftot, Mtot]))
    return out
