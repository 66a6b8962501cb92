"""Optimal versus non-optimal poses over the workspace (paper figures "ratio" and "MedianRatio").

Choices (documented, not given by the paper):

* **Targets** (``sampling="uniform"``, the default) are spread evenly over the reachable
  ``(rho, z)`` region, so that the FN-ratio map covers the workspace as the paper's
  figure of "found solutions" does (the paper does not say how its targets were drawn)
  and the edge of the workspace, where the optimisation has least freedom, weighs as
  much as the interior. A pool of random *feasible poses* is drawn (every platform's
  ``(rho_i, z_i, theta_i)`` uniformly in a box that contains its whole feasible set,
  :func:`~stackik.sampling.platform_box`, kept when its 24 limits hold; the limits of
  one platform depend on its own variables only, so platforms are drawn independently),
  their forward kinematics in the plane ``phi`` give reachable targets, and these are
  thinned to an even density on a grid of ``cell`` x ``cell`` mm squares: cells are
  visited in a random order, one target each, round after round
  (:func:`~stackik.sampling.uniform_reachable_targets`). Every target is therefore
  reachable; theta keeps its distribution among the pool's targets of the same cell.
  ``sampling="poses"`` keeps the forward kinematics of random feasible poses unthinned
  (:func:`~stackik.sampling.random_reachable_targets`): they cluster where the stack
  reaches most easily and under-represent the edge of the workspace, where the FN ratio
  is close to 1; with the reference geometry this narrows the range of FN ratios and
  lowers the regression's r^2 markedly (README, "Reproducing the paper").
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
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from stackik.analysis.montecarlo import monte_carlo
from stackik.batch import checkpointed_map
from stackik.geometry import Stack
from stackik.sampling import (  # re-exported: the workspace study's targets
    platform_box,
    random_feasible_poses,
    random_reachable_targets,
    uniform_reachable_targets,
)

if TYPE_CHECKING:
    from stackik.result import IKResult
    from stackik.targets import PlanarTarget

__all__ = [
    "DEFAULT_PERTURBATION",
    "MedianPair",
    "NonOptimalSearch",
    "Regression",
    "WorkspaceStudy",
    "nonoptimal_poses",
    "platform_box",
    "random_feasible_poses",
    "random_reachable_targets",
    "regress",
    "study_targets",
    "uniform_reachable_targets",
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

    def prepare(self) -> None:
        """Load the compiled kernels once per process (called by workers before a chunk)."""
        from stackik.solve.warmup import warm_up

        warm_up(("planar",), notice=False)

    def starts(self, target: PlanarTarget) -> FloatArray:
        """All ``max_attempts`` perturbed starts, shape (max_attempts, n, 3), in draw order
        (the same values the sequential search draws one by one)."""
        from stackik.starts import paper_initial_guess

        g = paper_initial_guess(self.stack, target)
        gen = np.random.default_rng(self.seed)
        return g + gen.normal(0.0, self.perturbation, (self.max_attempts, *g.shape))  # type: ignore[no-any-return]

    def attempt(self, target: PlanarTarget, x0: FloatArray) -> IKResult:
        """One feasibility solve from ``x0``."""
        from stackik.solve import solve_ik

        return solve_ik(self.stack, target, objective="feasible", x0=x0, **self.solve_kwargs)

    def __call__(self, target: PlanarTarget) -> list[IKResult]:
        from stackik.solve import solve_ik
        from stackik.starts import paper_initial_guess

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


@dataclass(frozen=True)
class _Attempt:
    """Picklable: :meth:`NonOptimalSearch.attempt` of one target from a given start."""

    search: NonOptimalSearch
    target: PlanarTarget

    def prepare(self) -> None:
        self.search.prepare()

    def __call__(self, x0: FloatArray) -> IKResult:
        return self.search.attempt(self.target, x0)


@dataclass(frozen=True)
class MedianPair:
    """Picklable callable: Monte Carlo medians of an (optimal, non-optimal) pose pair.

    ``MedianPair(...)((q_opt, q_non))`` is ``monte_carlo([q_opt, q_non], n_samples,
    sigma_t, sigma_theta, rng=seed).medians`` (common draws for the two poses, the same
    seed for every pair): the Monte Carlo stage of :func:`workspace_study`, which an
    executor spreads like the solves.
    """

    n_samples: int
    sigma_t: float
    sigma_theta: float
    seed: int

    def __call__(self, poses: tuple[FloatArray, FloatArray]) -> tuple[float, float]:
        mc = monte_carlo(
            list(poses), self.n_samples, self.sigma_t, self.sigma_theta, rng=self.seed,
            keep_samples=False,
        )  # fmt: skip
        a, b = mc.medians
        return float(a), float(b)


def nonoptimal_poses(
    stack: Stack,
    target: PlanarTarget,
    count: int = 2,
    seed: int = 0,
    perturbation: tuple[float, float, float] = DEFAULT_PERTURBATION,
    max_attempts: int = 20,
    executor: Executor | Any | None = None,
    **solve_kwargs: Any,
) -> list[IKResult]:
    """The paper's non-optimised poses of one target (see :class:`NonOptimalSearch`).

    With ``executor`` (a pool or a Dask client) the starts are tried in waves of as many
    as the executor runs at once, and the first ``count`` successes in draw order are
    kept: the poses of the sequential search, sooner when the first starts fail.

    Returns up to ``count`` successful :class:`~stackik.result.IKResult` (fewer if
    ``max_attempts`` starts did not give enough).
    """
    search = NonOptimalSearch(stack, count, seed, _triple(perturbation), max_attempts, solve_kwargs)
    if executor is None:
        return search(target)
    from stackik.batch import executor_slots

    starts = search.starts(target)
    wave = max(2, executor_slots(executor))
    found: list[IKResult] = []
    for a in range(0, max_attempts, wave):
        results = checkpointed_map(
            _Attempt(search, target),
            list(starts[a : a + wave]),
            key=lambda x0: None,
            encode=lambda r: r,
            decode=lambda r: r,
            executor=executor,
            chunksize=1,
        )
        for r in results:
            if r.success:
                found.append(r)
                if len(found) >= count:
                    return found
    return found


def _essentials(r: IKResult) -> tuple[bool, FloatArray, float]:
    """What the study keeps of a result: success (the non-optimal search keeps successes
    only), pose and FN."""
    return bool(r.success), np.array(r.q, dtype=float), float(r.frobenius_norm)


def study_targets(
    stack: Stack,
    count: int,
    *,
    seed: int = 0,
    phi: float = 0.0,
    sampling: Literal["uniform", "poses"] = "uniform",
    cell: float = 100.0,
) -> list[PlanarTarget]:
    """The targets :func:`workspace_study` draws when given a number (same arguments)."""
    if sampling == "uniform":
        return uniform_reachable_targets(stack, int(count), rng=seed, phi=phi, cell=cell)
    if sampling == "poses":
        return random_reachable_targets(stack, int(count), rng=seed, phi=phi)
    raise ValueError(f"sampling must be 'uniform' or 'poses', got {sampling!r}")


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
    executor: Executor | Any | None = None,
    solve_kwargs: dict[str, Any] | None = None,
    checkpoint_dir: str | Path | None = None,
    sampling: Literal["uniform", "poses"] = "uniform",
    cell: float = 100.0,
) -> WorkspaceStudy:
    """Compare the optimal and the first non-optimal pose on many targets.

    Parameters
    ----------
    stack : Stack
    targets : sequence of PlanarTarget or int
        Targets, or a number of targets drawn (seeded with ``seed``, in the plane ``phi``)
        as ``sampling`` says.
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
    executor : concurrent.futures.Executor or distributed.Client, optional
        Spreads the optimal solves (:func:`stackik.solve_many`), the non-optimal searches
        and the Monte Carlo stage (:class:`MedianPair`), each in chunks
        (:mod:`stackik.batch`); the results are those of a serial run.
    solve_kwargs : dict, optional
        Extra keyword arguments of :func:`stackik.solve_ik`.
    checkpoint_dir : path, optional
        Folder for ``optimal.jsonl`` and ``nonoptimal.jsonl``: every finished solve is
        recorded there, and a rerun with the same arguments resumes where it stopped
        (:func:`stackik.batch.checkpointed_map`). The Monte Carlo is recomputed (seeded).
    sampling : {"uniform", "poses"}
        How a number of targets is drawn: evenly over the reachable ``(rho, z)`` region
        (:func:`~stackik.sampling.uniform_reachable_targets` with squares of ``cell``
        mm), or as the forward kinematics of random feasible poses
        (:func:`~stackik.sampling.random_reachable_targets`).
    cell : float
        Grid size of the uniform sampling [mm].
    """
    if sampling not in ("uniform", "poses"):
        raise ValueError(f"sampling must be 'uniform' or 'poses', got {sampling!r}")
    kw = dict(solve_kwargs or {})
    if isinstance(targets, int | np.integer):
        tlist = study_targets(stack, int(targets), seed=seed, phi=phi, sampling=sampling, cell=cell)
    else:
        tlist = list(targets)
    ckpt = None if checkpoint_dir is None else Path(checkpoint_dir)
    if ckpt is not None:
        ckpt.mkdir(parents=True, exist_ok=True)
    search = NonOptimalSearch(stack, 1, seed + 1, _triple(perturbation), max_attempts, kw)
    valid, q_opt, q_non, fn_opt, fn_non = _pose_pairs(
        stack, tlist, search, kw, progress, executor, ckpt
    )
    median = MedianPair(int(n_samples), float(sigma_t), float(sigma_theta), seed + 2)
    med_opt, med_non = _pair_medians(median, valid, q_opt, q_non, progress, executor)
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


def _pose_pairs(
    stack: Stack,
    tlist: list[PlanarTarget],
    search: NonOptimalSearch,
    kw: dict[str, Any],
    progress: bool,
    executor: Any,
    ckpt: Path | None,
) -> tuple[NDArray[np.bool_], FloatArray, FloatArray, FloatArray, FloatArray]:
    """The optimal and the first non-optimal pose of every target, and their FN.

    Returns ``(valid, q_opt, q_non, fn_opt, fn_non)``; ``valid[i]``: both poses were found
    (the arrays hold NaN elsewhere). Only (success, pose, FN) of every result stays in
    memory; the checkpoints under ``ckpt`` hold it all.
    """
    from stackik.result import IKResult
    from stackik.solve import solve_many
    from stackik.targets import target_to_dict

    opt = solve_many(
        stack,
        tlist,
        objective="frobenius",
        progress=progress,
        executor=executor,
        checkpoint=None if ckpt is None else ckpt / "optimal.jsonl",
        reduce=_essentials,
        **kw,
    )
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
        reduce=lambda rs: _essentials(rs[0]) if rs else (False, None, np.nan),
    )
    m, n = len(tlist), stack.n
    valid = np.zeros(m, dtype=bool)
    q_opt = np.full((m, n, 3), np.nan)
    q_non = np.full((m, n, 3), np.nan)
    fn_opt, fn_non = np.full(m, np.nan), np.full(m, np.nan)
    for i in range(m):
        (ok_a, qa, fa), (ok_b, qb, fb) = opt[i], non[i]
        if ok_a and ok_b:
            valid[i] = True
            q_opt[i], q_non[i] = qa, qb
            fn_opt[i], fn_non[i] = fa, fb
    return valid, q_opt, q_non, fn_opt, fn_non


def _pair_medians(
    median: MedianPair,
    valid: NDArray[np.bool_],
    q_opt: FloatArray,
    q_non: FloatArray,
    progress: bool,
    executor: Any,
) -> tuple[FloatArray, FloatArray]:
    """Monte Carlo median displacement of the optimal and non-optimal pose of each valid
    target (NaN where not valid)."""
    m = valid.shape[0]
    med_opt, med_non = np.full(m, np.nan), np.full(m, np.nan)
    rows = np.flatnonzero(valid)
    medians = checkpointed_map(
        median,
        [(q_opt[i], q_non[i]) for i in rows],
        key=lambda pair: None,
        encode=list,
        decode=tuple,
        executor=executor,
        progress=progress,
        desc="monte carlo",
    )
    for i, (mo, mn) in zip(rows.tolist(), medians, strict=True):
        med_opt[i], med_non[i] = mo, mn
    return med_opt, med_non
