"""Test session set-up."""

import pytest


@pytest.fixture(scope="session", autouse=True)
def _compiled_kernels():
    """Load or compile stackik's numba kernels once, before any test measures a time (on
    an empty cache the two modes' families compile in two processes at once)."""
    import os

    from stackik.solve.warmup import warm_up

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    warm_up(jobs=min(2, cores or 1))
