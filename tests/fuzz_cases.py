"""Fuzz-case generators and the independent re-check shared by the fuzz suite and the soak run.

Used by ``tests/test_fuzz.py`` (hypothesis and seeded campaigns) and ``benchmarks/soak.py``
(thousands of seeded solves). Everything here is deterministic in its ``rng``: a case is
identified by ``(seed, index)`` (see :func:`make_case`), so any soak record can be rebuilt
and rerun with ``python benchmarks/soak.py --replay INDEX``.

A :class:`Case` carries a ``make`` callable that builds ``(stack, target, kwargs)`` *and may
raise* (malformed geometry or target), so input validation is fuzzed end to end.
:func:`run_case` builds and solves one case and classifies the outcome:

``success`` / ``infeasible`` / ``max_iter`` / ``max_time`` / ``failed``
    the :class:`stackik.IKStatus` of a well-formed case;
``value_error``
    a malformed case rejected with a ``ValueError`` (expected);
``unexpected_exception``
    any exception from a well-formed case, or a non-``ValueError`` (or a ``ValueError``
    without a message) from a malformed one;
``accepted_malformed``
    a malformed case that was solved instead of rejected;
plus flags ``false_success`` (``result.success`` but :func:`recheck` or
:func:`stackik.check_pose` disagrees), ``time_overrun`` (returned later than
``max_time + TIME_SLACK``) and ``iter_overrun`` (``nit`` above the bound implied by the
iteration limit and the number of starts).

The re-check (:func:`recheck`) recomputes the end effector with both
``stackik.planar_forward``/``spatial_forward`` and the loop-based oracle in
``tests/reference_impl.py`` (which imports nothing from stackik), every limit with both
``Stack.planar_constraints``/``spatial_constraints`` and the oracle, the leg lengths that a
user would send to hardware (``result.leg_lengths``, ``result.P``, ``result.R``) against the
oracle, and requires position error <= 1e-6 mm, angle error <= 1e-8 rad, leg lengths in
``[leg_min - 1e-6, leg_max + 1e-6]`` mm and joint terms >= -1e-6 mm.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import stackik as sk
from stackik.obstacles import Obstacle, as_obstacles
from stackik.result import IKStatus
from stackik.sampling import random_feasible_poses
from stackik.sqp.qp import available_qp_solvers
from stackik.targets import PlanarTarget, SpatialTarget

sys.path.insert(0, str(Path(__file__).resolve().parent))
import reference_impl as ref  # noqa: E402

POS_TOL = 1e-6  # [mm]
ANG_TOL = 1e-8  # [rad]
LIMIT_TOL = 1e-6  # [mm]
CLEARANCE_TOL = 1e-6  # [mm] two legs of a platform may be this much closer than required
TIME_SLACK = 2.0  # [s] allowed lateness of a solve with max_time (sanity bound, not speed)
FALLBACK_STARTS = 3  # extra starts solve_ik adds when no start passes the check
SCREENED_STARTS = 3  # structured starts by default (n >= 2, no x0): 3 planar, 5 spatial
SCREENED_STARTS_SPATIAL = 5

PHIS = (0.0, 0.3, math.pi / 4, -1.2, 2.5, math.pi)
NATIVE_QP = tuple(b for b in ("daqp", "osqp", "clarabel") if b in available_qp_solvers())


def ipopt_available() -> bool:
    from stackik.methods.ipopt import ipopt_available as avail

    return avail()


HAVE_IPOPT = ipopt_available()

OUTCOMES = (
    "success",
    "infeasible",
    "max_iter",
    "max_time",
    "failed",
    "value_error",
    "unexpected_exception",
    "accepted_malformed",
)


# =========================================================================================
# Geometry
# =========================================================================================
def random_platform(rng: np.random.Generator, scale: float = 1.0) -> sk.PlatformGeometry:
    """A valid hexagonal platform with random radii, half angles, leg range and joint limit."""
    leg_min = rng.uniform(150.0, 350.0)
    return sk.PlatformGeometry.hexagonal(
        base_radius=scale * rng.uniform(60.0, 250.0),
        top_radius=scale * rng.uniform(60.0, 250.0),
        base_half_angle=math.radians(rng.uniform(3.0, 25.0)),
        top_half_angle=math.radians(rng.uniform(3.0, 25.0)),
        leg_min=scale * leg_min,
        leg_max=scale * (leg_min + rng.uniform(80.0, 300.0)),
        joint_min=math.radians(rng.uniform(0.0, 30.0)),
    )


def random_stack(rng: np.random.Generator, n: int, scale: float = 1.0) -> sk.Stack:
    """A stack of ``n`` platforms: uniform (half the time) or all different."""
    if rng.random() < 0.5:
        return sk.Stack.uniform(random_platform(rng, scale), n)
    return sk.Stack(tuple(random_platform(rng, scale) for _ in range(n)))


def geometry_dicts(stack: sk.Stack) -> list[dict[str, Any]]:
    """The stack in the plain-dict form of ``reference_impl``."""
    return [
        {
            "base": np.array(g.base_nodes),
            "top": np.array(g.top_nodes),
            "leg_min": g.leg_min,
            "leg_max": g.leg_max,
            "joint_min": g.joint_min,
        }
        for g in stack
    ]


def centred(stack: sk.Stack) -> bool:
    """True when every plate's nodes have centroid 0 (hexagonal layouts)."""
    tol = 1e-9 * float(np.max(stack.leg_max))
    return bool(
        np.abs(stack.base_nodes.mean(axis=1)).max() <= tol
        and np.abs(stack.top_nodes.mean(axis=1)).max() <= tol
    )


# =========================================================================================
# Feasible poses (bounded rejection sampling; None when the box misses the feasible set)
# =========================================================================================
def feasible_planar_pose(
    stack: sk.Stack, rng: np.random.Generator, phi: float, batches: int = 30
) -> np.ndarray | None:
    """One random feasible planar pose (n, 3), each platform drawn in its own box."""
    if np.allclose(stack.leg_max, 450.0) and np.allclose(stack.leg_min, 250.0):
        # the reference geometry: the library's own sampler (never fails there)
        return random_feasible_poses(stack, 1, rng, phi, batch=512)[0]
    n = stack.n
    L = np.asarray(stack.leg_max)[:, None]
    lo = np.concatenate([-0.6 * L, 0.0 * L, np.full((n, 1), -0.8)], axis=1)
    hi = np.concatenate([0.6 * L, 1.0 * L, np.full((n, 1), 0.8)], axis=1)
    q = np.full((n, 3), np.nan)
    for _ in range(batches):
        cand = lo + (hi - lo) * rng.random((512, n, 3))
        ok = np.all(stack.planar_constraints(cand, phi) >= 0.0, axis=-1)  # (512, n)
        for i in range(n):
            if np.isnan(q[i, 0]) and ok[:, i].any():
                q[i] = cand[np.argmax(ok[:, i]), i]
        if not np.isnan(q).any():
            return q
    return None


def feasible_spatial_pose(
    stack: sk.Stack, rng: np.random.Generator, batches: int = 30
) -> np.ndarray | None:
    """One random feasible spatial pose (n, 6)."""
    n = stack.n
    L = np.asarray(stack.leg_max)[:, None]
    a = np.full((n, 3), 0.5)
    lo = np.concatenate([-0.5 * L, -0.5 * L, 0.0 * L, -a], axis=1)
    hi = np.concatenate([0.5 * L, 0.5 * L, 1.0 * L, a], axis=1)
    q = np.full((n, 6), np.nan)
    for _ in range(batches):
        cand = lo + (hi - lo) * rng.random((512, n, 6))
        ok = np.all(stack.spatial_constraints(cand) >= 0.0, axis=-1)
        for i in range(n):
            if np.isnan(q[i, 0]) and ok[:, i].any():
                q[i] = cand[np.argmax(ok[:, i]), i]
        if not np.isnan(q).any():
            return q
    return None


def random_rotation(rng: np.random.Generator, max_angle: float = math.pi) -> np.ndarray:
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    return ref.rodrigues(axis, rng.uniform(0.0, max_angle))


