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
REF = sk.Stack.reference(4, leg_radius=0.0)
#: targets (random_spatial_targets(REF, 12, rng=4242)) whose least-FN default pose on
#: zero-radius legs puts two legs of a platform within 2 x 12 mm
COLLIDING = (1, 3, 9)


def _targets() -> list[sk.SpatialTarget]:
    return random_spatial_targets(REF, 12, rng=np.random.default_rng(4242))


def _problem(n: int, seed: int, margin: float = 0.0) -> tuple[Problem, np.ndarray]:
    stack = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=RADIUS), n)
    target = random_spatial_targets(sk.Stack.reference(n, leg_radius=0.0), 1, seed)[0]
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
    assert planar.self_legs is not None and planar.dense_rows  # outside the planar kernels
    thin = Problem(REF, sk.PlanarTarget(100.0, 500.0, 0.0), "frobenius", None)
    assert thin.self_legs is None and not thin.dense_rows


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


@pytest.mark.parametrize(
    "target", [["--target", "300", "800", "0.2"], ["--spatial", "--position", "100", "50", "600"]]
)
def test_cli_solve_shows_far_obstacles(
    capsys: pytest.CaptureFixture[str], tmp_path, target: list[str]
) -> None:
    """An obstacle out of every body's reach: the solve's check leaves it out
    (``IKResult.clearances`` None), the CLI's table and JSON still give its distance."""
    import json

    from stackik.cli import main

    obs = tmp_path / "far.toml"
    obs.write_text('[[obstacles]]\ntype = "sphere"\ncenter = [3000, 0, 500]\nradius = 100\n')
    args = ["solve", "--n", "4", *target, "--obstacles", str(obs)]
    assert main(args) == 0
    assert "obstacle 0:" in capsys.readouterr().out
    assert main([*args, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["clearances"]["obstacles"][0] > 1000.0


OBSTACLES3 = (
    sk.Sphere((50, 20, 500), 30.0),
    sk.Capsule((-300, 100, 300), (300, -50, 700), 10.0),
    sk.HalfSpace((0, 0, -50), (0.1, 0, 1)),
)


@pytest.mark.derivatives
def test_obstacle_rows_derivatives_and_values() -> None:
    """The obstacle rows' Jacobian against central differences, and their values against
    the check's own leg-obstacle distances."""
    from stackik.formulation.obstacle_rows import ObstacleRows

    stack = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=RADIUS), 3)
    rows = ObstacleRows(stack, OBSTACLES3, 1.0)
    rng = np.random.default_rng(1)
    base = np.tile([0.0, 0.0, 300.0, 0.0, 0.0, 0.0], (3, 1))
    q = base + rng.normal(0, [20, 20, 20, 0.2, 0.2, 0.2], (3, 6))
    c, J = rows(q)
    assert c.shape == (rows.size,) == (18 + 3 + 18 + 36,) and J.shape == (rows.size, 18)
    num = fd.central(lambda x: rows(x.reshape(3, 6))[0], q.ravel())
    fd.assert_derivative_close(J, num, f_scale=fd.term_scale(c, num), what="obstacle rows")
    # leg surface distances from the rows, against stackik.clearance's (legs and plates:
    # where a leg is the closest body they agree)
    L = rows.L
    legs_sphere = np.sqrt(c[:18] * L**2 + (30 + RADIUS + 1) ** 2) - RADIUS - 30
    legs_half = (c[39:] * L + RADIUS + 1).min() - RADIUS
    cl = sk.clearances(stack, q, OBSTACLES3)
    assert legs_sphere.min() == pytest.approx(cl.obstacles[0], abs=1e-9)
    assert legs_half == pytest.approx(cl.obstacles[2], abs=1e-9)


def test_auto_goes_around_a_sphere_on_a_leg() -> None:
    """A sphere on a leg of the least-FN pose: the default (whose interior point carries
    the obstacle rows) returns a clear pose nearby."""
    from stackik.kinematics import spatial_chain

    targets = _targets()
    for k in (0, 1, 3):
        t = targets[k]
        plain = sk.solve_ik(REF, t)
        ch = spatial_chain(plain.q)
        B = ch.O[1] + ch.A[1] @ REF.base_nodes[1][2]
        T = ch.O[2] + ch.A[2] @ REF.top_nodes[1][2]
        sphere = sk.Sphere((B + T) / 2, 15.0)
        assert sk.clearances(REF, plain.q, [sphere]).obstacles[0] < 0
        r = sk.solve_ik(REF, t, obstacles=[sphere])
        assert r.success, (k, r.message)
        assert sk.clearances(REF, r.q, [sphere]).obstacles[0] >= -1e-6
        assert r.frobenius_norm <= plain.frobenius_norm * 1.01


