"""The primal-dual barrier method, once for both modes (numba), and what runs it.

Solves the scaled problem of :class:`stackik.formulation.Problem` (``u = q / xs``)

    min f(u)  s.t.  c_E(u) = 0 (the end-effector equalities),  c_I(u) >= 0 (the limits,
    the self-leg rows, a path step's box, then the dense rows: obstacles, leg forces)

in the spirit of IPOPT (Waechter & Biegler 2006; Nocedal & Wright 2006, ch. 19): slacks
``s > 0`` with ``c_I(u) - s = 0``, the barrier parameter ``mu`` decreased Fiacco-McCormick
style, Newton steps on the perturbed KKT conditions with the exact Hessian of the
Lagrangian (an SR1 estimate for the leg-force rows' curvature), a null-space KKT solve
with inertia correction, the fraction-to-the-boundary rule and a filter line search. The
interior path is what makes the method find good local minima from few starts: it keeps
away from the limits until the objective has shaped the pose.

Everything mode-specific (the evaluation, the Hessian, the KKT solve, the equality
multipliers) comes through :mod:`stackik._compiled.kernel`, resolved at compile time by
the type of the problem data ``P``: :class:`stackik._compiled.planar.PlanarData` or
:class:`stackik._compiled.spatial.SpatialData`. The path kernels
(:mod:`stackik._compiled.planar_path`, :mod:`stackik._compiled.spatial_path`) call the same
loop for their barrier solves. The caller re-checks every returned pose
(:func:`stackik.check.check_pose`); this module makes no claim of its own.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from stackik._compiled import kernel
from stackik._compiled.core import (
    GIVE_UP_AFTER,
    GIVE_UP_VIOLATION,
    IP_MAX_ITER,
    IP_MAX_TIME,
    IP_NONFINITE,
    IP_SKIPPED,
    IP_STALLED,
    IP_SUCCESS,
    OBJ_MAX_GRAD,
    _abs_max,
    _amin,
    _finite,
    _jit,
    _jit_inline,
    _now,
)
from stackik._compiled.dense_rows import (
    AI_dot,
    AIT_dot,
    add_normal,
    block_part,
    force_update,
    ineq_row,
)
from stackik._compiled.linalg import min_norm_solve

FloatArray = Any

#: Line-search halvings before a step counts as rejected.
_LS_TRIES = 40
#: Second-order corrections after a rejected full step, at most (IPOPT's ``max_soc``) ...
_SOC_MAX = 4
#: ... each while it cuts the infeasibility by this factor (IPOPT's ``kappa_soc``) ...
_SOC_KAPPA = 0.99
#: ... in problems of at least this many variables: below it (planar n = 4) the
#: corrections saved 3 % of the iterations and cost about 4 % more time (paired runs,
#: docs/benchmarks.md); from planar n = 8 and spatial n = 4 on they pay or cost nothing.
_SOC_MIN_N = 24
#: The acceptable level (IPOPT's ``acceptable_tol`` / ``acceptable_iter``, here with an
#: objective test): a run stops as converged when for ``_ACC_ITER`` iterations in a row
#: the scaled dual infeasibility and complementarity are at most ``_ACC_TOL``, the
#: infeasibility at most ``constr_tol`` and the objective moved by at most
#: ``_ACC_OBJ_RTOL`` (relative) since the first of them. On planar n = 64, 12 % of the
#: runs reached their FN to 1e-11 in 80-160 iterations and then crawled to ``max_iter``
#: with the dual infeasibility falling ~1 % an iteration (1e-6 to 1e-7, every step with
#: an inertia shift); with this test 13 % fewer iterations, the same FN to 1.1e-9
#: (docs/benchmarks.md, 2026-12-07).
_ACC_TOL = 1e-4
_ACC_ITER = 15
_ACC_OBJ_RTOL = 1e-10


@_jit_inline
def _errors(g: FloatArray, AEty: FloatArray, AItz: FloatArray, cE: FloatArray,
            cI: FloatArray, s: FloatArray, z: FloatArray,
            yE: FloatArray) -> tuple[Any, ...]:  # fmt: skip
    """IPOPT's optimality errors (fused loops: these vectors are short): the dual
    infeasibility and the complementarity scaled by ``sd`` (large multipliers), the primal
    infeasibility. Returns ``e_du, e_pr, comp, sd``."""
    m = cI.size
    sd_acc = 0.0
    for k in range(yE.size):
        sd_acc += abs(yE[k])
    for r in range(m):
        sd_acc += abs(z[r])
    sd = max(100.0, sd_acc / (m + yE.size)) / 100.0
    e_du = 0.0
    for a in range(g.size):
        e_du = max(e_du, abs(g[a] - AEty[a] - AItz[a]))
    e_du /= sd
    e_pr = 0.0
    for k in range(cE.size):
        e_pr = max(e_pr, abs(cE[k]))
    comp = 0.0
    for r in range(m):
        e_pr = max(e_pr, abs(cI[r] - s[r]))
        comp = max(comp, abs(s[r] * z[r]))
    return e_du, e_pr, comp, sd


@_jit_inline
def _next_mu(mu: float, mu_min: float, e_du: float, e_pr: float, sd: float, s: FloatArray,
             z: FloatArray) -> float:  # fmt: skip
    """The barrier parameter after the monotone (Fiacco-McCormick) test: decreased while
    the barrier problem of the current ``mu`` is solved to ``10 mu``."""
    while mu > mu_min:
        comp_mu = 0.0
        for r in range(s.size):
            comp_mu = max(comp_mu, abs(s[r] * z[r] - mu))
        e_mu = max(e_du, max(comp_mu / sd, e_pr))
        if e_mu > 10.0 * mu:
            break
        mu = max(mu_min, min(0.2 * mu, mu**1.5))
    return mu


@_jit_inline
def _to_boundary(s: FloatArray, z: FloatArray, ds: FloatArray, dz: FloatArray,
                 mu: float) -> tuple[float, float]:  # fmt: skip
    """Fraction-to-the-boundary step lengths of the slacks and the multipliers."""
    tau = max(0.99, 1.0 - mu)
    a_s = 1.0
    a_z = 1.0
    for r in range(s.size):
        if ds[r] < 0.0:
            a_s = min(a_s, -tau * s[r] / ds[r])
        if dz[r] < 0.0:
            a_z = min(a_z, -tau * z[r] / dz[r])
    return a_s, a_z


@_jit_inline
def _filter_accepts(theta: float, phi: float, gphi: float, alpha: float, theta_t: float,
                    phi_t: float, theta_max: float, theta_min: float, filt: FloatArray,
                    nfilt: int) -> tuple[bool, bool]:  # fmt: skip
    """Whether the filter line search (Waechter & Biegler 2006, sec. 2.3) accepts a trial
    point, and whether by the objective's (Armijo) test, which adds no filter entry."""
    if not theta_t <= theta_max:
        return False, False
    for j in range(nfilt):
        if theta_t >= filt[j, 0] and phi_t >= filt[j, 1]:
            return False, False
    switching = gphi < 0.0 and alpha * (-gphi) ** 2.3 > theta**1.1
    armijo = phi_t <= phi + 1e-4 * alpha * gphi + 1e-14 * abs(phi)
    if switching and theta <= theta_min:
        return armijo, armijo
    if theta_t <= (1.0 - 1e-5) * theta or phi_t <= phi - 1e-8 * theta:
        return True, False
    if switching and armijo:
        return True, True
    return False, False


