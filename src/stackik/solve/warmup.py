"""The compiled kernels: loaded (or compiled) once per process, before any clock starts.

The planar interior point and its re-check (:mod:`stackik._compiled.planar`,
:mod:`stackik._compiled.check`), the spatial evaluation
(:mod:`stackik._compiled.spatial_kinematics`) and the spatial interior point
(:mod:`stackik._compiled.spatial`) are compiled by numba with
``cache=True``: the first use on a machine compiles them (a minute or more each on a
loaded 2-core machine: ``benchmarks/results/first_run.md``) and writes machine code beside
the sources (or to ``NUMBA_CACHE_DIR``); later processes load it (a fraction of a
second). :func:`solve_ik` calls :func:`ensure_kernels` for what the request needs
*before* its clock starts, so compilation never eats a solve's time budget nor shows in
:attr:`IKResult.time` (:func:`stackik.solve_path` does the same for its mode's path
family: the continuation steps of :mod:`stackik._compiled.planar_path` or
:mod:`stackik._compiled.spatial_path` and the batch checks, compiled on the first path,
not the first solve); the warm-up also runs what numba compiles per process whatever
the cache (the interior point's object-mode clock) and creates the BLAS controller, so
that a first solve after it pays nothing a later one does not.

A compilation shows its progress on stderr, per kernel family: on a terminal a bar that
ticks per entry point compiled (``stackik: planar kernels 3/8 [00:41, ip_multi]``: the
elapsed time and the function numba compiles now); otherwise (a log, a pipe) one line
when it starts and one when it ends, with the seconds it took.
"""

from __future__ import annotations

import math
import operator
import os
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import IO, Any

__all__ = ["KERNEL_KINDS", "ensure_kernels", "kernels_cached", "rows_needed", "warm_up"]

#: The kernel families, compiled and loaded separately: a spatial solve needs no planar
#: kernel unless its target turns out unreachable, and a solve needs no path kernel (the
#: path families hold the continuation steps and the batch checks of
#: :func:`stackik.solve_path`: about 30 % of a mode's compile time, paid on the first
#: path instead of the first solve). Each family has a ``_rows`` twin: the same kernels
#: compiled for problems with rows beyond the leg and joint limits (obstacle, non-adjacent
#: body, constraint-family or leg-force rows: :mod:`stackik._compiled.dense_rows`; spatial
#: self-leg rows). The problem data without them are a type of their own
#: (:func:`stackik._compiled.core.lean_type`), compiled without their code, so a solve
#: without such rows compiles none of it; a request that can carry them loads the twins
#: (:func:`rows_needed`).
KERNEL_KINDS: tuple[str, ...] = (
    "planar", "spatial", "planar_path", "spatial_path",
    "planar_rows", "spatial_rows", "planar_path_rows", "spatial_path_rows",
)  # fmt: skip

#: The families a family's warm-up runs on top of (its kernels call theirs).
_NEEDS: dict[str, tuple[str, ...]] = {
    "planar_path": ("planar",),
    "spatial_path": ("spatial",),
    "planar_rows": ("planar",),
    "spatial_rows": ("spatial",),
    "planar_path_rows": ("planar_path", "planar_rows"),
    "spatial_path_rows": ("spatial_path", "spatial_rows"),
}

#: numba's LLVM IR optimisation level (``NUMBA_OPT``) for stackik's kernels: 1 instead of
#: numba's default 3 compiles a family about 20 % faster on an empty cache (planar and
#: spatial solver families 32 s instead of 40 s each on a 2-core machine) for the same
#: poses, and solves 1-2 % slower at n <= 8 (``docs/benchmarks.md``). A ``NUMBA_OPT`` in
#: the environment takes precedence over this and :data:`FAST_KINDS`.
COMPILE_OPT = 1

#: The families compiled at numba's level 3 all the same: the planar solver's dense
#: O(n^2) loops (its reduced Hessian, the FN's Gauss-Newton part) run 4-9 % faster there at
#: n = 16-64 (``benchmarks/paired_trees.py``, docs/benchmarks.md), for about 8-10 s more of
#: a first planar solve's compile.
FAST_KINDS: frozenset[str] = frozenset({"planar"})

_READY: set[str] = set()
_LOCK = threading.Lock()


