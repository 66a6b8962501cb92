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


def test_cholesky_factor_and_solve_in_both_branches() -> None:
    """``A + shift I = R^T R`` with ``R`` upper triangular, from the loops (below 24 rows)
    and from LAPACK (24 on), and the solve with it; an indefinite matrix is refused, and
    its returned ``R`` is ``A + shift I`` itself (lower triangle as upper), as before."""
    from stackik._compiled.linalg import _cho_solve, _cholesky

    rng = np.random.default_rng(6)
    for k in (5, 23, 24, 60):
        X = rng.normal(size=(k, k))
        A = X @ X.T + k * np.eye(k)
        for shift in (0.0, 0.25):
            R, ok = _cholesky(A, shift)
            S = A + shift * np.eye(k)
            assert ok and np.array_equal(R, np.triu(R))
            np.testing.assert_allclose(R, np.linalg.cholesky(S).T, rtol=1e-12, atol=1e-12)
            b = rng.normal(size=k)
            np.testing.assert_allclose(_cho_solve(R, b), np.linalg.solve(S, b), rtol=1e-9)
        bad = A - 2.0 * np.abs(np.linalg.eigvalsh(A)).max() * np.eye(k)
        R, ok = _cholesky(bad, 0.5)
        assert not ok
        if k >= 24:  # LAPACK's refusal returns the matrix, as numba's copy was returned
            np.testing.assert_array_equal(R, np.triu(bad + 0.5 * np.eye(k)))


def test_cholesky_plus_is_the_factor_of_the_sum() -> None:
    """``_cholesky_plus(A, D, t)`` is ``_cholesky(A + t * D, 0.0)`` bit for bit, refusals
    and their returned matrix included, reading only the two lower triangles."""
    from stackik._compiled.linalg import _cholesky, _cholesky_plus

    rng = np.random.default_rng(7)
    for k in (6, 30, 100):
        X = rng.normal(size=(k, k))
        A = X @ X.T - 0.5 * k * np.eye(k)  # indefinite: small t refused, large t accepted
        Y = rng.normal(size=(3, k))
        D = Y.T @ Y + np.eye(k)
        upper = np.triu_indices(k, 1)
        A_lower, D_lower = A.copy(), D.copy()
        A_lower[upper] = np.nan
        D_lower[upper] = np.nan
        for t in (1e-4, 0.37, 1e2, 1e4):
            R, ok = _cholesky(A + t * D, 0.0)
            R2, ok2 = _cholesky_plus(A, D, t)
            assert ok == ok2 and np.array_equal(R, R2)
            if k >= 24:
                assert np.array_equal(R, _cholesky_plus(A_lower, D_lower, t)[0])


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
