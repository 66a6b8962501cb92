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
TIME_LIMIT = 20.0  # [s] per example
#: Lines every example must print (beyond running without error).
EXPECTED = {
    "quickstart.py": ["success: True", "check: ok=True"],
    "compare_solvers.py": ["ip", "sqp", "slsqp", "trust-constr"],
    "sensitivity.py": ["optimal", "non-optimised", "sqrt(trace(J C_x J^T))"],
}


def test_examples_found() -> None:
    names = {p.name for p in SCRIPTS}
    assert set(EXPECTED) <= names


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
    for text in EXPECTED.get(script.name, []):
        assert text in proc.stdout, f"{script.name}: {text!r} missing"
    if script.name == "compare_solvers.py":
        rows = [ln for ln in proc.stdout.splitlines() if ln.startswith("(")]
        assert len(rows) == 12  # 3 targets x 4 methods
