"""Array arguments of the compiled kernels, in one canonical form.

numba compiles one machine-code specialisation per argument type, and a read-only array is
a different type from a writable one. Arrays reach the kernels from caches (read-only),
from fresh computations (writable) and from unpickled objects (writable again), so without
a rule a worker process could compile the same kernel a second time mid-solve. Every
geometry-derived array therefore enters a kernel through :func:`readonly`: contiguous
float64 and read-only, whatever it was.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["readonly"]


def readonly(a: ArrayLike) -> NDArray[np.float64]:
    """A read-only, C-contiguous float64 view of ``a`` (a copy only when ``a`` is not
    already contiguous float64)."""
    v = np.ascontiguousarray(a, dtype=float).view()
    v.setflags(write=False)
    return v
