"""The default's quality with and without a start-plan rule on the same bench_spatial targets.

``python benchmarks/spatial_rule_compare.py WITHOUT.jsonl WITH.jsonl`` (two
``spatial_bench.jsonl`` of one seed, sizes and leg radius): per n, how many of the
default's poses are within 0.1 % and 0.5 % of the joint best known (the least FN of every
success in both files) and its median CPU time, without and with the rule.
"""

from __future__ import annotations

import json
import statistics
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

DEFAULT = "stackik default"


def load(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def compare(without: Path, with_rule: Path) -> list[str]:
    a, b = load(without), load(with_rule)
    best: dict[tuple[int, int], float] = defaultdict(lambda: float("inf"))
    for r in a + b:
        if r["success"]:
            key = (r["n"], r["target"])
            best[key] = min(best[key], r["fn"])
    lines = [
        "| n | targets | within 0.1 % (without / with) | within 0.5 % | median CPU [ms] |",
        "|---|---|---|---|---|",
    ]
    for n in sorted({r["n"] for r in b}):
        cells = []
        for rows in (a, b):
            rs = [r for r in rows if r["n"] == n and r["method"] == DEFAULT]
            w1 = sum(r["success"] and r["fn"] <= best[(n, r["target"])] * 1.001 for r in rs)
            w5 = sum(r["success"] and r["fn"] <= best[(n, r["target"])] * 1.005 for r in rs)
            cpu = statistics.median(r["cpu"] for r in rs) * 1e3
            cells.append((len(rs), w1, w5, cpu))
        (m, a1, a5, ac), (_, b1, b5, bc) = cells
        lines.append(f"| {n} | {m} | {a1} / {b1} | {a5} / {b5} | {ac:.0f} / {bc:.0f} |")
    return lines


if __name__ == "__main__":
    print("\n".join(compare(Path(sys.argv[1]), Path(sys.argv[2]))))
