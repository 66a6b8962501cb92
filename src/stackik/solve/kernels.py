"""The compiled kernels: loaded (or compiled) once per process, before any clock starts.

The planar interior point and its re-check (:mod:`stackik._compiled.planar`,
:mod:`stackik._compiled.check`), the spatial evaluation
(:mod:`stackik._compiled.spatial_kinematics`) and the spatial interior point
(:mod:`stackik._compiled.spatial`) are compiled by numba with
``cache=True``: the first use on a machine compiles them (tens of seconds) and writes
machine code beside the sources (or to ``NUMBA_CACHE_DIR``); later processes load it
(a fraction of a second). :func:`solve_ik` calls :func:`ensure_kernels` for what the
request needs *before* its clock starts, so compilation never eats a solve's time budget
nor shows in :attr:`IKResult.time`. A compilation says so on stderr once.
"""

from __future__ import annotations

import math
import sys
import threading
import time
from typing import Any

__all__ = ["KERNEL_KINDS", "ensure_kernels", "kernels_cached", "warm_up"]

#: The kernel sets, and the rough first-compile time of each on a 2-core machine [s]
#: (measured with an empty NUMBA_CACHE_DIR at load ~2 from other jobs, path kernels
#: included: the first planar command 42 s in all, a first spatial solve 86 s with both).
KERNEL_KINDS: dict[str, float] = {"planar": 40.0, "spatial": 45.0}

_READY: set[str] = set()
_LOCK = threading.Lock()


def _dispatchers(kind: str) -> list[Any]:
    if kind == "planar":
        from stackik._compiled import check as _check
        from stackik._compiled import planar as _ipm
        from stackik._compiled import planar_path as _ipm_path

        return [_ipm._ip_multi, _ipm.ip_box, _ipm_path.ip_path, _ipm._evaluate,
                _ipm._lagrangian_hessian, _check._planar_check,
                _check._planar_check_many, _check._planar_path_arrays]  # fmt: skip
    from stackik._compiled import check as _check
    from stackik._compiled import spatial as _spatial_ipm
    from stackik._compiled import spatial_kinematics as _spatial
    from stackik._compiled import spatial_path as _spatial_ipm_path

    return [_spatial.spatial_parts, _spatial.block_jacobian, _spatial_ipm.ip_multi,
            _spatial_ipm.ip_box, _spatial_ipm_path.ip_path, _spatial_ipm.evaluate,
            _spatial_ipm.polish, _spatial_ipm.lagrangian_hessian, _check._spatial_check,
            _check._spatial_check_many]  # fmt: skip


def _small_problem(planar: bool) -> tuple[Any, ...]:
    """``(stack, planar target, target of the mode, Problem, paper's guess)`` of the
    two-platform problem the warm-ups run the kernels on."""
    from stackik.formulation import Problem
    from stackik.geometry import Stack
    from stackik.starts import paper_initial_guess
    from stackik.targets import PlanarTarget

    stack = Stack.reference(2)
    pt = PlanarTarget(0.0, 700.0, 0.0)
    target = pt if planar else pt.to_spatial()
    return (
        stack,
        pt,
        target,
        Problem(stack, target, "frobenius", None),
        paper_initial_guess(stack, target),
    )


def _warm_sqp_kernels(planar: bool) -> None:
    """Run the kernels the SQP method evaluates its compiled problem with
    (:class:`stackik.methods._sqp_compiled.CompiledNLP`: writable point and multipliers,
    read-only problem arrays; a path's transit step computes its ``f0`` with the same
    planar evaluation) once, so that a solve's clock sees no loading."""
    import numpy as np

    from stackik.methods._sqp_compiled import CompiledNLP

    stack, _, _, prob, q0 = _small_problem(planar)
    nlp = CompiledNLP(prob)
    u = prob.u_of(q0)
    nlp.evaluate(u)
    nlp.hessian(u, np.zeros(3 if planar else 6), np.zeros(24 * stack.n))