@_jit_inline
def _trial_measures(cEt: FloatArray, cIt: FloatArray, st: FloatArray) -> tuple[float, float]:
    """The infeasibility (:func:`_infeasibility`) and the log-barrier sum of a trial
    point (slacks ``st``)."""
    logsum_t = 0.0
    for r in range(st.size):
        logsum_t += math.log(st[r])
    return _infeasibility(cEt, cIt, st), logsum_t


@_jit_inline
def _infeasibility(cE: FloatArray, cI: FloatArray, s: FloatArray) -> float:
    """The filter's infeasibility ``|c_E|_1 + |c_I - s|_1`` (slacks ``s``), summed in
    index order, ``c_E`` first."""
    theta = 0.0
    for k in range(cE.size):
        theta += abs(cE[k])
    for r in range(s.size):
        theta += abs(cI[r] - s[r])
    return theta


@_jit_inline
def _objective_scale(g: FloatArray) -> float:
    """The objective's scale factor by IPOPT's gradient-based rule: ``max |grad f(x0)|
    <= OBJ_MAX_GRAD``."""
    gmax = _abs_max(g)
    return OBJ_MAX_GRAD / gmax if gmax > OBJ_MAX_GRAD else 1.0


@_jit_inline
def _filter_bounds(cE: FloatArray, cI: FloatArray, s: FloatArray) -> tuple[float, float]:
    """The filter's upper and lower bounds on the infeasibility, from the start's."""
    theta0 = _infeasibility(cE, cI, s)
    return 1e4 * max(1.0, theta0), 1e-4 * max(1.0, theta0)


