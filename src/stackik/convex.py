"""Convex restriction of the IK problem (DESIGN §6): a feasible start from an SOCP.

With every platform rotation fixed, the forward kinematics are linear in the translations,
``FN^2`` is a convex quadratic in them, ``|l| <= leg_max`` and both joint-angle limits
(``|l| sin(joint_min) <= l.n`` and ``<= l.(R n)``) are second-order cones, and
``|l| >= leg_min`` is replaced by the linear ``u.l >= leg_min`` for a unit vector ``u``
(which implies it). Any solution of this SOCP is therefore feasible for the true problem.
Solved with cvxpy + Clarabel.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.geometry import Stack
from stackik.rotations import euler_zyx, plane_axis, rodrigues
from stackik.starts import paper_initial_guess
from stackik.targets import PlanarTarget, SpatialTarget

__all__ = ["ConvexStartError", "convex_start"]

FloatArray = NDArray[np.float64]


class ConvexStartError(RuntimeError):
    """The convex restriction has no solution for the chosen rotations."""


def convex_start(
    stack: Stack,
    target: PlanarTarget | SpatialTarget,
    rotations: ArrayLike | None = None,
    solver: str = "CLARABEL",
    margin: float = 1e-3,
) -> FloatArray:
    """Translations minimising FN^2 with the rotations fixed, feasible for the true problem.

    Parameters
    ----------
    rotations : array_like, optional
        Planar: angles ``theta_i`` (n,) [rad]; spatial: Euler angles (n, 3). Default: the
        paper's even split of the target rotation (:func:`stackik.paper_initial_guess`).
    margin : float
        Every limit is tightened by this much [mm] so that the SOCP solver's own
        tolerance cannot make the pose infeasible.

    Returns
    -------
    q : ndarray, shape (n, 3) or (n, 6)
        A pose whose end effector is at the target's position; in planar mode also at the
        target angle when the rotations sum to it.

    Raises
    ------
    ConvexStartError
        If the SOCP is infeasible or the solver fails.
    """
    import cvxpy as cp

    n = stack.n
    guess = paper_initial_guess(stack, target)
    planar = isinstance(target, PlanarTarget)
    if isinstance(target, PlanarTarget):
        th = guess[:, 2] if rotations is None else np.asarray(rotations, dtype=float)
        if th.shape != (n,):
            raise ValueError(f"rotations: expected shape ({n},), got {th.shape}")
        s = plane_axis(target.phi)
        R = rodrigues(s, th)  # (n, 3, 3)
        e_phi = np.array([np.cos(target.phi), np.sin(target.phi), 0.0])
        M = np.column_stack([e_phi, [0.0, 0.0, 1.0]])  # P_i = M p_i, p_i = (rho_i, z_i)
        Theta = np.cumsum(th) - th
        # world (rho, z) contribution of platform i: Rot2(Theta_i) p_i
        W = np.array([[[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]] for a in Theta])
        P_goal = np.array([target.rho, target.z])
        p0 = guess[:, :2]
        dim = 2
    else:
        assert isinstance(target, SpatialTarget)
        eul = guess[:, 3:] if rotations is None else np.asarray(rotations, dtype=float)
        if eul.shape != (n, 3):
            raise ValueError(f"rotations: expected shape ({n}, 3), got {eul.shape}")
        R = euler_zyx(eul)
        M = np.eye(3)
        A = [np.eye(3)]
        for i in range(n - 1):
            A.append(A[-1] @ R[i])
        W = np.array(A)
        P_goal = target.position
        p0 = guess[:, :3]
        dim = 3
    p = cp.Variable((n, dim))
    world = [W[i] @ p[i] for i in range(n)]
    cons = [sum(world) == P_goal]
    # FN^2 - const = sum_{j<n} |sum_{k>j} world_k|^2
    tails = []
    acc = None
    for k in range(n - 1, 0, -1):
        acc = world[k] if acc is None else acc + world[k]
        tails.append(acc)
    obj = cp.Minimize(sum(cp.sum_squares(t) for t in tails)) if tails else cp.Minimize(0)
    ez = np.array([0.0, 0.0, 1.0])
    for i in range(n):
        b, t = stack.base_nodes[i], stack.top_nodes[i]
        Rt = t @ R[i].T  # (6, 3)
        Rn = R[i] @ ez
        s_j = stack.sin_joint_min[i]
        l0 = Rt + M @ p0[i] - b
        u = l0 / np.linalg.norm(l0, axis=1, keepdims=True)
        for k in range(6):
            lk = Rt[k] - b[k] + M @ p[i]
            cons += [
                cp.norm(lk) <= stack.leg_max[i] - margin,
                u[k] @ lk >= stack.leg_min[i] + margin,
                s_j * cp.norm(lk) + margin <= ez @ lk,
                s_j * cp.norm(lk) + margin <= Rn @ lk,
            ]
    prob = cp.Problem(obj, cons)
    try:
        prob.solve(solver=solver)
    except cp.error.SolverError as exc:
        raise ConvexStartError(f"convex start: solver failed ({exc})") from None
    if prob.status not in ("optimal", "optimal_inaccurate") or p.value is None:
        raise ConvexStartError(f"convex start: SOCP is {prob.status} for these rotations")
    q = guess.copy()
    q[:, :dim] = p.value
    if planar:
        q[:, 2] = th
    else:
        q[:, 3:] = eul
    return q