def _dispatchers(kind: str) -> list[Any]:
    """The compiled entry points of the family ``kind`` (what its progress counts)."""
    if kind.endswith("_rows"):
        return _row_dispatchers(kind)
    if kind == "planar_path":
        from stackik._compiled import check as _check
        from stackik._compiled import planar_path as _ipm_path

        return [_ipm_path.ip_path, _check._planar_check_many, _check._planar_path_arrays]
    if kind == "spatial_path":
        from stackik._compiled import check as _check
        from stackik._compiled import spatial_path as _spatial_ipm_path

        return [_spatial_ipm_path.ip_path, _check._spatial_check_many]
    # the check's screen for legs through plates and its distances, which every check of
    # a zero-size stack may call (stackik.clearance.cores_cross): in both solver families
    from stackik._compiled import body_distances as _body

    check = [_body.any_crossing, _body.body_clearances]
    if kind == "planar":
        from stackik._compiled import barrier as _barrier
        from stackik._compiled import check as _check
        from stackik._compiled import planar as _ipm

        return [_barrier.ip_multi, _ipm._evaluate, _ipm._lagrangian_hessian,
                _check._planar_check, *check]  # fmt: skip
    # (the barrier method's entry points are both modes', compiled once for each)
    from stackik._compiled import barrier as _barrier
    from stackik._compiled import spatial as _spatial_ipm
    from stackik._compiled import spatial_kinematics as _spatial

    return [_spatial.spatial_parts, _spatial.block_jacobian, _barrier.ip_multi,
            _spatial_ipm._evaluate, _spatial_ipm._hessian, *check]  # fmt: skip


def _row_dispatchers(kind: str) -> list[Any]:
    """The entry points of a ``_rows`` family: its plain twin's main kernel (compiled
    again for problem data with rows beyond the limits) and, for the solver families, the rows'
    kernels the NumPy evaluation calls (shared by both modes)."""
    from stackik._compiled import barrier as _barrier
    from stackik._compiled import body_distances as _body
    from stackik._compiled import force_rows as _force_rows
    from stackik._compiled import obstacle_rows as _obstacle_rows
    from stackik._compiled import planar_path as _ipm_path
    from stackik._compiled import spatial_path as _spatial_ipm_path

    if kind == "planar_path_rows":
        return [_ipm_path.ip_path]
    if kind == "spatial_path_rows":
        return [_spatial_ipm_path.ip_path]
    from stackik._compiled import self_legs as _self_legs

    # (the spatial NumPy evaluation's self-leg rows for legs of a radius: spatial only)
    own = [_self_legs.self_leg_block] if kind == "spatial_rows" else []
    return [_barrier.ip_multi, _obstacle_rows.obstacle_rows, _force_rows.force_rows,
            _body.body_clearances, _force_rows.leg_force_jacobian, *own]  # fmt: skip


def rows_needed(
    stack: Any,
    obstacles: Any = (),
    clearance: Any = 0.0,
    constraints: Any = (),
    force_weight: Any = 0.0,
    objective: Any = "frobenius",
    *,
    planar_solve: bool = False,
) -> bool:
    """Whether a request on ``stack`` with these arguments (those of
    :func:`stackik.solve_ik`) can carry rows beyond the leg and joint limits, so that it
    needs the ``_rows`` kernel families: obstacles, a clearance margin, legs or plates with
    a size (the spatial self-leg rows; the non-adjacent bodies' rows a folded pose gets),
    constraint families, finite force limits or a force term. Arguments the request's
    validation will refuse count as none (it reports them).

    ``planar_solve``: for a planar :func:`stackik.solve_ik`, legs and plates of a size do
    not count. Its self-leg rows are lazy and outside the interior point, and its
    non-adjacent bodies' rows come only with a folded pose, whose unfold loads the family
    then, off the solve's clock (``stages._unfold``; on the reference geometry's 12 mm legs
    no planar solve of 30 targets at n = 4 nor 10 at n = 8 called for it): a first solve
    of the reference stack compiles the planar family alone, as for legs as lines."""
    from stackik.clearance import needs_clearances
    from stackik.formulation.forces import force_limited

    try:
        if obstacles is not None and not isinstance(obstacles, list | tuple):
            obstacles = (obstacles,)
        obstacles, margin = tuple(obstacles or ()), float(clearance or 0.0)
        bodies = (
            bool(obstacles) or margin > 0.0  # (needs_clearances less the bodies' sizes)
            if planar_solve
            else needs_clearances(stack, obstacles, margin)
        )
        return bool(
            bodies
            or constraints
            or force_limited(stack)
            or float(force_weight or 0.0) > 0.0
            or objective == "force"
        )
    except (TypeError, ValueError, AttributeError):
        return False


