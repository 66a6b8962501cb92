"""A constraint family added from outside the package (stackik.families): one definition
per mode, solved by the compiled interior point and the SQP engine, planar and spatial,
and enforced by the check.

The test-only family: every plate's origin at least ``h`` mm above the base plane.
"""

from __future__ import annotations

import numpy as np
import pytest
from plate_height import PlateHeight

import stackik
from stackik import ConstraintFamily, PlanarTarget
from stackik.families import FamilyRows, family, family_names, kernel_rows, register_family
from stackik.formulation import Problem
from tests import fd

PLANAR = PlanarTarget(600.0, 1000.0, -1.57)


def _spatial_target(stack):
    """The paper's first target as a spatial one (its free optimum lifts plate 0 to
    350 mm, 100 mm short of its legs' reach: 25 mm more is feasible)."""
    return PLANAR.to_spatial()


@pytest.fixture(scope="module")
def stack():
    return stackik.Stack.reference(4)


@pytest.mark.derivatives
@pytest.mark.parametrize("planar", [True, False])
def test_family_rows_jacobian_matches_finite_differences(stack, planar):
    """Problem's inequality rows with the family: the family's block of the Jacobian
    (scaled variables) against central differences of the rows' values (tolerance from
    tests/fd.py's scale model, the terms' scale of each row)."""
    rng = np.random.default_rng(3)
    target = PLANAR if planar else _spatial_target(stack)
    prob = Problem(stack, target, "frobenius", None, constraints=[PlateHeight(50.0)])
    k = 3 if planar else 6
    q = np.tile([20.0, 300.0, 0.1] if planar else [10.0, -5.0, 300.0, 0.05, 0.02, -0.03],
                (stack.n, 1)) + rng.normal(0, [1.0] * (k - 1) + [0.01], (stack.n, k))  # fmt: skip
    u = prob.u_of(q)
    rows = slice(prob.n_ineq - stack.n, prob.n_ineq)  # the family's rows are last here
    _, _, _, _, cin, Jin = prob.evaluate(u)
    num = fd.central(lambda v: prob.evaluate(v)[4][rows].copy(), u)
    fd.assert_derivative_close(
        Jin[rows], num, f_scale=fd.term_scale(cin[rows], num), what="family rows"
    )
    # the values: z - h over the longest leg (the family's row scale)
    z = (stackik.planar_plate_origins(q)[1:, 1] if planar
         else stackik.spatial_plate_origins(q)[1:, 2])  # fmt: skip
    np.testing.assert_allclose(cin[rows], (z - 50.0) / stack.leg_max.max(), rtol=1e-12)


def _solve_pair(stack, target, method):
    free = stackik.solve_ik(stack, target, method=method, rng=0)
    assert free.success
    z = (stackik.planar_plate_origins(free.q)[1:, 1] if isinstance(target, PlanarTarget)
         else stackik.spatial_plate_origins(free.q)[1:, 2])  # fmt: skip
    h = float(z.min()) + 25.0  # the free optimum's lowest plate is 25 mm too low
    fam = PlateHeight(h)
    held = stackik.solve_ik(stack, target, method=method, rng=0, constraints=[fam])
    return free, held, fam, h


@pytest.mark.parametrize("method", ["ip", "sqp"])
@pytest.mark.parametrize("planar", [True, False])
def test_ip_and_sqp_keep_the_family_and_the_check_enforces_it(stack, method, planar):
    target = PLANAR if planar else _spatial_target(stack)
    free, held, fam, h = _solve_pair(stack, target, method)
    assert held.success, held.message
    assert held.method == method  # solved by the engine asked, not handed over
    phi = target.phi if planar else None
    values = fam.check_values(stack, held.q, phi)
    assert values.min() >= -stackik.check.FEAS_TOL
    assert held.frobenius_norm >= free.frobenius_norm * (1 - 1e-9)
    # the check with the family refuses the free optimum and accepts the held pose
    bad = stackik.check_pose(stack, target, free.q, constraints=[fam])
    assert not bad.ok
    assert bad.family_violation == pytest.approx(25.0, rel=1e-9)
    assert bad.violation_mm >= 25.0 - 1e-9
    good = stackik.check_pose(stack, target, held.q, constraints=fam)
    assert good.ok and good.family_violation <= stackik.check.FEAS_TOL
    # without the family the free pose is fine
    assert stackik.check_pose(stack, target, free.q).ok


