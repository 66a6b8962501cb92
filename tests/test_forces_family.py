"""The leg-force limit family (stackik.formulation.forces) and force-limited solves."""

from __future__ import annotations

import math

import fd
import numpy as np
import pytest

from stackik import (
    IKStatus,
    Load,
    PlanarTarget,
    PlatformGeometry,
    Stack,
    check_pose,
    leg_forces,
    solve_ik,
)
from stackik.formulation import Problem
from stackik.formulation.forces import ForceLimits
from stackik.methods.ipopt import ipopt_available

LOAD = Load(
    mass=3.0, com=(10.0, 5.0, 20.0), force=(1.0, 2.0, 3.0), moment=(0.5, -0.2, 0.1),
    frame="end_effector", gravity=(1.0, -2.0, -9.0),
)  # fmt: skip


def _mixed_stack(n: int) -> Stack:
    """Platforms with and without a force limit, different masses."""
    gs = [
        PlatformGeometry.hexagonal(
            plate_mass=2.0 + i, leg_mass=0.3 * i, force_max=(60.0 if i % 2 == 0 else math.inf)
        )
        for i in range(n)
    ]
    return Stack(tuple(gs))


def _pose(planar: bool, n: int, rng: np.random.Generator) -> np.ndarray:
    if planar:
        return np.tile([0.0, 350.0, 0.0], (n, 1)) + rng.normal(size=(n, 3)) * [20, 20, 0.2]
    base = np.tile([0.0, 0.0, 350.0, 0.0, 0.0, 0.0], (n, 1))
    return base + rng.normal(size=(n, 6)) * [20, 20, 20, 0.2, 0.2, 0.2]


@pytest.mark.derivatives
@pytest.mark.parametrize("planar", [False, True])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_force_rows_values_and_jacobian(planar: bool, seed: int) -> None:
    """Row values are 1 -+ f / force_max of stackik.leg_forces on the limited platforms; the
    complex-step Jacobian matches central differences of stackik.leg_forces (Richardson,
    tolerance from tests/fd.py's scale model: F = the force scale over force_max)."""
    rng = np.random.default_rng(seed)
    n = 4
    stack = _mixed_stack(n)
    phi = 0.4 if planar else None
    q = _pose(planar, n, rng)
    rows = ForceLimits(stack, LOAD, phi)
    assert rows.platforms.tolist() == [0, 2] and rows.size == 24
    c, J = rows(q)
    f = leg_forces(stack, q, LOAD, phi=phi)
    for j, i in enumerate(rows.platforms):
        block = c[12 * j : 12 * j + 12]
        np.testing.assert_allclose(block[:6], 1 - f[i] / 60.0, rtol=0, atol=1e-13)
        np.testing.assert_allclose(block[6:], 1 + f[i] / 60.0, rtol=0, atol=1e-13)

    def values(x: np.ndarray) -> np.ndarray:
        g = leg_forces(stack, x.reshape(q.shape), LOAD, phi=phi)[rows.platforms] / 60.0
        return np.concatenate([np.concatenate([1 - r, 1 + r]) for r in g])

    typical = fd.TYPICAL_PLANAR if planar else fd.TYPICAL_SPATIAL
    num = fd.central(values, q.ravel(), typical=np.tile(typical, n), richardson=True)
    F = 1.0 + float(np.abs(f).max()) / 60.0  # the rows' terms: 1 and f / force_max
    fd.assert_derivative_close(J, num, f_scale=F, what="force rows")


def test_no_force_limit_no_rows() -> None:
    """Without a finite force_max a problem has exactly the 24 n limit rows (every solve is
    unchanged), with or without a load."""
    stack = Stack.reference(3, leg_radius=0.0)
    target = PlanarTarget(300.0, 900.0, 0.3)
    for load in (None, LOAD):
        prob = Problem(stack, target, "frobenius", None, load=load)
        assert prob.forces is None and prob.n_ineq == 24 * 3
        assert prob.evaluate(prob.u_of(np.tile([0.0, 300.0, 0.1], (3, 1))))[4].size == 72


def _binding_stack(fraction: float) -> tuple[Stack, PlanarTarget, float]:
    """A planar n = 4 target whose unloaded least-FN pose has its peak leg force over
    ``fraction`` of it as the limit."""
    target = PlanarTarget(600.0, 1000.0, -1.57)
    free = Stack.uniform(PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5), 4)
    r0 = solve_ik(free, target)
    peak = float(np.abs(leg_forces(free, r0.q, phi=target.phi)).max())
    g = PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5, force_max=fraction * peak)
    return Stack.uniform(g, 4), target, r0.frobenius_norm


