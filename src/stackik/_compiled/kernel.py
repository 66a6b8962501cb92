"""The kernel interface: what the one barrier method (:mod:`stackik._compiled.barrier`)
asks of a mode's evaluation, and the registry that answers it.

The barrier method is written once; numba compiles it once per problem-data type (the
planar :class:`stackik._compiled.planar.PlanarData`, the spatial
:class:`stackik._compiled.spatial.SpatialData`). Each function below is a stub whose first
argument is that problem data ``P``; at compile time numba resolves the call to the
implementation the mode registered for ``type(P)`` (:func:`register`, called by the mode's
module right after its data type) and calls it directly: nothing is dispatched at run
time, and no function is compiled in between (:func:`_direct_call`). The compiled kernels
are cached like every other (the package stamp, :mod:`stackik._compiled`), so an edited
implementation recompiles the loop that calls it.

Every implementation takes the stub's arguments in the stub's order, ``P`` first, and
works in the scaled variables ``u = q / xs`` of ``P`` (:class:`stackik.formulation.Problem`'s
scaling). ``N`` below is the number of variables (3 n planar, 6 n spatial), ``E`` the number
of end-effector equalities (3, 6), ``m`` the inequality rows (the per-platform blocks, a
path step's box rows, then the dense rows: :mod:`stackik._compiled.dense_rows`).
"""

from __future__ import annotations

from typing import Any

from numba.core import types as nbtypes
from numba.core.errors import TypingError
from numba.extending import intrinsic

__all__ = [
    "chain_hessian",
    "chain_kkt_step",
    "chained",
    "clock_period",
    "eq_multipliers",
    "eq_transpose_dot",
    "evaluate",
    "hessian",
    "kkt_step",
    "kkt_solve",
    "register",
    "with_fscale",
]

#: The implementations by problem-data class, then by stub name.
_REGISTRY: dict[type, dict[str, Any]] = {}
#: The stubs' names; :func:`register` wants exactly these.
_HOOKS: list[str] = []


def register(data_class: type, **implementations: Any) -> None:
    """Register a mode: ``implementations`` maps every stub's name to the mode's jitted
    function with the stub's parameters (same names, same order) or those without the
    first, the problem data (then one specialisation serves every problem-data type) or,
    for :func:`clock_period` and :func:`chained`, an int. Raises ``ValueError`` when a
    stub is missing, a name is not a stub or a function's parameters are not the stub's."""
    missing = sorted(set(_HOOKS) - set(implementations))
    unknown = sorted(set(implementations) - set(_HOOKS))
    if missing or unknown:
        raise ValueError(
            f"kernel.register({data_class.__name__}): missing {missing}, unknown {unknown}"
        )
    for name, impl in implementations.items():
        if isinstance(impl, int):
            continue
        code = impl.py_func.__code__
        if code.co_varnames[: code.co_argcount] not in (_PARAMETERS[name], _PARAMETERS[name][1:]):
            raise ValueError(
                f"kernel.register({data_class.__name__}): {name} takes "
                f"{code.co_varnames[: code.co_argcount]}, not {_PARAMETERS[name]}"
            )
    _REGISTRY[data_class] = dict(implementations)


def _registered(name: str, P: Any) -> Any:
    """The function (or int) the mode of the problem data type ``P`` registered as ``name``."""
    cls = getattr(P, "instance_class", None)
    if cls not in _REGISTRY:
        raise TypingError(f"stackik._compiled.kernel.{name}: no mode registered for {P}")
    return _REGISTRY[cls][name]