@_jit_inline
def _filter_add(filt: FloatArray, nfilt: int, theta: float, phi: float) -> int:
    """Adds the current point's margins to the filter (while it has room); returns the
    new entry count."""
    if nfilt < filt.shape[0]:
        filt[nfilt, 0] = (1.0 - 1e-5) * theta
        filt[nfilt, 1] = phi - 1e-8 * theta
        nfilt += 1
    return nfilt


@_jit_inline
def _backtrack(x: FloatArray, s: FloatArray, dx: FloatArray, ds: FloatArray, alpha: float,
               P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray, wq: float,
               mu: float, theta: float, phi: float, gphi: float, theta_max: float,
               theta_min: float, filt: FloatArray, nfilt: int, logsum: float,
               here: Any, tries: int) -> tuple[Any, ...]:  # fmt: skip
    """Backtracking from the step length ``alpha`` until the filter accepts, at most
    ``tries`` trial points, halving down to 1e-12. Returns whether a trial point was
    accepted and whether by the objective's test, the last step length, the trial point,
    its slacks, their log-barrier sum and the evaluation there (:func:`kernel.evaluate`'s
    tuple; ``here``, the current point's, if none was made)."""
    accepted = by_f = False
    xt, st, logsum_t, ev = x, s, logsum, here
    for _ in range(tries):
        xt = x + alpha * dx
        st = s + alpha * ds
        ev = kernel.evaluate(xt, P, lo, hi, ug, wq)
        theta_t, logsum_t = _trial_measures(ev[2], ev[4], st)
        if math.isfinite(ev[0]) and math.isfinite(theta_t):  # NaN/inf anywhere shows here
            accepted, by_f = _filter_accepts(theta, phi, gphi, alpha, theta_t,
                                             ev[0] - mu * logsum_t, theta_max, theta_min,
                                             filt, nfilt)  # fmt: skip
            if accepted:
                break
        alpha *= 0.5
        if alpha < 1e-12:
            break
    return accepted, by_f, alpha, xt, st, logsum_t, ev