def test_no_clear_pose_is_infeasible_with_the_least_penetrating_pose() -> None:
    """A sphere around the end effector that every top joint lies in: no pose is clear;
    the result is infeasible, not a crash, with the pose and its clearances."""
    stack = sk.Stack.reference(1, leg_radius=0.0)
    t = random_spatial_targets(stack, 1, rng=3)[0]
    r = sk.solve_ik(stack, t, obstacles=[sk.Sphere(t.position, 200.0)])
    assert r.status is sk.IKStatus.INFEASIBLE and not r.success
    assert r.clearances is not None and r.clearances.obstacles[0] < 0.0
    assert r.target_error <= 1e-6  # at the target, within its limits: only the clearance fails


def test_planar_solve_checks_obstacles() -> None:
    """The planar interior point's compiled re-check knows no obstacle: a planar pose
    through one is re-checked in full and never a success."""
    t = sk.PlanarTarget(150.0, 1200.0, 0.3)
    plain = sk.solve_ik(REF, t)
    assert plain.success and plain.clearances is None
    from stackik.clearance import plate_frames

    Pw = plate_frames(REF, plain.q, phi=t.phi)[1]  # plate origins, base frame
    sphere = sk.Sphere(Pw[2], 40.0)  # on plate 2
    r = sk.solve_ik(REF, t, obstacles=[sphere])
    assert r.clearances is not None
    assert not r.success or r.clearances.obstacles[0] >= -1e-6


def test_out_of_reach_obstacles_have_no_rows() -> None:
    """Obstacles no leg can reach (beyond reach_bound of the base origin) add no rows: the
    problem is the obstacle-free one, only the check measures them."""
    from stackik.clearance import body_reach

    t = _targets()[0]
    R = body_reach(REF)
    far = [sk.Sphere((R + 200.0, 0, 0), 100.0), sk.HalfSpace((0, 0, -R - 50.0), (0, 0, 1))]
    near = [sk.Sphere((R - 50.0, 0, 0), 100.0)]
    assert Problem(REF, t, "frobenius", None, obstacles=far).clearance.obstacle_rows is None
    assert not Problem(REF, t, "frobenius", None, obstacles=far).dense_rows
    assert Problem(REF, t, "frobenius", None, obstacles=near).clearance.obstacle_rows is not None
    r = sk.solve_ik(REF, t, obstacles=far)
    # the interior point's check leaves out obstacles no body of the pose reaches: the
    # plain solve's pose, no clearances measured; the full check passes it
    assert r.success and r.clearances is None
    np.testing.assert_array_equal(r.q, sk.solve_ik(REF, t).q)
    chk = sk.check_pose(REF, t, r.q, obstacles=far)
    assert chk.ok and chk.clearances is not None and chk.clearances.minimum > 0
    from stackik.clearance import clearances_can_fail

    assert not clearances_can_fail(REF, far) and clearances_can_fail(REF, near)
    assert clearances_can_fail(FAT, far) and clearances_can_fail(REF, far, 1.0)


def test_body_reach_bounds_every_joint() -> None:
    """Every joint of random feasible poses (and of poses at the leg limits: the least-FN
    ones) lies within body_reach of the base origin."""
    from stackik.clearance import body_reach, plate_frames
    from stackik.sampling import random_feasible_poses

    R = body_reach(REF)
    poses = [(q, 0.7) for q in random_feasible_poses(REF, 200, rng=5, phi=0.7)]
    poses += [(sk.solve_ik(REF, t).q, None) for t in _targets()[:4]]
    for q, phi in poses:
        A, O = plate_frames(REF, q, phi=phi)
        joints = np.concatenate(
            [O[:-1, None] + np.einsum("iab,ikb->ika", A[:-1], REF.base_nodes),
             O[1:, None] + np.einsum("iab,ikb->ika", A[1:], REF.top_nodes)]
        )  # fmt: skip
        assert np.linalg.norm(joints, axis=-1).max() <= R