METHODS = [
    dict(),
    dict(method="ip"),
    dict(method="slsqp"),
    dict(method="sqp"),
    dict(method="sqp", qp_solver="clarabel"),
    dict(method="trust-constr"),
]
if ipopt_available():
    METHODS.append(dict(method="ipopt"))


@pytest.mark.parametrize("kw", METHODS, ids=lambda kw: "-".join(map(str, kw.values())) or "auto")
def test_every_method_keeps_a_binding_force_limit(kw: dict) -> None:
    """With force_max at 85 % of the unloaded optimum's peak force every method returns a
    success whose forces are within the limit (the check enforces it independently), at
    an FN no lower than the unconstrained optimum's."""
    stack, target, fn_free = _binding_stack(0.85)
    r = solve_ik(stack, target, **kw)
    assert r.success, (kw, r.status, r.message)
    chk = check_pose(stack, target, r.q)
    assert chk.ok and chk.peak_force_ratio <= 1 + 1e-6
    assert r.frobenius_norm >= fn_free * (1 - 1e-9)


@pytest.mark.skipif(not ipopt_available(), reason="needs the ipopt extra (CI installs it)")
def test_default_matches_ipopt_with_lifted_forces() -> None:
    """The default's force-limited pose has the FN that IPOPT from 8 starts finds with the
    forces lifted as variables (a formulation written apart), within 0.1 %."""
    stack, target, _ = _binding_stack(0.85)
    r = solve_ik(stack, target)
    ref = solve_ik(stack, target, method="ipopt", starts=8)
    assert r.success and ref.success
    assert r.frobenius_norm <= ref.frobenius_norm * (1 + 1e-3)


def test_a_load_no_pose_can_carry_is_not_a_success() -> None:
    """A force limit far below what the stack's own weight needs: no pose passes, the
    result is not a success and its pose is over the limit (the least-violating one)."""
    g = PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5, force_max=0.5)
    stack = Stack.uniform(g, 3)
    target = PlanarTarget(200.0, 900.0, 0.2)
    r = solve_ik(stack, target, max_time=20.0)
    assert not r.success and r.status is not IKStatus.SUCCESS
    assert check_pose(stack, target, r.q).peak_force_ratio > 1


def test_load_must_be_a_load() -> None:
    with pytest.raises(ValueError, match="load"):
        solve_ik(
            Stack.reference(2, leg_radius=0.0), PlanarTarget(0.0, 700.0, 0.0), load={"mass": 1.0}
        )


def test_result_carries_leg_forces_margins_and_singularity() -> None:
    """With a load (or a finite force_max) IKResult has the statics of its pose, equal to
    stackik.statics, and they survive to_record/from_record; without either, None."""
    import json

    from stackik import IKResult, statics

    stack, target, _ = _binding_stack(0.85)
    load = Load(mass=0.0)
    r = solve_ik(stack, target, load=load)
    st = statics(stack, r.q, load, phi=target.phi)
    assert r.leg_forces is not None and r.force_margin is not None
    np.testing.assert_array_equal(r.leg_forces, st.leg_forces)
    np.testing.assert_array_equal(r.force_margin, st.force_margin)
    np.testing.assert_array_equal(r.sigma_min, st.sigma_min)
    np.testing.assert_array_equal(r.condition, st.condition)
    assert r.peak_force == pytest.approx(st.peak_force)
    back = IKResult.from_record(json.loads(json.dumps(r.to_record())))
    np.testing.assert_array_equal(back.leg_forces, r.leg_forces)
    free = solve_ik(Stack.reference(2, leg_radius=0.0), PlanarTarget(0.0, 700.0, 0.0))
    assert free.leg_forces is None and free.peak_force is None
    assert free.to_dict()["leg_forces"] is None


