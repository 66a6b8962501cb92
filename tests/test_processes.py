"""The same answer in every process: pickled stacks, spawned workers, process pools.

A used :class:`Stack` carries caches; pickled (as ``ProcessPoolExecutor`` does) it must
come back without them, with read-only arrays, so that a worker solves with the arrays
and compiled kernels of the parent and returns the parent's pose, without compiling again.
"""

from __future__ import annotations

import multiprocessing as mp
import pickle
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

import stackik as sk

STACK = sk.Stack.reference(6, leg_radius=0.0)
PLANAR = [sk.PlanarTarget(400.0, 1500.0, -0.8), sk.PlanarTarget(-200.0, 1700.0, 0.4, 0.7)]


def _spatial_target() -> sk.SpatialTarget:
    q = np.array([[10.0, -5.0, 330.0, 0.05, 0.02, -0.03]] * 3)
    return sk.SpatialTarget(*sk.spatial_forward(q))


def _solve_in_worker(payload: bytes) -> dict:
    """Runs in a fresh (spawned) process: unpickle a used stack, solve, report."""
    from stackik._compiled import barrier as _barrier
    from stackik._compiled import check as _check

    stack, target = pickle.loads(payload)
    r = sk.solve_ik(stack, target)
    out = {"q": r.q, "status": r.status.value, "time": r.time}
    if isinstance(target, sk.PlanarTarget):
        out["signatures"] = (
            len(_barrier.ip_multi.signatures),
            len(_check._planar_check.signatures),
        )
    else:
        from stackik._compiled import spatial_kinematics as _spatial

        out["signatures"] = (
            len(_spatial.spatial_parts.signatures),
            len(_spatial.block_jacobian.signatures),
        )
    return out


def test_a_pickled_used_stack_comes_back_without_caches():
    stack = sk.Stack.reference(3, leg_radius=0.0)
    sk.solve_ik(stack, sk.PlanarTarget(0.0, 900.0, 0.0))
    assert stack._derived and stack._arrays  # used: caches filled
    for protocol in (2, 4, pickle.HIGHEST_PROTOCOL):
        back = pickle.loads(pickle.dumps(stack, protocol=protocol))
        assert back == stack and not back._derived and not back._arrays
        assert not back[0].base_nodes.flags.writeable
        assert not back.base_nodes.flags.writeable


@pytest.mark.parametrize("kind", ["planar", "spatial"])
def test_spawned_worker_returns_the_parents_pose_without_recompiling(kind):
    target = PLANAR[0] if kind == "planar" else _spatial_target()
    stack = STACK if kind == "planar" else sk.Stack.reference(3, leg_radius=0.0)
    parent = sk.solve_ik(stack, target)  # also fills the stack's caches
    payload = pickle.dumps((stack, target), protocol=4)
    with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn")) as pool:
        child = pool.submit(_solve_in_worker, payload).result(timeout=600)
    assert child["status"] == parent.status.value
    np.testing.assert_array_equal(child["q"], parent.q)
    assert child["signatures"] == (1, 1)  # one compiled specialisation, loaded from cache
    assert child["time"] < 5.0  # the solve's own time: no compilation inside it


def test_solve_many_in_a_process_pool_gives_the_serial_poses():
    serial = sk.solve_many(STACK, PLANAR)
    with ProcessPoolExecutor(2, mp_context=mp.get_context("spawn")) as pool:
        pooled = sk.solve_many(STACK, PLANAR, executor=pool)
    for a, b in zip(serial, pooled, strict=True):
        assert a.status is b.status
        np.testing.assert_array_equal(a.q, b.q)


def _path_kernels_in_fresh_process() -> dict:
    """Runs in a fresh (spawned) process: load the kernels as a path's solve does before
    its clock, then run every compiled call of a path (boxed and transit steps, planar and
    spatial, both modes); report the kernels that got a new specialisation after that."""
    from stackik._compiled import barrier, core, linalg, path, planar_path, spatial_path
    from stackik._compiled import check as _check
    from stackik._compiled import planar as _ipm
    from stackik._compiled import spatial as _spatial_ipm
    from stackik._compiled import spatial_kinematics as _spatial
    from stackik.paths.bounded import bounded_ip
    from stackik.solve.warmup import warm_up

    warm_up()
    mods = (_ipm, _spatial_ipm, _check, _spatial, core, linalg, path, planar_path, spatial_path,
            barrier)  # fmt: skip

    def count() -> dict[str, int]:
        return {f"{m.__name__}.{k}": len(v.signatures) for m in mods
                for k, v in vars(m).items() if hasattr(v, "signatures")}  # fmt: skip

    before = count()
    stack = sk.Stack.reference(3, leg_radius=0.0)
    for planar in (True, False):
        keys = [sk.PlanarTarget(0.0, 1000.0, 0.0), sk.PlanarTarget(150.0, 950.0, 0.2)]
        targets = sk.interpolate_targets(
            keys if planar else [t.to_spatial() for t in keys], steps=4
        )
        for mode in ("fast", "global"):
            sk.solve_path(stack, targets, mode=mode)
        q0 = sk.solve_ik(stack, targets[0]).q
        goal = sk.solve_ik(stack, targets[1]).q
        scale = np.full(q0.shape[1], 0.5)
        for g in (None, goal):
            bounded_ip(stack, targets[1], q0, scale, goal=g)
    after = count()
    return {k: (before.get(k, 0), v) for k, v in after.items() if before.get(k, 0) != v}


def test_a_paths_compiled_calls_are_all_loaded_before_its_clock():
    """Every kernel a path calls from Python has its specialisation loaded by the
    warm-up (a missing one compiles inside the path's time: ~1 s on first use)."""
    with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn")) as pool:
        new = pool.submit(_path_kernels_in_fresh_process).result(timeout=900)
    assert new == {}
