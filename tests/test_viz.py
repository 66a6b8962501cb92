"""The interactive 3D viewer (stackik.viz, `stackik view`, `--html`): figure contents,
leg margins against the CLI's own margins, obstacle records, one self-contained HTML file,
and a real headless Chromium rendering it (non-blank canvas, no console error)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess

import numpy as np
import pytest

from stackik.geometry import Stack
from stackik.targets import PlanarTarget, SpatialTarget

go = pytest.importorskip("plotly.graph_objects")

from stackik import viz  # noqa: E402

STACK = Stack.reference(3)
#: A feasible planar pose without a solve: each platform straight up at mid-stroke.
Q_PLANAR = np.array([[20.0, 350.0, 0.05], [0.0, 340.0, -0.05], [10.0, 360.0, 0.1]])
Q_SPATIAL = np.array(
    [[10.0, 5.0, 350.0, 0.1, 0.02, -0.03], [0.0, 0.0, 340.0, -0.1, 0.0, 0.05],
     [-5.0, 10.0, 360.0, 0.05, -0.04, 0.0]]
)  # fmt: skip
OBSTACLES = [
    {"kind": "sphere", "center": [300, 0, 500], "radius": 60},
    {"kind": "capsule", "a": [-300, -200, 0], "b": [-300, 200, 800], "radius": 20},
    {"kind": "box", "center": [0, 350, 300], "half_extents": [50, 50, 300]},
    {"kind": "halfspace", "normal": [0, 0, 1], "point": [0, 0, -5]},
]


def _trace(fig, name):
    return next(t for t in fig.data if t.name == name)


def test_leg_margins_match_the_cli_margins():
    """The viewer's margins (from Stack.*_constraints) agree with the direct geometry of
    `stackik solve` (pose_margins) to rounding, planar and spatial."""
    from types import SimpleNamespace

    from stackik.cli.solve import pose_margins
    from stackik.kinematics import lift_planar
    from stackik.rotations import euler_zyx

    for q, phi in ((Q_PLANAR, 0.4), (Q_SPATIAL, None)):
        if phi is None:
            P, R = q[:, :3], euler_zyx(q[:, 3:])
        else:
            P, R = lift_planar(q, phi)
        ref = pose_margins(STACK, SimpleNamespace(P=P, R=R))
        m = viz.leg_margins(STACK, q, phi)
        to_min = m.length - STACK.leg_min[:, None]
        assert np.allclose(to_min.min(1), ref["leg_min_mm"], atol=1e-9)
        assert np.allclose(m.joint_base.min(1), ref["joint_base_deg"], atol=1e-7)
        assert np.allclose(m.joint_top.min(1), ref["joint_top_deg"], atol=1e-7)
        assert np.all(m.fraction > 0) and np.all(m.fraction <= 1)
        assert set(m.nearest.ravel()) <= {"leg_min", "leg_max", "joint_base", "joint_top"}


def test_leg_margin_fraction_is_zero_at_a_limit_and_negative_beyond():
    q = Q_SPATIAL.copy()
    lmin = float(STACK.leg_min[0])
    q[0] = [0, 0, 300.0, 0, 0, 0]  # no rotation: every leg has the same horizontal offset h
    h2 = viz.leg_margins(STACK, q).length[0, 0] ** 2 - 300.0**2
    q[0, 2] = np.sqrt(lmin**2 - h2)  # every leg at leg_min
    m = viz.leg_margins(STACK, q)
    assert np.allclose(m.fraction[0], 0.0, atol=1e-9) and set(m.nearest[0]) == {"leg_min"}
    q[0, 2] -= 10
    assert np.all(viz.leg_margins(STACK, q).fraction[0] < 0)


def test_pose_figure_draws_plates_legs_target_and_colour_bar():
    t = PlanarTarget(30.0, 1050.0, 0.1, 0.4)
    fig = viz.pose_figure(STACK, Q_PLANAR, phi=0.4, target=t)
    plates, legs = _trace(fig, "plates"), _trace(fig, "legs")
    assert plates.type == "mesh3d" and len(plates.i) == 6 + 12 + 12 + 6  # fans of 6/12 nodes
    assert len(legs.x) == 3 * 6 * STACK.n  # a segment and a gap per leg
    assert legs.line.showscale and legs.line.colorbar.title.text == viz.MARGIN_TITLE
    frac = viz.leg_margins(STACK, Q_PLANAR, 0.4).fraction.ravel()
    assert np.allclose(legs.line.color[::3], frac)
    axes = [tr for tr in fig.data if tr.legendgroup == "target"]
    assert len(axes) == 3
    # the target's x axis starts at the target position, along its rotation's first column
    T = t.to_spatial()
    assert np.allclose([axes[0].x[0], axes[0].y[0], axes[0].z[0]], T.position)
    d = np.array([axes[0].x[1], axes[0].y[1], axes[0].z[1]]) - T.position
    assert np.allclose(d / np.linalg.norm(d), T.rotation[:, 0])
    assert fig.layout.scene.aspectmode == "manual" and not fig.frames


def test_leg_values_and_obstacles_are_drawn():
    forces = np.arange(18.0).reshape(3, 6) - 5
    fig = viz.pose_figure(
        STACK, Q_SPATIAL, leg_values=forces, leg_values_title="leg force [N]",
        obstacles=OBSTACLES,
    )  # fmt: skip
    legs = _trace(fig, "legs")
    assert legs.line.colorbar.title.text == "leg force [N]"
    assert (legs.line.cmin, legs.line.cmax) == (-5.0, 12.0)
    assert np.allclose(legs.line.color[::3], forces.ravel())
    obs = [t for t in fig.data if t.name == "obstacles"]
    assert len(obs) == 4 and sum(bool(t.showlegend) for t in obs) == 1
    sphere = obs[0]
    r = np.linalg.norm(np.stack([sphere.x, sphere.y, sphere.z], 1) - [300, 0, 500], axis=1)
    assert np.allclose(r, 60)
    with pytest.raises(ValueError, match="leg_values"):
        viz.pose_figure(STACK, Q_SPATIAL, leg_values=np.ones((2, 6)))


def test_obstacle_records_from_objects_and_bad_input():
    from dataclasses import dataclass

    @dataclass
    class Sphere:  # another module's obstacle type, read by duck typing
        center: tuple[float, float, float]
        radius: float

    rec = viz.obstacle_record(Sphere((1.0, 2.0, 3.0), 4.0))
    assert rec.kind == "sphere" and rec.radius == 4.0
    hs = viz.obstacle_record({"kind": "halfspace", "normal": [0, 0, 2], "offset": 10})
    assert np.allclose(hs.normal, [0, 0, 1]) and np.allclose(hs.center, [0, 0, 5])
    box = viz.obstacle_record({"kind": "box", "center": [0, 0, 0], "size": [2, 4, 6]})
    assert np.allclose(box.half_extents, [1, 2, 3])
    with pytest.raises(ValueError, match="unknown kind"):
        viz.obstacle_record({"kind": "torus"})
    with pytest.raises(ValueError, match="center"):
        viz.obstacle_record({"kind": "sphere", "center": [0, 0], "radius": 1})


def test_path_figure_has_frames_slider_and_play_button():
    poses = np.stack([Q_SPATIAL + [0, 0, 5 * k, 0, 0, 0] for k in range(4)])
    fig = viz.path_figure(STACK, poses, labels=list("abcd"))
    assert [f.name for f in fig.frames] == list("abcd")
    assert len(fig.frames[0].data) == len(fig.frames[0].traces)
    assert [s.label for s in fig.layout.sliders[0].steps] == list("abcd")
    assert fig.layout.updatemenus[0].buttons[0].label == "play"
    # the scene is fixed for every frame: it holds the highest pose
    top = max(max(v for v in f.data[1].z if v is not None) for f in fig.frames)
    assert fig.layout.scene.zaxis.range[1] > top
    with pytest.raises(ValueError, match="phi"):
        viz.path_figure(STACK, poses[:, :, :3])
    with pytest.raises(ValueError, match="NaN"):
        viz.path_figure(STACK, np.full((2, 3, 6), np.nan))


def test_write_html_is_one_self_contained_file(tmp_path):
    out = viz.write_html(viz.pose_figure(STACK, Q_PLANAR, phi=0.0), tmp_path / "a" / "v.html")
    text = out.read_text()
    assert "<script src=" not in text and "cdn.plot.ly" not in text.replace("cdn.plot.ly/", "")
    assert text.count("<script") >= 2 and len(text) > 1_000_000  # plotly.js inlined


def test_missing_plotly_gives_the_install_hint(monkeypatch):
    import builtins

    real = builtins.__import__

    def fake(name, *a, **k):
        if name.startswith("plotly"):
            raise ImportError("no plotly")
        return real(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", fake)
    with pytest.raises(ImportError, match=r"stackik\[plot\]"):
        viz.require_plotly()


def _solve_json(q, mode, phi, target):
    return {
        "success": True, "status": "success", "mode": mode, "q": q.tolist(), "phi": phi,
        "frobenius_norm": 123.4, "target": target, "geometry": STACK.to_dict(),
    }  # fmt: skip


def test_cli_view_reads_solve_and_path_json(tmp_path, capsys):
    from stackik.cli import main
    from stackik.paths.result import PathResult, PathStatus
    from stackik.rotations import euler_zyx

    pj = tmp_path / "pose.json"
    pj.write_text(json.dumps(_solve_json(Q_PLANAR, "planar", 0.2,
                                         {"rho": 30.0, "z": 1050.0, "theta": 0.1})))  # fmt: skip
    assert main(["view", str(pj), "--out", str(tmp_path / "pose.html")]) == 0
    assert (tmp_path / "pose.html").stat().st_size > 1_000_000
    sj = tmp_path / "spatial.json"
    spatial = {"position": [0, 0, 1050], "euler_zyx": [0.1, 0, 0]}
    sj.write_text(json.dumps(_solve_json(Q_SPATIAL, "spatial", None, spatial)))
    assert main(["view", str(sj)]) == 0 and (tmp_path / "spatial.html").exists()
    m = 3
    tg = tuple(SpatialTarget([0, 0, 1050.0 + k], euler_zyx([0, 0, 0])) for k in range(m))
    res = PathResult(
        targets=tg, q=np.stack([Q_SPATIAL] * m), success=True, completed=m,
        status=PathStatus.SUCCESS, message="ok", frobenius_norm=np.ones(m),
        leg_lengths=np.full((m, 3, 6), 350.0), margins=np.ones((m, 3, 4)),
        max_jump=(50.0, 0.25), mode="fast", source=np.arange(m, dtype=float),
    )  # fmt: skip
    doc = res.to_dict()
    doc["geometry"] = STACK.to_dict()
    path_json = tmp_path / "path.json"
    path_json.write_text(json.dumps(doc))
    assert main(["view", str(path_json), "--out", str(tmp_path / "p.html")]) == 0
    assert "p.html" in capsys.readouterr().out
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2]")
    assert main(["view", str(bad)]) == 2
    assert "expected a JSON object" in capsys.readouterr().err


def test_cli_view_colours_legs_by_force_and_draws_obstacles(tmp_path, capsys):
    """``--color force`` colours every leg by its force [N] (stackik.leg_forces under the
    payload, earth gravity) on a scale symmetric about 0; ``--obstacles`` draws the file's."""
    from stackik import Load, leg_forces
    from stackik.cli import main
    from stackik.cli.view import figure_of

    doc = _solve_json(
        Q_SPATIAL, "spatial", None, {"position": [0, 0, 1050], "euler_zyx": [0, 0, 0]}
    )
    fig = figure_of(doc, STACK, load=Load(mass=10.0))
    want = leg_forces(STACK, Q_SPATIAL, Load(mass=10.0))
    legs = [tr for tr in fig.data if tr.name == "legs"]
    colours = np.concatenate([np.asarray(tr.line.color, dtype=float) for tr in legs])
    assert set(np.round(want.ravel(), 6)) <= set(np.round(colours[np.isfinite(colours)], 6))
    bar = legs[0].line
    assert bar.cmin == -bar.cmax and bar.cmax >= np.abs(want).max() - 1e-9
    pj = tmp_path / "pose.json"
    pj.write_text(json.dumps(doc))
    obs = tmp_path / "obstacles.json"
    obs.write_text(json.dumps([{"type": "sphere", "center": [400, 0, 600], "radius": 50}]))
    out = tmp_path / "force.html"
    argv = ["view", str(pj), "--out", str(out), "--color", "force", "--payload-mass", "10"]
    assert main([*argv, "--obstacles", str(obs)]) == 0 and out.stat().st_size > 1_000_000
    assert main([*argv[:-1], "-1"]) == 2
    assert "--payload-mass" in capsys.readouterr().err


