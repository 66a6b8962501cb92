"""The default's plan with obstacle rows (solve/stages._clear_first): it acts only on the
planar and spatial structured defaults with obstacle rows; an obstacle that does not bind
changes nothing (the obstacle-free default's pose, bit for bit); a binding one gets runs
with the obstacle rows from the obstacle-free basins' minima; a costly one runs the batch
with the rows from the plan's starts too."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from plan_spies import spy_batches, spy_settled

import stackik.solve.stages as stages
from stackik import Capsule, Sphere, Stack, solve_ik
from stackik.sampling import random_planar_targets, random_spatial_targets
from stackik.solve.policy import CLEAR_COST_RTOL, CLEAR_MU0

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from bench_obstacles import obstacle_gap, place  # noqa: E402


def _planar(n: int, rng: int, k: int = 0, count: int = 12) -> Any:
    """Target k of bench_obstacles' planar construction (plane 2 pi k / count)."""
    phi = 2 * np.pi * (k % count) / count
    return random_planar_targets(Stack.reference(n, leg_radius=0.0), 1, rng=rng + k, phis=(phi,))[0]


def _truss(n: int, seed: int, k: int) -> tuple[Stack, Any, Any, Capsule]:
    """bench_obstacles' planar truss case k of ``seed``: the stack, target, obstacle-free
    default solve and the truss member across its leg."""
    stack = Stack.reference(n, leg_radius=0.0)
    target = _planar(n, seed, k)
    free = solve_ik(stack, target)
    assert free.success
    ob = place("truss", stack, free.q, target.phi, k)
    assert isinstance(ob, Capsule)
    return stack, target, free, ob


