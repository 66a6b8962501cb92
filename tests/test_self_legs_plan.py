"""The spatial default on legs with a radius searches without the self-leg rows first
(stackik.solve.stages._clear_first, docs/clearance.md): where the rule acts, what it
changes, and that it keeps the time budget."""

from __future__ import annotations

import numpy as np
import pytest
from plan_spies import spy_batches, spy_settled

from stackik import Stack, clearances, solve_ik
from stackik.geometry import ACTUATOR_RADIUS
from stackik.sampling import random_spatial_targets
from stackik.solve.policy import spatial_start_count

THICK4 = Stack.reference(4, leg_radius=ACTUATOR_RADIUS)
THIN4 = Stack.reference(4, leg_radius=0.0)


@pytest.fixture
def calls(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    return spy_settled(monkeypatch, "_clear_first")


@pytest.fixture
def batches(monkeypatch: pytest.MonkeyPatch) -> list[tuple[int, bool]]:
    return spy_batches(monkeypatch, lambda prob: prob.self_legs is not None)


def test_only_the_spatial_default_on_legs_with_a_radius(calls: list[bool]) -> None:
    target = random_spatial_targets(THICK4, 1, rng=61004)[0]
    solve_ik(THIN4, target)  # no self-leg rows
    solve_ik(THICK4, target, starts=3)  # explicit starts
    solve_ik(THICK4, target, x0=solve_ik(THIN4, target).q)  # explicit start
    assert calls == []
    solve_ik(THICK4, target)
    assert len(calls) == 1


def test_the_basin_where_two_legs_touch_is_found(calls: list[bool]) -> None:
    # reference n = 4, rng 5: the zero-radius optimum (FN 1266.1) crosses two legs of a
    # platform; from the plan's starts with the self-leg rows every run (8 or 64 starts)
    # ended 3.2 % above, in another basin (FN 1308.3); from the zero-radius minimum with
    # the rows the run stays in its basin, legs touching
    target = random_spatial_targets(THICK4, 1, rng=5)[0]
    free = solve_ik(THIN4, target)
    assert free.success and clearances(THICK4, free.q).self_legs < 0
    r = solve_ik(THICK4, target)
    assert r.success and calls and r.method == "ip"
    assert clearances(THICK4, r.q).minimum >= -1e-6
    assert r.frobenius_norm <= free.frobenius_norm * (1 + 2e-3)


def test_a_clear_zero_radius_pose_is_the_answer_bit_for_bit(
    calls: list[bool], batches: list[tuple[int, bool]]
) -> None:
    # where the zero-radius default's pose keeps the 12 mm legs apart, the search without
    # the rows is the zero-radius search and its pose the answer
    for target in random_spatial_targets(THICK4, 6, rng=61004):
        free = solve_ik(THIN4, target)
        if clearances(THICK4, free.q).minimum > 1.0:
            break
    else:
        pytest.fail("no target whose zero-radius pose is clear")
    calls.clear()
    batches.clear()
    r = solve_ik(THICK4, target)
    assert calls == [True]
    assert all(not rows for _, rows in batches)  # no run with the rows
    np.testing.assert_array_equal(r.q, free.q)
    assert (r.nit, r.n_starts) == (free.nit, free.n_starts)


def test_no_batch_starts_past_the_budget() -> None:
    stack = Stack.reference(5, leg_radius=ACTUATOR_RADIUS)
    target = random_spatial_targets(stack, 1, 9605)[0]
    r = solve_ik(stack, target, max_time=1e-9)
    # the search's batch keeps 1 ms (Request.time_left); past it no batch with the rows
    # runs; a pose the search did not settle goes to the SQP engine for one start
    assert r.n_starts <= spatial_start_count(5) + (r.method == "sqp")


def test_the_batch_with_the_rows_runs_without_hops(
    calls: list[bool], monkeypatch: pytest.MonkeyPatch
) -> None:
    # rng 3000: the runs with the rows from the zero-radius basins' minima end more than
    # CLEAR_COST_RTOL above the zero-radius least, so the batch with the rows from the
    # plan's starts runs too (here it finds the answer, 2 % lower); after it no hops (they
    # found a lower pose on 1 of 29 such targets, docs/clearance.md), and each run from a
    # basin stops at CLEAR_BASIN_MAX_ITER iterations
    from stackik.methods.ip import IPMethod
    from stackik.solve.policy import CLEAR_BASIN_MAX_ITER

    seen: list[tuple[int, bool, object]] = []
    original = IPMethod.run_many

    def run_many(self: IPMethod, prob, starts, options, *args):  # type: ignore[no-untyped-def]
        seen.append((len(starts), prob.self_legs is not None, options.get("max_iter")))
        return original(self, prob, starts, options, *args)

    monkeypatch.setattr(IPMethod, "run_many", run_many)
    target = random_spatial_targets(THIN4, 1, rng=3000)[0]
    r = solve_ik(THICK4, target)
    assert calls == [False] and r.success
    assert clearances(THICK4, r.q).minimum >= -1e-6
    with_rows = [(k, it) for k, rows, it in seen if rows]
    singles = [it for k, it in with_rows if k == 1]
    assert singles and all(it == CLEAR_BASIN_MAX_ITER for it in singles)
    assert with_rows[-1][0] == spatial_start_count(4)  # the batch, last: no hops after it
