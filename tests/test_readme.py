"""The README's commands, examples and numbers, checked.

Every fenced code block of README.md carries a marker comment just above it that says how
it is checked (a block without one fails :func:`test_every_block_has_a_marker`):

- ``<!-- test_readme: setup -->``: the set-up commands. The ``pip install`` is not re-run
  (CI installs exactly so before the tests), nor ``pytest`` (this is it); the solve after
  ``&&`` is run.
- ``<!-- test_readme: run -->``: Python blocks are executed; each ``stackik ...`` line of a
  shell block is run in order in one scratch directory (``stackik.cli.main``, the
  console script's entry point) and must exit 0.
- ``<!-- test_readme: parse-only (...) -->``: commands that run for seconds to minutes;
  each must be accepted by the argument parser.

The headline table is generated from ``benchmarks/results`` by ``docs/gen_benchmarks.py``
(no number in it is copied by hand); the claims the README makes about defaults, the
summary line, exit codes and the reference geometry are checked against the code.
"""

from __future__ import annotations

import contextlib
import io
import math
import re
import shlex
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
TEXT = README.read_text(encoding="utf-8")
#: The text with line breaks (and block-quote marks) as spaces, for phrases.
PROSE = " ".join(re.sub(r"^> ?", "", TEXT, flags=re.MULTILINE).split())
MAX_LINES = 250

_BLOCK = re.compile(
    r"(?:<!-- test_readme: (?P<marker>[^>]*?) -->\n)?```(?P<lang>\w*)\n(?P<body>.*?)\n```",
    re.DOTALL,
)


def _blocks() -> list[tuple[str | None, str, str]]:
    return [(m["marker"], m["lang"], m["body"]) for m in _BLOCK.finditer(TEXT)]


def _kind(marker: str | None) -> str | None:
    return None if marker is None else marker.split()[0]


def _commands(body: str) -> list[list[str]]:
    """The ``stackik`` commands of a shell block, comments stripped, as argument lists."""
    out = []
    for line in body.splitlines():
        tokens = shlex.split(line, comments=True)
        if tokens:
            assert tokens[0] == "stackik", f"not a stackik command: {line!r}"
            out.append(tokens[1:])
    return out


def _stackik(args: list[str]) -> tuple[int, str]:
    """``stackik ARGS`` in this process: (exit code, stdout + stderr)."""
    from stackik.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
        rc = main(args)
    return rc, buf.getvalue()


def test_readme_is_short() -> None:
    n = len(TEXT.splitlines())
    assert n <= MAX_LINES, f"README.md has {n} lines (at most {MAX_LINES})"


def test_every_block_has_a_marker() -> None:
    blocks = _blocks()
    assert blocks
    for marker, lang, body in blocks:
        assert _kind(marker) in ("setup", "run", "parse-only"), (
            f"README block without a test_readme marker:\n{body[:200]}"
        )
        assert lang in ("bash", "python"), lang