def test_cli_solve_load_options(capsys: pytest.CaptureFixture[str], tmp_path) -> None:
    """stackik solve --payload-mass/--gravity/...: the load reaches the solve, the table
    shows leg forces, margins and the singularity measure, JSON has them; bad values are
    a clear CLI error naming the option."""
    import json

    from stackik.cli import main

    geo = tmp_path / "g.toml"
    geo.write_text("n = 4\n[platform.hexagonal]\nplate_mass = 5.0\nleg_mass = 1.5\n")
    args = ["solve", "--geometry", str(geo), "--target", "600", "1000", "-1.57"]
    assert main([*args, "--payload-mass", "2", "--gravity", "moon"]) == 0
    out = capsys.readouterr().out
    assert "Leg forces [N] (compression positive)" in out and "sigma_min" in out
    assert main([*args, "--payload-mass", "2", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert len(data["leg_forces"]) == 4 and len(data["condition"]) == 4
    assert main([*args, "--gravity", "0", "0", "-9.81", "--load-frame", "end_effector"]) == 0
    capsys.readouterr()
    assert main([*args, "--gravity", "jupiter"]) != 0
    assert "gravity" in capsys.readouterr().err
    assert main([*args, "--payload-mass", "-1"]) != 0
    assert "mass" in capsys.readouterr().err


def test_payload_capacity_brackets_the_largest_payload() -> None:
    """payload_capacity: the pose at ``mass`` carries it (independent check with that load),
    ``upper`` is not carried, and they are within ``tol``; bad input is a ValueError."""
    import dataclasses

    from stackik import payload_capacity

    g = PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5, force_max=450.0)
    stack = Stack.uniform(g, 4)
    target = PlanarTarget(600.0, 1000.0, -1.57)
    cap = payload_capacity(stack, target, tol=0.5)
    assert 0.0 < cap.mass < cap.upper <= cap.mass + 0.5 and cap.result.success
    chk = check_pose(stack, target, cap.result.q, Load(mass=cap.mass))
    assert chk.ok and chk.peak_force_ratio <= 1 + 1e-6
    over = solve_ik(stack, target, load=dataclasses.replace(Load(), mass=cap.upper))
    assert not over.success
    with pytest.raises(ValueError, match="force_max"):
        payload_capacity(Stack.reference(2, leg_radius=0.0), PlanarTarget(0.0, 700.0, 0.0))
    with pytest.raises(ValueError, match="tol"):
        payload_capacity(stack, target, tol=0.0)


@pytest.mark.parametrize("kw", [dict(), dict(method="sqp"), dict(method="trust-constr")])
def test_force_objective_balances_the_legs(kw: dict) -> None:
    """objective="force" minimises the sum of squared scaled leg forces: its value equals
    that sum at the returned pose and is below the least-FN pose's (with the same load and
    force limit); "ip" refuses it with a clear error."""
    g = PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5, force_max=450.0)
    stack = Stack.uniform(g, 4)
    target = PlanarTarget(600.0, 1000.0, -1.57)
    load = Load(mass=2.0)
    fn_pose = solve_ik(stack, target, load=load)
    r = solve_ik(stack, target, load=load, objective="force", **kw)
    assert r.success and r.leg_forces is not None and fn_pose.leg_forces is not None
    value = float(np.sum((r.leg_forces / 450.0) ** 2))
    assert r.objective_value == pytest.approx(value, rel=1e-9)
    assert value < 0.5 * float(np.sum((fn_pose.leg_forces / 450.0) ** 2))
    assert r.frobenius_norm >= fn_pose.frobenius_norm * (1 - 1e-9)
    with pytest.raises(ValueError, match="force"):
        solve_ik(stack, target, objective="force", method="ip")


@pytest.mark.derivatives
def test_force_residuals_jacobian() -> None:
    """The force objective's residual Jacobian (complex step) against Richardson central
    differences of stackik.leg_forces, spatial, a mixed stack."""
    from stackik.formulation.forces import ForceResiduals, force_scales

    rng = np.random.default_rng(5)
    stack = _mixed_stack(3)
    q = _pose(False, 3, rng)
    res = ForceResiduals(stack, LOAD, None)
    r, J = res.residuals(q)
    s = force_scales(stack)
    np.testing.assert_allclose(r, (leg_forces(stack, q, LOAD) / s[:, None]).ravel(), atol=1e-12)

    def values(x: np.ndarray) -> np.ndarray:
        return (leg_forces(stack, x.reshape(q.shape), LOAD) / s[:, None]).ravel()

    num = fd.central(values, q.ravel(), typical=np.tile(fd.TYPICAL_SPATIAL, 3), richardson=True)
    fd.assert_derivative_close(J, num, f_scale=1.0 + float(np.abs(r).max()), what="force residuals")


