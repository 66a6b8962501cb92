"""Statics (DESIGN §10): leg forces against an independent virtual-work model, equilibrium of
every cut body, the singularity measure, the statics fields of the geometry, and the check.

The independent model (:func:`virtual_work_forces`) knows nothing of cuts or wrench
matrices: it lists every point mass of the stack with its position as a function of the
pose (written with tests/reference_impl.py's kinematics), moves one platform at a time
through six small rigid motions of its top plate (the others fixed) and solves the
principle of virtual work

    sum_k f_k dl_k + sum_m m g . dr_m + F . dp_ee + M . dtheta_ee = 0

for the six leg forces, with every derivative by the complex step (exact to rounding).
Masses that do not move (below the moved platform) drop out by themselves.
"""

from __future__ import annotations

import dataclasses
import json
import math
import pickle
import zlib

import fd
import numpy as np
import pytest
import reference_impl as ref

import stackik as sk
from stackik import GeometryError, Load, PlatformGeometry, Stack
from stackik.check import FORCE_TOL, check_pose
from stackik.cli.geometry import describe_stack
from stackik.loads import GRAVITY, SINGULAR_CONDITION, characteristic_length
from stackik.sampling import random_stack

REL = 1e-9  # leg forces equal the independent model to this, relative to the peak force


# =========================================================================================
# The independent model
# =========================================================================================
def _rotation(x):
    """A complex-safe rotation near the identity: the explicit Rz Ry Rx of reference_impl."""
    return ref.euler_zyx_explicit(x[0], x[1], x[2])


def _geometry_dict(g: PlatformGeometry):
    return {"base": g.base_nodes, "top": g.top_nodes, "pm": g.plate_mass, "lm": g.leg_mass}


def _point_masses(geoms, poses, load_mass, com):
    """Every point mass ``(m [kg], r [mm] in the base frame)`` of the stack at per-platform
    poses ``[(P_i, R_i)]`` (complex allowed): plates at their centres, each leg's mass half
    at each joint, the payload at the end effector plus com."""
    O, A = ref.chain(poses)
    out = []
    for i, g in enumerate(geoms):  # platform i + 1 joins plate i to plate i + 1
        out.append((g["pm"], O[i + 1]))
        for k in range(6):
            out.append((0.5 * g["lm"], O[i] + A[i] @ g["base"][k]))
            out.append((0.5 * g["lm"], O[i + 1] + A[i + 1] @ g["top"][k]))
    out.append((load_mass, O[-1] + A[-1] @ com))
    return out, O, A


def _vee(S):
    return np.array([S[2, 1], S[0, 2], S[1, 0]])


def virtual_work_forces(stack: Stack, poses, load: Load, derivative: str = "complex"):
    """Leg forces (n, 6) [N] by virtual work (module doc); poses: real [(P_i, R_i)].

    derivative: "complex" (complex step, exact to rounding) or "central" (real central
    differences with Richardson extrapolation, tests/fd.py: error ~ eps^(4/5) of the scale).
    """
    if derivative == "complex":
        diff = ref.complex_step
    else:

        def diff(f, x):
            def real(y):
                return np.real(f(y))  # reference_impl's explicit rotation is complex-typed

            return fd.central(real, x, typical=fd.TYPICAL_SPATIAL, richardson=True).value

    geoms = [_geometry_dict(g) for g in stack]
    n = len(geoms)
    g_acc = load.gravity  # [m/s^2]: m g is in N
    _, _, A0 = _point_masses(geoms, poses, load.mass, load.com)
    F, M = load.force, load.moment * 1000.0  # N, N mm
    if load.frame == "end_effector":
        F, M = A0[-1] @ F, A0[-1] @ M
    out = np.zeros((n, 6))
    for i in range(n):

        def moved(x, i=i):
            P, R = poses[i]
            return [*poses[:i], (P + x[:3], _rotation(x[3:]) @ R), *poses[i + 1 :]]

        def lengths(x, i=i):
            P, R = moved(x)[i]
            g = geoms[i]
            return np.array(
                [np.sqrt(np.sum((R @ g["top"][k] + P - g["base"][k]) ** 2)) for k in range(6)]
            )

        def work_of_loads(x):
            # sum_m m g . r_m + F . p_ee (the moment's work needs the rotation, below)
            masses, O, _ = _point_masses(geoms, moved(x), load.mass, load.com)
            return sum(m * (g_acc @ r) for m, r in masses) + F @ O[-1]

        def end_rotation(x):
            return ref.chain(moved(x))[1][-1]

        x0 = np.zeros(6)
        dl = diff(lengths, x0)  # (6 legs, 6 motions)
        Q = diff(work_of_loads, x0)  # (6,)
        dA = diff(end_rotation, x0)  # (3, 3, 6)
        dtheta = np.array([_vee(dA[:, :, a] @ A0[-1].T) for a in range(6)])  # (6, 3)
        Q = Q + dtheta @ M
        out[i] = np.linalg.solve(dl.T, -Q)
    return out


