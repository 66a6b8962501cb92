"""The scaled NLP of one IK request: objective, end-effector equalities, limits.

.. math::

    \\min_u\\; f(u) \\quad \\text{s.t.}\\quad c_E(u) = 0,\\quad c_I(u) \\ge 0

with ``u = x / xs`` (translations scaled by ``L = max leg_max`` [mm], angles by 1), the
leg-length limits (mm^2) by ``leg_max^2``, the joint limits (mm) by ``leg_max``, position
errors by ``L``. Results are reported raw. The target's :class:`~stackik.formulation.modes.Mode`
says which evaluation applies (planar: :class:`PlanarEvaluator`; spatial: the compiled
:mod:`stackik._compiled.spatial_kinematics`).
"""

from __future__ import annotations

import copy
import dataclasses
import math
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik._arrays import readonly
from stackik.families import FamilyRows, as_families
from stackik.formulation.clearance import Clearance, SelfLegs, clearance_of
from stackik.formulation.forces import ForceLimits, ForceResiduals, force_limited
from stackik.formulation.modes import mode_of
from stackik.formulation.planar import PlanarEvaluator
from stackik.formulation.spatial import so3_log_fast, so3_right_jac_inv
from stackik.geometry import Stack
from stackik.kinematics import _J2, planar_fn_residuals, spatial_chain
from stackik.loads import Load
from stackik.targets import PlanarTarget, SpatialTarget, Target

__all__ = ["POLISH_MARGIN", "POLISH_REACH", "Problem", "polish", "problem_scalings"]

FloatArray = NDArray[np.float64]


def problem_scalings(
    stack: Stack, planar: bool, wt: FloatArray, wth: FloatArray
) -> tuple[Any, ...]:
    """Scalings of :class:`Problem` (geometry and weights only; arrays read-only).

    Variables ``u = x / xs`` (xs = L = max leg_max for translations [mm], 1 for angles);
    constraint rows: leg blocks / leg_max^2, joint blocks / leg_max; equalities ``es``;
    objective ``f = (c0 + sum_i w_i |r_i|^2) / fscale`` with per-residual weights ``rw``
    (sqrt, residuals indexed by the platform of the angle column).
    """
    n = stack.n
    L = float(stack.leg_max.max())
    per = [L, L, 1.0] if planar else [L] * 3 + [1.0] * 3
    xs = np.tile(per, n)
    cs = np.empty((n, 24))
    cs[:, :12] = 1.0 / stack.leg_max[:, None] ** 2
    cs[:, 12:] = 1.0 / stack.leg_max[:, None]
    es = np.array([1 / L, 1 / L, 1.0]) if planar else np.array([1 / L] * 3 + [1.0] * 3)
    n_rot = 1 if planar else 3
    n_tr = 2 if planar else 3
    rot_const = 1.0 if planar else 2.0  # |d R_ee / d angle|_F^2 (+ theta row)
    c0 = float(np.sum(wt) * n_tr + np.sum(wth) * n_rot * rot_const)
    fscale = L**2 * float(np.max(wth))
    rw = np.repeat(np.sqrt(wth[: n - 1]), 2) if planar else np.repeat(np.sqrt(wth), 9)
    arrays = (xs, cs.ravel(), es, np.array(wt, float), np.array(wth, float), rw)
    for a in arrays:
        a.setflags(write=False)
    xs, cs_flat, es, wt, wth, rw = arrays
    return L, xs, cs_flat, es, wt, wth, c0, fscale, rw


