"""``method="ipopt"`` with the self-leg clearance rows: the CasADi rows are the family's one
definition (:mod:`stackik._compiled.self_legs`), and IPOPT keeps two legs of a platform
apart where the unconstrained optimum drives them through each other."""

from __future__ import annotations

import numpy as np
import pytest

from stackik import PlatformGeometry, Stack, clearances, solve_ik
from stackik._compiled.self_legs import self_leg_block
from stackik.formulation.clearance import SELF_LEG_PAIRS
from stackik.methods.ipopt import self_leg_function
from stackik.sampling import random_spatial_targets

#: A target (rng seed of random_spatial_targets on the n = 4 reference stack) whose
#: zero-radius least-FN pose has two legs of one platform within 24 mm (the clearance
#: baseline's seed 704: axes 0.7 mm apart); asserted below, not assumed.
COLLIDING_SEED = 704


def _rows(base, top, q, rho, scale):
    f = self_leg_function(base, top, rho, scale, SELF_LEG_PAIRS)
    ca_c = np.asarray(f(q.ravel())).ravel()
    import casadi as ca

    qs = ca.SX.sym("q", q.size)
    Jf = ca.Function("J", [qs], [ca.jacobian(f(qs), qs)])
    ca_J = np.asarray(Jf(q.ravel()))
    c, J = self_leg_block(
        np.ascontiguousarray(q), base, top, SELF_LEG_PAIRS, np.asarray(rho), np.asarray(scale)
    )
    n, m = c.shape
    Jd = np.zeros((n * m, 6 * n))
    for i in range(n):
        Jd[i * m : (i + 1) * m, 6 * i : 6 * i + 6] = J[i]
    return ca_c, ca_J, c.ravel(), Jd


def _close(a, b, rtol):
    scale = np.maximum(np.abs(b), 1.0 if a.ndim == 1 else np.abs(b).max())
    return np.abs(a - b) <= rtol * scale


@pytest.mark.parametrize("seed", range(6))
def test_casadi_rows_equal_the_kernel(seed: int) -> None:
    """Random poses of the reference stack (wide angles, so that legs cross and every
    clamping branch is taken): values to 1e-10 relative, Jacobians (AD against the
    kernel's FD-tested closed form) to 1e-8."""
    rng = np.random.default_rng(seed)
    stack = Stack.uniform(PlatformGeometry.hexagonal(leg_radius=12.0), 3)
    q = np.c_[
        rng.normal(0, 60, (3, 2)),
        rng.uniform(20, 400, 3),
        rng.uniform(-np.pi, np.pi, 3),
        rng.normal(0, 0.6, (3, 2)),
    ]
    rho = np.array([24.0, 30.0, 0.0])
    scale = np.asarray(stack.leg_max, float) ** 2
    ca_c, ca_J, c, J = _rows(stack.base_nodes, stack.top_nodes, q, rho, scale)
    rel = np.abs(ca_c - c) / np.maximum(np.abs(c), 1e-300)
    assert np.all((rel <= 1e-10) | (np.abs(ca_c - c) <= 1e-14)), rel.max()
    assert np.all(np.abs(ca_J - J) <= 1e-8 * max(np.abs(J).max(), 1.0))


def test_casadi_rows_parallel_and_clamped_cases() -> None:
    """Two legs made exactly parallel (the kernel's parallel branch, s = 0), then turned
    and moved out of it."""
    base = np.zeros((1, 6, 3))
    top = np.zeros((1, 6, 3))
    ang = np.linspace(0, 2 * np.pi, 6, endpoint=False)
    base[0, :, :2] = np.c_[100 * np.cos(ang), 100 * np.sin(ang)]
    top[0, :, :2] = np.c_[70 * np.cos(ang + 0.4), 70 * np.sin(ang + 0.4)]
    top[0, 1] = top[0, 0] + (base[0, 1] - base[0, 0])  # legs 0, 1 parallel at q below
    q = np.array([[0.0, 0.0, 150.0, 0.0, 0.0, 0.0]])
    for qq in (q, q + [[0, 0, 0, 0.3, 0.0, 0.0]], q + [[5, -3, 40, 0.1, 0.2, -0.1]]):
        ca_c, ca_J, c, J = _rows(base, top, qq, np.array([24.0]), np.array([4e4]))
        assert np.all(_close(ca_c, c, 1e-10)), (ca_c, c)
        assert np.all(np.abs(ca_J - J) <= 1e-8 * max(np.abs(J).max(), 1.0))


def test_ipopt_keeps_the_legs_apart() -> None:
    """On 12 mm legs, a target whose unconstrained optimum self-collides: IPOPT returns a
    success whose legs are at least 24 mm apart (axis to axis)."""
    thin = Stack.reference(4, leg_radius=0.0)
    fat = Stack.uniform(PlatformGeometry.hexagonal(leg_radius=12.0), 4)
    target = random_spatial_targets(thin, 1, rng=COLLIDING_SEED)[0]
    free = solve_ik(thin, target, method="ipopt", starts=8)
    assert free.success
    assert clearances(fat, free.q).self_legs < 0  # the unconstrained optimum collides
    r = solve_ik(fat, target, method="ipopt", starts=8)
    assert r.success, r.message
    assert clearances(fat, r.q).self_legs >= -1e-6
    assert r.frobenius_norm >= free.frobenius_norm * (1 - 1e-6)  # a constraint costs FN


def test_planar_ipopt_runs_with_self_leg_rows() -> None:
    # the planar CasADi rows on 12 mm legs (once raised: the start came back, 0 iterations)
    from stackik import PlanarTarget, check_pose

    stack = Stack.reference(4, leg_radius=12.0)
    target = PlanarTarget(600.0, 1000.0, -1.57)
    r = solve_ik(stack, target, method="ipopt", starts=1)
    assert r.success and r.nit > 0
    assert check_pose(stack, target, r.q).ok


def test_a_solver_that_raises_is_never_a_success(monkeypatch) -> None:
    """A run whose solver raised leaves its start: even a start that passes the check is
    no answer, and the solve fails."""
    from stackik.methods.ipopt import IpoptMethod
    from stackik.result import IKStatus

    stack = Stack.reference(3, leg_radius=12.0)
    target = random_spatial_targets(stack, 1, rng=5)[0]
    good = solve_ik(stack, target)
    assert good.success

    def boom(self, *args, **kwargs):
        raise RuntimeError("broken rows")

    monkeypatch.setattr(IpoptMethod, "solve", boom)
    r = solve_ik(stack, target, method="ipopt", x0=good.q)
    assert not r.success and r.status is IKStatus.FAILED
