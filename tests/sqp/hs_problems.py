"""Hock-Schittkowski test problems with analytic derivatives and published optima.

Test data, not part of the library: imported by the tests in this folder and by
``benchmarks/bench_sqp.py`` (which puts this folder on ``sys.path``).

Source: W. Hock and K. Schittkowski, *Test Examples for Nonlinear Programming Codes*,
Lecture Notes in Economics and Mathematical Systems 187, Springer, 1981 (standard start
points ``x0`` and optimal values ``f_star`` from there).

Use :func:`problem` (``problem(71)``) or iterate :data:`PROBLEMS`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from stackik.sqp.problem import FloatArray, NonlinearProgram

SQ2 = np.sqrt(2.0)
SQ3 = np.sqrt(3.0)


@dataclass(frozen=True)
class HSProblem:
    """One Hock-Schittkowski problem.

    Attributes
    ----------
    number : int
        HS number.
    nlp : NonlinearProgram
        The problem with analytic gradient and Jacobians (and Hessian when ``has_hessian``).
    x0 : ndarray, shape (n,)
        Standard starting point.
    f_star : float
        Published optimal value.
    """

    number: int
    nlp: NonlinearProgram
    x0: FloatArray
    f_star: float

    @property
    def has_hessian(self) -> bool:
        """Whether an exact Lagrangian Hessian is provided."""
        return self.nlp.hessian is not None


PROBLEMS: dict[int, HSProblem] = {}

#: Test-problem callables return array-likes (lists or arrays); ``_reg`` converts them.
_Fn = Callable[[FloatArray], Any]


def _reg(
    number: int,
    x0: list[float],
    f_star: float,
    f: Callable[[FloatArray], Any],
    g: _Fn,
    ce: _Fn | None = None,
    je: _Fn | None = None,
    ci: _Fn | None = None,
    ji: _Fn | None = None,
    lower: list[float] | None = None,
    upper: list[float] | None = None,
    hess: Callable[[FloatArray, FloatArray, FloatArray], Any] | None = None,
) -> None:
    def arr(fn: _Fn | None) -> _Fn | None:
        if fn is None:
            return None
        return lambda x: np.asarray(fn(x), dtype=float)

    def mat(fn: _Fn | None) -> _Fn | None:
        if fn is None:
            return None
        return lambda x: np.atleast_2d(np.asarray(fn(x), dtype=float))

    nlp = NonlinearProgram(
        objective=lambda x: float(f(x)),
        gradient=arr(g),
        eq=arr(ce),
        eq_jacobian=mat(je),
        ineq=arr(ci),
        ineq_jacobian=mat(ji),
        hessian=hess,
        lower=None if lower is None else np.array(lower, dtype=float),
        upper=None if upper is None else np.array(upper, dtype=float),
        name=f"HS{number}",
    )
    PROBLEMS[number] = HSProblem(number, nlp, np.array(x0, dtype=float), float(f_star))


def problem(number: int) -> HSProblem:
    """Return HS problem ``number`` (KeyError if not in the set)."""
    return PROBLEMS[number]


INF = np.inf


# ---- Rosenbrock-type (HS1-2, 15-17, 20) -------------------------------------------------
def _rosen(x: FloatArray) -> float:
    return 100 * (x[1] - x[0] ** 2) ** 2 + (1 - x[0]) ** 2


def _rosen_g(x: FloatArray) -> FloatArray:
    return np.array([-400 * x[0] * (x[1] - x[0] ** 2) - 2 * (1 - x[0]), 200 * (x[1] - x[0] ** 2)])


def _rosen_h(x: FloatArray) -> FloatArray:
    return np.array([[1200 * x[0] ** 2 - 400 * x[1] + 2, -400 * x[0]], [-400 * x[0], 200.0]])


_reg(1, [-2, 1], 0.0, _rosen, _rosen_g, lower=[-INF, -1.5],
     hess=lambda x, ye, yi: _rosen_h(x))  # fmt: skip
_reg(2, [-2, 1], 0.0504261879, _rosen, _rosen_g, lower=[-INF, 1.5],
     hess=lambda x, ye, yi: _rosen_h(x))  # fmt: skip
_reg(
    15, [-2, 1], 306.5, _rosen, _rosen_g,
    ci=lambda x: [x[0] * x[1] - 1, x[0] + x[1] ** 2],
    ji=lambda x: [[x[1], x[0]], [1, 2 * x[1]]],
    upper=[0.5, INF],
    hess=lambda x, ye, yi: _rosen_h(x)
    - yi[0] * np.array([[0, 1.0], [1, 0]])
    - yi[1] * np.array([[0, 0], [0, 2.0]]),
)  # fmt: skip
_reg(
    16, [-2, 1], 0.25, _rosen, _rosen_g,
    ci=lambda x: [x[0] + x[1] ** 2, x[0] ** 2 + x[1]],
    ji=lambda x: [[1, 2 * x[1]], [2 * x[0], 1]],
    lower=[-0.5, -INF], upper=[0.5, 1.0],
)  # fmt: skip
_reg(
    17, [-2, 1], 1.0, _rosen, _rosen_g,
    ci=lambda x: [x[1] ** 2 - x[0], x[0] ** 2 - x[1]],
    ji=lambda x: [[-1, 2 * x[1]], [2 * x[0], -1]],
    lower=[-0.5, -INF], upper=[0.5, 1.0],
)  # fmt: skip
_reg(
    20, [-2, 1], 81.5 - 25 * SQ3, _rosen, _rosen_g,
    ci=lambda x: [x[0] + x[1] ** 2, x[0] ** 2 + x[1], x[0] ** 2 + x[1] ** 2 - 1],
    ji=lambda x: [[1, 2 * x[1]], [2 * x[0], 1], [2 * x[0], 2 * x[1]]],
    lower=[-0.5, -INF], upper=[0.5, INF],
)  # fmt: skip

# ---- two variables ------------------------------------------------------------------------
_reg(3, [10, 1], 0.0, lambda x: x[1] + 1e-5 * (x[1] - x[0]) ** 2,
     lambda x: np.array([-2e-5 * (x[1] - x[0]), 1 + 2e-5 * (x[1] - x[0])]),
     lower=[-INF, 0])  # fmt: skip
_reg(4, [1.125, 0.125], 8.0 / 3.0, lambda x: (x[0] + 1) ** 3 / 3 + x[1],
     lambda x: np.array([(x[0] + 1) ** 2, 1.0]), lower=[1, 0])  # fmt: skip
_reg(
    5, [0, 0], -SQ3 / 2 - np.pi / 3,
    lambda x: np.sin(x[0] + x[1]) + (x[0] - x[1]) ** 2 - 1.5 * x[0] + 2.5 * x[1] + 1,
    lambda x: np.array([
        np.cos(x[0] + x[1]) + 2 * (x[0] - x[1]) - 1.5,
        np.cos(x[0] + x[1]) - 2 * (x[0] - x[1]) + 2.5,
    ]),
    lower=[-1.5, -3], upper=[4, 3],
)  # fmt: skip
_reg(
    6, [-1.2, 1], 0.0, lambda x: (1 - x[0]) ** 2, lambda x: np.array([-2 * (1 - x[0]), 0]),
    ce=lambda x: [10 * (x[1] - x[0] ** 2)], je=lambda x: [[-20 * x[0], 10]],
    hess=lambda x, ye, yi: np.array([[2.0, 0], [0, 0]]) - ye[0] * np.array([[-20.0, 0], [0, 0]]),
)  # fmt: skip
_reg(
    7, [2, 2], -SQ3, lambda x: np.log(1 + x[0] ** 2) - x[1],
    lambda x: np.array([2 * x[0] / (1 + x[0] ** 2), -1]),
    ce=lambda x: [(1 + x[0] ** 2) ** 2 + x[1] ** 2 - 4],
    je=lambda x: [[4 * x[0] * (1 + x[0] ** 2), 2 * x[1]]],
    hess=lambda x, ye, yi: np.array([[2 * (1 - x[0] ** 2) / (1 + x[0] ** 2) ** 2, 0], [0, 0]])
    - ye[0] * np.array([[4 + 12 * x[0] ** 2, 0], [0, 2]]),
)  # fmt: skip
_reg(
    8, [2, 1], -1.0, lambda x: -1.0, lambda x: np.zeros(2),
    ce=lambda x: [x[0] ** 2 + x[1] ** 2 - 25, x[0] * x[1] - 9],
    je=lambda x: [[2 * x[0], 2 * x[1]], [x[1], x[0]]],
)  # fmt: skip
_reg(
    9, [0, 0], -0.5, lambda x: np.sin(np.pi * x[0] / 12) * np.cos(np.pi * x[1] / 16),
    lambda x: np.array([
        np.pi / 12 * np.cos(np.pi * x[0] / 12) * np.cos(np.pi * x[1] / 16),
        -np.pi / 16 * np.sin(np.pi * x[0] / 12) * np.sin(np.pi * x[1] / 16),
    ]),
    ce=lambda x: [4 * x[0] - 3 * x[1]], je=lambda x: [[4, -3]],
)  # fmt: skip
_reg(
    10, [-10, 10], -1.0, lambda x: x[0] - x[1], lambda x: np.array([1.0, -1.0]),
    ci=lambda x: [-3 * x[0] ** 2 + 2 * x[0] * x[1] - x[1] ** 2 + 1],
    ji=lambda x: [[-6 * x[0] + 2 * x[1], 2 * x[0] - 2 * x[1]]],
    hess=lambda x, ye, yi: -yi[0] * np.array([[-6.0, 2], [2, -2]]),
)  # fmt: skip
_reg(
    11, [4.9, 0.1], -8.498464223, lambda x: (x[0] - 5) ** 2 + x[1] ** 2 - 25,
    lambda x: np.array([2 * (x[0] - 5), 2 * x[1]]),
    ci=lambda x: [-x[0] ** 2 + x[1]], ji=lambda x: [[-2 * x[0], 1]],
)  # fmt: skip
_reg(
    12, [0, 0], -30.0, lambda x: 0.5 * x[0] ** 2 + x[1] ** 2 - x[0] * x[1] - 7 * x[0] - 7 * x[1],
    lambda x: np.array([x[0] - x[1] - 7, 2 * x[1] - x[0] - 7]),
    ci=lambda x: [25 - 4 * x[0] ** 2 - x[1] ** 2], ji=lambda x: [[-8 * x[0], -2 * x[1]]],
    hess=lambda x, ye, yi: np.array([[1.0, -1], [-1, 2]]) + yi[0] * np.diag([8.0, 2.0]),
)  # fmt: skip
_reg(
    14, [2, 2], 9 - 2.875 * np.sqrt(7), lambda x: (x[0] - 2) ** 2 + (x[1] - 1) ** 2,
    lambda x: np.array([2 * (x[0] - 2), 2 * (x[1] - 1)]),
    ce=lambda x: [x[0] - 2 * x[1] + 1], je=lambda x: [[1, -2]],
    ci=lambda x: [-(x[0] ** 2) / 4 - x[1] ** 2 + 1], ji=lambda x: [[-x[0] / 2, -2 * x[1]]],
    hess=lambda x, ye, yi: 2 * np.eye(2) + yi[0] * np.diag([0.5, 2.0]),
)  # fmt: skip
_reg(
    18, [2, 2], 5.0, lambda x: 0.01 * x[0] ** 2 + x[1] ** 2,
    lambda x: np.array([0.02 * x[0], 2 * x[1]]),
    ci=lambda x: [x[0] * x[1] - 25, x[0] ** 2 + x[1] ** 2 - 25],
    ji=lambda x: [[x[1], x[0]], [2 * x[0], 2 * x[1]]],
    lower=[2, 0], upper=[50, 50],
)  # fmt: skip
_reg(
    19, [20.1, 5.84], -6961.81381, lambda x: (x[0] - 10) ** 3 + (x[1] - 20) ** 3,
    lambda x: np.array([3 * (x[0] - 10) ** 2, 3 * (x[1] - 20) ** 2]),
    ci=lambda x: [(x[0] - 5) ** 2 + (x[1] - 5) ** 2 - 100,
                  -((x[1] - 5) ** 2) - (x[0] - 6) ** 2 + 82.81],
    ji=lambda x: [[2 * (x[0] - 5), 2 * (x[1] - 5)], [-2 * (x[0] - 6), -2 * (x[1] - 5)]],
    lower=[13, 0], upper=[100, 100],
)  # fmt: skip
_reg(
    21, [-1, -1], -99.96, lambda x: 0.01 * x[0] ** 2 + x[1] ** 2 - 100,
    lambda x: np.array([0.02 * x[0], 2 * x[1]]),
    ci=lambda x: [10 * x[0] - x[1] - 10], ji=lambda x: [[10, -1]],
    lower=[2, -50], upper=[50, 50],
    hess=lambda x, ye, yi: np.diag([0.02, 2.0]),
)  # fmt: skip
_reg(
    22, [2, 2], 1.0, lambda x: (x[0] - 2) ** 2 + (x[1] - 1) ** 2,
    lambda x: np.array([2 * (x[0] - 2), 2 * (x[1] - 1)]),
    ci=lambda x: [-x[0] - x[1] + 2, -x[0] ** 2 + x[1]],
    ji=lambda x: [[-1, -1], [-2 * x[0], 1]],
)  # fmt: skip
_reg(
    23, [3, 1], 2.0, lambda x: x[0] ** 2 + x[1] ** 2, lambda x: 2 * x,
    ci=lambda x: [x[0] + x[1] - 1, x[0] ** 2 + x[1] ** 2 - 1, 9 * x[0] ** 2 + x[1] ** 2 - 9,
                  x[0] ** 2 - x[1], x[1] ** 2 - x[0]],
    ji=lambda x: [[1, 1], [2 * x[0], 2 * x[1]], [18 * x[0], 2 * x[1]], [2 * x[0], -1],
                  [-1, 2 * x[1]]],
    lower=[-50, -50], upper=[50, 50],
)  # fmt: skip
_reg(
    24, [1, 0.5], -1.0, lambda x: ((x[0] - 3) ** 2 - 9) * x[1] ** 3 / (27 * SQ3),
    lambda x: np.array([2 * (x[0] - 3) * x[1] ** 3 / (27 * SQ3),
                        3 * ((x[0] - 3) ** 2 - 9) * x[1] ** 2 / (27 * SQ3)]),
    ci=lambda x: [x[0] / SQ3 - x[1], x[0] + SQ3 * x[1], -x[0] - SQ3 * x[1] + 6],
    ji=lambda x: [[1 / SQ3, -1], [1, SQ3], [-1, -SQ3]],
    lower=[0, 0],
)  # fmt: skip

# ---- three variables ----------------------------------------------------------------------
_reg(
    26, [-2.6, 2, 2], 0.0, lambda x: (x[0] - x[1]) ** 2 + (x[1] - x[2]) ** 4,
    lambda x: np.array([2 * (x[0] - x[1]), -2 * (x[0] - x[1]) + 4 * (x[1] - x[2]) ** 3,
                        -4 * (x[1] - x[2]) ** 3]),
    ce=lambda x: [(1 + x[1] ** 2) * x[0] + x[2] ** 4 - 3],
    je=lambda x: [[1 + x[1] ** 2, 2 * x[0] * x[1], 4 * x[2] ** 3]],
)  # fmt: skip
_reg(
    27, [2, 2, 2], 0.04, lambda x: 0.01 * (x[0] - 1) ** 2 + (x[1] - x[0] ** 2) ** 2,
    lambda x: np.array([0.02 * (x[0] - 1) - 4 * x[0] * (x[1] - x[0] ** 2),
                        2 * (x[1] - x[0] ** 2), 0]),
    ce=lambda x: [x[0] + x[2] ** 2 + 1], je=lambda x: [[1, 0, 2 * x[2]]],
)  # fmt: skip
_reg(
    28, [-4, 1, 1], 0.0, lambda x: (x[0] + x[1]) ** 2 + (x[1] + x[2]) ** 2,
    lambda x: np.array([2 * (x[0] + x[1]), 2 * (x[0] + x[1]) + 2 * (x[1] + x[2]),
                        2 * (x[1] + x[2])]),
    ce=lambda x: [x[0] + 2 * x[1] + 3 * x[2] - 1], je=lambda x: [[1, 2, 3]],
    hess=lambda x, ye, yi: np.array([[2.0, 2, 0], [2, 4, 2], [0, 2, 2]]),
)  # fmt: skip
_reg(
    29, [1, 1, 1], -16 * SQ2, lambda x: -x[0] * x[1] * x[2],
    lambda x: -np.array([x[1] * x[2], x[0] * x[2], x[0] * x[1]]),
    ci=lambda x: [-x[0] ** 2 - 2 * x[1] ** 2 - 4 * x[2] ** 2 + 48],
    ji=lambda x: [[-2 * x[0], -4 * x[1], -8 * x[2]]],
    hess=lambda x, ye, yi: -np.array([[0, x[2], x[1]], [x[2], 0, x[0]], [x[1], x[0], 0]])
    + yi[0] * np.diag([2.0, 4, 8]),
)  # fmt: skip
_reg(
    30, [1, 1, 1], 1.0, lambda x: x @ x, lambda x: 2 * x,
    ci=lambda x: [x[0] ** 2 + x[1] ** 2 - 1], ji=lambda x: [[2 * x[0], 2 * x[1], 0]],
    lower=[1, -10, -10], upper=[10, 10, 10],
)  # fmt: skip
_reg(
    31, [1, 1, 1], 6.0, lambda x: 9 * x[0] ** 2 + x[1] ** 2 + 9 * x[2] ** 2,
    lambda x: np.array([18 * x[0], 2 * x[1], 18 * x[2]]),
    ci=lambda x: [x[0] * x[1] - 1], ji=lambda x: [[x[1], x[0], 0]],
    lower=[-10, 1, -10], upper=[10, 10, 1],
)  # fmt: skip
_reg(
    32, [0.1, 0.7, 0.2], 1.0,
    lambda x: (x[0] + 3 * x[1] + x[2]) ** 2 + 4 * (x[0] - x[1]) ** 2,
    lambda x: np.array([2 * (x[0] + 3 * x[1] + x[2]) + 8 * (x[0] - x[1]),
                        6 * (x[0] + 3 * x[1] + x[2]) - 8 * (x[0] - x[1]),
                        2 * (x[0] + 3 * x[1] + x[2])]),
    ce=lambda x: [1 - x[0] - x[1] - x[2]], je=lambda x: [[-1, -1, -1]],
    ci=lambda x: [6 * x[1] + 4 * x[2] - x[0] ** 3 - 3], ji=lambda x: [[-3 * x[0] ** 2, 6, 4]],
    lower=[0, 0, 0],
)  # fmt: skip
_reg(
    33, [0, 0, 3], SQ2 - 6, lambda x: (x[0] - 1) * (x[0] - 2) * (x[0] - 3) + x[2],
    lambda x: np.array([3 * x[0] ** 2 - 12 * x[0] + 11, 0, 1]),
    ci=lambda x: [x[2] ** 2 - x[1] ** 2 - x[0] ** 2, x[0] ** 2 + x[1] ** 2 + x[2] ** 2 - 4],
    ji=lambda x: [[-2 * x[0], -2 * x[1], 2 * x[2]], [2 * x[0], 2 * x[1], 2 * x[2]]],
    lower=[0, 0, 0], upper=[INF, INF, 5],
)  # fmt: skip
_reg(
    34, [0, 1.05, 2.9], -np.log(np.log(10.0)), lambda x: -x[0], lambda x: np.array([-1.0, 0, 0]),
    ci=lambda x: [x[1] - np.exp(x[0]), x[2] - np.exp(x[1])],
    ji=lambda x: [[-np.exp(x[0]), 1, 0], [0, -np.exp(x[1]), 1]],
    lower=[0, 0, 0], upper=[100, 100, 10],
)  # fmt: skip
_reg(
    35, [0.5, 0.5, 0.5], 1.0 / 9.0,
    lambda x: 9 - 8 * x[0] - 6 * x[1] - 4 * x[2] + 2 * x[0] ** 2 + 2 * x[1] ** 2 + x[2] ** 2
    + 2 * x[0] * x[1] + 2 * x[0] * x[2],
    lambda x: np.array([-8 + 4 * x[0] + 2 * x[1] + 2 * x[2], -6 + 4 * x[1] + 2 * x[0],
                        -4 + 2 * x[2] + 2 * x[0]]),
    ci=lambda x: [3 - x[0] - x[1] - 2 * x[2]], ji=lambda x: [[-1, -1, -2]],
    lower=[0, 0, 0],
    hess=lambda x, ye, yi: np.array([[4.0, 2, 2], [2, 4, 0], [2, 0, 2]]),
)  # fmt: skip
_reg(
    36, [10, 10, 10], -3300.0, lambda x: -x[0] * x[1] * x[2],
    lambda x: -np.array([x[1] * x[2], x[0] * x[2], x[0] * x[1]]),
    ci=lambda x: [72 - x[0] - 2 * x[1] - 2 * x[2]], ji=lambda x: [[-1, -2, -2]],
    lower=[0, 0, 0], upper=[20, 11, 42],
)  # fmt: skip
_reg(
    37, [10, 10, 10], -3456.0, lambda x: -x[0] * x[1] * x[2],
    lambda x: -np.array([x[1] * x[2], x[0] * x[2], x[0] * x[1]]),
    ci=lambda x: [72 - x[0] - 2 * x[1] - 2 * x[2], x[0] + 2 * x[1] + 2 * x[2]],
    ji=lambda x: [[-1, -2, -2], [1, 2, 2]],
    lower=[0, 0, 0], upper=[42, 42, 42],
)  # fmt: skip
_reg(
    60, [2, 2, 2], 0.0325682003,
    lambda x: (x[0] - 1) ** 2 + (x[0] - x[1]) ** 2 + (x[1] - x[2]) ** 4,
    lambda x: np.array([2 * (x[0] - 1) + 2 * (x[0] - x[1]),
                        -2 * (x[0] - x[1]) + 4 * (x[1] - x[2]) ** 3, -4 * (x[1] - x[2]) ** 3]),
    ce=lambda x: [x[0] * (1 + x[1] ** 2) + x[2] ** 4 - 4 - 3 * SQ2],
    je=lambda x: [[1 + x[1] ** 2, 2 * x[0] * x[1], 4 * x[2] ** 3]],
    lower=[-10, -10, -10], upper=[10, 10, 10],
)  # fmt: skip
_reg(
    61, [0, 0, 0], -143.6461422,
    lambda x: 4 * x[0] ** 2 + 2 * x[1] ** 2 + 2 * x[2] ** 2 - 33 * x[0] + 16 * x[1] - 24 * x[2],
    lambda x: np.array([8 * x[0] - 33, 4 * x[1] + 16, 4 * x[2] - 24]),
    ce=lambda x: [3 * x[0] - 2 * x[1] ** 2 - 7, 4 * x[0] - x[2] ** 2 - 11],
    je=lambda x: [[3, -4 * x[1], 0], [4, 0, -2 * x[2]]],
    hess=lambda x, ye, yi: np.diag([8.0, 4, 4]) - ye[0] * np.diag([0, -4.0, 0])
    - ye[1] * np.diag([0, 0, -2.0]),
)  # fmt: skip
_reg(
    63, [2, 2, 2], 961.7151721,
    lambda x: 1000 - x[0] ** 2 - 2 * x[1] ** 2 - x[2] ** 2 - x[0] * x[1] - x[0] * x[2],
    lambda x: np.array([-2 * x[0] - x[1] - x[2], -4 * x[1] - x[0], -2 * x[2] - x[0]]),
    ce=lambda x: [8 * x[0] + 14 * x[1] + 7 * x[2] - 56, x @ x - 25],
    je=lambda x: [[8, 14, 7], 2 * x],
    lower=[0, 0, 0],
)  # fmt: skip
_reg(
    64, [1, 1, 1], 6299.842428,
    lambda x: 5 * x[0] + 50000 / x[0] + 20 * x[1] + 72000 / x[1] + 10 * x[2] + 144000 / x[2],
    lambda x: np.array([5 - 50000 / x[0] ** 2, 20 - 72000 / x[1] ** 2, 10 - 144000 / x[2] ** 2]),
    ci=lambda x: [1 - 4 / x[0] - 32 / x[1] - 120 / x[2]],
    ji=lambda x: [[4 / x[0] ** 2, 32 / x[1] ** 2, 120 / x[2] ** 2]],
    lower=[1e-5, 1e-5, 1e-5],
)  # fmt: skip
_reg(
    65, [-5, 5, 0], 0.9535288567,
    lambda x: (x[0] - x[1]) ** 2 + (x[0] + x[1] - 10) ** 2 / 9 + (x[2] - 5) ** 2,
    lambda x: np.array([2 * (x[0] - x[1]) + 2 * (x[0] + x[1] - 10) / 9,
                        -2 * (x[0] - x[1]) + 2 * (x[0] + x[1] - 10) / 9, 2 * (x[2] - 5)]),
    ci=lambda x: [48 - x @ x], ji=lambda x: [-2 * x],
    lower=[-4.5, -4.5, -5], upper=[4.5, 4.5, 5],
    hess=lambda x, ye, yi: np.array([[2 + 2 / 9, -2 + 2 / 9, 0], [-2 + 2 / 9, 2 + 2 / 9, 0],
                                      [0, 0, 2]]) + 2 * yi[0] * np.eye(3),
)  # fmt: skip
_reg(
    66, [0, 1.05, 2.9], 0.5181632741, lambda x: 0.2 * x[2] - 0.8 * x[0],
    lambda x: np.array([-0.8, 0, 0.2]),
    ci=lambda x: [x[1] - np.exp(x[0]), x[2] - np.exp(x[1])],
    ji=lambda x: [[-np.exp(x[0]), 1, 0], [0, -np.exp(x[1]), 1]],
    lower=[0, 0, 0], upper=[100, 100, 10],
)  # fmt: skip

# ---- four variables -----------------------------------------------------------------------
_reg(
    38, [-3, -1, -3, -1], 0.0,
    lambda x: 100 * (x[1] - x[0] ** 2) ** 2 + (1 - x[0]) ** 2 + 90 * (x[3] - x[2] ** 2) ** 2
    + (1 - x[2]) ** 2 + 10.1 * ((x[1] - 1) ** 2 + (x[3] - 1) ** 2)
    + 19.8 * (x[1] - 1) * (x[3] - 1),
    lambda x: np.array([
        -400 * x[0] * (x[1] - x[0] ** 2) - 2 * (1 - x[0]),
        200 * (x[1] - x[0] ** 2) + 20.2 * (x[1] - 1) + 19.8 * (x[3] - 1),
        -360 * x[2] * (x[3] - x[2] ** 2) - 2 * (1 - x[2]),
        180 * (x[3] - x[2] ** 2) + 20.2 * (x[3] - 1) + 19.8 * (x[1] - 1),
    ]),
    lower=[-10] * 4, upper=[10] * 4,
)  # fmt: skip
_reg(
    39, [2, 2, 2, 2], -1.0, lambda x: -x[0], lambda x: np.array([-1.0, 0, 0, 0]),
    ce=lambda x: [x[1] - x[0] ** 3 - x[2] ** 2, x[0] ** 2 - x[1] - x[3] ** 2],
    je=lambda x: [[-3 * x[0] ** 2, 1, -2 * x[2], 0], [2 * x[0], -1, 0, -2 * x[3]]],
    hess=lambda x, ye, yi: -ye[0] * np.diag([-6 * x[0], 0, -2, 0])
    - ye[1] * np.diag([2.0, 0, 0, -2]),
)  # fmt: skip
_reg(
    40, [0.8, 0.8, 0.8, 0.8], -0.25, lambda x: -np.prod(x),
    lambda x: -np.array([x[1] * x[2] * x[3], x[0] * x[2] * x[3], x[0] * x[1] * x[3],
                         x[0] * x[1] * x[2]]),
    ce=lambda x: [x[0] ** 3 + x[1] ** 2 - 1, x[0] ** 2 * x[3] - x[2], x[3] ** 2 - x[1]],
    je=lambda x: [[3 * x[0] ** 2, 2 * x[1], 0, 0], [2 * x[0] * x[3], 0, -1, x[0] ** 2],
                  [0, -1, 0, 2 * x[3]]],
)  # fmt: skip
_reg(
    41, [2, 2, 2, 2], 52.0 / 27.0, lambda x: 2 - x[0] * x[1] * x[2],
    lambda x: -np.array([x[1] * x[2], x[0] * x[2], x[0] * x[1], 0]),
    ce=lambda x: [x[0] + 2 * x[1] + 2 * x[2] - x[3]], je=lambda x: [[1, 2, 2, -1]],
    lower=[0, 0, 0, 0], upper=[1, 1, 1, 2],
)  # fmt: skip
_reg(
    42, [1, 1, 1, 1], 28 - 10 * SQ2, lambda x: np.sum((x - np.arange(1, 5)) ** 2),
    lambda x: 2 * (x - np.arange(1, 5)),
    ce=lambda x: [x[0] - 2, x[2] ** 2 + x[3] ** 2 - 2],
    je=lambda x: [[1, 0, 0, 0], [0, 0, 2 * x[2], 2 * x[3]]],
    hess=lambda x, ye, yi: 2 * np.eye(4) - ye[1] * np.diag([0, 0, 2.0, 2.0]),
)  # fmt: skip


def _hs43_c(x: FloatArray) -> FloatArray:
    return np.array([
        8 - x[0] ** 2 - x[1] ** 2 - x[2] ** 2 - x[3] ** 2 - x[0] + x[1] - x[2] + x[3],
        10 - x[0] ** 2 - 2 * x[1] ** 2 - x[2] ** 2 - 2 * x[3] ** 2 + x[0] + x[3],
        5 - 2 * x[0] ** 2 - x[1] ** 2 - x[2] ** 2 - 2 * x[0] + x[1] + x[3],
    ])  # fmt: skip


def _hs43_j(x: FloatArray) -> FloatArray:
    return np.array([
        [-2 * x[0] - 1, -2 * x[1] + 1, -2 * x[2] - 1, -2 * x[3] + 1],
        [-2 * x[0] + 1, -4 * x[1], -2 * x[2], -4 * x[3] + 1],
        [-4 * x[0] - 2, -2 * x[1] + 1, -2 * x[2], 1],
    ])  # fmt: skip


_reg(
    43, [0, 0, 0, 0], -44.0,
    lambda x: x[0] ** 2 + x[1] ** 2 + 2 * x[2] ** 2 + x[3] ** 2 - 5 * x[0] - 5 * x[1]
    - 21 * x[2] + 7 * x[3],
    lambda x: np.array([2 * x[0] - 5, 2 * x[1] - 5, 4 * x[2] - 21, 2 * x[3] + 7]),
    ci=_hs43_c, ji=_hs43_j,
    hess=lambda x, ye, yi: np.diag([2.0, 2, 4, 2]) + yi[0] * np.diag([2.0, 2, 2, 2])
    + yi[1] * np.diag([2.0, 4, 2, 4]) + yi[2] * np.diag([4.0, 2, 2, 0]),
)  # fmt: skip
_reg(
    44, [0, 0, 0, 0], -15.0,
    lambda x: x[0] - x[1] - x[2] - x[0] * x[2] + x[0] * x[3] + x[1] * x[2] - x[1] * x[3],
    lambda x: np.array([1 - x[2] + x[3], -1 + x[2] - x[3], -1 - x[0] + x[1], x[0] - x[1]]),
    ci=lambda x: [8 - x[0] - 2 * x[1], 12 - 4 * x[0] - x[1], 12 - 3 * x[0] - 4 * x[1],
                  8 - 2 * x[2] - x[3], 8 - x[2] - 2 * x[3], 5 - x[2] - x[3]],
    ji=lambda x: [[-1, -2, 0, 0], [-4, -1, 0, 0], [-3, -4, 0, 0], [0, 0, -2, -1],
                  [0, 0, -1, -2], [0, 0, -1, -1]],
    lower=[0, 0, 0, 0],
)  # fmt: skip
_reg(
    71, [1, 5, 5, 1], 17.0140173,
    lambda x: x[0] * x[3] * (x[0] + x[1] + x[2]) + x[2],
    lambda x: np.array([x[3] * (2 * x[0] + x[1] + x[2]), x[0] * x[3], x[0] * x[3] + 1,
                        x[0] * (x[0] + x[1] + x[2])]),
    ce=lambda x: [x @ x - 40], je=lambda x: [2 * x],
    ci=lambda x: [np.prod(x) - 25],
    ji=lambda x: [[x[1] * x[2] * x[3], x[0] * x[2] * x[3], x[0] * x[1] * x[3], x[0] * x[1] * x[2]]],
    lower=[1] * 4, upper=[5] * 4,
    hess=lambda x, ye, yi: np.array([
        [2 * x[3], x[3], x[3], 2 * x[0] + x[1] + x[2]],
        [x[3], 0, 0, x[0]], [x[3], 0, 0, x[0]],
        [2 * x[0] + x[1] + x[2], x[0], x[0], 0]])
    - 2 * ye[0] * np.eye(4)
    - yi[0] * np.array([
        [0, x[2] * x[3], x[1] * x[3], x[1] * x[2]],
        [x[2] * x[3], 0, x[0] * x[3], x[0] * x[2]],
        [x[1] * x[3], x[0] * x[3], 0, x[0] * x[1]],
        [x[1] * x[2], x[0] * x[2], x[0] * x[1], 0]]),
)  # fmt: skip
_reg(
    76, [0.5, 0.5, 0.5, 0.5], -4.681818181,
    lambda x: x[0] ** 2 + 0.5 * x[1] ** 2 + x[2] ** 2 + 0.5 * x[3] ** 2 - x[0] * x[2]
    + x[2] * x[3] - x[0] - 3 * x[1] + x[2] - x[3],
    lambda x: np.array([2 * x[0] - x[2] - 1, x[1] - 3, 2 * x[2] - x[0] + x[3] + 1,
                        x[3] + x[2] - 1]),
    ci=lambda x: [5 - x[0] - 2 * x[1] - x[2] - x[3], 4 - 3 * x[0] - x[1] - 2 * x[2] + x[3],
                  x[1] + 4 * x[2] - 1.5],
    ji=lambda x: [[-1, -2, -1, -1], [-3, -1, -2, 1], [0, 1, 4, 0]],
    lower=[0, 0, 0, 0],
    hess=lambda x, ye, yi: np.array([[2.0, 0, -1, 0], [0, 1, 0, 0], [-1, 0, 2, 1],
                                      [0, 0, 1, 1]]),
)  # fmt: skip

# ---- five and more variables ------------------------------------------------------------
_reg(
    45, [2, 2, 2, 2, 2], 1.0, lambda x: 2 - np.prod(x) / 120,
    lambda x: -np.array([np.prod(np.delete(x, i)) for i in range(5)]) / 120,
    lower=[0] * 5, upper=[1, 2, 3, 4, 5],
)  # fmt: skip
_reg(
    46, [SQ2 / 2, 1.75, 0.5, 2, 2], 0.0,
    lambda x: (x[0] - x[1]) ** 2 + (x[2] - 1) ** 2 + (x[3] - 1) ** 4 + (x[4] - 1) ** 6,
    lambda x: np.array([2 * (x[0] - x[1]), -2 * (x[0] - x[1]), 2 * (x[2] - 1),
                        4 * (x[3] - 1) ** 3, 6 * (x[4] - 1) ** 5]),
    ce=lambda x: [x[0] ** 2 * x[3] + np.sin(x[3] - x[4]) - 1,
                  x[1] + x[2] ** 4 * x[3] ** 2 - 2],
    je=lambda x: [[2 * x[0] * x[3], 0, 0, x[0] ** 2 + np.cos(x[3] - x[4]), -np.cos(x[3] - x[4])],
                  [0, 1, 4 * x[2] ** 3 * x[3] ** 2, 2 * x[2] ** 4 * x[3], 0]],
)  # fmt: skip
_reg(
    47, [2, SQ2, -1, 2 - SQ2, 0.5], 0.0,
    lambda x: (x[0] - x[1]) ** 2 + (x[1] - x[2]) ** 3 + (x[2] - x[3]) ** 4 + (x[3] - x[4]) ** 4,
    lambda x: np.array([
        2 * (x[0] - x[1]), -2 * (x[0] - x[1]) + 3 * (x[1] - x[2]) ** 2,
        -3 * (x[1] - x[2]) ** 2 + 4 * (x[2] - x[3]) ** 3,
        -4 * (x[2] - x[3]) ** 3 + 4 * (x[3] - x[4]) ** 3, -4 * (x[3] - x[4]) ** 3]),
    ce=lambda x: [x[0] + x[1] ** 2 + x[2] ** 3 - 3, x[1] - x[2] ** 2 + x[3] - 1,
                  x[0] * x[4] - 1],
    je=lambda x: [[1, 2 * x[1], 3 * x[2] ** 2, 0, 0], [0, 1, -2 * x[2], 1, 0],
                  [x[4], 0, 0, 0, x[0]]],
)  # fmt: skip
_reg(
    48, [3, 5, -3, 2, -2], 0.0,
    lambda x: (x[0] - 1) ** 2 + (x[1] - x[2]) ** 2 + (x[3] - x[4]) ** 2,
    lambda x: np.array([2 * (x[0] - 1), 2 * (x[1] - x[2]), -2 * (x[1] - x[2]),
                        2 * (x[3] - x[4]), -2 * (x[3] - x[4])]),
    ce=lambda x: [np.sum(x) - 5, x[2] - 2 * (x[3] + x[4]) + 3],
    je=lambda x: [[1, 1, 1, 1, 1], [0, 0, 1, -2, -2]],
    hess=lambda x, ye, yi: np.array([[2.0, 0, 0, 0, 0], [0, 2, -2, 0, 0], [0, -2, 2, 0, 0],
                                      [0, 0, 0, 2, -2], [0, 0, 0, -2, 2]]),
)  # fmt: skip
_reg(
    49, [10, 7, 2, -3, 0.8], 0.0,
    lambda x: (x[0] - x[1]) ** 2 + (x[2] - 1) ** 2 + (x[3] - 1) ** 4 + (x[4] - 1) ** 6,
    lambda x: np.array([2 * (x[0] - x[1]), -2 * (x[0] - x[1]), 2 * (x[2] - 1),
                        4 * (x[3] - 1) ** 3, 6 * (x[4] - 1) ** 5]),
    ce=lambda x: [x[0] + x[1] + x[2] + 4 * x[3] - 7, x[2] + 5 * x[4] - 6],
    je=lambda x: [[1, 1, 1, 4, 0], [0, 0, 1, 0, 5]],
)  # fmt: skip
_reg(
    50, [35, -31, 11, 5, -5], 0.0,
    lambda x: (x[0] - x[1]) ** 2 + (x[1] - x[2]) ** 2 + (x[2] - x[3]) ** 4 + (x[3] - x[4]) ** 2,
    lambda x: np.array([
        2 * (x[0] - x[1]), -2 * (x[0] - x[1]) + 2 * (x[1] - x[2]),
        -2 * (x[1] - x[2]) + 4 * (x[2] - x[3]) ** 3,
        -4 * (x[2] - x[3]) ** 3 + 2 * (x[3] - x[4]), -2 * (x[3] - x[4])]),
    ce=lambda x: [x[0] + 2 * x[1] + 3 * x[2] - 6, x[1] + 2 * x[2] + 3 * x[3] - 6,
                  x[2] + 2 * x[3] + 3 * x[4] - 6],
    je=lambda x: [[1, 2, 3, 0, 0], [0, 1, 2, 3, 0], [0, 0, 1, 2, 3]],
)  # fmt: skip
_reg(
    51, [2.5, 0.5, 2, -1, 0.5], 0.0,
    lambda x: (x[0] - x[1]) ** 2 + (x[1] + x[2] - 2) ** 2 + (x[3] - 1) ** 2 + (x[4] - 1) ** 2,
    lambda x: np.array([2 * (x[0] - x[1]), -2 * (x[0] - x[1]) + 2 * (x[1] + x[2] - 2),
                        2 * (x[1] + x[2] - 2), 2 * (x[3] - 1), 2 * (x[4] - 1)]),
    ce=lambda x: [x[0] + 3 * x[1] - 4, x[2] + x[3] - 2 * x[4], x[1] - x[4]],
    je=lambda x: [[1, 3, 0, 0, 0], [0, 0, 1, 1, -2], [0, 1, 0, 0, -1]],
)  # fmt: skip


def _f52(x: FloatArray) -> float:
    return (4 * x[0] - x[1]) ** 2 + (x[1] + x[2] - 2) ** 2 + (x[3] - 1) ** 2 + (x[4] - 1) ** 2


def _g52(x: FloatArray) -> FloatArray:
    return np.array([8 * (4 * x[0] - x[1]), -2 * (4 * x[0] - x[1]) + 2 * (x[1] + x[2] - 2),
                     2 * (x[1] + x[2] - 2), 2 * (x[3] - 1), 2 * (x[4] - 1)])  # fmt: skip


_reg(
    52, [2, 2, 2, 2, 2], 1859.0 / 349.0, _f52, _g52,
    ce=lambda x: [x[0] + 3 * x[1], x[2] + x[3] - 2 * x[4], x[1] - x[4]],
    je=lambda x: [[1, 3, 0, 0, 0], [0, 0, 1, 1, -2], [0, 1, 0, 0, -1]],
)  # fmt: skip
_reg(
    53, [2, 2, 2, 2, 2], 176.0 / 43.0,
    lambda x: (x[0] - x[1]) ** 2 + (x[1] + x[2] - 2) ** 2 + (x[3] - 1) ** 2 + (x[4] - 1) ** 2,
    lambda x: np.array([2 * (x[0] - x[1]), -2 * (x[0] - x[1]) + 2 * (x[1] + x[2] - 2),
                        2 * (x[1] + x[2] - 2), 2 * (x[3] - 1), 2 * (x[4] - 1)]),
    ce=lambda x: [x[0] + 3 * x[1], x[2] + x[3] - 2 * x[4], x[1] - x[4]],
    je=lambda x: [[1, 3, 0, 0, 0], [0, 0, 1, 1, -2], [0, 1, 0, 0, -1]],
    lower=[-10] * 5, upper=[10] * 5,
)  # fmt: skip
_reg(
    77, [2, 2, 2, 2, 2], 0.24150513,
    lambda x: (x[0] - 1) ** 2 + (x[0] - x[1]) ** 2 + (x[2] - 1) ** 2 + (x[3] - 1) ** 4
    + (x[4] - 1) ** 6,
    lambda x: np.array([2 * (x[0] - 1) + 2 * (x[0] - x[1]), -2 * (x[0] - x[1]),
                        2 * (x[2] - 1), 4 * (x[3] - 1) ** 3, 6 * (x[4] - 1) ** 5]),
    ce=lambda x: [x[0] ** 2 * x[3] + np.sin(x[3] - x[4]) - 2 * SQ2,
                  x[1] + x[2] ** 4 * x[3] ** 2 - 8 - SQ2],
    je=lambda x: [[2 * x[0] * x[3], 0, 0, x[0] ** 2 + np.cos(x[3] - x[4]), -np.cos(x[3] - x[4])],
                  [0, 1, 4 * x[2] ** 3 * x[3] ** 2, 2 * x[2] ** 4 * x[3], 0]],
)  # fmt: skip


def _c78(x: FloatArray) -> FloatArray:
    return np.array([x @ x - 10, x[1] * x[2] - 5 * x[3] * x[4], x[0] ** 3 + x[1] ** 3 + 1])


def _j78(x: FloatArray) -> FloatArray:
    return np.array([2 * x, [0, x[2], x[1], -5 * x[4], -5 * x[3]],
                     [3 * x[0] ** 2, 3 * x[1] ** 2, 0, 0, 0]])  # fmt: skip


def _prod_grad(x: FloatArray) -> FloatArray:
    return np.array([np.prod(np.delete(x, i)) for i in range(x.size)])


_reg(78, [-2, 1.5, 2, -1, -1], -2.919700, lambda x: np.prod(x), _prod_grad, ce=_c78, je=_j78)
_reg(
    79, [2, 2, 2, 2, 2], 0.0787768209,
    lambda x: (x[0] - 1) ** 2 + (x[0] - x[1]) ** 2 + (x[1] - x[2]) ** 2 + (x[2] - x[3]) ** 4
    + (x[3] - x[4]) ** 4,
    lambda x: np.array([
        2 * (x[0] - 1) + 2 * (x[0] - x[1]), -2 * (x[0] - x[1]) + 2 * (x[1] - x[2]),
        -2 * (x[1] - x[2]) + 4 * (x[2] - x[3]) ** 3,
        -4 * (x[2] - x[3]) ** 3 + 4 * (x[3] - x[4]) ** 3, -4 * (x[3] - x[4]) ** 3]),
    ce=lambda x: [x[0] + x[1] ** 2 + x[2] ** 3 - 2 - 3 * SQ2,
                  x[1] - x[2] ** 2 + x[3] + 2 - 2 * SQ2, x[0] * x[4] - 2],
    je=lambda x: [[1, 2 * x[1], 3 * x[2] ** 2, 0, 0], [0, 1, -2 * x[2], 1, 0],
                  [x[4], 0, 0, 0, x[0]]],
)  # fmt: skip
_reg(
    80, [-2, 2, 2, -1, -1], 0.0539498478, lambda x: np.exp(np.prod(x)),
    lambda x: np.exp(np.prod(x)) * _prod_grad(x), ce=_c78, je=_j78,
    lower=[-2.3, -2.3, -3.2, -3.2, -3.2], upper=[2.3, 2.3, 3.2, 3.2, 3.2],
)  # fmt: skip
_reg(
    81, [-2, 2, 2, -1, -1], 0.0539498478,
    lambda x: np.exp(np.prod(x)) - 0.5 * (x[0] ** 3 + x[1] ** 3 + 1) ** 2,
    lambda x: np.exp(np.prod(x)) * _prod_grad(x)
    - (x[0] ** 3 + x[1] ** 3 + 1) * np.array([3 * x[0] ** 2, 3 * x[1] ** 2, 0, 0, 0]),
    ce=_c78, je=_j78,
    lower=[-2.3, -2.3, -3.2, -3.2, -3.2], upper=[2.3, 2.3, 3.2, 3.2, 3.2],
)  # fmt: skip


def _f100(x: FloatArray) -> float:
    return ((x[0] - 10) ** 2 + 5 * (x[1] - 12) ** 2 + x[2] ** 4 + 3 * (x[3] - 11) ** 2
            + 10 * x[4] ** 6 + 7 * x[5] ** 2 + x[6] ** 4 - 4 * x[5] * x[6] - 10 * x[5]
            - 8 * x[6])  # fmt: skip


def _g100(x: FloatArray) -> FloatArray:
    return np.array([2 * (x[0] - 10), 10 * (x[1] - 12), 4 * x[2] ** 3, 6 * (x[3] - 11),
                     60 * x[4] ** 5, 14 * x[5] - 4 * x[6] - 10,
                     4 * x[6] ** 3 - 4 * x[5] - 8])  # fmt: skip


_reg(
    100, [1, 2, 0, 4, 0, 1, 1], 680.6300573, _f100, _g100,
    ci=lambda x: [
        127 - 2 * x[0] ** 2 - 3 * x[1] ** 4 - x[2] - 4 * x[3] ** 2 - 5 * x[4],
        282 - 7 * x[0] - 3 * x[1] - 10 * x[2] ** 2 - x[3] + x[4],
        196 - 23 * x[0] - x[1] ** 2 - 6 * x[5] ** 2 + 8 * x[6],
        -4 * x[0] ** 2 - x[1] ** 2 + 3 * x[0] * x[1] - 2 * x[2] ** 2 - 5 * x[5] + 11 * x[6]],
    ji=lambda x: [
        [-4 * x[0], -12 * x[1] ** 3, -1, -8 * x[3], -5, 0, 0],
        [-7, -3, -20 * x[2], -1, 1, 0, 0],
        [-23, -2 * x[1], 0, 0, 0, -12 * x[5], 8],
        [-8 * x[0] + 3 * x[1], -2 * x[1] + 3 * x[0], -4 * x[2], 0, 0, -5, 11]],
)  # fmt: skip


def _f110(x: FloatArray) -> float:
    return float(np.sum(np.log(x - 2) ** 2 + np.log(10 - x) ** 2) - np.prod(x) ** 0.2)


def _g110(x: FloatArray) -> FloatArray:
    p = np.prod(x)
    return 2 * np.log(x - 2) / (x - 2) - 2 * np.log(10 - x) / (10 - x) - 0.2 * p**0.2 / x


_reg(110, [9.0] * 10, -45.77846971, _f110, _g110, lower=[2.001] * 10, upper=[9.999] * 10)


def _f113(x: FloatArray) -> float:
    return (x[0] ** 2 + x[1] ** 2 + x[0] * x[1] - 14 * x[0] - 16 * x[1] + (x[2] - 10) ** 2
            + 4 * (x[3] - 5) ** 2 + (x[4] - 3) ** 2 + 2 * (x[5] - 1) ** 2 + 5 * x[6] ** 2
            + 7 * (x[7] - 11) ** 2 + 2 * (x[8] - 10) ** 2 + (x[9] - 7) ** 2 + 45)  # fmt: skip


def _g113(x: FloatArray) -> FloatArray:
    return np.array([2 * x[0] + x[1] - 14, 2 * x[1] + x[0] - 16, 2 * (x[2] - 10),
                     8 * (x[3] - 5), 2 * (x[4] - 3), 4 * (x[5] - 1), 10 * x[6],
                     14 * (x[7] - 11), 4 * (x[8] - 10), 2 * (x[9] - 7)])  # fmt: skip


def _c113(x: FloatArray) -> FloatArray:
    return np.array([
        105 - 4 * x[0] - 5 * x[1] + 3 * x[6] - 9 * x[7],
        -10 * x[0] + 8 * x[1] + 17 * x[6] - 2 * x[7],
        8 * x[0] - 2 * x[1] - 5 * x[8] + 2 * x[9] + 12,
        -3 * (x[0] - 2) ** 2 - 4 * (x[1] - 3) ** 2 - 2 * x[2] ** 2 + 7 * x[3] + 120,
        -5 * x[0] ** 2 - 8 * x[1] - (x[2] - 6) ** 2 + 2 * x[3] + 40,
        -0.5 * (x[0] - 8) ** 2 - 2 * (x[1] - 4) ** 2 - 3 * x[4] ** 2 + x[5] + 30,
        -x[0] ** 2 - 2 * (x[1] - 2) ** 2 + 2 * x[0] * x[1] - 14 * x[4] + 6 * x[5],
        3 * x[0] - 6 * x[1] - 12 * (x[8] - 8) ** 2 + 7 * x[9],
    ])  # fmt: skip


def _j113(x: FloatArray) -> FloatArray:
    J = np.zeros((8, 10))
    J[0, [0, 1, 6, 7]] = [-4, -5, 3, -9]
    J[1, [0, 1, 6, 7]] = [-10, 8, 17, -2]
    J[2, [0, 1, 8, 9]] = [8, -2, -5, 2]
    J[3, [0, 1, 2, 3]] = [-6 * (x[0] - 2), -8 * (x[1] - 3), -4 * x[2], 7]
    J[4, [0, 1, 2, 3]] = [-10 * x[0], -8, -2 * (x[2] - 6), 2]
    J[5, [0, 1, 4, 5]] = [-(x[0] - 8), -4 * (x[1] - 4), -6 * x[4], 1]
    J[6, [0, 1, 4, 5]] = [-2 * x[0] + 2 * x[1], -4 * (x[1] - 2) + 2 * x[0], -14, 6]
    J[7, [0, 1, 8, 9]] = [3, -6, -24 * (x[8] - 8), 7]
    return J


_reg(113, [2, 3, 5, 5, 1, 2, 7, 3, 6, 10], 24.3062091, _f113, _g113, ci=_c113, ji=_j113)