# =========================================================================================
# Independent re-check
# =========================================================================================
def _rot_angle(E: np.ndarray) -> float:
    """Rotation angle of E in [0, pi], well conditioned near 0: |E - I|_F = 2 sqrt2 sin(a/2)."""
    d = float(np.linalg.norm(E - np.eye(3)))
    return 2.0 * math.asin(min(1.0, d / (2.0 * math.sqrt(2.0))))


@dataclass
class Recheck:
    ok: bool
    reasons: list[str]
    position_error: float = math.nan
    angle_error: float = math.nan
    leg_violation: float = math.nan  # [mm] worst |l| outside [leg_min, leg_max]
    joint_violation: float = math.nan  # [mm] worst negative joint term
    clearance_slack: float = math.nan  # [mm] least (leg gap - required gap), legs of a size


def recheck(
    stack: sk.Stack,
    target: PlanarTarget | SpatialTarget,
    result: sk.IKResult,
    clearance: float = 0.0,
    load: Any = None,
    obstacles: Any = (),
) -> Recheck:
    """Check ``result`` against ``target`` and every limit without trusting the solver; with
    legs of a size (or a ``clearance`` margin [mm]), also the distance of every two legs of
    a platform, and every leg and plate (but the base) against every obstacle
    (:func:`clearance_problems`, :func:`obstacle_problems`), planar and spatial; always, no
    leg's axis or plate through a plate (``reference_impl.cores_through_plates``)."""
    reasons: list[str] = []
    planar = isinstance(target, PlanarTarget)
    n, k = stack.n, (3 if planar else 6)
    q = np.asarray(result.q, dtype=float)
    if q.shape != (n, k) or not np.all(np.isfinite(q)):
        return Recheck(False, [f"q has shape {q.shape} or non-finite values"])
    geoms = geometry_dicts(stack)
    if planar:
        phi = target.phi
        y_ref = ref.planar_forward(q, phi)
        O, _ = ref.planar_chain(q, phi)
        off_plane = abs(float(O[-1] @ ref.plane_axis(phi)))
        y_lib = sk.planar_forward(q)
        pos = max(
            math.hypot(y_ref[0] - target.rho, y_ref[1] - target.z),
            math.hypot(y_lib[0] - target.rho, y_lib[1] - target.z),
            off_plane,
        )
        ang = max(abs(y_ref[2] - target.theta), abs(y_lib[2] - target.theta))
        c_ref = ref.planar_constraints(geoms, q, phi)
        c_lib = stack.planar_constraints(q, phi)
        poses = [ref.planar_platform_pose(row, phi) for row in q]
    else:
        P_ref, R_ref = ref.spatial_forward(q)
        P_lib, R_lib = sk.spatial_forward(q)
        Pt, Rt = target.position, target.rotation
        pos = max(float(np.linalg.norm(P_ref - Pt)), float(np.linalg.norm(P_lib - Pt)))
        ang = max(_rot_angle(Rt.T @ R_ref), _rot_angle(Rt.T @ R_lib))
        c_ref = ref.spatial_constraints(geoms, q)
        c_lib = stack.spatial_constraints(q)
        poses = [ref.spatial_platform_pose(row) for row in q]
    if not pos <= POS_TOL:
        reasons.append(f"position error {pos:.3e} mm > {POS_TOL}")
    if not ang <= ANG_TOL:
        reasons.append(f"angle error {ang:.3e} rad > {ANG_TOL}")
    lmin = stack.leg_min[:, None]
    lmax = stack.leg_max[:, None]
    legs = np.array([ref.leg_lengths(g, P, R) for g, (P, R) in zip(geoms, poses, strict=True)])
    leg_v = 0.0
    joint_v = 0.0
    for c in (c_ref, c_lib):
        if not np.all(np.isfinite(c)):
            reasons.append("non-finite constraint values")
            continue
        # |l| from the leg-length blocks: |l|^2 - lmin^2 and lmax^2 - |l|^2
        l_from_min = np.sqrt(np.maximum(c[:, 0:6] + lmin**2, 0.0))
        l_from_max = np.sqrt(np.maximum(lmax**2 - c[:, 6:12], 0.0))
        for lv in (l_from_min, l_from_max):
            leg_v = max(leg_v, float(np.max(lmin - lv)), float(np.max(lv - lmax)))
        joint_v = max(joint_v, float(np.max(-c[:, 12:24])))
    leg_v = max(leg_v, float(np.max(lmin - legs)), float(np.max(legs - lmax)))
    if not leg_v <= LIMIT_TOL:
        reasons.append(f"leg length outside limits by {leg_v:.3e} mm")
    if not joint_v <= LIMIT_TOL:
        reasons.append(f"joint limit violated by {joint_v:.3e} mm")
    # what a user sends to hardware must describe the same pose
    scale = max(1.0, float(np.max(stack.leg_max)))
    P_all = np.array([P for P, _ in poses])
    R_all = np.array([R for _, R in poses])
    hw = [
        ("leg_lengths", result.leg_lengths, legs, 1e-9 * scale),
        ("P", result.P, P_all, 1e-9 * scale),
        ("R", result.R, R_all, 1e-9),
    ]
    for name, got, want, tol in hw:
        got = np.asarray(got, dtype=float)
        if got.shape != want.shape or not np.all(np.abs(got - want) <= tol):
            reasons.append(f"result.{name} disagrees with q")
    problems, slack = clearance_problems(stack, poses, clearance)
    reasons += problems
    ob_problems, ob_slack = obstacle_problems(stack, poses, obstacles, clearance)
    reasons += ob_problems
    O, A = ref.chain(poses)
    for what, j in ref.cores_through_plates(geoms, O, A, CLEARANCE_TOL):
        reasons.append(f"{what} passes through plate {j}")
    slack = float(np.fmin(slack, ob_slack))  # (nan: nothing to keep clear)
    reasons += force_problems(stack, poses, load)
    return Recheck(not reasons, reasons, pos, ang, leg_v, joint_v, slack)


def obstacle_problems(
    stack: sk.Stack, poses: list[Any], obstacles: Any = (), clearance: float = 0.0
) -> tuple[list[str], float]:
    """Legs (capsules of ``leg_radius``) or plates (zero thickness; the base plate left out)
    closer to an obstacle than ``clearance - CLEARANCE_TOL`` [mm], by the oracle's exact
    distances (``reference_impl.obstacle_body_gaps``, plain data: independent of stackik's
    clearance code); and the least slack (surface distance - margin) [mm] (nan without
    obstacles)."""
    obs = as_obstacles(obstacles)
    if not obs:
        return [], math.nan
    if any(g.plate_thickness > 0.0 for g in stack):  # not in the oracle
        raise NotImplementedError("the obstacle oracle has plates of zero thickness only")
    O, A = ref.chain(poses)
    radius = np.array([g.leg_radius for g in stack], dtype=float)[:, None]
    geoms = geometry_dicts(stack)
    problems: list[str] = []
    slack = math.inf
    for j, ob in enumerate(obs):
        g = ref.obstacle_body_gaps(geoms, O, A, ob.to_dict())
        leg = g["leg"] - radius - clearance
        plate = g["plate"] - clearance
        worst = min(float(leg.min()), float(plate.min()))
        slack = min(slack, worst)
        if not worst >= -CLEARANCE_TOL:
            body = "a leg" if leg.min() <= plate.min() else "a plate"
            problems.append(f"{body} {worst:.6g} mm inside obstacle {j}'s margin")
    return problems, slack