def poses_of(q, phi=None):
    """Per-platform ``[(P_i, R_i)]`` of a spatial or (with phi) planar pose, by reference_impl."""
    if phi is None:
        return [ref.spatial_platform_pose(row) for row in q]
    return [ref.planar_platform_pose(row, phi) for row in q]


def massive(stack: Stack, rng) -> Stack:
    """The stack with random plate and leg masses per platform (a mixed stack)."""
    return Stack(
        tuple(
            dataclasses.replace(g, plate_mass=rng.uniform(1.0, 8.0), leg_mass=rng.uniform(0.2, 2.5))
            for g in stack
        )
    )


def asymmetric_stack(n: int, rng) -> Stack:
    """Different asymmetric geometries (nodes off their plate by up to 10 mm) with masses."""
    out = []
    for _ in range(n):
        g = ref.random_geometry(rng)
        out.append(PlatformGeometry(g["base"], g["top"], g["leg_min"], g["leg_max"], 0.3))
    return massive(Stack(tuple(out)), rng)


def random_load(rng, gravity="earth", frame="base") -> Load:
    return Load(
        force=rng.normal(0, 50, 3),
        moment=rng.normal(0, 5, 3),
        frame=frame,
        mass=rng.uniform(0, 15),
        com=rng.normal(0, 40, 3),
        gravity=gravity,
    )


def random_pose(rng, n, planar):
    return ref.random_planar_pose(rng, n) if planar else ref.random_spatial_pose(rng, n)


def feasible_pose(stack, rng, planar):
    """A pose within every limit near straight up (no solver needed), and its target."""
    n = stack.n
    if planar:
        q = np.tile([0.0, 350.0, 0.0], (n, 1)) + rng.normal(0, 1, (n, 3)) * [10, 10, 0.05]
        return q, sk.PlanarTarget(*sk.planar_forward(q), phi=0.5)
    q = np.tile([0.0, 0.0, 350.0, 0.0, 0.0, 0.0], (n, 1))
    q = q + rng.normal(0, 1, (n, 6)) * [10, 10, 10, 0.05, 0.05, 0.05]
    return q, sk.SpatialTarget(*sk.spatial_forward(q))


def assert_forces_close(f, f_ref):
    scale = float(np.abs(f_ref).max())
    err = float(np.abs(f - f_ref).max())
    assert err <= REL * scale, (err / scale, f, f_ref)


GRAVITIES = [*GRAVITY, (9.80665, 0.0, 0.0), (-3.0, 4.0, -2.0)]  # presets, sideways, any


