"""Soak run of stackik (issue 7): thousands of fuzzed solves, unattended.

Every case comes from ``tests/fuzz_cases.py`` (``make_case(seed, index)``): reachable planar
and spatial targets from random feasible poses, spatial targets on legs of a size (leg radii
0-15 mm, clearance margins; every success's legs re-measured with an exact segment
distance), obstacles across the legs (spheres, capsules, boxes, half-spaces; every leg and
plate re-measured against them by the oracle's exact distances), random and extreme-scale
geometries, large stacks, unreachable targets, impossible geometries, wild warm starts,
iteration and time limits, ``start="convex"``, and malformed input (NaN/inf, wrong shapes,
bad geometries, bad arguments) across every method, QP backend and objective. Each case is
solved in a worker process with a watchdog (a case that outlives ``--timeout`` is recorded
as a ``hang`` and its worker replaced), its outcome classified and every success re-checked
independently (``fuzz_cases.recheck``).

Writes ``benchmarks/results/soak.json`` (counts, per-category and per-method tables,
every problem case, compact per-case records, machine and date; rewritten every 100 cases
so an interrupted run keeps its finished work) and ``soak.md``, prints the summary, and
exits non-zero on any false success, unexpected exception, hang or accepted malformed input
(``--strict-limits``: also on time / iteration-limit overruns).

Usage::

    python benchmarks/soak.py                 # 2000 cases, seed 7, 2 workers
    python benchmarks/soak.py --quick         # 200 cases
    python benchmarks/soak.py --cases 5000 --seed 11 --jobs 1
    python benchmarks/soak.py --replay 123 456   # rerun cases in-process, print records
    python benchmarks/soak.py --only clearance_spatial --cases 300   # one category
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import statistics
import sys
import time
import traceback
from collections import Counter, defaultdict
from multiprocessing.connection import wait
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
TESTS = ROOT / "tests"
DEFAULT_OUT = ROOT / "benchmarks" / "results"

sys.path.insert(0, str(TESTS))  # the case generators live with the fuzz tests
import fuzz_cases  # noqa: E402

OUTCOME_ORDER = (*fuzz_cases.OUTCOMES, "hang", "harness_error")
BAD_OUTCOMES = ("unexpected_exception", "accepted_malformed", "hang")
ACTIVE_MM = 1e-3  # a clearance slack below this [mm] counts as an active self-leg row


def _setup_path() -> None:
    if str(TESTS) not in sys.path:
        sys.path.insert(0, str(TESTS))


# =========================================================================================
# Worker
# =========================================================================================
def _one(seed: int, index: int, only: str | None = None) -> dict[str, Any]:
    _setup_path()
    import fuzz_cases as fc

    try:
        case = fc.make_case(seed, index, only)
    except Exception:  # noqa: BLE001 - a bug of the generator, not of stackik
        return {
            "index": index,
            "category": "?",
            "label": "",
            "outcome": "harness_error",
            "false_success": False,
            "exception": traceback.format_exc(limit=3)[-400:],
            "time": 0.0,
        }
    rec = fc.run_case(case)
    rec["index"] = index
    return rec


def _worker(seed: int, only: str | None, conn: Any) -> None:
    import warnings

    warnings.simplefilter("ignore")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    while True:
        index = conn.recv()
        if index is None:
            return
        conn.send(_one(seed, index, only))


class _Slot:
    def __init__(self, ctx: Any, seed: int, only: str | None = None) -> None:
        self.ctx, self.seed, self.only = ctx, seed, only
        self.start()

    def start(self) -> None:
        parent, child = self.ctx.Pipe()
        self.conn = parent
        self.proc = self.ctx.Process(
            target=_worker, args=(self.seed, self.only, child), daemon=True
        )
        self.proc.start()
        child.close()
        self.index: int | None = None
        self.t0 = 0.0

    def submit(self, index: int) -> None:
        self.index, self.t0 = index, time.perf_counter()
        self.conn.send(index)

    def kill(self) -> None:
        self.proc.kill()
        self.proc.join(5)
        self.conn.close()


def run_cases(
    seed: int,
    indices: list[int],
    jobs: int,
    timeout: float,
    progress: Any,
    only: str | None = None,
) -> list[dict[str, Any]]:
    """Solve the cases in ``jobs`` worker processes with a per-case watchdog (``only``: of
    that category only)."""
    ctx = mp.get_context("spawn")
    slots = [_Slot(ctx, seed, only) for _ in range(max(1, jobs))]
    todo = list(reversed(indices))
    records: list[dict[str, Any]] = []
    try:
        while todo or any(s.index is not None for s in slots):
            for s in slots:
                if s.index is None and todo:
                    s.submit(todo.pop())
            busy = [s for s in slots if s.index is not None]
            ready = wait([s.conn for s in busy], timeout=0.5)
            now = time.perf_counter()
            for s in busy:
                if s.conn in ready:
                    try:
                        rec = s.conn.recv()
                    except (EOFError, OSError):  # worker died (segfault, OOM...)
                        rec = _dead(s, "worker process died", now)
                        s.kill()
                        s.start()
                    s.index = None
                    records.append(rec)
                    progress(rec, len(records))
                elif now - s.t0 > timeout:
                    rec = _dead(s, f"no result after {timeout:.0f} s (killed)", now)
                    rec["outcome"] = "hang"
                    s.kill()
                    s.start()
                    records.append(rec)
                    progress(rec, len(records))
    finally:
        for s in slots:
            if s.proc.is_alive():
                try:
                    s.conn.send(None)
                except OSError:
                    pass
                s.proc.join(2)
                if s.proc.is_alive():
                    s.proc.kill()
    records.sort(key=lambda r: r["index"])
    return records


def _dead(slot: _Slot, why: str, now: float) -> dict[str, Any]:
    _setup_path()
    import fuzz_cases as fc

    assert slot.index is not None
    try:
        case = fc.make_case(slot.seed, slot.index, slot.only)
        category, label = case.category, case.label
    except Exception:  # noqa: BLE001
        category, label = "?", ""
    return {
        "index": slot.index,
        "category": category,
        "label": label,
        "outcome": "unexpected_exception",
        "exception": why,
        "false_success": False,
        "time": now - slot.t0,
    }


# =========================================================================================
# Summary
# =========================================================================================
def _machine() -> dict[str, Any]:
    from stackik.bench import machine_info

    info = machine_info()
    try:
        import subprocess

        info["git"] = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            timeout=5,
        ).stdout.strip()
    except Exception:  # noqa: BLE001
        pass
    return info


def _row(recs: list[dict[str, Any]]) -> dict[str, Any]:
    c = Counter(r["outcome"] for r in recs)
    times = [r["time"] for r in recs if "time" in r]
    row: dict[str, Any] = {
        "cases": len(recs),
        **{k: c.get(k, 0) for k in OUTCOME_ORDER if c.get(k, 0) or k in OUTCOME_ORDER[:7]},
        "false_success": sum(bool(r.get("false_success")) for r in recs),
        "time_overrun": sum(bool(r.get("time_overrun")) for r in recs),
        "iter_overrun": sum(bool(r.get("iter_overrun")) for r in recs),
        "median_time_s": statistics.median(times) if times else 0.0,
        "max_time_s": max(times) if times else 0.0,
    }
    slack = [r["clearance_slack"] for r in recs if "clearance_slack" in r]
    if slack:  # successes with a clearance to keep: how many sit at the least distance
        row["clearance_rechecked"] = len(slack)
        row["clearance_active"] = sum(s <= ACTIVE_MM for s in slack)
        row["clearance_least_slack_mm"] = min(slack)
    return row


def summarize(records: list[dict[str, Any]], meta: dict[str, Any]) -> dict[str, Any]:
    counts = Counter(r["outcome"] for r in records)
    by_cat: dict[str, list[dict[str, Any]]] = defaultdict(list)
    by_method: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in records:
        by_cat[r["category"]].append(r)
        if not r.get("malformed") and "method" in r:
            by_method[r["method"]].append(r)
    groups: dict[tuple[str, str], list[int]] = defaultdict(list)
    for r in records:
        if r["outcome"] in BAD_OUTCOMES or r["outcome"] == "harness_error":
            msg = str(r.get("exception", f"{r['outcome']}: {r['label']}"))
            groups[(r["category"], msg[:110])].append(r["index"])
    unexpected = [
        {"category": cat, "error": msg, "count": len(ix), "indices": ix[:20]}
        for (cat, msg), ix in sorted(groups.items(), key=lambda kv: -len(kv[1]))
    ]

    def pick(flag: str) -> list[dict[str, Any]]:
        keys = ("index", "category", "label", "outcome", "time", "nit", "nit_bound", "problems")
        return [{k: r[k] for k in keys if k in r} for r in records if r.get(flag)]

    n_ok = counts.get("success", 0)
    summary = {
        "meta": meta,
        "counts": {
            "cases": len(records),
            **{k: counts.get(k, 0) for k in OUTCOME_ORDER},
            "limit_reached": counts.get("max_iter", 0) + counts.get("max_time", 0),
            "false_success": sum(bool(r.get("false_success")) for r in records),
            "successes_rechecked": n_ok,
            "time_overrun": sum(bool(r.get("time_overrun")) for r in records),
            "iter_overrun": sum(bool(r.get("iter_overrun")) for r in records),
            "anomaly": sum("anomaly" in r for r in records),
        },
        "per_category": {k: _row(v) for k, v in sorted(by_cat.items())},
        "per_method": {k: _row(v) for k, v in sorted(by_method.items())},
        "unexpected": unexpected,
        "false_successes": pick("false_success"),
        "time_overruns": pick("time_overrun"),
        "iter_overruns": pick("iter_overrun"),
        "anomalies": [
            {"index": r["index"], "label": r["label"], "anomaly": r["anomaly"]}
            for r in records
            if "anomaly" in r
        ],
        "columns": ["index", "category", "method", "n", "outcome", "false_success", "time_s"],
        "cases": [
            [
                r["index"],
                r["category"],
                r.get("method", ""),
                r.get("n", 0),
                r["outcome"],
                bool(r.get("false_success")),
                round(float(r.get("time", 0.0)), 4),
            ]
            for r in records
        ],
    }
    return summary


def failed(summary: dict[str, Any], strict_limits: bool) -> bool:
    c = summary["counts"]
    bad = c["false_success"] + sum(c[k] for k in BAD_OUTCOMES) + c["harness_error"]
    if strict_limits:
        bad += c["time_overrun"] + c["iter_overrun"]
    return bad > 0


def _md_table(rows: dict[str, dict[str, Any]], first: str) -> list[str]:
    cols = [
        "cases", "success", "infeasible", "max_iter", "max_time", "failed", "value_error",
        "unexpected_exception", "false_success", "time_overrun", "iter_overrun",
        "median_time_s", "max_time_s",
    ]  # fmt: skip
    extra = sorted({k for r in rows.values() for k in r} - set(cols))
    cols += extra
    head = [first] + [c.replace("_", " ") for c in cols]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, r in rows.items():
        cells = []
        for c in cols:
            v = r.get(c, "-" if c.startswith("clearance") else 0)
            cells.append(f"{v:.3f}" if isinstance(v, float) else str(v))
        out.append(f"| {name} | " + " | ".join(cells) + " |")
    return out


def markdown(summary: dict[str, Any]) -> str:
    m, c = summary["meta"], summary["counts"]
    mach = m["machine"]
    lines = [
        "# stackik soak run",
        "",
        f"{c['cases']} fuzzed solves, seed {m['seed']}, {m['jobs']} worker(s), "
        f"wall time {m['wall_time_s']:.0f} s. Command: `{m['command']}`.",
        "",
        f"Machine: {mach.get('cpu', mach['processor'])}, {mach['cpus']} CPUs, "
        f"{mach['platform']}; Python {mach['python']}, NumPy {mach['numpy']}, "
        f"SciPy {mach['scipy']}; stackik {mach['stackik']} (git {mach.get('git', '?')}). "
        f"Date: {mach['date']}.",
        "",
        "## Counts",
        "",
        "| outcome | cases |",
        "|---|---|",
    ]
    for k in (
        "success", "infeasible", "max_iter", "max_time", "failed", "value_error",
        "unexpected_exception", "accepted_malformed", "hang", "harness_error",
    ):  # fmt: skip
        lines.append(f"| {k} | {c[k]} |")
    lines += [
        f"| **false successes** (success but the independent re-check fails) | "
        f"**{c['false_success']}** |",
        f"| time overruns (> max_time + 2 s) | {c['time_overrun']} |",
        f"| iteration-limit overruns (nit > bound) | {c['iter_overrun']} |",
        "",
        "`value_error` is the expected outcome of malformed input; `unexpected_exception` "
        "is any exception from well-formed input or a non-ValueError from malformed input.",
        "",
        "## Per category",
        "",
        *_md_table(summary["per_category"], "category"),
        "",
        "## Per method (well-formed cases)",
        "",
        *_md_table(summary["per_method"], "method"),
        "",
    ]
    if summary["unexpected"]:
        lines += ["## Unexpected exceptions, hangs, accepted malformed input", ""]
        lines += ["| category | count | error | first cases |", "|---|---|---|---|"]
        for u in summary["unexpected"]:
            err = u["error"].replace("|", "\\|").replace("\n", " ")
            lines.append(
                f"| {u['category']} | {u['count']} | `{err}` | "
                f"{', '.join(map(str, u['indices'][:8]))} |"
            )
        lines.append("")
    for key, title in (
        ("false_successes", "False successes"),
        ("time_overruns", "Time overruns"),
        ("iter_overruns", "Iteration-limit overruns"),
    ):
        if summary[key]:
            lines += [f"## {title}", ""]
            for r in summary[key][:30]:
                lines.append(
                    f"- case {r['index']} ({r['category']}): {r['label']} -> {r['outcome']}, "
                    f"{r.get('time', 0):.2f} s, nit {r.get('nit', '?')}"
                    + (f" (bound {r['nit_bound']})" if "nit_bound" in r else "")
                    + (f"; {'; '.join(r['problems'])}" if r.get("problems") else "")
                )
            lines.append("")
    lines += [
        "Rerun one case in-process: `python benchmarks/soak.py --seed "
        f"{m['seed']} --replay INDEX`.",
        "",
    ]
    return "\n".join(lines)


def print_summary(summary: dict[str, Any]) -> None:
    c = summary["counts"]
    print(
        f"\n{c['cases']} cases: success {c['success']}, infeasible {c['infeasible']}, "
        f"limit reached {c['limit_reached']} (max_iter {c['max_iter']}, max_time "
        f"{c['max_time']}), failed {c['failed']}, value_error {c['value_error']}, "
        f"unexpected {c['unexpected_exception']}, accepted malformed "
        f"{c['accepted_malformed']}, hang {c['hang']}"
    )
    print(
        f"false successes: {c['false_success']} (of {c['successes_rechecked']} re-checked "
        f"successes); time overruns {c['time_overrun']}; iteration overruns {c['iter_overrun']}"
    )
    print("\nper category:")
    for cat, r in summary["per_category"].items():
        print(
            f"  {cat:20s} {r['cases']:5d}  ok {r['success']:4d}  inf {r['infeasible']:4d}  "
            f"lim {r['max_iter'] + r['max_time']:3d}  fail {r['failed']:3d}  "
            f"verr {r['value_error']:4d}  unexp {r['unexpected_exception']:3d}  "
            f"false {r['false_success']}  med {r['median_time_s']:.3f}s  "
            f"max {r['max_time_s']:.2f}s"
        )
        if "clearance_rechecked" in r:
            print(
                f"  {'':20s} clearances: {r['clearance_rechecked']} successes re-measured, "
                f"{r['clearance_active']} with a pair at the least distance "
                f"(slack <= {ACTIVE_MM} mm), least slack {r['clearance_least_slack_mm']:.2e} mm"
            )
    for u in summary["unexpected"]:
        print(f"  UNEXPECTED x{u['count']} [{u['category']}] {u['error']}  e.g. {u['indices'][:5]}")
    for r in summary["false_successes"]:
        print(f"  FALSE SUCCESS case {r['index']}: {r['label']}: {r.get('problems')}")
    for r in summary["time_overruns"][:10]:
        print(f"  TIME OVERRUN case {r['index']}: {r['label']}: {r['time']:.2f} s")
    for r in summary["iter_overruns"][:10]:
        print(f"  ITER OVERRUN case {r['index']}: {r['label']}: nit {r['nit']} > {r['nit_bound']}")


def write(summary: dict[str, Any], out: Path, complete: bool) -> None:
    out.mkdir(parents=True, exist_ok=True)
    summary["meta"]["complete"] = complete
    tmp = out / "soak.json.tmp"
    tmp.write_text(json.dumps(summary, indent=1, default=str) + "\n")
    tmp.replace(out / "soak.json")
    if complete:
        (out / "soak.md").write_text(markdown(summary))


# =========================================================================================
# Main
# =========================================================================================
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=2000, help="number of cases (default 2000)")
    ap.add_argument("--quick", action="store_true", help="200 cases (overrides --cases)")
    ap.add_argument("--seed", type=int, default=7, help="campaign seed (default 7)")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--timeout", type=float, default=120.0, help="per-case watchdog [s]")
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT, help="results directory")
    ap.add_argument("--no-write", action="store_true", help="print only")
    ap.add_argument(
        "--strict-limits", action="store_true", help="also fail on time/iteration overruns"
    )
    ap.add_argument("--replay", type=int, nargs="+", metavar="INDEX", help="rerun cases")
    ap.add_argument(
        "--only", metavar="CATEGORY", help="cases of one category (e.g. clearance_spatial)"
    )
    args = ap.parse_args(argv)
    if args.only is not None and args.only not in fuzz_cases.CATEGORIES:
        ap.error(f"--only: one of {', '.join(fuzz_cases.CATEGORIES)}")

    if args.replay:
        import warnings

        warnings.simplefilter("ignore")
        bad = False
        for i in args.replay:
            rec = _one(args.seed, i, args.only)
            print(json.dumps(rec, indent=1, default=str))
            bad |= rec["outcome"] in BAD_OUTCOMES or bool(rec.get("false_success"))
        return 1 if bad else 0

    n_cases = 200 if args.quick else args.cases
    indices = list(range(n_cases))
    t0 = time.perf_counter()
    done: list[dict[str, Any]] = []
    meta = {
        "seed": args.seed,
        "jobs": args.jobs,
        "timeout_s": args.timeout,
        "only": args.only,
        "command": "python benchmarks/soak.py "
        + " ".join(a for a in (argv if argv is not None else sys.argv[1:])),
        "machine": _machine(),
    }

    def progress(rec: dict[str, Any], k: int) -> None:
        done.append(rec)
        flag = ""
        if rec.get("false_success"):
            flag = f"  FALSE SUCCESS: {rec.get('problems')}"
        elif rec["outcome"] in BAD_OUTCOMES:
            flag = f"  {rec['outcome'].upper()}: {str(rec.get('exception', ''))[:120]}"
        if flag:
            print(f"[{k}/{n_cases}] case {rec['index']} {rec['category']} {rec['label']}{flag}")
        if k % 100 == 0 or k == n_cases:
            c = Counter(r["outcome"] for r in done)
            print(
                f"[{k}/{n_cases}] {time.perf_counter() - t0:6.0f} s  "
                + ", ".join(f"{o} {c[o]}" for o in OUTCOME_ORDER if c.get(o)),
                flush=True,
            )
            if not args.no_write and k < n_cases:  # checkpoint: keep finished work
                meta["wall_time_s"] = time.perf_counter() - t0
                write(summarize(sorted(done, key=lambda r: r["index"]), meta), args.out, False)

    records = run_cases(args.seed, indices, args.jobs, args.timeout, progress, args.only)
    meta["wall_time_s"] = time.perf_counter() - t0
    summary = summarize(records, meta)
    if not args.no_write:
        write(summary, args.out, True)
        print(f"\nwrote {args.out / 'soak.json'} and {args.out / 'soak.md'}")
    print_summary(summary)
    return 1 if failed(summary, args.strict_limits) else 0


if __name__ == "__main__":
    raise SystemExit(main())
