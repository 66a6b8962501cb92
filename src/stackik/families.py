"""Constraint families a user adds: rows ``c(q) >= 0`` defined once per mode, carried by
every engine that takes them.

A family is a subclass of :class:`ConstraintFamily` with one definition of its rows per
mode (:meth:`~ConstraintFamily.planar_rows`, :meth:`~ConstraintFamily.spatial_rows`:
values and their Jacobian against the pose, in the family's own unit, e.g. mm). An
instance passed as ``solve_ik(..., constraints=[family])`` (or
``check_pose(..., constraints=...)``) is then

- appended to the inequality rows of :class:`stackik.formulation.Problem` (after the
  obstacle and leg-pair rows, before the leg-force rows), which is what the SQP engine
  (``method="sqp"``, its dense formulation with damped BFGS, every QP backend), SLSQP and
  trust-constr solve;
- carried by both compiled interior points (``method="ip"``, the default) as *dense rows*
  (:mod:`stackik._compiled.dense_rows`): the kernel calls back into Python for the rows
  (numba object mode, :func:`kernel_rows`) through a token in the problem data, so a new
  family needs no compiled code and no recompilation; its curvature is not formed (as for
  the obstacle rows);
- enforced by the acceptance rule (:func:`stackik.check.check_pose`): a pose whose
  family rows are below ``-FEAS_TOL`` (in the family's unit) is not a success.
  The check uses the family's values (:meth:`~ConstraintFamily.check_values`, by default
  the same rows); a family may override it with an independent plain implementation.

Registration by name (:func:`register_family`, :func:`family`) serves files and the
command line; passing an instance needs none. ``method="ipopt"`` does not carry user
families (its rows are symbolic): it refuses a problem with one.

Scaling: the solvers see ``c / scale`` with :meth:`~ConstraintFamily.row_scale` (default
the stack's longest leg [mm], as for the other length rows).
"""

from __future__ import annotations

import contextlib
import itertools
import threading
import weakref
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from stackik.geometry import Stack

__all__ = [
    "ConstraintFamily",
    "FamilyError",
    "FamilyRows",
    "family",
    "family_names",
    "kernel_rows",
    "register_family",
]

FloatArray = NDArray[np.float64]


class FamilyError(ValueError):
    """A constraint family failed: its rows raised, or came with the wrong shape or a
    row count that changed. Every engine lets it through (a failing start of a solver is
    otherwise a failed run): the family is broken, not the start."""