# =========================================================================================
# Leg forces against the independent model
# =========================================================================================
@pytest.mark.parametrize("planar", [False, True], ids=["spatial", "planar"])
@pytest.mark.parametrize("frame", ["base", "end_effector"])
@pytest.mark.parametrize("gravity", GRAVITIES, ids=[str(g) for g in GRAVITIES])
def test_leg_forces_equal_virtual_work(planar, frame, gravity):
    rng = np.random.default_rng(zlib.crc32(f"{planar}{frame}{gravity}".encode()))
    for trial in range(3):
        n = (1, 3, 4)[trial]
        stack = asymmetric_stack(n, rng) if trial % 2 else massive(random_stack(n, rng), rng)
        q = random_pose(rng, n, planar)
        phi = float(rng.uniform(-3, 3)) if planar else None
        load = random_load(rng, gravity, frame)
        f = sk.leg_forces(stack, q, load, phi=phi)
        assert f.shape == (n, 6)
        assert_forces_close(f, virtual_work_forces(stack, poses_of(q, phi), load))
        if trial == 2:  # once more with real finite differences of the kinematics
            assert_forces_close(f, virtual_work_forces(stack, poses_of(q, phi), load, "central"))


def test_leg_forces_are_batched():
    rng = np.random.default_rng(3)
    stack = asymmetric_stack(3, rng)
    load = random_load(rng, frame="end_effector")
    Q = np.stack([ref.random_spatial_pose(rng, 3) for _ in range(5)]).reshape(5, 1, 3, 6)
    f = sk.leg_forces(stack, Q, load)
    assert f.shape == (5, 1, 3, 6)
    for k in range(5):
        np.testing.assert_array_equal(f[k, 0], sk.leg_forces(stack, Q[k, 0], load))
    qp = np.stack([ref.random_planar_pose(rng, 3) for _ in range(4)])
    fp = sk.leg_forces(stack, qp, load, phi=0.7)
    for k in range(4):
        np.testing.assert_allclose(fp[k], sk.leg_forces(stack, qp[k], load, phi=0.7), rtol=1e-13)


def test_planar_forces_equal_those_of_the_same_spatial_pose():
    from stackik.rotations import euler_zyx_from_matrix

    rng = np.random.default_rng(4)
    stack = asymmetric_stack(4, rng)
    q = ref.random_planar_pose(rng, 4)
    phi = 1.1
    P, R = sk.lift_planar(q, phi)
    qs = np.column_stack([P, euler_zyx_from_matrix(R)])
    load = random_load(rng, gravity=(1.0, -2.0, -9.0), frame="end_effector")
    assert_forces_close(sk.leg_forces(stack, q, load, phi=phi), sk.leg_forces(stack, qs, load))


# =========================================================================================
# Equilibrium of every cut body, moments about the base origin
# =========================================================================================
@pytest.mark.parametrize("planar", [False, True], ids=["spatial", "planar"])
@pytest.mark.parametrize("frame", ["base", "end_effector"])
def test_every_cut_body_is_in_equilibrium(planar, frame):
    rng = np.random.default_rng(11 + planar + 2 * (frame == "base"))
    for gravity in GRAVITIES:
        n = 4
        stack = asymmetric_stack(n, rng)
        q = random_pose(rng, n, planar)
        phi = 0.4 if planar else None
        load = random_load(rng, gravity, frame)
        f = sk.leg_forces(stack, q, load, phi=phi)
        geoms = [_geometry_dict(g) for g in stack]
        poses = poses_of(q, phi)
        O, A = ref.chain(poses)
        F = load.force if frame == "base" else A[-1] @ load.force
        M = 1000.0 * (load.moment if frame == "base" else A[-1] @ load.moment)  # N mm
        for i in range(n):  # the body above platform i + 1's legs
            terms_f, terms_m = [F], [M, np.cross(O[-1], F)]
            for k in range(6):  # platform i + 1's legs push the body at their top joints
                top = O[i + 1] + A[i + 1] @ geoms[i]["top"][k]
                bottom = O[i] + A[i] @ geoms[i]["base"][k]
                u = (top - bottom) / np.linalg.norm(top - bottom)
                terms_f.append(f[i, k] * u)
                terms_m.append(np.cross(top, f[i, k] * u))
                terms_f.append(0.5 * geoms[i]["lm"] * load.gravity)  # top half of the leg
                terms_m.append(np.cross(top, 0.5 * geoms[i]["lm"] * load.gravity))
            for j in range(i, n):  # plates i+1..n and what they carry
                pts = [(geoms[j]["pm"], O[j + 1])]
                if j > i:
                    pts += [(0.5 * geoms[j]["lm"], O[j] + A[j] @ b) for b in geoms[j]["base"]]
                    pts += [
                        (0.5 * geoms[j]["lm"], O[j + 1] + A[j + 1] @ t) for t in geoms[j]["top"]
                    ]
                for m, r in pts:
                    terms_f.append(m * load.gravity)
                    terms_m.append(np.cross(r, m * load.gravity))
            terms_f.append(load.mass * load.gravity)
            terms_m.append(np.cross(O[-1] + A[-1] @ load.com, load.mass * load.gravity))
            for terms in (terms_f, terms_m):
                total = np.sum(terms, axis=0)
                scale = np.sum(np.abs(terms), axis=0).max()
                assert np.abs(total).max() <= 1e-12 * scale, (i, total, scale)


