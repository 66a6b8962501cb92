"""Robustness fuzz suite (issue 7): stackik must never claim success wrongly, never hang,
and reject malformed input with a ``ValueError`` naming the problem.

Rules checked on every case (see ``fuzz_cases.run_case``):

* malformed input raises ``ValueError`` (``GeometryError`` is one) with a message;
* nothing else raises, for any well-formed input;
* ``result.success`` implies ``check_pose(...).ok`` *and* the independent re-check of
  ``fuzz_cases.recheck`` (oracle forward kinematics and limits, hardware fields);
* provably unreachable targets never succeed;
* a solve with ``max_time`` returns within ``max_time + 2 s`` (sanity bound, not a speed
  test) and ``nit`` stays within the iteration limit times the number of solver runs.

Hypothesis draws seeds for the generators of ``fuzz_cases`` (derandomized, so CI is
reproducible; set ``STACKIK_FUZZ_EXAMPLES`` to run more) plus raw values for the malformed
inputs; a seeded campaign mixes every category like ``benchmarks/soak.py`` does.
Bugs the suite found have regression tests at the end (all fixed so far; an open one
would be an ``xfail(strict=True)`` left out of the fuzzed inputs).
"""

from __future__ import annotations

import math
import os
import time
import warnings
from collections import Counter

import fuzz_cases as fc
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import stackik as sk
from stackik.result import IKStatus
from stackik.targets import PlanarTarget, SpatialTarget

pytestmark = pytest.mark.filterwarnings("ignore")

SCALE = float(os.environ.get("STACKIK_FUZZ_SCALE", "1"))


def fuzz(examples: int) -> settings:
    return settings(
        max_examples=max(1, int(examples * SCALE)),
        deadline=None,
        derandomize=os.environ.get("STACKIK_FUZZ_RANDOM", "") == "",
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )


SEEDS = st.integers(0, 2**32 - 1)


def assert_rules(rec: dict) -> None:
    """Every rule of the suite on one ``run_case`` record."""
    assert rec["outcome"] != "unexpected_exception", rec
    assert rec["outcome"] != "accepted_malformed", rec
    if rec["malformed"]:
        assert rec["outcome"] == "value_error", rec
    assert not rec["false_success"], rec
    assert not rec.get("time_overrun"), rec
    assert not rec.get("iter_overrun"), rec
    assert "anomaly" not in rec, rec
    if rec["unreachable"]:
        assert rec["outcome"] != "success", rec


def run(case: fc.Case) -> dict:
    rec = fc.run_case(case)
    assert_rules(rec)
    return rec


# =========================================================================================
# Hypothesis: generators driven by drawn seeds
# =========================================================================================
@fuzz(14)
@given(seed=SEEDS, n=st.integers(1, 4))
def test_reachable_planar(seed, n):
    run(fc.gen_reachable_planar(np.random.default_rng(seed), n=n))


@fuzz(8)
@given(seed=SEEDS, n=st.integers(1, 3))
def test_reachable_spatial(seed, n):
    run(fc.gen_reachable_spatial(np.random.default_rng(seed), n=n))


@fuzz(8)
@given(seed=SEEDS, n=st.integers(1, 4))
def test_clearance_spatial(seed, n):
    """Legs of a size (0-15 mm) and clearance margins: a success keeps every two legs of a
    platform apart (the oracle's exact segment distance in ``fuzz_cases.recheck``)."""
    run(fc.gen_clearance_spatial(np.random.default_rng(seed), n=n))


@fuzz(6)
@given(seed=SEEDS, n=st.integers(1, 3))
def test_obstacles(seed, n):
    """Spheres, truss capsules, boxes and half-spaces across the legs, planar and spatial,
    legs of 0-12 mm: a success keeps every leg and plate clear of every obstacle by the
    oracle's exact distances (``fuzz_cases.obstacle_problems``)."""
    run(fc.gen_obstacles(np.random.default_rng(seed), n=n))


@fuzz(8)
@given(seed=SEEDS, n=st.integers(1, 3))
def test_loads(seed, n):
    """Masses, payloads, gravity and leg force limits: a success keeps every leg within its
    force_max by the oracle's statics (``reference_impl.world_leg_forces``)."""
    run(fc.gen_loads(np.random.default_rng(seed), n=n))


@fuzz(10)
@given(seed=SEEDS)
def test_random_geometry(seed):
    run(fc.gen_random_geometry(np.random.default_rng(seed)))