def force_problems(stack: sk.Stack, poses: list[Any], load: Any) -> list[str]:
    """A leg over its ``force_max`` (1 + 1e-6) or a non-finite force under ``load`` (None:
    the stack's own weight, earth gravity), by the oracle's statics
    (``reference_impl.world_leg_forces``); nothing to check without a finite force_max."""
    fmax = np.asarray(stack.force_max, dtype=float)
    if not np.isfinite(fmax).any():
        return []
    if load is None:
        load = sk.Load()
    f = ref.world_leg_forces(
        stack.base_nodes, stack.top_nodes, stack.plate_mass, stack.leg_mass, poses,
        load.mass, load.com, load.g, load.force, load.moment, load.frame,
    )  # fmt: skip
    if not np.all(np.isfinite(f)):
        return ["non-finite leg forces"]
    over = np.abs(f) - fmax[:, None] * (1.0 + 1e-6)
    if np.any(over > 0):
        return [f"a leg over its force limit by {float(over.max()):.3e} N"]
    return []


def clearance_problems(
    stack: sk.Stack, poses: list[Any], clearance: float = 0.0
) -> tuple[list[str], float]:
    """Legs of one platform closer than ``2 leg_radius - CLEARANCE_TOL`` (capsules that
    overlap) or, with a margin, than ``2 leg_radius + clearance - CLEARANCE_TOL`` axis to
    axis, by the oracle's exact segment distance (``reference_impl``; ``poses``: each
    platform's ``(P, R)``, planar ones lifted); and the least slack
    ``gap - (2 leg_radius + clearance)`` [mm] (nan without radii and margin)."""
    radius = np.array([g.leg_radius for g in stack], dtype=float)
    if not (radius.max() > 0.0 or clearance > 0.0):
        return [], math.nan
    gaps = ref.self_leg_gaps(geometry_dicts(stack), poses)
    need = 2.0 * radius + float(clearance)
    bad = np.flatnonzero(~(gaps >= need - CLEARANCE_TOL))
    problems = [f"legs of platform {i} {gaps[i]:.6g} mm apart < {need[i]:.6g} mm" for i in bad]
    return problems, float(np.min(gaps - need))


# =========================================================================================
# Cases
# =========================================================================================
Built = tuple[Any, Any, dict[str, Any]]  # (stack, target, solve_ik keyword arguments)


@dataclass
class Case:
    """One fuzz case.

    ``make()`` returns ``(stack, target, kwargs)`` for ``solve_ik(stack, target, **kwargs)``
    and may raise (malformed inputs are built inside the timed, classified call).
    """

    category: str
    label: str
    make: Callable[[], Built]
    malformed: bool = False
    unreachable: bool = False  # provably unreachable: success is impossible
    info: dict[str, Any] = field(default_factory=dict)


def _iter_limit(kwargs: dict[str, Any]) -> int | None:
    opts = kwargs.get("options") or {}
    method = kwargs.get("method", "sqp")
    key = "max_iter" if method in ("sqp", "ipopt") else "maxiter"
    v = opts.get(key)
    return int(v) if isinstance(v, int) and not isinstance(v, bool) else None


def nit_bound(stack: sk.Stack, target: Any, kwargs: dict[str, Any], per_run: int) -> int:
    """Largest ``nit`` solve_ik may report with ``per_run`` iterations per solver run.

    SQP: the screened structured starts (n >= 2, no x0, default starts), the
    planned starts, and up to FALLBACK_STARTS more when none passes the check (each twice
    on planar problems with self-leg rows: first without them). The
    interior-point path (``method="ip"``, or ``"auto"`` where it applies): its planned
    starts (structured ones plus the documented fold patterns, :func:`stackik.starts.fold_depth`)
    and, for ``"auto"``, the bisection toward an unreachable target and the SQP runs
    above when none passes.
    """
    from stackik.solve.policy import auto_method as _auto_method
    from stackik.starts import fold_depth

    planar = isinstance(target, PlanarTarget)
    x0 = kwargs.get("x0")
    starts = kwargs.get("starts")
    method = kwargs.get("method", "auto")
    structured = stack.n >= 2 and x0 is None and kwargs.get("start", "paper") == "paper"
    screened = SCREENED_STARTS if planar else SCREENED_STARTS_SPATIAL
    # planar self-leg rows (legs of a size or a margin): a local engine's run without them
    # may be followed by one with them from the same start (``Problem.lazy_self_legs``)
    radius = max(float(g.leg_radius) for g in stack)
    lazy = planar and (radius > 0.0 or float(kwargs.get("clearance", 0.0)) > 0.0)

    def sqp_runs() -> int:
        return (2 if lazy else 1) * _sqp_starts()

    def _sqp_starts() -> int:
        runs = 0
        if starts is None and structured and not planar:
            from stackik.starts import SPATIAL_STARTS

            runs += SPATIAL_STARTS
        elif starts is None:
            runs += screened + 1 if structured else 1
        else:
            runs += int(starts)
        if x0 is None:
            runs += FALLBACK_STARTS
        return runs

    resolved = method
    if method == "auto":
        resolved = _auto_method(
            planar,
            kwargs.get("objective", "frobenius"),
            kwargs.get("sigma_theta"),
            kwargs.get("qp_solver"),
            kwargs.get("options"),
        )
    if resolved != "ip":
        return per_run * sqp_runs()
    if starts is None:
        ip_runs = SCREENED_STARTS if structured else 1
        if structured:
            from stackik.starts import tall_random_starts

            ip_runs += 2 ** min(fold_depth(stack.n), stack.n) + tall_random_starts(stack.n)
    else:
        ip_runs = int(starts)
    if method == "auto":
        from stackik.solve.nearest import NEAREST_STEPS

        # every start stalled: the bisection toward the target (two starts per step),
        # then possibly the SQP runs
        return per_run * (ip_runs + 2 * NEAREST_STEPS + sqp_runs())
    return per_run * ip_runs


def default_max_time(stack: sk.Stack) -> float:
    """solve_ik's default time budget [s] (documented: 10 + 2 n)."""
    return 10.0 + 2.0 * stack.n


def run_case(case: Case) -> dict[str, Any]:
    """Build and solve one case; never raises. Returns a JSON-ready record."""
    rec: dict[str, Any] = {
        "category": case.category,
        "label": case.label,
        "malformed": case.malformed,
        "unreachable": case.unreachable,
        **case.info,
    }
    t0 = time.perf_counter()
    try:
        stack, target, kwargs = case.make()
        res = sk.solve_ik(stack, target, **kwargs)
    except Exception as exc:  # noqa: BLE001 - classifying every exception is the point
        rec["time"] = time.perf_counter() - t0
        rec["exception"] = f"{type(exc).__module__}.{type(exc).__qualname__}: {exc}"[:300]
        expected = case.malformed and isinstance(exc, ValueError) and bool(str(exc).strip())
        rec["outcome"] = "value_error" if expected else "unexpected_exception"
        rec["false_success"] = False
        return rec
    elapsed = time.perf_counter() - t0
    rec["time"] = elapsed
    rec["nit"] = int(res.nit)
    rec["n_starts"] = int(res.n_starts)
    rec["status"] = res.status.value
    if case.malformed:
        rec["outcome"] = "accepted_malformed"
        rec["false_success"] = False
        return rec
    rec["outcome"] = res.status.value
    problems: list[str] = []
    if res.success != (res.status is IKStatus.SUCCESS):
        problems.append("success flag disagrees with status")
    if res.success:
        load = kwargs.get("load")
        margin = float(kwargs.get("clearance", 0.0))
        obstacles = kwargs.get("obstacles") or ()
        chk = sk.check_pose(stack, target, res.q, load, obstacles=obstacles, clearance=margin)
        rc = recheck(stack, target, res, margin, load, obstacles)
        if not chk.ok:
            problems.append("check_pose fails")
        problems += rc.reasons
        if math.isfinite(rc.clearance_slack):
            rec["clearance_slack"] = rc.clearance_slack
        if case.unreachable:
            problems.append("success on a provably unreachable target")
    elif not np.all(np.isfinite(res.q)):
        rec["anomaly"] = "non-finite q in an unsuccessful result"
    rec["false_success"] = bool(res.success and problems)
    if problems:
        rec["problems"] = problems
    mt = kwargs.get("max_time", default_max_time(stack))
    rec["time_overrun"] = bool(elapsed > float(mt) + TIME_SLACK)
    lim = _iter_limit(kwargs)
    if lim is not None and lim >= 1:
        bound = nit_bound(stack, target, kwargs, lim)
        rec["nit_bound"] = bound
        rec["iter_overrun"] = bool(res.nit > bound)
    return rec


