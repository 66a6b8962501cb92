"""``solve_ik(..., force_weight=w)``: the scaled leg forces added to any objective
(stackik.formulation.problem.Problem, stackik.formulation.forces.ForceResiduals)."""

from __future__ import annotations

import math

import fd
import numpy as np
import pytest

from stackik import (
    Load,
    PlanarTarget,
    PlatformGeometry,
    SpatialTarget,
    Stack,
    check_pose,
    leg_forces,
    solve_ik,
    statics,
)
from stackik.formulation import Problem
from stackik.formulation.forces import force_scales
from stackik.kinematics import frobenius_norm, planar_jacobian, spatial_jacobian

LOAD = Load(mass=4.0)
GEOMETRY = PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5)
SPATIAL = SpatialTarget.from_euler((100.0, 50.0, 900.0), 0.2, 0.1, 0.0)
PLANAR = PlanarTarget(600.0, 1000.0, -1.57)


def _mixed_stack(n: int) -> Stack:
    """Platforms with and without a force limit (so both scalings of the residuals)."""
    gs = [
        PlatformGeometry.hexagonal(
            plate_mass=2.0 + i, leg_mass=0.3 * i, force_max=(300.0 if i % 2 == 0 else math.inf)
        )
        for i in range(n)
    ]
    return Stack(tuple(gs))


def _pose(planar: bool, n: int, rng: np.random.Generator) -> np.ndarray:
    if planar:
        return np.tile([0.0, 350.0, 0.0], (n, 1)) + rng.normal(size=(n, 3)) * [20, 20, 0.2]
    base = np.tile([0.0, 0.0, 350.0, 0.0, 0.0, 0.0], (n, 1))
    return base + rng.normal(size=(n, 6)) * [20, 20, 20, 0.2, 0.2, 0.2]


def _fn(q: np.ndarray, planar: bool) -> float:
    return frobenius_norm(planar_jacobian(q) if planar else spatial_jacobian(q))


def _force_term(stack: Stack, q: np.ndarray, load: Load, phi: float | None) -> float:
    """``sum_ik (f_ik / s_i)^2`` by the statics model (stackik.leg_forces)."""
    s = force_scales(stack)
    return float(np.sum((leg_forces(stack, q, load, phi=phi) / s[:, None]) ** 2))


@pytest.mark.derivatives
@pytest.mark.parametrize(
    ("planar", "objective"),
    [(False, "frobenius"), (True, "frobenius"), (False, "weighted"), (True, "feasible")],
)
def test_weighted_objective_value_and_gradient(planar: bool, objective: str) -> None:
    """With a force weight, the scaled objective is ``(FN^2 + w sum (f/s)^2) / fscale``
    (FN^2 the objective's own value, 0 for "feasible"), ``objective_value`` its unscaled
    value, the Gauss-Newton residuals give it as ``c + |r|^2``, and its gradient matches
    central differences."""
    rng = np.random.default_rng(11)
    n = 3
    stack = _mixed_stack(n)
    q = _pose(planar, n, rng)
    target = (
        PlanarTarget(0.0, 1000.0, 0.0)
        if planar
        else SpatialTarget.from_euler((0, 0, 1000), 0, 0, 0)
    )
    phi = 0.0 if planar else None
    weights = (np.full(n, 1.0), np.full(n, 0.005**2)) if objective == "weighted" else None
    w = 3.0
    prob = Problem(stack, target, objective, weights, load=LOAD, force_weight=w)
    bare = Problem(stack, target, objective, weights, load=LOAD)
    assert prob.force_weight == w and bare.force_weight == 0.0
    u = prob.u_of(q)
    force = _force_term(stack, q, LOAD, phi)
    expected = bare.objective_value(q) + w * force
    assert prob.objective_value(q) == pytest.approx(expected, rel=1e-12)
    if objective == "frobenius":
        assert bare.objective_value(q) == pytest.approx(_fn(q, planar) ** 2, rel=1e-12)
    f, g = prob.evaluate(u)[:2]
    assert f == pytest.approx(expected / prob.fscale, rel=1e-12)
    r, _ = prob.gauss_newton(u)
    c = 0.0 if objective == "feasible" else prob.c0 / prob.fscale
    assert float(r @ r) + c == pytest.approx(f, rel=1e-12)

    def value(x: np.ndarray) -> np.ndarray:
        fresh = Problem(stack, target, objective, weights, load=LOAD, force_weight=w)
        return np.array([fresh.evaluate(x)[0]])

    num = fd.central(value, u, typical=1.0)
    fd.assert_derivative_close(g[None, :], num, f_scale=abs(f) + 1.0, what="weighted objective")
    # the Gauss-Newton Jacobian of the stacked residuals: 2 Jr^T r is the gradient
    r, Jr = prob.gauss_newton(u)
    np.testing.assert_allclose(2.0 * Jr.T @ r, g, rtol=1e-12, atol=1e-12 * np.abs(g).max())


