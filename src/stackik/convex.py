"""Convex restriction of the IK problem (DESIGN §6): a feasible start from an SOCP.

With every platform rotation fixed, the forward kinematics are linear in the translations,
``FN^2`` is a convex quadratic in them, ``|l| <= leg_max`` and both joint-angle limits
(``|l| sin(joint_min) <= l.n`` and ``<= l.(R n)``) are second-order cones, and
``|l| >= leg_min`` is replaced by the linear ``u.l >= leg_min`` for a unit vector ``u``
(which implies it). Any solution of this SOCP is therefore feasible for the true problem.
Solved with cvxpy + Clarabel.
"""

from __future__ import annotations

from typing import Any, NamedTuple

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


class _Fixed(NamedTuple):
    """The IK problem with every rotation fixed: the end effector is ``sum_i W[i] p[i]``."""

    R: FloatArray  # (n, 3, 3) platform rotations
    M: FloatArray  # (3, dim): a platform's translation in its base frame is M p
    W: FloatArray  # (n, dim, dim): world contribution of platform i is W[i] p[i]
    goal: FloatArray  # (dim,) target position
    p0: FloatArray  # (n, dim) the guess's translations
    rotations: FloatArray  # the pose's rotation columns: (n, 1) planar, (n, 3) spatial


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

    guess = paper_initial_guess(stack, target)
    # the two modes' kinematics differ in kind (a plane's 2D chain, 3D frames); a Mode
    # method would drag cvxpy's problem set-up into formulation/modes.py
    if isinstance(target, PlanarTarget):
        fixed = _planar_fixed(stack.n, target, guess, rotations)
    else:
        assert isinstance(target, SpatialTarget)
        fixed = _spatial_fixed(stack.n, target, guess, rotations)
    n, dim = fixed.p0.shape
    p = cp.Variable((n, dim))
    world = [fixed.W[i] @ p[i] for i in range(n)]
    cons = [sum(world) == fixed.goal] + _leg_cones(stack, fixed, p, margin)
    prob = cp.Problem(_fn2_objective(world), cons)
    try:
        prob.solve(solver=solver)
    except cp.error.SolverError as exc:
        raise ConvexStartError(f"convex start: solver failed ({exc})") from None
    if prob.status not in ("optimal", "optimal_inaccurate") or p.value is None:
        raise ConvexStartError(f"convex start: SOCP is {prob.status} for these rotations")
    q = guess.copy()
    q[:, :dim] = p.value
    q[:, dim:] = fixed.rotations
    return q


def _planar_fixed(
    n: int, target: PlanarTarget, guess: FloatArray, rotations: ArrayLike | None
) -> _Fixed:
    """Planar: translations ``(rho_i, z_i)`` in the plane ``phi``, angles ``theta_i`` fixed."""
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
    return _Fixed(R, M, W, np.array([target.rho, target.z]), guess[:, :2], th[:, None])


def _spatial_fixed(
    n: int, target: SpatialTarget, guess: FloatArray, rotations: ArrayLike | None
) -> _Fixed:
    """Spatial: translations (x, y, z), Euler angles fixed."""
    eul = guess[:, 3:] if rotations is None else np.asarray(rotations, dtype=float)
    if eul.shape != (n, 3):
        raise ValueError(f"rotations: expected shape ({n}, 3), got {eul.shape}")
    R = euler_zyx(eul)
    A = [np.eye(3)]
    for i in range(n - 1):
        A.append(A[-1] @ R[i])
    return _Fixed(R, np.eye(3), np.array(A), target.position, guess[:, :3], eul)


def _fn2_objective(world: list[Any]) -> Any:
    """``FN^2 - const = sum_{j<n} |sum_{k>j} world_k|^2`` as a cvxpy objective."""
    import cvxpy as cp

    tails = []
    acc = None
    for k in range(len(world) - 1, 0, -1):
        acc = world[k] if acc is None else acc + world[k]
        tails.append(acc)
    return cp.Minimize(sum(cp.sum_squares(t) for t in tails)) if tails else cp.Minimize(0)


def _leg_cones(stack: Stack, fixed: _Fixed, p: Any, margin: float) -> list[Any]:
    """Leg length and joint-angle limits as cones (``|l| >= leg_min`` made linear)."""
    import cvxpy as cp

    cons = []
    ez = np.array([0.0, 0.0, 1.0])
    M = fixed.M
    for i in range(stack.n):
        b, t = stack.base_nodes[i], stack.top_nodes[i]
        Rt = t @ fixed.R[i].T  # (6, 3)
        Rn = fixed.R[i] @ ez
        s_j = stack.sin_joint_min[i]
        l0 = Rt + M @ fixed.p0[i] - b
        u = l0 / np.linalg.norm(l0, axis=1, keepdims=True)
        for k in range(6):
            lk = Rt[k] - b[k] + M @ p[i]
            cons += [
                cp.norm(lk) <= stack.leg_max[i] - margin,
                u[k] @ lk >= stack.leg_min[i] + margin,
                s_j * cp.norm(lk) + margin <= ez @ lk,
                s_j * cp.norm(lk) + margin <= Rn @ lk,
            ]
    return cons
