"""Command line: in-process ``main([...])`` calls and one real subprocess run."""

from __future__ import annotations

import argparse
import ast
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import stackik
import stackik.cli
from stackik import Stack, planar_forward
from stackik.cli import COMMANDS, build_parser, main
from stackik.cli._common import call_entry
from stackik.solve import METHOD_NAMES
from stackik.sqp.qp import available_qp_solvers
from stackik.targets import PAPER_TARGETS

TARGET = ["600", "1000", "-1.57"]


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def _assert_one_line_error(rc: int, err: str) -> None:
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("stackik: error: ")
    assert "Traceback" not in err


# -----------------------------------------------------------------------------------------
# solve
# -----------------------------------------------------------------------------------------
def test_solve_subprocess_json_checked_independently() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "stackik", "solve", "--n", "4", "--target", *TARGET, "--json"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    for key in (
        "success",
        "status",
        "q",
        "phi",
        "frobenius_norm",
        "max_violation",
        "time_s",
        "method",
        "qp_solver",
        "geometry",
    ):
        assert key in data
    assert data["success"] is True
    assert data["status"] == "success"
    assert data["method"] == "ip"  # method auto: the interior-point path for planar targets
    assert data["qp_solver"] == "-"
    assert available_qp_solvers()
    assert data["phi"] == 0.0
    q = np.array(data["q"])
    assert q.shape == (4, 3)
    # independent check: forward kinematics, limits, geometry and FN closed form
    assert np.allclose(planar_forward(q), [600.0, 1000.0, -1.57], atol=1e-6)
    stack = Stack.reference(4)
    assert Stack.from_dict(data["geometry"]) == stack
    assert np.all(stack.planar_constraints(q, 0.0) >= -1e-6)
    J = stackik.planar_jacobian(q)
    assert math.isclose(data["frobenius_norm"], float(np.linalg.norm(J)), rel_tol=1e-9)
    margins = data["margins"]
    assert min(min(v) for v in margins.values()) >= -1e-6


