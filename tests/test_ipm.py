"""Tests of the compiled interior-point path (stackik._compiled.planar) and of
method="ip"/"auto"."""

from __future__ import annotations

import math

import numpy as np
import pytest

import stackik as sk
from stackik._compiled import linalg as _ip_linalg
from stackik._compiled import planar as _ipm
from stackik.check import check_pose
from stackik.formulation import Problem
from stackik.geometry import Stack
from stackik.methods import ip as ip_method
from stackik.result import IKStatus, OptionError
from stackik.sampling import random_stack
from stackik.starts import paper_initial_guess

PAPER_TARGETS = [(600.0, 1000.0, -1.57), (145.0, 1500.0, -0.207), (-319.0, 1532.0, 0.332)]
STACK4 = sk.Stack.reference(4, leg_radius=0.0)


def random_problem(n: int, seed: int, phi: float, objective: str = "frobenius"):
    rng = np.random.default_rng(seed)
    st = random_stack(n, seed) if seed % 2 else Stack.reference(n, leg_radius=0.0)
    t = sk.PlanarTarget(300 * rng.standard_normal(), 300 * n + 100 * rng.random(), 0.3, phi)
    prob = Problem(st, t, objective, None)
    q = paper_initial_guess(st, t)
    q[:, :2] += rng.normal(0, 40, (n, 2))
    q[:, 2] += rng.normal(0, 0.2, n)
    return prob, prob.u_of(q), ip_method.problem_arrays(prob), rng


def blocks_to_dense(D: np.ndarray) -> np.ndarray:
    n = D.shape[0]
    full = np.zeros((n, 24, n, 3))
    full[np.arange(n), :, np.arange(n), :] = D
    return full.reshape(24 * n, 3 * n)


CASES = [(n, seed, phi) for n in (1, 2, 4, 7) for seed in (0, 1) for phi in (0.0, 0.8, -2.1)]


