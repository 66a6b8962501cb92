"""Obstacles: least-FN IK with a sphere, a truss member or a box beam across a leg of the
obstacle-free optimum, against IPOPT with the same obstacle rows (docs/clearance.md,
issue 29).

Run: ``python benchmarks/bench_obstacles.py [--count 12] [--seed 2950] [--ref-starts 32]
[--cases spatial4_sphere,spatial4_truss,spatial4_box,planar4_sphere,planar4_truss,planar4_box,
planar8_sphere,planar8_truss]
[--out benchmarks/results]``;
writes ``obstacle_bench.{csv,json,md}``.

Targets. On ``Stack.reference(n)`` (n = 4, or 8 for the ``planar8_*`` cases; legs of
zero radius, plates of zero thickness), target
k (k = 0 .. count - 1) is drawn with ``rng = seed + k`` (spatial:
:func:`stackik.sampling.random_spatial_targets`; planar:
:func:`stackik.sampling.random_planar_targets` in the plane ``phi = 2 pi k / count``) and
solved without obstacles by the default ``solve_ik`` (timed: the obstacle-free reference;
a target whose obstacle-free solve fails is skipped, and counted). The obstacle is placed
on leg ``k mod 6`` of platform 2 (0-based 1) of that optimum, at the midpoint ``m`` of its
axis:

* ``*_sphere``: ``Sphere(m, 15)``;
* ``*_truss``: ``Capsule(m - 300 d, m + 300 d, 10)``, ``d`` the unit vector
  ``u x e_z`` (``u`` the leg's direction: perpendicular to the leg and horizontal), or
  ``u x e_x`` if the leg is within 1e-6 of vertical;
* ``*_box``: a 300 mm beam of 20 mm square section, ``Box(m, (150, 10, 10), [d, u, d x u])``
  (its long axis ``d``, as the truss member's).

So the obstacle-free optimum collides by construction (the table counts how often, by this
file's re-check). Plates are not in the solvers' rows (the check refuses a pose whose plate
meets the obstacle): with the obstacle on a leg's midpoint the plates stay clear of it.

Per target, with the obstacle: the default ``solve_ik`` (timed), ``method="slsqp"``,
IPOPT from 1 and from 8 starts (``method="ipopt", starts=1/8``; the obstacle rows written
in CasADi) and IPOPT from ``--ref-starts`` starts (rng ``1000 + k``). Warm-up: per case,
every method solves once, untimed, a target of another seed with its own obstacle (kernels
loaded); and IPOPT builds a CasADi solver per stack and obstacle set (and plane, planar):
before the timed IPOPT runs of a target, one untimed IPOPT solve of that target with the
same obstacle builds it, so the IPOPT times exclude the symbolic set-up (none subtracted).
The best known FN is the least over every success of the row that passes the re-check.

Re-check. Every pose called a success is re-checked apart from stackik's clearance code:
target and limits by ``check_pose`` on the stack without obstacles, and the obstacle by
the test oracle's exact distances (``tests/reference_impl.obstacle_body_gaps``, which the
soak's obstacle cases use too): each leg axis segment against the sphere's
centre (point-segment), the capsule's axis (segment-segment) or the box
(``segment_box_gap``: slab clipping decides whether the axis meets it, else ends and
edges; ``plate_box_gap`` for a plate), and each plate except the base (the convex
polygon of its nodes in its plane: the top nodes of platform j and the base nodes of
platform j + 1) against the centre (exact point-polygon: the height when the centre
projects inside, else the distance to the nearest edge) or the axis (exact
segment-polygon: 0 when the segment crosses the polygon, else the least of the endpoints'
heights where they project inside and the distances to the edges). A success closer than
``radius - 1e-6`` mm or with a failed check is a **false success**.

Columns: success rate, false successes, share within 0.5 % of the best known FN, median
time, speed-up against IPOPT-8 (median of per-target ratios ``t_ipopt8 / t``, same run)
and time against the obstacle-free default solve (median of per-target ratios ``t / t0``).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from _results import method_columns, write_results

from stackik import Box, Capsule, Sphere, Stack, check_pose, solve_ik
from stackik.bench import machine_info
from stackik.kinematics import lift_planar
from stackik.obstacles import Obstacle
from stackik.rotations import euler_zyx
from stackik.sampling import random_planar_targets, random_spatial_targets
from stackik.targets import PlanarTarget

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import reference_impl as ref  # noqa: E402  (the test oracle's exact distances)
from fuzz_cases import geometry_dicts  # noqa: E402

CASES = {  # name: (planar, obstacle kind, n)
    "spatial4_sphere": (False, "sphere", 4),
    "spatial4_truss": (False, "truss", 4),
    "spatial4_box": (False, "box", 4),
    "planar4_sphere": (True, "sphere", 4),
    "planar4_truss": (True, "truss", 4),
    "planar4_box": (True, "box", 4),
    "planar8_sphere": (True, "sphere", 8),
    "planar8_truss": (True, "truss", 8),
}
PLATFORM = 1  # 0-based: the obstacle sits on a leg of platform 2
SPHERE_R, TRUSS_R, TRUSS_LEN = 15.0, 10.0, 600.0  # [mm]
BOX_HALF = (150.0, 10.0, 10.0)  # [mm] a 300 mm beam of 20 mm square section
WITHIN = 5e-3  # "best known" within 0.5 %
TOL = 1e-6  # [mm] a success closer than radius - TOL is false
LABELS = ("default", "slsqp", "ipopt1", "ipopt8", "ipopt_ref")


# ---------------------------------------------------------------------------------------
# exact distances, written apart from stackik.distance / stackik.clearance
# ---------------------------------------------------------------------------------------
def frames(stack: Stack, q: np.ndarray, phi: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Plate rotations A (n + 1, 3, 3) and origins O (n + 1, 3) [mm] in the base frame."""
    q = np.asarray(q, float)
    P, R = (q[:, :3], euler_zyx(q[:, 3:])) if phi is None else lift_planar(q, phi)
    A = np.empty((stack.n + 1, 3, 3))
    O = np.zeros((stack.n + 1, 3))
    A[0] = np.eye(3)
    for i in range(stack.n):
        O[i + 1] = O[i] + A[i] @ P[i]
        A[i + 1] = A[i] @ R[i]
    return A, O


