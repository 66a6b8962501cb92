"""Self-leg clearance in the solvers (issue 29): the compiled kernels' rows and second
derivatives, and solves whose poses the independent check (stackik.clearance) finds clear."""

from __future__ import annotations

import fd
import numpy as np
import pytest

import stackik as sk
from stackik.formulation import Problem
from stackik.sampling import random_spatial_targets

RADIUS = 12.0
FAT = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=RADIUS), 4)
REF = sk.Stack.reference(4)
#: targets (random_spatial_targets(REF, 12, rng=4242)) whose least-FN default pose on
#: zero-radius legs puts two legs of a platform within 2 x 12 mm
COLLIDING = (1, 3, 9)


def _targets() -> list[sk.SpatialTarget]:
    return random_spatial_targets(REF, 12, rng=np.random.default_rng(4242))


def _problem(n: int, seed: int, margin: float = 0.0) -> tuple[Problem, np.ndarray]:
    stack = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=RADIUS), n)
    target = random_spatial_targets(sk.Stack.reference(n), 1, seed)[0]
    prob = Problem(stack, target, "frobenius", None, clearance=margin)
    rng = np.random.default_rng(seed)
    q = sk.paper_initial_guess(stack, target)
    q = q + rng.normal(size=q.shape) * np.array([20, 20, 20, 0.4, 0.3, 0.3])
    return prob, q


@pytest.mark.derivatives
@pytest.mark.parametrize("n", [2, 3])
def test_compiled_rows_and_lagrangian_hessian(n: int) -> None:
    """The compiled spatial evaluation carries each platform's 15 self-leg rows after its 24
    limits, with Problem's values, and its Lagrangian Hessian has their curvature."""
    from stackik._compiled.spatial import evaluate, lagrangian_hessian
    from stackik.methods.ip import spatial_problem_arrays

    prob, q = _problem(n, 7100 + n, margin=2.0)
    P = spatial_problem_arrays(prob)
    u = prob.u_of(q)
    f, g, cE, AE, cI, D = evaluate(u, P)
    R = 24 + 15
    assert D.shape == (n, R, 6) and cI.shape == (R * n,)
    cin = prob.evaluate(u)[4]
    blocks = cI.reshape(n, R)
    np.testing.assert_allclose(blocks[:, :24].ravel(), cin[: 24 * n], rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(blocks[:, 24:].ravel(), cin[24 * n :], rtol=1e-13, atol=1e-15)
    num = fd.central(lambda v: evaluate(v, P)[4], u)
    ana = np.zeros((R * n, 6 * n))
    for i in range(n):
        ana[R * i : R * (i + 1), 6 * i : 6 * i + 6] = D[i]
    fd.assert_derivative_close(ana, num, f_scale=fd.term_scale(cI, num), what="A_I")
    rng = np.random.default_rng(n)
    yE, z = rng.normal(size=6), rng.uniform(0, 2, size=R * n)

    def lag_grad(v: np.ndarray) -> np.ndarray:
        _, g_, _, AE_, _, D_ = evaluate(v, P)
        return g_ - AE_.T @ yE - np.einsum("ir,irk->ik", z.reshape(n, R), D_).ravel()

    H = lagrangian_hessian(u, yE, z, P)
    num = fd.central(lag_grad, u)
    fd.assert_derivative_close(H, num, f_scale=fd.term_scale(lag_grad(u), num), what="W")


def test_zero_radius_problem_has_no_rows() -> None:
    from stackik.methods.ip import spatial_problem_arrays

    t = _targets()[0]
    prob = Problem(REF, t, "frobenius", None)
    assert prob.self_legs is None and prob.n_ineq == 96
    assert spatial_problem_arrays(prob).pairs.shape == (0, 2)
    assert Problem(REF, t, "frobenius", None, clearance=1.0).self_legs is not None
    planar = Problem(FAT, sk.PlanarTarget(100.0, 500.0, 0.0), "frobenius", None)
    assert planar.self_legs is None  # planar legs: checked, not constrained


@pytest.mark.parametrize("method", ["auto", "sqp", "slsqp"])
def test_solves_keep_the_legs_apart(method: str) -> None:
    """On targets whose zero-radius optimum drives legs into each other, every method
    returns a success whose legs the check's own distances find clear, at a small FN cost."""
    targets = _targets()
    for k in COLLIDING:
        t = targets[k]
        plain = sk.solve_ik(REF, t)
        assert plain.success and sk.clearances(FAT, plain.q).self_legs < 0.0
        r = sk.solve_ik(FAT, t, method=method)
        assert r.success, (k, r.message)
        assert r.clearances is not None and r.clearances.self_legs >= -1e-6
        assert sk.clearances(FAT, r.q).self_legs >= -1e-6
        assert r.frobenius_norm >= plain.frobenius_norm * (1 - 1e-9) - 1e-9
        assert r.frobenius_norm <= plain.frobenius_norm * 1.02


def test_margin_is_kept() -> None:
    t = _targets()[COLLIDING[0]]
    r = sk.solve_ik(FAT, t, clearance=5.0)
    assert r.success and r.clearances is not None
    assert r.clearances.self_legs >= 5.0 - 1e-6
    with pytest.raises(ValueError, match="clearance"):
        sk.solve_ik(FAT, t, clearance=-1.0)
    with pytest.raises(ValueError, match="clearance"):
        sk.solve_ik(FAT, t, clearance=float("nan"))


def test_obstacles_are_enforced_by_the_check() -> None:
    """A sphere around the target point meets the end-effector plate in every pose that
    reaches the target: the check refuses every pose, so no success."""
    t = _targets()[0]
    r = sk.solve_ik(REF, t, obstacles=[sk.Sphere(t.position, 30.0)])
    assert not r.success and r.clearances is not None
    assert r.clearances.minimum < 0.0
    with pytest.raises(ValueError):
        sk.solve_ik(REF, t, obstacles=[sk.Sphere(t.position, -1.0)])


def test_cli_solve_clearance_and_obstacles(capsys: pytest.CaptureFixture[str], tmp_path) -> None:
    """stackik solve --geometry (12 mm legs) --obstacles FILE --clearance MM: the table has
    the clearances, the JSON their values; a bad file is a one-line usage error."""
    import json

    from stackik.cli import main

    geo = tmp_path / "legs12.toml"
    FAT.to_toml(geo)
    obs = tmp_path / "obstacles.toml"
    obs.write_text('[[obstacles]]\ntype = "sphere"\ncenter = [300, 0, 300]\nradius = 40\n')
    args = ["solve", "--spatial", "--position", "20", "-30", "1300", "--geometry", str(geo)]
    assert main([*args, "--obstacles", str(obs), "--clearance", "2"]) == 0
    out = capsys.readouterr().out
    assert "Clearances [mm]" in out and "obstacle 0:" in out and "closest:" in out
    assert main([*args, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["success"] and data["clearances"]["self_legs"] >= -1e-6
    bad = tmp_path / "bad.toml"
    bad.write_text('[[obstacles]]\ntype = "sphere"\ncenter = [0, 0, 0]\nradius = -1\n')
    assert main([*args, "--obstacles", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "--obstacles" in err and len(err.strip().splitlines()) == 1
