"""solve_many: :func:`~stackik.solve.pipeline.solve_ik` over many targets, checkpointed."""

from __future__ import annotations

from collections.abc import Iterable
from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stackik.batch import checkpointed_map
from stackik.geometry import Stack
from stackik.result import IKResult
from stackik.solve.pipeline import solve_ik
from stackik.targets import Target, target_to_dict

__all__ = ["solve_many"]


def solve_many(
    stack: Stack,
    targets: Iterable[Target],
    *,
    progress: bool = False,
    executor: Executor | None = None,
    checkpoint: str | Path | None = None,
    **kwargs: Any,
) -> list[IKResult]:
    """Solve :func:`solve_ik` for many targets (same keyword arguments).

    Parameters
    ----------
    progress : bool
        Show a tqdm progress bar.
    executor : concurrent.futures.Executor, optional
        Spread the targets (e.g. a ``ProcessPoolExecutor``); results keep the input order.
    checkpoint : path, optional
        JSON-lines file: every finished result is appended (and flushed) as soon as it
        completes; a later call with the same targets and file skips the targets already
        there, so an interrupted batch resumes without losing or repeating work.

    Returns
    -------
    list of IKResult
        In the order of ``targets``.
    """
    return checkpointed_map(
        _SolveOne(stack, kwargs),
        targets,
        key=target_to_dict,
        encode=IKResult.to_record,
        decode=IKResult.from_record,
        checkpoint=checkpoint,
        executor=executor,
        progress=progress,
        desc="solve",
    )


@dataclass(frozen=True)
class _SolveOne:
    stack: Stack
    kwargs: dict[str, Any]

    def __call__(self, target: Target) -> IKResult:
        return solve_ik(self.stack, target, **self.kwargs)