@pytest.mark.parametrize("planar", [True, False])
def test_ip_and_sqp_agree_on_the_held_optimum(stack, planar):
    """Both engines, from the same starts, end at poses whose FN agree to 1e-5
    (the family binds: the lowest plate sits at h)."""
    target = PLANAR if planar else _spatial_target(stack)
    _, held_ip, fam, h = _solve_pair(stack, target, "ip")
    held_sqp = stackik.solve_ik(stack, target, method="sqp", rng=0, constraints=[fam])
    phi = target.phi if planar else None
    for r in (held_ip, held_sqp):
        assert r.success
        assert fam.check_values(stack, r.q, phi).min() == pytest.approx(0.0, abs=1e-4)
    assert held_sqp.frobenius_norm == pytest.approx(held_ip.frobenius_norm, rel=1e-5)


def test_default_method_keeps_the_family(stack):
    free = stackik.solve_ik(stack, PLANAR)
    h = float(stackik.planar_plate_origins(free.q)[1:, 1].min()) + 25.0
    r = stackik.solve_ik(stack, PLANAR, constraints=[PlateHeight(h)])
    assert r.success
    assert stackik.planar_plate_origins(r.q)[1:, 1].min() >= h - stackik.check.FEAS_TOL


def test_a_family_no_pose_meets_is_not_a_success(stack):
    """Plates above 10 m on a target at 1 m: no pose passes; the result says so."""
    r = stackik.solve_ik(stack, PLANAR, constraints=[PlateHeight(1e4)], max_time=5.0)
    assert not r.success
    assert r.status != stackik.IKStatus.SUCCESS


def test_ipopt_refuses_families_and_bad_input_is_a_clear_error(stack):
    with pytest.raises(ValueError, match="ipopt"):
        stackik.solve_ik(stack, PLANAR, method="ipopt", constraints=[PlateHeight(0.0)])
    with pytest.raises(ValueError, match="ConstraintFamily"):
        stackik.solve_ik(stack, PLANAR, constraints=[object()])
    with pytest.raises(ValueError, match="ConstraintFamily"):
        stackik.check_pose(stack, PLANAR, np.zeros((stack.n, 3)), constraints=["h"])

    class WrongShape(PlateHeight):
        def planar_rows(self, stack, q, phi):
            c, J = super().planar_rows(stack, q, phi)
            return c, J[:, :-1]

    with pytest.raises(ValueError, match="Jacobian of shape"):
        Problem(stack, PLANAR, "frobenius", None, constraints=[WrongShape(0.0)])

    class PlanarOnly(ConstraintFamily):
        def planar_rows(self, stack, q, phi):
            return np.zeros(1), np.zeros((1, q.size))

    with pytest.raises(ValueError, match="no spatial rows"):
        stackik.solve_ik(stack, _spatial_target(stack), constraints=[PlanarOnly()])


def test_registry_by_name():
    assert "test_plate_height" in family_names()
    f = family("test_plate_height", h=12.0)
    assert isinstance(f, PlateHeight) and f.h == 12.0
    with pytest.raises(ValueError, match="unknown constraint family"):
        family("no_such_family")

    class Other(ConstraintFamily):
        name = "test_plate_height"

    with pytest.raises(ValueError, match="taken"):
        register_family(Other)
    with pytest.raises(ValueError, match="subclass"):
        register_family(int)  # type: ignore[arg-type]


def test_kernel_rows_token_lives_with_its_rows(stack):
    rows = FamilyRows(stack, (PlateHeight(10.0),), float(PLANAR.phi))
    q = np.tile([20.0, 300.0, 0.1], (stack.n, 1))
    c, J = kernel_rows(rows.token, q)
    c2, J2 = rows(q)
    np.testing.assert_array_equal(c, c2)
    np.testing.assert_array_equal(J, J2)
    assert c.flags.c_contiguous and J.flags.c_contiguous
    token = rows.token
    del rows
    import gc

    gc.collect()
    with pytest.raises(RuntimeError, match="gone"):
        kernel_rows(token, q)


def test_slsqp_keeps_the_family(stack):
    free, held, fam, h = _solve_pair(stack, PLANAR, "slsqp")
    assert held.success and held.method == "slsqp"
    assert fam.check_values(stack, held.q, PLANAR.phi).min() >= -stackik.check.FEAS_TOL


def test_the_guide_example_runs_and_says_what_it_prints(capsys):
    """docs/guide/constraints.md's example, run as written; its comments give the
    printed values."""
    import re
    from pathlib import Path

    page = Path(__file__).resolve().parents[1] / "docs" / "guide" / "constraints.md"
    code = re.search(r"```python\n(.*?)```", page.read_text(), re.S)
    assert code is not None
    exec(compile(code.group(1), str(page), "exec"), {"__name__": "guide_example"})
    lines = capsys.readouterr().out.split("\n")
    z_free, fn_free = map(float, lines[0].split())
    z_held, fn_held = map(float, lines[1].split())
    assert z_free == pytest.approx(376.8, abs=0.05) and z_held >= 400.0 - 1e-6
    assert fn_held > fn_free
    ok, viol = lines[2].split()
    assert ok == "False" and float(viol) == pytest.approx(23.2, abs=0.05)


