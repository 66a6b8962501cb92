"""Benchmark: what a new user waits for on a fresh numba cache, and what a warm process pays.

Run with ``python benchmarks/first_run.py`` (a few minutes: it compiles both kernel families
once, each in its own empty ``NUMBA_CACHE_DIR``); writes ``benchmarks/results/first_run.json``
and ``.md``. Every step runs in a fresh subprocess with the same interpreter:

1. ``import stackik`` (nothing compiled or loaded by the import).
2. A first planar solve on an empty cache (``Stack.reference(4)``, the paper's target
   ``PlanarTarget(600, 1000, -1.57)``): the wall time of the call, compilation included,
   and the solve's own ``result.time``; the compilations numba reports (``numba:compile``
   events) and the progress lines stackik printed on stderr.
3. A first spatial solve on another empty cache (n = 4, a reachable target): the same, and
   the planar kernels it compiled (none expected: a spatial solve needs none).
4. With the caches now filled, ``--repeats`` (5) fresh processes per family: import,
   ``warm_up`` (loading), the first solve's ``result.time`` and the median of the next 20
   (the first used to cost 31-39 ms against 0.6-0.9 ms later: an object-mode clock numba
   compiles in every process, and threadpoolctl's first scan, both now paid in the
   warm-up). On a loaded machine a single solve can be preempted: compare medians.
5. The command ``stackik solve --target 600 1000 -1.57`` end to end on a filled cache.

The machine is shared when this runs in the project's sessions: the load average before
and after is recorded, and compile times scale with it.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path
from typing import Any

OUT = Path(__file__).resolve().parent / "results"

_STACK = "sk.Stack.reference(4)"
_PLANAR = "sk.PlanarTarget(600.0, 1000.0, -1.57)"
_SPATIAL = (
    "sk.SpatialTarget(*sk.spatial_forward(np.array([[10.0, -5.0, 330.0, 0.05, 0.02, -0.03]] * 4)))"
)

#: A first solve on an empty cache: wall time, the solve's own time, what numba compiled.
_FIRST_SOLVE = """
import json, sys, time
from numba.core import event
import numpy as np
t0 = time.perf_counter()
import stackik as sk
t_import = time.perf_counter() - t0
stack, target = {stack}, {target}
with event.install_recorder("numba:compile") as rec:
    t0 = time.perf_counter()
    r = sk.solve_ik(stack, target)
    wall = time.perf_counter() - t0
from stackik.solve.warmup import _dispatchers
starts = [e.data["dispatcher"].py_func for _, e in rec.buffer if e.is_start]
entry = [d.py_func for d in _dispatchers("planar")]  # planar entry points
ipm = entry[0].__module__  # and the planar interior point's module, all of it
planar = sorted(set(f.__qualname__ for f in starts if f in entry or f.__module__ == ipm))
modules = sorted({{f.__module__ for f in starts if f.__module__.startswith("stackik")}})
print(json.dumps({{"import_s": t_import, "wall_s": wall, "solve_time_s": r.time,
                  "status": r.status.value, "functions_compiled": len(starts),
                  "stackik_modules_compiled": modules, "planar_kernels_compiled": planar}}))
"""

#: A warm process: import, loading, first and later solves.
_WARM = """
import json, statistics, sys, time
import numpy as np
t0 = time.perf_counter()
import stackik as sk
t_import = time.perf_counter() - t0
t_load = sk.warm_up(({kind!r},))
stack, target = {stack}, {target}
first = sk.solve_ik(stack, target).time
later = [sk.solve_ik(stack, target).time for _ in range(20)]
print(json.dumps({{"import_s": t_import, "load_s": t_load, "first_solve_s": first,
                  "later_solve_median_s": statistics.median(later),
                  "later_solve_min_s": min(later), "later_solve_max_s": max(later)}}))
"""


def _run(code: str, cache: str) -> tuple[dict[str, Any], str, float]:
    """Run ``code`` in a fresh interpreter with ``NUMBA_CACHE_DIR=cache``: its JSON line,
    its stderr and the wall time of the whole process [s]."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        env=env,
        timeout=3600,
        check=False,
    )
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"child failed ({proc.returncode}):\n{proc.stderr}")
    return json.loads(proc.stdout.strip().splitlines()[-1]), proc.stderr, wall


def _import_time(cache: str) -> dict[str, Any]:
    code = (
        "import json, sys, time\nt0 = time.perf_counter()\nimport stackik\n"
        "print(json.dumps({'import_s': time.perf_counter() - t0, "
        "'numba_imported': 'numba' in sys.modules}))"
    )
    return _run(code, cache)[0]


def _cli(cache: str) -> dict[str, Any]:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    cmd = [sys.executable, "-m", "stackik", "solve", "--target", "600", "1000", "-1.57"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600, check=False)
    return {"command": "stackik solve --target 600 1000 -1.57", "returncode": proc.returncode,
            "wall_s": time.perf_counter() - t0}  # fmt: skip


