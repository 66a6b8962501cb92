"""``method="ipopt"`` with the obstacle rows: the CasADi rows equal the family's one
definition (:class:`stackik.formulation.obstacle_rows.ObstacleRows`) in value and Jacobian,
and IPOPT keeps the legs clear of a sphere placed on a leg of the least-FN pose (spatial
and planar)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackik import Capsule, HalfSpace, PlatformGeometry, Sphere, Stack, check_pose, solve_ik
from stackik.formulation.obstacle_rows import ObstacleRows
from stackik.methods.ipopt import obstacle_function
from stackik.sampling import random_planar_targets, random_spatial_targets


def _leg_midpoint(stack, q, phi, k):
    from stackik.clearance import plate_frames

    A, O = plate_frames(stack, q, phi=phi)
    b = O[1] + A[1] @ stack.base_nodes[1, k]
    t = O[2] + A[2] @ stack.top_nodes[1, k]
    return 0.5 * (b + t)


def test_rows_match_the_numpy_definition():
    import casadi as ca

    stack = Stack.uniform(PlatformGeometry.hexagonal(leg_radius=7.0), 3)
    rng = np.random.default_rng(3)
    obstacles = (
        Sphere(np.array([60.0, -40.0, 250.0]), 15.0),
        Capsule(np.array([-300.0, 20.0, 400.0]), np.array([300.0, 60.0, 380.0]), 10.0),
        HalfSpace(np.array([0.0, 0.0, -20.0]), np.array([0.1, 0.0, 1.0])),
    )
    rows = ObstacleRows(stack, obstacles, 2.0)
    f = obstacle_function(stack, obstacles, 2.0)
    qs = ca.SX.sym("q", 6 * stack.n)
    Jf = ca.Function("J", [qs], [ca.jacobian(f(qs), qs)])
    for _ in range(5):
        q = np.column_stack(
            [rng.uniform(-30, 30, (3, 2)), rng.uniform(180, 260, (3, 1)),
             rng.uniform(-0.3, 0.3, (3, 3))]
        )  # fmt: skip
        c, J = rows(q)
        np.testing.assert_allclose(np.asarray(f(q.ravel())).ravel(), c, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(np.asarray(Jf(q.ravel())), J, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("planar", [False, True])
def test_ipopt_goes_around_a_sphere_on_a_leg(planar):
    stack = Stack.reference(4)
    if planar:
        target = random_planar_targets(stack, 1, rng=5, phis=(0.7,))[0]
        phi = target.phi
    else:
        target = random_spatial_targets(stack, 1, rng=5)[0]
        phi = None
    # the obstacle-free least FN (the default's: IPOPT from 4 starts ends 3 % higher on the
    # spatial target, which the obstacle-constrained IPOPT run can beat)
    r0 = solve_ik(stack, target)
    assert r0.success
    sphere = Sphere(_leg_midpoint(stack, r0.q, phi, 2), 15.0)
    assert not check_pose(stack, target, r0.q, obstacles=[sphere]).ok  # in the way
    r = solve_ik(stack, target, method="ipopt", starts=4, rng=0, obstacles=[sphere])
    assert r.success
    assert check_pose(stack, target, r.q, obstacles=[sphere]).ok
    assert r.frobenius_norm >= r0.frobenius_norm * (1 - 1e-6)
    assert math.isfinite(r.frobenius_norm)


def test_no_solver_build_past_the_budget(monkeypatch):
    """``run_ipopt``'s builds (``_built``): a solver not built yet whose stack and obstacles
    took longer to build last time than the time left is not built (status
    ``"max_time"`` in ``run_ipopt``); one built already is reused whatever the time."""
    import time

    from stackik.methods import ipopt as m

    monkeypatch.setattr(m, "_BUILT", set())
    monkeypatch.setattr(m, "_BUILD_S", {})
    calls = []

    def build(*args):
        calls.append(args)
        time.sleep(0.05)
        return "solver"

    assert m._built(build, 10.0, ("stack", "boxes"), "stack", 1) == "solver"
    assert m._BUILD_S[("build", ("stack", "boxes"))] >= 0.05
    # the same shape with other options (another max_wall_time) and too little time left
    assert m._built(build, 0.01, ("stack", "boxes"), "stack", 2) is None
    assert len(calls) == 1
    assert m._built(build, 0.01, ("stack", "boxes"), "stack", 1) == "solver"  # built
    assert m._built(build, 0.01, ("stack", "none"), "stack", 3) == "solver"  # no history
    assert len(calls) == 3
