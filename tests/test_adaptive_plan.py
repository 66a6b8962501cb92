"""The adaptive start plan of the planar default from n = ADAPTIVE_N (solve/policy.py,
solve/stages.py): untouched below, early stop when the first starts agree, the whole
batch when they do not."""

from __future__ import annotations

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
from stackik.starts import fold_depth, tall_random_starts

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
    return random_planar_targets(Stack.reference(n), 1, rng=seed, phis=(0.3,))[0]


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
def test_below_adaptive_n_the_batch_is_one_call(n: int, spy: list[list[Any]]) -> None:
    res = solve_ik(Stack.reference(n), _target(n))
    assert res.success
    assert _counts(spy) == [_batch_size(n)]
    assert res.n_starts == _batch_size(n)


def test_agree() -> None:
    def run(fn: float) -> Any:
        return SimpleNamespace(obj=fn**2)

    assert stages.agree([run(100.0), run(100.01)], 2e-4)
    assert not stages.agree([run(100.0), run(100.03)], 2e-4)
    assert stages.agree([run(100.03), run(100.0)], 1e-3)  # any order
    assert not stages.agree([run(100.0), None], 1.0)  # a start that failed the check
    assert not stages.agree([], 1.0)


def test_early_stop_when_the_first_starts_agree(
    spy: list[list[Any]], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(stages, "ADAPTIVE_RTOL", 1.0)  # any two passing poses agree
    stack, target = Stack.reference(N_BIG), _target(N_BIG)
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


def test_whole_batch_when_the_first_starts_disagree(
    spy: list[list[Any]], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(stages, "ADAPTIVE_RTOL", -1.0)  # never agree
    stack, target = Stack.reference(N_BIG), _target(N_BIG)
    res = solve_ik(stack, target)
    size = _batch_size(N_BIG)
    assert res.success
    assert _counts(spy) == [1] * ADAPTIVE_FIRST + [size - ADAPTIVE_FIRST]
    assert res.n_starts == size
    spy.clear()
    monkeypatch.setattr(policy, "ADAPTIVE_N", math.inf)  # the plan off: one call
    full = solve_ik(stack, target)
    assert _counts(spy) == [size]
    assert res.frobenius_norm == pytest.approx(full.frobenius_norm, rel=1e-12)
    np.testing.assert_allclose(res.q, full.q, rtol=0, atol=1e-9)


def test_default_at_adaptive_n_is_reproducible(spy: list[list[Any]]) -> None:
    stack, target = Stack.reference(N_BIG), _target(N_BIG, seed=7)
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
    # tests/test_leg_pairs.py); here none is
    monkeypatch.setattr(stages, "UNFOLD_STARTS", 0)
    stack, target = Stack.reference(N_BIG), _target(N_BIG)
    solve_ik(stack, target, method="ip", starts=3)
    assert _counts(spy) == [3]
    spy.clear()
    g = PlatformGeometry.reference()
    g = PlatformGeometry(**{**g.to_dict(), "leg_radius": 1.0})  # planar self-leg rows
    fat = Stack((g,) * N_BIG)
    solve_ik(fat, target, method="ip")
    assert _counts(spy) == [_batch_size(N_BIG)]  # rows outside the interior point: one call
