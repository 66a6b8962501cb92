"""The spatial default's plan with leg-force limits (solve/stages._free_first): it acts only
on the spatial structured default with a finite force_max; a limit that does not bind
changes nothing (the unloaded default's pose, bit for bit); a binding one gets force-row
runs from the unloaded basins' minima; costly limits run the loaded batch too."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from plan_spies import spy_batches, spy_settled

import stackik.solve.stages as stages
from stackik import Load, PlanarTarget, PlatformGeometry, Stack, check_pose, leg_forces, solve_ik
from stackik.methods.ip import Basins
from stackik.sampling import random_spatial_targets
from stackik.solve.policy import FORCE_COST_RTOL, FORCE_MU0
from stackik.starts import spatial_start_count

LOAD = Load(mass=4.0)


def _stack(n: int, force_max: float = np.inf) -> Stack:
    g = PlatformGeometry.hexagonal(plate_mass=5.0, leg_mass=1.5, force_max=force_max)
    return Stack.uniform(g, n)


def _target(n: int, rng: int) -> Any:
    return random_spatial_targets(_stack(n), 1, rng=rng)[0]


def _binding(n: int, rng: int, bind: float) -> tuple[Stack, Any, Any]:
    """A target, the unloaded default's pose under the load, and a stack whose force_max is
    ``bind`` times that pose's peak leg force (as benchmarks/bench_loads.py)."""
    target = _target(n, rng)
    free = solve_ik(_stack(n), target, load=LOAD)
    assert free.success
    peak = float(np.abs(leg_forces(_stack(n), free.q, LOAD)).max())
    return _stack(n, bind * peak), target, free


def _solve_limited(
    rng: int, bind: float, batches: list[tuple[int, bool]]
) -> tuple[Stack, Any, Any, Any]:
    """:func:`_binding` at n = 4, then the default solve under the load (``batches``
    cleared before it): it passes the check."""
    stack, target, free = _binding(4, rng, bind)
    batches.clear()
    r = solve_ik(stack, target, load=LOAD)
    assert r.success and r.method == "ip"
    assert check_pose(stack, target, r.q, LOAD).ok
    return stack, target, free, r


def _without_rule(monkeypatch: pytest.MonkeyPatch, stack: Stack, target: Any) -> Any:
    """The default solve without the rule (the loaded batch from the plan's starts alone,
    as before it)."""
    monkeypatch.setattr(stages, "_free_first_applies", lambda *a: False)
    old = solve_ik(stack, target, load=LOAD)
    assert old.success
    return old


@pytest.fixture
def calls(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """``settled`` of every _free_first call of a solve."""
    return spy_settled(monkeypatch, "_free_first")


@pytest.fixture
def batches(monkeypatch: pytest.MonkeyPatch) -> list[tuple[int, bool]]:
    """(starts, with force rows) of every interior-point call with checks."""
    return spy_batches(monkeypatch, lambda prob: prob.forces is not None)


def test_only_the_spatial_default_with_a_finite_force_max(calls: list[bool]) -> None:
    target = _target(4, 9811)
    solve_ik(_stack(4), target)  # no load
    solve_ik(_stack(4), target, load=LOAD)  # a load, no limit: no force rows
    solve_ik(_stack(4, 300.0), target, load=LOAD, starts=3)  # explicit starts
    solve_ik(_stack(4, 300.0), target, load=LOAD, starts=1)  # (re-centring runs)
    planar = PlanarTarget(600.0, 1000.0, -1.57)
    solve_ik(_stack(4, 2000.0), planar, load=LOAD)  # planar
    assert calls == []
    solve_ik(_stack(4, 300.0), target, load=LOAD)
    assert len(calls) == 1


@pytest.mark.parametrize("n", [3, 6])
def test_a_limit_that_does_not_bind_changes_nothing(n: int, calls: list[bool]) -> None:
    target = _target(n, 9820 + n)
    free = solve_ik(_stack(n), target, load=LOAD)
    limited = solve_ik(_stack(n, 1e6), target, load=LOAD)
    assert calls == [True]
    assert free.success and limited.success
    assert np.array_equal(free.q, limited.q)
    assert (free.nit, free.n_starts, free.method) == (
        limited.nit, limited.n_starts, limited.method,
    )  # fmt: skip


def test_binding_limits_take_force_runs_from_the_unloaded_optimum(
    calls: list[bool], batches: list[tuple[int, bool]], monkeypatch: pytest.MonkeyPatch
) -> None:
    # seed 9805 (bench_loads --seed 9800, target 5): the loaded batch from the plan's
    # starts ended 0.16 % above the best known, the force runs from the unloaded optimum
    # at it
    stack, target, free, r = _solve_limited(9805, 0.85, batches)
    assert calls == [True]
    assert np.abs(leg_forces(stack, r.q, LOAD)).max() <= stack.force_max.max() * (1 + 1e-6)
    # force rows only after the unloaded search, and no loaded batch from the plan's starts
    assert batches and all(size == 1 and forces for size, forces in batches)
    assert free.frobenius_norm <= r.frobenius_norm <= free.frobenius_norm * (1 + FORCE_COST_RTOL)
    # the force run from the unloaded optimum's basin is one of the runs
    one = solve_ik(stack, target, load=LOAD, method="ip", x0=free.q, starts=1,
                   options={"mu0": FORCE_MU0})  # fmt: skip
    assert one.success
    assert r.frobenius_norm <= one.frobenius_norm * (1 + 1e-6)
    # without the rule the pose is not better on this target
    old = _without_rule(monkeypatch, stack, target)
    assert r.frobenius_norm <= old.frobenius_norm * (1 + 1e-9)


def test_costly_limits_run_the_loaded_batch_too(
    calls: list[bool], batches: list[tuple[int, bool]], monkeypatch: pytest.MonkeyPatch
) -> None:
    # force_max 0.4 x the unloaded optimum's peak: the best force run costs more than
    # FORCE_COST_RTOL of FN, so the plan's starts run with the force rows as well
    stack, target, free, r = _solve_limited(9701, 0.4, batches)
    assert calls == [False]
    assert (spatial_start_count(stack.n), True) in batches
    assert r.frobenius_norm > free.frobenius_norm * (1 + FORCE_COST_RTOL)
    old = _without_rule(monkeypatch, stack, target)
    assert r.frobenius_norm <= old.frobenius_norm * (1 + 1e-12)  # the better of both


def test_basins_keep_one_point_per_basin_lowest_first() -> None:
    b = Basins([], [], [], 0, [])
    for obj in (5.0, 3.0, 3.0 * (1 + 1e-9), 4.0, 5.0 * (1 - 1e-8), 1.0):
        b.add(np.array([obj]), obj, (1, "success"))
    assert b.objs == [1.0, 3.0, 4.0, 5.0]
    assert [float(u[0]) for u in b.points] == b.objs
    other = Basins([np.array([2.0]), np.array([4.0])], [2.0, 4.0], [(2, "a"), (3, "b")], 5, [])
    b.merge(other)
    assert b.objs == [1.0, 2.0, 3.0, 4.0, 5.0] and b.nit == 5
    assert b.runs[1] == (2, "a")