def test_zero_weight_is_todays_solve() -> None:
    """``force_weight=0`` (and 0.0) is the default: the same pose, value and method."""
    stack = Stack.uniform(GEOMETRY, 4)
    a = solve_ik(stack, PLANAR, load=LOAD)
    for w in (0, 0.0):
        b = solve_ik(stack, PLANAR, load=LOAD, force_weight=w)
        np.testing.assert_array_equal(a.q, b.q)
        assert (a.objective_value, a.frobenius_norm, a.method) == (
            b.objective_value,
            b.frobenius_norm,
            b.method,
        )


@pytest.mark.parametrize(
    ("n", "target", "weights"),
    [(3, SPATIAL, (0.0, 0.01, 0.1, 1.0)), (4, PLANAR, (0.0, 0.01, 0.1, 1.0, 10.0))],
)
def test_weight_trades_frobenius_norm_for_leg_force(n: int, target, weights) -> None:
    """On a loaded stack a growing weight lowers the sum of squared leg forces and the
    peak force, and raises FN; every result passes the check with the load, reports
    ``objective_value = FN^2 + w sum f^2`` and the pose's own FN."""
    stack = Stack.uniform(GEOMETRY, n)
    planar = isinstance(target, PlanarTarget)
    phi = target.phi if planar else None
    fns, forces, peaks = [], [], []
    for w in weights:
        r = solve_ik(stack, target, load=LOAD, force_weight=w)
        assert r.success
        assert check_pose(stack, target, r.q, LOAD).ok
        fn = _fn(r.q, planar)
        force = _force_term(stack, r.q, LOAD, phi)
        assert r.frobenius_norm == pytest.approx(fn, rel=1e-12)
        assert r.objective_value == pytest.approx(fn**2 + w * force, rel=1e-9)
        if w > 0:
            assert r.method == "slsqp"
        fns.append(fn)
        forces.append(force)
        peaks.append(statics(stack, r.q, LOAD, phi=phi).peak_force)
    assert all(b >= a * (1 - 1e-9) for a, b in zip(fns, fns[1:], strict=False)), fns
    assert all(b <= a * (1 + 1e-9) for a, b in zip(forces, forces[1:], strict=False)), forces
    assert peaks[-1] < 0.75 * peaks[0], peaks
    assert fns[-1] > fns[0] * 1.01


@pytest.mark.parametrize("kw", [dict(method="sqp"), dict(method="trust-constr")])
def test_other_methods_take_the_weight(kw: dict) -> None:
    """The SQP engine (dense, damped BFGS) and trust-constr take the weight: from the
    weightless optimum they lower the weighted objective and pass the check."""
    stack = Stack.uniform(GEOMETRY, 4)
    w = 0.1
    base = solve_ik(stack, PLANAR, load=LOAD)
    r = solve_ik(stack, PLANAR, load=LOAD, force_weight=w, x0=base.q, **kw)
    assert r.success and check_pose(stack, PLANAR, r.q, LOAD).ok
    before = base.frobenius_norm**2 + w * _force_term(stack, base.q, LOAD, PLANAR.phi)
    assert r.objective_value < before * (1 - 1e-3)
    assert r.objective_value == pytest.approx(
        r.frobenius_norm**2 + w * _force_term(stack, r.q, LOAD, PLANAR.phi), rel=1e-9
    )


