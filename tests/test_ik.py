"""Tests of the IK layer: paper targets, starts, statuses, derivatives, baselines."""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import stackik as sk
from stackik.check import check_pose
from stackik.formulation import Problem
from stackik.result import IKStatus
from stackik.starts import paper_initial_guess

PAPER_TARGETS = [(600.0, 1000.0, -1.57), (145.0, 1500.0, -0.207), (-319.0, 1532.0, 0.332)]
STACK4 = sk.Stack.reference(4, leg_radius=0.0)


@pytest.mark.parametrize("target", PAPER_TARGETS)
def test_paper_targets_optimal_beats_feasible(target):
    t = sk.PlanarTarget(*target, phi=0.0)
    opt = sk.solve_ik(STACK4, t)
    non = sk.solve_ik(STACK4, t, objective="feasible")
    assert opt.success and non.success
    assert opt.status is IKStatus.SUCCESS
    assert opt.frobenius_norm < non.frobenius_norm
    for res in (opt, non):
        chk = check_pose(STACK4, t, res.q)
        assert chk.ok
        assert chk.position_error <= 1e-6 and chk.angle_error <= 1e-8
        assert np.all(STACK4.planar_constraints(res.q, 0.0) >= -1e-6)
        y = sk.planar_forward(res.q)
        np.testing.assert_allclose(y, target, atol=1e-6)


def test_result_fields_for_hardware():
    t = sk.PlanarTarget(*PAPER_TARGETS[0], phi=0.4)
    r = sk.solve_ik(STACK4, t)
    assert r.q.shape == (4, 3) and r.P.shape == (4, 3) and r.R.shape == (4, 3, 3)
    assert r.leg_lengths.shape == (4, 6)
    lifted_P, lifted_R = sk.lift_planar(r.q, 0.4)
    np.testing.assert_allclose(r.P, lifted_P)
    legs = np.stack([sk.leg_lengths(g, r.P[i], r.R[i]) for i, g in enumerate(STACK4)])
    np.testing.assert_allclose(r.leg_lengths, legs)
    assert np.all(legs >= 250 - 1e-6) and np.all(legs <= 450 + 1e-6)
    d = r.to_dict()
    assert d["success"] is True and d["status"] == "success" and len(d["q"]) == 4


def test_convex_start_is_feasible():
    for target in PAPER_TARGETS:
        t = sk.PlanarTarget(*target, phi=0.3)
        q = sk.convex_start(STACK4, t)
        chk = check_pose(STACK4, t, q)
        assert chk.max_violation_mm <= 1e-6
        assert chk.position_error <= 1e-6 and chk.angle_error <= 1e-8
        r = sk.solve_ik(STACK4, t, start="convex")
        assert r.success


def test_convex_start_infeasible_raises():
    t = sk.PlanarTarget(3000.0, 100.0, 0.0)
    with pytest.raises(sk.ConvexStartError):
        sk.convex_start(STACK4, t)


def test_paper_initial_guess_shares_rotation():
    t = sk.PlanarTarget(*PAPER_TARGETS[0])
    g = paper_initial_guess(STACK4, t)
    np.testing.assert_allclose(g[:, 2], -1.57 / 4)
    assert np.all(g[:, 1] > 0)


@pytest.mark.parametrize("qp", ["daqp", "osqp", "clarabel"])
def test_backends_agree(qp):
    t = sk.PlanarTarget(*PAPER_TARGETS[1])
    r = sk.solve_ik(STACK4, t, qp_solver=qp)
    ref = sk.solve_ik(STACK4, t)
    assert r.success
    assert r.frobenius_norm == pytest.approx(ref.frobenius_norm, rel=1e-4)


@pytest.mark.parametrize("method", ["slsqp", "trust-constr"])
def test_baselines_return_same_type(method):
    t = sk.PlanarTarget(*PAPER_TARGETS[1])
    r = sk.solve_ik(STACK4, t, method=method, options={"maxiter": 300})
    assert isinstance(r, sk.IKResult) and r.method == method
    if r.success:
        assert check_pose(STACK4, t, r.q).ok


BEYOND = [
    sk.PlanarTarget(5000.0, 5000.0, 0.0),
    sk.PlanarTarget(6000.0, 1000.0, 0.0, 0.4),
    sk.SpatialTarget([4000.0, 2000.0, 3000.0], np.eye(3)),
]


