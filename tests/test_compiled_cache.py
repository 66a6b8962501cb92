"""numba's on-disk cache can never hand back a kernel compiled against an older callee.

numba stamps a cached function with its own file: a caller in one file that inlines a
callee from another is loaded stale after only the callee's file changed. The kernels of
:mod:`stackik._compiled` are stamped with a hash of every file of the package instead
(:func:`stackik._compiled.stamp_by_package`). Checked on a toy caller/callee pair in two
files, in fresh processes (a cache is only read by a new process).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numba

import stackik
from stackik import _compiled

SRC = Path(stackik.__file__).resolve().parents[1]

CALLEE = """
from numba import njit


@njit(cache=True)
def callee():
    return {value}
"""

CALLER = """
from numba import njit

from {pkg}.callee import callee


@njit(cache=True)
def caller():
    return callee()
"""


def _write_package(root: Path, pkg: str, stamped: bool, value: int) -> None:
    d = root / pkg
    d.mkdir(exist_ok=True)
    init = "import os\n\nfrom stackik._compiled import stamp_by_package\n\n"
    init += "stamp_by_package(os.path.dirname(__file__))\n"
    (d / "__init__.py").write_text(init if stamped else "")
    (d / "caller.py").write_text(textwrap.dedent(CALLER.format(pkg=pkg)))
    _write_callee(root, pkg, value)


def _write_callee(root: Path, pkg: str, value: int) -> None:
    (root / pkg / "callee.py").write_text(textwrap.dedent(CALLEE.format(value=value)))


def _run(root: Path) -> list[tuple[int, int]]:
    """``(caller(), cache hits)`` of the stamped and the plain package, in a new process."""
    code = (
        "from stamped.caller import caller as a\n"
        "from plain.caller import caller as b\n"
        "print([(f(), sum(f.stats.cache_hits.values())) for f in (a, b)])\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = os.pathsep.join([str(root), str(SRC)])
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr
    return eval(out.stdout.strip())  # noqa: S307 - our own printed list of tuples


def test_editing_a_callee_in_another_file_recompiles_its_caller(tmp_path):
    for pkg, stamped in (("stamped", True), ("plain", False)):
        _write_package(tmp_path, pkg, stamped, 1)
    assert _run(tmp_path) == [(1, 0), (1, 0)]  # compiled and cached
    assert _run(tmp_path) == [(1, 1), (1, 1)]  # loaded from the cache
    for pkg in ("stamped", "plain"):
        _write_callee(tmp_path, pkg, 2)
    stamped, plain = _run(tmp_path)
    assert stamped == (2, 0)  # the package's stamp changed: compiled again
    assert plain == (1, 1)  # numba's own stamp: the stale caller (why the stamp exists)
    assert _run(tmp_path)[0] == (2, 1)  # and cached again


def test_every_kernel_of_the_package_carries_the_package_stamp():
    import importlib
    import pkgutil

    directory = os.path.dirname(_compiled.__file__)
    seen = 0
    for info in pkgutil.iter_modules(_compiled.__path__):
        mod = importlib.import_module(f"stackik._compiled.{info.name}")
        for obj in vars(mod).values():
            if (
                isinstance(obj, numba.core.registry.CPUDispatcher)
                and obj.__module__ == mod.__name__
            ):
                locator = obj._cache._impl.locator
                assert isinstance(locator, _compiled._PackageStampLocator), obj
                assert locator.get_source_stamp() == _compiled.package_stamp(directory)
                seen += 1
    assert seen > 50


def test_no_kernel_is_cached_outside_the_package():
    pkg = Path(stackik.__file__).parent
    compiled = pkg / "_compiled"
    outside = [
        str(p.relative_to(pkg))
        for p in pkg.rglob("*.py")
        if compiled not in p.parents and re.search(r"jit\([^)]*cache\s*=\s*True", p.read_text())
    ]
    assert outside == []
