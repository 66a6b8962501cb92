"""One solve on one thread against the same solve on the machine's threads.

Run: ``python benchmarks/bench_threads.py [--cases spatial:4 spatial:8 spatial:16 planar:16
planar:64] [--count 10] [--seed 75000] [--reps 3] [--out benchmarks/results]``; writes
``threads.{json,md}``.

``solve_ik(threads=...)`` runs the interior point's batches of starts side by side
(:mod:`stackik._threads`). For each case (mode and n, the reference stack, targets of
:func:`_results.targets`), every target is solved with ``threads=1`` and with the default
(the CPUs this process may use), in turn within one process, the order alternating with
the target and the repetition; a target's time under a setting is the least wall time of
its ``--reps`` repetitions (a neighbour on a shared machine only ever slows a solve). The
report gives per case the median of those times, the median and range of the per-target
ratios (one thread / default), the CPU time of both (``time.process_time``: all threads),
and whether every pose agreed bit for bit between the two settings.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np
from _results import targets

from stackik import Stack, solve_ik
from stackik._threads import resolve
from stackik.bench import machine_info


def _timed(stack: Stack, target: Any, threads: int | None) -> tuple[float, float, Any]:
    c0, t0 = time.process_time(), time.perf_counter()
    res = solve_ik(stack, target, threads=threads)
    return time.perf_counter() - t0, time.process_time() - c0, res


def run_case(mode: str, n: int, count: int, seed: int, reps: int) -> dict[str, Any]:
    stack = Stack.reference(n)
    ts = targets(mode == "planar", stack, count, seed)
    solve_ik(stack, ts[0])  # kernels loaded, pools made
    settings: tuple[int | None, ...] = (1, None)
    wall = {s: [np.inf] * count for s in settings}
    cpu = {s: [np.inf] * count for s in settings}
    same = True
    ok = 0
    for rep in range(reps):
        for k, t in enumerate(ts):
            order = settings if (k + rep) % 2 == 0 else settings[::-1]
            poses = {}
            for s in order:
                w, c, res = _timed(stack, t, s)
                wall[s][k] = min(wall[s][k], w)
                cpu[s][k] = min(cpu[s][k], c)
                poses[s] = res
            same = same and np.array_equal(poses[1].q, poses[None].q)
            ok += rep == 0 and bool(poses[None].success)
    ratios = [a / b for a, b in zip(wall[1], wall[None])]
    return {
        "case": f"{mode} n={n}",
        "targets": count,
        "success": ok,
        "threads": resolve(None),
        "median_ms_1": 1e3 * statistics.median(wall[1]),
        "median_ms_default": 1e3 * statistics.median(wall[None]),
        "ratio_median": statistics.median(ratios),
        "ratio_min": min(ratios),
        "ratio_max": max(ratios),
        "cpu_ms_1": 1e3 * statistics.median(cpu[1]),
        "cpu_ms_default": 1e3 * statistics.median(cpu[None]),
        "same_poses": same,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--cases", nargs="+",
        default=["spatial:4", "spatial:8", "spatial:16", "planar:16", "planar:64"],
    )  # fmt: skip
    ap.add_argument("--count", type=int, default=10)
    ap.add_argument("--seed", type=int, default=75000)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = ap.parse_args()
    rows = []
    for spec in args.cases:
        mode, n = spec.split(":")
        rows.append(run_case(mode, int(n), args.count, args.seed, args.reps))
        print(json.dumps(rows[-1]), flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    info = machine_info()
    (args.out / "threads.json").write_text(json.dumps({"machine": info, "rows": rows}, indent=1))
    head = (
        "| case | targets | successes | threads | median ms, 1 thread | median ms, default |"
        " speed-up (median, range) | median CPU ms, 1 / default | same poses |"
    )
    lines = [
        "# One thread against the default's threads (benchmarks/bench_threads.py)",
        "",
        f"`python benchmarks/bench_threads.py --cases {' '.join(args.cases)} --count "
        f"{args.count} --seed {args.seed} --reps {args.reps}` on {info.get('cpus', '?')} CPUs "
        f"({info.get('cpu', '?')}), {info.get('date', '')}. Wall times, the least of the "
        "repetitions per target; speed-up = one thread's time / the default's, per target.",
        "",
        head,
        "|" + "---|" * 9,
    ]
    for r in rows:
        lines.append(
            f"| {r['case']} | {r['targets']} | {r['success']} | {r['threads']} | "
            f"{r['median_ms_1']:.1f} | {r['median_ms_default']:.1f} | "
            f"{r['ratio_median']:.2f}x ({r['ratio_min']:.2f}-{r['ratio_max']:.2f}) | "
            f"{r['cpu_ms_1']:.1f} / {r['cpu_ms_default']:.1f} | {r['same_poses']} |"
        )
    (args.out / "threads.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
