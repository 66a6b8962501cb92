"""Benchmark of stackik.paths.solve_path against independent per-waypoint solves.

Random straight and curved paths (quadratic Bezier through a random control target)
between random reachable targets (:mod:`stackik.sampling`), n = 4, 8, 16, planar and
spatial, ``max_jump = (60 mm, 0.3 rad)``. For every path, in the same run and one after
the other:

* ``independent``: the default multi-start ``solve_ik`` at every waypoint (the per-waypoint
  optimum; its poses jump between folds);
* ``naive warm`` (planar): ``solve_ik(x0=previous pose, starts=1)``, the naive continuation;
* ``fast`` and ``global`` modes of ``solve_path``.

Measured: complete paths (and the break index of the others), every reached pose checked
again with ``check_pose``, the largest step in units of max_jump (must be <= 1), steps
above max_jump, mean FN along the path against the mean of the independent optima over
the same waypoints, and wall time per waypoint (ratio to independent solves). Writes
``path_bench.json`` (every path), ``path_bench.csv`` and ``path_bench.md`` (tables).

Usage: ``python benchmarks/bench_path.py [--quick] [--only planar:4,...] [--out DIR]``
(``--only``: the rows of those kinds and sizes, written as ``path_bench_partial.*`` so
that a partial run never replaces the full run's files; give it a scratch ``--out``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np

from stackik._io import write_csv
from stackik.check import check_pose
from stackik.geometry import Stack
from stackik.paths import PathResult, interpolate_targets, solve_path
from stackik.paths.interpolate import slerp
from stackik.sampling import random_reachable_targets, random_spatial_targets
from stackik.solve import solve_ik
from stackik.targets import PlanarTarget, SpatialTarget, Target

MAX_JUMP = (60.0, 0.3)
SEED = 2024
#: Fast mode runs each path this many times and reports the median time (the same poses
#: every time, checked): a fast path takes a few milliseconds, where one interruption on
#: a shared machine moves a single timing by tens of percent; its independent solves
#: (tens of solves) average such noise out by themselves.
FAST_REPEATS = 3

#: (kind, n, straight paths, curved paths, local paths, waypoints, run global mode)
FULL = [
    ("planar", 4, 3, 3, 0, 60, True),
    ("planar", 8, 3, 3, 0, 60, True),  # as the outside check: n = 8, 60 waypoints
    ("planar", 16, 3, 3, 0, 60, True),
    ("spatial", 4, 2, 2, 0, 16, True),
    ("spatial", 8, 1, 1, 0, 12, True),
    # a spatial default solve takes 3-5 s at n = 16: one short path
    ("spatial", 16, 0, 0, 1, 8, True),
    # long spatial paths (fast mode only: their independent solves alone take ~1 min):
    # with 8-16 waypoints the first waypoint's default solve caps the speed-up at m
    ("spatial", 4, 1, 1, 0, 60, False),
    ("spatial", 8, 1, 1, 0, 60, False),
    ("spatial", 16, 0, 0, 1, 60, False),
]
QUICK = [
    ("planar", 4, 1, 1, 0, 30, True),
    ("planar", 8, 1, 1, 0, 30, True),
    ("spatial", 4, 1, 0, 0, 6, True),
]
#: A local path: from a random reachable target, this far in position [mm] and rotation.
LOCAL_STEP = (150.0, 0.15)


# =========================================================================================
# Paths
# =========================================================================================
def bezier(a: Target, c: Target, b: Target, m: int) -> list[Target]:
    """m waypoints of the quadratic Bezier curve a -> b with control c (orientation: slerp
    from a to b)."""
    out: list[Target] = []
    for s in np.linspace(0.0, 1.0, m):
        w = np.array([(1 - s) ** 2, 2 * s * (1 - s), s**2])
        if isinstance(a, PlanarTarget):
            assert isinstance(b, PlanarTarget) and isinstance(c, PlanarTarget)
            y = w[0] * a.y + w[1] * c.y + w[2] * b.y
            out.append(PlanarTarget(float(y[0]), float(y[1]), float(y[2]), a.phi))
        else:
            assert isinstance(b, SpatialTarget) and isinstance(c, SpatialTarget)
            P = w[0] * a.position + w[1] * c.position + w[2] * b.position
            out.append(SpatialTarget(P, slerp(a.rotation, b.rotation, float(s))))
    out[0], out[-1] = a, b
    return out


def local_target(a: Target, rng: np.random.Generator) -> Target:
    """A target ``LOCAL_STEP`` away from ``a`` in a random direction (and rotation)."""
    u = rng.normal(size=3)
    v = rng.normal(size=3)
    u, v = u / np.linalg.norm(u), v / np.linalg.norm(v)
    if isinstance(a, PlanarTarget):
        return PlanarTarget(a.rho + LOCAL_STEP[0] * u[0], a.z + LOCAL_STEP[0] * u[1],
                            a.theta + LOCAL_STEP[1] * np.sign(v[0]), a.phi)  # fmt: skip
    from scipy.spatial.transform import Rotation

    R = a.rotation @ Rotation.from_rotvec(LOCAL_STEP[1] * v).as_matrix()
    return SpatialTarget(a.position + LOCAL_STEP[0] * u, R)


def make_paths(
    kind: str, stack: Stack, straight: int, curved: int, local: int, m: int, seed: int
) -> list[tuple[str, list[Target]]]:
    count = 2 * straight + 3 * curved + local
    if kind == "planar":
        keys: list[Any] = random_reachable_targets(stack, count, rng=seed)
    else:
        keys = random_spatial_targets(stack, count, rng=seed)
    paths: list[tuple[str, list[Target]]] = []
    for i in range(straight):
        a, b = keys[2 * i], keys[2 * i + 1]
        paths.append(("straight", interpolate_targets([a, b], steps=m - 1)))
    for i in range(curved):
        a, c, b = keys[2 * straight + 3 * i : 2 * straight + 3 * i + 3]
        paths.append(("curved", bezier(a, c, b, m)))
    rng = np.random.default_rng(seed)
    for i in range(local):
        a = keys[2 * straight + 3 * curved + i]
        paths.append(("local", interpolate_targets([a, local_target(a, rng)], steps=m - 1)))
    return paths


# =========================================================================================
# Measurements
# =========================================================================================
def jump_ratio(q: np.ndarray, k: int) -> np.ndarray:
    """Largest per-variable step / max_jump between consecutive poses, shape (m-1,)."""
    nt = 2 if k == 3 else 3
    lim = np.array([MAX_JUMP[0]] * nt + [MAX_JUMP[1]] * (k - nt))
    return np.max(np.abs(np.diff(q, axis=0)) / lim, axis=(1, 2))  # type: ignore[no-any-return]


def path_record(stack: Stack, targets: list[Target], r: PathResult, ind_fn: np.ndarray) -> dict:
    c = r.completed
    valid = all(check_pose(stack, t, q).ok for t, q in zip(r.targets[:c], r.q[:c]))
    jr = jump_ratio(r.q[:c], r.q.shape[2]) if c > 1 else np.zeros(0)
    same = c > 0 and r.m == len(targets)
    fn_ref = float(np.mean(ind_fn[:c])) if same else math.nan
    return {
        "complete": r.success,
        "completed": c,
        "status": r.status.value,
        "break_index": r.break_index,
        "valid": valid,
        "max_step_ratio": float(jr.max()) if jr.size else 0.0,
        "jumps_above": int(np.sum(jr > 1.0)),
        "mean_fn": r.mean_frobenius_norm,
        "fn_ratio": r.mean_frobenius_norm / fn_ref if same else math.nan,
        "time_s": r.time,
        "first_s": float(r.info.get("first_solve_s", 0.0)),
        "ms_per_waypoint": 1e3 * r.time / len(targets),
        "info": r.info,
        "message": r.message if not r.success else "",
    }


def run_path(kind: str, n: int, shape: str, idx: int, stack: Stack, targets: list[Target],
             do_global: bool) -> dict:  # fmt: skip
    planar = kind == "planar"
    k = 3 if planar else 6
    rec: dict[str, Any] = {"kind": kind, "n": n, "shape": shape, "path": idx, "m": len(targets)}
    # independent default solves (the per-waypoint optima)
    t0 = time.perf_counter()
    ind = [solve_ik(stack, targets[0])]
    t_ind0 = time.perf_counter() - t0  # waypoint 0 (a fast path runs the same solve)
    ind += [solve_ik(stack, t) for t in targets[1:]]
    t_ind = time.perf_counter() - t0
    ok = np.array([r.success for r in ind])
    fn = np.array([r.frobenius_norm if r.success else math.nan for r in ind])
    first_bad = int(np.argmin(ok)) if not ok.all() else None
    q_ind = np.stack([r.q for r in ind])
    reach = len(targets) if first_bad is None else first_bad
    jr = jump_ratio(q_ind[:reach], k) if reach > 1 else np.zeros(0)
    rec["independent"] = {
        "all_reachable": bool(ok.all()),
        "first_unreachable": first_bad,
        "mean_fn": float(np.nanmean(fn)),
        "jumps_above": int(np.sum(jr > 1.0)),
        "max_step_ratio": float(jr.max()) if jr.size else 0.0,
        "time_s": t_ind,
        "first_s": t_ind0,
        "ms_per_waypoint": 1e3 * t_ind / len(targets),
    }
    if planar:  # the naive continuation of the issue: one warm start per waypoint
        t0 = time.perf_counter()
        q = [ind[0].q]
        for t in targets[1:]:
            r = solve_ik(stack, t, x0=q[-1], starts=1)
            q.append(r.q)
        t_warm = time.perf_counter() - t0
        jr = jump_ratio(np.stack(q)[:reach], k) if reach > 1 else np.zeros(0)
        rec["naive_warm"] = {
            "jumps_above": int(np.sum(jr > 1.0)),
            "max_step_ratio": float(jr.max()) if jr.size else 0.0,
            "ms_per_waypoint": 1e3 * t_warm / len(targets),
        }
    runs = [solve_path(stack, targets, max_jump=MAX_JUMP, mode="fast") for _ in range(FAST_REPEATS)]
    if any(not np.array_equal(r.q, runs[0].q, equal_nan=True) for r in runs[1:]):
        raise AssertionError(f"{kind} n = {n} path {idx}: fast mode gave different poses")
    fast = sorted(runs, key=lambda r: r.time)[len(runs) // 2]  # the median time
    rec["fast"] = path_record(stack, targets, fast, fn)
    if do_global:
        glob = solve_path(stack, targets, max_jump=MAX_JUMP, mode="global")
        rec["global"] = path_record(stack, targets, glob, fn)
    return rec


# =========================================================================================
# Summary
# =========================================================================================
def summarise(records: list[dict]) -> list[dict]:
    rows = []
    groups: dict[tuple[str, int, int], list[dict]] = {}
    for r in records:
        groups.setdefault((r["kind"], r["n"], r["m"]), []).append(r)
    for (kind, n, _), recs in groups.items():
        t_ind = sum(r["independent"]["time_s"] for r in recs)
        wps = sum(r["m"] for r in recs)
        for mode in ("fast", "global"):
            rs = [r[mode] for r in recs if mode in r]
            if not rs:
                continue
            t_mode = sum(x["time_s"] for x in rs)
            t_ind_mode = sum(r["independent"]["time_s"] for r in recs if mode in r)
            ratios = [x["fn_ratio"] for x in rs if not math.isnan(x["fn_ratio"])]
            reachable = [r for r in recs if mode in r and r["independent"]["all_reachable"]]
            rows.append(
                {
                    "kind": kind,
                    "n": n,
                    "mode": mode,
                    "paths": len(rs),
                    "waypoints": recs[0]["m"],
                    "complete": sum(x["complete"] for x in rs),
                    "reachable_paths": len(reachable),
                    "complete_of_reachable": sum(r[mode]["complete"] for r in reachable),
                    "all_poses_valid": all(x["valid"] for x in rs),
                    "jumps_above_max": sum(x["jumps_above"] for x in rs),
                    "max_step_ratio": max(x["max_step_ratio"] for x in rs),
                    "fn_ratio_mean": float(np.mean(ratios)) if ratios else math.nan,
                    "fn_ratio_max": float(np.max(ratios)) if ratios else math.nan,
                    "ms_per_waypoint": 1e3 * t_mode / sum(r["m"] for r in recs if mode in r),
                    "independent_ms_per_waypoint": 1e3 * t_ind / wps,
                    "speedup": t_ind_mode / t_mode,
                    # waypoints 1.. only: the first waypoint's default solve left out of
                    # both (fast mode; global mode solves every waypoint's default)
                    "speedup_steps": (
                        t_ind_mode - sum(r["independent"]["first_s"] for r in recs if mode in r)
                    )
                    / (t_mode - sum(x["first_s"] for x in rs))
                    if mode == "fast"
                    else None,
                    "steps_ms_per_waypoint": 1e3
                    * (t_mode - sum(x["first_s"] for x in rs))
                    / sum(r["m"] - 1 for r in recs if mode in r)
                    if mode == "fast"
                    else None,
                    "bounded_steps": sum(x["info"].get("bounded", 0) for x in rs),
                    "pc_steps": sum(x["info"].get("pc", 0) for x in rs),
                    "warm_steps": sum(x["info"].get("warm", 0) for x in rs),
                    "sqp_fallbacks": sum(x["info"].get("sqp_fallback", 0) for x in rs),
                    "breaks": [
                        f"path {r['path']}: index {r[mode]['break_index']} ({r[mode]['status']})"
                        for r in recs
                        if mode in r and not r[mode]["complete"]
                    ],
                }
            )
        ind_jumps = sum(r["independent"]["jumps_above"] for r in recs)
        paths_jumping = sum(r["independent"]["jumps_above"] > 0 for r in recs)
        naive = [r["naive_warm"] for r in recs if "naive_warm" in r]
        rows.append(
            {
                "kind": kind,
                "n": n,
                "mode": "independent",
                "paths": len(recs),
                "waypoints": recs[0]["m"],
                "jumps_above_max": ind_jumps,
                "paths_with_jumps": paths_jumping,
                "max_step_ratio": max(r["independent"]["max_step_ratio"] for r in recs),
                "ms_per_waypoint": 1e3 * t_ind / wps,
                "naive_warm_paths_with_jumps": sum(x["jumps_above"] > 0 for x in naive)
                if naive
                else None,
                "naive_warm_max_step_ratio": max(
                    (x["max_step_ratio"] for x in naive), default=None
                ),
            }
        )
    return rows


def flatten(rec: dict) -> dict:
    """One CSV row per path: its identity, then ``<mode>_<measure>`` columns."""
    row = {k: rec[k] for k in ("kind", "n", "shape", "path", "m")}
    for mode in ("independent", "naive_warm", "fast", "global"):
        for k, v in rec.get(mode, {}).items():
            if not isinstance(v, dict):
                row[f"{mode}_{k}"] = v
    return row


def markdown(rows: list[dict], meta: dict) -> str:
    out = [
        "# Path benchmark (stackik.paths.solve_path)",
        "",
        f"Command: `{meta['command']}`  ",
        f"Run: {meta['date']}, {meta['machine']}, {meta['total_s']:.0f} s. max_jump = "
        f"({MAX_JUMP[0]:g} mm, {MAX_JUMP[1]:g} rad); seed {SEED}. Times are wall times "
        "measured in the same run, path by path (independent solves, then the modes), on a "
        f"shared machine: compare ratios, not absolute numbers. Fast mode: the median of "
        f"{FAST_REPEATS} runs of each path (the same poses each time).",
        "",
        "FN ratio = mean FN along the path / mean FN of the independent default solves at "
        "the same waypoints (over the waypoints the path reached). Speed-up = time of the "
        "independent solves / time of the mode (a fast path's time includes the default "
        "solve of its first waypoint: with m waypoints the speed-up stays below about m). "
        "Steps = the same without waypoint 0 (its default solve left out of both times; "
        "fast mode: the cost of the continuation itself, reanchoring solves included). "
        "Continuation steps = warm steps made by the predictor-corrector step / all warm "
        "steps (the others: a barrier solve). Max step = largest change of a platform "
        "variable between consecutive waypoints, in units of max_jump.",
        "",
        "| paths | mode | complete | all poses valid | steps > max_jump | max step | FN ratio "
        "mean (max) | ms / waypoint | speed-up | steps: ms / waypoint, speed-up | "
        "continuation steps | bounded steps (SQP fallbacks) | breaks |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if r["mode"] == "independent":
            continue
        steps = "-"
        if r["speedup_steps"] is not None:
            steps = f"{r['steps_ms_per_waypoint']:.2f}, {r['speedup_steps']:.1f}x"
        out.append(
            f"| {r['kind']} n={r['n']}, {r['paths']} x {r['waypoints']} wp | {r['mode']} | "
            f"{r['complete']}/{r['paths']} ({r['complete_of_reachable']}/"
            f"{r['reachable_paths']} reachable) | {r['all_poses_valid']} | "
            f"{r['jumps_above_max']} | {r['max_step_ratio']:.3f} | "
            f"{r['fn_ratio_mean']:.4f} ({r['fn_ratio_max']:.4f}) | {r['ms_per_waypoint']:.2f} | "
            f"{r['speedup']:.1f}x | {steps} | {r['pc_steps']}/{r['warm_steps']} | "
            f"{r['bounded_steps']} ({r['sqp_fallbacks']}) | "
            f"{'; '.join(r['breaks']) or '-'} |"
        )
    out += [
        "",
        "Independent per-waypoint solves (the problem the modes solve):",
        "",
        "| paths | ms / waypoint | paths with a step > max_jump | steps > max_jump | "
        "largest step | naive warm start: paths with a step > max_jump (largest step) |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        if r["mode"] != "independent":
            continue
        naive = (
            "-"
            if r["naive_warm_paths_with_jumps"] is None
            else f"{r['naive_warm_paths_with_jumps']}/{r['paths']} "
            f"({r['naive_warm_max_step_ratio']:.2f})"
        )
        out.append(
            f"| {r['kind']} n={r['n']}, {r['waypoints']} wp | {r['ms_per_waypoint']:.2f} | "
            f"{r['paths_with_jumps']}/{r['paths']} | {r['jumps_above_max']} | "
            f"{r['max_step_ratio']:.2f} | {naive} |"
        )
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a few small paths")
    ap.add_argument(
        "--only",
        default=None,
        help="only these rows, KIND:N comma-separated (e.g. planar:4); seeds as in the full "
        "run; written as path_bench_partial.*",
    )
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = ap.parse_args(argv)
    only = None
    if args.only:
        only = set()
        for item in args.only.split(","):
            kind, _, n = item.partition(":")
            if kind not in ("planar", "spatial") or not n.isdigit():
                ap.error(f"--only: expected KIND:N (planar:4, spatial:8, ...), got {item!r}")
            only.add((kind, int(n)))
    t_all = time.perf_counter()
    solve_ik(Stack.reference(2), PlanarTarget(0.0, 700.0, 0.0))  # compile / load kernels
    solve_ik(Stack.reference(2), PlanarTarget(0.0, 700.0, 0.0).to_spatial())
    records = []
    for j, (kind, n, straight, curved, local, m, do_global) in enumerate(
        QUICK if args.quick else FULL
    ):
        if only is not None and (kind, n) not in only:
            continue  # (the seed stays the row's: SEED + its index in the full list)
        stack = Stack.reference(n)
        paths = make_paths(kind, stack, straight, curved, local, m, SEED + j)
        for i, (shape, targets) in enumerate(paths):
            rec = run_path(kind, n, shape, i, stack, targets, do_global)
            records.append(rec)
            f = rec["fast"]
            print(
                f"{kind} n={n} path {i} ({shape}, {m} wp): fast {f['status']} "
                f"{f['completed']}/{m}, FN ratio {f['fn_ratio']:.4f}, "
                f"{f['ms_per_waypoint']:.2f} ms/wp vs {rec['independent']['ms_per_waypoint']:.2f}"
                + (
                    f"; global {rec['global']['status']} FN ratio {rec['global']['fn_ratio']:.4f}"
                    if "global" in rec
                    else ""
                ),  # fmt: skip
                flush=True,
            )
    rows = summarise(records)
    meta = {
        "command": "python benchmarks/bench_path.py"
        + (" --quick" if args.quick else "")
        + (f" --only {args.only}" if args.only else ""),
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}",
        "total_s": time.perf_counter() - t_all,
        "max_jump": MAX_JUMP,
        "seed": SEED,
        "leg_radius": Stack.reference().platforms[0].leg_radius,  # [mm]
    }
    args.out.mkdir(parents=True, exist_ok=True)
    name = "path_bench_quick" if args.quick else "path_bench"
    if only is not None:
        name = "path_bench_partial"
    (args.out / f"{name}.json").write_text(
        json.dumps({"meta": meta, "summary": rows, "paths": records}, indent=1, default=str)
    )
    flat = [flatten(r) for r in records]
    write_csv(args.out / f"{name}.csv", flat)
    (args.out / f"{name}.md").write_text(markdown(rows, meta))
    print(markdown(rows, meta))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
