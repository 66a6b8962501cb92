"""Sensitivity analysis of stack poses (paper section 6, DESIGN §7).

* :mod:`~stackik.analysis.montecarlo`: Algorithm 1 (common-noise Monte Carlo),
  displacement statistics and 95 % confidence ellipses;
* :mod:`~stackik.analysis.linear`: the first-order covariance ``J C_x J^T`` and the
  F factor;
* :mod:`~stackik.analysis.workspace`: optimal vs non-optimal poses over the workspace,
  FN ratio vs median-displacement ratio regression;
* :mod:`~stackik.analysis.figures`: matplotlib figures (imported lazily, Agg backend);
* :mod:`~stackik.analysis.reproduce`: the paper's Tables 1-2 and figures in one report.
"""

from stackik.analysis.linear import LinearCheck, f_factor, linear_covariance, linearity_check
from stackik.analysis.montecarlo import (
    ConfidenceEllipse,
    MonteCarloResult,
    PoseMonteCarlo,
    draw_perturbations,
    monte_carlo,
)

__all__ = [
    "ConfidenceEllipse",
    "LinearCheck",
    "MonteCarloResult",
    "PoseMonteCarlo",
    "draw_perturbations",
    "f_factor",
    "linear_covariance",
    "linearity_check",
    "monte_carlo",
]