# =========================================================================================
# Known answers and signs
# =========================================================================================
def test_symmetric_stack_under_its_weight_is_in_equal_compression():
    g = PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5)
    stack = Stack.uniform(g, 3)
    q = np.tile([0.0, 0.0, 350.0, 0.0, 0.0, 0.0], (3, 1))
    f = sk.leg_forces(stack, q, Load(mass=10.0))
    l = sk.leg_vectors(g, q[0, :3], np.eye(3))
    uz = l[:, 2] / np.linalg.norm(l, axis=1)
    # above platform 1: payload, 3 plates, the legs of platforms 2 and 3, half of its own
    above = np.array([10 + 3 * 5 + 2 * 9 + 4.5, 10 + 2 * 5 + 9 + 4.5, 10 + 5 + 4.5])
    expected = above[:, None] * 9.80665 / (6 * uz)
    np.testing.assert_allclose(f, expected, rtol=1e-12)
    assert np.all(f > 0)  # compression: the legs push their plates apart


def test_pulling_the_end_effector_up_puts_the_legs_in_tension():
    stack = Stack.reference(2)
    q = np.tile([0.0, 0.0, 350.0, 0.0, 0.0, 0.0], (2, 1))
    f = sk.leg_forces(stack, q, Load(force=(0, 0, 600.0)))
    assert np.all(f < 0)
    np.testing.assert_allclose(f[0], f[1], rtol=1e-12)  # massless: the same load throughout


def test_massless_stack_without_load_carries_nothing():
    rng = np.random.default_rng(5)
    stack = random_stack(3, rng)
    q = ref.random_spatial_pose(rng, 3)
    assert np.all(sk.leg_forces(stack, q) == 0.0)
    assert np.all(sk.leg_forces(stack, q, Load(mass=3.0, gravity="none")) == 0.0)


def test_gravity_presets_scale_the_forces():
    rng = np.random.default_rng(6)
    stack = massive(Stack.reference(3), rng)
    q = ref.random_spatial_pose(rng, 3)
    earth = sk.leg_forces(stack, q, Load(mass=4.0))
    for name, g in GRAVITY.items():
        np.testing.assert_allclose(
            sk.leg_forces(stack, q, Load(mass=4.0, gravity=name)),
            earth * g[2] / GRAVITY["earth"][2],
            rtol=1e-12,
            atol=1e-12 * np.abs(earth).max(),
        )
    assert sk.leg_forces(stack, q) == pytest.approx(sk.leg_forces(stack, q, Load()))


# =========================================================================================
# The singularity measure
# =========================================================================================
def parallel_legs_geometry() -> PlatformGeometry:
    """Top nodes over the base nodes: straight up, all six legs vertical (singular)."""
    g = PlatformGeometry.reference()
    return PlatformGeometry(g.base_nodes, g.base_nodes, 250.0, 450.0, 0.3, plate_mass=2.0)


