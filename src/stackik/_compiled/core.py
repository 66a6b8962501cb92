"""What every compiled interior point shares: the jit options, the status codes, the
give-up rule of a multi-start call, the objective scaling, the clock, two array tests and
two reductions (``max |x|``, ``min x``) written as loops.

The planar (:mod:`stackik._compiled.planar`) and spatial (:mod:`stackik._compiled.spatial`)
barrier methods and their path kernels take these from here, one definition each.
"""

from __future__ import annotations

import math
import time
import warnings
from typing import Any

import numpy as np
from numba import njit, objmode, types
from numba.extending import overload

FloatArray = Any


#: Compiled once per machine and cached; floating-point errors give inf/nan (numpy's
#: model) rather than exceptions, and the loop treats non-finite values as failures.
#: nogil: solves in threads (``solve_many(executor=ThreadPoolExecutor(...))``) run in
#: parallel; only the occasional clock read (:func:`_now`, object mode) takes the GIL,
#: which numba warns about at compile time.
_jit = njit(cache=True, error_model="numpy", nogil=True)
#: The same, inlined where called (numba IR): for the small parts of one iteration that
#: the kernels' hot loops call (the barrier method's errors, barrier update, step lengths
#: and filter test; the Hessian's block subtraction), so that splitting a loop into named
#: parts costs no call; and for small functions called in one or a few places (the
#: polish, the KKT solves behind the kernel interface, a path step's target test):
#: every compiled (not inlined) function is a library of its own that numba optimises
#: and turns into machine code with all its callees linked in, so a thin layer compiles
#: its callees once more. Large functions stay compiled: numba's inlining and LLVM's
#: function passes on the inlined whole cost more than the library they save.
_jit_inline = njit(cache=True, error_model="numpy", nogil=True, inline="always")
#: The same, for a function only compiled code calls (the implementations of the kernel
#: interface, :mod:`stackik._compiled.kernel`, that nothing calls from Python): without the
#: CPython wrapper numba otherwise generates for every compiled function (unboxing and
#: boxing the problem data, a tuple of some thirty arrays, is more code than many of
#: these functions' own). Called from Python, such a function crashes.
_NO_WRAPPER: Any = {"no_cpython_wrapper": True}  # (a flag numba's type stubs do not list)
_jit_internal = njit(cache=True, error_model="numpy", nogil=True, **_NO_WRAPPER)
warnings.filterwarnings(
    "ignore", message="Code running in object mode won't allow parallel execution"
)

#: The jit options of an implementation numba compiles in place of an overloaded stub (the
#: kernels'; not cached by itself: it is part of the cached kernel that calls it).
_OVERLOAD: Any = {"error_model": "numpy", "nogil": True}


def unresolved() -> Any:
    """The body of an overloaded stub (:mod:`stackik._compiled.kernel`,
    :mod:`stackik._compiled.dense_rows`): numba compiles an implementation in its place,
    chosen by the argument types; called from Python, it raises."""
    raise NotImplementedError("resolved by numba in compiled code (stackik._compiled)")


def lean_type(P: Any) -> bool:
    """Whether the numba type ``P`` of problem data (the ``NamedTuple`` type of
    :class:`stackik._compiled.planar.PlanarData` or
    :class:`stackik._compiled.spatial.SpatialData`) is the lean one: ``n_dense`` None, a
    problem with no rows beyond the leg and joint limits (no dense rows:
    :mod:`stackik._compiled.dense_rows`; no spatial self-leg rows). numba compiles the
    kernels for it as a specialisation of their own; the overloads that carry those rows
    (``dense_rows.with_dense_rows``, the spatial self-leg rows' calls) compile to nothing
    for it, so a solve without such rows never compiles their code."""
    return isinstance(P.types[P.fields.index("n_dense")], types.NoneType)


def no_dense_rows(P: Any) -> bool:
    """Whether the problem data ``P`` has no dense rows: ``P.n_dense`` None or 0; in
    compiled code the constant True for the lean type (:func:`lean_type`)."""
    return P.n_dense is None or P.n_dense == 0


@overload(no_dense_rows, jit_options=_OVERLOAD)
def _no_dense_rows(P):  # type: ignore[no-untyped-def]
    if lean_type(P):
        return lambda P: True
    return lambda P: P.n_dense == 0


#: The multi-start kernel (:func:`stackik._compiled.barrier.ip_multi`) stops when its
#: first GIVE_UP_AFTER starts all end farther than GIVE_UP_VIOLATION (scaled) from
#: feasibility: an unreachable target is then reported by the SQP fallback in a fraction
#: of the time the remaining starts would take.
GIVE_UP_AFTER = 3
GIVE_UP_VIOLATION = 1e-4
#: The objective is scaled so that its gradient at the start is at most this (IPOPT's
#: nlp_scaling_max_gradient).
OBJ_MAX_GRAD = 100.0

#: Status codes of a barrier solve (``ip_loop``), and their names.
IP_SUCCESS, IP_MAX_ITER, IP_STALLED, IP_NONFINITE, IP_MAX_TIME, IP_SKIPPED = 0, 1, 2, 3, 4, 5
IP_STATUS = {
    IP_SKIPPED: "skipped",
    IP_SUCCESS: "success",
    IP_MAX_ITER: "max_iter",
    IP_STALLED: "stalled",
    IP_NONFINITE: "nonfinite",
    IP_MAX_TIME: "max_time",
}


@_jit
def _finite(a: FloatArray) -> bool:
    """``np.all(np.isfinite(a))`` without the boolean temporary (a kernel's hot loops
    test a few arrays every iteration)."""
    for v in a.flat:
        if not math.isfinite(v):
            return False
    return True


@_jit_inline
def _abs_max(a: FloatArray) -> float:
    """``np.abs(a).max()``, as numpy gives it (the first NaN if there is one; ValueError
    when empty), without the temporary: numba's reduction is written over ``np.nditer``
    and compiles to far more code than this loop."""
    if a.size == 0:
        raise ValueError("zero-size array to reduction operation maximum")
    m = 0.0
    for v in a.flat:
        av = abs(v)
        if math.isnan(av):
            return av
        if av > m:
            m = av
    return m


@_jit_inline
def _amin(a: FloatArray) -> float:
    """``a.min()`` of a 1-D array, as numpy gives it (the first NaN if there is one;
    ValueError when empty), by a loop (see :func:`_abs_max`)."""
    if a.size == 0:
        raise ValueError("zero-size array to reduction operation minimum")
    m = a[0]
    for v in a:
        if math.isnan(v):
            return v
        if v < m:
            m = v
    return m


@_jit
def _now() -> float:
    with objmode(t="float64"):
        t = time.perf_counter()
    return t


@_jit
def _limit_rows(z: FloatArray, n: int, keep: int = 24) -> FloatArray:
    """The multipliers of the first ``keep`` rows a platform (the 24 limits, and any
    further rows with curvature) among the ``z.size / n`` rows per platform of a boxed
    problem (a box adds two rows a variable; ``z`` itself without a box): the box is
    linear, so only these enter the Hessian."""
    if z.size == keep * n:
        return z
    R = z.size // n
    out = np.empty(keep * n)
    for i in range(n):
        for r in range(keep):
            out[keep * i + r] = z[R * i + r]
    return out
