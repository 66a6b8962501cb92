"""The test-only constraint family (issue 25's proof that a family is one definition per
mode plus a registration, from outside the package): every plate's origin at least ``h``
mm above the base plane. Used by ``tests/test_families.py`` and
``benchmarks/bench_families.py``."""

from __future__ import annotations

import numpy as np

import stackik
from stackik import ConstraintFamily, register_family


@register_family
class PlateHeight(ConstraintFamily):
    """Every plate's origin at least ``h`` [mm] above the base plane: one row per
    platform, ``z_i - h >= 0`` [mm]."""

    name = "test_plate_height"

    def __init__(self, h: float) -> None:
        self.h = float(h)

    def planar_rows(self, stack, q, phi):
        n = q.shape[0]
        c = np.empty(n)
        J = np.zeros((n, 3 * n))
        for i in range(n):  # plate i's origin: the end effector of platforms 0..i
            y = stackik.planar_forward(q[: i + 1])
            c[i] = y[1] - self.h
            J[i, : 3 * (i + 1)] = stackik.planar_jacobian(q[: i + 1])[1]
        return c, J

    def spatial_rows(self, stack, q):
        n = q.shape[0]
        c = np.empty(n)
        J = np.zeros((n, 6 * n))
        for i in range(n):
            P, _ = stackik.spatial_forward(q[: i + 1])
            c[i] = P[2] - self.h
            J[i, : 6 * (i + 1)] = stackik.spatial_jacobian(q[: i + 1])[2]
        return c, J

    def check_values(self, stack, q, phi):
        """Independent of the rows: the plate origins of the forward kinematics."""
        if phi is None:
            return stackik.spatial_plate_origins(q)[1:, 2] - self.h
        return stackik.planar_plate_origins(q)[1:, 1] - self.h