def test_singular_platform_gives_infinite_forces_and_says_which():
    stack = Stack((PlatformGeometry.reference(), parallel_legs_geometry()))
    q = np.tile([0.0, 0.0, 350.0, 0.0, 0.0, 0.0], (2, 1))
    load = Load(mass=1.0)
    f = sk.leg_forces(stack, q, load)
    assert np.all(np.isfinite(f[0])) and np.all(np.isinf(f[1]))
    st = sk.statics(stack, q, load)
    assert st.singular.tolist() == [False, True]
    assert st.singular_platforms == (2,)
    assert "platform(s) 2 of 2" in st.message
    assert st.peak_force_ratio == math.inf and st.force_margin[1].tolist() == [-math.inf] * 6
    cond = sk.wrench_conditioning(stack, q)
    assert cond.condition[1] > SINGULAR_CONDITION and cond.sigma_min[1] < 1e-12
    assert np.isfinite(cond.condition[0])
    target = sk.SpatialTarget(*sk.spatial_forward(q))
    assert not check_pose(stack, target, q, load).ok
    assert check_pose(stack, target, q).ok  # no load, no limit: forces are not looked at


def test_conditioning_is_dimensionless_and_frame_free():
    rng = np.random.default_rng(7)
    g = ref.random_geometry(rng)
    geo = PlatformGeometry(g["base"], g["top"], g["leg_min"], g["leg_max"], 0.3)
    big = PlatformGeometry(3 * g["base"], 3 * g["top"], 3 * g["leg_min"], 3 * g["leg_max"], 0.3)
    q = ref.random_spatial_pose(rng, 1)
    q3 = q * [3, 3, 3, 1, 1, 1]
    c1 = sk.wrench_conditioning(Stack((geo,)), q)
    c3 = sk.wrench_conditioning(Stack((big,)), q3)
    np.testing.assert_allclose(c3.sigma_min, c1.sigma_min, rtol=1e-12)
    np.testing.assert_allclose(c3.condition, c1.condition, rtol=1e-12)
    # the same platform higher up a stack, whatever the pose below it: the same measure
    two = Stack((PlatformGeometry.reference(), geo))
    q2 = np.vstack([ref.random_spatial_pose(rng, 1), q])
    np.testing.assert_allclose(sk.wrench_conditioning(two, q2).sigma_min[1], c1.sigma_min[0])
    assert characteristic_length(Stack.reference(2)).tolist() == pytest.approx([150.0, 150.0])
    # a straight-up reference platform: well away from a singularity
    ref_c = sk.wrench_conditioning(Stack.reference(1), [[0, 0, 350, 0, 0, 0]])
    assert 0.1 < ref_c.sigma_min[0] < 1.5 and 1 < ref_c.condition[0] < 30


def test_conditioning_singular_values_are_those_of_the_scaled_matrix():
    rng = np.random.default_rng(8)
    stack = asymmetric_stack(2, rng)
    q = ref.random_spatial_pose(rng, 2)
    cond = sk.wrench_conditioning(stack, q)
    L = characteristic_length(stack)
    for i, (P, R) in enumerate(poses_of(q)):
        g = stack[i]
        cols = []
        for k in range(6):
            l = R @ g.top_nodes[k] + P - g.base_nodes[k]
            u = l / np.linalg.norm(l)
            cols.append(np.concatenate([u, np.cross(R @ g.top_nodes[k], u) / L[i]]))
        s = np.linalg.svd(np.array(cols).T, compute_uv=False)
        assert cond.sigma_min[i] == pytest.approx(s[-1], rel=1e-12)
        assert cond.condition[i] == pytest.approx(s[0] / s[-1], rel=1e-12)


# =========================================================================================
# The statics result and the check
# =========================================================================================
def test_statics_margins_and_ratios():
    rng = np.random.default_rng(9)
    stack = Stack(
        tuple(
            dataclasses.replace(g, force_max=fm)
            for g, fm in zip(
                massive(Stack.reference(3), rng), (400.0, math.inf, 150.0), strict=True
            )
        )
    )
    q = ref.random_spatial_pose(rng, 3)
    load = random_load(rng)
    st = sk.statics(stack, q, load)
    f = sk.leg_forces(stack, q, load)
    np.testing.assert_array_equal(st.leg_forces, f)
    np.testing.assert_array_equal(st.force_margin[0], 400.0 - np.abs(f[0]))
    assert np.all(st.force_margin[1] == math.inf) and np.all(st.force_ratio[1] == 0.0)
    np.testing.assert_array_equal(st.force_ratio[2], np.abs(f[2]) / 150.0)
    assert st.peak_force == np.abs(f).max()
    assert st.peak_force_ratio == max(np.abs(f[0]).max() / 400, np.abs(f[2]).max() / 150)
    assert "peak leg force" in st.message and not st.singular.any()
    assert not st.leg_forces.flags.writeable