def _small_problem(planar: bool, rows: bool = False) -> tuple[Any, ...]:
    """``(stack, planar target, target of the mode, Problem, paper's guess)`` of the
    two-platform problem the warm-ups run the kernels on; with ``rows``, a sphere within
    reach gives it dense rows (the obstacle rows: the ``_rows`` families' problem data)."""
    import numpy as np

    from stackik.formulation import Problem
    from stackik.geometry import PlatformGeometry, Stack
    from stackik.obstacles import Sphere
    from stackik.starts import paper_initial_guess
    from stackik.targets import PlanarTarget

    # the paper's model (legs of zero radius)
    stack = Stack.uniform(PlatformGeometry.hexagonal(), 2)
    pt = PlanarTarget(0.0, 700.0, 0.0)
    target = pt if planar else pt.to_spatial()
    obstacles = [Sphere(np.array([0.0, 0.0, 300.0]), 10.0)] if rows else []
    return (
        stack,
        pt,
        target,
        Problem(stack, target, "frobenius", None, obstacles=obstacles),
        paper_initial_guess(stack, target),
    )


def _warm_sqp_kernels(planar: bool, rows: bool = False) -> None:
    """Run the kernels the SQP method evaluates its compiled problem with
    (:class:`stackik.methods._sqp_compiled.CompiledNLP`: writable point and multipliers,
    read-only problem arrays; a path's transit step computes its ``f0`` with the same
    planar evaluation) once, so that a solve's clock sees no loading."""
    import numpy as np

    from stackik.methods._sqp_compiled import CompiledNLP

    stack, _, _, prob, q0 = _small_problem(planar, rows)
    nlp = CompiledNLP(prob)
    u = prob.u_of(q0)
    nlp.evaluate(u)
    nlp.hessian(u, np.zeros(3 if planar else 6), np.zeros(nlp.R * stack.n))


def _warm_path_kernels(planar: bool, rows: bool = False) -> None:
    """Run the path kernels (:mod:`stackik.paths`: the boxed and goal-seeking step, the
    run of warm steps, the batch check) once on a small problem, with the argument
    types the paths pass (read-only arrays), so that a path's clock sees no loading."""
    import numpy as np

    from stackik._arrays import readonly
    from stackik._compiled import barrier
    from stackik._compiled import planar_path as _ipm_path
    from stackik._compiled import spatial_path as _spatial_ipm_path
    from stackik._compiled.check import planar_check_many, planar_path_arrays, spatial_check_many
    from stackik.formulation import POLISH_MARGIN, POLISH_REACH
    from stackik.methods.ip import problem_arrays, spatial_problem_arrays

    stack, pt, _, prob, q0 = _small_problem(planar, rows)
    u0 = readonly(prob.u_of(q0))
    lo, hi = readonly(u0 - 0.1), readonly(u0 + 0.1)
    P = problem_arrays(prob) if planar else spatial_problem_arrays(prob)
    for ug, wq in ((readonly(np.zeros(0)), 0.0), (u0, 1.0)):
        barrier.ip_box(u0, P, lo, hi, ug, wq, 1e-7, 1e-9, 1e-3, 3, POLISH_REACH,
                       POLISH_MARGIN)  # fmt: skip
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
        if kind.endswith("_rows"):  # its main kernel's index holds the rows' data type
            index = _dispatchers(kind)[0]._cache._cache_file._load_index()
            return any(_rows_signature(key[0], kind.startswith("planar")) for key in index)
        return all(bool(d._cache._cache_file._load_index()) for d in _dispatchers(kind))
    except Exception:  # noqa: BLE001 - numba internals: unknown, not an error
        return None


def _rows_signature(sig: Any, planar: bool) -> bool:
    """Whether a compiled signature takes the mode's problem data of the rows' type (not
    the lean one)."""
    from stackik._compiled.core import lean_type
    from stackik._compiled.planar import PlanarData
    from stackik._compiled.spatial import SpatialData

    data = PlanarData if planar else SpatialData
    return any(
        getattr(t, "instance_class", None) is data and not lean_type(t)
        for t in getattr(sig, "args", sig)
    )


