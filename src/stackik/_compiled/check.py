"""Compiled re-check of planar poses: the hot path of ``solve_ik``'s independent check.

A second implementation of DESIGN §1-2 for planar poses, written from the 3D leg vectors
(Rodrigues rotation about ``s(phi)``, leg ``l_k = R t_k + P - b_k``) and sharing no code
with the solver it checks (:mod:`stackik._compiled.planar` works in the plane's basis). It returns
the same numbers as :func:`stackik.check.check_pose` (tested on random poses, feasible and
not, mixed geometries and several phi) in a few microseconds instead of ~50, plus the
per-platform ``P``, ``R`` and leg lengths that :class:`stackik.result.IKResult` reports.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

FloatArray = np.ndarray


@njit(cache=True, nogil=True, error_model="numpy")
def _planar_check(q: FloatArray, phi: float, base: FloatArray, top: FloatArray,
                  leg_min: FloatArray, leg_max: FloatArray, sin_joint: FloatArray,
                  target: FloatArray) -> tuple[Any, ...]:  # fmt: skip
    n = q.shape[0]
    e_phi = np.array([math.cos(phi), math.sin(phi), 0.0])
    s = np.array([math.sin(phi), -math.cos(phi), 0.0])  # plane_axis(phi)
    # forward kinematics in the (rho, z) plane
    th = 0.0
    ox = 0.0
    oz = 0.0
    for i in range(n):
        c = math.cos(th)
        sn = math.sin(th)
        ox += c * q[i, 0] - sn * q[i, 1]
        oz += sn * q[i, 0] + c * q[i, 1]
        th += q[i, 2]
    pos_err = math.hypot(ox - target[0], oz - target[1])
    ang_err = abs(th - target[2])
    # 3D legs of every platform
    P = np.empty((n, 3))
    R = np.empty((n, 3, 3))
    legs = np.empty((n, 6))
    C = np.empty((n, 24))
    for i in range(n):
        ct = math.cos(q[i, 2])
        st = math.sin(q[i, 2])
        for a in range(3):
            for b in range(3):
                R[i, a, b] = (1.0 - ct) * s[a] * s[b] + (ct if a == b else 0.0)
        # + sin(theta) [s]x
        R[i, 0, 1] -= st * s[2]
        R[i, 0, 2] += st * s[1]
        R[i, 1, 0] += st * s[2]
        R[i, 1, 2] -= st * s[0]
        R[i, 2, 0] -= st * s[1]
        R[i, 2, 1] += st * s[0]
        for a in range(3):
            P[i, a] = q[i, 0] * e_phi[a] + (q[i, 1] if a == 2 else 0.0)
        rn0 = R[i, 0, 2]
        rn1 = R[i, 1, 2]
        rn2 = R[i, 2, 2]
        for k in range(6):
            l0 = R[i, 0, 0] * top[i, k, 0] + R[i, 0, 1] * top[i, k, 1] + R[i, 0, 2] * top[i, k, 2]
            l1 = R[i, 1, 0] * top[i, k, 0] + R[i, 1, 1] * top[i, k, 1] + R[i, 1, 2] * top[i, k, 2]
            l2 = R[i, 2, 0] * top[i, k, 0] + R[i, 2, 1] * top[i, k, 1] + R[i, 2, 2] * top[i, k, 2]
            l0 += P[i, 0] - base[i, k, 0]
            l1 += P[i, 1] - base[i, k, 1]
            l2 += P[i, 2] - base[i, k, 2]
            sq = l0 * l0 + l1 * l1 + l2 * l2
            nrm = math.sqrt(sq)
            legs[i, k] = nrm
            C[i, k] = sq - leg_min[i] ** 2
            C[i, 6 + k] = leg_max[i] ** 2 - sq
            C[i, 12 + k] = l2 - nrm * sin_joint[i]
            C[i, 18 + k] = l0 * rn0 + l1 * rn1 + l2 * rn2 - nrm * sin_joint[i]
    # worst violation, raw and as a length (leg blocks: |l| against the limit)
    max_v = 0.0
    v_mm = 0.0
    finite = True
    for i in range(n):
        for r in range(24):
            v = max(-C[i, r], 0.0)
            if not math.isfinite(C[i, r]):
                finite = False
            max_v = max(max_v, v)
            if r < 6:
                vm = leg_min[i] - math.sqrt(max(leg_min[i] ** 2 - v, 0.0))
            elif r < 12:
                vm = math.sqrt(leg_max[i] ** 2 + v) - leg_max[i]
            else:
                vm = v
            v_mm = max(v_mm, vm)
    return pos_err, ang_err, max_v, v_mm, finite, C, P, R, legs


def planar_check(stack: Any, target: Any, q: FloatArray) -> tuple[Any, ...]:
    """``(PoseCheck, P, R, leg_lengths)`` of a planar pose ``q`` (n, 3), finite.

    The :class:`stackik.check.PoseCheck` has the same values and the same acceptance
    rule (:func:`stackik.check.pose_ok`) as :func:`stackik.check.check_pose`.
    """
    from stackik._arrays import readonly  # one compiled specialisation for every caller
    from stackik.check import PoseCheck, pose_ok

    pos_err, ang_err, max_v, v_mm, finite, C, P, R, legs = _planar_check(  # type: ignore[call-arg]
        readonly(q),
        float(target.phi),
        *_limits_args(stack),
        readonly([target.rho, target.z, target.theta]),
    )
    ok = pose_ok(float(pos_err), float(ang_err), float(v_mm), bool(finite))
    chk = PoseCheck(bool(ok), float(pos_err), float(ang_err), float(max_v), float(v_mm), C)
    return chk, P, R, legs


@njit(cache=True, nogil=True, error_model="numpy")
def _planar_check_many(Q: FloatArray, phi: float, base: FloatArray, top: FloatArray,
                       leg_min: FloatArray, leg_max: FloatArray, sin_joint: FloatArray,
                       targets: FloatArray) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_planar_check` of poses ``Q`` (m, n, 3) against targets (m, 3): position
    and angle errors, worst violations [mm] and finiteness per pose."""
    m = Q.shape[0]
    pos = np.empty(m)
    ang = np.empty(m)
    v_mm = np.empty(m)
    finite = np.empty(m, dtype=np.bool_)
    for j in range(m):
        p, a, _, v, f, _, _, _, _ = _planar_check(
            Q[j], phi, base, top, leg_min, leg_max, sin_joint, targets[j]
        )
        pos[j], ang[j], v_mm[j], finite[j] = p, a, v, f
    return pos, ang, v_mm, finite