@pytest.mark.parametrize(("mode", "planar"), [("fast", True), ("global", True), ("fast", False)])
def test_solve_path_keeps_the_family_at_every_waypoint(stack, mode, planar):
    """A path whose least-FN poses have their lowest plate below h on some waypoints:
    with the family every waypoint keeps it (the full check), no step goes over
    max_jump, and the path completes."""
    from stackik.paths import interpolate_targets

    ends = [PLANAR, PlanarTarget(450.0, 1100.0, -1.2)]
    ts = interpolate_targets(ends if planar else [t.to_spatial() for t in ends], steps=8)
    plain = stackik.solve_path(stack, ts, mode=mode)
    assert plain.success
    phi = PLANAR.phi if planar else None
    fam = PlateHeight(0.0)
    low = [float(fam.check_values(stack, q, phi).min()) for q in plain.q]
    fam = PlateHeight(min(low) + 15.0)
    assert sum(z < fam.h for z in low) >= 2  # the family binds on some waypoints
    path = stackik.solve_path(stack, ts, mode=mode, constraints=[fam])
    assert path.success and path.completed == len(ts)
    d = np.abs(np.diff(path.q, axis=0))
    k = 2 if planar else 3
    assert np.all(d[..., :k] <= 50.0 + 1e-9) and np.all(d[..., k:] <= 0.25 + 1e-12)
    for t, q in zip(ts, path.q):
        assert stackik.check_pose(stack, t, q, constraints=[fam]).ok
    with pytest.raises(ValueError, match="ConstraintFamily"):
        stackik.solve_path(stack, ts, constraints=[1.0])


class _NaNRows(ConstraintFamily):
    def planar_rows(self, stack, q, phi):
        return (np.ones(2) if not q.any() else np.full(2, np.nan)), np.zeros((2, q.size))


class _Raises(ConstraintFamily):
    def planar_rows(self, stack, q, phi):
        if q.any():
            raise RuntimeError("a bug in the family")
        return np.ones(1), np.zeros((1, q.size))


class _Grows(ConstraintFamily):
    def planar_rows(self, stack, q, phi):
        m = 1 if not q.any() else 2
        return np.ones(m), np.zeros((m, q.size))


@pytest.mark.parametrize("method", ["ip", "sqp", "auto"])
def test_a_broken_family_is_a_clear_error_from_every_engine(stack, method):
    """NaN rows make a failed solve (no success, no exception); rows that raise or change
    their count are a FamilyError naming the family, whichever engine met them first."""
    r = stackik.solve_ik(stack, PLANAR, method=method, constraints=[_NaNRows()], max_time=5)
    assert not r.success
    with pytest.raises(stackik.FamilyError, match="_Raises: RuntimeError: a bug"):
        stackik.solve_ik(stack, PLANAR, method=method, constraints=[_Raises()], max_time=5)
    with pytest.raises(stackik.FamilyError, match="_Grows: 2 rows at this pose, 1 at"):
        stackik.solve_ik(stack, PLANAR, method=method, constraints=[_Grows()], max_time=5)


def test_solve_many_in_worker_processes_gives_the_same_poses(stack):
    """A family travels to worker processes pickled (its class importable there) and the
    poses they find are the in-process ones, bit for bit."""
    from concurrent.futures import ProcessPoolExecutor

    ts = [PLANAR, PlanarTarget(450.0, 1100.0, -1.2)]
    fam = PlateHeight(390.0)
    here = stackik.solve_many(stack, ts, constraints=[fam])
    with ProcessPoolExecutor(1) as ex:
        there = stackik.solve_many(stack, ts, constraints=[fam], executor=ex)
    for t, a, b in zip(ts, here, there):
        assert a.success and b.success
        np.testing.assert_array_equal(a.q, b.q)
        assert stackik.check_pose(stack, t, b.q, constraints=[fam]).ok


def test_a_path_checkpoint_tells_families_apart_by_their_arrays():
    """Two families that differ only in the middle of a large array have different
    checkpoint keys (an array's repr elides its middle)."""
    import json

    from stackik.paths.request import _family_key

    a, b = PlateHeight(1.0), PlateHeight(1.0)
    a.w, b.w = np.arange(2000.0), np.arange(2000.0)
    b.w[1000] = -1.0
    assert json.dumps(_family_key(a)) != json.dumps(_family_key(b))
