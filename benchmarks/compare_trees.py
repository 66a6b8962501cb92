"""Speed of two source trees, interleaved: the default solve's median time per case in
fresh processes of each tree, alternating, so that load on a shared machine hits both.

Run: ``python benchmarks/compare_trees.py OLD_SRC NEW_SRC [--rounds 3] [--out FILE]``,
each ``*_SRC`` a ``src`` directory holding a ``stackik`` package (e.g. a git worktree of
the old commit: ``git worktree add /tmp/old <rev>`` then ``/tmp/old/src``). Cases: the
reference stack at n = 4, 15 spatial targets and 30 planar targets (rng 77); the SQP
method with Clarabel on 4 planar targets at n = 16 (rng 78); fast-mode paths at n = 4,
planar and spatial, of 40 waypoints between consecutive targets of the sets above (5
each). One untimed solve of each kind first. Prints, and writes with ``--out`` (JSON),
the per-round medians and the ratio new / old of the medians over rounds.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

CHILD = r"""
import json, time
import numpy as np
import stackik as sk
from stackik.paths import interpolate_targets, solve_path
from stackik.sampling import random_planar_targets, random_spatial_targets

ref = sk.Stack.reference(4)
sk.warm_up()
cases = {
    "spatial4": random_spatial_targets(ref, 15, rng=np.random.default_rng(77)),
    "planar4": random_planar_targets(ref, 30, rng=np.random.default_rng(77)),
}
ref16 = sk.Stack.reference(16)
sqp = dict(method="sqp", qp_solver="clarabel", starts=1)
solves = {name: (ref, targets, {}) for name, targets in cases.items()}
t16 = random_planar_targets(ref16, 4, rng=np.random.default_rng(78))
solves["sqp16_clarabel"] = (ref16, t16, sqp)
out = {}
for name, (stack, targets, kw) in solves.items():
    sk.solve_ik(stack, targets[0], **kw)
    times = []
    for t in targets:
        t0 = time.perf_counter()
        sk.solve_ik(stack, t, **kw)
        times.append(time.perf_counter() - t0)
    out[name] = float(np.median(times))
for name in ("planar4", "spatial4"):
    ends = zip(cases[name][:5], cases[name][1:6])
    legs = [interpolate_targets([a, b], steps=39) for a, b in ends]
    solve_path(ref, legs[0])
    times = []
    for targets in legs:
        t0 = time.perf_counter()
        solve_path(ref, targets, mode="fast")
        times.append(time.perf_counter() - t0)
    out["path_fast_" + name] = float(np.median(times))
print(json.dumps(out))
"""


def _run(src: Path) -> dict[str, float]:
    env = {**os.environ, "PYTHONPATH": str(src)}
    res = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True,
                         text=True, check=True, timeout=1800)  # fmt: skip
    return json.loads(res.stdout.strip().splitlines()[-1])  # type: ignore[no-any-return]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    rounds: dict[str, list[dict[str, float]]] = {"old": [], "new": []}
    for _ in range(args.rounds):
        rounds["old"].append(_run(args.old))
        rounds["new"].append(_run(args.new))
    summary = {}
    for case in rounds["old"][0]:
        old = float(np.median([r[case] for r in rounds["old"]]))
        new = float(np.median([r[case] for r in rounds["new"]]))
        summary[case] = {"old_ms": 1e3 * old, "new_ms": 1e3 * new, "ratio": new / old}
        print(f"{case}: old {1e3 * old:.3f} ms, new {1e3 * new:.3f} ms, new/old {new / old:.3f}")
    if args.out is not None:
        args.out.write_text(json.dumps({"rounds": rounds, "summary": summary}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
