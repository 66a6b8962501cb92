"""Monte Carlo sensitivity of stack poses (paper Algorithm 1, DESIGN §7).

Every platform variable of a pose is perturbed with independent Gaussian noise,
``sigma_t`` [mm] on translations and ``sigma_theta`` [rad] on angles, and the end
effector is recomputed with the exact (non-linear) forward kinematics. All poses compared
in one call see **the same draws**: the noise array ``dx`` of shape
``(n_samples, n, ncols)`` is drawn once and added to every pose, as in Algorithm 1.

The draws are generated sample-major in chunks, so ``dx`` (and every number derived from
it) does not depend on the ``chunk`` size: for a given ``rng`` seed the result is that of
``dx = sigma * rng.standard_normal((n_samples, n, ncols))``.

Planar poses ``(n, 3)`` (rows ``[rho_i, z_i, theta_i]``) give end-effector displacements
in the ``(rho, z)`` plane; the planar forward kinematics do not depend on ``phi``, which
only matters for the 3D constraints and drawings. Spatial poses ``(n, 6)`` (rows
``[x, y, z, yaw, pitch, roll]``) give 3D position displacements and the rotation angle of
``R_nominal^T R_perturbed``.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import chi2

from stackik.kinematics import planar_forward, spatial_forward

__all__ = [
    "ConfidenceEllipse",
    "MonteCarloResult",
    "PoseMonteCarlo",
    "as_pose_batch",
    "draw_perturbations",
    "monte_carlo",
]

FloatArray = NDArray[np.float64]
RngLike = np.random.Generator | int | np.random.SeedSequence | None

#: Quantiles reported for the displacement distance: 2.5 %, median, 97.5 %.
_QUANTILES = (0.025, 0.5, 0.975)


# =========================================================================================
# Confidence ellipse
# =========================================================================================
@dataclass(frozen=True)
class ConfidenceEllipse:
    """Gaussian confidence ellipse (ellipsoid in 3D) of a sample cloud.

    The region ``(x - center)^T C^{-1} (x - center) <= quantile`` with ``quantile`` the
    chi-square quantile with ``d`` degrees of freedom at ``level`` (5.991 for d = 2 and
    95 %).

    Attributes
    ----------
    center : ndarray, shape (d,)
        Sample mean [mm].
    semi_axes : ndarray, shape (d,)
        Semi-axis lengths ``sqrt(quantile * eigenvalue)``, largest first [mm].
    axes : ndarray, shape (d, d)
        Unit directions of the semi-axes as **columns** (``axes[:, 0]`` is the major axis).
    level : float
        Coverage probability (0.95).
    quantile : float
        Chi-square quantile used.
    """

    center: FloatArray
    semi_axes: FloatArray
    axes: FloatArray
    level: float
    quantile: float

    @classmethod
    def from_covariance(
        cls, center: ArrayLike, covariance: ArrayLike, level: float = 0.95
    ) -> ConfidenceEllipse:
        """Ellipse of a Gaussian with the given mean (d,) and covariance (d, d)."""
        c = np.asarray(center, dtype=float)
        C = np.asarray(covariance, dtype=float)
        d = c.shape[0]
        if C.shape != (d, d):
            raise ValueError(f"covariance: expected shape ({d}, {d}), got {C.shape}")
        if not 0.0 < level < 1.0:
            raise ValueError(f"level must be in (0, 1), got {level}")
        k2 = float(chi2.ppf(level, d))
        w, V = np.linalg.eigh(0.5 * (C + C.T))
        order = np.argsort(w)[::-1]
        w, V = np.clip(w[order], 0.0, None), V[:, order]
        # deterministic sign: first non-negligible component of each axis positive
        for j in range(d):
            i = int(np.argmax(np.abs(V[:, j]) > 1e-12))
            if V[i, j] < 0:
                V[:, j] = -V[:, j]
        return cls(center=c, semi_axes=np.sqrt(k2 * w), axes=V, level=level, quantile=k2)

    @property
    def dim(self) -> int:
        """Dimension d."""
        return int(self.center.shape[0])

    @property
    def angle(self) -> float:
        """Angle of the major axis from the first coordinate axis [rad], in (-pi/2, pi/2].

        For the planar ``(rho, z)`` ellipse: measured from the rho axis towards z.
        """
        a = float(np.arctan2(self.axes[1, 0], self.axes[0, 0]))
        if a <= -np.pi / 2:
            a += np.pi
        elif a > np.pi / 2:
            a -= np.pi
        return a

    @property
    def area(self) -> float:
        """Area (d = 2) or volume (d = 3) [mm^2 or mm^3]."""
        if self.dim == 2:
            return float(np.pi * np.prod(self.semi_axes))
        return float(4.0 / 3.0 * np.pi * np.prod(self.semi_axes))

    def mahalanobis2(self, points: ArrayLike) -> FloatArray:
        """Squared Mahalanobis distance of ``points`` (..., d) scaled so the boundary is 1."""
        p = np.asarray(points, dtype=float) - self.center
        u = p @ self.axes  # coordinates along the axes
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(self.semi_axes > 0, u / self.semi_axes, np.where(u == 0, 0.0, np.inf))
        return np.sum(r * r, axis=-1)  # type: ignore[no-any-return]

    def contains(self, points: ArrayLike) -> NDArray[np.bool_]:
        """Whether each point (..., d) lies inside the ellipse; shape (...)."""
        return self.mahalanobis2(points) <= 1.0

    def boundary(self, num: int = 200) -> FloatArray:
        """Points on the boundary of a 2D ellipse, shape (num, 2) [mm]."""
        if self.dim != 2:
            raise ValueError("boundary() is defined for 2D ellipses only")
        t = np.linspace(0.0, 2.0 * np.pi, num)
        circle = np.stack([np.cos(t), np.sin(t)], axis=-1) * self.semi_axes
        return self.center + circle @ self.axes.T  # type: ignore[no-any-return]

    def to_dict(self) -> dict[str, object]:
        """JSON-friendly summary."""
        out: dict[str, object] = {
            "center": self.center.tolist(),
            "semi_axes": self.semi_axes.tolist(),
            "axes": self.axes.tolist(),
            "level": self.level,
            "quantile": self.quantile,
        }
        if self.dim == 2:
            out["angle"] = self.angle
        return out


# =========================================================================================
# Results
# =========================================================================================
@dataclass(frozen=True)
class PoseMonteCarlo:
    """Monte Carlo statistics of one pose.

    Attributes
    ----------
    pose : ndarray, shape (n, 3) or (n, 6)
        The nominal pose.
    nominal : ndarray, shape (d,)
        Nominal end-effector position: ``(rho, z)`` (d = 2) or ``(x, y, z)`` (d = 3) [mm].
    nominal_rotation : ndarray, shape () or (3, 3)
        Nominal ``theta_ee`` [rad] (planar) or ``R_ee`` (spatial).
    distance : ndarray, shape (N,)
        End-effector position displacement ``|p - p_nominal|`` of every sample [mm].
    displacement : ndarray, shape (N, d) or None
        Position displacement vectors [mm] (None when ``keep_samples=False``).
    angle : ndarray, shape (N,) or None
        Orientation change [rad]: signed ``theta_ee - theta_nominal`` (planar) or the
        rotation angle of ``R_nominal^T R`` in ``[0, pi]`` (spatial).
    median : float
        Median displacement distance [mm].
    interval : tuple of float
        2.5 % and 97.5 % percentiles of the distance [mm] (95 % interval).
    mean : ndarray, shape (d,)
        Mean displacement vector [mm].
    covariance : ndarray, shape (d, d)
        Observed covariance of the end-effector position [mm^2] (ddof = 1).
    ellipse : ConfidenceEllipse
        95 % confidence ellipse of the displacement cloud (centre = mean displacement).
    angle_median : float
        Median of ``|angle|`` [rad].
    angle_interval : tuple of float
        2.5 % and 97.5 % percentiles of ``|angle|`` [rad].
    """

    pose: FloatArray
    nominal: FloatArray
    nominal_rotation: FloatArray
    distance: FloatArray = field(repr=False)
    displacement: FloatArray | None = field(repr=False)
    angle: FloatArray | None = field(repr=False)
    median: float
    interval: tuple[float, float]
    mean: FloatArray
    covariance: FloatArray
    ellipse: ConfidenceEllipse
    angle_median: float
    angle_interval: tuple[float, float]

    @property
    def n_samples(self) -> int:
        """Number of samples N."""
        return int(self.distance.shape[0])

    def summary(self) -> dict[str, object]:
        """JSON-friendly summary (no per-sample arrays)."""
        return {
            "pose": self.pose.tolist(),
            "nominal": self.nominal.tolist(),
            "median": self.median,
            "interval": list(self.interval),
            "mean": self.mean.tolist(),
            "covariance": self.covariance.tolist(),
            "ellipse": self.ellipse.to_dict(),
            "angle_median": self.angle_median,
            "angle_interval": list(self.angle_interval),
        }


@dataclass(frozen=True)
class MonteCarloResult:
    """Result of :func:`monte_carlo` for k poses that shared the same draws.

    Attributes
    ----------
    poses : tuple of PoseMonteCarlo
        One entry per pose, in input order.
    n_samples : int
    sigma_t : float
        Translation noise [mm].
    sigma_theta : float
        Angle noise [rad].
    mode : {"planar", "spatial"}
    seed : int or None
        The integer seed when ``rng`` was an int, else None.
    """

    poses: tuple[PoseMonteCarlo, ...]
    n_samples: int
    sigma_t: float
    sigma_theta: float
    mode: Literal["planar", "spatial"]
    seed: int | None = None

    def __len__(self) -> int:
        return len(self.poses)

    def __getitem__(self, i: int) -> PoseMonteCarlo:
        return self.poses[i]

    def __iter__(self) -> Iterator[PoseMonteCarlo]:
        return iter(self.poses)

    @property
    def medians(self) -> FloatArray:
        """Median displacement distance of every pose, shape (k,) [mm]."""
        return np.array([p.median for p in self.poses])

    @property
    def intervals(self) -> FloatArray:
        """95 % intervals of every pose, shape (k, 2) [mm]."""
        return np.array([p.interval for p in self.poses])

    @property
    def covariances(self) -> FloatArray:
        """Observed covariances, shape (k, d, d) [mm^2]."""
        return np.stack([p.covariance for p in self.poses])

    def summary(self) -> dict[str, object]:
        """JSON-friendly summary (no per-sample arrays)."""
        return {
            "n_samples": self.n_samples,
            "sigma_t": self.sigma_t,
            "sigma_theta": self.sigma_theta,
            "mode": self.mode,
            "seed": self.seed,
            "poses": [p.summary() for p in self.poses],
        }


# =========================================================================================
# Input handling and noise
# =========================================================================================
def as_pose_batch(poses: ArrayLike | Sequence[ArrayLike]) -> tuple[FloatArray, str]:
    """Stack poses into a (k, n, ncols) array and detect the mode from ncols (3 or 6)."""
    arr = np.asarray(poses, dtype=float)
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[-1] not in (3, 6) or arr.shape[0] == 0:
        raise ValueError(
            f"poses: expected (n, 3)/(n, 6) or a batch (k, n, 3)/(k, n, 6), got {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError("poses: contains NaN or infinite values")
    return arr, "planar" if arr.shape[-1] == 3 else "spatial"


def _sigmas(ncols: int, sigma_t: float, sigma_theta: float) -> FloatArray:
    if not (np.isfinite(sigma_t) and np.isfinite(sigma_theta)) or sigma_t < 0 or sigma_theta < 0:
        raise ValueError("sigma_t and sigma_theta must be finite and >= 0")
    half = 2 if ncols == 3 else 3
    return np.array([sigma_t] * half + [sigma_theta] * (ncols - half))


def draw_perturbations(
    n_samples: int,
    n: int,
    sigma_t: float,
    sigma_theta: float,
    rng: RngLike = None,
    spatial: bool = False,
) -> FloatArray:
    """Draw the Algorithm-1 noise ``dx``, shape (n_samples, n, 3) or (n_samples, n, 6).

    Columns: ``(rho, z, theta)`` planar or ``(x, y, z, yaw, pitch, roll)`` spatial, with
    standard deviations ``sigma_t`` [mm] and ``sigma_theta`` [rad]. Identical to the draws
    :func:`monte_carlo` makes with the same ``rng``.
    """
    ncols = 6 if spatial else 3
    gen = np.random.default_rng(rng)
    return gen.standard_normal((int(n_samples), int(n), ncols)) * _sigmas(
        ncols, sigma_t, sigma_theta
    )


# =========================================================================================
# Forward kinematics of a chunk
# =========================================================================================
class _PlanarChunk:
    """Planar end-effector position of k poses under one chunk of noise (preallocated)."""

    def __init__(self, n: int, m: int) -> None:
        self.n = n
        self.T = np.empty((3, n, m))  # component-major copy of the noise
        self.Th = np.empty((max(n - 1, 1), m))
        self.c = np.empty_like(self.Th)
        self.s = np.empty_like(self.Th)
        self.a = np.empty(m)
        self.b = np.empty(m)
        self.tmp = np.empty(m)

    def load(self, xi: FloatArray, sig: FloatArray) -> None:
        """Scale standard normals xi (m, n, 3) by sig (3,) into the component-major buffer."""
        m = xi.shape[0]
        np.multiply(xi.transpose(2, 1, 0), sig[:, None, None], out=self.T[:, :, :m])

    def angle(self, m: int) -> FloatArray:
        return self.T[2, :, :m].sum(axis=0)  # type: ignore[no-any-return]

    def position(
        self, q: FloatArray, y0: FloatArray, m: int, out_r: FloatArray, out_z: FloatArray
    ) -> None:
        """Write ``rho_ee - y0[0]`` and ``z_ee - y0[1]`` of the m samples into out_*."""
        n = self.n
        rho, z = self.T[0, :, :m], self.T[1, :, :m]
        np.add(rho[0], q[0, 0], out=out_r)
        np.add(z[0], q[0, 1], out=out_z)
        if n > 1:
            Th, c, s = self.Th[:, :m], self.c[:, :m], self.s[:, :m]
            np.add(self.T[2, : n - 1, :m], q[: n - 1, 2, None], out=Th)
            np.cumsum(Th, axis=0, out=Th)  # Theta_2 .. Theta_n
            np.cos(Th, out=c)
            np.sin(Th, out=s)
            a, b, t = self.a[:m], self.b[:m], self.tmp[:m]
            for i in range(1, n):
                np.add(rho[i], q[i, 0], out=a)  # rho_i
                np.add(z[i], q[i, 1], out=b)  # z_i
                ci, si = c[i - 1], s[i - 1]
                out_r += np.multiply(ci, a, out=t)
                out_r -= np.multiply(si, b, out=t)
                out_z += np.multiply(si, a, out=t)
                out_z += np.multiply(ci, b, out=t)
        out_r -= y0[0]
        out_z -= y0[1]


@dataclass(frozen=True)
class _OnePose:
    """Picklable: :func:`monte_carlo` of one pose (a task of a spread Monte Carlo)."""

    n_samples: int
    sigma_t: float
    sigma_theta: float
    rng: int | np.random.SeedSequence
    chunk: int
    keep_samples: bool
    level: float

    def __call__(self, pose: FloatArray) -> MonteCarloResult:
        return monte_carlo(
            pose, self.n_samples, self.sigma_t, self.sigma_theta, self.rng, chunk=self.chunk,
            keep_samples=self.keep_samples, level=self.level,
        )  # fmt: skip


def _rotation_angle(R0: FloatArray, R: FloatArray) -> FloatArray:
    """Rotation angle [rad] of ``R0^T R`` for R (..., 3, 3), accurate at small angles."""
    M = np.einsum("ji,...jk->...ik", R0, R)
    v = np.stack(
        [M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]],
        axis=-1,
    )
    sin_t = 0.5 * np.linalg.norm(v, axis=-1)
    cos_t = 0.5 * (np.trace(M, axis1=-2, axis2=-1) - 1.0)
    return np.arctan2(sin_t, cos_t)  # type: ignore[no-any-return]


def _quantiles(x: FloatArray, probs: Sequence[float] = _QUANTILES) -> FloatArray:
    """``np.quantile(x, probs)`` (linear interpolation) with a single partial sort."""
    N = x.shape[0]
    h = (N - 1) * np.asarray(probs, dtype=float)
    lo = np.floor(h).astype(np.intp)
    hi = np.minimum(lo + 1, N - 1)
    part = np.partition(x, np.unique(np.concatenate([lo, hi])))
    return part[lo] + (h - lo) * (part[hi] - part[lo])  # type: ignore[no-any-return]


# =========================================================================================
# Monte Carlo
# =========================================================================================
def monte_carlo(
    poses: ArrayLike | Sequence[ArrayLike],
    n_samples: int,
    sigma_t: float,
    sigma_theta: float,
    rng: RngLike = None,
    *,
    chunk: int = 8192,
    keep_samples: bool = True,
    level: float = 0.95,
    executor: Any = None,
) -> MonteCarloResult:
    """Perturb poses with common Gaussian noise and measure the end-effector motion.

    Paper Algorithm 1, vectorised: the noise ``dx`` (n_samples, n, ncols) is drawn once
    (chunk by chunk, without a Python loop over samples) and added to **every** pose; the
    end effector of each perturbed pose is computed with the exact forward kinematics.

    Parameters
    ----------
    poses : array_like, shape (n, 3), (k, n, 3), (n, 6) or (k, n, 6), or a list of them
        Planar poses (rows ``[rho_i, z_i, theta_i]`` [mm, mm, rad]) or spatial poses
        (rows ``[x, y, z, yaw, pitch, roll]`` [mm, rad]); all with the same n.
    n_samples : int
        Number of Monte Carlo samples N (>= 2).
    sigma_t : float
        Standard deviation of the translation noise [mm].
    sigma_theta : float
        Standard deviation of the angle noise [rad].
    rng : numpy.random.Generator, int, SeedSequence or None
        Passed to :func:`numpy.random.default_rng`. With an int seed the result is
        reproducible and independent of ``chunk``.
    chunk : int, optional
        Samples per vectorised block (bounds memory to about ``chunk * n * 60`` bytes).
    keep_samples : bool, optional
        Keep the per-sample displacement vectors and angles (``distance`` is always kept).
    level : float, optional
        Coverage of the confidence ellipse (0.95: chi-square quantile 5.991 in 2D).
    executor : concurrent.futures.Executor or distributed.Client, optional
        Spreads the poses, one task each (:mod:`stackik.batch`): every task draws the
        same noise from ``rng``, so the result is that of the serial call. Only with an
        int (or SeedSequence) ``rng`` and more than one pose; otherwise ignored.

    Returns
    -------
    MonteCarloResult
        Per pose: displacements ((N, 2) in ``(rho, z)`` planar, (N, 3) spatial), angles
        (N,), median distance and its 2.5/97.5 % percentiles, observed covariance and the
        confidence ellipse.
    """
    Q, mode = as_pose_batch(poses)
    k, n, ncols = Q.shape
    N = int(n_samples)
    if N < 2:
        raise ValueError(f"n_samples must be >= 2, got {n_samples}")
    if (
        executor is not None
        and k > 1
        and isinstance(rng, int | np.integer | np.random.SeedSequence)
    ):
        return _spread_poses(
            Q, N, sigma_t, sigma_theta, rng, chunk, keep_samples, level, executor
        )  # fmt: skip
    chunk = max(1, int(chunk))
    sig = _sigmas(ncols, sigma_t, sigma_theta)
    seed = int(rng) if isinstance(rng, int | np.integer) else None
    gen = np.random.default_rng(rng)
    draws = _noise_chunks(gen, N, chunk, n, ncols)
    if mode == "planar":
        disp, ang = _planar_displacements(Q, N, min(chunk, N), sig, draws)
        Y0 = [planar_forward(Q[j]) for j in range(k)]
        nominals = [(y0[:2], np.asarray(y0[2])) for y0 in Y0]
    else:
        P0, R0 = spatial_forward(Q)  # (k, 3), (k, 3, 3)
        disp, ang = _spatial_displacements(Q, N, P0, R0, sig, draws)
        nominals = [(P0[j], R0[j]) for j in range(k)]
    results = []
    angle_stats: tuple[float, float, float] | None = None
    for j in range(k):
        if angle_stats is None or mode == "spatial":
            # planar: theta_ee changes by sum(dtheta_i) for every pose, computed once
            angle_stats = tuple(_quantiles(np.abs(ang[j])).tolist())
        results.append(
            _pose_statistics(
                Q[j], disp[j], ang[j], angle_stats, nominals[j], keep_samples, level
            )  # fmt: skip
        )
    return MonteCarloResult(
        poses=tuple(results),
        n_samples=N,
        sigma_t=float(sigma_t),
        sigma_theta=float(sigma_theta),
        mode=mode,  # type: ignore[arg-type]
        seed=seed,
    )


def _spread_poses(
    Q: FloatArray,
    N: int,
    sigma_t: float,
    sigma_theta: float,
    rng: int | np.integer | np.random.SeedSequence,
    chunk: int,
    keep_samples: bool,
    level: float,
    executor: Any,
) -> MonteCarloResult:
    """:func:`monte_carlo` with one task per pose, each drawing the same noise from ``rng``."""
    _sigmas(Q.shape[-1], sigma_t, sigma_theta)  # bad input is reported here, not remotely
    from stackik.batch import checkpointed_map

    seq = rng if isinstance(rng, np.random.SeedSequence) else int(rng)
    one = _OnePose(N, float(sigma_t), float(sigma_theta), seq, chunk, keep_samples, level)
    parts = checkpointed_map(
        one,
        list(Q),
        key=lambda q: None,
        encode=lambda r: r,
        decode=lambda r: r,
        executor=executor,
        chunksize=1,
    )
    return replace(parts[0], poses=tuple(p.poses[0] for p in parts))


def _noise_chunks(
    gen: np.random.Generator, N: int, chunk: int, n: int, ncols: int
) -> Iterator[tuple[int, FloatArray]]:
    """``(a, xi)`` per block of samples ``a .. a + m``: standard normals xi (m, n, ncols).

    One buffer is reused, so each ``xi`` is valid until the next one is drawn; the draws do
    not depend on ``chunk``.
    """
    raw = np.empty(min(chunk, N) * n * ncols)
    for a in range(0, N, chunk):
        m = min(chunk, N - a)
        xi = raw[: m * n * ncols]
        gen.standard_normal(out=xi)
        yield a, xi.reshape(m, n, ncols)


def _planar_displacements(
    Q: FloatArray,
    N: int,
    m_max: int,
    sig: FloatArray,
    draws: Iterator[tuple[int, FloatArray]],
) -> tuple[FloatArray, FloatArray]:
    """End-effector displacements (k, 2, N) and angle changes (k, N) of planar poses."""
    k, n, _ = Q.shape
    disp = np.empty((k, 2, N))  # component-major for fast writes
    ang = np.empty((k, N))
    work = _PlanarChunk(n, m_max)
    Y0 = planar_forward(Q)  # (k, 3)
    for a, xi in draws:
        m = xi.shape[0]
        work.load(xi, sig)
        angle = work.angle(m)
        for j in range(k):
            work.position(Q[j], Y0[j], m, disp[j, 0, a : a + m], disp[j, 1, a : a + m])
            ang[j, a : a + m] = angle
    return disp, ang


def _spatial_displacements(
    Q: FloatArray,
    N: int,
    P0: FloatArray,
    R0: FloatArray,
    sig: FloatArray,
    draws: Iterator[tuple[int, FloatArray]],
) -> tuple[FloatArray, FloatArray]:
    """End-effector displacements (k, 3, N) and rotation angles (k, N) of spatial poses."""
    k = Q.shape[0]
    disp = np.empty((k, 3, N))  # component-major for fast writes
    ang = np.empty((k, N))
    for a, xi in draws:
        m = xi.shape[0]
        dx = xi * sig
        for j in range(k):
            P, R = spatial_forward(Q[j] + dx)
            disp[j, :, a : a + m] = (P - P0[j]).T
            ang[j, a : a + m] = _rotation_angle(R0[j], R)
    return disp, ang


def _pose_statistics(
    pose: FloatArray,
    D: FloatArray,
    ang: FloatArray,
    angle_stats: tuple[float, float, float],
    nominal: tuple[FloatArray, FloatArray],
    keep_samples: bool,
    level: float,
) -> PoseMonteCarlo:
    """Distance quantiles, covariance and ellipse of one pose's displacements D (d, N)."""
    N = D.shape[1]
    dist = np.sqrt(np.einsum("dn,dn->n", D, D))
    lo, med, hi = _quantiles(dist)
    alo, amed, ahi = angle_stats
    mean = D.mean(axis=1)
    cov = (D @ D.T - N * np.outer(mean, mean)) / (N - 1)
    return PoseMonteCarlo(
        pose=pose.copy(),
        nominal=nominal[0],
        nominal_rotation=nominal[1],
        distance=dist,
        displacement=D.T.copy() if keep_samples else None,
        angle=ang.copy() if keep_samples else None,
        median=float(med),
        interval=(float(lo), float(hi)),
        mean=mean,
        covariance=cov,
        ellipse=ConfidenceEllipse.from_covariance(mean, cov, level),
        angle_median=float(amed),
        angle_interval=(float(alo), float(ahi)),
    )
