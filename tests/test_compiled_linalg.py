"""The compiled kernels' least-norm solve (the polishes' step) cuts singular values as
numpy does, so twin rows that differ by rounding do not blow the step up."""

from __future__ import annotations

import numpy as np

from stackik._compiled.linalg import min_norm_solve


def test_min_norm_solve_ignores_rounding_sized_singular_values() -> None:
    rng = np.random.default_rng(3)
    A = rng.normal(size=(4, 9))
    A = np.vstack([A, A[2] * (1.0 + 1e-16) + 1e-17])  # a twin row, apart by rounding
    b = rng.normal(size=5) * 1e-10
    b[4] = b[2] + 3e-26
    x = min_norm_solve(A, b)
    ref = np.linalg.lstsq(A, b, rcond=None)[0]
    assert np.abs(x).max() < 1e-8  # a step of the size of b, not of rounding / 1e-17
    assert np.allclose(x, ref, rtol=1e-8, atol=1e-18)


def test_cholesky_reads_only_the_lower_triangle() -> None:
    """The planar KKT step forms only the lower triangle of its reduced Hessian."""
    from stackik._compiled.linalg import _cholesky

    rng = np.random.default_rng(5)
    for k in (10, 30, 189):  # the loops below 24, LAPACK above
        X = rng.normal(size=(k, k))
        A = X @ X.T + k * np.eye(k)
        B = A.copy()
        upper = np.triu_indices(k, 1)
        B[upper] = np.nan
        for shift in (0.0, 0.5):
            (La, oka), (Lb, okb) = _cholesky(A, shift), _cholesky(B, shift)
            assert oka and okb and np.array_equal(La, Lb)
