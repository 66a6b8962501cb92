"""Writing a benchmark's results: ``<stem>.csv`` (every row), ``<stem>.json`` (meta,
summary lines, rows) and ``<stem>.md`` (the report), shared by the benchmarks that
compare stackik with IPOPT (bench_loads, bench_clearance, bench_obstacles)."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any


def write_results(
    out: Path,
    stem: str,
    meta: dict[str, Any],
    lines: list[dict[str, Any]],
    rows: list[dict[str, Any]],
    report: str,
) -> None:
    """Write the three files into ``out`` (created) and print the report."""
    out.mkdir(parents=True, exist_ok=True)
    with open(out / f"{stem}.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    (out / f"{stem}.json").write_text(
        json.dumps({"meta": meta, "summary": lines, "rows": rows}, indent=1, default=float)
    )
    (out / f"{stem}.md").write_text(report)
    print(report)