@pytest.mark.parametrize("planar", [False, True])
@pytest.mark.parametrize("gravity", ["earth", "moon", "mars", "none", (1.0, -2.0, -9.0)])
@pytest.mark.parametrize("frame", ["base", "end_effector"])
def test_compiled_statics_equal_the_independent_model(planar, gravity, frame) -> None:
    """The solvers' compiled leg forces (stackik._compiled.force_rows, the family's one
    definition) equal the check's statics (stackik.leg_forces, numpy with an SVD per
    platform) to 1e-9 relative on random poses of a mixed stack, every gravity preset,
    either load frame; the Jacobian of every platform's forces matches central
    differences of stackik.leg_forces."""
    from stackik._compiled.force_rows import leg_force_jacobian
    from stackik.formulation.forces import force_kernel_args

    load = Load(
        mass=2.0, com=(5.0, -3.0, 12.0), force=(2.0, -1.0, 4.0), moment=(0.3, 0.1, -0.2),
        frame=frame, gravity=gravity,
    )  # fmt: skip
    n = 3
    stack = _mixed_stack(n)
    phi = 0.9 if planar else None
    rng = np.random.default_rng(7)
    for _ in range(3):
        q = _pose(planar, n, rng)
        f, J, ok = leg_force_jacobian(
            np.ascontiguousarray(q), stack.top_nodes, stack.base_nodes,
            *force_kernel_args(stack, load), planar, 0.0 if phi is None else phi,
        )  # fmt: skip
        ref = leg_forces(stack, q, load, phi=phi)
        assert ok
        scale = float(np.abs(ref).max())
        np.testing.assert_allclose(f, ref, rtol=0, atol=1e-9 * scale)
    typical = fd.TYPICAL_PLANAR if planar else fd.TYPICAL_SPATIAL
    num = fd.central(
        lambda x: leg_forces(stack, x.reshape(q.shape), load, phi=phi).ravel(), q.ravel(),
        typical=np.tile(typical, n), richardson=True,
    )  # fmt: skip
    fd.assert_derivative_close(J, num, f_scale=scale, what="leg forces")


def test_compiled_statics_singular_platform_is_nan() -> None:
    """A platform whose legs have no length (top nodes on the base nodes) has no leg wrench
    matrix: the rows are NaN (the interior point reports a non-finite evaluation), no
    exception."""
    stack = _mixed_stack(2)
    rows = ForceLimits(stack, LOAD, None)
    q = np.zeros((2, 6))
    q[1, 2] = 350.0
    c, J = rows(q)
    assert c.shape == (12,) and J.shape == (12, 12)  # platform 0 has a limit
    assert np.isnan(c).all() and np.isnan(J).all()


def _spatial_binding(fraction: float) -> tuple[Stack, object, float]:
    """A spatial n = 3 target whose unloaded least-FN pose has its peak leg force over
    ``fraction`` of it as the limit (the stack's weight and a 4 kg payload)."""
    from stackik import SpatialTarget, spatial_forward

    free = Stack.uniform(PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5), 3)
    q = np.tile([0.0, 0.0, 330.0, 0.0, 0.0, 0.0], (3, 1))
    q[:, 0] = [40.0, 50.0, 30.0]
    q[:, 4] = [0.15, 0.1, 0.2]
    P, R = spatial_forward(q)
    target = SpatialTarget(P, R)
    load = Load(mass=4.0)
    r0 = solve_ik(free, target, load=load)
    assert r0.success
    peak = float(np.abs(leg_forces(free, r0.q, load)).max())
    g = PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5, force_max=fraction * peak)
    return Stack.uniform(g, 3), target, r0.frobenius_norm


@pytest.mark.parametrize("method", ["auto", "ip"])
def test_spatial_interior_point_carries_the_force_rows(method: str) -> None:
    """Spatial: a binding force limit is met by the compiled interior point itself (the
    result's method is "ip", no hand-over to SLSQP); the independent check passes and the
    FN is no lower than the unconstrained optimum's."""
    stack, target, fn_free = _spatial_binding(0.85)
    load = Load(mass=4.0)
    r = solve_ik(stack, target, load=load, method=method)
    assert r.success, (r.status, r.message)
    assert r.method == "ip"
    chk = check_pose(stack, target, r.q, load=load)
    assert chk.ok and chk.peak_force_ratio <= 1 + 1e-6
    assert r.frobenius_norm >= fn_free * (1 - 1e-9)
