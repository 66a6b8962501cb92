"""The planar default of two source trees on bench_scale's targets, interleaved (no IPOPT).

Run: ``python benchmarks/scale_trees.py OLD_SRC NEW_SRC [--n 16 32 64] [--count 20]
[--seed 64100] [--rounds 3] [--out FILE]``, each ``*_SRC`` a ``src`` directory holding a
``stackik`` package. Per n and round, each tree in a fresh process (the order alternating
between rounds) solves the targets of :func:`_results.targets` (reference stack, target k
drawn with ``rng = seed + k``) with ``solve_ik(stack, target)``, one untimed solve first;
each solve's CPU time (``time.process_time``) and wall time. Prints per tree and n the
median over targets of the per-target median over rounds (and the maximum), and how many
targets took at most 0.2 s of wall time (issue 27's goal at n = 64); ``--out`` writes
every solve's times, FN and start count (JSON).
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
import json, sys, time
sys.path.insert(0, sys.argv[4])
from _results import targets
from stackik import PlanarTarget, Stack, solve_ik
n, count, seed = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
solve_ik(Stack.reference(4), PlanarTarget(600.0, 1000.0, -1.57))
stack, out = Stack.reference(n), []
for target in targets(True, stack, count, seed):
    c, w = time.process_time(), time.perf_counter()
    r = solve_ik(stack, target)
    out.append([time.process_time() - c, time.perf_counter() - w, r.frobenius_norm, r.n_starts])
print(json.dumps(out))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("--n", type=int, nargs="+", default=[16, 32, 64])
    ap.add_argument("--count", type=int, default=20)
    ap.add_argument("--seed", type=int, default=64100)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    here = str(Path(__file__).resolve().parent)
    trees = {"old": args.old, "new": args.new}
    runs: dict[str, dict[str, list]] = {}
    for n in args.n:
        got: dict[str, list] = {name: [] for name in trees}
        for r in range(args.rounds):
            order = list(trees) if r % 2 == 0 else list(reversed(trees))
            for name in order:
                env = dict(os.environ, PYTHONPATH=str(trees[name]))
                cmd = [sys.executable, "-c", CHILD, str(n), str(args.count), str(args.seed), here]
                p = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
                got[name].append(json.loads(p.stdout.strip().splitlines()[-1]))
        for name, rounds in got.items():
            cpu = np.median([[x[0] for x in rnd] for rnd in rounds], axis=0)
            wall = np.median([[x[1] for x in rnd] for rnd in rounds], axis=0)
            print(
                f"n = {n} {name}: CPU median {1e3 * np.median(cpu):.0f} ms (max "
                f"{1e3 * cpu.max():.0f}), wall median {1e3 * np.median(wall):.0f} ms (max "
                f"{1e3 * wall.max():.0f}), at most 0.2 s: {int((wall <= 0.2).sum())}/{len(wall)}",
                flush=True,
            )
        runs[str(n)] = got
    if args.out:
        meta = {"old": str(args.old), "new": str(args.new), "seed": args.seed}
        args.out.write_text(json.dumps({"meta": meta, "runs": runs}))


if __name__ == "__main__":
    main()
