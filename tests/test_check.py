"""The compiled planar re-check (stackik._compiled.check) agrees with check_pose and lift_planar."""

from __future__ import annotations

import numpy as np
import pytest

import stackik as sk
from stackik._compiled.check import planar_check
from stackik.check import check_pose
from stackik.sampling import random_stack
from stackik.starts import paper_initial_guess

CASES = [(n, seed, phi) for n in (1, 2, 4, 7) for seed in range(4) for phi in (0.0, 0.8, -2.1, 3.0)]


@pytest.mark.parametrize(("n", "seed", "phi"), CASES)
def test_compiled_check_equals_check_pose(n, seed, phi):
    rng = np.random.default_rng(seed)
    st = random_stack(n, seed) if seed % 2 else sk.Stack.reference(n)
    t = sk.PlanarTarget(200 * rng.standard_normal(), 350.0 * n, 0.4 * rng.standard_normal(), phi)
    q0 = paper_initial_guess(st, t)
    poses = [q0 + rng.normal(0, s, (n, 3)) * [1, 1, 0.01] for s in (0.0, 5.0, 60.0, 150.0)]
    r = sk.solve_ik(st, t)
    if r.success:
        poses.append(r.q)  # on the limits: the borderline case that matters
        t_exact = sk.PlanarTarget(*sk.planar_forward(r.q), phi=phi)
        poses.append(r.q)
    else:
        t_exact = t
    for k, q in enumerate(poses):
        tt = t_exact if k >= len(poses) - 1 else t
        ref = check_pose(st, tt, q)
        chk, P, R, legs = planar_check(st, tt, q)
        assert chk.ok == ref.ok
        np.testing.assert_allclose(chk.constraints, ref.constraints, rtol=1e-12, atol=1e-9)
        for name in ("position_error", "angle_error", "max_violation", "max_violation_mm"):
            assert getattr(chk, name) == pytest.approx(getattr(ref, name), rel=1e-9, abs=1e-9)
        P_ref, R_ref = sk.lift_planar(q, phi)
        np.testing.assert_allclose(P, P_ref, atol=1e-12)
        np.testing.assert_allclose(R, R_ref, atol=1e-14)
        legs_ref = np.linalg.norm(
            np.einsum("nij,nkj->nki", R_ref, st.top_nodes) + P_ref[:, None, :] - st.base_nodes,
            axis=-1,
        )
        np.testing.assert_allclose(legs, legs_ref, rtol=1e-13)


def test_compiled_check_flags_non_finite_and_misses():
    st = sk.Stack.reference(3)
    t = sk.PlanarTarget(0.0, 1100.0, 0.0)
    q = paper_initial_guess(st, t)
    chk, *_ = planar_check(st, t, q)
    ref = check_pose(st, t, q)
    assert chk.ok == ref.ok
    far = sk.PlanarTarget(0.0, 1100.0 + 1e-3, 0.0)
    assert not planar_check(st, far, q)[0].ok
    bad = q.copy()
    bad[0, 0] = 1e200
    assert not planar_check(st, t, bad)[0].ok


def test_planar_check_many_rejects_mismatched_shapes() -> None:
    from stackik._compiled.check import planar_check_many
    from stackik.geometry import Stack
    from stackik.targets import PlanarTarget

    stack = Stack.reference(3)
    targets = [PlanarTarget(0.0, 900.0, 0.0)]
    with pytest.raises(ValueError, match="shape"):
        planar_check_many(stack, targets, np.zeros((4, 3, 3)))
    with pytest.raises(ValueError, match="shape"):
        planar_check_many(stack, targets, np.zeros((1, 2, 3)))


def test_poses_ok_is_pose_ok_elementwise():
    from itertools import product

    from stackik.check import FEAS_TOL, TARGET_ANGLE_TOL, TARGET_POS_TOL, pose_ok, poses_ok

    cases = list(
        product(
            [0.0, TARGET_POS_TOL, 2 * TARGET_POS_TOL, np.nan],
            [0.0, TARGET_ANGLE_TOL, 2 * TARGET_ANGLE_TOL, np.nan],
            [0.0, FEAS_TOL, 2 * FEAS_TOL, np.inf],
            [True, False],
        )
    )
    p, a, v, f = (np.array(c) for c in zip(*cases))
    assert poses_ok(p, a, v, f).tolist() == [pose_ok(*c) for c in cases]
