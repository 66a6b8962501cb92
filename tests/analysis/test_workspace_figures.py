"""Regression, workspace targets, figures and the quick reproduction."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import numpy as np
import pytest

from stackik import Stack, planar_forward
from stackik.analysis import figures, monte_carlo
from stackik.analysis.workspace import (
    platform_box,
    random_feasible_poses,
    random_reachable_targets,
    regress,
    uniform_reachable_targets,
    workspace_study,
)

pytest.importorskip("matplotlib")

Q1 = np.array([[0.0, 300.0, -0.3925]] * 4)
Q2 = np.array([[20.0, 310.0, -0.2], [-10.0, 300.0, -0.5], [15.0, 290.0, -0.4], [0, 305, -0.47]])
PNG = b"\x89PNG\r\n\x1a\n"


def _png(path):
    data = path.read_bytes()
    assert data[:8] == PNG and len(data) > 5000


def test_regression_synthetic():
    rng = np.random.default_rng(0)
    x = rng.uniform(0.5, 1.0, 200)
    reg = regress(x, 0.4 * x + 0.6)
    assert reg.slope == pytest.approx(0.4) and reg.intercept == pytest.approx(0.6)
    assert reg.r2 == pytest.approx(1.0)
    noisy = regress(x, 0.4 * x + 0.6 + rng.normal(0, 0.01, x.size))
    assert noisy.slope == pytest.approx(0.4, abs=0.03) and 0.8 < noisy.r2 < 1.0
    np.testing.assert_allclose(reg.predict([1.0]), [1.0])
    with pytest.raises(ValueError):
        regress([1, 2], [1, 2])


def test_random_feasible_poses_and_targets():
    s = Stack.reference(4)
    q = random_feasible_poses(s, 25, rng=3)
    assert q.shape == (25, 4, 3)
    assert np.all(s.planar_constraints(q, 0.0) >= 0)
    t = random_reachable_targets(s, 5, rng=3)
    np.testing.assert_allclose([t[0].rho, t[0].z, t[0].theta], planar_forward(q[0]))
    again = random_reachable_targets(s, 5, rng=3)
    assert [x.rho for x in again] == [x.rho for x in t]


def test_platform_box_contains_the_feasible_set():
    s = Stack.reference(4)
    box = np.array(platform_box(s))
    # a much larger box: every feasible pose found there lies inside platform_box
    q = random_feasible_poses(s, 3000, rng=0, box=[(-1500, 1500), (-600, 1200), (-3.1, 3.1)])
    p = q.reshape(-1, 3)
    assert np.all(p >= box[:, 0]) and np.all(p <= box[:, 1])
    # and it is not absurdly loose (theta is the loosest: 0.93 of 2.44 rad)
    assert np.all(p.max(axis=0) > 0.3 * box[:, 1])


def test_uniform_reachable_targets_even_and_reachable():
    pytest.importorskip("stackik.solve")
    s = Stack.reference(4)
    t = uniform_reachable_targets(s, 200, rng=7, phi=0.3)
    assert len(t) == 200 and all(x.phi == 0.3 for x in t)
    again = uniform_reachable_targets(s, 200, rng=7, phi=0.3)
    assert [(x.rho, x.z, x.theta) for x in again] == [(x.rho, x.z, x.theta) for x in t]
    # at most one target per 100 mm square until every square has one: far more even than
    # the unthinned forward kinematics of random poses
    X = np.array([[x.rho, x.z] for x in t])
    _, per_cell = np.unique(np.floor(X / 100.0), axis=0, return_counts=True)
    Y = np.array([[x.rho, x.z] for x in random_reachable_targets(s, 200, rng=7, phi=0.3)])
    _, per_cell_poses = np.unique(np.floor(Y / 100.0), axis=0, return_counts=True)
    assert per_cell.max() <= 2 < per_cell_poses.max()
    assert per_cell.size > per_cell_poses.size
    # every target is reached by the optimal solve
    from stackik.solve import solve_ik

    assert all(solve_ik(s, x, objective="frobenius").success for x in t[:5])
    with pytest.raises(ValueError):
        uniform_reachable_targets(s, 0)
    with pytest.raises(ValueError):
        uniform_reachable_targets(s, 5, cell=0.0)


def test_spatial_pose_plates_carry_every_leg_end():
    """The 3D drawing outlines each plate through all nodes it carries (12 in between)."""
    from matplotlib.collections import PolyCollection

    s = Stack.reference(4)
    fig = figures.plot_spatial_pose(s, Q2, phi=0.4)
    ax = fig.axes[0]
    polys = [c for c in ax.collections if isinstance(c, PolyCollection)]
    assert len(polys) == s.n + 1
    nodes = figures.stack_nodes(s, Q2, 0.4)
    # the outline line of plate 1 passes through platform 1's top and platform 2's base nodes
    rings = [ln for ln in ax.lines if len(ln.get_data_3d()[0]) == 13]
    assert len(rings) == s.n - 1
    ring = np.array(rings[0].get_data_3d()).T[:-1]
    want = np.concatenate([nodes["top"][0], nodes["base"][1]])
    d = np.linalg.norm(want[:, None, :] - ring[None, :, :], axis=-1).min(axis=1)
    assert np.all(d < 1e-9)


def test_figures_written(tmp_path):
    s = Stack.reference(4)
    mc = monte_carlo([Q1, Q2], 2000, 1.0, 0.005, rng=0)
    figures.plot_pose_diagram(s, [Q1, Q2], 0.0, ["a", "b"], path=tmp_path / "poses.png")
    figures.plot_perturbation_clouds(mc, ["a", "b"], path=tmp_path / "clouds.png")
    figures.plot_spatial_pose(s, Q2, phi=0.4, path=tmp_path / "pose3d.png")
    figures.plot_spatial_pose(s, figures.planar_to_spatial(Q2, 0.4), path=tmp_path / "p3.png")
    for name in ("poses.png", "clouds.png", "pose3d.png", "p3.png"):
        _png(tmp_path / name)
    # node helper: plate origins match the planar forward kinematics
    nodes = figures.stack_nodes(s, Q2, 0.0)
    np.testing.assert_allclose(nodes["O"][-1][[0, 2]], planar_forward(Q2)[:2], atol=1e-9)


def test_workspace_study_and_map(tmp_path):
    pytest.importorskip("stackik.solve")
    s = Stack.reference(4)
    st = workspace_study(s, 6, n_samples=1000, seed=1)
    assert len(st.targets) == 6 and st.valid.sum() >= 3
    with pytest.raises(ValueError):
        workspace_study(s, 6, sampling="grid")  # type: ignore[arg-type]
    v = st.valid
    assert np.all(st.fn_ratio[v] < 1.0 + 1e-9)  # the optimum has the least FN
    assert st.regression is not None and st.regression.n == v.sum()
    assert len(st.rows()) == 6
    figures.plot_fn_ratio_map(st, highlight=[(600, 1000)], path=tmp_path / "map.png")
    figures.plot_regression(st, path=tmp_path / "reg.png")
    _png(tmp_path / "map.png")
    _png(tmp_path / "reg.png")


def test_reproduce_quick(tmp_path):
    """Smoke test of ``stackik reproduce --quick`` (well under 30 s)."""
    pytest.importorskip("stackik.solve")
    from stackik.analysis.reproduce import reproduce

    res = reproduce(tmp_path, quick=True, rng=5, progress=False)
    report = (tmp_path / "report.md").read_text()
    assert "Table 1" in report and "Table 2" in report and "regression.png" in report
    for f in res.files:
        assert f.exists() and f.stat().st_size > 0
    for name in ("poses_target1.png", "clouds_target3.png", "fn_ratio_map.png", "regression.png"):
        _png(tmp_path / name)
    assert len(res.table1) == 3 and all(len(m) == 3 for m in res.table1)
    # deterministic
    again = reproduce(tmp_path / "again", quick=True, rng=5, progress=False)
    np.testing.assert_array_equal(res.table1[0].medians, again.table1[0].medians)
    assert res.table2 == again.table2