class ConstraintFamily:
    """A family of inequality rows ``c(q) >= 0`` on the poses of a stack (subclass it).

    Subclasses define :meth:`planar_rows` and/or :meth:`spatial_rows` (a mode left
    undefined raises ``ValueError`` when solved in it), and may override
    :meth:`row_scale` and :meth:`check_values`. Instances must not change once passed to
    a solve (the solvers evaluate them many times).
    """

    #: the name the family is registered under (:func:`register_family`)
    name: str = ""

    def planar_rows(self, stack: Stack, q: FloatArray, phi: float) -> tuple[FloatArray, FloatArray]:
        """Rows of a planar pose ``q`` (n, 3) [mm, mm, rad] in the plane at angle ``phi``
        [rad]: values ``c`` (m,) in the family's unit and their Jacobian (m, 3 n) against
        ``q.ravel()``."""
        raise FamilyError(f"constraint family {self._label()}: no planar rows defined")

    def spatial_rows(self, stack: Stack, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Rows of a spatial pose ``q`` (n, 6) [mm, rad]: values ``c`` (m,) in the
        family's unit and their Jacobian (m, 6 n) against ``q.ravel()``."""
        raise FamilyError(f"constraint family {self._label()}: no spatial rows defined")

    def row_scale(self, stack: Stack) -> float:
        """The unit the solvers measure the rows in: they see ``c / row_scale`` (default
        the longest leg of ``stack`` [mm], for rows that are lengths)."""
        return float(np.max(stack.leg_max))

    def check_values(self, stack: Stack, q: FloatArray, phi: float | None) -> FloatArray:
        """The row values the acceptance rule judges (``phi`` None: spatial; else the
        plane angle [rad]): the rows themselves unless overridden."""
        if phi is None:
            return self.spatial_rows(stack, q)[0]
        return self.planar_rows(stack, q, phi)[0]

    def _label(self) -> str:
        return repr(self.name) if self.name else type(self).__name__


_REGISTRY: dict[str, type[ConstraintFamily]] = {}


def register_family(cls: type[ConstraintFamily]) -> type[ConstraintFamily]:
    """Register ``cls`` under ``cls.name`` (a class decorator); ValueError for a class
    that is not a :class:`ConstraintFamily`, an empty name or a name taken by another
    class."""
    if not (isinstance(cls, type) and issubclass(cls, ConstraintFamily)):
        raise ValueError(f"register_family: expected a ConstraintFamily subclass, got {cls!r}")
    name = str(cls.name)
    if not name:
        raise ValueError(f"register_family: {cls.__name__} has no name")
    known = _REGISTRY.get(name)
    if known is not None and known is not cls:
        raise ValueError(f"register_family: the name {name!r} is taken by {known.__name__}")
    _REGISTRY[name] = cls
    return cls


def family_names() -> list[str]:
    """The registered family names, sorted."""
    return sorted(_REGISTRY)


def family(name: str, **params: Any) -> ConstraintFamily:
    """An instance of the family registered as ``name`` with ``params``; ValueError
    naming the known families for an unknown name."""
    cls = _REGISTRY.get(name)
    if cls is None:
        known = ", ".join(family_names()) or "none registered"
        raise ValueError(f"unknown constraint family {name!r} (known: {known})")
    return cls(**params)


def as_families(constraints: Any) -> tuple[ConstraintFamily, ...]:
    """``constraints`` (None, one family or a sequence of them) as a tuple; ValueError
    for anything else."""
    if constraints is None:
        return ()
    items = (constraints,) if isinstance(constraints, ConstraintFamily) else tuple(constraints)
    for f in items:
        if not isinstance(f, ConstraintFamily):
            raise ValueError(
                f"constraints: expected stackik.ConstraintFamily instances, got {type(f).__name__}"
            )
    return items


@contextlib.contextmanager
def _whose(f: ConstraintFamily) -> Iterator[None]:
    """Run the user's code of ``f``: what it raises (other than arithmetic, and
    :class:`FamilyError` itself) becomes a :class:`FamilyError` naming the family."""
    try:
        yield
    except (FamilyError, ArithmeticError):
        raise
    except Exception as exc:  # noqa: BLE001 - the user's code: say whose it is
        raise FamilyError(f"constraint family {f._label()}: {type(exc).__name__}: {exc}") from exc


def check_values_of(
    f: ConstraintFamily, stack: Stack, q: FloatArray, phi: float | None
) -> FloatArray:
    """``f.check_values(stack, q, phi)`` as a float array (:func:`_whose` for what it
    raises)."""
    with _whose(f):
        return np.asarray(f.check_values(stack, q, phi), dtype=float).reshape(-1)


def _rows_of(
    f: ConstraintFamily, stack: Stack, q: FloatArray, phi: float | None
) -> tuple[FloatArray, FloatArray]:
    """``f``'s rows at ``q`` as float arrays of checked shapes (:class:`FamilyError`
    otherwise, and for what the family raises: :func:`_whose`)."""
    n, k = q.shape
    with _whose(f):
        c, J = f.spatial_rows(stack, q) if phi is None else f.planar_rows(stack, q, phi)
        c = np.asarray(c, dtype=float).reshape(-1)
        J = np.asarray(J, dtype=float)
    if J.shape != (c.size, n * k):
        raise FamilyError(
            f"constraint family {f._label()}: Jacobian of shape {J.shape}, expected "
            f"({c.size}, {n * k})"
        )
    return c, J


class FamilyRows:
    """The rows of a problem's constraint families, as its solvers take them.

    ``self(q)`` gives the values ``c / row_scale`` (size,) and their Jacobian
    (size, k n) against the raw pose ``q`` (n, k); ``phi`` None for spatial problems.
    ``token`` names these rows to the compiled kernels (:func:`kernel_rows`) while the
    object lives.
    """

    def __init__(
        self, stack: Stack, families: tuple[ConstraintFamily, ...], phi: float | None
    ) -> None:
        self.stack = stack
        self.families = families
        self.phi = phi
        self.scales = np.array([f.row_scale(stack) for f in families], dtype=float)
        if not (np.all(np.isfinite(self.scales)) and np.all(self.scales > 0)):
            raise ValueError("constraint families: every row_scale must be finite and > 0")
        k = 6 if phi is None else 3
        #: the number of rows (a family's row count is fixed: the count at the zero pose)
        self.size = int(self._rows(np.zeros((stack.n, k)))[0].size)
        self.token = _register_rows(self)

    def __call__(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        c, J = self._rows(np.asarray(q, dtype=float))
        if c.size != self.size:
            names = ", ".join(f._label() for f in self.families)
            raise FamilyError(
                f"constraint families {names}: {c.size} rows at this pose, "
                f"{self.size} at the first (a family's row count must not change)"
            )
        return c, J

    def _rows(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Every family's rows at ``q``, scaled, stacked (families non-empty)."""
        parts = [_rows_of(f, self.stack, q, self.phi) for f in self.families]
        c = np.concatenate([c / s for (c, _), s in zip(parts, self.scales)])
        return c, np.vstack([J / s for (_, J), s in zip(parts, self.scales)])


_TOKENS = itertools.count(1)
_LIVE: weakref.WeakValueDictionary[int, FamilyRows] = weakref.WeakValueDictionary()
_LOCK = threading.Lock()


def _register_rows(rows: FamilyRows) -> int:
    with _LOCK:
        token = next(_TOKENS)
        _LIVE[token] = rows
    return token


def kernel_rows(token: int, q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The rows the compiled interior points call back for (object mode,
    :func:`stackik._compiled.dense_rows.dense_rows`): the values and Jacobian of the
    :class:`FamilyRows` named ``token`` at the raw pose ``q`` (n, k), C-contiguous; NaN
    where the family's arithmetic failed (``ArithmeticError``: the kernels treat it as a
    failed evaluation, as they do NaN rows). Anything else the family raises leaves the
    solve as a :class:`FamilyError`, from every engine."""
    rows = _LIVE.get(int(token))
    if rows is None:
        raise RuntimeError(f"constraint family rows {token} are gone")
    try:
        c, J = rows(q)
    except ArithmeticError:
        c, J = np.full(rows.size, np.nan), np.full((rows.size, q.size), np.nan)
    return np.ascontiguousarray(c, dtype=float), np.ascontiguousarray(J, dtype=float)