@fuzz(14)
@given(seed=SEEDS)
def test_unreachable(seed):
    rec = run(fc.gen_unreachable(np.random.default_rng(seed)))
    if rec["kind"] == "angle":  # n <= 2 with |theta| >= 2.6: never seen reachable
        assert rec["outcome"] != "success", rec


@fuzz(6)
@given(seed=SEEDS)
def test_infeasible_geometry(seed):
    run(fc.gen_infeasible_geometry(np.random.default_rng(seed)))


@fuzz(10)
@given(seed=SEEDS)
def test_extreme_x0(seed):
    run(fc.gen_extreme_x0(np.random.default_rng(seed)))


@fuzz(10)
@given(seed=SEEDS)
def test_limits(seed):
    run(fc.gen_limits(np.random.default_rng(seed)))


@fuzz(30)
@given(seed=SEEDS)
def test_nonfinite_inputs_raise_value_error(seed):
    run(fc.gen_nonfinite(np.random.default_rng(seed)))


@fuzz(30)
@given(seed=SEEDS)
def test_wrong_shapes_raise_value_error(seed):
    run(fc.gen_wrong_shape(np.random.default_rng(seed)))


@fuzz(25)
@given(seed=SEEDS)
def test_bad_geometry_raises_geometry_error(seed):
    case = fc.gen_bad_geometry(np.random.default_rng(seed))
    with pytest.raises(sk.GeometryError, match=r"\w"):
        case.make()
    run(case)


@fuzz(25)
@given(seed=SEEDS)
def test_bad_arguments_raise_value_error(seed):
    run(fc.gen_bad_args(np.random.default_rng(seed), exclude=fc.KNOWN_BAD_ARGS_BUGS))


# =========================================================================================
# Hypothesis: raw values
# =========================================================================================
ANY_FLOAT = st.one_of(
    st.floats(-3000, 3000), st.floats(allow_nan=True, allow_infinity=True), st.just(0.0)
)
STACKS = {n: sk.Stack.reference(n) for n in (1, 2, 3)}


@fuzz(40)
@given(rho=ANY_FLOAT, z=ANY_FLOAT, theta=ANY_FLOAT, phi=ANY_FLOAT, n=st.integers(1, 3))
def test_planar_target_any_floats(rho, z, theta, phi, n):
    values = (rho, z, theta, phi)
    if not all(math.isfinite(v) for v in values):
        with pytest.raises(ValueError, match=r"\w"):
            PlanarTarget(*values)
        return
    t = PlanarTarget(*values)
    run(fc.Case("raw", str(values), lambda: (STACKS[n], t, {"max_time": 3.0})))


@fuzz(25)
@given(
    position=hnp.arrays(np.float64, hnp.array_shapes(max_dims=2, max_side=4)),
    rotvec=hnp.arrays(np.float64, 3, elements=st.floats(-4, 4)),
)
def test_spatial_target_any_position(position, rotvec):
    from scipy.spatial.transform import Rotation

    R = Rotation.from_rotvec(rotvec).as_matrix()
    if position.shape != (3,) or not np.all(np.isfinite(position)):
        with pytest.raises(ValueError, match=r"\w"):
            SpatialTarget(position, R)
        return
    t = SpatialTarget(position, R)
    run(fc.Case("raw", str(position), lambda: (STACKS[2], t, {"max_time": 3.0})))


@fuzz(40)
@given(
    x0=hnp.arrays(
        np.float64,
        hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=7),
        elements=st.floats(-1e4, 1e4) | st.sampled_from([np.nan, np.inf, -np.inf]),
    ),
    spatial=st.booleans(),
)
def test_x0_any_array(x0, spatial):
    n = 2
    t = PlanarTarget(40.0, 650.0, 0.1, 0.3)
    target = t.to_spatial() if spatial else t
    k = 6 if spatial else 3
    malformed = x0.shape != (n, k) or not np.all(np.isfinite(x0))
    case = fc.Case(
        "raw",
        f"x0 {x0.shape}",
        lambda: (STACKS[n], target, {"x0": x0, "max_time": 3.0}),
        malformed=malformed,
    )
    run(case)


