"""Benchmark: Dask scale-out on this machine (a 2-worker LocalCluster against serial).

Run with ``python benchmarks/bench_distributed.py`` (about 5 minutes on 2 cores; ``--quick``
for a smoke run, ``--skip-100k`` without the 100,000-target run); writes
``benchmarks/results/distributed.json`` and ``.md``. Three parts:

1. ``solve_many`` on 300 random reachable targets at n = 8: serial against a Dask
   ``LocalCluster`` of two single-threaded worker processes (started and warmed before
   the clock, as a long-lived cluster is), repetitions interleaved so both see the same
   machine load; wall time, CPU time per target (inside the solves: the worker-side
   ``time.process_time`` of every chunk; and everything: the worker processes', the
   client's), identical poses. Once more on a fresh cluster whose workers load the
   kernels inside the timed call.
2. ``stackik map --targets 1000`` (default samples), serial against ``--scheduler
   local:2`` and ``--workers 2``, as subprocesses (imports, cluster start and the target
   drawing included); identical ``workspace.csv``.
3. 100,000 targets at n = 2 (``starts=1``) streamed to a JSON-lines file by
   ``solve_to_file`` on ``--scheduler local:2``: the client process (with its cluster) is
   killed mid-run, a second one resumes; every target must be in the file exactly once.
   Peak resident memory of the client against a 10,000-target run.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import signal
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path
from typing import Any

import numpy as np

import stackik as sk
from stackik.batch import BatchStats
from stackik.bench import machine_info
from stackik.sampling import random_reachable_targets

OUT = Path(__file__).resolve().parent / "results"


def _same(a: list[sk.IKResult], b: list[sk.IKResult]) -> bool:
    return len(a) == len(b) and all(
        x.status is y.status and np.array_equal(x.q, y.q) and x.frobenius_norm == y.frobenius_norm
        for x, y in zip(a, b, strict=True)
    )


def _cluster(warm: bool = True) -> tuple[Any, Any]:
    from distributed import Client, LocalCluster

    from stackik.distributed import register_warm_up

    cluster = LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    )
    client = Client(cluster)
    if warm:
        register_warm_up(client, kinds=("planar",))
    return cluster, client


def _free_cores() -> float:
    """CPU capacity two processes get right now: 2 x (one spinner's time alone) / (two
    spinners' time side by side); 2.0 on an idle 2-core machine, 1.0 when another job
    holds a core."""
    code = "import time\nt=time.perf_counter()\nx=0\nfor i in range(6_000_000): x+=i\n"
    code += "print(time.perf_counter()-t)"

    def spin(k: int) -> float:
        procs = [
            subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
            for _ in range(k)
        ]
        return max(float(p.communicate()[0]) for p in procs)

    return 2.0 * spin(1) / spin(2)


def _machine_cpu() -> float:
    """CPU seconds the whole machine has spent busy (all processes, /proc/stat)."""
    try:
        with open("/proc/stat") as fh:
            f = [int(v) for v in fh.readline().split()[1:]]
    except OSError:
        return float("nan")
    busy = f[0] + f[1] + f[2] + sum(f[5:8])  # user nice system irq softirq steal
    return busy / os.sysconf("SC_CLK_TCK")


def _worker_cpu(client: Any) -> float:
    return float(sum(client.run(time.process_time).values()))


# =========================================================================================
# 1. solve_many, 300 targets at n = 8
# =========================================================================================
def bench_solve_many(n: int, count: int, repeats: int) -> dict[str, Any]:
    stack = sk.Stack.reference(n)
    targets = random_reachable_targets(stack, count, rng=8)
    sk.warm_up(("planar",), notice=False)
    sk.solve_many(stack, targets[:5])  # first solves (imports) before any clock
    cluster, client = _cluster()
    sk.solve_many(stack, targets[:8], executor=client)  # first solves in the workers
    runs: list[dict[str, Any]] = []
    identical = True
    try:
        for r in range(repeats):
            row: dict[str, Any] = {"load": os.getloadavg()[0], "free_cores": _free_cores()}
            for mode in ("serial", "dask") if r % 2 == 0 else ("dask", "serial"):
                stats = BatchStats()
                c0, w0 = time.process_time(), _worker_cpu(client) if mode == "dask" else 0.0
                m0 = _machine_cpu()
                t0 = time.perf_counter()
                res = sk.solve_many(
                    stack, targets, executor=client if mode == "dask" else None, stats=stats
                )
                wall = time.perf_counter() - t0
                machine = _machine_cpu() - m0
                client_cpu = time.process_time() - c0
                row[mode] = {
                    "wall_s": wall,
                    "in_solve_cpu_ms": 1e3 * stats.cpu / count,
                    # wall time inside the solves / (slots x wall): gaps between chunks
                    "slot_utilisation": stats.busy / (stats.slots * wall),
                    # CPU / wall inside the solves: the share of a core the OS gave them
                    "cpu_share": stats.cpu / stats.busy,
                }
                ours = client_cpu
                if mode == "dask":
                    workers_cpu = _worker_cpu(client) - w0
                    ours += workers_cpu
                    row[mode].update(
                        {
                            "client_cpu_ms": 1e3 * client_cpu / count,
                            "workers_cpu_ms": 1e3 * workers_cpu / count,
                            "total_cpu_ms": 1e3 * (client_cpu + workers_cpu) / count,
                            "chunks": len(stats.chunks),
                            "chunk_sizes": stats.chunks,
                        }
                    )
                    dask_res = res
                else:
                    row[mode]["total_cpu_ms"] = 1e3 * client_cpu / count
                    serial_res = res
                # cores the rest of the machine (other jobs) used meanwhile
                row[mode]["other_cores"] = max(0.0, machine - ours) / wall
            identical &= _same(serial_res, dask_res)
            row["speedup"] = row["serial"]["wall_s"] / row["dask"]["wall_s"]
            row["cpu_ratio_in_solve"] = (
                row["dask"]["in_solve_cpu_ms"] / row["serial"]["in_solve_cpu_ms"]
            )
            row["cpu_ratio_total"] = row["dask"]["total_cpu_ms"] / row["serial"]["total_cpu_ms"]
            runs.append(row)
            print(
                f"  rep {r + 1} ({row['free_cores']:.2f} free cores): serial "
                f"{row['serial']['wall_s']:.2f} s, dask "
                f"{row['dask']['wall_s']:.2f} s ({row['speedup']:.2f}x); CPU/target in solves "
                f"{row['serial']['in_solve_cpu_ms']:.1f} / {row['dask']['in_solve_cpu_ms']:.1f} "
                f"ms, total {row['serial']['total_cpu_ms']:.1f} / "
                f"{row['dask']['total_cpu_ms']:.1f} ms; core share serial "
                f"{row['serial']['cpu_share']:.0%}, workers {row['dask']['cpu_share']:.0%}, "
                f"worker slots busy {row['dask']['slot_utilisation']:.0%}; other jobs used "
                f"{row['serial']['other_cores']:.2f} / {row['dask']['other_cores']:.2f} cores",
                flush=True,
            )
    finally:
        client.close()
        cluster.close()
    # a fresh cluster: the workers load the kernels inside the timed call
    cluster, client = _cluster(warm=False)
    try:
        t0 = time.perf_counter()
        fresh = sk.solve_many(stack, targets, executor=client)
        fresh_wall = time.perf_counter() - t0
    finally:
        client.close()
        cluster.close()
    identical &= _same(fresh, serial_res)

    def med(key: str) -> float:
        return float(statistics.median(r[key] for r in runs))

    return {
        "n": n,
        "targets": count,
        "repeats": repeats,
        "runs": runs,
        "serial_wall_s_median": float(statistics.median(r["serial"]["wall_s"] for r in runs)),
        "dask_wall_s_median": float(statistics.median(r["dask"]["wall_s"] for r in runs)),
        "speedup_median": med("speedup"),
        "speedup_min": min(r["speedup"] for r in runs),
        "cpu_ratio_in_solve_median": med("cpu_ratio_in_solve"),
        "cpu_ratio_total_median": med("cpu_ratio_total"),
        "fresh_cluster_wall_s": fresh_wall,
        "identical": bool(identical),
    }


# =========================================================================================
# 2. stackik map --targets 1000
# =========================================================================================
def bench_map(count: int, repeats: int, address: str | None = None) -> dict[str, Any]:
    modes = {"serial": [], "dask local:2": ["--scheduler", "local:2"], "pool 2": ["--workers", "2"]}
    if address is not None:  # a running cluster (dask scheduler / dask worker)
        modes["dask running cluster"] = ["--scheduler", address]
    times: dict[str, list[float]] = {m: [] for m in modes}
    others: dict[str, list[float]] = {m: [] for m in modes}
    csv: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(repeats):
            order = list(modes) if r % 2 == 0 else list(reversed(modes))
            for mode in order:
                out = Path(tmp) / f"{mode.replace(' ', '_').replace(':', '')}_{r}"
                argv = ["stackik", "map", "--targets", str(count), "--quiet", "--out", str(out)]
                ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
                m0 = _machine_cpu()
                t0 = time.perf_counter()
                subprocess.run([*argv, *modes[mode]], check=True, stdout=subprocess.DEVNULL)
                wall = time.perf_counter() - t0
                times[mode].append(wall)
                ru1 = resource.getrusage(resource.RUSAGE_CHILDREN)
                ours = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
                # the command and its local workers; a running cluster's workers count as
                # "other" here
                others[mode].append(max(0.0, _machine_cpu() - m0 - ours) / wall)
                csv[mode] = (out / "workspace.csv").read_text()
            print(
                "  rep "
                + str(r + 1)
                + ": "
                + ", ".join(f"{m} {times[m][-1]:.1f} s ({others[m][-1]:.2f})" for m in modes),
                flush=True,
            )
    med = {m: float(statistics.median(v)) for m, v in times.items()}
    return {
        "targets": count,
        "repeats": repeats,
        "wall_s": times,
        "other_cores": others,
        "wall_s_median": med,
        "speedup_dask_median": med["serial"] / med["dask local:2"],
        "speedup_pool_median": med["serial"] / med["pool 2"],
        "identical": all(v == csv["serial"] for v in csv.values()),
    }


# =========================================================================================
# 3. 100,000 targets streamed, killed, resumed
# =========================================================================================
_STREAM = textwrap.dedent(
    """
    import json, resource, sys, time
    import stackik as sk
    from stackik.distributed import connect
    from stackik.sampling import random_reachable_targets
    from stackik.solve.many import solve_to_file

    if __name__ == "__main__":
        count, ckpt = int(sys.argv[1]), sys.argv[2]
        t0 = time.perf_counter()
        stack = sk.Stack.reference(2)
        targets = random_reachable_targets(stack, count, rng=100)
        drawn = time.perf_counter() - t0
        with connect("local:2") as client:
            stats = solve_to_file(stack, targets, ckpt, executor=client, starts=1)
        kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        print(json.dumps({"resumed": stats.resumed, "computed": stats.computed,
                          "chunks": len(stats.chunks), "wall_s": time.perf_counter() - t0,
                          "draw_s": drawn, "client_peak_rss_mb": kb / 1024}))
    """
)


def _lines(path: Path) -> int:
    if not path.exists():
        return 0
    with open(path, "rb") as fh:
        return sum(1 for _ in fh)


def bench_stream(count: int, kill_at: float) -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "stream.py"
        script.write_text(_STREAM)
        ckpt = Path(tmp) / "stream.jsonl"
        # a run killed with its cluster (its own process group) once kill_at of it is done
        t0 = time.perf_counter()
        proc = subprocess.Popen(
            [sys.executable, str(script), str(count), str(ckpt)],
            stdout=subprocess.PIPE,
            start_new_session=True,
        )
        try:
            while proc.poll() is None and _lines(ckpt) < kill_at * count:
                time.sleep(0.2)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        killed_after = time.perf_counter() - t0
        at_kill = _lines(ckpt)
        print(f"  killed after {killed_after:.1f} s with {at_kill} lines", flush=True)
        t1 = time.perf_counter()
        done = subprocess.run(
            [sys.executable, str(script), str(count), str(ckpt)],
            check=True,
            capture_output=True,
            text=True,
        )
        resume = json.loads(done.stdout.strip().splitlines()[-1])
        resume_wall = time.perf_counter() - t1
        indices: list[int] = []
        keys = set()
        with open(ckpt) as fh:
            for line in fh:
                rec = json.loads(line)
                indices.append(rec["index"])
                keys.add(json.dumps(rec["key"], sort_keys=True))
        size_mb = ckpt.stat().st_size / 2**20
        # peak client memory of a run a tenth the size, for comparison
        small = subprocess.run(
            [sys.executable, str(script), str(count // 10), str(Path(tmp) / "small.jsonl")],
            check=True,
            capture_output=True,
            text=True,
        )
        small_res = json.loads(small.stdout.strip().splitlines()[-1])
    return {
        "targets": count,
        "n": 2,
        "starts": 1,
        "killed_after_s": killed_after,
        "lines_at_kill": at_kill,
        "resume": resume,
        "resume_wall_s": resume_wall,
        "lines": len(indices),
        "unique_indices": len(set(indices)),
        "unique_keys": len(keys),
        "every_target_once": sorted(indices) == list(range(count)),
        "file_mb": size_mb,
        "small_run": small_res,
    }


# =========================================================================================
def _when(part: dict[str, Any]) -> str:
    load = part.get("load", [float("nan")])[0]
    return (
        f"Measured {part.get('date', '?')}, load average {load:.1f}; CPU capacity two "
        f"processes got then: {part.get('free_cores', float('nan')):.2f} cores (2 x one "
        "spinner alone / two side by side: 2.0 on an idle 2-core machine, 1.0 when another "
        "job holds a core)."
    )


def _markdown(res: dict[str, Any]) -> str:
    m = res["machine"]
    L = [
        "# Dask scale-out benchmark",
        "",
        f"`python benchmarks/bench_distributed.py`, {m['date']}, {m.get('cpu', '?')}, "
        f"{m['cpus']} CPUs, Python {m['python']}, NumPy {m['numpy']}. The machine is shared:"
        " other work ran during the measurement (load shown below), so the repetitions are"
        " interleaved and the ratios come from the same repetition.",
        "",
        f"Load average before / after: {res['load_before']} / {res['load_after']}.",
        "",
    ]
    s = res.get("solve_many")
    if s:
        L += [
            f"## solve_many, {s['targets']} targets at n = {s['n']}",
            "",
            _when(s),
            "",
            "Serial (this process) against a LocalCluster of 2 single-threaded worker "
            "processes, started and warmed before the clock. CPU per target: inside the "
            "solves (worker-side `process_time` of the chunks) and in total (worker "
            "processes + client).",
            "",
            "| rep (free cores) | serial [s] | Dask [s] | speed-up | CPU/target in solves, "
            "serial / Dask [ms] | CPU/target total, serial / Dask [ms] | share of a core, "
            "serial / each worker | worker slots busy | other jobs' cores, serial / Dask "
            "run | chunks |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        for i, r in enumerate(s["runs"]):
            L.append(
                f"| {i + 1} ({r.get('free_cores', float('nan')):.2f}) | "
                f"{r['serial']['wall_s']:.2f} | "
                f"{r['dask']['wall_s']:.2f} | "
                f"{r['speedup']:.2f}x | {r['serial']['in_solve_cpu_ms']:.1f} / "
                f"{r['dask']['in_solve_cpu_ms']:.1f} | {r['serial']['total_cpu_ms']:.1f} / "
                f"{r['dask']['total_cpu_ms']:.1f} | {r['serial']['cpu_share']:.0%} / "
                f"{r['dask']['cpu_share']:.0%} | {r['dask']['slot_utilisation']:.0%} | "
                f"{r['serial'].get('other_cores', float('nan')):.2f} / "
                f"{r['dask'].get('other_cores', float('nan')):.2f} | {r['dask']['chunks']} |"
            )
        L += [
            "",
            f"Median speed-up {s['speedup_median']:.2f}x (lowest {s['speedup_min']:.2f}x); "
            f"CPU per target, Dask / serial: {s['cpu_ratio_in_solve_median']:.2f} inside the "
            f"solves, {s['cpu_ratio_total_median']:.2f} in total. A fresh cluster (workers "
            f"loading the kernels inside the timed call): {s['fresh_cluster_wall_s']:.2f} s. "
            f"Identical poses: {s['identical']}.",
            "",
        ]
    mp = res.get("map")
    if mp:
        L += [
            f"## stackik map --targets {mp['targets']}",
            "",
            _when(mp),
            "",
            "Whole commands as subprocesses (imports, cluster start, target drawing, "
            "figures, cluster shutdown); in brackets the cores other jobs used meanwhile "
            "(for the running cluster they include its workers).",
            "",
            "| rep | " + " | ".join(mp["wall_s"]) + " |",
            "|---|" + "---|" * len(mp["wall_s"]),
        ]
        for i in range(mp["repeats"]):
            oc = mp.get("other_cores", {})
            L.append(
                f"| {i + 1} | "
                + " | ".join(
                    f"{v[i]:.1f} s ({oc[k][i]:.2f})" if k in oc else f"{v[i]:.1f} s"
                    for k, v in mp["wall_s"].items()
                )
                + " |"
            )
        L += [
            "",
            "Medians: "
            + ", ".join(f"{k} {v:.1f} s" for k, v in mp["wall_s_median"].items())
            + f"; speed-up {mp['speedup_dask_median']:.2f}x (Dask), "
            f"{mp['speedup_pool_median']:.2f}x (process pool). Identical workspace.csv: "
            f"{mp['identical']}.",
            "",
        ]
    st = res.get("stream")
    if st:
        L += [
            f"## {st['targets']:,} targets streamed to disk, client killed, resumed",
            "",
            f"Measured {st.get('date', '?')}.",
            "",
            f"n = {st['n']}, `starts={st['starts']}`, `solve_to_file` on `connect('local:2')`."
            f" The first client (and its cluster) was killed with SIGKILL after "
            f"{st['killed_after_s']:.1f} s, {st['lines_at_kill']:,} lines written; the "
            f"second resumed ({st['resume']['resumed']:,} found, "
            f"{st['resume']['computed']:,} computed in {st['resume']['chunks']} chunks, "
            f"{st['resume_wall_s']:.1f} s). File: {st['lines']:,} lines, "
            f"{st['unique_indices']:,} distinct indices, {st['unique_keys']:,} distinct "
            f"targets, {st['file_mb']:.0f} MB; every target exactly once: "
            f"{st['every_target_once']}. Peak client memory "
            f"{st['resume']['client_peak_rss_mb']:.0f} MB "
            f"(a {st['small_run']['computed']:,}-target run: "
            f"{st['small_run']['client_peak_rss_mb']:.0f} MB).",
            "",
        ]
    return "\n".join(L)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (smoke run)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--skip-100k", action="store_true")
    ap.add_argument("--only", choices=["solve_many", "map", "stream"], default=None)
    ap.add_argument(
        "--address", default=None, help="also time `stackik map` on this running Dask scheduler"
    )
    args = ap.parse_args()
    q = args.quick
    res: dict[str, Any] = {"machine": machine_info(), "load_before": os.getloadavg()}

    def stamp() -> dict[str, Any]:
        return {
            "date": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
            "load": os.getloadavg(),
            "free_cores": _free_cores(),
        }

    if args.only in (None, "solve_many"):
        print("solve_many", flush=True)
        at = stamp()
        res["solve_many"] = {
            **at,
            **bench_solve_many(8, 60 if q else 300, 2 if q else args.repeats),
        }
    if args.only in (None, "map"):
        print("stackik map", flush=True)
        at = stamp()
        res["map"] = {
            **at,
            **bench_map(50 if q else 1000, 1 if q else max(3, args.repeats - 2), args.address),
        }
    if args.only in (None, "stream") and not args.skip_100k:
        print("streamed run", flush=True)
        at = stamp()
        res["stream"] = {**at, **bench_stream(5000 if q else 100_000, 0.4)}
    res["load_after"] = os.getloadavg()
    OUT.mkdir(parents=True, exist_ok=True)
    name = "distributed_quick" if q else "distributed"
    if args.only is not None and (OUT / f"{name}.json").exists():
        # one part rerun: keep the others from the last full run (their own dates inside)
        old = json.loads((OUT / f"{name}.json").read_text())
        for part in ("solve_many", "map", "stream"):
            if part in old and part not in res:
                res[part] = old[part]
    (OUT / f"{name}.json").write_text(json.dumps(res, indent=2) + "\n")
    (OUT / f"{name}.md").write_text(_markdown(res) + "\n")
    print(_markdown(res))


if __name__ == "__main__":
    main()
