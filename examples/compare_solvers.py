"""Compare stackik's solvers with scipy's SLSQP and trust-constr on the paper's targets.

Run: ``python examples/compare_solvers.py``. Same problem, scaling and analytic
derivatives for every method, and the same single start (the paper's initial guess,
``starts=1``; ``solve_ik`` tries several structured starts by default). ``success`` is the
independent check of every returned pose. Times are single runs on this machine (for
careful timings use ``stackik bench``).
"""

from stackik import PlanarTarget, Stack, solve_ik
from stackik.sqp.qp import default_qp_solver

TARGETS = [(600.0, 1000.0, -1.57), (145.0, 1500.0, -0.207), (-319.0, 1532.0, 0.332)]
METHODS = [
    ("ip", {}),  # compiled interior point (the default for planar targets)
    ("sqp", {}),
    ("slsqp", {}),
    ("trust-constr", {"maxiter": 200}),  # capped: trust-constr is slow to converge here
]

stack = Stack.reference(4)
print(f"QP backend of sqp: {default_qp_solver()}")
print(f"{'target (rho, z, theta)':<26} {'method':<13} {'success':<8} {'FN':>9} {'time[ms]':>9}")
for rho, z, theta in TARGETS:
    target = PlanarTarget(rho, z, theta)
    for method, options in METHODS:
        r = solve_ik(stack, target, method=method, starts=1, options=options or None)
        name = f"({rho:g}, {z:g}, {theta:g})"
        print(
            f"{name:<26} {method:<13} {str(r.success):<8} {r.frobenius_norm:>9.2f} "
            f"{r.time * 1e3:>9.1f}"
        )