@pytest.mark.derivatives
def test_planar_obstacle_rows_derivatives_and_values() -> None:
    """Planar poses (rho, z, theta in the plane phi): the rows' Jacobian against central
    differences and their values against the check's leg distances."""
    from stackik.formulation.obstacle_rows import ObstacleRows
    from stackik.sampling import random_feasible_poses

    phi = 0.4
    rows = ObstacleRows(REF, OBSTACLES3, 0.5, phi)
    q = random_feasible_poses(REF, 1, rng=8, phi=phi)[0]
    c, J = rows(q)
    assert J.shape == (rows.size, 12)
    num = fd.central(lambda x: rows(x.reshape(4, 3))[0], q.ravel())
    fd.assert_derivative_close(J, num, f_scale=fd.term_scale(c, num), what="planar rows")
    L = rows.L
    legs_half = (c[52:] * L + 0.5).min()
    assert legs_half == pytest.approx(sk.clearances(REF, q, OBSTACLES3, phi=phi).obstacles[2])


def test_planar_default_goes_around_a_sphere_on_a_leg() -> None:
    from stackik.clearance import plate_frames

    t = sk.PlanarTarget(150.0, 1200.0, 0.3, phi=0.2)
    plain = sk.solve_ik(REF, t)
    A, O = plate_frames(REF, plain.q, phi=t.phi)
    B, T = O[1] + A[1] @ REF.base_nodes[1][2], O[2] + A[2] @ REF.top_nodes[1][2]
    sphere = sk.Sphere((B + T) / 2, 15.0)
    assert sk.clearances(REF, plain.q, [sphere], phi=t.phi).obstacles[0] < 0
    prob = Problem(REF, t, "frobenius", None, obstacles=[sphere])
    assert prob.dense_rows and prob.n_ineq == 96 + 24 + 4  # legs, then plates
    r = sk.solve_ik(REF, t, obstacles=[sphere])
    assert r.success and r.clearances is not None and r.clearances.obstacles[0] >= -1e-6
    assert r.frobenius_norm <= plain.frobenius_norm * 1.02


def test_ipopt_keeps_legs_clear_of_a_sphere() -> None:
    """method="ipopt" carries the obstacle rows (CasADi, the same definition): a sphere on
    a leg of the least-FN pose is gone around, spatial and planar."""
    from stackik.clearance import plate_frames
    from stackik.methods.ipopt import obstacle_key

    t = _targets()[1]
    plain = sk.solve_ik(REF, t)
    A, O = plate_frames(REF, plain.q)
    sphere = sk.Sphere(
        (O[1] + A[1] @ REF.base_nodes[1][2] + O[2] + A[2] @ REF.top_nodes[1][2]) / 2, 15.0
    )
    key = obstacle_key(Problem(REF, t, "frobenius", None, obstacles=[sphere]))
    assert key[1][0][0] == "sphere"  # its leg rows, then its plate rows
    r = sk.solve_ik(REF, t, obstacles=[sphere], method="ipopt", starts=1)
    assert r.success and r.clearances is not None and r.clearances.obstacles[0] >= -1e-6
    tp = sk.PlanarTarget(150.0, 1200.0, 0.3, phi=0.2)
    plain = sk.solve_ik(REF, tp)
    A, O = plate_frames(REF, plain.q, phi=tp.phi)
    sphere = sk.Sphere(
        (O[1] + A[1] @ REF.base_nodes[1][2] + O[2] + A[2] @ REF.top_nodes[1][2]) / 2, 15.0
    )
    half = sk.HalfSpace((0.0, 0.0, -30.0), (0.0, 0.0, 1.0))
    r = sk.solve_ik(REF, tp, obstacles=[sphere, half], method="ipopt", starts=1)
    assert r.success and r.clearances is not None and min(r.clearances.obstacles) >= -1e-6


def test_pose_screen_is_sound() -> None:
    """clearances_can_fail with a pose says False only when no obstacle touches it (the
    exact distances agree), and it does say False for obstacles in reach but away."""
    from stackik.clearance import clearances_can_fail
    from stackik.sampling import random_feasible_poses

    rng = np.random.default_rng(12)
    phi = 0.3
    said_clear = 0
    for q in random_feasible_poses(REF, 150, rng=12, phi=phi):
        ob = sk.Sphere(rng.uniform(-1200, 1200, 3) + [0, 0, 600], float(rng.uniform(5, 200)))
        if not clearances_can_fail(REF, [ob], 0.0, q, phi):
            said_clear += 1
            assert sk.clearances(REF, q, [ob], phi=phi).obstacles[0] > 0
    assert said_clear > 30
    t = _targets()[0]
    q = sk.solve_ik(REF, t).q
    assert clearances_can_fail(REF, [sk.Sphere((0, 0, 0.0), 10.0)], 0.0)  # in reach
    assert not clearances_can_fail(REF, [sk.Sphere((1500.0, 0, -300.0), 10.0)], 0.0, q)
