"""How often today's least-FN poses collide once the legs have a size (docs/clearance.md).

Run: ``python benchmarks/clearance_baseline.py [--count 30] [--seed 700] [--radius 12]
[--out benchmarks/results]``; writes ``clearance_baseline.{json,md}``.

For each mode at n = 4 (spatial; planar), ``--count`` targets, target k drawn with
``rng = seed + k`` (spatial: :func:`stackik.sampling.random_spatial_targets`; planar:
:func:`stackik.sampling.random_planar_targets` in the plane ``phi = 2 pi k / count``), on
the reference stack:

1. today's default solve (``solve_ik``, legs of zero radius): its pose's clearances with
   legs of ``--radius`` mm (the least axis-to-axis distance of two legs of a platform,
   the non-adjacent bodies), and how many poses collide;
2. the default solve on the same stack with ``leg_radius = --radius``: its verdict goes
   through the clearances (the solvers have no clearance constraint yet, so a colliding
   run is only skipped in favour of another start's pose); how many succeed and at what
   FN cost;
3. the adjacent-platform argument, numerically: the least axis distance between legs of
   adjacent platforms (a pair the check leaves out) over the solved poses and over random
   feasible poses;
4. the time of one ``stackik.clearances`` call at n = 4 and 16 (without and with four
   obstacles). The machine is shared: treat times as rough.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from stackik import (
    Box,
    Capsule,
    HalfSpace,
    PlatformGeometry,
    Sphere,
    Stack,
    clearances,
    solve_ik,
)
from stackik import distance as dist
from stackik.bench import machine_info
from stackik.clearance import plate_frames
from stackik.sampling import random_feasible_poses, random_planar_targets, random_spatial_targets

N = 4
OBSTACLES = [
    Sphere([300, 0, 600], 50),
    Box([0, 300, 500], [50, 50, 50]),
    HalfSpace([0, 0, -20], [0, 0, 1]),
    Capsule([-500, 0, 300], [-500, 0, 900], 20),
]


def _targets(mode: str, count: int, seed: int) -> list[Any]:
    stack = Stack.reference(N, leg_radius=0.0)
    if mode == "spatial":
        return [random_spatial_targets(stack, 1, rng=seed + k)[0] for k in range(count)]
    phis = [2 * math.pi * k / count for k in range(count)]
    return [random_planar_targets(stack, 1, rng=seed + k, phis=(phis[k],))[0] for k in range(count)]


def _legs(stack: Stack, q: np.ndarray, phi: float | None) -> tuple[np.ndarray, np.ndarray]:
    A, O = plate_frames(stack, q, phi)
    B = O[:-1, None] + np.einsum("nij,nkj->nki", A[:-1], stack.base_nodes)
    T = O[1:, None] + np.einsum("nij,nkj->nki", A[1:], stack.top_nodes)
    return B, T


def adjacent_leg_gap(stack: Stack, q: np.ndarray, phi: float | None) -> float:
    """Least axis-to-axis distance [mm] between legs of adjacent platforms."""
    B, T = _legs(stack, q, phi)
    pairs = list(itertools.product(range(6), range(6)))
    k = np.array([p[0] for p in pairs])
    m = np.array([p[1] for p in pairs])
    best = math.inf
    for i in range(stack.n - 1):
        d = dist.segment_segment(B[i, k], T[i, k], B[i + 1, m], T[i + 1, m])
        best = min(best, float(d.min()))
    return best


def _stats(values: list[float]) -> dict[str, float]:
    v = np.array(values, dtype=float)
    if v.size == 0:
        return {}
    return {
        "min": float(v.min()),
        "p10": float(np.percentile(v, 10)),
        "median": float(np.median(v)),
        "p90": float(np.percentile(v, 90)),
        "max": float(v.max()),
    }


def run_mode(mode: str, count: int, seed: int, radius: float) -> dict[str, Any]:
    thin = Stack.reference(N, leg_radius=0.0)
    fat = Stack.uniform(PlatformGeometry.hexagonal(leg_radius=radius), N)
    rows = []
    for k, target in enumerate(_targets(mode, count, seed)):
        phi = target.phi if mode == "planar" else None
        res = solve_ik(thin, target)
        row: dict[str, Any] = {"k": k, "seed": seed + k, "success": bool(res.success)}
        row["fn"] = float(res.frobenius_norm)
        c0 = clearances(thin, res.q, phi=phi)  # radius 0: axis distances
        c = clearances(fat, res.q, phi=phi)
        row["leg_axis_gap"] = c0.self_legs
        row["leg_axis_gap_by_platform"] = c0.self_legs_by_platform.tolist()
        row["non_adjacent_gap"] = c0.non_adjacent
        row["self_legs_with_radius"] = c.self_legs
        row["non_adjacent_with_radius"] = c.non_adjacent
        row["adjacent_legs_with_radius"] = c.adjacent_legs
        row["collides"] = bool(c.minimum < 0)
        row["closest"] = str(c.closest)
        row["adjacent_leg_gap"] = adjacent_leg_gap(thin, res.q, phi)
        res_r = solve_ik(fat, target)
        row["radius_success"] = bool(res_r.success)
        row["radius_fn"] = float(res_r.frobenius_norm)
        row["radius_min_clearance"] = clearances(fat, res_r.q, phi=phi).minimum
        rows.append(row)
    ok = [r for r in rows if r["success"]]
    coll = [r for r in ok if r["collides"]]
    rescued = [r for r in coll if r["radius_success"]]
    cost = [100 * (r["radius_fn"] / r["fn"] - 1) for r in rescued]
    false_succ = [r for r in rows if r["radius_success"] and r["radius_min_clearance"] < -1e-6]
    return {
        "mode": mode,
        "n": N,
        "targets": count,
        "solved": len(ok),
        "collide_with_radius": len(coll),
        "collide_self_legs": sum(r["self_legs_with_radius"] < 0 for r in ok),
        "collide_non_adjacent": sum(r["non_adjacent_with_radius"] < 0 for r in ok),
        "collide_adjacent_legs": sum(r["adjacent_legs_with_radius"] < 0 for r in ok),
        "leg_axis_gap": _stats([r["leg_axis_gap"] for r in ok]),
        "non_adjacent_gap": _stats([r["non_adjacent_gap"] for r in ok]),
        "adjacent_leg_gap": _stats([r["adjacent_leg_gap"] for r in ok]),
        "radius_success": sum(r["radius_success"] for r in rows),
        "radius_false_success": len(false_succ),
        "colliding_then_collision_free": len(rescued),
        "fn_cost_percent_of_those": _stats(cost),
        "rows": rows,
    }


def random_adjacent_gaps(count: int, seed: int) -> dict[str, Any]:
    """Adjacent-leg axis gaps over random feasible poses: planar (phi spread) and spatial
    (every variable uniform in a wide box, kept within the limits)."""
    stack = Stack.reference(N, leg_radius=0.0)
    gen = np.random.default_rng(seed)
    planar = []
    phis = gen.uniform(0, 2 * math.pi, 20)
    for phi in phis:  # a batch of poses per plane
        for q in random_feasible_poses(stack, count // len(phis), rng=gen, phi=float(phi)):
            planar.append(adjacent_leg_gap(stack, q, float(phi)))
    # spatial: the limits of a platform depend on its own variables only, so each
    # platform's row is drawn until it is feasible on its own
    one = Stack.reference(1, leg_radius=0.0)
    rows: list[np.ndarray] = []
    while len(rows) < count * N:
        cand = np.column_stack(
            [
                gen.uniform(-200, 200, (4096, 2)),
                gen.uniform(80, 450, 4096),
                gen.uniform(-math.pi, math.pi, 4096),  # any yaw
                gen.uniform(-0.8, 0.8, (4096, 2)),
            ]
        )
        ok = one.spatial_constraints(cand[:, None, :])[:, 0].min(axis=-1) >= 0
        rows.extend(cand[ok])
    poses = np.array(rows[: count * N]).reshape(count, N, 6)
    spatial = [adjacent_leg_gap(stack, q, None) for q in poses]
    top, base = stack.top_nodes[0], stack.base_nodes[1]
    gap = float(np.min(np.linalg.norm(top[:, None] - base[None], axis=-1)))
    bound = gap * math.sin(stack[0].joint_min)
    return {"planar": _stats(planar), "spatial": _stats(spatial), "poses": count, "bound": bound}


def timing(repeats: int) -> list[dict[str, Any]]:
    """Wall and CPU (this process) time per call; the CPU time is less disturbed by other
    jobs on a shared machine."""
    out = []
    for n in (4, 16):
        stack = Stack.uniform(PlatformGeometry.hexagonal(leg_radius=12.0), n)
        qs = random_feasible_poses(stack, 20, rng=1, phi=0.3)
        for obs in ((), OBSTACLES):
            clearances(stack, qs[0], obs, phi=0.3)
            t0, c0 = time.perf_counter(), time.process_time()
            for r in range(repeats):
                clearances(stack, qs[r % len(qs)], obs, phi=0.3)
            ms = (time.perf_counter() - t0) / repeats * 1e3
            cpu = (time.process_time() - c0) / repeats * 1e3
            out.append({"n": n, "obstacles": len(obs), "ms_per_call": ms, "cpu_ms_per_call": cpu})
    return out


def _fmt(s: dict[str, float]) -> str:
    if not s:
        return "-"
    return " / ".join(f"{s[k]:.1f}" for k in ("min", "p10", "median", "p90", "max"))


def markdown(data: dict[str, Any]) -> str:
    r = data["radius"]
    lines = [
        "# Clearance baseline: today's poses with legs of a size",
        "",
        f"Reference stack, n = {N}, {data['count']} targets per mode (target k: rng seed "
        f"{data['seed']} + k), leg radius {r:g} mm (two legs collide below {2 * r:g} mm "
        "axis to axis). Distances in mm: min / p10 / median / p90 / max over the solved "
        "targets. Command: `python benchmarks/clearance_baseline.py`.",
        "",
        "| mode | solved | collide (r) | self legs | adjacent legs | non-adjacent | "
        "least leg axis gap | "
        "non-adjacent gap (r = 0) | adjacent legs gap | solved with r | of the colliding, "
        "collision-free with r | FN cost of those [%] | false successes |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for m in data["modes"]:
        lines.append(
            f"| {m['mode']} | {m['solved']}/{m['targets']} | {m['collide_with_radius']} | "
            f"{m['collide_self_legs']} | {m['collide_adjacent_legs']} | "
            f"{m['collide_non_adjacent']} | "
            f"{_fmt(m['leg_axis_gap'])} | {_fmt(m['non_adjacent_gap'])} | "
            f"{_fmt(m['adjacent_leg_gap'])} | {m['radius_success']} | "
            f"{m['colliding_then_collision_free']} | {_fmt(m['fn_cost_percent_of_those'])} | "
            f"{m['radius_false_success']} |"
        )
    a = data["adjacent_random"]
    lines += [
        "",
        '"collide (r)": solved poses with a negative clearance once the legs have radius r; '
        '"solved with r": the default solve on the stack with leg_radius = r, whose verdict '
        "now includes the clearances (a colliding run is skipped for another start's pose; "
        'no solver constrains clearances yet); "false successes": poses it calls a '
        "success whose exact clearance is negative (must be 0).",
        "",
        "## Adjacent platforms: the joint-angle argument, numerically",
        "",
        "Adjacent legs' axes lie on opposite sides of their shared plate and never cross; "
        "they stay at least `|t - b| sin(joint_min)` apart (docs/clearance.md), "
        f"{a['bound']:.2f} mm on the reference geometry, so capsules of radius up to "
        f"{a['bound'] / 2:.2f} mm never meet. "
        f"Least axis-to-axis distance between legs of adjacent platforms over {a['poses']} "
        "random feasible poses per mode (planar: random phi; spatial: yaw anywhere, "
        "x, y in +-200 mm, z 80-450 mm, pitch and roll +-0.8 rad, kept within the limits):",
        "",
        f"- planar: {_fmt(a['planar'])}",
        f"- spatial: {_fmt(a['spatial'])}",
        "",
        "## Time of one `stackik.clearances` call",
        "",
        "| n | obstacles | wall ms per call | CPU ms per call |",
        "|---|---|---|---|",
    ]
    for t in data["timing"]:
        lines.append(
            f"| {t['n']} | {t['obstacles']} | {t['ms_per_call']:.2f} | {t['cpu_ms_per_call']:.2f} |"
        )
    lines += ["", f"Machine: {data['machine']} (shared with other jobs: times are rough).", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=30)
    ap.add_argument("--seed", type=int, default=700)
    ap.add_argument("--radius", type=float, default=12.0)
    ap.add_argument("--random-poses", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=200)
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = ap.parse_args(argv)
    modes = [run_mode(m, args.count, args.seed, args.radius) for m in ("spatial", "planar")]
    data = {
        "count": args.count,
        "seed": args.seed,
        "radius": args.radius,
        "modes": modes,
        "adjacent_random": random_adjacent_gaps(args.random_poses, args.seed),
        "timing": timing(args.repeats),
        "machine": machine_info(),
    }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "clearance_baseline.json").write_text(json.dumps(data, indent=1) + "\n")
    md = markdown(data)
    (args.out / "clearance_baseline.md").write_text(md)
    print(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
