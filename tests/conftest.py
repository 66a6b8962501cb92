"""Test session set-up."""

from collections.abc import Iterator

import pytest


@pytest.fixture(scope="session", autouse=True)
def _compiled_kernels(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Load or compile stackik's numba kernels once, before any test measures a time (on
    an empty cache the two modes' families compile in two processes at once). Under
    pytest-xdist's workers one worker compiles while the others wait on a file lock, then
    load what it cached."""
    import os

    from stackik.solve.warmup import warm_up

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    jobs = min(2, cores or 1)
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        warm_up(jobs=jobs)
        return
    try:
        import fcntl
    except ImportError:  # no POSIX locks (Windows): each worker loads or compiles on its
        # own (docs/guide/start.md: a first session on an empty cache with -n 0)
        warm_up(jobs=jobs)
        return
    lock = tmp_path_factory.getbasetemp().parent / "stackik-warm-up.lock"
    with open(lock, "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            warm_up(jobs=jobs)
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


@pytest.fixture
def lines_pass_through() -> Iterator[None]:
    """The paper's model on stacks whose legs and plates have no size: a leg's axis may
    pass through a plate (:func:`helpers.screen_off`). For tests that need the least-FN
    pose of that model (on tall planar stacks it passes legs through plates:
    docs/clearance.md, "Cores through plates"), or that test the start plan's scheduling
    apart from the repair of such poses."""
    from helpers import screen_off

    with screen_off():
        yield
