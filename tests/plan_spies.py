"""Spies on a solve's stages for the start-plan tests (tests/test_loads_plan.py,
tests/test_obstacles_plan.py): what a rule decided and which interior-point batches ran."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from stackik.solve import stages


def spy_settled(monkeypatch: pytest.MonkeyPatch, name: str) -> list[bool]:
    """``settled`` (the 4th value returned) of every call of ``stages.<name>`` in a solve."""
    seen: list[bool] = []
    original = getattr(stages, name)

    def spy(*args: Any) -> Any:
        out = original(*args)
        seen.append(out[3])
        return out

    monkeypatch.setattr(stages, name, spy)
    return seen


def spy_batches(
    monkeypatch: pytest.MonkeyPatch, with_rows: Callable[[Any], bool]
) -> list[tuple[int, bool]]:
    """(starts, ``with_rows(problem)``) of every interior-point call with checks."""
    from stackik.methods.ip import IPMethod

    seen: list[tuple[int, bool]] = []
    original = IPMethod.run_many

    def run_many(self: IPMethod, prob: Any, starts: list[Any], *args: Any) -> Any:
        seen.append((len(starts), with_rows(prob)))
        return original(self, prob, starts, *args)

    monkeypatch.setattr(IPMethod, "run_many", run_many)
    return seen
