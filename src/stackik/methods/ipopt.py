"""``method="ipopt"``: IPOPT through CasADi (optional extra ``stackik[ipopt]``), planar mode.

The same scaled problem as :class:`stackik.formulation.Problem` is written symbolically so that
IPOPT gets exact first and second derivatives from CasADi's automatic differentiation.
Solvers are built once per (stack, phi, objective) and cached; the target is a parameter,
so timing a solve excludes the symbolic set-up.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from stackik.formulation import Problem
from stackik.geometry import Stack
from stackik.methods.base import Method
from stackik.result import OptionError
from stackik.rotations import plane_axis
from stackik.targets import PlanarTarget

FloatArray = NDArray[np.float64]

__all__ = ["IpoptMethod", "ipopt_available", "run_ipopt"]


def ipopt_available() -> bool:
    """True when CasADi (with its bundled IPOPT) can be imported."""
    try:
        import casadi  # noqa: F401
    except ImportError:
        return False
    return True


@lru_cache(maxsize=32)
def _solver(
    stack: Stack,
    phi: float,
    objective: str,
    xs: tuple[float, ...],
    user: tuple[tuple[str, Any], ...] = (),
) -> Any:
    try:
        import casadi as ca
    except ImportError:
        raise ValueError(
            'method "ipopt" needs CasADi: pip install "stackik[ipopt]" (or casadi)'
        ) from None
    n = stack.n
    L = float(stack.leg_max.max())
    e_phi = np.array([math.cos(phi), math.sin(phi), 0.0])
    B = np.stack([e_phi, plane_axis(phi), [0.0, 0.0, 1.0]])
    b = stack.base_nodes @ B.T
    t = stack.top_nodes @ B.T
    u = ca.SX.sym("u", 3 * n)
    p = ca.SX.sym("p", 3)  # target (rho, z, theta) [mm, mm, rad]
    xsv = np.asarray(xs)
    x = u * xsv
    rho, z, th = x[0::3], x[1::3], x[2::3]
    Theta: Any = 0
    P: list[Any] = [0, 0]
    origins = []
    for i in range(n):
        c, s = ca.cos(Theta), ca.sin(Theta)
        P = [P[0] + c * rho[i] - s * z[i], P[1] + s * rho[i] + c * z[i]]
        origins.append(P)
        Theta = Theta + th[i]
    theta_ee = ca.sum1(th)
    g_eq = ca.vertcat((P[0] - p[0]) / L, (P[1] - p[1]) / L, theta_ee - p[2])
    fn2: Any = 3 * n
    for j in range(n - 1):
        fn2 = fn2 + (P[0] - origins[j][0]) ** 2 + (P[1] - origins[j][1]) ** 2
    f = 0 if objective == "feasible" else fn2 / L**2
    g_in = []
    for i in range(n):
        c, s = ca.cos(th[i]), ca.sin(th[i])
        sj = float(stack.sin_joint_min[i])
        lmin2, lmax2, lm = stack.leg_min[i] ** 2, stack.leg_max[i] ** 2, stack.leg_max[i]
        rows: list[list[Any]] = [[], [], [], []]
        for k in range(6):
            lf = c * t[i, k, 0] - s * t[i, k, 2] + rho[i] - b[i, k, 0]
            ls = t[i, k, 1] - b[i, k, 1]
            lz = s * t[i, k, 0] + c * t[i, k, 2] + z[i] - b[i, k, 2]
            sq = lf**2 + ls**2 + lz**2
            nrm = ca.sqrt(sq)
            rows[0].append((sq - lmin2) / lmax2)
            rows[1].append((lmax2 - sq) / lmax2)
            rows[2].append((lz - nrm * sj) / lm)
            rows[3].append((c * lz - s * lf - nrm * sj) / lm)
        g_in += rows[0] + rows[1] + rows[2] + rows[3]
    g = ca.vertcat(g_eq, *g_in)
    nlp = {"x": u, "p": p, "f": f, "g": g}
    opts: dict[str, Any] = {
        "print_time": False,
        "ipopt": {
            "print_level": 0,
            "tol": 1e-9,
            "constr_viol_tol": 1e-10,
            "bound_relax_factor": 0.0,
            "max_iter": 3000,
            "sb": "yes",
            **dict(user),
        },
    }
    try:
        solver = ca.nlpsol("stackik_ipopt", "ipopt", nlp, opts)  # type: ignore[arg-type]
    except RuntimeError as exc:  # e.g. "No such IPOPT option"
        msg = str(exc).strip().splitlines()[-1]
        raise OptionError(f"options: IPOPT rejected them ({msg})") from None
    lbg = np.concatenate([np.zeros(3), np.zeros(24 * n)])
    ubg = np.concatenate([np.zeros(3), np.full(24 * n, np.inf)])
    return solver, lbg, ubg


def run_ipopt(
    prob: Problem, u0: FloatArray, options: dict[str, Any], time_left: float = math.inf
) -> tuple[FloatArray, int, str]:
    """Solve the scaled planar problem ``prob`` (:class:`~stackik.formulation.Problem`)
    with IPOPT from ``u0``.

    ``options`` are IPOPT options (``max_iter``, ``tol``, ...). ``time_left`` [s] becomes
    IPOPT's ``max_wall_time``, rounded down to a power of two so that cached solvers are
    reused.
    """
    target = prob.target
    if not isinstance(target, PlanarTarget):
        raise OptionError('method "ipopt" supports planar targets only')
    if prob.objective == "weighted" and np.ptp(prob.w_th) != 0:
        raise OptionError('method "ipopt" supports "weighted" only with uniform sigma_theta')
    user = dict(options)
    if math.isfinite(time_left):
        user["max_wall_time"] = 2.0 ** math.floor(math.log2(max(time_left, 1e-3)))
    try:
        key = tuple(sorted(user.items()))
        hash(key)
    except TypeError:
        raise OptionError("options: IPOPT option values must be numbers or strings") from None
    solver, lbg, ubg = _solver(prob.stack, target.phi, prob.objective, tuple(prob.xs), key)
    sol = solver(x0=u0, p=target.y, lbg=lbg, ubg=ubg)
    stats = solver.stats()
    u = np.asarray(sol["x"], dtype=float).ravel()
    status = "success" if stats.get("success") else str(stats.get("return_status"))
    return u, int(stats.get("iter_count", 0)), status


class IpoptMethod(Method):
    """IPOPT with exact derivatives by automatic differentiation (CasADi), planar only."""

    name: ClassVar[str] = "ipopt"
    modes: ClassVar[frozenset[str]] = frozenset({"planar"})

    def supports(self, prob: Problem) -> str | None:
        return None  # run_ipopt reports a spatial target as a failed run (as before)

    def check_options(self, options: dict[str, Any]) -> dict[str, Any]:
        return dict(options)  # IPOPT itself judges them (OptionError on the first run)

    def solve(
        self, prob: Problem, u0: FloatArray, options: dict[str, Any], time_left: float
    ) -> tuple[FloatArray, int, str]:
        return run_ipopt(prob, u0, options, time_left)