@_jit_inline
def _second_order(x: FloatArray, s: FloatArray, z: FloatArray, a_s: float, st: FloatArray,
                  ev: Any, P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray,
                  wq: float, mu: float, theta: float, phi: float, gphi: float,
                  theta_max: float, theta_min: float, filt: FloatArray, nfilt: int,
                  W: FloatArray, AEty: FloatArray, cE: FloatArray, cI: FloatArray,
                  AI: Any, g: FloatArray, Sig: FloatArray, fac: Any,
                  shift: float) -> tuple[Any, ...]:  # fmt: skip
    """Second-order corrections of a rejected full step (IPOPT's, Waechter & Biegler 2006,
    A-5.5 to A-5.9), when its trial point is finite and no less infeasible than the current
    point (``theta``): the step's constraint residuals (``c_E`` and ``c_I - s``) at the
    rejected trial point ``x + a_s dx`` (slacks ``st``, evaluation ``ev``) are corrected by
    a KKT step with the same matrix (``W``, its factor ``fac`` and shift ``shift``:
    :func:`kernel.kkt_solve`, no new factorisation) and the accumulated residuals
    ``a c(x) + c(x_trial)`` in place of ``c(x)``; the corrected point, cut to the boundary,
    goes to the filter with the full step's length and slope; at most :data:`_SOC_MAX`
    corrections, each while the infeasibility falls by :data:`_SOC_KAPPA`. Without it the
    curvature of the rows stops full steps near a solution of a tall stack (Maratos effect:
    planar n = 64 ran up to the iteration limit in steps of 1e-2; docs/benchmarks.md).
    Returns whether a corrected point was accepted, whether by the objective's test, the
    point, its slacks, their log-barrier sum, its evaluation, the step ``dx`` and step
    length that reached it, and the multipliers' step and its length."""
    m = s.size
    theta_old = _infeasibility(ev[2], ev[4], st)
    if not (math.isfinite(ev[0]) and theta <= theta_old < math.inf):
        return False, False, x, s, 0.0, ev, x, 0.0, z, 0.0
    cEs = a_s * cE + ev[2]
    rIs = np.empty(m)  # the accumulated c_I - s, as the row values c_I of the step's rhs
    for r in range(m):
        rIs[r] = s[r] + a_s * (cI[r] - s[r]) + (ev[4][r] - st[r])
    for _ in range(_SOC_MAX):
        rhs = _newton_rhs(g, AEty, AI, rIs, s, Sig, mu)
        dxc = kernel.kkt_solve(P, fac, W, cEs, rhs, shift)
        if not _finite(dxc):
            break
        dsc, dzc = _slack_steps(AI_dot(AI, dxc), rIs, s, z, Sig, mu)
        a_sc, a_zc = _to_boundary(s, z, dsc, dzc, mu)
        xc = x + a_sc * dxc
        sc = s + a_sc * dsc
        evc = kernel.evaluate(xc, P, lo, hi, ug, wq)
        theta_c, logsum_c = _trial_measures(evc[2], evc[4], sc)
        if not (math.isfinite(evc[0]) and math.isfinite(theta_c)):
            break
        accepted, by_f = _filter_accepts(theta, phi, gphi, a_s, theta_c, evc[0] - mu * logsum_c,
                                         theta_max, theta_min, filt, nfilt)  # fmt: skip
        if accepted:
            return True, by_f, xc, sc, logsum_c, evc, dxc, a_sc, dzc, a_zc
        if theta_c > _SOC_KAPPA * theta_old:
            break
        theta_old = theta_c
        cEs = a_sc * cEs + evc[2]
        for r in range(m):
            rIs[r] = s[r] + a_sc * (rIs[r] - s[r]) + (evc[4][r] - sc[r])
    return False, False, x, s, 0.0, ev, x, 0.0, z, 0.0


@_jit_inline
def _line_search(x: FloatArray, s: FloatArray, z: FloatArray, dx: FloatArray, ds: FloatArray,
                 dz: FloatArray, P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray,
                 wq: float, mu: float, theta_max: float, theta_min: float, filt: FloatArray,
                 nfilt: int, logsum: float, here: Any, soc: bool, W: FloatArray,
                 AEty: FloatArray, Sig: FloatArray, fac: Any,
                 shift: float) -> tuple[Any, ...]:  # fmt: skip
    """The filter line search of a step ``dx`` (slacks ``ds``, multipliers ``dz``) from the
    current point (evaluation ``here``): the full step (the fraction to the boundary);
    when it is rejected, and ``soc``, the second-order corrections (:func:`_second_order`,
    if the trial point is no less infeasible); then backtracking from half the step. An
    acceptance by the infeasibility adds the point's margins to the filter. Returns
    whether a point was accepted, the step length, the point, its slacks, their
    log-barrier sum, its evaluation, the step, the multipliers' step and its length that
    reached it (``dx``, ``dz`` themselves unless a correction did) and the filter's new
    entry count."""
    f, g, cE, _, cI, AI, _ = here
    a_s, a_z = _to_boundary(s, z, ds, dz, mu)
    theta, phi, gphi = _merit(f, g, cE, cI, s, ds, dx, mu, logsum)
    accepted, by_f, alpha, xt, st, logsum_t, ev = _backtrack(
        x, s, dx, ds, a_s, P, lo, hi, ug, wq, mu, theta, phi, gphi, theta_max, theta_min,
        filt, nfilt, logsum, here, 1,
    )  # fmt: skip
    if soc and not accepted:
        accepted, by_f, xc, sc, logsum_c, evc, dxc, a_sc, dzc, a_zc = _second_order(
            x, s, z, a_s, st, ev, P, lo, hi, ug, wq, mu, theta, phi, gphi, theta_max,
            theta_min, filt, nfilt, W, AEty, cE, cI, AI, g, Sig, fac, shift,
        )  # fmt: skip
        if accepted:
            xt, st, logsum_t, ev = xc, sc, logsum_c, evc
            alpha, dx, dz, a_z = a_sc, dxc, dzc, a_zc
    if not accepted and alpha >= 1e-12:  # backtracking (alpha = a_s / 2)
        accepted, by_f, alpha, xt, st, logsum_t, ev = _backtrack(
            x, s, dx, ds, alpha, P, lo, hi, ug, wq, mu, theta, phi, gphi, theta_max,
            theta_min, filt, nfilt, logsum, here, _LS_TRIES - 1,
        )  # fmt: skip
    if accepted and not by_f:
        nfilt = _filter_add(filt, nfilt, theta, phi)
    return accepted, alpha, xt, st, logsum_t, ev, dx, dz, a_z, nfilt