# =========================================================================================
# Solver settings
# =========================================================================================
def random_solver(
    rng: np.random.Generator, planar: bool, n: int, method_mix: bool = True
) -> dict[str, Any]:
    """Method, backend and objective: mostly the default SQP, a share of everything else."""
    kw: dict[str, Any] = {}
    u = rng.random() if method_mix else 0.0
    if u < 0.62:
        pass  # default sqp + default backend
    elif u < 0.76:
        kw["qp_solver"] = str(rng.choice(NATIVE_QP))
    elif u < 0.86:
        kw["method"] = "slsqp"
    elif u < 0.93:
        kw["method"] = "trust-constr"
        kw["options"] = {"maxiter": int(rng.integers(50, 300))}
    elif planar and HAVE_IPOPT:
        kw["method"] = "ipopt"
    else:
        kw["method"] = "slsqp"
    v = rng.random()
    if v < 0.65:
        pass  # frobenius
    elif v < 0.85:
        kw["objective"] = "feasible"
    elif kw.get("method") != "ipopt":
        kw["objective"] = "weighted"
        if rng.random() < 0.5:
            kw["sigma_t"], kw["sigma_theta"] = (
                float(rng.uniform(0.01, 1.0)),
                float(rng.uniform(1e-3, 0.05)),
            )
        else:
            kw["sigma_t"] = rng.uniform(0.0, 1.0, n).tolist()
            kw["sigma_theta"] = rng.uniform(1e-3, 0.05, n).tolist()
    # keep every solve short: big stacks get a time budget
    kw["max_time"] = 5.0 if n <= 8 else 8.0
    return kw


def _n_small(rng: np.random.Generator) -> int:
    return int(rng.choice([1, 1, 2, 2, 3, 3, 4, 4, 5, 6]))


# =========================================================================================
# Generators, one per category. Each takes an rng and returns a Case.
# =========================================================================================
def gen_reachable_planar(rng: np.random.Generator, n: int | None = None) -> Case:
    n = _n_small(rng) if n is None else n
    phi = float(rng.choice(PHIS))
    stack = sk.Stack.reference(n)
    q = feasible_planar_pose(stack, rng, phi)
    assert q is not None
    y = sk.planar_forward(q)
    kw = random_solver(rng, True, n)
    if rng.random() < 0.1:
        kw["starts"] = int(rng.integers(1, 4))
        kw["rng"] = int(rng.integers(0, 2**31))
    target = PlanarTarget(float(y[0]), float(y[1]), float(y[2]), phi)
    return Case(
        "reachable_planar",
        f"ref n={n} phi={phi:.3f} y={np.round(y, 3).tolist()} {_kw_label(kw)}",
        lambda: (stack, target, kw),
        info={"n": n, "method": kw.get("method", "sqp"), "mode": "planar"},
    )


def gen_reachable_spatial(rng: np.random.Generator, n: int | None = None) -> Case:
    n = int(rng.choice([1, 2, 2, 3])) if n is None else n
    stack = sk.Stack.reference(n)
    if rng.random() < 0.3:  # a planar pose lifted to 3D (a plane of random azimuth)
        phi = float(rng.uniform(-math.pi, math.pi))
        qp = feasible_planar_pose(stack, rng, phi)
        assert qp is not None
        target = PlanarTarget(*(float(v) for v in sk.planar_forward(qp)), phi=phi).to_spatial()
    else:
        q = feasible_spatial_pose(stack, rng)
        assert q is not None
        P, R = sk.spatial_forward(q)
        target = SpatialTarget(P, R)
    kw = random_solver(rng, False, n)
    if kw.get("method") == "trust-constr":
        kw["options"] = {"maxiter": 150}
    return Case(
        "reachable_spatial",
        f"ref n={n} P={np.round(target.position, 3).tolist()} {_kw_label(kw)}",
        lambda: (stack, target, kw),
        info={"n": n, "method": kw.get("method", "sqp"), "mode": "spatial"},
    )


def gen_random_geometry(rng: np.random.Generator) -> Case:
    """Reachable targets on random (and extreme-scale) geometries, planar or spatial."""
    n = int(rng.choice([1, 2, 3, 4]))
    scale = 1.0 if rng.random() < 0.7 else float(10.0 ** rng.uniform(-3.0, 6.0))
    stack = q = None
    for _ in range(10):
        stack = random_stack(rng, n, scale)
        phi = float(rng.choice(PHIS))
        planar = rng.random() < 0.75
        q = feasible_planar_pose(stack, rng, phi) if planar else feasible_spatial_pose(stack, rng)
        if q is not None:
            break
    if q is None:  # pragma: no cover - never seen; fall back to the reference platform
        stack, planar, phi = sk.Stack.reference(n), True, 0.0
        q = feasible_planar_pose(stack, rng, phi)
    assert stack is not None and q is not None
    if planar:
        target: Any = PlanarTarget(*(float(v) for v in sk.planar_forward(q)), phi=phi)
    else:
        target = SpatialTarget(*sk.spatial_forward(q))
    kw = random_solver(rng, planar, n)
    if kw.get("method") == "ipopt" and not planar:
        kw["method"] = "slsqp"
    st_ = stack
    return Case(
        "random_geometry",
        f"random n={n} scale={scale:.3g} {'planar' if planar else 'spatial'} {_kw_label(kw)}",
        lambda: (st_, target, kw),
        info={"n": n, "method": kw.get("method", "sqp"), "mode": "planar" if planar else "spatial"},
    )


def gen_clearance_spatial(rng: np.random.Generator, n: int | None = None) -> Case:
    """Spatial targets on legs of a size: leg radii 0-15 mm (one for the stack, one per
    platform, or some zero) and a clearance margin half the time (0-10 mm), reference or
    random platforms; targets from random feasible poses of the zero-radius stack (so some
    are reachable only with other poses, some not at all once the legs have a size)."""
    n = int(rng.choice([1, 2, 3, 4])) if n is None else n
    u = rng.random()
    if u < 0.35:
        radii = np.full(n, rng.uniform(0.0, 15.0))
    elif u < 0.75:
        radii = rng.uniform(0.0, 15.0, n)
    else:
        radii = rng.uniform(0.0, 15.0, n) * (rng.random(n) < 0.5)
    margin = 0.0 if rng.random() < 0.5 else float(rng.uniform(0.0, 10.0))
    thin = sk.Stack.reference(n) if rng.random() < 0.75 else random_stack(rng, n)
    q = feasible_spatial_pose(thin, rng)
    if q is None:  # pragma: no cover - never seen on these geometries
        thin = sk.Stack.reference(n)
        q = feasible_spatial_pose(thin, rng)
    assert q is not None
    stack = sk.Stack(
        tuple(
            sk.PlatformGeometry(**{**g.to_dict(), "leg_radius": float(r)})
            for g, r in zip(thin, radii, strict=True)
        )
    )
    target = SpatialTarget(*sk.spatial_forward(q))
    kw = random_solver(rng, False, n)
    if kw.get("method") == "trust-constr":
        kw["options"] = {"maxiter": 150}
    if HAVE_IPOPT and rng.random() < 0.15:
        kw["method"] = "ipopt"
        kw.pop("qp_solver", None)
        kw.pop("options", None)
    if margin > 0.0:
        kw["clearance"] = margin
    return Case(
        "clearance_spatial",
        f"n={n} radii={np.round(radii, 2).tolist()} P={np.round(target.position, 3).tolist()} "
        f"{_kw_label(kw)}",
        lambda: (stack, target, kw),
        info={
            "n": n,
            "method": kw.get("method", "sqp"),
            "mode": "spatial",
            "leg_radius_max": float(radii.max()),
            "margin": margin,
        },
    )


