"""Small assertion helpers shared by the test modules."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import numpy as np


def assert_close(actual, expected, rtol, what=""):
    """max |actual - expected| <= rtol * max(1, max |expected|)."""
    actual = np.asarray(actual, dtype=float)
    expected = np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, (what, actual.shape, expected.shape)
    scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
    err = float(np.abs(actual - expected).max(initial=0.0))
    assert err <= rtol * scale, f"{what}: max error {err:.3e} > {rtol:.0e} * {scale:.3e}"


@contextlib.contextmanager
def screen_off() -> Iterator[None]:
    """The paper's model while in the block: on stacks whose legs and plates have no size a
    leg's axis may pass through a plate (the check's screen for it,
    :func:`stackik.clearance.cores_cross`, answers no). Stacks with a leg radius, a plate
    thickness, obstacles or a margin are checked as always."""
    import stackik.check
    import stackik.clearance

    def never(*args: object, **kwargs: object) -> bool:
        return False

    saved = stackik.clearance.cores_cross, stackik.check.cores_cross
    stackik.clearance.cores_cross = stackik.check.cores_cross = never
    try:
        yield
    finally:
        stackik.clearance.cores_cross, stackik.check.cores_cross = saved
