"""Finite-difference test of the self-leg clearance rows (stackik._compiled.self_legs)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from fd import assert_derivative_close, central

from stackik._compiled.self_legs import self_leg_rows

PAIRS = np.array(list(itertools.combinations(range(6), 2)), dtype=np.int64)


def _joints(rng):
    ang_b = np.sort(rng.uniform(0, 2 * np.pi, 6))
    ang_t = np.sort(rng.uniform(0, 2 * np.pi, 6))
    base = np.c_[100 * np.cos(ang_b), 100 * np.sin(ang_b), np.zeros(6)]
    top = np.c_[70 * np.cos(ang_t), 70 * np.sin(ang_t), np.zeros(6)]
    return base, top


def _rows(q, base, top):
    c = np.empty(len(PAIRS))
    J = np.empty((len(PAIRS), 6))
    self_leg_rows(np.asarray(q, float), base, top, PAIRS, 24.0, 1e4, c, J)
    return c, J


@pytest.mark.parametrize("seed", range(5))
def test_self_leg_jacobian_fd(seed):
    rng = np.random.default_rng(seed)
    base, top = _joints(rng)
    q = np.r_[rng.normal(0, 10, 2), 150 + rng.normal(0, 10), rng.normal(0, 0.2, 3)]
    _, J = _rows(q, base, top)
    num = central(lambda x: _rows(x, base, top)[0], q, typical=[100, 100, 100, 1, 1, 1])
    assert_derivative_close(J, num, f_scale=4.0)
