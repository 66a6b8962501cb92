"""Optimal versus non-optimal poses over the workspace (paper figures "ratio" and "MedianRatio").

Choices (documented, not given by the paper):

* **Targets** are generated from random *feasible poses*: every platform's
  ``(rho_i, z_i, theta_i)`` is drawn uniformly in a box and kept when its 24 limits hold
  (the limits of one platform depend on its own variables only, so platforms are drawn
  independently); the target is the forward kinematics of the assembled pose, in the
  plane ``phi``. Every target is therefore reachable, and they cluster where the stack
  reaches most easily, like the paper's "found solutions".
* **Optimal pose**: ``solve_ik(objective="frobenius")`` from the paper's start, run
  through :func:`stackik.solve_many` (so an executor can spread it).
* **Non-optimal poses**: ``solve_ik(objective="feasible")`` (the first feasible point the
  solver reaches) started from :func:`stackik.paper_initial_guess` plus Gaussian noise of
  standard deviations ``perturbation`` = (80 mm, 80 mm, 0.3 rad) drawn from a generator
  seeded with ``seed``; the first ``count`` successful runs are kept, in draw order.
* **Ratios**: ``FN_opt / FN_non`` and ``median_opt / median_non`` of the Monte Carlo
  displacement (common draws for the two poses of a target, the same seed for every
  target), regressed with :func:`scipy.stats.linregress` (median ratio on FN ratio).
"""

from __future__ import annotations

from collections.abc import Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.analysis.montecarlo import monte_carlo
from stackik.batch import checkpointed_map
from stackik.geometry import Stack
from stackik.kinematics import planar_forward

if TYPE_CHECKING:
    from stackik.ik import IKResult, PlanarTarget

__all__ = [
    "DEFAULT_PERTURBATION",
    "NonOptimalSearch",
    "Regression",
    "WorkspaceStudy",
    "nonoptimal_poses",
    "random_feasible_poses",
    "random_reachable_targets",
    "regress",
    "workspace_study",
]

FloatArray = NDArray[np.float64]


def _triple(values: Any) -> tuple[float, float, float]:
    a, b, c = (float(v) for v in values)
    return (a, b, c)


#: Standard deviations of the start perturbation for non-optimal poses [mm, mm, rad].
DEFAULT_PERTURBATION = (80.0, 80.0, 0.3)


# =========================================================================================
# Regression
# =========================================================================================
@dataclass(frozen=True)
class Regression:
    """Least-squares line ``y = slope * x + intercept`` (:func:`scipy.stats.linregress`)."""

    slope: float
    intercept: float
    rvalue: float
    pvalue: float
    stderr: float
    n: int

    @property
    def r2(self) -> float:
        """Coefficient of determination r^2."""
        return self.rvalue**2

    def predict(self, x: ArrayLike) -> FloatArray:
        return self.slope * np.asarray(x, dtype=float) + self.intercept  # type: ignore[no-any-return]

    def to_dict(self) -> dict[str, float | int]:
        return {
            "slope": self.slope,
            "intercept": self.intercept,
            "r2": self.r2,
            "rvalue": self.rvalue,
            "pvalue": self.pvalue,
            "stderr": self.stderr,
            "n": self.n,
        }


def regress(x: ArrayLike, y: ArrayLike) -> Regression:
    """Linear regression of ``y`` on ``x`` (both shape (m,), m >= 3)."""
    from scipy.stats import linregress

    xa = np.asarray(x, dtype=float).ravel()
    ya = np.asarray(y, dtype=float).ravel()
    if xa.shape != ya.shape or xa.size < 3:
        raise ValueError("x and y must have the same length >= 3")
    r = linregress(xa, ya)
    return Regression(
        float(r.slope), float(r.intercept), float(r.rvalue), float(r.pvalue), float(r.stderr),
        int(xa.size),
    )  # fmt: skip