@pytest.mark.parametrize("planar", [False, True], ids=["spatial", "planar"])
def test_check_enforces_force_limits_at_its_tolerance(planar):
    rng = np.random.default_rng(10 + planar)
    n = 3
    stack = massive(random_stack(n, rng), rng)
    load = Load(mass=8.0, moment=(1.0, -2.0, 0.5))
    q, target = feasible_pose(stack, rng, planar)
    phi = 0.5 if planar else None
    base = check_pose(stack, target, q)
    assert base.ok
    assert base.statics is None and base.peak_force_ratio == 0.0  # unchanged without loads
    loaded = check_pose(stack, target, q, load)
    assert loaded.ok and loaded.peak_force_ratio == 0.0  # no limits: forces only finite
    peak = float(np.abs(sk.leg_forces(stack, q, load, phi=phi)).max())
    for factor, ok in ((1.0 + 0.5 * FORCE_TOL, True), (1.0 - 2 * FORCE_TOL, False)):
        limited = Stack(tuple(dataclasses.replace(g, force_max=peak * factor) for g in stack))
        chk = check_pose(limited, target, q, load)
        assert chk.ok is ok
        assert chk.peak_force_ratio == pytest.approx(1.0 / factor, rel=1e-12)
        for field in ("position_error", "angle_error", "max_violation_mm"):
            assert getattr(chk, field) == getattr(base, field)
        # a finite limit alone checks the stack's own weight (load=None: earth gravity)
        own = check_pose(limited, target, q)
        assert own.statics is not None
        assert own.peak_force_ratio == pytest.approx(
            float(np.abs(sk.leg_forces(limited, q, phi=phi)).max()) / (peak * factor)
        )


def test_check_without_load_or_limit_is_unchanged():
    stack = massive(Stack.reference(4), np.random.default_rng(12))
    q, target = feasible_pose(stack, np.random.default_rng(13), True)
    a = check_pose(stack, target, q)
    b = check_pose(Stack.reference(4), target, q)
    assert a.ok == b.ok and a.statics is None and a.peak_force_ratio == 0.0
    np.testing.assert_array_equal(a.constraints, b.constraints)


# =========================================================================================
# Bad input
# =========================================================================================
@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"mass": -1.0}, "mass"),
        ({"mass": math.nan}, "mass"),
        ({"mass": math.inf}, "mass"),
        ({"mass": "heavy"}, "mass"),
        ({"gravity": "jupiter"}, "gravity"),
        ({"gravity": (0, 0)}, "gravity"),
        ({"gravity": (0, math.nan, 0)}, "gravity"),
        ({"force": (1, 2)}, "force"),
        ({"force": "up"}, "force"),
        ({"moment": (0, math.inf, 0)}, "moment"),
        ({"com": [[1, 2, 3]]}, "com"),
        ({"frame": "world"}, "frame"),
    ],
)
def test_bad_load_names_the_field(kwargs, field):
    with pytest.raises(ValueError, match=f"^{field}:"):
        Load(**kwargs)


def test_load_value_semantics():
    a = Load(mass=2.0, gravity="moon", com=(0, 0, 10))
    assert a.gravity.tolist() == [0.0, 0.0, -1.62]
    assert a == Load(mass=2, gravity=(0, 0, -1.62), com=[0.0, 0.0, 10.0])
    assert hash(a) == hash(Load(mass=2, gravity=(0, 0, -1.62), com=[0.0, 0.0, 10.0]))
    back = pickle.loads(pickle.dumps(a))
    assert a != Load(mass=2.0) and back == a
    assert not a.force.flags.writeable and not back.gravity.flags.writeable


