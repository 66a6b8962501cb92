"""One continuation step of a path: from a pose at one target to a pose at the next.

The ladder, cheapest first (each rung is tried only when the one before fails):

1. **warm**: one warm-started solve from the previous pose (the compiled interior point,
   planar or spatial, first with a small initial barrier ``mu0`` so that it stays near
   its start, then with the default one if that finds no checked pose). Accepted when
   the pose passes the independent check and no variable moved more than ``max_jump``:
   the solve stayed in the basin of the previous pose, i.e. on its fold.
2. **subdivided**: bisect the target segment and solve the halves warm-started, recursively
   to ``max_depth`` (a step too large for a warm start to stay in its basin).
3. **bounded**: the least-FN pose within the ``max_jump`` box of the previous pose
   (:func:`stackik.paths.bounded.bounded_step`): the local minimum the path followed has
   ended, and the path leaves it continuously instead of jumping to another one.

A step that fails all three is a break: no pose of the next target within ``max_jump``.

Every rung accepts a pose only when the full check passes (clearances included). A pose
that the check refuses only for bodies of non-adjacent platforms (the stack folded into
itself, :func:`stackik.methods.ip.folds_only`) has the rung made again from the same pose
with rows for the pairs of such bodies close there or at the refused pose, as
:func:`stackik.solve.stages._unfold` does for a solve; and every step carries rows for the
pairs close at its start (:meth:`Tracker._pairs`, solve_ik's screen; on legs as lines,
zero-thickness plates and no margin only the rows found after a fold). A path on which no
such pair comes close has no such rows: it is the path without them, bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik import check
from stackik._arrays import readonly
from stackik.clearance import needs_clearances
from stackik.formulation.modes import mode_of
from stackik.geometry import Stack
from stackik.paths.bounded import bounded_ip, bounded_step
from stackik.paths.interpolate import lerp_target
from stackik.solve import solve_ik
from stackik.solve.policy import UNFOLD_ROUNDS, UNFOLD_SCREEN_MM
from stackik.targets import Target

__all__ = ["BOX_INSIDE", "WARM_MU0", "Step", "StepCounts", "Tracker", "jump_scale"]

FloatArray = NDArray[np.float64]

#: Initial barrier parameter of the warm interior-point solve: a warm start sits on its
#: active limits, and a small barrier keeps the iterates in that basin (9 instead of 13
#: iterations, and fewer fold changes). When it fails (no checked pose), the default
#: barrier (0.1) is tried; when it leaves its basin, the default one did too on every
#: case measured (31 of 31 on six n = 8 paths), so it is not tried.
WARM_MU0 = 1e-3
#: Spatial :meth:`Tracker.follow` (a fast path's goal basin beside the path): iterations
#: of its barrier solve when the continuation step fails; a solve that has not converged
#: within them drops the goal (a warm solve that keeps its basin takes 10-40; on the
#: bench's curved n = 4 path the dropped goal's solve had not converged after 60, 300 or
#: 1000 iterations, 30-60 ms each uncapped: the cap saves that time, the path is the
#: same with any cap from 40 to 300).
FOLLOW_MAX_ITER = 60
#: A bounded step whose largest change is below this fraction of ``max_jump`` has no
#: variable at its box (the boxed interior point ends within ~1e-7 of an active bound):
#: its pose is a minimum of the problem without the box.
BOX_INSIDE = 1.0 - 1e-4


def jump_scale(max_jump: tuple[float, float], k: int) -> FloatArray:
    """Per-variable jump limit of one platform, shape (k,): mm for translations (the
    first 2 planar / 3 spatial variables), rad for angles."""
    nt = 2 if k == 3 else 3
    return np.array([max_jump[0]] * nt + [max_jump[1]] * (k - nt))


@dataclass
class StepCounts:
    """Work done by a :class:`Tracker` (solver calls by rung)."""

    warm: int = 0
    warm_retry: int = 0
    subdivided: int = 0
    bounded: int = 0
    bounded_failed: int = 0
    transit: int = 0
    transit_failed: int = 0
    sqp_fallback: int = 0  # bounded/transit steps the compiled interior point missed
    pc: int = 0  # warm steps made by the predictor-corrector step (no barrier solve)
    unfold: int = 0  # rungs made again with rows for close non-adjacent bodies (a fold)

    def as_dict(self) -> dict[str, int]:
        return dict(self.__dict__)


@dataclass(frozen=True)
class Step:
    """A continuation step that succeeded: the pose and the rung that found it."""

    q: FloatArray
    how: str  # "warm", "subdivided" or "bounded"


@dataclass
class Tracker:
    """Continuation steps along a path for one stack and jump limit.

    Parameters
    ----------
    stack : Stack
    planar : bool
    max_jump : (float, float)
        Jump limit (mm, rad).
    max_depth : int
        Bisection depth of the subdivided rung (0: none).
    """

    stack: Stack
    planar: bool
    max_jump: tuple[float, float]
    max_depth: int = 1
    pc: bool = True
    counts: StepCounts = field(default_factory=StepCounts)
    #: keep-out bodies and the clearance margin [mm] (``solve_path``'s): the steps' problems
    #: have their rows, and a pose is accepted only when the full check passes too
    obstacles: tuple[Any, ...] = ()
    clearance: float = 0.0
    #: the load the leg forces carry: a pose is accepted only within the force limits
    load: Any = None
    #: the user's constraint families (stackik.families): the steps' problems have their
    #: rows, and a pose is accepted only when the full check passes too
    constraints: tuple[Any, ...] = ()

    def __post_init__(self) -> None:
        self.scale = jump_scale(self.max_jump, 3 if self.planar else 6)
        #: (last pose of the last run, its state: yE, z, active, have; planar: and hist)
        self._carry: tuple[Any, ...] | None = None
        #: (plane phi or None, Problem, kernel arrays, scaled jump) of the runs
        self._run_problem: tuple[Any, ...] | None = None
        #: the pose from which the last run's warm solve to its next target failed (in
        #: the kernel: a pose the Python check rejects may come from a continuation step,
        #: with no warm solve made), else None
        self.tried_from: FloatArray | None = None
        #: that failed solve found a pose of the target farther than one jump (it left
        #: its basin), not no pose
        self.tried_left = False
        #: the carried state of a second pose followed beside the path (a fast path's
        #: goal basin, :meth:`follow`)
        self._side_carry: tuple[Any, ...] | None = None
        #: rows for bodies of non-adjacent platforms (:meth:`_pairs`): whether a step
        #: carries them before any fold (legs or plates of a size, or a margin; else such
        #: bodies come closer than 0 only where a leg's axis passes through a plate, and
        #: the rows come once the check has refused that), and the pairs close at the
        #: poses that folded from a start (keyed by its bytes)
        self._sized = needs_clearances(self.stack, (), self.clearance)
        self._more: dict[bytes, frozenset[int]] = {}
        #: the full check that refused the last pose :meth:`_clear` was given (else None;
        #: a caller clears it before the checks whose refusal it reads)
        self._refused: Any = None

    @property
    def _kw(self) -> dict[str, Any]:
        """``obstacles``, ``clearance``, ``load`` and ``constraints`` as keywords (of
        ``Problem``, ``solve_ik``, ``check_pose`` and the bounded steps)."""
        return {
            "obstacles": self.obstacles,
            "clearance": self.clearance,
            "load": self.load,
            "constraints": self.constraints,
        }

    def folded_at(self, q: FloatArray, target: Target) -> bool:
        """Whether a step from ``q`` to ``target`` carries rows for bodies of non-adjacent
        platforms (:meth:`_pairs`: some pair is close at ``q``): a warm solve from a
        bounded step's pose on such rows mostly slides farther than one jump (planar fast
        mode then tries the bounded rung first, as spatial)."""
        return bool(self._pairs(q, target))

    def _problem(self, target: Target, pairs: tuple[int, ...] = ()) -> Any:
        """The FN problem of ``target`` with the path's clearances, load and families, and
        rows for ``pairs`` of bodies of non-adjacent platforms (none when empty)."""
        from stackik.formulation import Problem

        prob = Problem(self.stack, target, "frobenius", None, **self._kw)
        return prob.with_leg_pairs(pairs) if pairs else prob

    def _close(self, qs: list[FloatArray], target: Target) -> frozenset[int]:
        """The pairs of bodies of non-adjacent platforms within ``UNFOLD_SCREEN_MM`` of their
        least distance at any of the poses ``qs`` of ``target``'s mode
        (:func:`stackik.formulation.leg_pairs.close_pairs`, solve_ik's screen)."""
        from stackik.formulation.leg_pairs import close_pairs

        phi = mode_of(target).phi(target)
        near = close_pairs(self.stack, qs, self.clearance, phi, UNFOLD_SCREEN_MM)
        return frozenset(int(p) for p in near)

    def _pairs(self, q: FloatArray, target: Target) -> tuple[int, ...]:
        """The pairs of bodies of non-adjacent platforms a step from ``q`` to ``target``
        keeps apart (sorted): those close at ``q`` (:meth:`_close`) and those close at the
        poses that folded from ``q`` (:meth:`_folded`). With zero radii, thickness and
        margin only the latter: such bodies are then never closer than 0 except where a
        leg's axis passes through a plate, and the rows come after the check refused that
        (as solve_ik's :func:`~stackik.solve.stages._unfold`). A function of ``q`` and the
        rungs from it: a path resumed from a checkpoint carries the same rows."""
        more = self._more.get(q.tobytes(), frozenset())
        if not self._sized:
            return tuple(sorted(more))
        return tuple(sorted(more | self._close([q], target)))

    def _folded(
        self, q: FloatArray, target: Target, q_bad: FloatArray | None, used: tuple[int, ...]
    ) -> bool:
        """Whether a rung from ``q`` is worth making again with more rows: its pose ``q_bad``
        was refused by the full check (:attr:`_refused`) on bodies of non-adjacent
        platforms alone (:func:`stackik.methods.ip.folds_only`), and the pairs close at
        ``q`` or ``q_bad`` are not all in the rows it had (``used``). Those pairs are kept
        for rungs from ``q``."""
        from stackik.methods.ip import folds_only

        chk = self._refused
        if q_bad is None or chk is None or not folds_only(chk, self.clearance):
            return False
        key = q.tobytes()
        more = self._more.get(key, frozenset()) | self._close([q, q_bad], target)
        self._more[key] = more
        if more <= set(used):
            return False
        self.counts.unfold += 1
        return True

    def _clear(self, target: Target, q: FloatArray) -> bool:
        """The full check's verdict on what the compiled twins do not check (clearances,
        leg forces, constraint families): True at once when none of them can fail."""
        from stackik.clearance import clearances_can_fail
        from stackik.formulation.forces import force_limited

        phi = mode_of(target).phi(target)
        can_fail = (
            bool(self.constraints)
            or force_limited(self.stack)
            or clearances_can_fail(self.stack, self.obstacles, self.clearance, q, phi)
        )
        if not can_fail:
            return True
        chk = check.check_pose(self.stack, target, q, **self._kw)
        self._refused = None if chk.ok else chk
        return bool(chk.ok)

    def ratio(self, qa: FloatArray, qb: FloatArray) -> float:
        """Largest per-variable change from ``qa`` to ``qb`` in units of ``max_jump``."""
        return float(np.max(np.abs(qb - qa) / self.scale))

    # --- rungs ----------------------------------------------------------------------
    def warm(
        self, q: FloatArray, target: Target, *, tried: bool = False, left: bool = False
    ) -> FloatArray | None:
        """Warm-started solve from ``q``; the pose if checked and within one jump.
        ``tried``: the first solve (initial barrier ``WARM_MU0``) was made and failed
        (a run of :meth:`warm_many` stopped here): only the retry remains, unless
        ``left``: that solve found a pose farther than one jump (it left its basin), and
        the rung fails as when it makes that solve itself (the retry is for a first
        solve that finds no pose)."""
        if tried and left:
            return None
        if not tried:
            self.counts.warm += 1
            ok, qw = self._warm_solve(q, target, WARM_MU0)
            if ok:  # kept its basin, or left it: the default barrier would too
                return qw if self.ratio(q, qw) <= 1.0 else None
        self.counts.warm_retry += 1
        ok, qw = self._warm_solve(q, target, None)
        if ok and self.ratio(q, qw) <= 1.0:
            return qw
        return None

    def follow(self, q: FloatArray, target: Target) -> FloatArray | None:
        """:meth:`warm` for a pose followed beside the path (a fast path's goal basin):
        first the continuation step of :meth:`warm_many`, with its own carried state (the
        path's is kept), then the warm rung's barrier solves. A spatial barrier solve
        costs ~15 ms at n = 4, a continuation step well under 1 ms: spatial, the barrier
        solve gets ``FOLLOW_MAX_ITER`` iterations, and a goal is dropped (None; no warm
        rung) when that solve reaches no pose or one without converging."""
        saved = self._carry, self.tried_from, self.tried_left
        self._carry = self._side_carry
        cap = None if self.planar else FOLLOW_MAX_ITER
        try:
            out = self.warm_many(q, [target], max_iter=cap)
            if out and cap is not None:
                have = self._carry[1][3]  # type: ignore[index]  # spatial: (yE, z, act, have)
                if not have:
                    # the barrier solve reached the target without converging (out of
                    # its iterations or stalled): no minimum to follow there (the basin
                    # changes under the goal; a transit would follow a moving target)
                    self._side_carry = None
                    return None
            self._side_carry = self._carry
            tried = self.tried_from is q  # the kernel's warm solve from q failed
            left = self.tried_left
        finally:
            self._carry, self.tried_from, self.tried_left = saved
        if out:
            return out[0]
        self._side_carry = None
        if cap is not None and tried:
            return None  # spatial: the capped solve found no pose; no slow retry
        return self.warm(q, target, tried=tried, left=tried and left)

    def _warm_solve(self, q: FloatArray, target: Target, mu0: float | None) -> tuple[bool, Any]:
        """``solve_ik(stack, target, x0=q, starts=1, method="ip", options={"mu0": mu0})``
        (None: the default barrier): ``(success, pose)``. Planar: the same compiled call
        (:func:`stackik.methods.ip.ip_multi` with one start, then the compiled check)
        without the pipeline around it (its request, plan and result cost ~4x the solve
        at n = 4); the same pose and verdict."""
        from stackik._compiled.check import planar_check
        from stackik.methods.ip import ip_multi, ip_starts

        opts = {} if mu0 is None else {"mu0": mu0}
        pairs = self._pairs(q, target)

        def planar_run(prob: Any) -> tuple[bool, FloatArray]:
            X, *_ = ip_multi(prob, prob.u_of(q)[None], opts)
            qw = prob.q_of(X[0])
            return bool(planar_check(self.stack, target, qw)[0].ok) and self._clear(target, qw), qw

        def spatial_run(prob: Any) -> tuple[bool, FloatArray]:
            # solve_ik's run from x0 (polished and checked by the full check)
            got = ip_starts(prob, [q], opts, math.inf)
            run = got.best if got.best is not None else got.least
            if run is None:
                return False, q
            self._refused = None if run.check.ok else run.check
            return bool(run.check.ok), run.q

        run_one = planar_run
        if not self.planar:
            if not pairs:
                # (solve_ik remakes a run that folds with the rows of the pairs close at q
                # and at its pose itself)
                r = solve_ik(self.stack, target, x0=q, starts=1, method="ip", options=opts,
                             **self._kw)  # fmt: skip
                return r.success, r.q
            run_one = spatial_run
        for _ in range(UNFOLD_ROUNDS):
            self._refused = None
            ok, qw = run_one(self._problem(target, pairs))
            if ok or not self._folded(q, target, qw, pairs):
                return ok, qw
            pairs = self._pairs(q, target)
        return False, qw

    def warm_many(
        self, q: FloatArray, targets: list[Target], max_iter: int | None = None
    ) -> list[FloatArray]:
        """The warm rung along ``targets``, each from the pose before, in one compiled call
        (:func:`stackik._compiled.planar.ip_path`, :func:`stackik._compiled.spatial.ip_path`): the
        continuation step (``pc``) where it is verified, else the warm rung's first solve (initial
        barrier ``WARM_MU0``). Returns the poses of the leading targets that it reaches, as
        :meth:`warm` would accept them (checked by the compiled twin of ``check_pose``, each within
        one jump of the one before). Stops at the first it
        does not reach; the caller takes that one through the ladder (:meth:`step`).
        ``max_iter``: iterations of each barrier solve (default: the interior point's).

        A pose refused only for bodies of non-adjacent platforms (:meth:`_folded`): the run
        is made again from the pose before it with the rows of the pairs close there and
        at the refused pose, up to ``UNFOLD_ROUNDS`` times."""
        out: list[FloatArray] = []
        start = q
        for _ in range(UNFOLD_ROUNDS):
            if len(out) == len(targets):
                break
            pairs = self._pairs(start, targets[len(out)])
            got, bad = self._warm_run(start, targets[len(out) :], max_iter, pairs)
            out += got
            start = out[-1] if out else q
            if bad is None or not self._folded(start, targets[len(out)], bad, pairs):
                break
        return out

    def _warm_run(
        self, q: FloatArray, targets: list[Target], max_iter: int | None, pairs: tuple[int, ...]
    ) -> tuple[list[FloatArray], FloatArray | None]:
        """One compiled run of :meth:`warm_many` with rows for ``pairs`` of bodies of
        non-adjacent platforms: the poses it reaches and, when the full check refused the
        pose after them (:attr:`_refused`), that pose (else None)."""
        if not targets:
            return [], None
        from stackik._compiled import planar_path as _ipm_path
        from stackik._compiled import spatial_path as _spatial_ipm_path
        from stackik._compiled.check import planar_checks, spatial_check_many
        from stackik.formulation import POLISH_MARGIN, POLISH_REACH
        from stackik.methods.ip import IP_DEFAULTS, problem_arrays, spatial_problem_arrays

        # the scaled problem's arrays depend on the target only through its values (which
        # the kernels replace step by step) and, planar, its plane: built once per plane
        key = (getattr(targets[0], "phi", None), pairs)
        if self._run_problem is None or self._run_problem[0] != key:
            prob = self._problem(targets[0], pairs)
            arrays = problem_arrays(prob) if self.planar else spatial_problem_arrays(prob)
            jump = readonly(np.tile(self.scale, self.stack.n) / prob.xs)
            self._run_problem = (key, prob, arrays, jump)
        _, prob, arrays, jump = self._run_problem
        tol, ctol = float(IP_DEFAULTS["tol"]), float(IP_DEFAULTS["constr_tol"])
        max_iter = int(IP_DEFAULTS["max_iter"]) if max_iter is None else int(max_iter)
        # the multipliers and active set of q when the last run ended at q (its last pose)
        carry = self._carry
        state = carry[1] if carry is not None and carry[0] is q else self._no_state()
        tail = (POLISH_REACH, POLISH_MARGIN, check.TARGET_POS_TOL, check.TARGET_ANGLE_TOL,
                self.pc, *state)  # fmt: skip
        if self.planar:
            Y = readonly([(t.rho, t.z, t.theta) for t in targets])  # type: ignore[union-attr]
            X, reached, how, *end = _ipm_path.ip_path(
                readonly(prob.u_of(q)), Y, arrays, jump, tol, ctol, WARM_MU0, max_iter, *tail,
            )  # fmt: skip
        else:
            pos = np.array([t.position for t in targets])  # type: ignore[union-attr]
            rot = np.array([t.rotation for t in targets])  # type: ignore[union-attr]
            X, reached, how, *end = _spatial_ipm_path.ip_path(
                readonly(prob.u_of(q)), readonly(pos), readonly(rot),
                arrays, jump, tol, ctol, WARM_MU0, max_iter, *tail,
            )  # fmt: skip
        k = 3 if self.planar else 6
        reached = int(reached)
        Q = (X[:reached] * prob.xs).reshape(reached, self.stack.n, k)
        # every pose checked and within one jump of the one before, at once: the leading
        # ones that are
        good = np.zeros(0, dtype=bool)
        refused: FloatArray | None = None
        if reached:
            prev = np.concatenate([q[None], Q[:-1]])
            jumps = np.max(np.abs(Q - prev) / self.scale, axis=(1, 2))
            if self.planar:
                ok = planar_checks(self.stack, targets[0].phi, Y[:reached], Q)  # type: ignore[union-attr]
            else:
                ok = np.asarray(spatial_check_many(self.stack, targets[:reached], Q))
            good = ok & (jumps <= 1.0)
            for j in range(reached):  # the clearances, up to the first that fails
                if not good[j]:
                    break
                self._refused = None
                good[j] = self._clear(targets[j], Q[j])
                if not good[j]:
                    refused = Q[j]
        bad = np.flatnonzero(~good)
        out: list[FloatArray] = list(Q[: bad[0] if bad.size else reached])
        self.counts.warm += len(out)
        self.counts.pc += int(np.sum(how[: len(out)]))
        self._carry = None
        self.tried_from = None
        self.tried_left = False
        if out and len(out) == reached:
            self._carry = (out[-1], tuple(end))
        if len(out) == reached < len(targets):  # the kernel's warm solve failed
            self.tried_from = out[-1] if out else q
            self.tried_left = bool(how[reached] == -1)  # ... finding a far pose
        return out, refused

    def _no_state(self) -> tuple[Any, ...]:
        if self.planar:  # multipliers, active set, have, the point before and targets
            return (np.zeros(3), np.zeros(0), np.zeros(0, dtype=bool), False, np.zeros(0))
        return (np.zeros(6), np.zeros(0), np.zeros(0, dtype=bool), False)

    def _subdivide(self, q: FloatArray, ta: Target, tb: Target, depth: int) -> FloatArray | None:
        qb = self.warm(q, tb)
        if qb is not None or depth >= self.max_depth:
            return qb
        self.counts.subdivided += 1
        tm = lerp_target(ta, tb, 0.5)
        qm = self._subdivide(q, ta, tm, depth + 1)
        if qm is None:
            return None
        return self._subdivide(qm, tm, tb, depth + 1)

    def bounded(
        self, q: FloatArray, target: Target, max_time: float = math.inf
    ) -> FloatArray | None:
        """The least-FN pose of ``target`` within one jump of ``q`` (checked), or None."""
        return self._checked_step("bounded", q, target, max_time=max_time)

    def transit(self, q: FloatArray, target: Target, goal: FloatArray) -> FloatArray | None:
        """The pose of ``target`` within one jump of ``q`` nearest ``goal`` (checked), or
        None: one step of a path moving towards a better basin."""
        return self._checked_step("transit", q, target, goal=goal)

    def _checked_step(
        self, rung: str, q: FloatArray, target: Target, **kw: Any
    ) -> FloatArray | None:
        """:func:`bounded_step` accepted when within one jump of ``q`` and checked; counts
        the attempt (and a failure) under ``rung``."""
        setattr(self.counts, rung, getattr(self.counts, rung) + 1)
        goal = kw.get("goal")
        pairs = self._pairs(q, target)
        for _ in range(UNFOLD_ROUNDS):  # made again while its pose folds (_folded)
            qb = bounded_ip(self.stack, target, q, self.scale, goal=goal, pairs=pairs, **self._kw)
            if self._accepts(q, target, qb):
                return qb
            if not self._folded(q, target, qb, pairs):
                break
            pairs = self._pairs(q, target)
        self.counts.sqp_fallback += 1  # the SQP engine: slower, keeps its iterates in the box
        for _ in range(UNFOLD_ROUNDS):
            qb = bounded_step(self.stack, target, q, self.scale, **kw, pairs=pairs, **self._kw)
            if self._accepts(q, target, qb):
                return qb
            if not self._folded(q, target, qb, pairs):
                break
            pairs = self._pairs(q, target)
        failed = f"{rung}_failed"
        setattr(self.counts, failed, getattr(self.counts, failed) + 1)
        return None

    def _accepts(self, q: FloatArray, target: Target, qb: FloatArray | None) -> bool:
        """``qb`` is a pose of ``target`` (checked) within one jump of ``q`` (:attr:`_refused`:
        the full check's refusal, when that is what failed)."""
        self._refused = None
        if qb is None or not self.ratio(q, qb) <= 1.0:
            return False
        if self.planar:  # the compiled twin of check_pose (same verdicts, tested), ~30x faster
            from stackik._compiled.check import planar_check

            return bool(planar_check(self.stack, target, qb)[0].ok) and self._clear(target, qb)
        from stackik._compiled.check import spatial_check_many  # its verdict; 15 instead of 190 us

        ok = bool(spatial_check_many(self.stack, [target], qb[None])[0])
        return ok and self._clear(target, qb)

    # --- the ladder -------------------------------------------------------------------
    def step(
        self,
        q: FloatArray,
        ta: Target,
        tb: Target,
        *,
        subdivide: bool = True,
        bounded: bool = True,
        warm_tried: bool = False,
        warm_left: bool = False,
        box_first: bool = False,
    ) -> Step | None:
        """A pose of ``tb`` within ``max_jump`` of ``q`` (a pose of ``ta``), or None.

        Parameters
        ----------
        subdivide : bool
            Try the bisection rung (skipped right after a bounded step: the path is then
            off its optimum and bisecting rarely brings a warm start back within reach).
        bounded : bool
            Try the bounded rung.
        warm_tried : bool
            The warm rung's first solve from ``q`` to ``tb`` was made and failed (a run
            of :meth:`warm_many` stopped before ``tb``): the rung starts at its retry.
        warm_left : bool
            ... and found a pose farther than ``max_jump`` (it left its basin): the rung
            fails without the retry (:meth:`warm`).
        box_first : bool
            Try the bounded rung first (a pose off its optimum, after a bounded or transit
            step: a warm solve from there slides far, 100-200 spatial iterations at
            n = 4, and usually lands farther than one jump). Its pose is the step's
            ``"warm"`` pose when no variable sits at the box (a minimum of the problem
            without the box, as a warm solve finds), else ``"bounded"``; the warm rung
            only when it fails.
        """
        if box_first and bounded:
            qb = self.bounded(q, tb)
            if qb is not None:
                return Step(qb, "bounded" if self.ratio(q, qb) > BOX_INSIDE else "warm")
            bounded = False
        qb = self.warm(q, tb, tried=warm_tried, left=warm_left)
        if qb is not None:
            return Step(qb, "warm")
        if subdivide and self.max_depth > 0:
            self.counts.subdivided += 1
            tm = lerp_target(ta, tb, 0.5)
            qm = self._subdivide(q, ta, tm, 1)
            qb = None if qm is None else self._subdivide(qm, tm, tb, 1)
            if qb is not None and self.ratio(q, qb) <= 1.0:
                return Step(qb, "subdivided")
        if bounded:
            qb = self.bounded(q, tb)
            if qb is not None:
                return Step(qb, "bounded")
        return None

    def info(self) -> dict[str, Any]:
        return self.counts.as_dict()