def _warm_path_kernels(planar: bool) -> None:
    """Run the path kernels (:mod:`stackik.paths`: the boxed and goal-seeking step, the
    run of warm steps, the batch check) once on a small problem, with the argument
    types the paths pass (read-only arrays), so that a path's clock sees no loading."""
    import numpy as np

    from stackik._arrays import readonly
    from stackik._compiled import planar as _ipm
    from stackik._compiled import planar_path as _ipm_path
    from stackik._compiled import spatial as _spatial_ipm
    from stackik._compiled import spatial_path as _spatial_ipm_path
    from stackik._compiled.check import planar_check_many, planar_path_arrays, spatial_check_many
    from stackik.formulation import POLISH_MARGIN, POLISH_REACH
    from stackik.methods.ip import problem_arrays, spatial_problem_arrays

    stack, pt, _, prob, q0 = _small_problem(planar)
    u0 = readonly(prob.u_of(q0))
    lo, hi = readonly(u0 - 0.1), readonly(u0 + 0.1)
    for ug, wq in ((readonly(np.zeros(0)), 0.0), (u0, 1.0)):
        if planar:
            _ipm.ip_box(u0, problem_arrays(prob), lo, hi, ug, wq, 1e-7, 1e-9, 1e-3, 3,
                        POLISH_REACH, POLISH_MARGIN)  # fmt: skip
        else:
            P = spatial_problem_arrays(prob)
            u, _, _ = _spatial_ipm.ip_box(u0, P, lo, hi, ug, wq, 1e-7, 1e-9, 1e-3, 3)
            _spatial_ipm.polish(u, P, 3, POLISH_REACH, POLISH_MARGIN)  # as bounded_ip
    if planar:
        Y = readonly([[pt.rho, pt.z, pt.theta]])
        _ipm_path.ip_path(u0, Y, problem_arrays(prob), readonly(np.ones(u0.size)), 1e-7,
                          1e-9, 1e-3, 3, POLISH_REACH, POLISH_MARGIN, 1e-6, 1e-8, True,
                          np.zeros(3), np.zeros(0), np.zeros(0, dtype=bool), False,
                          np.zeros(0))  # fmt: skip
        planar_check_many(stack, [pt], q0[None])
        planar_path_arrays(stack, pt.phi, q0[None])
    else:
        st = pt.to_spatial()
        _spatial_ipm_path.ip_path(u0, readonly([st.position]), readonly([st.rotation]),
                                  spatial_problem_arrays(prob), readonly(np.ones(u0.size)),
                                  1e-7, 1e-9, 1e-3, 3, POLISH_REACH, POLISH_MARGIN, 1e-6,
                                  1e-8, True, np.zeros(6), np.zeros(0),
                                  np.zeros(0, dtype=bool), False)  # fmt: skip
        spatial_check_many(stack, [st], q0[None])


def kernels_cached(kind: str) -> bool | None:
    """True when numba's on-disk cache holds current machine code for every entry point
    of ``kind``, False when some must be compiled, None when that cannot be told."""
    try:
        return all(bool(d._cache._cache_file._load_index()) for d in _dispatchers(kind))
    except Exception:  # noqa: BLE001 - numba internals: unknown, not an error
        return None


def _warm(kind: str) -> None:
    if kind == "planar":
        from stackik.methods.ip import warm_up as planar_warm_up

        planar_warm_up()
        _warm_path_kernels(True)
        _warm_sqp_kernels(True)
        return
    from stackik.methods.ip import ip_starts

    _, _, _, prob, q0 = _small_problem(False)
    prob.evaluate(prob.u_of(q0))
    ip_starts(prob, [q0], {}, math.inf)  # spatial IP
    _warm_path_kernels(False)
    _warm_sqp_kernels(False)


def ensure_kernels(kind: str, *, notice: bool = True) -> float:
    """Load or compile the kernels of ``kind`` (``"planar"`` or ``"spatial"``) once per
    process; returns the seconds spent (0 when already done). A compilation prints one
    line on stderr first (``notice=False`` silences it)."""
    if kind not in KERNEL_KINDS:
        raise ValueError(f"kind: unknown {kind!r}; choose one of {tuple(KERNEL_KINDS)}")
    if kind in _READY:
        return 0.0
    with _LOCK:
        if kind in _READY:
            return 0.0
        t0 = time.perf_counter()
        if notice and kernels_cached(kind) is False:
            print(
                f"stackik: compiling the {kind} solver kernels (first run on this machine "
                f"only, about {KERNEL_KINDS[kind]:.0f} s; cached afterwards)",
                file=sys.stderr,
                flush=True,
            )
        _warm(kind)
        _READY.add(kind)
        return time.perf_counter() - t0


def warm_up(kinds: tuple[str, ...] = ("planar", "spatial"), *, notice: bool = True) -> float:
    """Load or compile every kernel set in ``kinds`` now (e.g. in a worker process before
    it takes work); returns the seconds spent."""
    return sum(ensure_kernels(k, notice=notice) for k in kinds)
