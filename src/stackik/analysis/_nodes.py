"""Plate frames and leg end points of a pose (shared by the figures and the HTML view)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.geometry import Stack
from stackik.kinematics import lift_planar
from stackik.rotations import euler_zyx

__all__ = ["stack_nodes"]

FloatArray = NDArray[np.float64]


def stack_nodes(stack: Stack, q: ArrayLike, phi: float | None = None) -> dict[str, FloatArray]:
    """3D plate frames and node positions of a pose in the base frame.

    Parameters
    ----------
    stack : Stack
    q : array_like, shape (n, 3) planar (then ``phi`` is required) or (n, 6) spatial
    phi : float, optional
        Plane azimuth of a planar pose [rad].

    Returns
    -------
    dict with
        ``O`` (n+1, 3) plate origins [mm], ``A`` (n+1, 3, 3) plate orientations,
        ``base`` (n, 6, 3) and ``top`` (n, 6, 3) world leg end points of each platform [mm].
    """
    qa = np.asarray(q, dtype=float)
    if qa.shape[-1] == 3:
        if phi is None:
            raise ValueError("phi is required for a planar pose")
        P, R = lift_planar(qa, phi)
    else:
        P, R = qa[:, :3], euler_zyx(qa[:, 3:])
    n = stack.n
    O = np.zeros((n + 1, 3))
    A = np.zeros((n + 1, 3, 3))
    A[0] = np.eye(3)
    for i in range(n):
        O[i + 1] = O[i] + A[i] @ P[i]
        A[i + 1] = A[i] @ R[i]
    base = O[:-1, None, :] + np.einsum("nij,nkj->nki", A[:-1], stack.base_nodes)
    top = O[1:, None, :] + np.einsum("nij,nkj->nki", A[1:], stack.top_nodes)
    return {"O": O, "A": A, "base": base, "top": top}