def _or_ipopt(rng: np.random.Generator, kw: dict[str, Any], chance: float) -> dict[str, Any]:
    """``kw``, or with probability ``chance`` (when IPOPT is installed: one draw of
    ``rng`` then) IPOPT with its defaults and ``kw``'s time budget instead: the solver
    keywords of the cases whose rows IPOPT carries (obstacles, loads)."""
    if HAVE_IPOPT and rng.random() < chance:
        return {"method": "ipopt", "max_time": kw["max_time"]}
    return kw


#: Obstacle kinds of :func:`gen_obstacles`.
OBSTACLE_KINDS = ("sphere", "capsule", "box", "halfspace")


def _random_obstacle(
    rng: np.random.Generator, stack: sk.Stack, poses: list[Any], kind: str
) -> Obstacle:
    """An obstacle of ``kind`` near a random point of a random leg of the pose ``poses``
    (the zero-radius pose the target came from): 0-60 mm off it, sizes of actuators, truss
    members, beams and walls; a half-space's boundary through such a point, its normal
    random but pointing away from the base origin's side (the bodies stay on that side)."""
    O, A = ref.chain(poses)
    geoms = geometry_dicts(stack)
    i, k = int(rng.integers(stack.n)), int(rng.integers(6))
    a = O[i] + A[i] @ geoms[i]["base"][k]
    b = O[i + 1] + A[i + 1] @ geoms[i]["top"][k]
    p = a + rng.uniform(0.0, 1.0) * (b - a) + rng.normal(0.0, 30.0, 3)
    if kind == "sphere":
        return sk.Sphere(p, float(rng.uniform(3.0, 60.0)))
    if kind == "capsule":
        d = rng.normal(size=3)
        d *= float(rng.uniform(50.0, 500.0)) / np.linalg.norm(d)
        return sk.Capsule(p - d, p + d, float(rng.uniform(2.0, 25.0)))
    if kind == "box":
        from scipy.spatial.transform import Rotation

        rot = Rotation.from_rotvec(rng.normal(0.0, 1.5, 3)).as_matrix()
        return sk.Box(p, rng.uniform(3.0, 120.0, 3), rot)
    normal = rng.normal(size=3)
    if normal @ p > 0.0:  # the base origin on the side the normal points to
        normal = -normal
    return sk.HalfSpace(p, normal)


def gen_obstacles(rng: np.random.Generator, n: int | None = None) -> Case:
    """Keep-out bodies (spheres, truss capsules, rotated boxes, half-spaces; one to three)
    placed across the legs of the pose a target came from, planar or spatial, legs of zero
    radius or 1-12 mm, a clearance margin a third of the time (0-5 mm), reference or random
    platforms, every method. Obstacles that would touch a base joint (every pose would
    collide: a ValueError by design) are drawn again. The re-check measures every leg and
    plate against every obstacle with the oracle's own exact distances."""
    n = int(rng.choice([1, 2, 3, 4])) if n is None else n
    planar = bool(rng.random() < 0.5)
    radius = 0.0 if rng.random() < 0.4 else float(rng.uniform(1.0, 12.0))
    margin = float(rng.uniform(0.0, 5.0)) if rng.random() < 0.33 else 0.0
    thin = sk.Stack.reference(n) if rng.random() < 0.75 else random_stack(rng, n)
    if planar:
        phi = float(rng.choice(PHIS))
        q = feasible_planar_pose(thin, rng, phi)
        if q is None:  # pragma: no cover - random geometries that fail the sampler
            thin = sk.Stack.reference(n)
            q = feasible_planar_pose(thin, rng, phi)
        assert q is not None
        y = sk.planar_forward(q)
        target: Any = PlanarTarget(float(y[0]), float(y[1]), float(y[2]), phi=phi)
        poses = [ref.planar_platform_pose(row, phi) for row in q]
    else:
        q = feasible_spatial_pose(thin, rng)
        if q is None:  # pragma: no cover
            thin = sk.Stack.reference(n)
            q = feasible_spatial_pose(thin, rng)
        assert q is not None
        target = SpatialTarget(*sk.spatial_forward(q))
        poses = [ref.spatial_platform_pose(row) for row in q]
    stack = sk.Stack(
        tuple(sk.PlatformGeometry(**{**g.to_dict(), "leg_radius": radius}) for g in thin)
    )
    base = np.asarray(stack.base_nodes[0], dtype=float)
    obstacles: list[Obstacle] = []
    kinds: list[str] = []
    for _ in range(int(rng.integers(1, 4))):
        kind = str(rng.choice(OBSTACLE_KINDS))
        for _attempt in range(20):
            ob = _random_obstacle(rng, stack, poses, kind)
            if float(np.min(ob.point_distance(base))) > radius + 1.0:
                obstacles.append(ob)
                kinds.append(kind)
                break
    kw = random_solver(rng, planar, n)
    if kw.get("method") == "trust-constr":
        kw["options"] = {"maxiter": 150}
    kw = _or_ipopt(rng, kw, 0.15)
    kw["obstacles"] = obstacles
    if margin > 0.0:
        kw["clearance"] = margin
    return Case(
        "obstacles",
        f"n={n} {'planar' if planar else 'spatial'} radius={radius:.3g} margin={margin:.3g} "
        f"obstacles={kinds} {_kw_label(kw, ('obstacles',))}",
        lambda: (stack, target, kw),
        info={
            "n": n,
            "method": kw.get("method", "sqp"),
            "mode": "planar" if planar else "spatial",
            "leg_radius_max": radius,
            "margin": margin,
            "obstacles": len(obstacles),
        },
    )


def gen_loads(rng: np.random.Generator, n: int | None = None) -> Case:
    """Loaded targets: plate and leg masses, a payload (mass, centre-of-mass offset, an
    external force and moment in the base or end-effector frame), every gravity preset or
    a random vector, and leg force limits (none, loose or binding: 40-600 N), planar or
    spatial, every method; targets from random feasible poses."""
    n = int(rng.choice([1, 2, 3, 4])) if n is None else n
    planar = bool(rng.random() < 0.5)
    u = rng.random()
    fmax = math.inf if u < 0.2 else float(rng.uniform(40.0, 600.0))
    geom = sk.PlatformGeometry.hexagonal(
        plate_mass=float(rng.uniform(0.0, 8.0)),
        leg_mass=float(rng.uniform(0.0, 2.0)),
        force_max=fmax,
    )
    stack = sk.Stack.uniform(geom, n)
    grav: Any = str(rng.choice(["earth", "moon", "mars", "none"]))
    if rng.random() < 0.25:
        grav = rng.normal(0.0, 6.0, 3).tolist()
    load = sk.Load(
        force=rng.normal(0.0, 20.0, 3).tolist() if rng.random() < 0.4 else (0.0, 0.0, 0.0),
        moment=rng.normal(0.0, 2.0, 3).tolist() if rng.random() < 0.3 else (0.0, 0.0, 0.0),
        frame=str(rng.choice(["base", "end_effector"])),
        mass=float(rng.uniform(0.0, 10.0)),
        com=rng.normal(0.0, 30.0, 3).tolist() if rng.random() < 0.3 else (0.0, 0.0, 0.0),
        gravity=grav,
    )
    if planar:
        phi = float(rng.choice(PHIS))
        q = feasible_planar_pose(stack, rng, phi)
        assert q is not None
        y = sk.planar_forward(q)
        target: Any = PlanarTarget(float(y[0]), float(y[1]), float(y[2]), phi=phi)
    else:
        qs = feasible_spatial_pose(stack, rng)
        assert qs is not None
        target = SpatialTarget(*sk.spatial_forward(qs))
    kw = random_solver(rng, planar, n)
    kw = _or_ipopt(rng, kw, 0.1)
    kw["load"] = load
    return Case(
        "loads",
        f"n={n} {'planar' if planar else 'spatial'} force_max={fmax:.4g} mass={load.mass:.3g} "
        f"gravity={grav if isinstance(grav, str) else 'vector'} {_kw_label(kw, ('load',))}",
        lambda: (stack, target, kw),
        info={"n": n, "method": kw.get("method", "sqp"), "mode": "planar" if planar else "spatial"},
    )


