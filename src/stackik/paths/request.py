"""The validated request of a path solve (:func:`stackik.paths.solve_path`'s input checks).

:class:`_Request` holds the checked inputs and the defaults filled in (the reanchoring
schedule's ``reanchor_every``, the seed drawn from ``rng``); its :meth:`_Request.key` is
the problem's identity for checkpoints and :meth:`_Request.default_solve` the memoised
default solve of a waypoint that both modes and the break diagnosis share.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from stackik._threads import resolve as resolve_threads
from stackik.check import check_pose
from stackik.families import as_families
from stackik.formulation.clearance import Clearance, clearance_of
from stackik.geometry import Stack
from stackik.loads import Load
from stackik.paths.interpolate import _pair, as_waypoints
from stackik.solve import solve_ik
from stackik.targets import PlanarTarget, Target, target_to_dict

__all__ = ["MODES", "REANCHOR_EVERY", "REANCHOR_PER_N", "SPATIAL_REANCHOR_N"]

FloatArray = NDArray[np.float64]

MODES = ("fast", "global")
#: Default ``reanchor_every``: ``max(REANCHOR_EVERY, REANCHOR_PER_N * n)`` waypoints
#: (the default solve's starts grow with n: planar 3 at n = 4, 19 at n = 8, 35 at n = 16;
#: this keeps its share of a fast path's time small); spatial paths up to
#: ``SPATIAL_REANCHOR_N`` platforms only (then 8 starts, ~10 ms, about 20 warm steps, at
#: n = 4; from n = 5 12 starts and hops, ~100 ms at n = 8 on 2026-12-06, where a check at waypoint
#: 40 of the benchmark's and 4 held-out 60-waypoint paths gave no lower FN (mean ratio
#: 1.0107 -> 1.0113 and 1.0025 -> 1.0027) at 60-70 % of the speed, with the 18 starts
#: and 12 hops of the plan then).
REANCHOR_EVERY = 20
REANCHOR_PER_N = 5
SPATIAL_REANCHOR_N = 4


@dataclass(frozen=True)
class _Request:
    stack: Stack
    targets: list[Target]
    planar: bool
    k: int
    max_jump: tuple[float, float]
    mode: str
    motion_weight: float
    refine: bool
    max_depth: int
    start: FloatArray | None
    leg_speed: float | None
    leg_accel: float | None
    max_candidates: int
    seed: int | None
    reanchor_every: int
    #: the margin [mm] and obstacles every waypoint keeps clear (solve_ik's)
    clear: Clearance = field(default_factory=Clearance)
    #: the load the leg forces carry (solve_ik's): every waypoint within the force limits
    load: Load | None = None
    #: the user's constraint families every waypoint keeps (solve_ik's ``constraints``)
    constraints: tuple[Any, ...] = ()
    #: solve_ik's ``threads`` for the default solves (not the problem's identity: the
    #: poses do not depend on it)
    threads: int | None = None
    memo: dict[Any, Any] = field(default_factory=dict, compare=False, repr=False)

    @property
    def clear_kw(self) -> dict[str, Any]:
        """``obstacles``, ``clearance``, ``load`` and ``constraints`` keywords for
        solve_ik, the Tracker and the bounded steps."""
        return {
            "obstacles": self.clear.obstacles,
            "clearance": self.clear.margin,
            "load": self.load,
            "constraints": self.constraints,
        }

    def key(self) -> dict[str, Any]:
        """JSON-ready identity of the problem (for checkpoints)."""
        return {
            "stack": self.stack.to_dict(),
            "targets": [target_to_dict(t) for t in self.targets],
            "max_jump": list(self.max_jump),
            "mode": self.mode,
            "motion_weight": self.motion_weight,
            "refine": self.refine,
            "max_depth": self.max_depth,
            "start": None if self.start is None else self.start.tolist(),
            "max_candidates": self.max_candidates,
            "seed": self.seed,
            "reanchor_every": self.reanchor_every,
            # (only when given: a checkpoint without them keeps its identity)
            **(
                {
                    "obstacles": [o.to_dict() for o in self.clear.obstacles],
                    "clearance": self.clear.margin,
                }
                if self.clear.obstacles or self.clear.margin
                else {}
            ),
            **({} if self.load is None else {"load": _load_key(self.load)}),
            **(
                {"constraints": [_family_key(f) for f in self.constraints]}
                if self.constraints
                else {}
            ),
        }

    def default_solve(self, target: Target, index: int) -> Any:
        """The default multi-start solve of waypoint ``index`` (memoised: a break's
        diagnosis reuses the rejoin attempt's solve)."""
        key = (index, json.dumps(target_to_dict(target)))
        if key not in self.memo:
            rng = None if self.seed is None else self.seed + index
            self.memo[key] = solve_ik(
                self.stack, target, rng=rng, threads=self.threads, **self.clear_kw
            )
        return self.memo[key]


def _request(
    stack: Any,
    targets: Any,
    max_jump: Any,
    mode: Any,
    motion_weight: Any,
    refine: Any,
    max_depth: Any,
    start: Any,
    leg_speed: Any,
    leg_accel: Any,
    max_candidates: Any,
    rng: Any,
    reanchor_every: Any,
    obstacles: Any = (),
    clearance: Any = 0.0,
    load: Any = None,
    constraints: Any = (),
    threads: Any = None,
) -> _Request:
    if not isinstance(stack, Stack):
        raise ValueError(f"stack: expected a Stack, got {type(stack).__name__}")
    if load is not None and not isinstance(load, Load):
        raise ValueError(f"load: expected a stackik.Load or None, got {type(load).__name__}")
    pts = as_waypoints(targets)
    planar = isinstance(pts[0], PlanarTarget)
    k = 3 if planar else 6
    clear = clearance_of(stack, planar, clearance, obstacles)
    fams = as_families(constraints)
    mj = _pair(max_jump, "max_jump")
    if mode not in MODES:
        raise ValueError(f"mode: unknown {mode!r}; choose one of {MODES}")
    try:
        w = float(motion_weight)
    except (TypeError, ValueError):
        raise ValueError(f"motion_weight: expected a number, got {motion_weight!r}") from None
    if not math.isfinite(w) or w < 0:
        raise ValueError(f"motion_weight: must be finite and >= 0, got {motion_weight!r}")
    if not isinstance(refine, bool):
        raise ValueError(f"refine: expected True or False, got {refine!r}")
    if isinstance(max_depth, bool) or not isinstance(max_depth, int) or not 0 <= max_depth <= 12:
        raise ValueError(f"max_depth: expected an integer in 0..12, got {max_depth!r}")
    if (
        isinstance(max_candidates, bool)
        or not isinstance(max_candidates, int)
        or max_candidates < 1
    ):
        raise ValueError(f"max_candidates: expected an integer >= 1, got {max_candidates!r}")
    if (leg_speed is None) != (leg_accel is None):
        raise ValueError("leg_speed and leg_accel: give both (mm/s, mm/s^2) or neither")
    speeds: list[float | None] = [None, None]
    for j, (name, v) in enumerate((("leg_speed", leg_speed), ("leg_accel", leg_accel))):
        if v is not None:
            try:
                fv = float(v)
            except (TypeError, ValueError):
                raise ValueError(f"{name}: expected a number, got {v!r}") from None
            if not math.isfinite(fv) or fv <= 0:
                raise ValueError(f"{name}: must be finite and > 0, got {v!r}")
            speeds[j] = fv
    q0 = None if start is None else _start_pose(stack, pts[0], k, start, clear, load, fams)
    if reanchor_every is None:
        reanchor_every = max(REANCHOR_EVERY, REANCHOR_PER_N * stack.n)
        if not planar and stack.n > SPATIAL_REANCHOR_N:
            reanchor_every = 0
    if (
        isinstance(reanchor_every, bool)
        or not isinstance(reanchor_every, int)
        or reanchor_every < 0
    ):
        raise ValueError(
            f"reanchor_every: expected an integer >= 0 or None, got {reanchor_every!r}"
        )
    seed = None
    if rng is not None:
        try:
            seed = int(np.random.default_rng(rng).integers(2**31))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"rng: expected None, an int seed or a Generator ({exc})") from None
    return _Request(
        stack, pts, planar, k, mj, mode, w, refine, max_depth, q0, speeds[0], speeds[1],
        max_candidates, seed, reanchor_every, clear, load, fams,
        None if threads is None else resolve_threads(threads),
    )  # fmt: skip


