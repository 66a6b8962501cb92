"""Planar stacks at scale: the default against IPOPT from 8 starts at n = 16, 32, 64 (issue 27).

Run: ``python benchmarks/bench_scale.py [--n 16 32 64] [--count 20] [--seed 27400]
[--ref-starts 16] [--out benchmarks/results]``; writes ``scale.{csv,json,md}``.

Per n: the reference stack (:meth:`stackik.Stack.reference`), ``--count`` targets, target k
drawn with ``rng = seed + k`` in the plane ``phi = 2 pi k / count``
(:func:`_results.targets`). Per target, timed in the same run:

- ``default``: ``solve_ik(stack, target)``;
- ``full``: the default with its adaptive early stop turned off
  (:data:`stackik.solve.policy.ADAPTIVE_N` set out of reach, which also turns off the
  compact-target plan, :data:`stackik.solve.policy.COMPACT_REACH`): every start of the
  structured batch without arcs or hops, the default before the adaptive plan (same as
  ``default`` for n < ADAPTIVE_N);
- ``ipopt8``: ``method="ipopt", starts=8`` (time for the eight, best FN);
- ``ipopt_ref``: ``method="ipopt", starts=--ref-starts, rng=1000 + k``.

Each run's wall time and the process's CPU time (the default's is reported too; it
counts the process's other threads, such as BLAS workers still spinning after IPOPT).

``--reuse A.json`` takes the IPOPT rows (``ipopt8``, ``ipopt_ref``) of an earlier run of
the same targets (same ``--seed`` and ``--count``) instead of solving them again, and that
run's ``default`` as ``before`` (the default of the tree that made it: a before/after on
the same targets; it counts toward the best known); only ``default`` and ``full`` are
solved.

``--ipopt-max-n N`` runs IPOPT (both rows) only up to ``n = N``: above, its columns are
NaN (not run; IPOPT with the rows that keep legs off plates took 42 s a target at
n = 16).

``--part i/m`` runs only the targets ``k = i mod m``; every row is also appended to
``<stem>.jsonl`` as it is done. ``--merge A.json B.json ...`` summarises the rows of
earlier runs (sizes or parts run as separate processes) into one report instead of
solving. Best known = least FN over every
successful run of the row. Reported per n: successes,
within 0.1 % of the best known (on FN), median time, the speed-up against IPOPT-8 (median
of per-target time ratios), and the growth exponent ``k`` of the median default time
(``t ~ n^k``) between consecutive sizes and from the first size to the last.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
from _results import targets, write_results

import stackik.solve.policy as policy
from stackik import PlanarTarget, Stack, solve_ik
from stackik.bench import machine_info

WITHIN = 1e-3  # "best known" within 0.1 %
LABELS = ("default", "full", "ipopt8", "ipopt_ref", "before")  # ipopt_ref: --ref-starts > 0
FIELDS = ("time", "cpu", "success", "fn", "nit", "starts")
#: --reuse: (label here, label in the earlier run)
REUSED = (("ipopt8", "ipopt8"), ("ipopt_ref", "ipopt_ref"), ("before", "default"))


def _full(stack: Stack, target: Any) -> Any:
    """The default without its adaptive early stop and compact-target plan (every start of
    the structured batch, no arcs or hops)."""
    saved = policy.ADAPTIVE_N
    policy.ADAPTIVE_N = math.inf
    try:
        return solve_ik(stack, target)
    finally:
        policy.ADAPTIVE_N = saved


def run_size(
    n: int,
    count: int,
    seed: int,
    ref_starts: int,
    part: tuple[int, int],
    log: Path,
    reuse: dict[tuple[int, int], dict[str, Any]] | None = None,
    ipopt_max_n: int | None = None,
) -> list[dict[str, Any]]:
    """The rows of size ``n``: targets ``k`` with ``k % part[1] == part[0]``, each also
    appended to ``log`` (JSON lines) as it is done; ``reuse``: rows of an earlier run by
    ``(n, k)`` whose IPOPT runs (and default, as ``before``) are taken, not solved."""
    stack = Stack.reference(n)
    rows = []
    for k, target in enumerate(targets(True, stack, count, seed)):
        if k % part[1] != part[0]:
            continue
        row: dict[str, Any] = {"n": n, "k": k}
        runs: dict[str, dict[str, Any]] = {
            "default": {},
            "full": {},
            "ipopt8": {"method": "ipopt", "starts": 8},
        }
        if ipopt_max_n is not None and n > ipopt_max_n:  # not run: recorded as such
            del runs["ipopt8"]
            row.update({f"ipopt8_{f}": math.nan for f in ("time", "cpu", "fn")})
            row.update({"ipopt8_nit": 0, "ipopt8_success": False, "ipopt8_starts": 0})
        elif ref_starts > 0:
            runs["ipopt_ref"] = {"method": "ipopt", "starts": ref_starts, "rng": 1000 + k}
        if reuse is not None:
            old = reuse[(n, k)]
            for label, src in REUSED:
                if f"{src}_time" in old:
                    row.update({f"{label}_{f}": old[f"{src}_{f}"] for f in FIELDS})
                    runs[label] = {}
        for label, kw in runs.items():
            if f"{label}_time" in row:  # reused
                continue
            t0, c0 = time.perf_counter(), time.process_time()
            r = _full(stack, target) if label == "full" else solve_ik(stack, target, **kw)
            row[f"{label}_time"] = time.perf_counter() - t0
            row[f"{label}_cpu"] = time.process_time() - c0
            row[f"{label}_success"] = bool(r.success)
            row[f"{label}_fn"] = r.frobenius_norm if r.success else math.nan
            row[f"{label}_nit"] = int(r.nit)
            row[f"{label}_starts"] = int(r.n_starts)
        runs = {label: runs[label] for label in LABELS if label in runs}
        fns = [row[f"{label}_fn"] for label in runs if row[f"{label}_success"]]
        row["best"] = min(fns) if fns else math.nan
        if "ipopt8" not in runs:
            row["ipopt8_within"] = False
        for label in runs:
            row[f"{label}_within"] = bool(row[f"{label}_fn"] <= row["best"] * (1 + WITHIN))
        rows.append(row)
        with open(log, "a") as fh:
            fh.write(json.dumps(row, default=float) + "\n")
        print(
            f"n={n} {k}: default {row['default_fn']:.6g} ({1e3 * row['default_time']:.0f} ms, "
            f"{row['default_starts']} starts) full {row['full_fn']:.6g} "
            f"({1e3 * row['full_time']:.0f} ms) ipopt8 {row['ipopt8_fn']:.6g} "
            f"({1e3 * row['ipopt8_time']:.0f} ms) best {row['best']:.6g}",
            flush=True,
        )
    return rows


def growth(n0: int, t0: float, n1: int, t1: float) -> float:
    """The exponent ``k`` of ``t ~ n^k`` through two (size, time) points."""
    return math.log(t1 / t0) / math.log(n1 / n0)


def summary(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    for n in dict.fromkeys(r["n"] for r in rows):
        rs = [r for r in rows if r["n"] == n]
        line: dict[str, Any] = {"n": n, "targets": len(rs)}
        for label in [lb for lb in LABELS if f"{lb}_time" in rs[0]]:
            line[f"{label}_success"] = sum(r[f"{label}_success"] for r in rs)
            line[f"{label}_within"] = sum(r[f"{label}_within"] for r in rs)
            line[f"{label}_median_ms"] = 1e3 * float(np.median([r[f"{label}_time"] for r in rs]))
            # NaN where IPOPT-8 was not run (--ipopt-max-n)
            line[f"{label}_speedup_vs_ipopt8"] = float(
                np.median([r["ipopt8_time"] / r[f"{label}_time"] for r in rs])
            )
        line["default_median_starts"] = float(np.median([r["default_starts"] for r in rs]))
        line["default_max_ms"] = 1e3 * max(r["default_time"] for r in rs)
        if all("default_cpu" in r for r in rs):  # rows of runs before the CPU column: none
            cpu = [r["default_cpu"] for r in rs]
            line["default_median_cpu_ms"] = 1e3 * float(np.median(cpu))
            line["default_max_cpu_ms"] = 1e3 * max(cpu)
        out.append(line)
    for label in ("default", "full", "ipopt8"):
        for prev, line in zip(out, out[1:], strict=False):
            line[f"{label}_growth"] = growth(
                prev["n"], prev[f"{label}_median_ms"], line["n"], line[f"{label}_median_ms"]
            )
    return out


def markdown(lines: list[dict[str, Any]], meta: dict[str, Any]) -> str:
    head = (
        "| n | targets | default: success, within 0.1 %, median ms (max), median starts | "
        "default vs IPOPT-8 | full batch: within, median ms, vs IPOPT-8 | "
        "IPOPT-8: within, median ms | growth n^k since the row above: default, full, "
        "IPOPT-8 |\n|---|---|---|---|---|---|---|\n"
    )
    body = ""
    for s in lines:
        c = s["targets"]
        g = (
            f"{s['default_growth']:.2f}, {s['full_growth']:.2f}, {s['ipopt8_growth']:.2f}"
            if "default_growth" in s
            else "-"
        )
        ran = math.isfinite(s["ipopt8_median_ms"])  # --ipopt-max-n
        ipopt = f"{s['ipopt8_within']}/{c}, {s['ipopt8_median_ms']:.0f}" if ran else "not run"
        body += (
            f"| {s['n']} | {c} | {s['default_success']}/{c}, {s['default_within']}/{c}, "
            f"{s['default_median_ms']:.0f} ({s['default_max_ms']:.0f}), "
            f"{s['default_median_starts']:.0f} | {s['default_speedup_vs_ipopt8']:.1f}x | "
            f"{s['full_within']}/{c}, {s['full_median_ms']:.0f}, "
            f"{s['full_speedup_vs_ipopt8']:.1f}x | {ipopt} | {g} |\n"
        )
    cpu = [s for s in lines if "default_median_cpu_ms" in s]
    if cpu:
        body += (
            "\nThe default's CPU time, median (max): the process's, so it also counts the "
            "process's other threads (BLAS workers the IPOPT runs leave spinning: it can "
            "exceed the wall time): "
            + ", ".join(
                f"n = {s['n']} {s['default_median_cpu_ms']:.0f} ({s['default_max_cpu_ms']:.0f}) ms"
                for s in cpu
            )
            + ".\n"
        )
    before = [s for s in lines if "before_within" in s]
    if before:
        body += (
            "\nThe default of the tree that made the reused rows (--reuse), within 0.1 % and "
            "median ms (max) there: "
            + ", ".join(
                f"n = {s['n']} {s['before_within']}/{s['targets']}, {s['before_median_ms']:.0f}"
                for s in before
            )
            + ".\n"
        )
    first, last = lines[0], lines[-1]
    tail = ""
    if len(lines) > 1:
        k = {
            label: growth(
                first["n"], first[f"{label}_median_ms"], last["n"], last[f"{label}_median_ms"]
            )
            for label in ("default", "full", "ipopt8")
        }
        tail = (
            f"\nGrowth of the median time from n = {first['n']} to {last['n']}: default "
            f"n^{k['default']:.2f}, full batch n^{k['full']:.2f}, IPOPT-8 n^{k['ipopt8']:.2f}.\n"
        )
    return (
        "# Planar stacks at scale (benchmarks/bench_scale.py)\n\n"
        f"`{meta['command']}` on {meta['machine']}. Reference stacks; best known = least FN "
        f"over IPOPT from --ref-starts starts ({meta['ref_starts']}; 0: not run), IPOPT-8, the "
        "default and the full batch (the default without its adaptive early stop and its "
        "compact-target plan: every start of the structured batch, no arcs or hops)"
        + (", and the reused default (--reuse)" if "--reuse" in meta["command"] else "")
        + ". Times are wall times on a shared machine; ratios are medians of per-target "
        "ratios (with --reuse, the IPOPT times are the earlier run's).\n\n" + head + body + tail
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[16, 32, 64])
    ap.add_argument("--count", type=int, default=20)
    ap.add_argument("--seed", type=int, default=27400)
    ap.add_argument("--ref-starts", type=int, default=16)
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    ap.add_argument("--stem", default="scale")
    ap.add_argument("--part", default="0/1", help="i/m: only the targets k = i mod m")
    ap.add_argument("--merge", type=Path, nargs="+", help="scale JSON files to summarise")
    ap.add_argument("--reuse", type=Path, help="scale JSON whose IPOPT rows to take")
    ap.add_argument("--ipopt-max-n", type=int, help="run IPOPT only up to this n")
    args = ap.parse_args()
    rows: list[dict[str, Any]] = []
    if args.merge:
        parts = [json.loads(path.read_text()) for path in args.merge]
        rows = sorted((r for part in parts for r in part["rows"]), key=lambda r: (r["n"], r["k"]))
        meta = {
            "command": " + ".join(part["meta"]["command"] for part in parts),
            "machine": parts[0]["meta"]["machine"],
            "ref_starts": ", ".join(str(part["meta"]["ref_starts"]) for part in parts),
            "leg_radius": parts[0]["meta"].get("leg_radius", 0.0),
        }
    else:
        solve_ik(Stack.reference(4), PlanarTarget(600.0, 1000.0, -1.57))  # kernels loaded
        solve_ik(Stack.reference(2), PlanarTarget(0.0, 700.0, 0.0), method="ipopt")
        part = tuple(int(x) for x in args.part.split("/"))
        assert len(part) == 2 and 0 <= part[0] < part[1], "--part i/m with 0 <= i < m"
        args.out.mkdir(parents=True, exist_ok=True)
        log = args.out / f"{args.stem}.jsonl"
        log.write_text("")
        reuse = None
        if args.reuse:
            old = json.loads(args.reuse.read_text())
            cmd = old["meta"]["command"]
            assert f"--count {args.count} --seed {args.seed} " in cmd + " ", (
                f"--reuse: {args.reuse} is not a run of --count {args.count} --seed {args.seed}"
            )
            reuse = {(r["n"], r["k"]): r for r in old["rows"]}
            args.ref_starts = old["meta"]["ref_starts"]
        for n in args.n:
            rows += run_size(
                n, args.count, args.seed, args.ref_starts, (part[0], part[1]), log, reuse,
                args.ipopt_max_n,
            )  # fmt: skip
        meta = {
            "command": "python benchmarks/bench_scale.py --n "
            + " ".join(map(str, args.n))
            + f" --count {args.count} --seed {args.seed} --ref-starts {args.ref_starts}"
            + (f" --part {args.part}" if args.part != "0/1" else "")
            + (f" --ipopt-max-n {args.ipopt_max_n}" if args.ipopt_max_n is not None else "")
            + (f" --reuse {args.reuse} (run on {old['meta']['machine']})" if args.reuse else ""),
            "machine": "{cpus} CPUs ({cpu}), {date}".format(**machine_info()),
            "ref_starts": args.ref_starts,
            "leg_radius": Stack.reference().platforms[0].leg_radius,  # [mm]
        }
    lines = summary(rows)
    write_results(args.out, args.stem, meta, lines, rows, markdown(lines, meta))


if __name__ == "__main__":
    main()