def planar_check_many(stack: Any, targets: Any, Q: FloatArray) -> list[bool]:
    """Whether each planar pose ``Q[j]`` (m, n, 3) passes the acceptance rule
    (:func:`stackik.check.pose_ok`) for ``targets[j]`` (one plane ``phi``): the same
    verdicts as :func:`planar_check` pose by pose, in one compiled call."""
    if len(targets) == 0:
        return []
    phi = float(targets[0].phi)
    if any(float(t.phi) != phi for t in targets):
        raise ValueError("targets: planar targets in one plane phi expected")
    Y = np.array([[t.rho, t.z, t.theta] for t in targets], dtype=float)
    return planar_checks(stack, phi, Y, Q).tolist()  # type: ignore[no-any-return]


def planar_checks(stack: Any, phi: float, Y: FloatArray, Q: FloatArray) -> Any:
    """:func:`planar_check_many` of poses ``Q`` (m, n, 3) for the targets ``Y`` (m, 3)
    (rows ``rho, z, theta``) in the plane ``phi``, as a boolean array."""
    from stackik._arrays import readonly
    from stackik.check import poses_ok

    Qa = np.ascontiguousarray(Q, dtype=float)
    if Qa.shape != (len(Y), stack.n, 3):
        raise ValueError(
            f"Q: shape (len(targets), n, 3) = ({len(Y)}, {stack.n}, 3) expected, got {Qa.shape}"
        )
    pos, ang, v_mm, finite = _planar_check_many(  # type: ignore[call-arg]
        readonly(Qa), float(phi), *_limits_args(stack), readonly(Y)
    )
    return poses_ok(pos, ang, v_mm, finite)