@_jit_inline
def _newton_rhs(g: FloatArray, AEty: FloatArray, AI: Any, cI: FloatArray, s: FloatArray,
                Sig: FloatArray, mu: float) -> FloatArray:  # fmt: skip
    """The right-hand side of the KKT step: ``-g + AE^T yE + AI^T v`` with the barrier
    term ``v = mu / s - Sigma (c_I - s)``."""
    m, N = s.size, g.size
    v = np.empty(m)
    for r in range(m):
        v[r] = mu / s[r] - Sig[r] * (cI[r] - s[r])
    AIv = AIT_dot(AI, v)
    rhs = np.empty(N)
    for a in range(N):
        rhs[a] = -g[a] + AEty[a] + AIv[a]
    return rhs


@_jit_inline
def _slack_steps(AIdx: FloatArray, cI: FloatArray, s: FloatArray, z: FloatArray,
                 Sig: FloatArray, mu: float) -> tuple[FloatArray, FloatArray]:  # fmt: skip
    """The slacks' and the multipliers' steps of a KKT step ``dx`` (``AIdx = AI dx``)."""
    m = s.size
    ds = np.empty(m)
    dz = np.empty(m)
    for r in range(m):
        ds[r] = AIdx[r] + cI[r] - s[r]
        dz[r] = -z[r] + mu / s[r] - Sig[r] * ds[r]
    return ds, dz


@_jit_inline
def _merit(f: float, g: FloatArray, cE: FloatArray, cI: FloatArray, s: FloatArray,
           ds: FloatArray, dx: FloatArray, mu: float,
           logsum: float) -> tuple[float, float, float]:  # fmt: skip
    """The line search's measures at the current point: the infeasibility
    (:func:`_infeasibility`), the barrier function and its slope along the step."""
    dsum = 0.0
    for r in range(s.size):
        dsum += ds[r] / s[r]
    gdx = 0.0
    for a in range(g.size):
        gdx += g[a] * dx[a]
    return _infeasibility(cE, cI, s), f - mu * logsum, gdx - mu * dsum


@_jit_inline
def _reset_slacks(s: FloatArray, z: FloatArray, cIt: FloatArray, dz: FloatArray, a_z: float,
                  mu: float, logsum: float) -> float:  # fmt: skip
    """After a step (in place): a slack below its constraint value is reset to it (it
    only adds violation), the multipliers take their step, kept within a factor 1e10 of
    ``mu / s``; returns the log-barrier sum of the new slacks (from ``logsum``, theirs
    before the reset)."""
    for r in range(s.size):
        if cIt[r] > s[r]:
            logsum += math.log(cIt[r]) - math.log(s[r])
            s[r] = cIt[r]
        zr = z[r] + a_z * dz[r]
        z[r] = min(max(zr, mu / (1e10 * s[r])), 1e10 * mu / s[r])
    return logsum


@_jit
def polished(cE: FloatArray, cI: FloatArray, reach: float) -> bool:
    """Whether :func:`polish` leaves a point with these constraint values as it is."""
    if not _abs_max(cE) < 1e-13:
        return False
    for r in range(cI.size):
        if -reach < cI[r] < 0.0:
            return False
    return True


