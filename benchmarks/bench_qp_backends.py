"""Can an SQP with the OSQP or Clarabel backend beat SLSQP by 2x on the n = 4 IK problem?

Run: ``python benchmarks/bench_qp_backends.py [--targets 40] [--out benchmarks/results]``.

Measured in one run, on random reachable planar targets of the 4-platform reference stack
(paper's initial guess, one start each):

1. SLSQP (scipy, same analytic derivatives): median wall time per solve.
2. The SQP engine with each QP backend: median wall time per solve and SQP iterations.
3. The QP subproblems that engine solved (recorded from the Clarabel run), re-solved by
   each backend alone, in three forms:

   * ``full``: as the engine passes them (12 variables, 3 equalities, 96 inequalities,
     box bounds on the step), engine settings;
   * ``loose``: the same with looser tolerances (OSQP eps 1e-3 relying on solution
     polishing, Clarabel 1e-8);
   * ``active``: only the rows active at the QP's solution (the smallest QP with the same
     solution, a floor for any constraint screening), loose settings.

   ``floor_ms`` = median SQP iterations x median per-QP time: the QP time alone of one
   solve, with zero cost for everything else. A backend cannot be 2x faster than SLSQP
   when ``floor_ms`` exceeds half SLSQP's time.

The QP timing counts only the backend's ``solve`` call (data update and solve).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np

import stackik as sk
from stackik.bench import BenchConfig, machine_info
from stackik.sampling import random_planar_targets
from stackik.sqp.qp import make_backend
from stackik.sqp.qp.clarabel_ import ClarabelBackend

LOOSE = {
    "osqp": {"eps_abs": 1e-3, "eps_rel": 1e-3},
    "clarabel": {"tol_gap_abs": 1e-8, "tol_gap_rel": 1e-8, "tol_feas": 1e-8},
    "daqp": {},
}


def _record_qps(stack: sk.Stack, targets: list[Any]) -> list[tuple[np.ndarray, ...]]:
    """The QPs the SQP engine solves (Clarabel backend), as ``solve`` arguments."""
    qps: list[tuple[np.ndarray, ...]] = []
    orig = ClarabelBackend.solve

    def rec(self: ClarabelBackend, *args: Any, **kw: Any) -> Any:
        qps.append(tuple(np.array(a, copy=True) for a in args[:8]))
        return orig(self, *args, **kw)

    ClarabelBackend.solve = rec  # type: ignore[method-assign]
    try:
        for t in targets:
            sk.solve_ik(stack, t, method="sqp", starts=1, qp_solver="clarabel")
    finally:
        ClarabelBackend.solve = orig  # type: ignore[method-assign]
    return qps


def _time_qps(name: str, opts: dict[str, Any], qps: list, rows: list | None) -> dict[str, Any]:
    times, fails = [], 0
    shape = None
    be = None
    for k, (P, q, A, b, G, h, lb, ub) in enumerate(qps):
        if rows is not None:
            G, h = G[rows[k]], h[rows[k]]
        if be is None or shape != (q.size, b.size, h.size):
            shape = (q.size, b.size, h.size)
            be = make_backend(name, opts)
            be.setup(*shape)
        t0 = time.perf_counter()
        sol = be.solve(P, q, A, b, G, h, lb, ub)
        times.append(time.perf_counter() - t0)
        fails += sol.status.name != "SOLVED"
    return {"per_qp_ms": 1e3 * statistics.median(times), "failed": fails}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--targets", type=int, default=40)
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = ap.parse_args()
    stack = sk.Stack.reference(4)
    targets = random_planar_targets(stack, args.targets, 7, phis=BenchConfig().phis)
    for t in targets[:2]:  # warm-up (imports, JIT of the default path)
        sk.solve_ik(stack, t, method="slsqp", starts=1)

    def per_solve(**kw: Any) -> tuple[float, float]:
        ts, its = [], []
        for t in targets:
            t0 = time.perf_counter()
            r = sk.solve_ik(stack, t, starts=1, **kw)
            ts.append(time.perf_counter() - t0)
            its.append(r.nit)
        return 1e3 * statistics.median(ts), statistics.median(its)

    slsqp_ms, slsqp_nit = per_solve(method="slsqp")
    qps = _record_qps(stack, targets)
    # rows active at each QP's solution (DAQP, exact active set)
    active = []
    daqp = make_backend("daqp")
    for P, q, A, b, G, h, lb, ub in qps:
        daqp.setup(q.size, b.size, h.size)
        x = daqp.solve(P, q, A, b, G, h, lb, ub).x
        active.append(np.flatnonzero(G @ x >= h - 1e-7))
    rows = []
    for name in ("daqp", "osqp", "clarabel"):
        ms, nit = per_solve(method="sqp", qp_solver=name)
        row: dict[str, Any] = {"backend": name, "sqp_ms": ms, "sqp_nit": nit}
        for form, opts, sel in (
            ("full", {}, None),
            ("loose", LOOSE[name], None),
            ("active", LOOSE[name], active),
        ):
            r = _time_qps(name, opts, qps, sel)
            row[f"{form}_qp_ms"] = r["per_qp_ms"]
            row[f"{form}_failed"] = r["failed"]
        row["floor_ms"] = nit * min(row["full_qp_ms"], row["loose_qp_ms"], row["active_qp_ms"])
        row["floor_vs_half_slsqp"] = row["floor_ms"] / (slsqp_ms / 2)
        rows.append(row)
    mi = machine_info()
    head = (
        f"# QP backends vs SLSQP, planar n = 4 ({len(targets)} targets, one start)\n\n"
        f"Machine: {mi.get('cpu', mi['processor'])}, {mi['cpus']} CPUs; Python {mi['python']}, "
        f"NumPy {mi['numpy']}. Date: {mi['date']}.\n\n"
        f"SLSQP: median {slsqp_ms:.3f} ms per solve ({slsqp_nit:g} iterations); "
        f"2x faster means <= {slsqp_ms / 2:.3f} ms.\n"
        f"Recorded QP subproblems: {len(qps)}; median active rows "
        f"{statistics.median(len(a) for a in active):g} of {qps[0][4].shape[0]}.\n\n"
    )
    cols = list(rows[0])
    table = "| " + " | ".join(cols) + " |\n|" + "---|" * len(cols) + "\n"
    for r in rows:
        table += (
            "| "
            + " | ".join(f"{v:.3g}" if isinstance(v, float) else str(v) for v in r.values())
            + " |\n"
        )
    note = (
        "\nfloor_ms: SQP iterations x the fastest per-QP time of the three forms, i.e. the "
        "QP time of one solve with everything else free. floor_vs_half_slsqp > 1: no SQP "
        "engine with that backend and that iteration count can be 2x faster than SLSQP.\n"
    )
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "qp_backends.md").write_text(head + table + note)
    (args.out / "qp_backends.json").write_text(
        json.dumps({"slsqp_ms": slsqp_ms, "slsqp_nit": slsqp_nit, "rows": rows}, indent=2)
    )
    print(head + table + note)


if __name__ == "__main__":
    main()