@njit(cache=True, nogil=True, error_model="numpy")
def _planar_path_arrays(Q: FloatArray, phi: float, base: FloatArray, top: FloatArray,
                        leg_min: FloatArray, leg_max: FloatArray,
                        sin_joint: FloatArray) -> tuple[Any, ...]:  # fmt: skip
    """FN, leg lengths and limit margins of planar poses ``Q`` (m, n, 3), as
    :func:`stackik.paths.path_arrays` reports them: ``FN^2 = 3 n + sum_{0<i<n} |O_n -
    O_i|^2`` (:func:`stackik.kinematics.planar_fn2`), ``|l|`` per leg, and per platform
    ``min |l| - leg_min``, ``leg_max - max |l|`` and the smallest angle of a leg with the
    base (top) plate minus ``asin(sin_joint)`` (the legs as :func:`_planar_check` builds
    them)."""
    m, n = Q.shape[0], Q.shape[1]
    fn = np.empty(m)
    legs = np.empty((m, n, 6))
    margins = np.empty((m, n, 4))
    e_phi = np.array([math.cos(phi), math.sin(phi), 0.0])
    s = np.array([math.sin(phi), -math.cos(phi), 0.0])  # plane_axis(phi)
    O = np.zeros((n + 1, 2))
    R = np.empty((3, 3))
    for j in range(m):
        th = 0.0
        for i in range(n):
            c = math.cos(th)
            sn = math.sin(th)
            O[i + 1, 0] = O[i, 0] + c * Q[j, i, 0] - sn * Q[j, i, 1]
            O[i + 1, 1] = O[i, 1] + sn * Q[j, i, 0] + c * Q[j, i, 1]
            th += Q[j, i, 2]
        acc = 3.0 * n
        for i in range(1, n):
            d0 = O[n, 0] - O[i, 0]
            d1 = O[n, 1] - O[i, 1]
            acc += d0 * d0 + d1 * d1
        fn[j] = math.sqrt(acc)
        for i in range(n):
            ct = math.cos(Q[j, i, 2])
            st = math.sin(Q[j, i, 2])
            for a in range(3):
                for b in range(3):
                    R[a, b] = (1.0 - ct) * s[a] * s[b] + (ct if a == b else 0.0)
            R[0, 1] -= st * s[2]
            R[0, 2] += st * s[1]
            R[1, 0] += st * s[2]
            R[1, 2] -= st * s[0]
            R[2, 0] -= st * s[1]
            R[2, 1] += st * s[0]
            p0 = Q[j, i, 0] * e_phi[0]
            p1 = Q[j, i, 0] * e_phi[1]
            p2 = Q[j, i, 1]
            lo = math.inf
            hi = -math.inf
            ab = math.inf
            at = math.inf
            for k in range(6):
                l0 = R[0, 0] * top[i, k, 0] + R[0, 1] * top[i, k, 1] + R[0, 2] * top[i, k, 2]
                l1 = R[1, 0] * top[i, k, 0] + R[1, 1] * top[i, k, 1] + R[1, 2] * top[i, k, 2]
                l2 = R[2, 0] * top[i, k, 0] + R[2, 1] * top[i, k, 1] + R[2, 2] * top[i, k, 2]
                l0 += p0 - base[i, k, 0]
                l1 += p1 - base[i, k, 1]
                l2 += p2 - base[i, k, 2]
                nrm = math.sqrt(l0 * l0 + l1 * l1 + l2 * l2)
                legs[j, i, k] = nrm
                lo = min(lo, nrm)
                hi = max(hi, nrm)
                ab = min(ab, l2 / nrm)  # sines: asin is increasing
                at = min(at, (l0 * R[0, 2] + l1 * R[1, 2] + l2 * R[2, 2]) / nrm)
            jmin = math.asin(sin_joint[i])
            margins[j, i, 0] = lo - leg_min[i]
            margins[j, i, 1] = leg_max[i] - hi
            margins[j, i, 2] = math.asin(min(max(ab, -1.0), 1.0)) - jmin
            margins[j, i, 3] = math.asin(min(max(at, -1.0), 1.0)) - jmin
    return fn, legs, margins


def planar_path_arrays(stack: Any, phi: float, Q: FloatArray) -> tuple[Any, ...]:
    """``(FN (m,), leg lengths (m, n, 6), margins (m, n, 4))`` of planar poses ``Q``
    (m, n, 3) in the plane ``phi`` (:func:`_planar_path_arrays`)."""
    from stackik._arrays import readonly

    return _planar_path_arrays(  # type: ignore[no-any-return]
        readonly(np.ascontiguousarray(Q, dtype=float)), float(phi), *_limits_args(stack)
    )


def _limits_args(stack: Any) -> tuple[FloatArray, ...]:
    """The stack's node and limit arrays as the compiled checks take them (read-only)."""
    from stackik._arrays import readonly

    return (
        readonly(stack.base_nodes),
        readonly(stack.top_nodes),
        readonly(stack.leg_min),
        readonly(stack.leg_max),
        readonly(stack.sin_joint_min),
    )