def legs(stack: Stack, A: np.ndarray, O: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Base and top joints (n, 6, 3) [mm] of every leg."""
    B = O[:-1, None, :] + np.einsum("iab,ikb->ika", A[:-1], stack.base_nodes)
    T = O[1:, None, :] + np.einsum("iab,ikb->ika", A[1:], stack.top_nodes)
    return B, T


def obstacle_gap(stack: Stack, q: np.ndarray, phi: float | None, ob: Obstacle) -> dict[str, float]:
    """Least distance [mm] of the leg axes and of the plates (base excluded) from the
    obstacle's core (a sphere's centre, a capsule's axis; a box's signed distance), by the
    test oracle's exact distances (``tests/reference_impl.obstacle_body_gaps``)."""
    A, O = frames(stack, q, phi)
    d = ob.to_dict()
    g = ref.obstacle_body_gaps(geometry_dicts(stack), O, A, d)
    core = float(d.get("radius", 0.0))  # the oracle measures from the surface
    return {"leg": float(g["leg"].min()) + core, "plate": float(g["plate"].min()) + core}


# ---------------------------------------------------------------------------------------
def _target(planar: bool, stack: Stack, k: int, count: int, seed: int) -> Any:
    if planar:
        phi = 2 * math.pi * (k % count) / count
        return random_planar_targets(stack, 1, rng=seed + k, phis=(phi,))[0]
    return random_spatial_targets(stack, 1, rng=seed + k)[0]


def place(kind: str, stack: Stack, q: np.ndarray, phi: float | None, k: int) -> Obstacle:
    """The case's obstacle on leg ``k mod 6`` of platform ``PLATFORM`` of pose q."""
    A, O = frames(stack, q, phi)
    B, T = legs(stack, A, O)
    b, t = B[PLATFORM, k % 6], T[PLATFORM, k % 6]
    m = 0.5 * (b + t)
    if kind == "sphere":
        return Sphere(m, SPHERE_R)
    u = (t - b) / np.linalg.norm(t - b)
    d = np.cross(u, [0.0, 0.0, 1.0])
    if np.linalg.norm(d) < 1e-6:
        d = np.cross(u, [1.0, 0.0, 0.0])
    d /= np.linalg.norm(d)
    if kind == "box":  # long axis d, second axis the leg's direction
        return Box(m, BOX_HALF, np.column_stack([d, u, np.cross(d, u)]))
    return Capsule(m - 0.5 * TRUSS_LEN * d, m + 0.5 * TRUSS_LEN * d, TRUSS_R)


