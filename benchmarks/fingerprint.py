"""Behaviour fingerprint of solve_ik: every method and path on fixed targets.

A refactor that claims "behaviour unchanged" runs this before and after and compares:

    python benchmarks/fingerprint.py --out before.json      # on the old commit
    python benchmarks/fingerprint.py --out after.json       # on the new one
    python benchmarks/fingerprint.py --compare before.json after.json

``--rows`` adds the cases whose problems carry rows beyond the limits (obstacles, legs of a
radius, force limits). The script runs the tree its ``PYTHONPATH`` names, so the same copy
of it can fingerprint an old tree: ``PYTHONPATH=OLD/src python benchmarks/fingerprint.py``.

Each case records the status, the FN, the method that produced the pose, the number of
starts and iterations, and the pose itself; ``--compare`` reports every case whose status,
method or start count differs, or whose FN or pose differs by more than 1e-9 relative.
Only the public API is used, so the same script runs on any commit.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np


def _cases() -> list[tuple[str, Any, Any, dict[str, Any]]]:
    from stackik import PlanarTarget, PlatformGeometry, SpatialTarget, Stack, spatial_forward
    from stackik.sampling import random_reachable_targets

    out: list[tuple[str, Any, Any, dict[str, Any]]] = []
    st4 = Stack.reference(4, leg_radius=0.0)
    paper = [(600.0, 1000.0, -1.57), (145.0, 1500.0, -0.207), (-319.0, 1532.0, 0.332)]
    tg4 = [PlanarTarget(*t) for t in paper]
    tg4 += list(random_reachable_targets(st4, 6, rng=11, phi=0.0))
    tg4 += list(random_reachable_targets(st4, 6, rng=12, phi=0.8))
    methods: list[tuple[str, dict[str, Any]]] = [
        ("default", {}),
        ("ip1", {"method": "ip", "starts": 1}),
        ("sqp", {"method": "sqp"}),
        ("sqp1", {"method": "sqp", "starts": 1}),
        ("osqp1", {"method": "sqp", "qp_solver": "osqp", "starts": 1}),
        ("clarabel1", {"method": "sqp", "qp_solver": "clarabel", "starts": 1}),
        ("slsqp1", {"method": "slsqp", "starts": 1}),
        ("slsqp3", {"method": "slsqp", "starts": 3, "rng": 0}),
        ("feasible", {"objective": "feasible"}),
        ("weighted", {"objective": "weighted", "sigma_t": 1.0, "sigma_theta": 0.005}),
        (
            "weighted_mixed",
            {"objective": "weighted", "sigma_t": 1.0, "sigma_theta": [0.005, 0.01, 0.005, 0.02]},
        ),
        ("convex", {"start": "convex"}),
    ]
    try:
        import casadi  # noqa: F401

        methods += [("ipopt1", {"method": "ipopt", "starts": 1})]
    except ImportError:
        pass
    for i, t in enumerate(tg4):
        for name, kw in methods:
            if name in ("osqp1", "clarabel1", "weighted_mixed", "convex") and i >= 6:
                continue
            out.append((f"n4/{i}/{name}", st4, t, kw))
        if i < 3:
            out.append((f"n4/{i}/tc", st4, t, {"method": "trust-constr", "starts": 1}))
            x0 = np.column_stack([np.zeros(4), np.full(4, 330.0), np.full(4, t.theta / 4)])
            out.append((f"n4/{i}/x0", st4, t, {"x0": x0}))
    for n in (1, 2, 8, 16):
        st = Stack.reference(n, leg_radius=0.0)
        for i, t in enumerate(random_reachable_targets(st, 3, rng=20 + n, phi=0.3)):
            out.append((f"n{n}/{i}/default", st, t, {}))
            out.append((f"n{n}/{i}/ip1", st, t, {"method": "ip", "starts": 1}))
    g = PlatformGeometry.hexagonal(
        base_radius=170.0, top_radius=130.0, leg_min=240.0, leg_max=460.0
    )
    line = PlatformGeometry.reference(leg_radius=0.0)
    mixed = Stack((g, line, g, line, g, g))
    for i, t in enumerate(random_reachable_targets(mixed, 4, rng=31, phi=-1.7)):
        out.append((f"mixed6/{i}/default", mixed, t, {}))
    # unreachable: inside the reach bound and far beyond it
    out.append(("unreach/in", st4, PlanarTarget(1500.0, 300.0, 0.0), {}))
    out.append(("unreach/in/sqp", st4, PlanarTarget(1500.0, 300.0, 0.0), {"method": "sqp"}))
    out.append(("unreach/far", st4, PlanarTarget(6000.0, 1000.0, 0.0), {}))
    # spatial
    st3 = Stack.reference(3, leg_radius=0.0)
    gen = np.random.default_rng(5)
    sp = []
    while len(sp) < 3:
        q = np.column_stack(
            [
                gen.uniform(-60, 60, (3, 2)),
                gen.uniform(260, 420, 3),
                gen.uniform(-0.25, 0.25, (3, 3)),
            ]
        )
        if st3.spatial_constraints(q).min() >= 0:
            sp.append(SpatialTarget(*spatial_forward(q)))
    for i, t in enumerate(sp):
        out.append((f"spatial3/{i}/default", st3, t, {}))
        out.append((f"spatial3/{i}/sqp1", st3, t, {"method": "sqp", "starts": 1}))
        if i == 0:
            out.append((f"spatial3/{i}/slsqp1", st3, t, {"method": "slsqp", "starts": 1}))
    out.append(("spatial3/unreach", st3, SpatialTarget([2000.0, 0.0, 500.0], np.eye(3)), {}))
    return out


def _row_cases() -> list[tuple[str, Any, Any, dict[str, Any]]]:
    """Cases whose problems carry rows beyond the limits (``--rows``): obstacles, legs of
    a radius (spatial self-leg rows, planar non-adjacent bodies' rows), force limits;
    the kernels of the ``_rows`` families."""
    from stackik import Capsule, PlatformGeometry, Sphere, Stack
    from stackik.sampling import random_reachable_targets, random_spatial_targets

    out: list[tuple[str, Any, Any, dict[str, Any]]] = []
    st4 = Stack.reference(4, leg_radius=0.0)
    sphere = Sphere(np.array([300.0, 0.0, 500.0]), 50.0)
    truss = Capsule(np.array([-500.0, 200.0, 600.0]), np.array([500.0, 200.0, 600.0]), 20.0)
    planar = random_reachable_targets(st4, 4, rng=41, phi=0.0)
    spatial = random_spatial_targets(st4, 4, rng=np.random.default_rng(42))
    for i, t in enumerate(planar):
        out.append((f"rows/planar4/{i}/sphere", st4, t, {"obstacles": [sphere]}))
        out.append((f"rows/planar4/{i}/sphere/sqp1", st4, t,
                    {"obstacles": [sphere], "method": "sqp", "starts": 1}))  # fmt: skip
    for i, t in enumerate(spatial):
        out.append((f"rows/spatial4/{i}/truss", st4, t, {"obstacles": [truss]}))
    legs = Stack.reference(4, leg_radius=12.0)
    for i, t in enumerate(spatial):
        out.append((f"rows/spatial4/{i}/legs12", legs, t, {}))
        out.append((f"rows/spatial4/{i}/legs12/ip1", legs, t, {"method": "ip", "starts": 1}))
    for n in (8, 16):
        tall = Stack.reference(n, leg_radius=12.0)
        for i, t in enumerate(random_reachable_targets(tall, 2, rng=43 + n, phi=0.3)):
            out.append((f"rows/planar{n}/{i}/legs12", tall, t, {}))
    g = PlatformGeometry.hexagonal(plate_mass=5.0, force_max=150.0)
    limited = Stack.uniform(g, 4)
    for i, t in enumerate(planar[:2]):
        out.append((f"rows/planar4/{i}/force", limited, t, {}))
    for i, t in enumerate(spatial[:2]):
        out.append((f"rows/spatial4/{i}/force", limited, t, {}))
    return out


def run(path: Path, rows: bool = False) -> None:
    from stackik import solve_ik

    rec: dict[str, Any] = {}
    t0 = time.perf_counter()
    for key, stack, target, kw in _cases() + (_row_cases() if rows else []):
        r = solve_ik(stack, target, **kw)
        rec[key] = {
            "status": r.status.value,
            "method": r.method,
            "fn": r.frobenius_norm,
            "n_starts": r.n_starts,
            "nit": r.nit,
            "q": r.q.tolist(),
        }
    path.write_text(json.dumps(rec, indent=0))
    print(f"{len(rec)} cases in {time.perf_counter() - t0:.1f} s -> {path}")


def compare(a: Path, b: Path, rtol: float = 1e-9) -> int:
    A, B = json.loads(a.read_text()), json.loads(b.read_text())
    bad = 0
    for key in sorted(set(A) | set(B)):
        if key not in A or key not in B:
            print(f"{key}: only in {'A' if key in A else 'B'}")
            bad += 1
            continue
        x, y = A[key], B[key]
        why = [f for f in ("status", "method", "n_starts", "nit") if x[f] != y[f]]
        fa, fb = x["fn"], y["fn"]
        if abs(fa - fb) > rtol * max(abs(fa), 1.0):
            why.append(f"fn {fa:.12g} vs {fb:.12g}")
        qa, qb = np.array(x["q"]), np.array(y["q"])
        if qa.shape != qb.shape or np.abs(qa - qb).max() > rtol * max(np.abs(qa).max(), 1.0):
            why.append("q")
        if why:
            bad += 1
            print(
                f"{key}: "
                + ", ".join(f"{w} ({x.get(w)} vs {y.get(w)})" if w in x else w for w in why)
            )
    print(f"{len(A)} vs {len(B)} cases; {bad} differ")
    return 1 if bad else 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path)
    p.add_argument("--compare", nargs=2, type=Path)
    p.add_argument("--rows", action="store_true", help="also the cases with rows beyond the limits")
    a = p.parse_args(argv)
    if a.compare:
        return compare(*a.compare)
    run(a.out or Path("fingerprint.json"), a.rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
