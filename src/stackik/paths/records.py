"""Typed records of a path solve: what the two modes keep per waypoint and hand back.

Fast mode keeps a list of :class:`_Waypoint` (the path so far) and a stack of
:class:`_Pending` (the waypoints still to reach, the top next), and moves towards a
:class:`_Goal` when a better basin is found; global mode keeps :class:`_Cand` candidates
per waypoint. Both drivers return an :class:`_Outcome`. The ``record``/``load`` methods
give the JSON form of the checkpoints (:mod:`stackik.paths.replay`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from stackik.paths.result import PathStatus
from stackik.targets import Target

FloatArray = NDArray[np.float64]


class _Waypoint(NamedTuple):
    """A reached waypoint of a fast path: its target, source (its index in the input, or
    the fraction of the way between two for an inserted one), pose and the rung that
    made the pose (``"default"``, ``"start"``, ``"warm"``, ``"bounded"``, ...)."""

    target: Target
    source: float
    q: FloatArray
    how: str


class _Pending(NamedTuple):
    """A waypoint a fast path has still to reach: its target, source and bisection depth
    (0: an input waypoint; more: inserted by ``refine=True``)."""

    target: Target
    source: float
    depth: int


@dataclass(frozen=True)
class _Outcome:
    """What a mode's driver hands to the result: the waypoints (the reached ones, then
    the input ones not reached), their sources, the poses reached, status, message and
    counters."""

    targets: list[Target]
    sources: list[float]
    poses: list[FloatArray]
    status: PathStatus
    message: str
    info: dict[str, Any]


@dataclass(frozen=True)
class _Goal:
    """A better basin a fast path is moving to: its pose at the current waypoint, the
    path's distance to it [max_jump] and the transit steps taken."""

    q: FloatArray
    dist: float
    steps: int

    def record(self) -> list[Any]:
        return [self.q.tolist(), self.dist, self.steps]

    @classmethod
    def load(cls, r: list[Any] | None) -> _Goal | None:
        return None if r is None else cls(np.array(r[0], dtype=float), float(r[1]), int(r[2]))


@dataclass(eq=False)  # identity: candidates hold arrays
class _Cand:
    """A candidate pose of one waypoint in global mode."""

    q: FloatArray
    fn2: float
    origin: str  # "default", "start", "forward", "backward" or "transit"
    how: str = ""  # rung of the continuation that produced it
    steps: int = 0  # transit steps taken (origin "transit")
    goal_dist: float = math.inf  # transit: distance to its goal, in max_jump
    back_done: bool = False  # backward continuation tried

    def record(self) -> list[Any]:
        return [self.q.tolist(), self.fn2, self.origin, self.how, self.steps,
                None if math.isinf(self.goal_dist) else self.goal_dist, self.back_done]  # fmt: skip

    @classmethod
    def load(cls, r: list[Any]) -> _Cand:
        gd = math.inf if r[5] is None else float(r[5])
        return cls(np.array(r[0], dtype=float), float(r[1]), str(r[2]), str(r[3]), int(r[4]),
                   gd, bool(r[6]))  # fmt: skip
