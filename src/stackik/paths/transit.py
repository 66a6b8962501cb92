"""Transit steps shared by both path modes: moving towards a better basin.

A transit step (:meth:`stackik.paths.continuation.Tracker.transit`) is the pose of the
next waypoint within one jump of the current pose nearest a goal pose (least FN^2 plus
distance to the goal). Fast mode takes them to move the path to the basin of a better
default pose (:func:`stackik.paths.reanchor._towards`) and to walk a detour back from a
waypoint its branch does not reach (:func:`stackik.paths.fast._rejoin_fast`); global mode
to add transit candidates towards better default poses and to walk back from the
cheapest candidate when the cheapest sequence ends (:class:`stackik.paths.global_._Sweep`).
A transit that does not come :data:`TRANSIT_PROGRESS` jumps closer to its goal per step is
given up (:func:`closer`).

The two gains (when a better basin is worth a transit) differ by mode on purpose:

* fast mode (:data:`FAST_TRANSIT_GAIN`, 1 %) commits its single path to the move: the
  transit steps leave the followed branch (off the optimum, through the ladder, at a
  default solve's cost per check), so only a clearly better basin is worth it;
* global mode (:data:`GLOBAL_TRANSIT_GAIN`, 0.5 %) only adds transit candidates, which
  the dynamic programming keeps or drops by cost: a smaller gain costs some candidates,
  not the path (fast mode compares FN, global mode FN^2 with ``(1 - gain)^2``: the same
  comparison of FN).

Both values came with the transits themselves (commit e6d8384) and are kept as chosen.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from stackik.paths.continuation import Tracker
from stackik.targets import Target

__all__ = [
    "FAST_TRANSIT_GAIN",
    "GLOBAL_TRANSIT_GAIN",
    "TRANSIT_COOLDOWN",
    "TRANSIT_GAIN",
    "TRANSIT_PROGRESS",
    "TRANSIT_STEPS",
    "closer",
]

FloatArray = NDArray[np.float64]

#: Transit steps per attempt to reach a better basin (each must bring it
#: TRANSIT_PROGRESS jumps closer).
TRANSIT_STEPS = 10
#: Least progress of a transit step towards its goal [max_jump].
TRANSIT_PROGRESS = 0.25
#: Fast mode: at the reanchoring checks (``reanchor_every``, backing off) the default
#: solve is compared with the path, which moves to the default pose's basin when its FN
#: is lower by this fraction.
FAST_TRANSIT_GAIN = 0.01
#: Global mode: a default pose that no candidate reaches within max_jump is approached by
#: transit steps when its FN is lower than every reachable candidate's by this fraction
#: (one transit at a time; after one gives up, none starts for TRANSIT_COOLDOWN waypoints).
GLOBAL_TRANSIT_GAIN = 0.005
#: The global gain's name before the two gains had one home (kept for old imports).
TRANSIT_GAIN = GLOBAL_TRANSIT_GAIN
TRANSIT_COOLDOWN = 5


def closer(
    tracker: Tracker, q: FloatArray, target: Target, goal: FloatArray, dist: float
) -> tuple[FloatArray, float] | None:
    """A transit step from ``q`` to ``target`` towards ``goal`` that ends more than
    :data:`TRANSIT_PROGRESS` jumps closer to ``goal`` than ``dist``: ``(pose, its distance
    to goal [max_jump])``, or None (no transit pose, or not closer enough: give up).
    ``dist = inf`` for a transit's first step (any transit pose counts)."""
    qt = tracker.transit(q, target, goal)
    if qt is None:
        return None
    d = tracker.ratio(qt, goal)
    return (qt, d) if d < dist - TRANSIT_PROGRESS else None
