"""Array arguments of the compiled kernels, in one canonical form.

numba compiles one machine-code specialisation per argument type, and a read-only array is
a different type from a writable one. Arrays reach the kernels from caches (read-only),
from fresh computations (writable) and from unpickled objects (writable again), so without
a rule a worker process could compile the same kernel a second time mid-solve. Every
geometry-derived array therefore enters a kernel through :func:`readonly`: contiguous
float64 and read-only, whatever it was.
"""

from __future__ import annotations

import reprlib

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["finite_array", "readonly"]


def readonly(a: ArrayLike) -> NDArray[np.float64]:
    """A read-only, C-contiguous float64 view of ``a`` (a copy only when ``a`` is not
    already contiguous float64)."""
    v = np.ascontiguousarray(a, dtype=float).view()
    v.setflags(write=False)
    return v


def finite_array(value: ArrayLike, name: str, shape: tuple[int, ...]) -> NDArray[np.float64]:
    """``value`` as a new float64 array of ``shape`` with finite entries, else a
    ``ValueError`` naming ``name`` that says what is wrong: not numbers, the wrong shape
    (the one got), or which entries are NaN or infinite."""
    want = str(shape) if len(shape) != 1 else f"({shape[0]},)"
    try:
        raw = np.asarray(value)
        if raw.dtype.kind not in "iuf":  # strings, booleans, None, ragged lists
            raise TypeError
        arr = np.array(raw, dtype=float)
    except (TypeError, ValueError):
        got = reprlib.repr(value)
        msg = f"{name}: expected an array of numbers of shape {want}, got {got}"
        raise ValueError(msg) from None
    if arr.shape != shape:
        raise ValueError(f"{name}: expected shape {want}, got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        where = [tuple(int(i) for i in ix) for ix in np.argwhere(bad)]
        at = ", ".join(str(w[0]) if len(w) == 1 else str(w) for w in where[:4])
        more = f" (and {len(where) - 4} more)" if len(where) > 4 else ""
        raise ValueError(f"{name}: must be finite; NaN or infinite at index {at}{more}")
    return arr