def _timed(stack: Stack, target: Any, **kw: Any) -> tuple[Any, float]:
    t0 = time.perf_counter()
    r = solve_ik(stack, target, **kw)
    return r, time.perf_counter() - t0


RUNS = {
    "default": {},
    "slsqp": {"method": "slsqp"},
    "ipopt1": {"method": "ipopt", "starts": 1},
    "ipopt8": {"method": "ipopt", "starts": 8},
}


def _row(name: str, k: int, target: Any, stack: Stack, ob: Obstacle, r0: Any, t0: float,
         args: Any) -> dict[str, Any]:  # fmt: skip
    phi = target.phi if isinstance(target, PlanarTarget) else None
    g0 = obstacle_gap(stack, r0.q, phi, ob)
    radius = 0.0 if isinstance(ob, Box) else float(ob.radius)  # type: ignore[attr-defined]
    row: dict[str, Any] = {"case": name, "k": k, "leg": k % 6, "fn_free": r0.frobenius_norm}
    row["time_free"] = t0
    row["free_leg_gap"], row["free_plate_gap"] = g0["leg"], g0["plate"]
    row["free_collides"] = bool(min(g0.values()) < radius - TOL)
    solve_ik(stack, target, method="ipopt", starts=1, obstacles=[ob])  # builds the solver
    runs = {**RUNS, "ipopt_ref": {"method": "ipopt", "starts": args.ref_starts, "rng": 1000 + k}}
    fns = []
    for label, kw in runs.items():
        r, dt = _timed(stack, target, obstacles=[ob], **kw)
        ok = bool(r.success)
        indep = False
        row[f"{label}_gap"] = math.nan
        if ok:
            g = obstacle_gap(stack, r.q, phi, ob)
            row[f"{label}_gap"] = min(g.values())
            indep = bool(check_pose(stack, target, r.q).ok and min(g.values()) >= radius - TOL)
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


def _warm_up(planar: bool, kind: str, stack: Stack, args: Any) -> None:
    """One untimed solve per method on a target of another seed, with its own obstacle."""
    target = _target(planar, stack, 0, args.count, args.seed - 1)
    r0 = solve_ik(stack, target)
    phi = target.phi if planar else None
    ob = place(kind, stack, r0.q, phi, 0)
    for kw in RUNS.values():
        solve_ik(stack, target, obstacles=[ob], **kw)


def run_case(name: str, args: Any) -> tuple[list[dict[str, Any]], int]:
    planar, kind, n = CASES[name]
    stack = Stack.reference(n, leg_radius=0.0)
    assert all(g.leg_radius == 0 and g.plate_thickness == 0 for g in stack)
    _warm_up(planar, kind, stack, args)
    rows: list[dict[str, Any]] = []
    skipped = 0
    for k in range(args.count):
        target = _target(planar, stack, k, args.count, args.seed)
        r0, t0 = _timed(stack, target)
        if not r0.success:
            skipped += 1
            continue
        phi = target.phi if planar else None
        ob = place(kind, stack, r0.q, phi, k)
        row = _row(name, k, target, stack, ob, r0, t0, args)
        rows.append(row)
        print(
            f"{name} {k}: free {row['fn_free']:.6g} collides {row['free_collides']}; "
            f"default {row['default_fn']:.6g} ({row['default_time'] * 1e3:.0f} ms) "
            f"slsqp {row['slsqp_fn']:.6g} ipopt8 {row['ipopt8_fn']:.6g} "
            f"({row['ipopt8_time'] * 1e3:.0f} ms) best {row['best']:.6g}",
            flush=True,
        )
    return rows, skipped


