"""Self-leg clearance: least-FN IK on legs of a realistic size against IPOPT with the same
rows (docs/clearance.md, issue 29).

Run: ``python benchmarks/bench_clearance.py [--count 12] [--seed 2900] [--ref-starts 32]
[--cases spatial4,spatial6,planar4,planar8] [--radius 12] [--out benchmarks/results]``;
writes ``clearance_bench.{csv,json,md}``.

Targets. Per case (mode and n), candidate k is drawn with ``rng = seed + k`` (spatial:
:func:`stackik.sampling.random_spatial_targets`; planar:
:func:`stackik.sampling.random_planar_targets` in the plane ``phi = 2 pi k / count``) on the
reference stack (legs of zero radius) and solved there with the default ``solve_ik``
(timed: the zero-radius reference; one untimed solve per method on another target comes
first). Spatial cases keep the first ``--count`` candidates
(k = 0, 1, ..., at most ``--max-draws`` x count) whose zero-radius optimum has two legs
of one platform closer than ``2 --radius`` mm axis to axis, i.e. those where the radius
changes the answer. Planar cases keep the first ``--count`` candidates whatever they do
(planar legs of one platform stay >= 48 mm apart on this geometry: the self-leg rows change
nothing; the table says how many zero-radius optima collided, self legs and any body: a
folded planar stack of 8 can touch its own upper plates, which no solver constrains).

Per kept target, on the same stack with ``leg_radius = --radius`` on every platform: the
default ``solve_ik`` (timed), ``method="sqp"``, ``method="slsqp"``, IPOPT from 1 and from 8
starts (``method="ipopt"``: the self-leg rows written in CasADi) and IPOPT from
``--ref-starts`` starts (rng ``1000 + k``). The best known FN is the least over every
success of the row that passes the re-check below.

Re-check. Every pose called a success is re-checked in this file: the target and limits by
``check_pose`` on the zero-radius stack (so the product's clearance code is not used), and
every pair of legs of one platform and of adjacent platforms by an exact segment-segment
distance written here (:func:`segment_distance`: the interior stationary point when it lies
in the unit square, else the least of the four endpoint-to-segment distances; no
sampling). A success with two legs closer than ``2 radius - 1e-6`` mm or a failed check is
a **false success**.

Columns: success rate, false successes, share within 0.5 % of the best known FN, median
time, speed-up against IPOPT-8 (median of per-target ratios ``t_ipopt8 / t``, same run)
and time against the zero-radius default solve (median of per-target ratios ``t / t0``).
"""

from __future__ import annotations

import argparse
import itertools
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
from _results import method_columns, write_results

from stackik import PlatformGeometry, Stack, check_pose, clearances, solve_ik
from stackik.bench import machine_info
from stackik.kinematics import lift_planar
from stackik.rotations import euler_zyx
from stackik.sampling import random_planar_targets, random_spatial_targets
from stackik.targets import PlanarTarget

CASES = {"spatial4": (False, 4), "spatial6": (False, 6), "planar4": (True, 4), "planar8": (True, 8)}
WITHIN = 5e-3  # "best known" within 0.5 %
TOL = 1e-6  # [mm] a success closer than 2 r - TOL is false
LABELS = ("default", "sqp", "slsqp", "ipopt1", "ipopt8", "ipopt_ref")


# ---------------------------------------------------------------------------------------
# exact distances, written apart from stackik.distance / stackik._compiled.self_legs
# ---------------------------------------------------------------------------------------
def _point_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    d = b - a
    dd = float(d @ d)
    t = 0.0 if dd == 0.0 else min(1.0, max(0.0, float((p - a) @ d) / dd))
    return float(np.linalg.norm(p - (a + t * d)))


def segment_distance(p0: np.ndarray, p1: np.ndarray, q0: np.ndarray, q1: np.ndarray) -> float:
    """Exact distance [mm] of segments p0-p1 and q0-q1: |P(s) - Q(t)| is convex on the unit
    square, so its minimum is the interior stationary point (when the segments are not
    parallel and it lies inside) or on the boundary, where one parameter is 0 or 1 and the
    distance is an endpoint-to-segment distance."""
    u, v, w = p1 - p0, q1 - q0, p0 - q0
    a, b, c = float(u @ u), float(u @ v), float(v @ v)
    d, e = float(u @ w), float(v @ w)
    den = a * c - b * b
    best = min(
        _point_segment(p0, q0, q1),
        _point_segment(p1, q0, q1),
        _point_segment(q0, p0, p1),
        _point_segment(q1, p0, p1),
    )
    if den > 1e-14 * a * c:  # grad = 0: a s - b t + d = 0, b s - c t + e = 0
        s = (b * e - c * d) / den
        t = (a * e - b * d) / den
        if 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0:
            best = min(best, float(np.linalg.norm(w + s * u - t * v)))
    return best