def _direct_call(typingctx: Any, name: str, P: Any, args: tuple[Any, ...]) -> Any:
    """The typing of a stub's call (an intrinsic, below): the signature and the code of a
    direct call of the function the mode of ``P`` registered (a constant for an int). No
    function of its own is compiled in between: numba makes every compiled function a
    library and finishes it with its callees linked in, so a layer (an ``@overload``'s
    implementation, even one numba inlines) would compile its callee's code once more
    in every kernel family; the registered function is one library, shared with its
    callers elsewhere (the SQP method calls the evaluation and the Hessian itself)."""
    impl = _registered(name, P)
    if isinstance(impl, int):
        value = impl

        def constant(context: Any, builder: Any, sig: Any, llargs: Any) -> Any:
            return context.get_constant(nbtypes.int64, value)

        return nbtypes.int64(*args), constant
    # an implementation that does not need the problem data leaves it out (its first
    # parameter): then one specialisation serves every problem-data type (the lean and
    # the rows' kernel families, :func:`stackik._compiled.core.lean_type`)
    code = impl.py_func.__code__
    keep = 0 if code.co_varnames[: code.co_argcount] == _PARAMETERS[name] else 1
    disp = nbtypes.Dispatcher(impl)
    target = disp.get_call_type(typingctx, args[keep:], {})
    if target is None:
        raise TypingError(f"stackik._compiled.kernel.{name}: {impl} takes no {args}")

    def call(context: Any, builder: Any, sig: Any, llargs: Any) -> Any:
        values = [context.cast(builder, v, a, b)
                  for v, a, b in zip(llargs[keep:], sig.args[keep:], target.args,
                                     strict=True)]  # fmt: skip
        return context.get_function(disp, target)(builder, values)

    return target.return_type(*args), call


def _evaluate_call(typingctx: Any, u: Any, P: Any, lo: Any, hi: Any, ug: Any, wq: Any) -> Any:
    """``f, g, cE, AE, cI, AI, parts`` at ``u`` (N,): the scaled objective and gradient
    (N,), equalities (E,) and their Jacobian (E, N), inequality rows (m,) and their
    Jacobian as the pair ``AI = (blocks, dense rows)``, and whatever :func:`hessian` reuses
    (``parts``). ``lo``/``hi`` (N,; empty: none) add the box ``lo <= u <= hi`` as block rows
    and ``wq |u - ug|^2`` is added to the objective (a path step's extensions)."""
    return _direct_call(typingctx, "evaluate", P, (u, P, lo, hi, ug, wq))


evaluate: Any = intrinsic(_evaluate_call)


def _hessian_call(typingctx: Any, parts: Any, yE: Any, z: Any, P: Any, wq: Any) -> Any:
    """Hessian (N, N) of ``f - yE.cE - z.cI`` at the point :func:`evaluate` returned
    ``parts`` for, ``z`` the block rows' multipliers (the dense rows have no exact
    curvature); ``2 wq I`` for the distance term."""
    return _direct_call(typingctx, "hessian", P, (parts, yE, z, P, wq))


hessian: Any = intrinsic(_hessian_call)


def _kkt_step_call(typingctx: Any, P: Any, W: Any, AE: Any, cE: Any, rhs: Any,
                   last_shift: Any, try_plain: Any) -> Any:  # fmt: skip
    """``dx, shift, fac``: the Newton step of ``[W AE^T; AE 0] [dx; -y] = [rhs; -cE]`` with
    the reduced Hessian made positive definite by the smallest shift ``delta I`` that does
    it (inertia correction; ``last_shift`` the last nonzero shift, 0: none yet; the
    unshifted matrix tried first only when ``try_plain``, i.e. the previous step needed
    none), and the factor (a mode's own tuple) for :func:`kkt_solve`."""
    return _direct_call(typingctx, "kkt_step", P,
                        (P, W, AE, cE, rhs, last_shift, try_plain))  # fmt: skip


kkt_step: Any = intrinsic(_kkt_step_call)


def _kkt_solve_call(typingctx: Any, P: Any, fac: Any, W: Any, cE: Any, rhs: Any,
                    shift: Any) -> Any:  # fmt: skip
    """``dx`` (N,): the step of ``[W + shift I, AE^T; AE 0] [dx; -y] = [rhs; -cE]`` from
    :func:`kkt_step`'s factor of ``W`` and ``AE``: the Newton step, and with other
    ``cE`` and ``rhs`` its second-order corrections (no new factorisation)."""
    return _direct_call(typingctx, "kkt_solve", P, (P, fac, W, cE, rhs, shift))


