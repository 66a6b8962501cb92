"""The default solve of several source trees on the same targets, paired per solve.

Run: ``python benchmarks/paired_trees.py SRC [SRC ...] [--mode planar|spatial] [--n 64]
[--count 20] [--seed 64100] [--reps 5] [--out FILE]``, each ``SRC`` a ``src`` directory
holding a ``stackik`` package, optionally followed by ``::NAME=VALUE`` environment settings
for that tree's process (e.g. ``/tmp/x/src::NUMBA_OPT=3``).

Each tree runs in one long-lived process (BLAS on one thread) that loads its kernels,
solves target 0 once untimed, then solves the target it is sent; the parent sends target
k to every tree in turn (the order alternating with k and the repetition), ``--reps``
times over the ``--count`` targets of :func:`_results.targets` (reference stack, target k
drawn with ``rng = seed + k``). A target's time in a tree is the least CPU time
(``time.process_time``) of its repetitions: on a shared machine a solve is only ever made
slower by the neighbours, so the least of a few paired repetitions estimates the ratio
between trees to a few percent where whole-process rounds (``scale_trees.py``) scatter by
tens of percent. Prints per tree the sum and median of those times and, against the first
tree, the ratio of the sums and the median (and range) of the per-target ratios, and
whether the FNs are equal; ``--out`` writes every time and FN (JSON).
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
sys.path.insert(0, sys.argv[5])
from _results import targets
from stackik import Stack, solve_ik
mode, n, count, seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
stack = Stack.reference(n)
ts = targets(mode == "planar", stack, count, seed)
solve_ik(stack, ts[0])
print("ready", flush=True)
for line in sys.stdin:
    c = time.process_time()
    r = solve_ik(stack, ts[int(line)])
    print(json.dumps([time.process_time() - c, r.frobenius_norm]), flush=True)
"""


def _start(spec: str, args: argparse.Namespace, here: str) -> subprocess.Popen[str]:
    """The process of one tree (``SRC[::NAME=VALUE...]``), once it says it is ready."""
    src, *settings = spec.split("::")
    env = dict(os.environ, PYTHONPATH=src, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    for setting in settings:
        name, _, value = setting.partition("=")
        env[name] = value
    argv = [args.mode, str(args.n), str(args.count), str(args.seed), here]
    p = subprocess.Popen(
        [sys.executable, "-c", CHILD, *argv],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env=env,
    )
    assert p.stdout is not None
    if p.stdout.readline().strip() != "ready":
        raise SystemExit(f"{spec}: the tree's process did not start (its stderr above)")
    return p


def _solve(p: subprocess.Popen[str], k: int) -> tuple[float, float]:
    assert p.stdin is not None and p.stdout is not None
    p.stdin.write(f"{k}\n")
    p.stdin.flush()
    cpu, fn = json.loads(p.stdout.readline())
    return float(cpu), float(fn)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trees", nargs="+", help="SRC[::NAME=VALUE...], the first the reference")
    ap.add_argument("--mode", choices=("planar", "spatial"), default="planar")
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--count", type=int, default=20)
    ap.add_argument("--seed", type=int, default=64100)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    here = str(Path(__file__).resolve().parent)
    procs = [_start(spec, args, here) for spec in args.trees]
    cpu = np.full((len(procs), args.count, args.reps), np.nan)
    fn = np.full((len(procs), args.count), np.nan)
    for rep in range(args.reps):
        for k in range(args.count):
            order = list(range(len(procs)))
            if (rep + k) % 2:
                order.reverse()
            for i in order:
                cpu[i, k, rep], fn[i, k] = _solve(procs[i], k)
    for p in procs:
        assert p.stdin is not None
        p.stdin.close()
        p.wait()
    least = cpu.min(axis=2)
    for spec, t in zip(args.trees, least, strict=True):
        median = 1e3 * np.median(t)
        print(f"{spec}: sum {t.sum():.3f} s, median {median:.1f} ms (least CPU of {args.reps})")
    for i in range(1, len(procs)):
        r = least[i] / least[0]
        total = least[i].sum() / least[0].sum()
        print(
            f"{args.trees[i]} / {args.trees[0]}: ratio of sums {total:.3f}, "
            f"per-target median {np.median(r):.3f} [{r.min():.3f}, {r.max():.3f}], "
            f"FN equal: {bool(np.allclose(fn[i], fn[0], rtol=1e-9))}"
        )
    if args.out:
        meta = {k: v for k, v in vars(args).items() if k != "out"}
        args.out.write_text(json.dumps({"meta": meta, "cpu": cpu.tolist(), "fn": fn.tolist()}))


if __name__ == "__main__":
    main()
