"""Solve methods behind one interface (:class:`~stackik.methods.base.Method`), by name.

The registry is the one list of methods: :data:`METHOD_NAMES` (``"auto"`` first), the CLI's
``--method`` choices and the error for an unknown name derive from it. A new method is one
module with a :class:`Method` subclass and one line in :data:`_BUILTIN` (or a call to
:func:`register` from outside, e.g. a test's fake method).
"""

from __future__ import annotations

from stackik.methods.base import Method, Run, RunStatus, run_status
from stackik.methods.ip import IPMethod
from stackik.methods.ipopt import IpoptMethod
from stackik.methods.scipy_ import SLSQPMethod, TrustConstrMethod
from stackik.methods.sqp import SQPMethod

__all__ = [
    "AUTO",
    "METHOD_NAMES",
    "Method",
    "Run",
    "RunStatus",
    "get_method",
    "method_names",
    "register",
    "run_status",
    "unregister",
]

#: The name of the policy that picks a method per request (:mod:`stackik.solve.policy`).
AUTO = "auto"

_BUILTIN: tuple[Method, ...] = (
    SQPMethod(),
    IPMethod(),
    SLSQPMethod(),
    TrustConstrMethod(),
    IpoptMethod(),
)
_REGISTRY: dict[str, Method] = {m.name: m for m in _BUILTIN}


def method_names() -> tuple[str, ...]:
    """``"auto"`` and every registered method, in registration order."""
    return (AUTO, *_REGISTRY)


#: The built-in names (``"auto"``, ``"sqp"``, ``"ip"``, ``"slsqp"``, ``"trust-constr"``,
#: ``"ipopt"``); :func:`method_names` also lists methods registered later.
METHOD_NAMES: tuple[str, ...] = method_names()


def register(method: Method) -> None:
    """Make ``method`` available to :func:`stackik.solve_ik` under ``method.name``."""
    if method.name == AUTO or method.name in _REGISTRY:
        raise ValueError(f"method {method.name!r} is already registered")
    _REGISTRY[method.name] = method


def unregister(name: str) -> None:
    """Remove a method registered with :func:`register` (built-ins stay)."""
    if any(m.name == name for m in _BUILTIN):
        raise ValueError(f"method {name!r} is built in")
    _REGISTRY.pop(name, None)


def get_method(name: str) -> Method:
    """The registered method ``name``; ``ValueError`` listing the choices otherwise."""
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise ValueError(f"method: unknown {name!r}; choose one of {method_names()}") from None
