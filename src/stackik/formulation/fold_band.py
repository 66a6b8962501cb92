"""A planar fold kept from curling back on itself: rows that make the bodies of
non-adjacent platforms clear by construction (docs/clearance.md, "Taller stacks").

The least-FN planar pose of a tall stack reaches toward the target with its lower
platforms and packs the surplus ones into a *fold* below the end effector; on legs of a
size the fold's platforms pass through each other, and the interior point with the
non-adjacent bodies' rows (:func:`stackik.solve.stages._unfold`) often ends folded again
from n = 32 on. The rows here keep each fold platform's plate nearly parallel to the end
effector's: for every platform ``i`` of the fold

    band - |Theta_i - theta_t| >= 0   and   tilt - |theta_i| >= 0   [rad]

with ``Theta_i`` the plate's absolute angle in the plane (the sum of the relative turns
``theta_0 + ... + theta_i``), ``theta_t`` the target's and ``theta_i`` the platform's
own turn. Plates that are nearly parallel are stacked along their common normal, each
platform at least its least height above the one below (125 mm on the reference
geometry), so two platforms with a third between them are separated by that platform,
and the fold cannot come back on itself: the pose is clear unless ``band`` is too wide
for the plates' size. The check's exact distances decide; the rows are a start, not a
guarantee, and they are never part of the user's problem: the solve re-checks the pose on
the problem without them.

``fold_platforms`` finds the fold of a pose: every platform that stands on the lowest
plate of a pair of bodies of non-adjacent platforms within :data:`FOLD_SCREEN_MM` of
their least distance (touching or passing through each other), and every platform above
it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from stackik.families import ConstraintFamily

if TYPE_CHECKING:
    from stackik.geometry import Stack

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: When no run of a planar batch passes and its runs folded into themselves, the lowest
#: folded run's fold is kept within a band [rad] of the end effector's angle with each of
#: its platforms turning at most a tilt [rad] (:class:`FoldBand`,
#: :func:`stackik.solve.stages._fold_band`): these ``(band, tilt)`` pairs, tried in this
#: order until one gives a clear pose (a wider band, a lower FN; a narrower one, clear
#: more often). On the 12 mm reference stacks (seed 8461, 5 targets each at n = 16, 32
#: and 64, from the paper's guess and the folded pose): (0.5, 0.4) clear on 5, 5 and 2
#: of them, 0.2-4.4 % above the zero-radius FN, (0.35, 0.3) on all 15, 0.3-31 % above;
#: (0.6, 0.4) on none at n = 64, (0.7, 0.5) on none at n = 32 (docs/clearance.md,
#: ``benchmarks/tall_clear_probe.py``). On legs of no size (seed 349716, n = 64, target
#: 2, where both gave no pose from the paper's guess or the folded pose and the solve ran
#: out of time): from the upright pose (0.35, 0.3) is clear (+2.1 % over the pose through
#: plates), and (0.25, 0.2) from the folded and the upright pose (+2.7-3.2 %); so the band
#: also starts upright, and (0.25, 0.2) comes last.
FOLD_BANDS = ((0.5, 0.4), (0.35, 0.3), (0.25, 0.2))
#: From this many platforms on, a planar batch whose runs folded goes to the fold band
#: first, and makes its folded runs again with the non-adjacent bodies' rows
#: (:func:`stackik.solve.stages._unfold_batch`) only when the band gives no pose
#: (:meth:`Mode.band_first <stackik.formulation.modes.Mode.band_first>`). On the tall
#: targets of two fresh seeds (15583: n = 32 and 64, 14 targets; 349716: 20) the
#: unfolds before the band gave the answer on none: the same pose on 29 of 34, lower
#: without them on 2 (-4.4 % and -0.004 %), higher on 3 (+0.03 to +0.53 %), each solve
#: 2-10x faster; at n = 16 they do give the answer (on 12 of 20 targets of seed 15583 a
#: pose lower by up to 2.7 %). Where the band fails they still rescue a pose (seed
#: 698528, n = 64: 3 of 10 targets, 19-59 s).
FOLD_BAND_FIRST_N = 32
#: The fold of a folded pose: the platforms from the lowest plate of a pair of bodies of
#: non-adjacent platforms within this [mm] of their least distance (:func:`fold_platforms`):
#: 0, the pairs that touch or pass through each other. With the unfold's 20 mm
#: (:data:`~stackik.solve.policy.UNFOLD_SCREEN_MM`) a compact n = 32 target (seed 9461,
#: target 4) had a pair near the base plate, the fold was the whole stack and no band gave
#: a pose; its colliding pairs start at plate 13, and that fold's band gives a clear pose
#: 3.9 % above the zero-radius FN. The other 19 targets of seeds 8461 and 9461 (n = 16,
#: 32, 64) keep their fold within one platform.
FOLD_SCREEN_MM = 0.0


class FoldBand(ConstraintFamily):
    """The fold's rows (module doc), planar only: ``4 m`` rows for the ``m`` platforms
    ``fold`` (indices, ascending), values in rad.

    Parameters
    ----------
    fold : sequence of int
        The fold's platforms (0-based).
    band : float
        Largest ``|Theta_i - theta_t|`` [rad].
    tilt : float
        Largest ``|theta_i|`` [rad].
    theta_t : float
        The target's angle in the plane [rad].
    """

    name = "fold_band"

    def __init__(self, fold: Any, band: float, tilt: float, theta_t: float) -> None:
        self.fold = np.asarray(fold, dtype=np.int64)
        if self.fold.ndim != 1 or self.fold.size == 0:
            raise ValueError("fold: expected a non-empty sequence of platform indices")
        self.band, self.tilt, self.theta_t = float(band), float(tilt), float(theta_t)

    def planar_rows(self, stack: Stack, q: FloatArray, phi: float) -> tuple[FloatArray, FloatArray]:
        """Values (4 m,) [rad] and their Jacobian (4 m, 3 n) against the pose ``q`` (n, 3):
        ``band -+ (Theta_i - theta_t)`` then ``tilt -+ theta_i``, each block in the order
        of ``fold``."""
        q = np.asarray(q, dtype=float).reshape(-1, 3)
        m, n = self.fold.size, q.shape[0]
        absolute = np.cumsum(q[:, 2])[self.fold] - self.theta_t
        own = q[self.fold, 2]
        c = np.concatenate([self.band - absolute, self.band + absolute,
                            self.tilt - own, self.tilt + own])  # fmt: skip
        J = np.zeros((4 * m, 3 * n))
        for r, i in enumerate(self.fold):
            J[r, 2 : 3 * (i + 1) : 3] = -1.0  # d Theta_i / d theta_j = 1 for j <= i
            J[m + r, 2 : 3 * (i + 1) : 3] = 1.0
            J[2 * m + r, 3 * i + 2] = -1.0
            J[3 * m + r, 3 * i + 2] = 1.0
        return c, J

    def row_scale(self, stack: Stack) -> float:
        """The rows are angles [rad]: unscaled."""
        return 1.0


def fold_platforms(
    stack: Stack, q: FloatArray, margin: float, phi: float, screen: float
) -> IntArray | None:
    """The fold of the planar pose ``q`` (n, 3): the platform standing on the lowest plate
    (plate ``j`` is the base of platform ``j``) of a pair of bodies of non-adjacent
    platforms within ``screen`` [mm] of their least distance (``margin`` [mm] included),
    and every platform above it (int64, ascending), or None when no pair comes that
    close."""
    from stackik.formulation.leg_pairs import close_pairs, pair_table

    near = close_pairs(stack, [np.asarray(q, dtype=float).reshape(-1, 3)], margin, phi, screen)
    if near.size == 0:
        return None
    table = pair_table(stack)
    lowest = int(table.plates[table.pairs[near]].min())
    return np.arange(min(lowest, stack.n - 1), stack.n, dtype=np.int64)