@_jit_inline
def polish(u: FloatArray, P: Any, iters: int, reach: float, margin: float) -> FloatArray:
    """:func:`stackik.formulation.polish` compiled: up to ``iters`` min-norm Newton
    corrections of the end-effector equalities and of the rows violated by less than
    ``reach`` (scaled), put at ``margin``; the dense rows too
    (:mod:`stackik._compiled.dense_rows`). Tiny moves only."""
    none = np.empty(0)
    for _ in range(iters):
        f, g, cE, AE, cI, AI, _ = kernel.evaluate(u, P, none, none, none, 0.0)
        if polished(cE, cI, reach):
            break
        nv = 0
        for r in range(cI.size):
            if -reach < cI[r] < 0.0:
                nv += 1
        E = cE.size
        A = np.zeros((E + nv, u.size))
        rr = np.empty(E + nv)
        for r in range(E):  # loops, not slice assignments: see ip_multi
            rr[r] = cE[r]
            for k in range(u.size):
                A[r, k] = AE[r, k]
        k = E
        for r in range(cI.size):
            if -reach < cI[r] < 0.0:
                ineq_row(AI, r, A[k])
                rr[k] = cI[r] - margin
                k += 1
        if not (_finite(A) and _finite(rr)):
            break
        u = u - min_norm_solve(A, rr)
    return u


