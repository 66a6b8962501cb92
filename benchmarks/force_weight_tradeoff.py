"""The trade-off of ``solve_ik(..., force_weight=w)``: FN against leg force (issue 26).

Run: ``python benchmarks/force_weight_tradeoff.py [--out benchmarks/results]``; writes
``force_weight.json`` and ``force_weight.md``.

The reference geometry with 5 kg plates and 1.5 kg legs (split half at each joint), no
force limit (so the force term is ``sum f^2`` in N^2 and ``w`` is in mm^2 per N^2), a
4 kg payload at the end-effector origin, earth gravity. Two targets: spatial n = 3 at
(100, 50, 900) mm, yaw/pitch/roll (0.2, 0.1, 0) rad, and planar n = 4 at
(rho, z, theta) = (600, 1000, -1.57). For each weight of :data:`WEIGHTS` the default
(``method="auto"``) solve; the table gives its FN, the sum of squared leg forces, the
peak ``|f|``, the least singularity measure ``sigma_min`` of its platforms
(:func:`stackik.statics`), whether it passes :func:`stackik.check_pose` with the load, and
the wall time (a shared machine: noisy).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from stackik.bench import machine_info
from stackik.check import check_pose
from stackik.geometry import PlatformGeometry, Stack
from stackik.loads import Load, statics
from stackik.solve import solve_ik
from stackik.targets import PlanarTarget, SpatialTarget, Target

PLATE_MASS = 5.0  # [kg] each plate
LEG_MASS = 1.5  # [kg] each leg
PAYLOAD = 4.0  # [kg] at the end-effector origin
WEIGHTS = (0.0, 0.001, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 100.0)  # [mm^2 / N^2]


def cases() -> dict[str, tuple[Stack, Target]]:
    g = PlatformGeometry.hexagonal(plate_mass=PLATE_MASS, leg_mass=LEG_MASS)
    return {
        "spatial n=3": (
            Stack.uniform(g, 3),
            SpatialTarget.from_euler((100.0, 50.0, 900.0), 0.2, 0.1, 0.0),
        ),
        "planar n=4": (Stack.uniform(g, 4), PlanarTarget(600.0, 1000.0, -1.57)),
    }


def rows() -> list[dict[str, Any]]:
    load = Load(mass=PAYLOAD)
    out = []
    for name, (stack, target) in cases().items():
        phi = target.phi if isinstance(target, PlanarTarget) else None
        solve_ik(stack, target, load=load)  # kernels loaded before the clock
        for w in WEIGHTS:
            t = time.perf_counter()
            r = solve_ik(stack, target, load=load, force_weight=w)
            dt = time.perf_counter() - t
            st = statics(stack, r.q, load, phi=phi)
            out.append(
                {
                    "case": name,
                    "force_weight": w,
                    "success": bool(r.success),
                    "check": bool(check_pose(stack, target, r.q, load).ok),
                    "method": r.method,
                    "frobenius_norm": float(r.frobenius_norm),
                    "sum_f2": float(np.sum(st.leg_forces**2)),
                    "peak_force": float(st.peak_force),
                    "sigma_min": float(np.min(st.sigma_min)),
                    "objective_value": float(r.objective_value),
                    "time_s": dt,
                }
            )
    return out


def markdown(data: list[dict[str, Any]]) -> str:
    lines = [
        "# force_weight: FN against leg force",
        "",
        "`python benchmarks/force_weight_tradeoff.py` (module doc: stack, load, targets).",
        "",
        "| case | w [mm^2/N^2] | FN | sum f^2 [N^2] | peak abs(f) [N] | min sigma_min | "
        "check | method | time [s] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in data:
        lines.append(
            f"| {r['case']} | {r['force_weight']:g} | {r['frobenius_norm']:.1f} | "
            f"{r['sum_f2']:.3g} | {r['peak_force']:.0f} | {r['sigma_min']:.3f} | "
            f"{'pass' if r['check'] else 'FAIL'} | {r['method']} | {r['time_s']:.2f} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    p.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = p.parse_args(argv)
    data = rows()
    args.out.mkdir(parents=True, exist_ok=True)
    doc = {"machine": machine_info(), "rows": data}
    (args.out / "force_weight.json").write_text(json.dumps(doc, indent=1) + "\n")
    text = markdown(data)
    (args.out / "force_weight.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