@pytest.mark.parametrize("target", BEYOND)
@pytest.mark.parametrize("method", ["auto", "sqp", "slsqp"])
def test_beyond_the_reach_bound_answers_a_stretched_pose_within_limits(target, method):
    # never the raw first start (legs metres past their limits): a pose within every
    # limit stretched toward the target, with what is left as target_error
    if isinstance(target, sk.SpatialTarget) and method == "slsqp":
        method = "auto"
    r = sk.solve_ik(STACK4, target, method=method)
    assert r.status is IKStatus.INFEASIBLE and not r.success and "reach bound" in r.message
    assert r.max_violation <= 1e-6 and r.target_error > 1000.0
    assert np.all(r.leg_lengths >= 250.0 - 1e-6) and np.all(r.leg_lengths <= 450.0 + 1e-6)
    if isinstance(target, sk.PlanarTarget):
        reached = sk.PlanarTarget(*sk.planar_forward(r.q), phi=target.phi)
    else:
        reached = sk.SpatialTarget(*sk.spatial_forward(r.q))
    assert check_pose(STACK4, reached, r.q).ok  # within every limit
    # stretched: nearer the target than the upright pose
    upright = np.column_stack([np.zeros((4, 2)), np.full(4, 330.0), np.zeros((4, 3))])
    if isinstance(target, sk.PlanarTarget):
        upright_err = check_pose(STACK4, target, upright[:, [0, 2, 3]]).position_error
    else:
        upright_err = check_pose(STACK4, target, upright).position_error
    assert r.target_error < upright_err


def test_status_infeasible_inside_the_bound():
    r2 = sk.solve_ik(STACK4, sk.PlanarTarget(100.0, 300.0, 2.5), max_time=5.0)
    assert not r2.success
    assert r2.status in (IKStatus.INFEASIBLE, IKStatus.MAX_ITER, IKStatus.FAILED)


UNREACHABLE = [(1500.0, 100.0, 0.0), (100.0, 300.0, 2.5), (900, 900, 2.5)]


@pytest.mark.parametrize("target", UNREACHABLE)
def test_unreachable_within_reach_bound_gets_a_quick_verdict(target):
    # every interior-point start stalls far from feasibility: the answer is a pose within
    # every limit on the way to the target (bisection of interior-point solves along the
    # segment from the upright pose), and the remaining target error
    t = sk.PlanarTarget(*target, phi=0.4)
    r = sk.solve_ik(STACK4, t)
    assert r.status is IKStatus.INFEASIBLE and not r.success and r.method == "ip"
    assert r.max_violation <= 1e-3 and r.target_error > 1.0  # raw: mm^2 for legs
    y = sk.planar_forward(r.q)
    assert check_pose(STACK4, sk.PlanarTarget(*y, phi=0.4), r.q).ok  # within every limit
    from stackik.starts import nominal_height

    y0 = sk.planar_forward(np.column_stack([np.zeros(4), nominal_height(STACK4), np.zeros(4)]))
    d, e = y - y0, t.y - y0
    tt = float(d @ e / (e @ e))
    assert 0.0 < tt < 1.0 and np.allclose(d, tt * e, atol=1e-6 * np.abs(e).max())


def test_unreachable_near_the_end_of_the_segment_goes_to_sqp(monkeypatch):
    # when the bisection gets (almost) all the way, the SQP engine decides, starting from
    # the pose reached, and certifies local infeasibility (forced here)
    import stackik.solve.stages as stages

    monkeypatch.setattr(stages, "NEAREST_MAX_T", -1.0)
    r = sk.solve_ik(STACK4, sk.PlanarTarget(*UNREACHABLE[1]))
    assert r.status is IKStatus.INFEASIBLE and r.method == "sqp" and r.max_violation > 1.0


def test_status_max_iter():
    t = sk.PlanarTarget(*PAPER_TARGETS[0])
    x0 = paper_initial_guess(STACK4, t) + 30.0
    r = sk.solve_ik(STACK4, t, x0=x0, options={"max_iter": 1})
    assert r.status is IKStatus.MAX_ITER and not r.success


def test_status_max_time():
    t = sk.PlanarTarget(*PAPER_TARGETS[0])
    r = sk.solve_ik(STACK4, t, max_time=1e-9, starts=3)
    assert r.status is IKStatus.MAX_TIME or r.success  # first start always runs