def _warm(kind: str) -> None:
    planar = kind.startswith("planar")
    rows = kind.endswith("_rows")
    if "_path" in kind:
        _warm_path_kernels(planar, rows)
        return
    from stackik.methods.ip import ip_starts, n_dense
    from stackik.solve.blas import _blas_controller

    _blas_controller()  # threadpoolctl's scan of the loaded libraries (~20 ms), once
    stack, pt, _, prob, q0 = _small_problem(planar, rows)
    assert bool(n_dense(prob)) == rows  # the problem data's type is the family's
    prob.evaluate(prob.u_of(q0))
    # two starts: the batch reads its clock before the second (an object-mode call that
    # numba compiles in every process, cache or not: 31-39 ms of the first solve's time)
    ip_starts(prob, [q0, q0], {}, math.inf)
    _warm_sqp_kernels(planar, rows)
    if rows:
        _warm_row_evaluations(prob, q0, planar)
    else:  # the check's screen and distances (a pose whose legs pass through a plate)
        from stackik.clearance import clearances, cores_cross

        phi = pt.phi if planar else None
        cores_cross(stack, q0, phi)
        clearances(stack, q0, phi=phi)


def _warm_row_evaluations(prob: Any, q0: Any, planar: bool) -> None:
    """The rows' kernels the NumPy evaluation (:class:`stackik.formulation.Problem`, the
    SQP engine's and SciPy's) and the check call on their own."""
    from stackik.clearance import clearances
    from stackik.formulation import Problem
    from stackik.geometry import PlatformGeometry, Stack

    # the self-leg rows Problem appends for legs with a radius
    fat = Stack.uniform(PlatformGeometry.hexagonal(leg_radius=1.0), prob.n)
    Problem(fat, prob.target, "frobenius", None).evaluate(prob.u_of(q0))
    # the check's distances between the bodies (stackik._compiled.body_distances)
    clearances(fat, q0, phi=getattr(prob.target, "phi", None) if planar else None)
    # the leg-force rows and the force objective's residuals (stackik._compiled.force_rows)
    limited = Stack.uniform(PlatformGeometry.hexagonal(plate_mass=1.0, force_max=1e3), prob.n)
    for objective in ("frobenius", "force"):
        Problem(limited, prob.target, objective, None).evaluate(prob.u_of(q0))


@contextmanager
def _compile_opt(kind: str) -> Iterator[None]:
    """numba's LLVM IR optimisation level while in the block (the warm-up's compilation of
    ``kind``): 3 for :data:`FAST_KINDS`, else :data:`COMPILE_OPT`, unless the user chose
    one (``NUMBA_OPT`` in the environment: then that one); restored afterwards, so that the
    user's own numba code keeps its own. Machine-code generation keeps numba's level
    (fixed when numba starts)."""
    from numba.core import config as numba_config

    config: Any = numba_config  # its settings are set at import time: mypy sees none
    if "NUMBA_OPT" in os.environ:
        yield
        return
    before = config.OPT
    config.OPT = config._OptLevel(3 if kind in FAST_KINDS else COMPILE_OPT)
    try:
        yield
    finally:
        config.OPT = before


def _label(kind: str) -> str:
    """``"planar solver"``, ``"spatial path"``, ``"planar solver (with rows)"``, ...: the
    family in a progress line (``_rows``: for rows beyond the limits)."""
    base, rows = kind.removesuffix("_rows"), kind.endswith("_rows")
    mode, _, part = base.partition("_")
    return f"{mode} {part or 'solver'}" + (" (with rows)" if rows else "")


class _Progress:
    """Compilation progress of one kernel family on ``stream``, fed by numba's
    ``numba:compile`` events: a tqdm bar ticking per entry point when ``tty``, else a
    line at the start; a line at the end either way."""

    def __init__(self, kind: str, entry_points: list[Any], stream: IO[str], tty: bool) -> None:
        self.kind, self.stream = kind, stream
        self.entry = {id(d) for d in entry_points}
        self.total = len(entry_points)
        self.done: set[int] = set()
        self.functions = 0
        self.t0 = time.perf_counter()
        self.bar: Any = None
        if tty:
            from tqdm.auto import tqdm

            self.bar = tqdm(
                total=self.total,
                desc=f"stackik: {kind.replace('_', ' ')} kernels",
                file=stream,
                bar_format="{desc} {n_fmt}/{total_fmt} [{elapsed}{postfix}]",
                mininterval=0.0,  # every tick shown (a few per family)
                leave=False,
            )
        else:
            print(
                f"stackik: compiling the {_label(kind)} kernels ({self.total} entry points; "
                "first run on this machine only, cached afterwards)",
                file=stream,
                flush=True,
            )

    def started(self, event: Any) -> None:
        """A ``numba:compile`` event starts: name the function on the bar."""
        if self.bar is not None:
            name = getattr(getattr(event.data.get("dispatcher"), "py_func", None), "__name__", "?")
            self.bar.set_postfix_str(name, refresh=True)

    def ended(self, event: Any) -> None:
        """A ``numba:compile`` event ends: tick when it is a new entry point."""
        self.functions += 1
        key = id(event.data.get("dispatcher"))
        if key in self.entry and key not in self.done:
            self.done.add(key)
            if self.bar is not None:
                self.bar.update(1)

    def close(self) -> None:
        seconds = time.perf_counter() - self.t0
        if self.bar is not None:
            self.bar.close()
        print(
            f"stackik: compiled the {_label(self.kind)} kernels in {seconds:.0f} s "
            f"({len(self.done)} of {self.total} entry points, {self.functions} functions "
            "in all)",
            file=self.stream,
            flush=True,
        )


