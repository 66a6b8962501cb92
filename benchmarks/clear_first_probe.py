"""Probe of the planar default's plan with obstacle rows (``stages._clear_first``):
bench_obstacles' planar targets and obstacles, the default solve without the rule (the
batch with the obstacle rows from the plan's starts) and with it, against IPOPT from
``REF`` starts; FN above the best of the three [%], and the count within 0.5 %.

Run: ``python benchmarks/clear_first_probe.py SEED COUNT KIND N [REF]`` (e.g.
``4290 12 truss 4 32``); prints one line per target. Not timed for the record (the
times printed are one solve each).
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_obstacles as bo  # noqa: E402

from stackik import Stack, solve_ik  # noqa: E402
from stackik.solve import stages  # noqa: E402


def _run(stack: Stack, target: Any, ob: Any, rule: bool) -> tuple[Any, float]:
    original = stages._clear_first_applies
    if not rule:
        stages._clear_first_applies = lambda *a: False  # type: ignore[assignment]
    try:
        t0 = time.perf_counter()
        r = solve_ik(stack, target, obstacles=[ob])
        return r, time.perf_counter() - t0
    finally:
        stages._clear_first_applies = original  # type: ignore[assignment]


def main() -> None:
    seed, count, kind, n = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3], int(sys.argv[4])
    ref = int(sys.argv[5]) if len(sys.argv) > 5 else 32
    stack = Stack.reference(n, leg_radius=0.0)
    within = {"old": 0, "new": 0}
    for k in range(count):
        target = bo._target(True, stack, k, count, seed)
        r0 = solve_ik(stack, target)
        if not r0.success:
            print(f"k={k} skipped (obstacle-free solve failed)")
            continue
        ob = bo.place(kind, stack, r0.q, target.phi, k)
        _run(stack, target, ob, False)  # (warm)
        ro, to = _run(stack, target, ob, False)
        rn, tn = _run(stack, target, ob, True)
        ri = solve_ik(stack, target, obstacles=[ob], method="ipopt", starts=ref, rng=1000 + k)
        best = min([r.frobenius_norm for r in (ro, rn, ri) if r.success] or [math.nan])

        def above(r: Any, best: float = best) -> float:
            return (r.frobenius_norm / best - 1) * 100 if r.success else math.nan

        within["old"] += above(ro) <= 100 * bo.WITHIN
        within["new"] += above(rn) <= 100 * bo.WITHIN
        print(
            f"k={k} free={r0.frobenius_norm:.6g} best={best:.6g} "
            f"without rule {above(ro):+.2f} % ({to * 1e3:.0f} ms) "
            f"with rule {above(rn):+.2f} % ({tn * 1e3:.0f} ms) ipopt{ref} {above(ri):+.2f} %",
            flush=True,
        )
    print(f"within 0.5 %: without the rule {within['old']}/{count}, with {within['new']}/{count}")


if __name__ == "__main__":
    main()
