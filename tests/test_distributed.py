"""Scale-out on a real (small) Dask cluster: serial results, a worker killed mid-batch,
resume from a checkpoint, cancel on error; process pools; the CLI's --scheduler.

One LocalCluster of two single-threaded worker processes serves the module.
"""

from __future__ import annotations

import json
import os
import signal
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

import cloudpickle  # noqa: E402 - a dependency of distributed

import stackik as sk  # noqa: E402
from stackik.analysis.montecarlo import monte_carlo  # noqa: E402
from stackik.analysis.workspace import nonoptimal_poses, workspace_study  # noqa: E402
from stackik.batch import BatchStats, checkpointed_map, is_dask_client  # noqa: E402
from stackik.cli import main  # noqa: E402
from stackik.distributed import connect, parse_scheduler, register_warm_up  # noqa: E402
from stackik.sampling import random_reachable_targets  # noqa: E402
from stackik.solve.many import solve_to_file  # noqa: E402
from stackik.targets import target_to_dict  # noqa: E402

# the helpers below travel to the workers by value (the workers cannot import tests/)
cloudpickle.register_pickle_by_value(sys.modules[__name__])

STACK = sk.Stack.reference(4)
TARGETS = [
    *random_reachable_targets(STACK, 22, rng=5, phi=0.4),
    sk.PlanarTarget(5000.0, 0.0, 0.0),  # unreachable: its result travels too
    sk.PlanarTarget(600.0, 1000.0, -1.57),
]


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    cluster = LocalCluster(  # its HTTP server on any free port: other clusters may run
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    )
    c = Client(cluster)
    register_warm_up(c, kinds=("planar",))  # all the tests here solve planar targets
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def serial() -> list[sk.IKResult]:
    return sk.solve_many(STACK, TARGETS)


def _same(a: list[sk.IKResult], b: list[sk.IKResult]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert x.status is y.status and x.success == y.success
        np.testing.assert_array_equal(x.q, y.q)
        assert x.frobenius_norm == y.frobenius_norm


def _indices(path: Path) -> list[int]:
    return [json.loads(line)["index"] for line in path.read_text().splitlines() if line]


class _SlowSolve:
    """solve_ik with a pause, logging every call (to count work done twice)."""

    def __init__(self, stack: sk.Stack, pause: float, log: str) -> None:
        self.stack, self.pause, self.log = stack, pause, log

    def __call__(self, target: sk.PlanarTarget) -> sk.IKResult:
        time.sleep(self.pause)
        with open(self.log, "a") as fh:
            fh.write(f"{os.getpid()}\n")
        return sk.solve_ik(self.stack, target)


# -----------------------------------------------------------------------------------------
# solve_many on a Dask client
# -----------------------------------------------------------------------------------------
def test_client_gives_the_serial_results(client, serial):
    assert is_dask_client(client)
    stats = BatchStats()
    _same(sk.solve_many(STACK, TARGETS, executor=client, stats=stats), serial)
    assert sum(stats.chunks) == len(TARGETS) and len(stats.chunks) > 2  # chunked
    assert stats.slots == 2 and stats.cpu > 0.0
    # the Client's concurrent.futures face takes the same path
    _same(sk.solve_many(STACK, TARGETS, executor=client.get_executor()), serial)


def test_workers_loaded_the_kernels_when_they_started(client):
    def ready() -> list[str]:
        from stackik.solve import warmup

        return sorted(warmup._READY)

    assert all("planar" in v for v in client.run(ready).values())


def test_a_worker_killed_mid_batch_costs_only_its_chunk(client, serial, tmp_path):
    ckpt, log = tmp_path / "run.jsonl", tmp_path / "calls.log"
    fn = _SlowSolve(STACK, 0.1, str(log))
    out: dict[str, object] = {}

    def run() -> None:
        try:
            out["results"] = checkpointed_map(
                fn, TARGETS, key=target_to_dict, encode=sk.IKResult.to_record,
                decode=sk.IKResult.from_record, checkpoint=ckpt, executor=client, chunksize=3,
            )  # fmt: skip
        except BaseException as exc:  # noqa: BLE001 - reported below
            out["error"] = exc

    pids = client.run(os.getpid)  # worker address -> process id
    batch = threading.Thread(target=run)
    batch.start()
    deadline = time.monotonic() + 60
    victim = None
    while victim is None and batch.is_alive() and time.monotonic() < deadline:
        if ckpt.exists() and len(_indices(ckpt)) >= 3:
            busy = [w for w, keys in client.processing().items() if keys]
            victim = busy[0] if busy else None
        time.sleep(0.02)
    assert victim is not None, "the batch ended before a worker could be killed"
    done_at_kill = len(_indices(ckpt))
    os.kill(pids[victim], signal.SIGKILL)  # the worker process dies mid-chunk
    batch.join(timeout=120)
    assert "error" not in out, out.get("error")
    assert done_at_kill < len(TARGETS)  # the kill landed mid-batch
    _same(out["results"], serial)  # type: ignore[arg-type]
    assert sorted(_indices(ckpt)) == list(range(len(TARGETS)))  # each target exactly once
    calls = len(log.read_text().splitlines())
    assert len(TARGETS) <= calls <= len(TARGETS) + 3  # at most the lost chunk ran twice


def test_resume_from_a_checkpoint_on_the_cluster(client, serial, tmp_path):
    ckpt = tmp_path / "run.jsonl"
    sk.solve_many(STACK, TARGETS[:9], checkpoint=ckpt)  # an interrupted first run
    with open(ckpt, "a") as fh:
        fh.write('{"index": 9, "key": {"rho"')  # torn last line
    stats = BatchStats()
    resumed = sk.solve_many(STACK, TARGETS, executor=client, checkpoint=ckpt, stats=stats)
    _same(resumed, serial)
    assert (stats.resumed, stats.computed) == (9, len(TARGETS) - 9)
    assert sorted(_indices(ckpt)) == list(range(len(TARGETS)))


def test_streamed_batch_keeps_nothing_and_resumes(client, serial, tmp_path):
    ckpt = tmp_path / "stream.jsonl"
    first = solve_to_file(STACK, TARGETS[:5], ckpt)  # the first five, as a killed run left
    assert first.computed == 5
    stats = solve_to_file(STACK, TARGETS, ckpt, executor=client)
    assert (stats.resumed, stats.computed) == (5, len(TARGETS) - 5)
    lines = [json.loads(x) for x in ckpt.read_text().splitlines()]
    assert sorted(r["index"] for r in lines) == list(range(len(TARGETS)))
    back = {r["index"]: sk.IKResult.from_record(r["value"]) for r in lines}
    _same([back[i] for i in range(len(TARGETS))], serial)


def test_an_error_cancels_the_pending_chunks(client):
    stats = BatchStats()
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match="non-negative"):
        checkpointed_map(
            time.sleep, [-1.0] + [0.5] * 15, key=lambda x: None, encode=lambda r: r,
            decode=lambda r: r, executor=client, chunksize=1, stats=stats,
        )  # fmt: skip
    assert time.perf_counter() - t0 < 3.0  # not the 7.5 s the rest would take
    assert len(stats.chunks) <= 4  # the window, never all 16

    def ours(dask_scheduler) -> list[str]:  # noqa: ANN001 - Dask's calling convention
        return [str(k) for k in dask_scheduler.tasks if str(k).startswith("stackik-chunk")]

    deadline = time.monotonic() + 10
    while client.run_on_scheduler(ours) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert client.run_on_scheduler(ours) == []  # cancelled and released


