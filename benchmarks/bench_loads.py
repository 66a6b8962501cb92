"""Force-limited IK against IPOPT with the same force limits (docs/loads.md).

Run: ``python benchmarks/bench_loads.py [--count 12] [--seed 9100] [--ref-starts 32]
[--cases spatial4,planar4,planar8,spatial6] [--out benchmarks/results] [--stem
loads_bench]``; writes ``STEM.{csv,json,md}`` (``loads_bench``). A case may carry its own
count, ``--cases spatial4:20,spatial6:10``.

Per case (mode and n), ``--count`` targets, target k drawn with ``rng = seed + k``
(spatial: :func:`stackik.sampling.random_spatial_targets`; planar:
:func:`stackik.sampling.random_planar_targets` in the plane ``phi = 2 pi k / count``), on
reference platforms with 5 kg plates and 1.5 kg legs carrying a 4 kg payload (earth
gravity):

1. the unloaded default solve (no force limit) and its pose's peak leg force ``F``;
2. every platform's ``force_max`` set to ``0.85 F``: the limit binds at that optimum;
3. on that stack, with the load: the default ``solve_ik`` (timed), IPOPT from 1 and from 8
   starts (``method="ipopt"``: the forces lifted as variables with world-frame
   equilibrium equalities, a formulation written apart from stackik's eliminated-force
   rows), and IPOPT from ``--ref-starts`` starts for the best known FN (with every other
   successful pose of the row: the best known is the least FN of all);
4. every pose called a success is re-checked here by a statics model of this file (each
   cut body's equilibrium in the base frame, moments about the base origin, solved with
   ``numpy.linalg.solve``): a success with a leg over ``force_max (1 + 1e-6)`` or a
   limit or target miss would be a **false success**.

Times: the least of ``--repeat`` (3) runs of each solve, the reference's one run (a
shared machine: another process's burst inflates a single run). Columns: success rate,
share within 0.1 % of the best known FN, median time, the
speed-up against IPOPT-8 and the time against the unloaded default on the same target
(``solve_ik(free_stack, target)``: no load, no limit); both medians of per-target time
ratios, same run.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
from _results import targets, write_results

from stackik import Load, PlatformGeometry, Stack, check_pose, leg_forces, solve_ik
from stackik.bench import machine_info
from stackik.kinematics import lift_planar
from stackik.rotations import euler_zyx
from stackik.targets import PlanarTarget

CASES = {"spatial4": (False, 4), "spatial6": (False, 6), "planar4": (True, 4), "planar8": (True, 8)}
LOAD = Load(mass=4.0)
PLATE_MASS, LEG_MASS = 5.0, 1.5
BIND = 0.85  # force_max as a fraction of the unloaded optimum's peak force
WITHIN = 1e-3  # "best known" within 0.1 %


def world_forces(stack: Stack, q: np.ndarray, load: Load, phi: float | None) -> np.ndarray:
    """Leg forces (n, 6) [N], compression positive, from each cut body's equilibrium in the
    base frame with moments about the base origin (independent of stackik.loads)."""
    q = np.asarray(q, float)
    if phi is None:
        P, R = q[:, :3], euler_zyx(q[:, 3:])
    else:
        P, R = lift_planar(q, phi)
    n = stack.n
    O, A = [np.zeros(3)], [np.eye(3)]
    for i in range(n):
        O.append(O[-1] + A[-1] @ P[i])
        A.append(A[-1] @ R[i])
    T = [[O[i + 1] + A[i + 1] @ stack.top_nodes[i, k] for k in range(6)] for i in range(n)]
    B = [[O[i] + A[i] @ stack.base_nodes[i, k] for k in range(6)] for i in range(n)]
    g = load.g
    F_ext, M_ext = load.force, load.moment * 1000.0
    if load.frame == "end_effector":
        F_ext, M_ext = A[n] @ F_ext, A[n] @ M_ext
    out = np.empty((n, 6))
    half = 0.5 * stack.leg_mass
    for i in range(n):
        masses = [(half[i], T[i][k]) for k in range(6)]
        masses += [(stack.plate_mass[j], O[j + 1]) for j in range(i, n)]
        for j in range(i + 1, n):
            masses += [(half[j], p) for p in T[j] + B[j]]
        masses.append((load.mass, O[n] + A[n] @ load.com))
        F = F_ext + sum(m for m, _ in masses) * g
        M = M_ext + np.cross(O[n], F_ext) + sum(np.cross(r, m * g) for m, r in masses)
        G = np.empty((6, 6))
        for k in range(6):
            u = (T[i][k] - B[i][k]) / np.linalg.norm(T[i][k] - B[i][k])
            G[:3, k], G[3:, k] = u, np.cross(T[i][k], u)
        out[i] = -np.linalg.solve(G, np.concatenate([F, M]))
    return out


def independent_ok(stack: Stack, target: Any, q: np.ndarray) -> bool:
    """Target and limits by the product's check with no force limit, forces by
    :func:`world_forces`."""
    free = Stack(tuple(PlatformGeometry(**{**g.to_dict(), "force_max": math.inf})
                       for g in stack))  # fmt: skip
    phi = target.phi if isinstance(target, PlanarTarget) else None
    f = world_forces(stack, q, LOAD, phi)
    return bool(
        check_pose(free, target, q).ok
        and np.all(np.abs(f) <= stack.force_max[:, None] * (1 + 1e-6))
    )


def timed(repeat: int, *args: Any, **kw: Any) -> tuple[Any, float]:
    """``solve_ik(*args, **kw)`` and its least wall time [s] over ``repeat`` calls (the
    solves are deterministic: every call returns the same pose)."""
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = solve_ik(*args, **kw)
        best = min(best, time.perf_counter() - t0)
    return out, best


def run_case(
    name: str, count: int, seed: int, ref_starts: int, repeat: int = 1
) -> list[dict[str, Any]]:
    planar, n = CASES[name]
    g0 = PlatformGeometry.hexagonal(plate_mass=PLATE_MASS, leg_mass=LEG_MASS)
    free = Stack.uniform(g0, n)
    rows = []
    for k, target in enumerate(targets(planar, free, count, seed)):
        phi = target.phi if planar else None
        r0 = solve_ik(free, target, load=LOAD)
        if not r0.success:
            continue
        peak = float(np.abs(leg_forces(free, r0.q, LOAD, phi=phi)).max())
        g = PlatformGeometry.hexagonal(
            plate_mass=PLATE_MASS, leg_mass=LEG_MASS, force_max=BIND * peak
        )
        stack = Stack.uniform(g, n)
        # the unloaded default (no load, no limit), timed
        _, free_time = timed(repeat, free, target)
        row: dict[str, Any] = {
            "case": name, "k": k, "fn_free": r0.frobenius_norm, "peak": peak,
            "free_time": free_time,
        }  # fmt: skip
        runs = {
            "default": dict(),
            "ipopt1": dict(method="ipopt", starts=1),
            "ipopt8": dict(method="ipopt", starts=8),
            "ipopt_ref": dict(method="ipopt", starts=ref_starts, rng=1000 + k),
        }
        fns = []
        for label, kw in runs.items():
            r, dt = timed(1 if label == "ipopt_ref" else repeat, stack, target, load=LOAD, **kw)
            ok = bool(r.success)
            indep = independent_ok(stack, target, r.q) if ok else False
            row[f"{label}_success"] = ok
            row[f"{label}_false"] = ok and not indep
            row[f"{label}_fn"] = r.frobenius_norm if ok else math.nan
            row[f"{label}_time"] = dt
            if ok and indep:
                fns.append(r.frobenius_norm)
        row["best"] = min(fns) if fns else math.nan
        for label in runs:
            fn = row[f"{label}_fn"]
            row[f"{label}_within"] = bool(fn <= row["best"] * (1 + WITHIN))
        row["fn_cost"] = row["best"] / r0.frobenius_norm - 1 if fns else math.nan
        rows.append(row)
        print(
            f"{name} {k}: default {row['default_fn']:.6g} ({row['default_time'] * 1e3:.0f} ms) "
            f"ipopt8 {row['ipopt8_fn']:.6g} ({row['ipopt8_time'] * 1e3:.0f} ms) "
            f"best {row['best']:.6g}",
            flush=True,
        )
    return rows


def summary(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    out = []
    for name in dict.fromkeys(r["case"] for r in rows):
        rs = [r for r in rows if r["case"] == name]
        feasible = [r for r in rs if np.isfinite(r["best"])]
        line: dict[str, Any] = {"case": name, "targets": len(rs), "feasible": len(feasible)}
        for label in ("default", "ipopt1", "ipopt8"):
            line[f"{label}_success"] = sum(r[f"{label}_success"] for r in feasible)
            line[f"{label}_false"] = sum(r[f"{label}_false"] for r in rs)
            line[f"{label}_within"] = sum(r[f"{label}_within"] for r in feasible)
            line[f"{label}_median_ms"] = 1e3 * float(np.median([r[f"{label}_time"] for r in rs]))
        line["speedup_vs_ipopt8"] = float(
            np.median([r["ipopt8_time"] / r["default_time"] for r in rs])
        )
        line["time_vs_unloaded"] = float(
            np.median([r["default_time"] / r["free_time"] for r in rs])
        )
        line["free_median_ms"] = 1e3 * float(np.median([r["free_time"] for r in rs]))
        line["median_fn_cost"] = float(np.nanmedian([r["fn_cost"] for r in rs]))
        out.append(line)
    return out


def markdown(lines: list[dict[str, Any]], meta: dict[str, Any]) -> str:
    head = (
        "| case | targets (feasible) | default: success, within 0.1 %, median ms | "
        "IPOPT-1: success, within | IPOPT-8: success, within, median ms | "
        "default vs IPOPT-8 | unloaded default: median ms, loaded / unloaded | "
        "false successes | FN cost of the limit |\n"
        "|---|---|---|---|---|---|---|---|---|\n"
    )
    body = ""
    for s in lines:
        f = s["feasible"]
        false = s["default_false"] + s["ipopt1_false"] + s["ipopt8_false"]
        body += (
            f"| {s['case']} | {s['targets']} ({f}) | {s['default_success']}/{f}, "
            f"{s['default_within']}/{f}, {s['default_median_ms']:.0f} | "
            f"{s['ipopt1_success']}/{f}, {s['ipopt1_within']}/{f} | "
            f"{s['ipopt8_success']}/{f}, {s['ipopt8_within']}/{f}, "
            f"{s['ipopt8_median_ms']:.0f} | {s['speedup_vs_ipopt8']:.1f}x | "
            f"{s['free_median_ms']:.0f}, {s['time_vs_unloaded']:.2f}x | {false} | "
            f"{100 * s['median_fn_cost']:.2f} % |\n"
        )
    return (
        "# Force-limited IK (benchmarks/bench_loads.py)\n\n"
        f"`{meta['command']}` on {meta['machine']}. Every platform's `force_max` is "
        f"{BIND} x the peak leg force of the unloaded optimum (5 kg plates, 1.5 kg legs, "
        "4 kg payload, earth gravity); best known = least FN over IPOPT from "
        f"{meta['ref_starts']} starts and every other success of the row. Times are wall "
        f"times on a shared machine, each the least of {meta['repeat']} runs (the "
        "reference: one); the ratios are medians of per-target ratios (loaded / unloaded: "
        "the default with the load and the limits against the default on the same target "
        "with neither).\n\n" + head + body
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=12)
    ap.add_argument("--seed", type=int, default=9100)
    ap.add_argument("--ref-starts", type=int, default=32)
    ap.add_argument(
        "--cases", default="spatial4,planar4,planar8,spatial6",
        help="comma-separated NAME or NAME:COUNT (COUNT overrides --count for that case)",
    )  # fmt: skip
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    ap.add_argument("--stem", default="loads_bench", help="output file names STEM.{csv,json,md}")
    ap.add_argument(
        "--repeat", type=int, default=3,
        help="time each solve (but the reference) as the least of this many runs",
    )  # fmt: skip
    args = ap.parse_args()
    rows: list[dict[str, Any]] = []
    for case in args.cases.split(","):
        name, _, count = case.partition(":")
        if name not in CASES:
            raise SystemExit(f"--cases: unknown case {name!r}; choose from {sorted(CASES)}")
        count = int(count) if count else args.count
        rows += run_case(name, count, args.seed, args.ref_starts, args.repeat)
    lines = summary(rows)
    meta = {
        "command": "python benchmarks/bench_loads.py "
        f"--count {args.count} --seed {args.seed} --ref-starts {args.ref_starts} "
        f"--cases {args.cases} --repeat {args.repeat}"
        + ("" if args.stem == "loads_bench" else f" --stem {args.stem}"),
        "machine": "{cpus} CPUs ({cpu}), {date}".format(**machine_info()),
        "ref_starts": args.ref_starts,
        "repeat": args.repeat,
    }
    write_results(args.out, args.stem, meta, lines, rows, markdown(lines, meta))


if __name__ == "__main__":
    main()