def test_bad_pose_or_load_argument():
    stack = Stack.reference(2)
    with pytest.raises(ValueError, match="^phi:"):
        sk.leg_forces(stack, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="^phi:"):
        sk.leg_forces(stack, np.tile([0, 0, 350, 0, 0, 0.0], (2, 1)), phi=0.0)
    with pytest.raises(ValueError, match="^q:"):
        sk.leg_forces(stack, np.zeros((3, 6)))
    with pytest.raises(ValueError, match="^q:"):
        sk.leg_forces(stack, np.zeros((2, 4)))
    with pytest.raises(ValueError, match="^q:"):
        sk.leg_forces(stack, [[math.nan] * 6] * 2)
    with pytest.raises(ValueError, match="^load:"):
        sk.leg_forces(stack, np.tile([0, 0, 350, 0, 0, 0.0], (2, 1)), {"mass": 1})
    with pytest.raises(ValueError, match="^q:"):
        sk.statics(stack, np.zeros((3, 2, 6)))


# =========================================================================================
# The statics fields of the geometry
# =========================================================================================
def test_geometry_statics_defaults_change_nothing():
    g = PlatformGeometry.reference()
    assert (g.plate_mass, g.leg_mass, g.force_max) == (0.0, 0.0, math.inf)
    assert set(g.to_dict()) == {
        "base_nodes",
        "top_nodes",
        "leg_min",
        "leg_max",
        "joint_min",
        "leg_radius",
    }
    assert "mass" not in Stack.reference(
        2, leg_radius=0.0
    ).to_toml() and "limit" not in describe_stack(Stack.reference(2))


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"plate_mass": -0.1}, "plate_mass"),
        ({"plate_mass": math.inf}, "plate_mass"),
        ({"leg_mass": math.nan}, "leg_mass"),
        ({"leg_mass": "1"}, "leg_mass"),
        ({"force_max": 0.0}, "force_max"),
        ({"force_max": -5.0}, "force_max"),
        ({"force_max": math.nan}, "force_max"),
        ({"force_max": True}, "force_max"),
    ],
)
def test_bad_statics_field_names_it(kwargs, field):
    with pytest.raises(GeometryError, match=f"^{field}:"):
        PlatformGeometry.hexagonal(**kwargs)
    g = PlatformGeometry.reference()
    with pytest.raises(GeometryError, match=f"^{field}:"):
        PlatformGeometry(g.base_nodes, g.top_nodes, 250, 450, 0.3, **kwargs)
    with pytest.raises(GeometryError, match=rf"^platforms\[0\]\.{field}:"):
        Stack.from_dict({"platforms": [{**g.to_dict(), **kwargs}]})


def test_geometry_statics_fields_round_trip(tmp_path):
    g = PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5, force_max=300.0)
    assert (g.plate_mass, g.leg_mass, g.force_max) == (5.0, 1.5, 300.0)
    assert g != PlatformGeometry.reference() and hash(g) != hash(PlatformGeometry.reference())
    assert g == PlatformGeometry.hexagonal(plate_mass=5, leg_mass=1.5, force_max=300)
    assert pickle.loads(pickle.dumps(g)) == g
    stack = Stack((g, PlatformGeometry.hexagonal(leg_mass=0.5), PlatformGeometry.reference()))
    assert stack.plate_mass.tolist() == [5.0, 0.0, 0.0]
    assert stack.leg_mass.tolist() == [1.5, 0.5, 0.0]
    assert stack.force_max.tolist() == [300.0, math.inf, math.inf]
    for suffix in (".toml", ".json"):
        path = tmp_path / f"stack{suffix}"
        (stack.to_toml if suffix == ".toml" else stack.to_json)(path)
        back = Stack.from_file(path)
        assert back == stack
        assert back.force_max.tolist() == [300.0, math.inf, math.inf]
    assert pickle.loads(pickle.dumps(stack)) == stack
    spec = {"platform": {"hexagonal": {"plate_mass": 2, "force_max": 50}}, "n": 2}
    assert Stack.from_dict(spec).force_max.tolist() == [50.0, 50.0]
    assert json.loads(stack.to_json())["platforms"][1] == {
        **PlatformGeometry.hexagonal().to_dict(),
        "leg_mass": 0.5,
    }
    assert "plate 5 kg, each leg 1.5 kg, leg force limit 300 N" in describe_stack(stack)


