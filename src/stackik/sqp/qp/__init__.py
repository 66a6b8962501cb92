"""QP backends of the SQP engine and their registry.

Backends are discovered by try-import: ``daqp`` (default, dense active set), ``osqp``
(ADMM, persistent updates), ``clarabel`` (interior point, persistent updates) and any
solver known to :mod:`qpsolvers`, by ``"qpsolvers:NAME"`` or plain ``NAME``
(e.g. ``"quadprog"``, ``"piqp"``, ``"highs"``).
"""

from __future__ import annotations

import functools
import importlib
from collections.abc import Callable
from typing import Any

from .base import QPBackend, QPSolution, QPStatus

__all__ = [
    "SPARSE_BACKENDS",
    "QPBackend",
    "QPSolution",
    "QPStatus",
    "available_qp_solvers",
    "default_qp_solver",
    "make_backend",
]

#: Native backends, fastest first: name -> (module, class name).
_NATIVE: dict[str, tuple[str, str]] = {
    "daqp": ("daqp_", "DAQPBackend"),
    "osqp": ("osqp_", "OSQPBackend"),
    "clarabel": ("clarabel_", "ClarabelBackend"),
}

#: Backends that factorise sparse matrices (the engine's sparse mode pays off with them).
SPARSE_BACKENDS = frozenset({"osqp", "clarabel"})

_INSTALL_HINT = (
    "install a QP solver, e.g. `pip install daqp osqp clarabel` "
    "or `pip install qpsolvers[open_source_solvers]`"
)


@functools.cache
def _native_factory(name: str) -> Callable[[dict[str, Any] | None], QPBackend] | None:
    module_name, cls_name = _NATIVE[name]
    try:
        module = importlib.import_module(f"{__name__}.{module_name}")
    except ImportError:
        return None
    cls: Callable[[dict[str, Any] | None], QPBackend] = getattr(module, cls_name)
    return cls


def _qpsolvers_names() -> list[str]:
    try:
        from .qpsolvers_ import available
    except ImportError:
        return []
    return available()


@functools.cache
def _available() -> tuple[str, ...]:
    names = [name for name in _NATIVE if _native_factory(name) is not None]
    names += [f"qpsolvers:{s}" for s in _qpsolvers_names()]
    return tuple(names)


def available_qp_solvers() -> list[str]:
    """Names accepted by ``solve(..., qp_solver=NAME)`` in this environment.

    Returns
    -------
    list of str
        Native backends first (fastest first), then ``"qpsolvers:NAME"`` entries.
    """
    return list(_available())


def default_qp_solver() -> str:
    """Fastest installed dense backend: daqp, else osqp, else clarabel, else qpsolvers."""
    names = available_qp_solvers()
    if not names:
        raise ValueError(f"no QP solver available; {_INSTALL_HINT}")
    return names[0]


def make_backend(name: str, options: dict[str, Any] | None = None) -> QPBackend:
    """Instantiate the backend ``name``.

    Parameters
    ----------
    name : str
        ``"daqp"``, ``"osqp"``, ``"clarabel"``, ``"qpsolvers:NAME"`` or a plain qpsolvers
        solver name.
    options : dict, optional
        Settings passed straight through to the backend.

    Raises
    ------
    ValueError
        If the name is unknown or the solver is not installed.
    """
    if not isinstance(name, str):
        raise ValueError(f"qp_solver must be a string, got {name!r}")
    key = name.strip().lower()
    if key in _NATIVE:
        factory = _native_factory(key)
        if factory is not None:
            return factory(options)
    sub = key.split(":", 1)[1] if key.startswith("qpsolvers:") else key
    if f"qpsolvers:{sub}" in _available():
        from .qpsolvers_ import QPSolversBackend

        return QPSolversBackend(sub, options)
    raise ValueError(
        f"unknown or uninstalled QP solver {name!r}; available: "
        f"{', '.join(available_qp_solvers()) or 'none'}; {_INSTALL_HINT}"
    )
