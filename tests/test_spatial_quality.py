"""Spatial targets at planar quality: IPOPT as a spatial method, the spatial interior point
and its exact second derivatives, the weighted objective, unreachable targets and
solve_many in spatial mode."""

from __future__ import annotations

import pytest

from stackik.check import check_pose
from stackik.geometry import Stack
from stackik.sampling import random_spatial_targets
from stackik.solve import solve_ik

try:
    import casadi  # noqa: F401

    HAVE_IPOPT = True
except ImportError:  # pragma: no cover - optional extra
    HAVE_IPOPT = False


@pytest.mark.skipif(not HAVE_IPOPT, reason="casadi not installed")
@pytest.mark.parametrize("n", [2, 4])
def test_ipopt_spatial_matches_sqp(n: int) -> None:
    stack = Stack.reference(n)
    for target in random_spatial_targets(stack, 3, 9301 + n):
        ip = solve_ik(stack, target, method="ipopt", starts=1)
        assert ip.success, ip.message
        assert check_pose(stack, target, ip.q).ok
        sq = solve_ik(stack, target, method="sqp", starts=1)
        assert sq.success
        # same start, same problem: the same local minimum or a close one
        assert ip.frobenius_norm <= sq.frobenius_norm * 1.05


@pytest.mark.skipif(not HAVE_IPOPT, reason="casadi not installed")
def test_ipopt_spatial_weighted_and_feasible() -> None:
    stack = Stack.reference(3)
    target = random_spatial_targets(stack, 1, 9311)[0]
    w = solve_ik(
        stack, target, method="ipopt", starts=1, objective="weighted",
        sigma_t=[0.1, 0.5, 1.0], sigma_theta=[0.01, 0.02, 0.03],
    )  # fmt: skip
    assert w.success
    f = solve_ik(stack, target, method="ipopt", starts=1, objective="feasible")
    assert f.success
