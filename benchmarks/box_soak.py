"""Box soak: random oriented boxes on the legs of the obstacle-free least-FN pose, solved
by the default; every success re-checked by :mod:`bench_obstacles`' own distances (slab
clipping, ends and edges, plate against box), written apart from stackik's check.

Run: ``python benchmarks/box_soak.py [--cases 1000] [--seed 2992]``; prints the counts.

Case c (odd: planar in a random plane, even: spatial) on ``Stack.reference(4)``: a box
of half extents uniform in [2, 40] mm, a random rotation, centred 10 mm (normal, per
axis) off a uniform point of a random leg of the obstacle-free optimum, clearance margin
0 or 2 mm. A success whose target/limit check fails or whose leg or plate the re-check
finds inside the box (by more than 1e-6 mm) is a false success. A ValueError (a box over
a base joint) is counted, not a failure.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from stackik import Box, Stack, check_pose, solve_ik
from stackik.sampling import random_planar_targets, random_spatial_targets

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_obstacles import frames, legs, obstacle_gap  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=2992)
    args = ap.parse_args()
    stack = Stack.reference(4, leg_radius=0.0)
    rng = np.random.default_rng(args.seed)
    successes = false = 0
    statuses: dict[str, int] = {}
    for c in range(args.cases):
        planar = c % 2 == 1
        if planar:
            phis = (float(rng.uniform(0, 2 * math.pi)),)
            t = random_planar_targets(stack, 1, rng=rng, phis=phis)[0]
        else:
            t = random_spatial_targets(stack, 1, rng=rng)[0]
        phi = t.phi if planar else None  # type: ignore[union-attr]
        r0 = solve_ik(stack, t)
        if not r0.success:
            statuses["free_failed"] = statuses.get("free_failed", 0) + 1
            continue
        B, T = legs(stack, *frames(stack, r0.q, phi))
        i, k, s = rng.integers(stack.n), rng.integers(6), rng.uniform(0, 1)
        centre = B[i, k] + s * (T[i, k] - B[i, k]) + rng.normal(0, 10, 3)
        Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        box = Box(centre, rng.uniform(2, 40, 3), Q if np.linalg.det(Q) > 0 else -Q)
        try:
            r = solve_ik(stack, t, obstacles=[box], clearance=float(rng.choice([0.0, 2.0])))
        except ValueError:
            statuses["ValueError"] = statuses.get("ValueError", 0) + 1
            continue
        statuses[r.status.name] = statuses.get(r.status.name, 0) + 1
        if r.success:
            successes += 1
            gap = min(obstacle_gap(stack, r.q, phi, box).values())
            if not (check_pose(stack, t, r.q).ok and gap >= -1e-6):
                false += 1
                print(f"false success: case {c}, gap {gap:.3g} mm", flush=True)
    head = f"cases {args.cases} (seed {args.seed})"
    print(f"{head}: successes {successes}, false {false}; {statuses}")


if __name__ == "__main__":
    main()
