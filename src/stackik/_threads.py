"""Threads of one solve's interior-point batches (:func:`stackik.solve_ik`'s ``threads``).

A solve runs its interior-point starts in batches (the spatial default: 12 structured
starts, then its hops; the planar default at scale: its random and structured starts).
Each start's run is independent of the others, so a batch can run on several threads
(the compiled kernels release the GIL) and give the same runs, in the same order, as one
after another: the pose a solve returns does not depend on the thread count.

The count in force is a context variable: :func:`stackik.solve_ik` sets it for the
duration of a solve (its ``threads``; by default the CPUs this process may use, at most
:data:`MAX_THREADS`, unless an enclosing context set it), and the workers of
:mod:`stackik.batch` set it to 1, since they already run solves side by side.
"""

from __future__ import annotations

import itertools
import os
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from contextvars import ContextVar
from typing import TypeVar

__all__ = [
    "MAX_THREADS",
    "THREAD_MIN_N",
    "available_cpus",
    "batch_threads",
    "current",
    "for_problem",
    "map_in_threads",
    "resolve",
]

R = TypeVar("R")

#: The most threads a solve uses by default (a spatial default's batch has 6-12 starts).
MAX_THREADS = 8
#: Problems of at least this many variables (spatial from 4 platforms, planar from 8)
#: run a batch's starts on several threads: below, a run costs about what handing it to
#: another thread does (planar n = 4: 0.6 ms a solve for its eight starts).
THREAD_MIN_N = 24

_CURRENT: ContextVar[int | None] = ContextVar("stackik_batch_threads", default=None)


def available_cpus() -> int:
    """CPUs this process may run on (its affinity where the OS tells, else the count)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def resolve(threads: int | None) -> int:
    """The thread count of a solve: ``threads`` when given (a positive integer, else
    ValueError), else the enclosing context's, else ``min(available_cpus(), MAX_THREADS)``."""
    if threads is None:
        outer = _CURRENT.get()
        return outer if outer is not None else min(available_cpus(), MAX_THREADS)
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"threads must be a positive integer or None, got {threads!r}")
    return threads


def current() -> int:
    """The thread count in force for a batch (1 outside any solve)."""
    value = _CURRENT.get()
    return 1 if value is None else value


def for_problem(n_vars: int) -> int:
    """The threads a batch of a problem of ``n_vars`` variables runs on: :func:`current`
    from :data:`THREAD_MIN_N` variables on, else 1."""
    return current() if n_vars >= THREAD_MIN_N else 1


@contextmanager
def batch_threads(threads: int) -> Iterator[None]:
    """Run the enclosed code's batches on ``threads`` threads (restored on exit)."""
    token = _CURRENT.set(threads)
    try:
        yield
    finally:
        _CURRENT.reset(token)


_POOLS: dict[int, ThreadPoolExecutor] = {}
_POOLS_LOCK = threading.Lock()


def _pool(workers: int) -> ThreadPoolExecutor:
    """A process-wide pool of ``workers`` threads (made on first need, kept). Solves
    running at once share it: a solve's own thread works through its batch while its
    helpers wait their turn, so none waits on another's batch to start its own."""
    with _POOLS_LOCK:
        if workers not in _POOLS:
            _POOLS[workers] = ThreadPoolExecutor(workers, thread_name_prefix="stackik-batch")
        return _POOLS[workers]


def map_in_threads(fn: Callable[[int], R], count: int, threads: int) -> list[R]:
    """``[fn(0), ..., fn(count - 1)]``, computed on up to ``threads`` threads (this one and
    a pool's): each takes the next index not yet taken, so the calls spread evenly
    whatever they cost. With one thread (or one call), in turn on this thread. ``fn`` must
    not depend on which thread runs it or on the order of the calls; the first error is
    raised once every thread has stopped."""
    threads = min(threads, count)
    if threads <= 1:
        return [fn(j) for j in range(count)]
    out: list[R | None] = [None] * count
    taken = itertools.count()  # next() is atomic under the GIL

    def work() -> None:
        while (j := next(taken)) < count:
            out[j] = fn(j)

    helpers = [_pool(threads - 1).submit(work) for _ in range(threads - 1)]
    try:
        work()
    finally:
        for h in helpers:
            h.result()
    return out  # type: ignore[return-value]