# =========================================================================================
# Targets
# =========================================================================================
def random_feasible_poses(
    stack: Stack,
    count: int,
    rng: np.random.Generator | int | None = None,
    phi: float = 0.0,
    box: Sequence[tuple[float, float]] | None = None,
    batch: int = 4096,
) -> FloatArray:
    """Random feasible planar poses by per-platform rejection sampling.

    Parameters
    ----------
    stack : Stack
    count : int
        Number of poses.
    rng : Generator, int or None
    phi : float
        Plane azimuth [rad] (the 3D limits depend on it).
    box : sequence of 3 (low, high) pairs, optional
        Sampling box of ``(rho_i, z_i, theta_i)`` [mm, mm, rad]; default
        ``(+-0.6 leg_max, (0.3 leg_min, leg_max), +-0.8 rad)`` of the largest platform.

    Returns
    -------
    q : ndarray, shape (count, n, 3)
    """
    gen = np.random.default_rng(rng)
    n = stack.n
    if box is None:
        lmax, lmin = float(np.max(stack.leg_max)), float(np.min(stack.leg_min))
        box = [(-0.6 * lmax, 0.6 * lmax), (0.3 * lmin, lmax), (-0.8, 0.8)]
    lo = np.array([b[0] for b in box], dtype=float)
    hi = np.array([b[1] for b in box], dtype=float)
    pools: list[list[FloatArray]] = [[] for _ in range(n)]
    have = np.zeros(n, dtype=int)
    for _ in range(10_000):
        if np.all(have >= count):
            break
        cand = lo + (hi - lo) * gen.random((batch, n, 3))
        ok = np.all(stack.planar_constraints(cand, phi) >= 0.0, axis=-1)  # (batch, n)
        for i in range(n):
            if have[i] < count:
                good = cand[ok[:, i], i]
                pools[i].append(good)
                have[i] += good.shape[0]
    else:  # pragma: no cover - only for a box that misses the feasible set
        raise RuntimeError("random_feasible_poses: too few feasible samples in the box")
    return np.stack([np.concatenate(p)[:count] for p in pools], axis=1)


def random_reachable_targets(
    stack: Stack,
    count: int,
    rng: np.random.Generator | int | None = None,
    phi: float = 0.0,
    box: Sequence[tuple[float, float]] | None = None,
) -> list[PlanarTarget]:
    """Reachable planar targets: forward kinematics of :func:`random_feasible_poses`."""
    from stackik.ik import PlanarTarget

    y = planar_forward(random_feasible_poses(stack, count, rng, phi, box))
    return [PlanarTarget(rho=float(a), z=float(b), theta=float(c), phi=phi) for a, b, c in y]


# =========================================================================================
# Non-optimal poses
# =========================================================================================
@dataclass(frozen=True)
class NonOptimalSearch:
    """Picklable callable: the first ``count`` feasible poses from perturbed paper starts.

    For each attempt ``k = 0, 1, ...`` the start is
    ``paper_initial_guess(stack, target) + N(0, perturbation)`` drawn in order from
    ``numpy.random.default_rng(seed)``; ``solve_ik(objective="feasible", x0=start)`` is
    run and successful results are kept until ``count`` are found or ``max_attempts``
    starts were tried.
    """

    stack: Stack
    count: int = 2
    seed: int = 0
    perturbation: tuple[float, float, float] = DEFAULT_PERTURBATION
    max_attempts: int = 20
    solve_kwargs: dict[str, Any] = field(default_factory=dict)

    def __call__(self, target: PlanarTarget) -> list[IKResult]:
        from stackik.ik import paper_initial_guess, solve_ik

        gen = np.random.default_rng(self.seed)
        g = paper_initial_guess(self.stack, target)
        found: list[IKResult] = []
        for _ in range(self.max_attempts):
            x0 = g + gen.normal(0.0, self.perturbation, g.shape)
            res = solve_ik(self.stack, target, objective="feasible", x0=x0, **self.solve_kwargs)
            if res.success:
                found.append(res)
                if len(found) >= self.count:
                    break
        return found