@_jit
def ip_multi(U0: FloatArray, P: Any, tol: float, constr_tol: float, mu0: FloatArray,
             max_iter: int, deadline: float, polish_iters: int, reach: float,
             margin: float, lo: FloatArray, hi: FloatArray, ug: FloatArray,
             wq: float, rank: bool) -> tuple[Any, ...]:  # fmt: skip
    """The barrier method from each row of ``U0`` (k, N), each run followed by
    ``polish_iters`` steps of :func:`polish` (0: none, the caller polishes).

    ``mu0[j]`` is the initial barrier parameter of start j; ``lo``/``hi`` (N,; empty:
    none) add the box ``lo <= u <= hi`` as block rows and ``wq |u - ug|^2`` is added to the
    objective (a path step's extensions, :func:`kernel.evaluate`; writable arrays: one
    compiled specialisation). Returns the points (k, N), statuses, iteration counts and,
    with ``rank``, the scaled objective values and the worst scaled violation of each
    (equalities and rows, without the extensions; else inf), for ranking; then the last
    run's final slacks ``s`` and multipliers ``z``, ``yE`` (of the problem as ``P`` states
    it, i.e. without the objective scaling the loop applies: a path's continuation step
    starts from them, the path kernels' ``_pc_step``). The caller re-checks the pose it
    returns.

    One compiled function holds the loop and the starts: numba finishes every compiled
    function as a library with its callees linked in, so a loop of its own would be
    optimised and turned into machine code twice (as itself, and inside this kernel).
    """
    ns, N = U0.shape
    X = U0.copy()  # a start skipped past the deadline keeps its start
    statuses = np.full(ns, IP_SKIPPED)
    nit = np.zeros(ns, dtype=np.int64)
    obj = np.full(ns, np.inf)
    viol = np.full(ns, np.inf)
    none = np.empty(0)
    s_last = z_last = yE_last = none
    soc = N >= _SOC_MIN_N  # second-order corrections (:func:`_second_order`)
    for j in range(ns):
        if j > 0 and _now() > deadline:
            break
        x = U0[j].copy()
        f, g, cE, AE, cI, AI, parts = kernel.evaluate(x, P, lo, hi, ug, wq)
        m = cI.size
        if not (_finite(cI) and _finite(cE) and math.isfinite(f)):
            # a start of non-finite values: no run, multipliers of 1 and 0
            stj, it, fs = IP_NONFINITE, 0, 1.0
            s, z, yE = cI, np.ones(m), np.zeros(cE.size)
        else:
            fs = _objective_scale(g)
            Ps = kernel.with_fscale(P, P.fscale / fs)
            f, g = f * fs, g * fs
            wqs = wq * fs
            mu = mu0[j]
            mu_min = min(tol, constr_tol) / 10.0
            s = np.maximum(cI, 1e-2)
            z = np.ones(m)  # bound multipliers start at 1, as IPOPT's
            yE = kernel.eq_multipliers(Ps, AE, g, AIT_dot(AI, z))
            last_shift = prev_shift = 0.0  # the last nonzero shift; the previous step's
            logsum = np.log(s).sum()
            theta_max, theta_min = _filter_bounds(cE, cI, s)
            filt = np.empty((max_iter + 1, 2))
            nfilt = 0
            status = IP_MAX_ITER
            fails = 0
            it = 0
            n_acc = 0  # iterations in a row at the acceptable level (_ACC_TOL) ...
            f_acc = f  # ... and the objective at the first of them
            period = kernel.clock_period(Ps)
            chain = kernel.chained(Ps, N)  # the mode's structured steps
            # the leg-force rows' curvature (the last n_force dense rows): an SR1 estimate
            n_force = 12 * P.forces[9].size
            B = np.zeros((N, N)) if n_force > 0 else np.zeros((0, 0))
            for it in range(max_iter):
                if it % period == period - 1 and _now() > deadline:
                    status = IP_MAX_TIME
                    break
                AEty = kernel.eq_transpose_dot(Ps, AE, yE)
                AItz = AIT_dot(AI, z)
                e_du, e_pr, comp, sd = _errors(g, AEty, AItz, cE, cI, s, z, yE)
                if max(e_du, comp / sd) <= tol and e_pr <= constr_tol:
                    status = IP_SUCCESS
                    break
                if max(e_du, comp / sd) <= _ACC_TOL and e_pr <= constr_tol:
                    if n_acc == 0 or abs(f - f_acc) > _ACC_OBJ_RTOL * max(abs(f), 1.0):
                        n_acc = 0
                        f_acc = f
                    n_acc += 1
                    if n_acc >= _ACC_ITER:
                        status = IP_SUCCESS
                        break
                else:
                    n_acc = 0
                mu_next = _next_mu(mu, mu_min, e_du, e_pr, sd, s, z)
                if mu_next != mu:
                    mu = mu_next
                    nfilt = 0
                # --- Newton step -----------------------------------------------------------
                if chain:
                    W = kernel.chain_hessian(parts, yE, block_part(z, AI), Ps, wqs)
                else:
                    W = kernel.hessian(parts, yE, block_part(z, AI), Ps, wqs)
                if not (_finite(W) and _finite(g) and _finite(AE)):
                    status = IP_NONFINITE
                    break
                if n_force > 0:
                    W += B
                Sig = z / s
                add_normal(W, AI, Sig)  # the blocks' J^T Sigma J (and the dense rows', everywhere)
                rhs = _newton_rhs(g, AEty, AI, cI, s, Sig, mu)
                if chain:
                    dx, shift, fac = kernel.chain_kkt_step(Ps, W, AE, cE, rhs, last_shift,
                                                           prev_shift == 0.0)  # fmt: skip
                else:
                    dx, shift, fac = kernel.kkt_step(Ps, W, AE, cE, rhs, last_shift,
                                                     prev_shift == 0.0)  # fmt: skip
                if not _finite(dx):
                    status = IP_NONFINITE
                    break
                prev_shift = shift
                if shift > 0.0:
                    last_shift = shift
                ds, dz = _slack_steps(AI_dot(AI, dx), cI, s, z, Sig, mu)
                # --- filter line search -----------------------------------------------------
                accepted, alpha, xt, st, logsum_t, ev, dx, dz, a_z, nfilt = _line_search(
                    x, s, z, dx, ds, dz, Ps, lo, hi, ug, wqs, mu, theta_max, theta_min, filt,
                    nfilt, logsum, (f, g, cE, AE, cI, AI, parts), soc, W, AEty, Sig, fac, shift,
                )  # fmt: skip
                ft, gt, cEt, AEt, cIt, AIt, parts_t = ev
                if not accepted:
                    fails += 1
                    if fails >= 3:
                        status = IP_STALLED
                        break
                    # a tiny step keeps the iteration going; the barrier will be re-centred
                    nfilt = 0
                    alpha = min(alpha, 1e-8)
                    xt = x + alpha * dx
                    st = s + alpha * ds
                    ft, gt, cEt, AEt, cIt, AIt, parts_t = kernel.evaluate(xt, Ps, lo, hi, ug, wqs)
                    if not (math.isfinite(ft) and _finite(cIt)):
                        status = IP_NONFINITE
                        break
                else:
                    fails = 0
                x = xt
                # slack reset: a slack below its constraint value only adds violation
                s = st
                logsum = logsum_t if accepted else np.log(s).sum()
                logsum = _reset_slacks(s, z, cIt, dz, a_z, mu, logsum)
                if n_force > 0:
                    force_update(B, alpha * dx, AI, AIt, z, n_force)
                f, g, cE, AE, cI, AI, parts = ft, gt, cEt, AEt, cIt, AIt, parts_t
                yE = kernel.eq_multipliers(Ps, AE, g, AIT_dot(AI, z))
            stj = status
            if status != IP_SUCCESS:
                it += 1
        s_last, z_last, yE_last = s, z / fs, yE / fs
        if stj == IP_NONFINITE or not _finite(x):
            x = U0[j].copy()
            stj = IP_NONFINITE
        x = polish(x, P, polish_iters, reach, margin)
        for k in range(N):
            X[j, k] = x[k]
        statuses[j] = stj
        nit[j] = it
        if not rank:
            continue
        f, g, cE, AE, cI, _, _ = kernel.evaluate(x, P, none, none, none, 0.0)
        obj[j] = f
        viol[j] = max(_abs_max(cE), max(0.0, -_amin(cI)))
        if j + 1 == GIVE_UP_AFTER and _amin(viol[: j + 1]) > GIVE_UP_VIOLATION:
            break  # likely unreachable: the caller's SQP fallback decides, quickly
    return X, statuses, nit, obj, viol, s_last, z_last, yE_last


