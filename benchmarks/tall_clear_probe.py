"""Clear-by-construction starts for tall planar stacks on legs of a size (issue 29's
blocker; docs/clearance.md, "Taller stacks: clear by construction"). A probe, not a
default: it measures whether a pose whose fold is kept from curling back on itself can
seed the solve with the non-adjacent bodies' rows.

Run: ``python benchmarks/tall_clear_probe.py [--n 32] [--seed 8461] [--count 5]
[--band 0.35] [--tilt 0.3] [--fold-screen 0] [--unfold]``.

For each planar target (``random_reachable_targets`` in the plane ``phi = 0.3``, ``rng =
seed + n``, as ``bench_nonadj.py``) on ``Stack.reference(n, leg_radius=12)``:

1. the zero-radius default pose (``Stack.reference(n)``); its *fold* is every platform
   from the lowest plate of a non-adjacent pair within ``--fold-screen`` mm at 12 mm
   (default ``FOLD_SCREEN_MM``: the pairs that collide;
   :func:`stackik.formulation.fold_band.fold_platforms`) up to the top;
2. the *band* pose: the interior point from the paper's guess and from the zero-radius pose
   with :class:`stackik.formulation.fold_band.FoldBand`'s rows on the fold,
   ``|Theta_i - theta_target| <= band`` (the plate's absolute angle within ``band`` [rad]
   of the end effector's) and ``|theta_i| <= tilt`` (its relative turn): the fold's plates
   stay nearly parallel, so non-adjacent platforms are separated by the platforms between
   them (at least 125 mm high on the reference geometry), clear by construction (the
   default's last resort, :func:`stackik.solve.stages._fold_band`, tries the pairs of
   ``FOLD_BANDS``; the defaults here are its narrowest);
3. with ``--unfold``, the solve with the non-adjacent rows from the band pose, as
   :func:`stackik.solve.stages._unfold` makes it (rows of the pairs within 20 mm at the band
   and zero-radius poses, more after each folded round, up to 8 rounds).

Prints, per target, the FN of each pose relative to the zero-radius FN, whether the exact
check passes, and the seconds it took (BLAS on one thread, as in a solve).
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from stackik import Stack, solve_ik
from stackik.formulation.fold_band import FOLD_BANDS, FOLD_SCREEN_MM, FoldBand, fold_platforms
from stackik.formulation.leg_pairs import close_pairs
from stackik.formulation.problem import Problem
from stackik.methods.ip import ip_starts
from stackik.sampling import random_reachable_targets
from stackik.solve.blas import BlasLimit
from stackik.starts import paper_initial_guess

PHI = 0.3
RADIUS = 12.0
SCREEN = 20.0


def _close(stack: Stack, poses: list[Any]) -> set[int]:
    return {int(p) for p in close_pairs(stack, poses, 0.0, PHI, SCREEN, 3)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=32)
    ap.add_argument("--seed", type=int, default=8461)
    ap.add_argument("--count", type=int, default=5)
    ap.add_argument("--band", type=float, default=FOLD_BANDS[-1][0])
    ap.add_argument("--tilt", type=float, default=FOLD_BANDS[-1][1])
    ap.add_argument("--unfold", action="store_true")
    ap.add_argument("--fold-screen", type=float, default=FOLD_SCREEN_MM,
                    help="the fold: pairs within this [mm] of their least distance")  # fmt: skip
    a = ap.parse_args()
    BlasLimit(1).apply()  # as a solve does: threaded BLAS on the rows' products is slow
    n = a.n
    zero, fat = Stack.reference(n, leg_radius=0.0), Stack.reference(n, leg_radius=RADIUS)
    targets = random_reachable_targets(zero, a.count, rng=a.seed + n, phi=PHI)
    solve_ik(fat, targets[0], method="ip", starts=1, max_time=5)  # kernels loaded
    print("| target | fold | band: FN vs 0 mm, clear, s "
          "| unfold from it: FN, clear, rounds, rows, s |")  # fmt: skip
    print("|---|---|---|---|")
    for k, t in enumerate(targets):
        r0 = solve_ik(zero, t)
        q = r0.q.reshape(-1, 3)
        fold = fold_platforms(fat, q, 0.0, PHI, a.fold_screen)
        if fold is None:
            print(f"| {k} | none | - | - |")
            continue
        plain = Problem(fat, t, "frobenius", None)
        banded = Problem(fat, t, "frobenius", None,
                         constraints=[FoldBand(fold, a.band, a.tilt, t.theta)])  # fmt: skip
        t0 = time.perf_counter()
        got = ip_starts(banded, [paper_initial_guess(fat, t), q], {}, 60.0).best
        dt = time.perf_counter() - t0
        if got is None or not plain.check(got.q).ok:
            print(f"| {k} | {fold[0]}-{n - 1} | no clear pose ({dt:.2f} s) | - |")
            continue
        cost = np.sqrt(got.obj) / r0.frobenius_norm - 1.0
        cell = "-"
        if a.unfold:
            start = got.q.reshape(-1, 3)
            pairs = _close(fat, [start, q])
            t1 = time.perf_counter()
            ok, rounds, last = False, 0, got
            for _ in range(8):
                rounds += 1
                b = ip_starts(plain.with_leg_pairs(sorted(pairs)), [start], {"mu0": 1e-2}, 60.0)
                last = b.best if b.best is not None else b.least
                ok = plain.check(last.q).ok
                more = pairs | _close(fat, [last.q.reshape(-1, 3)])
                if ok or more == pairs:
                    break
                pairs = more
            dt1 = time.perf_counter() - t1
            fn = np.sqrt(last.obj) / r0.frobenius_norm - 1.0
            cell = f"{fn:+.2%}, {ok}, {rounds}, {len(pairs)}, {dt1:.2f}"
        print(f"| {k} | {fold[0]}-{n - 1} | {cost:+.2%}, True, {dt:.2f} | {cell} |", flush=True)


if __name__ == "__main__":
    main()
