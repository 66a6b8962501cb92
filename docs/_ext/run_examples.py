"""Sphinx extension: run a script of ``examples/`` at build time and show it with its output.

Usage in a MyST page::

    ```{run-example} quickstart.py
    :args: --quick
    ```

``run-command`` does the same for a command line (``stackik ARGS``, run as
``python -m stackik ARGS``), so that the documented ``--help`` texts and outputs are the
program's own::

    ```{run-command} solve --help
    ```

The ``run-example`` directive shows the script's source and, below it, what it printed (stdout and
stderr), run with the interpreter that runs Sphinx, ``src/`` first on ``PYTHONPATH``, in a
temporary directory, with ``MPLBACKEND=Agg``. A script that exits non-zero or runs longer
than ``:timeout:`` seconds (default 600) is a build error, so the examples in the
documentation are always ones that ran. Each script runs once per build (cached by file and
arguments); the time each took is logged.
"""

from __future__ import annotations

import os
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from docutils import nodes
from docutils.parsers.rst import directives
from sphinx.application import Sphinx
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective

LOG = logging.getLogger(__name__)
ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
_CACHE: dict[tuple[str, str], str] = {}


class ExampleError(RuntimeError):
    """An example script failed at build time."""


def run_example(name: str, args: list[str], timeout: float) -> str:
    """Run ``examples/<name>`` with ``args``; its combined output (raises on failure)."""
    return _run([str(EXAMPLES / name), *args], f"examples/{name}", timeout)


def run_command(args: list[str], timeout: float, ok: tuple[int, ...] = (0,)) -> str:
    """Run ``stackik ARGS`` (as ``python -m stackik``); its combined output."""
    return _run(["-m", "stackik", *args], shlex.join(["stackik", *args]), timeout, ok)


def _run(argv: list[str], label: str, timeout: float, ok: tuple[int, ...] = (0,)) -> str:
    key = (label, shlex.join(argv))
    if key in _CACHE:
        return _CACHE[key]
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        [str(ROOT / "src")] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else [])
    )
    env["MPLBACKEND"] = "Agg"
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="stackik_example_") as tmp:
        try:
            proc = subprocess.run(
                [sys.executable, *argv],
                cwd=tmp,
                env=env,
                capture_output=True,
                text=True,
                timeout=timeout,
                stdin=subprocess.DEVNULL,
            )
        except subprocess.TimeoutExpired as exc:
            raise ExampleError(f"{label} ran longer than {timeout:g} s") from exc
        output = (proc.stdout + proc.stderr).replace(tmp, "OUTDIR")
    if proc.returncode not in ok:
        raise ExampleError(f"{label} exited {proc.returncode}:\n{output}")
    LOG.info(f"[run-example] {label}: {time.perf_counter() - t0:.1f} s")
    _CACHE[key] = output
    return output


class RunExample(SphinxDirective):
    """``run-example NAME``: the script's source, then its output at build time."""

    required_arguments = 1
    option_spec = {"args": directives.unchanged, "timeout": directives.positive_int}

    def run(self) -> list[nodes.Node]:
        name = self.arguments[0]
        script = EXAMPLES / name
        if not script.is_file():
            raise self.error(f"run-example: no examples/{name}")
        self.env.note_dependency(str(script))
        args = shlex.split(self.options.get("args", ""))
        try:
            output = run_example(name, args, float(self.options.get("timeout", 600)))
        except ExampleError as exc:
            raise self.error(str(exc)) from exc
        command = shlex.join(["python", f"examples/{name}", *args])
        source = nodes.literal_block(script.read_text(encoding="utf-8"), script.read_text())
        source["language"] = "python"
        caption = nodes.paragraph(text="Output of ")
        caption += nodes.literal(text=command)
        caption += nodes.Text(" (run when this page was built):")
        out = nodes.literal_block(output, output)
        out["language"] = "text"
        return [source, caption, out]


class RunCommand(SphinxDirective):
    """``run-command ARGS...``: ``stackik ARGS`` and its output at build time.

    ``:exit: N`` accepts exit code N as well as 0 (e.g. 1 for an unreachable target).
    """

    required_arguments = 1
    final_argument_whitespace = True
    option_spec = {"exit": directives.nonnegative_int, "timeout": directives.positive_int}

    def run(self) -> list[nodes.Node]:
        args = shlex.split(self.arguments[0])
        ok = (0, self.options.get("exit", 0))
        try:
            output = run_command(args, float(self.options.get("timeout", 600)), ok)
        except ExampleError as exc:
            raise self.error(str(exc)) from exc
        text = f"$ {shlex.join(['stackik', *args])}\n{output}"
        block = nodes.literal_block(text, text)
        block["language"] = "text"
        return [block]


def setup(app: Sphinx) -> dict[str, Any]:
    app.add_directive("run-example", RunExample)
    app.add_directive("run-command", RunCommand)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
