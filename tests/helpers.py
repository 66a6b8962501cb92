"""Small assertion helpers shared by the test modules."""

from __future__ import annotations

import numpy as np


def assert_close(actual, expected, rtol, what=""):
    """max |actual - expected| <= rtol * max(1, max |expected|)."""
    actual = np.asarray(actual, dtype=float)
    expected = np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, (what, actual.shape, expected.shape)
    scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
    err = float(np.abs(actual - expected).max(initial=0.0))
    assert err <= rtol * scale, f"{what}: max error {err:.3e} > {rtol:.0e} * {scale:.3e}"