def test_solve_table(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, err = _run(capsys, "solve", "--target", *TARGET)
    assert rc == 0, err
    for word in ("rho[mm]", "l6", ">lmin", "<lmax", "jb[deg]", "jt[deg]", "frobenius norm"):
        assert word in out
    assert "success         True" in out
    # one row per platform
    rows = [ln for ln in out.splitlines() if ln[:2].strip() in {"1", "2", "3", "4"}]
    assert len(rows) == 4


def test_solve_margins_match_limits(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, _ = _run(capsys, "solve", "--target", *TARGET, "--json")
    assert rc == 0
    data = json.loads(out)
    legs = np.array(data["leg_lengths"])
    m = data["margins"]
    assert np.allclose(m["leg_min_mm"], legs.min(axis=1) - 250.0)
    assert np.allclose(m["leg_max_mm"], 450.0 - legs.max(axis=1))
    # joint margins: angle between leg and base plate minus 20 deg, recomputed here
    stack = Stack.reference(4)
    P, R = np.array(data["P"]), np.array(data["R"])
    lv = np.einsum("nij,nkj->nki", R, stack.top_nodes) + P[:, None, :] - stack.base_nodes
    ang = np.degrees(np.arcsin(lv[..., 2] / np.linalg.norm(lv, axis=-1))).min(axis=1)
    assert np.allclose(m["joint_base_deg"], ang - 20.0)


@pytest.mark.parametrize("method", ["slsqp", "trust-constr"])
def test_solve_scipy_methods(capsys: pytest.CaptureFixture[str], method: str) -> None:
    rc, out, _ = _run(capsys, "solve", "--target", *TARGET, "--method", method, "--json")
    data = json.loads(out)
    assert data["method"] == method
    assert data["qp_solver"] == "-"
    assert rc == (0 if data["success"] else 1)


def test_solve_qp_solver_and_objectives(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, _ = _run(capsys, "solve", "--target", *TARGET, "--qp-solver", "osqp", "--json")
    assert json.loads(out)["qp_solver"] == "osqp"
    rc, out, _ = _run(capsys, "solve", "--target", *TARGET, "--objective", "feasible", "--json")
    assert rc == 0 and json.loads(out)["objective"] == "feasible"
    rc, out, _ = _run(
        capsys,
        "solve",
        "--target",
        *TARGET,
        "--objective",
        "weighted",
        "--sigma-t",
        "1",
        "--sigma-theta",
        "0.005",
        "--json",
    )
    assert rc == 0 and json.loads(out)["objective"] == "weighted"


def test_solve_phi_deg(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, _ = _run(capsys, "solve", "--target", *TARGET, "--phi-deg", "30", "--json")
    assert rc == 0
    data = json.loads(out)
    assert math.isclose(data["phi"], math.radians(30))
    q = np.array(data["q"])
    assert np.all(Stack.reference(4).planar_constraints(q, data["phi"]) >= -1e-6)


def test_solve_spatial(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, err = _run(
        capsys,
        "solve",
        "--spatial",
        "--position",
        "100",
        "50",
        "1000",
        "--euler",
        "0.1",
        "0.2",
        "0",
        "--json",
    )
    assert rc == 0, err
    data = json.loads(out)
    q = np.array(data["q"])
    assert q.shape == (4, 6)
    P, R = stackik.spatial_forward(q)
    assert np.allclose(P, [100, 50, 1000], atol=1e-6)
    from stackik.rotations import euler_zyx

    assert np.allclose(R, euler_zyx([0.1, 0.2, 0.0]), atol=1e-8)
    assert np.all(Stack.reference(4).spatial_constraints(q) >= -1e-6)


def test_solve_with_geometry_file(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = tmp_path / "g.toml"
    assert main(["geometry", "write", str(path), "--n", "3"]) == 0
    capsys.readouterr()
    rc, out, err = _run(capsys, "solve", "--geometry", str(path), "--target", *TARGET, "--json")
    assert rc in (0, 1), err
    assert len(json.loads(out)["q"]) == 3
    # --n disagreeing with the file is bad input
    rc, _, err = _run(capsys, "solve", "--geometry", str(path), "--n", "4", "--target", *TARGET)
    _assert_one_line_error(rc, err)


def test_unreachable_target_exit_1(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, _ = _run(capsys, "solve", "--target", "5000", "5000", "0")
    assert rc == 1
    assert "success         False" in out
    rc, out, _ = _run(capsys, "solve", "--target", "5000", "5000", "0", "--json")
    assert rc == 1 and json.loads(out)["success"] is False


@pytest.mark.parametrize(
    "argv",
    [
        ["solve", "--target", "nan", "1000", "0"],
        ["solve", "--target", "600", "inf", "0"],
        ["solve", "--target", "600", "1000", "x"],
        ["solve", "--target", *TARGET, "--method", "newton"],
        ["solve", "--target", *TARGET, "--qp-solver", "no-such-solver"],
        ["solve", "--target", *TARGET, "--method", "slsqp", "--qp-solver", "osqp"],
        ["solve", "--target", *TARGET, "--geometry", "/no/such/file.toml"],
        ["solve", "--target", *TARGET, "--n", "0"],
        ["solve", "--target", *TARGET, "--n", "-2"],
        ["solve", "--target", *TARGET, "--starts", "0"],
        ["solve", "--target", *TARGET, "--phi", "nan"],
        ["solve", "--target", *TARGET, "--sigma-t", "2"],
        ["solve"],
        ["solve", "--spatial", "--target", *TARGET],
        ["solve", "--spatial", "--position", "0", "0", "nan"],
        ["frobnicate"],
        [],
    ],
)
def test_bad_input_exit_2_one_line(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    rc, _, err = _run(capsys, *argv)
    _assert_one_line_error(rc, err)


@pytest.mark.parametrize(
    "text",
    [
        "this is = not [toml",
        "[[platforms]]\nleg_min = 250.0\n",
        '[[platforms]]\nleg_min = "a"\nleg_max = 450.0\njoint_min = 0.3\n'
        "base_nodes = []\ntop_nodes = []\n",
    ],
)
def test_malformed_geometry_exit_2(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, text: str
) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    rc, _, err = _run(capsys, "solve", "--geometry", str(path), "--target", *TARGET)
    _assert_one_line_error(rc, err)
    assert str(path) in err
    rc, _, err = _run(capsys, "geometry", "validate", str(path))
    _assert_one_line_error(rc, err)


def test_bad_input_subprocess_no_traceback() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "stackik", "solve", "--target", "nan", "1", "0"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == ["stackik: error: rho: must be finite, got nan"]


# -----------------------------------------------------------------------------------------
# geometry
# -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_geometry_write_validate_roundtrip(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, suffix: str
) -> None:
    path = tmp_path / f"stack{suffix}"
    rc, out, _ = _run(capsys, "geometry", "write", str(path), "--n", "2")
    assert rc == 0 and path.exists()
    assert Stack.from_file(path) == Stack.reference(2)
    rc, out, err = _run(capsys, "geometry", "validate", str(path))
    assert rc == 0 and out.startswith("valid")
    assert "warning" not in err  # the reference's legs have a radius (12 mm)
    lines = tmp_path / f"lines{suffix}"  # a file whose legs have none
    (
        Stack.reference(2, leg_radius=0.0).to_toml
        if suffix == ".toml"
        else Stack.reference(2, leg_radius=0.0).to_json
    )(lines)
    rc, out, err = _run(capsys, "geometry", "validate", str(lines))
    assert rc == 0 and "warning" in err and "leg_radius" in err
    # no silent overwrite
    rc, _, err = _run(capsys, "geometry", "write", str(path))
    _assert_one_line_error(rc, err)
    assert main(["geometry", "write", str(path), "--force"]) == 0


def test_geometry_write_bad_suffix(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    rc, _, err = _run(capsys, "geometry", "write", str(tmp_path / "g.yaml"))
    _assert_one_line_error(rc, err)


def test_geometry_show(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    rc, out, _ = _run(capsys, "geometry", "show")
    assert rc == 0
    assert "4 platform(s)" in out and "250-450 mm" in out and "joint_min 20 deg" in out
    rc, out, _ = _run(capsys, "geometry", "show", "--n", "2", "--format", "json")
    assert Stack.from_dict(json.loads(out)) == Stack.reference(2)
    rc, out, _ = _run(capsys, "geometry", "show", "--format", "toml")
    path = tmp_path / "shown.toml"
    path.write_text(out)
    assert Stack.from_file(path) == Stack.reference(4)


# -----------------------------------------------------------------------------------------
# mc, map, lazily wired subcommands
# -----------------------------------------------------------------------------------------
def test_mc_json(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, err = _run(capsys, "mc", "--target", *TARGET, "--samples", "300", "--quiet", "--json")
    assert rc == 0, err
    data = json.loads(out)
    assert [p["pose"] for p in data["poses"]] == ["optimal", "non-opt 1", "non-opt 2"]
    fns = [p["frobenius_norm"] for p in data["poses"]]
    assert fns[0] <= min(fns[1:]) + 1e-6
    for p in data["poses"]:
        lo, hi = p["interval_mm"]
        assert 0 < lo < p["median_mm"] < hi


def test_mc_bad_sigma(capsys: pytest.CaptureFixture[str]) -> None:
    rc, _, err = _run(capsys, "mc", "--target", *TARGET, "--sigma-t", "-1")
    _assert_one_line_error(rc, err)


def test_mc_out_dir(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "mc"
    rc, text, err = _run(
        capsys, "mc", "--target", *TARGET, "--samples", "200", "--quiet", "--out", str(out)
    )
    assert rc == 0, err
    assert "optimal" in text and "non-opt 2" in text
    data = json.loads((out / "mc.json").read_text())
    assert data["seed"] == 2024 and len(data["poses"]) == 3


def test_map_small(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "map"
    rc, text, err = _run(
        capsys,
        "map",
        "--targets",
        "4",
        "--samples",
        "200",
        "--quiet",
        "--out",
        str(out),
        "--json",
    )
    assert rc == 0, err
    data = json.loads(text)
    assert data["targets"] == 4 and len(data["rows"]) == 4
    assert (out / "workspace.csv").read_text().startswith("rho,z,theta")
    assert (out / "regression.json").exists()


def test_map_too_few_targets(capsys: pytest.CaptureFixture[str]) -> None:
    rc, _, err = _run(capsys, "map", "--targets", "2")
    _assert_one_line_error(rc, err)


def test_reproduce_quick(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "results"
    rc, text, err = _run(capsys, "reproduce", "--quick", "--quiet", "--out", str(out))
    assert rc == 0, err
    assert (out / "report.md").exists()
    assert "target 1" in text


def test_missing_entry_point_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    rc = call_entry("stackik.no_such_module", ("main",), [], "demo")
    _, err = capsys.readouterr()
    _assert_one_line_error(rc, err)
    assert "not available yet" in err


def test_version_and_help(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, _ = _run(capsys, "--version")
    assert rc == 0 and stackik.__version__ in out
    rc, out, _ = _run(capsys, "solve", "--help")
    assert rc == 0 and "--target" in out


def test_paper_targets_constant() -> None:
    assert PAPER_TARGETS[0] == (600.0, 1000.0, -1.57)


def test_cli_module_has_no_heavy_top_level_imports() -> None:
    # every module of the package; its own modules are imported relatively (``from . import``)
    files = sorted(Path(stackik.cli.__file__).parent.glob("*.py"))
    assert len(files) == len(COMMANDS) + 2  # __init__, _common and one per subcommand
    heavy = {"numpy", "scipy", "cvxpy", "tqdm", "matplotlib", "stackik"}
    for path in files:
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.Import):
                assert not {a.name.split(".")[0] for a in node.names} & heavy, path
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                assert node.module.split(".")[0] not in heavy - {"__future__"}, path


def test_commands_follow_the_module_convention() -> None:
    names = [m.NAME for m in COMMANDS]
    assert names == ["solve", "mc", "map", "reproduce", "bench", "geometry", "path", "view"]
    for m in COMMANDS:
        assert isinstance(m.HELP, str) and m.HELP
        assert callable(m.add_parser) and callable(m.run)
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    assert list(sub.choices) == names


def test_method_choices_from_one_place(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, _ = _run(capsys, "solve", "--help")
    assert rc == 0 and "{" + ",".join(METHOD_NAMES) + "}" in out


# -----------------------------------------------------------------------------------------
# --workers / --scheduler (the runs themselves: tests/test_distributed.py)
# -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("command", ["map", "mc", "reproduce"])
def test_scale_out_options_listed(capsys: pytest.CaptureFixture[str], command: str) -> None:
    rc, out, _ = _run(capsys, command, "--help")
    assert rc == 0 and "--workers" in out and "--scheduler" in out and "local:K" in out


@pytest.mark.parametrize(
    "extra",
    [
        ["--scheduler", "local:x"],
        ["--scheduler", "local:0"],
        ["--workers", "0"],
        ["--scheduler", "tcp://127.0.0.1:1", "--workers", "2"],
    ],
)
def test_bad_scale_out_options_exit_2(capsys: pytest.CaptureFixture[str], extra: list[str]) -> None:
    rc, _, err = _run(capsys, "mc", "--target", *TARGET, "--quiet", *extra)
    _assert_one_line_error(rc, err)


def test_mc_on_two_local_processes_is_the_serial_run(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["mc", "--target", *TARGET, "--samples", "500", "--quiet", "--json"]
    rc, serial, _ = _run(capsys, *argv)
    assert rc == 0
    rc, pooled, _ = _run(capsys, *argv, "--workers", "2")
    assert rc == 0 and json.loads(pooled) == json.loads(serial)


# -----------------------------------------------------------------------------------------
# Defaults, help and the summary: what the command line says is what the code does
# -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("command", ["solve", "mc"])
def test_the_default_number_of_starts_is_the_librarys(command: str) -> None:
    args = build_parser().parse_args([command, "--target", *TARGET])
    assert args.starts is None  # solve_ik's own default (starts=None)


def test_solve_by_default_returns_the_librarys_default_pose(
    capsys: pytest.CaptureFixture[str],
) -> None:
    rc, out, _ = _run(capsys, "solve", "--target", *TARGET, "--json")
    data = json.loads(out)
    lib = stackik.solve_ik(Stack.reference(4), stackik.PlanarTarget(600.0, 1000.0, -1.57))
    assert rc == 0 and data["n_starts"] == lib.n_starts > 1
    np.testing.assert_array_equal(np.array(data["q"]), lib.q)


def test_method_help_states_the_auto_rule_of_the_code(capsys: pytest.CaptureFixture[str]) -> None:
    from stackik.methods import get_method
    from stackik.solve.policy import auto_method

    rc, out, _ = _run(capsys, "solve", "--help")
    text = " ".join(out.split())
    assert rc == 0
    # "auto (default): ip ... for planar and spatial targets with --objective frobenius or
    # weighted (planar: one sigma-theta for all platforms); sqp ... for --objective
    # feasible or when --qp-solver is given"
    assert "for planar and spatial targets with --objective frobenius or weighted" in text
    for planar in (True, False):
        assert auto_method(planar, "frobenius", None, None) == "ip"
        assert auto_method(planar, "weighted", 0.005, None) == "ip"
        assert auto_method(planar, "feasible", None, None) == "sqp"
        assert auto_method(planar, "frobenius", None, "osqp") == "sqp"
    assert "(planar: one sigma-theta for all platforms)" in text
    assert auto_method(True, "weighted", [0.005, 0.01], None) == "sqp"
    assert auto_method(False, "weighted", [0.005, 0.01], None) == "ip"
    assert "ipopt, IPOPT through CasADi (planar and spatial;" in text
    assert get_method("ipopt").modes == {"planar", "spatial"}


@pytest.mark.parametrize(
    ("method", "row"),
    [
        ("auto", "ip (QP backend: none)"),
        ("ip", "ip (QP backend: none)"),
        ("sqp", None),  # the default backend, named
        ("slsqp", "slsqp (QP backend: none)"),
    ],
)
def test_the_summary_names_method_and_qp_backend_for_every_method(
    capsys: pytest.CaptureFixture[str], method: str, row: str | None
) -> None:
    from stackik.sqp.qp import default_qp_solver

    rc, out, _ = _run(capsys, "solve", "--target", *TARGET, "--method", method, "--starts", "1")
    assert rc == 0
    line = next(ln for ln in out.splitlines() if ln.startswith("method "))
    expect = row or f"sqp (QP backend: {default_qp_solver()})"
    assert line == f"{'method':<16}{expect}"


def test_the_unreachable_message_is_one_short_line_then_details(
    capsys: pytest.CaptureFixture[str],
) -> None:
    rc, out, _ = _run(capsys, "solve", "--target", "0", "9000", "0")  # beyond the reach bound
    assert rc == 1
    lines = out.splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("status "))
    headline = "infeasible: Unreachable: the target lies beyond the reach bound of the stack."
    assert lines[k] == f"{'status':<16}{headline}"
    details = lines[k + 1 : next(i for i in range(k + 1, len(lines)) if lines[i][:1] != " ")]
    assert details and all(ln.startswith(" " * 16) and len(ln) <= 88 for ln in details)
    assert "target_error is what is left" in " ".join(details)


def test_version_subprocess() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "stackik", "--version"], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 0 and proc.stdout.strip() == f"stackik {stackik.__version__}"


def test_help_texts_print_no_format_escapes(capsys: pytest.CaptureFixture[str]) -> None:
    """Every subcommand's --help prints plain text: no '%%' left from argparse escaping
    (descriptions are not %-formatted, help strings are)."""
    for module in COMMANDS:
        with pytest.raises(SystemExit):
            build_parser().parse_args([module.NAME, "--help"])
        out = capsys.readouterr().out
        assert "%%" not in out, module.NAME


def test_geometry_validate_is_quiet_with_a_leg_radius(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    from stackik import PlatformGeometry

    path = tmp_path / "thick.toml"
    Stack.uniform(PlatformGeometry.hexagonal(leg_radius=10.0), 2).to_toml(path)
    rc, out, err = _run(capsys, "geometry", "validate", str(path))
    assert rc == 0 and out.startswith("valid") and "warning" not in err
