"""Solving: :func:`solve_ik` (one target, a short pipeline) and :func:`solve_many`.

Modules: :mod:`~stackik.solve.request` (validation), :mod:`~stackik.solve.policy` (the
``"auto"`` rule and the start plan), :mod:`~stackik.solve.stages` (runs, selection),
:mod:`~stackik.solve.nearest` (unreachable targets), :mod:`~stackik.solve.pipeline`
(:func:`solve_ik`), :mod:`~stackik.solve.many` (:func:`solve_many`).
"""

from stackik.methods import METHOD_NAMES
from stackik.solve.many import solve_many
from stackik.solve.pipeline import solve_ik

__all__ = ["METHOD_NAMES", "solve_ik", "solve_many"]
