"""Checkpointed batch evaluation: finished work survives an interruption.

:func:`checkpointed_map` applies a function to many items and appends each result to a
JSON-lines file as soon as it is finished (flushed chunk by chunk). Run again with the
same items and file, it loads what is there, skips those items and computes only the
rest, so an interrupted batch resumes without losing or repeating work and ends with the
same results as an uninterrupted run. A torn last line (the process died while writing)
is dropped; a file written for other items is refused. :func:`checkpointed_run` does the
same without keeping the results in memory (the file is the output).

Spreading the work. ``executor`` may be any :class:`concurrent.futures.Executor` (a
process or thread pool) or a Dask ``distributed.Client`` (or its ``get_executor()``);
Dask is only imported when a Client is passed. Either way the items go out in *chunks*
(one task computes a list of items), at most ``window`` chunks are in flight at a time,
results are written to the checkpoint as their chunks complete (in completion order; the
returned list is in input order), and on an error or an interrupt (``KeyboardInterrupt``)
the pending chunks are cancelled before the exception propagates. With a Dask Client the
function is scattered to every worker once (``client.scatter(fn, broadcast=True)``), so
a task carries only its chunk of items; a worker that dies mid-batch costs only its
chunk, which Dask reruns on another worker.

Chunk size (``chunksize=None``): the first chunks hold one item; each finished chunk
reports its worker-side time, and later chunks hold ``chunk_seconds / t`` items, ``t``
the mean time per item over the last ``2 slots`` chunks (worker-side, so queueing and
transfer do not count; ``slots`` = the workers' threads or the pool's processes),
capped so that what remains is still shared out in at least two chunks per slot (the
tail stays balanced). A function may define ``prepare()``: it is called in the worker
before each chunk's clock starts (e.g. loading compiled kernels once per process).
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
import uuid
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from stackik._threads import batch_threads

__all__ = [
    "BatchStats",
    "checkpointed_map",
    "checkpointed_run",
    "executor_slots",
    "is_dask_client",
]

T = TypeVar("T")
R = TypeVar("R")

#: Default target of worker-side seconds per chunk (adaptive chunk size).
CHUNK_SECONDS = 0.5
#: Largest adaptive chunk (items).
MAX_CHUNK = 10_000


@dataclass
class BatchStats:
    """What a batch did (filled in when passed as ``stats=``).

    Attributes
    ----------
    total : int
        Items in the batch.
    resumed : int
        Items found in the checkpoint (not computed again).
    computed : int
        Items computed by this call.
    chunks : list of int
        Size of every chunk computed, in submission order (serial runs: none).
    busy, cpu : float
        Worker-side wall and process CPU seconds (:func:`time.process_time`) spent
        inside the chunks, summed over chunks (serial runs: the caller's).
    wall : float
        Wall seconds of the whole call, as the caller sees them.
    slots : int
        Chunks the executor can run at once (1 for a serial run).
    """

    total: int = 0
    resumed: int = 0
    computed: int = 0
    chunks: list[int] = field(default_factory=list)
    busy: float = 0.0
    cpu: float = 0.0
    wall: float = 0.0
    slots: int = 1


# =========================================================================================
# Checkpoint file
# =========================================================================================
def _norm(value: Any) -> Any:
    """A key as it reads back from JSON (tuples become lists, ...)."""
    return json.loads(json.dumps(value))


def _load(path: Path, count: int, key_of: Callable[[int], Any], keep: bool) -> dict[int, Any]:
    """Records of ``path``: index -> stored value (None when not ``keep``)."""
    if not path.exists():
        return {}
    raw = path.read_bytes()
    if raw and not raw.endswith(b"\n"):  # died while writing: keep whole lines only
        raw = raw[: raw.rfind(b"\n") + 1]
        with open(path, "r+b") as fh:
            fh.truncate(len(raw))
    done: dict[int, Any] = {}
    for k, line in enumerate(raw.decode().splitlines()):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
            i = int(rec["index"])
            key, value = rec["key"], rec["value"]
        except (ValueError, KeyError, TypeError) as exc:
            raise ValueError(
                f"checkpoint {path}: line {k + 1} is not a stackik record ({exc})"
            ) from None
        if not 0 <= i < count or key != key_of(i):
            raise ValueError(
                f"checkpoint {path}: line {k + 1} belongs to a different batch; "
                "use another checkpoint file"
            )
        done[i] = value if keep else None
    return done


# =========================================================================================
# Executors
# =========================================================================================
def is_dask_client(obj: Any) -> bool:
    """True for a ``distributed.Client`` (never imports Dask itself)."""
    mod = sys.modules.get("distributed")
    return mod is not None and isinstance(obj, mod.Client)


def _dask_parts(executor: Any) -> tuple[Any, dict[str, Any]] | None:
    """(client, submit kwargs) of a Dask Client or its ``get_executor()``; else None."""
    if is_dask_client(executor):
        return executor, {}
    cf = sys.modules.get("distributed.cfexecutor")
    if cf is not None and isinstance(executor, cf.ClientExecutor):
        return executor._client, dict(getattr(executor, "_kwargs", {}))
    return None


def _run_chunk(fn: Callable[[Any], Any], items: list[Any]) -> tuple[list[Any], float, float]:
    """One task: ``[fn(x) for x in items]`` and its worker-side wall and CPU seconds."""
    prepare = getattr(fn, "prepare", None)
    if callable(prepare):
        prepare()
    t0, c0 = time.perf_counter(), time.process_time()
    with batch_threads(1):  # the workers run solves side by side: one thread a solve
        out = [fn(x) for x in items]
    return out, time.perf_counter() - t0, time.process_time() - c0


class _Sizer:
    """Adaptive chunk sizes (module docstring): the time per item is that of the last
    ``2 slots`` chunks, so the slow first call of a fresh worker soon stops counting."""

    def __init__(self, chunksize: int | None, seconds: float, slots: int) -> None:
        self.fixed = chunksize
        self.seconds = seconds
        self.slots = max(1, slots)
        self.recent: deque[tuple[int, float]] = deque()

    def observe(self, items: int, busy: float) -> None:
        self.recent.append((items, busy))
        while len(self.recent) > 2 * self.slots:
            self.recent.popleft()

    def next(self, remaining: int) -> int:
        if self.fixed is not None:
            return max(1, min(self.fixed, remaining))
        if not self.recent:
            size = 1
        else:
            items = sum(k for k, _ in self.recent)
            per = max(sum(b for _, b in self.recent) / items, 1e-6)
            size = min(MAX_CHUNK, max(1, int(self.seconds / per)))
        tail = math.ceil(remaining / (2 * self.slots))
        return max(1, min(size, tail, remaining))


def executor_slots(executor: Any) -> int:
    """How many tasks ``executor`` runs at once: a Dask cluster's worker threads, a
    pool's ``max_workers``, 1 for None."""
    return 1 if executor is None else _slots(executor, _dask_parts(executor))


def _slots(executor: Any, dask: tuple[Any, dict[str, Any]] | None) -> int:
    if dask is not None:
        try:
            return max(1, sum(dask[0].nthreads().values()))
        except Exception:  # noqa: BLE001 - no workers yet: start small
            return 1
    n = getattr(executor, "_max_workers", None)
    return int(n) if isinstance(n, int) and n > 0 else (os.cpu_count() or 1)


def _spread(
    fn: Callable[[T], R],
    items: Sequence[T],
    todo: list[int],
    executor: Any,
    *,
    chunksize: int | None,
    window: int | None,
    chunk_seconds: float,
    stats: BatchStats,
) -> Iterator[tuple[list[int], list[R]]]:
    """Yield (indices, results) chunk by chunk as they complete; cancel the rest on exit."""
    dask = _dask_parts(executor)
    slots = _slots(executor, dask)
    stats.slots = slots
    limit = max(1, window if window is not None else 2 * slots)
    sizer = _Sizer(chunksize, chunk_seconds, slots)
    pos = 0
    pending: dict[Any, list[int]] = {}
    shared: Any = None
    failed: Any = None
    refreshed = time.monotonic()

    if dask is not None:
        import distributed

        client, extra = dask
        token = uuid.uuid4().hex[:12]
        shared = client.scatter(fn, broadcast=True, hash=False)
        counter = 0

        def submit(idx: list[int]) -> Any:
            nonlocal counter
            counter += 1
            return client.submit(
                _run_chunk,
                shared,
                [items[i] for i in idx],
                key=f"stackik-chunk-{token}-{counter}",
                pure=False,
                **extra,
            )

        done_iter: Any = distributed.as_completed()
    else:

        def submit(idx: list[int]) -> Any:
            return executor.submit(_run_chunk, fn, [items[i] for i in idx])

    def fill() -> None:
        nonlocal pos, refreshed, limit
        if dask is not None and window is None and time.monotonic() - refreshed > 2.0:
            refreshed = time.monotonic()  # workers come and go: follow the cluster's size
            sizer.slots = stats.slots = _slots(executor, dask)
            limit = 2 * sizer.slots
        while pos < len(todo) and len(pending) < limit:
            size = sizer.next(len(todo) - pos)
            idx = todo[pos : pos + size]
            pos += size
            fut = submit(idx)
            pending[fut] = idx
            stats.chunks.append(len(idx))
            if dask is not None:
                done_iter.add(fut)

    try:
        fill()
        while pending:
            if dask is not None:
                finished = [next(done_iter)]
            else:  # record the chunks that succeeded before raising for one that failed
                finished = list(wait(list(pending), return_when=FIRST_COMPLETED).done)
                finished.sort(key=lambda f: f.exception() is not None)
            for fut in finished:
                failed = fut  # released with the pending chunks if .result() raises
                idx = pending.pop(fut)
                results, busy, cpu = fut.result()  # a failed chunk raises here
                failed = None
                sizer.observe(len(idx), busy)
                stats.busy += busy
                stats.cpu += cpu
                yield idx, results
            fill()
    finally:
        drop = [*pending, *([] if failed is None else [failed])]
        if drop:  # error, interrupt or an abandoned generator: drop queued work
            if dask is not None:
                try:
                    dask[0].cancel(drop)
                except Exception:  # noqa: BLE001 - best effort while unwinding
                    pass
            else:
                for fut in drop:
                    fut.cancel()
        shared = None  # releases the scattered function


def _drive(
    fn: Callable[[T], R],
    items: Iterable[T],
    *,
    key: Callable[[T], Any],
    encode: Callable[[R], Any],
    decode: Callable[[Any], R] | None,
    checkpoint: str | Path | None,
    executor: Any,
    progress: bool,
    desc: str,
    chunksize: int | None,
    window: int | None,
    chunk_seconds: float,
    stats: BatchStats | None,
    reduce: Callable[[R], Any] | None = None,
) -> dict[int, Any]:
    t_start = time.perf_counter()
    st = BatchStats() if stats is None else stats
    ilist = items if isinstance(items, list | tuple) else list(items)
    keep = decode is not None
    path = None if checkpoint is None else Path(checkpoint)
    if chunksize is not None and chunksize < 1:
        raise ValueError(f"chunksize must be >= 1, got {chunksize}")

    def key_of(i: int) -> Any:
        return _norm(key(ilist[i]))

    loaded = {} if path is None else _load(path, len(ilist), key_of, keep)
    done: dict[int, Any] = {}
    if keep:
        assert decode is not None
        done = {i: decode(v) for i, v in loaded.items()}
        if reduce is not None:
            done = {i: reduce(r) for i, r in done.items()}
    todo = [i for i in range(len(ilist)) if i not in loaded]
    st.total, st.resumed = len(ilist), len(loaded)
    del loaded
    bar: Any = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(ilist), initial=st.resumed, desc=desc, unit="item")
    fh = None if path is None else open(path, "a")  # noqa: SIM115 - closed in finally
    try:

        def record(idx: list[int], results: list[R]) -> None:
            if fh is not None:
                lines = [
                    json.dumps({"index": i, "key": key_of(i), "value": encode(r)})
                    for i, r in zip(idx, results, strict=True)
                ]
                fh.write("\n".join(lines) + "\n")
                fh.flush()
            if keep:
                kept = results if reduce is None else [reduce(r) for r in results]
                done.update(zip(idx, kept, strict=True))
            st.computed += len(idx)
            if bar is not None:
                bar.update(len(idx))

        if executor is None:  # (``prepare`` is for workers: fn prepares itself here)
            for i in todo:
                t0, c0 = time.perf_counter(), time.process_time()
                res = fn(ilist[i])
                st.busy += time.perf_counter() - t0
                st.cpu += time.process_time() - c0
                record([i], [res])
        else:
            for idx, results in _spread(
                fn,
                ilist,
                todo,
                executor,
                chunksize=chunksize,
                window=window,
                chunk_seconds=chunk_seconds,
                stats=st,
            ):
                record(idx, results)
    finally:
        if fh is not None:
            fh.close()
        if bar is not None:
            bar.close()
        st.wall = time.perf_counter() - t_start
    return done