def _family_key(f: Any) -> dict[str, Any]:
    """A constraint family's identity for checkpoints: its class and its attributes
    (arrays in full: their repr elides the middle of a large one)."""
    state = {
        k: np.asarray(v).tolist() if isinstance(v, np.ndarray) else repr(v)
        for k, v in sorted(vars(f).items())
    }
    return {"class": f"{type(f).__module__}.{type(f).__qualname__}", "state": state}


def _load_key(load: Load) -> dict[str, Any]:
    """A load's identity for checkpoints (plain data)."""
    g = load.gravity
    return {
        "force": np.asarray(load.force, dtype=float).tolist(),
        "moment": np.asarray(load.moment, dtype=float).tolist(),
        "frame": load.frame,
        "mass": float(load.mass),
        "com": np.asarray(load.com, dtype=float).tolist(),
        "gravity": g if isinstance(g, str) else np.asarray(g, dtype=float).tolist(),
    }


def _start_pose(
    stack: Stack,
    target: Target,
    k: int,
    start: Any,
    clear: Clearance,
    load: Load | None,
    constraints: tuple[Any, ...] = (),
) -> FloatArray:
    """``start`` as a pose that passes the check for the first waypoint, or a ValueError."""
    try:
        q0 = np.array(start, dtype=float)
    except (TypeError, ValueError):
        raise ValueError("start: expected an array of numbers") from None
    if q0.shape != (stack.n, k) or not np.all(np.isfinite(q0)):
        raise ValueError(f"start: expected finite values of shape ({stack.n}, {k}), got {q0.shape}")
    chk = check_pose(
        stack, target, q0, load, obstacles=clear.obstacles, clearance=clear.margin,
        constraints=constraints,
    )  # fmt: skip
    if not chk.ok:
        raise ValueError(
            "start: the pose does not reach targets[0] within every limit, force limit and "
            "clearance "
            f"(position error {chk.position_error:.3g} mm, angle error "
            f"{chk.angle_error:.3g} rad, worst violation {chk.violation_mm:.3g} mm)"
        )
    return q0
