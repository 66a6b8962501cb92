"""A solve's interior-point batches on several threads (``solve_ik(threads=...)``):
the same runs, the same pose, whatever the thread count."""

from __future__ import annotations

import numpy as np
import pytest

import stackik as sk
from stackik import _threads
from stackik.batch import checkpointed_map
from stackik.formulation import Problem
from stackik.methods import ip as ip_method
from stackik.paths import interpolate_targets
from stackik.sampling import random_spatial_targets
from stackik.starts import paper_initial_guess


def test_resolve_counts_and_refuses_bad_values():
    assert _threads.resolve(None) == min(_threads.available_cpus(), _threads.MAX_THREADS)
    assert _threads.resolve(3) == 3
    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(ValueError, match="threads"):
            _threads.resolve(bad)  # type: ignore[arg-type]
    with _threads.batch_threads(1):  # an enclosing context (a batch worker) decides
        assert _threads.resolve(None) == 1
        assert _threads.resolve(2) == 2
    assert _threads.current() == 1  # outside any solve: one after another


def test_solve_ik_refuses_bad_thread_counts():
    with pytest.raises(ValueError, match="threads"):
        sk.solve_ik(sk.Stack.reference(2), sk.PlanarTarget(0.0, 700.0, 0.0), threads=0)


def _batch(prob: Problem, U0: np.ndarray, threads: int, options: dict | None = None):
    with _threads.batch_threads(threads):
        return ip_method.ip_multi(prob, U0, options)


@pytest.mark.parametrize("planar", [True, False])
def test_a_batch_on_threads_is_the_batch_one_after_another(planar):
    """Every start's point, status, iteration count, objective and violation agree bit
    for bit between one compiled call and two threads taking starts in turn."""
    rng = np.random.default_rng(5)
    if planar:
        stack = sk.Stack.reference(8)  # 24 variables: the smallest that uses threads
        target = sk.PlanarTarget(250.0, 1200.0, 0.2)
    else:
        stack = sk.Stack.reference(4)
        target = random_spatial_targets(stack, 1, 11)[0]
    prob = Problem(stack, target, "frobenius", None)
    q0 = paper_initial_guess(stack, target)
    U0 = np.stack([prob.u_of(q0 + rng.normal(0.0, 0.05, q0.shape)) for _ in range(5)])
    assert U0.shape[1] >= _threads.THREAD_MIN_N
    one = _batch(prob, U0, 1)
    two = _batch(prob, U0, 2)
    np.testing.assert_array_equal(one[0], two[0])
    assert one[1] == two[1]
    for a, b in zip(one[2:], two[2:]):
        np.testing.assert_array_equal(a, b)


def test_a_batch_past_its_deadline_skips_the_later_starts_on_threads_too():
    stack = sk.Stack.reference(4)
    target = random_spatial_targets(stack, 1, 12)[0]
    prob = Problem(stack, target, "frobenius", None)
    u0 = prob.u_of(paper_initial_guess(stack, target))
    U0 = np.stack([u0] * 4)
    late = {"max_time": 1e-12}
    one = _batch(prob, U0, 1, late)
    two = _batch(prob, U0, 3, late)
    assert one[1] == two[1]
    assert one[1][1:] == ["skipped"] * 3
    np.testing.assert_array_equal(one[0], two[0])
    np.testing.assert_array_equal(one[0][1:], U0[1:])  # a skipped start keeps its start


def test_a_batch_that_gives_up_on_threads_gives_up_as_one_call():
    """An unreachable target: the first three runs end far from feasible, and the kernel
    skips the rest; on threads the later runs are skipped (or discarded) alike."""
    stack = sk.Stack.reference(4)
    target = sk.SpatialTarget.from_euler([0.0, 0.0, 5000.0], 0.0, 0.0, 0.0)
    prob = Problem(stack, target, "frobenius", None)
    rng = np.random.default_rng(3)
    q0 = paper_initial_guess(stack, target)
    U0 = np.stack([prob.u_of(q0 + rng.normal(0.0, 0.05, q0.shape)) for _ in range(6)])
    one = _batch(prob, U0, 1, {"max_iter": 40})
    two = _batch(prob, U0, 2, {"max_iter": 40})
    assert one[1][3:] == ["skipped"] * 3  # the kernel gave up after three
    assert one[1] == two[1]
    for a, b in zip(one[2:], two[2:]):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(one[0], two[0])


@pytest.mark.parametrize("n", [4, 6])
def test_the_spatial_default_gives_the_same_pose_on_one_thread_or_two(n):
    stack = sk.Stack.reference(n)
    for target in random_spatial_targets(stack, 2, 400 + n):
        one = sk.solve_ik(stack, target, threads=1)
        two = sk.solve_ik(stack, target, threads=2)
        assert one.success and two.success
        np.testing.assert_array_equal(one.q, two.q)
        assert (one.nit, one.n_starts) == (two.nit, two.n_starts)


def test_the_planar_default_gives_the_same_pose_on_one_thread_or_two():
    stack = sk.Stack.reference(16)
    target = sk.PlanarTarget(-400.0, 2100.0, 0.4)
    one = sk.solve_ik(stack, target, threads=1)
    two = sk.solve_ik(stack, target, threads=2)
    assert one.success
    np.testing.assert_array_equal(one.q, two.q)
    assert one.nit == two.nit


def _threads_in_force(_: object) -> int:
    return _threads.resolve(None)


def test_batch_workers_run_one_thread_a_solve():
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(2) as pool:
        got = checkpointed_map(
            _threads_in_force, list(range(4)), key=str, encode=int, decode=int, executor=pool
        )
    assert got == [1, 1, 1, 1]


def test_solves_side_by_side_share_the_pool_and_keep_their_poses():
    """Two solves at once, each on two threads (one pool of helpers between them): no
    wait on each other's batches that never ends, and each pose is its serial one."""
    from concurrent.futures import ThreadPoolExecutor

    stack = sk.Stack.reference(4)
    targets = random_spatial_targets(stack, 4, 21)
    serial = [sk.solve_ik(stack, t, threads=1).q for t in targets]
    with ThreadPoolExecutor(2) as pool:
        got = list(pool.map(lambda t: sk.solve_ik(stack, t, threads=2).q, targets))
    for a, b in zip(serial, got):
        np.testing.assert_array_equal(a, b)


def test_a_path_is_the_same_on_one_thread_or_two_and_refuses_bad_counts():
    """``solve_path(threads=...)`` reaches the default solves: the same path either way."""
    stack = sk.Stack.reference(4)
    a, b = random_spatial_targets(stack, 2, 4321)
    waypoints = interpolate_targets([a, b], steps=6)
    one = sk.solve_path(stack, waypoints, max_jump=(60.0, 0.3), threads=1)
    two = sk.solve_path(stack, waypoints, max_jump=(60.0, 0.3), threads=2)
    assert one.completed == two.completed
    np.testing.assert_array_equal(one.q, two.q)
    with pytest.raises(ValueError, match="threads"):
        sk.solve_path(stack, waypoints, threads=0)


def test_cli_threads(capsys):
    """``stackik solve --threads N``: the same pose as the default; 0 is a usage error."""
    import json

    from stackik.cli import main

    args = ["solve", "--n", "4", "--spatial", "--position", "100", "50", "600", "--json"]
    assert main([*args, "--threads", "1"]) == 0
    one = json.loads(capsys.readouterr().out)
    assert main(args) == 0
    assert json.loads(capsys.readouterr().out)["q"] == one["q"]
    assert main([*args, "--threads", "0"]) == 2
    assert "--threads" in capsys.readouterr().err