@pytest.fixture
def calls(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """``settled`` of every _clear_first call of a solve."""
    return spy_settled(monkeypatch, "_clear_first")


@pytest.fixture
def batches(monkeypatch: pytest.MonkeyPatch) -> list[tuple[int, bool]]:
    """(starts, with obstacle rows) of every interior-point call with checks."""
    return spy_batches(monkeypatch, lambda prob: prob.clearance.obstacle_rows is not None)


def _without_rule(monkeypatch: pytest.MonkeyPatch, stack: Stack, target: Any, ob: Any) -> Any:
    """The default solve without the rule (the batch with the obstacle rows from the
    plan's starts alone, as before it)."""
    with monkeypatch.context() as m:
        m.setattr(stages, "_clear_first_applies", lambda *a: False)
        old = solve_ik(stack, target, obstacles=[ob])
    assert old.success
    return old


def test_only_the_default_with_obstacle_rows(calls: list[bool]) -> None:
    stack, target, free, ob = _truss(4, 4290, 1)
    solve_ik(stack, target)  # no obstacle
    solve_ik(stack, target, obstacles=[Sphere((0.0, 0.0, 1e5), 10.0)])  # beyond reach: no rows
    solve_ik(stack, target, obstacles=[ob], starts=3)  # explicit starts
    solve_ik(stack, target, obstacles=[ob], x0=free.q)  # a given start
    solve_ik(stack, target, obstacles=[ob], method="sqp")
    spatial = random_spatial_targets(stack, 1, rng=4290)[0]
    far = [Sphere((0.0, 0.0, 1e5), 10.0)]
    solve_ik(stack, spatial, obstacles=far)  # spatial, beyond reach: no rows
    solve_ik(stack, spatial, obstacles=[ob], starts=3)  # spatial, explicit starts
    assert calls == []
    solve_ik(stack, target, obstacles=[ob])
    assert len(calls) == 1
    solve_ik(stack, spatial, obstacles=[Sphere((0.0, 0.0, 200.0), 10.0)])  # spatial default
    assert len(calls) == 2


def test_an_obstacle_that_does_not_bind_changes_nothing(calls: list[bool]) -> None:
    stack = Stack.reference(4, leg_radius=0.0)
    target = _planar(4, 4290, 2)
    free = solve_ik(stack, target)
    assert free.success
    # a sphere 60 mm beside the middle of a leg of platform 2, in the plane: rows, clear
    ob = place("sphere", stack, free.q, target.phi, 2)
    center = np.asarray(ob.center) + 60.0 * np.array([0.0, 0.0, 1.0])
    clear = Sphere(center, 5.0)
    assert min(obstacle_gap(stack, free.q, target.phi, clear).values()) > 5.0 + 1.0
    r = solve_ik(stack, target, obstacles=[clear])
    assert calls == [True]
    assert r.success
    assert np.array_equal(free.q, r.q)
    assert (free.nit, free.n_starts, free.method) == (r.nit, r.n_starts, r.method)


@pytest.mark.parametrize("k", [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11])
def test_binding_truss_takes_runs_from_the_obstacle_free_basins(
    k: int, calls: list[bool], batches: list[tuple[int, bool]], monkeypatch: pytest.MonkeyPatch
) -> None:
    # bench_obstacles --seed 4290 planar4_truss: the batch with the rows from the plan's
    # starts ended 0.6-8.3 % above the best known on four of these twelve targets
    stack, target, free, ob = _truss(4, 4290, k)
    batches.clear()
    r = solve_ik(stack, target, obstacles=[ob])
    assert r.success and r.method == "ip"
    assert len(calls) == 1
    gap = min(obstacle_gap(stack, r.q, target.phi, ob).values())
    assert gap >= ob.radius - 1e-6
    assert r.frobenius_norm >= free.frobenius_norm * (1 - 1e-12)
    if calls[0]:  # settled: runs of one start each with the rows, no batch from the plan's
        assert all(size == 1 and rows for size, rows in batches)
        assert r.frobenius_norm <= free.frobenius_norm * (1 + CLEAR_COST_RTOL)
        # the run from the obstacle-free optimum's basin is one of them
        one = solve_ik(stack, target, obstacles=[ob], method="ip", x0=free.q, starts=1,
                       options={"mu0": CLEAR_MU0})  # fmt: skip
        if one.success:
            assert r.frobenius_norm <= one.frobenius_norm * (1 + 1e-9)
    # deterministic
    again = solve_ik(stack, target, obstacles=[ob])
    assert np.array_equal(r.q, again.q)
    # not settled: the better of both; settled: within the cost cap of the obstacle-free
    # optimum, which no clear pose is below
    old = _without_rule(monkeypatch, stack, target, ob)
    if not calls[0]:
        assert r.frobenius_norm <= old.frobenius_norm * (1 + 1e-12)


def test_costly_obstacles_run_the_batch_too(
    calls: list[bool], batches: list[tuple[int, bool]], monkeypatch: pytest.MonkeyPatch
) -> None:
    # with no cost allowed every binding obstacle is "costly": the plan's starts run with
    # the rows as well, and the better pose of both wins
    monkeypatch.setattr(stages, "CLEAR_COST_RTOL", 0.0)
    stack, target, free, ob = _truss(4, 4290, 1)
    batches.clear()
    r = solve_ik(stack, target, obstacles=[ob])
    assert calls == [False]
    assert any(size > 1 and rows for size, rows in batches)
    assert r.success
    old = _without_rule(monkeypatch, stack, target, ob)
    assert r.frobenius_norm <= old.frobenius_norm * (1 + 1e-12)


def _spatial_truss(n: int, seed: int, k: int) -> tuple[Stack, Any, Any, Capsule]:
    """bench_obstacles' spatial truss case k of ``seed`` (as :func:`_truss`)."""
    stack = Stack.reference(n, leg_radius=0.0)
    target = random_spatial_targets(stack, 1, rng=seed + k)[0]
    free = solve_ik(stack, target)
    assert free.success
    ob = place("truss", stack, free.q, None, k)
    assert isinstance(ob, Capsule)
    return stack, target, free, ob


@pytest.mark.parametrize("n", [4, 5])
def test_spatial_obstacle_that_does_not_bind_changes_nothing(n: int, calls: list[bool]) -> None:
    # n = 5: the hops run without the obstacle rows too
    stack, target, free, ob = _spatial_truss(n, 4400, 3)
    # a sphere 80 mm above the middle of a leg of platform 2: rows, clear
    center = 0.5 * (np.asarray(ob.a) + np.asarray(ob.b)) + np.array([0.0, 0.0, 80.0])
    clear = Sphere(center, 5.0)
    assert min(obstacle_gap(stack, free.q, None, clear).values()) > 5.0 + 1.0
    r = solve_ik(stack, target, obstacles=[clear])
    assert calls == [True]
    assert r.success
    assert np.array_equal(free.q, r.q)
    assert (free.nit, free.n_starts, free.method) == (r.nit, r.n_starts, r.method)


@pytest.mark.parametrize("k", [0, 1, 2])
def test_binding_spatial_truss_takes_runs_from_the_obstacle_free_basins(
    k: int, calls: list[bool], batches: list[tuple[int, bool]], monkeypatch: pytest.MonkeyPatch
) -> None:
    stack, target, free, ob = _spatial_truss(4, 4400, k)
    batches.clear()
    r = solve_ik(stack, target, obstacles=[ob])
    assert r.success and r.method == "ip"
    assert len(calls) == 1
    gap = min(obstacle_gap(stack, r.q, None, ob).values())
    assert gap >= ob.radius - 1e-6
    if calls[0]:  # settled: runs of one start each with the rows, no batch from the plan's
        assert all(size == 1 and rows for size, rows in batches)
        assert r.frobenius_norm <= free.frobenius_norm * (1 + CLEAR_COST_RTOL)
    again = solve_ik(stack, target, obstacles=[ob])
    assert np.array_equal(r.q, again.q)
    old = _without_rule(monkeypatch, stack, target, ob)
    if not calls[0]:  # not settled: the better of both
        assert r.frobenius_norm <= old.frobenius_norm * (1 + 1e-12)
