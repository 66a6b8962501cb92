"""Compact planar targets at scale: the default's compact-target plan against IPOPT.

Run: ``python benchmarks/bench_compact.py [--n 64] [--count 12] [--seed 97000]
[--ref-starts 32] [--before FILE] [--out benchmarks/results] [--stem compact]``.

Targets: ``random_planar_targets(Stack.reference(n), 1, rng=seed + k, phis=(2 pi (k mod
20) / 20,))`` for k = 0, 1, ... kept when :func:`stackik.starts.reach_fraction` is below
:data:`stackik.solve.policy.COMPACT_REACH` (the targets the default's compact plan
takes: most of the stack coils around the target), until ``--count`` are kept. Per
target: the default (``solve_ik(stack, target)``, wall time, iterations, starts) and,
with ``--ref-starts K > 0``, IPOPT from K starts (``rng = 1000 + k``). ``--before FILE``
adds the default column of an earlier run on the same targets (e.g. of an older tree:
``PYTHONPATH=OLD/src python benchmarks/bench_compact.py --ref-starts 0 ...``). Best
known = the least FN of every column; reported: within 0.1 % of it, the worst gap, the
median time and the iterations.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time
from pathlib import Path
from typing import Any

from _results import write_results

from stackik import Stack, solve_ik
from stackik.bench import machine_info
from stackik.sampling import random_planar_targets
from stackik.solve.policy import COMPACT_REACH
from stackik.starts import reach_fraction

WITHIN = 1e-3  # "best known" within 0.1 %


def compact_targets(n: int, count: int, seed: int) -> list[tuple[int, Any]]:
    """``count`` compact targets of ``Stack.reference(n)`` as ``(k, target)``."""
    stack = Stack.reference(n, leg_radius=0.0)
    out: list[tuple[int, Any]] = []
    k = 0
    while len(out) < count:
        phi = 2 * math.pi * (k % 20) / 20
        t = random_planar_targets(stack, 1, rng=seed + k, phis=(phi,))[0]
        if reach_fraction(stack, t) < COMPACT_REACH:
            out.append((k, t))
        k += 1
    return out


def run(n: int, count: int, seed: int, ref_starts: int) -> list[dict[str, Any]]:
    stack = Stack.reference(n, leg_radius=0.0)
    rows = []
    for k, t in compact_targets(n, count, seed):
        row: dict[str, Any] = {"n": n, "k": k, "reach": reach_fraction(stack, t)}
        t0 = time.perf_counter()
        r = solve_ik(stack, t)
        row.update(
            default_time=time.perf_counter() - t0,
            default_fn=r.frobenius_norm if r.success else math.nan,
            default_nit=r.nit,
            default_starts=r.n_starts,
        )
        if ref_starts > 0:
            t0 = time.perf_counter()
            r = solve_ik(stack, t, method="ipopt", starts=ref_starts, rng=1000 + k)
            row.update(
                ipopt_time=time.perf_counter() - t0,
                ipopt_fn=r.frobenius_norm if r.success else math.nan,
            )
        rows.append(row)
        print(json.dumps(row), flush=True)
    return rows


def summarise(rows: list[dict[str, Any]], labels: list[str]) -> dict[str, Any]:
    line: dict[str, Any] = {"targets": len(rows)}
    for row in rows:
        fns = [row[f"{lab}_fn"] for lab in labels if math.isfinite(row[f"{lab}_fn"])]
        row["best"] = min(fns) if fns else math.nan
    for lab in labels:
        gaps = [row[f"{lab}_fn"] / row["best"] - 1 for row in rows]
        line[f"{lab}_within"] = sum(g <= WITHIN for g in gaps)
        line[f"{lab}_worst_gap"] = max(gaps)
        line[f"{lab}_median_ms"] = 1e3 * statistics.median(row[f"{lab}_time"] for row in rows)
        if f"{lab}_nit" in rows[0]:
            line[f"{lab}_nit"] = sum(row[f"{lab}_nit"] for row in rows)
    return line


def report(meta: dict[str, Any], line: dict[str, Any], labels: list[str]) -> str:
    names = {"default": "default", "before": "default before (--before)", "ipopt": "IPOPT"}
    body = "".join(
        f"| {names[lab]} | {line[f'{lab}_within']}/{line['targets']} | "
        f"{100 * line[f'{lab}_worst_gap']:.3f} % | {line[f'{lab}_median_ms']:.0f} | "
        f"{line.get(f'{lab}_nit', '-')} |\n"
        for lab in labels
    )
    return (
        "# Compact planar targets at scale (benchmarks/bench_compact.py)\n\n"
        f"`{meta['command']}` on {meta['machine']}. Reference stacks, "
        f"n = {meta['n']}; targets with a reach fraction below {COMPACT_REACH} (the "
        "default's compact plan). Best known = the least FN of every column (IPOPT from "
        f"{meta['ref_starts']} starts when run). Times are wall times on a shared machine."
        "\n\n| method | within 0.1 % | worst gap | median ms | iterations (sum) |\n"
        "|---|---|---|---|---|\n" + body
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--count", type=int, default=12)
    ap.add_argument("--seed", type=int, default=97000)
    ap.add_argument("--ref-starts", type=int, default=32)
    ap.add_argument("--before", type=Path, help="an earlier run's JSON (its default column)")
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    ap.add_argument("--stem", default="compact")
    args = ap.parse_args()
    rows = run(args.n, args.count, args.seed, args.ref_starts)
    labels = ["default"] + (["ipopt"] if args.ref_starts > 0 else [])
    if args.before:
        old = {r["k"]: r for r in json.loads(args.before.read_text())["rows"]}
        for row in rows:
            prev = old[row["k"]]
            for key in ("time", "fn", "nit", "starts"):
                row[f"before_{key}"] = prev[f"default_{key}"]
        labels.insert(1, "before")
    line = summarise(rows, labels)
    meta = {
        "machine": "{cpus} CPUs ({cpu}), {date}".format(**machine_info()),
        "command": "python benchmarks/bench_compact.py "
        + f"--n {args.n} --count {args.count} --seed {args.seed} --ref-starts {args.ref_starts}"
        + (f" --before {args.before}" if args.before else ""),
        "n": args.n,
        "ref_starts": args.ref_starts,
    }
    write_results(args.out, args.stem, meta, [line], rows, report(meta, line, labels))


if __name__ == "__main__":
    main()