kkt_solve: Any = intrinsic(_kkt_solve_call)


def _eq_multipliers_call(typingctx: Any, P: Any, AE: Any, g: Any, AItz: Any) -> Any:
    """Least-squares equality multipliers (E,): ``argmin |g - AI^T z - AE^T y|``."""
    return _direct_call(typingctx, "eq_multipliers", P, (P, AE, g, AItz))


eq_multipliers: Any = intrinsic(_eq_multipliers_call)


def _eq_transpose_dot_call(typingctx: Any, P: Any, AE: Any, y: Any) -> Any:
    """``AE^T y`` (N,)."""
    return _direct_call(typingctx, "eq_transpose_dot", P, (P, AE, y))


eq_transpose_dot: Any = intrinsic(_eq_transpose_dot_call)


def _with_fscale_call(typingctx: Any, P0: Any, fscale: Any) -> Any:
    """``P0`` with the objective scale ``fscale``."""
    return _direct_call(typingctx, "with_fscale", P0, (P0, fscale))


with_fscale: Any = intrinsic(_with_fscale_call)


def _clock_period_call(typingctx: Any, P: Any) -> Any:
    """Iterations between two reads of the clock (a read takes the GIL): more where an
    iteration is cheap."""
    return _direct_call(typingctx, "clock_period", P, (P,))


clock_period: Any = intrinsic(_clock_period_call)


def _chained_call(typingctx: Any, P: Any, N: Any) -> Any:
    """Whether the barrier loop's steps of the problem ``P`` with ``N`` variables are the
    mode's structured ones (:func:`chain_hessian`, :func:`chain_kkt_step`) instead of
    :func:`hessian` and :func:`kkt_step`; decided once a start, so that the plain step's
    code is what it is without them (0: never)."""
    return _direct_call(typingctx, "chained", P, (P, N))


chained: Any = intrinsic(_chained_call)


def _chain_hessian_call(typingctx: Any, parts: Any, yE: Any, z: Any, P: Any, wq: Any) -> Any:
    """:func:`hessian` for the structured step: the entries :func:`chain_kkt_step` reads
    (the others may be left zero)."""
    return _direct_call(typingctx, "chain_hessian", P, (parts, yE, z, P, wq))


chain_hessian: Any = intrinsic(_chain_hessian_call)


def _chain_kkt_step_call(typingctx: Any, P: Any, W: Any, AE: Any, cE: Any, rhs: Any,
                         last_shift: Any, try_plain: Any) -> Any:  # fmt: skip
    """:func:`kkt_step` from :func:`chain_hessian`'s ``W``, by the problem's structure; its
    factor is one :func:`kkt_solve` takes too."""
    return _direct_call(typingctx, "chain_kkt_step", P,
                        (P, W, AE, cE, rhs, last_shift, try_plain))  # fmt: skip


chain_kkt_step: Any = intrinsic(_chain_kkt_step_call)


#: The stubs' parameters by name (of their typing functions, ``typingctx`` left out).
_PARAMETERS: dict[str, tuple[str, ...]] = {
    name: fn.__code__.co_varnames[1 : fn.__code__.co_argcount]
    for name, fn in (("evaluate", _evaluate_call), ("hessian", _hessian_call),
                     ("kkt_step", _kkt_step_call), ("kkt_solve", _kkt_solve_call),
                     ("eq_multipliers", _eq_multipliers_call),
                     ("eq_transpose_dot", _eq_transpose_dot_call),
                     ("with_fscale", _with_fscale_call), ("clock_period", _clock_period_call),
                     ("chained", _chained_call), ("chain_hessian", _chain_hessian_call),
                     ("chain_kkt_step", _chain_kkt_step_call))
}  # fmt: skip
_HOOKS.extend(_PARAMETERS)