@njit(cache=True, nogil=True, error_model="numpy")
def _spatial_check(q: FloatArray, base: FloatArray, top: FloatArray, leg_min: FloatArray,
                   leg_max: FloatArray, sin_joint: FloatArray, p_t: FloatArray,
                   R_t: FloatArray) -> tuple[Any, ...]:  # fmt: skip
    """A spatial pose ``q`` (n, 6) ``[x, y, z, yaw, pitch, roll]`` against a target:
    position error [mm], rotation angle of ``R_t^T R_ee`` [rad], worst violation raw and
    as a length [mm] (as :func:`stackik.check.check_pose`), finiteness. Written from
    DESIGN §1-2 (``R = Rz Ry Rx``, leg ``l = R t + p - b`` in the platform's base frame,
    top normal ``R e_z``), sharing no code with the spatial solver."""
    n = q.shape[0]
    A = np.eye(3)
    P = np.zeros(3)
    max_v = 0.0
    v_mm = 0.0
    finite = True
    for i in range(n):
        for a in range(3):
            P[a] += A[a, 0] * q[i, 0] + A[a, 1] * q[i, 1] + A[a, 2] * q[i, 2]
        cy, sy = math.cos(q[i, 3]), math.sin(q[i, 3])
        cp, sp = math.cos(q[i, 4]), math.sin(q[i, 4])
        cr, sr = math.cos(q[i, 5]), math.sin(q[i, 5])
        R = np.array([
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ])  # fmt: skip
        A = A @ R
        for k in range(6):
            l0 = R[0, 0] * top[i, k, 0] + R[0, 1] * top[i, k, 1] + R[0, 2] * top[i, k, 2]
            l1 = R[1, 0] * top[i, k, 0] + R[1, 1] * top[i, k, 1] + R[1, 2] * top[i, k, 2]
            l2 = R[2, 0] * top[i, k, 0] + R[2, 1] * top[i, k, 1] + R[2, 2] * top[i, k, 2]
            l0 += q[i, 0] - base[i, k, 0]
            l1 += q[i, 1] - base[i, k, 1]
            l2 += q[i, 2] - base[i, k, 2]
            sq = l0 * l0 + l1 * l1 + l2 * l2
            nrm = math.sqrt(sq)
            c = (sq - leg_min[i] ** 2, leg_max[i] ** 2 - sq, l2 - nrm * sin_joint[i],
                 l0 * R[0, 2] + l1 * R[1, 2] + l2 * R[2, 2] - nrm * sin_joint[i])  # fmt: skip
            for b in range(4):
                if not math.isfinite(c[b]):
                    finite = False
                v = max(-c[b], 0.0)
                max_v = max(max_v, v)
                if b == 0:
                    vm = leg_min[i] - math.sqrt(max(leg_min[i] ** 2 - v, 0.0))
                elif b == 1:
                    vm = math.sqrt(leg_max[i] ** 2 + v) - leg_max[i]
                else:
                    vm = v
                v_mm = max(v_mm, vm)
    pos_err = math.sqrt((P[0] - p_t[0]) ** 2 + (P[1] - p_t[1]) ** 2 + (P[2] - p_t[2]) ** 2)
    E = R_t.T @ A
    sx = 0.5 * (E[2, 1] - E[1, 2])
    sy_ = 0.5 * (E[0, 2] - E[2, 0])
    sz = 0.5 * (E[1, 0] - E[0, 1])
    ang_err = math.atan2(math.sqrt(sx * sx + sy_ * sy_ + sz * sz),
                         0.5 * (E[0, 0] + E[1, 1] + E[2, 2] - 1.0))  # fmt: skip
    return pos_err, ang_err, max_v, v_mm, finite


@njit(cache=True, nogil=True, error_model="numpy")
def _spatial_check_many(Q: FloatArray, base: FloatArray, top: FloatArray, leg_min: FloatArray,
                        leg_max: FloatArray, sin_joint: FloatArray, pos: FloatArray,
                        rot: FloatArray) -> tuple[Any, ...]:  # fmt: skip
    """:func:`_spatial_check` of poses ``Q`` (m, n, 6) against targets ``pos`` (m, 3),
    ``rot`` (m, 3, 3)."""
    m = Q.shape[0]
    pe = np.empty(m)
    ae = np.empty(m)
    v_mm = np.empty(m)
    finite = np.empty(m, dtype=np.bool_)
    for j in range(m):
        p, a, _, v, f = _spatial_check(Q[j], base, top, leg_min, leg_max, sin_joint, pos[j],
                                       rot[j])  # fmt: skip
        pe[j], ae[j], v_mm[j], finite[j] = p, a, v, f
    return pe, ae, v_mm, finite


def spatial_check_many(stack: Any, targets: Any, Q: FloatArray) -> list[bool]:
    """Whether each spatial pose ``Q[j]`` (m, n, 6) passes the acceptance rule
    (:func:`stackik.check.pose_ok`) for ``targets[j]``: the verdicts of
    :func:`stackik.check.check_pose`, in one compiled call."""
    from stackik._arrays import readonly
    from stackik.check import poses_ok

    if len(targets) == 0:
        return []
    pos = np.array([t.position for t in targets], dtype=float)
    rot = np.array([t.rotation for t in targets], dtype=float)
    pe, ae, v_mm, finite = _spatial_check_many(  # type: ignore[call-arg]
        readonly(np.ascontiguousarray(Q, dtype=float)),
        *_limits_args(stack),
        readonly(pos),
        readonly(rot),
    )
    return poses_ok(pe, ae, v_mm, finite).tolist()  # type: ignore[no-any-return]
