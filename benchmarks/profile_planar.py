"""Where a planar default solve spends its time at scale (issue 27): a per-iteration profile.

Run: ``python benchmarks/profile_planar.py [--n 16 32 64] [--count 5] [--seed 27900]
[--out benchmarks/results]``; writes ``planar_profile.{json,md}``.

The compiled interior point cannot be profiled from Python, so its parts are timed one
by one on the poses the default ends at (BLAS on one thread, as a solve runs it): the
evaluation (objective, equalities, limits and their Jacobians), the barrier loop's
Lagrangian Hessian and KKT step as the loop calls them (from ``STRUCTURED_MIN_N``
variables on ``_partial_hessian``, the Hessian's blocks that the structured step reads, and
that step, ``_structured_step``), and for comparison the dense KKT step (null-space
reduction, the Cholesky factor of the reduced Hessian ``(3n - 3) x (3n - 3)``, the
solve: the step below ``STRUCTURED_MIN_N``). Each part's share is its time times the
default's iteration count (one KKT step, one Hessian and at least one evaluation an
iteration: the evaluation's share is a lower bound, the line search's extra trial points
add to it) over the solve's measured time; what is left is the line search's extra
trials, the start plan's Python side, the polish, the checks and the rest of the loop.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from threadpoolctl import threadpool_limits

from stackik import Stack, solve_ik
from stackik._compiled import planar as kernel
from stackik.bench import machine_info
from stackik.formulation import Problem
from stackik.methods.ip import problem_arrays
from stackik.sampling import random_reachable_targets

NONE = np.empty(0)


@njit
def _loop_hessian(u: Any, yE: Any, z: Any, P: Any) -> Any:
    """The barrier loop's Hessian (its kernel entries have no Python wrapper)."""
    if kernel._chained(P, u.shape[0]):
        return kernel._partial_hessian(u, yE, z, P, 0.0)
    return kernel._lagrangian_hessian(u, yE, z, P, 0.0)


@njit
def _loop_step(P: Any, W: Any, AE: Any, cE: Any, rhs: Any) -> Any:
    """The barrier loop's KKT step (its kernel entries have no Python wrapper)."""
    if kernel._chained(P, W.shape[0]):
        return kernel._structured_step(P, W, AE, cE, rhs, 0.0, True)[0]
    return kernel._kernel_kkt_step(W, AE, cE, rhs, 0.0, True)[0]


def _time(fn: Any, reps: int) -> float:
    fn()
    t0 = time.perf_counter()
    for _ in range(reps):
        fn()
    return (time.perf_counter() - t0) / reps


def _parts(stack: Stack, target: Any, q: Any) -> dict[str, float]:
    """Times [s] of the interior point's parts at the pose ``q`` (BLAS on one thread)."""
    n = stack.n
    prob = Problem(stack, target, "frobenius", None)
    P = problem_arrays(prob)
    u = prob.u_of(q)
    f, g, cE, AE, cI, AI = kernel._evaluate_ip(u, P, NONE, NONE, NONE, 0.0)
    yE, z = np.zeros(3), np.full(24 * n, 1e-3)
    W = kernel._lagrangian_hessian(u, yE, z, P) + 1e-2 * np.eye(3 * n)
    Wl = _loop_hessian(u, yE, z, P) + 1e-2 * np.eye(3 * n)
    reps = 200 if n <= 32 else 40
    with threadpool_limits(1, user_api="blas"):
        return {
            "evaluate": _time(lambda: kernel._evaluate_ip(u, P, NONE, NONE, NONE, 0.0), reps),
            "hessian": _time(lambda: _loop_hessian(u, yE, z, P), reps),
            "kkt_step": _time(lambda: _loop_step(P, Wl, AE, cE, -g), reps),
            "dense_step": _time(lambda: kernel._kkt_step(W, AE, cE, -g, 0.0, True), reps),
        }


def profile(n: int, count: int, seed: int) -> dict[str, Any]:
    stack = Stack.reference(n)
    rows = []
    for k, t in enumerate(random_reachable_targets(stack, count, rng=seed + n, phi=0.3)):
        t0 = time.perf_counter()
        r = solve_ik(stack, t)
        wall = time.perf_counter() - t0
        parts = _parts(stack, t, r.q)
        rows.append({"k": k, "wall": wall, "nit": r.nit, "starts": r.n_starts, **parts})
    med = {key: statistics.median(row[key] for row in rows) for key in rows[0] if key != "k"}
    share = {key: med["nit"] * med[key] / med["wall"] for key in ("evaluate", "hessian",
             "kkt_step")}  # fmt: skip
    return {"n": n, "rows": rows, "median": med, "share": share}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[16, 32, 64])
    ap.add_argument("--count", type=int, default=5)
    ap.add_argument("--seed", type=int, default=27900)
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    a = ap.parse_args()
    solve_ik(Stack.reference(4), random_reachable_targets(Stack.reference(4), 1, rng=1)[0])
    out = [profile(n, a.count, a.seed) for n in a.n]
    sizes = " ".join(map(str, a.n))
    meta = {
        "machine": "{cpus} CPUs ({cpu}), {date}".format(**machine_info()),
        "command": f"python benchmarks/profile_planar.py --n {sizes} --count {a.count} "
        f"--seed {a.seed}",
    }
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "planar_profile.json").write_text(json.dumps({"meta": meta, "sizes": out}, indent=1))
    lines = [
        "# Planar default at scale: per-iteration profile (benchmarks/profile_planar.py)",
        "",
        f"`{meta['command']}` on {meta['machine']}. Medians over the targets; parts timed on "
        "the default's final poses with BLAS on one thread; share = part x iterations / "
        "solve time (for the evaluation a lower bound: the line search evaluates more).",
        "",
        "| n | solve ms | iterations | starts | evaluate us | Hessian us | KKT step us "
        "(dense step us) | share: evaluate / Hessian / KKT step |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for s in out:
        m, sh = s["median"], s["share"]
        lines.append(
            f"| {s['n']} | {1e3 * m['wall']:.1f} | {m['nit']:.0f} | {m['starts']:.0f} | "
            f"{1e6 * m['evaluate']:.1f} | {1e6 * m['hessian']:.1f} | {1e6 * m['kkt_step']:.1f} "
            f"({1e6 * m['dense_step']:.1f}) | {100 * sh['evaluate']:.0f} % / "
            f"{100 * sh['hessian']:.0f} % / {100 * sh['kkt_step']:.0f} % |"
        )
    (a.out / "planar_profile.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
