"""Every figure the package writes has a background-coloured border: no title, label or
legend is cut at an edge. Small fast cases of analysis/figures.py, paths/animate.py and the
PNGs of `stackik mc`, `stackik map` and `stackik path`."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from PIL import Image  # noqa: E402  (a matplotlib dependency)

from stackik.cli import main  # noqa: E402
from stackik.geometry import Stack  # noqa: E402

#: Width of the border that must be background [px].
BORDER = 4


def assert_clean_border(path: Path, border: int = BORDER) -> None:
    """Every pixel within ``border`` of an edge has the colour of the corner (the figure
    background); every frame of an animated GIF is checked."""
    with Image.open(path) as im:
        frames = getattr(im, "n_frames", 1)
        for f in range(frames):
            im.seek(f)
            a = np.asarray(im.convert("RGB"), dtype=int)
            bg = a[0, 0]
            edges = np.concatenate(
                [
                    a[:border].reshape(-1, 3),
                    a[-border:].reshape(-1, 3),
                    a[:, :border].reshape(-1, 3),
                    a[:, -border:].reshape(-1, 3),
                ]
            )
            off = np.abs(edges - bg).max(axis=1) > 8
            assert not off.any(), f"{path.name} frame {f}: {int(off.sum())} border pixels drawn"
            assert np.abs(a - bg).max() > 50, f"{path.name} frame {f}: blank"


def test_the_border_check_catches_a_clipped_figure(tmp_path: Path) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3, 2), dpi=80)
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))  # the axes frame on the edge
    ax.set_title("cut off")
    fig.savefig(tmp_path / "bad.png")
    with pytest.raises(AssertionError, match="border pixels"):
        assert_clean_border(tmp_path / "bad.png")


def test_cli_mc_figures(tmp_path: Path) -> None:
    out = tmp_path / "mc"
    rc = main(["mc", "--n", "3", "--target", "300", "800", "-0.5", "--samples", "300",
               "--quiet", "--out", str(out), "--json"])  # fmt: skip
    assert rc == 0
    for name in ("poses.png", "clouds.png"):
        assert_clean_border(out / name)


def test_cli_map_figures(tmp_path: Path) -> None:
    out = tmp_path / "map"
    rc = main(["map", "--n", "3", "--targets", "5", "--samples", "200", "--quiet",
               "--out", str(out), "--json"])  # fmt: skip
    assert rc == 0
    pngs = sorted(out.glob("*.png"))
    assert {p.name for p in pngs} >= {"fn_ratio_map.png", "regression.png"}
    for p in pngs:
        assert_clean_border(p)


def test_cli_path_figures(tmp_path: Path) -> None:
    out = tmp_path / "path"
    rc = main(["path", "--n", "4", "--from", "600", "1000", "-1.57", "--to", "145", "1500",
               "-0.207", "--steps", "4", "--max-jump", "60", "0.3", "--frames", "3",
               "--out", str(out), "--json"])  # fmt: skip
    assert rc == 0
    assert_clean_border(out / "path.png")
    assert_clean_border(out / "path.gif")


def test_spatial_pose_figure(tmp_path: Path) -> None:
    from stackik.analysis.figures import plot_spatial_pose

    stack = Stack.reference(3)
    q = np.array([[10.0, 5.0, 350.0, 0.1, 0.02, -0.03], [0.0, 0.0, 340.0, -0.1, 0.0, 0.05],
                  [-5.0, 10.0, 360.0, 0.05, -0.04, 0.0]])  # fmt: skip
    plot_spatial_pose(stack, q, title="a spatial pose", path=tmp_path / "spatial.png")
    assert_clean_border(tmp_path / "spatial.png")


def test_spatial_path_figures(tmp_path: Path) -> None:
    """plot_path and animate_path of a spatial path (the CLI test covers a planar one)."""
    from stackik.paths.animate import animate_path, plot_path
    from stackik.paths.result import PathResult, PathStatus
    from stackik.targets import SpatialTarget

    stack = Stack.reference(3)
    m = 3
    q = np.array([[[0.0, 0.0, 350.0 + 5 * k, 0.02 * k, 0.0, 0.0]] * 3 for k in range(m)])
    res = PathResult(
        targets=tuple(SpatialTarget([0, 0, 1050.0 + 15 * k], np.eye(3)) for k in range(m)),
        q=q, success=True, completed=m, status=PathStatus.SUCCESS, message="ok",
        frobenius_norm=np.full(m, 900.0), leg_lengths=np.full((m, 3, 6), 350.0),
        margins=np.ones((m, 3, 4)), max_jump=(50.0, 0.25), mode="fast",
        source=np.arange(m, dtype=float),
    )  # fmt: skip
    import matplotlib.pyplot as plt

    plt.close(plot_path(res, stack, tmp_path / "p.png"))
    assert_clean_border(tmp_path / "p.png")
    (gif,) = animate_path(res, stack, tmp_path / "a.gif", max_frames=2, dpi=50, mp4=False)
    assert_clean_border(gif)
