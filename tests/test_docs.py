"""The documentation's generated parts, checked without building the site (CI builds it
with ``python -m sphinx -W``): the benchmark pages of ``docs/gen_benchmarks.py`` and the
pieces the site relies on."""

from __future__ import annotations

import re
import sys
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
RESULTS = ROOT / "benchmarks" / "results"


@pytest.fixture(scope="module")
def gen() -> ModuleType:
    sys.path.insert(0, str(DOCS))
    try:
        import gen_benchmarks
    finally:
        sys.path.remove(str(DOCS))
    return gen_benchmarks


def _headings(text: str) -> list[int]:
    levels, fenced = [], False
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif not fenced and (m := re.match(r"^(#{1,6})\s", line)):
            levels.append(len(m.group(1)))
    return levels


def test_every_report_has_a_page(gen: ModuleType) -> None:
    pages = gen.pages(RESULTS)
    reports = sorted(RESULTS.rglob("*.md"))
    assert len(pages) == len(reports) + 1  # + the headline table
    for rel in (p.relative_to(RESULTS) for p in reports):
        note = f"_Generated from `benchmarks/results/{rel.as_posix()}` ("
        (page,) = [t for t in pages.values() if note in t]
        levels = _headings(page)
        assert levels[0] == 1 and levels.count(1) == 1, rel  # one title
        assert all(b <= a + 1 for a, b in zip(levels, levels[1:])), rel  # no skipped level


def test_report_bodies_are_unchanged(gen: ModuleType) -> None:
    """Only headings change: every other line of a report is on its page as written."""
    pages = "\n".join(gen.pages(RESULTS).values())
    for report in RESULTS.rglob("*.md"):
        for line in report.read_text(encoding="utf-8").splitlines():
            if line.strip() and not line.startswith("#"):
                assert line in pages, (report, line)


def test_headline_reads_the_results(gen: ModuleType, tmp_path: Path) -> None:
    """The headline table follows the JSON files: change a number, the table changes."""
    import json
    import shutil

    names = ("ik_bench.json", "spatial_bench.json", "path_bench.json", "scale.json")
    for name in (*names, "nonadj_bench.json"):
        shutil.copy(RESULTS / name, tmp_path / name)
    data = json.loads((tmp_path / "ik_bench.json").read_text())
    for row in data["summary"]:
        if row["section"] == "planar" and row["method"] == "stackik (default)":
            row["median_ms"] = 123.0
    (tmp_path / "ik_bench.json").write_text(json.dumps(data))
    assert "| 123 ms |" in gen.headline(tmp_path)
    assert "| 123 ms |" not in gen.headline(RESULTS)


def test_headline_says_which_legs_each_run_measured(gen: ModuleType, tmp_path: Path) -> None:
    """Rows name the legs of their run (files without ``leg_radius``: legs as lines, the
    reference before its 12 mm legs); while any run is on legs as lines, the 12 mm
    comparison (``nonadj_bench.json``) follows the tables, and not once all are on 12 mm."""
    import json
    import shutil

    names = ("ik_bench.json", "spatial_bench.json", "path_bench.json", "scale.json")
    for name in (*names, "nonadj_bench.json"):
        shutil.copy(RESULTS / name, tmp_path / name)
    for name, key in zip(names, (None, None, "meta", "meta"), strict=True):
        data = json.loads((tmp_path / name).read_text())
        data.pop("leg_radius", None)
        data.get("meta", {}).pop("leg_radius", None)
        (data[key] if key else data)["leg_radius"] = 12.0
        (tmp_path / name).write_text(json.dumps(data))
    text = gen.headline(tmp_path)
    assert "legs as lines" not in text and "| planar, " in text
    assert all("12 mm legs" in line for line in text.splitlines() if line.startswith("| planar"))
    data = json.loads((tmp_path / "scale.json").read_text())
    data["meta"]["leg_radius"] = 0.0
    (tmp_path / "scale.json").write_text(json.dumps(data))
    text = gen.headline(tmp_path)
    assert "planar n = 64, 10 targets, legs as lines" in text
    assert "What the 12 mm legs change" in text


def test_every_example_is_on_the_examples_page() -> None:
    page = (DOCS / "examples.md").read_text(encoding="utf-8")
    shown = set(re.findall(r"```\{run-example\} (\S+)", page))
    assert shown == {p.name for p in (ROOT / "examples").glob("*.py")}


def test_guide_pages_are_in_the_index() -> None:
    index = (DOCS / "index.md").read_text(encoding="utf-8")
    for page in (DOCS / "guide").glob("*.md"):
        assert f"guide/{page.stem}\n" in index, page.name


def test_every_public_name_has_a_docstring() -> None:
    """Every public function and class of ``stackik`` and ``stackik.sqp`` (the API
    reference's names) has a docstring beyond a one-word stub."""
    import inspect

    import stackik
    import stackik.sqp

    short = []
    for module in (stackik, stackik.sqp):
        for name in module.__all__:
            obj = getattr(module, name)
            if not name.startswith("__") and (callable(obj) or isinstance(obj, type)):
                doc = inspect.getdoc(obj) or ""
                if len(doc) < 40:
                    short.append(f"{module.__name__}.{name}")
    assert short == []