@fuzz(40)
@given(
    nodes=hnp.arrays(
        np.float64,
        st.sampled_from([(6, 3), (6, 3), (6, 3), (5, 3), (6, 2), (18,)]),
        elements=st.floats(-300, 300) | st.sampled_from([np.nan, np.inf, 0.0, 1e-12]),
    ),
    leg_min=st.floats(-10, 500),
    leg_range=st.floats(-50, 300),
    joint_min=st.floats(-0.5, 2.0),
)
def test_geometry_any_nodes(nodes, leg_min, leg_range, joint_min):
    top = sk.PlatformGeometry.reference().top_nodes
    try:
        g = sk.PlatformGeometry(nodes, top, leg_min, leg_min + leg_range, joint_min)
    except sk.GeometryError as exc:
        assert str(exc)
        return
    assert g.base_nodes.shape == (6, 3) and np.all(np.isfinite(g.base_nodes))
    assert 0 < g.leg_min < g.leg_max and 0 <= g.joint_min < math.pi / 2
    stack = sk.Stack.uniform(g, 2)
    t = PlanarTarget(10.0, 1.2 * g.leg_max, 0.05)
    run(fc.Case("raw", "nodes", lambda: (stack, t, {"max_time": 3.0})))


# =========================================================================================
# Seeded campaign (the soak's mix, small)
# =========================================================================================
CAMPAIGN_SEED = 20240607
CAMPAIGN_SIZE = int(48 * SCALE)


def test_seeded_campaign():
    recs = []
    for i in range(CAMPAIGN_SIZE):
        case = fc.make_case(CAMPAIGN_SEED, i)
        if case.category == "bad_args" and any(k in case.label for k in fc.KNOWN_BAD_ARGS_BUGS):
            continue
        recs.append(fc.run_case(case))
    for rec in recs:
        assert_rules(rec)
    reach = [r for r in recs if r["category"] in ("reachable_planar", "reachable_spatial")]
    assert len(reach) >= 8
    # not a speed or quality target: guards against a solver that never succeeds
    assert sum(r["outcome"] == "success" for r in reach) >= 0.75 * len(reach), Counter(
        r["outcome"] for r in reach
    )
    assert {r["category"] for r in recs} >= {"reachable_planar", "unreachable", "nonfinite"}


# =========================================================================================
# Every method, backend and objective
# =========================================================================================
SOLVERS = [pytest.param({"qp_solver": b}, id=f"sqp-{b}") for b in fc.NATIVE_QP] + [
    pytest.param({"method": "slsqp"}, id="slsqp"),
    pytest.param({"method": "trust-constr", "options": {"maxiter": 150}}, id="trust-constr"),
    pytest.param(
        {"method": "ipopt"},
        id="ipopt",
        marks=pytest.mark.skipif(not fc.HAVE_IPOPT, reason="casadi not installed"),
    ),
]
OBJECTIVES = [
    pytest.param({}, id="frobenius"),
    pytest.param({"objective": "feasible"}, id="feasible"),
    pytest.param({"objective": "weighted", "sigma_t": 0.2, "sigma_theta": 0.01}, id="weighted"),
]


def _method_targets():
    rng = np.random.default_rng(7)
    out = []
    for n, phi in ((1, 0.3), (3, -1.2)):
        stack = sk.Stack.reference(n)
        q = fc.feasible_planar_pose(stack, rng, phi)
        out.append((stack, PlanarTarget(*(float(v) for v in sk.planar_forward(q)), phi=phi)))
    stack = sk.Stack.reference(2)
    out.append((stack, SpatialTarget(*sk.spatial_forward(fc.feasible_spatial_pose(stack, rng)))))
    out.append((sk.Stack.reference(2), PlanarTarget(0.0, -500.0, 0.0)))  # unreachable
    return out


METHOD_TARGETS = _method_targets()


@pytest.mark.parametrize("objective", OBJECTIVES)
@pytest.mark.parametrize("solver", SOLVERS)
def test_every_method_and_objective(solver, objective):
    kw = {**solver, **objective, "max_time": 5.0}
    recs = []
    for stack, target in METHOD_TARGETS:
        recs.append(run(fc.Case("method", str(kw), lambda s=stack, t=target: (s, t, kw))))
    assert recs[0]["outcome"] == "success", recs[0]  # n = 1: every method gets it
    assert recs[-1]["outcome"] != "success", recs[-1]