def test_cli_solve_html(tmp_path, capsys):
    from stackik.cli import main

    out = tmp_path / "solve.html"
    rc = main(["solve", "--n", "3", "--target", "0", "1000", "0", "--html", str(out)])
    assert rc == 0 and out.stat().st_size > 1_000_000
    assert f"wrote {out}" in capsys.readouterr().out


# =========================================================================================
# A real browser
# =========================================================================================
HOOK = """<script>
window.__stackikErrors = [];
window.addEventListener("error", function (e) {
  window.__stackikErrors.push("error: " + e.message);
});
["error", "warn"].forEach(function (level) {
  var orig = console[level];
  console[level] = function () {
    window.__stackikErrors.push(level + ": " + Array.prototype.join.call(arguments, " "));
    orig.apply(console, arguments);
  };
});
window.addEventListener("load", function () { setTimeout(function () {
  var out = document.createElement("pre");
  out.id = "stackik-report";
  out.textContent = JSON.stringify({errors: window.__stackikErrors,
    canvases: document.querySelectorAll(".gl-container canvas").length});
  document.body.appendChild(out);
}, 3000); });
</script>"""


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "chrome"):
        path = shutil.which(name)
        if path:
            return path
    if os.environ.get("CI"):
        pytest.fail("CI: the viewer's browser test needs chromium (apt-get install chromium)")
    pytest.skip("chromium not installed (required in CI)")
    return None