def gen_large_n(rng: np.random.Generator, n: int | None = None) -> Case:
    """n = 8..16 with the default solver (or n = 32/64 with one start and a time budget)."""
    if n is None:
        n = (
            int(rng.choice([8, 10, 12, 16, 16]))
            if rng.random() < 0.9
            else int(rng.choice([32, 64]))
        )
    stack = sk.Stack.reference(n)
    phi = float(rng.choice(PHIS))
    q = feasible_planar_pose(stack, rng, phi)
    assert q is not None
    target = PlanarTarget(*(float(v) for v in sk.planar_forward(q)), phi=phi)
    kw: dict[str, Any] = {"max_time": 8.0}
    r = rng.random()
    if n >= 32:
        kw.update(starts=1, max_time=2.0)  # one start: keeps the soak short
        if r < 0.5:
            kw["objective"] = "feasible"
    elif r < 0.2:
        kw["objective"] = "feasible"
    elif r < 0.3:
        kw["method"] = "slsqp"
    return Case(
        "large_n",
        f"ref n={n} phi={phi:.3f} {_kw_label(kw)}",
        lambda: (stack, target, kw),
        info={"n": n, "method": kw.get("method", "sqp"), "mode": "planar"},
    )


def gen_unreachable(rng: np.random.Generator) -> Case:
    """Beyond reach, impossible angles, too low. ``unreachable`` only when provable."""
    n = int(rng.choice([1, 1, 2, 2, 3, 4]))
    stack = sk.Stack.reference(n) if rng.random() < 0.7 else random_stack(rng, n)
    g0 = stack[0]
    lmax_sum = float(np.sum(stack.leg_max))
    kind = str(rng.choice(["far", "far", "angle", "low", "low_deep"]))
    phi = float(rng.choice(PHIS))
    proven = False
    if kind == "far":
        # centred plates: |p_i| <= mean |l_k| <= leg_max, hence |P_ee| <= sum(leg_max)
        d = lmax_sum * float(rng.choice([1.0 + 1e-3, 1.05, 1.3, 2.0, 10.0, 1e6]))
        a = rng.uniform(-math.pi, math.pi)
        y = (d * math.cos(a), d * math.sin(a), float(rng.uniform(-1, 1)))
        proven = centred(stack)
    elif kind == "angle":
        # one plate tilts by at most pi - 2 joint_min (l within pi/2 - joint_min of n and Rn);
        # n = 2 with theta = 3 needs ~1.5 rad per plate (sampling finds <= 0.94; not proven).
        # Plate angles are not wrapped, so bigger stacks reach theta - 2 pi: only n <= 2 here.
        n = 1 if n == 1 else 2
        stack = sk.Stack.reference(n) if rng.random() < 0.7 else random_stack(rng, n)
        g0 = stack[0]
        sgn = float(rng.choice([-1.0, 1.0]))
        th = sgn * float(rng.uniform(2.6, 3.1)) if n == 1 else sgn * 3.0
        y = (float(rng.uniform(-100, 100)), 300.0 * n, th)
        proven = n == 1 and abs(th) > math.pi - 2 * g0.joint_min + 1e-3
    elif kind == "low":
        # centred plate: 6 z = sum l_k.e_z >= 6 leg_min sin(joint_min), so z >= lmin sin(jm)
        zmin = g0.leg_min * math.sin(g0.joint_min)
        z = (
            float(rng.uniform(-0.5 * g0.leg_max, zmin - 1e-3))
            if n == 1
            else -float(rng.uniform(0.0, 0.5 * lmax_sum))
        )
        y = (float(rng.uniform(-200, 200)), z, float(rng.uniform(-0.3, 0.3)))
        proven = n == 1 and centred(stack)
    else:  # low_deep: far below the base
        y = (0.0, -float(rng.uniform(0.6, 0.99)) * lmax_sum, 0.0)
        proven = False
    planar = rng.random() < 0.8 or kind == "angle"
    if planar:
        target: Any = PlanarTarget(*y, phi=phi)
    else:
        target = PlanarTarget(*y, phi=phi).to_spatial()
    kw = random_solver(rng, planar, n)
    return Case(
        "unreachable",
        f"{kind} n={n} y={np.round(y, 3).tolist()} {'planar' if planar else 'spatial'} "
        f"{_kw_label(kw)}",
        lambda: (stack, target, kw),
        unreachable=proven,
        info={"n": n, "method": kw.get("method", "sqp"), "kind": kind, "proven": proven},
    )


_BAD_FLOATS = (math.nan, math.inf, -math.inf)


def gen_nonfinite(rng: np.random.Generator) -> Case:
    """NaN / inf in a target, x0, a geometry field, sigma or an SQP option."""
    n = int(rng.choice([1, 2, 3]))
    bad = float(rng.choice(_BAD_FLOATS))
    where = str(
        rng.choice(
            [
                "planar_target",
                "phi",
                "spatial_pos",
                "spatial_rot",
                "x0",
                "nodes",
                "leg",
                "joint",
                "radius",
                "sigma",
                "option",
            ]
        )
    )
    stack = sk.Stack.reference(n)
    tgt = PlanarTarget(0.0, 330.0 * n, 0.1)

    def make() -> Built:
        kw: dict[str, Any] = {}
        s: Any = stack
        t: Any = tgt
        if where == "planar_target":
            vals = [0.0, 330.0 * n, 0.1]
            vals[int(rng.integers(0, 3))] = bad
            t = PlanarTarget(*vals)
        elif where == "phi":
            t = PlanarTarget(0.0, 330.0 * n, 0.1, phi=bad)
        elif where == "spatial_pos":
            P = np.array([0.0, 0.0, 330.0 * n])
            P[int(rng.integers(0, 3))] = bad
            t = SpatialTarget(P, np.eye(3))
        elif where == "spatial_rot":
            R = np.eye(3)
            R[tuple(rng.integers(0, 3, 2))] = bad
            t = SpatialTarget([0.0, 0.0, 330.0 * n], R)
        elif where == "x0":
            x0 = sk.paper_initial_guess(stack, tgt)
            x0[tuple(rng.integers(0, x0.shape))] = bad
            kw["x0"] = x0
        elif where == "nodes":
            g = sk.PlatformGeometry.reference()
            nodes = np.array(g.base_nodes)
            nodes[tuple(rng.integers(0, (6, 3)))] = bad
            s = sk.Stack.uniform(sk.PlatformGeometry(nodes, g.top_nodes, 250, 450, 0.3), n)
        elif where == "leg":
            s = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_max=bad), n)
        elif where == "joint":
            s = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(joint_min=bad), n)
        elif where == "radius":
            s = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(top_radius=bad), n)
        elif where == "sigma":
            sig = [1.0] * n
            sig[int(rng.integers(0, n))] = bad
            kw.update(objective="weighted", sigma_t=sig, sigma_theta=0.01)
        else:  # +inf is a legitimate "no limit" for SQPOptions.max_time; use -inf instead
            kw["options"] = {str(rng.choice(["tol", "constr_tol", "max_time"])): -abs(bad)}
        return s, t, kw

    return Case("nonfinite", f"{where}={bad} n={n}", make, malformed=True, info={"n": n})