class Problem:
    """Scaled IK problem: evaluation of objective, equalities and limits with derivatives.

    Variables ``u = x / xs`` with ``xs`` = L for translations, 1 for angles.
    """

    def __init__(
        self,
        stack: Stack,
        target: Target,
        objective: str,
        weights: tuple[FloatArray, FloatArray] | None,
        x_ref: FloatArray | None = None,
        load: Load | None = None,
        clearance: float = 0.0,
        obstacles: Any = (),
        force_weight: float = 0.0,
        constraints: Any = (),
    ) -> None:
        self.stack = stack
        self.load = load
        self.target = target
        self.mode = mode_of(target)
        n = stack.n
        self.objective = objective
        self.x_ref = x_ref
        if objective == "weighted":
            assert weights is not None
            scal = problem_scalings(stack, self.planar, *weights)
        else:  # unit weights: the same arrays for every target (read-only, cached)
            scal = stack.derived(
                ("problem_scalings", self.planar),
                lambda st: problem_scalings(st, self.planar, np.ones(n), np.ones(n)),
            )
        (self.L, self.xs, self.cs, self.es, self.w_t, self.w_th, self.c0, self.fscale,
         self.rw) = scal  # fmt: skip
        self.fast = PlanarEvaluator(stack, target.phi) if isinstance(target, PlanarTarget) else None
        if self.fast is not None:
            self.fast.set_scaling(self.cs, self.xs)
        self._gn_cache: tuple[FloatArray, FloatArray, FloatArray] | None = None
        self._fn_cache: tuple[FloatArray, FloatArray] = (np.zeros(0), np.zeros((0, 0)))
        self._cache: tuple[FloatArray, tuple[Any, ...]] | None = None  # (u, evaluate(u))
        self.nfev = 0
        #: the margin [mm], the obstacles and the self-leg rows (stackik.formulation.clearance)
        self.clearance: Clearance = clearance_of(
            stack, self.planar, clearance, obstacles, self.mode.phi(target)
        )
        # one statics object serves the limit rows and the force objective (one batch)
        phi = self.mode.phi(target)
        rows: ForceLimits | None = None
        if objective == "force":
            rows = ForceResiduals(stack, load, phi)
        elif force_weight > 0.0:  # the weighted leg forces added to the objective
            rows = ForceResiduals(stack, load, phi, weight=force_weight)
        if rows is None and force_limited(stack):
            rows = ForceLimits(stack, load, phi)
        fams = as_families(constraints)
        #: the rows of the user's constraint families (stackik.families), or None
        self.families: FamilyRows | None = FamilyRows(stack, fams, phi) if fams else None
        #: the leg-force limit rows (appended after the limits), or None: no finite force_max
        self.forces = rows if force_limited(stack) else None
        #: objective="force" or a force_weight: the scaled leg forces as residuals
        #: (stackik.formulation.forces)
        self.force_residuals = rows if isinstance(rows, ForceResiduals) else None

    @property
    def force_weight(self) -> float:
        """``solve_ik``'s ``force_weight`` ``w`` [mm^2]: the objective is ``FN^2 + w sum_ik
        (f_ik / s_i)^2`` (``s`` = :func:`~stackik.formulation.forces.force_scales`; FN^2 the
        ``"weighted"`` trace, or 0 for ``"feasible"``); 0 = no force term (and 0 for
        ``objective="force"``, whose objective is the force term alone)."""
        fr = self.force_residuals
        return 0.0 if fr is None or self.objective == "force" else fr.weight

    @property
    def has_objective(self) -> bool:
        """Whether the objective is not identically zero (``"feasible"`` without a force
        weight is)."""
        return self.objective != "feasible" or self.force_weight > 0.0

    def _weighted_forces(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The force weight's residuals in the scaled objective, ``sqrt(w / fscale) f / s``,
        and their Jacobian in scaled variables ``u``: stacked under the objective's own
        residuals (Gauss-Newton form), so that ``f(u) = (FN^2 + w |f / s|^2) / fscale``."""
        fr = self.force_residuals
        assert fr is not None
        r, Jr = fr.residuals(q)
        c = math.sqrt(fr.weight / self.fscale)
        return r * c, Jr * self.xs * c

    @property
    def constraints(self) -> tuple[Any, ...]:
        """The user's constraint families (``solve_ik``'s ``constraints``; () when none)."""
        return () if self.families is None else self.families.families

    @property
    def family_token(self) -> int:
        """The token that names the families' rows to the compiled kernels (0: none;
        :func:`stackik.families.kernel_rows`)."""
        return 0 if self.families is None else self.families.token

    @property
    def n(self) -> int:
        """Number of platforms."""
        return self.stack.n

    @property
    def k(self) -> int:
        """Variables per platform: 3 planar, 6 spatial."""
        return self.mode.k

    @property
    def planar(self) -> bool:
        """Planar mode (3 variables per platform), else spatial (6)."""
        return self.mode.planar

    @property
    def self_legs(self) -> SelfLegs | None:
        """The self-leg rows (appended after the limits, before the force rows), or None."""
        return self.clearance.self_legs

    def check(self, q: FloatArray, *, screen: bool = False) -> Any:
        """:func:`stackik.check.check_pose` of ``q`` (raw) with this problem's load, obstacles
        and clearance margin: the acceptance rule every method applies.

        ``screen``: leave the obstacles out when none can touch the pose
        (:func:`stackik.clearance.clearances_can_fail` with ``q``: zero radii and thickness,
        margin 0, every obstacle beyond the ball that holds the pose's bodies), as the planar
        interior point's compiled check does: the same verdict without measuring distances
        that cannot fail (the check's ``clearances`` is then None)."""
        from stackik.check import check_pose
        from stackik.clearance import clearances_can_fail

        cl = self.clearance
        obstacles = cl.obstacles
        if (
            screen
            and obstacles
            and not clearances_can_fail(
                self.stack, obstacles, cl.margin, q, self.mode.phi(self.target)
            )
        ):
            obstacles = ()
        return check_pose(
            self.stack, self.target, q, self.load, obstacles=obstacles, clearance=cl.margin,
            constraints=self.constraints,
        )  # fmt: skip

    def without_force_limits(self) -> Problem:
        """This problem without its leg-force limit rows (a shallow copy, its own
        evaluation caches): what the solvers see of it is the unloaded problem's, the
        rows and arrays of a stack without a finite ``force_max``. Its :meth:`check` is
        still this problem's (load and force limits): it serves starts, not answers
        (:func:`stackik.solve.stages.ip_stage`, the spatial default with force limits)."""
        out = self._variant()
        out.forces = None
        return out

    def without_obstacle_rows(self) -> Problem:
        """This problem without its obstacle rows (a shallow copy, its own evaluation
        caches): the solvers see the obstacle-free problem. Its :meth:`check` is still
        this problem's (obstacles and margin): it serves starts, not answers
        (:func:`stackik.solve.stages.ip_stage`, the default with obstacle rows)."""
        out = self._variant()
        out.clearance = dataclasses.replace(self.clearance, obstacle_rows=None)
        return out

    def _variant(self) -> Problem:
        """A shallow copy with its own evaluation caches (for a copy with fewer rows)."""
        out = copy.copy(self)
        out._gn_cache, out._cache = None, None
        out._fn_cache = (np.zeros(0), np.zeros((0, 0)))
        out.nfev = 0
        return out

    @property
    def dense_rows(self) -> bool:
        """Whether the problem has rows outside the per-platform blocks of the compiled
        kernels, without second derivatives: leg-force limits, obstacle rows, non-adjacent
        leg-pair rows, planar self-leg rows, constraint families (the SQP engine takes them
        in its dense form)."""
        return (
            self.forces is not None
            or self.families is not None
            or self.clearance.obstacle_rows is not None
            or self.clearance.leg_pairs is not None
            or (self.planar and self.self_legs is not None)
        )

    @property
    def rows_outside_ip(self) -> bool:
        """Whether the problem has rows the compiled interior point does not carry: planar
        self-leg rows (both interior points carry the obstacle and leg-force rows as dense
        rows, :mod:`stackik._compiled.dense_rows`). A run that fails only on such rows is a
        start for an engine that has them (:func:`stackik.methods.ip.ip_starts`)."""
        return self.planar and self.self_legs is not None

    @property
    def lazy_self_legs(self) -> bool:
        """Whether the local engines first run without the self-leg rows: planar problems
        with them (:meth:`without_self_legs`; planar poses rarely bring two legs of a
        platform close, so a run that does not need the rows is the run on the problem
        without them). The same rows as :attr:`rows_outside_ip`: the interior point does
        not carry them either."""
        return self.rows_outside_ip

    def without_self_legs(self) -> Problem:
        """This problem without its self-leg rows (same stack, target, load, obstacles and
        margin: :meth:`check` still enforces every clearance)."""
        lean = self._variant()
        lean.clearance = dataclasses.replace(self.clearance, self_legs=None)
        return lean

    def with_leg_pairs(self, pairs: Any) -> Problem:
        """This problem with rows for the pairs ``pairs`` (indices into
        :func:`stackik.formulation.leg_pairs.pair_table`'s pairs) of bodies of non-adjacent
        platforms (:class:`~stackik.formulation.leg_pairs.LegPairRows`, in place of any it
        has; none when ``pairs`` is empty): a shallow copy, its own evaluation caches."""
        from stackik.formulation.leg_pairs import LegPairRows

        out = self._variant()
        rows = LegPairRows(self.stack, pairs, self.clearance.margin, self.mode.phi(self.target))
        out.clearance = dataclasses.replace(self.clearance, leg_pairs=rows if rows.size else None)
        return out

    def with_families(self, extra: tuple[Any, ...]) -> Problem:
        """This problem with the constraint families ``extra`` after its own (a shallow
        copy, its own evaluation caches). Its :meth:`check` enforces them too: a solve
        that adds rows of its own re-checks the pose on the problem without them."""
        out = self._variant()
        phi = self.mode.phi(self.target)
        out.families = FamilyRows(self.stack, self.constraints + tuple(extra), phi)
        return out

    @property
    def dense_families(self) -> tuple[Any, ...]:
        """The row families after the per-platform blocks, in the order every engine
        takes them (:mod:`stackik._compiled.dense_rows`): obstacle rows, non-adjacent
        leg-pair rows, constraint families, leg-force rows (None where absent); each
        ``rows(q) -> (values, Jacobian against the raw pose)`` with a ``size``."""
        cl = self.clearance
        return (cl.obstacle_rows, cl.leg_pairs, self.families, self.forces)

    @property
    def n_ineq(self) -> int:
        """Number of inequality rows: the 24 n limits, the self-leg rows, the obstacle
        rows, the non-adjacent leg-pair rows, the constraint families' rows, the force
        rows."""
        sl = 0 if self.self_legs is None else self.n * self.self_legs.m
        extra = sum(0 if f is None else f.size for f in self.dense_families)
        return int(self.cs.size + sl + extra)

    # --- index arrays (built on first use) ------------------------------------------
    @cached_property
    def _angle_cols(self) -> Any:
        a = np.arange(self.n * self.k)
        return a[a % 6 >= 3] if self.k == 6 else a[a % 3 == 2]

    @cached_property
    def _hi(self) -> Any:
        a = np.arange(self.n * self.k)
        return np.maximum(a[:, None], a[None, :])

    @cached_property
    def _theta_lo(self) -> FloatArray:
        a = np.arange(self.n * self.k)
        return (np.minimum(a[:, None], a[None, :]) % 3 == 2).astype(float)

    # --- conversions ---------------------------------------------------------------
    def q_of(self, u: FloatArray) -> FloatArray:
        return (u * self.xs).reshape(self.n, self.k)

    def u_of(self, q: FloatArray) -> FloatArray:
        return np.asarray(q, dtype=float).ravel() / self.xs

    # --- residuals of the objective -------------------------------------------------
    def residuals(self, q: FloatArray, ch: Any = None) -> tuple[FloatArray, FloatArray]:
        """Objective residuals (unscaled x) ``r``, ``dr/dx`` with obj = c0 + |r|^2.

        ``ch``: the :class:`~stackik.kinematics.SpatialChain` of ``q`` if already built.
        """
        if self.planar:
            r, Jr = planar_fn_residuals(q)
        else:  # spatial
            ch = spatial_chain(q) if ch is None else ch
            N = 6 * self.n
            ang = self._angle_cols
            r = ch.J[:3, ang].T.ravel()  # (3n*3,)
            H = ch.position_hessian(ang)  # (3, 3n, N)
            Jr = np.moveaxis(H, 0, 1).reshape(-1, N)
            # rows are platform-major (3 angles x 3 coordinates = 9 per platform): rw matches
        return r * self.rw, Jr * self.rw[:, None]

    def gauss_newton(self, u: FloatArray) -> tuple[FloatArray, FloatArray]:
        if not self.has_objective:
            return np.zeros(1), np.zeros((1, u.size))
        gc = self._gn_cache
        if gc is not None and np.array_equal(gc[0], u):
            return gc[1], gc[2]
        if self.objective == "force":
            assert self.force_residuals is not None
            r, Jr = self.force_residuals.residuals(self.q_of(u))
            return r, Jr * self.xs
        if self.force_weight > 0.0:
            return self._with_force_term(u)[:2]
        r, Jr = self.residuals(self.q_of(u))
        s = 1.0 / math.sqrt(self.fscale)
        return r * s, Jr * self.xs * s

    def _with_force_term(self, u: FloatArray) -> tuple[FloatArray, FloatArray, float]:
        """A force weight's scaled residuals ``[r_obj; r_force]``, their Jacobian (scaled
        ``u``) and the constant of the scaled objective, ``f = c + |r|^2``."""
        q = self.q_of(u)
        rf, Jf = self._weighted_forces(q)
        if self.objective == "feasible":
            return rf, Jf, 0.0
        r, Jr = self.residuals(q)
        s = 1.0 / math.sqrt(self.fscale)
        r = np.concatenate([r * s, rf])
        Jr = np.vstack([Jr * self.xs * s, Jf])
        return r, Jr, self.c0 / self.fscale

    # --- all functions at once ------------------------------------------------------
    def evaluate(self, u: FloatArray) -> tuple[Any, ...]:
        if self._cache is not None and np.array_equal(u, self._cache[0]):
            return self._cache[1]
        self.nfev += 1
        q = self.q_of(u)
        st = self.stack
        spatial_ch: Any = None
        if self.fast is not None:
            tgt = self.target
            assert isinstance(tgt, PlanarTarget)
            y, Jy, r_fn, Jr_fn = self.fast.kinematics(q)
            self._fn_cache = (r_fn, Jr_fn)
            ceq = (y - tgt.y) * self.es
            Jeq = Jy * self.es[:, None] * self.xs
            cin, Jin = self.fast(q)  # scaled (set_scaling in __init__)
            if self.self_legs is not None:
                cin, Jin = self._with_self_legs(q, cin, Jin)
        else:
            from stackik._compiled.spatial_kinematics import block_jacobian, spatial_parts

            tgs = self.target
            assert isinstance(tgs, SpatialTarget)
            # compiled: the values of spatial_chain, spatial_legs, constraints_from_legs
            # and residuals (tested equal)
            # geometry arrays read-only, whatever their source: one compiled specialisation
            Pee, Ree, Jp, w_ax, c, Jc, r_sp, Jr_sp = spatial_parts(
                q,
                readonly(st.top_nodes),
                readonly(st.base_nodes),
                readonly(st.leg_min),
                readonly(st.leg_max),
                readonly(st.sin_joint_min),
            )
            spatial_ch = (r_sp * self.rw, Jr_sp * self.rw[:, None])
            E = tgs.rotation.T @ Ree
            phi_v = so3_log_fast(E)
            # dphi = Jr^{-1}(phi) v with v = R_ee^T w (body-frame axis)
            v = Ree.T @ w_ax.T  # (3, N)
            Jphi = so3_right_jac_inv(phi_v) @ v
            ceq = np.concatenate([Pee - tgs.position, phi_v]) * self.es
            Jeq = np.vstack([Jp, Jphi]) * self.es[:, None] * self.xs
            cin = c.ravel() * self.cs
            Jin = block_jacobian(Jc, readonly(self.cs), readonly(self.xs))
            if self.self_legs is not None:
                cin, Jin = self._with_self_legs(q, cin, Jin)
        for dense in self.dense_families:
            if dense is not None:  # the compiled interior points' dense rows, in their order
                c_d, J_d = dense(q)
                cin = np.concatenate([cin, c_d])
                Jin = np.vstack([Jin, J_d * self.xs])
        f, g = self._objective(u, q, spatial_ch)
        out = (f, g, ceq, Jeq, cin, Jin)
        self._cache = (u.copy(), out)
        return out

    def _objective(self, u: FloatArray, q: FloatArray, spatial_ch: Any) -> tuple[float, Any]:
        """The scaled objective and its gradient at ``u`` (pose ``q``), from the residuals
        :meth:`evaluate` computed (planar: ``_fn_cache``; spatial: ``spatial_ch``), with a
        force weight's scaled leg forces stacked under them (:meth:`_weighted_forces`)."""
        w = self.force_weight
        if self.objective == "feasible" and w == 0.0:
            return 0.0, np.zeros(self.n * self.k)
        if self.objective == "force":  # |r|^2 of the scaled leg forces
            assert self.force_residuals is not None
            r, Jr = self.force_residuals.residuals(q)
            Jr = Jr * self.xs
            self._gn_cache = (u.copy(), r, Jr)
            return float(r @ r), 2.0 * Jr.T @ r
        if self.objective == "feasible":
            r, Jr, c = np.zeros(0), np.zeros((0, self.n * self.k)), 0.0
        else:
            sc = 1.0 / math.sqrt(self.fscale)
            if self.fast is not None:
                r = self._fn_cache[0] * self.rw * sc
                Jr = self._fn_cache[1] * (self.rw * sc)[:, None] * self.xs
            else:
                r, Jr = spatial_ch
                r, Jr = r * sc, Jr * self.xs * sc
            c = self.c0 / self.fscale
        if w > 0.0:  # [objective residuals; weighted scaled leg forces]
            rf, Jf = self._weighted_forces(q)
            r, Jr = np.concatenate([r, rf]), np.vstack([Jr, Jf])
        self._gn_cache = (u.copy(), r, Jr)
        return float(r @ r) + c, 2.0 * Jr.T @ r

    def _with_self_legs(
        self, q: FloatArray, cin: FloatArray, Jin: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """``cin``, ``Jin`` with the self-leg rows appended (platform-major, scaled)."""
        from stackik._compiled.self_legs import planar_self_leg_block, self_leg_block

        sl = self.self_legs
        assert sl is not None
        st = self.stack
        geo = (readonly(st.base_nodes), readonly(st.top_nodes), sl.pairs, sl.rho, sl.scale)
        qc = np.ascontiguousarray(q, dtype=float)
        phi = self.mode.phi(self.target)
        if phi is not None:  # planar
            c, J = planar_self_leg_block(qc, float(phi), *geo)
        else:
            c, J = self_leg_block(qc, *geo)
        n, m, k = self.n, sl.m, self.k
        Js = np.zeros((n * m, n * k))
        for i in range(n):
            Js[i * m : (i + 1) * m, i * k : (i + 1) * k] = J[i]
        return np.concatenate([cin, c.ravel()]), np.vstack([Jin, Js * self.xs])

    def lagrangian_hessian(self, u: FloatArray, y_eq: FloatArray, y_in: FloatArray) -> FloatArray:
        """Exact Hessian of ``f - y_eq.c_E - y_in.c_I`` in scaled variables (planar only)."""
        assert self.fast is not None
        q = self.q_of(u)
        Hx: Any = 0.0
        if self.objective != "feasible":
            Hx = self.fast.fn2_hessian(q) * (float(self.w_th[0]) / self.fscale)
        # end-effector equalities: sum_r y_r d2 y_r = isTheta[min(a,b)] * v[max(a,b)]
        Jy = self.fast.kinematics(q)[1]  # (fn2_hessian above computed it already: cheap)
        yp = y_eq[:2] * self.es[:2]
        v = (yp @ _J2) @ Jy[:2]  # (3n,)
        H_eq = self._theta_lo * v[self._hi]
        # (the force rows' curvature is not formed: engines use quasi-Newton with them)
        H_in = self.fast.constraint_hessian(q, y_in[: self.cs.size] * self.cs)
        H = Hx - H_eq - H_in
        return H * np.outer(self.xs, self.xs)  # type: ignore[no-any-return]

    def objective_value(self, q: FloatArray) -> float:
        """Unscaled objective value at q (with a force weight ``w``: ``FN^2 + w sum_ik
        (f_ik / s_i)^2``, mm^2)."""
        w = self.force_weight
        force = 0.0
        if w > 0.0:
            assert self.force_residuals is not None
            force = w * float(np.sum(self.force_residuals.residuals(q)[0] ** 2))
        if self.objective == "feasible":
            return force
        if self.objective == "force":
            assert self.force_residuals is not None
            return float(np.sum(self.force_residuals.residuals(q)[0] ** 2))
        r, _ = self.residuals(q)
        return float(self.c0 + r @ r) + force


POLISH_MARGIN = 1e-12  # scaled margin the polish puts violated limits at (>= 0 raw)
POLISH_REACH = 1e-6  # only limits violated by less than this (scaled) are polished


def polish(prob: Problem, u: FloatArray, iters: int = 3) -> FloatArray:
    """Min-norm Newton corrections of the end-effector equalities and of limits that a
    solver left violated by roundoff (tiny moves; a far-off point is left as it is).

    Each step solves ``[J_E; J_V] du = -[c_E; c_V - margin]`` in the least-norm sense,
    where V are the limits with ``-POLISH_REACH < c < 0``, so that the returned pose meets
    the target to rounding and its limits with ``c >= 0`` raw, not only within the
    solver's tolerance.
    """
    for _ in range(iters):
        _, _, ceq, Jeq, cin, Jin = prob.evaluate(u)
        viol = (cin < 0) & (cin > -POLISH_REACH)
        if np.abs(ceq).max() < 1e-13 and not viol.any():
            break
        A = np.vstack([Jeq, Jin[viol]])
        r = np.concatenate([ceq, cin[viol] - POLISH_MARGIN])
        u = u - np.linalg.lstsq(A, r, rcond=None)[0]
    return u
