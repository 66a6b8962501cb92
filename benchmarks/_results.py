"""A benchmark's summary columns and its results: ``<stem>.csv`` (every row), ``<stem>.json`` (meta,
summary lines, rows) and ``<stem>.md`` (the report), shared by the benchmarks that
compare stackik with IPOPT (bench_loads, bench_clearance, bench_obstacles, bench_scale),
and their random targets."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from stackik.sampling import random_planar_targets, random_spatial_targets


def targets(planar: bool, stack: Any, count: int, seed: int) -> list[Any]:
    """``count`` reachable targets of ``stack``, target k drawn with ``rng = seed + k``
    (planar: in the plane ``phi = 2 pi k / count``)."""
    if planar:
        return [
            random_planar_targets(stack, 1, rng=seed + k, phis=(2 * math.pi * k / count,))[0]
            for k in range(count)
        ]
    return [random_spatial_targets(stack, 1, rng=seed + k)[0] for k in range(count)]


def method_columns(
    rs: list[dict[str, Any]], feasible: list[dict[str, Any]], labels: tuple[str, ...]
) -> dict[str, Any]:
    """Per method of ``labels``, over one case's rows ``rs`` (``feasible``: those with a
    best known): successes, false successes, within the best known, median time [ms],
    speed-up against IPOPT-8 and time against the reference solve (``time_free``), both
    medians of per-target ratios; then the reference's median time and the median FN
    cost."""
    line: dict[str, Any] = {}
    for label in labels:
        line[f"{label}_success"] = sum(r[f"{label}_success"] for r in rs)
        line[f"{label}_false"] = sum(r[f"{label}_false"] for r in rs)
        line[f"{label}_within"] = sum(r[f"{label}_within"] for r in feasible)
        line[f"{label}_median_ms"] = 1e3 * float(np.median([r[f"{label}_time"] for r in rs]))
        line[f"{label}_speedup_vs_ipopt8"] = float(
            np.median([r["ipopt8_time"] / r[f"{label}_time"] for r in rs])
        )
        line[f"{label}_vs_free"] = float(
            np.median([r[f"{label}_time"] / r["time_free"] for r in rs])
        )
    line["free_median_ms"] = 1e3 * float(np.median([r["time_free"] for r in rs]))
    line["median_fn_cost"] = float(np.nanmedian([r["fn_cost"] for r in rs]))
    return line


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
