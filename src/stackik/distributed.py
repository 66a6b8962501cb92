"""Scale-out: local process pools and Dask clusters for batches, studies and reproductions.

Everything that spreads work in stackik goes through :mod:`stackik.batch`, which takes a
:class:`concurrent.futures.Executor` or a Dask ``distributed.Client``
(:func:`stackik.solve_many`, :func:`stackik.analysis.workspace.workspace_study`,
:func:`stackik.analysis.reproduce.reproduce`, ``stackik map / mc / reproduce``). This
module makes those executors:

* :func:`connect` — a context manager: ``workers=K`` gives a local process pool of K
  processes (no Dask needed), ``scheduler="local:K"`` starts a Dask ``LocalCluster`` of K
  single-threaded worker processes, any other ``scheduler`` (``tcp://host:8786``)
  connects to a running Dask scheduler (``dask scheduler`` / ``dask worker``,
  dask-jobqueue, Kubernetes). Dask workers get the :class:`WarmUpPlugin`.
* :class:`WarmUpPlugin` — a ``distributed.WorkerPlugin`` that loads (or compiles) the
  numba kernels once per worker when it starts (also on workers that join later), in a
  thread so the worker keeps answering; with ``cache_dir`` it first points numba's cache
  at a directory the workers share (``NUMBA_CACHE_DIR``), so one compilation serves all.
  A process pool's processes do the same in their initializer.

Dask is imported only inside these functions (``pip install "stackik[dask]"``), so
``import stackik`` never needs it.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor
from contextlib import contextmanager
from pathlib import Path
from typing import Any

#: (``WarmUpPlugin`` is built on first access, so it is not in ``__all__``: a star
#: import must not need Dask.)
__all__ = [
    "PLUGIN_NAME",
    "connect",
    "describe",
    "parse_scheduler",
    "register_warm_up",
    "slots",
]

#: Name under which the warm-up plugin is registered (registering again replaces it).
PLUGIN_NAME = "stackik-warm-up"


def _use_cache_dir(cache_dir: str | os.PathLike[str] | None) -> bool:
    """Point numba's cache at ``cache_dir`` in this process; False when the kernels were
    already imported (numba fixes a function's cache location when it is defined)."""
    import sys

    if cache_dir is None:
        return True
    path = str(Path(cache_dir).expanduser().resolve())
    Path(path).mkdir(parents=True, exist_ok=True)
    kernels = (
        "stackik._compiled.planar",
        "stackik._compiled.check",
        "stackik._compiled.spatial_kinematics",
    )  # and _spatial_ipm
    if any(m.startswith(kernels) for m in list(sys.modules)):
        return os.environ.get("NUMBA_CACHE_DIR") == path
    os.environ["NUMBA_CACHE_DIR"] = path
    if "numba" in sys.modules:  # numba read its configuration at import: read it again
        from numba.core import config

        config.reload_config()
    return True


def _warm(kinds: tuple[str, ...], cache_dir: str | None) -> dict[str, Any]:
    """Load or compile the kernels in this process (a worker); what it did."""
    import time

    from stackik.solve.warmup import warm_up

    t0 = time.perf_counter()
    shared = _use_cache_dir(cache_dir)
    if not shared:
        import logging

        logging.getLogger(__name__).warning(
            "stackik: kernels already imported in process %d: cache_dir %s not used "
            "(set NUMBA_CACHE_DIR in the worker's environment instead)",
            os.getpid(),
            cache_dir,
        )
    seconds = warm_up(kinds, notice=False)
    if "planar" in kinds:  # first solves import what a solve imports on first use
        from stackik.geometry import Stack
        from stackik.solve import solve_ik
        from stackik.targets import PlanarTarget

        for objective in ("frobenius", "feasible"):
            solve_ik(Stack.reference(2), PlanarTarget(0.0, 700.0, 0.0), objective=objective)
    return {
        "pid": os.getpid(),
        "seconds": time.perf_counter() - t0,
        "kernel_seconds": seconds,
        "cache_dir": os.environ.get("NUMBA_CACHE_DIR"),
        "shared_cache": shared,
    }


def _plugin_class() -> type:
    """Build :class:`WarmUpPlugin` (on first use: it subclasses Dask's WorkerPlugin)."""
    cls = globals().get("_WARM_UP_PLUGIN")
    if cls is not None:
        return cls  # type: ignore[no-any-return]
    from distributed import WorkerPlugin

    class WarmUpPlugin(WorkerPlugin):  # type: ignore[misc]
        """Load (or compile) stackik's kernels once per Dask worker, when it starts.

        Parameters
        ----------
        cache_dir : path, optional
            numba cache directory the workers share (set as ``NUMBA_CACHE_DIR`` in the
            worker before the kernels are imported; every machine must see the same
            path, e.g. on a network file system). Default: numba's default location,
            beside stackik's sources, or the workers' own ``NUMBA_CACHE_DIR``.
        kinds : tuple of str
            Kernel sets (:data:`stackik.solve.warmup.KERNEL_KINDS`).
        """

        name = PLUGIN_NAME
        idempotent = False  # registering again (another cache_dir) replaces it

        def __init__(
            self,
            cache_dir: str | os.PathLike[str] | None = None,
            kinds: tuple[str, ...] = ("planar", "spatial"),
        ) -> None:
            self.cache_dir = None if cache_dir is None else str(cache_dir)
            self.kinds = tuple(kinds)
            self.report: dict[str, Any] | None = None

        async def setup(self, worker: Any) -> None:
            import asyncio

            # in a thread: a first compilation takes tens of seconds, and the worker's
            # event loop must keep answering the scheduler meanwhile
            self.report = await asyncio.to_thread(_warm, self.kinds, self.cache_dir)

    WarmUpPlugin.__module__ = __name__
    WarmUpPlugin.__qualname__ = "WarmUpPlugin"
    globals()["_WARM_UP_PLUGIN"] = WarmUpPlugin
    return WarmUpPlugin


def __getattr__(name: str) -> Any:
    if name == "WarmUpPlugin":  # built on first access (and on unpickling in a worker)
        return _plugin_class()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def register_warm_up(
    client: Any,
    cache_dir: str | os.PathLike[str] | None = None,
    kinds: tuple[str, ...] = ("planar", "spatial"),
) -> None:
    """Register :class:`WarmUpPlugin` with a Dask client: every current worker loads the
    kernels now (this call waits for them), every later worker when it starts."""
    client.register_plugin(_plugin_class()(cache_dir, kinds), name=PLUGIN_NAME)


def parse_scheduler(text: str) -> tuple[str, Any]:
    """``"local:K"`` -> ``("local", K)``; an address -> ``("address", text)``.

    Raises
    ------
    ValueError
        ``local:`` without a positive integer, or an empty address.
    """
    text = text.strip()
    if not text:
        raise ValueError("empty scheduler address")
    if text == "local" or text.startswith("local:"):
        _, _, k = text.partition(":")
        try:
            count = int(k) if k else (os.cpu_count() or 1)
        except ValueError:
            raise ValueError(f"expected local:K with an integer K, got {text!r}") from None
        if count < 1:
            raise ValueError(f"expected local:K with K >= 1, got {text!r}")
        return "local", count
    return "address", text


def _pool_initializer(cache_dir: str | None, kinds: tuple[str, ...]) -> None:
    _warm(kinds, cache_dir)


@contextmanager
def connect(
    scheduler: str | None = None,
    workers: int | None = None,
    *,
    cache_dir: str | os.PathLike[str] | None = None,
    warm: bool = True,
    kinds: tuple[str, ...] = ("planar", "spatial"),
) -> Iterator[Executor | Any | None]:
    """An executor for :mod:`stackik.batch` (closed on exit), or None for serial work.

    Parameters
    ----------
    scheduler : str, optional
        ``"local:K"``: start a Dask ``LocalCluster`` of K worker processes with one
        thread each (its HTTP server on a free port); an address
        (``"tcp://10.0.0.5:8786"``): connect to a running Dask scheduler (its cluster is
        left running on exit).
    workers : int, optional
        Without ``scheduler``: a local ``ProcessPoolExecutor`` of this many processes
        (1 or None: serial, yields None). With ``"local"`` (no K) it sets K.
    cache_dir : path, optional
        numba cache directory shared by the workers (:class:`WarmUpPlugin`).
    warm : bool
        Load the kernels in every worker before returning (Dask: the plugin; pool: the
        initializer, run when a process starts).
    kinds : tuple of str
        Kernel sets to load (``("planar",)`` for planar work: the spatial kernels are
        then loaded only by a worker that needs them).
    """
    cache = None if cache_dir is None else str(Path(cache_dir).expanduser().resolve())
    if scheduler is None:
        if workers is None or workers <= 1:
            yield None
            return
        if warm:
            pool = ProcessPoolExecutor(
                workers, initializer=_pool_initializer, initargs=(cache, tuple(kinds))
            )
        else:
            pool = ProcessPoolExecutor(workers)
        with pool:
            yield pool
        return
    kind, value = parse_scheduler(scheduler)
    if kind == "local" and scheduler.strip() == "local" and workers:
        value = workers
    try:
        from distributed import Client, LocalCluster
    except ImportError as exc:
        raise ImportError(
            f"a Dask scheduler needs Dask: pip install 'stackik[dask]' ({exc})"
        ) from None
    cluster = None
    if kind == "local":
        if cache is not None:
            _use_cache_dir(cache)  # inherited by the local worker processes
        cluster = LocalCluster(
            n_workers=int(value),
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # any free port: never collide with another cluster
        )
        client = Client(cluster)
    else:
        client = Client(value)
    try:
        if warm:
            register_warm_up(client, cache, kinds)
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def slots(executor: Any) -> int:
    """How many tasks ``executor`` runs at once (1 for None)."""
    from stackik.batch import executor_slots

    return executor_slots(executor)


def describe(executor: Any) -> str:
    """One line saying where the work runs."""
    if executor is None:
        return "serial (this process)"
    from stackik.batch import is_dask_client

    if is_dask_client(executor):
        info = executor.scheduler_info()
        n = len(info.get("workers", {}))
        return f"Dask scheduler {info.get('address', '?')}, {n} workers, {slots(executor)} threads"
    return f"{type(executor).__name__} of {slots(executor)} processes"
