"""Algorithm constants of the SQP engine (the formula or source each comes from beside it).

Constants of one component live with it: the barrier start's in
:mod:`stackik.sqp.barrier`, the convexification's in :mod:`stackik.sqp.linalg`, BFGS's in
:mod:`stackik.sqp.hessian`, row screening's in :mod:`stackik.sqp.subproblem`.
"""

from __future__ import annotations

import numpy as np

ETA_ACCEPT = 1e-4  # eta: step acceptance threshold on ared/pred, N&W Alg. 18.4 (eta in (0,1))
ETA_GOOD = 0.75  # very successful step -> enlarge radius, N&W Alg. 4.1
ETA_BAD = 0.25  # poor step -> shrink radius, N&W Alg. 4.1
SOC_BELOW = ETA_GOOD  # a second-order correction is tried when the ratio is below this
SOC_REG = 1e-10  # relative regularisation of J_A J_A' in the least-norm correction
BACKTRACK_STEPS = 2  # rejected steps: shorter steps along d tried before shrinking
BACKTRACK_FACTOR = 0.5
GAMMA_SHRINK = 0.25  # radius factor on poor/rejected steps, N&W Alg. 4.1
GAMMA_GROW = 2.0  # radius factor on very successful boundary steps, N&W Alg. 4.1
BOUNDARY_FRACTION = 0.8  # a step "hits the boundary" if ||d|| >= 0.8 radius
RHO_PENALTY = 0.1  # rho in N&W eq. (18.36) for the penalty lower bound
PENALTY_MARGIN = 1.1  # nu >= 1.1 ||y||_inf (exactness of the l1 penalty, N&W Thm. 17.3)
NU_INIT = 1.0  # initial penalty parameter
NU_DECREASE_RATIO = 1.0  # nu is lowered to this multiple of 1.1 ||y||_inf when above it
NU_MAX = 1e10  # cap on the penalty parameter
NU_STEER_FACTOR = 10.0  # penalty increase during steering, Byrd-Nocedal-Waltz 2008
NU_STEER_MAX_TRIES = 6
EPS1_STEER = 0.1  # eps_1: fraction of achievable linearised-violation reduction, BNW 2008
EPS2_STEER = 0.05  # eps_2 < eps_1: merit-model reduction condition, BNW 2008
NU_FEAS = 1e6  # penalty factor emulating the pure feasibility subproblem (nu -> inf)
SCALE_MAX_GRADIENT = 100.0  # IPOPT nlp_scaling_max_gradient (Waechter & Biegler 2006, 3.8)
KKT_S_MAX = 100.0  # IPOPT s_max for multiplier-scaled stationarity (W&B 2006, eq. 5)
ROUNDOFF_GUARD = 10.0 * np.finfo(float).eps  # 10 eps_M max(1,|phi|), CGT (2000) 17.4.2
DELTA_MIN = 1e-12  # trust-region collapse threshold (relative to 1 + ||x/xs||_inf)
# Inexact subproblems (SQPOptions.qp_accuracy = "adaptive")
QP_ACC_FACTOR = 0.1  # QP tolerance = factor x the SQP optimality measure ...
QP_ACC_MAX = 1e-3  # ... at most this (never looser)


def radius_after(
    delta: float, ratio: float, dnorm: float, max_radius: float, backtracked: bool
) -> float:
    """Trust-region radius after an accepted step of ratio ``ratio`` and scaled length
    ``dnorm`` (N&W Alg. 4.1; a backtracked step never grows it)."""
    if backtracked:
        if ratio < ETA_BAD:
            return GAMMA_SHRINK * delta
        return delta
    if ratio >= ETA_GOOD and dnorm >= BOUNDARY_FRACTION * delta:
        return min(GAMMA_GROW * delta, max_radius)
    if ratio < ETA_BAD:
        return GAMMA_SHRINK * delta
    return delta


def radius_rejected(delta: float, dnorm: float) -> float:
    """Trust-region radius after a rejected step (shrunk with the step's length)."""
    return GAMMA_SHRINK * min(delta, dnorm if dnorm > 0 else delta)
