"""Rows for the bodies of non-adjacent platforms (numba), the one definition of the family
(:mod:`stackik.formulation.leg_pairs` documents it and wraps this kernel).

Every body is a set of segments whose two ends are fixed on plates: segment ``e`` runs from
``X_0 = O_{p_0} + A_{p_0} x_0`` to ``X_1 = O_{p_1} + A_{p_1} x_1`` (``plates[e] = (p_0, p_1)``,
``points[e] = (x_0, x_1)`` in those plates' frames [mm]; plate frames as
:func:`stackik._compiled.obstacle_rows._frames`): a leg ``k`` of platform ``i`` from plate ``i``
to plate ``i + 1``; a plate's covering segments within that plate. For a pair ``(a, b)`` of
segments the row is ``(d^2 - rho^2) / L^2 >= 0`` with ``d`` the distance of the two
segments at their clamped closest points (:func:`stackik._compiled.self_legs._closest`),
``rho`` the pair's least distance [mm]; its gradient is the envelope rule's
``2 g . ((1 - s) dX_0^a + s dX_1^a - (1 - t) dX_0^b - t dX_1^b) / L^2`` (``g`` from the
closest point of ``b`` to that of ``a``), the points' derivatives those of the obstacle rows
(both modes). No second derivatives.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from stackik._compiled.core import _jit
from stackik._compiled.obstacle_rows import _frames, _joint, _point_jacobian
from stackik._compiled.self_legs import _closest

FloatArray = Any


@_jit
def segment_pair_rows(
    q: FloatArray, plates: FloatArray, points: FloatArray, pairs: FloatArray, rho: FloatArray,
    L: float, planar: bool, phi: float, jacobian: bool,
) -> tuple[FloatArray, FloatArray]:  # fmt: skip
    """Rows ``c`` (m,) and Jacobian ``J`` (m, k n) against the raw pose ``q`` (n, k):
    ``plates`` (S, 2) int64 and ``points`` (S, 2, 3) [mm] the segments (module doc);
    ``pairs`` (m, 2) int64 segment indices; ``rho`` (m,) [mm]; ``L`` the length scale [mm];
    ``planar``, ``phi``: the mode's variables (spatial: False, 0). Without ``jacobian``
    ``J`` is empty (m, 0): the values alone (a screen)."""
    n = q.shape[0]
    k = 3 if planar else 6
    N = k * n
    m = pairs.shape[0]
    c = np.empty(m)
    J = np.zeros((m, N if jacobian else 0))
    if m == 0:
        return c, J
    A, O, w, tdir, angle = _frames(q, planar, phi)
    S = plates.shape[0]
    used = np.zeros(S, dtype=np.bool_)
    for r in range(m):
        used[pairs[r, 0]] = True
        used[pairs[r, 1]] = True
    X0 = np.empty((S, 3))
    X1 = np.empty((S, 3))
    NJ = N if jacobian else 0
    J0 = np.empty((S if jacobian else 0, 3, NJ))
    J1 = np.empty((S if jacobian else 0, 3, NJ))
    for e in range(S):
        if used[e]:
            _joint(A, O, plates[e, 0], points[e, 0], X0[e])
            _joint(A, O, plates[e, 1], points[e, 1], X1[e])
            if jacobian:
                _point_jacobian(X0[e], plates[e, 0], O, w, tdir, angle, k, J0[e])
                _point_jacobian(X1[e], plates[e, 1], O, w, tdir, angle, k, J1[e])
    d1 = np.empty(3)
    d2 = np.empty(3)
    rr = np.empty(3)
    g = np.empty(3)
    LL = L * L
    for r in range(m):
        a = pairs[r, 0]
        b = pairs[r, 1]
        for x in range(3):
            d1[x] = X1[a, x] - X0[a, x]
            d2[x] = X1[b, x] - X0[b, x]
            rr[x] = X0[a, x] - X0[b, x]
        s, t = _closest(d1, d2, rr)
        gg = 0.0
        for x in range(3):
            g[x] = rr[x] + s * d1[x] - t * d2[x]
            gg += g[x] * g[x]
        c[r] = (gg - rho[r] * rho[r]) / LL
        if not jacobian:
            continue
        # columns of platforms above every end's plate move neither segment
        top = k * max(plates[a, 0], plates[a, 1], plates[b, 0], plates[b, 1])
        for v in range(top):
            acc = 0.0
            for x in range(3):
                acc += g[x] * ((1.0 - s) * J0[a, x, v] + s * J1[a, x, v]
                               - (1.0 - t) * J0[b, x, v] - t * J1[b, x, v])  # fmt: skip
            J[r, v] = 2.0 * acc / LL
    return c, J