def test_setup_commands(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The first screen's two commands: install and solve, run the tests."""
    (setup,) = [body for marker, _, body in _blocks() if _kind(marker) == "setup"]
    install, tests = setup.splitlines()
    assert TEXT.index(setup) < 1500, "the set-up commands must be on the first screen"
    pip, solve = (part.strip() for part in install.split("&&"))
    assert pip == 'pip install -e ".[dev]"'  # what .ci/run installs; not re-run here
    assert 'pip install --quiet -e ".[dev]"' in (ROOT / ".ci" / "run").read_text()
    assert tests == "python -m pytest -q"  # this suite; not re-run here
    (args,) = _commands(solve)
    monkeypatch.chdir(tmp_path)
    rc, out = _stackik(args)
    assert rc == 0, out
    assert "success         True" in out
    assert "reference geometry" in out
    # the prose says which target it is
    rho, z, theta = args[args.index("--target") + 1 :][:3]
    assert f"rho = {rho} mm, z = {z} mm, theta = {theta} rad" in PROSE
    assert args[args.index("--n") + 1] == "4" and "stack of four platforms" in PROSE


@pytest.mark.parametrize(
    "index",
    [
        i
        for i, (marker, lang, _) in enumerate(_blocks())
        if _kind(marker) == "run" and lang == "python"
    ],
)
def test_python_example(
    index: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture
) -> None:
    _, _, code = _blocks()[index]
    monkeypatch.chdir(tmp_path)
    exec(compile(code, f"README.md block {index}", "exec"), {"__name__": "__readme__"})
    out = capsys.readouterr().out
    assert out.startswith("True"), out  # every example prints result.success first


def test_run_commands(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every command of the README's "run" shell blocks, in order, in one directory (so
    that ``geometry write`` makes the file the next commands read)."""
    monkeypatch.chdir(tmp_path)
    bodies = [b for m, lang, b in _blocks() if _kind(m) == "run" and lang == "bash"]
    assert bodies
    for args in (a for body in bodies for a in _commands(body)):
        rc, out = _stackik(args)
        assert rc == 0, f"stackik {shlex.join(args)} exited {rc}:\n{out}"


def test_parse_only_commands() -> None:
    from stackik.cli import build_parser

    parser = build_parser()
    bodies = [b for m, _, b in _blocks() if _kind(m) == "parse-only"]
    assert bodies
    for args in (a for body in bodies for a in _commands(body)):
        if args[0] != "bench":
            parser.parse_args(args)
        else:  # every argument goes to the benchmark's own parser
            with pytest.raises(SystemExit) as exc, contextlib.redirect_stdout(io.StringIO()) as h:
                from stackik.bench import main as bench_main

                bench_main(["--help"])
            assert exc.value.code == 0
            for token in args[1:]:
                if token.startswith("--"):
                    assert token in h.getvalue(), f"stackik bench has no {token}"


def test_headline_table_is_generated() -> None:
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        import gen_benchmarks
    finally:
        sys.path.remove(str(ROOT / "docs"))
    assert gen_benchmarks.BEGIN in TEXT
    assert gen_benchmarks.readme_with_block(TEXT) == TEXT, (
        "README's headline table differs from benchmarks/results: "
        "run python docs/gen_benchmarks.py --write"
    )


# --- claims in the prose ------------------------------------------------------------------


def test_default_starts() -> None:
    """The README's default starts: "three for planar stacks up to n = 4", "eight for
    spatial stacks up to n = 3, twelve from n = 4" and six hops (twelve at n = 7 and 8),
    and the command line's same default."""
    from stackik import PlanarTarget, SpatialTarget, Stack, solve_ik
    from stackik.cli import build_parser
    from stackik.rotations import euler_zyx
    from stackik.sampling import random_spatial_targets

    assert "three for planar stacks up to n = 4" in PROSE
    assert "eight for spatial stacks up to n = 3, twelve from n = 4" in PROSE
    assert "The command line uses the same default unless given `--starts K`" in PROSE
    stack = Stack.reference(4)
    assert solve_ik(stack, PlanarTarget(600.0, 1000.0, -1.57)).n_starts == 3
    spatial = SpatialTarget(np.array([100.0, 50.0, 1000.0]), euler_zyx([0.1, 0.2, 0.0]))
    assert 'then "hops" from the best pose from n = 4: six, twelve at n = 7 and 8' in PROSE
    lines = Stack.reference(4, leg_radius=0.0)  # the plan without self-leg rows
    assert solve_ik(lines, spatial).n_starts == 12 + 6
    stack6 = Stack.reference(6, leg_radius=0.0)
    assert solve_ik(stack6, random_spatial_targets(stack6, 1, 9606)[0]).n_starts == 12 + 6
    stack8 = Stack.reference(8, leg_radius=0.0)
    assert solve_ik(stack8, random_spatial_targets(stack8, 1, 9608)[0]).n_starts == 12 + 12
    # the reference's 12 mm legs: the same search first, then runs with the self-leg rows
    # where its pose brings two legs of a platform together
    assert "the spatial default runs this search without the self-leg rows first" in PROSE
    thick = solve_ik(stack, spatial)
    assert thick.success and thick.n_starts >= 12 + 6
    args = build_parser().parse_args(["solve", "--target", "600", "1000", "-1.57"])
    assert args.starts is None  # None: solve_ik's default


def test_kernel_families_claim() -> None:
    """The README's kernel families: "a planar solve compiles the planar family; a spatial
    solve compiles only the spatial family" (the planar one only beyond the reach bound)."""
    from stackik import PlanarTarget, SpatialTarget, Stack
    from stackik.solve.pipeline import _kernels_needed

    assert "a spatial solve compiles only the spatial family" in PROSE
    stack = Stack.reference(4)
    assert _kernels_needed(stack, PlanarTarget(600.0, 1000.0, -1.57)) == ("planar",)
    spatial = SpatialTarget(np.array([100.0, 50.0, 1000.0]), np.eye(3))
    assert _kernels_needed(stack, spatial) == ("spatial",)
    far = SpatialTarget(np.array([3000.0, 0.0, 500.0]), np.eye(3))
    assert set(_kernels_needed(stack, far)) == {"spatial", "planar"}


SUMMARY_LABELS = (
    "success",
    "status",
    "frobenius norm",
    "objective",
    "phi",
    "max violation",
    "target error",
    "time",
    "method",
)


def test_summary_line_claim(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The summary fields the README lists are the ones ``solve`` prints, in that order,
    with the QP backend beside the method (``none`` where no QP is solved)."""
    head = "`solve` prints a summary:"
    sentence = TEXT[TEXT.index(head) + len(head) : TEXT.index("Exit codes:")]
    listed = re.findall(r"`([a-z ]+)`", sentence)
    assert tuple(listed) == SUMMARY_LABELS
    monkeypatch.chdir(tmp_path)
    for extra, qp in (([], False), (["--method", "sqp"], True)):
        rc, out = _stackik(["solve", "--target", "600", "1000", "-1.57", *extra])
        assert rc == 0
        summary = out.split("\n\n")[-1].splitlines()
        labels = tuple(line[:16].strip() for line in summary if line.strip())
        assert labels == SUMMARY_LABELS
        assert ("(QP backend: none)" in summary[-1]) != qp and "(QP backend: " in summary[-1]


def test_exit_codes_claim(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    assert "**0** success, **1** no feasible pose" in PROSE and "**2** bad input" in PROSE
    monkeypatch.chdir(tmp_path)
    rc, _ = _stackik(["solve", "--target", "3000", "100", "0"])  # beyond reach
    assert rc == 1
    rc, out = _stackik(["solve", "--target", "600", "nan", "0"])
    assert rc == 2 and "stackik: error:" in out


def test_reference_geometry_claim() -> None:
    from stackik import Stack

    assert (
        "node radius 150 mm, half-angles 15 deg, legs 250-450 mm, joint angle at least 20 deg"
        in PROSE
    )
    p = Stack.reference(4)[0]
    assert np.allclose(np.hypot(*p.base_nodes[:, :2].T), 150.0)
    assert np.allclose(np.hypot(*p.top_nodes[:, :2].T), 150.0)
    assert math.isclose(math.degrees(np.arctan2(*p.base_nodes[1, 1::-1])), 15.0)
    assert (p.leg_min, p.leg_max) == (250.0, 450.0)
    assert math.isclose(math.degrees(p.joint_min), 20.0)
    # "chosen so that the paper's three targets are reachable with n = 4"
    assert "chosen so that the paper's three targets are reachable with n = 4" in PROSE
    from stackik import solve_ik
    from stackik.targets import paper_targets

    assert all(solve_ik(Stack.reference(4), t).success for t in paper_targets())


def test_project_files() -> None:
    """LICENSE matches pyproject's licence; CITATION.cff cites the paper the README names."""
    import tomllib

    yaml = pytest.importorskip("yaml")  # a dependency of dask, in the dev extra
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert meta["license"] == {"text": "MIT"} and "MIT licence (`LICENSE`)" in PROSE
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert cff["cff-version"] == "1.2.0" and cff["version"] == meta["version"]
    paper = cff["preferred-citation"]
    assert f'"{paper["title"]}."' in PROSE
    names = [f"{a['given-names']} {a['family-names']}" for a in paper["authors"]]
    assert ", ".join(names[:-1]) + ", " + names[-1] in PROSE
    assert f"AAMAS {paper['year']}" in PROSE
    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert "## Unreleased" in changelog and f"## {meta['version']} - " in changelog


def test_docs_command_is_the_ci_one() -> None:
    (command,) = re.findall(r"`(python -m sphinx [^`]*)`", TEXT)
    ci = (ROOT / ".ci" / "run").read_text()
    assert command.replace(" -b ", " -q -b ") in ci, "README's docs build is not .ci/run's"


def test_linked_files_exist() -> None:
    for target in re.findall(r"\]\(([^)#]+)\)", TEXT):
        if "://" not in target:
            assert (ROOT / target).exists(), target
    for name in re.findall(r"`((?:LICENSE|CITATION\.cff|CHANGELOG\.md))`", TEXT):
        assert (ROOT / name).is_file(), name