def test_status_failed():
    # a method that claims success at a point that misses the target, registered like any
    # other: the independent check rejects its pose
    from stackik.methods import register, unregister
    from stackik.methods.sqp import SQPMethod

    class Lying(SQPMethod):
        name = "lying-sqp"

        def solve_with(self, prob, u0, options, time_left, qp_solver):
            return u0 + 1e-3, 5, "success"

    register(Lying())
    try:
        t = sk.PlanarTarget(*PAPER_TARGETS[0])
        r = sk.solve_ik(STACK4, t, x0=paper_initial_guess(STACK4, t), method="lying-sqp")
        assert not r.success and r.status is IKStatus.FAILED and r.method == "lying-sqp"
        with pytest.raises(ValueError, match="already registered"):
            register(Lying())
    finally:
        unregister("lying-sqp")
    with pytest.raises(ValueError, match="unknown 'lying-sqp'"):
        sk.solve_ik(STACK4, t, method="lying-sqp")


def test_multistart_never_worse_and_reproducible():
    t = sk.PlanarTarget(*PAPER_TARGETS[0])
    one = sk.solve_ik(STACK4, t)
    many = sk.solve_ik(STACK4, t, starts=4, rng=3)
    again = sk.solve_ik(STACK4, t, starts=4, rng=3)
    assert many.frobenius_norm <= one.frobenius_norm * (1 + 1e-9)
    np.testing.assert_array_equal(many.q, again.q)
    assert many.n_starts == 4


def test_weighted_objective():
    t = sk.PlanarTarget(*PAPER_TARGETS[0])
    with pytest.raises(ValueError, match="sigma"):
        sk.solve_ik(STACK4, t, objective="weighted")
    uni = sk.solve_ik(STACK4, t, objective="weighted", sigma_t=1.0, sigma_theta=0.005)
    fro = sk.solve_ik(STACK4, t)
    assert uni.success
    # uniform noise: trace(J Cx J^T) is an affine function of FN^2 in planar mode
    assert uni.frobenius_norm == pytest.approx(fro.frobenius_norm, rel=1e-6)
    w = sk.solve_ik(
        STACK4, t, objective="weighted", sigma_t=1.0, sigma_theta=[0.005, 0.004, 0.003, 0.002]
    )
    assert w.success


def test_spatial_agrees_with_planar_target():
    t = sk.PlanarTarget(*PAPER_TARGETS[0], phi=0.5)
    planar = sk.solve_ik(STACK4, t)
    st = t.to_spatial()
    from stackik.rotations import euler_zyx_from_matrix

    q_lift = np.column_stack([planar.P, euler_zyx_from_matrix(planar.R)])
    chk = check_pose(STACK4, st, q_lift)
    assert chk.ok
    spatial = sk.solve_ik(STACK4, st)
    assert spatial.success and spatial.q.shape == (4, 6)
    assert check_pose(STACK4, st, spatial.q).ok
    # the spatial optimum can only be better than the lifted planar optimum
    fn_lift = sk.frobenius_norm(sk.spatial_jacobian(q_lift))
    assert spatial.frobenius_norm <= fn_lift + 1e-6


def _problem_scales(p, u):
    """Function scales (tests/fd.py) of the scaled problem's objective, equalities and
    limits at u: positions are at most the chain length Lc [mm] (Lc / L scaled), the
    objective sums (n - 1 planar, 3 n spatial) squared residuals of at most that, the
    equalities add the target and the angles, the limits are the raw constraint scales
    (fd.constraint_scale) times their row scaling."""
    import fd

    q = p.q_of(u)
    f, _, cE, _, _, _ = p.evaluate(u)
    lc = fd.chain_length(q) / p.L
    k = q.shape[1]
    terms = q.shape[0] if k == 3 else 3 * q.shape[0]
    F_f = abs(f) + terms * lc**2
    F_E = 1.0 + 2.0 * lc + float(np.abs(q[:, 3 if k == 6 else 2 :]).sum() + np.abs(cE).max())
    st = p.stack
    F_I = fd.constraint_scale(st.top_nodes, st.base_nodes, st.leg_max, q).ravel() * p.cs
    return F_f, F_E, F_I


