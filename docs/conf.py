"""Sphinx configuration of the stackik documentation.

Build: ``python -m sphinx -W --keep-going -b html docs docs/_build/html`` (CI runs it with
warnings as errors). Before reading the sources this file writes, into ``docs/_generated``:

- ``api.rst``: the API reference, one autosummary entry per name of ``stackik.__all__`` and
  of ``stackik.sqp.__all__`` (nothing listed by hand, so a new public name appears by
  itself);
- the benchmark pages, from ``benchmarks/results`` by :mod:`gen_benchmarks` (no number is
  copied by hand).

The examples in ``examples/`` are run while the pages are read (``_ext/run_examples.py``).
"""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(DOCS))
sys.path.insert(0, str(DOCS / "_ext"))

import gen_benchmarks  # noqa: E402
from sphinx.pycode import ModuleAnalyzer  # noqa: E402

import stackik  # noqa: E402
import stackik.sqp  # noqa: E402

project = "stackik"
author = "stackik developers"
copyright = "2026, stackik developers"  # noqa: A001
release = stackik.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "run_examples",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]
templates_path = ["_templates"]

myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3

autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"members": True, "inherited-members": False}
autodoc_typehints = "none"  # numpydoc docstrings carry the types
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

html_theme = "furo"
html_title = f"stackik {release}"
html_static_path: list[str] = []


def _api_page() -> str:
    """The API reference page: every public name, grouped as the package exports them."""

    def names(module: object) -> list[str]:
        return sorted((n for n in module.__all__ if not n.startswith("_")), key=str.lower)

    def entry(module: str, name: str) -> str:
        """A function or class by its public name; a constant by the module that defines
        it, where its ``#:`` comment (its docstring) is."""
        obj = getattr(sys.modules[module], name)
        if callable(obj) or isinstance(obj, type):
            return name
        for mod_name, mod in sorted(sys.modules.items()):
            if mod_name.startswith(module + ".") and getattr(mod, name, None) is obj:
                docs = ModuleAnalyzer.for_module(mod_name).find_attr_docs()
                if ("", name) in docs:
                    return f"~{mod_name.removeprefix(module + '.')}.{name}"
        return name

    def block(module: str, members: list[str]) -> list[str]:
        out = [f".. currentmodule:: {module}", "", ".. autosummary::", "   :toctree: api", ""]
        entries = [entry(module, m) for m in members]
        pages.update(f"{module}.{e.lstrip('~')}.rst" for e in entries)
        return out + [f"   {e}" for e in entries] + [""]

    pages: set[str] = set()

    lines = [
        "API reference",
        "=============",
        "",
        "Generated from the docstrings of every name in ``stackik.__all__`` and",
        "``stackik.sqp.__all__`` (``docs/conf.py`` lists them; nothing here is written by",
        "hand). Units: millimetres, radians, seconds; shapes as the docstrings give them.",
        "",
        "``stackik``",
        "-----------",
        "",
        *block("stackik", names(stackik)),
        "``stackik.sqp``: the generic SQP engine",
        "---------------------------------------",
        "",
        *block("stackik.sqp", names(stackik.sqp)),
    ]
    for stale in (DOCS / "_generated" / "api").glob("*.rst"):
        if stale.name not in pages:  # a name no longer public: autosummary leaves its page
            stale.unlink()
    return "\n".join(lines)


def _write_if_changed(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


_write_if_changed(DOCS / "_generated" / "api.rst", _api_page())
_pages = gen_benchmarks.pages(ROOT / "benchmarks" / "results")
for _name, _text in _pages.items():
    _write_if_changed(DOCS / "_generated" / "benchmarks" / _name, _text)
for _stale in (DOCS / "_generated" / "benchmarks").glob("*.md"):
    if _stale.name not in _pages:  # a report removed or renamed since the last build
        _stale.unlink()
