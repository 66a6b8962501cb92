"""stackik.sampling: the random stacks and targets of tests and benchmarks."""

from __future__ import annotations

import numpy as np
import pytest

from stackik import sampling
from stackik.analysis import workspace
from stackik.geometry import Stack
from stackik.kinematics import planar_forward
from stackik.sampling import (
    random_planar_targets,
    random_reachable_targets,
    random_spatial_targets,
    random_stack,
)

PHIS = (0.0, 0.8, -2.1)  # the benchmark's planes


def _tuples(targets):
    return [(t.rho, t.z, t.theta, t.phi) for t in targets]


def test_same_draws_as_the_benchmark_always_had():
    # values drawn by stackik.bench before the samplers moved here (seeded, so pinned)
    t = random_planar_targets(Stack.reference(4), 7, 0, phis=PHIS)
    assert np.allclose(t[0].y, [-84.04688122596801, 1402.8928502080712, 0.020127532485219368])
    assert np.allclose(t[1].y, [421.08905391504464, 1110.254368852508, -0.3098093060651256])
    assert random_stack(3, 3005)[0].leg_min == pytest.approx(262.8887285310606, rel=1e-12)
    sp = random_spatial_targets(Stack.reference(4), 3, 7)
    assert np.allclose(sp[0].position, [158.75943577474158, 35.14738124121104, 1333.434363745841])


def test_random_stack_seeded_and_asymmetric():
    a, b = random_stack(3, 11), random_stack(3, 11)
    assert a == b and a.n == 3
    assert a != random_stack(3, 12)
    assert a[0] != a[1]  # platforms differ
    assert random_stack(3, np.random.default_rng(11)) == a  # a Generator draws the same
    assert np.all((a.leg_min >= 230) & (a.leg_min <= 270))
    assert np.all((a.leg_max >= 420) & (a.leg_max <= 480))


def test_planar_targets_shared_out_over_planes():
    st = Stack.reference(3)
    t = random_planar_targets(st, 7, 5, phis=PHIS)
    assert [x.phi for x in t] == [0.0] * 3 + [0.8] * 2 + [-2.1] * 2
    # an int seed s draws plane i with seed s + i
    expect = []
    for i, (phi, k) in enumerate(zip(PHIS, (3, 2, 2), strict=True)):
        expect += random_reachable_targets(st, k, rng=5 + i, phi=phi)
    assert _tuples(t) == _tuples(expect)
    # a Generator is used for the planes in turn: reproducible from the same seed
    g1 = random_planar_targets(st, 5, np.random.default_rng(1), phis=PHIS)
    g2 = random_planar_targets(st, 5, np.random.default_rng(1), phis=PHIS)
    assert _tuples(g1) == _tuples(g2) and len(g1) == 5
    assert random_planar_targets(st, 0, 1) == []
    assert {x.phi for x in random_planar_targets(st, 2, 1)} == {0.0}


def test_planar_targets_bad_arguments():
    st = Stack.reference(2)
    with pytest.raises(ValueError, match="phis"):
        random_planar_targets(st, 3, 0, phis=())
    with pytest.raises(ValueError, match="count"):
        random_planar_targets(st, -1, 0)


def test_planar_targets_are_forward_kinematics_of_feasible_poses():
    st = random_stack(3, 4)
    q = sampling.random_feasible_poses(st, 4, rng=9, phi=0.3)
    assert q.shape == (4, 3, 3)
    assert np.all(st.planar_constraints(q, 0.3) >= 0.0)
    t = random_reachable_targets(st, 4, rng=9, phi=0.3)
    assert np.allclose([x.y for x in t], planar_forward(q))


def test_spatial_targets_seeded_and_valid():
    st = Stack.reference(2)
    a, b = random_spatial_targets(st, 3, 2), random_spatial_targets(st, 3, 2)
    assert len(a) == 3
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x.position, y.position)
        assert np.array_equal(x.rotation, y.rotation)
        assert np.allclose(x.rotation @ x.rotation.T, np.eye(3))
    assert random_spatial_targets(st, 0, 2) == []


def test_spatial_targets_give_up_after_max_draws():
    # legs of at most 100 mm cannot reach plates at z >= 260 mm: no draw is feasible
    from stackik.geometry import PlatformGeometry

    g = PlatformGeometry.hexagonal(leg_min=50.0, leg_max=100.0)
    with pytest.raises(RuntimeError, match="0 of 2"):
        random_spatial_targets(Stack((g,)), 2, 0, max_draws=50)


def test_workspace_reexports_the_samplers():
    for name in (
        "platform_box",
        "random_feasible_poses",
        "random_reachable_targets",
        "uniform_reachable_targets",
    ):
        assert getattr(workspace, name) is getattr(sampling, name)
        assert name in workspace.__all__
