"""Sensitivity: the least-FN pose against a non-optimised pose of the same target.

Run: ``python examples/sensitivity.py``. Target 1 of the paper (rho = 600 mm, z = 1000 mm,
theta = -1.57 rad). The non-optimised pose is the first feasible pose the solver reaches
(``objective="feasible"``) from a perturbed paper start, like the paper's "Non-Opt" poses.
Both are perturbed with the paper's Table 1 noise (sigma_t = 1 mm, sigma_theta = 0.005 rad)
using the same draws (Algorithm 1); without :mod:`stackik.analysis` the linearised
estimate ``sqrt(trace(J C_x J^T))`` is printed instead.
"""

import numpy as np

from stackik import PlanarTarget, Stack, nonoptimal_poses, planar_jacobian, solve_ik

SIGMA_T, SIGMA_THETA = 1.0, 0.005  # [mm], [rad]
SAMPLES = 10_000

stack = Stack.reference(4)
target = PlanarTarget(600.0, 1000.0, -1.57)
optimal = solve_ik(stack, target)

# the paper's non-optimised pose: first feasible pose from a perturbed initial guess
other = nonoptimal_poses(stack, target, count=1, seed=1)[0]

poses = {"optimal": optimal, "non-optimised": other}
print(f"target: rho = {target.rho} mm, z = {target.z} mm, theta = {target.theta} rad")
for name, r in poses.items():
    print(f"{name:<14} success={r.success}  FN = {r.frobenius_norm:8.2f}")

# Linearised estimate of the RMS end-effector displacement: sqrt(trace(J C_x J^T)) over
# the position rows (rho, z) of J, with C_x = diag(sigma_t^2, sigma_t^2, sigma_theta^2, ...).
w = np.tile([SIGMA_T**2, SIGMA_T**2, SIGMA_THETA**2], stack.n)
print("\nlinearised RMS displacement sqrt(trace(J C_x J^T)) [mm]:")
for name, r in poses.items():
    J = planar_jacobian(r.q)[:2]
    print(f"  {name:<14} {np.sqrt(np.trace((J * w) @ J.T)):.3f}")

try:
    from stackik.analysis import monte_carlo
except ImportError:
    print("\n(stackik.analysis not installed: Monte Carlo skipped)")
else:
    mc = monte_carlo([optimal.q, other.q], SAMPLES, SIGMA_T, SIGMA_THETA, rng=0)
    print(f"\nMonte Carlo, {SAMPLES} common-noise samples: median displacement [mm]")
    for name, pm in zip(poses, mc.poses):
        lo, hi = pm.interval
        print(f"  {name:<14} {pm.median:.3f}   95% interval [{lo:.2f}, {hi:.2f}]")
    ratio = mc.medians[0] / mc.medians[1]
    fn_ratio = optimal.frobenius_norm / other.frobenius_norm
    print(f"median ratio {ratio:.3f} for an FN ratio of {fn_ratio:.3f}")