def _check_problem_first_derivatives(p, u):
    """Objective gradient and constraint Jacobians of a scaled IK problem against central
    differences, tolerances from the step and the scales (tests/fd.py)."""
    import fd

    def part(i):
        def f(v):
            p._cache = None
            return np.atleast_1d(p.evaluate(v)[i])

        return f

    p._cache = None
    _, g, _, Je, _, Ji = p.evaluate(u)
    F_f, F_E, F_I = _problem_scales(p, u)
    fd.assert_derivative_close(g[None], fd.central(part(0), u), f_scale=F_f, what="gradient")
    fd.assert_derivative_close(Je, fd.central(part(2), u), f_scale=F_E, what="J_eq")
    fd.assert_derivative_close(Ji, fd.central(part(4), u), f_scale=F_I, what="J_ineq")


@pytest.mark.derivatives
@pytest.mark.parametrize("phi", [0.0, 1.1])
def test_problem_derivatives_planar(phi):
    t = sk.PlanarTarget(*PAPER_TARGETS[2], phi=phi)
    p = Problem(STACK4, t, "frobenius", None)
    rng = np.random.default_rng(7)
    u = p.u_of(paper_initial_guess(STACK4, t)) + 0.02 * rng.standard_normal(12)
    _check_problem_first_derivatives(p, u)
    ye, yi = rng.standard_normal(3), rng.standard_normal(96)

    def lag_grad(v):
        p._cache = None
        _, gg, _, JJe, _, JJi = p.evaluate(v)
        return gg - JJe.T @ ye - JJi.T @ yi

    import fd

    H = p.lagrangian_hessian(u, ye, yi)
    num = fd.central(lag_grad, u, richardson=True)
    F_f, F_E, F_I = _problem_scales(p, u)
    F_L = F_f + float(np.abs(ye).sum()) * F_E + float(np.abs(yi) @ F_I)  # the Lagrangian's
    fd.assert_derivative_close(
        H, num, f_scale=fd.derivative_scale(F_L, num.x_scale), what="Lagrangian Hessian"
    )


def test_spatial_default_tries_the_folded_starts():
    # the paper's start and four folds of the top two platforms (x and y, both signs);
    # the best of them is at least as good as the paper's start alone
    from stackik.sampling import random_spatial_targets

    t = random_spatial_targets(STACK4, 1, 7)[0]
    r = sk.solve_ik(STACK4, t)
    one = sk.solve_ik(STACK4, t, x0=paper_initial_guess(STACK4, t))
    assert r.success and one.success and r.n_starts >= 5
    assert r.frobenius_norm <= one.frobenius_norm * (1 + 1e-9)
    assert check_pose(STACK4, t, r.q).ok


def test_spatial_unreachable_stops_after_three_far_off_starts():
    from scipy.spatial.transform import Rotation

    t = sk.SpatialTarget([1500.0, 0.0, 200.0], Rotation.from_rotvec([0.5, -0.6, 0.4]).as_matrix())
    r = sk.solve_ik(STACK4, t)
    assert r.status is IKStatus.INFEASIBLE and not r.success
    # the first three interior-point starts stall far off; the answer is a pose within
    # every limit stretched toward the target (as in planar mode), not a violating one
    assert r.max_violation <= 1e-6 and r.target_error > 1.0
    sqp = sk.solve_ik(STACK4, t, method="sqp")  # the SQP engine's early stop
    assert sqp.status is IKStatus.INFEASIBLE and sqp.n_starts == 3


def test_so3_log_fast_matches_scipy():
    from scipy.spatial.transform import Rotation

    from stackik.check import so3_log as _so3_log
    from stackik.formulation.spatial import so3_log_fast as _so3_log_fast

    rng = np.random.default_rng(3)
    mats = list(Rotation.random(200, random_state=4).as_matrix())
    for angle in (0.0, 1e-12, 1e-6, 1e-3, 0.7, np.pi - 1e-3, np.pi - 1e-9):
        axis = rng.normal(size=3)
        mats.append(Rotation.from_rotvec(angle * axis / np.linalg.norm(axis)).as_matrix())
    for R in mats:
        a, b = _so3_log_fast(R), _so3_log(R)
        if np.linalg.norm(b) > np.pi - 1e-6:  # +-axis at pi are the same rotation
            assert min(np.abs(a - b).max(), np.abs(a + b).max()) < 1e-7
        else:
            np.testing.assert_allclose(a, b, atol=1e-12)


@pytest.mark.derivatives
def test_problem_derivatives_spatial():
    t = sk.PlanarTarget(*PAPER_TARGETS[0], phi=0.2).to_spatial()
    st = sk.Stack.reference(3, leg_radius=0.0)
    p = Problem(st, t, "frobenius", None)
    rng = np.random.default_rng(11)
    u = p.u_of(paper_initial_guess(st, t)) + 0.02 * rng.standard_normal(18)
    _check_problem_first_derivatives(p, u)


