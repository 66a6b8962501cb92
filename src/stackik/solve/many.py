"""solve_many: :func:`~stackik.solve.pipeline.solve_ik` over many targets, checkpointed
and optionally spread over a process pool or a Dask cluster (:mod:`stackik.batch`)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar, overload

from stackik.batch import BatchStats, checkpointed_map, checkpointed_run
from stackik.geometry import Stack
from stackik.result import IKResult
from stackik.solve.pipeline import solve_ik
from stackik.solve.warmup import warm_up
from stackik.targets import PlanarTarget, Target, target_to_dict

__all__ = ["solve_many", "solve_to_file"]

T = TypeVar("T")


@overload
def solve_many(
    stack: Stack,
    targets: Iterable[Target],
    *,
    progress: bool = ...,
    executor: Executor | Any | None = ...,
    checkpoint: str | Path | None = ...,
    chunksize: int | None = ...,
    stats: BatchStats | None = ...,
    reduce: None = ...,
    **kwargs: Any,
) -> list[IKResult]: ...


@overload
def solve_many(
    stack: Stack,
    targets: Iterable[Target],
    *,
    progress: bool = ...,
    executor: Executor | Any | None = ...,
    checkpoint: str | Path | None = ...,
    chunksize: int | None = ...,
    stats: BatchStats | None = ...,
    reduce: Callable[[IKResult], T],
    **kwargs: Any,
) -> list[T]: ...


def solve_many(
    stack: Stack,
    targets: Iterable[Target],
    *,
    progress: bool = False,
    executor: Executor | Any | None = None,
    checkpoint: str | Path | None = None,
    chunksize: int | None = None,
    stats: BatchStats | None = None,
    reduce: Callable[[IKResult], Any] | None = None,
    **kwargs: Any,
) -> list[Any]:
    """Solve :func:`solve_ik` for many targets (same keyword arguments).

    Parameters
    ----------
    progress : bool
        Show a tqdm progress bar.
    executor : concurrent.futures.Executor or distributed.Client, optional
        Spread the targets over a ``ProcessPoolExecutor`` (or thread pool), or over a
        Dask cluster given its ``distributed.Client``: targets go out in chunks of about
        0.5 s of work, the stack and options are sent to each worker once (scattered),
        a bounded number of chunks is in flight, results stream back into the checkpoint
        as they complete, pending work is cancelled on an error or an interrupt, and a
        worker lost mid-batch costs only its chunk (:mod:`stackik.batch`). Each worker
        loads the compiled kernels once before its first chunk is timed
        (:func:`stackik.distributed.connect` also registers a worker plugin that does it
        when a worker starts). The poses are those of the serial run; results keep the
        input order.
    checkpoint : path, optional
        JSON-lines file: every finished result is appended (and flushed) as soon as it
        completes; a later call with the same targets and file skips the targets already
        there, so an interrupted batch resumes without losing or repeating work.
    chunksize : int, optional
        Targets per task with an executor (default: adaptive, from the measured time per
        target).
    stats : stackik.batch.BatchStats, optional
        Filled in with counts and worker-side wall and CPU seconds.
    reduce : callable, optional
        Keep ``reduce(result)`` instead of each IKResult (e.g. only the pose and FN of a
        100,000-target study); the checkpoint still records the full results.

    Returns
    -------
    list of IKResult
        In the order of ``targets`` (``reduce`` of each with ``reduce``).
    """
    tlist = list(targets)
    return checkpointed_map(
        _SolveOne(stack, kwargs, _kinds(tlist)),
        tlist,
        key=target_to_dict,
        encode=IKResult.to_record,
        decode=IKResult.from_record,
        checkpoint=checkpoint,
        executor=executor,
        progress=progress,
        desc="solve",
        chunksize=chunksize,
        stats=stats,
        reduce=reduce,
    )


def solve_to_file(
    stack: Stack,
    targets: Sequence[Target],
    checkpoint: str | Path,
    *,
    progress: bool = False,
    executor: Executor | Any | None = None,
    chunksize: int | None = None,
    **kwargs: Any,
) -> BatchStats:
    """:func:`solve_many` for batches too large to hold: every result is streamed to the
    JSON-lines file ``checkpoint`` (one record per target: ``index``, ``key`` = the
    target, ``value`` = :meth:`IKResult.to_record`) and not kept, so memory stays flat
    however many targets there are; rerun with the same file to resume after an
    interruption (every target ends up in the file exactly once). Returns the batch
    statistics.
    """
    tlist = list(targets)
    return checkpointed_run(
        _SolveOne(stack, kwargs, _kinds(tlist)),
        tlist,
        key=target_to_dict,
        encode=IKResult.to_record,
        checkpoint=checkpoint,
        executor=executor,
        progress=progress,
        desc="solve",
        chunksize=chunksize,
    )


def _kinds(targets: Sequence[Target]) -> tuple[str, ...]:
    """Kernel sets a worker loads before its first chunk (solve_ik loads any other)."""
    kinds: tuple[str, ...] = ()
    if any(isinstance(t, PlanarTarget) for t in targets):
        kinds += ("planar",)
    if any(not isinstance(t, PlanarTarget) for t in targets):
        kinds += ("spatial",)
    return kinds


@dataclass(frozen=True)
class _SolveOne:
    """The per-target function shipped to workers: the stack and the solve options."""

    stack: Stack
    kwargs: dict[str, Any]
    kinds: tuple[str, ...] = ("planar",)

    def prepare(self) -> None:
        """Load (or compile) the kernels once per process, before a chunk is timed."""
        warm_up(self.kinds, notice=False)

    def __call__(self, target: Target) -> IKResult:
        return solve_ik(self.stack, target, **self.kwargs)
