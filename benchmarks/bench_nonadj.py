"""What the reference geometry with 12 mm legs would do (issue 29, non-adjacent leg rows;
docs/clearance.md): the default ``solve_ik`` on legs of radius 12 mm against 0 mm.

Run: ``python benchmarks/bench_nonadj.py [--seed 5917] [--ipopt] [--cases 0,1,2,3]
[--screen MM] [--out benchmarks/results]``; writes ``nonadj_bench.{csv,json,md}``
(``--screen``: the lazy rows' screening distance instead of ``UNFOLD_SCREEN_MM``).

Cases: planar n = 4, 8 (20 targets each), 16 (10), 32 (5) and 64 (3), spatial n = 4 (20),
drawn with
``rng = seed + n`` (planar: :func:`stackik.sampling.random_reachable_targets` in the plane
``phi = 0.3``; spatial: :func:`stackik.sampling.random_spatial_targets`), each solved with
the default on ``Stack.uniform(PlatformGeometry.hexagonal(leg_radius=r), n)`` for
r = 0 and r = 12 mm, interleaved (each variant solves the first target once untimed
before: kernels loaded). With ``--ipopt``, IPOPT from 8 starts
(``method="ipopt", starts=8``) on the 12 mm stack too, with the same rows (the self legs;
the non-adjacent bodies' rows added lazily, as for every local engine), on the cases up to
``IPOPT_MAX_N`` platforms; with ``--best K``, IPOPT from ``K`` starts as well (the same
cases), and the best known FN of a target is the least over the clear successes of the
default, IPOPT-8 and IPOPT-K.

Every 12 mm pose called a success is re-checked with :func:`stackik.clearances` (the exact
distances, independent of the rows): ``false`` counts the successes with a negative
clearance (must be 0). Columns: successes at 0 and 12 mm, the FN cost of the 12 mm pose
relative to the 0 mm pose (median and largest, over targets where both succeed), how many
12 mm poses differ from the 0 mm pose (FN relative difference > 1e-9), the ratio of
the summed solve times (12 / 0 mm; wall, and CPU: ``time.process_time``), the median
solve times [ms] and the longest 12 mm solve [s].
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from stackik import PlatformGeometry, Stack, clearances, solve_ik
from stackik.bench import machine_info
from stackik.sampling import random_reachable_targets, random_spatial_targets

CASES = [
    ("planar", 4, 20),
    ("planar", 8, 20),
    ("planar", 16, 10),
    ("spatial", 4, 20),
    ("planar", 32, 5),
    ("planar", 64, 3),
]
#: IPOPT from 8 starts only up to this many platforms (at n = 32 and 64 it takes minutes a
#: target with the rows)
IPOPT_MAX_N = 16
RADIUS = 12.0
SAME_FN = 1e-9


def _targets(mode: str, n: int, count: int, seed: int) -> list[Any]:
    st = Stack.reference(n, leg_radius=0.0)  # the targets drawn as before the 12 mm default
    if mode == "spatial":
        return random_spatial_targets(st, count, rng=np.random.default_rng(seed + n))
    return random_reachable_targets(st, count, rng=seed + n, phi=0.3)


def _solve(stack: Stack, t: Any, kw: dict[str, Any]) -> dict[str, Any]:
    t0, c0 = time.perf_counter(), time.process_time()
    r = solve_ik(stack, t, **kw)
    dt, cpu = time.perf_counter() - t0, time.process_time() - c0
    phi = getattr(t, "phi", None)
    c = clearances(stack, r.q, phi=phi)
    return {
        "status": r.status.value,
        "ok": bool(r.success),
        "fn": float(r.frobenius_norm),
        "time": dt,
        "cpu": cpu,
        "method": r.method,
        "clearance": float(c.minimum),
        "non_adjacent": float(c.non_adjacent),
    }


def run_case(
    mode: str, n: int, count: int, seed: int, ipopt: bool, best: int = 0
) -> list[dict[str, Any]]:
    st0 = Stack.reference(n, leg_radius=0.0)
    st12 = Stack.uniform(PlatformGeometry.hexagonal(leg_radius=RADIUS), n)
    rows = []
    targets = _targets(mode, n, count, seed)
    variants: tuple[tuple[str, Stack, dict[str, Any]], ...] = (
        ("r0", st0, {}),
        ("r12", st12, {}),
    ) + (
        (("ipopt8", st12, {"method": "ipopt", "starts": 8}),) if ipopt and n <= IPOPT_MAX_N else ()
    )
    if best and n <= IPOPT_MAX_N:
        variants += (("best", st12, {"method": "ipopt", "starts": best}),)
    for _, st, kw in variants:  # kernels loaded, caches warm: not timed
        solve_ik(st, targets[0], **kw)
    for i, t in enumerate(targets):
        row: dict[str, Any] = {"mode": mode, "n": n, "target": i}
        for tag, st, kw in variants:
            for key, v in _solve(st, t, kw).items():
                row[f"{tag}_{key}"] = v
        rows.append(row)
        print(mode, n, i, {k: v for k, v in row.items() if k.endswith(("ok", "fn", "time"))})
    return rows


def summarise(rows: list[dict[str, Any]], ipopt: bool) -> list[dict[str, Any]]:
    out = []
    for mode, n, _ in CASES:
        sel = [r for r in rows if r["mode"] == mode and r["n"] == n]
        if not sel:
            continue
        both = [r for r in sel if r["r0_ok"] and r["r12_ok"]]
        cost = [r["r12_fn"] / r["r0_fn"] - 1.0 for r in both]
        s: dict[str, Any] = {
            "case": f"{mode} n={n}",
            "targets": len(sel),
            "ok_r0": sum(r["r0_ok"] for r in sel),
            "ok_r12": sum(r["r12_ok"] for r in sel),
            "false_r12": sum(r["r12_ok"] and r["r12_clearance"] < 0 for r in sel),
            "changed": sum(abs(c) > SAME_FN for c in cost),
            "cost_median": float(np.median(cost)) if cost else float("nan"),
            "cost_max": float(np.max(cost)) if cost else float("nan"),
            "time_ratio": sum(r["r12_time"] for r in sel) / sum(r["r0_time"] for r in sel),
            "cpu_ratio": sum(r["r12_cpu"] for r in sel) / sum(r["r0_cpu"] for r in sel),
            "median_ms_r0": 1e3 * float(np.median([r["r0_time"] for r in sel])),
            "median_ms_r12": 1e3 * float(np.median([r["r12_time"] for r in sel])),
            "max_s_r12": max(r["r12_time"] for r in sel),
        }
        if any("best_ok" in r for r in sel):
            for r in sel:
                fns = [r[f"{v}_fn"] for v in ("r12", "ipopt8", "best")
                       if r.get(f"{v}_ok") and r[f"{v}_clearance"] >= 0]  # fmt: skip
                r["best_known"] = min(fns) if fns else float("nan")
            s["r12_at_best"] = sum(
                r["r12_ok"] and r["r12_fn"] <= r["best_known"] * (1 + 5e-3) for r in sel
            )
            s["ipopt8_at_best"] = sum(
                r.get("ipopt8_ok", False) and r["ipopt8_clearance"] >= 0
                and r["ipopt8_fn"] <= r["best_known"] * (1 + 5e-3)
                for r in sel
            )  # fmt: skip
        if ipopt and n <= IPOPT_MAX_N:
            s["ok_ipopt8"] = sum(r["ipopt8_ok"] and r["ipopt8_clearance"] >= 0 for r in sel)
            s["ipopt8_vs_r12"] = sum(
                r["ipopt8_ok"] and r["r12_ok"] and r["r12_fn"] > r["ipopt8_fn"] * (1 + 5e-3)
                for r in sel
            )
            s["time_ratio_ipopt8"] = sum(r["ipopt8_time"] for r in sel) / sum(
                r["r12_time"] for r in sel
            )
        out.append(s)
    return out


def markdown(
    summary: list[dict[str, Any]], seed: int, info: dict[str, Any], command: str = ""
) -> str:
    keys = list(dict.fromkeys(k for s in summary for k in s))  # (no IPOPT past IPOPT_MAX_N)
    lines = [
        f"# Non-adjacent leg rows: 12 mm legs against 0 mm (seed {seed})",
        "",
        *([f"`{command}`, {info['date']}.", ""] if command else []),
        "Default `solve_ik`; `ok_*`: successes (the check, exact distances); `false_r12`: "
        "12 mm successes with a negative clearance by `stackik.clearances`; `changed`: "
        "12 mm poses whose FN differs from the 0 mm pose's by more than 1e-9 (relative); "
        "`cost_*`: FN(12 mm) / FN(0 mm) - 1 over targets where both succeed; "
        "`time_ratio`, `cpu_ratio`: summed wall and CPU time 12 mm / 0 mm; `median_ms_*`: "
        "median solve time [ms]; `max_s_r12`: the longest 12 mm solve [s]"
        + (
            "; `ok_ipopt8`: IPOPT from 8 starts on the 12 mm stack, success and clear; "
            "`ipopt8_vs_r12`: targets where its FN is more than 0.5 % below the default's; "
            "`time_ratio_ipopt8`: its summed time / the default's (12 mm)"
            if "ok_ipopt8" in keys
            else ""
        )
        + (
            "; `r12_at_best`, `ipopt8_at_best`: targets where the default's (IPOPT-8's) clear "
            "FN is within 0.5 % of the best known (the least of the default, IPOPT-8 and "
            "IPOPT from more starts)"
            if "r12_at_best" in keys
            else ""
        )  # fmt: skip
        + ".",
        "",
        "| " + " | ".join(keys) + " |",
        "|" + "---|" * len(keys),
    ]
    for s in summary:
        vals = [(k, s.get(k, "-")) for k in keys]
        cells = [f"{v:.2e}" if isinstance(v, float) and k.startswith("cost") else
                 f"{v:.2f}" if isinstance(v, float) else str(v) for k, v in vals]  # fmt: skip
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", f"Machine: {info.get('cpu', '?')}, shared (timings rough)."]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=5917)
    ap.add_argument("--ipopt", action="store_true")
    ap.add_argument("--best", type=int, default=0, help="IPOPT from this many starts too")
    ap.add_argument("--cases", default="", help="comma list of indices into CASES (all)")
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    ap.add_argument("--screen", type=float, default=None, help="UNFOLD_SCREEN_MM [mm] to use")
    args = ap.parse_args()
    if args.screen is not None:  # the screen of the lazy rows (stackik.solve.policy)
        import stackik.solve.stages as stages

        stages.UNFOLD_SCREEN_MM = args.screen
    cases = [CASES[int(c)] for c in args.cases.split(",")] if args.cases else CASES
    rows: list[dict[str, Any]] = []
    for mode, n, count in cases:
        rows += run_case(mode, n, count, args.seed, args.ipopt, args.best)
    summary = summarise(rows, args.ipopt)
    info = machine_info()
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "nonadj_bench.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(dict.fromkeys(k for r in rows for k in r)))
        w.writeheader()
        w.writerows(rows)
    command = "python benchmarks/bench_nonadj.py " + " ".join(sys.argv[1:])
    (args.out / "nonadj_bench.json").write_text(
        json.dumps(
            {
                "command": command,
                "seed": args.seed,
                "machine": info,
                "summary": summary,
                "rows": rows,
            },
            indent=1,
        )  # fmt: skip
    )
    text = markdown(summary, args.seed, info, command)
    (args.out / "nonadj_bench.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
