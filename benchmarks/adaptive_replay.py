"""Replay the planar adaptive plan's stopping rules on every start of its batch.

For each target of the planar scale runs at n = 32 and 64 (``benchmarks/results/scale*.json``
with a ``--seed`` in their command; the targets the compact plan takes are left out), the
default solve runs with the adaptive plan's stops off (:func:`stackik.solve.stages.confirmed`
never true, :data:`~stackik.solve.policy.ADAPTIVE_STANDS` infinite) and its starts one
after another, in the plan's order: every start's FN (None where the check refused the
run), iterations and CPU time. ``--replay`` then runs the plan on those runs with each
rule (confirmation alone; confirmation or the best standing ``S`` runs; a cap of ``M``
starts): within 0.1 % of the best known (the scale runs' best and every run here), starts,
and the plan's wall time as its groups of two would take it (the longer run of each pair).

    python benchmarks/adaptive_replay.py            # collect, then replay
    python benchmarks/adaptive_replay.py --replay   # replay the collected runs

Writes ``adaptive_replay.{json,md}`` to ``--out``.
"""

from __future__ import annotations

import argparse
import glob
import json
import re
import sys
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

import stackik
import stackik.solve.stages as stages
from stackik.methods.ip import IPMethod
from stackik.solve.policy import ADAPTIVE_FIRST, ADAPTIVE_RTOL, COMPACT_REACH
from stackik.starts import reach_fraction

sys.path.insert(0, str(Path(__file__).parent))
from _results import targets  # noqa: E402

RULES: list[tuple[str, float | None, int | None]] = [
    ("confirmation alone", None, None),
    ("or the best stands 4", 4, None),
    ("or the best stands 6 (default)", 6, None),
    ("or the best stands 8", 8, None),
    ("or at most 8 starts", None, 8),
    ("or at most 12 starts", None, 12),
]


def best_known(results: Path) -> dict[tuple[int, int, int, int], float]:
    """(seed, count, n, k) -> the least FN of the scale runs in ``results`` at n = 32 and
    64 (target k of ``count`` lies in the plane ``phi = 2 pi k / count``)."""
    best: dict[tuple[int, int, int, int], float] = {}
    for f in sorted(glob.glob(str(results / "scale*.json"))):
        d = json.load(open(f))
        if "rows" not in d:
            continue
        command = d["meta"].get("command", "")
        m = re.search(r"--seed (\d+)", command)
        if not m:
            continue
        c = re.search(r"--count (\d+)", command)
        count = int(c.group(1)) if c else 20
        for r in d["rows"]:
            if r["n"] in (32, 64) and r.get("best") is not None:
                key = (int(m.group(1)), count, r["n"], r["k"])
                best[key] = min(best.get(key, np.inf), float(r["best"]))
    return best


def collect(results: Path) -> list[dict[str, Any]]:
    """Every start of the adaptive plan's batch, run alone in the plan's order."""
    log: list[tuple[int, int, float | None, float]] = []
    original = IPMethod.run_many

    def logged(self: IPMethod, prob: Any, starts: Any, opts: Any, left: Any) -> Any:
        t0 = time.thread_time()
        batch = original(self, prob, starts, opts, left)
        fn = None if batch.best is None else float(np.sqrt(batch.best.obj))
        log.append((len(starts), int(batch.nit), fn, time.thread_time() - t0))
        return batch

    IPMethod.run_many = logged  # type: ignore[method-assign]
    stages.confirmed = lambda runs, rtol: False  # type: ignore[assignment]
    stages.ADAPTIVE_STANDS = np.inf  # type: ignore[assignment]
    stages.map_in_threads = lambda f, k, *a: [f(i) for i in range(k)]  # type: ignore[assignment]
    out = []
    for (seed, count, n, k), best in sorted(best_known(results).items()):
        stack = stackik.Stack.reference(n, leg_radius=0.0)
        target = targets(True, stack, count, seed)[k]
        if reach_fraction(stack, target) < COMPACT_REACH:
            continue
        log.clear()
        stackik.solve_ik(stack, target)
        out.append({"seed": seed, "n": n, "k": k, "best": best, "runs": list(log)})
        print(seed, n, k, len(log), flush=True)
    return out