def summary(rows: list[dict[str, Any]], skipped: dict[str, int]) -> list[dict[str, Any]]:
    out = []
    for name in dict.fromkeys(r["case"] for r in rows):
        rs = [r for r in rows if r["case"] == name]
        feasible = [r for r in rs if np.isfinite(r["best"])]
        line: dict[str, Any] = {"case": name, "targets": len(rs), "feasible": len(feasible)}
        line["skipped"] = skipped.get(name, 0)
        line["free_collides"] = sum(r["free_collides"] for r in rs)
        line.update(method_columns(rs, feasible, LABELS))
        out.append(line)
    return out


def markdown(lines: list[dict[str, Any]], meta: dict[str, Any]) -> str:
    head = (
        "| case | targets (feasible) | obstacle-free optima colliding | obstacle-free "
        "median ms | method | success | false successes | within 0.5 % | median ms | "
        "speed-up vs IPOPT-8 | time / obstacle-free solve |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|\n"
    )
    body = ""
    for s in lines:
        t, f = s["targets"], s["feasible"]
        for j, label in enumerate(LABELS):
            lead = (
                f"| {s['case']} | {t} ({f}) | {s['free_collides']}/{t} | {s['free_median_ms']:.0f} "
                if j == 0
                else "| | | | "
            )
            body += (
                f"{lead}| {label} | {s[f'{label}_success']}/{t} | {s[f'{label}_false']} | "
                f"{s[f'{label}_within']}/{f} | {s[f'{label}_median_ms']:.0f} | "
                f"{s[f'{label}_speedup_vs_ipopt8']:.1f}x | {s[f'{label}_vs_free']:.1f}x |\n"
            )
    cost = ", ".join(f"{s['case']} {100 * s['median_fn_cost']:.2f} %" for s in lines)
    skip = ", ".join(f"{s['case']} {s['skipped']}" for s in lines)
    return (
        "# Obstacles (benchmarks/bench_obstacles.py)\n\n"
        f"`{meta['command']}` on {meta['machine']}. `Stack.reference(n)`, n the case "
        "name's digit (zero leg radius); "
        f"per target a sphere of radius {SPHERE_R:g} mm (`*_sphere`) or a capsule of radius "
        f"{TRUSS_R:g} mm and length {TRUSS_LEN:g} mm, horizontal and perpendicular to the leg "
        f"(`*_truss`), or a box beam of half extents {BOX_HALF} mm along the same axis "
        "(`*_box`, signed distances), on the midpoint of leg k mod 6 of platform 2 of the "
        "obstacle-free least-FN pose. Best known = least FN over IPOPT from "
        f"{meta['ref_starts']} starts and every other success of the row; a success is "
        "re-checked with this file's exact distances (legs and plates against the "
        "obstacle; false: closer than its radius - 1e-6 mm or a failed target/limit "
        "check). Times are wall times on a shared machine (IPOPT's CasADi build excluded: "
        "an untimed IPOPT solve with the same obstacle first); ratios are medians of "
        "per-target ratios. `ipopt_ref` is the reference run (its time is that of "
        "--ref-starts starts).\n\n"
        + head
        + body
        + f"\nMedian FN cost of the obstacle (best known / obstacle-free optimum - 1): {cost}."
        f" Targets skipped (obstacle-free solve failed): {skip}.\n"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=12)
    ap.add_argument("--seed", type=int, default=2950)
    ap.add_argument("--ref-starts", type=int, default=32)
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = ap.parse_args()
    if args.ref_starts < 32:
        ap.error("--ref-starts must be >= 32 (the best known needs many starts)")
    rows: list[dict[str, Any]] = []
    skipped: dict[str, int] = {}
    for name in args.cases.split(","):
        rs, skipped[name] = run_case(name, args)
        rows += rs
    lines = summary(rows, skipped)
    meta = {
        "command": "python benchmarks/bench_obstacles.py "
        f"--count {args.count} --seed {args.seed} --ref-starts {args.ref_starts} "
        f"--cases {args.cases}",
        "machine": "{cpus} CPUs ({cpu}), {date}".format(**machine_info()),
        "ref_starts": args.ref_starts,
    }
    write_results(args.out, "obstacle_bench", meta, lines, rows, markdown(lines, meta))


if __name__ == "__main__":
    main()