def measure(repeats: int = 5) -> dict[str, Any]:
    """Every step of the module docstring; the caches are temporary directories."""
    from stackik.bench import machine_info

    out: dict[str, Any] = {"machine": machine_info(), "load_before": os.getloadavg()}
    with tempfile.TemporaryDirectory() as planar_cache, tempfile.TemporaryDirectory() as sp:
        out["import"] = _import_time(planar_cache)
        steps = (("planar", planar_cache, _PLANAR), ("spatial", sp, _SPATIAL))
        for kind, cache, target in steps:
            code = _FIRST_SOLVE.format(stack=_STACK, target=target)
            data, err, wall = _run(code, cache)
            data["process_wall_s"] = wall
            data["stderr"] = [ln for ln in err.splitlines() if ln.startswith("stackik:")]
            out[f"first_{kind}_solve_empty_cache"] = data
        for kind, cache, target in steps:
            code = _WARM.format(kind=kind, stack=_STACK, target=target)
            out[f"warm_{kind}_process"] = [_run(code, cache)[0] for _ in range(repeats)]
        out["cli_warm_cache"] = _cli(planar_cache)
    out["load_after"] = os.getloadavg()
    return out


def _ms(s: float) -> str:
    return f"{1e3 * s:.2f} ms"


def markdown(res: dict[str, Any]) -> str:
    """The Markdown report of :func:`measure`'s result."""
    m = res["machine"]
    lines = [
        "# First run on a fresh numba cache",
        "",
        f"`python benchmarks/first_run.py`, {m['date']}, {m.get('cpu', m['processor'])}, "
        f"{m['cpus']} CPUs, Python {m['python']}, NumPy {m['numpy']}, stackik {m['stackik']}. "
        "Each step is a fresh subprocess; the two first solves each get an empty "
        "`NUMBA_CACHE_DIR`. The machine is shared (load average before / after: "
        f"{', '.join(f'{x:.1f}' for x in res['load_before'])} / "
        f"{', '.join(f'{x:.1f}' for x in res['load_after'])}): compile times grow with the "
        "load.",
        "",
        f"`import stackik`: {res['import']['import_s']:.2f} s (numba imported: "
        f"{res['import']['numba_imported']}).",
        "",
        "## First solve on an empty cache (n = 4)",
        "",
        "| target | call, compilation included [s] | the solve's `result.time` | functions "
        "compiled | planar kernels compiled | stackik's progress on stderr |",
        "|---|---|---|---|---|---|",
    ]
    for kind in ("planar", "spatial"):
        d = res[f"first_{kind}_solve_empty_cache"]
        planar = ", ".join(d["planar_kernels_compiled"]) or "none"
        if kind == "planar":
            planar = f"(all: {len(d['planar_kernels_compiled'])} functions)"
        lines.append(
            f"| {kind} | {d['wall_s']:.1f} | {_ms(d['solve_time_s'])} | "
            f"{d['functions_compiled']} | {planar} | {'<br>'.join(d['stderr'])} |"
        )
    reps = len(res["warm_planar_process"])
    lines += [
        "",
        f"## A process on the filled cache ({reps} fresh processes per family)",
        "",
        "Medians over the processes; in brackets each process's value.",
        "",
        "| family | import [s] | `warm_up` (load) [s] | first solve | later solves (median of "
        "20 in each process) |",
        "|---|---|---|---|---|",
    ]
    for kind in ("planar", "spatial"):
        runs = res[f"warm_{kind}_process"]

        def cell(key: str, fmt: Any, runs: list[dict[str, Any]] = runs) -> str:
            values = [r[key] for r in runs]
            each = ", ".join(fmt(v) for v in values)
            return f"{fmt(statistics.median(values))} ({each})"

        lines.append(
            f"| {kind} | {cell('import_s', lambda v: f'{v:.2f}')} | "
            f"{cell('load_s', lambda v: f'{v:.2f}')} | "
            f"{cell('first_solve_s', lambda v: f'{1e3 * v:.2f}')} ms | "
            f"{cell('later_solve_median_s', lambda v: f'{1e3 * v:.2f}')} ms |"
        )
    c = res["cli_warm_cache"]
    lines += [
        "",
        f"`{c['command']}` on the filled cache, end to end: {c['wall_s']:.2f} s "
        f"(exit code {c['returncode']}).",
        "",
        "Targets: planar `PlanarTarget(600, 1000, -1.57)` (the paper's first); spatial "
        "the pose of `spatial_forward` at `[10, -5, 330, 0.05, 0.02, -0.03]` per platform.",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT, help="results directory")
    parser.add_argument("--repeats", type=int, default=5, help="warm processes per family")
    args = parser.parse_args(argv)
    res = measure(args.repeats)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "first_run.json").write_text(json.dumps(res, indent=2) + "\n")
    (args.out / "first_run.md").write_text(markdown(res))
    print(markdown(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
