"""Soak of stackik.paths.solve_path: random paths, every waypoint re-checked independently.

Each case: a reference stack (planar n in ``--planar-n``, spatial n in ``--spatial-n``; 60 %
planar), legs as lines or 12 mm legs (even odds), a straight path of 8-20 waypoints
between two random reachable targets (planar: a random plane), fast mode (global mode on
a fifth of the cases), ``max_jump = (60 mm, 0.3 rad)``. Every path is solved twice; the
case records:

* every reached waypoint re-checked by the tests' oracle (``tests/fuzz_cases.recheck``:
  target, limits, the legs of each platform, no leg's axis or plate through a plate, by
  ``tests/reference_impl``, which imports nothing from stackik) and by
  :func:`stackik.clearances` (every exact distance >= 0, non-adjacent bodies included);
* no step over ``max_jump`` between reached waypoints;
* the same poses, bit for bit, on the second run;
* a path that does not complete says so (its status and break index);
* a path that outlives ``--timeout`` [s] is a hang (a signal ends it).

Writes ``path_soak_<seed>.json`` (every case) and ``.md`` (the counts) into ``--out``
(default ``benchmarks/results``), prints the summary, and exits non-zero on any bad pose,
jump, difference between the runs, exception or hang.

Usage::

    python benchmarks/path_soak.py --seed 37001 --cases 150
    python benchmarks/path_soak.py --seed 37101 --cases 10 --planar-n 12 16 --spatial-n 12 16
"""

from __future__ import annotations

import argparse
import json
import platform
import signal
import sys
import time
import types
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))  # the oracle lives with the fuzz tests
import fuzz_cases  # noqa: E402
import reference_impl as ref  # noqa: E402
from bench_path import MAX_JUMP, jump_ratio  # noqa: E402

import stackik as sk  # noqa: E402
from stackik.paths import interpolate_targets  # noqa: E402
from stackik.sampling import random_reachable_targets, random_spatial_targets  # noqa: E402


class _HangError(Exception):
    pass


def _alarm(signum: int, frame: Any) -> None:
    raise _HangError


def _bad_poses(stack: sk.Stack, path: Any, planar: bool) -> list[str]:
    """What the oracle and the exact clearances find wrong with the reached waypoints."""
    bad = []
    for j in range(path.completed):
        t, q = path.targets[j], path.q[j]
        phi = t.phi if planar else None
        if planar:
            poses = [ref.planar_platform_pose(row, phi) for row in q]
        else:
            poses = [ref.spatial_platform_pose(row) for row in q]
        result = types.SimpleNamespace(
            q=q,
            leg_lengths=path.leg_lengths[j],
            P=np.array([P for P, _ in poses]),
            R=np.array([R for _, R in poses]),
        )
        rc = fuzz_cases.recheck(stack, t, result)
        bad += [f"waypoint {j}: {r}" for r in rc.reasons]
        cl = sk.clearances(stack, q, phi=phi)
        if cl.minimum < -fuzz_cases.CLEARANCE_TOL:
            bad.append(f"waypoint {j}: clearance {cl.minimum:.3g} mm")
    return bad


def run_case(rng: np.random.Generator, index: int, args: argparse.Namespace) -> dict[str, Any]:
    planar = bool(rng.random() < 0.6)
    n = int(rng.choice(args.planar_n if planar else args.spatial_n))
    radius = float(rng.choice([0.0, 12.0]))
    mode = "global" if rng.random() < 0.2 else "fast"
    m = int(rng.integers(8, 21))
    seed = int(rng.integers(1 << 30))
    phi = float(rng.uniform(-3.0, 3.0))
    stack = sk.Stack.reference(n, leg_radius=radius)
    if planar:
        keys: list[Any] = random_reachable_targets(stack, 2, rng=seed, phi=phi)
    else:
        keys = random_spatial_targets(stack, 2, rng=seed)
    targets = interpolate_targets([keys[0], keys[1]], steps=m - 1)
    rec: dict[str, Any] = {"case": index, "planar": planar, "n": n, "leg_radius": radius,
                           "mode": mode, "waypoints": m, "seed": seed}  # fmt: skip
    signal.alarm(args.timeout)
    try:
        t0 = time.perf_counter()
        first = sk.solve_path(stack, targets, max_jump=MAX_JUMP, mode=mode)
        rec["time_s"] = time.perf_counter() - t0
        second = sk.solve_path(stack, targets, max_jump=MAX_JUMP, mode=mode)
    except _HangError:
        rec["error"] = f"hang (over {args.timeout} s)"
        return rec
    except Exception as exc:  # noqa: BLE001 - recorded: the soak's finding
        rec["error"] = f"{type(exc).__name__}: {exc}"
        return rec
    finally:
        signal.alarm(0)
    k = first.completed
    rec.update(status=first.status.value, completed=k, success=first.success)
    rec["same"] = bool(np.array_equal(first.q, second.q, equal_nan=True))
    rec["bad"] = _bad_poses(stack, first, planar)
    rec["max_step"] = float(jump_ratio(first.q[:k], first.q.shape[2]).max()) if k > 1 else 0.0
    if not first.success:
        rec["message"] = first.message
    return rec


def summary(records: list[dict[str, Any]]) -> dict[str, int]:
    ok = [r for r in records if "error" not in r]
    return {
        "cases": len(records),
        "complete": sum(r["success"] for r in ok),
        "broke_with_reason": sum(not r["success"] for r in ok),
        "bad_poses": sum(bool(r["bad"]) for r in ok),
        "jumps": sum(r["max_step"] > 1.0 + 1e-9 for r in ok),
        "runs_differ": sum(not r["same"] for r in ok),
        "errors_or_hangs": len(records) - len(ok),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=37001)
    ap.add_argument("--cases", type=int, default=150)
    ap.add_argument("--planar-n", type=int, nargs="+", default=[3, 4, 6, 8])
    ap.add_argument("--spatial-n", type=int, nargs="+", default=[3, 4, 6])
    ap.add_argument("--timeout", type=int, default=300, help="seconds a path (both runs)")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = ap.parse_args(argv)
    signal.signal(signal.SIGALRM, _alarm)
    rng = np.random.default_rng(args.seed)
    t0 = time.perf_counter()
    records = []
    for i in range(args.cases):
        rec = run_case(rng, i, args)
        records.append(rec)
        print(json.dumps({k: v for k, v in rec.items() if k != "message"}), flush=True)
    counts = summary(records)
    meta = {
        "command": "python benchmarks/path_soak.py "
        + " ".join(sys.argv[1:] if argv is None else argv),
        "date": time.strftime("%Y-%m-%d %H:%M"),
        "machine": f"{platform.machine()}, Python {platform.python_version()}",
        "seconds": round(time.perf_counter() - t0, 1),
        "max_jump": MAX_JUMP,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    stem = args.out / f"path_soak_{args.seed}"
    stem.with_suffix(".json").write_text(
        json.dumps({"meta": meta, "summary": counts, "cases": records}, indent=1)
    )
    rows = "\n".join(f"| {k.replace('_', ' ')} | {v} |" for k, v in counts.items())
    stem.with_suffix(".md").write_text(
        f"# Path soak, seed {args.seed}\n\nCommand: `{meta['command']}`  \n"
        f"Run: {meta['date']}, {meta['machine']}, {meta['seconds']} s.\n\n"
        f"| count | |\n|---|---|\n{rows}\n"
    )
    print(json.dumps(counts))
    bad = ("bad_poses", "jumps", "runs_differ", "errors_or_hangs")
    return 1 if any(counts[k] for k in bad) else 0


if __name__ == "__main__":
    raise SystemExit(main())
