"""Paths on 12 mm legs that fold into themselves (issue 29, rows for bodies of non-adjacent
platforms in the path steps; docs/clearance.md).

Run: ``python benchmarks/bench_path_folds.py [--out benchmarks/results] [--tag NAME]``;
writes ``path_folds[_TAG].{json,md}``. Run it with another tree's ``src`` on ``PYTHONPATH``
(e.g. ``PYTHONPATH=/path/to/old/src``) for the comparison: the file names the tree it ran.

Paths: ``benchmarks/bench_path.py``'s (``make_paths``, seed 2024) planar n = 16 (3 straight,
3 curved, 30 waypoints) and spatial n = 12 (3 + 3, 8 waypoints), their waypoints drawn on
the reference stack, solved in fast mode on
``Stack.uniform(PlatformGeometry.hexagonal(leg_radius=12), n)``. Per path: complete or
where it breaks and why; at a break, whether the default ``solve_ik`` of that waypoint
succeeds; every reached pose re-checked with exact distances (``stackik.clearances``,
``false`` counts a negative one: must be 0); the zero-radius path's least non-adjacent
clearance with 12 mm legs (negative: the stack folds); CPU time.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import stackik
from stackik import PlatformGeometry, Stack, check_pose, clearances, solve_ik
from stackik.bench import machine_info
from stackik.paths import solve_path

sys.path.insert(0, str(Path(__file__).parent))
from bench_path import SEED, make_paths  # noqa: E402

CASES = [("planar", 16, 3, 3, 30), ("spatial", 12, 3, 3, 8)]
RADIUS = 12.0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="benchmarks/results")
    ap.add_argument("--tag", default="")
    args = ap.parse_args()
    rows: list[dict[str, Any]] = []
    for kind, n, straight, curved, m in CASES:
        ref = Stack.reference(n, leg_radius=0.0)
        fat = Stack.uniform(PlatformGeometry.hexagonal(leg_radius=RADIUS), n)
        for idx, (shape, ts) in enumerate(make_paths(kind, ref, straight, curved, 0, m, SEED)):
            phi = getattr(ts[0], "phi", None)
            thin = solve_path(ref, ts)
            fold = min(clearances(fat, q, phi=phi).non_adjacent for q in thin.q[: thin.completed])
            t0 = time.process_time()
            r = solve_path(fat, ts)
            cpu = time.process_time() - t0
            c = r.completed
            false = sum(
                clearances(fat, q, phi=phi).minimum < -1e-6 or not check_pose(fat, t, q).ok
                for t, q in zip(r.targets[:c], r.q[:c])
            )
            ik_at_break = None
            if not r.success and c < r.m:
                ik_at_break = bool(solve_ik(fat, r.targets[c]).success)
            rows.append({
                "case": f"{kind} n={n}", "path": idx, "shape": shape, "m": len(ts),
                "thin_ok": bool(thin.success), "thin_fold_mm": float(fold),
                "ok": bool(r.success), "completed": c, "status": r.status.value,
                "ik_at_break": ik_at_break, "false": int(false), "cpu_s": cpu,
                "unfold": r.info.get("unfold"), "how": r.info.get("how"),
            })  # fmt: skip
            print(rows[-1], flush=True)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stem = "path_folds" + (f"_{args.tag}" if args.tag else "")
    meta = {"machine": machine_info(), "tree": stackik.__file__, "seed": SEED}
    (out / f"{stem}.json").write_text(json.dumps({**meta, "paths": rows}, indent=1))
    cols = ["case", "path", "shape", "m", "thin_fold_mm", "ok", "completed", "status",
            "ik_at_break", "false", "unfold", "cpu_s"]  # fmt: skip
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        cells = [f"{r[x]:.3g}" if isinstance(r[x], float) else str(r[x]) for x in cols]
        lines.append("| " + " | ".join(cells) + " |")
    head = (
        f"# Paths on 12 mm legs that fold{f' ({args.tag})' if args.tag else ''}\n\n"
        f"`python benchmarks/bench_path_folds.py` (tree: `{stackik.__file__}`)\n\n"
    )
    (out / f"{stem}.md").write_text(head + "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
