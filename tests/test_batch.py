"""Batch solves: checkpointed solve_many resumes after an interruption without losing or
repeating work, and gives the same final results as an uninterrupted run."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import stackik as sk
import stackik.solve.many as ik  # solve_many calls solve_ik through this module

STACK = sk.Stack.reference(4)
TARGETS = [
    sk.PlanarTarget(600.0, 1000.0, -1.57),
    sk.PlanarTarget(145.0, 1500.0, -0.207),
    sk.PlanarTarget(-319.0, 1532.0, 0.332),
    sk.PlanarTarget(200.0, 1300.0, 0.1, phi=0.8),
    sk.PlanarTarget(5000.0, 0.0, 0.0),  # unreachable: its result is recorded too
    sk.PlanarTarget(-100.0, 1400.0, -0.3, phi=-2.0),
]


def _lines(path: Path) -> list[dict]:
    return [json.loads(x) for x in path.read_text().splitlines() if x.strip()]


def _same(a: list[sk.IKResult], b: list[sk.IKResult]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert x.success == y.success and x.status == y.status
        np.testing.assert_array_equal(x.q, y.q)
        assert x.frobenius_norm == y.frobenius_norm


def test_record_round_trip():
    r = sk.solve_ik(STACK, TARGETS[0])
    back = sk.IKResult.from_record(json.loads(json.dumps(r.to_record())))
    np.testing.assert_array_equal(back.q, r.q)
    np.testing.assert_array_equal(back.R, r.R)
    assert back.status is r.status and back.frobenius_norm == r.frobenius_norm


def test_interrupted_batch_resumes_to_same_results(tmp_path, monkeypatch):
    reference = sk.solve_many(STACK, TARGETS)
    ckpt = tmp_path / "run.jsonl"
    real = ik.solve_ik
    calls = {"n": 0}

    def flaky(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 4:
            raise KeyboardInterrupt  # the user hits Ctrl-C during the 4th solve
        return real(*args, **kwargs)

    monkeypatch.setattr(ik, "solve_ik", flaky)
    with pytest.raises(KeyboardInterrupt):
        sk.solve_many(STACK, TARGETS, checkpoint=ckpt)
    assert [rec["index"] for rec in _lines(ckpt)] == [0, 1, 2]
    # a torn last line, as left by a process killed while writing
    with open(ckpt, "a") as fh:
        fh.write('{"index": 3, "target": {"rho"')
    monkeypatch.setattr(ik, "solve_ik", real)
    calls["n"] = 0
    counted = {"n": 0}

    def counting(*args, **kwargs):
        counted["n"] += 1
        return real(*args, **kwargs)

    monkeypatch.setattr(ik, "solve_ik", counting)
    resumed = sk.solve_many(STACK, TARGETS, checkpoint=ckpt)
    assert counted["n"] == len(TARGETS) - 3  # finished work is not repeated
    _same(resumed, reference)
    indices = [rec["index"] for rec in _lines(ckpt)]
    assert sorted(indices) == list(range(len(TARGETS)))  # nothing lost, nothing duplicated
    # a complete checkpoint: nothing left to solve
    again = sk.solve_many(STACK, TARGETS, checkpoint=ckpt)
    assert counted["n"] == len(TARGETS) - 3
    _same(again, reference)


def test_checkpoint_of_other_targets_is_refused(tmp_path):
    ckpt = tmp_path / "run.jsonl"
    sk.solve_many(STACK, TARGETS[:2], checkpoint=ckpt)
    with pytest.raises(ValueError, match="different batch"):
        sk.solve_many(STACK, TARGETS[1:3], checkpoint=ckpt)


def test_killed_process_resumes(tmp_path):
    """SIGKILL a real batch process mid-run, then resume it in this process."""
    ckpt = tmp_path / "killed.jsonl"
    script = tmp_path / "batch.py"
    spec = [(t.rho, t.z, t.theta, t.phi) for t in TARGETS]
    script.write_text(
        textwrap.dedent(
            f"""
            import stackik as sk, time
            import stackik.solve.many as ik
            real = ik.solve_ik
            def slow(*a, **k):
                r = real(*a, **k)
                time.sleep(0.3)  # make the kill land mid-batch
                return r
            ik.solve_ik = slow
            targets = [sk.PlanarTarget(*t) for t in {spec!r}]
            sk.solve_many(sk.Stack.reference(4), targets, checkpoint={str(ckpt)!r})
            """
        )
    )
    proc = subprocess.Popen([sys.executable, str(script)])
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if ckpt.exists() and len(ckpt.read_text().splitlines()) >= 2:
                break
            time.sleep(0.05)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait(timeout=30)
    n_before = len(_lines(ckpt))
    assert 2 <= n_before < len(TARGETS)
    resumed = sk.solve_many(STACK, TARGETS, checkpoint=ckpt)
    _same(resumed, sk.solve_many(STACK, TARGETS))
    assert sorted(rec["index"] for rec in _lines(ckpt)) == list(range(len(TARGETS)))


def test_checkpointed_map_resumes_with_executor(tmp_path):
    from concurrent.futures import ThreadPoolExecutor

    from stackik.batch import checkpointed_map

    calls: list[int] = []
    interrupt = {"armed": True}

    def square(x: int) -> int:
        calls.append(x)
        if interrupt["armed"] and len(calls) == 5:
            raise KeyboardInterrupt
        return x * x

    kw = dict(key=lambda x: x, encode=lambda r: r, decode=lambda r: r)
    ckpt = tmp_path / "sq.jsonl"
    with pytest.raises(KeyboardInterrupt):
        checkpointed_map(square, range(10), checkpoint=ckpt, **kw)
    assert len(_lines(ckpt)) == 4
    calls.clear()
    interrupt["armed"] = False
    with ThreadPoolExecutor(2) as ex:
        out = checkpointed_map(square, range(10), checkpoint=ckpt, executor=ex, **kw)
    assert out == [x * x for x in range(10)]
    assert sorted(calls) == list(range(4, 10))  # only the unfinished items ran
    assert sorted(rec["index"] for rec in _lines(ckpt)) == list(range(10))


def test_workspace_study_resumes_from_checkpoint(tmp_path, monkeypatch):
    from stackik.analysis.workspace import workspace_study

    kw = dict(n_samples=500, seed=3)
    first = workspace_study(STACK, 4, checkpoint_dir=tmp_path, **kw)
    assert (tmp_path / "optimal.jsonl").exists() and (tmp_path / "nonoptimal.jsonl").exists()

    def no_solving(*args, **kwargs):
        raise AssertionError("a finished solve was repeated")

    monkeypatch.setattr(ik, "solve_ik", no_solving)
    import stackik.solve

    monkeypatch.setattr(stackik.solve, "solve_ik", no_solving)
    again = workspace_study(STACK, 4, checkpoint_dir=tmp_path, **kw)
    np.testing.assert_array_equal(first.fn_opt, again.fn_opt)
    np.testing.assert_array_equal(first.median_non, again.median_non)


def test_chunk_sizes_follow_the_measured_time_and_keep_the_tail_balanced():
    from stackik.batch import _Sizer

    sizer = _Sizer(None, 0.5, slots=2)
    assert sizer.next(1000) == 1  # nothing measured yet: one item
    sizer.observe(1, 0.4)  # a fresh worker's slow first item ...
    for _ in range(4):
        sizer.observe(10, 0.1)  # ... then 10 ms per item: it soon stops counting
    assert sizer.next(1000) == 50  # 0.5 s / 10 ms
    assert sizer.next(60) == 15  # the rest still makes two chunks per slot
    assert sizer.next(1) == 1
    assert _Sizer(7, 0.5, slots=2).next(5) == 5  # a fixed size, capped by what is left


def test_chunked_executor_run_streams_and_reduces(tmp_path):
    from concurrent.futures import ThreadPoolExecutor

    from stackik.batch import BatchStats, checkpointed_map, checkpointed_run

    def square(x: int) -> int:
        return x * x

    kw = dict(key=lambda x: x, encode=lambda r: r)
    ckpt = tmp_path / "sq.jsonl"
    stats = BatchStats()
    with ThreadPoolExecutor(2) as ex:
        checkpointed_run(square, range(40), checkpoint=ckpt, executor=ex, stats=stats, **kw)
    assert stats.computed == 40 and sum(stats.chunks) == 40 and len(stats.chunks) > 4
    assert sorted(rec["index"] for rec in _lines(ckpt)) == list(range(40))
    halves = checkpointed_map(
        square, range(40), checkpoint=ckpt, decode=lambda r: r, reduce=lambda r: r / 2, **kw
    )
    assert halves == [x * x / 2 for x in range(40)]  # read back, then reduced