# -----------------------------------------------------------------------------------------
# studies
# -----------------------------------------------------------------------------------------
def test_workspace_study_on_the_cluster_is_the_serial_study(client):
    kw = dict(n_samples=300, seed=3)
    a = workspace_study(STACK, 6, **kw)
    b = workspace_study(STACK, 6, executor=client, **kw)
    assert a.targets == b.targets
    for name in ("valid", "q_opt", "q_non", "fn_opt", "fn_non", "median_opt", "median_non"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_monte_carlo_and_nonoptimal_poses_spread(client):
    target = sk.PlanarTarget(600.0, 1000.0, -1.57)
    a = nonoptimal_poses(STACK, target, 2, seed=7)
    b = nonoptimal_poses(STACK, target, 2, seed=7, executor=client)
    _same(a, b)
    poses = [r.q for r in a]
    m1 = monte_carlo(poses, 3000, 1.0, 0.005, rng=11)
    m2 = monte_carlo(poses, 3000, 1.0, 0.005, rng=11, executor=client)
    assert m1.seed == m2.seed and len(m2) == 2
    for p, q in zip(m1.poses, m2.poses, strict=True):
        np.testing.assert_array_equal(p.distance, q.distance)
        np.testing.assert_array_equal(p.displacement, q.displacement)
        assert p.median == q.median and p.interval == q.interval


def test_process_pool_from_connect_is_chunked_and_serial_identical(serial):
    with connect(workers=2) as pool:
        assert isinstance(pool, ProcessPoolExecutor)
        stats = BatchStats()
        _same(sk.solve_many(STACK, TARGETS, executor=pool, stats=stats), serial)
    assert sum(stats.chunks) == len(TARGETS) and stats.slots == 2
    with connect() as none:
        assert none is None


def test_parse_scheduler():
    assert parse_scheduler("local:3") == ("local", 3)
    assert parse_scheduler(" tcp://10.0.0.5:8786 ") == ("address", "tcp://10.0.0.5:8786")
    for bad in ("", "local:x", "local:0"):
        with pytest.raises(ValueError):
            parse_scheduler(bad)


# -----------------------------------------------------------------------------------------
# command line
# -----------------------------------------------------------------------------------------
def test_map_on_a_local_cluster_writes_the_serial_study(tmp_path, capsys):
    argv = ["map", "--targets", "5", "--samples", "200", "--quiet", "--json"]
    assert main([*argv, "--out", str(tmp_path / "serial")]) == 0
    assert main([*argv, "--out", str(tmp_path / "dask"), "--scheduler", "local:2"]) == 0
    capsys.readouterr()
    a = (tmp_path / "serial" / "workspace.csv").read_text()
    assert a == (tmp_path / "dask" / "workspace.csv").read_text()
    assert (tmp_path / "dask" / "regression.json").exists()