# --- solves with a finite force limit -----------------------------------------------


def test_solve_ik_never_calls_a_pose_over_its_force_limit_a_success() -> None:
    """A finite ``force_max`` is enforced (the solvers keep it; the check decides): the
    result is a success only with every leg within its limit, and a pose within every
    leg and joint limit that only its forces fail is never a success; a limit the
    unconstrained pose keeps leaves the verdict a success."""
    from stackik import PlanarTarget, solve_ik

    target = PlanarTarget(600.0, 1000.0, -1.57)
    tight = PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5, force_max=200.0)
    r = solve_ik(Stack((tight,) * 4), target)
    chk = check_pose(Stack((tight,) * 4), target, r.q)
    assert r.success == chk.ok
    if not r.success:
        assert chk.peak_force_ratio > 1.0 or chk.max_violation_mm > 1e-6
    else:
        assert chk.peak_force_ratio <= 1.0 + 1e-6
    loose = PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5, force_max=1e6)
    assert solve_ik(Stack((loose,) * 4), target).success


def test_solve_path_keeps_a_finite_force_limit() -> None:
    """Paths used to refuse a finite force_max (they could not enforce it); now every
    waypoint they return passes the check with the force limits (tests/test_path_loads.py
    has the case where the limit binds)."""
    from stackik import PlanarTarget, check_pose, solve_path

    g = PlatformGeometry.hexagonal(force_max=500.0)
    stack = Stack((g,) * 4)
    targets = [PlanarTarget(600.0, 1000.0, -1.57)] * 2
    path = solve_path(stack, targets)
    assert path.leg_forces is not None
    for t, q in zip(targets[: path.completed], path.q):
        assert check_pose(stack, t, q).ok
    assert np.abs(path.leg_forces[: path.completed]).max() <= 500.0 * (1 + 1e-6)


def test_oracle_statics_agree_with_leg_forces() -> None:
    """The fuzz oracle's statics (tests/reference_impl.world_leg_forces, base-frame
    equilibrium of each cut body) and stackik.leg_forces agree, planar and spatial."""
    from stackik import Load, leg_forces

    rng = np.random.default_rng(4)
    g = PlatformGeometry.hexagonal(plate_mass=3.0, leg_mass=1.2)
    stack = Stack((g,) * 3)
    load = Load(force=(3.0, -2.0, 5.0), moment=(0.4, 0.1, -0.2), frame="end_effector",
                mass=2.5, com=(10.0, -5.0, 20.0), gravity="mars")  # fmt: skip
    q = np.tile([0.0, 0.0, 330.0, 0.0, 0.0, 0.0], (3, 1)) + rng.normal(
        0, [8, 8, 8, 0.1, 0.1, 0.1], (3, 6)
    )
    poses = [ref.spatial_platform_pose(row) for row in q]
    want = ref.world_leg_forces(stack.base_nodes, stack.top_nodes, stack.plate_mass,
                                stack.leg_mass, poses, load.mass, load.com, load.g,
                                load.force, load.moment, load.frame)  # fmt: skip
    np.testing.assert_allclose(leg_forces(stack, q, load), want, rtol=1e-9, atol=1e-9)
    qp = np.tile([0.0, 330.0, 0.0], (3, 1)) + rng.normal(0, [8, 8, 0.1], (3, 3))
    poses = [ref.planar_platform_pose(row, 0.7) for row in qp]
    want = ref.world_leg_forces(stack.base_nodes, stack.top_nodes, stack.plate_mass,
                                stack.leg_mass, poses, load.mass, load.com, load.g,
                                load.force, load.moment, load.frame)  # fmt: skip
    np.testing.assert_allclose(leg_forces(stack, qp, load, phi=0.7), want, rtol=1e-9, atol=1e-9)