def _browser(exe: str, html, *extra: str) -> subprocess.CompletedProcess[str]:
    cmd = [
        exe, "--headless", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
        "--enable-unsafe-swiftshader", "--hide-scrollbars", "--window-size=1200,900",
        "--virtual-time-budget=15000", "--enable-logging=stderr", "--v=0", *extra,
        html.as_uri(),
    ]  # fmt: skip
    return subprocess.run(cmd, capture_output=True, text=True, timeout=180, check=False)


@pytest.mark.parametrize("kind", ["pose", "path"])
def test_html_renders_in_headless_chromium(tmp_path, kind):
    """The page draws a non-blank WebGL canvas and logs no error or warning."""
    from PIL import Image

    exe = _chromium()
    assert exe is not None
    if kind == "pose":
        fig = viz.pose_figure(STACK, Q_PLANAR, phi=0.3, target=PlanarTarget(0, 1050, 0.1, 0.3),
                              obstacles=OBSTACLES)  # fmt: skip
    else:
        poses = np.stack([Q_SPATIAL + [0, 0, 5 * k, 0.02 * k, 0, 0] for k in range(5)])
        fig = viz.path_figure(STACK, poses)
    html = viz.write_html(fig, tmp_path / f"{kind}.html")
    text = html.read_text()
    probe = tmp_path / f"{kind}_probe.html"
    probe.write_text(text.replace("<head>", "<head>" + HOOK, 1))
    dom = _browser(exe, probe, "--dump-dom")
    assert dom.returncode == 0, dom.stderr[-2000:]
    start = dom.stdout.index('<pre id="stackik-report">') + len('<pre id="stackik-report">')
    raw = dom.stdout[start : dom.stdout.index("</pre>", start)]
    report = json.loads(raw.replace("&quot;", '"'))
    assert report["errors"] == [] and report["canvases"] >= 1, report
    shot = tmp_path / f"{kind}.png"
    run = _browser(exe, html, f"--screenshot={shot}")
    assert run.returncode == 0 and shot.exists(), run.stderr[-2000:]
    logged = [ln for ln in run.stderr.splitlines() if "CONSOLE" in ln or "Uncaught" in ln]
    assert not [ln for ln in logged if "Uncaught" in ln or "ERROR:CONSOLE" in ln], logged
    img = np.asarray(Image.open(shot).convert("RGB"), dtype=float)
    centre = img[150:-150, 250:-250]  # the scene
    assert centre.std() > 20  # not blank
    drawn = (np.abs(centre - centre[0, 0]).sum(-1) > 30).mean()
    assert drawn > 0.03, drawn
    reddish = ((img[..., 0] > 150) & (img[..., 1] < 120) & (img[..., 2] < 120)).sum()
    assert reddish + ((img[..., 1] > 120) & (img[..., 0] < 120)).sum() > 200  # coloured legs
    keep = os.environ.get("STACKIK_KEEP_SCREENSHOTS")
    if keep:
        shutil.copy(shot, os.path.join(keep, shot.name))