def test_feasible_objective_with_weight() -> None:
    """``objective="feasible"`` with a weight minimises the force term alone among the
    poses that reach the target: lower than the first feasible pose's."""
    stack = Stack.uniform(GEOMETRY, 4)
    plain = solve_ik(stack, PLANAR, load=LOAD, objective="feasible")
    r = solve_ik(stack, PLANAR, load=LOAD, objective="feasible", force_weight=1.0)
    assert r.success and plain.success
    assert r.objective_value == pytest.approx(_force_term(stack, r.q, LOAD, PLANAR.phi), rel=1e-9)
    assert r.objective_value < _force_term(stack, plain.q, LOAD, PLANAR.phi)


@pytest.mark.parametrize("bad", [-1.0, math.nan, math.inf, "1", None, True, [1.0]])
def test_bad_weight(bad) -> None:
    stack = Stack.uniform(GEOMETRY, 2)
    with pytest.raises(ValueError, match="force_weight"):
        solve_ik(stack, PlanarTarget(0.0, 700.0, 0.0), force_weight=bad)


@pytest.mark.parametrize("method", ["ip", "ipopt"])
def test_ip_and_ipopt_refuse_the_weight(method: str) -> None:
    stack = Stack.uniform(GEOMETRY, 2)
    with pytest.raises(ValueError, match=f'method "{method}" does not take force_weight'):
        solve_ik(stack, PlanarTarget(0.0, 700.0, 0.0), force_weight=1.0, method=method)


def test_force_objective_takes_no_weight() -> None:
    stack = Stack.uniform(GEOMETRY, 2)
    with pytest.raises(ValueError, match="force_weight"):
        solve_ik(stack, PlanarTarget(0.0, 700.0, 0.0), objective="force", force_weight=1.0)


def test_cli_force_weight(capsys: pytest.CaptureFixture[str], tmp_path) -> None:
    """``stackik solve --force-weight W``: the weight reaches the solve (the JSON objective
    value is FN^2 + W sum f^2 at the pose, below the weightless pose's force term), the
    table names it, a negative weight is a CLI error naming it."""
    import json

    from stackik.cli import main

    geo = tmp_path / "g.toml"
    geo.write_text("n = 4\n[platform.hexagonal]\nplate_mass = 5.0\nleg_mass = 1.5\n")
    args = ["solve", "--geometry", str(geo), "--target", "600", "1000", "-1.57"]
    args += ["--payload-mass", "4"]
    assert main([*args, "--force-weight", "1", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    stack = Stack.uniform(GEOMETRY, 4)
    q = np.array(data["q"])
    force = _force_term(stack, q, LOAD, PLANAR.phi)
    assert data["force_weight"] == 1.0 and data["method"] == "slsqp"
    assert data["objective_value"] == pytest.approx(data["frobenius_norm"] ** 2 + force, rel=1e-9)
    base = solve_ik(stack, PLANAR, load=LOAD)
    assert force < 0.5 * _force_term(stack, base.q, LOAD, PLANAR.phi)
    assert main([*args, "--force-weight", "0.5"]) == 0
    assert "force weight" in capsys.readouterr().out
    assert main([*args, "--force-weight", "-1"]) != 0
    assert "force_weight" in capsys.readouterr().err


def test_weight_with_a_force_limit() -> None:
    """With a finite force_max the force term is in force ratios (s = force_max): the
    weighted solve keeps the limit (the check passes with the load), reports
    ``FN^2 + w sum (f / force_max)^2`` and loads the legs less than the weightless one."""
    g = PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5, force_max=450.0)
    stack = Stack.uniform(g, 3)
    load = Load(mass=2.0)
    w = 1e4
    base = solve_ik(stack, SPATIAL, load=load)
    r = solve_ik(stack, SPATIAL, load=load, force_weight=w)
    assert r.success and base.success and check_pose(stack, SPATIAL, r.q, load).ok
    ratios = leg_forces(stack, r.q, load) / 450.0
    assert r.objective_value == pytest.approx(
        _fn(r.q, False) ** 2 + w * float(np.sum(ratios**2)), rel=1e-9
    )
    peak = statics(stack, r.q, load).peak_force_ratio
    assert peak < 0.9 * statics(stack, base.q, load).peak_force_ratio
