"""Benchmark of stackik.sqp on the Hock-Schittkowski set against scipy SLSQP and trust-constr.

Run: ``python benchmarks/bench_sqp.py``.  Writes ``benchmarks/results/sqp_hs.{csv,json,md}``
(``--out DIR`` elsewhere; ``--methods stackik/daqp,scipy/SLSQP`` runs a subset).
A run counts as solved when the method reports success and reaches the published optimum
to 1e-5 relative (1e-6 absolute when ``f* = 0``).
"""

from __future__ import annotations

import argparse
import csv
import datetime as dt
import json
import platform
import statistics
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import Bounds, NonlinearConstraint, minimize

from stackik.sqp import solve

# The Hock-Schittkowski problems are test data: they live with the tests.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "sqp"))
from hs_problems import PROBLEMS, HSProblem  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
REPEATS = 3


def _ok(fun: float, f_star: float) -> bool:
    if f_star == 0.0:
        return abs(fun) <= 1e-6
    return abs(fun - f_star) <= 1e-5 * abs(f_star)


def _scipy(p: HSProblem, method: str) -> tuple[bool, float, int]:
    nlp = p.nlp
    cons = []
    if method == "SLSQP":
        if nlp.eq is not None:
            cons.append({"type": "eq", "fun": nlp.eq, "jac": nlp.eq_jacobian})
        if nlp.ineq is not None:
            cons.append({"type": "ineq", "fun": nlp.ineq, "jac": nlp.ineq_jacobian})
    else:
        if nlp.eq is not None:
            cons.append(NonlinearConstraint(nlp.eq, 0.0, 0.0, jac=nlp.eq_jacobian))
        if nlp.ineq is not None:
            cons.append(NonlinearConstraint(nlp.ineq, 0.0, np.inf, jac=nlp.ineq_jacobian))
    n = p.x0.size
    lo = np.full(n, -np.inf) if nlp.lower is None else np.asarray(nlp.lower)
    up = np.full(n, np.inf) if nlp.upper is None else np.asarray(nlp.upper)
    x0 = np.clip(p.x0, lo, up)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = minimize(
            nlp.objective,
            x0,
            jac=nlp.gradient,
            method=method,
            bounds=Bounds(lo, up),
            constraints=cons,
            options={"maxiter": 1000} if method == "SLSQP" else {"maxiter": 3000},
        )
    viol = 0.0
    if nlp.eq is not None:
        viol = max(viol, float(np.max(np.abs(nlp.eq(res.x)))))
    if nlp.ineq is not None:
        viol = max(viol, float(np.max(-np.asarray(nlp.ineq(res.x)), initial=0.0)))
    success = bool(res.success) and viol <= 1e-6
    return success and _ok(float(res.fun), p.f_star), float(res.fun), int(res.nit)


def _stackik(p: HSProblem, solver: str) -> tuple[bool, float, int]:
    res = solve(p.nlp, p.x0, qp_solver=solver)
    return res.success and _ok(res.fun, p.f_star), res.fun, res.nit


def main() -> None:
    parser = argparse.ArgumentParser(description="stackik.sqp Hock-Schittkowski benchmark")
    parser.add_argument("--out", type=Path, default=RESULTS, help="output directory")
    parser.add_argument("--methods", default="", help="comma-separated subset of methods")
    parser.add_argument("--repeats", type=int, default=REPEATS)
    args = parser.parse_args()
    methods = {
        "stackik/daqp": lambda p: _stackik(p, "daqp"),
        "stackik/osqp": lambda p: _stackik(p, "osqp"),
        "stackik/clarabel": lambda p: _stackik(p, "clarabel"),
        "scipy/SLSQP": lambda p: _scipy(p, "SLSQP"),
        "scipy/trust-constr": lambda p: _scipy(p, "trust-constr"),
    }
    if args.methods:
        wanted = [m.strip() for m in args.methods.split(",") if m.strip()]
        unknown = sorted(set(wanted) - set(methods))
        if unknown:
            parser.error(f"unknown methods {unknown}; known: {sorted(methods)}")
        methods = {m: methods[m] for m in wanted}
    out: Path = args.out
    repeats: int = args.repeats
    rows: list[dict[str, Any]] = []
    for name, fn in methods.items():
        for num, p in sorted(PROBLEMS.items()):
            times = []
            for _ in range(repeats):
                t = time.perf_counter()
                ok, fun, nit = fn(p)
                times.append(time.perf_counter() - t)
            rows.append(
                {
                    "method": name,
                    "problem": f"HS{num}",
                    "solved": ok,
                    "fun": fun,
                    "f_star": p.f_star,
                    "nit": nit,
                    "time_s": min(times),
                }
            )
    summary = []
    for name in methods:
        rs = [r for r in rows if r["method"] == name]
        summary.append(
            {
                "method": name,
                "solved": sum(r["solved"] for r in rs),
                "problems": len(rs),
                "median_nit": statistics.median(r["nit"] for r in rs),
                "median_time_ms": 1e3 * statistics.median(r["time_s"] for r in rs),
            }
        )
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "sqp_hs.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    machine = (
        f"{platform.machine()} {platform.processor() or ''} Python {platform.python_version()}"
    )
    date = dt.datetime.now().isoformat(timespec="seconds")
    (out / "sqp_hs.json").write_text(
        json.dumps({"machine": machine, "date": date, "summary": summary, "runs": rows}, indent=1)
    )
    lines = [
        "# stackik.sqp on Hock-Schittkowski problems",
        "",
        f"Machine: {machine} ({platform.node()}); date: {date}; "
        f"best of {repeats} runs per problem.",
        "",
        "| method | solved | median iterations | median time per solve [ms] |",
        "|---|---|---|---|",
    ]
    for s in summary:
        lines.append(
            f"| {s['method']} | {s['solved']}/{s['problems']} | {s['median_nit']:g} | "
            f"{s['median_time_ms']:.3f} |"
        )
    text = "\n".join(lines) + "\n"
    (out / "sqp_hs.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
