"""How often plates of a folded stack meet (issue 29, plate against plate of non-adjacent
platforms; docs/clearance.md): the default ``solve_ik`` on legs of radius 12 mm, with plates
of zero thickness and of ``--thickness`` mm, on random targets.

Run: ``python benchmarks/plate_contacts.py [--seed 7129] [--thickness 10] [--cases ...]
[--count K] [--out benchmarks/results]``; writes ``plate_contacts.{json,md}``. With
``--paths P [--waypoints M]``: P straight fast paths of M waypoints a case instead (between
pairs of the random targets), every pose a step refused on non-adjacent bodies alone
counted by its closest pair's kind (``plate_contacts_paths.{json,md}``).

Per solve it records (by wrapping :func:`stackik.solve.stages._unfold`, which remakes a run
that folded into itself with rows for the close pairs) every folded run: the closest pair
of its non-adjacent bodies (leg-leg, leg-plate or plate-plate) and whether any pair was
close enough to get rows (none: no run made, the "plate-plate contact, which has no rows"
case). Then, independently of the solver, the least exact distance
(:func:`stackik.distance.polygon_polygon` of the plates' polygons, minus their half
thicknesses) over the plate pairs two or more apart, of the final pose, and whether the
final pose passes the check (a failure whose closest non-adjacent pair is two plates counts
as a plate-plate failure).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from stackik import PlatformGeometry, Stack, check_pose, solve_ik
from stackik import distance as dist
from stackik.bench import machine_info
from stackik.clearance import plate_frames
from stackik.sampling import random_reachable_targets, random_spatial_targets
from stackik.solve import stages

CASES = {
    "planar8": ("planar", 8, 20),
    "planar12": ("planar", 12, 20),
    "planar16": ("planar", 16, 20),
    "spatial8": ("spatial", 8, 6),
    "spatial12": ("spatial", 12, 4),
    "planar24": ("planar", 24, 20),
    "planar32": ("planar", 32, 20),
    "spatial16": ("spatial", 16, 3),
}
RADIUS = 12.0


def _targets(mode: str, n: int, count: int, seed: int) -> list[Any]:
    st = Stack.reference(n, leg_radius=0.0)
    if mode == "spatial":
        return random_spatial_targets(st, count, rng=np.random.default_rng(seed + n))
    return random_reachable_targets(st, count, rng=seed + n, phi=0.3)


def plate_plate(stack: Stack, q: np.ndarray, phi: float | None) -> float:
    """Least signed distance [mm] of two plates two or more apart (exact polygons, minus
    half thicknesses), from the nodes (independent of the rows and of the check)."""
    n = stack.n
    A, O = plate_frames(stack, q, phi=phi)
    polys, half = [], []
    for p in range(n + 1):
        nodes = np.concatenate(
            ([stack.top_nodes[p - 1]] if p > 0 else []) + ([stack.base_nodes[p]] if p < n else [])
        )
        polys.append(dist.Polygon(O[p], A[p], dist.convex_hull_2d(nodes[:, :2])))
        half.append(max(stack[i].plate_thickness for i in (p - 1, p) if 0 <= i < n) / 2)
    best = np.inf
    for a in range(n + 1):
        for b in range(a + 2, n + 1):
            d = float(dist.polygon_polygon(polys[a], polys[b])) - half[a] - half[b]
            best = min(best, d)
    return best


def _kind(contact: Any) -> str:
    if contact is None:
        return "none"
    return f"{contact.a.kind}-{contact.b.kind}" if contact.b is not None else "obstacle"


def run_case(name: str, thickness: float, seed: int, count: int | None = None) -> dict[str, Any]:
    mode, n, default = CASES[name]
    count = default if count is None else count
    geo = PlatformGeometry.hexagonal(leg_radius=RADIUS, plate_thickness=thickness)
    stack = Stack.uniform(geo, n)
    log: list[dict[str, Any]] = []
    orig = stages._unfold

    def spy(req: Any, run: Any, start: Any, solve: Any) -> Any:
        c = run.check.clearances
        na = [x for x in c.contacts if x.distance == c.non_adjacent]
        out = orig(req, run, start, solve)
        log.append({"kind": _kind(na[-1] if na else None), "rows": out is not None})
        return out

    stages._unfold = spy
    rows = []
    try:
        for k, t in enumerate(_targets(mode, n, count, seed)):
            log.clear()
            t0 = time.process_time()
            r = solve_ik(stack, t)
            cpu = time.process_time() - t0
            phi = getattr(t, "phi", None)
            chk = check_pose(stack, t, r.q)
            c = chk.clearances
            fail_kind = "-"
            if not chk.ok and c is not None:
                na = [x for x in c.contacts if x.distance == c.minimum]
                fail_kind = _kind(na[-1] if na else None)
            rows.append({
                "k": k, "ok": bool(r.success), "cpu_s": cpu, "fail_kind": fail_kind,
                "plate_plate_mm": plate_plate(stack, r.q, phi),
                "non_adjacent_mm": None if c is None else float(c.non_adjacent),
                "folded": list(log),
            })  # fmt: skip
            print(name, thickness, rows[-1], flush=True)
    finally:
        stages._unfold = orig
    folded = [f for r in rows for f in r["folded"]]
    return {
        "case": name, "thickness": thickness, "targets": len(rows),
        "ok": sum(r["ok"] for r in rows),
        "folded_runs": len(folded),
        "folded_plate_plate": sum(f["kind"] == "plate-plate" for f in folded),
        "folded_no_rows": sum(not f["rows"] for f in folded),
        "final_plate_fail": sum(r["fail_kind"] == "plate-plate" for r in rows),
        "final_plates_touch": sum(r["plate_plate_mm"] <= 1e-9 for r in rows),
        "least_plate_plate_mm": min(r["plate_plate_mm"] for r in rows),
        "cpu_s": sum(r["cpu_s"] for r in rows),
        "rows": rows,
    }  # fmt: skip


def run_paths(name: str, thickness: float, seed: int, count: int, m: int) -> dict[str, Any]:
    """``count`` straight paths of ``m`` waypoints between random targets of case ``name``
    (fast mode) on 12 mm legs and plates of ``thickness``: every pose a step's rung had
    refused on non-adjacent bodies alone (:meth:`stackik.paths.continuation.Tracker._folded`),
    by its closest non-adjacent pair's kind."""
    from stackik.methods.ip import folds_only
    from stackik.paths import interpolate_targets, solve_path
    from stackik.paths.continuation import Tracker

    mode, n, _ = CASES[name]
    geo = PlatformGeometry.hexagonal(leg_radius=RADIUS, plate_thickness=thickness)
    stack = Stack.uniform(geo, n)
    kinds: list[str] = []
    orig = Tracker._folded

    def spy(self: Any, q: Any, target: Any, q_bad: Any, used: Any) -> bool:
        chk = self._refused
        if q_bad is not None and chk is not None and folds_only(chk, self.clearance):
            c = chk.clearances
            na = [x for x in c.contacts if x.distance == c.non_adjacent]
            kinds.append(_kind(na[-1] if na else None))
        return orig(self, q, target, q_bad, used)  # type: ignore[no-any-return]

    Tracker._folded = spy  # type: ignore[method-assign]
    rows = []
    try:
        keys = _targets(mode, n, 2 * count, seed)
        for k in range(count):
            ts = interpolate_targets([keys[2 * k], keys[2 * k + 1]], steps=m - 1)
            t0 = time.process_time()
            r = solve_path(stack, ts)
            rows.append({"path": k, "ok": bool(r.success), "completed": r.completed,
                         "cpu_s": time.process_time() - t0})  # fmt: skip
            print(name, thickness, "path", rows[-1], flush=True)
    finally:
        Tracker._folded = orig  # type: ignore[method-assign]
    return {
        "case": f"{name} paths", "thickness": thickness, "targets": count,
        "ok": sum(r["ok"] for r in rows), "folded_runs": len(kinds),
        "folded_plate_plate": kinds.count("plate-plate"), "folded_no_rows": 0,
        "final_plate_fail": 0, "final_plates_touch": 0, "least_plate_plate_mm": float("nan"),
        "cpu_s": sum(r["cpu_s"] for r in rows), "rows": rows, "kinds": kinds,
    }  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=7129)
    ap.add_argument("--thickness", type=float, default=10.0)
    ap.add_argument("--cases", default="planar8,planar12,planar16,spatial8,spatial12")
    ap.add_argument("--count", type=int, default=None, help="targets a case (default: CASES)")
    ap.add_argument("--paths", type=int, default=0, help="straight fast paths a case, not solves")
    ap.add_argument("--waypoints", type=int, default=12)
    ap.add_argument("--out", default="benchmarks/results")
    args = ap.parse_args()
    out = []
    for name in args.cases.split(","):
        for th in (0.0, args.thickness):
            if args.paths:
                out.append(run_paths(name, th, args.seed, args.paths, args.waypoints))
            else:
                out.append(run_case(name, th, args.seed, args.count))
    d = Path(args.out)
    d.mkdir(parents=True, exist_ok=True)
    stem = "plate_contacts_paths" if args.paths else "plate_contacts"
    (d / f"{stem}.json").write_text(
        json.dumps({"machine": machine_info(), "seed": args.seed, "cases": out}, indent=1)
    )
    cols = ["case", "thickness", "targets", "ok", "folded_runs", "folded_plate_plate",
            "folded_no_rows", "final_plate_fail", "final_plates_touch", "least_plate_plate_mm",
            "cpu_s"]  # fmt: skip
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for c in out:
        lines.append(
            "| "
            + " | ".join(f"{c[x]:.3g}" if isinstance(c[x], float) else str(c[x]) for x in cols)
            + " |"
        )
    count = f" --count {args.count}" if args.count else ""
    if args.paths:
        count += f" --paths {args.paths} --waypoints {args.waypoints}"
    cmd = (
        f"python benchmarks/plate_contacts.py --seed {args.seed} --thickness {args.thickness}"
        f" --cases {args.cases}{count}"
    )
    title = "# Plate against plate: how often folded stacks bring plates together"
    if args.paths:
        title += " (paths)"
    (d / f"{stem}.md").write_text(f"{title}\n\n`{cmd}`\n\n" + "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
