"""How often the paper's model passes legs through plates, and what refusing it costs.

Run: ``python benchmarks/cores_through.py [--seed 4121] [--sizes planar:4:20 ...]
[--out benchmarks/results]``; writes ``cores_through.{csv,json,md}``.

Per case (mode, n, targets; the reference stack, legs and plates of no size): targets from
:func:`stackik.sampling.random_reachable_targets` (planar, plane ``phi = 0.3``) or
:func:`stackik.sampling.random_spatial_targets` (``rng = seed + n``), each solved twice by
the default ``solve_ik``:

- ``lines``: with the check's screen for cores through plates off
  (:func:`stackik.clearance.cores_cross` answering no): the paper's model, legs as lines
  that may pass through plates, what the default answered before the check knew of it;
- ``now``: the default as it is.

Every pose is examined by the test oracle (``tests/reference_impl.cores_through_plates``:
a leg's axis or a plate's edge through a plate by more than 1e-6 mm, written apart from
stackik's distances). Reported: the ``lines`` poses that pass through a plate, the
``now`` successes and any of them that pass through one (a false success), the FN cost
``FN(now) / FN(lines) - 1`` (median and largest, over targets where both succeed), and
the median and largest wall time of each.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from _results import write_results

from stackik import Stack, solve_ik
from stackik.bench import machine_info
from stackik.sampling import random_reachable_targets, random_spatial_targets

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import fuzz_cases  # noqa: E402
import reference_impl as ref  # noqa: E402
from helpers import screen_off  # noqa: E402

PHI = 0.3
SIZES = ["planar:4:20", "planar:8:20", "planar:16:20", "planar:32:8", "planar:64:6",
         "spatial:4:20", "spatial:8:10", "spatial:16:10"]  # fmt: skip


def _through(stack: Stack, q: Any, planar: bool) -> int:
    """The oracle's count of cores through plates at pose ``q``."""
    poses = [
        ref.planar_platform_pose(r, PHI) if planar else ref.spatial_platform_pose(r) for r in q
    ]
    O, A = ref.chain(poses)
    return len(ref.cores_through_plates(fuzz_cases.geometry_dicts(stack), O, A))


def _solve(stack: Stack, target: Any, lines: bool) -> tuple[Any, float]:
    with screen_off() if lines else contextlib.nullcontext():
        t0 = time.perf_counter()
        r = solve_ik(stack, target)
        return r, time.perf_counter() - t0


def run_case(mode: str, n: int, count: int, seed: int) -> tuple[dict[str, Any], list[Any]]:
    planar = mode == "planar"
    stack = Stack.reference(n, leg_radius=0.0)
    if planar:
        targets = random_reachable_targets(stack, count, rng=seed + n, phi=PHI)
    else:
        targets = random_spatial_targets(stack, count, rng=seed + n)
    solve_ik(stack, targets[0], max_time=5.0)  # kernels loaded
    rows = []
    for k, t in enumerate(targets):
        a, ta = _solve(stack, t, True)
        b, tb = _solve(stack, t, False)
        row = {"mode": mode, "n": n, "k": k,
               "lines_success": bool(a.success), "lines_fn": a.frobenius_norm,
               "lines_s": ta, "lines_through": _through(stack, a.q, planar),
               "now_success": bool(b.success), "now_fn": b.frobenius_norm, "now_s": tb,
               "now_through": _through(stack, b.q, planar)}  # fmt: skip
        rows.append(row)
        print(f"{mode} n={n} {k}: lines {row['lines_through']} through "
              f"({1e3 * ta:.0f} ms) now {b.status.name} {row['now_through']} through, "
              f"FN {b.frobenius_norm / a.frobenius_norm - 1:+.3%} ({1e3 * tb:.0f} ms)",
              flush=True)  # fmt: skip
    both = [r for r in rows if r["lines_success"] and r["now_success"]]
    cost = [r["now_fn"] / r["lines_fn"] - 1.0 for r in both]
    line = {
        "case": f"{mode} n={n}",
        "targets": len(rows),
        "lines_through": sum(r["lines_success"] and r["lines_through"] > 0 for r in rows),
        "now_success": sum(r["now_success"] for r in rows),
        "now_false": sum(r["now_success"] and r["now_through"] > 0 for r in rows),
        "cost_median": float(np.median(cost)) if cost else math.nan,
        "cost_max": max(cost) if cost else math.nan,
        "lines_median_ms": 1e3 * float(np.median([r["lines_s"] for r in rows])),
        "now_median_ms": 1e3 * float(np.median([r["now_s"] for r in rows])),
        "lines_max_s": max(r["lines_s"] for r in rows),
        "now_max_s": max(r["now_s"] for r in rows),
    }
    return line, rows


def _cell(key: str, v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.2e}" if "cost" in key else f"{v:.1f}"
    return str(v)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=4121)
    ap.add_argument("--sizes", nargs="+", default=SIZES, help="mode:n:count")
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    a = ap.parse_args()
    summary, rows = [], []
    for spec in a.sizes:
        mode, n, count = spec.split(":")
        line, got = run_case(mode, int(n), int(count), a.seed)
        summary.append(line)
        rows += got
    command = f"python benchmarks/cores_through.py --seed {a.seed} --sizes {' '.join(a.sizes)}"
    cols = list(summary[0])
    table = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for line in summary:
        cells = [_cell(k, v) for k, v in line.items()]
        table.append("| " + " | ".join(cells) + " |")
    report = "\n".join([
        "# Cores through plates: the paper's model against the default", "",
        f"`{command}` ({time.strftime('%Y-%m-%d')}). `lines`: the default with the check's "
        "screen for cores through plates off (the paper's model, legs as lines); `now`: the "
        "default. `lines_through`: its successes whose poses pass a leg's axis or a plate "
        "through a plate (test oracle, `tests/reference_impl.cores_through_plates`); "
        "`now_false`: successes of `now` that do (must be 0); cost = FN(now) / FN(lines) - 1 "
        "where both succeed; times are wall times of one solve.", "", *table, "",
    ])  # fmt: skip
    meta = {"machine": machine_info(), "command": command}
    write_results(a.out, "cores_through", meta, summary, rows, report)


if __name__ == "__main__":
    main()