def ip_loop(u0: FloatArray, P0: Any, tol: float, constr_tol: float, mu0: float,
            max_iter: int, deadline: float, lo: FloatArray, hi: FloatArray, ug: FloatArray,
            wq: float) -> tuple[Any, ...]:  # fmt: skip
    """The barrier method from ``u0`` alone (:func:`ip_multi` with one start, no polish,
    no ranking): the point, the status, the iteration count and the final slacks ``s``
    and multipliers ``z``, ``yE`` (of the problem as ``P0`` states it)."""
    X, st, nit, _, _, s, z, yE = ip_multi(
        np.array(u0, dtype=float).reshape(1, -1), P0, tol, constr_tol,
        np.array([float(mu0)]), max_iter, deadline, 0, 0.0, 0.0, np.array(lo, dtype=float),
        np.array(hi, dtype=float), np.array(ug, dtype=float), float(wq), False,
    )  # fmt: skip
    return X[0], int(st[0]), int(nit[0]), s, z, yE


def ip_box(u0: FloatArray, P: Any, lo: FloatArray, hi: FloatArray, ug: FloatArray, wq: float,
           tol: float, constr_tol: float, mu0: float, max_iter: int, reach: float,
           margin: float) -> tuple[FloatArray, int, int]:  # fmt: skip
    """One barrier solve of a path step inside the box ``lo <= u <= hi`` (scaled, (N,)
    each) with ``wq |u - ug|^2`` added to the objective (``wq = 0``, ``ug`` empty: none),
    then 3 steps of :func:`polish`: :func:`ip_multi` with the one start ``u0`` (N,) (one
    compiled kernel for both, not two). Returns the point (``u0`` itself when the solve
    gave non-finite values), the status and the iteration count; the caller checks the
    pose and the box."""
    # copies: the compiled loop sees writable arrays whatever the caller passes
    U0 = np.array(u0, dtype=float).reshape(1, -1)
    X, st, nit, _, _, _, _, _ = ip_multi(U0, P, tol, constr_tol, np.array([float(mu0)]),
                                         max_iter, 1e300, 3, reach, margin,
                                         np.array(lo, dtype=float), np.array(hi, dtype=float),
                                         np.array(ug, dtype=float), float(wq), False)  # fmt: skip
    if st[0] == IP_NONFINITE:
        return np.array(u0, dtype=float), IP_NONFINITE, int(nit[0])
    return X[0], int(st[0]), int(nit[0])