@contextmanager
def _progress(kind: str, stream: IO[str] | None = None) -> Iterator[_Progress]:
    """Show the compilation of ``kind`` on ``stream`` (default stderr) while in the block."""
    from numba.core import event

    stream = sys.stderr if stream is None else stream
    tty = bool(getattr(stream, "isatty", lambda: False)())
    progress = _Progress(kind, _dispatchers(kind), stream, tty)

    class Forward(event.Listener):  # numba's listener interface, to the progress
        def on_start(self, e: Any) -> None:
            progress.started(e)

        def on_end(self, e: Any) -> None:
            progress.ended(e)

    listener = Forward()
    event.register("numba:compile", listener)
    try:
        yield progress
    finally:
        event.unregister("numba:compile", listener)
        progress.close()


def ensure_kernels(kind: str, *, notice: bool = True) -> float:
    """Load or compile the kernels of ``kind`` (one of :data:`KERNEL_KINDS`: ``"planar"``,
    ``"spatial"``, ``"planar_path"``, ``"spatial_path"``; a path family with its mode's
    solver family) once per process; returns the seconds spent (0 when already done). A
    compilation shows its progress on stderr (module docstring; ``notice=False``
    silences it)."""
    if kind not in KERNEL_KINDS:
        raise ValueError(f"kind: unknown {kind!r}; choose one of {KERNEL_KINDS}")
    if kind in _READY:
        return 0.0
    spent = sum(ensure_kernels(k, notice=notice) for k in _NEEDS.get(kind, ()))
    with _LOCK:
        if kind in _READY:
            return spent
        t0 = time.perf_counter()
        with _compile_opt(kind):
            if notice and kernels_cached(kind) is False:
                with _progress(kind):
                    _warm(kind)
            else:
                _warm(kind)
        _READY.add(kind)
        return spent + time.perf_counter() - t0


def warm_up(kinds: tuple[str, ...] = KERNEL_KINDS, *, notice: bool = True, jobs: int = 1) -> float:
    """Load or compile every kernel set in ``kinds`` now (e.g. in a worker process before
    it takes work), and import the SQP engine's QP backends and :mod:`scipy.optimize`
    (the scipy baselines'): their first import (~0.2 s and ~0.3 s) would otherwise land
    in the first such solve's time; returns the seconds spent.

    ``jobs`` > 1 compiles the planar and the spatial families (those of ``kinds`` the
    cache does not hold yet) in that many child processes at once, each mode's in one
    child (a family compiles its mode's solver family first), then loads them from the
    cache here: on a machine with two or more free cores a first warm-up of both modes
    takes about the time of the slower mode instead of the sum. The machine code is the
    same as compiled here (the same compiler and settings; numba's cache is per
    machine). The children take turns to write the cache (a file lock: two writes of
    one function's cache index at once could pair an entry with the other's code), so
    this needs POSIX file locks; elsewhere, and in a frozen application, ``jobs`` is
    ignored. A child that fails or runs longer than :data:`CHILD_TIMEOUT` is stopped and
    leaves its families to this process, which compiles them."""
    try:
        count = -1 if isinstance(jobs, bool) else operator.index(jobs)
    except TypeError:
        count = -1
    if count < 1:
        raise ValueError(f"jobs: expected an integer >= 1, got {jobs!r}")
    for kind in kinds:
        if kind not in KERNEL_KINDS:
            raise ValueError(f"kind: unknown {kind!r}; choose one of {KERNEL_KINDS}")
    t0 = time.perf_counter()
    if count > 1:
        _compile_apart(_uncached_by_mode(kinds), count, notice)
    for kind in kinds:
        ensure_kernels(kind, notice=notice)
    _import_qp_backends()
    import scipy.optimize  # noqa: F401 - the import is the point

    return time.perf_counter() - t0


