"""Checkpointed batch evaluation: finished work survives an interruption.

:func:`checkpointed_map` applies a function to many items and appends each result to a
JSON-lines file as soon as it is finished (flushed line by line). Run again with the same
items and file, it loads what is there, skips those items and computes only the rest, so
an interrupted batch resumes without losing or repeating work and ends with the same
results as an uninterrupted run. A torn last line (the process died while writing) is
dropped; a file written for other items is refused.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import Executor, as_completed
from pathlib import Path
from typing import Any, TypeVar

__all__ = ["checkpointed_map"]

T = TypeVar("T")
R = TypeVar("R")


def _load(path: Path, keys: Sequence[Any]) -> dict[int, Any]:
    if not path.exists():
        return {}
    raw = path.read_bytes()
    if raw and not raw.endswith(b"\n"):  # died while writing: keep whole lines only
        raw = raw[: raw.rfind(b"\n") + 1]
        path.write_bytes(raw)
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
        if not 0 <= i < len(keys) or key != keys[i]:
            raise ValueError(
                f"checkpoint {path}: line {k + 1} belongs to a different batch; "
                "use another checkpoint file"
            )
        done[i] = value
    return done


def checkpointed_map(
    fn: Callable[[T], R],
    items: Iterable[T],
    *,
    key: Callable[[T], Any],
    encode: Callable[[R], Any],
    decode: Callable[[Any], R],
    checkpoint: str | Path | None = None,
    executor: Executor | None = None,
    progress: bool = False,
    desc: str = "batch",
) -> list[R]:
    """``[fn(x) for x in items]``, with every finished result appended to ``checkpoint``.

    Parameters
    ----------
    key : callable
        JSON-ready identity of an item, stored with its result and compared on resume.
    encode, decode : callable
        Result to JSON-ready data and back (``decode(encode(r))`` must equal ``r``).
    checkpoint : path, optional
        JSON-lines file; None computes everything and writes nothing.
    executor : concurrent.futures.Executor, optional
        Spreads the items; results are recorded as they complete, returned in input order.
    """
    ilist = list(items)
    keys = [json.loads(json.dumps(key(x))) for x in ilist]
    path = None if checkpoint is None else Path(checkpoint)
    done: dict[int, R] = {}
    if path is not None:
        done = {i: decode(v) for i, v in _load(path, keys).items()}
    todo = [i for i in range(len(ilist)) if i not in done]
    bar: Any = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(ilist), initial=len(done), desc=desc, unit="item")
    fh = None if path is None else open(path, "a")  # noqa: SIM115 - closed in finally
    try:

        def record(i: int, res: R) -> None:
            done[i] = res
            if fh is not None:
                rec = {"index": i, "key": keys[i], "value": encode(res)}
                fh.write(json.dumps(rec) + "\n")
                fh.flush()
            if bar is not None:
                bar.update(1)

        if executor is None:
            for i in todo:
                record(i, fn(ilist[i]))
        else:
            futures = {executor.submit(fn, ilist[i]): i for i in todo}
            for fut in as_completed(futures):
                record(futures[fut], fut.result())
    finally:
        if fh is not None:
            fh.close()
        if bar is not None:
            bar.close()
    return [done[i] for i in range(len(ilist))]
