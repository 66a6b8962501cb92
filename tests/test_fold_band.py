"""The fold kept from curling back (stackik.formulation.fold_band, the planar default's
last resort when the unfolds end folded: stackik.solve.stages._fold_band): the rows'
values and Jacobian, the fold of a pose, and a solve whose unfolds find nothing."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import stackik as sk
from stackik.check import FEAS_TOL
from stackik.formulation import Problem
from stackik.formulation.fold_band import FOLD_BANDS, FOLD_SCREEN_MM, FoldBand, fold_platforms
from stackik.methods.ip import IPMethod
from stackik.sampling import random_reachable_targets
from stackik.solve import stages
from tests import fd

REF16 = sk.Stack.reference(16, leg_radius=0.0)
FAT16 = sk.Stack.reference(16, leg_radius=12.0)
#: the fingerprint's planar n = 16 target whose default pose folds with 12 mm legs
#: (tests/test_unfold.py)
FOLDED = random_reachable_targets(REF16, 3, rng=36, phi=0.3)[1]


def test_rows_values_and_jacobian() -> None:
    rng = np.random.default_rng(7)
    n, fold = 6, np.array([2, 3, 5])
    q = np.column_stack([rng.normal(0, 50, n), rng.uniform(150, 400, n), rng.normal(0, 0.3, n)])
    band = FoldBand(fold, 0.35, 0.3, 0.4)
    c, J = band.planar_rows(FAT16, q, 0.3)
    absolute = np.cumsum(q[:, 2])[fold] - 0.4
    expect = np.concatenate([0.35 - absolute, 0.35 + absolute,
                             0.3 - q[fold, 2], 0.3 + q[fold, 2]])  # fmt: skip
    np.testing.assert_allclose(c, expect, rtol=0, atol=1e-15)
    assert J.shape == (12, 3 * n)

    def rows(x: Any) -> Any:
        return band.planar_rows(FAT16, x.reshape(n, 3), 0.3)[0]

    num = fd.central(rows, q.ravel(), typical=np.tile(fd.TYPICAL_PLANAR, n))
    fd.assert_derivative_close(J, num, f_scale=fd.term_scale(c, num), what="fold band rows")


def test_bad_fold_is_refused() -> None:
    with pytest.raises(ValueError, match="fold"):
        FoldBand([], 0.35, 0.3, 0.0)


def test_fold_of_a_folded_pose_and_of_an_upright_one(lines_pass_through: None) -> None:
    q = sk.solve_ik(REF16, FOLDED).q  # the zero-radius pose: it folds with 12 mm legs
    fold = fold_platforms(FAT16, q, 0.0, FOLDED.phi, FOLD_SCREEN_MM)
    assert fold is not None
    assert fold[-1] == FAT16.n - 1 and np.all(np.diff(fold) == 1)
    upright = np.tile([0.0, 300.0, 0.0], (FAT16.n, 1))
    assert fold_platforms(FAT16, upright, 0.0, FOLDED.phi, FOLD_SCREEN_MM) is None


def test_with_families_checks_the_extra_rows() -> None:
    prob = Problem(FAT16, FOLDED, "frobenius", None)
    q = sk.solve_ik(REF16, FOLDED).q
    tight = prob.with_families((FoldBand(np.arange(FAT16.n), 0.0, 0.0, 1.0),))
    assert prob.constraints == ()
    assert len(tight.constraints) == 1
    assert tight.check(q).family_violation > 0.0
    assert prob.check(q).family_violation == 0.0


def test_a_batch_whose_unfolds_find_nothing_gets_the_folds_clear_pose(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A batch with no passing run whose unfolds find nothing (both made so here: on this
    target a run of the batch passes and the unfold finds a pose) still answers with a
    pose clear by the exact distances: the one the fold's rows give, checked without those
    rows."""
    banded: list[bool] = []
    original_run, original_unfold = IPMethod.run_many, stages._unfold_batch

    def run_many(self: IPMethod, prob: Any, starts: Any, options: Any, left: float) -> Any:
        banded.append(any(isinstance(f, FoldBand) for f in prob.constraints))
        return original_run(self, prob, starts, options, left)

    def unfold_batch(req: Any, method: Any, batch: Any) -> None:
        assert batch.folded
        batch.best = None  # as if no run of the batch had passed
        original_unfold(req, method, batch)

    monkeypatch.setattr(IPMethod, "run_many", run_many)
    monkeypatch.setattr(stages, "_unfold_batch", unfold_batch)
    monkeypatch.setattr(stages, "_unfold", lambda *a, **k: None)
    res = sk.solve_ik(FAT16, FOLDED)
    assert res.success and res.method == "ip"
    assert 1 <= banded.count(True) <= len(FOLD_BANDS)  # runs with the fold's rows
    assert sk.clearances(FAT16, res.q, phi=FOLDED.phi).minimum >= -FEAS_TOL
    check = sk.check_pose(FAT16, FOLDED, res.q)
    assert check.ok and check.family_violation == 0.0


def test_tall_planar_batches_go_to_the_fold_band_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """From FOLD_BAND_FIRST_N platforms on (planar), a batch whose runs pass legs through
    plates is not made again run by run: the fold band answers, and only its pose is
    unfolded once (stages._fold_band); below, and in spatial mode, the batch's runs are."""
    from stackik.formulation.fold_band import FOLD_BAND_FIRST_N
    from stackik.formulation.modes import PLANAR, SPATIAL
    from stackik.solve import stages

    assert PLANAR.band_first(sk.Stack.reference(FOLD_BAND_FIRST_N, leg_radius=0.0))
    assert not PLANAR.band_first(sk.Stack.reference(FOLD_BAND_FIRST_N - 1, leg_radius=0.0))
    assert not SPATIAL.band_first(sk.Stack.reference(64, leg_radius=0.0))
    h = np.array([300.0, 310.0, 320.0])  # the band's upright start, at these heights
    np.testing.assert_array_equal(PLANAR.upright(h), [[0.0, z, 0.0] for z in h])
    np.testing.assert_array_equal(SPATIAL.upright(h), [[0.0, 0.0, z, 0.0, 0.0, 0.0] for z in h])
    unfolds: list[int] = []
    bands: list[int] = []
    unfold, band = stages._unfold, stages._fold_band

    def spy_unfold(*args: Any, **kwargs: Any) -> Any:
        unfolds.append(1)
        return unfold(*args, **kwargs)

    def spy_band(*args: Any, **kwargs: Any) -> Any:
        bands.append(len(unfolds))  # the unfolds before the band
        return band(*args, **kwargs)

    monkeypatch.setattr(stages, "_unfold", spy_unfold)
    monkeypatch.setattr(stages, "_fold_band", spy_band)
    stack = sk.Stack.reference(FOLD_BAND_FIRST_N, leg_radius=0.0)
    t = random_reachable_targets(stack, 8, rng=15583 + FOLD_BAND_FIRST_N, phi=0.3)[0]
    res = sk.solve_ik(stack, t)
    assert res.success and sk.check_pose(stack, t, res.q).ok
    assert bands == [0] and len(unfolds) == 1
