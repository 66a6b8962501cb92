"""Leg forces of today's poses: how hard do least-FN poses load the legs? (issue 26)

Run: ``python benchmarks/loads_baseline.py [--count 30] [--out benchmarks/results]``;
writes ``loads_baseline.json`` and ``loads_baseline.md``.

The stack is the reference geometry, n = 4, with masses chosen for an Assembler-sized
robot (not given by any source): each plate 5 kg, each leg 1.5 kg (split half at each
joint), a 10 kg payload at the end-effector origin, earth gravity along -z. The solves do
not know of the masses (no load is passed, every ``force_max`` is infinite, so they are
today's solves bit for bit); the leg forces of their poses are then computed by
:func:`stackik.statics`. For each target two poses are compared: the default solve (least
FN) and the ``objective="feasible"`` solve (the paper's non-optimised pose: the first
feasible point). Targets: :func:`stackik.sampling.random_spatial_targets` and
:func:`stackik.sampling.random_planar_targets` (phi = 0) on the reference stack, seed
:data:`SEED` (used nowhere else).

Also timed (wall clock, median of repeats; the machine is shared, numbers are noisy):
:func:`stackik.leg_forces` per call at n = 4 and 16, one pose and a batch of 100.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np

from stackik.bench import machine_info
from stackik.geometry import PlatformGeometry, Stack
from stackik.loads import Load, leg_forces, statics
from stackik.sampling import random_planar_targets, random_spatial_targets
from stackik.solve import solve_ik

SEED = 26026
PLATE_MASS = 5.0  # [kg] each plate
LEG_MASS = 1.5  # [kg] each leg
PAYLOAD = 10.0  # [kg] at the end-effector origin
OBJECTIVES = ("frobenius", "feasible")


def massive_stack(n: int) -> Stack:
    """The reference geometry with the masses of this benchmark."""
    return Stack.uniform(PlatformGeometry.hexagonal(plate_mass=PLATE_MASS, leg_mass=LEG_MASS), n)


def _quantiles(values: list[float]) -> dict[str, float]:
    a = np.asarray(values, dtype=float)
    if a.size == 0:
        return {}
    q = np.percentile(a, [0, 10, 50, 90, 100])
    return {k: float(v) for k, v in zip(("min", "p10", "median", "p90", "max"), q, strict=True)}


def solve_rows(mode: str, count: int) -> list[dict[str, Any]]:
    """One row per target and objective: status, FN and the statics of the pose."""
    stack = massive_stack(4)
    ref = Stack.reference(4, leg_radius=0.0)
    if mode == "spatial":
        targets: list[Any] = random_spatial_targets(ref, count, rng=SEED)
    else:
        targets = random_planar_targets(ref, count, rng=SEED)
    load = Load(mass=PAYLOAD)
    rows = []
    for j, t in enumerate(targets):
        for objective in OBJECTIVES:
            r = solve_ik(stack, t, objective=objective)
            row: dict[str, Any] = {
                "mode": mode,
                "target": j,
                "objective": objective,
                "success": bool(r.success),
                "fn": float(r.frobenius_norm),
            }
            if r.success:
                phi = t.phi if mode == "planar" else None
                st = statics(stack, r.q, load, phi=phi)
                f = st.leg_forces
                row.update(
                    peak_force=float(np.abs(f).max()),
                    peak_per_platform=np.abs(f).max(axis=1).tolist(),
                    max_compression=float(f.max()),
                    max_tension=float(max(0.0, -f.min())),
                    imbalance=float(np.abs(f[0]).max() / max(np.abs(f[0]).mean(), 1e-300)),
                    sigma_min=float(st.sigma_min.min()),
                    condition=float(st.condition.max()),
                    weakest_platform=int(np.argmin(st.sigma_min)) + 1,
                )
            rows.append(row)
    return rows


def summarise(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    out = []
    for mode in ("spatial", "planar"):
        for objective in OBJECTIVES:
            sel = [r for r in rows if r["mode"] == mode and r["objective"] == objective]
            ok = [r for r in sel if r["success"]]
            if not sel:
                continue
            per_platform = np.array([r["peak_per_platform"] for r in ok]) if ok else None
            out.append(
                {
                    "mode": mode,
                    "objective": objective,
                    "targets": len(sel),
                    "success": len(ok),
                    "peak_force": _quantiles([r["peak_force"] for r in ok]),
                    "max_tension": _quantiles([r["max_tension"] for r in ok]),
                    "poses_with_tension": sum(r["max_tension"] > 0 for r in ok),
                    "platform_1_imbalance": _quantiles([r["imbalance"] for r in ok]),
                    "median_peak_per_platform": (
                        np.median(per_platform, axis=0).tolist() if per_platform is not None else []
                    ),
                    "sigma_min": _quantiles([r["sigma_min"] for r in ok]),
                    "condition": _quantiles([r["condition"] for r in ok]),
                    "fn": _quantiles([r["fn"] for r in ok]),
                }
            )
    return out


def timings(repeats: int = 200) -> list[dict[str, Any]]:
    """Median wall time per call of :func:`leg_forces` [us], one pose and a batch."""
    rng = np.random.default_rng(SEED)
    load = Load(mass=PAYLOAD)
    out = []
    for n in (4, 16):
        stack = massive_stack(n)
        q = np.tile([0.0, 0.0, 350.0, 0.0, 0.0, 0.0], (n, 1)) + rng.normal(0, 0.02, (n, 6))
        batch = np.repeat(q[None], 100, axis=0)
        for label, arg, per in (("one pose", q, 1), ("batch of 100", batch, 100)):
            reps = repeats if per == 1 else max(repeats // 20, 5)
            leg_forces(stack, arg, load)
            samples = []
            for _ in range(reps):
                t0 = time.perf_counter()
                leg_forces(stack, arg, load)
                samples.append(time.perf_counter() - t0)
            out.append(
                {
                    "n": n,
                    "call": label,
                    "us_per_call": 1e6 * statistics.median(samples),
                    "us_per_pose": 1e6 * statistics.median(samples) / per,
                }
            )
    return out


def markdown(summary: list[dict[str, Any]], times: list[dict[str, Any]], info: dict) -> str:
    lines = [
        "# Leg forces of today's poses (benchmarks/loads_baseline.py)",
        "",
        f"Reference geometry, n = 4; each plate {PLATE_MASS:g} kg, each leg {LEG_MASS:g} kg, "
        f"payload {PAYLOAD:g} kg at the end effector, earth gravity (-z). The solves ignore "
        "the masses (no load, no force limit: today's solves); leg forces [N] of their poses "
        "by `stackik.statics`, compression positive. `frobenius` = the default (least-FN) "
        "pose, `feasible` = the first feasible pose (the paper's non-optimised one). "
        "Quantiles min / p10 / median / p90 / max over the solved targets.",
        "",
        f"Machine: {info.get('processor')}, {info.get('cpus')} cpus, {info.get('date')}; "
        "shared with other jobs, timings are noisy.",
        "",
        "| mode | objective | solved | peak |f| [N] | max tension [N] (poses with any) "
        "| median peak per platform 1..4 [N] | sigma_min (least) | condition (worst) |",
        "|---|---|---|---|---|---|---|---|",
    ]

    def fmt(q: dict[str, float], digits: str = ".0f") -> str:
        if not q:
            return "-"
        return " / ".join(format(q[k], digits) for k in ("min", "p10", "median", "p90", "max"))

    for s in summary:
        lines.append(
            f"| {s['mode']} | {s['objective']} | {s['success']}/{s['targets']} "
            f"| {fmt(s['peak_force'])} | {fmt(s['max_tension'])} ({s['poses_with_tension']}) "
            f"| {' / '.join(f'{v:.0f}' for v in s['median_peak_per_platform'])} "
            f"| {fmt(s['sigma_min'], '.3f')} | {fmt(s['condition'], '.1f')} |"
        )
    lines += [
        "",
        "sigma_min and condition: of each platform's leg wrench matrix with moment rows "
        "divided by the top-node radius (150 mm); per pose the least sigma_min and the "
        "worst condition over its platforms.",
        "",
        "## Time of `leg_forces` (NumPy, not compiled)",
        "",
        "| n | call | us per call | us per pose |",
        "|---|---|---|---|",
    ]
    for t in times:
        lines.append(
            f"| {t['n']} | {t['call']} | {t['us_per_call']:.0f} | {t['us_per_pose']:.1f} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--count", type=int, default=30, help="targets per mode (30)")
    p.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = p.parse_args(argv)
    info = machine_info()
    rows = solve_rows("spatial", args.count) + solve_rows("planar", args.count)
    summary = summarise(rows)
    times = timings()
    args.out.mkdir(parents=True, exist_ok=True)
    data = {
        "machine": info,
        "masses": {"plate_kg": PLATE_MASS, "leg_kg": LEG_MASS, "payload_kg": PAYLOAD},
        "gravity": "earth",
        "seed": SEED,
        "summary": summary,
        "timings": times,
        "rows": rows,
    }
    (args.out / "loads_baseline.json").write_text(json.dumps(data, indent=1) + "\n")
    text = markdown(summary, times, info)
    (args.out / "loads_baseline.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
