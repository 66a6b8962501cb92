"""Test session set-up."""

import pytest


@pytest.fixture(scope="session", autouse=True)
def _compiled_kernels():
    """Compile stackik's numba kernels once, before any test measures a time limit."""
    from stackik.methods.ip import warm_up

    warm_up()
