"""The kernel interface's registry (stackik._compiled.kernel): what a mode may register."""

from __future__ import annotations

from typing import NamedTuple

import pytest
from numba import njit

from stackik._compiled import kernel


class _Data(NamedTuple):
    x: float


@njit
def _evaluate_swapped(P, u, lo, hi, ug, wq):  # type: ignore[no-untyped-def]
    return u


@njit
def _transpose_dot(AE, y):  # type: ignore[no-untyped-def]
    return y


def test_register_wants_the_stubs_parameters_or_those_without_the_data() -> None:
    # the stubs are called with their arguments in order (no layer of their own to compare
    # names): a function with other parameters is refused
    good = {name: _transpose_dot for name in kernel._HOOKS}
    bad = dict(good, evaluate=_evaluate_swapped)
    with pytest.raises(ValueError, match="evaluate takes"):
        kernel.register(_Data, **bad)
    with pytest.raises(ValueError, match="evaluate takes"):
        kernel.register(_Data, **good)  # (AE, y) is eq_transpose_dot's without P alone
    assert _Data not in kernel._REGISTRY
    assert kernel._PARAMETERS["eq_transpose_dot"] == ("P", "AE", "y")
