"""What the planar and spatial path kernels (:mod:`stackik._compiled.planar_path`,
:mod:`stackik._compiled.spatial_path`) share: the continuation step's budgets and
tolerances, its handling of mirror limits (rows that copy another row of the set), its
optimality errors, its start (the objective scaling) and its active-set change.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from stackik._compiled import kernel
from stackik._compiled.core import OBJ_MAX_GRAD, _abs_max, _jit, _jit_inline

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
    rounding, i.e. the same function). ``D`` (n, R, nv): R rows a platform (its 24 limits
    and, spatial on legs of a size, its self-leg rows), compared within each platform."""
    m = cI.size
    R = D.shape[1]
    nv = D.shape[2]
    parent = np.full(m, -1)
    for r in range(m):
        if not act[r]:
            continue
        i = r // R
        for r2 in range(R * i, r):
            same = act[r2] and parent[r2] < 0 and abs(cI[r2] - cI[r]) <= 1e-12
            for k in range(nv):
                dk = D[i, r % R, k]
                same = same and abs(D[i, r2 % R, k] - dk) <= 1e-9 * (1.0 + abs(dk))
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


@_jit_inline
def _pc_start(x0: FloatArray, P0: Any, g: FloatArray, yE0: FloatArray, z0: FloatArray,
              active: FloatArray, m: int) -> tuple[Any, ...]:  # fmt: skip
    """The start of a continuation step at ``x0`` (N,) with the objective gradient ``g``
    (N,) there: the objective scaling of :func:`stackik._compiled.barrier.ip_loop`
    (``max |g| <= OBJ_MAX_GRAD``). Returns ``(fs, P, g, x, yE, zf, act, new)``: the scale
    factor, ``P0`` with the scaled objective, ``g`` scaled, a copy of ``x0``, the
    multipliers ``yE0`` (E,) and ``z0`` (m,) scaled, a copy of the active mask ``active``
    (m,) and the mask of the limits the last change added (m,; none yet)."""
    gmax = _abs_max(g)
    fs = OBJ_MAX_GRAD / gmax if gmax > OBJ_MAX_GRAD else 1.0
    P = kernel.with_fscale(P0, P0.fscale / fs)
    new = np.zeros(m, dtype=np.bool_)
    return fs, P, g * fs, x0.copy(), yE0 * fs, z0 * fs, active.copy(), new


@_jit_inline
def _merge_twins(act: FloatArray, cI: FloatArray, D: FloatArray, zf: FloatArray,
                 m: int) -> FloatArray:  # fmt: skip
    """:func:`_twins` of the set ``act`` (``m`` rows); each copy's multiplier summed onto
    the row it copies and zeroed, and those of the rows off the set zeroed. Returns the
    parents."""
    parent = _twins(act, cI, D)
    for r in range(m):
        if act[r] and parent[r] >= 0:
            zf[parent[r]] += zf[r]
            zf[r] = 0.0
        elif not act[r]:
            zf[r] = 0.0
    return parent


@_jit_inline
def _pc_errors(rd: FloatArray, yE: FloatArray, zA: FloatArray, cE: FloatArray,
               cI: FloatArray, held: FloatArray, idx: FloatArray,
               m: int) -> tuple[float, float, float, float]:  # fmt: skip
    """The continuation step's optimality errors, scaled as the barrier method's
    (:func:`stackik._compiled.barrier._errors`): the stationarity error ``rd`` (N,), the
    residuals of the equalities and of the held rows ``held`` (at PC_OFFSET), the
    complementarity of the Newton system's rows ``idx`` with multipliers ``zA``; ``m``
    rows in all. Returns ``e_du, e_pr, comp, sd``."""
    sd_acc = 0.0
    for k in range(yE.size):
        sd_acc += abs(yE[k])
    for j in range(zA.size):
        sd_acc += abs(zA[j])
    sd = max(100.0, sd_acc / (m + yE.size)) / 100.0
    e_du = _abs_max(rd) / sd
    e_pr = 0.0
    for k in range(cE.size):
        e_pr = max(e_pr, abs(cE[k]))
    for j in range(held.size):
        e_pr = max(e_pr, abs(cI[held[j]] - PC_OFFSET))
    comp = 0.0
    for j in range(idx.size):
        comp = max(comp, abs(cI[idx[j]] * zA[j]))
    return e_du, e_pr, comp, sd


@_jit_inline
def _pc_change(act: FloatArray, new: FloatArray, zf: FloatArray, parent: FloatArray,
               idx: FloatArray, zA: FloatArray, cI: FloatArray, m: int, changes: int,
               max_changes: int) -> tuple[bool, bool]:  # fmt: skip
    """The active-set change after a converged Newton solve: release the row with the
    most negative multiplier (and its copies), or else add the rows off the set that the
    point violates or nearly meets (closer than half the offset: within rounding of it);
    ``new`` marks the rows added. Returns ``(verified, changed)``: verified when there is
    nothing to change (a KKT point), changed when a change was made (``changes`` made
    before, at most ``max_changes``)."""
    jmin = -1
    for j in range(zA.size):
        if zA[j] < 0.0 and (jmin < 0 or zA[j] < zA[jmin]):
            jmin = j
    nadd = 0
    for r in range(m):
        if not act[r] and not cI[r] >= 0.5 * PC_OFFSET:
            nadd += 1
    if jmin < 0 and nadd == 0:
        return True, False
    if changes >= max_changes:
        return False, False
    new[:] = False
    if jmin >= 0:
        _release(act, zf, parent, idx[jmin])
    else:
        for r in range(m):
            if not act[r] and not cI[r] >= 0.5 * PC_OFFSET:
                act[r] = True
                new[r] = True
    return False, True


@_jit_inline
def _pc_verdict(e_du: float, e_pr: float, comp: float, sd: float, tol: float,
                constr_tol: float, it: int, max_newton: int, inner: int,
                err_prev: float) -> tuple[int, float]:  # fmt: skip
    """One Newton iteration's errors judged: 1 converged (the barrier method's test, the
    residuals within ``min(constr_tol, PC_PRIMAL_TOL)``), 2 give up (``max_newton``
    iterations spent, or, after PC_FREE iterations in this active set (``inner``), an
    error that did not shrink by PC_CONTRACT: Newton's method converges quadratically near
    a solution, so the barrier solve takes the step at once), 0 go on; and the error in
    units of the tolerances."""
    ptol = min(constr_tol, PC_PRIMAL_TOL)
    if e_du <= tol and comp / sd <= tol and e_pr <= ptol:
        return 1, 0.0
    if it >= max_newton:
        return 2, 0.0
    err = max(e_du / tol, max(comp / sd / tol, e_pr / ptol))
    if inner >= PC_FREE and not err <= PC_CONTRACT * err_prev:
        return 2, err
    return 0, err
