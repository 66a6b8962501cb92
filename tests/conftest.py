"""Test session set-up."""

import pytest


@pytest.fixture(scope="session", autouse=True)
def _compiled_kernels():
    """Load or compile stackik's numba kernels once, before any test measures a time."""
    from stackik.solve.warmup import warm_up

    warm_up()