@pytest.mark.parametrize(("n", "seed", "phi"), CASES)
def test_compiled_evaluation_matches_python_problem(n, seed, phi):
    prob, u, P, _ = random_problem(n, seed, phi)
    f, g, cE, AE, cI, D = _ipm._evaluate(u, P)
    f0, g0, cE0, AE0, cI0, AI0 = prob.evaluate(u)
    np.testing.assert_allclose(f, f0, rtol=1e-12)
    np.testing.assert_allclose(g, g0, rtol=1e-10, atol=1e-12 * np.abs(g0).max())
    np.testing.assert_allclose(cE, cE0, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(AE, AE0, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(cI, cI0, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(blocks_to_dense(D), AI0, rtol=1e-12, atol=1e-13)


@pytest.mark.derivatives
@pytest.mark.parametrize(("n", "seed", "phi"), CASES)
def test_compiled_derivatives_by_finite_differences(n, seed, phi):
    """Tolerances from the step and the scales of f, cE, cI in the scaled variables u
    (x / L for translations, L = max leg_max; see tests/fd.py)."""
    import fd  # the derivative toolkit of tests/

    prob, u, P, rng = random_problem(n, seed, phi)

    def parts(v):
        f, g, cE, AE, cI, D = _ipm._evaluate(v, P)
        return f, g, cE, AE, cI, blocks_to_dense(D)

    f, g, cE, AE, cI, AI = parts(u)
    # scales: positions are at most Lc (chain length) [mm], i.e. Lc / L in u; the objective
    # sums n squared residuals of at most that; the equalities add the target; the limits
    # are the raw constraints (fd.constraint_scale) times their row scaling prob.cs
    q = prob.q_of(u)
    lc = fd.chain_length(q) / prob.L
    F_f = f + n * lc**2
    F_E = 1.0 + 2.0 * lc + float(np.abs(q[:, 2]).sum() + np.abs(cE).max())
    st = prob.stack
    F_I = fd.constraint_scale(st.top_nodes, st.base_nodes, st.leg_max, q).ravel() * prob.cs
    num = fd.central(lambda v: parts(v)[0], u)
    fd.assert_derivative_close(g, num, f_scale=F_f, what="gradient")
    num = fd.central(lambda v: parts(v)[2], u)
    fd.assert_derivative_close(AE, num, f_scale=F_E, what="AE")
    num = fd.central(lambda v: parts(v)[4], u)
    fd.assert_derivative_close(AI, num, f_scale=F_I, what="AI")
    # Hessian of the Lagrangian f - yE.cE - z.cI against differences of its gradient
    yE = rng.standard_normal(3)
    z = rng.random(24 * n)

    def grad_l(v):
        f, g, cE, AE, cI, AI = parts(v)
        return g - AE.T @ yE - AI.T @ z

    H = _ipm._lagrangian_hessian(u, yE, z, P)
    num = fd.central(grad_l, u, richardson=True)  # Richardson: a ~100x tighter bound
    F_L = F_f + float(np.abs(yE).sum()) * F_E + float(z @ F_I)  # the Lagrangian's scale
    F_rows = fd.derivative_scale(F_L, num.x_scale)
    fd.assert_derivative_close(H, num, f_scale=F_rows, what="Lagrangian Hessian")
    scale = max(1.0, np.abs(H).max())
    np.testing.assert_allclose(H, H.T, atol=1e-12 * scale)
    np.testing.assert_allclose(H, prob.lagrangian_hessian(u, yE, z), rtol=1e-9, atol=1e-11 * scale)


def test_feasible_objective_is_zero_in_compiled_evaluation():
    prob, u, _, _ = random_problem(3, 0, 0.0, objective="feasible")
    P = ip_method.problem_arrays(prob)
    f, g, *_ = _ipm._evaluate(u, P)
    assert f == 0.0 and not np.any(g)


def test_cholesky_and_kkt_step():
    rng = np.random.default_rng(4)
    A = rng.standard_normal((6, 6))
    S = A @ A.T + 0.1 * np.eye(6)
    R, ok = _ip_linalg._cholesky(S, 0.0)
    assert ok and np.array_equal(R, np.triu(R))  # S = R^T R, R upper triangular
    np.testing.assert_allclose(R.T @ R, S, atol=1e-12)
    b = rng.standard_normal(6)
    np.testing.assert_allclose(_ip_linalg._cho_solve(R, b), np.linalg.solve(S, b), rtol=1e-10)
    assert not _ip_linalg._cholesky(S - 10.0 * np.eye(6), 0.0)[1]
    big = rng.standard_normal((40, 40))
    assert _ip_linalg._cholesky(big @ big.T + np.eye(40), 0.0)[1]  # the LAPACK branch
    assert not _ip_linalg._cholesky(-np.eye(40), 0.0)[1]
    # KKT: [W -A^T; A 0][dx; dy] = [r; -c] with W positive definite on null(A)
    N = 9
    W = rng.standard_normal((N, N))
    W = W @ W.T + np.eye(N)
    Aeq = rng.standard_normal((3, N))
    c = rng.standard_normal(3)
    r = rng.standard_normal(N)
    dx, dy, curv, shift = _ipm._kkt_step(W, Aeq, c, r, 0.0, True)
    assert shift == 0.0
    np.testing.assert_allclose(W @ dx - Aeq.T @ dy, r, atol=1e-10)
    np.testing.assert_allclose(Aeq @ dx, -c, atol=1e-10)
    np.testing.assert_allclose(curv, dx @ W @ dx, rtol=1e-12)
    # indefinite: a shift makes the reduced Hessian positive definite
    dx, dy, curv, shift = _ipm._kkt_step(-W, Aeq, c, r, 0.0, True)
    assert shift > 0.0
    np.testing.assert_allclose(Aeq @ dx, -c, atol=1e-10)
    np.testing.assert_allclose(-W @ dx + shift * dx - Aeq.T @ dy, r, atol=1e-8 * (1 + shift))
    # after a shifted step (try_plain False) the unshifted matrix is not tried: the shift
    # starts at a third of the last one, even where none is needed, and the step solves
    # the shifted system
    dx, dy, curv, shift = _ipm._kkt_step(W, Aeq, c, r, 3.0, False)
    assert shift == 1.0
    np.testing.assert_allclose(Aeq @ dx, -c, atol=1e-10)
    np.testing.assert_allclose(W @ dx + shift * dx - Aeq.T @ dy, r, atol=1e-8)
    # ... and with no earlier shift the unshifted matrix is tried whatever try_plain says
    assert _ipm._kkt_step(W, Aeq, c, r, 0.0, False)[3] == 0.0


def _block_semiseparable(rng, nb, r, shift):
    """A symmetric matrix with diagonal blocks ``Ad`` and blocks ``U_b V_c^T`` below them."""
    K = 3 * nb
    U, V = rng.standard_normal((K, r)), rng.standard_normal((K, r))
    blk = np.arange(K) // 3
    below = blk[:, None] > blk[None, :]
    S = np.where(below, U @ V.T, 0.0)
    S = S + S.T
    Ad = np.empty((nb, 3, 3))
    for b in range(nb):
        G = rng.standard_normal((3, 3))
        Ad[b] = G @ G.T + shift * np.eye(3)
        S[3 * b : 3 * b + 3, 3 * b : 3 * b + 3] = Ad[b]
    return S, Ad, U, V


@pytest.mark.parametrize(("nb", "r"), [(1, 2), (4, 3), (21, 11)])
def test_semiseparable_factor_solves_and_refuses_as_the_dense_one(nb, r):
    """The block semiseparable factor (``linalg.semisep_factor``) solves like a dense
    solve (to the matrix's condition times rounding) and is refused exactly where the
    matrix is not positive definite."""
    rng = np.random.default_rng(nb + r)
    for shift in (3.0 * r * nb, 0.3 * r * nb, -5.0):
        S, Ad, U, V = _block_semiseparable(rng, nb, r, shift)
        G, ok = _ip_linalg.semisep_factor(Ad, U, V)
        assert ok == (np.linalg.eigvalsh(S).min() > 1e-8 * np.abs(S).max())
        if ok:
            b = rng.standard_normal(3 * nb)
            x = _ip_linalg.semisep_solve(G, b)
            x0 = np.linalg.solve(S, b)
            bound = 1e3 * np.linalg.cond(S) * np.finfo(float).eps
            np.testing.assert_allclose(x, x0, atol=bound * np.abs(x0).max())


@pytest.mark.parametrize(("n", "seed", "objective"),
                         [(5, 0, "frobenius"), (24, 1, "frobenius"), (64, 2, "frobenius"),
                          (9, 3, "feasible")])  # fmt: skip
def test_chain_generators_reproduce_the_hessian_below_its_blocks(n, seed, objective):
    """Below a platform's own block, the planar Lagrangian Hessian is ``U V^T`` with the
    chain's five generator columns (``_chain_generators``), for the FN and the feasibility
    objectives, reference and random stacks."""
    prob, u, P, rng = random_problem(n, seed, 0.7, objective)
    H = _ipm._lagrangian_hessian(u, rng.standard_normal(3), rng.random(24 * n), P)
    AE = _ipm._evaluate(u, P)[3]
    U, V = _ipm._chain_generators(H, AE, P)
    blk = np.arange(3 * n) // 3
    below = blk[:, None] > blk[None, :]
    np.testing.assert_allclose((U @ V.T)[below], H[below], rtol=0,
                               atol=1e-13 * np.abs(H).max())  # fmt: skip


@pytest.mark.parametrize(("n", "seed", "bump", "last_shift"),
                         [(24, 0, 1e3, 0.0), (24, 0, 1e3, 5.0), (64, 2, 1e4, 0.0),
                          (40, 4, 1e6, 0.0), (64, 6, 1e8, 5.0), (13, 1, 1e3, 0.0),
                          (31, 3, 1e5, 5.0)])  # fmt: skip
def test_structured_kkt_step_matches_the_dense_one(n, seed, bump, last_shift):
    """From ``STRUCTURED_MIN_N`` variables on, the KKT step of a problem without dense rows
    factors the reduced Hessian by its structure: the same shift as the dense factor, and
    the same step to the reduced Hessian's condition number times rounding (reference
    stacks for even seeds, random ones for odd)."""
    assert 3 * n >= _ipm.STRUCTURED_MIN_N  # the structured path
    prob, u, P, rng = random_problem(n, seed, 0.3)
    yE, z = rng.standard_normal(3), rng.random(24 * n)
    barrier = np.zeros((3 * n, 3 * n))  # the barrier terms: a psd block per platform
    for b in range(n):
        G = rng.standard_normal((3, 3))
        barrier[3 * b : 3 * b + 3, 3 * b : 3 * b + 3] = bump * G @ G.T
    W = _ipm._lagrangian_hessian(u, yE, z, P) + barrier
    AE = _ipm._evaluate(u, P)[3]
    cE, rhs = 1e-3 * rng.standard_normal(3), rng.standard_normal(3 * n)
    dx0, _, _, shift0 = _ipm._kkt_step(W, AE, cE, rhs, last_shift, last_shift == 0.0)
    # the kernel's entry point has no Python wrapper: its Python body runs the same code
    assert _ipm._chained.py_func(P, 3 * n)
    dx, shift, fac = _ipm._structured_step.py_func(P, W, AE, cE, rhs, last_shift,
                                                   last_shift == 0.0)  # fmt: skip
    assert fac[4].shape[0] > 0 and shift == shift0  # the structured factor
    # the barrier loop's Hessian there forms only the blocks that step reads: the same step
    Wp = _ipm._hessian_of(u, yE, z, P, 0.0, True) + barrier
    blk = np.arange(3 * n) // 3
    needed = (blk[:, None] == blk[None, :]) | (blk[:, None] == 0) | (blk[None, :] == 0)
    assert not Wp[~needed].any()
    dxp = _ipm._structured_step.py_func(P, Wp, AE, cE, rhs, last_shift, last_shift == 0.0)[0]
    np.testing.assert_array_equal(dxp, dx)
    E = fac[1]
    Z = np.vstack([E, np.eye(3 * n - 3)])
    cond = np.linalg.cond(Z.T @ (W + shift * np.eye(3 * n)) @ Z)
    bound = 1e2 * cond * np.finfo(float).eps
    np.testing.assert_allclose(dx, dx0, rtol=0, atol=bound * np.abs(dx0).max())
    np.testing.assert_allclose(AE @ dx, -cE, atol=1e-12)


def test_structured_step_shifts_as_far_as_the_dense_one():
    """Extreme negative curvature in the first platform's block (it reaches every entry of
    the reduced Hessian): the structured step's shift schedule goes as far as the dense
    one's (its end is the reduced Hessian's largest diagonal entry, not W's) and ends at
    the same shift with a finite step."""
    n = 16
    prob, u, P, rng = random_problem(n, 0, 0.3)
    W = _ipm._lagrangian_hessian(u, rng.standard_normal(3), rng.random(24 * n), P)
    W[:3, :3] -= 1e25 * np.eye(3)
    for b in range(1, n):
        W[3 * b : 3 * b + 3, 3 * b : 3 * b + 3] += 1e3 * np.eye(3)
    AE = _ipm._evaluate(u, P)[3]
    cE, rhs = 1e-3 * rng.standard_normal(3), rng.standard_normal(3 * n)
    dx0, _, _, shift0 = _ipm._kkt_step(W, AE, cE, rhs, 0.0, True)
    dx, shift, _ = _ipm._structured_step.py_func(P, W, AE, cE, rhs, 0.0, True)
    assert shift == shift0 > 1e24
    assert np.all(np.isfinite(dx)) and np.all(np.isfinite(dx0))


def test_kkt_factor_serves_other_right_hand_sides():
    """The factor the step returns (``_kkt_factor``) solves the system with another ``cE``
    and ``rhs`` (a second-order correction) exactly as a fresh step would, planar and
    spatial, shifted or not; the spatial SVD basis (first six columns singular) too."""
    from stackik._compiled import spatial as _sp

    rng = np.random.default_rng(7)
    for mod, E, N in ((_ipm, 3, 12), (_sp, 6, 24)):
        W = rng.standard_normal((N, N))
        W = W @ W.T + np.eye(N)
        AE = rng.standard_normal((E, N))
        for sign in (1.0, -1.0):  # positive definite, then indefinite (a shift)
            fac, shift = mod._kkt_factor(sign * W, AE, 0.0, True)
            assert (shift > 0.0) == (sign < 0.0)
            c2, r2 = rng.standard_normal(E), rng.standard_normal(N)
            dx = mod._kkt_solve(fac, sign * W, c2, r2, shift)
            np.testing.assert_array_equal(dx, mod._kkt_step(sign * W, AE, c2, r2, 0.0, True)[0])
            np.testing.assert_allclose(AE @ dx, -c2, atol=1e-10)
            # W dx + shift dx - rhs lies in the range of AE^T
            res = sign * W @ dx + shift * dx - r2
            y = np.linalg.lstsq(AE.T, res, rcond=None)[0]
            np.testing.assert_allclose(AE.T @ y, res, atol=1e-8 * (1.0 + shift))
    AE = rng.standard_normal((6, 24))
    AE[:, 5] = AE[:, 4]  # B singular: the orthonormal basis from the SVD
    W = rng.standard_normal((24, 24))
    W = W @ W.T + np.eye(24)
    fac, shift = _sp._kkt_factor(W, AE, 0.0, True)
    assert not fac[-1] and shift == 0.0
    c, r = rng.standard_normal(6), rng.standard_normal(24)
    dx = _sp._kkt_solve(fac, W, c, r, shift)
    np.testing.assert_allclose(AE @ dx, -c, atol=1e-10)
    res = W @ dx - r
    np.testing.assert_allclose(AE.T @ np.linalg.lstsq(AE.T, res, rcond=None)[0], res, atol=1e-8)


def test_second_order_corrections_finish_a_tall_stack(lines_pass_through: None):
    """Planar n = 64 from the paper's guess toward a far target: without the barrier
    method's second-order corrections the run crawled in backtracked steps (the rows'
    curvature raised the infeasibility of every full step) to the 300-iteration limit;
    with them it converges in about 60 (docs/benchmarks.md, 2026-12-06)."""
    stack = Stack.reference(64, leg_radius=0.0)
    t = sk.PlanarTarget(12532.055335141049, 13229.59741863084, -1.309481835825551,
                        4.39822971502571)  # fmt: skip
    prob = Problem(stack, t, "frobenius", None)
    u, nit, status = ip_method.ip_solve(prob, prob.u_of(paper_initial_guess(stack, t)))
    assert status == "success" and nit < 150
    assert check_pose(stack, t, prob.q_of(u)).ok


def test_acceptable_level_ends_a_run_that_cannot_meet_tol():
    """A tolerance no run meets (1e-30): the run ends at the acceptable level
    (``barrier._ACC_TOL`` for ``_ACC_ITER`` iterations with the objective still) as a
    success, at the optimum the default tolerance reaches, well before ``max_iter``."""
    from stackik._compiled import barrier

    t = sk.PlanarTarget(*PAPER_TARGETS[0])
    prob = Problem(STACK4, t, "frobenius", None)
    u0 = prob.u_of(paper_initial_guess(STACK4, t))
    u, nit, status = ip_method.ip_solve(prob, u0)
    u_acc, nit_acc, status_acc = ip_method.ip_solve(prob, u0, {"tol": 1e-30, "max_iter": 300})
    assert status == status_acc == "success"
    assert nit <= nit_acc <= nit + 2 * barrier._ACC_ITER + 20
    fn = math.sqrt(prob.objective_value(prob.q_of(u)))
    fn_acc = math.sqrt(prob.objective_value(prob.q_of(u_acc)))
    # the same optimum: the longer run no higher, within the default tolerance's reach
    assert fn_acc <= fn * (1 + 1e-12)
    assert fn_acc == pytest.approx(fn, rel=1e-8)


def test_ip_solve_reaches_the_paper_optimum():
    t = sk.PlanarTarget(*PAPER_TARGETS[0])
    prob = Problem(STACK4, t, "frobenius", None)
    u, nit, status = ip_method.ip_solve(prob, prob.u_of(paper_initial_guess(STACK4, t)))
    assert status == "success" and 5 < nit < 100
    q = prob.q_of(u)
    assert check_pose(STACK4, t, q).ok
    fn = math.sqrt(prob.objective_value(q))
    assert fn == pytest.approx(884.152, abs=0.01)  # IPOPT's value (issue text: 884.2)


@pytest.mark.parametrize("target", PAPER_TARGETS)
@pytest.mark.parametrize("phi", [0.0, 1.1])
def test_ip_matches_or_beats_sqp(target, phi):
    t = sk.PlanarTarget(*target, phi=phi)
    ip = sk.solve_ik(STACK4, t, method="ip")
    sqp = sk.solve_ik(STACK4, t, method="sqp")
    non = sk.solve_ik(STACK4, t, objective="feasible")
    assert ip.success and ip.method == "ip" and ip.n_starts == 3
    assert check_pose(STACK4, t, ip.q).ok
    assert ip.frobenius_norm <= sqp.frobenius_norm * 1.001
    assert ip.frobenius_norm < non.frobenius_norm
    assert ip.objective_value == pytest.approx(ip.frobenius_norm**2, rel=1e-9)


def test_auto_picks_the_engine():
    t = sk.PlanarTarget(*PAPER_TARGETS[1])
    assert sk.solve_ik(STACK4, t).method == "ip"
    assert sk.solve_ik(STACK4, t, objective="feasible").method == "sqp"
    assert sk.solve_ik(STACK4, t, qp_solver="daqp").method == "sqp"
    assert sk.solve_ik(STACK4, t, options={"hessian": "bfgs"}).method == "sqp"
    assert sk.solve_ik(STACK4, t, options={"mu0": 0.5}).method == "ip"
    w = sk.solve_ik(STACK4, t, objective="weighted", sigma_t=1.0, sigma_theta=0.005)
    assert w.method == "ip" and w.success
    w2 = sk.solve_ik(
        STACK4, t, objective="weighted", sigma_t=1.0, sigma_theta=[0.005, 0.01, 0.005, 0.005]
    )
    assert w2.method == "sqp" and w2.success
    sp = sk.solve_ik(STACK4, t.to_spatial())  # the spatial interior point
    assert sp.method == "ip" and sp.success
    sp = sk.solve_ik(STACK4, t.to_spatial(), objective="feasible")
    assert sp.method == "sqp" and sp.success


def test_weighted_uniform_has_the_frobenius_minimiser():
    t = sk.PlanarTarget(*PAPER_TARGETS[0])
    fro = sk.solve_ik(STACK4, t)
    w = sk.solve_ik(STACK4, t, objective="weighted", sigma_t=0.0, sigma_theta=0.01)
    # sigma_t = 0: trace(J C J^T) = sigma_theta^2 (FN^2 - 2n), same minimiser
    assert w.frobenius_norm == pytest.approx(fro.frobenius_norm, rel=1e-6)


def test_ip_input_errors():
    t = sk.PlanarTarget(*PAPER_TARGETS[0])
    with pytest.raises(ValueError, match="one sigma_theta"):
        sk.solve_ik(
            STACK4, t, method="ip", objective="weighted", sigma_t=1.0, sigma_theta=[1, 2, 1, 1]
        )
    with pytest.raises(OptionError, match="not an interior-point option"):
        sk.solve_ik(STACK4, t, method="ip", options={"hessian": "bfgs"})
    for bad in (0, -1.0, math.nan, "x", True):
        with pytest.raises(OptionError, match="bad value"):
            sk.solve_ik(STACK4, t, method="ip", options={"tol": bad})
    with pytest.raises(OptionError):
        sk.solve_ik(STACK4, t, method="ip", options={"max_iter": math.inf})


def test_ip_statuses_without_fallback():
    t = sk.PlanarTarget(*PAPER_TARGETS[0])
    x0 = paper_initial_guess(STACK4, t) + 30.0
    r = sk.solve_ik(STACK4, t, x0=x0, method="ip", options={"max_iter": 1})
    assert r.status is IKStatus.MAX_ITER and not r.success and r.method == "ip"
    # method="auto" hands over to SQP with the same iteration limit
    r = sk.solve_ik(STACK4, t, x0=x0, options={"max_iter": 1})
    assert r.status is IKStatus.MAX_ITER and not r.success and r.method == "sqp"
    r = sk.solve_ik(STACK4, t, method="ip", options={"max_time": 1e-9})
    assert r.success or r.status is IKStatus.MAX_TIME


def test_ip_never_claims_a_pose_that_fails_the_check(monkeypatch):
    t = sk.PlanarTarget(*PAPER_TARGETS[0])

    def lying(prob, U0, options=None):  # reports feasible optima at points off target
        k = U0.shape[0]
        return U0 + 1e-3, ["success"] * k, np.ones(k, int), np.zeros(k), np.zeros(k)

    monkeypatch.setattr(ip_method, "ip_multi", lying)
    r = sk.solve_ik(STACK4, t, method="ip")
    assert not r.success and r.status is IKStatus.FAILED
    assert not check_pose(STACK4, t, r.q).ok
    r = sk.solve_ik(STACK4, t)  # auto: the SQP engine takes over and succeeds
    assert r.success and r.method == "sqp" and check_pose(STACK4, t, r.q).ok


def test_ip_unreachable_target_reports_infeasible():
    r = sk.solve_ik(STACK4, sk.PlanarTarget(100.0, 300.0, 2.5), max_time=5.0)
    assert not r.success
    assert r.status in (IKStatus.INFEASIBLE, IKStatus.MAX_ITER, IKStatus.FAILED)
    assert r.max_violation > 0 or r.target_error > 0


@pytest.mark.parametrize("n", [1, 2, 8, 16])
def test_ip_other_sizes_and_geometries(n):
    st = random_stack(n, n)
    rng = np.random.default_rng(n)
    q = paper_initial_guess(st, sk.PlanarTarget(0.0, 350.0 * n, 0.0))
    q[:, 2] += rng.normal(0, 0.05, n)
    t = sk.PlanarTarget(*sk.planar_forward(q), phi=0.4)  # reachable by construction?
    r = sk.solve_ik(st, t, method="ip")
    if check_pose(st, t, q).ok:  # when the construction is feasible, must succeed
        assert r.success
    if r.success:
        assert check_pose(st, t, r.q).ok


def test_ip_reproducible_with_rng():
    t = sk.PlanarTarget(*PAPER_TARGETS[2])
    a = sk.solve_ik(STACK4, t, method="ip", starts=6, rng=5)
    b = sk.solve_ik(STACK4, t, method="ip", starts=6, rng=5)
    np.testing.assert_array_equal(a.q, b.q)
    one = sk.solve_ik(STACK4, t, method="ip", starts=1)
    assert a.frobenius_norm <= one.frobenius_norm * (1 + 1e-9)


def test_warm_up_returns_seconds():
    assert ip_method.warm_up() >= 0.0


@pytest.mark.parametrize("n", [1, 2, 3, 4, 7, 12])
def test_gauss_newton_closed_form(n):
    rng = np.random.default_rng(n)
    q = np.column_stack([rng.normal(0, 100, n), 300 + rng.normal(0, 50, n), rng.normal(0, 0.4, n)])
    c, s, _, J, d = _ipm._kinematics(q)
    _, Jr = sk.kinematics.planar_fn_residuals(q)  # the Python residual Jacobian
    GN = _ipm._gauss_newton(c, s, d, False)
    np.testing.assert_allclose(GN, Jr.T @ Jr, rtol=1e-12, atol=1e-9 * max(1.0, np.abs(GN).max()))


def test_threads_give_the_serial_results():
    from concurrent.futures import ThreadPoolExecutor

    targets = [sk.PlanarTarget(*t, phi=phi) for t in PAPER_TARGETS for phi in (0.0, 0.9)]
    serial = sk.solve_many(STACK4, targets)
    with ThreadPoolExecutor(2) as ex:
        threaded = sk.solve_many(STACK4, targets, executor=ex)
    for a, b in zip(serial, threaded, strict=True):
        assert a.success and b.success and a.method == "ip"
        np.testing.assert_array_equal(a.q, b.q)