def gen_wrong_shape(rng: np.random.Generator) -> Case:
    """Wrong shapes of x0, spatial position/rotation and node arrays; non-rotations."""
    n = int(rng.choice([1, 2, 3]))
    stack = sk.Stack.reference(n)
    planar_t = PlanarTarget(0.0, 330.0 * n, 0.1)
    spatial_t = planar_t.to_spatial()
    where = str(rng.choice(["x0", "x0_mode", "position", "rotation", "not_rotation", "nodes"]))
    shapes = [(n, 2), (n + 1, 3), (3 * n,), (n, 3, 1), (0, 3), (), (n, 4), (1, n, 3)]
    shape = shapes[int(rng.integers(0, len(shapes)))]

    def make() -> Built:
        if where == "x0":
            return stack, planar_t, {"x0": np.ones(shape)}
        if where == "x0_mode":  # a planar x0 for a spatial target and vice versa
            if rng.random() < 0.5:
                return stack, spatial_t, {"x0": sk.paper_initial_guess(stack, planar_t)}
            return stack, planar_t, {"x0": sk.paper_initial_guess(stack, spatial_t)}
        if where == "position":
            pshape = [(2,), (4,), (3, 1), (1, 3), (), (0,)][int(rng.integers(0, 6))]
            return stack, SpatialTarget(np.ones(pshape), np.eye(3)), {}
        if where == "rotation":
            rshape = [(3,), (2, 2), (3, 4), (4, 4), (1, 3, 3), ()][int(rng.integers(0, 6))]
            return stack, SpatialTarget([0.0, 0.0, 600.0], np.ones(rshape)), {}
        if where == "not_rotation":
            R = random_rotation(rng)
            k = int(rng.integers(0, 3))
            R = [R @ np.diag([1, 1, -1]), 1.01 * R, R + 1e-4 * rng.standard_normal((3, 3))][k]
            return stack, SpatialTarget([0.0, 0.0, 600.0], R), {}
        g = sk.PlatformGeometry.reference()
        nshape = [(5, 3), (6, 2), (7, 3), (18,), (6, 3, 1), (3, 6)][int(rng.integers(0, 6))]
        nodes = np.resize(g.base_nodes, nshape)
        return (
            sk.Stack.uniform(sk.PlatformGeometry(nodes, g.top_nodes, 250, 450, 0.3), n),
            planar_t,
            {},
        )

    return Case("wrong_shape", f"{where} shape={shape} n={n}", make, malformed=True, info={"n": n})


def _collinear_nodes(rng: np.random.Generator) -> np.ndarray:
    d = rng.standard_normal(3)
    return np.outer(np.arange(6) - 2.5, d * 40.0) + rng.standard_normal(3)


def gen_bad_geometry(rng: np.random.Generator) -> Case:
    """Malformed geometries that must raise GeometryError (a ValueError)."""
    g = sk.PlatformGeometry.reference()
    kind = str(
        rng.choice(
            [
                "collinear",
                "duplicate",
                "leg_order",
                "leg_equal",
                "leg_nonpos",
                "joint_high",
                "joint_neg",
                "radius",
                "empty",
                "n_zero",
                "not_geometry",
                "string",
            ]
        )
    )
    lmin = float(rng.uniform(100, 400))

    def make() -> Built:
        P = sk.PlatformGeometry
        if kind == "collinear":
            s = sk.Stack.uniform(P(_collinear_nodes(rng), g.top_nodes, 250, 450, 0.3), 2)
        elif kind == "duplicate":
            nodes = np.array(g.top_nodes)
            nodes[3] = nodes[1]
            s = sk.Stack.uniform(P(g.base_nodes, nodes, 250, 450, 0.3), 2)
        elif kind == "leg_order":
            s = sk.Stack.uniform(P.hexagonal(leg_min=lmin, leg_max=lmin * rng.uniform(0.5, 1)), 2)
        elif kind == "leg_equal":
            s = sk.Stack.uniform(P.hexagonal(leg_min=lmin, leg_max=lmin), 2)
        elif kind == "leg_nonpos":
            s = sk.Stack.uniform(P.hexagonal(leg_min=-rng.uniform(0, 10)), 2)
        elif kind == "joint_high":
            s = sk.Stack.uniform(P.hexagonal(joint_min=math.pi / 2 + rng.uniform(0, 2)), 2)
        elif kind == "joint_neg":
            s = sk.Stack.uniform(P.hexagonal(joint_min=-rng.uniform(1e-6, 1)), 2)
        elif kind == "radius":
            s = sk.Stack.uniform(P.hexagonal(base_radius=-rng.uniform(0, 100)), 2)
        elif kind == "empty":
            s = sk.Stack(())
        elif kind == "n_zero":
            s = sk.Stack.uniform(g, int(rng.integers(-3, 1)))
        elif kind == "not_geometry":
            s = sk.Stack((g, "platform"))  # type: ignore[arg-type]
        else:
            s = sk.Stack.uniform(P(g.base_nodes, g.top_nodes, "250", 450, 0.3), 2)
        return s, PlanarTarget(0.0, 660.0, 0.1), {}

    return Case("bad_geometry", kind, make, malformed=True)


def gen_infeasible_geometry(rng: np.random.Generator) -> Case:
    """Valid geometries where (almost) nothing is feasible: must not claim false success."""
    n = int(rng.choice([1, 2, 3]))
    kind = str(rng.choice(["huge_base", "huge_top", "joint_near_90", "thin_legs", "tiny_range"]))
    P = sk.PlatformGeometry
    if kind == "huge_base":
        g = P.hexagonal(base_radius=float(10 ** rng.uniform(3.5, 6)))
    elif kind == "huge_top":
        g = P.hexagonal(top_radius=float(10 ** rng.uniform(3.5, 6)))
    elif kind == "joint_near_90":
        g = P.hexagonal(joint_min=float(rng.uniform(1.4, math.pi / 2 - 1e-9)))
    elif kind == "thin_legs":
        g = P.hexagonal(leg_min=300.0, leg_max=300.0 + float(10 ** rng.uniform(-9, -2)))
    else:
        g = P.hexagonal(base_radius=1.0, top_radius=1.0, leg_min=1.0, leg_max=1.0 + 1e-6)
    stack = sk.Stack.uniform(g, n)
    # huge radii: the base nodes are > 2 leg_max apart, so no leg pair can meet a plate
    proven = kind in ("huge_base", "huge_top")
    y = (float(rng.uniform(-100, 100)), float(rng.uniform(0.5, 1.0)) * n * g.leg_max, 0.0)
    planar = rng.random() < 0.8
    target: Any = PlanarTarget(*y, phi=0.3)
    if not planar:
        target = target.to_spatial()
    kw = random_solver(rng, planar, n)
    return Case(
        "infeasible_geometry",
        f"{kind} n={n} {'planar' if planar else 'spatial'} {_kw_label(kw)}",
        lambda: (stack, target, kw),
        unreachable=proven,
        info={"n": n, "method": kw.get("method", "sqp"), "kind": kind},
    )


#: bad_args kinds that currently raise something other than ValueError (library bugs, see
#: the xfail tests in test_fuzz.py); the hypothesis tests skip them, the soak keeps them.
KNOWN_BAD_ARGS_BUGS = ("rng_str",)


def gen_bad_args(rng: np.random.Generator, exclude: tuple[str, ...] = ()) -> Case:
    """Unknown names, bad counts and malformed options / sigma values."""
    n = int(rng.choice([1, 2, 3]))
    stack = sk.Stack.reference(n)
    t = PlanarTarget(0.0, 330.0 * n, 0.1)
    choices: list[tuple[str, Any]] = [
        ("method", {"method": "newton"}),
        ("objective", {"objective": "fn"}),
        ("qp_solver", {"qp_solver": "no-such-qp"}),
        ("qp_solver_type", {"qp_solver": 3}),
        ("starts_zero", {"starts": 0}),
        ("starts_neg", {"starts": -2}),
        ("starts_bool", {"starts": True}),
        ("starts_float", {"starts": 2.5}),
        ("start", {"start": "random"}),
        ("weighted_no_sigma", {"objective": "weighted"}),
        ("sigma_neg", {"objective": "weighted", "sigma_t": -1.0, "sigma_theta": 0.1}),
        ("sigma_theta_zero", {"objective": "weighted", "sigma_t": 1.0, "sigma_theta": 0.0}),
        ("sigma_shape", {"objective": "weighted", "sigma_t": [1.0] * (n + 1), "sigma_theta": 0.1}),
        ("max_iter_zero", {"options": {"max_iter": 0}}),
        ("max_iter_float", {"options": {"max_iter": 2.5}}),
        ("tol_neg", {"options": {"tol": -1.0}}),
        ("hessian_name", {"options": {"hessian": "magic"}}),
        ("unknown_option", {"options": {"max_iterations": 5}}),
        ("max_time_str", {"max_time": "fast"}),
        ("max_time_nan", {"method": "slsqp", "max_time": math.nan}),
        ("max_time_zero", {"max_time": 0.0}),
        ("max_time_negative", {"method": "trust-constr", "max_time": -1.0}),
        ("rng_str", {"starts": 2, "rng": "seed"}),
        ("stack_type", {}),
        ("target_type", {}),
    ]
    choices = [c for c in choices if c[0] not in exclude]
    name, kw = choices[int(rng.integers(0, len(choices)))]

    def make() -> Built:
        if name == "stack_type":
            return [sk.PlatformGeometry.reference()] * n, t, {}
        if name == "target_type":
            return stack, (0.0, 330.0 * n, 0.1), {}
        return stack, t, dict(kw)

    return Case("bad_args", f"{name} n={n}", make, malformed=True, info={"n": n, "kind": name})


