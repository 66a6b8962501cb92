"""The verified working-set step (SQPOptions.qp_working_set) and the inexact mode's
tolerance on the screened-rows backend."""

from __future__ import annotations

import numpy as np
import pytest
from hs_problems import PROBLEMS

from stackik.sqp import SQPOptions, solve
from stackik.sqp.qp import QPStatus, make_backend
from stackik.sqp.working_set import WorkingSetStep


def _qp(rng: np.random.Generator, n: int = 8, me: int = 2, mi: int = 12) -> tuple:
    M = rng.standard_normal((n, n))
    B = M @ M.T + n * np.eye(n)
    g = rng.standard_normal(n) * 5
    J = rng.standard_normal((me + mi, n))
    d0 = rng.uniform(-0.3, 0.3, n)  # feasible by construction
    c = -J @ d0 + np.r_[np.zeros(me), rng.uniform(0.0, 0.5, mi)]
    lb, ub = -np.full(n, 0.6), np.full(n, 0.6)
    return B, g, J, c, lb, ub


def _backend_solution(args: tuple, me: int, mi: int):
    be = make_backend("clarabel")
    n = args[0].shape[0]
    be.setup(n, me, mi)
    return be.solve_sqp(*args)


@pytest.mark.parametrize("seed", range(8))
def test_verified_step_is_the_qp_solution(seed: int) -> None:
    """Recorded from the backend's solution of a QP, the step solves that QP again (the
    backend's answer, more accurately); a duplicated row changes nothing."""
    rng = np.random.default_rng(seed)
    B, g, J, c, lb, ub = _qp(rng)
    J = np.vstack((J, J[-1]))  # a limit stated twice: dependent working set
    c = np.r_[c, c[-1]]
    ref = _backend_solution((B, g, J, c, lb, ub), 2, 13)
    assert ref.status is QPStatus.SOLVED
    ws = WorkingSetStep(8, 2, 13)
    assert ws.solve(B, g, J, c, lb, ub) is None  # nothing recorded yet
    ws.record(ref)
    sol = ws.solve(B, g, J, c, lb, ub)
    assert sol is not None and ws.hits == 1
    np.testing.assert_allclose(sol.x, ref.x, atol=1e-6)
    # KKT of the returned point, in the backends' sign convention
    r = B @ sol.x + g + J[:2].T @ sol.y_eq - J[2:].T @ sol.y_ineq + sol.y_bounds
    assert np.abs(r).max() < 1e-8
    assert (sol.y_ineq >= 0).all()
    assert (c[2:] + J[2:] @ sol.x >= -1e-9).all()
    np.testing.assert_allclose(c[:2] + J[:2] @ sol.x, 0.0, atol=1e-9)


@pytest.mark.parametrize("seed", range(8))
def test_changed_qp_verified_or_declined(seed: int) -> None:
    """On a different QP the step either declines (None) or returns that QP's solution."""
    rng = np.random.default_rng(100 + seed)
    args = _qp(rng)
    ws = WorkingSetStep(8, 2, 12)
    ws.record(_backend_solution(args, 2, 12))
    B, g, J, c, lb, ub = args
    new = (B, g + rng.standard_normal(8), J, c + np.r_[0, 0, rng.uniform(0, 0.2, 12)], lb, ub)
    ref = _backend_solution(new, 2, 12)
    sol = ws.solve(*new)
    if sol is not None and ref.status is QPStatus.SOLVED:
        np.testing.assert_allclose(sol.x, ref.x, atol=1e-6)


@pytest.mark.parametrize("solver", ["osqp", "clarabel"])
def test_working_set_option_on_hs(solver: str) -> None:
    """Same answers with the option; some QPs solved by the step, the rest counted."""
    opts = SQPOptions(qp_working_set=True)
    hits = 0
    for number in (35, 43, 65, 71, 100):
        p = PROBLEMS[number]
        res = solve(p.nlp, p.x0, qp_solver=solver, options=opts)
        ref = solve(p.nlp, p.x0, qp_solver=solver)
        assert res.success, (number, res.message)
        assert abs(res.fun - ref.fun) <= 1e-6 * max(1.0, abs(ref.fun)), number
        assert ref.qp_working_set_solves == 0
        assert ref.qp_backend_solves > 0
        hits += res.qp_working_set_solves
    assert hits > 0
    with pytest.raises(ValueError, match="qp_working_set"):
        SQPOptions(qp_working_set=1)  # type: ignore[arg-type]


def test_adaptive_accuracy_reaches_screened_backend() -> None:
    """qp_accuracy="adaptive" sets the tolerance of the backend that solves the QPs
    without the rows that cannot bind (sparse mode) too, not only the main one."""
    import stackik as sk
    from stackik.sampling import random_planar_targets
    from stackik.sqp.qp.osqp_ import OSQPBackend

    seen: dict[int, list[float]] = {}
    orig = OSQPBackend.solve_sqp

    def spy(self, *args):  # type: ignore[no-untyped-def]
        seen.setdefault(id(self), []).append(float(self.settings["eps_abs"]))
        return orig(self, *args)

    st = sk.Stack.reference(4)
    target = random_planar_targets(st, 1, rng=3)[0]
    try:
        OSQPBackend.solve_sqp = spy  # type: ignore[method-assign]
        r = sk.solve_ik(
            st,
            target,
            method="sqp",
            qp_solver="osqp",
            starts=1,
            options={"qp_accuracy": "adaptive"},
        )
    finally:
        OSQPBackend.solve_sqp = orig  # type: ignore[method-assign]
    assert r.success
    # every backend that solved (here the screened-rows one) got loose tolerances
    assert seen
    assert all(max(eps) > 1e-6 for eps in seen.values())