# the product's rules (collect() turns them off in stages)
CONFIRMED = stages.confirmed
STANDS = stages.stands


def _runs(fns: list[float | None]) -> list[Any]:
    return [None if f is None else SimpleNamespace(obj=f * f) for f in fns]


def replay(
    runs: list[Any], stand: float | None, cap: int | None
) -> tuple[float | None, int, float]:
    """The plan on ``runs``: the FN it keeps, the starts it runs, its wall time [s]."""
    fns = [r[2] for r in runs]
    times = [r[3] for r in runs]
    b = 0
    while b < len(runs):
        b = min(b + ADAPTIVE_FIRST, len(runs))
        runs_b = _runs(fns[:b])
        if CONFIRMED(runs_b, ADAPTIVE_RTOL) or (
            stand is not None and STANDS(runs_b, ADAPTIVE_RTOL, stand)
        ):
            break
        if cap is not None and b >= cap:
            break
    kept = [f for f in fns[:b] if f is not None]
    wall = sum(max(times[j : j + ADAPTIVE_FIRST]) for j in range(0, b, ADAPTIVE_FIRST))
    return (min(kept) if kept else None), b, wall


def table(data: list[dict[str, Any]]) -> tuple[list[dict[str, Any]], str]:
    lines = [
        "| rule | n | targets | within 0.1 % | mean starts | mean ms | max ms | changed |",
        "|---|---|---|---|---|---|---|---|",
    ]
    rows = []
    base = {id(d): replay(d["runs"], None, None) for d in data}
    for label, stand, cap in RULES:
        for n in sorted({d["n"] for d in data}):
            ds = [d for d in data if d["n"] == n]
            res = [replay(d["runs"], stand, cap) for d in ds]
            within = 0
            for d, (fn, _, _) in zip(ds, res, strict=True):
                best = min([d["best"]] + [r[2] for r in d["runs"] if r[2] is not None])
                within += fn is not None and fn <= 1.001 * best
            changed = [
                f"{d['seed']}/{d['k']} ({base[id(d)][1]}->{r[1]})"
                for d, r in zip(ds, res, strict=True)
                if r[1] != base[id(d)][1]
            ]
            row = {
                "rule": label,
                "n": n,
                "targets": len(ds),
                "within": within,
                "mean_starts": float(np.mean([r[1] for r in res])),
                "mean_ms": 1e3 * float(np.mean([r[2] for r in res])),
                "max_ms": 1e3 * float(np.max([r[2] for r in res])),
                "changed": changed,
            }
            rows.append(row)
            lines.append(
                f"| {label} | {n} | {len(ds)} | {within} | {row['mean_starts']:.2f} | "
                f"{row['mean_ms']:.0f} | {row['max_ms']:.0f} | {', '.join(changed) or '-'} |"
            )
    return rows, "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--replay", action="store_true", help="replay the collected runs only")
    ap.add_argument("--results", type=Path, default=Path("benchmarks/results"))
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = ap.parse_args()
    path = args.out / "adaptive_replay.json"
    if args.replay:
        data = json.load(open(path))["targets"]
    else:
        data = collect(args.results)
    rows, md = table(data)
    args.out.mkdir(parents=True, exist_ok=True)
    json.dump({"targets": data, "rules": rows}, open(path, "w"))
    head = (
        "# The adaptive plan's stops, replayed\n\n`python benchmarks/adaptive_replay.py` "
        f"on {len(data)} targets (planar n = 32 and 64, not compact; every start of the "
        "batch run alone, CPU time a run; wall = the longer run of each pair). `changed`: "
        "seed/target (starts before -> after) where the rule ran another number of "
        "starts than confirmation alone.\n\n"
    )
    (args.out / "adaptive_replay.md").write_text(head + md + "\n")
    print(md)


if __name__ == "__main__":
    main()