def nonoptimal_poses(
    stack: Stack,
    target: PlanarTarget,
    count: int = 2,
    seed: int = 0,
    perturbation: tuple[float, float, float] = DEFAULT_PERTURBATION,
    max_attempts: int = 20,
    **solve_kwargs: Any,
) -> list[IKResult]:
    """The paper's non-optimised poses of one target (see :class:`NonOptimalSearch`).

    Returns up to ``count`` successful :class:`~stackik.ik.IKResult` (fewer if
    ``max_attempts`` starts did not give enough).
    """
    return NonOptimalSearch(stack, count, seed, _triple(perturbation), max_attempts, solve_kwargs)(
        target
    )


# =========================================================================================
# Study
# =========================================================================================
@dataclass(frozen=True)
class WorkspaceStudy:
    """FN ratio and Monte Carlo median ratio of optimal vs non-optimal poses.

    Arrays have one entry per target (m,); entries of targets where either solve failed
    are NaN and ``valid`` is False.

    Attributes
    ----------
    targets : tuple of PlanarTarget
    valid : ndarray of bool, shape (m,)
    q_opt, q_non : ndarray, shape (m, n, 3)
        Optimal and (first) non-optimal pose.
    fn_opt, fn_non, fn_ratio : ndarray, shape (m,)
    median_opt, median_non, median_ratio : ndarray, shape (m,) [mm, mm, 1]
    regression : Regression or None
        ``median_ratio`` on ``fn_ratio`` over valid targets (None if fewer than 3).
    n_samples, sigma_t, sigma_theta : Monte Carlo settings.
    """

    targets: tuple[PlanarTarget, ...]
    valid: NDArray[np.bool_]
    q_opt: FloatArray
    q_non: FloatArray
    fn_opt: FloatArray
    fn_non: FloatArray
    median_opt: FloatArray
    median_non: FloatArray
    regression: Regression | None
    n_samples: int
    sigma_t: float
    sigma_theta: float

    @property
    def fn_ratio(self) -> FloatArray:
        return self.fn_opt / self.fn_non  # type: ignore[no-any-return]

    @property
    def median_ratio(self) -> FloatArray:
        return self.median_opt / self.median_non  # type: ignore[no-any-return]

    @property
    def positions(self) -> FloatArray:
        """Target ``(rho, z)``, shape (m, 2) [mm]."""
        return np.array([[t.rho, t.z] for t in self.targets])

    def rows(self) -> list[dict[str, float | bool]]:
        """One CSV-ready row per target."""
        out = []
        for i, t in enumerate(self.targets):
            out.append(
                {
                    "rho": t.rho,
                    "z": t.z,
                    "theta": t.theta,
                    "phi": t.phi,
                    "valid": bool(self.valid[i]),
                    "fn_opt": float(self.fn_opt[i]),
                    "fn_non": float(self.fn_non[i]),
                    "fn_ratio": float(self.fn_ratio[i]),
                    "median_opt": float(self.median_opt[i]),
                    "median_non": float(self.median_non[i]),
                    "median_ratio": float(self.median_ratio[i]),
                }
            )
        return out


