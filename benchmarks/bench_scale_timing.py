"""Wall time of the planar default and of its full batch on bench_scale's targets, no IPOPT.

Run: ``python benchmarks/bench_scale_timing.py [--n 16 32 64] [--count 20] [--seed 27400]``.

``bench_scale.py`` spends most of its time in IPOPT, so on a shared machine its default
times come from a loaded run; this one times only the default and the full batch (the
default without its adaptive early stop, :func:`bench_scale._full`), alternately per
target, for a quieter reading. Prints the median and maximum per n and how many targets
took at most 0.2 s (issue 27's goal at n = 64).
"""

from __future__ import annotations

import argparse
import statistics
import time

from _results import targets
from bench_scale import _full

from stackik import PlanarTarget, Stack, solve_ik


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[16, 32, 64])
    ap.add_argument("--count", type=int, default=20)
    ap.add_argument("--seed", type=int, default=27400)
    args = ap.parse_args()
    solve_ik(Stack.reference(4), PlanarTarget(600.0, 1000.0, -1.57))  # kernels loaded
    for n in args.n:
        stack = Stack.reference(n)
        default, full = [], []
        for target in targets(True, stack, args.count, args.seed):
            t0 = time.perf_counter()
            solve_ik(stack, target)
            default.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            _full(stack, target)
            full.append(time.perf_counter() - t0)
        fast = sum(t <= 0.2 for t in default)
        print(
            f"n = {n}: default median {1e3 * statistics.median(default):.0f} ms "
            f"(max {1e3 * max(default):.0f} ms, <= 0.2 s on {fast}/{len(default)}), "
            f"full batch median {1e3 * statistics.median(full):.0f} ms",
            flush=True,
        )


if __name__ == "__main__":
    main()