def checkpointed_map(
    fn: Callable[[T], R],
    items: Iterable[T],
    *,
    key: Callable[[T], Any],
    encode: Callable[[R], Any],
    decode: Callable[[Any], R],
    checkpoint: str | Path | None = None,
    executor: Executor | Any | None = None,
    progress: bool = False,
    desc: str = "batch",
    chunksize: int | None = None,
    window: int | None = None,
    chunk_seconds: float = CHUNK_SECONDS,
    stats: BatchStats | None = None,
    reduce: Callable[[R], Any] | None = None,
) -> list[Any]:
    """``[fn(x) for x in items]``, with every finished result appended to ``checkpoint``.

    Parameters
    ----------
    key : callable
        JSON-ready identity of an item, stored with its result and compared on resume.
    encode, decode : callable
        Result to JSON-ready data and back (``decode(encode(r))`` must equal ``r``); they
        run in the calling process only.
    checkpoint : path, optional
        JSON-lines file; None computes everything and writes nothing.
    executor : concurrent.futures.Executor or distributed.Client, optional
        Spreads the items in chunks (module docstring); ``fn`` and the items must pickle.
        Results are recorded as their chunks complete, returned in input order.
    chunksize : int, optional
        Items per task (default: adaptive, about ``chunk_seconds`` of work per task).
    window : int, optional
        Most chunks in flight at once (default: twice the executor's slots).
    chunk_seconds : float
        Worker-side seconds per chunk the adaptive size aims at.
    stats : BatchStats, optional
        Filled in with what the call did.
    reduce : callable, optional
        Applied (in this process) to every result, computed or read back, before it is
        kept: the list holds ``reduce(r)`` instead of ``r`` (the checkpoint still gets
        ``encode(r)``), so a large batch keeps only what its caller needs.
    """
    done = _drive(
        fn, items, key=key, encode=encode, decode=decode, checkpoint=checkpoint,
        executor=executor, progress=progress, desc=desc, chunksize=chunksize, window=window,
        chunk_seconds=chunk_seconds, stats=stats, reduce=reduce,
    )  # fmt: skip
    return [done[i] for i in range(len(done))]


def checkpointed_run(
    fn: Callable[[T], R],
    items: Iterable[T],
    *,
    key: Callable[[T], Any],
    encode: Callable[[R], Any],
    checkpoint: str | Path,
    executor: Executor | Any | None = None,
    progress: bool = False,
    desc: str = "batch",
    chunksize: int | None = None,
    window: int | None = None,
    chunk_seconds: float = CHUNK_SECONDS,
    stats: BatchStats | None = None,
) -> BatchStats:
    """:func:`checkpointed_map` that keeps no results: they are streamed to
    ``checkpoint`` (required) and dropped, so the caller's memory does not grow with
    the batch (a resume reads back only which items are done). Returns the statistics.
    """
    st = BatchStats() if stats is None else stats
    _drive(
        fn, items, key=key, encode=encode, decode=None, checkpoint=checkpoint,
        executor=executor, progress=progress, desc=desc, chunksize=chunksize, window=window,
        chunk_seconds=chunk_seconds, stats=st,
    )  # fmt: skip
    return st
