"""Scaling of the SQP engine with its sparse QP backends against SLSQP, IPOPT and the
compiled interior point, planar (n = 4 ... 64) and spatial (n = 4 ... 16).

Run: ``python benchmarks/bench_sqp_scaling.py [--mode planar|spatial] [--sizes 4,8,16]
[--targets 8]``. Writes ``benchmarks/results/sqp_scaling.{json,md}`` (spatial:
``sqp_scaling_spatial.{json,md}``; ``--out DIR`` elsewhere).

Every method solves the same random reachable targets of the reference stack
(``random_planar_targets(stack, K, rng=seed + n)``; ``--mode spatial``:
``random_spatial_targets``) from one start, the paper's initial
guess (``solve_ik(..., starts=1)``); methods are interleaved target by target so that they
share the machine's load. Success is the independent check of the returned pose; "within
0.1 %" compares the FN with the best any method found for that target, including
stackik's default (structured multi-start interior point, the reference row). Reported:
success rate, within-0.1 % rate, median time per solve, median iterations, the fitted
exponent of median time vs n (least squares in log-log over the sizes run) and the one
from n = 16 to 64, and the ratios of the goals (n = 16: SLSQP / SQP and IPOPT / SQP; n = 4:
SLSQP / SQP and IPOPT / SQP).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np

import stackik as sk
from stackik.bench import result_payload
from stackik.sampling import random_planar_targets, random_spatial_targets

RESULTS = Path(__file__).resolve().parent / "results"

#: label -> solve_ik keyword arguments (one start: the paper's initial guess)
METHODS: dict[str, dict[str, Any]] = {
    "sqp/osqp": {"method": "sqp", "qp_solver": "osqp", "starts": 1},
    "sqp/clarabel": {"method": "sqp", "qp_solver": "clarabel", "starts": 1},
    "sqp/daqp": {"method": "sqp", "qp_solver": "daqp", "starts": 1},
    # the opt-in interior start phase (SQPOptions.barrier_start): quality from one start
    "sqp/clarabel+interior": {
        "method": "sqp",
        "qp_solver": "clarabel",
        "starts": 1,
        "options": {"barrier_start": True},
    },
    # the opt-in verified working-set step (SQPOptions.qp_working_set)
    "sqp/osqp+ws": {
        "method": "sqp",
        "qp_solver": "osqp",
        "starts": 1,
        "options": {"qp_working_set": True},
    },
    "sqp/clarabel+ws": {
        "method": "sqp",
        "qp_solver": "clarabel",
        "starts": 1,
        "options": {"qp_working_set": True},
    },
    # spatial only: the NumPy evaluation with damped BFGS (the spatial SQP before the
    # compiled problem with its exact Hessian)
    "sqp/clarabel+bfgs": {
        "method": "sqp",
        "qp_solver": "clarabel",
        "starts": 1,
        "options": {"formulation": "dense"},
    },
    "sqp/daqp+bfgs": {
        "method": "sqp",
        "qp_solver": "daqp",
        "starts": 1,
        "options": {"formulation": "dense"},
    },
    "slsqp": {"method": "slsqp", "starts": 1},
    "ipopt": {"method": "ipopt", "starts": 1},
    "ip": {"method": "ip", "starts": 1},
    "default": {},
}
#: methods of one mode only
SPATIAL_ONLY = {"sqp/clarabel+bfgs", "sqp/daqp+bfgs"}
PLANAR_ONLY: set[str] = set()
#: methods not timed beyond these sizes by default (minutes per solve)
MAX_N = {
    "slsqp": 32,
    "sqp/daqp": 32,
    "sqp/clarabel+interior": 16,
    "sqp/osqp+ws": 16,
    "sqp/clarabel+ws": 16,
}


def _fit(ns: list[int], ts: list[float]) -> float | None:
    pts = [(math.log(n), math.log(t)) for n, t in zip(ns, ts) if t > 0 and math.isfinite(t)]
    if len(pts) < 2:
        return None
    x = np.array([p[0] for p in pts])
    y = np.array([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mode", choices=("planar", "spatial"), default="planar")
    parser.add_argument("--sizes", default=None, help="default 4,8,16,32,64 (spatial 4,8,16)")
    parser.add_argument("--targets", type=int, default=8, help="targets per size")
    parser.add_argument("--methods", default=None, help="default: every method of the mode")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=1, help="timing: min over repeats")
    parser.add_argument("--max-time", type=float, default=120.0, help="per solve [s]")
    parser.add_argument("--no-caps", action="store_true", help="run every method at every n")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()
    spatial = args.mode == "spatial"
    if args.sizes is None:
        args.sizes = "4,8,16" if spatial else "4,8,16,32,64"
    if args.methods is None:
        skip = PLANAR_ONLY if spatial else SPATIAL_ONLY
        args.methods = ",".join(m for m in METHODS if m not in skip)
    sizes = [int(s) for s in args.sizes.split(",")]
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    make_targets = random_spatial_targets if spatial else random_planar_targets
    stem = "sqp_scaling_spatial" if spatial else "sqp_scaling"
    unknown = sorted(set(methods) - set(METHODS))
    if unknown:
        parser.error(f"unknown methods {unknown}; known: {sorted(METHODS)}")
    if "ipopt" in methods:
        from stackik.methods.ipopt import ipopt_available

        if not ipopt_available():
            methods.remove("ipopt")
    # warm-up: load or compile every kernel, import every solver
    st4 = sk.Stack.reference(4)
    t4 = make_targets(st4, 1, rng=12345)[0]
    for m in methods:
        sk.solve_ik(st4, t4, **METHODS[m])
    load0 = os.getloadavg()
    rows: list[dict[str, Any]] = []
    for n in sizes:
        stack = sk.Stack.reference(n)
        targets = make_targets(stack, args.targets, rng=args.seed + n)
        for i, target in enumerate(targets):
            for m in methods:
                if not args.no_caps and n > MAX_N.get(m, 10**9):
                    continue
                best_t = math.inf
                r: Any = None
                for _ in range(args.repeats):
                    t0 = time.perf_counter()
                    r = sk.solve_ik(stack, target, max_time=args.max_time, **METHODS[m])
                    best_t = min(best_t, time.perf_counter() - t0)
                rows.append(
                    {
                        "n": n,
                        "target": i,
                        "method": m,
                        "success": bool(r.success),
                        "fn": float(r.frobenius_norm) if r.success else math.nan,
                        "time_s": best_t,
                        "nit": int(r.nit),
                    }
                )
            done = [x for x in rows if x["n"] == n and x["target"] == i]
            print(
                f"n={n:3d} target {i}: "
                + "  ".join(f"{x['method']} {x['time_s'] * 1e3:.1f}ms" for x in done),
                flush=True,
            )
    load1 = os.getloadavg()
    best: dict[tuple[int, int], float] = {}
    for x in rows:
        if x["success"]:
            k = (x["n"], x["target"])
            best[k] = min(best.get(k, math.inf), x["fn"])
    summary: list[dict[str, Any]] = []
    for n in sizes:
        for m in methods:
            rs = [x for x in rows if x["n"] == n and x["method"] == m]
            if not rs:
                continue
            within = [x["success"] and x["fn"] <= best[(n, x["target"])] * (1 + 1e-3) for x in rs]
            summary.append(
                {
                    "n": n,
                    "method": m,
                    "targets": len(rs),
                    "success": float(np.mean([x["success"] for x in rs])),
                    "within_0.1%": float(np.mean(within)),
                    "median_ms": 1e3 * statistics.median(x["time_s"] for x in rs),
                    "median_nit": statistics.median(x["nit"] for x in rs),
                }
            )
    med = {(s["n"], s["method"]): s["median_ms"] for s in summary}
    exps: dict[str, dict[str, float | None]] = {}
    for m in methods:
        ns = [n for n in sizes if (n, m) in med]
        big = [n for n in ns if n >= 16]
        exps[m] = {
            "all": _fit(ns, [med[(n, m)] for n in ns]),
            "16-64": _fit(big, [med[(n, m)] for n in big]) if len(big) >= 2 else None,
        }
    ratios = []
    for n, base in ((16, "slsqp"), (16, "ipopt"), (4, "slsqp"), (4, "ipopt")):
        for m in ("sqp/osqp", "sqp/clarabel", "sqp/daqp"):
            if (n, m) in med and (n, base) in med:
                ratios.append(
                    {"n": n, "method": m, "baseline": base, "speedup": med[(n, base)] / med[(n, m)]}
                )
    args.out.mkdir(parents=True, exist_ok=True)
    payload = result_payload(
        args,
        (load0, load1),
        summary=summary,
        exponents=exps,
        ratios=ratios,
        rows=rows,
    )
    info = payload["machine"]
    (args.out / f"{stem}.json").write_text(json.dumps(payload, indent=1))
    lines = [
        f"# SQP scaling: {args.mode}, reference geometry, one start (paper's guess)",
        "",
        f"Command: `python benchmarks/bench_sqp_scaling.py --mode {args.mode} --sizes "
        f"{args.sizes} --targets {args.targets} --seed {args.seed} --max-time {args.max_time:g}`",
        "",
        f"Machine: {info.get('cpu', info['processor'])}, {info['cpus']} CPUs, load average "
        f"{load0[0]:.1f} at start, {load1[0]:.1f} at end; Python {info['python']}, NumPy "
        f"{info['numpy']}. Date: {info['date']}. {args.targets} targets per n "
        f"(`{make_targets.__name__}(stack, K, rng={args.seed} + n)`), min of {args.repeats} "
        "timing(s) per solve.",
        "",
        "| n | method | success | within 0.1 % of best | median time [ms] | median iterations |",
        "|---|---|---|---|---|---|",
    ]
    for s in summary:
        lines.append(
            f"| {s['n']} | {s['method']} | {100 * s['success']:.0f} % | "
            f"{100 * s['within_0.1%']:.0f} % | {s['median_ms']:.3g} | {s['median_nit']:g} |"
        )
    lines += ["", "Fitted exponent of median time vs n:", ""]
    lines += ["| method | all sizes | n = 16 to 64 |", "|---|---|---|"]
    for m, e in exps.items():
        a = "-" if e["all"] is None else f"{e['all']:.2f}"
        b = "-" if e["16-64"] is None else f"{e['16-64']:.2f}"
        lines.append(f"| {m} | {a} | {b} |")
    lines += ["", "Speed-ups in this run (baseline median / method median):", ""]
    lines += ["| n | method | baseline | speed-up |", "|---|---|---|---|"]
    for r in ratios:
        lines.append(f"| {r['n']} | {r['method']} | {r['baseline']} | {r['speedup']:.2f}x |")
    (args.out / f"{stem}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
