"""The adaptive start plan of the planar default from n = ADAPTIVE_N (solve/policy.py,
solve/stages.py): untouched below, early stop when the first starts agree, more starts
two at a time until one confirms the best when they do not; the compact-target plans."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

import stackik.solve.policy as policy
import stackik.solve.stages as stages
from stackik import PlanarTarget, PlatformGeometry, Stack, solve_ik
from stackik.methods.ip import IPMethod
from stackik.sampling import random_planar_targets
from stackik.solve.policy import ADAPTIVE_FIRST, ADAPTIVE_N, StartPlan
from stackik.starts import (
    ARC_PLATFORMS,
    ARC_TURN,
    arc_starts,
    fold_depth,
    fold_offset,
    nominal_height,
    paper_initial_guess,
    reach_fraction,
    tall_random_starts,
)

N_BIG = int(ADAPTIVE_N)


@pytest.fixture
def spy(monkeypatch: pytest.MonkeyPatch) -> list[list[Any]]:
    """The starts of every interior-point call of a solve, in order."""
    seen: list[list[Any]] = []
    original = IPMethod.run_many

    def run_many(self: IPMethod, prob: Any, starts: list[Any], *args: Any) -> Any:
        seen.append([q.copy() for q in starts])
        return original(self, prob, starts, *args)

    monkeypatch.setattr(IPMethod, "run_many", run_many)
    return seen


def _counts(seen: list[list[Any]]) -> list[int]:
    return [len(c) for c in seen]


def _target(n: int, seed: int = 5) -> PlanarTarget:
    return random_planar_targets(Stack.reference(n, leg_radius=0.0), 1, rng=seed, phis=(0.3,))[0]


def _batch_size(n: int) -> int:
    depth = fold_depth(n)
    return 3 + (2**depth if depth > 0 else 0) + tall_random_starts(n)


def test_adaptive_first_only_on_the_large_planar_structured_default() -> None:
    plan = StartPlan([np.zeros((2, 3))], 3, None, False)
    size = _batch_size(N_BIG)
    randoms = size - tall_random_starts(N_BIG)  # the batch ends with its random starts
    assert plan.adaptive_first(True, True, N_BIG, size) == list(
        range(randoms, randoms + ADAPTIVE_FIRST)
    )
    assert len(plan.adaptive_first(True, True, 64, _batch_size(64))) == ADAPTIVE_FIRST
    assert plan.adaptive_first(True, True, N_BIG - 1, _batch_size(N_BIG - 1)) == []
    assert plan.adaptive_first(True, True, 4, 3) == []
    assert plan.adaptive_first(False, True, N_BIG, size) == []  # x0 or start="convex"
    assert plan.adaptive_first(True, False, N_BIG, size) == []  # spatial
    user = StartPlan([np.zeros((2, 3))], 5, 5, False)
    assert user.adaptive_first(True, True, N_BIG, 5) == []  # the user's starts


@pytest.mark.parametrize("n", [4, 16])
def test_below_adaptive_n_the_batch_is_one_call(
    n: int, spy: list[list[Any]], lines_pass_through: None
) -> None:
    res = solve_ik(Stack.reference(n, leg_radius=0.0), _target(n))
    assert res.success
    assert _counts(spy) == [_batch_size(n)]
    assert res.n_starts == _batch_size(n)


def test_confirmed() -> None:
    def run(fn: float) -> Any:
        return SimpleNamespace(obj=fn**2)

    assert stages.confirmed([run(100.0), run(100.01)], 2e-4)
    assert not stages.confirmed([run(100.0), run(100.03)], 2e-4)
    assert stages.confirmed([run(100.03), run(100.0)], 1e-3)  # any order
    assert not stages.confirmed([run(100.0), None], 1.0)  # a start that failed the check
    assert not stages.confirmed([], 1.0)
    # the least matched by another, whatever the others found
    assert stages.confirmed([run(120.0), run(100.0), None, run(100.01)], 2e-4)
    assert not stages.confirmed([run(100.0), run(120.0), run(120.0)], 2e-4)


def test_stands() -> None:
    def run(fn: float) -> Any:
        return SimpleNamespace(obj=fn**2)

    # the least first found by the second run, five runs after it: stands for 5, not 6
    runs = [run(107.0), run(100.0), run(107.0), None, run(107.1), run(106.9), run(107.0)]
    assert stages.stands(runs, 5e-4, 5)
    assert not stages.stands(runs, 5e-4, 6)
    # a later run within rtol does not move the first one's place; a lower one does
    assert stages.stands([run(100.0), run(100.01), run(101.0)], 5e-4, 2)
    assert not stages.stands([run(100.0), run(101.0), run(99.0)], 5e-4, 1)
    assert stages.stands([run(100.0), run(101.0), run(99.0)], 5e-4, 0)
    assert not stages.stands([None, None, None], 5e-4, 0)  # nothing passed
    assert not stages.stands([], 5e-4, 0)


def test_more_starts_stop_when_the_best_stands(
    spy: list[list[Any]], monkeypatch: pytest.MonkeyPatch, lines_pass_through: None
) -> None:
    # no two runs agree, and the first run's pose is reported lowest of all: the plan
    # stops at the first group boundary ADAPTIVE_STANDS runs after it
    monkeypatch.setattr(stages, "ADAPTIVE_RTOL", 0.0)
    monkeypatch.setattr(stages, "ADAPTIVE_STANDS", 3)
    original = IPMethod.run_many
    calls = {"n": 0}

    def first_lowest(self: IPMethod, prob: Any, starts: list[Any], *args: Any) -> Any:
        batch = original(self, prob, starts, *args)
        calls["n"] += 1
        if batch.best is not None:  # distinct objectives, the first run's the least
            batch.best = dataclasses.replace(batch.best, obj=batch.best.obj * (1 + calls["n"]))
        return batch

    monkeypatch.setattr(IPMethod, "run_many", first_lowest)
    monkeypatch.setattr(stages, "map_in_threads", lambda f, k, *a: [f(i) for i in range(k)])
    res = solve_ik(Stack.reference(N_BIG, leg_radius=0.0), _target(N_BIG))
    assert res.success
    # runs 0, 1 | 2, 3: three after run 0 -> stop at four
    assert res.n_starts == 4 and calls["n"] == 4


def test_early_stop_when_the_first_starts_agree(
    spy: list[list[Any]], monkeypatch: pytest.MonkeyPatch, lines_pass_through: None
) -> None:
    monkeypatch.setattr(stages, "ADAPTIVE_RTOL", 1.0)  # any two passing poses agree
    stack, target = Stack.reference(N_BIG, leg_radius=0.0), _target(N_BIG)
    res = solve_ik(stack, target)
    assert res.success
    assert _counts(spy) == [1] * ADAPTIVE_FIRST
    assert res.n_starts == ADAPTIVE_FIRST
    firsts = [c[0] for c in spy]
    spy.clear()
    monkeypatch.setattr(policy, "ADAPTIVE_N", math.inf)  # the plan off: the whole batch
    solve_ik(stack, target)
    batch = spy[0]
    size = len(batch)
    randoms = size - tall_random_starts(N_BIG)
    for q, b in zip(firsts, batch[randoms:], strict=False):  # its first random starts
        np.testing.assert_array_equal(q, b)
    # the better of the first starts, each alone
    alone = [solve_ik(stack, target, method="ip", x0=q).frobenius_norm for q in firsts]
    assert res.frobenius_norm == pytest.approx(min(alone), rel=1e-12)
    monkeypatch.setattr(policy, "ADAPTIVE_N", ADAPTIVE_N)
    again = solve_ik(stack, target)
    np.testing.assert_array_equal(again.q, res.q)  # deterministic


def test_whole_batch_when_no_run_confirms_the_best(
    spy: list[list[Any]], monkeypatch: pytest.MonkeyPatch, lines_pass_through: None
) -> None:
    monkeypatch.setattr(stages, "ADAPTIVE_RTOL", -1.0)  # never agree
    monkeypatch.setattr(stages, "ADAPTIVE_STANDS", math.inf)  # nor stand
    stack, target = Stack.reference(N_BIG, leg_radius=0.0), _target(N_BIG)
    res = solve_ik(stack, target)
    size = _batch_size(N_BIG)
    assert res.success
    assert _counts(spy) == [1] * size  # every start, each alone
    assert res.n_starts == size
    order = [c[0] for c in spy]
    spy.clear()
    monkeypatch.setattr(policy, "ADAPTIVE_N", math.inf)  # the plan off: one call
    full = solve_ik(stack, target)
    assert _counts(spy) == [size]
    batch = spy[0]
    randoms = size - tall_random_starts(N_BIG)
    # the random starts first (the first ADAPTIVE_FIRST, then the others), then the rest
    expect = batch[randoms:] + batch[:randoms]
    for q, b in zip(order, expect, strict=True):
        np.testing.assert_array_equal(q, b)
    assert res.frobenius_norm == pytest.approx(full.frobenius_norm, rel=1e-12)
    np.testing.assert_allclose(res.q, full.q, rtol=0, atol=1e-9)


def test_more_starts_until_one_confirms_the_best(
    spy: list[list[Any]], monkeypatch: pytest.MonkeyPatch, lines_pass_through: None
) -> None:
    # the first two starts disagree (the check refuses the first run), the next two
    # confirm the best found: four starts, the best of them
    stack, target = Stack.reference(N_BIG, leg_radius=0.0), _target(N_BIG)
    monkeypatch.setattr(stages, "ADAPTIVE_RTOL", 1.0)  # any two passing poses agree
    original = IPMethod.run_many
    calls = {"n": 0}

    def first_fails(self: IPMethod, prob: Any, starts: list[Any], *args: Any) -> Any:
        batch = original(self, prob, starts, *args)
        calls["n"] += 1
        if calls["n"] == 1:
            batch.best = None
        return batch

    monkeypatch.setattr(IPMethod, "run_many", first_fails)
    res = solve_ik(stack, target)
    assert res.success
    assert res.n_starts == 2 * ADAPTIVE_FIRST
    assert calls["n"] == 2 * ADAPTIVE_FIRST


def test_default_at_adaptive_n_is_reproducible(spy: list[list[Any]]) -> None:
    stack, target = Stack.reference(N_BIG, leg_radius=0.0), _target(N_BIG, seed=7)
    a = solve_ik(stack, target)
    b = solve_ik(stack, target)
    assert a.success and b.success
    assert a.n_starts == b.n_starts and a.nit == b.nit
    np.testing.assert_array_equal(a.q, b.q)
    assert _counts(spy)[:ADAPTIVE_FIRST] == [1] * ADAPTIVE_FIRST  # the adaptive plan ran


def test_explicit_starts_and_rows_outside_the_ip_keep_one_call(
    spy: list[list[Any]], monkeypatch: pytest.MonkeyPatch
) -> None:
    # the start plan's batch alone: the runs that fold into themselves (at n = N_BIG with
    # 1 mm legs some do) are made again one by one after it (stages._unfold_batch,
    # tests/test_leg_pairs.py), and when none passes the fold band runs
    # (stages._fold_band, tests/test_fold_band.py); here neither does
    monkeypatch.setattr(stages, "UNFOLD_STARTS", 0)
    monkeypatch.setattr(stages, "_fold_band", lambda *a, **k: None)
    stack, target = Stack.reference(N_BIG, leg_radius=0.0), _target(N_BIG)
    solve_ik(stack, target, method="ip", starts=3)
    assert _counts(spy) == [3]
    spy.clear()
    g = PlatformGeometry.reference(leg_radius=0.0)
    g = PlatformGeometry(**{**g.to_dict(), "leg_radius": 1.0})  # planar self-leg rows
    fat = Stack((g,) * N_BIG)
    solve_ik(fat, target, method="ip")
    assert _counts(spy) == [_batch_size(N_BIG)]  # rows outside the interior point: one call


def test_reach_fraction_and_arc_starts() -> None:
    stack = Stack.reference(N_BIG, leg_radius=0.0)
    target = PlanarTarget(300.0, 400.0, 1.0)
    assert reach_fraction(stack, target) == pytest.approx(500.0 / np.sum(nominal_height(stack)))
    q0 = paper_initial_guess(stack, target)
    left, right = arc_starts(stack, q0)
    m, a = ARC_PLATFORMS, fold_offset(stack)
    for q, sign in ((left, 1.0), (right, -1.0)):
        assert q.shape == q0.shape
        np.testing.assert_allclose(q[:m, 2] - q0[:m, 2], sign * ARC_TURN, rtol=0, atol=1e-12)
        np.testing.assert_allclose(q[:m, 0] - q0[:m, 0], -sign * a, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(q[:m, 1], q0[:m, 1])
        np.testing.assert_array_equal(q[m:], q0[m:])
    short = Stack.reference(
        3, leg_radius=0.0
    )  # fewer platforms than ARC_PLATFORMS: all of them bend
    q3 = paper_initial_guess(short, target)
    np.testing.assert_allclose(arc_starts(short, q3)[0][:, 2] - q3[:, 2], ARC_TURN, atol=1e-12)


def _compact_target(n: int) -> PlanarTarget:
    """A reachable target of ``Stack.reference(n, leg_radius=0.0)`` with a reach fraction below
    COMPACT_REACH (the first such seed of random_planar_targets in the plane 0.3)."""
    stack = Stack.reference(n, leg_radius=0.0)
    for seed in range(200):
        t = random_planar_targets(stack, 1, rng=seed, phis=(0.3,))[0]
        if reach_fraction(stack, t) < policy.COMPACT_REACH:
            return t
    raise AssertionError("no compact target")


def test_compact_targets_take_arcs_the_whole_batch_and_hops(
    spy: list[list[Any]], lines_pass_through: None
) -> None:
    stack, target = Stack.reference(N_BIG, leg_radius=0.0), _compact_target(N_BIG)
    res = solve_ik(stack, target)
    size = _batch_size(N_BIG) + 2  # the two arcs
    assert res.success
    assert _counts(spy) == [size, policy.COMPACT_HOPS]
    assert res.n_starts == size + policy.COMPACT_HOPS
    q0 = paper_initial_guess(stack, target)
    batch = spy[0]
    randoms = size - tall_random_starts(N_BIG)
    for q, arc in zip(batch[randoms - 2 : randoms], arc_starts(stack, q0), strict=True):
        np.testing.assert_array_equal(q, arc)  # the arcs, before the random starts
    # the hops perturb the batch's best pose at the random starts' scale
    best = min(
        (solve_ik(stack, target, method="ip", x0=q) for q in batch),
        key=lambda r: r.frobenius_norm if r.success else math.inf,
    )
    scale = np.max(np.abs(np.asarray(spy[1]) - best.q) / policy_scale(stack))
    assert 0.0 < scale < 6.0
    assert res.frobenius_norm <= best.frobenius_norm * (1 + 1e-12)
    spy.clear()
    again = solve_ik(stack, target)
    np.testing.assert_array_equal(again.q, res.q)  # deterministic


def test_lean_compact_plan_from_compact_lean_n(
    spy: list[list[Any]], monkeypatch: pytest.MonkeyPatch, lines_pass_through: None
) -> None:
    # the lean plan at N_BIG (its threshold lowered): the arcs and COMPACT_RANDOM random
    # starts alone, then rounds of hops, each from the best pose so far
    monkeypatch.setattr(policy, "COMPACT_LEAN_N", N_BIG)
    assert policy.compact_hop_rounds(N_BIG) == [policy.COMPACT_LEAN_HOPS] * policy.COMPACT_ROUNDS
    assert policy.compact_hop_rounds(N_BIG - 1) == [policy.COMPACT_HOPS]
    stack, target = Stack.reference(N_BIG, leg_radius=0.0), _compact_target(N_BIG)
    res = solve_ik(stack, target)
    size = 2 + policy.COMPACT_RANDOM
    hops = policy.compact_hop_rounds(N_BIG)
    assert res.success
    assert _counts(spy) == [size, *hops]
    assert res.n_starts == size + sum(hops)
    q0 = paper_initial_guess(stack, target)
    for q, arc in zip(spy[0][:2], arc_starts(stack, q0), strict=True):
        np.testing.assert_array_equal(q, arc)  # the arcs first
    again = solve_ik(stack, target)
    np.testing.assert_array_equal(again.q, res.q)  # deterministic


def policy_scale(stack: Stack) -> Any:
    """The random starts' per-variable scale, shape (n, 3)."""
    from stackik.formulation.modes import mode_of

    return mode_of(PlanarTarget(0.0, 1.0, 0.0)).perturbation(stack).reshape(stack.n, 3)


def test_compact_plan_only_on_the_large_planar_structured_default(
    spy: list[list[Any]], lines_pass_through: None
) -> None:
    stack, target = Stack.reference(N_BIG, leg_radius=0.0), _compact_target(N_BIG)
    solve_ik(stack, target, method="ip", starts=3)  # the user's starts
    assert _counts(spy) == [3]
    spy.clear()
    solve_ik(stack, target, x0=paper_initial_guess(stack, target))  # x0: one start
    assert _counts(spy) == [1]
    small = Stack.reference(N_BIG // 2, leg_radius=0.0)
    spy.clear()
    res = solve_ik(small, _compact_target(N_BIG // 2))  # below ADAPTIVE_N: unchanged
    assert _counts(spy) == [_batch_size(N_BIG // 2)]
    assert res.n_starts == _batch_size(N_BIG // 2)
