"""Time parameterisation of a pose sequence under leg speed and acceleration limits.

The legs (actuators) move along the path through the waypoint leg lengths
``L_0 .. L_{m-1}`` (each of shape (n, 6)). With waypoint times ``t_k`` and segment
durations ``h_k = t_{k+1} - t_k``, the rates are the finite differences

.. math::

    v_k = \\frac{L_{k+1} - L_k}{h_k}, \\qquad
    a_k = \\frac{2 (v_k - v_{k-1})}{h_{k-1} + h_k}

(segment velocities, and accelerations at the waypoints by the non-uniform second
difference), with the robot at rest before the first and after the last waypoint
(``v_{-1} = v_{m-1} = 0``, ``h_{-1} = h_{m-1} = 0``). :func:`time_parameterize` returns
times with ``|v_k| <= leg_speed`` and ``|a_k| <= leg_accel`` for every leg;
:func:`leg_rates` computes ``v`` and ``a`` for any times (the check).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["MIN_SEGMENT_TIME", "leg_rates", "time_parameterize"]

FloatArray = NDArray[np.float64]

#: Shortest segment duration [s] (segments where no leg moves get it).
MIN_SEGMENT_TIME = 1e-6
_SAFETY = 1.0 - 1e-9  # rates land this fraction below the limits (rounding)


def _legs(leg_lengths: Any) -> FloatArray:
    L = getattr(leg_lengths, "leg_lengths", leg_lengths)
    completed = getattr(leg_lengths, "completed", None)
    La = np.asarray(L, dtype=float)
    if completed is not None:
        La = La[:completed]
    if La.ndim != 3 or La.shape[2] != 6:
        raise ValueError(f"leg_lengths: expected shape (m, n, 6), got {La.shape}")
    if not np.all(np.isfinite(La)):
        raise ValueError("leg_lengths: must be finite")
    return La.reshape(La.shape[0], -1)


def _limit(value: Any, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"{name}: must be finite and > 0, got {value!r}")
    return v


def _accel(D: FloatArray, sigma: FloatArray) -> FloatArray:
    """Largest |a| over the legs at every waypoint, shape (m,), for speeds ``sigma = 1/h``."""
    m = D.shape[0] + 1
    V = np.zeros((m + 1, D.shape[1]))
    V[1:m] = D * sigma[:, None]
    h = np.zeros(m + 1)
    h[1:m] = 1.0 / sigma
    return 2.0 * np.abs(V[1:] - V[:-1]).max(axis=1) / (h[:-1] + h[1:])  # type: ignore[no-any-return]


def _slow_one(D: FloatArray, sigma: FloatArray, k: int, j: int, amax: float) -> None:
    """Scale ``sigma[j]`` (a segment next to waypoint k) down until ``a_k <= amax``."""

    def ok(c: float) -> bool:
        s = sigma.copy()
        s[j] *= c
        lo, hi = max(k - 1, 0), min(k + 1, len(s))
        return bool(_accel(D[lo:hi], s[lo:hi])[k - lo] <= amax)

    lo = 0.5
    while not ok(lo):  # a_k -> 0 as the segment slows down: this ends
        lo *= 0.5
        if lo < 1e-12:
            break
    hi = 2.0 * lo if lo < 0.5 else 1.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if ok(mid):
            lo = mid
        else:
            hi = mid
    sigma[j] *= lo


def time_parameterize(
    leg_lengths: ArrayLike | Any,
    *,
    leg_speed: float,
    leg_accel: float,
    max_sweeps: int = 200,
) -> FloatArray:
    """Waypoint times at which every leg respects a speed and an acceleration limit.

    Starts from the speed limit alone (each segment as short as its fastest leg allows),
    then slows the segments next to every waypoint whose acceleration exceeds the limit
    (the faster side: accelerating segments forward, decelerating ones backward), sweep
    after sweep until none does; if sweeps run out, all speeds are scaled down together
    (``a`` scales with the square). Rest-to-rest; not time-optimal, but every limit holds
    (:func:`leg_rates` gives the rates of any times).

    Parameters
    ----------
    leg_lengths : array_like, shape (m, n, 6), or a PathResult
        Leg lengths along the path [mm] (a result's completed waypoints).
    leg_speed : float
        Largest leg speed [mm/s].
    leg_accel : float
        Largest leg acceleration [mm/s^2].
    max_sweeps : int
        Sweeps before the global scaling fallback.

    Returns
    -------
    ndarray, shape (m,)
        Times [s], ``t_0 = 0``, non-decreasing (strictly increasing: every segment lasts at
        least ``MIN_SEGMENT_TIME``).
    """
    vmax = _limit(leg_speed, "leg_speed") * _SAFETY
    amax = _limit(leg_accel, "leg_accel") * _SAFETY
    L = _legs(leg_lengths)
    m = L.shape[0]
    if m < 2:
        return np.zeros(m)
    D = np.diff(L, axis=0)  # (m-1, 6n)
    dmax = np.abs(D).max(axis=1)
    sigma = np.full(m - 1, 1.0 / MIN_SEGMENT_TIME)
    moving = dmax > 0
    sigma[moving] = np.minimum(sigma[moving], vmax / dmax[moving])
    for _ in range(max_sweeps):
        a = _accel(D, sigma)
        bad = np.flatnonzero(a > amax)
        if bad.size == 0:
            break
        for k in (int(b) for b in bad):
            a_k = _accel(D[max(k - 1, 0) : k + 1], sigma[max(k - 1, 0) : k + 1])
            if a_k[min(k, 1)] <= amax:  # fixed by a neighbour's slow-down
                continue
            v_in = D[k - 1] * sigma[k - 1] if k >= 1 else np.zeros(D.shape[1])
            v_out = D[k] * sigma[k] if k < m - 1 else np.zeros(D.shape[1])
            leg = int(np.argmax(np.abs(v_out - v_in)))
            out_faster = abs(v_out[leg]) >= abs(v_in[leg])
            j = k if (out_faster and k < m - 1) or k == 0 else k - 1
            _slow_one(D, sigma, k, j, amax)
    a_max = float(_accel(D, sigma).max())
    if a_max > amax:  # fallback: a scales with sigma^2
        sigma *= math.sqrt(amax / a_max) * _SAFETY
    return np.concatenate([[0.0], np.cumsum(1.0 / sigma)])  # type: ignore[no-any-return]


def leg_rates(leg_lengths: ArrayLike | Any, times: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Leg velocities and accelerations of a timed path, by finite differences.

    Parameters
    ----------
    leg_lengths : array_like, shape (m, n, 6), or a PathResult
    times : array_like, shape (m,)
        Strictly increasing waypoint times [s].

    Returns
    -------
    v : ndarray, shape (m-1, n, 6)
        Segment velocities [mm/s].
    a : ndarray, shape (m, n, 6)
        Accelerations at the waypoints [mm/s^2], at rest before and after the path (see
        the module docstring).
    """
    L = _legs(leg_lengths)
    m = L.shape[0]
    shape = np.asarray(getattr(leg_lengths, "leg_lengths", leg_lengths)).shape[1:]
    t = np.asarray(times, dtype=float)[:m]
    if t.shape != (m,) or np.any(np.diff(t) <= 0):
        raise ValueError(f"times: expected {m} strictly increasing values")
    h = np.diff(t)
    V = np.diff(L, axis=0) / h[:, None]
    Vp = np.concatenate([np.zeros((1, L.shape[1])), V, np.zeros((1, L.shape[1]))])
    hp = np.concatenate([[0.0], h, [0.0]])
    A = 2.0 * (Vp[1:] - Vp[:-1]) / (hp[:-1] + hp[1:])[:, None]
    return V.reshape((m - 1, *shape)), A.reshape((m, *shape))
