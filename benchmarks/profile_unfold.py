"""Where a folded planar default solve spends its time (issue 29 with issue 27): the
interior point's calls of one ``solve_ik`` on 12 mm legs, each timed and counted.

Run: ``python benchmarks/profile_unfold.py [--n 16 32 64] [--count 10] [--seed 5917]
[--out FILE.json]``; prints one line per call and a summary per n.

Targets as :mod:`benchmarks.bench_nonadj` (``random_reachable_targets`` on the reference
stack, ``rng = seed + n``, ``phi = 0.3``), solved by the default on
``Stack.uniform(PlatformGeometry.hexagonal(leg_radius=12), n)`` and on the 0 mm reference.
Every call of :meth:`stackik.methods.ip.IPMethod.run_many` is wrapped: its phase (the
batch, or the unfold of a folded run and its round), starts, non-adjacent rows, summed
iterations and CPU time (``time.process_time``); every call of
:func:`stackik.formulation.leg_pairs.close_pairs` (the screen) too. The cost per
iteration of a call is its CPU time over its iterations.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path
from typing import Any

from stackik import PlatformGeometry, Stack, solve_ik
from stackik.formulation import leg_pairs
from stackik.methods.ip import IPMethod
from stackik.sampling import random_reachable_targets
from stackik.solve import stages

CALLS: list[dict[str, Any]] = []
PHASE: dict[str, Any] = {"name": "batch", "round": 0}


def _install() -> None:
    run_many = IPMethod.run_many
    unfold = stages._unfold
    close = leg_pairs.close_pairs

    def timed_run_many(self: Any, prob: Any, starts: Any, options: Any, max_time: float) -> Any:
        lp = prob.clearance.leg_pairs
        c0, w0 = time.process_time(), time.perf_counter()
        out = run_many(self, prob, starts, options, max_time)
        CALLS.append({
            "phase": PHASE["name"], "round": PHASE["round"], "starts": len(starts),
            "rows": 0 if lp is None else int(lp.size), "nit": int(out.nit),
            "cpu": time.process_time() - c0, "wall": time.perf_counter() - w0,
            "ok": out.best is not None, "folded": len(out.folded),
        })  # fmt: skip
        if PHASE["name"].startswith("unfold"):
            PHASE["round"] += 1
        return out

    def timed_unfold(*args: Any) -> Any:
        PHASE["name"], PHASE["round"] = f"unfold{PHASE.get('k', 0)}", 1
        PHASE["k"] = PHASE.get("k", 0) + 1
        try:
            return unfold(*args)
        finally:
            PHASE["name"], PHASE["round"] = "after", 0

    def timed_close(*a: Any, **kw: Any) -> Any:
        c0 = time.process_time()
        out = close(*a, **kw)
        CALLS.append({"phase": "screen", "round": PHASE["round"], "starts": len(a[1]),
                      "rows": int(out.size), "nit": 0, "cpu": time.process_time() - c0,
                      "wall": 0.0, "ok": False, "folded": 0})  # fmt: skip
        return out

    IPMethod.run_many = timed_run_many  # type: ignore[method-assign]
    stages._unfold = timed_unfold  # type: ignore[assignment]
    leg_pairs.close_pairs = timed_close


def _line(c: dict[str, Any]) -> str:
    per = c["cpu"] / c["nit"] * 1e3 if c["nit"] else float("nan")
    return (
        f"   {c['phase']:>8} r{c['round']} starts={c['starts']:2d} rows={c['rows']:5d} "
        f"nit={c['nit']:4d} cpu={c['cpu']:.3f} ms/it={per:.2f} ok={c['ok']} "
        f"folded={c['folded']}"
    )


def summary(sel: list[dict[str, Any]]) -> dict[str, Any]:
    """One n's figures: successes, the summed CPU time 12 / 0 mm, how many targets
    unfolded, the unfold runs a target (median, largest), the rows of a target's largest
    run (median, largest), iterations an unfold run (median), CPU ms an iteration in the
    batch (per start) and in the unfold runs (median over runs), the unfold runs' share of
    the 12 mm CPU time."""
    runs = [[c for c in r["calls"] if c["phase"].startswith("unfold")] for r in sel]
    folded = [u for u in runs if u]
    every = [c for u in runs for c in u]
    batch = [c for r in sel for c in r["calls"] if c["phase"] == "batch"]
    return {
        "n": sel[0]["n"],
        "targets": len(sel),
        "ok": sum(r["ok"] for r in sel),
        "cpu_ratio": sum(r["cpu12"] for r in sel) / sum(r["cpu0"] for r in sel),
        "median_cpu12": statistics.median(r["cpu12"] for r in sel),
        "median_cpu0": statistics.median(r["cpu0"] for r in sel),
        "unfolded": len(folded),
        "runs_median": statistics.median(len(u) for u in folded) if folded else 0,
        "runs_max": max((len(u) for u in folded), default=0),
        "rows_median": statistics.median(max(c["rows"] for c in u) for u in folded)
        if folded
        else 0,
        "rows_max": max((c["rows"] for c in every), default=0),
        "nit_median": statistics.median(c["nit"] for c in every) if every else 0,
        "ms_it_batch": sum(c["cpu"] for c in batch) / max(1, sum(c["nit"] for c in batch)) * 1e3,
        "ms_it_unfold": statistics.median(c["cpu"] / c["nit"] * 1e3 for c in every if c["nit"])
        if every
        else float("nan"),
        "unfold_share": sum(c["cpu"] for c in every) / sum(r["cpu12"] for r in sel),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[16, 32, 64])
    ap.add_argument("--count", type=int, default=10)
    ap.add_argument("--seed", type=int, default=5917)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    _install()
    report: list[dict[str, Any]] = []
    sums = []
    for n in args.n:
        st0 = Stack.reference(n, leg_radius=0.0)
        st12 = Stack.uniform(PlatformGeometry.hexagonal(leg_radius=12.0), n)
        targets = random_reachable_targets(st0, args.count, rng=args.seed + n, phi=0.3)
        solve_ik(st12, targets[0])  # kernels and caches warm
        solve_ik(st0, targets[0])
        for i, t in enumerate(targets):
            c0 = time.process_time()
            r0 = solve_ik(st0, t)
            cpu0 = time.process_time() - c0
            CALLS.clear()
            PHASE.update(name="batch", round=0, k=0)
            c0 = time.process_time()
            r = solve_ik(st12, t)
            cpu12 = time.process_time() - c0
            cost = r.frobenius_norm / r0.frobenius_norm - 1
            report.append({
                "n": n, "target": i, "ok": bool(r.success), "fn0": r0.frobenius_norm,
                "fn12": r.frobenius_norm, "cpu0": cpu0, "cpu12": cpu12, "calls": list(CALLS),
            })  # fmt: skip
            print(f"n={n} k={i} ok={r.success} cost={cost:+.4%} cpu0={cpu0:.3f} cpu12={cpu12:.3f}")
            for c in CALLS:
                print(_line(c))
        sums.append(summary([r for r in report if r["n"] == n]))
        print(json.dumps(sums[-1]))
    if args.out is not None:
        args.out.write_text(json.dumps({"seed": args.seed, "summary": sums, "rows": report}))


if __name__ == "__main__":
    main()