def world_legs(stack: Stack, q: np.ndarray, phi: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Bottom and top joints (n, 6, 3) [mm] of every leg in the base frame."""
    q = np.asarray(q, float)
    P, R = (q[:, :3], euler_zyx(q[:, 3:])) if phi is None else lift_planar(q, phi)
    O, A = np.zeros(3), np.eye(3)
    B = np.empty((stack.n, 6, 3))
    T = np.empty((stack.n, 6, 3))
    for i in range(stack.n):
        B[i] = O + stack.base_nodes[i] @ A.T
        O, A = O + A @ P[i], A @ R[i]
        T[i] = O + stack.top_nodes[i] @ A.T
    return B, T


def leg_gaps(stack: Stack, q: np.ndarray, phi: float | None) -> tuple[float, float]:
    """Least axis-to-axis distance [mm] of two legs of one platform, and of legs of
    adjacent platforms."""
    B, T = world_legs(stack, q, phi)
    own = min(
        segment_distance(B[i, k], T[i, k], B[i, m], T[i, m])
        for i in range(stack.n)
        for k, m in itertools.combinations(range(6), 2)
    )
    adj = min(
        (
            segment_distance(B[i, k], T[i, k], B[i + 1, m], T[i + 1, m])
            for i in range(stack.n - 1)
            for k, m in itertools.product(range(6), range(6))
        ),
        default=math.inf,
    )
    return own, adj


# ---------------------------------------------------------------------------------------
def _target(planar: bool, stack: Stack, k: int, count: int, seed: int) -> Any:
    if planar:
        phi = 2 * math.pi * (k % count) / count
        return random_planar_targets(stack, 1, rng=seed + k, phis=(phi,))[0]
    return random_spatial_targets(stack, 1, rng=seed + k)[0]


def _timed(stack: Stack, target: Any, **kw: Any) -> tuple[Any, float]:
    t0 = time.perf_counter()
    r = solve_ik(stack, target, **kw)
    return r, time.perf_counter() - t0


def _row(
    name: str, k: int, target: Any, thin: Stack, fat: Stack, r0: Any, t0: float, args: Any
) -> dict[str, Any]:
    phi = target.phi if isinstance(target, PlanarTarget) else None
    gap0 = leg_gaps(thin, r0.q, phi)
    row: dict[str, Any] = {"case": name, "k": k, "fn_free": r0.frobenius_norm, "time_free": t0}
    row["gap_free"], row["adjacent_gap_free"] = gap0
    # descriptive only (stackik's own measure of every body pair, plates included)
    row["free_collides_any"] = bool(clearances(fat, r0.q, phi=phi).minimum < 0)
    runs = {
        "default": dict(),
        "sqp": dict(method="sqp"),
        "slsqp": dict(method="slsqp"),
        "ipopt1": dict(method="ipopt", starts=1),
        "ipopt8": dict(method="ipopt", starts=8),
        "ipopt_ref": dict(method="ipopt", starts=args.ref_starts, rng=1000 + k),
    }
    fns = []
    for label, kw in runs.items():
        r, dt = _timed(fat, target, **kw)
        ok = bool(r.success)
        indep = False
        if ok:
            own, adj = leg_gaps(fat, r.q, phi)
            limit = 2 * args.radius - TOL
            indep = bool(check_pose(thin, target, r.q).ok and own >= limit and adj >= limit)
            row[f"{label}_gap"] = own
        else:
            row[f"{label}_gap"] = math.nan
        row[f"{label}_success"] = ok
        row[f"{label}_false"] = ok and not indep
        row[f"{label}_fn"] = r.frobenius_norm if ok else math.nan
        row[f"{label}_time"] = dt
        if ok and indep:
            fns.append(r.frobenius_norm)
    row["best"] = min(fns) if fns else math.nan
    for label in runs:
        ok = row[f"{label}_success"] and not row[f"{label}_false"]
        row[f"{label}_within"] = bool(ok and row[f"{label}_fn"] <= row["best"] * (1 + WITHIN))
    row["fn_cost"] = row["best"] / r0.frobenius_norm - 1 if fns else math.nan
    return row


def _warm_up(planar: bool, thin: Stack, fat: Stack, args: Any) -> None:
    """One untimed solve per method (kernels loaded, IPOPT's symbolic set-up cached)."""
    target = _target(planar, thin, 0, args.count, args.seed - 1)
    solve_ik(thin, target)
    for kw in ({}, {"method": "sqp"}, {"method": "slsqp"}, {"method": "ipopt", "starts": 1}):
        solve_ik(fat, target, **kw)


def run_case(name: str, args: Any) -> list[dict[str, Any]]:
    planar, n = CASES[name]
    thin = Stack.reference(n, leg_radius=0.0)
    fat = Stack.uniform(PlatformGeometry.hexagonal(leg_radius=args.radius), n)
    _warm_up(planar, thin, fat, args)
    rows: list[dict[str, Any]] = []
    for k in range(args.max_draws * args.count):
        if len(rows) == args.count:
            break
        target = _target(planar, thin, k, args.count, args.seed)
        r0, t0 = _timed(thin, target)
        if not r0.success:
            continue
        phi = target.phi if planar else None
        if not planar and leg_gaps(thin, r0.q, phi)[0] >= 2 * args.radius:
            continue  # the radius does not change this target's optimum
        row = _row(name, k, target, thin, fat, r0, t0, args)
        rows.append(row)
        print(
            f"{name} {k}: free {row['fn_free']:.6g} gap {row['gap_free']:.1f} mm; "
            f"default {row['default_fn']:.6g} ({row['default_time'] * 1e3:.0f} ms) "
            f"ipopt8 {row['ipopt8_fn']:.6g} ({row['ipopt8_time'] * 1e3:.0f} ms) "
            f"best {row['best']:.6g}",
            flush=True,
        )
    return rows


def summary(rows: list[dict[str, Any]], radius: float) -> list[dict[str, Any]]:
    out = []
    for name in dict.fromkeys(r["case"] for r in rows):
        rs = [r for r in rows if r["case"] == name]
        feasible = [r for r in rs if np.isfinite(r["best"])]
        line: dict[str, Any] = {"case": name, "targets": len(rs), "feasible": len(feasible)}
        line["colliding_free"] = sum(r["gap_free"] < 2 * radius for r in rs)
        line["colliding_free_any"] = sum(r["free_collides_any"] for r in rs)
        line["last_draw"] = max(r["k"] for r in rs)
        line.update(method_columns(rs, feasible, LABELS))
        out.append(line)
    return out


def markdown(lines: list[dict[str, Any]], meta: dict[str, Any]) -> str:
    head = (
        "| case | targets (feasible) | zero-radius optima: self legs colliding (any body) | "
        "zero-radius median ms | "
        "method | success | false successes | within 0.5 % | median ms | speed-up vs "
        "IPOPT-8 | time / zero-radius solve |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|\n"
    )
    body = ""
    for s in lines:
        t, f = s["targets"], s["feasible"]
        for j, label in enumerate(LABELS):
            lead = (
                f"| {s['case']} | {t} ({f}) | {s['colliding_free']} "
                f"({s['colliding_free_any']}) | {s['free_median_ms']:.0f} "
                if j == 0
                else "| | | | "
            )
            body += (
                f"{lead}| {label} | {s[f'{label}_success']}/{t} | {s[f'{label}_false']} | "
                f"{s[f'{label}_within']}/{f} | {s[f'{label}_median_ms']:.0f} | "
                f"{s[f'{label}_speedup_vs_ipopt8']:.1f}x | {s[f'{label}_vs_free']:.1f}x |\n"
            )
    cost = ", ".join(f"{s['case']} {100 * s['median_fn_cost']:.2f} %" for s in lines)
    return (
        "# Self-leg clearance (benchmarks/bench_clearance.py)\n\n"
        f"`{meta['command']}` on {meta['machine']}. Legs of radius {meta['radius']:g} mm on "
        "every platform; spatial targets are those whose zero-radius default optimum has "
        f"two legs of a platform closer than {2 * meta['radius']:g} mm (planar: every drawn "
        "target). Best known = least FN over IPOPT from "
        f"{meta['ref_starts']} starts and every other success of the row; a success is "
        "re-checked with this file's exact segment distances (false: legs closer than "
        f"{2 * meta['radius']:g} mm - 1e-6 or a failed target/limit check). Times are wall "
        "times on a shared machine; ratios are medians of per-target ratios. `ipopt_ref` is "
        "the reference run (its time is that of --ref-starts starts). 'Any body': the "
        "zero-radius optimum's least clearance by `stackik.clearances` (plates and "
        "non-adjacent platforms included: bodies no solver constrains) on the 12 mm stack.\n\n"
        + head
        + body
        + f"\nMedian FN cost of the radius (best known / zero-radius optimum - 1): {cost}.\n"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=12)
    ap.add_argument("--seed", type=int, default=2900)
    ap.add_argument("--ref-starts", type=int, default=32)
    ap.add_argument("--cases", default="spatial4,spatial6,planar4,planar8")
    ap.add_argument("--radius", type=float, default=12.0)
    ap.add_argument("--max-draws", type=int, default=20)
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = ap.parse_args()
    if args.ref_starts < 32:
        ap.error("--ref-starts must be >= 32 (the best known needs many starts)")
    rows: list[dict[str, Any]] = []
    for name in args.cases.split(","):
        rows += run_case(name, args)
    lines = summary(rows, args.radius)
    meta = {
        "command": "python benchmarks/bench_clearance.py "
        f"--count {args.count} --seed {args.seed} --ref-starts {args.ref_starts} "
        f"--cases {args.cases} --radius {args.radius:g}",
        "machine": "{cpus} CPUs ({cpu}), {date}".format(**machine_info()),
        "ref_starts": args.ref_starts,
        "radius": args.radius,
    }
    write_results(args.out, "clearance_bench", meta, lines, rows, markdown(lines, meta))


if __name__ == "__main__":
    main()