@pytest.mark.parametrize("n", [1, 2, 8, 16])
def test_other_stack_sizes(n):
    st = sk.Stack.reference(n, leg_radius=0.0)
    q_true = np.tile([10.0, 330.0, -0.1], (n, 1))
    y = sk.planar_forward(q_true)
    t = sk.PlanarTarget(y[0], y[1], y[2], phi=0.7)
    r = sk.solve_ik(st, t)
    assert r.success and check_pose(st, t, r.q).ok


def test_bad_input():
    t = sk.PlanarTarget(*PAPER_TARGETS[0])
    with pytest.raises(ValueError, match="objective"):
        sk.solve_ik(STACK4, t, objective="nope")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="method"):
        sk.solve_ik(STACK4, t, method="nope")  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        sk.solve_ik(STACK4, t, qp_solver="no-such-solver")
    with pytest.raises(ValueError, match="x0"):
        sk.solve_ik(STACK4, t, x0=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="starts"):
        sk.solve_ik(STACK4, t, starts=0)
    with pytest.raises(ValueError, match="rho"):
        sk.PlanarTarget(math.nan, 1.0, 0.0)
    with pytest.raises(ValueError, match="rotation"):
        sk.SpatialTarget([0, 0, 1000], np.ones((3, 3)))
    with pytest.raises(ValueError, match="target"):
        sk.solve_ik(STACK4, (600, 1000, -1.57))  # type: ignore[arg-type]


def test_solve_many_with_executor():
    targets = [sk.PlanarTarget(*t) for t in PAPER_TARGETS]
    serial = sk.solve_many(STACK4, targets)
    with ThreadPoolExecutor(2) as ex:
        parallel = sk.solve_many(STACK4, targets, executor=ex)
    assert [r.success for r in serial] == [True] * 3
    for a, b in zip(serial, parallel, strict=True):
        np.testing.assert_allclose(a.q, b.q)


def test_unknown_sqp_option_is_a_value_error():
    with pytest.raises(ValueError, match="bogus"):
        sk.solve_ik(STACK4, sk.PlanarTarget(*PAPER_TARGETS[0]), options={"bogus": 1})


def test_convex_start_falls_back_when_socp_infeasible():
    t = sk.PlanarTarget(1500.0, 100.0, 0.0)  # within the reach bound, not reachable
    with pytest.raises(sk.ConvexStartError):
        sk.convex_start(STACK4, t)
    r = sk.solve_ik(STACK4, t, start="convex", max_time=5.0)
    assert not r.success and r.status is IKStatus.INFEASIBLE


def test_planar_interior_point_limits_blas_threads_on_tall_stacks(monkeypatch):
    # from 32 platforms the planar kernels' matrix products reach sizes where OpenBLAS
    # starts threads (CPU time 2x wall at n = 48-64); below, the limit's round trip is skipped
    from stackik.sampling import random_planar_targets
    from stackik.solve import blas, stages

    applied = []
    real = blas.BlasLimit.apply
    monkeypatch.setattr(blas.BlasLimit, "apply", lambda self: (applied.append(1), real(self)))
    for n, expect in ((4, False), (stages.PLANAR_BLAS_N, True)):
        applied.clear()
        stack = sk.Stack.reference(n, leg_radius=0.0)
        r = sk.solve_ik(stack, random_planar_targets(stack, 1, rng=n)[0], starts=1)
        assert r.success and bool(applied) is expect


@pytest.mark.parametrize("method", ["sqp", "slsqp", "ip", "auto"])
def test_planar_kernels_load_before_the_clock_for_every_method(monkeypatch, method):
    # every planar method evaluates through the compiled planar kernels (the SQP also its
    # Hessian): they must be loaded before the solve's clock starts, or a cold first solve
    # spends its time budget compiling (an SQP returned its start after 0 iterations)
    import stackik.solve.pipeline as pipeline

    loaded: list[str] = []
    real = pipeline.ensure_kernels
    monkeypatch.setattr(pipeline, "ensure_kernels", lambda kind: loaded.append(kind) or real(kind))
    stack = sk.Stack.reference(2, leg_radius=0.0)
    sk.solve_ik(stack, sk.PlanarTarget(0.0, 1000.0, 0.0), method=method, starts=1)
    assert "planar" in loaded