def test_weighted_with_per_platform_sigmas():
    stack, target = METHOD_TARGETS[1]
    for st_, sth in (([0.1, 0.5, 1.0], [0.01, 0.02, 0.03]), ([0.0, 0.0, 0.0], 0.01)):
        kw = {"objective": "weighted", "sigma_t": st_, "sigma_theta": sth, "max_time": 5.0}
        rec = run(fc.Case("weighted", str(kw), lambda kw=kw: (stack, target, kw)))
        assert rec["outcome"] == "success", rec


# =========================================================================================
# Limits: time and iterations
# =========================================================================================
LIMIT_TARGETS = [
    (sk.Stack.reference(4), PlanarTarget(120.0, 1100.0, 0.3, 0.3)),  # reachable
    (sk.Stack.reference(4), PlanarTarget(0.0, -900.0, 0.0)),  # unreachable: runs to limits
    (sk.Stack.reference(2), PlanarTarget(50.0, 600.0, 0.1).to_spatial()),
]


@pytest.mark.parametrize("backend", fc.NATIVE_QP)
def test_max_time_is_respected_sqp(backend):
    for stack, target in LIMIT_TARGETS:
        for kw in ({"starts": 1}, {"starts": 2, "rng": 0}):
            kw = {**kw, "qp_solver": backend, "max_time": 0.2}
            t0 = time.perf_counter()
            res = sk.solve_ik(stack, target, **kw)
            elapsed = time.perf_counter() - t0
            assert elapsed <= 0.2 + fc.TIME_SLACK, (backend, kw, elapsed)
            assert res.time <= elapsed + 1e-3
            run(fc.Case("max_time", str(kw), lambda s=stack, t=target, kw=kw: (s, t, kw)))


def test_max_time_is_respected_default_starts():
    # default backend and structured starts (screened runs share the budget)
    for stack, target in LIMIT_TARGETS:
        for mt in (1e-3, 0.05, 0.2):
            run(
                fc.Case(
                    "max_time", str(mt), lambda s=stack, t=target, mt=mt: (s, t, {"max_time": mt})
                )
            )


ITER_SOLVERS = [pytest.param({"qp_solver": b}, "max_iter", id=f"sqp-{b}") for b in fc.NATIVE_QP]
ITER_SOLVERS += [
    pytest.param({"method": "slsqp"}, "maxiter", id="slsqp"),
    pytest.param({"method": "trust-constr"}, "maxiter", id="trust-constr"),
]


@pytest.mark.parametrize(("solver", "key"), ITER_SOLVERS)
def test_iteration_limit_bounds_nit(solver, key):
    for stack, target in LIMIT_TARGETS:
        for starts in (1, None):
            kw = {**solver, "options": {key: 3}, "max_time": 5.0}
            if starts is not None:
                kw["starts"] = starts
            rec = run(fc.Case("max_iter", str(kw), lambda s=stack, t=target, kw=kw: (s, t, kw)))
            bound = fc.nit_bound(stack, target, kw, 3)
            assert rec["nit"] <= bound, rec
            if starts == 1:
                assert rec["nit"] <= 3 * (1 + fc.FALLBACK_STARTS), rec


# =========================================================================================
# Large n (few: they are slow)
# =========================================================================================
@pytest.mark.parametrize(
    ("n", "kw"),
    [
        (32, {"objective": "feasible", "starts": 1, "max_time": 3.0}),
        (64, {"objective": "feasible", "starts": 1, "max_time": 3.0}),
        (32, {"starts": 1, "max_time": 0.5}),
    ],
)
def test_large_n(n, kw):
    stack = sk.Stack.reference(n)
    q = fc.feasible_planar_pose(stack, np.random.default_rng(n), 0.3)
    target = PlanarTarget(*(float(v) for v in sk.planar_forward(q)), phi=0.3)
    rec = run(fc.Case("large_n", str(kw), lambda: (stack, target, kw)))
    if kw.get("objective") == "feasible":
        assert rec["outcome"] == "success", rec


def test_solve_many_keeps_every_result_in_order():
    stack = sk.Stack.reference(2)
    rng = np.random.default_rng(3)
    targets = [
        PlanarTarget(
            *(float(v) for v in sk.planar_forward(fc.feasible_planar_pose(stack, rng, 0.0)))
        )
        for _ in range(3)
    ]
    targets.insert(1, PlanarTarget(0.0, -700.0, 0.0))
    targets.insert(3, PlanarTarget(1e6, 0.0, 0.0))
    results = sk.solve_many(stack, targets, max_time=3.0)
    assert len(results) == len(targets)
    for t, r in zip(targets, results, strict=True):
        assert r.success == (r.status is IKStatus.SUCCESS)
        if r.success:
            assert fc.recheck(stack, t, r).ok
    assert [r.success for r in results] == [True, False, True, False, True]


