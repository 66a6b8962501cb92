"""Path demo: continuous least-FN poses of an 8-platform stack along a straight path.

Solving every waypoint on its own gives each its least-FN pose, but neighbouring poses
may lie on different folds of the stack: a platform then jumps hundreds of millimetres
between waypoints a few millimetres apart. ``solve_path`` keeps every step within
``max_jump`` (here 60 mm and 0.3 rad per platform variable) at nearly the same FN.

Run: ``python examples/path_demo.py [OUTDIR]`` (CSV, JSON and, with matplotlib, a plot
and a GIF of the stack following the path are written to OUTDIR; default a temporary
directory). Units: mm, rad, s.
"""

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from stackik.geometry import Stack
from stackik.paths import interpolate_targets, solve_path
from stackik.solve import solve_ik
from stackik.targets import PlanarTarget

stack = Stack.reference(8)
keys = [PlanarTarget(-600.0, 2300.0, 0.3), PlanarTarget(700.0, 2400.0, -0.6)]
waypoints = interpolate_targets(keys, max_step=(25.0, 0.05))  # 25 mm, 0.05 rad steps
max_jump = (60.0, 0.3)  # [mm], [rad]


def where(t: PlanarTarget) -> str:
    """A target as ``(rho, z, theta)`` in plain numbers [mm, mm, rad]."""
    return f"(rho, z, theta) = ({t.rho:.0f} mm, {t.z:.0f} mm, {t.theta:.2f} rad)"


print(
    f"{len(waypoints)} waypoints from {where(keys[0])} to {where(keys[1])}; max jump "
    f"{max_jump[0]:g} mm / {max_jump[1]:g} rad"
)


def largest_steps(q: np.ndarray) -> tuple[float, float]:
    d = np.abs(np.diff(q, axis=0))
    return float(d[..., :2].max()), float(d[..., 2].max())


# 1. every waypoint on its own: the per-waypoint optimum
t0 = time.perf_counter()
independent = [solve_ik(stack, t) for t in waypoints]
t_ind = time.perf_counter() - t0
q_ind = np.stack([r.q for r in independent])
fn_ind = np.mean([r.frobenius_norm for r in independent])
mm, rad = largest_steps(q_ind)
print(f"independent: mean FN {fn_ind:.1f}, largest step {mm:.1f} mm / {rad:.3f} rad, "
      f"{1e3 * t_ind / len(waypoints):.2f} ms per waypoint")  # fmt: skip

# 2. the path modes, with waypoint times for legs at most 100 mm/s and 200 mm/s^2
for mode in ("fast", "global"):
    r = solve_path(stack, waypoints, max_jump=max_jump, mode=mode, leg_speed=100.0, leg_accel=200.0)
    mm, rad = r.step_jumps.max(axis=0)
    print(
        f"{mode:>11}: {r.status.value} ({r.completed}/{r.m} waypoints), mean FN "
        f"{r.mean_frobenius_norm:.1f} ({r.mean_frobenius_norm / fn_ind - 1:+.2%}), largest "
        f"step {mm:.1f} mm / {rad:.3f} rad, {1e3 * r.time / r.m:.2f} ms per waypoint, "
        f"duration {r.times[-1]:.1f} s"
    )
    if not r.success:
        print("   ", r.message)

# 3. files: CSV and JSON of the fast result, and the figures when matplotlib is there
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="path_demo_"))
out.mkdir(parents=True, exist_ok=True)
r = solve_path(stack, waypoints, max_jump=max_jump, leg_speed=100.0, leg_accel=200.0)
r.to_csv(out / "path.csv")
r.to_json(out / "path.json")
written = ["path.csv", "path.json"]
if len(sys.argv) > 1:  # the animation takes a few seconds: only when asked for a directory
    try:
        from stackik.paths.animate import animate_path, plot_path

        plot_path(r, stack, out / "path.png")
        written += ["path.png"] + [p.name for p in animate_path(r, stack, out / "path.gif")]
    except ImportError:
        print("matplotlib not installed: no figures (pip install stackik[plot])")
print(f"wrote {', '.join(written)} to {out}")