def workspace_study(
    stack: Stack,
    targets: Sequence[PlanarTarget] | int,
    *,
    n_samples: int = 10_000,
    sigma_t: float = 1.0,
    sigma_theta: float = 0.005,
    seed: int = 0,
    phi: float = 0.0,
    perturbation: tuple[float, float, float] = DEFAULT_PERTURBATION,
    max_attempts: int = 10,
    progress: bool = False,
    executor: Executor | None = None,
    solve_kwargs: dict[str, Any] | None = None,
    checkpoint_dir: str | Path | None = None,
) -> WorkspaceStudy:
    """Compare the optimal and the first non-optimal pose on many targets.

    Parameters
    ----------
    stack : Stack
    targets : sequence of PlanarTarget or int
        Targets, or a number of targets drawn with :func:`random_reachable_targets`
        (seeded with ``seed``, in the plane ``phi``).
    n_samples, sigma_t, sigma_theta :
        Monte Carlo settings [-, mm, rad] (default: the paper's Table 1 level).
    seed : int
        Seeds the targets, the non-optimal starts and the Monte Carlo draws.
    perturbation : (float, float, float)
        Start perturbation of the non-optimal poses [mm, mm, rad].
    max_attempts : int
        Perturbed starts tried per target before giving up.
    progress : bool
        tqdm progress bars.
    executor : concurrent.futures.Executor, optional
        Spreads the solves (passed to :func:`stackik.solve_many` and ``executor.map``).
    solve_kwargs : dict, optional
        Extra keyword arguments of :func:`stackik.solve_ik`.
    checkpoint_dir : path, optional
        Folder for ``optimal.jsonl`` and ``nonoptimal.jsonl``: every finished solve is
        recorded there, and a rerun with the same arguments resumes where it stopped
        (:func:`stackik.batch.checkpointed_map`). The Monte Carlo is recomputed (seeded).
    """
    from stackik.ik import IKResult, solve_many, target_to_dict

    kw = dict(solve_kwargs or {})
    if isinstance(targets, int | np.integer):
        tlist = random_reachable_targets(stack, int(targets), rng=seed, phi=phi)
    else:
        tlist = list(targets)
    m, n = len(tlist), stack.n
    ckpt = None if checkpoint_dir is None else Path(checkpoint_dir)
    if ckpt is not None:
        ckpt.mkdir(parents=True, exist_ok=True)
    opt = solve_many(
        stack,
        tlist,
        objective="frobenius",
        progress=progress,
        executor=executor,
        checkpoint=None if ckpt is None else ckpt / "optimal.jsonl",
        **kw,
    )
    search = NonOptimalSearch(stack, 1, seed + 1, _triple(perturbation), max_attempts, kw)
    non = checkpointed_map(
        search,
        tlist,
        key=target_to_dict,
        encode=lambda rs: [r.to_record() for r in rs],
        decode=lambda data: [IKResult.from_record(d) for d in data],
        checkpoint=None if ckpt is None else ckpt / "nonoptimal.jsonl",
        executor=executor,
        progress=progress,
        desc="non-optimal",
    )

    valid = np.zeros(m, dtype=bool)
    q_opt = np.full((m, n, 3), np.nan)
    q_non = np.full((m, n, 3), np.nan)
    fn_opt, fn_non = np.full(m, np.nan), np.full(m, np.nan)
    med_opt, med_non = np.full(m, np.nan), np.full(m, np.nan)
    rows = range(m)
    if progress:
        from tqdm.auto import tqdm

        rows = tqdm(rows, desc="monte carlo", unit="target")
    for i in rows:
        if not (opt[i].success and non[i]):
            continue
        a, b = opt[i], non[i][0]
        mc = monte_carlo([a.q, b.q], n_samples, sigma_t, sigma_theta, rng=seed + 2)
        valid[i] = True
        q_opt[i], q_non[i] = a.q, b.q
        fn_opt[i], fn_non[i] = a.frobenius_norm, b.frobenius_norm
        med_opt[i], med_non[i] = mc.medians
    reg = None
    if valid.sum() >= 3:
        reg = regress(fn_opt[valid] / fn_non[valid], med_opt[valid] / med_non[valid])
    return WorkspaceStudy(
        targets=tuple(tlist),
        valid=valid,
        q_opt=q_opt,
        q_non=q_non,
        fn_opt=fn_opt,
        fn_non=fn_non,
        median_opt=med_opt,
        median_non=med_non,
        regression=reg,
        n_samples=int(n_samples),
        sigma_t=float(sigma_t),
        sigma_theta=float(sigma_theta),
    )
