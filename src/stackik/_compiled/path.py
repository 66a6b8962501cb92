"""What the planar and spatial path kernels (:mod:`stackik._compiled.planar_path`,
:mod:`stackik._compiled.spatial_path`) share: the continuation step's budgets and
tolerances, and its handling of mirror limits (rows that copy another row of the set).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from stackik._compiled.core import _jit

FloatArray = Any


#: Newton iterations of a continuation step (``_pc_step`` of the path kernels), all
#: active sets together, and active-set changes (a limit added or released) it may make; a step that
#: has not converged by then goes to the barrier solve.
PC_NEWTON = 16
PC_CHANGES = 3
#: ... and it gives up early when Newton's method does not converge: after PC_FREE
#: iterations in one active set, each must shrink the error by PC_CONTRACT.
PC_FREE = 2
PC_CONTRACT = 0.5
#: The continuation step holds its active limits at this scaled value rather than at 0,
#: on the feasible side as the barrier solve's points are (slacks ~ mu / z there), so
#: that rounding never leaves them violated for the polish to move.
PC_OFFSET = 1e-10
#: ... and converges its equality and active-limit residuals (scaled) to this, below
#: the polish's threshold (1e-13), where the barrier solve's own test asks constr_tol.
PC_PRIMAL_TOL = 1e-13

#: Rows of a platform's active limits whose part orthogonal to the rows taken before
#: is below this fraction of their length depend on those (the KKT solve of the
#: continuation step, :func:`stackik._compiled.planar_path._pc_kkt`). Not smaller: near
#: the ridge where a leg's base and top joint limits coincide, rows that depend there are
#: off by ~|theta| during Newton's iterations, and taken as independent they gave
#: multipliers of 4e4 (n = 8).
#: In spatial mode (:func:`stackik._compiled.spatial_path._dependent`) such rows stay
#: active, out of the Newton system (multiplier 0, their residuals still converged).
PC_DEPENDENT = 1e-6


@_jit
def _twins(act: FloatArray, cI: FloatArray, D: FloatArray) -> FloatArray:
    """For each limit row of the set ``act``: -1 when it enters the Newton system, else
    the earlier row of the set it copies (mirror legs: the same value and gradient to
    rounding, i.e. the same function)."""
    m = cI.size
    nv = D.shape[2]
    parent = np.full(m, -1)
    for r in range(m):
        if not act[r]:
            continue
        i = r // 24
        for r2 in range(24 * i, r):
            same = act[r2] and parent[r2] < 0 and abs(cI[r2] - cI[r]) <= 1e-12
            for k in range(nv):
                dk = D[i, r % 24, k]
                same = same and abs(D[i, r2 % 24, k] - dk) <= 1e-9 * (1.0 + abs(dk))
            if same:
                parent[r] = r2
                break
    return parent


@_jit
def _release(act: FloatArray, zf: FloatArray, parent: FloatArray, rj: int) -> None:
    """Release limit ``rj`` from the active set, with the limits that mirror it."""
    act[rj] = False
    zf[rj] = 0.0
    for r in range(act.size):
        if parent[r] == rj:
            act[r] = False