def gen_limits(rng: np.random.Generator) -> Case:
    """Short iteration / time limits on reachable and unreachable targets."""
    n = int(rng.choice([1, 2, 3, 4, 6, 8]))
    stack = sk.Stack.reference(n)
    phi = float(rng.choice(PHIS))
    q = feasible_planar_pose(stack, rng, phi)
    assert q is not None
    y = sk.planar_forward(q)
    if rng.random() < 0.3:
        y = np.array([0.0, -0.5 * n * 450.0, 0.0])  # unreachable: solvers run to their limit
    target = PlanarTarget(*(float(v) for v in y), phi=phi)
    kw: dict[str, Any] = {}
    if rng.random() < 0.5:
        kw["starts"] = int(rng.integers(1, 3))
    m = rng.random()
    if m < 0.6:
        kind = "max_iter"
        k = int(rng.integers(1, 6))
        if m < 0.4:
            kw["options"] = {"max_iter": k}
            if rng.random() < 0.5:
                kw["qp_solver"] = str(rng.choice(NATIVE_QP))
        elif m < 0.5:
            kw.update(method="slsqp", options={"maxiter": k})
        else:
            kw.update(method="trust-constr", options={"maxiter": k})
    else:
        kind = "max_time"
        kw["max_time"] = float(rng.choice([1e-3, 0.01, 0.05, 0.2]))
        if rng.random() < 0.3:
            kw["qp_solver"] = str(rng.choice(NATIVE_QP))
        if n >= 6 and kw.get("qp_solver") == "clarabel":
            kw["starts"] = 1  # one clarabel QP can take seconds at n >= 16 (see test_fuzz)
    return Case(
        "limits",
        f"{kind} n={n} {_kw_label(kw)}",
        lambda: (stack, target, kw),
        info={"n": n, "method": kw.get("method", "sqp"), "kind": kind},
    )


def _lift_pose(q: np.ndarray, phi: float) -> np.ndarray:
    """The spatial pose (n, 6) equal to the planar pose ``q`` in the plane ``phi``."""
    from scipy.spatial.transform import Rotation

    P, R = sk.lift_planar(q, phi)
    return np.column_stack([P, Rotation.from_matrix(R).as_euler("ZYX")])


def gen_extreme_x0(rng: np.random.Generator) -> Case:
    """Well-formed but wild warm starts (zeros, huge, negative heights, random)."""
    n = int(rng.choice([1, 2, 3, 4]))
    stack = sk.Stack.reference(n)
    phi = float(rng.choice(PHIS))
    q = feasible_planar_pose(stack, rng, phi)
    assert q is not None
    planar = rng.random() < 0.75
    if planar:
        target: Any = PlanarTarget(*(float(v) for v in sk.planar_forward(q)), phi=phi)
    else:
        target = PlanarTarget(*(float(v) for v in sk.planar_forward(q)), phi=phi).to_spatial()
    k = 3 if planar else 6
    kind = str(rng.choice(["zeros", "big", "huge", "negative_z", "random", "solution"]))
    x0 = {
        "zeros": lambda: np.zeros((n, k)),
        "big": lambda: np.full((n, k), 1e8),
        "huge": lambda: np.full((n, k), 1e150) * rng.choice([-1, 1], (n, k)),
        "negative_z": lambda: np.tile([0.0, -300.0] + [0.0] * (k - 2), (n, 1)),
        "random": lambda: rng.standard_normal((n, k)) * 10 ** rng.uniform(0, 4),
        "solution": lambda: q if planar else _lift_pose(q, phi),
    }[kind]()
    kw = random_solver(rng, planar, n)
    kw["x0"] = x0
    if kw.get("method") == "trust-constr":
        kw["options"] = {"maxiter": 100}
    return Case(
        "extreme_x0",
        f"{kind} n={n} {'planar' if planar else 'spatial'} {_kw_label(kw, skip=('x0',))}",
        lambda: (stack, target, kw),
        info={"n": n, "method": kw.get("method", "sqp"), "kind": kind},
    )


def gen_convex_start(rng: np.random.Generator) -> Case:
    """``start="convex"`` on reachable targets (planar and spatial)."""
    n = int(rng.choice([1, 2, 3, 4]))
    stack = sk.Stack.reference(n)
    phi = float(rng.choice(PHIS))
    q = feasible_planar_pose(stack, rng, phi)
    assert q is not None
    u = rng.random()
    if u < 0.5:  # reachable
        y = tuple(float(v) for v in sk.planar_forward(q))
    elif u < 0.75:  # anywhere in a box (reachable or not)
        y = (rng.uniform(-300, 300) * n, rng.uniform(0, 450) * n, rng.uniform(-1, 1))
    else:  # too low
        y = (0.0, -rng.uniform(0, 200) * n, 0.0)
    target: Any = PlanarTarget(*y, phi=phi)
    if rng.random() < 0.3:
        target = target.to_spatial()
    kw = {"start": "convex", "max_time": 5.0}
    return Case(
        "convex_start",
        f"n={n} {'planar' if isinstance(target, PlanarTarget) else 'spatial'}",
        lambda: (stack, target, kw),
        info={"n": n, "method": "sqp"},
    )


def _kw_label(kw: dict[str, Any], skip: tuple[str, ...] = ()) -> str:
    parts = []
    for key in sorted(kw):
        if key in skip or key == "max_time" and kw[key] in (5.0, 8.0):
            continue
        v = kw[key]
        if isinstance(v, list):
            v = f"[{len(v)} values]"
        parts.append(f"{key}={v}")
    return " ".join(parts)


#: Soak mix: category -> (weight, generator).
CATEGORIES: dict[str, tuple[float, Callable[[np.random.Generator], Case]]] = {
    "reachable_planar": (0.27, gen_reachable_planar),
    "reachable_spatial": (0.09, gen_reachable_spatial),
    "clearance_spatial": (0.05, gen_clearance_spatial),
    "obstacles": (0.05, gen_obstacles),
    "loads": (0.05, gen_loads),
    "random_geometry": (0.10, gen_random_geometry),
    "large_n": (0.035, gen_large_n),
    "unreachable": (0.12, gen_unreachable),
    "infeasible_geometry": (0.04, gen_infeasible_geometry),
    "extreme_x0": (0.06, gen_extreme_x0),
    "limits": (0.09, gen_limits),
    "convex_start": (0.015, gen_convex_start),
    "nonfinite": (0.06, gen_nonfinite),
    "wrong_shape": (0.05, gen_wrong_shape),
    "bad_geometry": (0.03, gen_bad_geometry),
    "bad_args": (0.03, gen_bad_args),
}


def make_case(seed: int, index: int, only: str | None = None) -> Case:
    """Case ``index`` of the campaign ``seed`` (deterministic, independent of other cases);
    ``only``: a case of that category (a campaign of one category)."""
    rng = np.random.default_rng([seed, index])
    if only is not None:
        return CATEGORIES[only][1](rng)
    names = list(CATEGORIES)
    w = np.array([CATEGORIES[k][0] for k in names])
    name = names[int(rng.choice(len(names), p=w / w.sum()))]
    return CATEGORIES[name][1](rng)
