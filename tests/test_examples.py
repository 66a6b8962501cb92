"""Smoke tests: every script in examples/ runs to completion in a fresh interpreter."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
SCRIPTS = sorted(EXAMPLES.glob("*.py"))
TIME_LIMIT = 20.0  # [s] per example (budget stated in the README)


def test_examples_found() -> None:
    names = {p.name for p in SCRIPTS}
    assert {"quickstart.py", "compare_solvers.py", "sensitivity.py"} <= names


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_example_runs(script: Path) -> None:
    env = {**os.environ, "MPLBACKEND": "Agg"}
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, str(script)],
        capture_output=True,
        text=True,
        timeout=5 * TIME_LIMIT,
        cwd=EXAMPLES.parent,
        env=env,
    )
    elapsed = time.perf_counter() - t0
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip(), "example printed nothing"
    assert "Traceback" not in proc.stderr
    assert elapsed < TIME_LIMIT, f"{script.name} took {elapsed:.1f} s"


def test_quickstart_output() -> None:
    proc = subprocess.run(
        [sys.executable, str(EXAMPLES / "quickstart.py")],
        capture_output=True,
        text=True,
        timeout=100,
    )
    assert "success: True" in proc.stdout
    assert "check: ok=True" in proc.stdout


def test_compare_solvers_output() -> None:
    proc = subprocess.run(
        [sys.executable, str(EXAMPLES / "compare_solvers.py")],
        capture_output=True,
        text=True,
        timeout=100,
    )
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("(")]
    assert len(lines) == 9  # 3 targets x 3 methods
    assert all(" sqp " in ln or " slsqp " in ln or " trust-constr " in ln for ln in lines)
