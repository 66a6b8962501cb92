"""The interior point's unfold of folded runs (stackik.solve.stages._unfold_batch,
docs/clearance.md): its runs with the rows of non-adjacent bodies take the solve's BLAS
thread limit and the initial barrier UNFOLD_MU0 (a caller's ``mu0`` wins), the runs
without those rows neither; a planar batch with dense rows takes the limit; the screen's
``per_plate`` keeps each leg's closest covering segments of a plate."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from threadpoolctl import threadpool_info

import stackik as sk
from stackik.check import FEAS_TOL
from stackik.clearance import plate_frames
from stackik.formulation.leg_pairs import LegPairRows, close_pairs, pair_table
from stackik.methods.ip import IPMethod
from stackik.sampling import random_reachable_targets
from stackik.solve.policy import UNFOLD_MU0

REF16 = sk.Stack.reference(16, leg_radius=0.0)
FAT16 = sk.Stack.uniform(sk.PlatformGeometry.hexagonal(leg_radius=12.0), 16)
#: the fingerprint's planar n = 16 target whose default pose folds with 12 mm legs
#: (tests/test_leg_pairs.py)
FOLDED = random_reachable_targets(REF16, 3, rng=36, phi=0.3)[1]


def _blas_threads() -> int:
    return max(p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas")


def _spy(monkeypatch: pytest.MonkeyPatch) -> list[dict[str, Any]]:
    """Every interior-point call of a solve: whether its problem has rows for non-adjacent
    bodies, its options and the BLAS threads in force."""
    seen: list[dict[str, Any]] = []
    original = IPMethod.run_many

    def run_many(self: IPMethod, prob: Any, starts: Any, options: Any, left: float) -> Any:
        seen.append({
            "rows": prob.clearance.leg_pairs is not None,
            "options": dict(options),
            "threads": _blas_threads(),
        })  # fmt: skip
        return original(self, prob, starts, options, left)

    monkeypatch.setattr(IPMethod, "run_many", run_many)
    return seen


def test_unfold_runs_take_the_blas_limit_and_their_barrier(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    seen = _spy(monkeypatch)
    res = sk.solve_ik(FAT16, FOLDED)
    assert res.success
    c = sk.clearances(FAT16, res.q, phi=FOLDED.phi)
    assert c.non_adjacent >= -FEAS_TOL  # clear by the exact distances
    rows = [s for s in seen if s["rows"]]
    assert rows, "the pose folded: the unfold ran"
    assert all(s["threads"] == 1 and s["options"]["mu0"] == UNFOLD_MU0 for s in rows)
    batch = seen[0]  # the start plan's batch: no rows, the request's options, no limit
    assert not batch["rows"] and "mu0" not in batch["options"]
    assert _blas_threads() == batch["threads"]  # the solve restored the limit


def test_a_callers_barrier_and_thread_count_win(monkeypatch: pytest.MonkeyPatch) -> None:
    seen = _spy(monkeypatch)
    before = _blas_threads()
    res = sk.solve_ik(FAT16, FOLDED, method="ip", options={"mu0": 0.05}, blas_threads=None)
    assert res.success
    rows = [s for s in seen if s["rows"]]
    assert rows
    assert all(s["options"]["mu0"] == 0.05 and s["threads"] == before for s in rows)


def test_planar_dense_rows_run_under_the_limit(monkeypatch: pytest.MonkeyPatch) -> None:
    """A planar batch with dense rows (an obstacle across the stack's legs, n = 4) runs
    under the solve's BLAS thread limit."""
    seen = _spy(monkeypatch)
    stack = sk.Stack.reference(4, leg_radius=0.0)
    t = random_reachable_targets(stack, 1, rng=29, phi=0.3)[0]
    free = sk.solve_ik(stack, t)
    A, O = plate_frames(stack, free.q, phi=t.phi)
    mid = (O[1] + A[1] @ stack.base_nodes[1][0] + O[2] + A[2] @ stack.top_nodes[1][0]) / 2
    seen.clear()
    sk.solve_ik(stack, t, obstacles=[sk.Sphere(mid, 15.0)])  # across leg 0 of platform 2
    assert seen and all(s["threads"] == 1 for s in seen)


def test_close_pairs_per_plate_keeps_the_closest_segments(lines_pass_through: None) -> None:
    """``close_pairs(..., per_plate=k)``: the screen's leg-leg pairs all, and of each leg's
    pairs with one plate's covering segments the ``k`` closest (least distance over the
    poses), a subset of the full screen; ``k < 1`` is refused."""
    thin = sk.solve_ik(REF16, FOLDED)
    poses = [thin.q, thin.q + 0.05]
    table = pair_table(FAT16)
    every = LegPairRows(FAT16, np.arange(table.pairs.shape[0]), 0.0, FOLDED.phi)
    d = np.min([every.distances(q) for q in poses], axis=0)
    full = close_pairs(FAT16, poses, 0.0, FOLDED.phi, 20.0)
    for k in (1, 3):
        kept = close_pairs(FAT16, poses, 0.0, FOLDED.phi, 20.0, per_plate=k)
        assert set(kept) <= set(full) and np.all(np.diff(kept) > 0)
        plate = table.body[table.pairs[:, 1]]
        assert set(full[plate[full] < 0]) <= set(kept)  # leg-leg pairs: every one
        groups: dict[tuple[int, int], list[int]] = {}
        for p in full[plate[full] >= 0]:
            groups.setdefault((int(table.pairs[p, 0]), int(plate[p])), []).append(int(p))
        want = {p for g in groups.values() for p in sorted(g, key=lambda p: (d[p], p))[:k]}
        assert set(kept[plate[kept] >= 0]) == want
        assert len(groups) > 0 and len(want) < len(full[plate[full] >= 0])
    with pytest.raises(ValueError, match="per_plate"):
        close_pairs(FAT16, poses, 0.0, FOLDED.phi, 20.0, per_plate=0)
