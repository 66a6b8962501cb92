"""Per-iteration overhead of the stackik.sqp engine on IK-shaped problems.

Run: ``python benchmarks/bench_sqp_overhead.py [--profile] [--repeats N]``.

Two problems of the shape of the IK layer (12 variables, 3 equalities, 96 inequalities,
exact Hessian and a single ``evaluate`` callable):

* ``ik``: the real planar IK problem of a 4-element reference stack;
* ``synthetic``: a random smooth problem of the same shape (no dependency on the IK layer).

The engine overhead per iteration is ``(time_total - time_eval) / nit``: everything but the
user's callbacks (``evaluate`` and ``hessian``), i.e. the SQP logic, the QP build and the
QP solve.  ``--profile`` prints a cProfile summary of repeated solves.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import statistics
from collections.abc import Callable
from typing import Any

import numpy as np

from stackik.sqp import NonlinearProgram, SQPOptions, SQPResult, solve

N, M_EQ, M_INEQ = 12, 3, 96


def ik_problem() -> tuple[NonlinearProgram, np.ndarray, SQPOptions]:
    """The real IK problem (4-element reference stack, paper initial guess)."""
    import stackik as sk
    from stackik.formulation import Problem as _Problem
    from stackik.starts import paper_initial_guess
    from stackik.targets import PlanarTarget

    st = sk.Stack.reference(4)
    target = PlanarTarget(600, 1000, -1.57, 0)
    p = _Problem(st, target, "frobenius", None)
    u0 = p.u_of(paper_initial_guess(st, target))
    nlp = NonlinearProgram(
        objective=None,
        evaluate=p.evaluate,
        hessian=p.lagrangian_hessian,
        eq_scale=np.ones(M_EQ),
        ineq_scale=np.ones(M_INEQ),
    )
    opts = SQPOptions(tol=1e-7, constr_tol=1e-10, initial_tr_radius=0.5)
    return nlp, u0, opts


def synthetic_problem(seed: int = 0) -> tuple[NonlinearProgram, np.ndarray, SQPOptions]:
    """Random smooth problem of the IK shape.

    ``f = 1/2 ||x - a||^2 + 1/4 sum(x^4) / 10``, equalities ``E x + 1/2 x'Q_k x - e = 0``
    (three), inequalities ``r_j^2 - ||x - p_j||^2 >= 0`` mixed with linear ones (96).
    """
    rng = np.random.default_rng(seed)
    a = rng.normal(size=N)
    E = rng.normal(size=(M_EQ, N))
    Q = [0.1 * (lambda R: R + R.T)(rng.normal(size=(N, N))) for _ in range(M_EQ)]
    e = rng.normal(size=M_EQ)
    n_ball = M_INEQ // 2
    P = rng.normal(scale=0.3, size=(n_ball, N))
    r2 = (3.0 + rng.random(n_ball)) ** 2
    L = rng.normal(size=(M_INEQ - n_ball, N))
    lb = -3.0 - rng.random(M_INEQ - n_ball)

    def evaluate(x: np.ndarray) -> tuple[Any, ...]:
        dx = x - a
        f = 0.5 * dx @ dx + 0.025 * np.sum(x**4)
        g = dx + 0.1 * x**3
        cE = E @ x + np.array([0.5 * x @ (Qk @ x) for Qk in Q]) - e
        JE = E + np.array([Qk @ x for Qk in Q])
        D = x[None, :] - P
        cI = np.concatenate((r2 - np.sum(D * D, axis=1), L @ x - lb))
        JI = np.vstack((-2.0 * D, L))
        return f, g, cE, JE, cI, JI

    def hessian(x: np.ndarray, yE: np.ndarray, yI: np.ndarray) -> np.ndarray:
        H = np.eye(N) + np.diag(0.3 * x**2)
        for k in range(M_EQ):
            H -= yE[k] * Q[k]
        H += 2.0 * float(np.sum(yI[:n_ball])) * np.eye(N)
        return H

    nlp = NonlinearProgram(objective=None, evaluate=evaluate, hessian=hessian)
    return nlp, np.zeros(N), SQPOptions(tol=1e-7, constr_tol=1e-10, initial_tr_radius=0.5)


PROBLEMS: dict[str, Callable[[], tuple[NonlinearProgram, np.ndarray, SQPOptions]]] = {
    "ik": ik_problem,
    "synthetic": synthetic_problem,
}


def overhead_us(r: SQPResult) -> float:
    """Engine time per iteration (total minus user callbacks), microseconds."""
    return 1e6 * (r.time_total - r.time_eval) / max(r.nit, 1)


def main() -> None:
    parser = argparse.ArgumentParser(description="stackik.sqp per-iteration overhead")
    parser.add_argument("--repeats", type=int, default=200)
    parser.add_argument("--profile", action="store_true", help="cProfile the repeated solves")
    parser.add_argument("--problems", default=",".join(PROBLEMS))
    parser.add_argument("--qp-solver", default="daqp")
    args = parser.parse_args()
    for name in args.problems.split(","):
        nlp, x0, opts = PROBLEMS[name]()
        r = solve(nlp, x0, qp_solver=args.qp_solver, options=opts)  # warm-up
        runs = []
        prof = cProfile.Profile() if args.profile else None
        for _ in range(args.repeats):
            if prof is not None:
                prof.enable()
            r = solve(nlp, x0, qp_solver=args.qp_solver, options=opts)
            if prof is not None:
                prof.disable()
            runs.append(r)
        per_it = [overhead_us(x) for x in runs]
        build = [1e6 * x.time_qp_build / max(x.nit, 1) for x in runs]
        qp = [1e6 * x.time_qp_solve / max(x.nit, 1) for x in runs]
        ev = [1e6 * x.time_eval / max(x.nit, 1) for x in runs]
        print(
            f"{name:10s} status={r.status.value} nit={r.nit} nfev={r.nfev} fun={r.fun:.10g} "
            f"viol={r.max_violation:.1e}\n"
            f"           per iteration [us] (median of {args.repeats}): "
            f"engine overhead {statistics.median(per_it):7.1f}  "
            f"(qp build {statistics.median(build):6.1f}, qp solve {statistics.median(qp):6.1f})"
            f"  user callbacks {statistics.median(ev):7.1f}"
        )
        if prof is not None:
            pstats.Stats(prof).sort_stats("tottime").print_stats(25)


if __name__ == "__main__":
    main()
