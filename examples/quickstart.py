"""Quickstart: the least-sensitive pose of a 4-platform stack for the paper's first target.

Run: ``python examples/quickstart.py``. Units: mm and rad.
"""

import numpy as np

from stackik import PlanarTarget, Stack, check_pose, solve_ik

stack = Stack.reference(4)  # r = 150 mm, legs 250-450 mm (12 mm thick), joints >= 20 deg
target = PlanarTarget(rho=600.0, z=1000.0, theta=-1.57)  # phi = 0: the x-z plane

result = solve_ik(stack, target)  # objective="frobenius", method="auto"
print(f"success: {result.success} ({result.status.value}), {result.time * 1e3:.1f} ms")
print(f"FN = {result.frobenius_norm:.2f}")
print(" i   rho[mm]    z[mm]  theta[rad]   leg lengths [mm]")
for i, (q, legs) in enumerate(zip(result.q, result.leg_lengths), start=1):
    print(f"{i:2d} {q[0]:9.2f} {q[1]:8.2f} {q[2]:10.4f}   " + " ".join(f"{v:6.1f}" for v in legs))

# Hardware form: translation P_i and rotation R_i of each platform (top in bottom frame).
np.set_printoptions(precision=3, suppress=True)
print("P_1 =", result.P[0], " R_1 =\n", result.R[0])

# Independent check: forward kinematics and all 24 n limits, not the solver's word.
check = check_pose(stack, target, result.q)
print(
    f"check: ok={check.ok}, position error {check.position_error:.2e} mm, "
    f"angle error {check.angle_error:.2e} rad, worst violation {check.max_violation_mm:.2e} mm"
)
if not check.ok:
    raise SystemExit(1)
