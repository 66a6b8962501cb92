"""Solver-comparison benchmark (``stackik bench``): every method on one fixed target set.

Sections, all measured in the same run:

1. **planar n = 4**: the paper's three targets plus random reachable targets (forward
   kinematics of random feasible poses, fixed seed, several phi). Methods: stackik's
   default (compiled interior point, structured starts), the interior point from one
   start, the SQP engine (three structured starts) with each QP backend and from one
   start, SciPy SLSQP and trust-constr (same scaled analytic derivatives) and IPOPT
   through CasADi (exact AD derivatives) from the paper's initial guess, and a "best
   global effort": IPOPT from eight starts. FN gap is relative to the best FN any method
   found. Speed-ups (baseline median time / method median time) from the same run.
2. **scaling** in n (4 ... 64) with the fitted exponent of median time vs n.
3. **other geometries**: random asymmetric stacks, n = 2 ... 8, default vs IPOPT.
4. **spatial** n = 4 (6 DOF per platform).

Each solve's success is the independent :func:`stackik.check_pose`. Results are written
as CSV (one row per solve), JSON (summary) and Markdown (tables with machine and date).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from stackik._io import write_csv
from stackik.batch import checkpointed_map
from stackik.geometry import Stack
from stackik.sampling import random_planar_targets, random_spatial_targets, random_stack
from stackik.solve import solve_ik
from stackik.targets import PAPER_TARGETS, PlanarTarget, target_to_dict

__all__ = ["BenchConfig", "machine_info", "main", "run_benchmark"]

DEFAULT = "stackik (default)"
SLSQP = "slsqp, 1 start"
SLSQP8 = "slsqp, 8 starts"
IPOPT1 = "ipopt, 1 start"
IPOPT8 = "ipopt, 8 starts"


@dataclass(frozen=True)
class Method:
    """One benchmarked configuration of :func:`solve_ik`."""

    label: str
    kwargs: dict[str, Any]
    max_targets: int | None = None  # slow baselines run on the first targets only


@dataclass
class BenchConfig:
    """What to run (defaults: the full benchmark; ``quick()`` for a smoke test)."""

    n_random: int = 200
    phis: tuple[float, ...] = (0.0, 0.8, -2.1)
    sizes: tuple[int, ...] = (4, 8, 16, 32, 64)
    per_size: int = 4
    n_spatial: int = 30
    rng: int = 0
    trust_constr_targets: int = 20
    geo_sizes: tuple[int, ...] = (2, 3, 5, 6, 8)
    geo_stacks: int = 3
    geo_per_stack: int = 6
    ipopt: bool = True
    extra: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def quick(cls) -> BenchConfig:
        return cls(
            n_random=6,
            sizes=(4, 8),
            per_size=2,
            n_spatial=2,
            trust_constr_targets=2,
            geo_sizes=(3,),
            geo_stacks=1,
            geo_per_stack=3,
        )


def machine_info() -> dict[str, Any]:
    """Machine, versions and date stamped on every benchmark result."""
    import scipy

    from stackik._version import __version__

    info = {
        "date": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "stackik": __version__,
    }
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    info["cpu"] = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return info


def result_payload(args: Any, load: tuple[Any, Any], **sections: Any) -> dict[str, Any]:
    """A benchmark's JSON payload: ``machine`` (:func:`machine_info` with the load
    averages at start and end, ``load``), ``args`` (an argparse namespace, as strings),
    then ``sections`` in order."""
    info = machine_info()
    info["loadavg_start"], info["loadavg_end"] = load
    return {"machine": info, "args": {k: str(v) for k, v in vars(args).items()}, **sections}


def _ipopt_ok() -> bool:
    from stackik.methods.ipopt import ipopt_available

    return ipopt_available()


def _planar_methods(cfg: BenchConfig) -> list[Method]:
    from stackik.sqp.qp import available_qp_solvers

    avail = set(available_qp_solvers())
    ms = [
        Method(DEFAULT, {}),
        Method("ip, 1 start", {"method": "ip", "starts": 1}),
        Method("sqp, 3 starts", {"method": "sqp"}),
    ]
    for qp in ("osqp", "clarabel"):
        if qp in avail:
            ms.append(Method(f"sqp/{qp}, 3 starts", {"method": "sqp", "qp_solver": qp}))
    ms.append(Method("sqp, 1 start", {"method": "sqp", "starts": 1}))
    ms.append(Method(SLSQP, {"method": "slsqp", "starts": 1}))
    # SLSQP at a quality comparable with the default's (same 3 structured starts + 5 random)
    ms.append(Method(SLSQP8, {"method": "slsqp", "starts": 8, "rng": 0}))
    ms.append(
        Method(
            "trust-constr, 1 start",
            {"method": "trust-constr", "starts": 1, "options": {"maxiter": 300}},
            max_targets=cfg.trust_constr_targets,
        )
    )
    if cfg.ipopt and _ipopt_ok():
        ms.append(Method(IPOPT1, {"method": "ipopt", "starts": 1}))
        ms.append(Method(IPOPT8, {"method": "ipopt", "starts": 8, "rng": 0}))
    return ms


def _ratios(summary: list[dict]) -> list[dict]:
    """Median-time ratios measured in this run (planar n = 4): baseline / method."""
    med = {s["method"]: s["median_ms"] for s in summary if s["section"] == "planar"}
    pairs = [(DEFAULT, SLSQP), (DEFAULT, SLSQP8), (DEFAULT, IPOPT1), (DEFAULT, IPOPT8)]
    pairs += [(m, SLSQP) for m in med if m.startswith("sqp/")]
    out = []
    for method, base in pairs:
        if method in med and base in med and med[method] > 0:
            out.append(
                {
                    "method": method,
                    "baseline": base,
                    "method_ms": med[method],
                    "baseline_ms": med[base],
                    "speedup": med[base] / med[method],
                }
            )
    return out


def _solve_row(stack: Stack, target: Any, i: int, method: Method, section: str) -> dict:
    t0 = time.perf_counter()
    r = solve_ik(stack, target, **method.kwargs)
    dt = time.perf_counter() - t0
    return {
        "section": section,
        "n": stack.n,
        "target": i,
        "method": method.label,
        "success": bool(r.success),
        "status": r.status.value,
        "fn": r.frobenius_norm if r.success else float("nan"),
        "time_s": dt,
        "nit": r.nit,
        "starts": r.n_starts,
    }


def _summarise(rows: list[dict], key: tuple[str, ...] = ("section", "n", "method")) -> list[dict]:
    best: dict[tuple[Any, ...], float] = {}
    for r in rows:
        k = (r["section"], r["n"], r["target"])
        if r["success"]:
            best[k] = min(best.get(k, np.inf), r["fn"])
    groups: dict[tuple[Any, ...], list[dict]] = {}
    for r in rows:
        groups.setdefault(tuple(r[x] for x in key), []).append(r)
    out = []
    for g, rs in groups.items():
        t = np.array([r["time_s"] for r in rs])
        gaps = np.array(
            [
                r["fn"] / best[(r["section"], r["n"], r["target"])] - 1.0
                if r["success"]
                else np.inf
                for r in rs
            ]
        )
        out.append(
            {
                **dict(zip(key, g, strict=True)),
                "targets": len(rs),
                "success_rate": float(np.mean([r["success"] for r in rs])),
                "within_0.1%": float(np.mean(gaps <= 1e-3)),
                "median_gap_%": float(np.median(gaps) * 100) if np.isfinite(gaps).any() else None,
                "max_gap_%": float(np.max(gaps[np.isfinite(gaps)]) * 100)
                if np.isfinite(gaps).any()
                else None,
                "median_ms": float(np.median(t) * 1e3),
                "p90_ms": float(np.quantile(t, 0.9) * 1e3),
                "median_nit": float(np.median([r["nit"] for r in rs])),
            }
        )
    return out


def _md_table(summary: list[dict], cols: Sequence[str]) -> str:
    def fmt(v: Any) -> str:
        if isinstance(v, float):
            return f"{v:.3g}" if abs(v) < 1e4 else f"{v:.0f}"
        return "-" if v is None else str(v)

    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(fmt(s.get(c)) for c in cols) + " |" for s in summary]
    return "\n".join(lines)


#: One benchmarked (stack, targets, method, section, index of the first target) set.
_Job = tuple[Stack, Sequence[Any], Method, str, int]


def run_benchmark(
    cfg: BenchConfig, out: Path, progress: bool = True, fresh: bool = False
) -> dict[str, Any]:
    """Run every section, write ``ik_bench.{csv,json,md}`` to ``out``; return the summary.

    Every finished solve is appended to ``out/ik_bench.jsonl``; rerunning the same
    configuration resumes after an interruption (``fresh=True`` starts over). Resuming
    mixes timings of two runs: rerun fresh for numbers to publish.
    """
    out.mkdir(parents=True, exist_ok=True)
    stack = Stack.reference(4)
    targets = [PlanarTarget(*t, phi=0.0) for t in PAPER_TARGETS]
    targets += random_planar_targets(stack, cfg.n_random, cfg.rng, phis=cfg.phis)
    jobs: list[_Job] = [(stack, targets, m, "planar", 0) for m in _planar_methods(cfg)]
    jobs += _scaling_jobs(cfg)
    jobs += _geometry_jobs(cfg)
    sp_targets = random_spatial_targets(stack, cfg.n_spatial, cfg.rng + 7)
    jobs += _spatial_jobs(cfg, stack, sp_targets)
    # warm up imports and caches (and compile or load the numba kernels, planar and
    # spatial) so the first timed solve is not penalised
    solve_ik(stack, targets[0])
    if sp_targets:
        solve_ik(stack, sp_targets[0])
    rows = _run_jobs(jobs, out / "ik_bench.jsonl", progress, fresh)
    summary = _summarise(rows)
    fits = _time_exponents(summary)
    machine = machine_info()
    ratios = _ratios(summary)
    result = {
        "machine": machine,
        "leg_radius": stack[0].leg_radius,  # [mm] the reference stack's legs
        "config": cfg.__dict__,
        "summary": summary,
        "exponents": fits,
        "speedups": ratios,
    }
    write_csv(out / "ik_bench.csv", rows)
    (out / "ik_bench.json").write_text(json.dumps(result, indent=2, default=str))
    md = _markdown(cfg, machine, summary, ratios, fits, len(targets), len(sp_targets))
    (out / "ik_bench.md").write_text("\n".join(md))
    return result


def _scaling_jobs(cfg: BenchConfig) -> list[_Job]:
    """Section 2: a few methods on random reachable targets of each stack size."""
    scale_methods = [
        Method(DEFAULT, {}),
        Method("ip, 1 start", {"method": "ip", "starts": 1}),
        Method(SLSQP, {"method": "slsqp", "starts": 1}),
    ]
    if cfg.ipopt and _ipopt_ok():
        scale_methods.append(Method(IPOPT1, {"method": "ipopt", "starts": 1}))
    jobs: list[_Job] = []
    for n in cfg.sizes:
        st = Stack.reference(n)
        tg = random_planar_targets(st, cfg.per_size, cfg.rng + 100 * n, phis=cfg.phis)
        # SLSQP fails and takes seconds per solve beyond n = 32: not worth the minutes
        jobs += [
            (st, tg, m, "scaling", 0)
            for m in scale_methods
            if not (m.kwargs.get("method") == "slsqp" and n > 32)
        ]
    return jobs


def _geometry_jobs(cfg: BenchConfig) -> list[_Job]:
    """Section 3: random asymmetric stacks, several n and phi, against IPOPT."""
    geo_methods = [Method(DEFAULT, {})]
    if cfg.ipopt and _ipopt_ok():
        geo_methods += [
            Method(IPOPT1, {"method": "ipopt", "starts": 1}),
            Method(IPOPT8, {"method": "ipopt", "starts": 8, "rng": 0}),
        ]
    jobs: list[_Job] = []
    for n in cfg.geo_sizes:
        offset = 0
        for g in range(cfg.geo_stacks):
            st = random_stack(n, cfg.rng + 1000 * n + g)
            tg = random_planar_targets(
                st, cfg.geo_per_stack, cfg.rng + 1000 * n + 10 * g, phis=cfg.phis
            )
            jobs += [(st, tg, m, "geometries", offset) for m in geo_methods]
            offset += len(tg)
    return jobs


def _spatial_jobs(cfg: BenchConfig, stack: Stack, sp_targets: Sequence[Any]) -> list[_Job]:
    """Section 4: the spatial methods (IPOPT as the independent reference when present)."""
    methods = [
        Method(DEFAULT, {}),
        Method(SLSQP, {"method": "slsqp", "starts": 1}),
        Method("sqp, 1 start", {"method": "sqp", "starts": 1}),
        Method("sqp, 5 structured starts", {"method": "sqp", "starts": 5}),
        Method("sqp, 12 starts (the former spatial default)", {"method": "sqp"}),
    ]
    if cfg.ipopt and _ipopt_ok():  # the independent reference for "within 0.1 %"
        methods += [
            Method(IPOPT1, {"method": "ipopt", "starts": 1}),
            Method(IPOPT8, {"method": "ipopt", "starts": 8, "rng": 0}),
        ]
    return [(stack, sp_targets, m, "spatial", 0) for m in methods]


def _run_jobs(jobs: list[_Job], ckpt: Path, progress: bool, fresh: bool) -> list[dict]:
    """One row per (job, target) solve, checkpointed to ``ckpt`` (started over if ``fresh``)."""
    tasks: list[tuple[int, int]] = []
    for j, job in enumerate(jobs):
        n_t, limit = len(job[1]), job[2].max_targets
        tasks += [(j, i) for i in range(n_t if limit is None else min(n_t, limit))]
    warmed: set[int] = set()

    def one(task: tuple[int, int]) -> dict:
        j, i = task
        st, tg, m, section, offset = jobs[j]
        if m.kwargs.get("method") == "ipopt" and j not in warmed:
            solve_ik(st, tg[0], **m.kwargs)  # build and cache the CasADi solver first
            warmed.add(j)
        return _solve_row(st, tg[i], offset + i, m, section)

    def key(task: tuple[int, int]) -> dict:
        st, tg, m, section, offset = jobs[task[0]]
        return {
            "section": section,
            "n": st.n,
            "method": m.label,
            "target": offset + task[1],
            "at": target_to_dict(tg[task[1]]),
        }

    if fresh and ckpt.exists():
        ckpt.unlink()
    return checkpointed_map(
        one,
        tasks,
        key=key,
        encode=lambda row: row,
        decode=lambda row: row,
        checkpoint=ckpt,
        progress=progress,
        desc="bench",
    )


def _time_exponents(summary: list[dict]) -> dict[str, float]:
    """Fitted exponent of median time vs n per method of the scaling section."""
    fits = {}
    for label in {s["method"] for s in summary if s["section"] == "scaling"}:
        pts = sorted(
            (s["n"], s["median_ms"])
            for s in summary
            if s["section"] == "scaling" and s["method"] == label
        )
        if len(pts) >= 2:
            x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
            fits[label] = float(np.polyfit(x, y, 1)[0])
    return fits


def _markdown(
    cfg: BenchConfig,
    machine: dict[str, Any],
    summary: list[dict],
    ratios: list[dict],
    fits: dict[str, float],
    n_planar: int,
    n_spatial: int,
) -> list[str]:
    """Lines of ``ik_bench.md``: machine, then one table per section."""
    cols = [
        "method",
        "targets",
        "success_rate",
        "within_0.1%",
        "median_gap_%",
        "max_gap_%",
        "median_ms",
        "p90_ms",
        "median_nit",
    ]
    return [
        "# stackik solver benchmark",
        "",
        f"Machine: {machine.get('cpu', machine['processor'])}, {machine['cpus']} CPUs, "
        f"{machine['platform']}; Python {machine['python']}, NumPy {machine['numpy']}, "
        f"SciPy {machine['scipy']}. Date: {machine['date']}.",
        "",
        "Success = independent check (target within 1e-6 mm / 1e-8 rad, limits within 1e-6 mm). "
        "FN gap relative to the best FN any method found for that target. Times are wall "
        "time per solve_ik call, including starts and the final check.",
        "",
        f"## Planar, n = 4 ({n_planar} targets: the paper's 3 + random reachable, "
        f"phi in {list(cfg.phis)})",
        "",
        _md_table([s for s in summary if s["section"] == "planar"], cols),
        "",
        "Speed-ups measured in this run (median time of the baseline / median time of the method):",
        "",
        _md_table(ratios, ["method", "baseline", "method_ms", "baseline_ms", "speedup"]),
        "",
        "## Scaling in n (planar, random reachable targets)",
        "",
        _md_table([s for s in summary if s["section"] == "scaling"], ["n", *cols]),
        "",
        "Fitted exponent of median time vs n: "
        + ", ".join(f"{k}: {v:.2f}" for k, v in sorted(fits.items())),
        "",
        f"## Other geometries ({cfg.geo_stacks} random asymmetric stacks per n, "
        f"{cfg.geo_per_stack} random reachable targets each, phi in {list(cfg.phis)})",
        "",
        _md_table([s for s in summary if s["section"] == "geometries"], ["n", *cols]),
        "",
        f"## Spatial, n = 4 ({n_spatial} random reachable 6-DOF targets)",
        "",
        _md_table([s for s in summary if s["section"] == "spatial"], cols),
        "",
        "Re-run: `stackik bench --out benchmarks/results` (or `python benchmarks/bench_ik.py`).",
        "",
    ]


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point of ``stackik bench``."""
    ap = argparse.ArgumentParser(prog="stackik bench", description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    ap.add_argument("--quick", action="store_true", help="a few targets only (smoke test)")
    ap.add_argument("--n-random", type=int, default=None, help="random planar n=4 targets")
    ap.add_argument("--sizes", type=int, nargs="+", default=None, help="stack sizes to scale over")
    ap.add_argument("--no-ipopt", action="store_true", help="skip IPOPT even if installed")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-progress", action="store_true")
    ap.add_argument("--fresh", action="store_true", help="ignore the checkpoint of an earlier run")
    args = ap.parse_args(argv)
    cfg = BenchConfig.quick() if args.quick else BenchConfig()
    if args.n_random is not None:
        cfg.n_random = args.n_random
    if args.sizes is not None:
        cfg.sizes = tuple(args.sizes)
    cfg.ipopt = not args.no_ipopt
    cfg.rng = args.seed
    res = run_benchmark(cfg, args.out, progress=not args.no_progress, fresh=args.fresh)
    print((args.out / "ik_bench.md").read_text())
    _ = res
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