#: How long :func:`warm_up` with ``jobs`` > 1 waits for a child's compilation [s] before
#: it stops the child and compiles that child's families itself (a mode's families take
#: 2-4 minutes on a 2-core machine).
CHILD_TIMEOUT = 1800.0

# A child of _compile_apart: numba's cache writes under an exclusive lock on the file
# argv[2], then the families argv[3:] (argv[1]: "1" to show progress).
_CHILD = """
import fcntl, sys
from numba.core import caching

_save = caching.IndexDataCacheFile.save


def save(self, key, data):
    with open(sys.argv[2], "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            _save(self, key, data)
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


caching.IndexDataCacheFile.save = save
from stackik.solve.warmup import ensure_kernels

for kind in sys.argv[3:]:
    ensure_kernels(kind, notice=sys.argv[1] == "1")
"""


def _uncached_by_mode(kinds: tuple[str, ...]) -> list[tuple[str, ...]]:
    """The families of ``kinds`` that this process has not loaded and numba's cache does
    not hold (those :func:`kernels_cached` cannot tell about are left to this process),
    grouped by mode (planar, spatial), in ``kinds``' order; empty groups left out."""
    groups: dict[str, list[str]] = {"planar": [], "spatial": []}
    for kind in kinds:
        if kind not in _READY and kernels_cached(kind) is False:
            groups["planar" if kind.startswith("planar") else "spatial"].append(kind)
    return [tuple(g) for g in groups.values() if g]


def _compile_apart(
    groups: list[tuple[str, ...]], jobs: int, notice: bool, timeout: float | None = None
) -> list[int]:
    """Compile each group of families (:func:`_uncached_by_mode`) in a child process of
    this interpreter (its ``sys.path`` passed on), at most ``jobs`` at once, and wait for
    them. Nothing to gain from one group (it compiles here as fast). A child's progress
    lines (the one-line form: it writes to a file) reach this process's stderr when it
    ends. A child that fails to start, fails or outlives ``timeout`` (default
    :data:`CHILD_TIMEOUT`) is not an error (the caller compiles what is missing); a child
    still running when this returns or raises is stopped. Returns the exit codes of the
    children that ran (negative: stopped by a signal), in the order they were collected."""
    import subprocess
    import tempfile

    try:
        import fcntl  # noqa: F401 - the children lock the cache with it
    except ImportError:  # no POSIX file locks: the caller compiles, one mode after the other
        return []
    if len(groups) < 2 or getattr(sys, "frozen", False):
        return []
    limit = CHILD_TIMEOUT if timeout is None else timeout
    lock = os.path.join(tempfile.gettempdir(), "stackik-numba-cache.lock")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    waiting = list(groups)
    running: list[tuple[subprocess.Popen[bytes], IO[bytes], float]] = []
    codes: list[int] = []
    try:
        while waiting or running:
            while waiting and len(running) < jobs:
                group = waiting.pop(0)
                out = tempfile.TemporaryFile()
                args = [sys.executable, "-c", _CHILD, "1" if notice else "0", lock, *group]
                try:
                    child = subprocess.Popen(
                        args, stdin=subprocess.DEVNULL, stdout=out, stderr=out, env=env
                    )
                except OSError:  # (the caller compiles the group)
                    out.close()
                    continue
                running.append((child, out, time.monotonic() + limit))
            if not running:
                break
            time.sleep(0.2)
            done = [r for r in running if r[0].poll() is not None or time.monotonic() > r[2]]
            running = [r for r in running if r not in done]
            for child, log, _ in done:
                if child.poll() is None:  # past its time: stopped
                    child.kill()
                    child.wait()
                codes.append(child.returncode)
                log.seek(0)
                text = log.read().decode(errors="replace")
                log.close()
                if notice and text:
                    print(text, end="", file=sys.stderr, flush=True)
    finally:
        for child, log, _ in running:
            child.kill()
            child.wait()
            log.close()
    return codes


def _import_qp_backends() -> None:
    """Import the installed QP backends (:func:`stackik.sqp.qp.available_qp_solvers`
    tries each) and build the default one, as a first SQP solve does."""
    from stackik.sqp.qp import default_qp_solver, make_backend

    try:
        make_backend(default_qp_solver())
    except ValueError:  # no QP solver installed: the SQP solve reports it
        pass