# =========================================================================================
# Regressions: bugs this suite found that are fixed
# =========================================================================================
REACHABLE3 = (sk.Stack.reference(3), PlanarTarget(100.0, 1000.0, 0.2, 0.1))


def test_max_time_is_respected_by_the_screening_of_structured_starts():
    # the three screened structured starts ran without any time budget (~5 s here)
    stack = sk.Stack.reference(6)
    target = PlanarTarget(0.0, 1800.0, 3.0)  # unreachable angle: every run goes to max_iter
    t0 = time.perf_counter()
    sk.solve_ik(stack, target, qp_solver="clarabel", max_time=0.01)
    assert time.perf_counter() - t0 <= 0.01 + fc.TIME_SLACK


def test_unknown_sqp_option_raises_value_error():
    # was a TypeError from SQPOptions(**options)
    with pytest.raises(ValueError, match="max_iterations"):
        sk.solve_ik(*REACHABLE3, options={"max_iterations": 5})


@pytest.mark.parametrize(
    ("max_time", "kw"),
    [("fast", {}), (math.nan, {"method": "slsqp"}), (0.0, {}), (-1.0, {"method": "ipopt"})],
    ids=["str", "nan", "zero", "negative"],
)
def test_max_time_is_validated(max_time, kw):
    # "fast" was a TypeError; NaN, 0 and negative budgets were accepted by some methods
    with pytest.raises(ValueError, match="max_time"):
        sk.solve_ik(*REACHABLE3, max_time=max_time, **kw)


@pytest.mark.parametrize("spatial", [False, True], ids=["planar", "spatial"])
def test_convex_start_returns_a_result(spatial):
    # an infeasible convex restriction let ConvexStartError (a RuntimeError) escape
    stack, target = sk.Stack.reference(3), PlanarTarget(0.0, -100.0, 0.0)
    target = target.to_spatial() if spatial else target
    res = sk.solve_ik(stack, target, start="convex", max_time=5.0)
    assert isinstance(res, sk.IKResult) and not res.success


# =========================================================================================
# Bugs found by the fuzz campaign, fixed: regression tests
# =========================================================================================
def test_max_time_is_respected_by_trust_constr():
    stack, target = sk.Stack.reference(6), PlanarTarget(0.0, -1350.0, 0.0)  # unreachable
    t0 = time.perf_counter()
    sk.solve_ik(
        stack,
        target,
        method="trust-constr",
        x0=np.full((6, 3), -1e5),
        options={"maxiter": 3000},  # ~3.5 s of iterations
        max_time=0.05,
    )
    assert time.perf_counter() - t0 <= 0.05 + fc.TIME_SLACK


def test_max_time_is_respected_by_one_slow_qp():
    if "clarabel" not in fc.NATIVE_QP:
        pytest.skip("clarabel not installed")
    stack, target = sk.Stack.reference(16), PlanarTarget(0.0, -3600.0, 0.0, phi=2.5)
    t0 = time.perf_counter()
    sk.solve_ik(stack, target, qp_solver="clarabel", max_time=0.2)
    assert time.perf_counter() - t0 <= 0.2 + 1.0  # measured ~2.75 s; 1 s is ample slack


def test_ipopt_honours_iteration_limit():
    if not fc.HAVE_IPOPT:
        pytest.skip("casadi not installed")
    stack, target = REACHABLE3
    res = sk.solve_ik(
        stack,
        target,
        method="ipopt",
        options={"max_iter": 3},
        x0=sk.paper_initial_guess(*REACHABLE3),
    )
    assert res.nit <= 3


def test_rng_type_is_validated():
    with pytest.raises(ValueError, match="rng"):
        sk.solve_ik(*REACHABLE3, starts=2, rng="seed")


@pytest.mark.parametrize("options", [{"ftol": 1e-9}, {"maxiter": "a"}], ids=["key", "value"])
def test_trust_constr_bad_option_is_value_error(options):
    with pytest.raises(ValueError):
        sk.solve_ik(*REACHABLE3, method="trust-constr", options=options)


def test_trust_constr_survives_huge_x0():
    stack, target = REACHABLE3
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = sk.solve_ik(stack, target, method="trust-constr", x0=np.full((3, 3), 1e300))
    assert not res.success
