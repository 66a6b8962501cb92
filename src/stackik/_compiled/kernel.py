"""The kernel interface: what the one barrier method (:mod:`stackik._compiled.barrier`)
asks of a mode's evaluation, and the registry that answers it.

The barrier method is written once; numba compiles it once per problem-data type (the
planar :class:`stackik._compiled.planar.PlanarData`, the spatial
:class:`stackik._compiled.spatial.SpatialData`). Each function below is a stub whose first
argument is that problem data ``P``; at compile time numba resolves the call to the
implementation the mode registered for ``type(P)`` (:func:`register`, called by the mode's
module right after its data type), so the mode-specific code is inlined where the loop
calls it and nothing is dispatched at run time. The compiled kernels are cached like every
other (the package stamp, :mod:`stackik._compiled`), so an edited implementation
recompiles the loop that inlined it.

Every implementation takes the stub's arguments in the stub's order, ``P`` first, and
works in the scaled variables ``u = q / xs`` of ``P`` (:class:`stackik.formulation.Problem`'s
scaling). ``N`` below is the number of variables (3 n planar, 6 n spatial), ``E`` the number
of end-effector equalities (3, 6), ``m`` the inequality rows (the per-platform blocks, a
path step's box rows, then the dense rows: :mod:`stackik._compiled.dense_rows`).
"""

from __future__ import annotations

import types
from typing import Any

from numba.core.errors import TypingError
from numba.extending import overload

from stackik._compiled.core import _OVERLOAD, unresolved

__all__ = [
    "clock_period",
    "eq_multipliers",
    "eq_transpose_dot",
    "evaluate",
    "hessian",
    "kkt_step",
    "register",
    "with_fscale",
]

#: The implementations by problem-data class, then by stub name.
_REGISTRY: dict[type, dict[str, Any]] = {}
#: The stubs' names; :func:`register` wants exactly these.
_HOOKS: list[str] = []


def register(data_class: type, **implementations: Any) -> None:
    """Register a mode: ``implementations`` maps every stub's name to the mode's jitted
    function with the stub's parameters (same names, same order; numba checks) or, for
    :func:`clock_period`, an int. Raises ``ValueError`` when a stub is missing or a name is
    not a stub."""
    missing = sorted(set(_HOOKS) - set(implementations))
    unknown = sorted(set(implementations) - set(_HOOKS))
    if missing or unknown:
        raise ValueError(
            f"kernel.register({data_class.__name__}): missing {missing}, unknown {unknown}"
        )
    _REGISTRY[data_class] = dict(implementations)


def _implementation(name: str, P: Any) -> Any:
    """The Python function numba compiles in place of the stub ``name`` for the problem
    data type ``P``: the registered function's own source, so that the call costs what a
    direct call of it costs (a forwarding layer would pass ``P``, a tuple of some thirty
    arrays, once more)."""
    cls = getattr(P, "instance_class", None)
    if cls not in _REGISTRY:
        raise TypingError(f"stackik._compiled.kernel.{name}: no mode registered for {P}")
    impl = _REGISTRY[cls][name]
    if isinstance(impl, int):
        value = impl

        def constant(P):  # type: ignore[no-untyped-def]
            return value

        return constant
    # the function's own code, without its annotations: numba requires the parameters of
    # the typing function (below: names only) and of the implementation to be equal
    fn = impl.py_func
    bare = types.FunctionType(fn.__code__, fn.__globals__, fn.__name__, fn.__defaults__,
                              fn.__closure__)  # fmt: skip
    bare.__annotations__ = {}
    return bare


def evaluate(u: Any, P: Any, lo: Any, hi: Any, ug: Any, wq: float) -> Any:
    """``f, g, cE, AE, cI, AI, parts`` at ``u`` (N,): the scaled objective and gradient
    (N,), equalities (E,) and their Jacobian (E, N), inequality rows (m,) and their
    Jacobian as the pair ``AI = (blocks, dense rows)``, and whatever :func:`hessian` reuses
    (``parts``). ``lo``/``hi`` (N,; empty: none) add the box ``lo <= u <= hi`` as block rows
    and ``wq |u - ug|^2`` is added to the objective (a path step's extensions)."""
    return unresolved()


def hessian(parts: Any, yE: Any, z: Any, P: Any, wq: float) -> Any:
    """Hessian (N, N) of ``f - yE.cE - z.cI`` at the point :func:`evaluate` returned
    ``parts`` for, ``z`` the block rows' multipliers (the dense rows have no exact
    curvature); ``2 wq I`` for the distance term."""
    return unresolved()


def kkt_step(P: Any, W: Any, AE: Any, cE: Any, rhs: Any, last_shift: float,
             try_plain: bool) -> Any:  # fmt: skip
    """``dx, shift``: the Newton step of ``[W AE^T; AE 0] [dx; -y] = [rhs; -cE]`` with the
    reduced Hessian made positive definite by the smallest shift ``delta I`` that does it
    (inertia correction; ``last_shift`` the last nonzero shift, 0: none yet; the unshifted
    matrix tried first only when ``try_plain``, i.e. the previous step needed none)."""
    return unresolved()


def eq_multipliers(P: Any, AE: Any, g: Any, AItz: Any) -> Any:
    """Least-squares equality multipliers (E,): ``argmin |g - AI^T z - AE^T y|``."""
    return unresolved()


def eq_transpose_dot(P: Any, AE: Any, y: Any) -> Any:
    """``AE^T y`` (N,)."""
    return unresolved()


def with_fscale(P0: Any, fscale: float) -> Any:
    """``P0`` with the objective scale ``fscale``."""
    return unresolved()


def clock_period(P: Any) -> Any:
    """Iterations between two reads of the clock (a read takes the GIL): more where an
    iteration is cheap."""
    return unresolved()


# the typing functions: the parameters of their stubs (numba compares the names), each the
# registered implementation for the problem data's type
_HOOKS.extend(
    ["evaluate", "hessian", "kkt_step", "eq_multipliers", "eq_transpose_dot", "with_fscale",
     "clock_period"]
)  # fmt: skip


@overload(evaluate, jit_options=_OVERLOAD)
def _evaluate(u, P, lo, hi, ug, wq):  # type: ignore[no-untyped-def]
    return _implementation("evaluate", P)


@overload(hessian, jit_options=_OVERLOAD)
def _hessian(parts, yE, z, P, wq):  # type: ignore[no-untyped-def]
    return _implementation("hessian", P)


@overload(kkt_step, jit_options=_OVERLOAD)
def _kkt_step(P, W, AE, cE, rhs, last_shift, try_plain):  # type: ignore[no-untyped-def]
    return _implementation("kkt_step", P)


@overload(eq_multipliers, jit_options=_OVERLOAD)
def _eq_multipliers(P, AE, g, AItz):  # type: ignore[no-untyped-def]
    return _implementation("eq_multipliers", P)


@overload(eq_transpose_dot, jit_options=_OVERLOAD)
def _eq_transpose_dot(P, AE, y):  # type: ignore[no-untyped-def]
    return _implementation("eq_transpose_dot", P)


@overload(with_fscale, jit_options=_OVERLOAD)
def _with_fscale(P0, fscale):  # type: ignore[no-untyped-def]
    return _implementation("with_fscale", P0)


@overload(clock_period, jit_options=_OVERLOAD)
def _clock_period(P):  # type: ignore[no-untyped-def]
    return _implementation("clock_period", P)
