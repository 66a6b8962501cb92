"""The compiled (numba) kernels: interior points, path steps and the compiled re-check.

Every kernel is compiled with ``cache=True``: once per machine, then loaded from
``__pycache__`` (or ``NUMBA_CACHE_DIR``). numba stamps each cached function with the
source of its own file only, so a kernel that calls (and inlines) a kernel of another file
would be loaded stale after that file changed. Importing this package first registers a
cache locator that stamps every kernel of the package with one hash of all its source
files instead (:func:`stamp_by_package`): editing any of them recompiles every kernel on
next use, and kernels may share code across files.
"""

from __future__ import annotations

import functools
import hashlib
import os
from typing import Any

from numba.core import caching

__all__ = ["package_stamp", "stamp_by_package"]

#: numba's cache implementation, whose class-level list of locators it tries in order
#: (``CacheImpl`` since numba 0.59, ``_CacheImpl`` before).
_CACHE_IMPL: Any = vars(caching).get("CacheImpl") or vars(caching)["_CacheImpl"]


@functools.lru_cache(maxsize=8)
def _hash_files(files: tuple[tuple[str, int, int], ...]) -> str:
    h = hashlib.sha256()
    for path, _, _ in files:
        h.update(os.path.basename(path).encode())
        with open(path, "rb") as f:
            h.update(hashlib.sha256(f.read()).digest())
    return h.hexdigest()


def package_stamp(directory: str) -> str:
    """SHA-256 of the names and contents of every ``.py`` file in ``directory`` (re-read
    when a file's modification time or size changes)."""
    files = []
    for name in sorted(os.listdir(directory)):
        if name.endswith(".py"):
            path = os.path.join(directory, name)
            st = os.stat(path)
            files.append((path, st.st_mtime_ns, st.st_size))
    return _hash_files(tuple(files))


class _PackageStampLocator(caching._CacheLocator):
    """numba's own locator for the file (same cache directory and file names), with the
    package's stamp instead of the file's."""

    directory = ""

    def __init__(self, base: Any) -> None:
        self._base = base

    def ensure_cache_path(self) -> None:
        self._base.ensure_cache_path()

    def get_cache_path(self) -> str:
        return str(self._base.get_cache_path())

    def get_source_stamp(self) -> Any:
        return package_stamp(self.directory)

    def get_disambiguator(self) -> str:
        return str(self._base.get_disambiguator())

    @classmethod
    def from_function(cls, py_func: Any, py_file: str) -> Any:
        if os.path.dirname(os.path.abspath(py_file)) != cls.directory:
            return None
        for other in _CACHE_IMPL._locator_classes:
            if issubclass(other, _PackageStampLocator):
                continue
            base = other.from_function(py_func, py_file)
            if base is not None:
                return cls(base)
        return None


def stamp_by_package(directory: str) -> None:
    """Stamp every numba-cached function defined in a ``.py`` file of ``directory`` with
    :func:`package_stamp` of it. Call before the first such function is decorated (a
    package's ``__init__``); calling again for the same directory does nothing."""
    directory = os.path.abspath(directory)
    classes = _CACHE_IMPL._locator_classes
    if any(issubclass(c, _PackageStampLocator) and c.directory == directory for c in classes):
        return
    locator = type("PackageStampLocator", (_PackageStampLocator,), {"directory": directory})
    classes.insert(0, locator)


stamp_by_package(os.path.dirname(__file__))
