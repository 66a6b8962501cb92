"""The BLAS thread limit of one solve, applied on first need."""

from __future__ import annotations

from typing import Any

__all__ = ["BlasLimit"]

_BLAS: list[Any] = []


class BlasLimit:
    """The BLAS thread limit of one solve, applied on first need: the planar compiled
    interior-point path below 32 platforms does not call threaded BLAS, so it skips the
    threadpoolctl round trip (about 20 us, 5 % of an n = 4 solve); every other path
    (SQP, scipy, IPOPT, the spatial chain, the spatial interior point, whose KKT step
    multiplies (6n)^2 matrices) calls :meth:`apply` before it runs. Multi-threaded
    OpenBLAS on such small matrices on a loaded machine was measured 300x slower."""

    def __init__(self, threads: int | None) -> None:
        self.threads = threads
        self._limiter: Any = None

    def apply(self) -> None:
        if self.threads is not None and self._limiter is None:
            self._limiter = _blas_controller().limit(limits=self.threads, user_api="blas")

    def restore(self) -> None:
        if self._limiter is not None:
            self._limiter.restore_original_limits()
            self._limiter = None


def _blas_controller() -> Any:
    """A cached :class:`threadpoolctl.ThreadpoolController` (creating one scans the libs)."""
    if not _BLAS:
        from threadpoolctl import ThreadpoolController

        _BLAS.append(ThreadpoolController())
    return _BLAS[0]
